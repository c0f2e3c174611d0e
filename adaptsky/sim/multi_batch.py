"""The network of several UAVs (docs/model.md §9), simulated for B independent layouts at once.

:class:`MultiUavBatch` holds B environments of U UAVs and N users: the users split into U
groups (``users.association``), each UAV serves its group in NOMA clusters, and under full
reuse cluster k of every UAV shares subchannel k, so every user hears the other UAVs' cluster-k
signals as interference. A step moves every UAV and every alpha by one action (the dense
index of docs/model.md §3 over all UAVs' components), holds back moves that break the
separation, and evaluates the gains of every UAV-user link (through the unchanged plugin
contract, :mod:`adaptsky.sim.links`), the interference, SINR and rates
(:mod:`adaptsky.sim.interference`) and eq. 13 over all users.

One UAV is :class:`adaptsky.sim.batch.NomaUavBatch` (:func:`network_batch` chooses), whose
numbers these functions give bit for bit with U = 1 (tests/unit/sim/test_several_uavs.py).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import LinkGeometry
from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.association import Association, associate, serving_groups
from adaptsky.sim.batch import (
    NomaUavBatch,
    build_channel,
    carrier_hz,
    deterministic_gain,
    fading_active,
    generators,
    reward_weights,
    scenario_geometry,
)
from adaptsky.sim.energy import EnergyAccount
from adaptsky.sim.gain_bounds import gain_range, reachable_heights
from adaptsky.sim.interference import serving_gain
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.links import all_links_geometry, link_gains
from adaptsky.sim.multi_observation import MultiObserver
from adaptsky.sim.reward import reward_per_uav
from adaptsky.sim.separation import separated
from adaptsky.sim.state import Dynamics, SimState, step, users_xy

FloatArray = NDArray[np.float64]
Seed = int | np.random.SeedSequence | list[np.random.SeedSequence] | None


@dataclass(frozen=True)
class MultiNetworkState:
    """The network of several UAVs after a reset or step; leading axis B, then users N.

    ``uav_m`` (B, U, 3) every UAV's position; per user (B, N): ``alpha`` its power share,
    ``gain`` the linear gain of one antenna pair from its serving UAV (with the step's
    fading where the channel draws it), ``interference_w`` the other UAVs' power it hears
    (W), ``los`` and ``p_los`` of its serving link, ``strong`` whether it is its cluster's
    strong user (SIC by the effective gain), ``rate_bps``; per environment the sum rate,
    Jain's index over all users and the reward (eq. 13); ``energy_j`` (B, U) each UAV's
    energy of the step (docs/model.md §10; hovering after a reset or for a held
    configuration).
    """

    uav_m: FloatArray
    alpha: FloatArray
    gain: FloatArray
    interference_w: FloatArray
    los: NDArray[np.bool_]
    p_los: FloatArray
    strong: NDArray[np.bool_]
    rate_bps: FloatArray
    sum_rate_bps: FloatArray
    fairness: FloatArray
    reward: FloatArray
    energy_j: FloatArray

    def for_env(self, index: int) -> dict[str, np.ndarray | float]:
        """The state of environment ``index`` as a Gymnasium ``info`` dict."""
        info: dict[str, np.ndarray | float] = {
            name: getattr(self, name)[index].copy()
            for name in ("uav_m", "alpha", "gain", "interference_w", "los", "p_los",
                         "rate_bps", "energy_j")}
        info["sum_rate_bps"] = float(self.sum_rate_bps[index])
        info["fairness"] = float(self.fairness[index])
        return info


class MultiUavBatch:
    """B independent copies of a network of U > 1 UAVs, vectorised with numpy.

    The arguments are those of :class:`~adaptsky.sim.batch.NomaUavBatch`: ``scenario``
    (validated), ``num_envs`` B, ``seed`` (one, or a list of B: every environment then draws
    its LoS states, fading and user moves from a generator of its own), ``users_m``
    (B, N, 2) to override the scenario's layouts, ``weights`` per environment (eq. 13).

    The association (serving UAV and NOMA cluster of every user) is made once per layout, at
    construction and by :meth:`set_layouts`: balanced k-means from the UAVs' start positions
    or ``users.uav``, pairs inside each group as ``users.pairing`` says, by the gains from
    the serving UAV's start position.
    """

    def __init__(self, scenario: Scenario, num_envs: int = 1, seed: Seed = None,
                 users_m: FloatArray | None = None,
                 weights: list[noma.RewardWeights] | None = None) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.scenario = scenario
        self.num_envs = num_envs
        self.num_users = scenario.num_users
        self.num_uavs = scenario.uav.count
        self.num_clusters = scenario.clusters_per_uav
        self.channel = build_channel(scenario)
        self._dynamics = Dynamics.of(scenario, num_envs)
        self.actions = self._dynamics.actions
        if weights is not None and len(weights) != num_envs:
            raise ValueError(f"weights must have {num_envs} entries, got {len(weights)}")
        self.weights = reward_weights(scenario) if weights is None else noma.stack_weights(
            weights)
        radio = scenario.radio
        self.bandwidth_hz = radio.bandwidth_hz
        self._radio = {"tx_power_w": radio.tx_power_w, "antenna_gain": radio.antenna_gain,
                       "noise_w": radio.noise_w, "bandwidth_hz": radio.bandwidth_hz,
                       "reuse": radio.reuse}
        self._los_mode = scenario.channel.los
        self._max_steps = scenario.train.steps
        self._speed_m = scenario.users.speed_m_per_step
        self.start_m = np.array(scenario.uav_start_positions_m, dtype=np.float64)  # (U, 3)
        self._observer = MultiObserver(scenario)
        if radio.reuse not in ("full", "orthogonal"):
            raise ValueError(f"unknown reuse {radio.reuse!r}; use full or orthogonal")
        self._full_reuse = radio.reuse == "full"
        self._carrier_hz = carrier_hz(scenario)
        # user antenna heights of every link (B*U, N), and h - h_UT needs a subtraction only
        # where they are > 0 (as LinkGeometry.between)
        self._user_height_m = np.full((num_envs * self.num_uavs, self.num_users),
                                      scenario.users.height_m)
        self._user_height_m.flags.writeable = False
        self._users_above_ground = bool(self._user_height_m.any())
        if users_m is None:
            users_m = user_layouts(scenario, num_envs)
        self._associate(users_m)
        self._seed(seed)
        self._to_start()
        self.state: MultiNetworkState | None = None

    # ---- layouts and association -----------------------------------------------------------

    def _check_layouts(self, users_m: FloatArray) -> None:
        expected = (self.num_envs, self.num_users, 2)
        if users_m.shape != expected:
            raise ValueError(f"users_m must have shape {expected}, got {users_m.shape}")

    def _associate(self, users_m: FloatArray) -> None:
        """Serving UAVs and NOMA clusters of the layouts ``users_m`` (B, N, 2)."""
        self._check_layouts(users_m)
        self.layouts_m = np.array(users_m, dtype=np.float64)
        scenario = self.scenario
        serving = serving_groups(self.layouts_m, self.start_m, scenario.users.association,
                                 scenario.users.uav)
        starts = np.broadcast_to(self.start_m, (self.num_envs, *self.start_m.shape))
        start_gain = deterministic_gain(self.channel, self._los_mode,
                                        self.geometry(starts, self.layouts_m))
        start_gain = start_gain.reshape(self.num_envs, self.num_uavs, self.num_users)
        self.association: Association = associate(
            serving, serving_gain(start_gain, serving), scenario.users.pairing, self.num_uavs)
        self._energy = EnergyAccount(scenario, self.weights, (self.num_envs, self.num_uavs),
                                     self.association.clusters_per_uav)
        # users in observation order: as listed, or UAV by UAV and cluster by cluster
        self.observation_order: NDArray[np.intp] | None = None
        if scenario.agent.user_order == "clusters":
            pairs = np.stack([self.association.first_user, self.association.second_user],
                             axis=-1)
            self.observation_order = pairs.reshape(self.num_envs, self.num_users)
        self._index()

    def _index(self) -> None:
        """Flat index arrays of the association, made once per layout, that put a step's
        arrays in user order with one ``take`` each (docs/model.md §9), each (B, N):

        ``_serving_link`` the position of user i's serving link in the links (B, U, N);
        ``_partner_flat`` its cluster partner's in a (B, N) array; ``_alpha_source`` its
        alpha_k's in the configuration (B, U, 3 + K); ``_is_first`` whether it is its
        cluster's first user; ``_interferer`` (B, U, N) whether UAV u' interferes with it
        (:func:`adaptsky.sim.interference.interference_w`); and, for the observation, the
        users in observation order: ``_observed`` their positions in a (B, N) array and
        ``_observed_uav_xy`` (2, B, N) the positions of their serving UAV's x and y in the
        configuration.
        """
        association = self.association
        num_envs, n, num_uavs = self.num_envs, self.num_users, self.num_uavs
        width = self._dynamics.config_low.shape[-1]     # 3 + K
        rows = np.arange(num_envs)[:, None]
        serving = association.serving_uav
        self._serving_link = rows * (num_uavs * n) + serving * n + np.arange(n)
        self._partner_flat = rows * n + association.partner
        uav_base = rows * (num_uavs * width) + serving * width
        self._alpha_source = uav_base + 3 + association.cluster
        self._is_first = association.is_first
        interferer = np.moveaxis(association.has_cluster[:, association.cluster], 0, 1)
        interferer &= np.arange(num_uavs)[None, :, None] != serving[:, None, :]
        self._interferer = interferer
        order = (np.broadcast_to(np.arange(n), (num_envs, n)) if self.observation_order is None
                 else self.observation_order)
        self._observed = rows * n + order
        observed_base = np.take_along_axis(uav_base, order, axis=1)
        self._observed_uav_xy = np.stack([observed_base, observed_base + 1])
        self._repeated_of: FloatArray | None = None    # see _repeated_users
        self._repeated: FloatArray | None = None

    def set_layouts(self, users_m: FloatArray) -> None:
        """New home positions of the users (B, N, 2), associated anew; they take effect at the
        next :meth:`reset` (``users.placement = "fresh"``)."""
        self._associate(users_m)

    # ---- generators ----------------------------------------------------------------------

    def _seed(self, seed: Seed) -> None:
        """New generators: one per environment for a list of B seeds, else one shared."""
        self.rngs, self.rng = generators(seed, self.num_envs)

    def _headings(self) -> FloatArray:
        """The step's user headings (B, N), rad: from the shared generator, or row b from
        environment b's."""
        shape = (self.num_envs, self.num_users)
        if self.rngs is None:
            return self.rng.uniform(0.0, 2 * np.pi, size=shape)
        return np.stack([rng.uniform(0.0, 2 * np.pi, size=self.num_users)
                         for rng in self.rngs])

    # ---- geometry ------------------------------------------------------------------------

    def geometry(self, uav_m: FloatArray, users_m: FloatArray) -> LinkGeometry:
        """The (B*U, N) geometry of the links from UAVs ``uav_m`` (B, U, 3) to the users
        ``users_m`` (B, N, 2) (:func:`adaptsky.sim.links.all_links_geometry`)."""
        scenario = self.scenario
        return all_links_geometry(uav_m, users_m, user_height_m=scenario.users.height_m,
                                  carrier_hz=carrier_hz(scenario),
                                  bandwidth_hz=scenario.radio.bandwidth_hz)

    def gain_bounds(self) -> tuple[float, float] | None:
        """The smallest and largest gain of a link, linear (None where the channel draws
        fading, whose factors have no bound): every link is one UAV's link to one user in
        the area, so the bounds of one UAV's links hold (``gain_bounds.gain_range``)."""
        if fading_active(self.channel):
            return None
        scenario = self.scenario
        return gain_range(self.channel, scenario.channel.los,
                          functools.partial(scenario_geometry, scenario),
                          reachable_heights(scenario.uav), scenario.area.side_m)

    # ---- state ---------------------------------------------------------------------------

    @property
    def max_steps(self) -> int:
        """T, the time limit of an episode (``train.steps``)."""
        return self._max_steps

    @property
    def t(self) -> int:
        return self.sim_state.t

    @property
    def uav_m(self) -> FloatArray:
        """UAV positions (B, U, 3), m."""
        return self.sim_state.uav_m

    @property
    def alpha_first(self) -> FloatArray:
        """First users' shares (B, U, K_u)."""
        return self.sim_state.alpha_first

    @property
    def users_m(self) -> FloatArray:
        return self.sim_state.users_m

    def _to_start(self, alpha_first: FloatArray | None = None) -> None:
        """Step 0: every UAV at its start, every alpha at ``start_alpha`` (or
        ``alpha_first``), users at home."""
        shape = (self.num_envs, self.num_uavs, self.num_clusters)
        alpha = (np.full(shape, self.scenario.uav.start_alpha) if alpha_first is None
                 else np.broadcast_to(alpha_first, shape))
        starts = np.broadcast_to(self.start_m, (self.num_envs, *self.start_m.shape))
        self.sim_state = SimState.of(starts, alpha, self.layouts_m)

    def reset(self, seed: Seed = None, alpha_first: FloatArray | None = None
              ) -> tuple[NDArray[np.float32], MultiNetworkState]:
        """Start an episode (every UAV at its start position, every first user's share at
        ``start_alpha``, or ``alpha_first`` (B, U, K) where given: exploring starts,
        docs/training.md); a ``seed`` re-seeds the generators."""
        if seed is not None:
            self._seed(seed)
        self._to_start(alpha_first)
        self.state = self._evaluate(self.sim_state)
        return self._obs, self.state

    def step(self, actions: NDArray[np.integer]
             ) -> tuple[NDArray[np.float32], FloatArray, bool, MultiNetworkState]:
        """Apply B actions (dense indices over all UAVs' components); return observations,
        rewards (eq. 13), truncated, and the state. Position moves that would bring two UAVs
        closer than ``uav.min_separation_m`` are held back (docs/model.md §9)."""
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        dynamics = self._dynamics
        actions = dynamics.checked(actions)
        before = self.sim_state
        headings = self._headings() if self._speed_m else None
        moved = step(before, actions, dynamics, headings)
        config = moved.config
        moved_m = config[..., :3]
        positions = separated(before.uav_m, moved_m, self.scenario.uav.min_separation_m)
        if positions is not moved_m:
            config = np.concatenate([positions, config[..., 3:]], axis=-1)
        self.sim_state = SimState._new(config, moved.users_m, moved.t)
        self.state = self._evaluate(self.sim_state,
                                    self._energy.of_move(before.uav_m, positions))
        return self._obs, self.state.reward, self.sim_state.t >= self._max_steps, self.state

    def evaluate_at(self, uav_m: FloatArray, alpha_first: FloatArray) -> MultiNetworkState:
        """The network with the UAVs at ``uav_m`` (B, U, 3) and first users' shares
        ``alpha_first`` (B, U, K_u), as given (no clipping); LoS drawn as in a step; the
        users stay where they are."""
        state = self.sim_state
        return self._held(uav_m, alpha_first, state.users_m, state.t)

    def hold_step(self, uav_m: FloatArray, alpha_first: FloatArray) -> MultiNetworkState:
        """One step of a held configuration: the users move as in :meth:`step` (the same
        draws in the same order), the UAVs are at ``uav_m`` (B, U, 3) with shares
        ``alpha_first`` (B, U, K_u), as given; a hovering step's energy."""
        state = self.sim_state
        users_m = state.users_m
        if self._speed_m:
            users_m = self._dynamics.walked(users_m, self._headings())
        return self._held(uav_m, alpha_first, users_m, state.t + 1)

    def _held(self, uav_m: FloatArray, alpha_first: FloatArray, users_m: FloatArray, t: int
              ) -> MultiNetworkState:
        """The network in the state of the given configuration, users and step count."""
        uav_m = np.broadcast_to(uav_m, (self.num_envs, self.num_uavs, 3))
        alpha_first = np.broadcast_to(alpha_first, (self.num_envs, self.num_uavs,
                                                    self.num_clusters))
        self.sim_state = SimState.of(uav_m, alpha_first, users_m, t)
        self.state = self._evaluate(self.sim_state)
        return self.state

    def _repeated_users(self, users_m: FloatArray) -> FloatArray:
        """``users_m`` (B, N, 2) repeated for every UAV (B*U, N, 2), the users of the links'
        geometry: kept until the users move (made once per move, not once per step)."""
        if users_m is not self._repeated_of:
            repeated = np.repeat(users_m, self.num_uavs, axis=0)
            repeated.flags.writeable = False
            self._repeated_of, self._repeated = users_m, repeated
        assert self._repeated is not None
        return self._repeated

    def _links_geometry(self, uav_m: FloatArray, users_m: FloatArray) -> LinkGeometry:
        """:meth:`geometry` of the links (B*U, N), the same numbers, made from x and y offsets
        laid out (B, U, N) (contiguous, as the channel computes fastest) and the users'
        repeated positions kept from step to step."""
        num_envs, num_uavs, n = self.num_envs, self.num_uavs, self.num_users
        shape, flat = (num_envs, num_uavs, n), (num_envs * num_uavs, n)
        x_m, y_m = users_xy(users_m)                  # (B, N) each
        dx_m = np.subtract(x_m[:, None, :], uav_m[:, :, 0:1])   # user - UAV, as between()
        dy_m = np.subtract(y_m[:, None, :], uav_m[:, :, 1:2])
        height_m = np.empty(shape)
        height_m[...] = uav_m[:, :, 2:3]
        height_m = height_m.reshape(flat)
        user_height_m = self._user_height_m
        return LinkGeometry._from_offsets(
            dx_m.reshape(flat), dy_m.reshape(flat), height_m, user_height_m,
            np.reshape(uav_m, (num_envs * num_uavs, 3)), self._repeated_users(users_m),
            self._carrier_hz, self.bandwidth_hz,
            height_m - user_height_m if self._users_above_ground else height_m)

    def _evaluate(self, state: SimState, energy_j: FloatArray | None = None
                  ) -> MultiNetworkState:
        """Gains of every link, interference, SIC order, SINR and rates (docs/model.md §9),
        eq. 9 over all users and eq. 13 (with its energy term where ``reward.w_energy`` is
        set) after a step of energy ``energy_j`` (B, U) (None: hovering); also sets ``_obs``.

        The numbers of :func:`adaptsky.sim.links.link_gains` and
        :func:`adaptsky.sim.interference.noma_rates`, bit for bit, with the association's
        index arrays made once per layout (:meth:`_index`)
        (tests/unit/sim/test_multi_batch_numbers.py).
        """
        config, users_m = state.config, state.users_m
        uav_m = config[..., :3]
        gains, los, p_los = link_gains(self.channel, self._los_mode,
                                       self._links_geometry(uav_m, users_m),
                                       self.rngs if self.rngs is not None else self.rng,
                                       num_uavs=self.num_uavs)
        serving_link = self._serving_link
        gain = gains.take(serving_link)
        link_los, link_p_los = los.take(serving_link), p_los.take(serving_link)
        # I_i (interference_w): the gains of every interfering link (B, U, N), kept for the
        # rates without one UAV's interference (difference_rewards)
        if self._full_reuse:
            self._interfering_gains = np.where(self._interferer, gains, 0.0)
            interference = self._interference_w(self._interfering_gains)
        else:
            self._interfering_gains = None
            interference = np.zeros(gain.shape)
        rate_bps, strong, alpha = self._noma_rates(gain, interference, config)
        fairness = noma.jain_fairness(rate_bps)
        rewards = noma.reward(rate_bps, gain, fairness, self.bandwidth_hz, self.weights)
        if energy_j is None:
            energy_j = self._energy.hover_j
        if self._energy.weighted:
            rewards = self._energy.rewarded(rewards, energy_j)
        observed = self._observed
        uav_xy = config.take(self._observed_uav_xy)              # (2, B, N)
        users = users_xy(users_m).reshape(2, -1).take(observed, axis=1)
        self._obs = self._observer.from_offsets(
            uav_xy[0] - users[0], uav_xy[1] - users[1], uav_m, alpha.take(observed),
            gain.take(observed), interference.take(observed))
        return MultiNetworkState(uav_m.copy(), alpha, gain, interference, link_los,
                                 link_p_los, strong, rate_bps, rate_bps.sum(axis=-1), fairness,
                                 rewards, energy_j)

    def _noma_rates(self, gain: FloatArray, interference: FloatArray, config: FloatArray
                    ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
        """Every user's rate (B, N), whether it is its cluster's strong user, and its share,
        from its serving gain, the interference it hears (W) and the UAVs' configuration:
        SIC by the effective gain c_i = g_i / (I_i + sigma^2) (strong_users), shares
        (user_shares), SINR and rates (noma_rates)."""
        radio = self._radio
        tx_power_w, antenna_gain = radio["tx_power_w"], radio["antenna_gain"]
        noise_plus = interference + radio["noise_w"]
        effective = gain / noise_plus
        partner = self._partner_flat
        effective_partner, gain_partner = effective.take(partner), gain.take(partner)
        is_first = self._is_first
        strong = (effective > effective_partner) | ((effective == effective_partner) & (
            (gain > gain_partner) | ((gain == gain_partner) & is_first)))
        alpha_k = config.take(self._alpha_source)
        second_share = 1.0 - alpha_k
        alpha = np.where(is_first, alpha_k, second_share)
        alpha_partner = np.where(is_first, second_share, alpha_k)
        snr_scale = tx_power_w * antenna_gain / noise_plus
        sinr = noma.user_sinr(alpha, alpha_partner, gain, strong, snr_scale)
        return noma.rate_bps(sinr, radio["bandwidth_hz"]), strong, alpha

    def rates_without(self, uav: int) -> FloatArray:
        """Every user's rate (B, N) in the last evaluated state had UAV ``uav`` sent nothing
        to the other UAVs' users: their interference without its term, SIC re-ordered (its
        own users' rates as they are)."""
        assert self.state is not None, "call reset() first"
        if self._interfering_gains is None:   # orthogonal reuse: no interference
            return self.state.rate_bps
        others = self._interfering_gains.copy()
        others[:, uav] = 0.0
        return self._noma_rates(self.state.gain, self._interference_w(others),
                                self.sim_state.config)[0]

    def _interference_w(self, interfering_gains: FloatArray) -> FloatArray:
        """I_i (B, N), W: P_T G times the gains (B, U, N) of the links that interfere."""
        radio = self._radio
        return radio["tx_power_w"] * radio["antenna_gain"] * interfering_gains.sum(axis=1)

    def observation(self) -> NDArray[np.float32]:
        assert self.state is not None, "call reset() first"
        return self._obs

    @property
    def hover_energy_j(self) -> FloatArray:
        """Each UAV's energy of a hovering step (B,) or (B, U), J (docs/model.md §10)."""
        return self._energy.hover_j

    def reward_parts(self, state: MultiNetworkState, split: str = "per-uav") -> FloatArray:
        """Eq. 13 of ``state``, the last evaluated one, for each UAV (B, U) (docs/agent.md,
        "A reward per UAV"): ``per-uav``, the part from its own users
        (:func:`adaptsky.sim.reward.reward_per_uav`) and its own energy; ``difference``, that
        part plus what its interference costs the other UAVs' users in eq. 13's rate term,
        w_r sum_{i not of u} (R_i - R_i^{-u}) / W 1[all R_i >= R_min], with R_i^{-u} the rate
        had UAV u sent them nothing (:meth:`rates_without`)."""
        parts = reward_per_uav(state.rate_bps, state.gain, state.fairness, self.bandwidth_hz,
                               self.weights, self.association.serving_uav, self.num_uavs)
        if self._energy.weighted:
            parts = parts + self._energy.reward_parts(state.energy_j)
        if split == "difference":
            parts = parts + self._interference_costs(state)
        return parts

    def _interference_costs(self, state: MultiNetworkState) -> FloatArray:
        """w_r sum_{i not of u} (R_i - R_i^{-u}) / W 1[all R_i >= R_min] per UAV (B, U)."""
        weights, serving = self.weights, self.association.serving_uav
        every = (state.rate_bps >= np.asarray(weights.min_rate_bps)[..., None]).all(axis=-1)
        costs = np.empty((self.num_envs, self.num_uavs))
        for uav in range(self.num_uavs):
            lost = np.where(serving == uav, 0.0, state.rate_bps - self.rates_without(uav))
            costs[:, uav] = lost.sum(axis=-1) / self.bandwidth_hz
        return np.asarray(weights.w_rate)[..., None] * costs * every[:, None]


NetworkBatch = NomaUavBatch | MultiUavBatch


def network_batch(scenario: Scenario, num_envs: int = 1, seed: Seed = None,
                  users_m: FloatArray | None = None,
                  weights: list[noma.RewardWeights] | None = None) -> NetworkBatch:
    """The batched environment of ``scenario``: :class:`NomaUavBatch` for one UAV (the
    paper's numbers, bit for bit), :class:`MultiUavBatch` for several."""
    kind = NomaUavBatch if scenario.uav.count == 1 else MultiUavBatch
    return kind(scenario, num_envs=num_envs, seed=seed, users_m=users_m, weights=weights)


def user_roles(batch: NetworkBatch) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Every user's serving UAV and its cluster k among that UAV's clusters, (B, N) each: the
    association of several UAVs; UAV 0 and the pairing's clusters for one."""
    if isinstance(batch, MultiUavBatch):
        return batch.association.serving_uav, batch.association.cluster
    return np.zeros_like(batch.cluster), batch.cluster
