"""Baselines of several UAVs (docs/model.md §9): SoA per UAV, best response, OMA.

- **SoA per UAV** (:func:`soa_per_uav`): every UAV at its group's 2D centroid at the start
  height, each cluster's power split of docs/model.md §6 planned without interference; rates
  evaluated with the true interference.
- **Best response** (:func:`best_response`, our reference, never called the optimum): from
  SoA's positions, each UAV in turn takes the lattice point and alphas (the oracle's lattice,
  docs/model.md §6) that maximise the whole network's objective with the others fixed (its
  interference on the other groups included); rounds until one gains less than 1e-9
  relative, or ``rounds`` rounds. For U = 1 it is the oracle.
- **OMA** (:func:`best_oma`): the same search when each cluster's two users share its
  resources orthogonally (half the band and half the power each).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario

FloatArray = NDArray[np.float64]
DEFAULT_ROUNDS = 10
RELATIVE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class SearchResult:
    """The configuration a search found for each of L layouts: ``objective_bps`` (L,) the
    constrained sum rate (0 where no point meets R_min), ``uav_m`` (L, U, 3),
    ``alpha_first`` (L, U, K_u) (NaN for OMA, which splits no power), ``rate_bps`` (L, N)
    every user's rate there, ``rounds`` (L,) rounds run, ``converged`` (L,) whether the last
    round gained less than 1e-9 relative (True for U = 1: the oracle is one search),
    ``seconds_per_layout`` the process time per layout."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    rate_bps: FloatArray
    rounds: NDArray[np.int64]
    converged: NDArray[np.bool_]
    seconds_per_layout: float


def soa_per_uav(scenario: Scenario, users_m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """UAV positions (L, U, 3) and first users' shares (L, U, K_u) of SoA per UAV on the
    layouts ``users_m`` (L, N, 2)."""
    raise NotImplementedError


def best_response(scenario: Scenario, users_m: FloatArray, *, rounds: int = DEFAULT_ROUNDS,
                  on_layout: Callable[[int], None] | None = None) -> SearchResult:
    """Best response on every layout (module doc); ``on_layout`` hears the layouts done."""
    raise NotImplementedError


def best_oma(scenario: Scenario, users_m: FloatArray, *, rounds: int = DEFAULT_ROUNDS,
             on_layout: Callable[[int], None] | None = None) -> SearchResult:
    """The best OMA configuration found the same way (module doc)."""
    raise NotImplementedError
