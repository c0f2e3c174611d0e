"""The baselines of an evaluation (docs/evaluation.md#baselines): which apply to a scenario,
how much work each is, and one run on L layouts as a :class:`Method`.

One UAV: SoA, the oracle, best response (the oracle itself), OMA and random. Several UAVs
(docs/model.md §9): SoA per UAV, best response (the reference), OMA and random; the oracle
is defined for one UAV and refused. The searches (oracle, best response, OMA) hold what they
found for one step, as gains are deterministic; OMA's rates are its own (each user of a
cluster on half the band with half the power), held as the search computed them, since the
environment computes NOMA rates. Under sampled LoS best response and OMA search the expected
gains and hold what they found for every step, their rates taken under the policy's own LoS
draws (:data:`SAMPLED_LOS_NOTE`); under the built-in fading (docs/model.md §11) they search
the mean gains, without fading, and hold what they found under the policy's own fading draws,
best response with each cluster's share chosen for the largest mean sum rate over those draws
where no minimum rate binds (:func:`searched_note`): a reference for static policies, not a
bound. Where the users walk, every rollout moves them with the same draws as the policy's;
the oracle (and best response) of one UAV is then the per-step oracle (with LoS not sampled;
under the built-in fading with no minimum rate), best response of several UAVs best response
at every step (under sampled LoS or the built-in fading searched on the expected or mean
gains and valued under the policy's own draws: :func:`step_response_note`), and OMA, which
finds one configuration for the users' home positions, is refused.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.progress import Tick
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.fading_genie import FADING_GENIE_NOTE, per_step_fading_oracle
from adaptsky.rollouts.fading_oracle import (
    STATIC_CEILING_NOTE,
    fading_oracle,
    fading_oracle_refusal,
    require_fading_oracle,
)
from adaptsky.rollouts.genie import GENIE_NOTE, per_step_oracle
from adaptsky.rollouts.mean_shares import mean_best_shares, shares_apply
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.oracle import oracle, require_deterministic_gains, require_static_users
from adaptsky.rollouts.rollout import (
    Trace,
    held_trace,
    hold,
    random_controls_policy,
    rollout,
)
from adaptsky.rollouts.several_uavs import SearchResult
from adaptsky.rollouts.soa import soa_configuration
from adaptsky.rollouts.step_response import STEP_RESPONSE_NOTE, per_step_response
from adaptsky.rollouts.tracking import track
from adaptsky.scenario import Scenario
from adaptsky.scenario.variants import with_values
from adaptsky.sim.controls import controls_of
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.state import users_move
from adaptsky.store.search_cache import search_once

BASELINES = ("soa", "tracking", "oracle", "best-response", "oma", "random")
SEARCHES = ("oracle", "best-response", "oma")
"""Searches over the lattice: they need deterministic gains and count layouts as progress."""
REFERENCES = ("oracle", "best-response")
"""What a policy's steady state is a percentage of, the first compared: the oracle (one UAV),
else best response (our reference for several UAVs, never called the optimum)."""
OMA_POWER_SHARE = 0.5
"""Each OMA user's share of its cluster's power (and of its band): the trace's ``alpha``."""


class EvaluationError(AdaptskyError):
    pass


SAMPLED_LOS_NOTE = ("searched on the expected gains (channel.los = 'expected'), its rates "
                    "under the policy's own LoS draws (channel.los = 'sampled'): a reference, "
                    "not a bound")
"""What best response and OMA are under sampled LoS (their label in tables and files)."""


def require_applies(scenario: Scenario, method: str, option: str = "") -> None:
    """Refuse, in one line (starting with ``option``, the command's option, if given), a
    baseline the scenario cannot have: the oracle for several UAVs; OMA where the users walk;
    the oracle (and best response) of one UAV where the users walk and no per-step oracle
    applies (:func:`_refuse_per_step`: the true reason); a search where gains are drawn at
    random (best response and OMA search sampled LoS on its expected gains:
    :func:`searched_scenario`)."""
    count = scenario.uav.count
    if method == "oracle" and count > 1:
        where = f"{option}: " if option else ""
        raise EvaluationError(f"{where}the oracle is defined for one UAV; use best-response "
                              f"(scenario '{scenario.name}' has {count} UAVs)")
    if method in SEARCHES:
        name = "the oracle" if method == "oracle" else method
        if per_step_reference(scenario, method):
            return
        if method in REFERENCES and users_move(scenario):
            _refuse_per_step(scenario, name)
        require_static_users(scenario, name)
        if method == "oracle" and scenario.channel.fading.model != "none":
            require_fading_oracle(scenario)
            return
        require_deterministic_gains(scenario if method == "oracle" else
                                    searched_scenario(scenario), name)


