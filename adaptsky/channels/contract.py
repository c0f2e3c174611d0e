"""The channel-model plugin contract: the only module a plugin needs to import.

A plugin is a subclass of :class:`ChannelModel` with a Pydantic ``Params`` model, registered
under the entry-point group ``adaptsky.channel_models``. See ``docs/plugins.md``.

Every array method takes a :class:`LinkGeometry` of shape (B, N): B UAVs (independent
environments), N ground users, and returns float64 arrays of that shape.

The contract is versioned (``CONTRACT_VERSION``, docs/plugins.md §2): a class says which
version it was written for with ``contract_version``; one that says nothing was written before
versions existed and is taken as contract 1 (users on the ground, no fading hook).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel, ConfigDict

SPEED_OF_LIGHT_M_PER_S = 299_792_458.0

CONTRACT_VERSION = 3
"""The plugin contract this adaptsky defines (docs/plugins.md §2, "Contract versions")."""
SUPPORTED_CONTRACT_VERSIONS = (1, 2, 3)
"""The versions a plugin may declare; 1 is what a class that declares none is taken as."""
DEFAULT_CARRIER_HZ = 28e9
"""f_c of a geometry built without one: the paper's mmWave carrier (Table I), Hz."""
DEFAULT_BANDWIDTH_HZ = 2e9
"""W of a geometry built without one: the paper's mmWave bandwidth (Table I), Hz."""

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


