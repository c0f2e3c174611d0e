"""Scenario files: shipped ones, defaults, resolution, and the printed TOML."""

import tomllib

import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.toml_writer import dumps
from tests.conftest import SCENARIOS, TRAINING_LAYOUT_M

SHIPPED = sorted(SCENARIOS.glob("*.toml"))


def test_the_required_scenarios_ship():
    names = {path.name for path in SHIPPED}
    assert {"nyc_mmwave.toml", "sub6_al_hourani.toml"} <= names


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_scenario_round_trips_through_show(path):
    scenario = load_scenario(path)
    again = parse_scenario(tomllib.loads(dumps(scenario.model_dump(mode="json"))), "shown")
    assert again == scenario


def test_nyc_mmwave_is_spec_e3():
    s = load_scenario(SCENARIOS / "nyc_mmwave.toml")
    assert [tuple(p) for p in s.users.positions_m] == TRAINING_LAYOUT_M
    assert s.users.pairing == "listed"
    assert (s.radio.thermal_noise_dbm, s.radio.noise_figure_db) == (-84.0, 0.0)
    assert (s.radio.tx_power_dbm, s.radio.bandwidth_hz, s.radio.antenna_gain) == (20.0, 2e9, 64)
    assert (s.channel.model, s.channel.los) == ("mmwave-nyc", "always")
    r = s.reward
    assert (r.min_se, r.w_rate, r.w_fairness, r.w_gain, r.w_satisfied, r.w_unsatisfied) == (
        0, 10, 0, 0, 0, 0)


def test_sub6_al_hourani_is_spec_e1a():
    s = load_scenario(SCENARIOS / "sub6_al_hourani.toml")
    assert s.radio.thermal_noise_dbm == -88.0 and s.radio.antenna_gain == 1
    assert (s.channel.model, s.channel.los) == ("sub6-al-hourani", "always")
    assert (s.reward.w_rate, s.reward.w_gain) == (1.0, 1e7)
    released = load_scenario(SCENARIOS / "sub6_al_hourani_released_code.toml")
    assert released.radio.thermal_noise_dbm == -53.0


def test_defaults_are_the_papers():
    s = parse_scenario({"name": "defaults"})
    assert s.uav.start_m == [0.0, 0.0, 50.0] and s.uav.min_height_m == 10.0
    assert s.uav.step_m == [1.0, 1.0, 1.0] and s.uav.power_step == 0.01
    a = s.agent
    assert (a.hidden_sizes, a.dueling, a.gamma, a.lr, a.batch_size, a.memory_size) == (
        [128, 128], True, 0.999, 1e-3, 128, 15000)
    assert (a.epsilon_start, a.epsilon_end, a.epsilon_decay_steps,
            a.target_update_episodes) == (0.9, 0.1, 200.0, 10)
    assert (s.train.episodes, s.train.steps) == (1000, 300)
    assert s.channel.params["los_c"] == 9.6117            # plugin defaults filled in
    assert s.radio.noise_w == pytest.approx(10 ** (-84 / 10) / 1000)


def test_a_users_table_without_positions_or_count_keeps_the_training_layout():
    s = parse_scenario({"name": "u", "users": {"height_m": 1.5, "speed_m_per_step": 1.0}})
    assert s.users.positions_m == [[4.0, 15.0], [-44.0, -49.0], [-5.0, 21.0], [47.0, 49.0]]
    assert (s.users.placement, s.users.pairing, s.users.height_m) == ("listed", "listed", 1.5)


def test_uniform_placement_resolves_count_and_pairing():
    s = parse_scenario({"name": "u", "users": {"count": 8}})
    assert (s.users.placement, s.users.pairing, s.num_clusters) == ("uniform", "near-far", 4)


@pytest.mark.parametrize(("users", "message"), [
    ({"count": 4, "placement": "listed"}, "placement = 'listed' needs positions_m"),
    ({"positions_m": [[0, 0], [1, 1]], "count": 4}, "count = 4 but positions_m lists 2"),
    ({"positions_m": [[0, 0], [1, 1]], "placement": "uniform"}, "exclude each other"),
    ({"speed_m_per_step": 1.0, "placement": "uniform"}, "give positions_m, or count"),
])
def test_inconsistent_user_sections(users, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario({"name": "u", "users": users})


@pytest.mark.parametrize(("section", "message"), [
    ({"uav": {"min_height_m": 100.0, "max_height_m": 50.0, "start_m": [0, 0, 60]}},
     "must be below max_height_m"),
    ({"uav": {"start_m": [0, 0, 5]}}, "lies outside"),
    ({"uav": {"start_m": [80, 0, 50]}}, "uav.start_m"),
    ({"uav": {"step_m": [1, 0, 1]}}, "uav.step_m.1: Input should be greater than or equal to 0.01"),
    ({"agent": {"memory_size": 10}}, "must hold at least one batch"),
    ({"train": {"seeds": [1, 1]}}, "distinct"),
])
def test_inconsistent_sections(section, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario({"name": "x", **section})
