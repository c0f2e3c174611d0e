"""The envs' ``max_episode_steps``: the time limit (default ``train.steps``), checked in one
line, and an episode of the env that equals ``eval``'s rollout of the same actions."""

from __future__ import annotations

import re

import gymnasium
import numpy as np
import pytest

import adaptsky  # noqa: F401  (registers adaptsky/NomaUav-v0)
from adaptsky.envs.gym_env import NomaUavEnv, NomaUavVectorEnv
from adaptsky.rollouts.rollout import rollout
from adaptsky.scenario import load_scenario
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario

ENV_ID = "adaptsky/NomaUav-v0"


def truncations(env: gymnasium.Env, steps: int) -> list[bool]:
    env.reset(seed=0)
    return [env.step(0)[3] for _ in range(steps)]


def test_the_time_limit_is_train_steps_by_default_or_max_episode_steps():
    scenario = make_scenario(train={"steps": 3})
    assert NomaUavEnv(scenario).max_episode_steps == 3
    assert truncations(NomaUavEnv(scenario), 3) == [False, False, True]
    longer = NomaUavEnv(scenario, max_episode_steps=np.int64(5))
    assert longer.max_episode_steps == 5 and isinstance(longer.max_episode_steps, int)
    assert truncations(longer, 5) == [False] * 4 + [True]
    with pytest.raises(RuntimeError, match="reset"):
        longer.step(0)
    assert truncations(NomaUavEnv(scenario, max_episode_steps=1), 1) == [True]


def test_make_vec_passes_it_to_the_env_make_keeps_it_for_its_time_limit():
    # gymnasium.make's max_episode_steps is Gymnasium's TimeLimit wrapper over the env's own
    # limit (docs/environment.md, "Episodes"): it can end an episode earlier, never later
    env = gymnasium.make(ENV_ID, scenario=make_scenario(train={"steps": 3}),
                         max_episode_steps=5)
    assert env.unwrapped.max_episode_steps == 3
    assert truncations(env, 3) == [False, False, True]
    shorter = gymnasium.make(ENV_ID, scenario=make_scenario(train={"steps": 3}),
                             max_episode_steps=2)
    assert truncations(shorter, 2) == [False, True]
    vec = gymnasium.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point",
                             max_episode_steps=2)
    assert isinstance(vec, NomaUavVectorEnv) and vec.max_episode_steps == 2
    vec.reset(seed=0)
    actions = np.zeros(2, dtype=np.int64)
    assert [vec.step(actions)[3].tolist() for _ in range(3)] == [
        [False, False], [True, True], [False, False]]   # the third step resets


def test_render_counts_to_max_episode_steps():
    env = NomaUavEnv(SCENARIOS / "nyc_mmwave.toml", render_mode="ansi", max_episode_steps=1000)
    env.reset(seed=0)
    env.step(0)
    assert env.render().startswith("step 1/1000  UAV")


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "300", 10**9 + 1])
def test_a_bad_max_episode_steps_is_one_line(bad):
    message = ("max_episode_steps must be a whole number from 1 to 1_000_000_000 (None: "
               f"train.steps, 300), got {bad!r}")
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        NomaUavEnv(make_scenario(), max_episode_steps=bad)
    with pytest.raises(ValueError, match=r"^max_episode_steps must be a whole number"):
        NomaUavVectorEnv(make_scenario(), num_envs=2, max_episode_steps=bad)


def test_an_episode_past_train_steps_equals_evals_rollout():
    # eval: `--steps` greedy steps from the episode start, LoS drawn from seed 0, on the
    # training layout; the env: reset(seed=0), the same actions, max_episode_steps = steps
    scenario = make_scenario(radio=SUB6_RADIO, train={"steps": 4},
                             channel={"model": "sub6-al-hourani", "los": "sampled"})
    steps, actions = 9, np.arange(9) * 7 % 32
    env = NomaUavEnv(scenario, max_episode_steps=steps)
    env.reset(seed=0)
    rates = [env.step(int(action))[4]["rate_bps"] for action in actions]
    chosen = iter(actions)
    trace = rollout(scenario, lambda obs: np.array([next(chosen)]), steps,
                    np.array([scenario.users.positions_m]))
    assert np.array_equal(trace.rate_bps[:, 0], np.array(rates))
    assert not np.array_equal(rates[0], rates[1])   # the draws differ from step to step


def test_the_default_stays_the_scenarios_train_steps():
    shipped = load_scenario(SCENARIOS / "nyc_mmwave.toml")
    assert NomaUavEnv(shipped).max_episode_steps == shipped.train.steps == 300