class ChannelParams(BaseModel):
    """Base of every plugin's ``Params``: unknown keys are errors, values must be finite."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


@dataclass(frozen=True)
class LinkGeometry:
    """UAV-to-user geometry of B UAVs and N users each, and the radio's f_c and W.

    Every link array is float64 of shape (B, N):
    horizontal_m: ground distance d2D; height_m: UAV height h above the ground (broadcast over
    users); user_height_m: antenna height h_UT of each user above the ground (0: the paper);
    distance_m: 3D distance d = sqrt(d2D^2 + (h - h_UT)^2) between the two antennas;
    elevation_deg: theta = asin((h - h_UT) / d), degrees.
    Positions: uav_m (B, 3) [x, y, h]; users_m (B, N, 2) [x, y]. carrier_hz and bandwidth_hz
    are the scenario's ``[radio]`` f_c and W (contract 2; a contract-1 plugin ignores them).
    los (contract 3): with ``channel.los = "geometric"`` each link's LoS state (B, N), bool,
    from the buildings (docs/model.md §12), which the environment uses to pick the model's
    LoS or NLoS gain and a model may read; None otherwise.

    A geometry built from distances alone (``LinkGeometry(horizontal_m, height_m, distance_m,
    elevation_deg)``) puts each UAV at (0, 0, h) and its users at (d2D, 0) on the ground.
    """

    horizontal_m: FloatArray
    height_m: FloatArray
    distance_m: FloatArray
    elevation_deg: FloatArray
    user_height_m: FloatArray = field(default=None)  # type: ignore[assignment]
    uav_m: FloatArray = field(default=None)  # type: ignore[assignment]
    users_m: FloatArray = field(default=None)  # type: ignore[assignment]
    carrier_hz: float = DEFAULT_CARRIER_HZ
    bandwidth_hz: float = DEFAULT_BANDWIDTH_HZ
    los: BoolArray | None = None

    def __post_init__(self) -> None:
        """Fill what a geometry built from distances alone leaves out (see the class doc)."""
        shape = np.shape(self.distance_m)
        if self.user_height_m is None:
            object.__setattr__(self, "user_height_m", np.zeros(shape))
        if len(shape) != 2:  # not links of B UAVs and N users: no placement to give
            return
        if self.uav_m is None:
            heights = np.broadcast_to(self.height_m, shape)
            uav_m = np.zeros((shape[0], 3))
            uav_m[:, 2] = heights[:, 0] if shape[1] else 0.0
            object.__setattr__(self, "uav_m", uav_m)
        if self.users_m is None:
            users_m = np.zeros((*shape, 2))
            users_m[..., 0] = self.horizontal_m
            object.__setattr__(self, "users_m", users_m)

    @classmethod
    def between(cls, uav_m: FloatArray, users_m: FloatArray, *,
                user_height_m: ArrayLike = 0.0, carrier_hz: float = DEFAULT_CARRIER_HZ,
                bandwidth_hz: float = DEFAULT_BANDWIDTH_HZ) -> LinkGeometry:
        """Geometry of UAVs ``uav_m`` (B, 3) [x, y, h] and users ``users_m`` (B, N, 2) [x, y]
        whose antennas stand ``user_height_m`` (a number, or anything that broadcasts to
        (B, N)) above the ground, on carrier ``carrier_hz`` with bandwidth ``bandwidth_hz``."""
        uav_m, users_m = np.asarray(uav_m, dtype=np.float64), np.asarray(users_m,
                                                                         dtype=np.float64)
        delta = users_m - uav_m[:, None, :2]
        height_m = np.empty_like(delta[..., 0])    # h broadcast over users, as an array
        height_m[...] = uav_m[:, 2:3]
        user_height = np.zeros_like(height_m)
        user_height[...] = user_height_m
        return cls._from_offsets(delta[..., 0], delta[..., 1], height_m, user_height, uav_m,
                                 users_m, carrier_hz, bandwidth_hz,
                                 None if user_height.any() else height_m)

    @classmethod
    def _from_offsets(cls, dx_m: FloatArray, dy_m: FloatArray, height_m: FloatArray,
                      user_height_m: FloatArray, uav_m: FloatArray, users_m: FloatArray,
                      carrier_hz: float, bandwidth_hz: float,
                      above_m: FloatArray | None = None) -> LinkGeometry:
        """Geometry from the ground offsets between UAV and user (either sign: only their
        sizes count), the UAV and user heights, each (B, N), and the positions; ``above_m``
        is h - h_UT where the caller has it (``height_m`` itself when users are on the
        ground, which gives the same numbers as the subtraction)."""
        horizontal_m = np.hypot(dx_m, dy_m)
        if above_m is None:
            above_m = height_m - user_height_m
        distance_m = np.hypot(horizontal_m, above_m)
        elevation_deg = np.degrees(np.arcsin(above_m / distance_m))
        # the frozen dataclass's __init__ sets each field through object.__setattr__; filling
        # the instance's __dict__ at once is the same object, made faster (once per step)
        geometry = object.__new__(cls)
        geometry.__dict__.update(horizontal_m=horizontal_m, height_m=height_m,
                                 distance_m=distance_m, elevation_deg=elevation_deg,
                                 user_height_m=user_height_m, uav_m=uav_m, users_m=users_m,
                                 carrier_hz=carrier_hz, bandwidth_hz=bandwidth_hz, los=None)
        return geometry

    @property
    def shape(self) -> tuple[int, ...]:
        return self.distance_m.shape

    def rows(self, start: int, stop: int) -> LinkGeometry:
        """The links of environments ``start:stop`` (views)."""
        rows = slice(start, stop)
        return LinkGeometry(self.horizontal_m[rows], self.height_m[rows],
                            self.distance_m[rows], self.elevation_deg[rows],
                            self.user_height_m[rows], self.uav_m[rows], self.users_m[rows],
                            self.carrier_hz, self.bandwidth_hz,
                            None if self.los is None else self.los[rows])

    def with_los(self, los: BoolArray) -> LinkGeometry:
        """This geometry with the LoS states ``los`` (B, N) of its links (contract 3)."""
        geometry = object.__new__(type(self))
        geometry.__dict__.update(self.__dict__, los=los)
        return geometry


SHARED_SETTINGS = ("carrier_hz", "bandwidth_hz", "user_height_m")
"""The scenario settings a geometry hands to every model (``LinkGeometry`` fields of the same
names), which a model may declare in :class:`Supports`."""


@dataclass(frozen=True)
class Supports:
    """What a model honours or is valid for of the settings a scenario shares with it
    (docs/plugins.md §2): for each, the inclusive range ``(low, high)`` of values it models,
    one value ``(f, f)`` where its constants hold only that one (``mmwave-nyc``'s 28 GHz: it
    ignores any other); None: every value a scenario allows, as for a model that declares
    nothing. A scenario outside a declared range is refused. ``monotone_gains`` is a promise
    about the gains instead, which lets the per-step searches bound them; ``reciprocal`` one
    that they hold in the uplink too."""

    carrier_hz: tuple[float, float] | None = None
    """f_c, Hz (``radio.carrier_hz``)."""
    bandwidth_hz: tuple[float, float] | None = None
    """W of each cluster, Hz (``radio.bandwidth_hz``)."""
    user_height_m: tuple[float, float] | None = None
    """h_UT, the users' antenna height, m (``users.height_m``)."""
    reciprocal: bool = False
    """True states that the model's gains hold both ways, user to UAV as UAV to user (the
    uplink, ``radio.direction = "uplink"``, takes the same large-scale gain, docs/model.md
    §17); False: a scenario of the uplink is refused with the model."""
    monotone_gains: bool = False
    """True promises, for the parameters and shared settings of a run: ``gain_los`` and
    ``gain_nlos`` depend on a link only through its ground distance d2D and the UAV's height
    h (not on ``geometry.los``), neither grows with d2D at a fixed h nor with h at a fixed d2D
    (h above the users' antennas), and ``gain_nlos <= gain_los`` on every link. So the LoS
    gain at a region's nearest point to a user bounds every gain in the region, and the
    gain at its farthest point bounds them from below: the per-step oracle and best response
    at every step search by branch and bound (docs/model.md §6, §9). False: every lattice
    point is searched, to the same results, slower."""


