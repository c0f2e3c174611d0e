"""The network of U UAVs and N users (docs/model.md §1-4 and §9), simulated for B independent
layouts at once: :class:`NetworkBatch`, the one simulator, for one UAV (the paper's, U = 1) and
for several.

A step is the gymnax-like pure step of :mod:`adaptsky.sim.state` followed by the evaluation of
the new state, each a named stage, called in this order (docs/architecture.md):

1. mobility: the users walk (:meth:`~adaptsky.sim.state.Dynamics.walked`);
2. controls: every UAV's move and every share's change, clipped to the feasible set
   (:meth:`~adaptsky.sim.state.Dynamics.moved`), moves that break the separation held back
   (:func:`~adaptsky.sim.separation.separated`), then moves into a building
   (:func:`~adaptsky.sim.blockage.kept_out`, docs/model.md §12);
3. geometry of every UAV-user link (:func:`~adaptsky.sim.links.links_geometry`);
4. channel: the plugin's gains, LoS and fading (:func:`~adaptsky.sim.links.link_gains`),
   with ``los = "geometric"`` the buildings' LoS states
   (:meth:`~adaptsky.sim.blockage.Blockage.los`), the built-in small-scale fading last
   (:class:`~adaptsky.sim.fading.FadingStage`);
5. association and clusters, fixed per layout (:mod:`adaptsky.sim.association`);
6. rates: interference (:func:`~adaptsky.sim.interference.interference_sum_w`), SIC order
   (:func:`~adaptsky.sim.noma.is_strong`), SINR and rates (eqs. 2-3);
7. reward terms (eq. 9 and eq. 13, :mod:`adaptsky.sim.reward`) and energy
   (:mod:`adaptsky.sim.energy`);
8. observation (:mod:`adaptsky.sim.observation`): the paper's layout for one UAV, the
   several-UAV layout otherwise, users as listed; what the agent sees of it is the adapter it
   picks (``view``, :mod:`adaptsky.envs.observations`).

Stages 3-8 are the one evaluation of the network (:meth:`NetworkBatch.evaluate`): a
configuration, the users' positions and the draws in, a :class:`NetworkState` out. A step
(stages 1-2, then it), every baseline and reference (a configuration held or flown) and the
training's greedy evaluations call it.

With U = 1 every public array keeps the paper's shapes: UAV positions (B, 3), shares (B, K),
energy (B,); with U > 1 they have a UAV axis: (B, U, 3), (B, U, K), (B, U).
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
from adaptsky.sim.blockage import Blockage, kept_out, users_kept_out
from adaptsky.sim.chain import Chain
from adaptsky.sim.city import City, city_of, on_footprints
from adaptsky.sim.csi import CsiStage
from adaptsky.sim.energy import EnergyAccount
from adaptsky.sim.fading import FadingStage, Generators
from adaptsky.sim.gain_bounds import gain_range, reachable_heights
from adaptsky.sim.interference import (
    interference_sum_w,
    interferers,
    serving_gain,
    sic_rates,
)
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.links import (
    build_channel,
    carrier_hz,
    deterministic_gain,
    fading_active,
    link_gains_and_means,
    links_geometry,
    offsets_geometry,
    scenario_geometry,
)
from adaptsky.sim.mobility import MODELS as MOBILITY_MODELS
from adaptsky.sim.mobility import MobilityStage
from adaptsky.sim.observation import (
    FEATURES_PER_USER,
    MultiObserver,
    ObservationView,
    Observer,
    WorldData,
    flat_gather,
    gathered,
    observation_size,
)
from adaptsky.sim.reward import RewardFromSums, reward_per_uav, reward_weights, stack_weights
from adaptsky.sim.separation import separated
from adaptsky.sim.state import (
    Dynamics,
    SimState,
    step,
    user_positions,
    users_xy,
    walk_step_m,
)

FloatArray = NDArray[np.float64]
Seed = int | np.random.SeedSequence | list[np.random.SeedSequence] | None
_ONE = np.array(1.0)


def generators(seed: Seed, num_envs: int
               ) -> tuple[list[np.random.Generator] | None, np.random.Generator]:
    """``(rngs, rng)``: for a list of ``num_envs`` seeds a generator per environment (and an
    unseeded shared one), else None and one shared generator from ``seed``."""
    rngs = None
    if isinstance(seed, list):
        if len(seed) != num_envs:
            raise ValueError(f"seed must list {num_envs} seeds, got {len(seed)}")
        rngs = [np.random.default_rng(s) for s in seed]
    return rngs, np.random.default_rng(None if isinstance(seed, list) else seed)


@dataclass(frozen=True)
class NetworkState:
    """The network after a reset or step; leading axis B, then users N where it applies.

    ``uav_m`` every UAV's position, m ((B, 3) for one UAV, (B, U, 3) for several); per user
    (B, N): ``alpha`` its power share, ``gain`` the linear gain of one antenna pair from its
    serving UAV (with the step's fading where the channel draws it), ``interference_w`` the
    other UAVs' power it hears (W; 0 for one UAV), ``los`` and ``p_los`` of its serving link
    (for ``los = "expected"``: P_LoS > 0.5), ``strong`` whether it is its cluster's strong
    user, ``rate_bps``; per environment the sum rate, Jain's index over all users and the
    reward (eq. 13); ``energy_j`` (B,) or (B, U) each UAV's energy of the step
    (docs/model.md §10; hovering after a reset or for a held configuration).
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

    @classmethod
    def _new(cls, *values: np.ndarray) -> NetworkState:
        """The state of these fields in order, made without the frozen dataclass's
        ``__init__`` (which sets each field through ``object.__setattr__``): once per step."""
        state = object.__new__(cls)
        state.__dict__.update(zip(_STATE_FIELDS, values, strict=True))
        return state

    def for_env(self, index: int) -> dict[str, np.ndarray | float]:
        """The state of environment ``index`` as a Gymnasium ``info`` dict (with the
        interference only for several UAVs)."""
        names = ("uav_m", "alpha", "gain", "interference_w", "los", "p_los", "rate_bps")
        if self.uav_m.ndim == 2:
            names = tuple(name for name in names if name != "interference_w")
        info: dict[str, np.ndarray | float] = {name: getattr(self, name)[index].copy()
                                               for name in names}
        info["sum_rate_bps"] = float(self.sum_rate_bps[index])
        info["fairness"] = float(self.fairness[index])
        energy = self.energy_j[index]
        info["energy_j"] = float(energy) if np.ndim(energy) == 0 else energy.copy()
        return info


_STATE_FIELDS = tuple(NetworkState.__dataclass_fields__)


class NetworkBatch:
    """B independent copies of the network of a scenario's U UAVs, vectorised with numpy.

    Arguments: ``scenario`` (validated), ``num_envs`` B, ``seed`` of the generator that draws
    LoS states, fading and user moves (or a list of B seeds: every environment then draws from
    a generator of its own, so its numbers do not depend on B or on its neighbours),
    ``users_m`` (B, N, 2) to override the scenario's layouts, ``weights`` per environment
    (eq. 13), ``view`` what the agent observes of the network (its adapter,
    :class:`~adaptsky.sim.observation.ObservationView`: the users' order, every UAV's local
    part, scaled or raw values; None: the network's observation, scaled, users as listed).
    The simulator reads no agent setting.

    The state between steps is ``sim_state`` (:class:`~adaptsky.sim.state.SimState`); the
    network there is ``state`` (:class:`NetworkState`). The association (serving UAV and NOMA
    cluster of every user) is made once per layout, at construction and by
    :meth:`set_layouts`: one group for one UAV, else balanced k-means from the UAVs' start
    positions or ``users.uav``; pairs inside each group as ``users.pairing`` says, by the
    gains from the serving UAV's start position. Index arrays of the association, made once
    per layout, put a step's arrays in user order with one ``take`` each.
    """

    def __init__(self, scenario: Scenario, num_envs: int = 1, seed: Seed = None,
                 users_m: FloatArray | None = None,
                 weights: list[noma.RewardWeights] | None = None,
                 view: ObservationView | None = None) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.scenario = scenario
        self.num_envs = num_envs
        self.num_users = scenario.num_users
        self.num_uavs = scenario.uav.count
        self.num_clusters = scenario.clusters_per_uav
        self.cluster_size = scenario.cluster_size            # M (2: the paper's pairs)
        self.num_shares = scenario.shares_per_uav            # K (M - 1) share components
        self.channel = build_channel(scenario)
        self._dynamics = Dynamics.of(scenario, num_envs)
        self.actions = self._dynamics.actions        # the dense set (None: continuous)
        self.controls = self._dynamics.controls      # the action kind's adapter
        if weights is not None and len(weights) != num_envs:
            raise ValueError(f"weights must have {num_envs} entries, got {len(weights)}")
        self.weights = reward_weights(scenario) if weights is None else stack_weights(weights)
        radio = scenario.radio
        if radio.reuse not in ("full", "orthogonal"):
            raise ValueError(f"unknown reuse {radio.reuse!r}; use full or orthogonal")
        self.bandwidth_hz = radio.bandwidth_hz
        self._uplink = scenario.uplink
        # P_T G, the uplink's P_u G (docs/model.md §17)
        self._power_w = scenario.sender_power_w * radio.antenna_gain
        self._noise_w = radio.noise_w
        self._sic_residual = radio.sic_residual
        self._full_reuse = radio.reuse == "full" and self.num_uavs > 1
        self._los_mode = scenario.channel.los
        self._max_steps = scenario.train.steps
        self._speed_m = walk_step_m(scenario)          # the random walk's step, m
        self._reassociate_steps = scenario.reassociate_steps   # None: once per episode
        # users that move by a model with a state (docs/model.md §3): None for the others
        self._mobility = (MobilityStage(scenario.users.mobility, num_envs, self.num_users,
                                        scenario.area.side_m / 2, scenario.uav.step_s)
                          if scenario.users.mobility.model in MOBILITY_MODELS else None)
        self._min_separation_m = scenario.uav.min_separation_m
        self.start_m = np.array(scenario.uav_start_positions_m, dtype=np.float64)  # (U, 3)
        self._carrier_hz = carrier_hz(scenario)
        self._user_height_m = scenario.users.height_m
        # every link's user antenna height (B*U, N), made once
        self._link_user_height_m = np.full((num_envs * self.num_uavs, self.num_users),
                                           scenario.users.height_m)
        self._link_user_height_m.flags.writeable = False
        self._users_above_ground = bool(scenario.users.height_m)
        self._fading = fading_active(self.channel)
        # the built-in fading (docs/model.md §11): None for fading.model = "none"
        self._small_scale = (None if scenario.channel.fading.model == "none" else
                             FadingStage(scenario.channel.fading, num_envs, self.num_uavs,
                                         self.num_users, self._max_steps))
        # imperfect channel knowledge (docs/model.md §16): None for csi.model = "perfect"
        self._csi = (None if scenario.channel.csi.model == "perfect"
                     else CsiStage(scenario.channel.csi))
        self._estimate: tuple[FloatArray, FloatArray | None] | None = None
        self._reward = RewardFromSums(self.weights, self.num_users, self.bandwidth_hz)
        self._num_users = np.array(float(self.num_users))
        self._bandwidth = np.array(self.bandwidth_hz)
        self._paper_observation = self.num_uavs == 1
        scaled = view is None or view.scaled
        if self._paper_observation:
            self._observer: Observer | MultiObserver = Observer(
                scenario, (num_envs, self.num_users), scaled)
        else:
            self._observer = MultiObserver(scenario, scaled)
        self._view = view
        self._observes_world = view is not None and view.observes_world
        self.world_data: WorldData | None = None   # the last state's, where the view asks
        self._moved_m = np.zeros((num_envs, self.num_users, 2))
        if users_m is None:
            users_m = user_layouts(scenario, num_envs)
        self._associate(users_m)
        self._seed(seed)
        self._to_start()
        self.state: NetworkState | None = None

    # ---- stage 5: association and clusters, once per layout ---------------------------------

    def _associate(self, users_m: FloatArray) -> None:
        """Serving UAVs and NOMA clusters of the layouts ``users_m`` (B, N, 2)."""
        expected = (self.num_envs, self.num_users, 2)
        if users_m.shape != expected:
            raise ValueError(f"users_m must have shape {expected}, got {users_m.shape}")
        self.layouts_m = np.array(users_m, dtype=np.float64)
        scenario = self.scenario
        self.city: City | None = city_of(scenario, self.layouts_m)
        self._blockage = (None if self.city is None
                          else Blockage(self.city, scenario.users.height_m))
        self._pair(self.layouts_m)

    def _pair(self, users_m: FloatArray) -> None:
        """Serving UAVs and NOMA clusters of the users at ``users_m`` (B, N, 2): a balanced
        k-means from the UAVs' starts (or the listed UAVs), pairs near-far by the gains at
        the starts (docs/model.md §9); at the start of every episode on the layouts, and every
        ``users.reassociate_every_s`` on the users' positions then (§3)."""
        scenario = self.scenario
        expected = (self.num_envs, self.num_users, 2)
        serving = (np.zeros(expected[:2], dtype=np.intp) if self.num_uavs == 1 else
                   serving_groups(users_m, self.start_m, scenario.users.association,
                                  scenario.users.uav))
        starts = np.broadcast_to(self.start_m, (self.num_envs, *self.start_m.shape))
        start_gain = deterministic_gain(self.channel, self._los_mode,
                                        self.geometry(starts, users_m))
        start_gain = start_gain.reshape(self.num_envs, self.num_uavs, self.num_users)
        self.association: Association = associate(
            serving, serving_gain(start_gain, serving), scenario.users.pairing, self.num_uavs,
            self.cluster_size)
        energy_shape = (self.num_envs,) if self.num_uavs == 1 else (self.num_envs,
                                                                     self.num_uavs)
        self._energy = EnergyAccount(scenario, self.weights, energy_shape,
                                     None if self.num_uavs == 1
                                     else self.association.clusters_per_uav)
        self._index()

    def _index(self) -> None:
        """Flat index arrays of the association (docs/model.md §9), each (B, N):

        ``_serving_link`` the position of user i's serving link in the links (B, U, N);
        ``_partner_flat`` its cluster partner's in a (B, N) array; ``_alpha_source`` its
        alpha_k's in the configuration (B, U, 3 + K); ``_is_first`` whether it is its
        cluster's first user; ``_interferer`` (B, U, N) whether UAV u' interferes with it;
        and, for the observation, ``_serving_xy`` (2, B, N) the positions of its serving
        UAV's x and y in the configuration, and ``_view_flat`` where the agent's view
        (``view``) takes its components from the network's observation
        (:func:`~adaptsky.sim.observation.flat_gather`; None: all of it, as it is), and
        ``_world_reader`` what adds the view's observations of the world (None: none).
        """
        association = self.association
        num_envs, n, num_uavs = self.num_envs, self.num_users, self.num_uavs
        width = self._dynamics.config_low.shape[-1]     # 3 + K
        rows = np.arange(num_envs)[:, None]
        serving = association.serving_uav
        self._serving_link = rows * (num_uavs * n) + serving * n + np.arange(n)
        uav_base = rows * (num_uavs * width) + serving * width
        self._serving_xy = np.stack([uav_base, uav_base + 1])
        # every link's UAV x, y and h in the configuration (3, B*U, N)
        link_base = (np.arange(num_envs * num_uavs) * width)[:, None] + np.zeros(n, np.intp)
        self._link_source = np.stack([link_base, link_base + 1, link_base + 2])
        self._interferer = interferers(association)
        self._chain = (None if not self.scenario.sic_chains else
                       Chain.of(association, width, self.scenario.shares_per_cluster))
        if self._chain is None:
            self._index_pairs(uav_base)
        # the uplink's interference: whether user j sends on user i's block to another UAV
        self._cross = None
        if self._uplink and self._full_reuse:
            self._cross = ((association.cluster[:, :, None] == association.cluster[:, None, :])
                           & (serving[:, :, None] != serving[:, None, :]))
        gather = None if self._view is None else self._view.gather(association)
        self._world_reader = (self._view.world_reader(association)
                              if self._view is not None and self._observes_world else None)
        self._view_flat = (None if gather is None
                           else flat_gather(gather, observation_size(n, num_uavs)))
        self._repeated_of: FloatArray | None = None    # see _repeated_users
        self._repeated: tuple[FloatArray, FloatArray] | None = None
        self._no_interference = np.zeros((num_envs, n))
        self._no_interference.flags.writeable = False

    def _index_pairs(self, uav_base: NDArray[np.intp]) -> None:
        """The index arrays of clusters of two (:meth:`_index`)."""
        association, n = self.association, self.num_users
        rows = np.arange(self.num_envs)[:, None]
        self._partner_flat = rows * n + association.partner
        self._alpha_source = uav_base + 3 + association.cluster
        self._is_first = association.is_first
        # every user's share and its partner's, alpha_k and 1 - alpha_k in one step:
        # offset + sign alpha_k, with (offset, sign) = (0, 1) for a first user, (1, -1) else
        sign = np.where(self._is_first, 1.0, -1.0)
        offset = np.where(self._is_first, 0.0, 1.0)
        self._share_sign = np.stack([sign, -sign])
        self._share_offset = np.stack([offset, 1.0 - offset])
        self._share_source = np.stack([self._alpha_source, self._alpha_source])

    def set_layouts(self, users_m: FloatArray) -> None:
        """New home positions of the users (B, N, 2), associated anew; they take effect at the
        next :meth:`reset` (``users.placement = "fresh"``: a layout per training episode)."""
        self._associate(users_m)

    def roles(self) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Every user's serving UAV and its cluster k among that UAV's clusters, (B, N)
        each."""
        return self.association.serving_uav, self.association.cluster

    @property
    def estimated_gains(self) -> FloatArray | None:
        """The latest step's estimate g_hat of every link (B, U, N) under imperfect channel
        knowledge (docs/model.md §16: what the agent observed last), else None."""
        return None if self._csi is None else self._gains_hat

    @property
    def first_user(self) -> NDArray[np.intp]:
        """The first user of every cluster: (B, K) for one UAV, (B, U, K_max) for several."""
        return self._squeezed(self.association.first_user)

    @property
    def second_user(self) -> NDArray[np.intp]:
        """The second user of every cluster, shaped as :attr:`first_user`."""
        return self._squeezed(self.association.second_user)

    # ---- generators ------------------------------------------------------------------------

    def _seed(self, seed: Seed) -> None:
        """New generators: one per environment for a list of B seeds, else one shared."""
        self.rngs, self.rng = generators(seed, self.num_envs)

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

    # ---- geometry --------------------------------------------------------------------------

    def geometry(self, uav_m: FloatArray, users_m: FloatArray, layout: int | None = None
                 ) -> LinkGeometry:
        """The links from UAVs ``uav_m`` to the users ``users_m`` (B', N, 2) of their
        environment: (B'*U, N) for ``uav_m`` (B', U, 3), (B', N) for one UAV per row
        ``uav_m`` (B', 3) (:func:`~adaptsky.sim.links.links_geometry`). With buildings, the
        links' LoS states by the city of environment b for row b, or, with ``layout``, by the
        city of that environment for every row (docs/model.md §12)."""
        uav_m = np.asarray(uav_m, dtype=np.float64)
        if uav_m.ndim == 2:
            uav_m = uav_m[:, None]
        geometry = links_geometry(uav_m, users_m, user_height_m=self._user_height_m,
                                  carrier_hz=self._carrier_hz, bandwidth_hz=self.bandwidth_hz)
        if self._blockage is None:
            return geometry
        if layout is None:
            los = self._blockage.los(uav_m, np.asarray(users_m, dtype=np.float64))
        else:
            assert self.city is not None
            blockage = Blockage(self.city.environment(layout), self._user_height_m)
            los = blockage.los(uav_m.reshape(1, -1, 3),
                               np.asarray(users_m, dtype=np.float64)[:1])
        return geometry.with_los(los.reshape(geometry.shape))

    def gain_bounds(self) -> tuple[float, float] | None:
        """The smallest and largest gain of a link, linear (``gain_bounds.gain_range``: the
        observation's bounds, docs/environment.md); None where the channel draws fading,
        whose factors have no bound (a plugin's or the built-in, docs/model.md §11). Every
        link is one UAV's link to one user in the area, so the bounds of one UAV's links
        hold."""
        if self._fading or self._small_scale is not None:
            return None
        scenario = self.scenario
        return gain_range(self.channel, scenario.channel.los,
                          functools.partial(scenario_geometry, scenario),
                          reachable_heights(scenario.uav), scenario.area.side_m)

    # ---- state -----------------------------------------------------------------------------

    @property
    def max_steps(self) -> int:
        """T, the time limit of an episode (``train.steps``)."""
        return self._max_steps

    @property
    def t(self) -> int:
        """Steps since the episode started."""
        return self.sim_state.t

    def _squeezed(self, values: np.ndarray) -> np.ndarray:
        """``values`` (B, U, ...) without the UAV axis for one UAV (a view)."""
        return values[:, 0] if self.num_uavs == 1 else values

    @property
    def uav_m(self) -> FloatArray:
        """UAV positions, m: (B, 3) for one UAV, (B, U, 3) for several (a view)."""
        return self._squeezed(self.sim_state.uav_m)

    @property
    def alpha_first(self) -> FloatArray:
        """First users' shares: (B, K) for one UAV, (B, U, K) for several (a view)."""
        return self._squeezed(self.sim_state.alpha_first)

    @property
    def users_m(self) -> FloatArray:
        """User positions (B, N, 2), m (``sim_state.users_m``)."""
        return self.sim_state.users_m

    def _per_uav(self, values: FloatArray, width: int) -> FloatArray:
        """``values`` broadcast to (B, U, width): given (..., width) with or, for one UAV,
        without the UAV axis."""
        values = np.asarray(values, dtype=np.float64)
        if self.num_uavs == 1 and values.ndim == 2:
            values = values[:, None]
        return np.broadcast_to(values, (self.num_envs, self.num_uavs, width))

    def _to_start(self, alpha_first: FloatArray | None = None,
                  uav_m: FloatArray | None = None) -> None:
        """Step 0: every UAV at its start (or ``uav_m``, (B, U, 3)), every first user's share
        at ``start_alpha`` (or ``alpha_first``), users at home."""
        alpha = (np.full((self.num_envs, self.num_uavs, self.num_shares),
                         self.scenario.uav.start_alpha) if alpha_first is None
                 else self._per_uav(alpha_first, self.num_shares))
        starts = np.broadcast_to(self.start_m if uav_m is None else uav_m,
                                 (self.num_envs, *self.start_m.shape))
        self.sim_state = SimState.of(starts, alpha, self.layouts_m)

    def reset(self, seed: Seed = None, alpha_first: FloatArray | None = None,
              uav_m: FloatArray | None = None) -> tuple[NDArray[np.float32], NetworkState]:
        """Start an episode: every UAV at its start position (``uav.start_m`` for one), or at
        ``uav_m`` (B, U, 3) where given, every first user's share at ``start_alpha`` (docs/
        model.md §3), or ``alpha_first`` where given (exploring starts, docs/training.md); a
        ``seed`` re-seeds the generators of LoS draws, fading and user moves."""
        if seed is not None:
            self._seed(seed)
        if self._small_scale is not None:
            self._small_scale.reset()
        if self._mobility is not None:
            self._mobility.reset(self._generators)
        if self._reassociate_steps is not None:
            self._pair(self.layouts_m)               # the start's association again
        self._to_start(alpha_first, uav_m)
        if self._observes_world:
            self._moved_m = np.zeros((self.num_envs, self.num_users, 2))
        self.state = self._evaluate(self.sim_state)
        return self._obs, self.state

    def step(self, actions: NDArray[np.integer]
             ) -> tuple[NDArray[np.float32], FloatArray, bool, NetworkState]:
        """Apply B actions (dense indices (B,) over all UAVs' components or continuous
        points (B, D), as :attr:`controls` takes them, docs/model.md §3);
        return observations, rewards (eq. 13), truncated, and the state.

        Stages 1-2 (:func:`adaptsky.sim.state.step`, then the separation: position moves
        that would bring two UAVs closer than ``uav.min_separation_m`` are held back), then
        stages 3-8 at the new state (:meth:`_evaluate`): the reward and next observation use
        the channel at the position after the move (the released code's one-step lag is not
        copied, docs/model.md §7).
        """
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        dynamics = self._dynamics
        actions = dynamics.checked(actions)    # before anything is drawn
        before = self.sim_state
        moved = step(before, actions, dynamics, self._headings() if self._speed_m else None)
        if self._mobility is not None:
            moved = SimState._new(moved.config, self._moved_users(before.users_m), moved.t)
        state = self._settled(before, moved, flown=True)
        return self._obs, state.reward, self.sim_state.t >= self._max_steps, state

    # ---- the one evaluation of the network -------------------------------------------------

    def evaluate(self, uav_m: FloatArray, alpha_first: FloatArray,
                 users_m: FloatArray | None = None, *, t: int | None = None,
                 flown: bool = False, draws: Generators | None = None) -> NetworkState:
        """The network (stages 3-8) with the UAVs at ``uav_m`` and first users' shares
        ``alpha_first`` (shaped as :attr:`uav_m` and :attr:`alpha_first`, or broadcast to
        them), the users at ``users_m`` (B, N, 2; None: where they are; :meth:`next_users`
        gives them one step on) at step ``t`` (None: this step), LoS and fading drawn from
        ``draws`` (a generator per environment or one shared; None: the network's own, as a
        step draws them). ``flown``: the configuration is reached by flying from the present
        one, under the controls stage's rules (a move that breaks the separation or ends in
        a building does not happen, nor a user's step onto a footprint), with the energy of
        the move (docs/model.md §10); else it is held as given, with a hovering step's
        energy. At a new step the association runs again where ``users.reassociate_every_s``
        says (§3). The result is the network's state from then on.

        Every baseline, reference and the training step evaluate the network here: a
        configuration as given (:meth:`evaluate_at`), held while the users move
        (:meth:`hold_step`), or flown to (:meth:`fly_step`, and :meth:`step` from an
        action)."""
        before = self.sim_state
        moved = SimState.of(self._per_uav(uav_m, 3), self._per_uav(alpha_first,
                                                                   self.num_shares),
                            before.users_m if users_m is None else users_m,
                            before.t if t is None else t)
        return self._settled(before, moved, flown=flown, draws=draws)

    def next_users(self) -> FloatArray:
        """The users' positions (B, N, 2) one step on: the same draws in the same order as
        :meth:`step` (headings or the mobility stage's numbers), the footprints of buildings
        kept; their present positions where they stand."""
        return self._users_of_step(self.sim_state.users_m)

    def evaluate_at(self, uav_m: FloatArray, alpha_first: FloatArray) -> NetworkState:
        """:meth:`evaluate` of a configuration as given (no clipping); LoS drawn as in a
        step; the users stay where they are."""
        return self.evaluate(uav_m, alpha_first)

    def hold_step(self, uav_m: FloatArray, alpha_first: FloatArray) -> NetworkState:
        """One step of a held configuration (:meth:`evaluate`): the users move as in
        :meth:`step` (the same draws in the same order: headings, then LoS), the UAVs are at
        ``uav_m`` with shares ``alpha_first``, as given; a hovering step's energy. Baselines
        hold a configuration so while the users walk (docs/evaluation.md)."""
        return self.evaluate(uav_m, alpha_first, self.next_users(), t=self.t + 1)

    def fly_step(self, uav_m: FloatArray, alpha_first: FloatArray) -> NetworkState:
        """One step to a configuration reached by flying (:meth:`evaluate`; a heuristic
        baseline's: tracking, docs/evaluation.md): the users move as in :meth:`hold_step`,
        the UAVs go to ``uav_m`` with shares ``alpha_first`` under the controls stage's
        rules, with the energy of the move."""
        return self.evaluate(uav_m, alpha_first, self.next_users(), t=self.t + 1,
                             flown=True)

    def _settled(self, before: SimState, moved: SimState, *, flown: bool,
                 draws: Generators | None = None) -> NetworkState:
        """The network at ``moved`` after ``before``: flown, the controls stage's rules
        (separation, buildings) and the energy of the move, else a hovering step's; the
        association where it runs again at a new step; then stages 3-8."""
        if flown and (self.num_uavs > 1 or self.city is not None):
            moved = self._kept_apart(before, moved)
        self.sim_state = moved
        if moved.t != before.t:
            self._reassociated(moved)
            if self._observes_world:     # the users' move over the step, for the view's
                self._moved_m = np.asarray(moved.users_m) - np.asarray(before.users_m)
        energy_j = (self._energy.of_move(self._squeezed(before.uav_m),
                                         self._squeezed(moved.uav_m)) if flown else None)
        self.state = self._evaluate(moved, energy_j, draws)
        return self.state

    def _reassociated(self, state: SimState) -> None:
        """Every ``users.reassociate_every_s``: the association and pairing run again on the
        users' positions of ``state`` (docs/model.md §3), before the step's channel."""
        every = self._reassociate_steps
        if every is not None and state.t % every == 0:
            self._pair(np.array(state.users_m, dtype=np.float64))

    def _kept_apart(self, before: SimState, moved: SimState) -> SimState:
        """The controls stage's rules of the UAVs' positions: moves that break the separation
        held back (several UAVs), then moves into a building, and the users' steps onto a
        footprint (docs/model.md §9 and §12)."""
        moved_m = positions = moved.config[..., :3]
        if self.num_uavs > 1:
            positions = separated(before.uav_m, moved_m, self._min_separation_m)
        users_m = moved.users_m
        if self.city is not None:
            positions = kept_out(before.uav_m, positions, self.city)
            if users_m is not before.users_m:
                users_m = users_kept_out(before.users_m, users_m, self.city.footprints_m)
        if positions is moved_m and users_m is moved.users_m:
            return moved
        config = (moved.config if positions is moved_m
                  else np.concatenate([positions, moved.config[..., 3:]], axis=-1))
        return SimState._new(config, users_m, moved.t)

    def _users_of_step(self, users_m: FloatArray) -> FloatArray:
        """The users' positions after a step's move from ``users_m`` (the same draws in the
        same order as :meth:`step`: headings or the mobility stage's numbers first)."""
        if self._speed_m:
            walked = self._dynamics.walked(users_m, self._headings())
            if self.city is not None:
                walked = users_kept_out(users_m, walked, self.city.footprints_m)
            return walked
        if self._mobility is not None:
            return self._moved_users(users_m)
        return users_m

    @property
    def _generators(self) -> Generators:
        return self.rngs if self.rngs is not None else self.rng

    def _moved_users(self, users_m: FloatArray) -> FloatArray:
        """The users' positions (B, N, 2) one step of the mobility stage after ``users_m``,
        a step onto a footprint undone (and told to the stage), laid out as a step computes
        with them (docs/model.md §3 and §12)."""
        assert self._mobility is not None
        moved = self._mobility.moved(users_m, self._generators)
        if self.city is not None:
            blocked = on_footprints(moved, self.city.footprints_m)
            if blocked.any():
                moved = np.where(blocked[..., None], users_m, moved)
                self._mobility.blocked(blocked)
        return user_positions(moved)

    # ---- the built-in fading's draws -------------------------------------------------------

    def next_scattered(self, steps: int) -> FloatArray:
        """The scattered parts s (steps, 2, B, U, N), real and imaginary, of the built-in
        fading (docs/model.md §11) of the next ``steps`` steps, drawn here as those steps
        would draw them (the fading moves on by ``steps``). They are a held configuration's
        draws wherever a step draws nothing else: LoS not sampled, no plugin fading, users
        that stand."""
        if self._small_scale is None:
            raise ValueError("the scenario has no built-in fading (channel.fading.model)")
        shape = (2, self.num_envs, self.num_uavs, self.num_users)
        return np.stack([np.array(self._small_scale.scattered(self._generators),
                                  dtype=np.float64).reshape(shape) for _ in range(steps)])

    def step_scattered(self) -> FloatArray:
        """The scattered parts s (2, B, U, N), real and imaginary, of the built-in fading at
        the latest step (a copy): what a held configuration's step drew (the per-step
        oracle under fading, :mod:`adaptsky.rollouts.fading_genie`)."""
        if self._small_scale is None or self._small_scale.last is None:
            raise ValueError("no step has drawn the built-in fading (channel.fading.model)")
        return np.array(self._small_scale.last, dtype=np.float64).reshape(
            2, self.num_envs, self.num_uavs, self.num_users)

    # ---- stages 3-8: the network at a state --------------------------------------------------

    def _repeated_users(self, users_m: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``users_m`` (B, N, 2) repeated for every UAV (B*U, N, 2), the users of the links'
        geometry, and their x and y (2, B*U, N): kept until the users move (made once per
        move, not once per step)."""
        if users_m is not self._repeated_of:
            repeated = users_m if self.num_uavs == 1 else np.repeat(users_m, self.num_uavs,
                                                                    axis=0)
            self._repeated_of, self._repeated = users_m, (repeated, users_xy(repeated))
        assert self._repeated is not None
        return self._repeated

    def _evaluate(self, state: SimState, energy_j: FloatArray | None = None,
                  draws: Generators | None = None) -> NetworkState:
        """Stages 3-8 at ``state`` after a step of energy ``energy_j`` (None: hovering), LoS
        and fading drawn from ``draws`` (None: the network's generators): geometry, channel,
        interference, SIC order, SINR and rates (eqs. 2-3, docs/model.md §9), eq. 9 over all
        users and eq. 13 (with its energy term where ``reward.w_energy`` is set); also sets
        ``_obs``."""
        config, users_m = state.config, state.users_m
        uav_m = config[..., :3]
        # stage 3: every link's UAV x, y, h (3, B*U, N) in one take; the offsets
        # x_UAV - x_i, y_UAV - y_i go straight into the paper's observation features
        link_uav_m = config.take(self._link_source)
        repeated_m, repeated_xy = self._repeated_users(users_m)
        features = (np.empty((FEATURES_PER_USER, *link_uav_m.shape[1:]))
                    if self._paper_observation else None)
        offsets_m = np.subtract(link_uav_m[:2], repeated_xy,
                                out=None if features is None else features[:2])
        geometry = offsets_geometry(offsets_m, link_uav_m[2], self._link_user_height_m,
                                    uav_m.reshape(-1, 3), repeated_m,
                                    carrier_hz=self._carrier_hz,
                                    bandwidth_hz=self.bandwidth_hz,
                                    users_above_ground=self._users_above_ground)
        if self._blockage is not None:
            geometry = geometry.with_los(self._blockage.los(uav_m, users_m).reshape(
                geometry.shape))
        if draws is None:
            draws = self.rngs if self.rngs is not None else self.rng
        gains, los, p_los, large_scale = link_gains_and_means(
            self.channel, self._los_mode, geometry, draws, num_uavs=self.num_uavs,
            fading=self._fading, small_scale=self._small_scale)
        if self.num_uavs == 1:    # the only link of every user is its serving link
            gain, link_los, link_p_los = gains[:, 0], los[:, 0], p_los[:, 0]
        else:
            serving_link = self._serving_link
            gain = gains.take(serving_link)
            link_los, link_p_los = los.take(serving_link), p_los.take(serving_link)
        if self._uplink:
            rate_bps, strong, alpha, interference = self._uplink_rates(gains, gain, config,
                                                                       features)
            seen_gain, seen_interference = gain, interference
        else:
            # I_i: the gains of every interfering link (B, U, N), kept for rates_without
            if self._full_reuse:
                self._interfering = gains
                interference = interference_sum_w(gains, self._interferer, self._power_w)
            else:
                self._interfering = None
                interference = self._no_interference
            seen_gain, seen_interference = gain, interference     # what the agent observes
            if self._csi is not None:
                seen_gain, seen_interference = self._estimated(gains, large_scale, draws)
            rate_bps, strong, alpha = self._noma_rates(
                gain, interference if self._full_reuse else None, config,
                None if features is None else features[2:4])
        rewards, total, fairness = self._rewarded(rate_bps, gain)
        if energy_j is None:
            energy_j = self._energy.hover_j
        if self._energy.weighted:
            rewards = self._energy.rewarded(rewards, energy_j)
        self._obs = self._observe(config, users_m, alpha, seen_gain, seen_interference,
                                  features)
        if self._observes_world:
            self._obs = self._with_world(uav_m, link_los, link_p_los)
        return NetworkState._new(self._squeezed(uav_m).copy(), alpha, gain, interference,
                                 link_los, link_p_los, strong, rate_bps, total, fairness,
                                 rewards, energy_j)

    def _uplink_rates(self, gains: FloatArray, gain: FloatArray, config: FloatArray,
                      features: FloatArray | None
                      ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray, FloatArray]:
        """Stage 6 of the uplink (docs/model.md §17): every user's rate by its UAV's SIC
        chain, whether its UAV decodes it first, its transmit share (also the observation's
        power feature, into ``features[2]`` where given) and the other UAVs' users' power its
        UAV hears on its block (W), each (B, N)."""
        assert self._chain is not None
        rate_bps, strong, alpha, interference = self._chain.uplink_rates(
            gains, gain, config, self._cross, self.association.serving_uav,
            power_w=self._power_w, noise_w=self._noise_w, bandwidth_hz=self._bandwidth,
            sic_residual=self._sic_residual)
        self._interfering = None
        if features is not None:
            features[2] = alpha
        return (rate_bps, strong, alpha,
                self._no_interference if interference is None else interference)

    def _estimated(self, gains: FloatArray, large_scale: FloatArray, draws: Generators
                   ) -> tuple[FloatArray, FloatArray]:
        """Stage 4b (docs/model.md §16): the step's estimates of every link (drawn after its
        fading), as the agent sees them: each user's serving gain g_hat and interference
        (from the estimated gains of the interfering links), each (B, N); kept for the SIC
        order where ``csi.order_on = "estimate"``."""
        assert self._csi is not None
        gains_hat = self._csi.estimate(gains, large_scale, draws)
        gain_hat = (gains_hat[:, 0] if self.num_uavs == 1
                    else gains_hat.take(self._serving_link))
        interference_hat = (interference_sum_w(gains_hat, self._interferer, self._power_w)
                            if self._full_reuse else self._no_interference)
        self._estimate = ((gain_hat, interference_hat if self._full_reuse else None)
                          if self._csi.order_on_estimate else None)
        self._gains_hat = gains_hat
        return gain_hat, interference_hat

    def _noma_rates(self, gain: FloatArray, interference: FloatArray | None,
                    config: FloatArray, out: FloatArray | None = None,
                    estimate: tuple[FloatArray, FloatArray | None] | None = None
                    ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
        """Stage 6: every user's rate (B, N), whether it is its cluster's strong user, and
        its share, from its serving gain, the interference it hears (W; None: none) and the
        UAVs' configuration: SIC by the effective gain c_i = g_i / (I_i + sigma^2)
        (:func:`~adaptsky.sim.interference.sic_rates`), or by the estimated one where the
        channel knowledge is imperfect and the order follows the estimate (docs/model.md
        §16; ``estimate``: other estimates than the step's). Every user's share and its
        partner's are written into ``out`` (2, B, N) where given."""
        estimate = self._estimate if estimate is None else estimate
        if self._chain is not None:
            return self._chain.rates(gain, interference, config, out, power_w=self._power_w,
                                     noise_w=self._noise_w, bandwidth_hz=self._bandwidth,
                                     sic_residual=self._sic_residual, estimate=estimate)
        partner = self._partner_flat
        shares = np.multiply(self._share_sign, config.take(self._share_source), out=out)
        shares += self._share_offset
        return sic_rates(gain, interference, shares, self._is_first,
                         lambda values: values.take(partner), power_w=self._power_w,
                         noise_w=self._noise_w, bandwidth_hz=self._bandwidth,
                         sic_residual=self._sic_residual, estimate=estimate)

    def _rewarded(self, rate_bps: FloatArray, gain: FloatArray
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Stage 7: eq. 13 (before the energy term), sum R and Jain's index (eq. 9), each
        (B,); the sums over users of R, R^2, R/W (and g where the reward needs it) are one
        reduction."""
        reward = self._reward
        terms = np.empty((4 if reward.needs_gain_sum else 3, *rate_bps.shape))
        terms[0] = rate_bps
        np.square(rate_bps, out=terms[1])
        np.divide(rate_bps, self._bandwidth, out=terms[2])       # spectral efficiency R/W
        if reward.needs_gain_sum:
            terms[3] = gain
        sums = np.add.reduce(terms, axis=2)
        total = sums[0]
        fairness = noma.jain_from_sums(total, sums[1], self._num_users)
        rewards = reward(rate_bps, gain, fairness, sums[2],
                         sums[3] if reward.needs_gain_sum else None)
        return rewards, total, fairness

    def _observe(self, config: FloatArray, users_m: FloatArray, alpha: FloatArray,
                 gain: FloatArray, interference: FloatArray,
                 features: FloatArray | None = None) -> NDArray[np.float32]:
        """Stage 8: the observations (B, size) the agent's view takes, users as listed;
        ``features`` (4, B, N) the paper's features for one UAV, whose first three rows the
        earlier stages filled (offsets and shares)."""
        if features is not None:
            assert isinstance(self._observer, Observer)
            network = self._observer(features, gain, config[:, 0, 2])
        else:
            assert isinstance(self._observer, MultiObserver)
            uav_xy, users = config.take(self._serving_xy), users_xy(users_m)   # (2, B, N)
            network = self._observer.from_offsets(uav_xy[0] - users[0], uav_xy[1] - users[1],
                                                  config[..., :3], alpha, gain, interference)
        return network if self._view_flat is None else gathered(network, *self._view_flat)

    def _with_world(self, uav_m: FloatArray, link_los: NDArray[np.bool_] | None,
                    link_p_los: FloatArray) -> NDArray[np.float32]:
        """The agent's observations with its view's observations of the world appended
        (docs/environment.md, "Observations of the world")."""
        assert self._world_reader is not None
        los = (np.asarray(link_p_los, dtype=np.float64) if link_los is None
               else np.asarray(link_los, dtype=np.float64))
        self.world_data = WorldData(uav_m.reshape(self.num_envs, self.num_uavs, 3),
                                    np.broadcast_to(los, (self.num_envs, self.num_users)),
                                    self._moved_m, self.scenario.uav.step_s, self.city)
        return self._world_reader(self._obs, self.world_data)

    def observation(self) -> NDArray[np.float32]:
        """The observations of the last evaluated state (B, size), float32."""
        assert self.state is not None, "call reset() first"
        return self._obs

    @property
    def hover_energy_j(self) -> FloatArray:
        """Each UAV's energy of a hovering step (B,) or (B, U), J (docs/model.md §10)."""
        return self._energy.hover_j

    # ---- rewards per UAV -------------------------------------------------------------------

    def rates_without(self, uav: int) -> FloatArray:
        """Every user's rate (B, N) in the last evaluated state had UAV ``uav`` sent nothing
        to the other UAVs' users: their interference without its term, SIC re-ordered (its
        own users' rates as they are)."""
        assert self.state is not None, "call reset() first"
        if self._interfering is None:   # one UAV, or orthogonal reuse: no interference
            return self.state.rate_bps
        interferer = self._interferer.copy()
        interferer[:, uav] = False
        estimate = None
        if self._estimate is not None:    # the order by the estimates without its term too
            estimate = (self._estimate[0], interference_sum_w(self._gains_hat, interferer,
                                                              self._power_w))
        return self._noma_rates(self.state.gain, interference_sum_w(
            self._interfering, interferer, self._power_w), self.sim_state.config,
            estimate=estimate)[0]

    def reward_parts(self, state: NetworkState, split: str = "per-uav") -> FloatArray:
        """Eq. 13 of ``state``, the last evaluated one, for each UAV (B, U) (docs/agent.md,
        "A reward per UAV"): ``per-uav``, the part from its own users
        (:func:`adaptsky.sim.reward.reward_per_uav`) and its own energy; ``difference``, that
        part plus what its interference costs the other UAVs' users in eq. 13's rate term,
        w_r sum_{i not of u} (R_i - R_i^{-u}) / W 1[all R_i >= R_min], with R_i^{-u} the rate
        had UAV u sent them nothing (:meth:`rates_without`)."""
        parts = reward_per_uav(state.rate_bps, state.gain, state.fairness, self.bandwidth_hz,
                               self.weights, self.association.serving_uav, self.num_uavs)
        if self._energy.weighted:
            energy_j = state.energy_j if state.energy_j.ndim > 1 else state.energy_j[:, None]
            parts = parts + self._energy.reward_parts(energy_j)
        if split == "difference":
            parts = parts + self._interference_costs(state)
        return parts

    def _interference_costs(self, state: NetworkState) -> FloatArray:
        """w_r sum_{i not of u} (R_i - R_i^{-u}) / W 1[all R_i >= R_min] per UAV (B, U)."""
        weights, serving = self.weights, self.association.serving_uav
        every = (state.rate_bps >= np.asarray(weights.min_rate_bps)[..., None]).all(axis=-1)
        costs = np.empty((self.num_envs, self.num_uavs))
        for uav in range(self.num_uavs):
            lost = np.where(serving == uav, 0.0, state.rate_bps - self.rates_without(uav))
            costs[:, uav] = lost.sum(axis=-1) / self.bandwidth_hz
        return np.asarray(weights.w_rate)[..., None] * costs * every[:, None]
