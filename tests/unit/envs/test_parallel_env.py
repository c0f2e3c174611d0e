"""The PettingZoo ParallelEnv: the API test for several UAVs and one (every observation and
reward_split), determinism, every agent's action landing in its own UAV's components, state()
for centralised critics. The rewards per agent: test_parallel_rewards.py."""

import warnings

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import parallel_api_test

from adaptsky.envs.gym_env import NomaUavEnv
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from tests.conftest import make_scenario
from tests.unit.envs.several_uavs import two_uavs

UNEVEN = make_scenario(
    train={"steps": 10},
    users={"positions_m": [[-30.0, 10.0], [-10.0, -20.0], [-40.0, -35.0], [-5.0, 30.0],
                           [30.0, 20.0], [40.0, -10.0]],
           "association": "listed", "uav": [0, 0, 0, 0, 1, 1]},
    uav={"count": 2, "start_positions_m": [[-20.0, 0.0, 50.0], [25.0, 0.0, 50.0]]})
"""Two UAVs serving two clusters and one (groups of different sizes)."""


@pytest.mark.parametrize("scenario", [two_uavs(steps=10, moving=True),
                                      make_scenario(train={"steps": 10}), UNEVEN],
                         ids=["two-uavs", "one-uav", "uneven-groups"])
@pytest.mark.parametrize("observation", ["global", "local"])
@pytest.mark.parametrize("reward_split", ["team", "per-uav", "difference"])
def test_parallel_api_test_passes(scenario, observation, reward_split):
    env = NomaUavParallelEnv(scenario, observation=observation, reward_split=reward_split)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(env, num_cycles=30)
    assert env.agents == []                         # the episode ended by truncation


def test_each_uav_acts_on_its_own_clusters():
    env = NomaUavParallelEnv(UNEVEN)
    assert [env.action_space(agent).shape for agent in env.possible_agents] == [(5,), (4,)]


def test_agents_spaces_and_state():
    env = NomaUavParallelEnv(two_uavs(steps=2), reward_split="team")
    assert env.possible_agents == ["uav_0", "uav_1"] and env.agents == []
    assert env.metadata["is_parallelizable"] and env.render_mode is None
    for agent in env.possible_agents:
        assert env.action_space(agent) == spaces.MultiDiscrete([2] * 5)
        assert env.observation_space(agent) == env.state_space
    assert env.state_space.shape == (46,)
    observations, infos = env.reset(seed=0)
    assert env.agents == ["uav_0", "uav_1"]
    assert np.array_equal(observations["uav_0"], env.state())
    assert env.state_space.contains(env.state()) and infos["uav_1"]["uav_m"].shape == (2, 3)
    actions = {agent: env.action_space(agent).sample() for agent in env.agents}
    _, rewards, terminations, truncations, _ = env.step(actions)
    assert rewards["uav_0"] == rewards["uav_1"] and not any(terminations.values())
    assert not any(truncations.values()) and env.agents == ["uav_0", "uav_1"]
    _, _, _, truncations, _ = env.step(actions)
    assert all(truncations.values()) and env.agents == []
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(actions)


def test_bad_actions_are_refused_in_one_line():
    env = NomaUavParallelEnv(two_uavs())
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^actions must name every agent \(uav_0, uav_1\); "
                                         r"missing: uav_1, unknown: uav_7$"):
        env.step({"uav_0": np.zeros(5, dtype=np.int64), "uav_7": np.zeros(5, dtype=np.int64)})
    with pytest.raises(ValueError, match=r"^the action of uav_1 must have shape \(5,\), got "
                                         r"\(10,\)$"):
        env.step({"uav_0": np.zeros(5, dtype=np.int64), "uav_1": np.zeros(10, dtype=np.int64)})
    with pytest.raises(ValueError, match=r"^unknown agent 'uav_2'; agents: uav_0, uav_1$"):
        env.action_space("uav_2")


def _rollout(env, seed, steps=50):
    observations, _ = env.reset(seed=seed)
    for offset, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(seed + offset)
    trace = [observations["uav_0"]]
    for _ in range(steps):
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        observations, rewards, _, _, infos = env.step(actions)
        trace += [observations["uav_1"], np.array([rewards["uav_0"]]), infos["uav_0"]["gain"]]
    return np.concatenate([np.ravel(t) for t in trace])


def test_same_seed_same_rollout_bit_for_bit():
    scenario = two_uavs(steps=60, moving=True)
    first = _rollout(NomaUavParallelEnv(scenario), seed=3)
    assert np.array_equal(first, _rollout(NomaUavParallelEnv(scenario), seed=3))
    assert not np.array_equal(first, _rollout(NomaUavParallelEnv(scenario), seed=4))


@pytest.mark.parametrize("climber", [0, 1])
def test_an_agents_action_moves_only_its_own_uav(climber):
    scenario = two_uavs(actions="with-hover")        # sub-action 1 holds, 2 climbs
    env, gym_env = NomaUavParallelEnv(scenario, reward_split="team"), NomaUavEnv(scenario)
    _, infos = env.reset(seed=0)
    gym_env.reset(seed=0)
    before = infos["uav_0"]["uav_m"]
    actions = {agent: np.ones(5, dtype=np.int64) for agent in env.agents}
    actions[f"uav_{climber}"][2] = 2                  # component h of the climbing UAV
    observations, rewards, _, _, infos = env.step(actions)
    change = infos["uav_0"]["uav_m"] - before
    expected = np.zeros((2, 3))
    expected[climber, 2] = scenario.uav.step_m[2]
    assert np.array_equal(change, expected)
    assert np.array_equal(infos["uav_0"]["alpha"], np.full(8, 0.5))      # no share moved
    # the joint action is the Gymnasium env's MultiDiscrete action, UAV 0's components first
    joint = np.concatenate([actions["uav_0"], actions["uav_1"]])
    obs, reward, _, _, _ = gym_env.step(joint)
    assert np.array_equal(observations["uav_1"], obs) and rewards["uav_0"] == reward
