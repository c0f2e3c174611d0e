"""The per-step objective baselines and policies are compared on: problem (10) of the paper
with w_f = 0, the sum rate when every user meets R_min, and 0 otherwise (eq. 13's rate term
divided by w_r / W)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def constrained_sum_rate(rate_bps: NDArray[np.float64], min_rate_bps: float
                         ) -> NDArray[np.float64]:
    """sum_i R_i if every R_i >= R_min, else 0; over the last (user) axis."""
    return np.where((rate_bps >= min_rate_bps).all(axis=-1), rate_bps.sum(axis=-1), 0.0)
