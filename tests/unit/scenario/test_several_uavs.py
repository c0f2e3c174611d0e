"""The scenario keys of several UAVs (docs/model.md §9): defaults that leave every shipped
one-UAV scenario as it was, and one line for each set-up that cannot work."""

from __future__ import annotations

import math

import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.toml_writer import dumps
from tests.conftest import SCENARIOS

ADDED = {"uav": {"count": 1, "start_positions_m": None, "min_separation_m": 10.0},
         "users": {"association": "kmeans", "uav": None}, "radio": {"reuse": "full"}}
EIGHT_USERS = {"positions_m": [[-40.0, -40.0], [-30.0, -45.0], [-45.0, 30.0], [-35.0, 40.0],
                               [40.0, 40.0], [30.0, 45.0], [45.0, -30.0], [35.0, -40.0]]}


def _refused(data: dict) -> list[str]:
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "uavs", **data}, "uavs.toml")
    return error.value.lines


ONE_UAV_SCENARIOS = [path for path in sorted(SCENARIOS.glob("*.toml"))
                     if load_scenario(path).uav.count == 1 and "200m" not in path.name]


@pytest.mark.parametrize("path", ONE_UAV_SCENARIOS, ids=lambda p: p.name)
def test_shipped_scenarios_get_the_new_keys_at_their_defaults_and_nothing_else(path):
    scenario = load_scenario(path)
    dumped = scenario.model_dump(mode="json")
    for section, keys in ADDED.items():
        assert {key: dumped[section][key] for key in keys} == keys
    assert scenario.uav_start_positions_m == [scenario.uav.start_m]
    # the file's text validates to the same scenario written without the added keys
    without = {section: {k: v for k, v in values.items() if k not in ADDED.get(section, {})}
               if isinstance(values, dict) else values for section, values in dumped.items()}
    assert parse_scenario(without, "again").model_dump(mode="json") == dumped


def test_default_start_positions_lie_evenly_on_the_circle_of_radius_l_over_4():
    scenario = parse_scenario({"name": "four", "area": {"side_m": 200.0},
                               "users": {"count": 16, "placement": "uniform"},
                               "uav": {"count": 4, "start_m": [0.0, 0.0, 60.0]}}, "four")
    starts = scenario.uav_start_positions_m
    assert len(starts) == 4
    for u, (x, y, h) in enumerate(starts):
        assert math.hypot(x, y) == pytest.approx(50.0)
        assert math.atan2(y, x) % (2 * math.pi) == pytest.approx(2 * math.pi * u / 4, abs=1e-12)
        assert h == 60.0


def test_listed_start_positions_and_association_read_back_from_their_toml():
    data = {"name": "two", "users": {**EIGHT_USERS, "uav": [0, 0, 0, 0, 1, 1, 1, 1]},
            "uav": {"count": 2, "start_positions_m": [[-20.0, 0.0, 50.0], [20.0, 0.0, 40.0]],
                    "min_separation_m": 5.0},
            "radio": {"reuse": "orthogonal"}}
    scenario = parse_scenario(data, "two")
    assert scenario.users.association == "listed"
    assert scenario.uav_start_positions_m == [[-20.0, 0.0, 50.0], [20.0, 0.0, 40.0]]
    import tomllib
    again = parse_scenario(tomllib.loads(dumps(scenario.model_dump(mode="json"))), "again")
    assert again == scenario


def test_one_uav_given_as_start_positions_is_the_start_position():
    scenario = parse_scenario({"name": "one", "uav": {"start_positions_m": [[3.0, 4.0, 30.0]]}},
                              "one")
    assert scenario.uav.start_m == [3.0, 4.0, 30.0]
    again = parse_scenario(scenario.model_dump(mode="json"), "again")   # both keys, equal
    assert again == scenario