def per_step_reference(scenario: Scenario, method: str) -> bool:
    """Whether ``method`` is searched at every step where the users move: the oracle or best
    response of one UAV, the per-step oracle (:mod:`adaptsky.rollouts.genie`, under the
    built-in fading where its oracle applies :mod:`adaptsky.rollouts.fading_genie`), with LoS
    not sampled; best response of several UAVs, best response at every step
    (:mod:`adaptsky.rollouts.step_response`), searched on the gains of
    :func:`searched_scenario` (the mean or expected ones under fading or sampled LoS) and
    valued under the policy's own draws."""
    if not (method in REFERENCES and users_move(scenario)):
        return False
    if scenario.uav.count > 1:
        return method == "best-response"
    return scenario.channel.los != "sampled" and (
        scenario.channel.fading.model == "none" or fading_oracle_refusal(scenario) is None)


def _refuse_per_step(scenario: Scenario, name: str) -> None:
    """Refuse, in one line with the true reason, the oracle (or best response, ``name``) of
    one UAV where the users move and no per-step oracle applies: under the built-in fading
    the reason of the fading oracle (a minimum rate, sampled LoS), else sampled LoS."""
    if scenario.channel.fading.model != "none":
        require_fading_oracle(scenario)
    raise EvaluationError(
        f"scenario '{scenario.name}': channel.los is 'sampled'; where the users move {name} "
        "of one UAV is the per-step oracle, an upper bound that needs deterministic LoS "
        "(channel.los = 'always', 'expected' or 'geometric'); compare with soa, tracking or "
        "random, or evaluate with --set channel.los=expected")


def static_ceiling(scenario: Scenario, method: str) -> bool:
    """Whether ``method`` is the fading oracle (:mod:`adaptsky.rollouts.fading_oracle`): the
    oracle, or best response of one UAV (the oracle itself), under the built-in fading where
    it applies."""
    return (method in REFERENCES and scenario.channel.fading.model != "none"
            and fading_oracle_refusal(scenario) is None)


def searched_scenario(scenario: Scenario) -> Scenario:
    """The scenario best response and OMA search on: as it is, or under sampled LoS the
    same with every link at its expected gain (``channel.los = "expected"``), and under the
    built-in fading at its mean gain (``channel.fading.model = "none"``: E|h|^2 = 1)."""
    values: dict[str, Any] = {}
    if scenario.channel.los == "sampled":
        values["los"] = "expected"
    if scenario.channel.fading.model != "none":
        values["fading"] = {"model": "none"}
    if not values:
        return scenario
    shown = ", ".join(f"channel.{key} = 'expected'" if key == "los" else
                      "channel.fading.model = 'none'" for key in values)
    return with_values(scenario, "channel", values, f"{scenario.name} with {shown}")


def searched_note(scenario: Scenario, method: str = "best-response") -> str | None:
    """What best response (``method``) or OMA is on ``scenario`` where it searches another
    one (:func:`searched_scenario`): the note of its results (:data:`SAMPLED_LOS_NOTE` under
    sampled LoS alone), else None. Under the built-in fading best response's shares are then
    those of the largest mean sum rate over the policy's draws where no minimum rate binds
    (:func:`refines_shares`)."""
    if scenario.channel.fading.model == "none":
        return SAMPLED_LOS_NOTE if scenario.channel.los == "sampled" else None
    gains, draws = _searched_gains(scenario)
    shares = ""
    if method == "best-response":
        shares = (f", each cluster's share then the one of the largest mean sum rate over the "
                  f"policy's own {draws} there" if refines_shares(scenario) else
                  " (its shares as searched: a minimum rate couples the clusters)")
    return (f"searched on {gains}{shares}, its rates under the policy's own {draws}: a "
            "reference for static policies, not a bound")