class ChannelModel(ABC):
    """Large-scale channel of one UAV-user antenna pair (sec. II-C), and optional fading.

    Subclasses set ``Params`` (a :class:`ChannelParams` subclass whose every field has a
    default and a description with its unit), ``description`` and ``contract_version``, and
    implement the three abstract methods. Gains are linear power gains (not dB) of one antenna
    pair; the antenna gain G = N_UAV x N_UE is applied by the environment.
    """

    Params: ClassVar[type[ChannelParams]] = ChannelParams
    description: ClassVar[str] = ""
    contract_version: ClassVar[int | None] = None
    """The contract the class was written for (``CONTRACT_VERSION`` today); None: 1."""
    supports: ClassVar[Supports | None] = None
    """Contract 2, optional: the shared settings it honours (:class:`Supports`); None: any."""
    default_radio: ClassVar[Mapping[str, float] | None] = None
    """Optional: the radio of the model's paper table, ``[radio]`` keys and values
    (``{"tx_power_dbm": 30.0, "bandwidth_hz": 5e7, ...}``) that a scenario naming the model
    takes for the keys it does not give (docs/plugins.md); None: adaptsky's defaults (the
    paper's mmWave Table I)."""

    def __init__(self, params: ChannelParams | None = None) -> None:
        self.params = params if params is not None else self.Params()

    @abstractmethod
    def los_probability(self, geometry: LinkGeometry) -> FloatArray:
        """Probability in [0, 1] that each link is line of sight, shape (B, N)."""

    @abstractmethod
    def gain_los(self, geometry: LinkGeometry) -> FloatArray:
        """Linear gain of each link when it is LoS, shape (B, N)."""

    @abstractmethod
    def gain_nlos(self, geometry: LinkGeometry) -> FloatArray:
        """Linear gain of each link when it is NLoS, shape (B, N)."""

    def sample_los(self, geometry: LinkGeometry, rng: np.random.Generator) -> BoolArray:
        """Draw the LoS state of each link from ``rng`` (the run's seeded generator).

        The default draws independently per link with :meth:`los_probability`; override it
        for correlated models, always drawing from ``rng`` only.
        """
        return rng.random(geometry.shape) < self.los_probability(geometry)

    def expected_gain(self, geometry: LinkGeometry) -> FloatArray:
        """``P g_LoS + (1 - P) g_NLoS`` (docs/model.md §2, ``los = "expected"``)."""
        p_los = self.los_probability(geometry)
        return p_los * self.gain_los(geometry) + (1 - p_los) * self.gain_nlos(geometry)

    def fading_enabled(self) -> bool:
        """Contract 2: whether :meth:`sample_fading` applies with these parameters (decided
        by the parameters alone). The default: whether the class implements it."""
        return implements_fading(type(self))

    def sample_fading(self, geometry: LinkGeometry, los: BoolArray,
                      rng: np.random.Generator) -> FloatArray:
        """Contract 2, optional: per-step fading or shadowing of each link, a linear power
        factor > 0 of shape (B, N) by which the step's gain is multiplied; ``los`` (B, N) is
        each link's LoS state in this step. Draw from ``rng`` only (the run's seeded
        generator). Not implemented here: the paper's models have no fading."""
        raise NotImplementedError(f"{type(self).__name__} has no fading hook")


def implements_fading(model: Any) -> bool:
    """Whether a model class implements :meth:`ChannelModel.sample_fading`."""
    return getattr(model, "sample_fading", None) is not ChannelModel.sample_fading


