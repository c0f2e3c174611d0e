"""A world needs open ground for the users it draws (docs/scenario-format.md, [world]): the
open share of listed boxes, exact; a world with too little refused by validation in one line;
and every draw-until-valid loop of the users bounded, with one line instead of a hang, while
its numbers stay those of the unbounded loop wherever it succeeds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario.ground import open_ground_share
from adaptsky.sim.city import (
    MAX_DRAWS,
    PlacementError,
    on_footprints,
    scenario_footprints,
    street_layouts,
)
from adaptsky.sim.lattice import exploring_positions
from adaptsky.sim.layout import _misplaced, hotspot_layouts, user_layouts
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS, make_scenario
from tests.helpers.cli import one_line

WHOLE_AREA = {"x_m": 0.0, "y_m": 0.0, "width_m": 200.0, "depth_m": 200.0, "height_m": 20.0}
CITY = {"area": {"side_m": 200.0}, "users": {"count": 4, "positions_m": None,
                                             "placement": "uniform"},
        "channel": {"los": "geometric"}}


# ---- the open share ---------------------------------------------------------------------------


@pytest.mark.parametrize(("footprints", "share"), [
    ([], 1.0),
    ([[-100, 100, -100, 100]], 0.0),
    ([[-50, 50, -50, 50]], 0.75),                              # 100 x 100 of 200 x 200
    ([[-100, 0, -100, 100], [-50, 50, -100, 100]], 0.25),      # overlap counted once
    ([[50, 150, -100, 100]], 0.75),                            # the part outside left out
    ([[-100, -60, -100, 100], [-100, 100, 60, 100], [0, 20, -10, 10]], 1 - (8000 + 6400 + 400)
     / 40000),                                                 # an L and a box apart
])
def test_the_open_share_is_the_area_off_every_footprint(footprints, share):
    assert open_ground_share(footprints, 100.0) == pytest.approx(share, abs=1e-12)


# ---- validation ---------------------------------------------------------------------------------


def _refused(**sections) -> str:
    with pytest.raises(ScenarioError) as error:
        make_scenario(**sections)
    assert len(error.value.lines) == 1
    return error.value.lines[0]


def test_a_world_without_open_ground_is_refused_in_one_line():
    line = _refused(**CITY, world={"buildings": "listed", "building": [WHOLE_AREA]})
    assert line.endswith("world.building: the boxes cover 100.0% of the area, leaving 0.0% "
                         "open ground; users.placement = 'uniform' draws users in the open "
                         "ground, which needs at least 1% of the area: shrink or remove "
                         "buildings, or list the users")
    # 99.5% covered (a 200 x 199 box): refused; 98% (200 x 196): accepted
    narrow = {**WHOLE_AREA, "depth_m": 199.0, "y_m": 0.5}
    assert "leaving 0.5% open ground" in _refused(
        **CITY, world={"buildings": "listed", "building": [narrow]})
    wide = {**WHOLE_AREA, "depth_m": 196.0, "y_m": 2.0}
    assert make_scenario(**CITY, world={"buildings": "listed", "building": [wide]})
    # a generated city of built-up ratio 0.995, and the hotspots' and fresh users alike
    generated = {"buildings": "generated", "built_up_ratio": 0.995, "buildings_per_km2": 300.0,
                 "height_scale_m": 20.0}
    assert "world.built_up_ratio: 0.995 leaves 0.5% open ground" in _refused(
        **CITY, world=generated)
    for placement in ("fresh", "hotspots"):
        users = {**CITY["users"], "placement": placement}
        assert f"users.placement = '{placement}'" in _refused(
            **{**CITY, "users": users}, world={"buildings": "listed", "building": [WHOLE_AREA]})


def test_listed_users_need_no_open_ground_share():
    # two users in a 2 m street between two boxes that cover 99% of the area
    boxes = [{"x_m": -50.5, "y_m": 0.0, "width_m": 99.0, "depth_m": 200.0, "height_m": 20.0},
             {"x_m": 50.5, "y_m": 0.0, "width_m": 99.0, "depth_m": 200.0, "height_m": 20.0}]
    scenario = make_scenario(area={"side_m": 200.0}, channel={"los": "geometric"},
                             users={"positions_m": [[0.0, -40.0], [0.0, 40.0]]},
                             world={"buildings": "listed", "building": boxes})
    assert scenario.num_users == 2


def _toml(tmp_path, text_of_world: str) -> str:
    text = (SCENARIOS / "city_sub6.toml").read_text()
    text = text.replace('buildings = "generated"\ncity = "urban"', text_of_world)
    path = tmp_path / "closed.toml"
    path.write_text(text)
    return str(path)


def test_validate_and_train_refuse_the_world_in_one_line(tmp_path, capsys):
    # issue 52 item 10: city_sub6.toml with one listed building over its whole 200 m area
    path = _toml(tmp_path, 'buildings = "listed"\n\n[[world.building]]\nx_m = 0.0\ny_m = 0.0\n'
                 'width_m = 200.0\ndepth_m = 200.0\nheight_m = 20.0')
    line = (f"{path}: world.building: the boxes cover 100.0% of the area, leaving 0.0% open "
            "ground; users.placement = 'uniform' draws users in the open ground, which needs "
            "at least 1% of the area: shrink or remove buildings, or list the users")
    assert main(["scenario", "validate", path]) == 1
    assert one_line(capsys) == line
    out = tmp_path / "run.h5"
    assert main(["train", path, "--seeds", "0", "--episodes", "1", "--steps", "2",
                 "--workers", "1", "--quiet", "--out", str(out)]) == 1
    assert one_line(capsys) == line
    assert not out.exists()


# ---- the bounded draw loops ---------------------------------------------------------------------


def test_users_in_the_streets_fail_in_one_line_where_no_street_is_left():
    closed = np.array([[-100.0, 100.0, -100.0, 100.0]])
    with pytest.raises(PlacementError) as error:
        street_layouts(np.random.default_rng(0), 2, 4, 100.0, closed)
    assert str(error.value) == (f"users: 8 of 8 users found no position off the buildings in "
                                f"{MAX_DRAWS} draws each: the buildings leave 0.0% of the area "
                                "open ground (at least 1% is needed, docs/scenario-format.md)")


def test_hotspot_offsets_fail_in_one_line_where_none_lands_in_the_area():
    # a spread of 100 km around centres in a 200 m area: an offset lands in it with a chance
    # of about 6e-7 a draw
    scenario = make_scenario(area={"side_m": 200.0}, users={
        "count": 4, "positions_m": None, "placement": "hotspots", "hotspots": 1,
        "spread_m": 100_000.0})
    with pytest.raises(PlacementError) as error:
        user_layouts(scenario, 1)
    assert str(error.value) == (f"users.spread_m: 4 users found no offset from their hotspot's "
                                f"centre in the area in {MAX_DRAWS} draws each (spread_m = "
                                "100000 m, area side 200 m): make spread_m smaller or open "
                                "more ground")


def test_train_stops_in_one_line_where_the_users_cannot_be_placed(tmp_path, capsys):
    path = _toml(tmp_path, 'buildings = "generated"\ncity = "urban"')
    text = Path(path).read_text().replace('pairing = "near-far"', 'pairing = "near-far"\n'
                                          'placement = "hotspots"\nhotspots = 1\n'
                                          'spread_m = 100000.0')
    Path(path).write_text(text)
    assert main(["train", path, "--seeds", "0", "--episodes", "1", "--steps", "2",
                 "--workers", "1", "--quiet", "--out", str(tmp_path / "run.h5")]) == 1
    assert one_line(capsys).startswith("users.spread_m: 4 users found no offset from their "
                                       "hotspot's centre in the area off the buildings (")


def _unbounded_streets(rng, count, num_users, half_m, footprints_m):
    # the loop before the bound (2e5caca), as it was
    users_m = rng.uniform(-half_m, half_m, size=(count, num_users, 2))
    inside = on_footprints(users_m, footprints_m)
    while inside.any():
        users_m[inside] = rng.uniform(-half_m, half_m, size=(int(inside.sum()), 2))
        inside = on_footprints(users_m, footprints_m)
    return users_m


def test_the_bounds_change_no_number_where_the_draws_succeed():
    # a street 4 m wide (2% open): many redraws, all within the bound; the same positions,
    # bit for bit, and the generator left in the same state, as the unbounded loop
    closed = np.array([[-100.0, -2.0, -100.0, 100.0], [2.0, 100.0, -100.0, 100.0]])
    bounded, unbounded = np.random.default_rng(5), np.random.default_rng(5)
    users = street_layouts(bounded, 3, 6, 100.0, closed)
    assert np.array_equal(users, _unbounded_streets(unbounded, 3, 6, 100.0, closed))
    assert np.all(np.abs(users[..., 0]) < 2.0)
    assert bounded.random() == unbounded.random()
    # hotspots in a generated city: the offsets' loop as it was, on the same draws
    scenario = make_scenario(area={"side_m": 200.0}, channel={"los": "geometric"},
                             users={"count": 8, "positions_m": None, "placement": "hotspots",
                                    "hotspots": 2, "spread_m": 40.0},
                             world={"buildings": "generated", "city": "dense-urban"})
    footprints = scenario_footprints(scenario)
    rng = np.random.default_rng(9)
    expected = np.empty((4, 8, 2))
    for layout in expected:
        centres = _unbounded_streets(rng, 1, 2, 100.0, footprints)[0]
        layout[...] = centres[rng.integers(0, 2, size=8)]
        offsets = rng.normal(0.0, 40.0, size=layout.shape)
        redraw = _misplaced(layout + offsets, 100.0, footprints)
        while redraw.any():
            offsets[redraw] = rng.normal(0.0, 40.0, size=(int(redraw.sum()), 2))
            redraw = _misplaced(layout + offsets, 100.0, footprints)
        layout += offsets
    assert np.array_equal(hotspot_layouts(scenario, np.random.default_rng(9), 4), expected)


def test_exploring_starts_fail_in_one_line_where_no_start_keeps_the_separation():
    # two UAVs 150 m apart at least in a 200 m area: the first drawn at the centre leaves the
    # second no lattice point far enough (the corners are 141 m away); seed 1 draws it there
    scenario = make_scenario(area={"side_m": 200.0}, train={"exploring_starts": "positions"},
                             uav={"count": 2, "min_separation_m": 150.0, "step_m": [20.0, 20.0,
                                                                                    10.0],
                                  "start_positions_m": [[-80.0, 0.0, 50.0], [80.0, 0.0, 50.0]]})
    with pytest.raises(PlacementError) as error:
        exploring_positions(scenario, [np.random.default_rng(1)])
    assert str(error.value) == ("train.exploring_starts: no start for UAV 1 at least "
                                "uav.min_separation_m = 150 m from the UAVs placed before it at "
                                f"(0, 0) in {MAX_DRAWS} draws: lower min_separation_m or use "
                                "exploring_starts = 'shares'")