@pytest.mark.parametrize(("data", "line"), [
    ({"uav": {"count": 3}},
     "uavs.toml: uav.count: 3 UAVs for 2 NOMA pairs; every UAV needs at least one pair"),
    ({"users": {"count": 12, "placement": "uniform"}, "uav": {"count": 4}},
     "uavs.toml: users.association: 12 users do not split into 4 equal groups of an even "
     "size; choose N divisible by 2 U, or association = 'listed' with users.uav"),
    ({"users": {"count": 6, "placement": "uniform"}, "uav": {"count": 2}},
     "uavs.toml: users.association: 6 users do not split into 2 equal groups of an even "
     "size; choose N divisible by 2 U, or association = 'listed' with users.uav"),
    ({"users": {**EIGHT_USERS, "uav": [0, 0, 1, 1]}, "uav": {"count": 2}},
     "uavs.toml: users.uav: lists 4 UAVs for 8 users; give one serving UAV per user"),
    ({"users": {**EIGHT_USERS, "uav": [0, 0, 0, 1, 1, 1, 1, 1]}, "uav": {"count": 2}},
     "uavs.toml: users.uav: group sizes [3, 5] for UAVs 0..1; every UAV serves an even number "
     ">= 2 of users"),
    ({"users": {**EIGHT_USERS, "uav": [0, 0, 0, 0, 2, 2, 2, 2]}, "uav": {"count": 2}},
     "uavs.toml: users.uav: UAV 2 serves users 5, 6, 7 and 8 (users counted from 1), but "
     "uav.count = 2 numbers the UAVs 0 to 1 (0-based); give every user one of them, or raise "
     "uav.count"),
    ({"users": {**EIGHT_USERS, "uav": [0, 0, 5, 5, 1, 1, 3, 0]}, "uav": {"count": 2}},
     "uavs.toml: users.uav: UAV 3 serves user 7; UAV 5 serves users 3 and 4 (users counted "
     "from 1), but uav.count = 2 numbers the UAVs 0 to 1 (0-based); give every user "
     "one of them, or raise uav.count"),
    ({"users": {**EIGHT_USERS, "association": "listed"}, "uav": {"count": 2}},
     "uavs.toml: users: association = 'listed' and uav: a list of serving UAVs goes with "
     "association = 'listed', and only with it"),
    ({"users": {**EIGHT_USERS, "association": "kmeans", "uav": [0] * 8}},
     "uavs.toml: users: association = 'kmeans' and uav: a list of serving UAVs goes with "
     "association = 'listed', and only with it"),
    ({"users": EIGHT_USERS, "uav": {"count": 2, "start_positions_m": [[0.0, 0.0, 50.0],
                                                                      [6.0, 8.0, 80.0]]}},
     "uavs.toml: uav.start_positions_m: UAVs 0 and 1 start 10 m apart, closer than "
     "uav.min_separation_m = 10.5 m"),
    ({"users": EIGHT_USERS, "uav": {"count": 2, "start_positions_m": [[0.0, 0.0, 50.0],
                                                                      [60.0, 0.0, 50.0]]}},
     "uavs.toml: uav.start_positions_m: UAV 1 at (60, 0) lies outside the area |x|, |y| <= "
     "50 m"),
    ({"users": EIGHT_USERS, "uav": {"count": 2, "start_positions_m": [[0.0, 0.0, 50.0]]}},
     "uavs.toml: uav: start_positions_m lists 1 positions for count = 2 UAVs; give one "
     "[x, y, h] per UAV"),
    ({"users": EIGHT_USERS, "uav": {"count": 2, "start_positions_m": [[0.0, 0.0, 50.0],
                                                                      [30.0, 0.0, 5.0]]}},
     "uavs.toml: uav: start_positions_m: UAV 1 at height 5.0 m lies outside [10.0, 200.0] m"),
    ({"uav": {"start_m": [1.0, 0.0, 50.0], "start_positions_m": [[0.0, 0.0, 50.0]]}},
     "uavs.toml: uav: start_m [1.0, 0.0, 50.0] and start_positions_m [0.0, 0.0, 50.0] differ; "
     "give one of them"),
    ({"users": EIGHT_USERS, "uav": {"count": 2, "start_m": [5.0, 0.0, 50.0]}},
     "uavs.toml: uav: start_m (5, 0) places one UAV; for count = 2 give start_positions_m "
     "(start_m sets only the height of the default circle)"),
    ({"users": {"count": 16, "placement": "uniform"}, "area": {"side_m": 20.0},
      "uav": {"count": 4, "min_height_m": 10.0}},
     "uavs.toml: uav.start_positions_m: UAVs 0 and 1 start 7.071 m apart, closer than "
     "uav.min_separation_m = 10 m"),
    ({"radio": {"reuse": "partial"}},
     "uavs.toml: radio.reuse: Input should be 'full' or 'orthogonal' (got 'partial')"),
    ({"uav": {"count": 0}},
     "uavs.toml: uav.count: Input should be greater than or equal to 1 (got 0)"),
])
def test_what_cannot_work_is_refused_in_one_line(data, line):
    if "10.5 m" in line:
        data = {**data, "uav": {**data["uav"], "min_separation_m": 10.5}}
    assert _refused(data) == [line]
