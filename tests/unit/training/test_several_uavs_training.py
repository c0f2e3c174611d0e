"""Training with several UAVs (docs/model.md §9): a BDQ over every UAV's components (a seed
in a stack equals the seed alone: tests/contract/test_learners.py), resumed bit for bit
(curves, weights, greedy evaluations and the best policy), greedy evaluations against best
response on the training layout, and a run file that stores every UAV's position and opens
for inspect."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from adaptsky.rollouts.several_uavs import best_response
from adaptsky.scenario import parse_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.layout import user_layouts
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from adaptsky.training.evaluation import evaluation_set
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.helpers.gpu import assert_graphs_replay_eager, cuda
from tests.helpers.training import (
    assert_same_curves,
    assert_same_results,
    curves,
)

TWO_UAVS = {
    "name": "two_small",
    "area": {"side_m": 20.0},
    "users": {"positions_m": [[-8.0, 6.0], [-3.0, -7.0], [-9.0, -2.0], [-5.0, 8.0],
                              [7.0, 5.0], [9.0, -8.0], [4.0, -1.0], [8.0, 9.0]],
              "pairing": "near-far"},
    "uav": {"count": 2, "start_m": [0.0, 0.0, 15.0], "min_height_m": 10.0,
            "max_height_m": 20.0},
    "reward": {"w_rate": 10.0},
    "agent": {"algorithm": "bdq", "hidden_sizes": [16, 16], "batch_size": 16,
              "memory_size": 200, "target_update_episodes": 2, "user_order": "clusters"},
    "train": {"steps": 10, "eval_every": 1, "eval_steps": 30},
}


SPLITS = ["team", "per-uav", "difference"]


def _with_split(split: str, exploring_starts: str = "none") -> dict:
    return {**TWO_UAVS, "agent": {**TWO_UAVS["agent"], "reward_split": split},
            "train": {**TWO_UAVS["train"], "exploring_starts": exploring_starts}}


def _scenario_file(tmp_path: Path, split: str = "team", exploring_starts: str = "none"
                   ) -> Path:
    path = tmp_path / "two_small.toml"
    path.write_text(dumps(_with_split(split, exploring_starts)))
    return path


@pytest.mark.parametrize(("split", "exploring_starts"),
                         [(split, "none") for split in SPLITS] + [("difference", "shares")])
def test_resume_equals_the_uninterrupted_run_and_evaluations_use_best_response(
        tmp_path, split, exploring_starts):
    args = {"scenario_path": _scenario_file(tmp_path, split, exploring_starts),
            "seeds": [0, 1], "workers": 1, "quiet": True}
    first, _ = api.train(out=tmp_path / "a.h5", episodes=4, **args)
    resumed, _ = api.train(out=tmp_path / "r.h5", episodes=2, **args)
    assert main(["train", "--resume", str(resumed), "--episodes", "4", "--workers", "1",
                 "--quiet"]) == 0
    assert_same_curves(curves(resumed), curves(first))
    scenario = parse_scenario(_with_split(split), "two")
    values = 1 if split == "team" else 2
    reference = best_response(scenario, user_layouts(scenario, 1)).objective_bps[0]
    with RunReader(first) as a, RunReader(resumed) as b:
        for seed in (0, 1):
            checkpoint = a.checkpoint(seed)
            for name, value in checkpoint["agent"]["policy"].items():
                assert np.array_equal(value, b.checkpoint(seed)["agent"]["policy"][name])
            # a value per UAV, and the replay keeps each UAV's part of every reward
            assert checkpoint["agent"]["policy"]["value.weight"].shape == (values, 16)
            stored = checkpoint["replay"]["rewards"]
            assert stored.shape == ((40, 2) if values == 2 else (40,))
            assert np.array_equal(stored, b.checkpoint(seed)["replay"]["rewards"])
            if split == "per-uav":  # the last episode's rows: its parts add up to its rewards
                np.testing.assert_allclose(stored[-10:].sum(axis=-1),
                                           a.trajectory(seed)["reward"], rtol=1e-6)
            evaluations = a.evaluations(seed)
            for name, value in evaluations.items():
                assert np.array_equal(value, b.evaluations(seed)[name], equal_nan=True), name
            # the share of best response: the greedy sum rate over the reference, in %
            assert np.allclose(evaluations["pct_oracle"],
                               100 * evaluations["sum_rate_bps"] / reference, rtol=1e-12)
            assert (evaluations["pct_oracle"] > 0).all()
            best_a, best_b = a.best(seed), b.best(seed)
            assert best_a is not None and best_a["episode"] == best_b["episode"]
            assert a.trajectory(seed)["uav_m"].shape == (10, 2, 3)
    assert main(["inspect", str(first)]) == 0


def test_exploring_starts_draw_every_share_per_seed_and_evaluations_start_at_start_alpha():
    scenario = parse_scenario(_with_split("difference", "shares"), "two")
    plain_scenario = parse_scenario(_with_split("difference"), "two")
    evaluation = evaluation_set(scenario)
    stack = StackRun([Member(scenario, seed) for seed in (3, 4)])
    alone = StackRun([Member(scenario, 4, evaluation)])
    firsts = []
    for together, single in zip([stack.run_episode() for _ in range(2)],
                                [alone.run_episode() for _ in range(2)], strict=True):
        assert_same_results(together[1], single[0])
        firsts.append(together[1].trajectory["alpha"][0])
    # after one step of 0.01 every share lies on the lattice 0.01 .. 0.99, and the episodes
    # start from other shares than 0.5 (which one step leaves at 0.49 or 0.51)
    for first in firsts:
        assert np.allclose(first * 100, np.round(first * 100), atol=1e-9)
        assert ((first >= 0.01 - 1e-12) & (first <= 0.99 + 1e-12)).all()
        assert not np.isin(np.round(first, 9), [0.49, 0.51]).all()
    assert not np.array_equal(firsts[0], firsts[1])
    # a greedy evaluation starts every share at start_alpha, as without exploring starts
    plain = StackRun([Member(plain_scenario, 4, evaluation)])
    plain.restore(0, alone.checkpoint(0))
    evaluated, expected = alone._evaluate()[0], plain._evaluate()[0]
    assert evaluated is not None and expected is not None and evaluated.keys() == expected.keys()
    for name, value in evaluated.items():
        assert np.array_equal(value, expected[name], equal_nan=True), name


@cuda
def test_a_reward_per_uav_replays_as_cuda_graphs_as_it_runs_eagerly():
    assert_graphs_replay_eager(parse_scenario(_with_split("per-uav"), "two"))


def test_eight_uavs_train_on_dense_indices_beyond_2_to_the_31():
    """Eight UAVs of one cluster each: 2^32 dense actions, more than an int32 holds (refused
    before the BDQ's limit became the int64 index). The environment steps the dense index of
    every branch's sub-action, and the replay keeps those sub-actions."""
    users = [[float(x), float(y)] for x in (-40, -20, 20, 40) for y in (-40, 40)]
    eight = {**TWO_UAVS, "name": "eight_small", "area": {"side_m": 100.0},
             "users": {"positions_m": [p for q in users for p in (q, [q[0] + 3, q[1] - 3])],
                       "pairing": "near-far"},
             "uav": {**TWO_UAVS["uav"], "count": 8},
             "train": {"steps": 20, "eval_every": 0}}
    scenario = parse_scenario(eight, "eight")
    run = StackRun([Member(scenario, 0)])
    assert run.env.actions.count == 2**32
    trajectory = run.run_episode()[0].trajectory
    actions = trajectory["action"]
    assert actions.dtype == np.int64 and actions.max() >= 2**31
    stored = run.algorithm.memory.arrays(0)["actions"][:len(actions)]
    assert np.array_equal(stored, (actions[:, None] // 2 ** np.arange(32)) % 2)
