"""The NOMA-UAV network of docs/model.md §1-4, simulated for B independent layouts at once.

One :class:`NomaUavBatch` holds B UAVs, each serving its own layout of N users in K = N/2
clusters. All B environments step in lockstep: one call to :meth:`NomaUavBatch.step` takes B
actions and returns B rewards. Episodes end by the time limit T (a truncation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import (
    DEFAULT_CARRIER_HZ,
    ChannelModel,
    LinkGeometry,
    contract_version_of,
)
from adaptsky.channels.registry import get_model_class
from adaptsky.scenario.models import Scenario
from adaptsky.scenario.one_uav import require_one_uav
from adaptsky.sim import noma
from adaptsky.sim.energy import EnergyAccount
from adaptsky.sim.gain_bounds import gain_range, reachable_heights
from adaptsky.sim.layout import pair_users, user_layouts
from adaptsky.sim.observation import FEATURES_PER_USER, Observer, observe
from adaptsky.sim.state import Dynamics, SimState, one_uav, step, user_positions, users_xy

FloatArray = NDArray[np.float64]

_ONE = np.array(1.0)


def build_channel(scenario: Scenario) -> ChannelModel:
    """The scenario's channel-model plugin with its parameters."""
    model_class = get_model_class(scenario.channel.model)
    return model_class(model_class.Params.model_validate(scenario.channel.params))


def deterministic_gain(channel: ChannelModel, los: str, geometry: LinkGeometry) -> FloatArray:
    """The gain planning uses: the LoS gain for ``los = "always"``, else the expected gain
    (never with fading)."""
    return channel.gain_los(geometry) if los == "always" else channel.expected_gain(geometry)


def fading_active(channel: ChannelModel) -> bool:
    """Whether the environment draws per-step fading from this model (contract 2 and its
    ``fading_enabled()``)."""
    return contract_version_of(channel) >= 2 and bool(channel.fading_enabled())


def carrier_hz(scenario: Scenario) -> float:
    """f_c of the scenario (``radio.carrier_hz``, resolved when the scenario is loaded)."""
    value = scenario.radio.carrier_hz
    return DEFAULT_CARRIER_HZ if value is None else value


def scenario_geometry(scenario: Scenario, uav_m: FloatArray, users_m: FloatArray
                      ) -> LinkGeometry:
    """The links between UAVs ``uav_m`` (B', 3) and users ``users_m`` (B', N, 2) in
    ``scenario`` (its user height, carrier and bandwidth; docs/plugins.md, the geometry)."""
    return LinkGeometry.between(uav_m, users_m, user_height_m=scenario.users.height_m,
                                carrier_hz=carrier_hz(scenario),
                                bandwidth_hz=scenario.radio.bandwidth_hz)


def generators(seed: int | np.random.SeedSequence | list[np.random.SeedSequence] | None,
               num_envs: int) -> tuple[list[np.random.Generator] | None, np.random.Generator]:
    """``(rngs, rng)``: for a list of ``num_envs`` seeds a generator per environment (and an
    unseeded shared one), else None and one shared generator from ``seed``."""
    rngs = None
    if isinstance(seed, list):
        if len(seed) != num_envs:
            raise ValueError(f"seed must list {num_envs} seeds, got {len(seed)}")
        rngs = [np.random.default_rng(s) for s in seed]
    return rngs, np.random.default_rng(None if isinstance(seed, list) else seed)


def reward_weights(scenario: Scenario) -> noma.RewardWeights:
    r = scenario.reward
    return noma.RewardWeights(w_rate=r.w_rate, w_fairness=r.w_fairness, w_gain=r.w_gain,
                              w_satisfied=r.w_satisfied, w_unsatisfied=r.w_unsatisfied,
                              min_rate_bps=scenario.min_rate_bps, w_energy=r.w_energy)


