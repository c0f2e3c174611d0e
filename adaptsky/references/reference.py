"""What a baseline, reference or bound is: :class:`Reference`, the object the registry
(:mod:`adaptsky.references.registry`) holds one of per kind."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.progress import Tick
from adaptsky.rollouts.metrics import Method
from adaptsky.scenario import Scenario

Label = Literal["bound", "reference", "baseline"]


@dataclass(frozen=True)
class Reference:
    """One baseline or bound of an evaluation. ``name`` is the method users ask for
    (``--compare oracle``); several objects may answer to one name, each for the scenarios
    it ``covers`` (the oracle of users that move is the per-step oracle), the registry
    taking the first that ``applies``. ``title`` is its name in figures and ``what`` says
    what it is (what it bounds, for a bound)."""

    name: str
    title: str
    what: str
    any_cluster_size: ClassVar[bool] = False
    """Whether it runs on NOMA clusters of any size M (docs/model.md §15); else on pairs
    only, and refused in one line for M > 2 (:meth:`cluster_refusal`)."""
    uplink: ClassVar[bool] = False
    """Whether it runs on the uplink (docs/model.md §17); else refused in one line there."""

    def cluster_refusal(self, scenario: Scenario) -> str | None:
        """Why it does not run on ``scenario``'s NOMA (clusters of M > 2, the uplink), in one
        line, or None."""
        if scenario.uplink and not self.uplink:
            return (f"radio.direction: '{self.name}' plans or searches the downlink only, not "
                    "the uplink (docs/model.md §17 lists what runs on it)")
        size = scenario.cluster_size
        if size == 2 or self.any_cluster_size:
            return None
        return (f"users.cluster_size: '{self.name}' plans or searches NOMA pairs only, not "
                f"clusters of {size} users (docs/model.md §15 lists what runs on them)")

    def label(self, scenario: Scenario) -> Label:
        """A bound, a reference or a baseline, on ``scenario``."""
        return "baseline"

    def covers(self, scenario: Scenario) -> bool:
        """Whether ``scenario`` is of the kind this object is for (users that move, fading,
        several UAVs...): its refusal is then the one users see when nothing applies."""
        return True

    def applies(self, scenario: Scenario) -> str | None:
        """None where it runs on ``scenario``, else the one-line reason it does not."""
        return None

    def per_layout(self, scenario: Scenario) -> bool:
        """Whether its value on a layout is fixed before any rollout (a search of the layout
        alone, no draws of the policy's): training's greedy evaluations compare with it."""
        return False

    def layout_bps(self, scenario: Scenario, layouts_m: np.ndarray,
                   on_progress: Tick | None = None, cached_only: bool = False
                   ) -> np.ndarray | None:
        """Its value on each layout (L,), where :meth:`per_layout`: searched (``on_progress``
        hears the layouts done), or with ``cached_only`` only if the search cache has it
        (else None)."""
        raise NotImplementedError(f"{self.name} has no value per layout")

    def work(self, scenario: Scenario, steps: int, users_m: np.ndarray) -> tuple[int, str]:
        """How much work a run is, for progress: (count, unit)."""
        return steps, "step"

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        """Its rollout on the layouts ``users_m`` (L, N, 2) for ``steps`` steps, with the
        draws of ``seed`` (those of the policy it is compared with); ``on_progress`` hears
        the units of :meth:`work` done."""
        raise NotImplementedError


def refusal_of(check: Callable[[], object]) -> str | None:
    """The one line a ``require_...`` check raises, or None where it passes."""
    try:
        check()
    except AdaptskyError as error:
        return str(error)
    return None
