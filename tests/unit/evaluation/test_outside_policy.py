"""``adaptsky.evaluate_policy``: a policy from outside adaptsky (a rule, an SB3 model) rolled
out as ``eval`` rolls out a run's policy, its eval file, and ``inspect`` of that file."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import h5py
import numpy as np
import pytest

import adaptsky
from adaptsky.envs.gym_env import NomaUavEnv
from adaptsky.errors import AdaptskyError
from adaptsky.report.episodes import eval_episodes
from adaptsky.report.eval_summary import read_eval_file
from adaptsky.scenario import load_scenario
from adaptsky.scenario.variants import eval_scenario
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

PAPER = SCENARIOS / "nyc_mmwave.toml"        # one UAV, LoS always: Discrete(32)
TWO_UAVS = SCENARIOS / "two_uavs_mmwave.toml"  # MultiDiscrete([2] * 10)
STEPS = 20


def gym_rates(act: Callable[[np.ndarray], Any], steps: int, **env_args: Any) -> np.ndarray:
    """Every user's rate (T, N) of ``act`` stepped through the Gymnasium env from
    ``reset(seed=0)`` for one episode of ``steps`` steps."""
    env = NomaUavEnv(max_episode_steps=steps, **env_args)
    obs, _ = env.reset(seed=0)
    rates, truncated = [], False
    while not truncated:
        obs, _, _, truncated, info = env.step(act(obs))
        rates.append(info["rate_bps"])
    return np.array(rates)


def toward_first_user(obs: np.ndarray) -> int:
    """A rule: move toward user 0 (dx, dy are the UAV's offsets from it), climb down, and
    shift power to the first users (digits x, y, h, alpha_1, alpha_2 of the dense index)."""
    assert obs.dtype == np.float32 and obs.shape == (17,)
    x_up, y_up = int(obs[0] < 0), int(obs[1] < 0)
    return x_up + 2 * y_up + 0 * 4 + 8 + 16


def test_sb3_ppo_policy_is_evaluated_against_soa_and_inspected(tmp_path, capsys):
    sb3 = pytest.importorskip("stable_baselines3")
    env = NomaUavEnv(PAPER, max_episode_steps=STEPS)
    model = sb3.PPO("MlpPolicy", env, n_steps=64, batch_size=32, n_epochs=1, seed=0,
                    device="cpu", policy_kwargs={"net_arch": [16]})
    model.learn(total_timesteps=128)

    def act(obs: np.ndarray) -> Any:
        return model.predict(obs, deterministic=True)[0]  # a 0-d int64 array

    out = tmp_path / "ppo-eval.h5"
    results, methods = adaptsky.evaluate_policy(act, scenario_path=PAPER, compare_with=["soa"],
                                                steps=STEPS, out=out, label="sb3-ppo")
    assert [m.name for m in methods] == ["policy", "soa"]
    assert results["policy"] == {"policy": "outside", "label": "sb3-ppo",
                                 "action_space": "discrete", "path": None}
    # the policy's rates are those of the same actions stepped through the Gymnasium env
    assert np.array_equal(methods[0].trace.rate_bps[:, 0], gym_rates(act, STEPS, scenario=PAPER))
    policy, soa = (results["methods"][name]["summary"] for name in ("policy", "soa"))
    assert np.isfinite(policy["mean_sum_rate_bps"]) and policy["mean_sum_rate_bps"] > 1e9
    assert soa["mean_sum_rate_bps"] == pytest.approx(31.77e9, rel=1e-3)  # SoA of the paper
    assert results["comparison"]["soa"]["mean_improvement_pct"] == pytest.approx(
        100 * (policy["mean_sum_rate_bps"] / soa["mean_sum_rate_bps"] - 1))

    with h5py.File(out, "r") as file:
        assert file.attrs["policy"] == "outside" and file.attrs["policy_label"] == "sb3-ppo"
        assert "checkpoint" not in file.attrs and "seed" not in file.attrs
        assert file["methods/policy/trajectory/rate_bps"].shape == (STEPS, 1, 4)
    assert main(["inspect", str(out), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert set(shown["methods"]) == {"policy", "soa"}
    assert shown["methods"]["policy"]["summary"] == pytest.approx(policy)
    assert shown["policy"]["label"] == "sb3-ppo" and "training_evaluations" not in shown
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"{out}: eval file of the outside policy 'sb3-ppo', adaptsky ")
    assert ("policy: the outside policy 'sb3-ppo', discrete actions (evaluate_policy; no run "
            "file, no training curve)") in text
    assert "greedy evaluations during training" not in text


def test_a_rule_is_evaluated_like_a_runs_policy_and_writes_no_file_without_out(tmp_path):
    results, methods = adaptsky.evaluate_policy(toward_first_user, scenario_path=PAPER,
                                                compare_with=["soa", "random"], steps=STEPS)
    assert "eval_file" not in results and not list(tmp_path.iterdir())
    rates = gym_rates(toward_first_user, STEPS, scenario=PAPER)
    assert np.array_equal(methods[0].trace.rate_bps[:, 0], rates)
    assert results["methods"]["policy"]["summary"]["mean_sum_rate_bps"] == pytest.approx(
        rates.sum(axis=1).mean())
    # the first move: x and y toward user 0 at (4, 15) from (0, 0), 1 m down
    assert methods[0].trace.uav_m[0, 0].tolist() == [1.0, 1.0, 49.0]
    assert set(results["comparison"]) == {"soa", "random"}


def test_every_layout_is_its_own_episode_of_the_env():
    seen: list[np.ndarray] = []

    def act(obs: np.ndarray) -> int:
        seen.append(obs)
        return toward_first_user(obs)

    results, methods = adaptsky.evaluate_policy(act, scenario_path=PAPER, steps=5, layouts=3,
                                                layout_seed=4)
    assert len(seen) == 3 * 5 and results["layouts"] == 3
    # the env on the same uniform layouts, paired near-far: layout i is its layout_index i
    uniform = eval_scenario(load_scenario(PAPER), 3, 4)
    for layout, users_m in enumerate(results["layouts_m"]):
        env = NomaUavEnv(uniform, layout_index=layout)
        assert np.array_equal(env.batch.users_m[0], users_m)
        rates = gym_rates(toward_first_user, 5, scenario=uniform, layout_index=layout)
        assert np.array_equal(methods[0].trace.rate_bps[:, layout], rates)


def test_several_uavs_take_multi_discrete_actions(tmp_path):
    def act(obs: np.ndarray) -> list[int]:  # a list works as the env's step takes it
        assert obs.shape == (46,)
        return [1, 0, 0, 1, 0] * 2

    out = tmp_path / "two.h5"
    results, methods = adaptsky.evaluate_policy(act, scenario_path=TWO_UAVS,
                                                compare_with=["soa"], steps=3, out=out)
    assert results["policy"]["action_space"] == "multi-discrete"
    assert np.array_equal(methods[0].trace.rate_bps[:, 0],
                          gym_rates(act, 3, scenario=TWO_UAVS))
    start_m = NomaUavEnv(TWO_UAVS).reset(seed=0)[1]["uav_m"]   # (2, 3)
    moved = methods[0].trace.uav_m[0, 0] - start_m               # every UAV: +x -y -h
    assert moved.tolist() == [[1.0, -1.0, -1.0]] * 2
    _, stored = read_eval_file(out)
    assert stored["policy"]["label"] == "outside" and stored["uavs"] == 2


def test_dense_actions_serve_several_uavs_with_action_space_discrete():
    results, methods = adaptsky.evaluate_policy(lambda obs: 0, scenario_path=TWO_UAVS, steps=2,
                                                action_space="discrete")
    assert results["policy"]["action_space"] == "discrete"
    start_m = NomaUavEnv(TWO_UAVS).reset(seed=0)[1]["uav_m"]
    assert (methods[0].trace.uav_m[0, 0] - start_m).tolist() == [[-1.0, -1.0, -1.0]] * 2


@pytest.mark.parametrize(("scenario", "action", "message"), [
    (PAPER, 32, "act returned 32 for layout 0 at step 0: not an action of the env's action "
                "space Discrete(32); give an int from 0 to 31"),
    (PAPER, 3.0, "act returned 3.0 for layout 0 at step 0: not an action of the env's action "
                 "space Discrete(32); give an int from 0 to 31"),
    (PAPER, np.array([3]), "act returned array([3]) for layout 0"),
    (TWO_UAVS, [0, 1, 2, 0, 0, 0, 0, 0, 0, 0], "give 10 integers from 0 to 1"),
    (TWO_UAVS, [0, 1], "MultiDiscrete([2 2 2 2 2 2 2 2 2 2]); give 10 integers"),
])
def test_an_action_outside_the_space_is_one_line(scenario, action, message):
    with pytest.raises(AdaptskyError) as error:
        adaptsky.evaluate_policy(lambda obs: action, scenario_path=scenario, steps=2)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_bad_inputs_are_one_line_before_any_rollout(tmp_path):
    calls: list[np.ndarray] = []
    existing = tmp_path / "there.h5"
    existing.write_bytes(b"")
    cases = [
        ({"steps": 0}, "steps: must be a whole number >= 1, got 0"),
        ({"label": ""}, "label: must be one line of 1 to 100 characters"),
        ({"out": existing}, f"out {existing}: exists; choose another out"),
        ({"out": tmp_path / "no" / "e.h5"}, f"the folder {tmp_path / 'no'} does not exist"),
        ({"out": tmp_path}, f"out {tmp_path}: is a folder"),
        ({"compare_with": ["orcale"]}, "--compare: unknown method 'orcale'"),
        ({"compare_with": ["oracle"], "scenario_path": TWO_UAVS},
         "the oracle is defined for one UAV"),
        ({"action_space": "tuple"}, "action_space 'tuple' is not supported"),
        ({"action_space": "box"}, "action_space 'box' does not fit uav.actions = 'paper'"),
        ({"scenario_path": tmp_path / "missing.toml"}, "missing.toml"),
    ]
    for arguments, message in cases:
        with pytest.raises(AdaptskyError) as error:
            adaptsky.evaluate_policy(calls.append, **({"scenario_path": PAPER, "steps": 2}
                                                      | arguments))
        assert message in str(error.value) and "\n" not in str(error.value), arguments
    with pytest.raises(AdaptskyError, match=r"^act: int is not callable; give a function"):
        adaptsky.evaluate_policy(3, scenario_path=PAPER)
    assert calls == [] and sorted(tmp_path.iterdir()) == [existing]


def test_inspect_reads_an_outside_eval_file_without_a_run(tmp_path, capsys):
    out = tmp_path / "rule.h5"
    adaptsky.evaluate_policy(toward_first_user, scenario_path=PAPER, compare_with=["soa"],
                             steps=3, out=out, label="toward user 0")
    header, results = read_eval_file(out)
    assert header["format_version"] == 1 and results["steps"] == 3
    assert results["scenario_file"] == str(PAPER.resolve())
    assert main(["inspect", str(out), "--csv", str(tmp_path / "rule.csv")]) == 0
    text = capsys.readouterr().out
    assert "eval file of the outside policy 'toward user 0'" in text
    rows = (tmp_path / "rule.csv").read_text().splitlines()
    assert [row.split(",")[:2] for row in rows[1:]] == [["policy", "0"], ["soa", "0"]]
    # show draws it under the caller's name (no seed, no episode)
    _, episodes = eval_episodes(out)
    assert episodes[0].label == "policy: the outside policy 'toward user 0', layout 0"
    assert episodes[1].label == "soa, layout 0"
