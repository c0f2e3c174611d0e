"""Propulsion energy of a rotary-wing UAV (docs/model.md §10).

Zeng, Xu and Zhang (IEEE TWC 18(4), 2019), eq. 12, the power of level flight at speed V:

    P(V) = P0 (1 + 3 V^2 / U_tip^2) + Pi (sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2))^(1/2)
           + (1/2) d0 rho s A V^3

with P0 = (delta / 8) rho s A Omega^3 R^3 (blade profile), Pi = (1 + k) W^(3/2) / sqrt(2 rho
A) (induced) and v0 = sqrt(W / (2 rho A)) (mean rotor induced velocity in hover), and that
paper's Table I (:data:`ZENG_2019`). A step of ``uav.step_s`` seconds flies its horizontal
displacement at V = |(dx, dy)| / step_s; climbing at v_z = dh / step_s > 0 adds W v_z (the
rate of potential energy: our approximation), descending adds nothing; the transmitter adds
P_T per cluster. The energy of a step is that power times ``step_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.reward import RewardWeights

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RotaryWing:
    """An airframe's parameters (SI units) and the constants of P(V) they give."""

    weight_n: float
    air_density_kg_m3: float
    rotor_radius_m: float
    disc_area_m2: float
    blade_angular_velocity_rad_s: float
    tip_speed_m_s: float
    solidity: float
    fuselage_drag_ratio: float
    induced_correction: float
    profile_drag_coefficient: float

    @property
    def blade_profile_w(self) -> float:
        """P0 = (delta / 8) rho s A Omega^3 R^3, W."""
        return (self.profile_drag_coefficient / 8 * self.air_density_kg_m3 * self.solidity
                * self.disc_area_m2 * self.blade_angular_velocity_rad_s**3
                * self.rotor_radius_m**3)

    @property
    def induced_w(self) -> float:
        """Pi = (1 + k) W^(3/2) / sqrt(2 rho A), W."""
        return ((1 + self.induced_correction) * self.weight_n**1.5
                / math.sqrt(2 * self.air_density_kg_m3 * self.disc_area_m2))

    @property
    def hover_induced_velocity_m_s(self) -> float:
        """v0 = sqrt(W / (2 rho A)), m/s."""
        return math.sqrt(self.weight_n / (2 * self.air_density_kg_m3 * self.disc_area_m2))

    @property
    def hover_power_w(self) -> float:
        """P(0) = P0 + Pi, W."""
        return self.blade_profile_w + self.induced_w


ZENG_2019 = RotaryWing(weight_n=20.0, air_density_kg_m3=1.225, rotor_radius_m=0.4,
                       disc_area_m2=0.503, blade_angular_velocity_rad_s=300.0,
                       tip_speed_m_s=120.0, solidity=0.05, fuselage_drag_ratio=0.6,
                       induced_correction=0.1, profile_drag_coefficient=0.012)
"""Table I of Zeng, Xu and Zhang (2019): P0 = 79.86 W, Pi = 88.63 W, v0 = 4.03 m/s."""


def propulsion_power_w(speed_m_s: FloatArray | float, airframe: RotaryWing = ZENG_2019
                       ) -> FloatArray:
    """P(V), W, of level flight at horizontal speed V (m/s), elementwise (module doc)."""
    v = np.asarray(speed_m_s, dtype=np.float64)
    v2 = v * v
    v0_2 = airframe.hover_induced_velocity_m_s**2
    blade = airframe.blade_profile_w * (1 + 3 * v2 / airframe.tip_speed_m_s**2)
    induced = airframe.induced_w * np.sqrt(np.sqrt(1 + v2 * v2 / (4 * v0_2 * v0_2))
                                           - v2 / (2 * v0_2))
    parasite = (0.5 * airframe.fuselage_drag_ratio * airframe.air_density_kg_m3
                * airframe.solidity * airframe.disc_area_m2 * v2 * v)
    return blade + induced + parasite


@dataclass(frozen=True)
class StepEnergy:
    """The energy of UAVs' steps of ``step_s`` seconds with ``clusters`` transmitters of
    ``tx_power_w`` each (a number, or one per UAV broadcasting over the last axis;
    docs/model.md §10)."""

    step_s: float
    tx_power_w: float
    clusters: int | NDArray[np.integer]
    airframe: RotaryWing = ZENG_2019

    @classmethod
    def of(cls, scenario: Scenario, clusters: NDArray[np.integer] | None = None) -> StepEnergy:
        """A scenario's steps (``uav.step_s``, P_T per cluster), with K_u per UAV
        ``clusters`` (U,) where they differ (default: the scenario's equal groups)."""
        # the uplink's UAV receives: no radio power of its own (docs/model.md §17)
        return cls(scenario.uav.step_s, 0.0 if scenario.uplink else scenario.radio.tx_power_w,
                   scenario.clusters_per_uav if clusters is None else clusters)

    @property
    def hover_step_j(self) -> float:
        """P(0) step_s, J: the unit of the reward's energy term."""
        return self.airframe.hover_power_w * self.step_s

    def power_w(self, displacement_m: FloatArray) -> FloatArray:
        """Each UAV's power over a step with displacements (..., 3) [dx, dy, dh], m:
        P(V) + W max(v_z, 0) + K P_T, W."""
        d = np.asarray(displacement_m, dtype=np.float64)
        speed = np.hypot(d[..., 0], d[..., 1]) / self.step_s
        climb = np.maximum(d[..., 2], 0.0) / self.step_s
        return (propulsion_power_w(speed, self.airframe) + self.airframe.weight_n * climb
                + self.clusters * self.tx_power_w)

    def energy_j(self, displacement_m: FloatArray) -> FloatArray:
        """Each UAV's energy of a step, J: :meth:`power_w` times ``step_s``."""
        return self.power_w(displacement_m) * self.step_s


