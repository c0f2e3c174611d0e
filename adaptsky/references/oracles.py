"""The oracle of one UAV in each world it has one: the best lattice point and shares held
for the episode (static users, deterministic gains: an upper bound on any policy), the
per-step oracle where the users move (the best at every step, free to jump: an upper bound),
and under the built-in fading the static ceiling (the best fixed position and shares over
the policy's own fading draws: a ceiling for static policies only). Asked for as
``best-response``, one UAV's best response is the oracle itself (1 round, converged)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from adaptsky.progress import Tick
from adaptsky.references.reference import Label, Reference, refusal_of
from adaptsky.references.searches import best_response_bps
from adaptsky.rollouts.cluster_oracle import exact_oracle
from adaptsky.rollouts.fading_genie import FADING_GENIE_NOTE, per_step_fading_oracle
from adaptsky.rollouts.fading_oracle import (
    STATIC_CEILING_NOTE,
    fading_oracle,
    fading_oracle_refusal,
    require_fading_oracle,
)
from adaptsky.rollouts.genie import GENIE_NOTE, per_step_oracle
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.oracle import require_deterministic_gains, require_static_users
from adaptsky.rollouts.rollout import held_trace, hold
from adaptsky.rollouts.search import UPLINK_MAX_VECTORS
from adaptsky.scenario import Scenario
from adaptsky.sim.lattice import share_lattice
from adaptsky.sim.state import users_move

CSI_NOTE = ("searched with perfect channel knowledge (the true gains and SIC order): its "
            "objective bounds any policy; its rollout holds that configuration under the "
            "estimates' SIC order")
"""What the oracle is under imperfect channel knowledge (docs/model.md §16)."""


def _one_uav(scenario: Scenario, name: str) -> str | None:
    """The refusal of the oracle (asked for by ``name``) for several UAVs, else None."""
    count = scenario.uav.count
    if name == "oracle" and count > 1:
        return (f"the oracle is defined for one UAV; use best-response (scenario "
                f"'{scenario.name}' has {count} UAVs)")
    return None


def _uplink_refusal(scenario: Scenario) -> str | None:
    """Where the uplink's oracle would try more transmit-share vectors per point than
    :data:`~adaptsky.rollouts.search.UPLINK_MAX_VECTORS` (a residual or R_min > 0: no
    shortcut), the one-line refusal, else None."""
    if not scenario.uplink or not (scenario.radio.sic_residual or scenario.reward.min_se):
        return None
    vectors = len(share_lattice(scenario)) ** scenario.shares_per_cluster
    if vectors <= UPLINK_MAX_VECTORS:
        return None
    return (f"scenario '{scenario.name}': the uplink's oracle would try {vectors:,} transmit "
            f"share vectors at each lattice point (a SIC residual or R_min > 0 leaves no "
            f"shortcut; at most {UPLINK_MAX_VECTORS:,}); raise uav.power_step or use fewer "
            "users per cluster")


def _as_best_response(name: str, layouts: int) -> dict[str, Any]:
    """The search details of one UAV's best response where the oracle answers for it."""
    if name != "best-response":
        return {}
    return {"rounds": np.ones(layouts, dtype=np.int64),
            "converged": np.ones(layouts, dtype=np.bool_)}


@dataclass(frozen=True)
class Oracle(Reference):
    """The best lattice point and shares of one UAV, held (docs/model.md §8): exhaustive
    over the lattice (:mod:`adaptsky.rollouts.oracle`; for clusters of M > 2 users over every
    share vector too, :mod:`adaptsky.rollouts.cluster_oracle`)."""

    any_cluster_size = True
    uplink = True

    def label(self, scenario: Scenario) -> Label:
        return "bound"

    def applies(self, scenario: Scenario) -> str | None:
        return (_one_uav(scenario, self.name)
                or refusal_of(lambda: require_static_users(scenario))
                or refusal_of(lambda: require_deterministic_gains(scenario))
                or _uplink_refusal(scenario))

    def per_layout(self, scenario: Scenario) -> bool:
        # training's greedy evaluations take it from best response's cached search (for one
        # UAV the oracle's: the pairs' or, for clusters of M > 2 and the uplink, the cluster
        # oracle's)
        return True

    def work(self, scenario: Scenario, steps: int, users_m: np.ndarray) -> tuple[int, str]:
        return len(users_m), "layout"

    def layout_bps(self, scenario: Scenario, layouts_m: np.ndarray,
                   on_progress: Tick | None = None, cached_only: bool = False
                   ) -> np.ndarray | None:
        """Each layout's optimum (L,) by best response's search, which for one UAV is the
        oracle's (as training's greedy evaluations always took it: one cache entry)."""
        return best_response_bps(scenario, layouts_m, on_progress, cached_only)

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        start = time.process_time()
        best = exact_oracle(scenario, users_m, on_progress, on_progress)
        details = {"seconds_per_layout": (time.process_time() - start) / len(users_m),
                   "objective_bps": best.objective_bps}
        if scenario.channel.csi.model != "perfect":
            details["note"] = CSI_NOTE
        trace = hold(scenario, best.uav_m, best.alpha_first, 1, users_m, seed)
        return Method.of(self.name, scenario, trace, details)


