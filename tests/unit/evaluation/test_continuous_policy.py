"""Continuous actions end to end: Stable-Baselines3's SAC trains on ``adaptsky/NomaUav-v0``
with ``actions="continuous"`` as it is (no wrappers beyond SB3's own), and
``adaptsky.evaluate_policy`` rolls its policy out beside the baselines, as the env steps it."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
import pytest

import adaptsky
from adaptsky.envs.gym_env import NomaUavEnv
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario
from adaptsky.training.resources import check_fits
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

STEPS = 20


@pytest.fixture
def continuous_file(tmp_path):
    """The paper's scenario with continuous actions, as a file."""
    text = (SCENARIOS / "nyc_mmwave.toml").read_text()
    assert 'actions = "paper"' in text
    path = tmp_path / "continuous.toml"
    path.write_text(text.replace('actions = "paper"', 'actions = "continuous"'))
    return path


def test_sac_trains_on_the_continuous_env_and_is_evaluated(continuous_file, tmp_path):
    sb3 = pytest.importorskip("stable_baselines3")
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        env = gymnasium.make("adaptsky/NomaUav-v0", scenario=str(continuous_file))
        assert env.action_space == gymnasium.spaces.Box(-1.0, 1.0, (5,), np.float32)
        model = sb3.SAC("MlpPolicy", env, learning_starts=100, batch_size=32,
                        buffer_size=1000, seed=0, device="cpu",
                        policy_kwargs={"net_arch": [32, 32]})
        model.learn(total_timesteps=300)
    finally:
        torch.set_num_threads(threads)

    def act(obs: np.ndarray) -> Any:
        return model.predict(obs, deterministic=True)[0]     # (5,) float32 in [-1, 1]

    out = tmp_path / "sac-eval.h5"
    results, methods = adaptsky.evaluate_policy(act, scenario_path=continuous_file,
                                                compare_with=["soa", "random"], steps=STEPS,
                                                out=out, label="sb3-sac")
    assert results["policy"]["action_space"] == "box"
    assert [m.name for m in methods] == ["policy", "soa", "random"]
    for name in ("policy", "random"):
        summary = results["methods"][name]["summary"]
        assert np.isfinite(summary["mean_sum_rate_bps"]) and summary["mean_sum_rate_bps"] > 1e9
    # the policy's rates are those of its actions stepped through the Gymnasium env
    gym_env = NomaUavEnv(continuous_file, max_episode_steps=STEPS)
    obs, _ = gym_env.reset(seed=0)
    rates, rewards, truncated = [], [], False
    while not truncated:
        obs, reward, _, truncated, info = gym_env.step(act(obs))
        rates.append(info["rate_bps"])
        rewards.append(reward)
    assert np.array_equal(methods[0].trace.rate_bps[:, 0], np.array(rates))
    assert np.isfinite(rewards).all()
    assert main(["inspect", str(out), "--json"]) == 0


def test_actions_outside_the_box_are_refused_by_evaluate_policy(continuous_file):
    with pytest.raises(adaptsky.AdaptskyError, match=r"not an action of the env's action "
                                                     r"space .*; give 5 numbers in \[-1, 1\]"):
        adaptsky.evaluate_policy(lambda obs: np.full(5, np.nan), scenario_path=continuous_file,
                                 steps=2)


@pytest.mark.parametrize("algorithm", ["dqn", "bdq"])
def test_the_learners_refuse_continuous_actions_in_one_line(continuous_file, algorithm,
                                                           capsys):
    text = continuous_file.read_text()
    if algorithm == "bdq":
        continuous_file.write_text(f'{text}\n[agent]\nalgorithm = "bdq"\n')
    scenario = load_scenario(continuous_file)
    assert scenario.agent.algorithm == algorithm
    expected = (f"{continuous_file}: uav.actions: agent.algorithm '{algorithm}' learns "
                f"'paper' or 'with-hover' actions, not 'continuous'; for 'continuous' choose "
                f"agent.algorithm 'ppo', 'sac'")
    with pytest.raises(ScenarioError) as error:
        check_fits(scenario, str(continuous_file))
    assert error.value.lines == [expected]
    for command in (["scenario", "validate"], ["train", "--quiet", "--episodes", "1"]):
        assert main([*command, str(continuous_file)]) == 1
        assert capsys.readouterr().err.strip() == expected
    # the resolved scenario is still shown
    assert main(["scenario", "show", str(continuous_file)]) == 0
    shown = capsys.readouterr().out
    assert 'actions = "continuous"' in shown and 'power = "change"' in shown
