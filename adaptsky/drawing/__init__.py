"""Pictures of an episode from plain arrays: the data of one episode (``episode``, numpy only)
and its matplotlib figure (``episode_figure``: Agg, no pyplot), which the Gymnasium env renders
and ``adaptsky show`` writes. Beside ``adaptsky.sim``: it knows no simulation, no file.

Nothing here is imported by ``import adaptsky``; matplotlib is imported with
``episode_figure`` only (docs/pictures.md)."""
