"""What a training run of a scenario needs in memory, against what this machine has.

The estimate adds up what grows with the scenario's sizes (docs/scenario-format.md, "Machine
limits"), per seed where it is per seed:

- replay: M rows of 2 obs + 3 float32 (obs = 4 N + 1), and a member's copy at a checkpoint;
- networks and optimizer: policy, target, gradients and two Adam moments (5 float32 per
  parameter), and the copies a checkpoint makes;
- dueling head: the fixed (1 + A) x A matrix that forms Q = V + A - mean A, and its build
  copy (measured: 22 users peak at 2.4 GB, estimated 2.6 GB);
- action table: the directions of every action, for A <= TABLE_MAX_ACTIONS;
- batch activations: every layer's output for a batch, forward and backward;
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
from itertools import pairwise

from adaptsky.errors import ResourceError
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import TABLE_MAX_ACTIONS

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


# what to lower when a part is the largest
REMEDY = {
    "replay": "lower agent.memory_size or the number of seeds",
    "networks and optimizer": "lower agent.hidden_sizes, users or the number of seeds",
    "dueling head": "fewer users (the action space doubles per cluster) or agent.dueling = false",
    "action table": "fewer users",
    "batch activations": "lower agent.batch_size or agent.hidden_sizes",
    "trajectories": "lower train.steps, train.checkpoint_every or raise train.trajectory_every",
    "runtime": "train fewer seeds at once (--workers)",
}


def _power(base: int, exponent: int) -> float:
    """base**exponent as a float, inf where it would overflow one."""
    return math.inf if exponent * math.log(base) > 700 else float(base**exponent)


def estimate(scenario: Scenario, workers: int | None = None) -> Estimate:
    """Bytes a training run of ``scenario`` (all its seeds, in ``workers`` processes, by default
    one per seed up to the cores) needs at its peak."""
    agent, train = scenario.agent, scenario.train
    seeds = len(train.seeds)
    users = scenario.num_users
    clusters = users // 2
    obs = 4 * users + 1
    base = 2 if scenario.uav.actions == "paper" else 3
    actions = _power(base, 3 + clusters)
    head = actions + 1 if agent.dueling else actions
    sizes = [obs, *agent.hidden_sizes]
    params = float(sum((a + 1) * b for a, b in pairwise(sizes)))
    params += (sizes[-1] + 1) * head
    width = 2 * obs + 3
    replay_row = width * FLOAT32
    hidden = float(sum(agent.hidden_sizes))
    batch = agent.batch_size
    # a step's state: uav (3), alpha, gain, p_los, rate (N each), los (N bytes), 3 sums;
    # the episode's trajectory stacks them, and every member gets a contiguous copy
    state_bytes = (6 + 4 * users) * FLOAT64 + users
    workers = min(workers or seeds, seeds, os.cpu_count() or 1)  # as train.runner.run_tasks
    kept = (train.checkpoint_every // train.trajectory_every) if train.trajectory_every else 0
    episode_rows = min(train.checkpoint_every, train.episodes)
    parts = {
        # a checkpoint copies one member's rows, and pickles them to the writer if apart
        "replay": (seeds + (3 if workers > 1 else 1)) * agent.memory_size * replay_row,
        "networks and optimizer": (5 * seeds + 2 * seeds + 8) * params * FLOAT32,
        "dueling head": 2 * (actions + 1) * actions * FLOAT32 if agent.dueling else 0.0,
        "action table": (actions * (3 + clusters) * 3 * FLOAT64
                         if actions <= TABLE_MAX_ACTIONS else 0.0),
        "batch activations": seeds * batch * (4 * (obs + hidden) + 8 * head) * FLOAT32,
        "trajectories": (train.steps * (STEP_OVERHEAD_BYTES + 3 * seeds * state_bytes)
                         + seeds * kept * train.steps * state_bytes
                         + seeds * episode_rows * (EPISODE_ROW_BYTES + 2 * users * FLOAT64)),
        # worker processes, and the writer beside them when there are several
        "runtime": float((workers + (workers > 1)) * RUNTIME_BYTES),
    }
    return Estimate({name: float(size) for name, size in parts.items()})


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
    """The estimate for ``scenario``; a one-line :class:`ResourceError` if it needs more than
    ``available`` bytes (default: what this machine has now)."""
    needed = estimate(scenario, workers)
    if available is None:
        available = available_bytes()
    if available is not None and needed.total > available:
        largest = needed.largest()
        parts = ", ".join(f"{name} {format_bytes(size)}" for name, size in largest
                          if size >= needed.total / 100)
        raise ResourceError([f"{source}: needs about {format_bytes(needed.total)} of memory "
                            f"({parts}), this machine has {format_bytes(available)} available; "
                            f"{REMEDY[largest[0][0]]}"])
    return needed
