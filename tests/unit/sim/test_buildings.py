"""Buildings and geometric line of sight (docs/model.md §12): the city, the slab test against
hand-built boxes and a brute-force walk along the segments, the controls that keep UAVs and
users out of buildings, the channel stage's LoS or NLoS gain, and one line per refused set-up."""

from __future__ import annotations

import numpy as np
import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario import parse_scenario
from adaptsky.sim.blockage import Blockage, inside_buildings, kept_out
from adaptsky.sim.city import City, city_of, grid_footprints, on_footprints, scenario_footprints
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario

ONE_BOX = City(np.array([[10.0, 20.0, -5.0, 5.0]]), np.array([[30.0]]))
URBAN = {"area": {"side_m": 200.0}, "users": {"count": 8, "placement": "uniform"},
         "uav": {"count": 2}, "channel": {"los": "geometric"},
         "world": {"buildings": "generated", "city": "urban"}}


def _los(city: City, uav: list[float], users: list[list[float]], user_height_m: float = 0.0
         ) -> np.ndarray:
    return Blockage(city, user_height_m).los(np.array([[uav]]), np.array([users]))[0, 0]


# ---- the slab test ------------------------------------------------------------------------


def test_one_box_between_user_and_uav_blocks_until_the_uav_clears_its_roof():
    # the user at the origin, the UAV 30 m away beyond a 30 m box spanning x in [10, 20]: the
    # segment enters the box at x = 10, a third of the way, at h / 3
    assert not _los(ONE_BOX, [30.0, 0.0, 60.0], [[0.0, 0.0]])[0]
    assert not _los(ONE_BOX, [30.0, 0.0, 89.9], [[0.0, 0.0]])[0]
    assert _los(ONE_BOX, [30.0, 0.0, 90.1], [[0.0, 0.0]])[0]      # above the roof line
    # through the roof's near edge (numbers exact in binary): touching, not blocked
    box = City(np.array([[8.0, 16.0, -4.0, 4.0]]), np.array([[32.0]]))
    assert _los(box, [32.0, 0.0, 128.0], [[0.0, 0.0]])[0]
    assert not _los(box, [32.0, 0.0, 127.0], [[0.0, 0.0]])[0]


def test_touching_a_box_is_not_blocking():
    # along the wall y = 5, over the corner, and ending on the wall: no inside crossed
    assert _los(ONE_BOX, [30.0, 5.0, 20.0], [[0.0, 5.0]])[0]
    assert _los(ONE_BOX, [30.0, 25.0, 20.0], [[0.0, -5.0]])[0]      # through corner (10, 5)
    assert _los(ONE_BOX, [10.0, 0.0, 50.0], [[0.0, 0.0]])[0]
    # a box behind the user or beyond the UAV blocks nothing
    assert _los(ONE_BOX, [-30.0, 0.0, 10.0], [[0.0, 0.0]])[0]
    assert _los(ONE_BOX, [5.0, 0.0, 10.0], [[0.0, 0.0]])[0]


def test_the_antenna_height_lifts_the_segment():
    # h_UT = 10 m: the segment enters at x = 10 at 10 + (h - 10) / 3
    assert not _los(ONE_BOX, [30.0, 0.0, 69.0], [[0.0, 0.0]], user_height_m=10.0)[0]
    assert _los(ONE_BOX, [30.0, 0.0, 71.0], [[0.0, 0.0]], user_height_m=10.0)[0]
    # a roof below the antenna blocks nothing
    low = City(ONE_BOX.footprints_m, np.array([[5.0]]))
    assert _los(low, [30.0, 0.0, 11.0], [[0.0, 0.0]], user_height_m=10.0)[0]


