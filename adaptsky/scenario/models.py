"""Pydantic models of a scenario file (docs/model.md §1-5). Every key is documented in
``docs/scenario-format.md``; defaults are the paper's mmWave training set-up (Table I, sec. V).

Every number has a documented range, physically meaningful and small enough that no step of a
run overflows; what a run needs in memory is checked apart (``training.resources``).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from adaptsky.scenario.agents import (
    AgentConfig,
    DqnAgent,
    check_network_keys,
    check_world_keys,
)
from adaptsky.scenario.ground import MIN_OPEN_SHARE, open_ground_share
from adaptsky.scenario.sections import (  # noqa: F401 (names of the scenario model)
    AREA_MAX_SIDE_M,
    MAX_ANTENNAS,
    MAX_COUNT,
    MAX_DENSE_ACTIONS,
    MAX_GAIN_WEIGHT,
    MAX_HEIGHT_M,
    MAX_INDEX_ACTIONS,
    MAX_MEMORY,
    MAX_REWARD_WEIGHT,
    MAX_SEED,
    MAX_UAVS,
    MIN_HEIGHT_M,
    NAME_MAX_BYTES,
    NAME_MAX_LENGTH,
    PAPER_TRAINING_LAYOUT_M,
    CoordinateM,
    LayerSize,
    Section,
    Seed,
    StepM,
    max_users,
    safe_name,
)


class Area(Section):
    side_m: float = Field(100.0, ge=1.0, le=AREA_MAX_SIDE_M,
                          description="side L of the square area |x|,|y| <= L/2, m")


MOBILITY_KEYS = {
    "static": (),
    "random-walk": ("speed_mps",),
    "random-waypoint": ("speed_min_mps", "speed_max_mps", "pause_max_s"),
    "gauss-markov": ("mean_speed_mps", "memory", "speed_sigma_mps", "heading_sigma_deg"),
}
"""The keys each mobility model reads (docs/model.md §3, users that move)."""
MOBILITY_DEFAULTS = {"pause_max_s": 0.0, "memory": 0.75, "speed_sigma_mps": 0.0,
                     "heading_sigma_deg": 0.0}
"""Defaults of the mobility keys that have one (ours); the speeds have none."""
MAX_USER_SPEED_MPS = 100.0


class Mobility(Section):
    """How the users move (docs/model.md §3): every step of ``uav.step_s`` seconds by their
    speed, reflected at the area's edge (random-waypoint, gauss-markov), out of buildings.
    Keys the model does not read are refused; its own keys left out take their defaults."""

    model: Literal["static", "random-walk", "random-waypoint", "gauss-markov"] = Field(
        "static", description="'static'; 'random-walk', a uniform heading every step at "
        "speed_mps; 'random-waypoint', straight to a uniform destination at a uniform speed, "
        "a uniform pause on arrival; 'gauss-markov', speed and heading with memory")
    speed_mps: float | None = Field(None, gt=0, le=MAX_USER_SPEED_MPS,
                                    description="random-walk speed, m/s")
    speed_min_mps: float | None = Field(None, gt=0, le=MAX_USER_SPEED_MPS,
                                        description="random-waypoint: least speed, m/s")
    speed_max_mps: float | None = Field(None, gt=0, le=MAX_USER_SPEED_MPS,
                                        description="random-waypoint: largest speed, m/s")
    pause_max_s: float | None = Field(None, ge=0, le=3600.0, description="random-waypoint: "
                                      "longest pause on arrival, s (default 0)")
    mean_speed_mps: float | None = Field(None, ge=0, le=MAX_USER_SPEED_MPS,
                                         description="gauss-markov: mean speed, m/s")
    memory: float | None = Field(None, ge=0, le=1, description="gauss-markov: memory a in "
                                 "[0, 1] (0: no memory, 1: straight lines; default 0.75)")
    speed_sigma_mps: float | None = Field(None, ge=0, le=MAX_USER_SPEED_MPS,
                                          description="gauss-markov: the speed's standard "
                                          "deviation, m/s (default 0)")
    heading_sigma_deg: float | None = Field(None, ge=0, le=360.0, description="gauss-markov: "
                                            "the heading's standard deviation, degrees "
                                            "(default 0)")

    @model_validator(mode="after")
    def _keys_of_the_model(self) -> Mobility:
        """Refuse the keys the model does not read and a model without its speed; fill in
        its own keys' defaults."""
        reads = MOBILITY_KEYS[self.model]
        every = {key for keys in MOBILITY_KEYS.values() for key in keys}
        ignored = sorted(key for key in every - set(reads) if getattr(self, key) is not None)
        if ignored:
            raise ValueError(f"{', '.join(ignored)} given with model = '{self.model}', which "
                             f"reads {', '.join(reads) if reads else 'none of them'}; remove "
                             f"{'it' if len(ignored) == 1 else 'them'} or choose another model")
        for key in reads:
            if getattr(self, key) is None:
                if key not in MOBILITY_DEFAULTS:
                    raise ValueError(f"model = '{self.model}' needs {key}")
                setattr(self, key, MOBILITY_DEFAULTS[key])
        if self.model == "random-waypoint" and self.speed_min_mps > self.speed_max_mps:
            raise ValueError(f"speed_min_mps = {self.speed_min_mps:g} exceeds speed_max_mps = "
                             f"{self.speed_max_mps:g}")
        return self


DEFAULT_HOTSPOTS = 3
DEFAULT_SPREAD_M = 10.0
"""placement = "hotspots": the number of centres and the spread of the users, m (ours)."""


DEFAULT_USER_TX_DBM = 23.0
"""The uplink's transmit power of a user when ``users.tx_power_dbm`` is unset: 23 dBm, a
handset's largest (3GPP power class 3)."""
MAX_CLUSTER_SIZE = 8
"""The largest NOMA cluster (``users.cluster_size``): a SIC chain of 8 users (ours)."""


