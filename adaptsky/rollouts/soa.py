"""The SoA baseline (Chen et al. 2019 as the paper uses it; docs/model.md §6).

The UAV stays at the users' 2D centroid at the start height (for several UAVs, each at its
group's: SoA per UAV, docs/model.md §9), or 1 m above the roof of a building standing there
(docs/model.md §12). Planning assumes LoS: in each
cluster the user with the smaller LoS gain is weak and gets the least power that meets R_min,

    alpha_w = min(1, (2^(R_min/W) - 1) / 2^(R_min/W) * (1 + sigma^2 / (P_T G g_w))),

the strong user the rest (R_min = 0 gives the weak user nothing). Rates are then evaluated
under the scenario's true channel. Under imperfect channel knowledge (docs/model.md §16) SoA
decides on the estimates instead: at every step the split of the latest estimated gains
g_hat of its links, the channel the agent observes (:func:`estimated_split`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.blockage import above_buildings
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
ESTIMATES_NOTE = ("decides its split on the channel estimates (every step the split of the "
                  "latest estimated gains, as the agent observes them)")
"""What SoA and tracking are under imperfect channel knowledge (docs/model.md §16)."""


def soa_configuration(env: NetworkBatch) -> tuple[FloatArray, FloatArray]:
    """UAV position (B, 3) and first users' power shares (B, K) for the env's B layouts of
    one UAV: :func:`soa_per_uav_configuration` with U = 1."""
    uav_m, alpha_first = soa_per_uav_configuration(env)
    return uav_m[:, 0], alpha_first[:, 0]


def soa_per_uav_configuration(env: NetworkBatch) -> tuple[FloatArray, FloatArray]:
    """SoA per UAV (docs/model.md §6 and §9) for the env's B layouts: every UAV's position
    (B, U, 3) at its group's 2D centroid at its start height, and its first users' shares
    (B, U, K_max) planned from the LoS gains without interference (a UAV with fewer clusters
    than K_max keeps ``start_alpha`` in its unused slots)."""
    uav_m = soa_positions(env)
    return uav_m, soa_split(env, uav_m, env.layouts_m)


def soa_positions(env: NetworkBatch) -> FloatArray:
    """Every UAV's SoA position (B, U, 3) on the env's layouts: its group's 2D centroid at
    its start height, 1 m above the roof of a building standing there."""
    centroid = group_centroids(env, env.layouts_m)                            # (B, U, 2)
    height = np.broadcast_to(env.start_m[:, 2], centroid.shape[:2])[..., None]
    uav_m = np.concatenate([centroid, height], axis=-1)
    if env.city is not None:
        uav_m = above_buildings(uav_m, env.city)
    return uav_m


def group_centroids(env: NetworkBatch, users_m: FloatArray) -> FloatArray:
    """Every UAV's group's 2D centroid (B, U, 2) of the users ``users_m`` (B, N, 2), by the
    env's association."""
    members = env.association.serving_uav[:, None, :] == np.arange(env.num_uavs)[None, :, None]
    return (members[..., None] * users_m[:, None]).sum(axis=2) / members.sum(axis=2)[..., None]


def soa_split(env: NetworkBatch, uav_m: FloatArray, users_m: FloatArray) -> FloatArray:
    """SoA's first users' shares (B, U, K_max) with the UAVs at ``uav_m`` (B, U, 3) and the
    users at ``users_m`` (B, N, 2): planned from the LoS gains without interference (module
    doc); a UAV with fewer clusters than K_max keeps ``start_alpha`` in its unused slots."""
    gain = env.channel.gain_los(env.geometry(uav_m, users_m)).reshape(
        len(users_m), env.num_uavs, env.num_users)
    return split_of_gains(env, gain)


def estimated_split(env: NetworkBatch) -> FloatArray:
    """SoA's first users' shares (B, U, K_max) planned from the env's latest estimates of
    its links (docs/model.md §16), the split of the module doc on g_hat: what SoA and
    tracking decide on under imperfect channel knowledge."""
    gains_hat = env.estimated_gains
    if gains_hat is None:
        raise ValueError("the environment draws no channel estimates (channel.csi.model = "
                         "'perfect')")
    return split_of_gains(env, gains_hat)


def split_of_gains(env: NetworkBatch, gain: FloatArray) -> FloatArray:
    """The split of the module doc (B, U, K_max) from every link's gain ``gain`` (B, U, N)
    (a UAV with fewer clusters than K_max keeps ``start_alpha`` in its unused slots)."""
    scenario, association = env.scenario, env.association
    rows = np.arange(len(gain))[:, None, None]
    uavs = np.arange(env.num_uavs)[None, :, None]
    gain_first = gain[rows, uavs, association.first_user]
    gain_second = gain[rows, uavs, association.second_user]
    return np.where(association.first_user >= 0,
                    soa_shares(scenario, gain_first, gain_second), scenario.uav.start_alpha)


def soa_shares(scenario: Scenario, gain_first: FloatArray, gain_second: FloatArray
               ) -> FloatArray:
    """Each cluster's first user's share from the LoS gains of its two users (module doc):
    the weak user gets the least share that meets R_min, the strong one the rest."""
    radio = scenario.radio
    threshold = 2.0 ** scenario.reward.min_se
    weak_gain = np.minimum(gain_first, gain_second)
    alpha_weak = np.minimum(1.0, (threshold - 1) / threshold * (
        1 + radio.noise_w / (radio.tx_power_w * radio.antenna_gain * weak_gain)))
    first_strong = noma.is_strong(gain_first, gain_second, gain_first, gain_second, True)
    return np.where(first_strong, 1.0 - alpha_weak, alpha_weak)
