"""Stacks of seeds: a member's numbers do not depend on its stack where it explores from drawn
starts or stands on drawn layouts (every learner alone and in a stack:
tests/contract/test_learners.py), members may differ in their reward, resumes from different
episodes catch up and merge, and reproduce can run a whole sweep as one stack. All on the CPU,
bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from adaptsky.experiment.executors import LocalExecutor, stacks
from adaptsky.experiment.plan import load_experiment, plan_experiment
from adaptsky.experiment.runs import execute_run
from adaptsky.sim.layout import user_layouts
from adaptsky.store.run_file import RunReader, SeedCheckpoint
from adaptsky.training.messages import Checkpoints, Done, Message
from adaptsky.training.runner import SeedTask, train_stack
from adaptsky.training.stack_run import Member, StackRun, stack_key
from tests.conftest import make_scenario
from tests.helpers.learners import PPO
from tests.helpers.training import (
    AGENT,
    assert_same_checkpoints,
    assert_same_results,
    stack_scenario,
)


def episodes(run: StackRun, count: int) -> list[list]:
    return [run.run_episode() for _ in range(count)]


def test_exploring_starts_of_one_uav_draw_per_seed_alone_or_in_a_stack():
    base = stack_scenario(train={"exploring_starts": "shares"})
    stack = StackRun([Member(base, seed) for seed in (11, 12)])
    alone = StackRun([Member(base, 12)])
    for together, single in zip(episodes(stack, 2), episodes(alone, 2), strict=True):
        assert_same_results(together[1], single[0])
        first = together[1].trajectory["alpha"][0]      # (N,) after one step of 0.01
        assert not np.isin(np.round(first, 9), [0.49, 0.51]).all()
    assert_same_checkpoints(stack.checkpoint(1), alone.checkpoint(0))


@pytest.mark.parametrize("kind", ["positions", "both"])
def test_exploring_positions_draw_per_seed_alone_or_in_a_stack(kind):
    base = stack_scenario(train={"exploring_starts": kind})
    stack = StackRun([Member(base, seed) for seed in (11, 12)])
    alone = StackRun([Member(base, 12)])
    starts = []
    for together, single in zip(episodes(stack, 2), episodes(alone, 2), strict=True):
        assert_same_results(together[1], single[0])
        uav_m = together[1].trajectory["uav_m"]
        starts.append(uav_m[0])
        # after one step of 1 m per axis from a point of the lattice (whole metres from the
        # start (0, 0, 50), |x|, |y| <= 50, h in [10, 200])
        assert np.allclose(uav_m[0], np.round(uav_m[0]), atol=1e-9)
        assert (np.abs(uav_m[0][:2]) <= 50).all() and 10 <= uav_m[0][2] <= 200
        first = together[1].trajectory["alpha"][0]
        assert np.isin(np.round(first, 9), [0.49, 0.5, 0.51]).all() == (kind == "positions")
    # far from the start (0, 0, 50) that one step leaves within 1 m per axis, and moving
    assert all(np.abs(start - [0, 0, 50]).max() > 1 for start in starts)
    assert not np.array_equal(starts[0], starts[1])
    assert_same_checkpoints(stack.checkpoint(1), alone.checkpoint(0))


@pytest.mark.parametrize("agent", [AGENT, PPO], ids=["dqn", "ppo"])
@pytest.mark.parametrize("placement", ["uniform", "hotspots"])
def test_a_member_trains_on_its_own_layouts_wherever_it_stands_in_the_stack(agent, placement):
    """Drawn layouts (users.count): environment e of every member stands on the scenario's
    layout e, as alone; a third member once stood on layouts 2E.. 3E - 1 (a seed's numbers
    then hung on how reproduce or train grouped the runs into stacks)."""
    base = make_scenario(agent=agent, train={"steps": 10, "episodes": 4},
                         channel={"los": "sampled"},
                         users={"count": 6, "placement": placement, "speed_m_per_step": 1.0})
    stack = StackRun([Member(base, seed) for seed in (11, 12, 13)])
    alone = StackRun([Member(base, 13)])
    envs = alone.envs
    assert envs == (2 if agent is PPO else 1)
    assert np.array_equal(alone.env.layouts_m, user_layouts(base, envs))
    assert not np.array_equal(user_layouts(base, 3 * envs)[2 * envs:], alone.env.layouts_m)
    assert np.array_equal(stack.env.layouts_m[2 * envs:], alone.env.layouts_m)
    for together, single in zip(episodes(stack, 2), episodes(alone, 2), strict=True):
        assert_same_results(together[2], single[0])
    assert_same_checkpoints(stack.checkpoint(2), alone.checkpoint(0))


def test_members_may_differ_in_their_reward():
    weights = [{"min_se": 0.0, "w_rate": 1.0}, {"min_se": 2.0, "w_satisfied": 100.0,
                                                 "w_unsatisfied": 10.0}]
    members = [Member(stack_scenario(reward=w), seed=5) for w in weights]
    stack = StackRun(members)
    alone = StackRun([members[1]])
    together, single = stack.run_episode(), alone.run_episode()
    assert_same_results(together[1], single[0])
    assert not np.array_equal(together[0].trajectory["reward"], together[1].trajectory["reward"])


def test_members_must_share_the_environment_and_network():
    with pytest.raises(ValueError, match="may differ only in"):
        StackRun([Member(stack_scenario(), 0),
                  Member(stack_scenario(radio={"tx_power_dbm": 10.0}), 1)])
    assert stack_key(stack_scenario(reward={"w_rate": 3.0})) == stack_key(stack_scenario())
    assert stack_key(stack_scenario(agent={"dueling": False})) != stack_key(stack_scenario())


class Collect:
    """A stand-in for the run-file writer: keeps every message."""

    def __init__(self) -> None:
        self.messages: list[Message] = []

    def __call__(self, message: Message) -> None:
        self.messages.append(message)

    def checkpoints(self, key) -> list[SeedCheckpoint]:
        """Every checkpoint of ``key``, in order."""
        return [item for m in self.messages if isinstance(m, Checkpoints) for item in m.items
                if item.key == key]


def test_resumes_from_different_episodes_catch_up_and_merge():
    """Seeds checkpointed at episodes 1 and 3 train to 4 as a stack: the one behind trains
    alone first, then both together; each ends as it would uninterrupted."""
    base = stack_scenario()
    reference = StackRun([Member(base, 1), Member(base, 2)])
    states = {}
    for episode in range(1, 5):
        reference.run_episode()
        states[episode] = [reference.checkpoint(0), reference.checkpoint(1)]
    tasks = [SeedTask(base, 1, 4, 1, 0, states[1][0]), SeedTask(base, 2, 4, 1, 0, states[3][1])]
    collect = Collect()
    train_stack(tasks, collect, lambda: False)
    assert [m.last_trajectory[0] for m in collect.checkpoints(1)] == [2, 3, 4]
    assert [m.last_trajectory[0] for m in collect.checkpoints(2)] == [4]
    for key, member in ((1, 0), (2, 1)):
        assert_same_checkpoints(collect.checkpoints(key)[-1].checkpoint, states[4][member])
    assert [m.key for m in collect.messages if isinstance(m, Done)] == [1, 2]


def test_stop_checkpoints_every_member():
    base = stack_scenario()
    tasks = [SeedTask(base, seed, 4, 10, 0) for seed in (0, 1)]
    collect = Collect()
    train_stack(tasks, collect, lambda: True)
    assert [m.last_trajectory[0] for m in collect.checkpoints(0)] == [1]
    assert [m.last_trajectory[0] for m in collect.checkpoints(1)] == [1]


def test_reproduce_runs_a_min_se_sweep_as_one_stack(tmp_path):
    """E2 (8 thresholds) tiny: one stack on the CPU writes the files separate runs write."""
    spec, path = load_experiment("e2")
    small = ["agent.hidden_sizes=[16]", "agent.batch_size=16", "agent.memory_size=200"]
    stacked = plan_experiment(spec, path, tmp_path / "stacked", runs=1, episodes=2, steps=20,
                              set_values=small)
    separate = plan_experiment(spec, path, tmp_path / "separate", runs=1, episodes=2,
                               steps=20, set_values=small)
    assert len(stacks(stacked.runs)) == 1 and len(stacked.runs) == 8
    executor = LocalExecutor(1, torch.device("cpu"))
    try:
        reports = [future.result() for future in executor.submit_all(stacked.runs)]
    finally:
        executor.close()
    assert [report.episodes_done for report in reports] == [2] * 8
    for run in separate.runs[:3]:
        execute_run(run)
    for mine, theirs in zip(stacked.runs[:3], separate.runs[:3], strict=True):
        with RunReader(mine.path) as a, RunReader(theirs.path) as b:
            for name, values in a.episodes(mine.seed).items():
                assert np.array_equal(values, b.episodes(theirs.seed)[name], equal_nan=True)


def test_reproduce_all_runs_only_trains_every_experiment(tmp_path, capsys, monkeypatch):
    from adaptsky_cli.cli.main import main

    # the worker processes search each training layout's oracle once, not once each
    monkeypatch.setenv("ADAPTSKY_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "out"
    code = main(["reproduce", "all", "--out", str(out), "--runs", "1", "--episodes", "1",
                 "--steps", "10", "--runs-only", "--workers", "1", "--quiet",
                 "--set", "agent.hidden_sizes=[8]", "--set", "agent.batch_size=8"])
    assert code == 0, capsys.readouterr().err
    counts = {folder.name: len(list((folder / "runs").glob("*.h5")))
              for folder in sorted(out.iterdir())}
    assert counts == {"e1a": 1, "e1b": 1, "e2": 8, "e3": 3}
    assert not (out / "report.md").exists()  # --runs-only: no index