class Users(Section):
    # first: the checks of positions_m and count read it
    cluster_size: int = Field(2, ge=2, le=MAX_CLUSTER_SIZE, description="users M of each NOMA "
                              "cluster, sharing one resource block by SIC (docs/model.md §15); "
                              "2: the paper's pairs")
    positions_m: list[Annotated[list[CoordinateM], Field(min_length=2, max_length=2)]] | None = (
        Field(None, description="explicit user positions [[x, y], ...], m; a multiple of "
              "cluster_size"))
    count: int | None = Field(None, ge=2, description="number of users N_UE = M K (a multiple "
                              "of cluster_size)")
    tx_power_dbm: float | None = Field(
        None, ge=-50.0, le=50.0, description="the uplink's largest transmit power P_u of every "
        "user, dBm (radio.direction = 'uplink' only; default 23, a handset's)")
    placement: Literal["listed", "uniform", "fresh", "hotspots"] | None = Field(
        None, description="'listed' (positions_m), 'uniform' over the area (count, "
        "layout_seed), 'fresh': uniform, drawn anew every training episode from the "
        "seed (evaluation without --layouts uses the layout_seed layout), or 'hotspots': "
        "around hotspot centres (hotspots, spread_m, layout_seed)"
    )
    hotspots: int | None = Field(None, ge=1, le=64, description="placement 'hotspots': the "
                                 "number of centres, uniform over the area (default 3)")
    spread_m: float | None = Field(None, gt=0, le=AREA_MAX_SIDE_M, description="placement "
                                   "'hotspots': the standard deviation of a user's offset "
                                   "from its centre along x and y, m (default 10)")
    layout_seed: int = Field(0, ge=0, le=MAX_SEED, description="seed of the uniform layouts")
    pairing: Literal["listed", "near-far"] | None = Field(
        None, description="NOMA pairs: listed order (1,2),(3,4)... or k-th strongest with "
        "k-th weakest"
    )
    speed_m_per_step: float = Field(0.0, ge=0, le=1000.0,
                                    description="random-walk speed of every user, m/step")
    mobility: Mobility = Field(default_factory=Mobility, description="how the users move "
                               "(docs/model.md §3); static by default")
    reassociate_every_s: float | None = Field(
        None, gt=0, le=1e6, description="re-run the association and the NOMA pairing on the "
        "users' positions every this many seconds, a whole number of uav.step_s (default: "
        "fixed for the episode from the start)")
    height_m: float = Field(0.0, ge=0, le=MAX_HEIGHT_M - MIN_HEIGHT_M,
                            description="antenna height h_UT of every user above the ground, "
                            "m (the paper: 0, users on the ground; needs a contract-2 "
                            "channel model)")
    association: Literal["kmeans", "listed"] | None = Field(
        None, description="which UAV serves each user (docs/model.md §9): 'kmeans', equal "
        "groups of a balanced k-means, or 'listed' (users.uav); default: 'listed' with uav, "
        "else 'kmeans'")
    uav: list[Annotated[int, Field(ge=0, lt=MAX_UAVS)]] | None = Field(
        None, description="serving UAV of every user, 0-based, for association = 'listed'")

    @field_validator("positions_m")
    @classmethod
    def _even_pairs_of_xy(cls, value: list[list[float]] | None, info: ValidationInfo
                          ) -> list[list[float]] | None:
        if value is None:
            return value
        size = info.data.get("cluster_size", 2)
        if size == 2 and (len(value) < 2 or len(value) % 2):
            raise ValueError(f"{len(value)} users given; NOMA pairs need an even count >= 2")
        if len(value) < size or len(value) % size:
            raise ValueError(f"{len(value)} users given; NOMA clusters of cluster_size = {size} "
                             f"users need a multiple of {size}")
        return value

    @field_validator("count")
    @classmethod
    def _even_count(cls, value: int | None, info: ValidationInfo) -> int | None:
        size = info.data.get("cluster_size", 2)
        if value is not None and value % size:
            if size == 2:
                raise ValueError(f"{value} users; NOMA pairs need an even count")
            raise ValueError(f"{value} users; NOMA clusters of cluster_size = {size} users need "
                             f"a multiple of {size}")
        return value

    @model_validator(mode="after")
    def _resolve(self) -> Users:
        if self.positions_m is not None:
            if self.placement in ("uniform", "fresh", "hotspots"):
                raise ValueError(f"positions_m and placement = '{self.placement}' exclude each "
                                 "other")
            if self.count is not None and self.count != len(self.positions_m):
                raise ValueError(f"count = {self.count} but positions_m lists "
                                 f"{len(self.positions_m)} users")
            self.placement = "listed"
            self.count = len(self.positions_m)
        elif self.count is None and self.placement in (None, "listed"):
            # a [users] table without positions or count (only height_m, say): the default
            # users, the paper's training layout
            self.positions_m = [list(p) for p in PAPER_TRAINING_LAYOUT_M]
            self.placement, self.count = "listed", len(self.positions_m)
        else:
            if self.count is None:
                raise ValueError("give positions_m, or count with placement = 'uniform'")
            if self.placement == "listed":
                raise ValueError("placement = 'listed' needs positions_m")
            self.placement = self.placement or "uniform"
        given = [key for key in ("hotspots", "spread_m") if getattr(self, key) is not None]
        if given and self.placement != "hotspots":
            raise ValueError(f"{', '.join(given)} given with placement = '{self.placement}', "
                             "which ignores it; hotspots and spread_m go with placement = "
                             "'hotspots' only")
        if self.placement == "hotspots":
            self.hotspots = DEFAULT_HOTSPOTS if self.hotspots is None else self.hotspots
            self.spread_m = DEFAULT_SPREAD_M if self.spread_m is None else self.spread_m
        if self.speed_m_per_step > 0 and self.mobility.model != "static":
            raise ValueError(f"speed_m_per_step and mobility.model = '{self.mobility.model}' "
                             "exclude each other: speed_m_per_step is the random walk of older "
                             "scenarios; give [users.mobility] alone")
        if self.pairing is None:
            self.pairing = "listed" if self.placement == "listed" else "near-far"
        if self.association is None:
            self.association = "kmeans" if self.uav is None else "listed"
        if (self.association == "listed") != (self.uav is not None):
            raise ValueError(f"association = '{self.association}' and uav: a list of "
                             "serving UAVs goes with association = 'listed', and only with it")
        return self


def _missing_uavs(serving: list[int], count: int) -> str:
    """``users.uav``'s UAVs that ``count`` UAVs do not have, each with its users (1-based, as
    listed): ``UAV 5 serves users 5 and 6``; "" where every UAV exists."""
    named: dict[int, list[int]] = {}
    for user, u in enumerate(serving):
        if u >= count:
            named.setdefault(u, []).append(user + 1)
    parts = [f"UAV {u} serves user{'s' if len(users) > 1 else ''} "
             f"{', '.join(map(str, users[:-1]))}{' and ' if len(users) > 1 else ''}{users[-1]}"
             for u, users in sorted(named.items())]
    return "; ".join(parts) + " (users counted from 1)" if parts else ""


