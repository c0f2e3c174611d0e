"""The Gymnasium envs over several UAVs (NetworkBatch): spaces, check_env, determinism, the
MultiDiscrete and dense actions against the batch stepped directly, the native vector env."""

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import adaptsky  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky.envs.action_spaces import to_dense, to_sub_actions
from adaptsky.envs.gym_env import NomaUavEnv, NomaUavVectorEnv
from adaptsky.envs.observations import AgentView
from adaptsky.scenario import parse_scenario
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario
from tests.unit.envs.several_uavs import TWO_UAVS, two_uavs

ENV_ID = "adaptsky/NomaUav-v0"


def test_make_by_id_accepts_several_uavs():
    env = gymnasium.make(ENV_ID, scenario=str(TWO_UAVS))
    assert env.action_space == gymnasium.spaces.MultiDiscrete([2] * 10)   # 2 x (3 + 2)
    assert env.observation_space.shape == (5 * 8 + 3 * 2,)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert info["uav_m"].shape == (2, 3) and info["interference_w"].shape == (8,)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs)
    assert reward == pytest.approx(10 * info["sum_rate_bps"] / 2e9)      # w_rate 10, R_min 0
    assert not terminated and not truncated
    dense = gymnasium.make(ENV_ID, scenario=str(TWO_UAVS), action_space="discrete")
    assert dense.action_space == gymnasium.spaces.Discrete(1024)


@pytest.mark.parametrize("action_space", ["multi-discrete", "discrete"])
def test_check_env_with_several_uavs(action_space):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gymnasium.make(ENV_ID, scenario=two_uavs(), render_mode="ansi",
                                 action_space=action_space).unwrapped)


def _rollout(env, seed, steps=50):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    trace = [obs]
    for _ in range(steps):
        obs, reward, _, _, info = env.step(env.action_space.sample())
        trace += [obs, np.array([reward]), info["gain"], info["uav_m"]]
    return np.concatenate([np.ravel(t) for t in trace])


@pytest.mark.parametrize("action_space", ["multi-discrete", "discrete"])
def test_same_seed_same_rollout_bit_for_bit(action_space):
    scenario = two_uavs(steps=60, moving=True)
    first = _rollout(NomaUavEnv(scenario, action_space=action_space), seed=3)
    second = _rollout(NomaUavEnv(scenario, action_space=action_space), seed=3)
    assert np.array_equal(first, second)
    assert not np.array_equal(first, _rollout(NomaUavEnv(scenario, action_space=action_space),
                                              seed=4))


def test_multi_discrete_and_dense_actions_step_as_the_batch():
    scenario = two_uavs(steps=30, moving=True)
    multi, dense = NomaUavEnv(scenario), NomaUavEnv(scenario, action_space="discrete")
    batch = NetworkBatch(scenario, num_envs=1, view=AgentView.of(scenario))  # as the env
    action_set = ActionSet.of(scenario)
    obs = [multi.reset(seed=7)[0], dense.reset(seed=7)[0], batch.reset(seed=7)[0][0]]
    assert all(np.array_equal(o, obs[0]) for o in obs)
    rng = np.random.default_rng(0)
    for index in rng.integers(0, action_set.count, size=30):
        sub_actions = to_sub_actions(action_set, index)
        assert sub_actions.shape == (10,) and to_dense(action_set, sub_actions) == index
        got_multi, got_dense = multi.step(sub_actions), dense.step(np.int64(index))
        obs, reward, truncated, state = batch.step(np.array([index]))
        for got in (got_multi, got_dense):
            assert np.array_equal(got[0], obs[0]) and got[1] == reward[0]
            assert got[3] == truncated
            for key, value in state.for_env(0).items():
                assert np.array_equal(got[4][key], value), key
    assert truncated


def test_sub_actions_are_the_digits_of_the_dense_index():
    action_set = ActionSet(2, "with-hover", 2)
    # UAV 1 climbs (its h digit 2 = +1), everything else hovers (digit 1 = 0)
    digits = np.ones(10, dtype=np.int64)
    digits[5 + 2] = 2
    index = to_dense(action_set, digits)
    assert index == sum(3**j for j in range(10)) + 3**7
    assert action_set.decode(index).tolist() == [0] * 7 + [1, 0, 0]
    every = np.arange(action_set.count)
    assert np.array_equal(to_dense(action_set, to_sub_actions(action_set, every)), every)


