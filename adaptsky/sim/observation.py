"""The observation stage (docs/environment.md). One UAV: the paper's layout (sec. IV-B.1,
:class:`Observer`), below; several UAVs: :class:`MultiObserver`; users as the layout lists
them. What the agent sees of it (the users' order, every UAV's local part, for one agent per
UAV) is the adapter it picks (:class:`ObservationView`, :mod:`adaptsky.envs.observations`).

Sec. IV-B.1: per user [dx_i, dy_i, alpha_i, g_i], then h (size 4 N + 1).

dx_i = x_UAV - x_i, dy_i = y_UAV - y_i. The raw values span 12 orders of magnitude, so by
default they are scaled (``observation = "scaled"``):

- dx_i, dy_i divided by L/2 (in [-2, 2]);
- alpha_i as is (in (0, 1));
- g_i as (10 log10 g_i - GAIN_DB_CENTER) / GAIN_DB_SCALE, i.e. (g_dB + 100) / 20;
- h divided by h_max (in (0, 1]).

``observation = "raw"`` gives the paper's values: m, 1, linear gain, m.
Relative positions make the features mean the same on every layout, so a policy trained on
one layout can be evaluated on another.

Users come in the order the layout lists them (the paper's); an agent with
``agent.user_order = "clusters"`` sees them cluster by cluster through its adapter
(:mod:`adaptsky.envs.observations`, docs/agent.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.association import Association
from adaptsky.sim.city import City

FloatArray = NDArray[np.float64]
GAIN_DB_CENTER = -100.0
GAIN_DB_SCALE = 20.0
FEATURES_PER_USER = 4


def observation_size(num_users: int, num_uavs: int = 1) -> int:
    """4 N + 1 for one UAV (sec. IV-B.1); 5 N + 3 U for several (docs/environment.md)."""
    if num_uavs == 1:
        return FEATURES_PER_USER * num_users + 1
    return 5 * num_users + 3 * num_uavs


def local_observation_size(scenario: Scenario) -> int:
    """L = 5 S + 3 U, one UAV's local observation (S = M K_max user slots)."""
    return (MULTI_FEATURES_PER_USER * scenario.users_per_uav
            + FEATURES_PER_UAV * scenario.uav.count)


class Observer:
    """Observations (B, 4 N + 1), float32, of one UAV (the paper's layout), for one scenario
    and B environments of N users, with its constants prepared once; ``scaled`` as below
    (False: the paper's raw values)."""

    def __init__(self, scenario: Scenario, shape: tuple[int, int], scaled: bool = True
                 ) -> None:
        self.scaled = scaled
        self._size = observation_size(shape[1])
        # 0-d arrays: numpy combines them with an array faster than Python floats
        self._ten = np.array(10.0)
        self._center = np.array(GAIN_DB_CENTER)
        self._max_height_m = np.array(scenario.uav.max_height_m)
        # every feature's divisor: L/2 for dx and dy, 1 for alpha (x / 1 is x), the dB scale
        divisor = [scenario.area.side_m / 2, scenario.area.side_m / 2, 1.0, GAIN_DB_SCALE]
        self._divisor = np.repeat(divisor, shape[0] * shape[1]).reshape(
            FEATURES_PER_USER, *shape)

    def __call__(self, features: NDArray[np.float64], gain: NDArray[np.float64],
                 height_m: NDArray[np.float64]) -> NDArray[np.float32]:
        """Observations (B, 4 N + 1) from ``features`` (4, B, N) whose first three rows hold
        x_UAV - x_i, y_UAV - y_i and alpha_i (the fourth is overwritten with g_i, then every
        row scaled in place), the gains g_i (B, N) and the UAV heights (B,), users as
        listed.

        The features are computed in float64, then rounded to float32 in one copy.
        """
        if self.scaled:
            gain_db = np.log10(gain, out=features[3])
            np.multiply(self._ten, gain_db, out=gain_db)
            np.subtract(gain_db, self._center, out=gain_db)
            np.divide(features, self._divisor, out=features)
            height_m = height_m / self._max_height_m
        else:
            features[3] = gain
        _, num_envs, num_users = features.shape
        obs = np.empty((num_envs, self._size), dtype=np.float32)
        obs[:, :-1].reshape(num_envs, num_users, FEATURES_PER_USER)[...] = features.transpose(
            1, 2, 0)
        obs[:, -1] = height_m
        return obs


