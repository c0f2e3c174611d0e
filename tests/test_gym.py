"""Gymnasium API: registration, check_env, determinism, the native vector env."""

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import adaptsky_cli  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky_cli.env.gym_env import NomaUavEnv, NomaUavVectorEnv
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario

INFO_SHAPES = {"uav_m": (3,), "alpha": (4,), "gain": (4,), "los": (4,), "rate_bps": (4,)}


def test_make_by_id_with_a_scenario_path():
    env = gymnasium.make("adaptsky/NomaUav-v0", scenario=str(SCENARIOS / "nyc_mmwave.toml"))
    obs, info = env.reset(seed=0)
    assert obs.shape == (17,)
    assert env.action_space.n == 32
    _, reward, terminated, truncated, info = env.step(0)
    for key, shape in INFO_SHAPES.items():
        assert np.shape(info[key]) == shape
    assert info["los"].dtype == bool
    assert isinstance(info["sum_rate_bps"], float) and isinstance(info["fairness"], float)
    assert info["sum_rate_bps"] == pytest.approx(info["rate_bps"].sum())
    assert reward == pytest.approx(10 * info["sum_rate_bps"] / 2e9)    # w_rate 10, R_min 0
    assert not terminated and not truncated


@pytest.mark.parametrize("los", ["always", "sampled", "expected"])
def test_check_env(los):
    scenario = make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani", "los": los},
                             train={"steps": 20})
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*infinity.*")   # scaled gains are unbounded
        check_env(NomaUavEnv(scenario), skip_render_check=True)


def _rollout(env, seed, steps=25):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    trace = [obs]
    for _ in range(steps):
        obs, reward, _, _, info = env.step(env.action_space.sample())
        trace += [obs, np.array([reward]), info["gain"]]
    return np.concatenate([np.ravel(t) for t in trace])


def test_two_envs_same_seed_identical_rollouts():
    scenario = make_scenario(radio=SUB6_RADIO,
                             channel={"model": "sub6-al-hourani", "los": "sampled"})
    first = _rollout(NomaUavEnv(scenario), seed=3)
    second = _rollout(NomaUavEnv(scenario), seed=3)
    assert np.array_equal(first, second)
    assert not np.array_equal(first, _rollout(NomaUavEnv(scenario), seed=4))


def test_stepping_past_the_time_limit_needs_a_reset():
    env = NomaUavEnv(make_scenario(train={"steps": 2}))
    env.reset(seed=0)
    assert env.step(0)[3] is False and env.step(0)[3] is True
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)


def test_vector_env_over_uniform_layouts_autoresets_next_step():
    scenario = make_scenario(users={"positions_m": None, "count": 4}, train={"steps": 2})
    env = gymnasium.make_vec("adaptsky/NomaUav-v0", num_envs=6,
                             vectorization_mode="vector_entry_point", scenario=scenario)
    assert isinstance(env, NomaUavVectorEnv)
    obs, info = env.reset(seed=0)
    assert obs.shape == (6, 17) and info["rate_bps"].shape == (6, 4)
    assert len({tuple(row) for row in obs}) == 6          # six different layouts
    actions = np.zeros(6, dtype=np.int64)
    assert not env.step(actions)[3].any()
    assert env.step(actions)[3].all()                      # truncated together
    reset_obs, reward, _, truncated, _ = env.step(actions)
    assert np.array_equal(reset_obs, obs) and not reward.any() and not truncated.any()
