"""Issue 35, item 7: values that validate but lie far outside what UAV networks use (most often
a wrong unit) give one warning line naming the key, the value and the unit; the scenario
still loads. Every shipped scenario and experiment is plausible."""

from __future__ import annotations

import pytest

from adaptsky.channels import registry
from adaptsky.channels.registry import PluginInfo
from adaptsky.experiment.plan import load_experiment, shipped_experiments
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.plausibility import plausibility_warnings
from tests.conftest import SCENARIOS
from tests.unit.scenario.free_space import FreeSpaceAny


def _warnings(**sections) -> list[str]:
    return plausibility_warnings(parse_scenario({"name": "odd", **sections}, "odd.toml"),
                                 "odd.toml")


# each case: sections that warn (with words the line must hold), and the same key at a value
# the field uses, which does not
CASES = {
    "bandwidth in MHz": (
        {"radio": {"bandwidth_hz": 50.0}}, {"radio": {"bandwidth_hz": 50e6}},
        ["odd.toml: radio.bandwidth_hz = 50 Hz is far below what UAV networks use "
         "(10 kHz .. 10 GHz); the unit is Hz: if 50 is in MHz, write 5e7 (50 MHz)"]),
    "bandwidth of 2 GHz in MHz": (  # issue 52, item 7: SoA then reported 26 kbit/s
        {"radio": {"bandwidth_hz": 2000.0}}, {"radio": {"bandwidth_hz": 180e3}},
        ["odd.toml: radio.bandwidth_hz = 2 kHz is far below what UAV networks use "
         "(10 kHz .. 10 GHz); the unit is Hz: if 2000 is in MHz, write 2e9 (2 GHz)"]),
    "bandwidth far below, not in MHz": (
        {"radio": {"bandwidth_hz": 1e-3}}, {"radio": {"bandwidth_hz": 1e4}},
        ["odd.toml: radio.bandwidth_hz = 0.001 Hz is far below what UAV networks use "
         "(10 kHz .. 10 GHz); the unit is Hz (50 MHz = 5e7)"]),
    "bandwidth too wide": (
        {"radio": {"bandwidth_hz": 5e10}}, {"radio": {"bandwidth_hz": 2e9}},
        ["radio.bandwidth_hz = 50 GHz is far above", "the unit is Hz"]),
    "power in watts": (
        {"radio": {"tx_power_dbm": 0.1}}, {"radio": {"tx_power_dbm": 20.0}},
        ["radio.tx_power_dbm = 0.1 dBm", "watts given as dBm", "the unit is dBm",
         "0.1 W = 20 dBm"]),
    "power far below": (
        {"radio": {"tx_power_dbm": -30.0}}, {"radio": {"tx_power_dbm": -5.0}},
        ["radio.tx_power_dbm = -30 dBm is far below", "(-10 .. 50 dBm)", "the unit is dBm"]),
    "power far above": (
        {"radio": {"tx_power_dbm": 70.0}}, {"radio": {"tx_power_dbm": 46.0}},
        ["radio.tx_power_dbm = 70 dBm is far above", "the unit is dBm"]),
    "noise density given as dBm": (
        {"radio": {"thermal_noise_dbm": -174.0}}, {"radio": {"thermal_noise_dbm": -81.0}},
        ["radio.thermal_noise_dbm = -174 dBm over 2 GHz is -267 dBm/Hz, far below",
         "the unit is dBm over the whole bandwidth W (kT over 2 GHz = -81 dBm)"]),
    "noise far above kT": (
        {"radio": {"thermal_noise_dbm": -10.0}}, {"radio": {"thermal_noise_dbm": -53.0,
                                                            "bandwidth_hz": 50e6}},
        ["radio.thermal_noise_dbm = -10 dBm over 2 GHz", "far above", "dBm/Hz"]),
    "noise figure": (
        {"radio": {"noise_figure_db": 30.0}}, {"radio": {"noise_figure_db": 5.0}},
        ["radio.noise_figure_db = 30 dB is far above", "the unit is dB"]),
    "carrier": (
        {"radio": {"carrier_hz": 5e11}, "channel": {"model": "free-space-any"}},
        {"radio": {"carrier_hz": 6e10}, "channel": {"model": "free-space-any"}},
        ["radio.carrier_hz = 500 GHz is far above", "the unit is Hz (28 GHz = 28e9)"]),
    "antennas": (
        {"radio": {"antennas_uav": 2048}}, {"radio": {"antennas_uav": 256}},
        ["radio.antennas_uav = 2048 is far above", "antenna elements"]),
    "user speed": (
        {"users": {"speed_m_per_step": 60.0}, "area": {"side_m": 2000.0}},
        {"users": {"speed_m_per_step": 30.0}, "area": {"side_m": 2000.0}},
        ["users.speed_m_per_step = 60 m per step is 60 m/s", "the unit is m per step"]),
    "user step across a small area": (
        {"users": {"speed_m_per_step": 30.0}}, {"users": {"speed_m_per_step": 8.0}},
        ["odd.toml: users.speed_m_per_step = 30 m per step crosses the 100 m area in 3.3 "
         "steps", "(at most 20 m per step, a fifth of area.side_m)",
         "the unit is m per step (30 km/h for 1 s = 8.3)"]),
    "user speed with short steps": (
        {"users": {"speed_m_per_step": 10.0}, "uav": {"step_s": 0.1}},
        {"users": {"speed_m_per_step": 1.0}, "uav": {"step_s": 0.1}},
        ["users.speed_m_per_step = 10 m per step is 100 m/s with uav.step_s = 0.1 s"]),
    "gauss-markov speed in km/h": (  # issue 52, item 7
        {"users": {"mobility": {"model": "gauss-markov", "mean_speed_mps": 90.0}},
         "area": {"side_m": 2000.0}},
        {"users": {"mobility": {"model": "gauss-markov", "mean_speed_mps": 14.0}},
         "area": {"side_m": 2000.0}},
        ["odd.toml: users.mobility.mean_speed_mps = 90 m/s is far above what ground users "
         "move (at most 50 m/s, 180 km/h); the unit is m/s (90 km/h = 25 m/s; a walk of "
         "1.4 m/s, a car of 14 m/s)"]),
    "gauss-markov speed spread": (
        {"users": {"mobility": {"model": "gauss-markov", "mean_speed_mps": 1.5,
                                "speed_sigma_mps": 60.0}}, "area": {"side_m": 2000.0}},
        {"users": {"mobility": {"model": "gauss-markov", "mean_speed_mps": 1.5,
                                "speed_sigma_mps": 3.0}}, "area": {"side_m": 2000.0}},
        ["users.mobility.speed_sigma_mps = 60 m/s is far above", "the unit is m/s"]),
    "random-waypoint speed": (
        {"users": {"mobility": {"model": "random-waypoint", "speed_min_mps": 1.0,
                                "speed_max_mps": 60.0}}, "area": {"side_m": 2000.0}},
        {"users": {"mobility": {"model": "random-waypoint", "speed_min_mps": 1.0,
                                "speed_max_mps": 30.0}}, "area": {"side_m": 2000.0}},
        ["users.mobility.speed_max_mps = 60 m/s is far above", "at most 50 m/s"]),
    "random-walk speed across a small area": (
        {"users": {"mobility": {"model": "random-walk", "speed_mps": 30.0}}},
        {"users": {"mobility": {"model": "random-walk", "speed_mps": 8.0}}},
        ["odd.toml: users.mobility.speed_mps = 30 m/s moves 30 m per step of uav.step_s = 1 s "
         "and crosses the 100 m area in 3.3 steps", "(at most 20 m per step, a fifth of "
         "area.side_m); the unit is m/s"]),
    "uav speed": (
        {"uav": {"step_m": [150.0, 1.0, 1.0]}}, {"uav": {"step_m": [20.0, 20.0, 5.0]}},
        ["uav.step_m = 150 m per step is 150 m/s", "the unit is m per step"]),
    "step duration": (
        {"uav": {"step_s": 600.0}}, {"uav": {"step_s": 0.1}},
        ["uav.step_s = 600 s is far above", "the unit is s"]),
    "area": (
        {"area": {"side_m": 50_000.0}}, {"area": {"side_m": 2000.0}},
        ["area.side_m = 50000 m is far above", "the unit is m"]),
    "uav height": (
        {"uav": {"max_height_m": 3000.0}}, {"uav": {"max_height_m": 300.0}},
        ["uav.max_height_m = 3000 m is far above", "the unit is m"]),
    "user height": (
        {"users": {"height_m": 80.0}, "uav": {"min_height_m": 100.0, "max_height_m": 200.0,
                                              "start_m": [0.0, 0.0, 150.0]}},
        {"users": {"height_m": 1.5}},
        ["users.height_m = 80 m is far above", "the unit is m"]),
    "minimum rate in Mbit/s": (
        {"reward": {"min_se": 50.0}}, {"reward": {"min_se": 3.5}},
        ["reward.min_se = 50 bit/s/Hz is far above", "the unit is bit/s/Hz"]),
}