def _default_users() -> Users:
    return Users(positions_m=[list(p) for p in PAPER_TRAINING_LAYOUT_M])


class Uav(Section):
    start_m: list[CoordinateM] = Field([0.0, 0.0, 50.0], min_length=3, max_length=3,
                                       description="position [x, y, h] at the start of every "
                                       "episode, m")
    min_height_m: float = Field(10.0, ge=MIN_HEIGHT_M, le=MAX_HEIGHT_M,
                                description="lowest flying height h_min, m")
    max_height_m: float = Field(200.0, ge=MIN_HEIGHT_M, le=MAX_HEIGHT_M,
                                description="highest flying height h_max, m")
    step_m: list[StepM] = Field([1.0, 1.0, 1.0], min_length=3, max_length=3,
                                description="move per step [delta_x, delta_y, delta_h], m")
    power_step: float = Field(0.01, ge=1e-4, lt=0.5, description="change of alpha per step")
    start_alpha: float = Field(0.5, gt=0, lt=1, description="alpha of every cluster's first "
                               "user at the start of every episode")
    actions: Literal["paper", "with-hover", "continuous"] = Field(
        "paper", description="'paper': each component in {-1,+1}; 'with-hover': in {-1,0,+1}; "
        "'continuous': each in [-1, 1], times its step (docs/model.md §3)")
    power: Literal["change", "absolute"] = Field(
        "change", description="what a cluster's action component does: 'change' its first "
        "user's share by at most power_step; 'absolute' (continuous actions only) set it, "
        "a = -1 .. +1 giving power_step .. 1 - power_step")
    step_s: float = Field(1.0, gt=0, le=3600, description="duration of a step, s: the speed "
                          "of a move and the energy of a step (docs/model.md §10)")
    count: int = Field(1, ge=1, le=MAX_UAVS, description="number of UAVs U (docs/model.md §9)")
    start_positions_m: list[Annotated[list[CoordinateM], Field(min_length=3, max_length=3)]] | (
        None) = Field(None, description="start [x, y, h] of every UAV, m; default: start_m "
                      "for one UAV, else evenly on the circle of radius L/4 at start_m's h")
    min_separation_m: float = Field(10.0, ge=0, le=AREA_MAX_SIDE_M,
                                    description="least horizontal distance between two UAVs, "
                                    "m")

    @model_validator(mode="after")
    def _consistent(self) -> Uav:
        if self.min_height_m >= self.max_height_m:
            raise ValueError(f"min_height_m ({self.min_height_m}) must be below "
                             f"max_height_m ({self.max_height_m})")
        if not self.min_height_m <= self.start_m[2] <= self.max_height_m:
            raise ValueError(f"start_m height {self.start_m[2]} m lies outside "
                             f"[{self.min_height_m}, {self.max_height_m}] m")
        if not self.power_step <= self.start_alpha <= 1 - self.power_step:
            raise ValueError(f"start_alpha {self.start_alpha} lies outside "
                             f"[power_step, 1 - power_step]")
        if self.power == "absolute" and self.actions != "continuous":
            raise ValueError(f"power = 'absolute' needs actions = 'continuous' (it sets each "
                             f"share from a continuous action), not '{self.actions}'; with "
                             f"'paper' or 'with-hover' use power = 'change'")
        starts = self.start_positions_m
        if starts is not None:
            if len(starts) != self.count:
                raise ValueError(f"start_positions_m lists {len(starts)} positions for "
                                 f"count = {self.count} UAVs; give one [x, y, h] per UAV")
            for u, (_, _, h) in enumerate(starts):
                if not self.min_height_m <= h <= self.max_height_m:
                    raise ValueError(f"start_positions_m: UAV {u} at height {h} m lies outside "
                                     f"[{self.min_height_m}, {self.max_height_m}] m")
            if self.count == 1 and starts[0] != self.start_m:
                if "start_m" in self.model_fields_set:
                    raise ValueError(f"start_m {self.start_m} and start_positions_m "
                                     f"{starts[0]} differ; give one of them")
                self.start_m = list(starts[0])
        elif self.count > 1 and self.start_m[:2] != [0.0, 0.0]:
            raise ValueError(f"start_m ({self.start_m[0]:g}, {self.start_m[1]:g}) places one "
                             f"UAV; for count = {self.count} give start_positions_m (start_m "
                             "sets only the height of the default circle)")
        return self


class Radio(Section):
    carrier_hz: float | None = Field(
        None, ge=1e8, le=1e12, description="carrier frequency f_c, Hz, handed to the channel "
        "model; default: the model's carrier_hz parameter where it has one, else 28e9 "
        "(Table I, mmWave)")
    tx_power_dbm: float = Field(20.0, ge=-50.0, le=80.0,
                                description="power P_T of each cluster, dBm (the downlink's: "
                                "in the uplink the users send, users.tx_power_dbm)")
    bandwidth_hz: float = Field(2e9, gt=0, le=1e12, description="bandwidth W of each cluster, Hz")
    thermal_noise_dbm: float = Field(-84.0, ge=-200.0, le=0.0,
                                     description="thermal noise over W, dBm")
    noise_figure_db: float = Field(0.0, ge=0, le=50.0, description="receiver noise figure, dB")
    antennas_uav: int = Field(8, ge=1, le=MAX_ANTENNAS, description="antennas at the UAV, N_UAV")
    antennas_ue: int = Field(8, ge=1, le=MAX_ANTENNAS, description="antennas at each user, N_UE")
    reuse: Literal["full", "orthogonal"] = Field(
        "full", description="spectrum of several UAVs (docs/model.md §9): 'full', cluster k of "
        "every UAV on subchannel k; 'orthogonal', every cluster its own (no interference)")
    sic_residual: float = Field(
        0.0, ge=0.0, le=1.0, description="imperfect SIC (docs/model.md §13): the fraction "
        "epsilon of its partner's signal that a cluster's strong user keeps after cancelling "
        "it, in [0, 1]; 0: perfect SIC (the paper), 1: no cancellation at all")
    direction: Literal["downlink", "uplink"] = Field(
        "downlink", description="'downlink' (the paper: the UAV sends, P_T per cluster split "
        "among its users) or 'uplink' (each user sends at its own power, users.tx_power_dbm; "
        "the UAV decodes each cluster by SIC, docs/model.md §17)")

    @property
    def noise_w(self) -> float:
        """sigma^2 = thermal noise + noise figure, in W (docs/model.md §1)."""
        return 10 ** ((self.thermal_noise_dbm + self.noise_figure_db - 30) / 10)

    @property
    def tx_power_w(self) -> float:
        return 10 ** ((self.tx_power_dbm - 30) / 10)

    @property
    def antenna_gain(self) -> int:
        """G = N_UAV x N_UE (sec. II-A)."""
        return self.antennas_uav * self.antennas_ue


