"""A run killed with kill -9 after a checkpoint and resumed is the uninterrupted run's file,
every dataset and attribute bit for bit, wherever something is drawn: users that move, fading,
sampled LoS, one UAV and two, and every learner (issue 52, item 1). And the greedy evaluations
draw alike at every episode (common random numbers, item 2; docs/training.md)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.observation import observation_size_of
from adaptsky.training.evaluation import COLUMNS, GreedyEvaluator, evaluation_set
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

EPISODES, KILLED_AT = 4, 2
RUN = ["--seeds", "0,1", "--workers", "1", "--quiet"]
TRAIN = {"episodes": EPISODES, "steps": 10, "checkpoint_every": 2, "eval_every": 1,
         "eval_steps": 12}
DQN = {"hidden_sizes": [16, 16], "batch_size": 8, "memory_size": 50,
       "target_update_episodes": 1}
PPO = {"hidden_sizes": [16, 16], "envs_per_seed": 2, "minibatches": 2, "epochs": 2}
SAC = {"algorithm": "sac", "hidden_sizes": [16, 16], "batch_size": 8, "memory_size": 50,
       "learning_starts": 10}
# (scenario, its changed sections): what draws, which learner
CASES = {
    "moving-users-dqn": ("moving_users_sub6.toml", {"agent": {"algorithm": "dqn", **DQN}}),
    "moving-users-fading-ppo": ("moving_users_fading_sub6.toml",
                                {"agent": {"algorithm": "ppo", **PPO}}),
    "city-fading-geometric-los-dqn": ("city_sub6.toml", {"agent": {"algorithm": "dqn", **DQN}}),
    # a fresh layout each episode, held-out layouts and exploring starts too
    "sampled-los-fresh-sac": ("sub6_al_hourani.toml", {
        "agent": SAC, "channel": {"los": "sampled"}, "uav": {"actions": "continuous"},
        "users": {"placement": "fresh", "positions_m": None},
        "train": {**TRAIN, "eval_layouts": 2, "exploring_starts": "both"}}),
    "two-uavs-sampled-los-bdq": ("two_uavs_sub6.toml", {"agent": {"algorithm": "bdq", **DQN}}),
    "two-uavs-moving-mappo": ("two_uavs_moving_mmwave.toml",
                              {"agent": {"algorithm": "mappo", **PPO}}),
}
# what differs between any two runs, by design: the command that made the file, when, and the
# log of the commands that wrote it (times, command lines, episodes before and after)
VARYING = {"/@command_line", "/@created_utc", "sessions"}

# trains as `adaptsky train` does in one process, and kills that process with SIGKILL as soon
# as the checkpoint of episode argv[1] is in the run file
KILL_AFTER_CHECKPOINT = """
import os, signal, sys
from adaptsky.store import run_file
write = run_file.append_checkpoints
def write_then_die(path, items):
    write(path, items)
    if min(item.episode for item in items) >= int(sys.argv[1]):
        os.kill(os.getpid(), signal.SIGKILL)
