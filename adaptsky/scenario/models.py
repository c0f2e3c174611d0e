"""Pydantic models of a scenario file (docs/model.md §1-5). Every key is documented in
``docs/scenario-format.md``; defaults are the paper's mmWave training set-up (Table I, sec. V).

Every number has a documented range, physically meaningful and small enough that no step of a
run overflows; what a run needs in memory is checked apart (``training.resources``).
"""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

PAPER_TRAINING_LAYOUT_M = [[4.0, 15.0], [-44.0, -49.0], [-5.0, 21.0], [47.0, 49.0]]

# names become file names (runs/<name>-<time>.h5, DIR/runs/<group>-...): see safe_name
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
NAME_MAX_LENGTH = 64
# the replay memory stores an action index as float32, exact up to 2^24: the dense action space
# (2^(3+K) or 3^(3+K) actions) may not be larger
MAX_DENSE_ACTIONS = 2**24
MAX_SEED = 2**63 - 1          # seeds are stored as int64
MAX_COUNT = 10**9             # episodes, steps, periods
MAX_MEMORY = 2**53            # replay rows are drawn as floor(u * size), u a float64
AREA_MAX_SIDE_M = 100_000.0
MIN_HEIGHT_M = 1.0            # every link is then >= 1 m long: no gain above the 1 m intercept
MAX_HEIGHT_M = 10_000.0
MAX_ANTENNAS = 4096
MAX_REWARD_WEIGHT = 1e6
MAX_GAIN_WEIGHT = 1e12        # linear gains are ~1e-12 .. 1e-5

Seed = Annotated[int, Field(ge=0, le=MAX_SEED)]
LayerSize = Annotated[int, Field(ge=1, le=2**31 - 1)]
StepM = Annotated[float, Field(ge=0.01, le=1000.0)]
CoordinateM = Annotated[float, Field(ge=-AREA_MAX_SIDE_M, le=AREA_MAX_SIDE_M)]


def max_users(mode: str) -> int:
    """The most users whose dense action space (``uav.actions = mode``) has at most
    ``MAX_DENSE_ACTIONS`` actions: 42 for ``paper``, 24 for ``with-hover``."""
    base, components = (2 if mode == "paper" else 3), 3
    while base ** (components + 1) <= MAX_DENSE_ACTIONS:
        components += 1
    return 2 * (components - 3)


def safe_name(value: str) -> str:
    """``value`` if it can be a file name's stem on every system, else a ValueError saying what
    is allowed."""
    if len(value) > NAME_MAX_LENGTH or not NAME_PATTERN.fullmatch(value):
        raise ValueError(f"not a safe file name: use 1 to {NAME_MAX_LENGTH} letters, digits, "
                         "'-', '_' or '.', starting with a letter or digit")
    return value