@pytest.fixture(autouse=True)
def _any_carrier_model(monkeypatch):
    monkeypatch.setitem(registry._loaded, "free-space-any",
                        PluginInfo("free-space-any", "tests", "0", "tests:FreeSpaceAny",
                                   FreeSpaceAny))


@pytest.mark.parametrize("case", CASES)
def test_a_value_far_outside_the_field_warns_in_one_line_naming_the_unit(case):
    odd, usual, words = CASES[case]
    lines = _warnings(**odd)
    assert len(lines) == 1, lines
    assert lines[0].startswith("odd.toml: ")
    for word in words:
        assert word in lines[0]
    assert _warnings(**usual) == []


def test_the_warning_for_a_bandwidth_leaves_the_noise_to_it():
    """50 Hz with -84 dBm is one mistake, the bandwidth: one line, not a second on the
    noise density."""
    assert len(_warnings(radio={"bandwidth_hz": 50.0})) == 1


def test_a_plausible_scenario_warns_nothing_and_the_library_prints_nothing(capsys):
    assert _warnings() == []
    assert _warnings(radio={"bandwidth_hz": 50.0})
    assert capsys.readouterr() == ("", "")


def test_without_a_source_the_line_starts_with_the_key():
    scenario = parse_scenario({"name": "odd", "radio": {"bandwidth_hz": 50.0}}, "odd.toml")
    assert plausibility_warnings(scenario)[0].startswith("radio.bandwidth_hz = 50 Hz")


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_scenario_is_plausible(path):
    assert plausibility_warnings(load_scenario(path), str(path)) == []


