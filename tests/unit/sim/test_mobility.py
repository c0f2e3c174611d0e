"""Users that move (docs/model.md §3): random waypoint and Gauss-Markov against their
definitions with fixed seeds and stated tolerances, the random walk of [users.mobility] as the
older one, users out of buildings, and one line for a bad [users.mobility] table."""

import math

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.scenario import parse_scenario
from adaptsky.sim.city import on_footprints
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario

HALF_M = 50.0
WAYPOINT = {"model": "random-waypoint", "speed_min_mps": 1.0, "speed_max_mps": 4.0,
            "pause_max_s": 6.0}


def _walk(mobility, steps, envs=4, seed=0, **sections):
    """Every user's position at every step (steps + 1, B, N, 2), the start first."""
    scenario = make_scenario(users={"count": 8, "positions_m": None, "mobility": mobility},
                             area={"side_m": 2 * HALF_M}, **sections)
    env = NetworkBatch(scenario, envs, seed=seed)
    env.reset()
    track = [env.users_m.copy()]
    for _ in range(steps):
        env.step(np.zeros(envs, dtype=int))
        track.append(env.users_m.copy())
    return np.array(track), env


def test_random_waypoint_users_stay_in_the_area_at_speeds_in_the_range_and_pause():
    track, _ = _walk(WAYPOINT, 600)
    assert np.all(np.abs(track) <= HALF_M)
    speed = np.hypot(*np.moveaxis(np.diff(track, axis=0), -1, 0))       # m per 1 s step
    moving = speed > 1e-12
    # a step either walks at the leg's speed, or ends on the destination (shorter), or stands
    assert speed.max() <= 4.0 + 1e-9
    assert np.mean(speed[moving] < 1.0 - 1e-9) < 0.2      # the shorter steps: arrivals
    # every user paused at some point (a run of standing steps) and walked at some point
    standing = ~moving
    assert standing.any(axis=0).all() and moving.any(axis=0).all()
    # the speeds of whole steps spread over [1, 4] m/s: mean of a uniform leg speed ~ 2.5
    whole = speed[moving & (speed >= 1.0 - 1e-9)]
    assert whole.min() >= 1.0 - 1e-9 and whole.max() <= 4.0 + 1e-9
    assert abs(whole.mean() - 2.5) < 0.4


def test_gauss_markov_speed_converges_to_its_mean_with_lag_one_autocorrelation_a():
    # tolerances: 64 x 8 users x 3000 steps; the mean speed's standard error is about
    # 0.5 / sqrt(512 x 3000 x (1 - a) / (1 + a)) = 0.001, its autocorrelation's about 0.002
    memory, mean, sigma = 0.8, 1.5, 0.5
    scenario = make_scenario(users={"count": 8, "positions_m": None, "mobility": {
        "model": "gauss-markov", "mean_speed_mps": mean, "memory": memory,
        "speed_sigma_mps": sigma, "heading_sigma_deg": 20.0}}, area={"side_m": 2 * HALF_M})
    env = NetworkBatch(scenario, 64, seed=3)
    env.reset()
    speeds = []
    for _ in range(3000):
        env.step(np.zeros(64, dtype=int))
        speeds.append(env._mobility.speed_mps.copy())
    speeds = np.array(speeds)[200:]                       # past the start at s_0 = mean
    assert abs(speeds.mean() - mean) < 0.02
    assert abs(speeds.std() - sigma) < 0.02
    centred = speeds - speeds.mean()
    lag1 = (centred[1:] * centred[:-1]).mean() / centred.var()
    assert abs(lag1 - memory) < 0.02


def test_gauss_markov_users_reflect_at_the_edge():
    # memory 1, no noise: straight lines at 3 m/s; every user stays in the area and some
    # come back from an edge (a mirrored heading)
    track, _ = _walk({"model": "gauss-markov", "mean_speed_mps": 3.0, "memory": 1.0}, 200)
    assert np.all(np.abs(track) <= HALF_M + 1e-9)
    step = np.diff(track, axis=0)
    assert np.allclose(np.hypot(step[..., 0], step[..., 1])[np.all(
        np.abs(track[1:]) < HALF_M - 3.0, axis=-1) & np.all(np.abs(track[:-1]) < HALF_M - 3.0,
                                                           axis=-1)], 3.0)
    turned = np.sign(step[1:, ..., 0]) * np.sign(step[:-1, ..., 0]) < 0
    assert turned.any()


