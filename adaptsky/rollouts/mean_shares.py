"""The shares of a held configuration for a policy's own draws (docs/model.md §11): at fixed
UAV positions, each cluster's first-user share on the lattice with the largest mean sum rate
over the draws a policy with the same seed sees (common random numbers).

Where no minimum rate binds (``reward.min_se = 0``) the objective, the sum rate, is a sum over
clusters, and at fixed positions a cluster's rates depend on its own share alone (a user's
interference is the other UAVs' whole cluster power, however it is split; docs/model.md §9).
So every cluster's best share is found on its own, exactly over the lattice
(:func:`~adaptsky.rollouts.search.best_on_grid`): one held rollout per share, every cluster
of every layout at that share, ``steps`` steps each.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.rollouts.rollout import hold
from adaptsky.rollouts.search import best_on_grid
from adaptsky.scenario.models import Scenario
from adaptsky.sim.lattice import share_lattice
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]


def shares_apply(scenario: Scenario) -> bool:
    """Whether :func:`mean_best_shares` applies: no minimum rate couples the clusters."""
    return scenario.reward.min_se == 0


def mean_best_shares(scenario: Scenario, uav_m: FloatArray, alpha_first: FloatArray,
                     steps: int, users_m: FloatArray, seed: int = 0) -> FloatArray:
    """``alpha_first`` ((L, K) for one UAV, (L, U, K_max) for several; slots without a
    cluster kept as they are) with each cluster's share replaced by the lattice share
    (:func:`~adaptsky.sim.lattice.share_lattice`) of the largest mean sum rate of its two
    users over ``steps`` steps held at ``uav_m`` with the draws of ``seed`` (the smallest of
    equal ones); needs ``reward.min_se = 0`` (:func:`shares_apply`)."""
    if not shares_apply(scenario):
        raise ValueError("the clusters' shares are separable only without a minimum rate")
    num_layouts = len(users_m)
    env = NetworkBatch(scenario, num_layouts, users_m=users_m)
    serving, cluster = env.roles()                                  # (L, N) each
    alpha = np.array(alpha_first, dtype=np.float64).reshape(num_layouts, env.num_uavs, -1)
    num_clusters = alpha.shape[-1]
    slot = (np.arange(num_layouts)[:, None] * env.num_uavs + serving) * num_clusters + cluster
    has_cluster = np.zeros(alpha.size, dtype=bool)
    has_cluster[slot.ravel()] = True

    def mean_sum_rate(share: float) -> FloatArray:
        trace = hold(scenario, uav_m, np.full(np.shape(alpha_first), share), steps, users_m,
                     seed)
        mean_bps = np.zeros(alpha.size)
        np.add.at(mean_bps, slot.ravel(), trace.rate_bps.mean(axis=0).ravel())
        return np.where(has_cluster, mean_bps, -np.inf)     # a slot without a cluster stays

    _, chosen = best_on_grid(share_lattice(scenario), mean_sum_rate, alpha.reshape(-1))
    return chosen.reshape(np.shape(alpha_first))
