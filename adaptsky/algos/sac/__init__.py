"""Soft actor-critic (Haarnoja et al. 2018) stacked over seeds, for continuous controls
(docs/agent.md): ``spec.SAC`` is its registry entry, ``learner.SacLearner`` its Algorithm."""