run_file.append_checkpoints = write_then_die
from adaptsky_cli.cli.main import main
sys.exit(main(sys.argv[2:]))
"""


def everything(path: Path) -> dict[str, object]:
    """Every dataset's value and every attribute (``name@attribute``) of the file at
    ``path`` but :data:`VARYING`."""
    found: dict[str, object] = {}
    with h5py.File(path) as f:
        def visit(name: str, node: h5py.Group | h5py.Dataset) -> None:
            if name in VARYING:
                return
            found.update({f"{name}@{key}": value for key, value in node.attrs.items()
                          if f"{name}@{key}" not in VARYING})
            if isinstance(node, h5py.Dataset):
                found[name] = node[()]
        visit("/", f)
        f.visititems(visit)
    return found


def assert_same_files(got: Path, expected: Path) -> None:
    a, b = everything(got), everything(expected)
    assert a.keys() == b.keys(), sorted(a.keys() ^ b.keys())
    different = [name for name in a if not _equal(a[name], b[name])]
    assert not different, different


def _equal(a: object, b: object) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind in "fc":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


def small_scenario(tmp_path: Path, name: str, changes: dict[str, dict]) -> Path:
    """The shipped scenario ``name`` with its ``changes`` (a new ``agent`` replaces its
    own) and the small :data:`TRAIN`, as a file."""
    data = load_scenario(SCENARIOS / name).model_dump(mode="json")
    data["agent"] = {}
    for section, values in ({"train": TRAIN} | changes).items():
        data[section] = {**data[section], **values}
    path = tmp_path / name
    path.write_text(dumps(data))
    return path


def killed_and_resumed(args: list[str], out: Path) -> Path:
    """``train ARGS --out OUT`` killed with SIGKILL right after the checkpoint of episode
    KILLED_AT, then ``train --resume OUT``."""
    killed = subprocess.run([sys.executable, "-c", KILL_AFTER_CHECKPOINT, str(KILLED_AT),
                             "train", *args, "--out", str(out)],
                            capture_output=True, text=True, timeout=300, check=False)
    assert killed.returncode == -9, killed.stderr
    with h5py.File(out) as f:
        assert [int(f[f"seeds/{s}"].attrs["episodes_done"]) for s in (0, 1)] == [KILLED_AT] * 2
    assert main(["train", "--resume", str(out), "--workers", "1", "--quiet"]) == 0
    return out


@pytest.mark.parametrize("case", CASES)
def test_kill_9_and_resume_give_the_uninterrupted_file_bit_for_bit(case, tmp_path):
    args = [str(small_scenario(tmp_path, *CASES[case])), *RUN]
    through = tmp_path / "through.h5"
    assert main(["train", *args, "--out", str(through)]) == 0
    resumed = killed_and_resumed(args, tmp_path / "resumed.h5")
    assert_same_files(resumed, through)
    with h5py.File(through) as f:  # the comparison holds evaluations after the resume
        assert f["seeds/0/evaluations/episode"][()].tolist() == list(range(1, EPISODES + 1))
        assert np.isfinite(f["seeds/1/evaluations/score"][()]).all()


def test_greedy_evaluations_of_one_policy_draw_alike_at_every_episode():
    """A frozen policy evaluated after episodes 1, 2 and 3 of a stack that trains in between
    (moving users, fading): every row equal; both seeds of the stack see the same draws, and
    a seed evaluated alone gets its row in the stack."""
    scenario = load_scenario(SCENARIOS / "moving_users_fading_sub6.toml")
    scenario = scenario.model_copy(update={"train": scenario.train.model_copy(update={
        "steps": 10, "episodes": 3, "eval_every": 1, "eval_steps": 30})})
    evaluation = evaluation_set(scenario)
    run = StackRun([Member(scenario, seed, evaluation) for seed in (0, 1)])
    frozen = np.random.default_rng(7).standard_normal((observation_size_of(scenario), 1))

    def greedy(observations: np.ndarray) -> np.ndarray:  # (S, n, obs) -> (S, n) indices
        count = run.env.controls.count
        return (np.floor(np.abs(observations @ frozen)[..., 0] * 1e3) % count).astype(int)

    run.algorithm.greedy = greedy  # type: ignore[method-assign]
    rows = [[result.evaluation for result in run.run_episode()] for _ in range(3)]
    columns = [c for c in COLUMNS if c != "episode"]
    first = rows[0][0]
    assert np.isfinite([first["sum_rate_bps"], first["tracking_bps"]]).all()
    for episode in rows:
        for row in episode:
            np.testing.assert_equal({c: row[c] for c in columns},
                                    {c: first[c] for c in columns})
    alone = GreedyEvaluator([evaluation], 30).run(greedy)[0]
    np.testing.assert_equal({c: alone[c] for c in columns}, {c: first[c] for c in columns})
    # the draws matter here: other draws, other numbers
    other = GreedyEvaluator([evaluation], 30)
    other.seeds = [[np.random.SeedSequence(1)]]
    assert other.run(greedy)[0]["sum_rate_bps"] != first["sum_rate_bps"]


def test_eval_gives_back_every_seed_s_best_score_and_tracking(tmp_path, capsys):
    """Users that move: the training layout's evaluations draw what ``adaptsky eval`` draws
    (seed 0), so eval of each seed's best policy gives back its stored best score, and its
    tracking the stored tracking, bit for bit."""
    scenario = small_scenario(tmp_path, "moving_users_sub6.toml",
                              {"agent": {"algorithm": "dqn", **DQN}})
    run = tmp_path / "run.h5"
    assert main(["train", str(scenario), *RUN, "--out", str(run)]) == 0
    for seed in (0, 1):
        capsys.readouterr()
        assert main(["eval", str(run), "--seed", str(seed), "--steps", str(TRAIN["eval_steps"]),
                     "--compare", "tracking", "--out", str(tmp_path / f"eval{seed}.h5"),
                     "--json"]) == 0
        methods = json.loads(capsys.readouterr().out)["methods"]
        with h5py.File(run) as f:
            best = f[f"seeds/{seed}/checkpoint/best"].attrs["score"]
            tracking = f[f"seeds/{seed}/evaluations/tracking_bps"][()]
        assert methods["policy"]["summary"]["steady_sum_rate_bps"] == best
        assert (tracking == methods["tracking"]["summary"]["steady_sum_rate_bps"]).all()


def _frozen(weights: list[np.ndarray], count: int) -> Callable[[np.ndarray], np.ndarray]:
    """A fixed greedy policy per member: indices (S, n) from observations (S, n, obs)."""
    def greedy(observations: np.ndarray) -> np.ndarray:
        return np.stack([(np.floor(np.abs(obs @ w)[..., 0] * 1e3) % count).astype(int)
                         for obs, w in zip(observations, weights, strict=True)])
    return greedy


@pytest.mark.parametrize(("name", "train"), [
    ("nyc_mmwave.toml", {}),                                       # nothing drawn
    ("moving_users_sub6.toml", {}),                                 # users move
    ("nyc_mmwave_any_layout.toml", {"eval_layouts": 3}),            # held-out layouts
])
def test_a_seed_s_evaluation_is_the_same_alone_and_in_a_stack(name, train):
    """Each member's row of a stack of two equals its row evaluated alone, bit for bit (the
    steady means are taken member by member)."""
    scenario = load_scenario(SCENARIOS / name)
    scenario = scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"eval_steps": 120, **train})})
    # a stored reference (no search): 30 Gbit/s on every layout
    evaluation = evaluation_set(scenario, [np.full(train.get("eval_layouts", 1), 3e10)])
    rng = np.random.default_rng(3)
    weights = [rng.standard_normal((observation_size_of(scenario), 1)) for _ in range(2)]
    stacked = GreedyEvaluator([evaluation] * 2, 120).run(_frozen(weights, 10))
    for member in range(2):
        alone = GreedyEvaluator([evaluation], 120).run(_frozen(weights[member:member + 1], 10))
        np.testing.assert_equal(stacked[member], alone[0])
    assert stacked[0]["score"] != stacked[1]["score"]  # two policies, two numbers