@pytest.mark.parametrize("mobility", [
    WAYPOINT, {"model": "gauss-markov", "mean_speed_mps": 2.0, "speed_sigma_mps": 0.5,
               "heading_sigma_deg": 30.0}])
def test_no_user_ever_stands_inside_a_building(mobility):
    track, env = _walk(mobility, 400, envs=8, channel={"model": "sub6-al-hourani",
                                                        "los": "geometric"},
                       world={"buildings": "generated", "city": "urban"},
                       radio={"carrier_hz": 2e9})
    assert env.city is not None and env.city.count > 5
    assert not on_footprints(track, env.city.footprints_m).any()
    assert np.abs(np.diff(track, axis=0)).max() > 0       # and they do move


def test_the_random_walk_of_users_mobility_is_the_older_one():
    scenario_old = make_scenario(users={"count": 8, "positions_m": None,
                                        "speed_m_per_step": 2.5}, area={"side_m": 100.0})
    scenario_new = make_scenario(users={"count": 8, "positions_m": None, "mobility": {
        "model": "random-walk", "speed_mps": 1.25}}, area={"side_m": 100.0},
        uav={"step_s": 2.0})
    tracks = []
    for scenario in (scenario_old, scenario_new):
        env = NetworkBatch(scenario, 3, seed=7)
        env.reset()
        track = []
        for _ in range(30):
            env.step(np.zeros(3, dtype=int))
            track.append(env.users_m.copy())
        tracks.append(np.array(track))
    assert np.array_equal(tracks[0], tracks[1])
    assert np.abs(np.diff(tracks[0], axis=0)).max() > 0


def test_the_same_seed_gives_the_same_tracks_and_an_environment_its_own():
    scenario = make_scenario(users={"count": 8, "positions_m": None, "mobility": WAYPOINT},
                             area={"side_m": 2 * HALF_M})
    layout = NetworkBatch(scenario, 1).users_m

    def tracks(seeds):
        env = NetworkBatch(scenario, len(seeds), seed=seeds,
                           users_m=np.repeat(layout, len(seeds), axis=0))
        env.reset()
        track = []
        for _ in range(40):
            env.step(np.zeros(len(seeds), dtype=int))
            track.append(env.users_m.copy())
        return np.array(track)

    first = tracks([11, 12, 13])
    assert np.array_equal(first, tracks([11, 12, 13]))
    assert np.array_equal(first[:, 1], tracks([12])[:, 0])   # its numbers do not depend on B
    assert not np.array_equal(first[:, 0], first[:, 1])


@pytest.mark.parametrize(("mobility", "message"), [
    ({"model": "static", "speed_mps": 1.0}, "speed_mps given with model = 'static'"),
    ({"model": "random-waypoint", "speed_min_mps": 1.0}, "needs speed_max_mps"),
    ({"model": "random-waypoint", "speed_min_mps": 3.0, "speed_max_mps": 1.0},
     "speed_min_mps = 3 exceeds speed_max_mps = 1"),
    ({"model": "gauss-markov", "mean_speed_mps": 1.0, "memory": 1.5}, "memory"),
    ({"model": "random-walk"}, "needs speed_mps"),
    ({"model": "sprint"}, "model"),
])
def test_a_bad_mobility_table_is_one_line(mobility, message):
    with pytest.raises(AdaptskyError, match=message):
        parse_scenario({"name": "t", "users": {"count": 4, "mobility": mobility}}, "t.toml")


def test_the_older_walk_and_a_mobility_model_exclude_each_other():
    with pytest.raises(AdaptskyError, match="exclude each other"):
        parse_scenario({"name": "t", "users": {"count": 4, "speed_m_per_step": 1.0,
                                               "mobility": WAYPOINT}}, "t.toml")


def test_moving_users_are_refused_by_the_searches():
    from adaptsky.references.registry import resolve
    scenario = make_scenario(users={"count": 4, "positions_m": None, "mobility": WAYPOINT})
    with pytest.raises(AdaptskyError, match="users"):
        resolve("oma", scenario)
    assert math.isfinite(scenario.users.mobility.pause_max_s)