@dataclass(frozen=True)
class PerStepOracle(Reference):
    """The best lattice point and shares at every step's user positions (and fading draws,
    under the built-in fading), free to jump between steps: one UAV whose users move, with
    LoS not sampled (:mod:`adaptsky.rollouts.genie`, :mod:`adaptsky.rollouts.fading_genie`)."""

    def label(self, scenario: Scenario) -> Label:
        return "bound"

    def covers(self, scenario: Scenario) -> bool:
        return users_move(scenario)

    def applies(self, scenario: Scenario) -> str | None:
        if (refused := _one_uav(scenario, self.name)) is not None:
            return refused
        if not users_move(scenario):
            return "the per-step oracle is for users that move"
        if scenario.channel.fading.model != "none" and fading_oracle_refusal(scenario):
            return refusal_of(lambda: require_fading_oracle(scenario))
        if scenario.channel.los == "sampled":
            what = "the oracle" if self.name == "oracle" else self.name
            return (f"scenario '{scenario.name}': channel.los is 'sampled'; where the users "
                    f"move {what} of one UAV is the per-step oracle, an upper bound that needs "
                    "deterministic LoS (channel.los = 'always', 'expected' or 'geometric'); "
                    "compare with soa, tracking or random, or evaluate with --set "
                    "channel.los=expected")
        return None

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        start = time.process_time()
        faded = scenario.channel.fading.model != "none"
        found = (per_step_fading_oracle if faded else per_step_oracle)(
            scenario, users_m, steps, seed, on_progress)
        details = {"seconds_per_step": (time.process_time() - start) / steps,
                   "objective_bps": found.objective_bps.mean(axis=0),
                   "note": FADING_GENIE_NOTE if faded else GENIE_NOTE,
                   **_as_best_response(self.name, len(users_m))}
        trace = held_trace(scenario, found.uav_m, found.alpha_first, users_m, seed)
        return Method.of(self.name, scenario, trace, details)


@dataclass(frozen=True)
class StaticCeiling(Reference):
    """Under the built-in fading (docs/model.md §11), the fixed position and shares of one
    UAV with the largest mean objective over the policy's own fading draws
    (:mod:`adaptsky.rollouts.fading_oracle`): a ceiling for static policies, not a bound on
    policies that move. Asked for as the oracle it is the oracle under fading; as best
    response, only where it applies (else best response searches the mean gains)."""

    def label(self, scenario: Scenario) -> Label:
        return "reference"

    def covers(self, scenario: Scenario) -> bool:
        return scenario.channel.fading.model != "none" and (
            self.name == "oracle" or fading_oracle_refusal(scenario) is None)

    def applies(self, scenario: Scenario) -> str | None:
        return (_one_uav(scenario, self.name)
                or refusal_of(lambda: require_static_users(scenario))
                or refusal_of(lambda: require_fading_oracle(scenario)))

    def work(self, scenario: Scenario, steps: int, users_m: np.ndarray) -> tuple[int, str]:
        return len(users_m), "layout"

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        start = time.process_time()
        ceiling = fading_oracle(scenario, users_m, steps, seed, on_progress, on_progress)
        details = {"seconds_per_layout": (time.process_time() - start) / len(users_m),
                   "objective_bps": ceiling.objective_bps, "note": STATIC_CEILING_NOTE,
                   **_as_best_response(self.name, len(users_m))}
        trace = hold(scenario, ceiling.uav_m, ceiling.alpha_first, steps, users_m, seed)
        return Method.of(self.name, scenario, trace, details)
