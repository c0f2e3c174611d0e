"""The channel-model plugin contract: the only module a plugin needs to import.

A plugin is a subclass of :class:`ChannelModel` with a Pydantic ``Params`` model, registered
under the entry-point group ``adaptsky.channel_models``. See ``docs/plugins.md``.

Every array method takes a :class:`LinkGeometry` of shape (B, N): B UAVs (independent
environments), N ground users, and returns float64 arrays of that shape.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict

SPEED_OF_LIGHT_M_PER_S = 299_792_458.0

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


class ChannelParams(BaseModel):
    """Base of every plugin's ``Params``: unknown keys are errors, values must be finite."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


@dataclass(frozen=True)
class LinkGeometry:
    """UAV-to-user geometry, every array of shape (B, N), users on the ground (height 0).

    horizontal_m: ground distance; height_m: UAV height (broadcast over users);
    distance_m: 3D Euclidean distance d; elevation_deg: theta = asin(h / d) in degrees.
    """

    horizontal_m: FloatArray
    height_m: FloatArray
    distance_m: FloatArray
    elevation_deg: FloatArray

    @classmethod
    def between(cls, uav_m: FloatArray, users_m: FloatArray) -> LinkGeometry:
        """Geometry of UAVs ``uav_m`` (B, 3) [x, y, h] and users ``users_m`` (B, N, 2)."""
        delta = users_m - uav_m[:, None, :2]
        height_m = np.empty_like(delta[..., 0])    # h broadcast over users, as an array
        height_m[...] = uav_m[:, 2:3]
        return cls._from_offsets(delta[..., 0], delta[..., 1], height_m)

    @classmethod
    def _from_offsets(cls, dx_m: FloatArray, dy_m: FloatArray, height_m: FloatArray
                      ) -> LinkGeometry:
        """Geometry from the ground offsets between UAV and user (either sign: only their
        sizes count) and the UAV height, each (B, N)."""
        horizontal_m = np.hypot(dx_m, dy_m)
        distance_m = np.hypot(horizontal_m, height_m)
        elevation_deg = np.degrees(np.arcsin(height_m / distance_m))
        # the frozen dataclass's __init__ sets each field through object.__setattr__; filling
        # the instance's __dict__ at once is the same object, made faster (once per step)
        geometry = object.__new__(cls)
        geometry.__dict__.update(horizontal_m=horizontal_m, height_m=height_m,
                                 distance_m=distance_m, elevation_deg=elevation_deg)
        return geometry

    @property
    def shape(self) -> tuple[int, ...]:
        return self.distance_m.shape

    def rows(self, start: int, stop: int) -> LinkGeometry:
        """The links of environments ``start:stop`` (a view)."""
        return LinkGeometry(self.horizontal_m[start:stop], self.height_m[start:stop],
                            self.distance_m[start:stop], self.elevation_deg[start:stop])


class ChannelModel(ABC):
    """Large-scale channel of one UAV-user antenna pair (sec. II-C).

    Subclasses set ``Params`` (a :class:`ChannelParams` subclass whose every field has a
    default and a description with its unit) and ``description``, and implement the three
    abstract methods. Gains are linear power gains (not dB) of one antenna pair; the antenna
    gain G = N_UAV x N_UE is applied by the environment.
    """

    Params: ClassVar[type[ChannelParams]] = ChannelParams
    description: ClassVar[str] = ""

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


def db_to_linear(value_db: FloatArray | float) -> FloatArray | float:
    """10^(x/10)."""
    return 10.0 ** (np.asarray(value_db) / 10.0)


def free_space_gain(distance_m: FloatArray, carrier_hz: float) -> FloatArray:
    """Friis free-space gain (c / (4 pi f_c d))^2 (eq. 8, first factor)."""
    return (SPEED_OF_LIGHT_M_PER_S / (4 * np.pi * carrier_hz * distance_m)) ** 2