@pytest.mark.parametrize("name", sorted(shipped_experiments()))
def test_every_shipped_experiment_trains_plausible_scenarios(name):
    from adaptsky.scenario.loading import load_scenario_with_overrides
    from adaptsky.scenario.toml_writer import toml_value
    experiment, path = load_experiment(name)
    for group in experiment.groups:
        points = [[]] if group.sweep is None else [
            [f"{group.sweep.key}={toml_value(value)}"] for value in group.sweep.values]
        for point in points:
            scenario, source = load_scenario_with_overrides(path.parent / group.scenario,
                                                            [*group.set, *point])
            assert plausibility_warnings(scenario, source) == []


def test_a_mobility_speed_warns_as_a_speed_per_step_does():
    """Issue 52, item 7: ``mean_speed_mps = 90`` in moving_users_sub6.toml (200 m, steps of
    1 s) warns as ``speed_m_per_step = 90`` does there: a speed and a step across the area."""
    from adaptsky.scenario.loading import load_scenario_with_overrides
    path = SCENARIOS / "moving_users_sub6.toml"
    fast, _ = load_scenario_with_overrides(path, ["users.mobility.mean_speed_mps=90"])
    lines = plausibility_warnings(fast)
    assert [line.split(" = ")[0] for line in lines] == ["users.mobility.mean_speed_mps"] * 2
    assert "90 m/s is far above" in lines[0] and "in 2.2 steps" in lines[1]
    older, _ = load_scenario_with_overrides(path, [
        'users.mobility={model="static"}', "users.speed_m_per_step=90"])
    assert [line.split(" = ")[0] for line in plausibility_warnings(older)] == [
        "users.speed_m_per_step"] * 2
