"""Plausibility of a valid scenario: values that validate but lie far outside what UAV networks
use, most often a number given in another unit (a bandwidth of ``50`` meant as 50 MHz, a
power of ``0.1`` meant as 0.1 W). Each is one warning line naming the key, the value, the
range the field uses and the unit; the scenario still runs (docs/scenario-format.md,
"Plausible values").

The library never prints: the command line prints these lines (``adaptsky: warning: ...``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from adaptsky.scenario.models import Scenario

THERMAL_NOISE_DBM_PER_HZ = -174.0
"""kT at 290 K, dBm/Hz: the thermal noise of 1 Hz."""
NOISE_DENSITY_BELOW_KT_DB = 10.0
"""A noise density this far below kT (a receiver colder than about 29 K) is not a thermal noise."""
NOISE_DENSITY_ABOVE_KT_DB = 60.0
"""A noise density this far above kT is no receiver's noise figure (the released code's sub-6
-53 dBm over 50 MHz is 44 dB above)."""
BANDWIDTH_HZ = (1e4, 1e10)
"""The bandwidths of a cluster the field uses, Hz: 10 kHz (narrow-band IoT is 180 kHz) to
10 GHz (sub-THz links). The low end is the high end written in MHz (1e10 / 1e6), so every
plausible bandwidth given in MHz (2000 meant as 2 GHz) falls below it."""
TX_POWER_LOOKS_LIKE_WATTS_DBM = (0.0, 1.0)
"""A power strictly between these, dBm, reads as watts written where dBm belong."""


@dataclass(frozen=True)
class Plausible:
    """The values of one key the field uses: ``[low, high]`` in ``unit``, where ``value`` of
    a scenario falls; outside, one warning ending in ``hint`` (how to write the unit)."""

    key: str
    low: float
    high: float
    unit: str
    hint: str
    value: Callable[[Scenario], float]
    typed_as: tuple[float, str] | None = None
    """A unit the value is often written in by mistake: (its size in ``unit``, its name)."""

    def shown(self, value: float) -> str:
        """``value`` with its unit: ``50 Hz``, ``2 GHz``, ``0.1 dBm``, ``2000`` (a count)."""
        if self.unit == "Hz":
            return _hertz(value)
        return f"{value:g} {self.unit}".rstrip()

    def range_text(self) -> str:
        """``1 kHz .. 10 GHz``, ``-10 .. 50 dBm``."""
        if self.unit == "Hz":
            return f"{_hertz(self.low)} .. {_hertz(self.high)}"
        return f"{self.low:g} .. {self.shown(self.high)}"


def _exponent(value: float) -> str:
    """``value`` as a TOML file writes it: ``2e9``, ``5e7``, ``180000``."""
    return f"{value:g}".replace("e+", "e").replace("e0", "e")


def _hertz(value: float) -> str:
    """``50 Hz``, ``2 GHz``, ``50 MHz``."""
    for scale, unit in ((1e9, "GHz"), (1e6, "MHz"), (1e3, "kHz")):
        if abs(value) >= scale:
            return f"{value / scale:g} {unit}"
    return f"{value:g} Hz"


PLAUSIBLE: tuple[Plausible, ...] = (
    Plausible("area.side_m", 10.0, 10_000.0, "m", "the unit is m (2 km = 2000)",
              lambda s: s.area.side_m),
    Plausible("users.height_m", 0.0, 50.0, "m", "the unit is m; a handset is about 1.5 m "
              "above the ground", lambda s: s.users.height_m),
    Plausible("uav.max_height_m", 0.0, 1_000.0, "m", "the unit is m (400 ft = 122 m)",
              lambda s: s.uav.max_height_m),
    Plausible("uav.step_s", 0.01, 60.0, "s", "the unit is s (100 ms = 0.1)",
              lambda s: s.uav.step_s),
    Plausible("radio.carrier_hz", 1e8, 3e11, "Hz", "the unit is Hz (28 GHz = 28e9)",
              lambda s: s.radio.carrier_hz or math.nan),
    Plausible("radio.bandwidth_hz", *BANDWIDTH_HZ, "Hz", "the unit is Hz (50 MHz = 5e7)",
              lambda s: s.radio.bandwidth_hz, typed_as=(1e6, "MHz")),
    Plausible("radio.tx_power_dbm", -10.0, 50.0, "dBm", "the unit is dBm (1 W = 30 dBm, "
              "100 mW = 20 dBm)", lambda s: s.radio.tx_power_dbm),
    Plausible("radio.noise_figure_db", 0.0, 20.0, "dB", "the unit is dB (a figure of 5 dB "
              "adds 5 dB to the thermal noise)", lambda s: s.radio.noise_figure_db),
    Plausible("radio.antennas_uav", 1, 1024, "", "the unit is antenna elements, a count (not "
              "a gain in dB)", lambda s: s.radio.antennas_uav),
    Plausible("radio.antennas_ue", 1, 1024, "", "the unit is antenna elements, a count (not "
              "a gain in dB)", lambda s: s.radio.antennas_ue),
    Plausible("reward.min_se", 0.0, 10.0, "bit/s/Hz", "the unit is bit/s/Hz, R_min / W "
              "(100 Mbit/s over 50 MHz = 2)", lambda s: s.reward.min_se),
)
"""The keys with a plausible range (docs/scenario-format.md lists them and the rules below)."""

MAX_USER_SPEED_M_PER_S = 50.0
"""The fastest ground user the field models (180 km/h), m/s."""
USER_STEP_MAX_SHARE_OF_SIDE = 0.2
"""A user step longer than this share of the area's side crosses the area in under five steps:
no mobility model of the field moves users that far between two decisions."""
MAX_UAV_SPEED_M_PER_S = 100.0
"""The fastest UAV the field models (a fixed-wing at 360 km/h; rotary wing: 10 to 30 m/s), m/s."""


def _range_line(rule: Plausible, value: float) -> str | None:
    if math.isnan(value) or rule.low <= value <= rule.high:
        return None
    side = "below" if value < rule.low else "above"
    hint = rule.hint
    if rule.typed_as is not None and rule.low <= value * rule.typed_as[0] <= rule.high:
        scale, unit = rule.typed_as
        hint = (f"the unit is {rule.unit}: if {value:g} is in {unit}, write "
                f"{_exponent(value * scale)} ({rule.shown(value * scale)})")
    return (f"{rule.key} = {rule.shown(value)} is far {side} what UAV networks use "
            f"({rule.range_text()}); {hint}")


def _tx_power_in_watts(scenario: Scenario) -> str | None:
    power = scenario.radio.tx_power_dbm
    low, high = TX_POWER_LOOKS_LIKE_WATTS_DBM
    if not low < power < high:
        return None
    return (f"radio.tx_power_dbm = {power:g} dBm is {10 ** (power / 10):.3g} mW, which reads "
            f"as watts given as dBm; the unit is dBm ({power:g} W = "
            f"{10 * math.log10(power) + 30:.3g} dBm)")


def _noise_density(scenario: Scenario) -> str | None:
    """The thermal noise over W against kT: catches a density (dBm/Hz) or dBW given as dBm."""
    radio = scenario.radio
    low_hz, high_hz = BANDWIDTH_HZ
    if not low_hz <= radio.bandwidth_hz <= high_hz:  # the bandwidth's own line says it
        return None
    density = radio.thermal_noise_dbm - 10 * math.log10(radio.bandwidth_hz)
    low = THERMAL_NOISE_DBM_PER_HZ - NOISE_DENSITY_BELOW_KT_DB
    high = THERMAL_NOISE_DBM_PER_HZ + NOISE_DENSITY_ABOVE_KT_DB
    if low <= density <= high:
        return None
    side = "below" if density < low else "above"
    kt_dbm = THERMAL_NOISE_DBM_PER_HZ + 10 * math.log10(radio.bandwidth_hz)
    return (f"radio.thermal_noise_dbm = {radio.thermal_noise_dbm:g} dBm over "
            f"{_hertz(radio.bandwidth_hz)} is {density:.3g} dBm/Hz, far {side} what receivers "
            f"have ({low:g} .. {high:g} dBm/Hz; kT = {THERMAL_NOISE_DBM_PER_HZ:g} dBm/Hz at "
            f"290 K); the unit is dBm over the whole bandwidth W (kT over "
            f"{_hertz(radio.bandwidth_hz)} = {kt_dbm:.3g} dBm)")


def _user_speed(scenario: Scenario) -> str | None:
    per_step, step_s = scenario.users.speed_m_per_step, scenario.uav.step_s
    if per_step / step_s <= MAX_USER_SPEED_M_PER_S:
        return None
    return (f"users.speed_m_per_step = {per_step:g} m per step is {per_step / step_s:.4g} m/s "
            f"with uav.step_s = {step_s:g} s, far above what ground users move (at most "
            f"{MAX_USER_SPEED_M_PER_S:g} m/s, 180 km/h); the unit is m per step (a walk of "
            "1.4 m/s, a car of 14 m/s = 50 km/h)")


MOBILITY_SPEED_KEYS = ("speed_mps", "speed_min_mps", "speed_max_mps", "mean_speed_mps",
                       "speed_sigma_mps")
"""The speeds of ``[users.mobility]``, m/s (the model's own; the others are unset)."""


def _mobility_speed(scenario: Scenario) -> str | None:
    """The mobility model's largest speed above what ground users move (as
    :func:`_user_speed` for ``speed_m_per_step``): 90 m/s is a speed in km/h given as m/s."""
    mobility = scenario.users.mobility
    key, speed_mps = max(((key, getattr(mobility, key)) for key in MOBILITY_SPEED_KEYS
                          if getattr(mobility, key) is not None),
                         key=lambda item: item[1], default=("", 0.0))
    if speed_mps <= MAX_USER_SPEED_M_PER_S:
        return None
    return (f"users.mobility.{key} = {speed_mps:g} m/s is far above what ground users move "
            f"(at most {MAX_USER_SPEED_M_PER_S:g} m/s, 180 km/h); the unit is m/s "
            f"({speed_mps:g} km/h = {speed_mps / 3.6:.3g} m/s; a walk of 1.4 m/s, a car of "
            "14 m/s)")


def _mobility_step_in_area(scenario: Scenario) -> str | None:
    """The mobility model's fastest speed over one step crossing the area in a few steps (as
    :func:`_user_step_in_area` for ``speed_m_per_step``)."""
    mobility, step_s, side_m = scenario.users.mobility, scenario.uav.step_s, scenario.area.side_m
    speeds = {key: getattr(mobility, key) for key in ("speed_mps", "speed_max_mps",
                                                       "mean_speed_mps")}
    key, speed_mps = max(((key, value) for key, value in speeds.items() if value is not None),
                         key=lambda item: item[1], default=("", 0.0))
    per_step = speed_mps * step_s
    return _crossing(f"users.mobility.{key} = {speed_mps:g} m/s moves {per_step:.4g} m per "
                     f"step of uav.step_s = {step_s:g} s and", per_step, side_m, "m/s")


def _user_step_in_area(scenario: Scenario) -> str | None:
    """A step that crosses the area in a few steps, whatever ``uav.step_s`` says (30 m per
    step in a 100 m area: km/h or m/min written as m per step)."""
    per_step, side_m = scenario.users.speed_m_per_step, scenario.area.side_m
    return _crossing(f"users.speed_m_per_step = {per_step:g} m per step", per_step, side_m,
                     "m per step (30 km/h for 1 s = 8.3)")


def _crossing(what: str, per_step_m: float, side_m: float, unit: str) -> str | None:
    """``what`` crosses the area in a few steps: the line that says so, else None."""
    if per_step_m <= USER_STEP_MAX_SHARE_OF_SIDE * side_m:
        return None
    return (f"{what} crosses the {side_m:g} m area in {side_m / per_step_m:.2g} steps, far "
            f"above what users move between two decisions (at most "
            f"{USER_STEP_MAX_SHARE_OF_SIDE * side_m:g} m per step, a fifth of area.side_m); "
            f"the unit is {unit}")


def _uav_speed(scenario: Scenario) -> str | None:
    step_m, step_s = max(scenario.uav.step_m), scenario.uav.step_s
    if step_m / step_s <= MAX_UAV_SPEED_M_PER_S:
        return None
    return (f"uav.step_m = {step_m:g} m per step is {step_m / step_s:.4g} m/s with uav.step_s "
            f"= {step_s:g} s, far above what UAVs fly (at most {MAX_UAV_SPEED_M_PER_S:g} m/s); "
            "the unit is m per step")


RULES: tuple[Callable[[Scenario], str | None], ...] = (
    _tx_power_in_watts, _noise_density, _user_speed, _user_step_in_area,
    _mobility_speed, _mobility_step_in_area, _uav_speed)
"""Checks that combine keys or look for a unit mistake inside a plausible range."""


def plausibility_warnings(scenario: Scenario, source: str = "") -> list[str]:
    """One line per value of ``scenario`` far outside what UAV networks use, each naming the
    key, the value, the range the field uses and the unit, after ``source: `` (a file); []
    for a plausible scenario (every shipped one)."""
    lines = [_range_line(rule, float(rule.value(scenario))) for rule in PLAUSIBLE]
    lines += [rule(scenario) for rule in RULES]
    prefix = f"{source}: " if source else ""
    return [prefix + line for line in lines if line is not None]
