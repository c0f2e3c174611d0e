"""Rollouts of policies and baselines on a scenario: greedy rollouts, SoA, the exact oracle,
their metrics. Below training (which evaluates while it trains) and the eval files."""