FLOAT64_GAIN_RANGE = (float(np.finfo(np.float64).smallest_subnormal),
                      float(np.finfo(np.float64).max))
"""Where the gains have no bound from the scenario (per-step fading): every positive float64."""


def observation_bounds(scenario: Scenario, gains: tuple[float, float] | None = None, *,
                       scaled: bool) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Lower and upper bounds of every observation component, finite (docs/environment.md,
    "Observation bounds"): dx, dy by the area, alpha in [0, 1], h in [h_min, h_max], and g_i
    between ``gains`` (linear, e.g. ``NetworkBatch.gain_bounds()``; None: every positive
    float64), ``scaled`` or raw as the observation is and rounded outward to float32."""
    side_m = scenario.area.side_m
    gain_low, gain_high = gains or FLOAT64_GAIN_RANGE
    if scaled:
        delta = 2.0
        gain_low, gain_high = _scaled_gain(gain_low), _scaled_gain(gain_high)
        height = (scenario.uav.min_height_m / scenario.uav.max_height_m, 1.0)
    else:
        delta = side_m
        gain_low, gain_high = 0.0, min(gain_high, float(np.finfo(np.float32).max))
        height = (scenario.uav.min_height_m, scenario.uav.max_height_m)
    n_users = scenario.num_users
    low = np.array([-delta, -delta, 0.0, gain_low] * n_users + [height[0]])
    high = np.array([delta, delta, 1.0, gain_high] * n_users + [height[1]])
    return float32_outward(low, -np.inf), float32_outward(high, np.inf)


def _scaled_gain(gain: float) -> float:
    """g as the observation scales it, with the same float64 operations (so that a gain
    between two others is scaled between theirs): (10 log10 g - GAIN_DB_CENTER) /
    GAIN_DB_SCALE."""
    return float((np.array(10.0) * np.log10(np.float64(gain)) - np.array(GAIN_DB_CENTER))
                 / np.array(GAIN_DB_SCALE))


def float32_outward(values: NDArray[np.float64], towards: float) -> NDArray[np.float32]:
    """``values`` in float32, each moved one float32 step towards ``towards`` where rounding
    moved it the other way (a bound then still holds every rounded observation)."""
    rounded = values.astype(np.float32)
    inward = rounded > values if towards < 0 else rounded < values
    rounded[inward] = np.nextafter(rounded[inward], np.float32(towards))
    return rounded


MULTI_FEATURES_PER_USER = 5
FEATURES_PER_UAV = 3


class MultiObserver:
    """Observations (B, 5 N + 3 U), float32, of a scenario of several UAVs (docs/environment.md,
    "Several UAVs"; docs/model.md §9): per user i, served by UAV u, [x_u - x_i, y_u - y_i,
    alpha_i, g_{u,i}, I_i], then every UAV's [x_u, y_u, h_u]. Scaled as for one UAV: offsets
    and UAV coordinates over L/2, h over h_max, the serving gain as (10 log10 g + 100) / 20,
    the interference as 10 log10(1 + I_i / sigma^2) / 20 (0 without interference); ``"raw"``
    gives m, 1, the linear gain and I_i / sigma^2 (``scaled`` False)."""

    def __init__(self, scenario: Scenario, scaled: bool = True) -> None:
        self.scaled = scaled
        self.half_side_m = scenario.area.side_m / 2
        self.max_height_m = scenario.uav.max_height_m
        self.noise_w = scenario.radio.noise_w

    def __call__(self, uav_m: FloatArray, users_m: FloatArray, serving_uav: NDArray[np.intp],
                 alpha: FloatArray, gain: FloatArray, interference_w: FloatArray,
                 order: NDArray[np.intp] | None = None) -> NDArray[np.float32]:
        """From the UAVs (B, U, 3), users (B, N, 2), each user's serving UAV, share, serving
        gain and interference (B, N); ``order`` (B, N) lists the users in observation order
        (None: as listed)."""
        if order is not None:   # every feature is elementwise: permute the users first
            users_m = np.take_along_axis(users_m, order[..., None], axis=1)
            serving_uav, alpha, gain, interference_w = (
                np.take_along_axis(values, order, axis=1)
                for values in (serving_uav, alpha, gain, interference_w))
        serving_m = np.take_along_axis(uav_m, serving_uav[..., None], axis=1)   # (B, N, 3)
        return self.from_offsets(serving_m[..., 0] - users_m[..., 0],
                                 serving_m[..., 1] - users_m[..., 1], uav_m, alpha, gain,
                                 interference_w)

    def from_offsets(self, dx_m: FloatArray, dy_m: FloatArray, uav_m: FloatArray,
                     alpha: FloatArray, gain: FloatArray, interference_w: FloatArray
                     ) -> NDArray[np.float32]:
        """The observations from every user's offsets x_u - x_i and y_u - y_i to its serving
        UAV, share, serving gain and interference (each (B, N), users in observation order)
        and the UAVs ``uav_m`` (B, U, 3): each feature is computed in float64 and rounded
        once to float32, straight into its place."""
        num_envs, num_users = gain.shape
        num_uavs = uav_m.shape[1]
        width = MULTI_FEATURES_PER_USER * num_users
        obs = np.empty((num_envs, width + FEATURES_PER_UAV * num_uavs), dtype=np.float32)
        features = obs[:, :width].reshape(num_envs, num_users, MULTI_FEATURES_PER_USER)
        uavs = obs[:, width:].reshape(num_envs, num_uavs, FEATURES_PER_UAV)
        features[..., 2] = alpha
        inr = interference_w / self.noise_w
        if self.scaled:
            half_side_m = self.half_side_m
            features[..., 0] = dx_m / half_side_m
            features[..., 1] = dy_m / half_side_m
            features[..., 3] = (10.0 * np.log10(gain) - GAIN_DB_CENTER) / GAIN_DB_SCALE
            features[..., 4] = 10.0 * np.log10(1.0 + inr) / GAIN_DB_SCALE
            uavs[..., :2] = uav_m[..., :2] / half_side_m
            uavs[..., 2] = uav_m[..., 2] / self.max_height_m
        else:
            features[..., 0] = dx_m
            features[..., 1] = dy_m
            features[..., 3] = gain
            features[..., 4] = inr
            uavs[...] = uav_m
        return obs


def multi_observation_bounds(scenario: Scenario, gains: tuple[float, float] | None = None, *,
                             scaled: bool) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Finite lower and upper bounds of every component (``gains``: the linear gain range of
    a link, None: every positive float64; ``scaled`` or raw values). The interference is at
    most U - 1 UAVs' full power P_T G at the largest gain."""
    uav, radio = scenario.uav, scenario.radio
    half_m = scenario.area.side_m / 2
    gain_low, gain_high = gains or FLOAT64_GAIN_RANGE
    inr_high = (uav.count - 1) * radio.tx_power_w * radio.antenna_gain * gain_high / radio.noise_w
    if scaled:
        delta, position = 2.0, 1.0
        gain_low, gain_high = _scaled_gain(gain_low), _scaled_gain(gain_high)
        inr_high = 10.0 * math.log10(1.0 + inr_high) / GAIN_DB_SCALE if math.isfinite(
            inr_high) else float(np.finfo(np.float32).max)
        height = (uav.min_height_m / uav.max_height_m, 1.0)
    else:
        delta, position = 2 * half_m, half_m
        gain_low, gain_high = 0.0, min(gain_high, float(np.finfo(np.float32).max))
        inr_high = min(inr_high, float(np.finfo(np.float32).max))
        height = (uav.min_height_m, uav.max_height_m)
    n, u = scenario.num_users, uav.count
    low = np.array([-delta, -delta, 0.0, gain_low, 0.0] * n + [-position, -position,
                                                              height[0]] * u)
    high = np.array([delta, delta, 1.0, gain_high, inr_high] * n + [position, position,
                                                                   height[1]] * u)
    return float32_outward(low, -np.inf), float32_outward(high, np.inf)