class Section(BaseModel):
    """Strict base: unknown keys are errors and no string is silently turned into a number."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class Area(Section):
    side_m: float = Field(100.0, ge=1.0, le=AREA_MAX_SIDE_M,
                          description="side L of the square area |x|,|y| <= L/2, m")


class Users(Section):
    positions_m: list[Annotated[list[CoordinateM], Field(min_length=2, max_length=2)]] | None = (
        Field(None, description="explicit user positions [[x, y], ...], m; even count"))
    count: int | None = Field(None, ge=2, description="number of users N_UE = 2K (even)")
    placement: Literal["listed", "uniform", "fresh"] | None = Field(
        None, description="'listed' (positions_m), 'uniform' over the area (count, "
        "layout_seed), or 'fresh': uniform, drawn anew every training episode from the "
        "seed (evaluation without --layouts uses the layout_seed layout)"
    )
    layout_seed: int = Field(0, ge=0, le=MAX_SEED, description="seed of the uniform layouts")
    pairing: Literal["listed", "near-far"] | None = Field(
        None, description="NOMA pairs: listed order (1,2),(3,4)... or k-th strongest with "
        "k-th weakest"
    )
    speed_m_per_step: float = Field(0.0, ge=0, le=1000.0,
                                    description="random-walk speed of every user, m/step")
    height_m: float = Field(0.0, ge=0, le=MAX_HEIGHT_M - MIN_HEIGHT_M,
                            description="antenna height h_UT of every user above the ground, "
                            "m (the paper: 0, users on the ground; needs a contract-2 "
                            "channel model)")

    @field_validator("positions_m")
    @classmethod
    def _even_pairs_of_xy(cls, value: list[list[float]] | None) -> list[list[float]] | None:
        if value is None:
            return value
        if len(value) < 2 or len(value) % 2:
            raise ValueError(f"{len(value)} users given; NOMA pairs need an even count >= 2")
        return value

    @field_validator("count")
    @classmethod
    def _even_count(cls, value: int | None) -> int | None:
        if value is not None and value % 2:
            raise ValueError(f"{value} users; NOMA pairs need an even count")
        return value

    @model_validator(mode="after")
    def _resolve(self) -> Users:
        if self.positions_m is not None:
            if self.placement in ("uniform", "fresh"):
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
        if self.pairing is None:
            self.pairing = "listed" if self.placement == "listed" else "near-far"
        return self


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
    actions: Literal["paper", "with-hover"] = Field(
        "paper", description="'paper': each component in {-1,+1}; 'with-hover': in {-1,0,+1}"
    )

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
        return self


class Radio(Section):
    carrier_hz: float | None = Field(
        None, ge=1e8, le=1e12, description="carrier frequency f_c, Hz, handed to the channel "
        "model; default: the model's carrier_hz parameter where it has one, else 28e9 "
        "(Table I, mmWave)")
    tx_power_dbm: float = Field(20.0, ge=-50.0, le=80.0,
                                description="power P_T of each cluster, dBm")
    bandwidth_hz: float = Field(2e9, gt=0, le=1e12, description="bandwidth W of each cluster, Hz")
    thermal_noise_dbm: float = Field(-84.0, ge=-200.0, le=0.0,
                                     description="thermal noise over W, dBm")
    noise_figure_db: float = Field(0.0, ge=0, le=50.0, description="receiver noise figure, dB")
    antennas_uav: int = Field(8, ge=1, le=MAX_ANTENNAS, description="antennas at the UAV, N_UAV")
    antennas_ue: int = Field(8, ge=1, le=MAX_ANTENNAS, description="antennas at each user, N_UE")

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


class Channel(Section):
    model: str = Field("mmwave-nyc", min_length=1, description="name of a channel-model plugin")
    los: Literal["always", "sampled", "expected"] = Field(
        "always", description="LoS handling: always LoS, drawn per user per step, or expected gain"
    )
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="the plugin's parameters (its own Params model)")


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


class Agent(Section):
    """The dueling DQN of sec. IV and V-A; extensions are off by default.

    ``preset`` names a set of values (``agent.presets``) for the keys a file does not give;
    ``"paper"`` is the paper's agent, every key at its default (docs/agent.md).
    """

    preset: str = Field("paper", description="named recipe for the keys not given "
                        "(docs/agent.md): 'paper' or 'tuned'")
    hidden_sizes: list[LayerSize] = Field([128, 128], min_length=1, max_length=100,
                                          description="hidden ReLU layers")
    dueling: bool = Field(True, description="dueling head; false gives the paper's plain 'DRL'")
    double_dqn: bool = Field(False, description="double-DQN target (extension)")
    loss: Literal["mse", "huber"] = Field("mse", description="TD loss; the paper uses MSE (eq. 12)")
    grad_clip_norm: float = Field(0.0, ge=0, le=1e6, description="gradient-norm clip; 0 disables")
    gamma: float = Field(0.999, ge=0, le=1, description="discount factor")
    lr: float = Field(1e-3, ge=1e-10, le=1.0, description="Adam learning rate l_r")
    batch_size: int = Field(128, ge=1, le=MAX_COUNT, description="mini-batch size B")
    memory_size: int = Field(15000, ge=1, le=MAX_MEMORY, description="replay memory capacity M")
    epsilon_start: float = Field(0.9, ge=0, le=1, description="epsilon_s")
    epsilon_end: float = Field(0.1, ge=0, le=1, description="epsilon_e")
    epsilon_decay_steps: float = Field(200.0, gt=0, le=1e15,
                                       description="chi, decay constant in steps")
    target_update_episodes: int = Field(10, ge=1, le=MAX_COUNT,
                                        description="hard target copy period")
    observation: Literal["scaled", "raw"] = Field(
        "scaled", description="observation scaling, see docs/environment.md"
    )
    user_order: Literal["listed", "clusters"] = Field(
        "listed", description="users in the observation: as the layout lists them, or cluster "
        "by cluster (first and second user of cluster 1, then cluster 2...)")
    reward_scale: float = Field(1.0, gt=0, le=1e6, description="rewards are multiplied by "
                                "this before they are stored for learning (extension)")
    n_step: int = Field(1, ge=1, le=100, description="n-step returns (extension); 1 is "
                        "eq. 12's one-step target")
    target_tau: float = Field(0.0, ge=0, le=1, description="soft target update theta' <- "
                              "theta' + tau (theta - theta') after every update (extension); "
                              "0 keeps the hard copies of target_update_episodes")
    lr_end: float | None = Field(None, ge=1e-12, le=1.0, description="learning rate reached "
                                 "after lr_decay_steps steps, linearly (extension); unset: "
                                 "constant lr")
    lr_decay_steps: float = Field(300_000.0, gt=0, le=1e15, description="steps over which lr "
                                  "falls to lr_end")

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        """A preset's values under the keys given explicitly."""
        if not isinstance(data, dict):
            return data
        from adaptsky.scenario.presets import preset_values

        name = data.get("preset", "paper")
        return {**preset_values(name), **data} if isinstance(name, str) else data

    @model_validator(mode="after")
    def _memory_holds_a_batch(self) -> Agent:
        if self.memory_size < self.batch_size:
            raise ValueError(f"memory_size ({self.memory_size}) must hold at least one batch "
                             f"({self.batch_size})")
        return self


