"""Observations of the world (``agent.observe``; docs/environment.md, "Observations of the
world") against hand-computed examples: a LoS flag where a box stands between the UAV and a
user, a raster cell's height over that box, the users' velocities from their positions before
and after a step (in the cluster order too); the Gymnasium space follows (check_env, bounds);
nothing changes where nothing is asked; the refusals are one line each."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import adaptsky  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.envs.observations import AgentView, observation_bounds_of
from adaptsky.scenario import load_scenario
from adaptsky.scenario.variants import with_values
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario
from tests.helpers.cli import refusal_of_scenario

MAX_HEIGHT_M = 100.0
BOX = {"x_m": 15.0, "y_m": 0.0, "width_m": 4.0, "depth_m": 10.0, "height_m": 40.0}


def boxed(observe=("los", "heights"), **agent):
    """One UAV at (0, 0, 20) m over 80 m x 80 m; user 1 at (30, 0) behind a 40 m box at
    x = 13..17 m, y = -5..5 m; user 2 at (-30, 0) in the open; LoS decided by the box."""
    return make_scenario(
        area={"side_m": 80.0}, radio=SUB6_RADIO,
        channel={"model": "sub6-al-hourani", "los": "geometric"},
        world={"buildings": "listed", "building": [BOX]},
        users={"positions_m": [[30.0, 0.0], [-30.0, 0.0]], "pairing": "listed"},
        uav={"start_m": [0.0, 0.0, 20.0], "max_height_m": MAX_HEIGHT_M},
        agent={"observe": list(observe), **agent})


def test_a_los_flag_and_a_raster_cell_by_hand():
    scenario = boxed(raster_cells=3, raster_cell_m=15.0)
    env = NetworkBatch(scenario, seed=0, view=AgentView.of(scenario))
    obs, state = env.reset()
    base = 4 * 2 + 1                              # the paper's 4 N + 1
    assert obs.shape == (1, base + 2 + 9) == (1, observation_size_of(scenario))
    # the segment (0, 0, 20) -> (30, 0, h_ue) crosses x = 13..17 m at heights near 10 m,
    # under the 40 m roof: user 1 NLoS; user 2 sees the UAV
    np.testing.assert_array_equal(obs[0, base:base + 2], [0.0, 1.0])
    np.testing.assert_array_equal(obs[0, base:base + 2], state.los[0].astype(np.float32))
    # cells at x, y in {-15, 0, 15} m around the UAV, rows along y: only (y 0, x 15) is over
    # the box, 40 m of a largest height of 100 m
    raster = np.zeros(9, dtype=np.float32)
    raster[1 * 3 + 2] = np.float32(40.0 / MAX_HEIGHT_M)
    np.testing.assert_array_equal(obs[0, base + 2:], raster)
    # raw: the roof in m, the flags as they are
    raw = boxed(raster_cells=3, raster_cell_m=15.0, observation="raw")
    raw_obs, _ = NetworkBatch(raw, seed=0, view=AgentView.of(raw)).reset()
    assert raw_obs[0, base + 2 + 5] == 40.0 and raw_obs[0, base:base + 2].tolist() == [0, 1]


def test_the_velocity_is_the_last_steps_move_in_uav_steps():
    scenario = with_values(load_scenario(SCENARIOS / "moving_users_sub6.toml"), "agent",
                           {"observe": ["velocity"], "user_order": "clusters"}, "test")
    env = NetworkBatch(scenario, seed=4, view=AgentView.of(scenario))
    obs, _ = env.reset()
    num_users, width = scenario.num_users, observation_size_of(scenario)
    assert obs.shape == (1, width) and width == 4 * num_users + 1 + 2 * num_users
    assert not obs[0, -2 * num_users:].any()      # no move before the first step
    before = env.users_m[0].copy()
    order = env.association.members[0].reshape(-1)            # cluster by cluster
    obs, *_ = env.step(np.zeros(1, dtype=np.int64))
    after = env.users_m[0]
    step_m = scenario.uav.step_m[0]
    expected = []
    for i in order:                     # [v_x, v_y] of each user in the observation's order
        expected += [(after[i, 0] - before[i, 0]) / step_m, (after[i, 1] - before[i, 1]) / step_m]
    assert np.abs(expected).max() > 0
    np.testing.assert_allclose(obs[0, -2 * num_users:], expected, rtol=1e-6)


def test_nothing_asked_nothing_changes():
    scenario = boxed(observe=())
    assert AgentView.of(scenario) is None
    plain = boxed(observe=("los",))
    obs_world, _ = NetworkBatch(plain, seed=0, view=AgentView.of(plain)).reset()
    obs, _ = NetworkBatch(scenario, seed=0).reset()
    np.testing.assert_array_equal(obs_world[:, :obs.shape[1]], obs)


def test_the_gymnasium_space_holds_the_world():
    scenario = boxed(raster_cells=5, raster_cell_m=8.0)
    low, high = observation_bounds_of(scenario)
    assert low.shape == high.shape == (observation_size_of(scenario),)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gymnasium.make("adaptsky/NomaUav-v0", scenario=scenario).unwrapped
        check_env(env)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs) and obs.shape == low.shape


@pytest.mark.parametrize("body, words", [
    ('[agent]\nobserve = ["heights"]', "'heights' reads the buildings, but world.buildings"),
    ('[agent]\nobserve = ["velocity"]', "'velocity' reads the users' moves, but the users"),
    ('[agent]\nobserve = ["los", "los"]', "lists an observation twice"),
    ('[agent]\nraster_cells = 3', "agent.raster_cells given without 'heights' in agent.observe"),
    ('[agent]\nobserve = ["los"]\nraster_cell_m = 4.0\nraster_cells = 3',
     "agent.raster_cells, agent.raster_cell_m given without 'heights'"),
    ('[agent]\nobserve = ["lidar"]', "observe"),
])
def test_refusals_are_one_line(tmp_path, capsys, body, words):
    assert words in refusal_of_scenario(tmp_path, capsys, body)


def test_an_even_raster_is_refused(tmp_path, capsys):
    body = ('[world]\nbuildings = "listed"\n[[world.building]]\nx_m = 30.0\ny_m = 30.0\n'
            'width_m = 4.0\ndepth_m = 4.0\nheight_m = 10.0\n[channel]\nlos = "geometric"\n'
            'model = "sub6-al-hourani"\n[agent]\nobserve = ["heights"]\nraster_cells = 4')
    assert "raster_cells: 4 is even" in refusal_of_scenario(tmp_path, capsys, body)


def test_pettingzoo_sees_the_world_globally_and_each_uav_its_own_locally():
    """Globally every agent sees the whole observation with the world's features; locally
    each UAV sees its own users' velocities in its slots (the global ones of those users),
    after its local observation."""
    from adaptsky.envs.observations import local_user_slots
    from adaptsky.envs.parallel_env import NomaUavParallelEnv
    from adaptsky.sim.observation import local_observation_size

    scenario = with_values(load_scenario(SCENARIOS / "two_uavs_moving_mmwave.toml"), "agent",
                           {"observe": ["velocity"]}, "test")
    global_env = NomaUavParallelEnv(scenario)
    observations, _ = global_env.reset(seed=0)
    width = observation_size_of(scenario)
    assert all(obs.shape == (width,) for obs in observations.values())
    local_env = NomaUavParallelEnv(scenario, observation="local")
    local_env.reset(seed=0)
    actions = {agent: local_env.action_spaces[agent].sample() for agent in local_env.agents}
    global_env.step(actions)
    observations, *_ = local_env.step(actions)
    association = local_env.env.batch.association
    order = association.members[0].reshape(-1)           # the tuned agent's cluster order
    assert scenario.agent.user_order == "clusters"
    velocity = np.empty((scenario.num_users, 2))
    velocity[order] = global_env.state()[-2 * scenario.num_users:].reshape(-1, 2)
    assert np.abs(velocity).max() > 0
    slots = local_user_slots(association, "clusters", scenario.users_per_uav)[0]
    size = local_observation_size(scenario)
    for u, agent in enumerate(local_env.possible_agents):
        obs = observations[agent]
        assert obs.shape == (size + 2 * scenario.users_per_uav,)
        assert local_env.observation_spaces[agent].contains(obs)
        np.testing.assert_array_equal(obs[size:].reshape(-1, 2), velocity[slots[u]])
