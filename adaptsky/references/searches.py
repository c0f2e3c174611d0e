"""Best response (docs/model.md §9: for one UAV the oracle itself), best response at every
step where several UAVs' users move, and OMA's best configuration found: searches over the
lattice, from the search cache where it has them (:mod:`adaptsky.store.search_cache`).
Under sampled LoS or the built-in fading they search the expected or mean gains and hold
what they found under the policy's own draws (:mod:`adaptsky.references.searched`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from adaptsky.progress import Tick
from adaptsky.references.reference import Label, Reference, refusal_of
from adaptsky.references.searched import (
    refines_shares,
    searched_note,
    searched_scenario,
    step_response_note,
)
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.mean_shares import mean_best_shares
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.oracle import require_deterministic_gains, require_static_users
from adaptsky.rollouts.rollout import Trace, held_trace, hold
from adaptsky.rollouts.several_uavs import SearchResult
from adaptsky.rollouts.step_response import per_step_response
from adaptsky.scenario import Scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.state import users_move
from adaptsky.store.search_cache import cached_search, search_once

OMA_POWER_SHARE = 0.5
"""The power components OMA holds in the environment, which computes NOMA rates its own
rates replace (each OMA user's share of its cluster's power and band, the trace's ``alpha``,
is 1/M: 0.5 in a pair)."""


def search(scenario: Scenario, method: str, users_m: np.ndarray,
           on_progress: Tick | None = None) -> SearchResult:
    """Best response (for one UAV the oracle: 1 round, converged) or OMA
    (:mod:`adaptsky.rollouts.several_uavs`) on ``users_m``, from the search cache where it
    has them (:mod:`adaptsky.store.search_cache`)."""
    run = several_uavs.best_oma if method == "oma" else several_uavs.best_response
    return search_once(scenario, users_m, lambda: run(
        scenario, users_m, on_layout=on_progress, on_search=on_progress),
        "oma" if method == "oma" else "best-response")


def best_response_bps(scenario: Scenario, layouts_m: np.ndarray,
                      on_progress: Tick | None = None, cached_only: bool = False
                      ) -> np.ndarray | None:
    """Best response's objective on each layout (L,) (for one UAV the oracle's optimum), from
    the search cache where it has it; with ``cached_only`` None where it has not."""
    if cached_only:
        found = cached_search(scenario, layouts_m)
        return None if found is None else found.objective_bps
    return search(scenario, "best-response", layouts_m, on_progress).objective_bps


def search_details(found: SearchResult) -> dict[str, Any]:
    """What an eval file keeps of a search besides its trace."""
    return {"seconds_per_layout": float(found.seconds_per_layout),
            "objective_bps": np.asarray(found.objective_bps, dtype=np.float64),
            "rounds": np.asarray(found.rounds, dtype=np.int64),
            "converged": np.asarray(found.converged, dtype=np.bool_)}


@dataclass(frozen=True)
class _LatticeSearch(Reference):
    """A search of one configuration per layout (best response, OMA) on the gains of
    :func:`searched_scenario`, for users that stand."""

    def applies(self, scenario: Scenario) -> str | None:
        return (refusal_of(lambda: require_static_users(scenario, self.name))
                or refusal_of(lambda: require_deterministic_gains(
                    searched_scenario(scenario), self.name)))

    def work(self, scenario: Scenario, steps: int, users_m: np.ndarray) -> tuple[int, str]:
        return len(users_m), "layout"

    def found(self, scenario: Scenario, users_m: np.ndarray, on_progress: Tick | None
              ) -> tuple[SearchResult, dict[str, Any], np.ndarray, np.ndarray, bool]:
        """The search on ``users_m``: its result, details (a note where it searched other
        gains than the scenario's), the positions and first shares found (one UAV's without
        the UAV axis), and whether the gains are drawn (its rates then under the draws)."""
        searched = searched_scenario(scenario)
        result = search(searched, self.name, users_m, on_progress)
        details = search_details(result)
        drawn = searched is not scenario   # rates under the policy's draws, every step
        if drawn:
            details["note"] = searched_note(scenario, self.name)
        if scenario.uav.count == 1:
            return result, details, result.uav_m[:, 0], result.alpha_first[:, 0], drawn
        return result, details, result.uav_m, result.alpha_first, drawn


@dataclass(frozen=True)
class BestResponse(_LatticeSearch):
    """Each UAV in turn moved to its best lattice point and shares given the others', in
    rounds until none moves (docs/model.md §9); under the built-in fading each cluster's
    share then chosen over the policy's own draws where no minimum rate binds. Clusters of
    M > 2 and the uplink search every share vector of the grid (§15, §17), without fading."""

    any_cluster_size = True
    uplink = True

    def applies(self, scenario: Scenario) -> str | None:
        if scenario.sic_chains and scenario.channel.fading.model != "none":
            what = ("the uplink" if scenario.uplink
                    else f"clusters of {scenario.cluster_size} users")
            return (f"channel.fading: '{self.name}' chooses shares over fading draws for the "
                    f"downlink's NOMA pairs only, not for {what} (docs/model.md §15, §17); "
                    "set channel.fading.model = 'none'")
        return super().applies(scenario) or several_uavs.response_refusal(scenario)

    def label(self, scenario: Scenario) -> Label:
        exact = scenario.uav.count == 1 and searched_scenario(scenario) is scenario
        return "bound" if exact else "reference"

    def per_layout(self, scenario: Scenario) -> bool:
        return searched_scenario(scenario) is scenario

    def layout_bps(self, scenario: Scenario, layouts_m: np.ndarray,
                   on_progress: Tick | None = None, cached_only: bool = False
                   ) -> np.ndarray | None:
        return best_response_bps(scenario, layouts_m, on_progress, cached_only)

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        _, details, uav_m, alpha_first, drawn = self.found(scenario, users_m, on_progress)
        if refines_shares(scenario):
            alpha_first = mean_best_shares(scenario, uav_m, alpha_first, steps, users_m, seed)
        trace = hold(scenario, uav_m, alpha_first, steps if drawn else 1, users_m, seed)
        return Method.of(self.name, scenario, trace, details)


@dataclass(frozen=True)
class Oma(_LatticeSearch):
    """The best configuration found for OMA (each user of a cluster of M on 1/M of the band
    with 1/M of the power), by best response's search; its rates its own, held as found,
    since the environment computes NOMA rates."""

    any_cluster_size = True

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        result, details, uav_m, held, drawn = self.found(scenario, users_m, on_progress)
        if drawn:   # (held: NaN, OMA splits no power)
            trace = hold(scenario, uav_m, np.full(held.shape, OMA_POWER_SHARE), steps,
                         users_m, seed, oma=True)
        else:
            hover_j = NetworkBatch(scenario, len(users_m), users_m=users_m).hover_energy_j
            trace = Trace(result.rate_bps[None].copy(), uav_m[None].copy(),
                          np.full((1, *result.rate_bps.shape), 1 / scenario.cluster_size),
                          hover_j[None].copy())
        return Method.of(self.name, scenario, trace, details)


@dataclass(frozen=True)
class StepResponse(Reference):
    """Best response at every step's user positions, several UAVs whose users move
    (:mod:`adaptsky.rollouts.step_response`), from the previous step's configuration; under
    sampled LoS or the built-in fading searched on the gains of :func:`searched_scenario`
    and valued under the policy's own draws."""

    def label(self, scenario: Scenario) -> Label:
        return "reference"

    def covers(self, scenario: Scenario) -> bool:
        return users_move(scenario) and scenario.uav.count > 1

    def applies(self, scenario: Scenario) -> str | None:
        if scenario.uav.count == 1:
            return "best response at every step is for several UAVs"
        if not users_move(scenario):
            return "best response at every step is for users that move"
        return None

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        found = per_step_response(scenario, users_m, steps, seed, on_step=on_progress)
        rounds = found.rounds.max(axis=0)
        details = {"seconds_per_step": found.seconds_per_step,
                   "objective_bps": found.objective_bps.mean(axis=0),
                   "note": step_response_note(scenario), "rounds": rounds,
                   # a step that used every round may not have converged
                   "converged": rounds < several_uavs.DEFAULT_ROUNDS}
        trace = held_trace(scenario, found.uav_m, found.alpha_first, users_m, seed)
        return Method.of(self.name, scenario, trace, details)