FADING_K_DB = (-40.0, 40.0)
"""The Rician K-factors a scenario may give, dB (1e-4 to 1e4: from Rayleigh-like to a pure LoS
ray)."""
DEFAULT_K0_DB = 0.0
"""K at elevation 0 (ours, docs/model.md §11), dB."""
DEFAULT_K90_DB = 15.0
"""K at elevation 90 degrees (ours, docs/model.md §11), dB."""


class Fading(Section):
    """Small-scale fading built in for every channel model (docs/model.md §11). Keys that only
    one model reads are refused with the others (a setting silently ignored is a bug); the
    model's own keys left out take their defaults (so a resolved scenario lists them)."""

    model: Literal["none", "rayleigh", "rician"] = Field(
        "none", description="'none'; 'rayleigh', |h|^2 ~ Exp(1) on every link; 'rician', K(theta) "
        "of the elevation on LoS links, Rayleigh on NLoS links")
    k0_db: float | None = Field(
        None, ge=FADING_K_DB[0], le=FADING_K_DB[1], description="Rician K-factor at elevation "
        f"0, dB (model 'rician' only; default {DEFAULT_K0_DB:g})")
    k90_db: float | None = Field(
        None, ge=FADING_K_DB[0], le=FADING_K_DB[1], description="Rician K-factor at elevation "
        f"90 degrees, dB (model 'rician' only; default {DEFAULT_K90_DB:g})")
    correlation: float | None = Field(
        None, description="rho in [0, 1), the correlation of the scattered part from one step "
        "to the next (0: independent every step; Jakes: J0(2 pi f_D step_s)); default 0")

    @property
    def k_db(self) -> tuple[float, float]:
        """(K at elevation 0, K at elevation 90 degrees), dB (eq. 11.2); (0, 0) for a model
        without K-factors, which never reads them."""
        return (self.k0_db if self.k0_db is not None else 0.0,
                self.k90_db if self.k90_db is not None else 0.0)

    @field_validator("correlation")
    @classmethod
    def _correlation_below_one(cls, value: float | None) -> float | None:
        if value is not None and not 0.0 <= value < 1.0:
            raise ValueError(f"correlation rho = {value:g} lies outside [0, 1): 0 draws every "
                             "step anew, values near 1 fade slowly, 1 would never change")
        return value

    @model_validator(mode="after")
    def _keys_of_the_model(self) -> Fading:
        """Refuse the keys the model does not read; fill in its own keys' defaults."""
        ignored = [key for key in ("k0_db", "k90_db") if getattr(self, key) is not None
                   and self.model != "rician"]
        if self.correlation is not None and self.model == "none":
            ignored.append("correlation")
        if ignored:
            reads = ("'rayleigh' reads correlation only" if self.model == "rayleigh"
                     else "'none' reads none of them")
            raise ValueError(f"{', '.join(ignored)} given with model = '{self.model}', which "
                             f"ignores {'it' if len(ignored) == 1 else 'them'} ({reads}; "
                             "'rician' reads k0_db, k90_db and correlation); remove "
                             f"{'it' if len(ignored) == 1 else 'them'} or choose another model")
        if self.model == "rician":
            self.k0_db = DEFAULT_K0_DB if self.k0_db is None else self.k0_db
            self.k90_db = DEFAULT_K90_DB if self.k90_db is None else self.k90_db
        if self.model != "none" and self.correlation is None:
            self.correlation = 0.0
        return self


CSI_NMSE_DB = (-60.0, 10.0)
"""The estimate's normalised mean squared error a scenario may give, dB (ours)."""


class Csi(Section):
    """What the network knows of its channels (docs/model.md §16): perfectly, or a Gaussian
    estimate of every link at every step."""

    model: Literal["perfect", "gaussian"] = Field(
        "perfect", description="'perfect' (the paper); 'gaussian': h_hat = h + e, "
        "e ~ CN(0, nmse E|h|^2) per link and step, g_hat = L |h_hat|^2")
    nmse_db: float | None = Field(
        None, ge=CSI_NMSE_DB[0], le=CSI_NMSE_DB[1], description="the estimate's normalised "
        "mean squared error E|e|^2 / E|h|^2, dB (model 'gaussian' only, which needs it)")
    order_on: Literal["estimate", "truth"] | None = Field(
        None, description="the SIC order by the estimated gains (a wrong order costs rate) or "
        "the true ones (model 'gaussian' only; default 'estimate')")

    @model_validator(mode="after")
    def _keys_of_the_model(self) -> Csi:
        if self.model == "perfect":
            given = [key for key in ("nmse_db", "order_on") if getattr(self, key) is not None]
            if given:
                raise ValueError(f"{', '.join(given)} given with model = 'perfect', which reads "
                                 "none of them; remove them or choose model = 'gaussian'")
            return self
        if self.nmse_db is None:
            raise ValueError("model = 'gaussian' needs nmse_db, the estimate's normalised mean "
                             f"squared error in dB (from {CSI_NMSE_DB[0]:g} to "
                             f"{CSI_NMSE_DB[1]:g}; -20: an error 20 dB below the channel)")
        if self.order_on is None:
            self.order_on = "estimate"
        return self

    @property
    def nmse(self) -> float:
        """The normalised mean squared error, linear (0 for perfect knowledge)."""
        return 0.0 if self.nmse_db is None else 10.0 ** (self.nmse_db / 10.0)


class Channel(Section):
    model: str = Field("mmwave-nyc", min_length=1, description="name of a channel-model plugin")
    los: Literal["always", "sampled", "expected", "geometric"] = Field(
        "always", description="LoS handling: always LoS, drawn per user per step, expected "
        "gain, or 'geometric': LoS where no building of [world] blocks the link "
        "(docs/model.md §12)"
    )
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="the plugin's parameters (its own Params model)")
    fading: Fading = Field(default_factory=Fading, description="small-scale fading "
                           "(docs/model.md §11), off by default")
    csi: Csi = Field(default_factory=Csi, description="channel knowledge (docs/model.md §16): "
                     "perfect by default")