@dataclass(frozen=True)
class WorldData:
    """What the simulator hands an agent's observations of the world (docs/environment.md,
    "Observations of the world"): the UAVs ``uav_m`` (B, U, 3), each user's serving link's
    LoS state ``serving_los`` (B, N) (1 or 0; its probability where LoS is not drawn), each
    user's displacement over the last step ``moved_m`` (B, N, 2) (0 after a reset), the step's
    duration ``step_s`` and the buildings ``city`` (None: none)."""

    uav_m: FloatArray
    serving_los: FloatArray
    moved_m: FloatArray
    step_s: float
    city: City | None


WorldReader = Callable[[NDArray[np.float32], WorldData], NDArray[np.float32]]
"""The agent's observations (B, W) and the step's :class:`WorldData` in, the observations
with its observations of the world out (:meth:`ObservationView.world_reader`)."""


class ObservationView(Protocol):
    """What an agent sees of the network's observation (B, size), users as listed: the
    adapter its settings pick (:class:`adaptsky.envs.observations.AgentView`: scaled or raw
    values, the users' order, every UAV's local part), given to the simulator, which reads
    no agent setting. ``gather`` is called once per association: where every component of
    the agent's observation (B, W) comes from in the network's with a zero appended
    (position ``size``), or None where the agent sees the network's as it is."""

    scaled: bool
    observes_world: bool
    """Whether :meth:`world_reader` adds features (then called once per association, its
    reader at every step)."""

    def gather(self, association: Association) -> NDArray[np.intp] | None: ...

    def world_reader(self, association: Association) -> WorldReader:
        """What adds the agent's observations of the world to its observations (after
        :meth:`gather`) at every step of ``association``."""
        ...


