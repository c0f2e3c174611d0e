"""The branching dueling Q-network (BDQ; Tavakoli, Pardo, Kormushev, AAAI 2018) for a stack of
seeds: the second algorithm (``spec.BDQ`` is its registry entry; ``learner.BdqLearner`` its
Algorithm). One advantage branch per action component instead of one output per dense action."""