CITY_PRESETS: dict[str, tuple[float, float, float]] = {
    "suburban": (0.1, 750.0, 8.0),
    "urban": (0.3, 500.0, 15.0),
    "dense-urban": (0.5, 300.0, 20.0),
    "high-rise": (0.5, 300.0, 50.0),
}
"""ITU-R P.1410's environments (docs/model.md §12): built-up ratio alpha, buildings per km^2
beta, Rayleigh scale gamma of the buildings' heights, m."""


class Building(Section):
    """An axis-aligned box standing on the ground (``world.buildings = "listed"``)."""

    x_m: CoordinateM = Field(description="x of the footprint's centre, m")
    y_m: CoordinateM = Field(description="y of the footprint's centre, m")
    width_m: float = Field(gt=0, le=AREA_MAX_SIDE_M, description="extent along x, m")
    depth_m: float = Field(gt=0, le=AREA_MAX_SIDE_M, description="extent along y, m")
    height_m: float = Field(gt=0, le=MAX_HEIGHT_M, description="height of the roof, m")

    @property
    def box_m(self) -> tuple[float, float, float, float, float]:
        """(x_min, x_max, y_min, y_max, height), m."""
        half_w, half_d = self.width_m / 2, self.depth_m / 2
        return (self.x_m - half_w, self.x_m + half_w, self.y_m - half_d, self.y_m + half_d,
                self.height_m)


class World(Section):
    """Buildings (docs/model.md §12): none, an ITU-R P.1410 city, or listed boxes."""

    buildings: Literal["none", "generated", "listed"] = Field(
        "none", description="'none'; 'generated', ITU-R P.1410's statistical city (city, or "
        "built_up_ratio, buildings_per_km2 and height_scale_m); 'listed', the [[world.building]] "
        "boxes")
    city: Literal["suburban", "urban", "dense-urban", "high-rise"] | None = Field(
        None, description="preset (alpha, beta, gamma) of a generated city")
    built_up_ratio: float | None = Field(
        None, gt=0, lt=1, description="alpha, the share of the ground under buildings")
    buildings_per_km2: float | None = Field(
        None, gt=0, le=1e5, description="beta, buildings per km^2")
    height_scale_m: float | None = Field(
        None, gt=0, le=1000.0, description="gamma, the Rayleigh scale of building heights, m")
    seed: int = Field(0, ge=0, le=MAX_SEED, description="seed of the generated city's grid "
                      "offset (the heights come from each layout, docs/model.md §12)")
    building: list[Building] = Field(default_factory=list,
                                     description="the boxes of world.buildings = 'listed'")

    @model_validator(mode="after")
    def _consistent(self) -> World:
        explicit = {key: getattr(self, key) for key in
                    ("built_up_ratio", "buildings_per_km2", "height_scale_m")}
        given = [key for key, value in explicit.items() if value is not None]
        if self.buildings != "generated" and (given or self.city is not None):
            keys = ", ".join(given + (["city"] if self.city is not None else []))
            raise ValueError(f"{keys} describe a generated city; set buildings = 'generated' "
                             f"(not '{self.buildings}') or remove them")
        if self.buildings != "listed" and self.building:
            raise ValueError(f"[[world.building]] boxes need buildings = 'listed', not "
                             f"'{self.buildings}'")
        if self.buildings == "listed" and not self.building:
            raise ValueError("buildings = 'listed' needs at least one [[world.building]] box")
        if self.buildings == "generated":
            if self.city is not None and given:
                raise ValueError(f"city = '{self.city}' and {', '.join(given)}: give a preset "
                                 "or the three numbers, not both")
            if self.city is None and len(given) < 3:
                missing = [key for key in explicit if key not in given]
                raise ValueError(f"buildings = 'generated' needs city (suburban, urban, "
                                 f"dense-urban, high-rise) or all of built_up_ratio, "
                                 f"buildings_per_km2, height_scale_m (missing: "
                                 f"{', '.join(missing)})")
        return self

    @property
    def city_parameters(self) -> tuple[float, float, float]:
        """(alpha, beta per km^2, gamma m) of a generated city: the preset's or the keys'."""
        if self.city is not None:
            return CITY_PRESETS[self.city]
        assert self.built_up_ratio is not None and self.buildings_per_km2 is not None
        assert self.height_scale_m is not None
        return self.built_up_ratio, self.buildings_per_km2, self.height_scale_m


class Reward(Section):
    """Weights of eq. 13, all >= 0 as the paper requires."""

    min_se: float = Field(0.0, ge=0, le=100.0,
                          description="minimum spectral efficiency R_min/W, bit/s/Hz")
    w_rate: float = Field(1.0, ge=0, le=MAX_REWARD_WEIGHT, description="w_r, sum-rate term")
    w_fairness: float = Field(0.0, ge=0, le=MAX_REWARD_WEIGHT,
                              description="w_f, Jain term (only when min_se = 0)")
    w_gain: float = Field(0.0, ge=0, le=MAX_GAIN_WEIGHT,
                          description="w_g, total channel gain term")
    w_satisfied: float = Field(0.0, ge=0, le=MAX_REWARD_WEIGHT,
                               description="w_s, per user at or above R_min")
    w_unsatisfied: float = Field(0.0, ge=0, le=MAX_REWARD_WEIGHT,
                                 description="w_u, SE of users below R_min")
    w_energy: float = Field(0.0, ge=0, le=MAX_REWARD_WEIGHT,
                            description="w_e, the step's propulsion and transmit energy in "
                            "hover steps, subtracted (docs/model.md §10)")