def flat_gather(gather: NDArray[np.intp], size: int) -> tuple[NDArray[np.intp], bool]:
    """:meth:`ObservationView.gather`'s positions (B, W) as flat positions for one ``take``
    from the network's observations (B, size), and whether they need the zero appended
    (then flat positions in (B, size + 1))."""
    padded = bool((gather == size).any())
    return gather + (size + padded) * np.arange(len(gather))[:, None], padded


def gathered(network: NDArray[np.float32], flat: NDArray[np.intp], padded: bool
             ) -> NDArray[np.float32]:
    """The agent's observations (B, W) from the network's (B, size) and
    :func:`flat_gather`'s positions: the same float32 values, copied."""
    if padded:
        zero = np.zeros((len(network), network.shape[1] + 1), dtype=np.float32)
        zero[:, :-1] = network
        network = zero
    return network.take(flat)


def local_observation_bounds(scenario: Scenario, gains: tuple[float, float] | None = None, *,
                             scaled: bool) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Bounds of every UAV's local observation (the same for all): those of
    :func:`multi_observation_bounds` for S user slots and the U UAVs, widened to hold 0 in the
    slots a UAV with fewer users pads."""
    low, high = multi_observation_bounds(scenario, gains, scaled=scaled)
    users = MULTI_FEATURES_PER_USER * scenario.num_users
    width = MULTI_FEATURES_PER_USER * scenario.users_per_uav
    low, high = (np.concatenate([bound[:width], bound[users:]]) for bound in (low, high))
    padded = slice(MULTI_FEATURES_PER_USER * scenario.cluster_size
                   * min(scenario.clusters_of_uavs), width)
    np.minimum(low[padded], 0.0, out=low[padded])
    np.maximum(high[padded], 0.0, out=high[padded])
    return low, high
