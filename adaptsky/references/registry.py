"""The registry of baselines, references and bounds (docs/evaluation.md#references): every
command asks it which applies to a scenario, how much work it is and for its run, and
:func:`reference_for` gives the bound (or reference) a policy's curve is a percentage of.

A user names a method (``--compare oracle``); several objects may answer to one name, each
for the worlds it covers, and the first that applies runs: the oracle of one UAV is the
per-step oracle where the users move, the static ceiling under the built-in fading, else the
oracle; best response of several UAVs whose users move is best response at every step. Where
none applies, the refusal is that of the first which covers the scenario. Adding one is a
module and a line of :data:`REGISTRY` (docs/evaluation.md#adding-a-reference).
"""

from __future__ import annotations

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.progress import Tick
from adaptsky.references.baselines import RandomControls, Soa, Tracking
from adaptsky.references.centroid import CentroidHover
from adaptsky.references.oracles import Oracle, PerStepOracle, StaticCeiling
from adaptsky.references.reference import Reference
from adaptsky.references.searches import BestResponse, Oma, StepResponse
from adaptsky.rollouts.metrics import Method
from adaptsky.scenario import Scenario

_ORACLE = "the best lattice point and shares for one UAV"
_BEST_RESPONSE = "each UAV's best response to the others', in rounds (one UAV: the oracle)"
REGISTRY: tuple[Reference, ...] = (
    Soa("soa", "SoA", "each UAV planned once above its users (the paper's state of the art)"),
    Tracking("tracking", "tracking", "SoA re-planned at every step, flown there"),
    PerStepOracle("oracle", "oracle", f"{_ORACLE} at every step's positions (users move)"),
    StaticCeiling("oracle", "oracle", f"{_ORACLE}, fixed, over the fading draws"),
    Oracle("oracle", "oracle", f"{_ORACLE}, held: an upper bound on any policy"),
    StepResponse("best-response", "best response",
                 f"{_BEST_RESPONSE}, at every step's positions (users move)"),
    PerStepOracle("best-response", "best response", f"{_ORACLE} at every step's positions"),
    StaticCeiling("best-response", "best response", f"{_ORACLE}, fixed, over the fading draws"),
    BestResponse("best-response", "best response", _BEST_RESPONSE),
    Oma("oma", "OMA (best found)", "best response's search for OMA (half the band each)"),
    RandomControls("random", "random", "uniformly random controls"),
    CentroidHover("centroid", "centroid", "hovering above the users' centroid at the best "
                  "height"),
)
NAMES: tuple[str, ...] = tuple(dict.fromkeys(entry.name for entry in REGISTRY))
"""The methods users can ask for, in the order the docs and refusals list them."""
REFERENCE_ORDER = ("oracle", "best-response")
"""What a policy's steady state is a percentage of, the first that applies (or, among the
methods of an evaluation, the first compared): the oracle (one UAV), else best response
(several UAVs: a reference, never called the optimum)."""


class UnknownMethod(AdaptskyError):
    pass


def candidates(name: str) -> list[Reference]:
    """The objects that answer to ``name``, in the order they are tried."""
    found = [entry for entry in REGISTRY if entry.name == name]
    if not found:
        raise UnknownMethod(f"unknown method '{name}'; choose from {', '.join(NAMES)}")
    return found


def title_of(name: str) -> str:
    """``name``'s title in figures and tables ('SoA', 'OMA (best found)')."""
    return candidates(name)[0].title


def applying(name: str, scenario: Scenario) -> Reference | None:
    """The first object that answers to ``name`` and applies to ``scenario``, or None."""
    return next((entry for entry in candidates(name)
                 if entry.cluster_refusal(scenario) is None and entry.applies(scenario) is None),
                None)


def refusal(name: str, scenario: Scenario) -> str | None:
    """Why ``name`` has nothing to run on ``scenario`` (one line), or None where it runs."""
    if applying(name, scenario) is not None:
        return None
    tried = candidates(name)
    covering = next((entry for entry in tried if entry.covers(scenario)), tried[-1])
    return covering.cluster_refusal(scenario) or covering.applies(scenario)


def resolve(name: str, scenario: Scenario, option: str = "") -> Reference:
    """The object that runs ``name`` on ``scenario``; refused in one line where none
    applies (after ``option``, the command's option, where given and the line does not
    name the scenario itself)."""
    found = applying(name, scenario)
    if found is not None:
        return found
    reason = str(refusal(name, scenario))
    named = reason.startswith("scenario '")   # (a refusal naming its scenario stands alone)
    raise AdaptskyError(f"{option}: {reason}" if option and not named else reason)


def reference_for(scenario: Scenario) -> Reference | None:
    """The bound or reference a policy's curve on ``scenario`` is a percentage of (the
    first of :data:`REFERENCE_ORDER` that applies), or None."""
    return next((found for name in REFERENCE_ORDER
                 if (found := applying(name, scenario)) is not None), None)


def reference_words(scenario: Scenario) -> str:
    """What curves are a percentage of, as progress names it: 'oracle' for one UAV, 'best
    response' for several (docs/model.md §9)."""
    return "oracle" if scenario.uav.count == 1 else "best response"


def layout_reference(scenario: Scenario) -> Reference | None:
    """The reference of training's greedy evaluations: :func:`reference_for` where its value
    on a layout is fixed before any rollout (:meth:`Reference.per_layout`), else None."""
    found = reference_for(scenario)
    return found if found is not None and found.per_layout(scenario) else None


def work_of(name: str, scenario: Scenario, steps: int, users_m: np.ndarray
            ) -> tuple[int, str]:
    """How much work ``name`` is on ``scenario``, for progress: (count, unit)."""
    return resolve(name, scenario).work(scenario, steps, users_m)


def run_baseline(scenario: Scenario, method: str, steps: int, users_m: np.ndarray,
                 seed: int = 0, on_progress: Tick | None = None) -> Method:
    """The method ``method`` on the layouts ``users_m`` (L, N, 2), with the draws of
    ``seed``; ``on_progress`` hears the units of :func:`work_of` done. The searches' details:
    ``seconds_per_layout`` (``seconds_per_step`` for the per-step searches, where the users
    move) and ``objective_bps`` (L,); best response and OMA also ``rounds`` and
    ``converged`` (L,), and where they search other gains than the scenario's a ``note``."""
    return resolve(method, scenario).run(scenario, steps, users_m, seed, on_progress)