class Train(Section):
    episodes: int = Field(1000, ge=1, le=MAX_COUNT, description="episodes E")
    steps: int = Field(300, ge=1, le=MAX_COUNT, description="steps per episode T (time limit)")
    seeds: list[Seed] = Field([0], min_length=1, max_length=1000,
                              description="seeds, one run each")
    checkpoint_every: int = Field(50, ge=1, le=MAX_COUNT,
                                  description="episodes between checkpoints")
    trajectory_every: int = Field(0, ge=0, le=MAX_COUNT, description="also store every k-th "
                                  "episode's trajectory; 0 keeps only the last")
    exploring_starts: Literal["none", "shares", "positions", "both"] = Field(
        "none", description="'shares': every training episode starts each cluster's "
        "first-user share at a uniform point of its lattice instead of uav.start_alpha; "
        "'positions': every UAV at a uniform point of its position lattice instead of its "
        "start (UAVs at least uav.min_separation_m apart); 'both': both (exploring starts, "
        "docs/training.md); greedy evaluations always start at the start")
    eval_every: int = Field(10, ge=0, le=MAX_COUNT, description="episodes between greedy "
                            "evaluations (docs/training.md); 0: none")
    eval_steps: int = Field(1000, ge=1, le=100_000, description="steps of a greedy "
                            "evaluation; its score is the mean over the last 100")
    eval_layouts: int | None = Field(None, ge=0, le=1000, description="held-out uniform "
                                     "layouts in every evaluation (default: 0, or 16 for "
                                     "users.placement = 'fresh')")
    eval_layout_seed: int = Field(1, ge=0, le=MAX_SEED, description="seed of the held-out "
                                  "layouts (keep it apart from the layouts you test on)")

    @field_validator("seeds")
    @classmethod
    def _distinct_seeds(cls, value: list[int]) -> list[int]:
        if len(set(value)) != len(value):
            raise ValueError("seeds must be distinct")
        return value


DEFAULT_OUTAGE_SE = 1.0
"""metrics.outage_se's default, bit/s/Hz (ours)."""


class Metrics(Section):
    """The service metrics every evaluation reports beside the sum rate (docs/model.md §14)."""

    outage_se: float = Field(DEFAULT_OUTAGE_SE, ge=0, le=100.0, description="a user-step is "
                             "in outage below this spectral efficiency, bit/s/Hz (ours: 1)")


