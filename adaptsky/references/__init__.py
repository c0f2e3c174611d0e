"""Every baseline, reference and bound of an evaluation as one small object in one registry
(docs/evaluation.md#references): its name, what it is (a bound, a reference or a baseline,
and of what), whether it applies to a scenario (else the one-line reason), its work for
progress and its run. ``eval``, ``baseline``, training's greedy evaluations, ``reproduce``
and ``tune`` ask :mod:`adaptsky.references.registry` only."""