def test_bad_action_spaces_and_actions_are_refused_in_one_line():
    with pytest.raises(ValueError, match=r"^action_space 'discrete': 4 UAVs have 1048576 dense "
                                         r"actions, more than 65536 \(2\^16\); use "
                                         r"action_space='multi-discrete'$"):
        NomaUavEnv(SCENARIOS / "four_uavs_mmwave.toml", action_space="discrete")
    with pytest.raises(ValueError, match=r"^action_space 'tuple' is not supported; allowed: "
                                         r"None, 'discrete', 'multi-discrete', 'box'$"):
        NomaUavEnv(two_uavs(), action_space="tuple")
    with pytest.raises(ValueError, match=r"^action_space 'box' does not fit uav.actions = "
                                         r"'paper'; its action spaces: 'discrete' or "
                                         r"'multi-discrete' \(or None\)$"):
        NomaUavEnv(two_uavs(), action_space="box")
    env = NomaUavEnv(two_uavs())
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^a MultiDiscrete action must be 10 integers, got "
                                         r"shape \(1, 3\) of int64$"):
        env.step(np.zeros(3, dtype=np.int64))
    with pytest.raises(ValueError, match=r"^every sub-action must lie in \[0, 2\)$"):
        env.step(np.full(10, 2))


def test_one_uav_multi_discrete_steps_as_its_dense_index():
    scenario = make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani",
                                                        "los": "sampled"})
    dense, multi = NomaUavEnv(scenario), NomaUavEnv(scenario, action_space="multi-discrete")
    assert dense.action_space == gymnasium.spaces.Discrete(32)
    assert multi.action_space == gymnasium.spaces.MultiDiscrete([2] * 5)
    assert np.array_equal(dense.reset(seed=1)[0], multi.reset(seed=1)[0])
    for index in (0, 31, 21, 5):
        want, got = dense.step(index), multi.step(to_sub_actions(dense.batch.actions, index))
        assert np.array_equal(want[0], got[0]) and want[1] == got[1]


def test_several_uavs_render_every_uav():
    env = NomaUavEnv(two_uavs(), render_mode="ansi")
    env.reset(seed=0)
    env.step(np.ones(10, dtype=np.int64))          # every component +1
    text = env.render()
    assert text.startswith("step 1/20  UAV 0 x=51.0 y=1.0 h=51.0 m  UAV 1 x=-49.0 y=1.0 h=51.0 m")


def test_vector_env_with_several_uavs_equals_the_sync_vector_env():
    scenario = two_uavs(steps=3, moving=True)
    native = gymnasium.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point",
                                scenario=scenario)
    assert isinstance(native, NomaUavVectorEnv)
    assert native.single_action_space == gymnasium.spaces.MultiDiscrete([2] * 10)
    sync = gymnasium.make_vec(ENV_ID, num_envs=3, vectorization_mode="sync", scenario=scenario)
    native_obs, native_info = native.reset(seed=[1, 2, 3])
    sync_obs, sync_info = sync.reset(seed=[1, 2, 3])
    assert native_obs.shape == (3, 46) and np.array_equal(native_obs, sync_obs)
    assert sorted(native_info) == sorted(sync_info)
    assert native_info["uav_m"].shape == (3, 2, 3) and native_info["_interference_w"].all()
    native.action_space.seed(0)
    for _ in range(7):      # two episodes of 3 steps and their next-step autoresets
        actions = native.action_space.sample()
        for got, want in zip(native.step(actions), sync.step(actions), strict=True):
            if isinstance(want, dict):
                assert sorted(got) == sorted(want)
                for key in want:
                    assert np.array_equal(got[key], want[key]), key
            else:
                assert np.array_equal(got, want)


def test_vector_env_with_dense_actions_of_several_uavs():
    env = NomaUavVectorEnv(two_uavs(steps=2), num_envs=2, action_space="discrete")
    assert env.single_action_space == gymnasium.spaces.Discrete(1024)
    env.reset(seed=0)
    obs, reward, _, truncated, info = env.step(np.array([0, 1023]))
    assert obs.shape == (2, 46) and reward.shape == (2,) and not truncated.any()
    assert info["uav_m"][0, 0, 2] == 49.0 and info["uav_m"][1, 0, 2] == 51.0


def test_fresh_layouts_of_several_uavs_are_drawn_and_associated_at_every_reset():
    scenario = two_uavs()
    data = scenario.model_dump(mode="json")
    data["users"] |= {"positions_m": None, "count": 8, "placement": "fresh"}
    scenario = parse_scenario(data, "fresh")
    env = NomaUavEnv(scenario)
    first = env.reset(seed=0)[0]
    layout = env.batch.layouts_m.copy()
    env.reset()
    assert not np.array_equal(env.batch.layouts_m, layout)
    assert np.bincount(env.batch.association.serving_uav[0]).tolist() == [4, 4]
    assert np.array_equal(NomaUavEnv(scenario).reset(seed=0)[0], first)
