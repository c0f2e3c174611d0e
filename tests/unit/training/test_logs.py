"""train --log tensorboard|csv (docs/training.md, "Logs"): the scalars of every episode, read
back with TensorBoard's own event reader and from the CSV, equal to the run file's curves at
the expected steps; continued across a resume without an episode twice."""

from __future__ import annotations

import csv
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from adaptsky.training.logs import CSV_NAME, logs_folder
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.learners import ppo_scenario

event_accumulator = pytest.importorskip(
    "tensorboard.backend.event_processing.event_accumulator")


def _events(folder: Path) -> dict[str, dict[int, float]]:
    """Every scalar tag of one TensorBoard folder: {tag: {step: value}} (purges applied)."""
    reader = event_accumulator.EventAccumulator(str(folder), size_guidance={"scalars": 0})
    reader.Reload()
    found: dict[str, dict[int, float]] = defaultdict(dict)
    for tag in reader.Tags()["scalars"]:
        for event in reader.Scalars(tag):
            assert event.step not in found[tag], f"{tag}: step {event.step} twice"
            found[tag][event.step] = event.value
    return found


def _csv(path: Path) -> dict[tuple[int, str], dict[int, float]]:
    """{(seed, name): {episode: value}} of scalars.csv, each (seed, name, episode) once."""
    found: dict[tuple[int, str], dict[int, float]] = defaultdict(dict)
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        key, episode = (int(row["seed"]), row["name"]), int(row["episode"])
        assert episode not in found[key], f"{key}: episode {episode} twice"
        found[key][episode] = float(row["value"])
    return found


def test_ppo_logs_every_scalar_of_every_episode_and_a_resume_continues_them(tmp_path):
    path = ppo_scenario(tmp_path, episodes=6)
    run = tmp_path / "run.h5"
    api.train(scenario_path=path, out=run, seeds=[0, 1], workers=1, quiet=True,
              logs=["csv", "tensorboard"])
    folder = logs_folder(run)
    assert folder == tmp_path / "run.logs"
    # a crash after episode 6's checkpoint: the logs hold an episode the run file lacks
    # (made up here, at a value no episode has); the resume must drop it and log it anew
    with (folder / CSV_NAME).open("a") as f:
        f.write("0,7,0.0,train/sum_rate_bps,12345.0\n")
    from torch.utils.tensorboard import SummaryWriter
    with SummaryWriter(log_dir=str(folder / "seed0")) as writer:
        writer.add_scalar("train/sum_rate_bps", 12345.0, 7)
    # resume without --log continues the logs the run has
    api.resume(run_path=run, episodes=9, workers=1, quiet=True)
    with RunReader(run) as reader:
        curves = {seed: reader.episodes(seed) for seed in (0, 1)}
        evaluations = {seed: reader.evaluations(seed) for seed in (0, 1)}
    table = _csv(folder / CSV_NAME)
    for seed in (0, 1):
        events = _events(folder / f"seed{seed}")
        expected = curves[seed]["sum_rate_bps"]
        assert len(expected) == 9
        steps = dict(enumerate(expected, start=1))
        assert table[(seed, "train/sum_rate_bps")] == pytest.approx(steps, rel=1e-15)
        # TensorBoard stores float32
        assert events["train/sum_rate_bps"] == pytest.approx(steps, rel=1e-6)
        assert events["train/fairness"] == pytest.approx(
            dict(enumerate(curves[seed]["fairness"], start=1)), rel=1e-6)
        # the learner's statistics: PPO's losses, entropy and learning rate, annealed over
        # 6 episodes, then (resumed with --episodes 9) over 9
        lr = table[(seed, "learner/lr")]
        assert lr == pytest.approx({e: 3e-4 * (1 - (e - 1) / (6 if e <= 6 else 9))
                                    for e in range(1, 10)}, rel=1e-12)
        for name in ("learner/policy_loss", "learner/value_loss", "learner/entropy",
                     "speed/env_steps_per_s"):
            assert sorted(table[(seed, name)]) == list(range(1, 10)), name
            assert set(events[name]) == set(range(1, 10)), name
        assert table[(seed, "learner/entropy")] == pytest.approx(
            dict(enumerate(curves[seed]["entropy"], start=1)), rel=1e-15)
        # the greedy evaluations, every third episode; no epsilon for PPO
        greedy = evaluations[seed]
        assert table[(seed, "greedy/pct_oracle")] == pytest.approx(
            dict(zip(greedy["episode"].tolist(), greedy["pct_oracle"], strict=True)))
        assert sorted(events["greedy/pct_oracle"]) == [3, 6, 9]
        assert (seed, "train/epsilon") not in table


def test_log_kinds_are_checked_in_one_line(tmp_path, capsys):
    path = ppo_scenario(tmp_path, episodes=1)
    assert main(["train", str(path), "--log", "wandb", "--out", str(tmp_path / "r.h5"),
                 "--quiet"]) == 2
    assert capsys.readouterr().err.strip() == (
        "adaptsky train: --log: unknown kind 'wandb'; choose from tensorboard, csv; see "
        "'adaptsky train --help'")
    assert not (tmp_path / "r.h5").exists()


def test_dqn_logs_its_epsilon_loss_and_learning_rate(tmp_path):
    data = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
    data["agent"] = {"algorithm": "dqn", "hidden_sizes": [16, 16], "batch_size": 16}
    data["train"] |= {"episodes": 2, "steps": 30, "eval_every": 0}
    path = tmp_path / "dqn.toml"
    path.write_text(dumps(data))
    run = tmp_path / "dqn.h5"
    assert main(["train", str(path), "--seeds", "0", "--out", str(run), "--log", "csv",
                 "--quiet"]) == 0
    table = _csv(logs_folder(run) / CSV_NAME)
    with RunReader(run) as reader:
        curves = reader.episodes(0)
    assert table[(0, "train/epsilon")] == pytest.approx(
        dict(enumerate(curves["epsilon"], start=1)), rel=1e-15)
    assert table[(0, "learner/lr")] == {1: 1e-3, 2: 1e-3}
    assert np.isfinite(list(table[(0, "train/loss")].values())).all()
    assert not any(name.startswith("greedy/") for _, name in table)
