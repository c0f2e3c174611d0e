"""Runs stopped and resumed: the resume command, run files compared bit for bit, leftovers,
a run file as ``train`` leaves it before its first checkpoint."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from adaptsky.scenario import Scenario
from adaptsky.store.lock import run_lock
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from tests.helpers.training import assert_same_curves, curves


def resume(path: Path) -> list[str]:
    return ["train", "--resume", str(path), "--workers", "1", "--quiet"]


def weights(path: Path) -> dict[int, dict[str, np.ndarray]]:
    with RunReader(path) as run:
        return {seed: run.checkpoint(seed)["agent"]["policy"] for seed in run.seeds}


def assert_same_run(path: Path, expected: Path) -> None:
    """Learning curves and final policy weights equal, bit for bit."""
    assert_same_curves(curves(path), curves(expected))
    got, want = weights(path), weights(expected)
    for seed in want:
        for name in want[seed]:
            assert np.array_equal(got[seed][name], want[seed][name]), (seed, name)


def leftovers(path: Path) -> list[str]:
    """Hidden copies and lock files beside ``path``."""
    return sorted(p.name for p in path.parent.glob(f".{path.name}*"))


def stub(scenario: Path, path: Path) -> Scenario:
    """The run file as ``train`` makes it before any checkpoint (a run killed then)."""
    loaded, text = api.load_with_overrides(scenario)
    loaded = api._with_train(loaded, seeds=[0, 1], episodes=2, steps=10, checkpoint_every=1)
    with run_lock(path):
        api.create_run_file(path, loaded, text)
    return loaded