class Train(Section):
    episodes: int = Field(1000, ge=1, le=MAX_COUNT, description="episodes E")
    steps: int = Field(300, ge=1, le=MAX_COUNT, description="steps per episode T (time limit)")
    seeds: list[Seed] = Field([0], min_length=1, max_length=1000,
                              description="seeds, one run each")
    checkpoint_every: int = Field(50, ge=1, le=MAX_COUNT,
                                  description="episodes between checkpoints")
    trajectory_every: int = Field(0, ge=0, le=MAX_COUNT, description="also store every k-th "
                                  "episode's trajectory; 0 keeps only the last")
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


class Scenario(Section):
    name: str = Field(min_length=1, description="short name, used in output file names "
                      "(letters, digits, '-', '_', '.'; at most 64)")
    description: str = ""
    area: Area = Field(default_factory=Area)
    users: Users = Field(default_factory=_default_users)
    uav: Uav = Field(default_factory=Uav)
    radio: Radio = Field(default_factory=Radio)
    channel: Channel = Field(default_factory=Channel)
    reward: Reward = Field(default_factory=Reward)
    agent: Agent = Field(default_factory=Agent)
    train: Train = Field(default_factory=Train)

    _safe_name = field_validator("name")(safe_name)

    @model_validator(mode="after")
    def _dense_actions(self) -> Scenario:
        """The users' action space must fit MAX_DENSE_ACTIONS (checked without computing it)."""
        limit, users = max_users(self.uav.actions), self.num_users
        if users > limit:
            base = 2 if self.uav.actions == "paper" else 3
            other = "with-hover" if self.uav.actions == "paper" else "paper"
            raise ValueError(
                f"users: {users} users give {base}^{3 + users // 2} actions; the dense action "
                f"space holds at most 2^24, so at most {limit} users with uav.actions = "
                f"'{self.uav.actions}' ({max_users(other)} with '{other}')")
        return self

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
    def num_clusters(self) -> int:
        return self.num_users // 2

    @property
    def min_rate_bps(self) -> float:
        """R_min = min_se * W (eq. 13)."""
        return self.reward.min_se * self.radio.bandwidth_hz