def test_the_slab_test_agrees_with_a_walk_along_every_segment():
    rng = np.random.default_rng(3)
    footprints = grid_footprints(24.5, 44.7, rng.uniform(0, 44.7, 2), 100.0)
    city = City(footprints, rng.rayleigh(15.0, size=(2, len(footprints))))
    users = np.stack([rng.uniform(-100, 100, (12, 2)) for _ in range(2)])
    uav = np.concatenate([rng.uniform(-100, 100, (2, 10, 2)), rng.uniform(10, 80, (2, 10, 1))],
                         axis=-1)
    los = Blockage(city, 1.5).los(uav, users)
    t = np.linspace(0, 1, 4001)[1:-1, None]
    f = footprints
    for b in range(2):
        for u in range(10):
            for n in range(12):
                start, end = np.array([*users[b, n], 1.5]), uav[b, u]
                p = start + t * (end - start)
                inside = ((p[:, :1] > f[:, 0]) & (p[:, :1] < f[:, 1]) & (p[:, 1:2] > f[:, 2])
                          & (p[:, 1:2] < f[:, 3]) & (p[:, 2:] < city.heights_m[b]))
                assert los[b, u, n] == (not inside.any()), (b, u, n)


def test_boxes_off_any_grid_agree_with_a_walk_along_every_segment():
    # listed boxes of every size and place (each its own column and row, not a grid)
    rng = np.random.default_rng(5)
    centre = rng.uniform(-80, 80, (9, 2))
    size = rng.uniform(5, 30, (9, 2))
    footprints = np.column_stack([centre[:, 0] - size[:, 0], centre[:, 0] + size[:, 0],
                                  centre[:, 1] - size[:, 1], centre[:, 1] + size[:, 1]])
    city = City(footprints, rng.uniform(5, 60, (1, 9)))
    blockage = Blockage(city, 0.0)
    assert not blockage._grid
    users = rng.uniform(-100, 100, (1, 40, 2))
    users = users[:, ~on_footprints(users[0], footprints)]
    uav = np.concatenate([rng.uniform(-100, 100, (1, 6, 2)), rng.uniform(10, 90, (1, 6, 1))],
                         axis=-1)
    los = blockage.los(uav, users)
    t = np.linspace(0, 1, 4001)[1:-1, None]
    f = footprints
    for u in range(6):
        for n in range(users.shape[1]):
            start, end = np.array([*users[0, n], 0.0]), uav[0, u]
            p = start + t * (end - start)
            inside = ((p[:, :1] > f[:, 0]) & (p[:, :1] < f[:, 1]) & (p[:, 1:2] > f[:, 2])
                      & (p[:, 1:2] < f[:, 3]) & (p[:, 2:] < city.heights_m[0]))
            assert los[0, u, n] == (not inside.any()), (u, n)


def test_many_links_are_tested_in_chunks_with_the_same_answer(monkeypatch):
    rng = np.random.default_rng(4)
    footprints = grid_footprints(24.5, 44.7, rng.uniform(0, 44.7, 2), 100.0)
    city = City(footprints, rng.rayleigh(15.0, size=(6, len(footprints))))
    users = rng.uniform(-100, 100, (6, 8, 2))
    uav = np.concatenate([rng.uniform(-100, 100, (6, 3, 2)), np.full((6, 3, 1), 40.0)], -1)
    whole = Blockage(city, 0.0).los(uav, users)
    monkeypatch.setattr("adaptsky.sim.blockage.CHUNK_ELEMENTS", 1)
    monkeypatch.setattr("adaptsky.sim.blockage.MIN_ENVS", 1)     # one environment a chunk
    assert np.array_equal(Blockage(city, 0.0).los(uav, users), whole)


# ---- the city -------------------------------------------------------------------------------


def test_a_generated_city_follows_p1410s_grid():
    scenario = make_scenario(**URBAN)
    footprints = scenario_footprints(scenario)
    sides = footprints[:, 1] - footprints[:, 0]
    assert np.allclose(sides, 1000 * np.sqrt(0.3 / 500))                   # 24.5 m
    assert np.allclose(footprints[:, 3] - footprints[:, 2], sides)
    pitch = np.diff(np.unique(footprints[:, 0]))
    assert np.allclose(pitch, 1000 / np.sqrt(500))                          # 44.7 m
    # every UAV start stands in a street
    starts = np.array(scenario.uav_start_positions_m)[:, :2]
    assert not on_footprints(starts, footprints).any()


