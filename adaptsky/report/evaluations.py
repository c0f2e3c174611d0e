"""The greedy evaluations during training, for people: which policy is used, and the curve
(``inspect`` and ``eval``; the columns are those of ``adaptsky.training.evaluation``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from rich import box
from rich.table import Table

from adaptsky.references.registry import layout_reference
from adaptsky.scenario import Scenario
from adaptsky.units import format_rate

CURVE_ROWS = 12


def format_score(value: float, kind: str) -> str:
    """A score or a column value: '97.3%' or '47.26 Gbit/s' ('-' for NaN)."""
    if not math.isfinite(value):
        return "-"
    return f"{value:.1f}%" if kind == "pct" else format_rate(value)


def curve_json(table: dict[str, np.ndarray]) -> dict[str, list[Any]]:
    """The evaluation rows as JSON lists (NaN as None)."""
    return {name: [None if isinstance(v, float) and math.isnan(v) else v
                   for v in values.tolist()] for name, values in table.items()}


def curve_arrays(curve: dict[str, list[Any]]) -> dict[str, np.ndarray]:
    """Inverse of :func:`curve_json`: float arrays, None as NaN."""
    return {name: np.array([np.nan if v is None else v for v in values], dtype=float)
            for name, values in curve.items()}


def shown_rows(episodes: np.ndarray, best_episode: int | None, limit: int = CURVE_ROWS
               ) -> list[int]:
    """At most ``limit`` row indices spread evenly over the curve, always with the first,
    the last and the best."""
    count = len(episodes)
    picked = set(np.linspace(0, count - 1, min(limit, count)).round().astype(int).tolist())
    if best_episode is not None:
        picked |= set(np.flatnonzero(episodes == best_episode).tolist())
    return sorted(picked)


def curve_table(seed: int, table: dict[str, np.ndarray], best_episode: int | None,
                limit: int = CURVE_ROWS) -> Table:
    """Rows of the curve (:func:`shown_rows`): the training layout's steady sum rate and
    percent of the oracle (where users move: the tracking baseline's sum rate on the same
    draws), and the held-out layouts' where the run has them; the best marked."""
    episodes = table["episode"]
    columns = [("sum_rate_bps", "R (train)", "rate"), ("pct_oracle", "% oracle", "pct"),
               ("tracking_bps", "tracking", "rate"),
               ("heldout_sum_rate_bps", "R (held-out)", "rate"),
               ("heldout_pct_oracle", "% oracle held-out", "pct"),
               ("heldout_pct_oracle_median", "median %", "pct"),
               ("heldout_tracking_bps", "tracking held-out", "rate")]
    columns = [c for c in columns if c[0] in table and np.isfinite(table[c[0]]).any()]
    rows = shown_rows(episodes, best_episode, limit)
    shown = f"{len(rows)} of {len(episodes)}" if len(rows) < len(episodes) else str(len(rows))
    result = Table("episode", *[title for _, title, _ in columns], "",
                   title=f"seed {seed}: greedy evaluations during training ({shown})",
                   box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    for index in rows:
        mark = "best" if best_episode is not None and episodes[index] == best_episode else ""
        cells = [format_score(float(table[name][index]), kind) for name, _, kind in columns]
        result.add_row(str(int(episodes[index])), *cells, mark)
    return result


def policy_line(record: dict[str, Any], kind: str) -> str:
    """Which policy an evaluation used, in one line."""
    seed, last = record["seed"], record["last_episode"]
    if record["policy"] == "best":
        return (f"policy: seed {seed}, best greedy evaluation during training, episode "
                f"{record['episode']} (score {format_score(record['best_score'], kind)}); the last "
                f"checkpoint is episode {last} (--policy last)")
    if record["policy_asked"] == "best":
        return (f"policy: seed {seed}, last checkpoint, episode {last}: the run has no greedy "
                "evaluation yet (too short for train.eval_every, or made before evaluations "
                "existed), so its last policy stands in for the best")
    return f"policy: seed {seed}, last checkpoint, episode {last} (--policy last)"


def score_kind(scenario: Scenario) -> str:
    """Whether a run's scores are percentages of the oracle ("pct") or sum rates ("rate")."""
    return "pct" if layout_reference(scenario) is not None else "rate"