@dataclass(frozen=True)
class NetworkState:
    """The network after a reset or step; leading axis B, then users N where it applies.

    gain is the linear gain of one antenna pair used for the rates (with the step's fading
    where the channel model draws it); los the LoS state of each link (for ``los =
    "expected"``: P_LoS > 0.5); p_los the LoS probability; energy_j the UAV's propulsion and
    transmit energy of the step (docs/model.md §10; a hovering step after a reset or for a
    held configuration).
    """

    uav_m: FloatArray
    alpha: FloatArray
    gain: FloatArray
    los: NDArray[np.bool_]
    p_los: FloatArray
    rate_bps: FloatArray
    sum_rate_bps: FloatArray
    fairness: FloatArray
    reward: FloatArray
    energy_j: FloatArray

    @classmethod
    def _new(cls, uav_m: FloatArray, alpha: FloatArray, gain: FloatArray,
             los: NDArray[np.bool_], p_los: FloatArray, rate_bps: FloatArray,
             sum_rate_bps: FloatArray, fairness: FloatArray, reward: FloatArray,
             energy_j: FloatArray) -> NetworkState:
        """The state with these fields, made without the frozen dataclass's ``__init__``,
        which sets each field through ``object.__setattr__`` (for the environment's step):
        each field is written straight into the instance's ``__dict__``, the cheapest way."""
        state = object.__new__(cls)
        fields = state.__dict__
        fields["uav_m"] = uav_m
        fields["alpha"] = alpha
        fields["gain"] = gain
        fields["los"] = los
        fields["p_los"] = p_los
        fields["rate_bps"] = rate_bps
        fields["sum_rate_bps"] = sum_rate_bps
        fields["fairness"] = fairness
        fields["reward"] = reward
        fields["energy_j"] = energy_j
        return state

    def for_env(self, index: int) -> dict[str, np.ndarray | float]:
        """The state of environment ``index`` as a Gymnasium ``info`` dict."""
        return {
            "uav_m": self.uav_m[index].copy(),
            "alpha": self.alpha[index].copy(),
            "gain": self.gain[index].copy(),
            "los": self.los[index].copy(),
            "p_los": self.p_los[index].copy(),
            "rate_bps": self.rate_bps[index].copy(),
            "sum_rate_bps": float(self.sum_rate_bps[index]),
            "fairness": float(self.fairness[index]),
            "energy_j": float(self.energy_j[index]),
        }


