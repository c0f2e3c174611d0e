"""3GPP TR 36.777 "UMa-AV" aerial-vehicle channel (Annex B): mean path loss, and optional
lognormal shadow fading drawn every step.

Heights h and distances in m, carrier f_c in GHz inside the formulas. h is the UAV height
(``geometry.height_m``), d2D the ground distance (``geometry.horizontal_m``), d3D the 3D
distance between the antennas (``geometry.distance_m``, which counts the users' antenna height
``users.height_m``: plugin contract 2).

LoS probability, TR 36.777 Table B-1 (UMa-AV)::

    22.5 m < h <= 100 m:  d1 = max(460 log10(h) - 700, 18),  p1 = 4300 log10(h) - 3800
                          P = 1                                     if d2D <= d1
                          P = d1/d2D + exp(-d2D/p1) (1 - d1/d2D)    otherwise
    100 m < h <= 300 m:   P = 1
    h <= 22.5 m:          terrestrial TR 38.901 UMa (Table 7.4.2-1), as Table B-1 prescribes:
                          P = 1                                     if d2D <= 18
                          P = [18/d2D + exp(-d2D/63) (1 - 18/d2D)]
                              (1 + C'(h) 5/4 (d2D/100)^3 exp(-d2D/150))   otherwise
                          C'(h) = 0 for h <= 13,  ((h - 13)/10)^1.5 for 13 < h <= 22.5

    clipped to [0, 1].

Path loss, TR 36.777 Table B-2 (UMa-AV), dB::

    PL_LoS  = 28.0 + 22 log10(d3D) + 20 log10(f_c)                 (specified 22.5 < h <= 300)
    PL_NLoS = -17.5 + (46 - 7 log10(h)) log10(d3D) + 20 log10(40 pi f_c / 3)
                                                                   (specified 10 < h <= 100)
    PL_NLoS <- max(PL_NLoS, PL_LoS)    (NLoS is never better than LoS, TR 36.777)

Gain g = 10^(-PL/10): linear power gain of one antenna pair (the antenna gain is applied by
the environment).

Shadow fading, TR 36.777 Annex B (UMa-AV), with ``shadowing = true`` only: every step each
link's path loss gains X ~ N(0, sigma_SF^2) dB, so its gain is multiplied by 10^(-X/10)::

    sigma_SF LoS  = 4.64 exp(-0.0066 h)  for h > 22.5 m,  4 dB (TR 38.901 UMa) below
    sigma_SF NLoS = 6 dB

drawn independently per link and per step from the run's generator (no spatial correlation).

Validity clamps. Outside their height ranges the aerial formulas are extended, not switched:
the height h inside PL_NLoS is clamped into the NLoS validity range [10, 100] m; PL_LoS has no
height term and is used at every height (TR 36.777 refers h <= 22.5 m to the terrestrial
TR 38.901 UMa path loss, which this plugin does not implement); P_LoS = 1 also above 300 m.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from adaptsky.channels import (
    ChannelModel,
    ChannelParams,
    LinkGeometry,
    Supports,
    db_to_linear,
)

TERRESTRIAL_MAX_HEIGHT_M = 22.5
"""Table B-1: at or below this height the TR 38.901 UMa LoS probability applies, m."""
AERIAL_LOS_MAX_HEIGHT_M = 100.0
"""Table B-1: above this height every link is LoS, m."""
NLOS_MIN_HEIGHT_M = 10.0
"""Table B-2: lowest height of the UMa-AV NLoS path loss (clamp), m."""
NLOS_MAX_HEIGHT_M = 100.0
"""Table B-2: highest height of the UMa-AV NLoS path loss (clamp), m."""


SHADOWING_LOS_TERRESTRIAL_DB = 4.0
"""sigma_SF of a LoS link at h <= 22.5 m (TR 38.901 UMa), dB."""
SHADOWING_NLOS_DB = 6.0
"""sigma_SF of an NLoS link (TR 36.777 UMa-AV), dB."""


class UmaAvParams(ChannelParams):
    """TR 38.901's UMa path loss is specified for 0.5 to 100 GHz."""

    carrier_hz: float = Field(2e9, ge=0.5e9, le=100e9, description="carrier frequency f_c, Hz "
                              "(shared with the scenario's [radio] carrier_hz)")
    shadowing: bool = Field(False, description="lognormal shadow fading of TR 36.777, drawn "
                            "every step; off: the mean path loss")


def _los_probability_aerial(height_m: np.ndarray, horizontal_m: np.ndarray) -> np.ndarray:
    """Table B-1, UMa-AV, 22.5 m < h <= 100 m (h is clipped into that range; callers select)."""
    log_h = np.log10(np.clip(height_m, TERRESTRIAL_MAX_HEIGHT_M, AERIAL_LOS_MAX_HEIGHT_M))
    d1_m = np.maximum(460.0 * log_h - 700.0, 18.0)
    p1_m = 4300.0 * log_h - 3800.0
    far_m = np.maximum(horizontal_m, d1_m)  # d2D wherever the formula is used; no 0/0 at d2D = 0
    p_far = d1_m / far_m + np.exp(-far_m / p1_m) * (1.0 - d1_m / far_m)
    return np.where(horizontal_m <= d1_m, 1.0, p_far)