class Scenario(Section):
    name: str = Field(min_length=1, description="short name, used in output file names "
                      "(letters and digits of any script, '-', '_', '.'; at most 64)")
    description: str = ""
    area: Area = Field(default_factory=Area)
    users: Users = Field(default_factory=_default_users)
    uav: Uav = Field(default_factory=Uav)
    radio: Radio = Field(default_factory=Radio)
    channel: Channel = Field(default_factory=Channel)
    world: World = Field(default_factory=World)
    reward: Reward = Field(default_factory=Reward)
    metrics: Metrics = Field(default_factory=Metrics, description="the service metrics' "
                             "settings (docs/model.md §14)")
    agent: AgentConfig = Field(default_factory=DqnAgent)
    train: Train = Field(default_factory=Train)

    _safe_name = field_validator("name")(safe_name)

    @model_validator(mode="after")
    def _dense_actions(self) -> Scenario:
        """The users' action space must fit MAX_DENSE_ACTIONS for the DQN (its replay stores
        the dense index as float32), MAX_INDEX_ACTIONS for an agent that acts per component
        (the BDQ: the environment's index is an int64); checked without computing it.
        Continuous actions have no index."""
        if self.uav.actions == "continuous":
            return self  # no index: D components of [-1, 1], whatever their number
        count, dense = self.uav.count, self.agent.algorithm == "dqn"
        actions = MAX_DENSE_ACTIONS if dense else MAX_INDEX_ACTIONS
        size, per_cluster = self.cluster_size, self.shares_per_cluster
        limit = max_users(self.uav.actions, count, actions, size, per_cluster)
        users = self.num_users
        if users > limit:
            base = 2 if self.uav.actions == "paper" else 3
            other = "with-hover" if self.uav.actions == "paper" else "paper"
            uavs = f" and {count} UAVs" if count > 1 else ""
            held = ("the dense action space holds at most 2^24" if dense else
                    f"an action index of agent '{self.agent.algorithm}' holds at most 2^62")
            branching = ("; agent.algorithm = 'bdq' acts per component and allows 2^62"
                         if dense and count > 1 else "")
            raise ValueError(
                f"users: {users} users{uavs} give "
                f"{base}^{3 * count + users // size * per_cluster} actions; "
                f"{held}, so at most {max(limit, 0)} users with uav.actions = "
                f"'{self.uav.actions}' "
                f"({max(max_users(other, count, actions, size, per_cluster), 0)} with "
                f"'{other}'){branching}")
        return self

    @model_validator(mode="after")
    def _fading_needs_link_states(self) -> Scenario:
        """Fading multiplies the gain of a link in a known LoS state (docs/model.md §11)."""
        model = self.channel.fading.model
        if model != "none" and self.channel.los == "expected":
            raise ValueError(f"channel.fading.model: '{model}' with channel.los = 'expected' "
                             "is ambiguous (the expected gain mixes the LoS and NLoS gains, "
                             "and only one of them would fade); use channel.los = 'always' or "
                             "'sampled', or channel.fading.model = 'none'")
        return self

    @model_validator(mode="after")
    def _reassociation_in_steps(self) -> Scenario:
        """users.reassociate_every_s is a whole number of steps (docs/model.md §3)."""
        every_s = self.users.reassociate_every_s
        if every_s is not None:
            steps = every_s / self.uav.step_s
            if abs(steps - round(steps)) > 1e-9 * steps or round(steps) < 1:
                raise ValueError(f"users.reassociate_every_s = {every_s:g} s is not a whole "
                                 f"number of steps of uav.step_s = {self.uav.step_s:g} s")
        return self

    @property
    def reassociate_steps(self) -> int | None:
        """Steps between two runs of the association and pairing (None: once per episode)."""
        every_s = self.users.reassociate_every_s
        return None if every_s is None else round(every_s / self.uav.step_s)

    @model_validator(mode="after")
    def _evaluation_layouts(self) -> Scenario:
        """Held-out layouts default to 16 where the training layout changes every episode."""
        if self.train.eval_layouts is None:
            self.train.eval_layouts = 16 if self.users.placement == "fresh" else 0
        return self

    @model_validator(mode="after")
    def _inside_area(self) -> Scenario:
        half_m = self.area.side_m / 2
        for i, (x, y) in enumerate(self.users.positions_m or []):
            if abs(x) > half_m or abs(y) > half_m:
                raise ValueError(f"users.positions_m: user {i + 1} at ({x}, {y}) lies outside "
                                 f"the area |x|, |y| <= {half_m:g} m")
        x, y, _ = self.uav.start_m
        if abs(x) > half_m or abs(y) > half_m:
            raise ValueError(f"uav.start_m: ({x}, {y}) lies outside the area "
                             f"|x|, |y| <= {half_m:g} m")
        return self

    @model_validator(mode="after")
    def _world_observations(self) -> Scenario:
        """``agent.observe`` asks only for what the world has (docs/environment.md,
        "Observations of the world")."""
        check_world_keys(self.agent)
        check_network_keys(self.agent)
        observe = list(getattr(self.agent, "observe", []))
        if not observe:
            return self
        if "heights" in observe and self.world.buildings == "none":
            raise ValueError("agent.observe: 'heights' reads the buildings, but "
                             "world.buildings = 'none'; remove it or add buildings")
        moving = (self.users.speed_m_per_step > 0 or self.users.mobility.model != "static")
        if "velocity" in observe and not moving:
            raise ValueError("agent.observe: 'velocity' reads the users' moves, but the users "
                             "stand (users.mobility.model = 'static'); remove it or let them "
                             "move")
        return self

    @model_validator(mode="after")
    def _direction(self) -> Scenario:
        """The uplink's keys with the uplink only, and what it does not model yet
        (docs/model.md §17)."""
        if not self.uplink:
            if self.users.tx_power_dbm is not None:
                raise ValueError("users.tx_power_dbm: the users' transmit power is the "
                                 "uplink's, but radio.direction = 'downlink' (the UAV sends "
                                 "radio.tx_power_dbm); remove it or set radio.direction = "
                                 "'uplink'")
            return self
        if self.channel.csi.model != "perfect":
            raise ValueError("channel.csi: imperfect channel knowledge is modelled for the "
                             "downlink (docs/model.md §16); with radio.direction = 'uplink' "
                             "use channel.csi.model = 'perfect'")
        if getattr(self.agent, "reward_split", "team") == "difference":
            raise ValueError("agent.reward_split: 'difference' prices a UAV's interference on "
                             "the downlink; the uplink's interference comes from the users "
                             "(docs/model.md §17): use 'team' or 'per-uav'")
        return self

    @model_validator(mode="after")
    def _several_uavs(self) -> Scenario:
        """Groups of users the UAVs can serve, and UAVs that start far enough apart
        (docs/model.md §9)."""
        uav, users, n, size = self.uav, self.users, self.num_users, self.cluster_size
        what = "pair" if size == 2 else "cluster"
        if uav.count > n // size:
            raise ValueError(f"uav.count: {uav.count} UAVs for {n // size} NOMA {what}s; every "
                             f"UAV needs at least one {what}")
        if users.uav is not None:
            if len(users.uav) != n:
                raise ValueError(f"users.uav: lists {len(users.uav)} UAVs for {n} users; give "
                                 "one serving UAV per user")
            missing = _missing_uavs(users.uav, uav.count)
            if missing:
                raise ValueError(f"users.uav: {missing}, but uav.count = {uav.count} numbers "
                                 f"the UAVs 0 to {uav.count - 1} (0-based); give every user "
                                 "one of them, or raise uav.count")
            sizes = [users.uav.count(u) for u in range(uav.count)]
            if any(group == 0 or group % size for group in sizes):
                served = ("an even number >= 2" if size == 2
                          else f"a multiple >= {size} (users.cluster_size)")
                raise ValueError(f"users.uav: group sizes {sizes} for UAVs 0..{uav.count - 1}; "
                                 f"every UAV serves {served} of users")
        elif n % uav.count or (n // uav.count) % size:
            sized = ("an even size" if size == 2
                     else f"a multiple of users.cluster_size = {size}")
            raise ValueError(f"users.association: {n} users do not split into {uav.count} "
                             f"equal groups of {sized}; choose N divisible by {size} U, or "
                             "association = 'listed' with users.uav")
        if len(set(self.clusters_of_uavs)) > 1 and getattr(self.agent, "reward_split",
                                                           "team") != "team":
            raise ValueError(f"agent.reward_split: '{self.agent.reward_split}' needs every UAV "
                             f"to serve as many clusters (users.uav gives "
                             f"{list(self.clusters_of_uavs)}); use 'team'")
        starts = self.uav_start_positions_m
        half_m = self.area.side_m / 2
        for u, (x, y, _) in enumerate(uav.start_positions_m or []):
            if abs(x) > half_m or abs(y) > half_m:
                raise ValueError(f"uav.start_positions_m: UAV {u} at ({x:g}, {y:g}) lies "
                                 f"outside the area |x|, |y| <= {half_m:g} m")
        for u in range(len(starts)):
            for v in range(u + 1, len(starts)):
                apart_m = math.dist(starts[u][:2], starts[v][:2])
                if apart_m < uav.min_separation_m:
                    raise ValueError(f"uav.start_positions_m: UAVs {u} and {v} start "
                                     f"{apart_m:.4g} m apart, closer than uav.min_separation_m "
                                     f"= {uav.min_separation_m:g} m")
        return self

    @model_validator(mode="after")
    def _buildings(self) -> Scenario:
        """Buildings go with geometric LoS and only with it; listed boxes lie in the area,
        with no UAV start inside one and no listed user on one (docs/model.md §12)."""
        world, los = self.world, self.channel.los
        if (world.buildings == "none") != (los != "geometric"):
            if los == "geometric":
                raise ValueError("channel.los = 'geometric' needs buildings: set "
                                 "world.buildings = 'generated' or 'listed'")
            raise ValueError(f"world.buildings = '{world.buildings}' needs channel.los = "
                             f"'geometric' (with los = '{los}' the buildings would block "
                             "nothing)")
        if world.buildings != "none" and self.train.exploring_starts in ("positions", "both"):
            raise ValueError(f"train.exploring_starts = '{self.train.exploring_starts}' draws "
                             "start positions without regard to buildings: with "
                             f"world.buildings = '{world.buildings}' use 'none' or 'shares'")
        half_m = self.area.side_m / 2
        for i, building in enumerate(world.building):
            x_lo, x_hi, y_lo, y_hi, height_m = building.box_m
            if x_lo < -half_m or x_hi > half_m or y_lo < -half_m or y_hi > half_m:
                raise ValueError(f"world.building {i}: x [{x_lo:g}, {x_hi:g}] m, y "
                                 f"[{y_lo:g}, {y_hi:g}] m reaches outside the area |x|, |y| "
                                 f"<= {half_m:g} m")
            for u, (x, y, h) in enumerate(self.uav_start_positions_m):
                if x_lo <= x <= x_hi and y_lo <= y <= y_hi and h <= height_m:
                    raise ValueError(f"uav: UAV {u} starts at ({x:g}, {y:g}, {h:g}) inside "
                                     f"world.building {i} (roof at {height_m:g} m)")
            if self.users.placement == "listed":
                for j, (x, y) in enumerate(self.users.positions_m or []):
                    if x_lo <= x <= x_hi and y_lo <= y <= y_hi:
                        raise ValueError(f"users.positions_m: user {j + 1} at ({x:g}, {y:g}) "
                                         f"stands inside world.building {i}; users stand "
                                         "in the streets")
        self._open_ground()
        return self

    def _open_ground(self) -> None:
        """Users drawn in the streets need MIN_OPEN_SHARE of the area off the footprints
        (docs/scenario-format.md): the listed boxes' exact union, a generated city's 1 - alpha."""
        world, placement = self.world, self.users.placement
        if world.buildings == "none" or placement == "listed":
            return
        if world.buildings == "listed":
            share = open_ground_share([b.box_m[:4] for b in world.building],
                                      self.area.side_m / 2)
        else:
            share = 1.0 - world.city_parameters[0]
        open_pct = math.floor(share * 1000) / 10      # rounded down: 0.99% reads 0.9%
        what = (f"world.building: the boxes cover {100 - open_pct:.1f}% of the area, leaving "
                f"{open_pct:.1f}% open ground" if world.buildings == "listed" else
                f"world.built_up_ratio: {world.city_parameters[0]:g} leaves {open_pct:.1f}% "
                "open ground")
        if share < MIN_OPEN_SHARE:
            raise ValueError(f"{what}; users.placement = '{placement}' draws users in "
                             f"the open ground, which needs at least {MIN_OPEN_SHARE:.0%} of "
                             "the area: shrink or remove buildings, or list the users")

    @model_validator(mode="after")
    def _uav_above_users(self) -> Scenario:
        """Every link at least MIN_HEIGHT_M long: the UAV's lowest height that far above the
        users' antennas."""
        if self.uav.min_height_m - self.users.height_m < MIN_HEIGHT_M:
            raise ValueError(f"users.height_m: {self.users.height_m:g} m leaves the UAV's "
                             f"lowest height (uav.min_height_m = {self.uav.min_height_m:g} m) "
                             f"less than {MIN_HEIGHT_M:g} m above the users; lower the users or "
                             "raise uav.min_height_m")
        return self

    @property
    def num_users(self) -> int:
        assert self.users.count is not None  # resolved by Users._resolve
        return self.users.count

    @property
    def uav_start_positions_m(self) -> list[list[float]]:
        """Start [x, y, h] of every UAV, m (docs/model.md §9): ``uav.start_positions_m``; else
        ``uav.start_m`` for one UAV and, for U > 1, U points evenly on the circle of radius
        L/4 around the centre at ``start_m``'s height, UAV u at the angle 2 pi u / U."""
        uav = self.uav
        if uav.start_positions_m is not None:
            return [list(p) for p in uav.start_positions_m]
        if uav.count == 1:
            return [list(uav.start_m)]
        radius_m, height_m = self.area.side_m / 4, uav.start_m[2]
        return [[radius_m * math.cos(2 * math.pi * u / uav.count),
                 radius_m * math.sin(2 * math.pi * u / uav.count), height_m]
                for u in range(uav.count)]

    @property
    def cluster_size(self) -> int:
        """M, the users of every NOMA cluster (docs/model.md §15; 2: the paper's pairs)."""
        return self.users.cluster_size

    @property
    def num_clusters(self) -> int:
        """K, the NOMA clusters of all UAVs together (N / M)."""
        return self.num_users // self.cluster_size

    @property
    def clusters_of_uavs(self) -> tuple[int, ...]:
        """K_u of every UAV (docs/model.md §9): its listed users (``users.uav``) over M, else
        N / (M U) each (equal groups)."""
        listed, size = self.users.uav, self.cluster_size
        if listed is not None:
            return tuple(listed.count(u) // size for u in range(self.uav.count))
        return (self.num_users // (size * self.uav.count),) * self.uav.count

    @property
    def clusters_per_uav(self) -> int:
        """K_max, the most clusters of one UAV: N / (M U) for equal groups."""
        return max(self.clusters_of_uavs)

    @property
    def users_per_uav(self) -> int:
        """M K_max, the most users of one UAV (the user slots of a UAV's local view)."""
        return self.cluster_size * self.clusters_per_uav

    @property
    def uplink(self) -> bool:
        """Whether the users send and the UAVs receive (docs/model.md §17)."""
        return self.radio.direction == "uplink"

    @property
    def sic_chains(self) -> bool:
        """Whether NOMA's clusters are SIC chains (clusters of M > 2, or the uplink: docs/
        model.md §15, §17), not the paper's downlink pairs with their closed forms."""
        return self.cluster_size > 2 or self.uplink

    @property
    def shares_per_cluster(self) -> int:
        """A cluster's power components: M - 1 shares of the downlink's split (docs/model.md
        §15), M transmit shares in the uplink (§17)."""
        return self.cluster_size if self.uplink else self.cluster_size - 1

    @property
    def user_tx_power_w(self) -> float:
        """P_u, W: every user's largest transmit power in the uplink (default 23 dBm)."""
        dbm = DEFAULT_USER_TX_DBM if self.users.tx_power_dbm is None else self.users.tx_power_dbm
        return 10 ** ((dbm - 30.0) / 10.0)

    @property
    def sender_power_w(self) -> float:
        """The power a link's sender has, W: P_T of each cluster in the downlink, P_u of each
        user in the uplink (docs/model.md §17)."""
        return self.user_tx_power_w if self.uplink else self.radio.tx_power_w

    @property
    def shares_of_uavs(self) -> tuple[int, ...]:
        """S_u of every UAV: its power components, K_u (M - 1) shares of the downlink's split
        (docs/model.md §15; K_u for pairs) or K_u M transmit shares in the uplink (§17)."""
        return tuple(k * self.shares_per_cluster for k in self.clusters_of_uavs)

    @property
    def shares_per_uav(self) -> int:
        """S_max, the most share components of one UAV: the width of every UAV's shares in
        the configuration (a UAV with fewer has padded, unused slots)."""
        return max(self.shares_of_uavs)

    @property
    def min_rate_bps(self) -> float:
        """R_min = min_se * W (eq. 13)."""
        return self.reward.min_se * self.radio.bandwidth_hz