def _searched_gains(scenario: Scenario) -> tuple[str, str]:
    """What :func:`searched_scenario` searches on, in words, and what it is then valued
    under: ('the expected gains ...', 'LoS draws'), for a scenario with drawn gains."""
    sampled = scenario.channel.los == "sampled"
    if scenario.channel.fading.model == "none":
        return "the expected gains (channel.los = 'expected')", "LoS draws"
    if sampled:
        return ("the expected gains without fading (channel.los = 'expected', "
                "channel.fading.model = 'none')", "LoS and fading draws")
    return ("the mean gains, without fading (channel.fading.model = 'none': E|h|^2 = 1)",
            "fading draws")


def step_response_note(scenario: Scenario) -> str:
    """What best response at every step (several UAVs, users that move) is on ``scenario``:
    :data:`STEP_RESPONSE_NOTE` on deterministic gains; under sampled LoS or the built-in
    fading, searched on the gains of :func:`searched_scenario` at every step and valued
    under the policy's own draws: a reference, not a bound."""
    if scenario.channel.los != "sampled" and scenario.channel.fading.model == "none":
        return STEP_RESPONSE_NOTE
    gains, draws = _searched_gains(scenario)
    return (f"best response at every step's user positions on {gains}, from the previous "
            f"step's configuration, its rates under the policy's own {draws}: a reference, "
            "not a bound")


def refines_shares(scenario: Scenario) -> bool:
    """Whether best response chooses its shares over the policy's own draws at the positions
    it found (:func:`~adaptsky.rollouts.mean_shares.mean_best_shares`): under the built-in
    fading, where no minimum rate couples the clusters."""
    return scenario.channel.fading.model != "none" and shares_apply(scenario)


def baseline_work(method: str, steps: int, users_m: np.ndarray,
                  scenario: Scenario | None = None) -> tuple[int, str]:
    """How much work a baseline is, for progress: (count, unit); the per-step oracle of
    ``scenario`` (users that move) counts steps."""
    if method in SEARCHES and not (scenario is not None
                                   and per_step_reference(scenario, method)):
        return len(users_m), "layout"
    return steps, "step"


