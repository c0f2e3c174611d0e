"""What best response and OMA search where gains are drawn (sampled LoS, the built-in fading
of docs/model.md §11): the expected or mean gains (:func:`searched_scenario`), their rates
then taken under the policy's own draws, and the notes that say so in tables and files."""

from __future__ import annotations

from typing import Any

from adaptsky.rollouts.mean_shares import shares_apply
from adaptsky.rollouts.step_response import STEP_RESPONSE_NOTE
from adaptsky.scenario import Scenario
from adaptsky.scenario.variants import with_values

SAMPLED_LOS_NOTE = ("searched on the expected gains (channel.los = 'expected'), its rates "
                    "under the policy's own LoS draws (channel.los = 'sampled'): a reference, "
                    "not a bound")
"""What best response and OMA are under sampled LoS (their label in tables and files)."""


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


def refines_shares(scenario: Scenario) -> bool:
    """Whether best response chooses its shares over the policy's own draws at the positions
    it found (:func:`~adaptsky.rollouts.mean_shares.mean_best_shares`): under the built-in
    fading, where no minimum rate couples the clusters."""
    return scenario.channel.fading.model != "none" and shares_apply(scenario)


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


def _searched_gains(scenario: Scenario) -> tuple[str, str]:
    """What :func:`searched_scenario` searches on, in words, and what it is then valued
    under: ('the expected gains ...', 'LoS draws'), for a scenario with drawn gains."""
    if scenario.channel.fading.model == "none":
        return "the expected gains (channel.los = 'expected')", "LoS draws"
    if scenario.channel.los == "sampled":
        return ("the expected gains without fading (channel.los = 'expected', "
                "channel.fading.model = 'none')", "LoS and fading draws")
    return ("the mean gains, without fading (channel.fading.model = 'none': E|h|^2 = 1)",
            "fading draws")