def _los_probability_terrestrial(height_m: np.ndarray, horizontal_m: np.ndarray) -> np.ndarray:
    """TR 38.901 Table 7.4.2-1 UMa, used by Table B-1 for h <= 22.5 m."""
    far_m = np.maximum(horizontal_m, 18.0)
    c_prime = ((np.clip(height_m, 13.0, TERRESTRIAL_MAX_HEIGHT_M) - 13.0) / 10.0) ** 1.5
    p_far = (18.0 / far_m + np.exp(-far_m / 63.0) * (1.0 - 18.0 / far_m)) * (
        1.0 + c_prime * 1.25 * (far_m / 100.0) ** 3 * np.exp(-far_m / 150.0))
    return np.where(horizontal_m <= 18.0, 1.0, p_far)


class UmaAv(ChannelModel):
    """3GPP TR 36.777 UMa-AV channel (Tables B-1 and B-2), mean path loss; see the module doc.

    Every method takes a :class:`LinkGeometry` of shape (B, N) and returns float64 (B, N).
    """

    Params = UmaAvParams
    description = "3GPP TR 36.777 UMa-AV aerial channel (Tables B-1, B-2), optional shadowing"
    contract_version = 2
    # no monotone bound: the NLoS slope 46 - 7 log10(h) falls with the height, so at a fixed
    # ground distance the NLoS gain can rise with h; the per-step searches then value every
    # lattice point (docs/plugins.md, "Monotone gains")
    supports = Supports(monotone_gains=False)
    params: UmaAvParams

    @property
    def carrier_ghz(self) -> float:
        return self.params.carrier_hz / 1e9

    def los_probability(self, geometry: LinkGeometry) -> np.ndarray:
        """P_LoS of Table B-1 (TR 38.901 UMa for h <= 22.5 m, 1 above 100 m), in [0, 1]."""
        height_m, horizontal_m = geometry.height_m, geometry.horizontal_m
        p_los = np.where(
            height_m <= TERRESTRIAL_MAX_HEIGHT_M,
            _los_probability_terrestrial(height_m, horizontal_m),
            np.where(height_m <= AERIAL_LOS_MAX_HEIGHT_M,
                     _los_probability_aerial(height_m, horizontal_m), 1.0),
        )
        return np.clip(p_los, 0.0, 1.0)

    def path_loss_los_db(self, geometry: LinkGeometry) -> np.ndarray:
        """PL_LoS of Table B-2: 28.0 + 22 log10(d3D) + 20 log10(f_c [GHz]), dB."""
        return 28.0 + 22.0 * np.log10(geometry.distance_m) + 20.0 * np.log10(self.carrier_ghz)

    def path_loss_nlos_db(self, geometry: LinkGeometry) -> np.ndarray:
        """PL_NLoS of Table B-2, h clamped into [10, 100] m, and never below PL_LoS, dB."""
        height_m = np.clip(geometry.height_m, NLOS_MIN_HEIGHT_M, NLOS_MAX_HEIGHT_M)
        pl_nlos_db = (-17.5 + (46.0 - 7.0 * np.log10(height_m)) * np.log10(geometry.distance_m)
                      + 20.0 * np.log10(40.0 * np.pi * self.carrier_ghz / 3.0))
        return np.maximum(pl_nlos_db, self.path_loss_los_db(geometry))

    def gain_los(self, geometry: LinkGeometry) -> np.ndarray:
        """10^(-PL_LoS/10), linear, one antenna pair."""
        return db_to_linear(-self.path_loss_los_db(geometry))

    def gain_nlos(self, geometry: LinkGeometry) -> np.ndarray:
        """10^(-PL_NLoS/10), linear, one antenna pair; never above :meth:`gain_los`."""
        return db_to_linear(-self.path_loss_nlos_db(geometry))

    def shadowing_std_db(self, geometry: LinkGeometry, los: np.ndarray) -> np.ndarray:
        """sigma_SF of each link (B, N), dB: 4.64 exp(-0.0066 h) LoS above 22.5 m, 4 dB LoS
        at or below, 6 dB NLoS."""
        height_m = geometry.height_m
        los_db = np.where(height_m > TERRESTRIAL_MAX_HEIGHT_M, 4.64 * np.exp(-0.0066 * height_m),
                          SHADOWING_LOS_TERRESTRIAL_DB)
        return np.where(los, los_db, SHADOWING_NLOS_DB)

    def fading_enabled(self) -> bool:
        """Shadow fading only with ``shadowing = true``."""
        return self.params.shadowing

    def sample_fading(self, geometry: LinkGeometry, los: np.ndarray,
                      rng: np.random.Generator) -> np.ndarray:
        """10^(-X/10) with X ~ N(0, sigma_SF^2) dB per link, drawn from ``rng``."""
        shadow_db = self.shadowing_std_db(geometry, los) * rng.standard_normal(geometry.shape)
        return db_to_linear(-shadow_db)
