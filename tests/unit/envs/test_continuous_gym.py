"""Continuous actions in the Gymnasium envs (docs/environment.md, "Action kinds"): the
``actions=`` argument, the Box of every kind's adapter, check_env for one UAV and two, the
vector env, the PettingZoo env's Box per agent, and the one-line refusals."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env

import adaptsky  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky.envs.gym_env import NomaUavEnv, NomaUavVectorEnv
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from tests.conftest import SCENARIOS, make_scenario

ENV_ID = "adaptsky/NomaUav-v0"
ONE_UAV = SCENARIOS / "nyc_mmwave.toml"
TWO_UAVS = SCENARIOS / "two_uavs_mmwave.toml"
BOX_ONE = spaces.Box(-1.0, 1.0, shape=(3 + 2,), dtype=np.float32)
BOX_TWO = spaces.Box(-1.0, 1.0, shape=(2 * (3 + 2),), dtype=np.float32)


@pytest.mark.parametrize(("path", "actions", "space"), [
    (ONE_UAV, None, spaces.Discrete(32)),
    (ONE_UAV, "paper", spaces.Discrete(32)),
    (ONE_UAV, "with-hover", spaces.Discrete(243)),
    (ONE_UAV, "continuous", BOX_ONE),
    (TWO_UAVS, None, spaces.MultiDiscrete([2] * 10)),
    (TWO_UAVS, "with-hover", spaces.MultiDiscrete([3] * 10)),
    (TWO_UAVS, "continuous", BOX_TWO),
])
def test_every_action_kind_passes_check_env(path, actions, space):
    env = gymnasium.make(ENV_ID, scenario=str(path), actions=actions)
    assert env.action_space == space
    if actions is not None:
        assert env.unwrapped.scenario.uav.actions == actions
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)


def test_a_continuous_step_moves_the_uav_by_a_times_its_step():
    env = NomaUavEnv(make_scenario(uav={"step_m": [2.0, 3.0, 4.0], "power_step": 0.05}),
                     actions="continuous")
    _, info = env.reset(seed=0)
    assert info["uav_m"].tolist() == [0.0, 0.0, 50.0]
    action = np.array([0.5, -1.0, 0.25, 1.0, -0.4], dtype=np.float32)
    obs, reward, terminated, truncated, info = env.step(action)
    np.testing.assert_allclose(info["uav_m"], [1.0, -3.0, 51.0], rtol=0, atol=1e-12)
    # every user's share: cluster 1 (users 0, 1) 0.5 + 0.05, cluster 2 (users 2, 3)
    # 0.5 - 0.4 * 0.05, where -0.4 is a float32 (-0.4 + 6e-9)
    np.testing.assert_allclose(info["alpha"], [0.55, 0.45, 0.48, 0.52], rtol=0, atol=1e-9)
    assert env.observation_space.contains(obs) and np.isfinite(reward)
    assert not terminated and not truncated


def test_absolute_power_through_the_env():
    scenario = make_scenario(uav={"actions": "continuous", "power": "absolute",
                                  "power_step": 0.05})
    env = NomaUavEnv(scenario)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0, 0, 0, -1, 0.5], dtype=np.float32))
    # alpha = d + (1 - 2 d)(a + 1)/2: a = -1 -> 0.05, a = 0.5 -> 0.05 + 0.9 * 0.75
    np.testing.assert_allclose(info["alpha"], [0.05, 0.95, 0.725, 0.275], rtol=0, atol=1e-12)


def test_the_vector_env_takes_a_box_per_environment():
    envs = gymnasium.make_vec(ENV_ID, num_envs=3, scenario=str(TWO_UAVS), actions="continuous")
    assert envs.single_action_space == BOX_TWO
    assert envs.action_space == spaces.Box(-1.0, 1.0, shape=(3, 10), dtype=np.float32)
    envs.reset(seed=0)
    envs.action_space.seed(0)
    for _ in range(3):
        obs, reward, _, _, _ = envs.step(envs.action_space.sample())
        assert np.isfinite(reward).all() and envs.observation_space.contains(obs)
    assert isinstance(envs.unwrapped, NomaUavVectorEnv)


def test_the_parallel_env_gives_each_uav_its_box():
    from pettingzoo.test import parallel_api_test

    scenario = make_scenario(uav={"actions": "continuous", "count": 2,
                                  "start_positions_m": [[-25.0, 0.0, 50.0],
                                                        [25.0, 0.0, 50.0]]},
                             users={"placement": "uniform", "count": 8})
    env = NomaUavParallelEnv(scenario)
    assert env.action_space("uav_0") == env.action_space("uav_1") == BOX_ONE
    parallel_api_test(env, num_cycles=5)
    env.reset(seed=0)
    _, _, _, _, infos = env.step({"uav_0": np.array([1, 0, 0, 0, 0], dtype=np.float32),
                                  "uav_1": np.array([0, -1, 0, 0, 0], dtype=np.float32)})
    np.testing.assert_allclose(infos["uav_0"]["uav_m"], [[-24.0, 0.0, 50.0],
                                                        [25.0, -1.0, 50.0]], rtol=0, atol=0)


def test_bad_continuous_actions_and_arguments_are_one_line():
    env = NomaUavEnv(ONE_UAV, actions="continuous")
    env.reset(seed=0)
    cases = [
        (np.array([np.nan, 0, 0, 0, 0], dtype=np.float32), "got NaN or infinity"),
        (np.array([1.5, 0, 0, 0, 0], dtype=np.float32), r"must lie in \[-1, 1\]"),
        (np.zeros(4, dtype=np.float32), r"shape \(1, 5\)"),
    ]
    for action, message in cases:
        with pytest.raises(ValueError, match=message) as error:
            env.step(action)
        assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match=r"^actions 'box' is not an action kind; allowed: "
                                         r"None, 'paper', 'with-hover', 'continuous'$"):
        NomaUavEnv(ONE_UAV, actions="box")
    with pytest.raises(ValueError, match=r"^action_space 'discrete' does not fit uav.actions "
                                         r"= 'continuous'; its action spaces: 'box' \(or "
                                         r"None\)$"):
        NomaUavEnv(ONE_UAV, actions="continuous", action_space="discrete")
    absolute = make_scenario(uav={"actions": "continuous", "power": "absolute"})
    with pytest.raises(ValueError, match=r"^actions='paper': uav: power = 'absolute' needs "
                                         r"actions = 'continuous'"):
        NomaUavEnv(absolute, actions="paper")
    many = make_scenario(uav={"actions": "continuous"},
                         users={"placement": "uniform", "count": 60})
    assert NomaUavEnv(many).action_space.shape == (3 + 30,)   # no dense limit
    with pytest.raises(ValueError, match=r"^actions='paper': users: 60 users give 2\^33 "
                                         r"actions"):
        NomaUavEnv(many, actions="paper")