def hover_energy_j(energy: StepEnergy, shape: tuple[int, ...]) -> FloatArray:
    """The energy of a hovering step for UAVs of ``shape`` (no displacement), J."""
    return energy.energy_j(np.zeros((*shape, 3)))


class EnergyAccount:
    """The energy of every UAV's steps in B environments of a scenario (``uav.step_s``, P_T
    per cluster, :data:`ZENG_2019`) and eq. 13's energy term, - w_e E_t / (P(0) step_s),
    with E_t the step's energy summed over the UAVs; ``shape`` is (B,) for one UAV, (B, U)
    for several, ``clusters`` K_u per UAV (U,) where they differ (default: the scenario's
    equal groups)."""

    def __init__(self, scenario: Scenario, weights: RewardWeights, shape: tuple[int, ...],
                 clusters: NDArray[np.integer] | None = None) -> None:
        self.step = StepEnergy.of(scenario, clusters)
        self.hover_j = hover_energy_j(self.step, shape)
        self.hover_j.flags.writeable = False
        w_energy = np.asarray(weights.w_energy, dtype=np.float64)
        self.weighted = bool(np.any(w_energy))
        # w_e / (P(0) step_s): a number, or (B,) with each environment's weight
        self.per_joule = w_energy / self.step.hover_step_j

    def of_move(self, before_m: FloatArray, after_m: FloatArray) -> FloatArray:
        """Each UAV's energy of a step from positions ``before_m`` to ``after_m`` (..., 3),
        J."""
        return self.step.energy_j(after_m - before_m)

    def rewarded(self, rewards: FloatArray, energy_j: FloatArray) -> FloatArray:
        """Rewards (B,) with the energy term of the step's energy ``energy_j`` (B,) or
        (B, U)."""
        total = energy_j if energy_j.ndim == 1 else energy_j.sum(axis=-1)
        return rewards - self.per_joule * total

    def reward_parts(self, energy_j: FloatArray) -> FloatArray:
        """Each UAV's share of the energy term (B, U): its own energy's, - w_e E_u / (P(0)
        step_s)."""
        return -(np.asarray(self.per_joule)[..., None] * energy_j)


def energy_efficiency_bpj(sum_rate_bps: FloatArray, energy_j: FloatArray, step_s: float
                          ) -> FloatArray:
    """EE = sum_t R_tot,t step_s / sum_t E_t, bit/J, over the first (step) axis, with E_t
    summed over the UAVs already (docs/model.md §10)."""
    return sum_rate_bps.sum(axis=0) * step_s / energy_j.sum(axis=0)


def episode_energy(sum_rate_bps: FloatArray, energy_j: FloatArray, step_s: float
                   ) -> dict[str, float]:
    """An episode's energy over its T steps and every UAV (``energy_j`` (T,) or (T, U)), J,
    and its :func:`energy_efficiency_bpj` (``sum_rate_bps`` (T,))."""
    total_j = np.sum(energy_j)
    return {"energy_j": float(total_j), "energy_efficiency_bpj": float(
        energy_efficiency_bpj(np.asarray(sum_rate_bps), total_j[None], step_s))}


CONTINUOUS_SPEEDS = 1025
"""Speeds from hover to a full diagonal move at which :func:`least_power_w` looks for the
least power of continuous moves."""


def least_power_w(scenario: Scenario) -> float:
    """The least power of one UAV over a step of the scenario's actions, W: P(V) at the
    speeds its moves can have (with hover: none, one axis, both axes; the paper's: both
    axes; continuous: every speed up to both axes', on a grid of CONTINUOUS_SPEEDS) plus its
    transmitters; climbing only adds (docs/model.md §10)."""
    uav = scenario.uav
    x_m, y_m = uav.step_m[0], uav.step_m[1]
    moves_m = [[x_m, y_m, 0.0]]
    if uav.actions == "with-hover":
        moves_m += [[0.0, 0.0, 0.0], [x_m, 0.0, 0.0], [0.0, y_m, 0.0]]
    elif uav.actions == "continuous":
        moves_m += [[t * x_m, t * y_m, 0.0] for t in np.linspace(0.0, 1.0, CONTINUOUS_SPEEDS)]
    return float(StepEnergy.of(scenario).power_w(np.array(moves_m)).min())


def efficiency_bound_bpj(scenario: Scenario, best_sum_rate_bps: float) -> float:
    """The most energy efficiency a policy of one UAV can reach, bit/J: no step carries more
    than the best sum rate (the oracle's) nor costs less than :func:`least_power_w`."""
    return best_sum_rate_bps / least_power_w(scenario)