def test_a_city_per_layout_from_its_numbers():
    scenario = make_scenario(**URBAN)
    layouts = user_layouts(scenario, 3)
    city = city_of(scenario, layouts)
    again = city_of(scenario, layouts[::-1])
    assert np.array_equal(city.heights_m, again.heights_m[::-1])   # the same layout, same city
    assert not np.array_equal(city.heights_m[0], city.heights_m[1])
    assert np.array_equal(city.footprints_m, again.footprints_m)
    # heights Rayleigh(gamma): over many layouts the mean is gamma sqrt(pi / 2)
    many = city_of(scenario, user_layouts(scenario, 400)).heights_m
    assert abs(many.mean() / (15.0 * np.sqrt(np.pi / 2)) - 1) < 0.03


def test_users_stand_in_the_streets():
    scenario = make_scenario(**URBAN)
    layouts = user_layouts(scenario, 50)
    assert not on_footprints(layouts, scenario_footprints(scenario)).any()
    assert np.array_equal(layouts, user_layouts(scenario, 50))   # seeded


def test_no_generated_building_stands_on_a_listed_user():
    users = [[-64.0, 28.0], [-7.0, -26.0], [-29.0, 58.0], [81.0, -65.0], [31.0, -40.0],
             [93.0, 84.0], [27.0, 51.0], [3.0, 65.0]]
    scenario = make_scenario(**{**URBAN, "users": {"positions_m": users}})
    assert not on_footprints(np.array(users), scenario_footprints(scenario)).any()


# ---- the step ---------------------------------------------------------------------------


def test_a_move_into_a_building_does_not_happen():
    before = np.array([[[5.0, 0.0, 20.0], [0.0, 0.0, 40.0]]])
    moved = np.array([[[11.0, 0.0, 20.0], [11.0, 0.0, 40.0]]])
    kept = kept_out(before, moved, ONE_BOX)
    assert np.array_equal(kept, [[[5.0, 0.0, 20.0], [11.0, 0.0, 40.0]]])
    assert kept_out(before, before, ONE_BOX) is before
    assert inside_buildings(np.array([[[15.0, 0.0, 30.0]]]), ONE_BOX)[0, 0]   # the roof counts


def test_uavs_and_walking_users_keep_out_of_the_buildings_over_an_episode():
    scenario = make_scenario(**{**URBAN, "users": {"count": 8, "placement": "uniform",
                                                   "speed_m_per_step": 3.0},
                                "uav": {"count": 2, "start_m": [0.0, 0.0, 12.0],
                                        "step_m": [4.0, 4.0, 1.0]}})
    env = NetworkBatch(scenario, num_envs=8, seed=1)
    env.reset()
    rng = np.random.default_rng(0)
    held = 0
    for _ in range(100):
        before = env.uav_m.copy()
        _, _, _, state = env.step(rng.integers(0, env.actions.count, size=8))
        assert not inside_buildings(env.uav_m, env.city).any()
        assert not on_footprints(env.users_m, env.city.footprints_m).any()
        held += int((env.uav_m[..., :2] == before[..., :2]).all(axis=-1).sum())
    assert held > 0           # some moves were held back at a wall
    assert 0 < state.los.mean() < 1


def test_the_channel_takes_the_los_or_nlos_gain_by_the_buildings():
    scenario = make_scenario(**URBAN)
    env = NetworkBatch(scenario, num_envs=4, seed=0)
    _, state = env.reset()
    geometry = env.geometry(env.uav_m, env.layouts_m)
    los = Blockage(env.city, 0.0).los(env.uav_m, env.layouts_m)
    assert np.array_equal(geometry.los, los.reshape(geometry.shape))
    gains = np.where(geometry.los, env.channel.gain_los(geometry),
                     env.channel.gain_nlos(geometry)).reshape(4, 2, 8)
    serving = env.association.serving_uav
    expected = np.take_along_axis(gains, serving[:, None, :], axis=1)[:, 0]
    assert np.array_equal(state.gain, expected)
    assert np.array_equal(state.los, np.take_along_axis(los, serving[:, None], 1)[:, 0])
    assert np.array_equal(state.p_los, state.los.astype(float))