class NomaUavBatch:
    """B independent copies of the network, vectorised with numpy.

    Arguments: ``scenario`` (validated), ``num_envs`` B, ``seed`` of the generator that draws
    LoS states and user moves, ``users_m`` (B, N, 2) to override the scenario's layouts.
    ``seed`` may also be a list of B seeds: then every environment draws from a generator of
    its own, so its numbers do not depend on B or on its neighbours (a stack of training
    seeds). ``weights`` gives each environment its own reward weights (eq. 13).

    The state between steps is ``sim_state``, a :class:`~adaptsky.sim.state.SimState` with a
    UAV axis (U = 1); :meth:`step` advances it with :func:`adaptsky.sim.state.step`, drawing
    the users' headings from this batch's generators, then evaluates the channel, rates and
    reward there (``state``, a :class:`NetworkState`).

    For small B a step costs what its numpy calls cost, not what they compute, so a step
    makes a fixed number of them whatever B (about 50; with per-environment seeds, plus one
    draw per environment where something is drawn). Every call is elementwise or reduces
    over users only, so environment b's numbers never depend on B or on its neighbours. The
    UAV positions and first users' shares live in one array (B, U, 3 + K), the configuration
    [x, y, h, alpha_1 .. alpha_K] of every UAV, so an action is a table lookup, an addition
    and a clip; eq. 2 is evaluated in user order through index arrays into the flattened
    configuration, built once from the pairing.
    """

    def __init__(self, scenario: Scenario, num_envs: int = 1,
                 seed: int | np.random.SeedSequence | list[np.random.SeedSequence] | None = None,
                 users_m: FloatArray | None = None,
                 weights: list[noma.RewardWeights] | None = None) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        require_one_uav(scenario, scenario.name)   # several UAVs: adaptsky.sim's own modules
        self.scenario = scenario
        self._max_steps = scenario.train.steps
        self.num_envs = num_envs
        self.num_users = scenario.num_users
        self.num_clusters = scenario.num_clusters
        self.num_uavs = 1
        self.channel = build_channel(scenario)
        self._dynamics = Dynamics.of(scenario, num_envs)
        self.actions = self._dynamics.actions
        self.weights = reward_weights(scenario) if weights is None else noma.stack_weights(
            weights)
        if weights is not None and len(weights) != num_envs:
            raise ValueError(f"weights must have {num_envs} entries, got {len(weights)}")
        radio = scenario.radio
        self.bandwidth_hz = radio.bandwidth_hz
        self.snr_scale = radio.tx_power_w * radio.antenna_gain / radio.noise_w
        if users_m is None:
            users_m = user_layouts(scenario, num_envs)
        if users_m.shape != (num_envs, self.num_users, 2):
            raise ValueError(f"users_m must have shape {(num_envs, self.num_users, 2)}, "
                             f"got {users_m.shape}")
        self._start_m = np.array(scenario.uav.start_m, dtype=np.float64)
        self._energy = EnergyAccount(scenario, self.weights, (num_envs,))
        self._pair(users_m)
        self._prepare_step()
        self._seed(seed)
        self._to_start()
        self.state: NetworkState | None = None

    def _pair(self, users_m: FloatArray) -> None:
        """Take the layouts ``users_m`` (B, N, 2) and pair their users into clusters by the
        gains from the start position (``users.pairing``)."""
        self.layouts_m = np.array(users_m, dtype=np.float64)
        start_uav = np.broadcast_to(self._start_m, (self.num_envs, 3))
        start_gain = deterministic_gain(self.channel, self.scenario.channel.los,
                                        self.geometry(start_uav, self.layouts_m))
        self.first_user, self.second_user = pair_users(start_gain, self.scenario.users.pairing)
        # flat positions of (first users, second users) in a (B, N) array, for fast gathers
        rows = np.arange(self.num_envs)[:, None] * self.num_users
        self._cluster_flat = (rows + np.concatenate([self.first_user, self.second_user],
                                                    axis=1)).ravel()
        # users in observation order: as listed, or cluster by cluster (agent.user_order)
        self.observation_order: NDArray[np.intp] | None = None
        self._order_flat: NDArray[np.intp] | None = None
        if self.scenario.agent.user_order == "clusters":
            self.observation_order = np.stack([self.first_user, self.second_user],
                                              axis=2).reshape(self.num_envs, self.num_users)
            self._order_flat = (rows + self.observation_order).ravel()

    def set_layouts(self, users_m: FloatArray) -> None:
        """New home positions of the users (B, N, 2), paired anew; they take effect at the next
        :meth:`reset` (``users.placement = "fresh"``: a layout per training episode)."""
        if users_m.shape != (self.num_envs, self.num_users, 2):
            raise ValueError(f"users_m must have shape {(self.num_envs, self.num_users, 2)}, "
                             f"got {users_m.shape}")
        self._pair(users_m)
        self._user_index()

    def _prepare_step(self) -> None:
        """Everything a step needs that does not change from step to step."""
        scenario = self.scenario
        self._user_index()
        self._speed_m = scenario.users.speed_m_per_step
        self._los_mode = scenario.channel.los
        channel_type = type(self.channel)
        # the base class's sample_los and expected_gain, computed here from the p_los at hand
        self._own_sample_los = channel_type.sample_los is ChannelModel.sample_los
        self._own_expected_gain = channel_type.expected_gain is ChannelModel.expected_gain
        self._fading = fading_active(self.channel)
        # gain, LoS state and LoS probability of every link under the scenario's LoS mode,
        # with the step's fading where the channel draws it (chosen once, not every step)
        self._link_gains = self._faded_gains if self._fading else self._large_scale_gains
        self._carrier_hz = carrier_hz(scenario)
        # user antenna heights (B, N), and h - h_UT needs a subtraction only where they are > 0
        self._user_height_m = np.full((self.num_envs, self.num_users), scenario.users.height_m)
        self._user_height_m.flags.writeable = False
        self._users_above_ground = scenario.users.height_m > 0
        self._reward = noma.RewardFromSums(self.weights, self.num_users, self.bandwidth_hz)
        self._shape = (self.num_envs, self.num_users)
        # the shapes of the features (4, B, N) and of the per-user terms summed over users
        self._features_shape = (FEATURES_PER_USER, *self._shape)
        self._terms_shape = (4 if self._reward.needs_gain_sum else 3, *self._shape)
        self._observer = Observer(scenario, self._shape)
        # numbers as 0-d arrays: numpy combines them with an array faster than Python floats
        self._snr_scale = np.array(self.snr_scale)
        self._bandwidth_hz = np.array(self.bandwidth_hz)
        self._num_users = np.array(float(self.num_users))
        self._all_los = np.ones(self._shape, dtype=bool)
        self._users_seen: FloatArray | None = None      # see _users_xy
        self._users_seen_xy: FloatArray | None = None

    def _user_index(self) -> None:
        """Index arrays that put a step in user order, each (..., B, N).

        For user i of environment b in cluster k: ``_config_source`` (5, B, N) holds the flat
        positions in the configuration (B, U, 3 + K) of its UAV's x, y, h and, twice, of
        alpha_k (every user is served by UAV 0: U = 1);
        user i's share and its partner's are ``_share_offset + _share_sign`` alpha_k (2, B, N),
        i.e. alpha_k and 1 - alpha_k for a first user, the other way round for a second user.
        ``_cluster_users`` (2, B, N) holds the flat positions (b N + j) in a (B, N) array of
        the first and the second user of i's cluster; ``_is_second`` marks second users.
        ``cluster`` (B, N), public, is every user's cluster k.
        """
        num_envs, n, k = self.num_envs, self.num_users, self.num_clusters
        shape = (num_envs, n)
        rows = np.arange(num_envs)[:, None]
        cluster = np.empty(shape, dtype=np.intp)      # cluster of every user
        np.put_along_axis(cluster, self.first_user, np.arange(k), axis=1)
        np.put_along_axis(cluster, self.second_user, np.arange(k), axis=1)
        self.cluster = cluster
        is_second = np.zeros(shape, dtype=bool)
        np.put_along_axis(is_second, self.second_user, True, axis=1)
        serving_uav = np.zeros(shape, dtype=np.intp)
        uav = rows * (self.num_uavs * (3 + k)) + serving_uav * (3 + k)
        alpha_k = uav + 3 + cluster
        self._config_source = np.stack([uav, uav + 1, uav + 2, alpha_k, alpha_k])
        self._cluster_users = np.stack([
            rows * n + np.take_along_axis(self.first_user, cluster, axis=1),
            rows * n + np.take_along_axis(self.second_user, cluster, axis=1)])
        self._is_second = is_second
        sign = np.where(is_second, -1.0, 1.0)
        offset = np.where(is_second, 1.0, 0.0)
        self._share_sign = np.stack([sign, -sign])
        self._share_offset = np.stack([offset, 1.0 - offset])

    def _seed(self, seed: int | np.random.SeedSequence | list[np.random.SeedSequence] | None
              ) -> None:
        """New generators: one per environment for a list of B seeds, else one shared."""
        self.rngs, self.rng = generators(seed, self.num_envs)

    def geometry(self, uav_m: FloatArray, users_m: FloatArray) -> LinkGeometry:
        """The links between UAVs ``uav_m`` (B', 3) and users ``users_m`` (B', N, 2) in this
        scenario (:func:`scenario_geometry`)."""
        return scenario_geometry(self.scenario, uav_m, users_m)

    def gain_bounds(self) -> tuple[float, float] | None:
        """The smallest and largest gain a step can give, linear (``gain_bounds.gain_range``:
        the observation's bounds, docs/environment.md); None where the channel draws fading,
        whose factors have no bound."""
        if self._fading:
            return None
        scenario = self.scenario
        return gain_range(self.channel, scenario.channel.los, self.geometry,
                          reachable_heights(scenario.uav), scenario.area.side_m)

    @property
    def max_steps(self) -> int:
        """T, the time limit of an episode (``train.steps``)."""
        return self._max_steps

    @property
    def t(self) -> int:
        """Steps since the episode started."""
        return self.sim_state.t

    @property
    def uav_m(self) -> FloatArray:
        """UAV positions (B, 3) [x, y, h], m (a view of the configuration)."""
        return one_uav(self.sim_state.config)[:, :3]

    @uav_m.setter
    def uav_m(self, value: FloatArray) -> None:
        self._set_config(value, self.alpha_first)

    @property
    def alpha_first(self) -> FloatArray:
        """Power shares (B, K) of every cluster's first user (a view of the configuration)."""
        return one_uav(self.sim_state.config)[:, 3:]

    @alpha_first.setter
    def alpha_first(self, value: FloatArray) -> None:
        self._set_config(self.uav_m, value)

    def _config(self, uav_m: FloatArray, alpha_first: FloatArray) -> FloatArray:
        """The configuration (B, U, 3 + K) of one UAV at ``uav_m`` (B, 3) with first users'
        shares ``alpha_first`` (B, K), each broadcast to B."""
        config = np.empty((self.num_envs, self.num_uavs, 3 + self.num_clusters))
        one_uav(config)[:, :3] = uav_m
        one_uav(config)[:, 3:] = alpha_first
        return config

    def _set_config(self, uav_m: FloatArray, alpha_first: FloatArray) -> None:
        """A new state with the UAV at ``uav_m`` (B, 3) and shares ``alpha_first`` (B, K)."""
        state = self.sim_state
        self.sim_state = SimState._new(self._config(uav_m, alpha_first), state.users_m, state.t)

    def _faded_gains(self, geometry: LinkGeometry) -> tuple[FloatArray, NDArray[np.bool_],
                                                            FloatArray]:
        """The large-scale gains times the step's fading factors, with their LoS states and
        probabilities (``_link_gains`` where the channel draws fading)."""
        gain, los, p_los = self._large_scale_gains(geometry)
        return gain * self._sample_fading(geometry, los), los, p_los

    def _large_scale_gains(self, geometry: LinkGeometry) -> tuple[FloatArray,
                                                                  NDArray[np.bool_], FloatArray]:
        """Gain, LoS state and LoS probability before fading."""
        channel = self.channel
        p_los = channel.los_probability(geometry)
        mode = self._los_mode
        if mode == "always":
            return channel.gain_los(geometry), self._all_los.copy(), p_los
        if mode == "sampled":
            los = self._sample_los(geometry, p_los)
            gain = np.where(los, channel.gain_los(geometry), channel.gain_nlos(geometry))
            return gain, los, p_los
        if self._own_expected_gain:   # ChannelModel.expected_gain with this p_los
            gain = p_los * channel.gain_los(geometry) + (_ONE - p_los) * channel.gain_nlos(
                geometry)
        else:
            gain = channel.expected_gain(geometry)
        return gain, p_los > 0.5, p_los

    def _sample_fading(self, geometry: LinkGeometry, los: NDArray[np.bool_]) -> FloatArray:
        """The step's fading factors (B, N), drawn after the LoS states from the same
        generator: the shared one, or row b from environment b's."""
        channel = self.channel
        if self.rngs is None:
            return channel.sample_fading(geometry, los, self.rng)
        return np.concatenate([channel.sample_fading(geometry.rows(b, b + 1), los[b:b + 1], rng)
                               for b, rng in enumerate(self.rngs)])

    def _sample_los(self, geometry: LinkGeometry, p_los: FloatArray) -> NDArray[np.bool_]:
        """LoS states drawn from the shared generator, or row b from environment b's."""
        if not self._own_sample_los:  # the plugin draws for itself
            if self.rngs is None:
                return self.channel.sample_los(geometry, self.rng)
            return np.concatenate([self.channel.sample_los(geometry.rows(b, b + 1), rng)
                                   for b, rng in enumerate(self.rngs)])
        # ChannelModel.sample_los: one uniform draw per link, LoS where it is below P_LoS
        if self.rngs is None:
            return self.rng.random(geometry.shape) < p_los
        if self.num_envs == 1:
            return self.rngs[0].random(geometry.shape) < p_los
        draws = np.empty(geometry.shape)
        for row, rng in zip(draws, self.rngs, strict=True):
            rng.random(out=row)     # the numbers random(row.shape) would return
        return draws < p_los

    def _to_users(self, first: FloatArray, second: FloatArray) -> FloatArray:
        """(B, N) array from the values of every cluster's first and second users (B, K)."""
        values = np.empty(self.num_envs * self.num_users)
        values[self._cluster_flat] = np.concatenate([first, second], axis=1).ravel()
        return values.reshape(self.num_envs, self.num_users)

    def per_user_alpha(self, alpha_first: FloatArray) -> FloatArray:
        """alpha (B, N) of every user from the first users' shares (B, K)."""
        return self._to_users(alpha_first, 1.0 - alpha_first)

    def _evaluate(self, state: SimState, energy_j: FloatArray | None = None) -> NetworkState:
        """The network in ``state`` after a step of energy ``energy_j`` (B,) (None: a hovering
        step); also sets ``_obs``.

        Eq. 2 (SINR) in user order, eq. 3 (rates), eq. 9 (Jain) and eq. 13 (reward, with its
        energy term where ``reward.w_energy`` is set); the sums over users of R, R^2, R/W (and
        g where the reward needs it) are one reduction.
        """
        config = state.config
        uav_m = one_uav(config)[:, :3]
        # per user (5, B, N): its UAV's x, y, h and, twice, its cluster's alpha_k
        per_user = config.take(self._config_source)
        # the observation's features (4, B, N) [x_UAV - x_i, y_UAV - y_i, alpha_i, g_i], raw;
        # rows 2 and 3 first hold every user's share and its partner's (alpha_k, 1 - alpha_k)
        features = np.empty(self._features_shape)
        delta = np.subtract(per_user[:2], self._users_xy(state.users_m), out=features[:2])
        height_m = per_user[2]
        geometry = LinkGeometry._from_offsets(
            delta[0], delta[1], height_m, self._user_height_m, uav_m, state.users_m,
            self._carrier_hz, self.bandwidth_hz,
            height_m - self._user_height_m if self._users_above_ground else height_m)
        gain, los, p_los = self._link_gains(geometry)
        shares = np.add(self._share_offset, self._share_sign * per_user[3:],
                        out=features[2:])
        alpha = shares[0]
        # SIC order (eq. 2): the first user is strong where g_first >= g_second
        first_second = gain.take(self._cluster_users)
        strong = (first_second[0] >= first_second[1]) ^ self._is_second
        sinr = noma.user_sinr(alpha, shares[1], gain, strong, self._snr_scale)
        bandwidth_hz, reward = self._bandwidth_hz, self._reward
        terms = np.empty(self._terms_shape)
        rates = np.multiply(bandwidth_hz, np.log2(_ONE + sinr), out=terms[0])  # eq. 3
        np.square(rates, out=terms[1])
        np.divide(rates, bandwidth_hz, out=terms[2])      # spectral efficiency R/W
        if reward.needs_gain_sum:
            terms[3] = gain
        sums = np.add.reduce(terms, axis=2)
        total = sums[0]
        fairness = noma.jain_from_sums(total, sums[1], self._num_users)
        rewards = reward(rates, gain, fairness, sums[2],
                         sums[3] if reward.needs_gain_sum else None)
        energy = self._energy
        if energy_j is None:
            energy_j = energy.hover_j
        if energy.weighted:
            rewards = energy.rewarded(rewards, energy_j)
        # the observer writes the gains over the partners' shares and scales every row in
        # place (alpha is divided by 1, which leaves it as it is)
        self._obs = self._observer(features, gain, uav_m[:, 2], self._order_flat)
        return NetworkState._new(uav_m.copy(), alpha, gain, los, p_los, rates, total,
                                 fairness, rewards, energy_j)

    def _users_xy(self, users_m: FloatArray) -> FloatArray:
        """:func:`~adaptsky.sim.state.users_xy` of ``users_m``, kept until the users move
        (made once per move, not once per step)."""
        if users_m is not self._users_seen:
            self._users_seen, self._users_seen_xy = users_m, users_xy(users_m)
        return self._users_seen_xy

    def evaluate_at(self, uav_m: FloatArray, alpha_first: FloatArray) -> NetworkState:
        """The network with every UAV at ``uav_m`` (B, 3) and first users' shares
        ``alpha_first`` (B, K), taken as given (no clipping); LoS is drawn as in a step;
        the users stay where they are."""
        self._set_config(uav_m, alpha_first)
        self.state = self._evaluate(self.sim_state)
        return self.state

    def hold_step(self, uav_m: FloatArray, alpha_first: FloatArray) -> NetworkState:
        """One step of a held configuration: the users move as in :meth:`step` (the same
        draws in the same order: headings, then LoS), the UAV is at ``uav_m`` (B, 3) with
        shares ``alpha_first`` (B, K), as given; a hovering step's energy. Baselines use
        this to hold a configuration while the users walk (docs/evaluation.md)."""
        state = self.sim_state
        users_m = state.users_m
        if self._speed_m:
            users_m = self._dynamics.walked(users_m, self._headings())
        self.sim_state = SimState._new(self._config(uav_m, alpha_first), users_m, state.t + 1)
        self.state = self._evaluate(self.sim_state)
        return self.state

    def observation(self) -> NDArray[np.float32]:
        assert self.state is not None, "call reset() first"
        return observe(self.scenario, self.uav_m, self.users_m, self.state.alpha,
                       self.state.gain, self.observation_order)

    def reset(self, seed: int | np.random.SeedSequence | list[np.random.SeedSequence] | None = None,
              alpha_first: FloatArray | None = None) -> tuple[NDArray[np.float32], NetworkState]:
        """Start an episode: UAV at ``uav.start_m``, every alpha at ``start_alpha``
        (docs/model.md §3), or the first users' shares ``alpha_first`` (B, K) where given
        (exploring starts, docs/training.md).

        A ``seed`` re-seeds the generator of LoS draws and user moves.
        """
        if seed is not None:
            self._seed(seed)
        self._to_start(alpha_first)
        self.state = self._evaluate(self.sim_state)
        return self._obs, self.state

    def _to_start(self, alpha_first: FloatArray | None = None) -> None:
        """Step 0: UAV at the start, first users' shares at start_alpha (or ``alpha_first``),
        users at home."""
        shares = self.scenario.uav.start_alpha if alpha_first is None else alpha_first
        self.sim_state = SimState(self._config(self._start_m, shares),
                                  user_positions(self.layouts_m), 0)

    @property
    def hover_energy_j(self) -> FloatArray:
        """Each UAV's energy of a hovering step (B,) or (B, U), J (docs/model.md §10)."""
        return self._energy.hover_j

    @property
    def users_m(self) -> FloatArray:
        """User positions (B, N, 2), m (``sim_state.users_m``)."""
        return self.sim_state.users_m

    @users_m.setter
    def users_m(self, value: FloatArray) -> None:
        state = self.sim_state
        self.sim_state = SimState._new(state.config, user_positions(value), state.t)

    def _headings(self) -> FloatArray:
        """The step's user headings (B, N), rad, uniform: from the shared generator, or row b
        from environment b's."""
        shape = (self.num_envs, self.num_users)
        if self.rngs is None:
            return self.rng.uniform(0.0, 2 * np.pi, size=shape)
        heading = np.empty(shape)
        for row, rng in zip(heading, self.rngs, strict=True):
            row[...] = rng.uniform(0.0, 2 * np.pi, size=self.num_users)
        return heading

    def apply(self, actions: NDArray[np.integer]) -> None:
        """Move every UAV and change every alpha by its action, clipped to the feasible set
        (:meth:`adaptsky.sim.state.Dynamics.moved`); users and the step count stay.

        Feasible set (alg. 1 line 7): |x|, |y| <= L/2, h_min <= h <= h_max,
        power_step <= alpha <= 1 - power_step.
        """
        state, dynamics = self.sim_state, self._dynamics
        config = dynamics.moved(state.config, dynamics.checked(actions))
        self.sim_state = SimState._new(config, state.users_m, state.t)

    def step(self, actions: NDArray[np.integer]
             ) -> tuple[NDArray[np.float32], FloatArray, bool, NetworkState]:
        """Apply B actions; return observations, rewards (eq. 13), truncated, and the state.

        The reward and next observation use the channel at the position after the move
        (the released code's one-step lag is not copied, docs/model.md §7).
        """
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        dynamics = self._dynamics
        actions = dynamics.checked(actions)    # before anything is drawn
        before = self.sim_state
        sim_state = self.sim_state = step(before, actions, dynamics,
                                          self._headings() if self._speed_m else None)
        energy_j = self._energy.of_move(one_uav(before.config)[:, :3],
                                        one_uav(sim_state.config)[:, :3])
        state = self.state = self._evaluate(sim_state, energy_j)
        return self._obs, state.reward, sim_state.t >= self._max_steps, state
