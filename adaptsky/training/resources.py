"""What a training run of a scenario needs in memory, against what this machine has.

The estimate adds up what grows with the scenario's sizes (docs/scenario-format.md, "Machine
limits"), per seed where it is per seed:

- the algorithm's parts (``AlgorithmSpec.memory_parts``; the DQN's: replay memory, networks
  and optimizer, dueling head, batch activations);
- action table: the directions of every action, for A <= TABLE_MAX_ACTIONS;
- trajectories: the states of an episode (T steps) and the kept episodes between checkpoints,
  and the episode table between checkpoints;
- runtime: the Python and torch of every process (workers and, beside them, the writer).

Every size is computed in Python integers or floats, so no size overflows (2**62 rows give a
number, not an error).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from adaptsky.algos.registry import algorithm_of, check_actions
from adaptsky.errors import ResourceError
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import TABLE_MAX_ACTIONS, count_estimate

FLOAT32 = 4
FLOAT64 = 8
RUNTIME_BYTES = 300 * 10**6  # Python, numpy and torch of one process (measured: 300 MB RSS)
STEP_OVERHEAD_BYTES = 1500  # a step's state object and its arrays' headers
EPISODE_ROW_BYTES = 1000  # a row of the episode table (a dict of numbers and two arrays)


@dataclass(frozen=True)
class Estimate:
    """Bytes a run needs, by part (float: sizes beyond any machine stay finite numbers)."""

    parts: dict[str, float]

    @property
    def total(self) -> float:
        return sum(self.parts.values())

    def largest(self, count: int = 3) -> list[tuple[str, float]]:
        return sorted(self.parts.items(), key=lambda item: -item[1])[:count]


# what to lower when a part is the largest (the algorithm's parts: its own remedies)
REMEDY = {
    "action table": "fewer users",
    "trajectories": "lower train.steps, train.checkpoint_every or raise train.trajectory_every",
    "runtime": "train fewer seeds at once (--workers)",
}


def estimate(scenario: Scenario, workers: int | None = None) -> Estimate:
    """Bytes a training run of ``scenario`` (all its seeds, in ``workers`` processes, by default
    one per seed up to the cores) needs at its peak."""
    train = scenario.train
    seeds = len(train.seeds)
    users = scenario.num_users
    clusters = users // 2
    actions = count_estimate(scenario.shares_per_uav, scenario.uav.actions,
                             scenario.uav.count)
    # a step's state: uav (3), alpha, gain, p_los, rate (N each), los (N bytes), 3 sums;
    # the episode's trajectory stacks them, and every member gets a contiguous copy
    state_bytes = (6 + 4 * users) * FLOAT64 + users
    workers = min(workers or seeds, seeds, os.cpu_count() or 1)  # as train.runner.run_tasks
    kept = (train.checkpoint_every // train.trajectory_every) if train.trajectory_every else 0
    episode_rows = min(train.checkpoint_every, train.episodes)
    parts = algorithm_of(scenario).memory_parts(scenario, seeds, workers) | {
        "action table": (actions * (3 + clusters) * 3 * FLOAT64
                         if actions <= TABLE_MAX_ACTIONS else 0.0),
        "trajectories": (train.steps * (STEP_OVERHEAD_BYTES + 3 * seeds * state_bytes)
                         + seeds * kept * train.steps * state_bytes
                         + seeds * episode_rows * (EPISODE_ROW_BYTES + 2 * users * FLOAT64)),
        # worker processes, and the writer beside them when there are several
        "runtime": float((workers + (workers > 1)) * RUNTIME_BYTES),
    }
    return Estimate({name: float(size) for name, size in parts.items()})


def remedy(scenario: Scenario, part: str) -> str:
    """What to lower when ``part`` is the largest."""
    return REMEDY.get(part) or algorithm_of(scenario).remedies[part]


def available_bytes() -> int | None:
    """Memory this machine can give a new run now: MemAvailable of /proc/meminfo, else the
    free physical pages; None where neither can be read."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return None


def format_bytes(size: float) -> str:
    """``2.3 TB``, ``512 MB``, ``7 B`` (decimal units); beyond yottabytes as a power of ten."""
    if not math.isfinite(size):
        return "more than 1e300 B"
    for unit in ("B", "kB", "MB", "GB", "TB", "PB", "EB", "ZB", "YB"):
        if size < 1000 or unit == "YB":
            break
        size /= 1000
    if size >= 1000:
        return f"{size:.1e} YB"
    return f"{size:.0f} {unit}" if unit == "B" or size >= 100 else f"{size:.1f} {unit}"


def check_fits(scenario: Scenario, source: str, available: int | None = None,
               workers: int | None = None) -> Estimate:
    """The estimate for ``scenario``; a one-line :class:`ScenarioError` if its algorithm does
    not learn its action kind (:func:`~adaptsky.algos.registry.check_actions`), a one-line
    :class:`ResourceError` if it needs more than ``available`` bytes (default: what this
    machine has now)."""
    check_actions(scenario, source)
    needed = estimate(scenario, workers)
    if available is None:
        available = available_bytes()
    if available is not None and needed.total > available:
        largest = needed.largest()
        parts = ", ".join(f"{name} {format_bytes(size)}" for name, size in largest
                          if size >= needed.total / 100)
        raise ResourceError([f"{source}: needs about {format_bytes(needed.total)} of memory "
                            f"({parts}), this machine has {format_bytes(available)} available; "
                            f"{remedy(scenario, largest[0][0])}"])
    return needed
