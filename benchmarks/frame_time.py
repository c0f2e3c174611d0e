"""Time to draw one animation frame of an episode (docs/pictures.md): move the artists to the
frame's step and draw to an RGB buffer at 100 dpi, the median over the frames of a 1000-step
episode (a frame every 5 steps: 200 frames, the default), for one UAV and for four, against
the target of 30 ms; and, for comparison, a full redraw (a new figure drawn whole for every
frame, as mobile-env does, 110-450 ms there).

The episodes are random-policy rollouts of the scenarios (every step moves every UAV), so no
trained run is needed.

    .venv/bin/python benchmarks/frame_time.py [--steps 1000] [--every 5] [--dpi 100]
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

from adaptsky.drawing.episode import EpisodeData, frame_steps  # noqa: E402
from adaptsky.drawing.episode_figure import EpisodeFigure  # noqa: E402
from adaptsky.report.episodes import trace_episode  # noqa: E402
from adaptsky.rollouts.rollout import random_policy, rollout  # noqa: E402
from adaptsky.scenario import load_scenario  # noqa: E402
from adaptsky.sim.actions import ActionSet  # noqa: E402
from adaptsky.sim.layout import user_layouts  # noqa: E402

TARGET_MS = 30.0
SCENARIOS = ("scenarios/nyc_mmwave.toml", "scenarios/four_uavs_mmwave.toml")
FULL_REDRAWS = 20
"""Frames timed with a full redraw (each costs a new figure)."""


def episode_of(path: str, steps: int) -> tuple[EpisodeData, float]:
    """A random-policy episode of ``steps`` steps on the scenario's layout, and its side, m."""
    scenario = load_scenario(path)
    users_m = user_layouts(scenario, 1)
    trace = rollout(scenario, random_policy(ActionSet.of(scenario).count, 0), steps, users_m)
    return trace_episode(scenario, trace, users_m, label=scenario.name), scenario.area.side_m


def frame_ms(episode: EpisodeData, side_m: float, rows: list[int], dpi: int) -> list[float]:
    """Milliseconds of every frame: show the row, draw to an RGB array (the first frame also
    draws what never moves, once)."""
    figure = EpisodeFigure([episode], side_m=side_m, dpi=dpi)
    times = []
    for row in rows:
        start = time.perf_counter()
        figure.show(row)
        figure.rgb()
        times.append(1000 * (time.perf_counter() - start))
    return times


def redraw_ms(episode: EpisodeData, side_m: float, rows: list[int], dpi: int) -> list[float]:
    """Milliseconds of a full redraw: a new figure of the episode so far, drawn whole."""
    times = []
    for row in rows:
        start = time.perf_counter()
        figure = EpisodeFigure([episode.until(row + 1)], side_m=side_m, dpi=dpi,
                               steps=episode.steps)
        figure.show(row)
        figure.rgb()
        times.append(1000 * (time.perf_counter() - start))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--every", type=int, default=5, help="steps per frame")
    parser.add_argument("--dpi", type=int, default=100)
    args = parser.parse_args()
    rows = frame_steps(args.steps, args.every)
    table = Table("scenario", "UAVs", "users", "frame", "median", "p90", "first",
                  "full redraw", "ratio", f"< {TARGET_MS:g} ms",
                  title=f"{args.steps} steps, a frame every {args.every}: {len(rows)} frames "
                        f"at {args.dpi} dpi")
    for path in SCENARIOS:
        episode, side_m = episode_of(path, args.steps)
        times = frame_ms(episode, side_m, rows, args.dpi)
        spaced = rows[:: max(1, len(rows) // FULL_REDRAWS)][:FULL_REDRAWS]
        full = float(np.median(redraw_ms(episode, side_m, spaced, args.dpi)))
        median = float(np.median(times))
        width, height = EpisodeFigure([episode.until(1)], side_m=side_m, dpi=args.dpi).size_px
        table.add_row(episode.label, str(episode.num_uavs), str(episode.num_users),
                      f"{width} x {height}", f"{median:.1f} ms",
                      f"{np.percentile(times, 90):.1f} ms", f"{times[0]:.0f} ms",
                      f"{full:.0f} ms", f"{full / median:.0f}x",
                      "PASS" if median < TARGET_MS else "FAIL")
    Console(width=120).print(table)
    print("frame: show(step) + rgb() on one figure; full redraw: a new figure drawn whole, "
          f"median of {FULL_REDRAWS} frames; first: the first frame, which draws the rest")


if __name__ == "__main__":
    main()
