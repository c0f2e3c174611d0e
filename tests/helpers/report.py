"""Inputs for the report tests: synthetic series, run files with known curves and
evaluations, the lines a figure drew."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from adaptsky.report.figures import (
    Series,
)
from adaptsky.store.layout import EVALUATIONS
from adaptsky.store.run_file import (
    EPISODE_METRICS,
    PER_USER_METRICS,
    append_checkpoint,
    create_run,
)
from tests.conftest import make_scenario


def two_series() -> list[Series]:
    x = np.arange(10, 101)
    rising = 30e9 + 10e9 * (1 - np.exp(-x / 30))
    return [Series("dueling DQN", x, rising, rising - 1e9, rising + 1e9, runs=3),
            Series("DQN", x, rising - 3e9, rising - 4e9, rising - 2e9, runs=1)]


def make_run(path: Path, seeds: dict[int, int], evaluated: dict[int, list[int]] | None = None,
             **sections: object) -> Path:
    """A run file of ``seeds[S]`` episodes per seed (in one checkpoint) with distinct curves,
    and greedy evaluations at the episodes ``evaluated[S]`` (scores 50 + episode + seed).
    Only its curves and evaluations are real (checkpoints are stubs: read ``needs="curves"``)."""
    config = make_scenario(name="alpha", train={"seeds": list(seeds), "episodes": 100},
                           **sections)
    create_run(path, 'name = "alpha"\n', config.model_dump(mode="json"), {}, seeds=list(seeds),
               episodes=100, num_users=config.num_users)
    rng = np.random.default_rng(0)
    for seed, episodes in seeds.items():
        rows = {name: rng.uniform(0.2, 0.9, episodes) for name in EPISODE_METRICS}
        rows["sum_rate_bps"] = rng.uniform(20e9, 40e9, episodes)
        rows |= {name: rng.uniform(1e8, 1e10, (episodes, config.num_users))
                 for name in PER_USER_METRICS}
        at = np.array((evaluated or {}).get(seed, []), dtype=np.int64)
        table = {field.name: np.full(len(at), np.nan) for field in EVALUATIONS}
        table |= {"episode": at, "score": 50.0 + at + seed, "pct_oracle": 50.0 + at + seed}
        append_checkpoint(path, seed, rows, {}, (episodes, {}), {"episode": episodes}, table)
    return path


def stored(path: Path, seed: int, name: str) -> np.ndarray:
    """``/seeds/<seed>/episodes/<name>`` (or ``evaluations/score``) as the file holds it."""
    with h5py.File(path, "r") as file:
        group = file[f"seeds/{seed}"]
        if name == "score":
            return group["evaluations/episode"][()], group["evaluations/score"][()]
        return group[f"episodes/{name}"][: group.attrs["episodes_done"]]


def line_of(axes) -> tuple[np.ndarray, np.ndarray]:
    (line,) = axes.get_lines()
    return np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
