"""Tiny experiments for ``adaptsky reproduce``: experiment files, the runs trained without a
stop, and processes started and watched."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import h5py
import numpy as np

from adaptsky.experiment.plan import RunSpec, load_experiment, plan_experiment
from adaptsky.experiment.runs import execute_run
from adaptsky.store.run_file import RunReader
from tests.conftest import ROOT
from tests.helpers.cli import ADAPTSKY

SMALL_AGENT = ['"agent.hidden_sizes=[32, 32]"', '"agent.batch_size=32"',
               '"agent.memory_size=2000"']


def write_experiment(folder: Path, body: str, name: str = "tiny") -> Path:
    """An experiment file beside a link to the shipped scenarios."""
    folder.mkdir(parents=True, exist_ok=True)
    if not (folder.parent / "scenarios").exists():
        (folder.parent / "scenarios").symlink_to(ROOT / "scenarios")
    path = folder / f"{name}.toml"
    path.write_text(body)
    return path


def curves_experiment(tmp_path: Path, runs: int = 2) -> Path:
    return write_experiment(tmp_path / "experiments", f"""
id = "tiny"
title = "tiny learning curves"
[[groups]]
name = "agent"
scenario = "../scenarios/sub6_al_hourani_released_code.toml"
runs = {runs}
set = [{", ".join(SMALL_AGENT)}]
[evaluation]
policy = "agent"
steps = 50
baselines = ["soa", "oracle"]
[figure]
kind = "learning-curves"
[[claims]]
text = "sum rate"
quantity = "sum_rate_bps"
paper = 400e6
[[claims]]
text = "gain"
quantity = "gain_vs_soa_pct"
""")


def last_mean(path: Path, name: str = "sum_rate_bps") -> float:
    with h5py.File(path, "r") as file:
        group = next(iter(file["seeds"].values()))
        done = int(group.attrs["episodes_done"])
        return float(np.mean(group["episodes"][name][:done][-100:]))


# long enough that neither run ends while the other's process still starts
EPISODES, STEPS = 60, 100


def start_adaptsky(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen([str(ADAPTSKY), *args], stdout=log.open("w"),
                            stderr=subprocess.STDOUT, start_new_session=True)


def episodes_trained(path: Path) -> int:
    try:
        with RunReader(path) as run:
            return run.seed_attrs(run.seeds[0])["episodes_done"]
    except Exception:
        return 0


def wait_for(condition, timeout_s: float = 120) -> None:
    end = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.1)


def plan_runs(experiment: Path, folder: Path) -> list[RunSpec]:
    """The runs of ``experiment`` at EPISODES x STEPS, a checkpoint every 2, into ``folder``."""
    model, path = load_experiment(str(experiment))
    return plan_experiment(model, path, folder, episodes=EPISODES, steps=STEPS,
                           set_values=["train.checkpoint_every=2"]).runs


def train_uninterrupted(folder: Path) -> list[tuple[RunSpec, dict[str, np.ndarray]]]:
    """curves_experiment's two runs trained without a stop, in this process (EPISODES x STEPS,
    a checkpoint every 2): each run's spec and learning curves. The session fixture
    ``uninterrupted`` (tests/e2e/conftest.py) trains them once for every test that stops and
    restarts these runs."""
    trained = []
    for spec in plan_runs(curves_experiment(folder), folder / "fresh"):
        execute_run(spec)
        with RunReader(spec.path) as run:
            trained.append((spec, run.episodes(spec.seed)))
    return trained


def assert_equal_to_uninterrupted(experiment: Path, runs: list[Path], folder: Path,
                                  uninterrupted: list[tuple[RunSpec, dict[str, np.ndarray]]]
                                  ) -> None:
    """Each run file's curves equal those of the same run trained without a stop
    (``uninterrupted``: the same spec, checked here, trained in this process)."""
    specs = plan_runs(experiment, folder)
    assert len(specs) == len(uninterrupted)
    for spec, (fresh, curves), stopped in zip(specs, uninterrupted, runs, strict=True):
        assert (spec.name, spec.seed, spec.config) == (fresh.name, fresh.seed, fresh.config)
        with RunReader(stopped) as b:
            for name, values in curves.items():
                assert np.array_equal(values, b.episodes(spec.seed)[name], equal_nan=True), name
