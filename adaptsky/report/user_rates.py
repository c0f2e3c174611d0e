"""Per-user rates, for people: each user's steady-state rate per method on one layout of an
evaluation (``eval``, ``inspect EVAL.h5``: the ``steady_user_rate_bps`` metric, the mean of
the last 100 steps as every steady state of eval), and each seed's mean rate per user in its
last stored episode (``inspect RUN.h5``). One table has a row per user, never one per layout:
an evaluation on 100 layouts shows one layout at a time (``--layout``; ``--csv`` writes all).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rich import box
from rich.table import Table

from adaptsky.errors import AdaptskyError
from adaptsky.rollouts.metrics import STEADY_STEPS
from adaptsky.units import rate_unit

USER_RATES = "steady_user_rate_bps"
"""The per-layout metric of each user's steady-state rate, (L, N) per method."""


def eval_user_rates(results: dict[str, Any]) -> dict[str, np.ndarray]:
    """Method label -> its users' steady-state rates (L, N) in bit/s, from the results of an
    evaluation (``eval --json``, an eval file's ``results_json``)."""
    return {name: np.asarray(entry["layouts"][USER_RATES], dtype=np.float64)
            for name, entry in results["methods"].items()}


def check_layout(layout: int, layouts: int, option: str = "--layout") -> int:
    """``layout`` if the evaluation has it (0 .. layouts - 1), else one line saying so."""
    if not 0 <= layout < layouts:
        have = "only layout 0" if layouts == 1 else f"layouts 0 to {layouts - 1}"
        raise AdaptskyError(f"{option} {layout}: the evaluation has {have}")
    return layout


def _user_table(title: str, caption: str, columns: list[str],
                rates_bps: list[np.ndarray | None]) -> Table:
    """Rows of users, a column of rates (N,) per entry of ``rates_bps`` (None: '-'), in one
    unit for the whole table."""
    shown = [r for r in rates_bps if r is not None]
    scale, unit = rate_unit([float(np.max(np.abs(r))) for r in shown if r.size])
    table = Table("user", *columns, title=f"{title} ({unit})", caption=caption,
                  box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True,
                  min_width=len(caption) // 2 + 4)
    for column in table.columns[1:]:
        column.justify = "right"
    users = max((len(r) for r in shown), default=0)
    for user in range(users):
        table.add_row(str(user), *("-" if r is None else f"{r[user] / scale:.2f}"
                                   for r in rates_bps))
    return table


def eval_user_table(results: dict[str, Any], layout: int = 0) -> Table:
    """Each user's steady-state rate (rows) per method (columns) on ``layout``."""
    rates = eval_user_rates(results)
    layouts = int(results["layouts"])
    check_layout(layout, layouts)
    steps = min(STEADY_STEPS, int(results["steps"]))
    caption = f"steady state: the mean of the last {steps} steps"
    if layouts > 1:
        caption += f"; another layout: --layout 0..{layouts - 1}; all: --csv FILE"
    title = "per-user rate" + (f", layout {layout}" if layouts > 1 else "")
    return _user_table(title, caption, list(rates), [r[layout] for r in rates.values()])


def run_user_rates(seed: dict[str, Any]) -> np.ndarray | None:
    """A seed of ``summary.summarize``: its users' mean rates (N,) in its last stored episode,
    or None before its first episode."""
    rates = seed.get("last_episode_user_rate_bps")
    return None if rates is None else np.asarray(rates, dtype=np.float64)


def run_user_table(summary: dict[str, Any]) -> Table | None:
    """Each user's mean rate (rows) in the last stored episode of each seed (columns); None
    where no seed has an episode yet."""
    seeds = summary["seeds"]
    rates = [run_user_rates(seed) for seed in seeds]
    if all(r is None for r in rates):
        return None
    columns = [f"seed {s['seed']} (ep. {s['episodes_done']})" for s in seeds]
    return _user_table("per-user rate, last episode",
                       "the mean over the episode's steps, exploring", columns, rates)