def declares_monotone_gains(model: Any) -> bool:
    """Whether a model class (or instance) declares ``Supports(monotone_gains=True)``."""
    return getattr(getattr(model, "supports", None), "monotone_gains", False) is True


def declares_reciprocal_gains(model: Any) -> bool:
    """Whether a model class (or instance) declares ``Supports(reciprocal=True)``."""
    return getattr(getattr(model, "supports", None), "reciprocal", False) is True


def carrier_parameter_hz(params: BaseModel) -> float | None:
    """The value of a model's ``carrier_hz`` parameter (shared with ``[radio] carrier_hz``,
    docs/plugins.md), or None where its ``Params`` has no such number."""
    value = getattr(params, "carrier_hz", None)
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    return None


def parameter_limits(params: type[BaseModel], key: str) -> dict[str, float]:
    """The numeric bounds of parameter ``key`` (its Field's gt, ge, lt, le) as
    ``{"ge": 1e8, "le": 1e11}``; {} where it has none or no such parameter."""
    field_info = params.model_fields.get(key)
    metadata = field_info.metadata if field_info is not None else []
    return {bound: getattr(item, bound) for item in metadata for bound in ("gt", "ge", "lt", "le")
            if isinstance(getattr(item, bound, None), int | float)}


def supported_range(model: Any, setting: str) -> tuple[float, float] | None:
    """The values of the shared ``setting`` (one of SHARED_SETTINGS) a model class supports:
    its declaration (``supports``), for the carrier narrowed to the range of a ``carrier_hz``
    parameter (whose value the carrier is, in a run); None: any value."""
    declared = getattr(getattr(model, "supports", None), setting, None)
    low, high = declared if declared is not None else (-np.inf, np.inf)
    if setting == "carrier_hz":
        limits = parameter_limits(getattr(model, "Params", BaseModel), "carrier_hz")
        low = max([low, *(limits[b] for b in ("gt", "ge") if b in limits)])
        high = min([high, *(limits[b] for b in ("lt", "le") if b in limits)])
    return None if (low, high) == (-np.inf, np.inf) else (float(low), float(high))


SETTING_WORDS = {"carrier_hz": "carriers", "bandwidth_hz": "bandwidths",
                 "user_height_m": "user antenna heights"}


def quantity_text(setting: str, value: float) -> str:
    """A value of a shared setting as a person reads it: ``3.5 GHz``, ``20 MHz``, ``1.5 m``."""
    if setting.endswith("_m"):
        return f"{value:g} m"
    for scale, unit in ((1e9, "GHz"), (1e6, "MHz"), (1e3, "kHz")):
        if abs(value) >= scale:
            return f"{value / scale:g} {unit}"
    return f"{value:g} Hz"


def supported_text(setting: str, value_range: tuple[float, float] | None) -> str:
    """``carriers of 28 GHz only``, ``carriers from 0.1 to 100 GHz``, ``any carriers``."""
    words = SETTING_WORDS[setting]
    if value_range is None:
        return f"any {words}"
    low, high = value_range
    if low == high:
        return f"{words} of {quantity_text(setting, low)} only"
    return f"{words} from {quantity_text(setting, low)} to {quantity_text(setting, high)}"


def default_carrier_hz(model: Any) -> float:
    """f_c where a scenario gives none and the model has no ``carrier_hz`` parameter: the one
    carrier a model declares it supports, else the paper's 28 GHz."""
    declared = getattr(getattr(model, "supports", None), "carrier_hz", None)
    if declared is not None and declared[0] == declared[1]:
        return float(declared[0])
    return DEFAULT_CARRIER_HZ


def contract_version_of(model: Any) -> int | Any:
    """The contract version a model class (or instance) was written for: its
    ``contract_version``, or 1 where it declares none."""
    declared = getattr(model, "contract_version", None)
    return 1 if declared is None else declared


def db_to_linear(value_db: FloatArray | float) -> FloatArray | float:
    """10^(x/10)."""
    return 10.0 ** (np.asarray(value_db) / 10.0)


def free_space_gain(distance_m: FloatArray, carrier_hz: float) -> FloatArray:
    """Friis free-space gain (c / (4 pi f_c d))^2 (eq. 8, first factor)."""
    return (SPEED_OF_LIGHT_M_PER_S / (4 * np.pi * carrier_hz * distance_m)) ** 2