def run_baseline(scenario: Scenario, method: str, steps: int, users_m: np.ndarray,
                 seed: int = 0, on_progress: Tick | None = None) -> Method:
    """A baseline of :data:`BASELINES` on ``users_m`` (L, N, 2); ``on_progress`` hears the
    units of :func:`baseline_work` done (the searches: within a layout too, with where they
    are). The searches' details: ``seconds_per_layout`` (``seconds_per_step`` for the
    per-step searches, where the users move) and ``objective_bps`` (L,); best response and
    OMA also ``rounds`` and ``converged`` (L,), and under sampled LoS or the built-in fading
    a ``note`` (:func:`searched_note`). Every rollout moves the
    users as the policy's does, with the same draws (:func:`~adaptsky.rollouts.rollout.hold`):
    SoA plans once and its rates are taken at each step's positions."""
    if method not in BASELINES:
        raise EvaluationError(f"unknown method '{method}'; choose from {', '.join(BASELINES)}")
    require_applies(scenario, method)
    details: dict[str, Any] = {}
    one_uav = scenario.uav.count == 1
    if method == "soa":
        if one_uav:
            env = NetworkBatch(scenario, num_envs=len(users_m), users_m=users_m)
            uav_m, alpha_first = soa_configuration(env)
        else:
            uav_m, alpha_first = several_uavs.soa_per_uav(scenario, users_m)
        trace = hold(scenario, uav_m, alpha_first, steps, users_m, seed, on_progress)
    elif per_step_reference(scenario, method) and not one_uav:
        found_steps = per_step_response(scenario, users_m, steps, seed,
                                        on_step=on_progress)
        details["seconds_per_step"] = found_steps.seconds_per_step
        details["objective_bps"] = found_steps.objective_bps.mean(axis=0)
        details["note"] = step_response_note(scenario)
        details["rounds"] = found_steps.rounds.max(axis=0)
        # a step that used every round may not have converged
        details["converged"] = found_steps.rounds.max(axis=0) < several_uavs.DEFAULT_ROUNDS
        trace = held_trace(scenario, found_steps.uav_m, found_steps.alpha_first, users_m,
                           seed)
    elif per_step_reference(scenario, method):
        start = time.process_time()
        faded = scenario.channel.fading.model != "none"
        found = (per_step_fading_oracle if faded else per_step_oracle)(
            scenario, users_m, steps, seed, on_progress)
        details["seconds_per_step"] = (time.process_time() - start) / steps
        details["objective_bps"] = found.objective_bps.mean(axis=0)
        details["note"] = FADING_GENIE_NOTE if faded else GENIE_NOTE
        if method == "best-response":
            details["rounds"] = np.ones(len(users_m), dtype=np.int64)
            details["converged"] = np.ones(len(users_m), dtype=np.bool_)
        trace = held_trace(scenario, found.uav_m, found.alpha_first, users_m, seed)
    elif static_ceiling(scenario, method):
        start = time.process_time()
        ceiling = fading_oracle(scenario, users_m, steps, seed, on_progress, on_progress)
        details["seconds_per_layout"] = (time.process_time() - start) / len(users_m)
        details["objective_bps"] = ceiling.objective_bps
        details["note"] = STATIC_CEILING_NOTE
        if method == "best-response":
            details["rounds"] = np.ones(len(users_m), dtype=np.int64)
            details["converged"] = np.ones(len(users_m), dtype=np.bool_)
        trace = hold(scenario, ceiling.uav_m, ceiling.alpha_first, steps, users_m, seed)
    elif method == "oracle":
        start = time.process_time()
        best = oracle(scenario, users_m, on_progress, on_progress)
        details["seconds_per_layout"] = (time.process_time() - start) / len(users_m)
        details["objective_bps"] = best.objective_bps
        trace = hold(scenario, best.uav_m, best.alpha_first, 1, users_m, seed)
    elif method in SEARCHES:
        searched = searched_scenario(scenario)
        found = search(searched, method, users_m, on_progress)
        details |= search_details(found)
        uav_m = found.uav_m[:, 0] if one_uav else found.uav_m
        drawn = searched is not scenario   # rates under the policy's draws, every step
        if drawn:
            details["note"] = searched_note(scenario, method)
        if method == "best-response":
            alpha_first = found.alpha_first[:, 0] if one_uav else found.alpha_first
            if refines_shares(scenario):
                alpha_first = mean_best_shares(scenario, uav_m, alpha_first, steps, users_m,
                                               seed)
            trace = hold(scenario, uav_m, alpha_first, steps if drawn else 1, users_m, seed)
        elif drawn:
            held = found.alpha_first[:, 0] if one_uav else found.alpha_first  # NaN: no split
            trace = hold(scenario, uav_m, np.full(held.shape, OMA_POWER_SHARE), steps,
                         users_m, seed, oma=True)
        else:
            hover_j = NetworkBatch(scenario, len(users_m), users_m=users_m).hover_energy_j
            trace = Trace(found.rate_bps[None].copy(), uav_m[None].copy(),
                          np.full((1, *found.rate_bps.shape), OMA_POWER_SHARE),
                          hover_j[None].copy())
    elif method == "tracking":
        trace = track(scenario, steps, users_m, seed, on_progress)
    else:
        policy = random_controls_policy(controls_of(scenario, len(users_m)), seed)
        trace = rollout(scenario, policy, steps, users_m, seed, on_progress)
    return Method.of(method, scenario, trace, details)


def search(scenario: Scenario, method: str, users_m: np.ndarray,
           on_progress: Tick | None = None) -> SearchResult:
    """Best response (for one UAV the oracle: 1 round, converged) or OMA
    (:mod:`adaptsky.rollouts.several_uavs`) on ``users_m``, from the search cache where it
    has them (:mod:`adaptsky.store.search_cache`)."""
    run = several_uavs.best_oma if method == "oma" else several_uavs.best_response
    return search_once(scenario, users_m, lambda: run(
        scenario, users_m, on_layout=on_progress, on_search=on_progress),
        "oma" if method == "oma" else "best-response")


def search_details(found: SearchResult) -> dict[str, Any]:
    """What an eval file keeps of a search besides its trace."""
    return {"seconds_per_layout": float(found.seconds_per_layout),
            "objective_bps": np.asarray(found.objective_bps, dtype=np.float64),
            "rounds": np.asarray(found.rounds, dtype=np.int64),
            "converged": np.asarray(found.converged, dtype=np.bool_)}
