"""Exploration schedule of algorithm 1, line 5 (docs/model.md §4)."""

import math


def epsilon(global_step: int, start: float, end: float, decay_steps: float) -> float:
    """eps = eps_e + (eps_s - eps_e) exp(-step / chi), step = ep T + tau."""
    return end + (start - end) * math.exp(-global_step / decay_steps)