def test_a_fresh_layout_brings_a_new_city():
    scenario = make_scenario(**URBAN)
    env = NetworkBatch(scenario, num_envs=2, seed=0)
    heights = env.city.heights_m.copy()
    env.set_layouts(user_layouts(scenario.model_copy(update={"users": scenario.users.model_copy(
        update={"layout_seed": 9})}), 2))
    assert not np.array_equal(env.city.heights_m, heights)


def test_without_buildings_there_is_no_city():
    env = NetworkBatch(make_scenario(), num_envs=2, seed=0)
    assert env.city is None and scenario_footprints(make_scenario()) is None


# ---- refused set-ups, one line each -----------------------------------------------------


def _refused(data: dict) -> list[str]:
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "city", **data}, "city.toml")
    assert len(error.value.lines) == 1
    return error.value.lines


@pytest.mark.parametrize(("data", "words"), [
    ({"channel": {"los": "geometric"}}, "channel.los = 'geometric' needs buildings"),
    ({"world": {"buildings": "generated", "city": "urban"}},
     "world.buildings = 'generated' needs channel.los = 'geometric'"),
    ({"channel": {"los": "geometric"}, "world": {"buildings": "generated"}},
     "needs city (suburban, urban, dense-urban, high-rise) or all of"),
    ({"channel": {"los": "geometric"},
      "world": {"buildings": "generated", "city": "urban", "built_up_ratio": 0.2}},
     "give a preset or the three numbers, not both"),
    ({"world": {"city": "urban"}}, "set buildings = 'generated'"),
    ({"channel": {"los": "geometric"}, "world": {"buildings": "listed"}},
     "needs at least one [[world.building]] box"),
    ({"channel": {"los": "geometric"}, "world": {"buildings": "listed", "building": [
        {"x_m": 45.0, "y_m": 0.0, "width_m": 20.0, "depth_m": 10.0, "height_m": 30.0}]}},
     "world.building 0: x [35, 55] m, y [-5, 5] m reaches outside the area"),
    ({"channel": {"los": "geometric"}, "world": {"buildings": "listed", "building": [
        {"x_m": 0.0, "y_m": 0.0, "width_m": 20.0, "depth_m": 10.0, "height_m": 60.0}]}},
     "uav: UAV 0 starts at (0, 0, 50) inside world.building 0"),
    ({"channel": {"los": "geometric"}, "world": {"buildings": "listed", "building": [
        {"x_m": 4.0, "y_m": 15.0, "width_m": 4.0, "depth_m": 4.0, "height_m": 20.0}]}},
     "users.positions_m: user 1 at (4, 15) stands inside world.building 0"),
])
def test_each_refused_set_up_is_one_line(data, words):
    assert words in _refused(data)[0]


def test_a_listed_building_blocks_in_the_step():
    scenario = make_scenario(channel={"los": "geometric"}, world={
        "buildings": "listed", "building": [
            {"x_m": 0.0, "y_m": 30.0, "width_m": 10.0, "depth_m": 10.0, "height_m": 40.0}]})
    env = NetworkBatch(scenario, num_envs=1, seed=0)
    _, state = env.reset()       # the UAV at (0, 0, 50); user 1 at (4, 15), user 3 at (-5, 21)
    assert state.los.tolist() == [[True, True, True, True]]
    moved = env.evaluate_at(np.array([[0.0, 45.0, 50.0]]), env.alpha_first)
    assert moved.los.tolist() == [[False, True, False, True]]
