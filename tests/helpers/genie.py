"""A per-step oracle against what any policy reaches: random policies and the baselines, over
the same draws, at every step."""

from __future__ import annotations

import numpy as np

from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.genie import GenieResult
from adaptsky.rollouts.objective import constrained_sum_rate
from adaptsky.rollouts.rollout import random_policy, rollout
from adaptsky.scenario.models import Scenario


def assert_at_least_every_policy(found: GenieResult, scenario: Scenario, users_m: np.ndarray,
                                 steps: int, seed: int) -> None:
    """``found`` (the oracle's result for ``steps`` steps from ``seed``) is at least the
    constrained objective of three random policies, SoA and tracking at every step, each
    flown through the same user walks and draws; and positive everywhere."""
    ceiling = found.objective_bps * (1 + 1e-12)               # (T, L)
    traces = [rollout(scenario, random_policy(32, policy_seed), steps, users_m, seed=seed)
              for policy_seed in range(3)]
    traces += [run_baseline(scenario, name, steps, users_m, seed=seed).trace
               for name in ("soa", "tracking")]
    for trace in traces:
        np.testing.assert_array_equal(trace.users_m, found.users_m)   # the same draws
        objective = constrained_sum_rate(trace.rate_bps, scenario.min_rate_bps)
        assert np.all(objective <= ceiling)
    assert np.all(found.objective_bps > 0)
