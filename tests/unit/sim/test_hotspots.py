"""Clustered users (``users.placement = "hotspots"``, docs/model.md §3): around their centres
with the stated spread, in the area and out of buildings, and one line for keys that go with
hotspots only."""

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.scenario import parse_scenario
from adaptsky.sim.city import on_footprints, scenario_footprints
from adaptsky.sim.layout import user_layouts
from tests.conftest import make_scenario


def test_one_hotspot_spreads_its_users_by_spread_m():
    # 40 users around one centre in a 2 km area: the deviation of their positions along x and
    # y is spread_m = 8 m, within 25% (40 samples, fixed seed: a fixed number)
    scenario = make_scenario(users={"count": 40, "positions_m": None, "placement": "hotspots",
                                    "hotspots": 1, "spread_m": 8.0}, area={"side_m": 2000.0})
    layouts = user_layouts(scenario, 5, layout_seed=3)
    deviations = layouts.std(axis=1)                       # (5, 2): x and y per layout
    assert np.all(np.abs(deviations - 8.0) < 2.0)
    # five layouts, five centres: far apart in a 2 km area
    centres = layouts.mean(axis=1)
    assert np.min(np.ptp(centres, axis=0)) > 100.0


def test_hotspot_users_stay_in_the_area_and_in_the_streets():
    scenario = make_scenario(users={"count": 16, "positions_m": None, "placement": "hotspots",
                                    "hotspots": 2, "spread_m": 30.0},
                             area={"side_m": 200.0},
                             channel={"model": "sub6-al-hourani", "los": "geometric"},
                             world={"buildings": "generated", "city": "dense-urban"},
                             radio={"carrier_hz": 2e9})
    layouts = user_layouts(scenario, 20)
    assert np.all(np.abs(layouts) <= 100.0)
    assert not on_footprints(layouts, scenario_footprints(scenario)).any()
    assert np.array_equal(layouts, user_layouts(scenario, 20))


@pytest.mark.parametrize(("users", "message"), [
    ({"count": 4, "spread_m": 5.0}, "spread_m given with placement = 'uniform'"),
    ({"count": 4, "placement": "fresh", "hotspots": 2}, "hotspots given with placement"),
    ({"count": 4, "placement": "hotspots", "hotspots": 0}, "hotspots"),
])
def test_hotspot_keys_go_with_hotspots_only(users, message):
    with pytest.raises(AdaptskyError, match=message):
        parse_scenario({"name": "t", "users": users}, "t.toml")


def test_hotspots_take_their_defaults():
    scenario = make_scenario(users={"count": 4, "positions_m": None, "placement": "hotspots"})
    assert (scenario.users.hotspots, scenario.users.spread_m) == (3, 10.0)
