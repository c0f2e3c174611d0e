"""The dueling (and plain) DQN of sec. IV for a stack of seeds: the first algorithm
(``spec.DQN`` is its registry entry; ``learner.DqnLearner`` its Algorithm)."""
