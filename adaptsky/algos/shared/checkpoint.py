"""A learner's part of a checkpoint that several learners share, torch-free
(docs/file-format.md): groups of torch-named weights, Adam's state as the stacked learners
store it, and the replay memory's fields and size (the DQN's, the BDQ's and SAC's)."""

from __future__ import annotations

from itertools import pairwise

from adaptsky.algos.protocol import LayoutCheck, Node
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.arrays import Field
from adaptsky.scenario.models import Scenario

FLOAT32 = 4
# /seeds/<S>/checkpoint/agent/<optimizer>/: Adam's step count and moments of every parameter
ADAM_STEP = Field("step", "int", ())
# /seeds/<S>/checkpoint/replay/: R rows in storage order, attr position
REPLAY = (
    Field("observations", "float", ("R", "O")),
    Field("actions", "int", ("R",)),
    Field("rewards", "float", ("R",)),
    Field("next_observations", "float", ("R", "O")),
    Field("terminated", "bool", ("R",)),
)


def check_weights(check: LayoutCheck, group: Node, shapes: dict[str, tuple[int, ...]]) -> None:
    """A group of torch-named parameters: every one of ``shapes``, nothing else."""
    check.exact_members(group, shapes)
    for param, shape in shapes.items():
        check.dataset(group, Field(param, "float", ()), {}, shape)


def check_adam(check: LayoutCheck, group: Node, shapes: dict[str, tuple[int, ...]]) -> None:
    """Adam's state of parameters ``shapes``: ``step``, ``exp_avg`` and ``exp_avg_sq``."""
    check.exact_members(group, ("step", "exp_avg", "exp_avg_sq"))
    check.dataset(group, ADAM_STEP, {})
    for name in ("exp_avg", "exp_avg_sq"):
        check_weights(check, check.group(group, name), shapes)


def replay_rows(scenario: Scenario, episodes: int, n_step: int = 1) -> tuple[int, int]:
    """Rows held and write position after ``episodes`` episodes of T steps (an ``n_step``
    window stores T - (n - 1) rows per episode; docs/agent.md)."""
    added = episodes * max(0, scenario.train.steps - n_step + 1)
    capacity = scenario.agent.memory_size
    return min(added, capacity), added % capacity


def check_replay(check: LayoutCheck, group: Node, scenario: Scenario, episodes_done: int,
                 fields: tuple[Field, ...], symbols: dict[str, int], n_step: int = 1) -> None:
    """``replay``: its write position after ``episodes_done`` episodes and its rows of
    ``fields`` (sizes ``symbols``, but R)."""
    replay = check.group(group, "replay")
    rows, position = replay_rows(scenario, episodes_done, n_step)
    stored_position = check.attr(replay, "position", "int")
    if stored_position != position:
        check.fail(f"{replay.name}/@position", f"is {stored_position}",
                   f"{position} after {episodes_done} episodes of "
                   f"{scenario.train.steps} steps")
    check.exact_members(replay, [field.name for field in fields])
    for field in fields:
        check.dataset(replay, field, {**symbols, "R": rows})


def replay_network_parts(scenario: Scenario, seeds: int, workers: int, head: float,
                         action_columns: int) -> dict[str, float]:
    """Bytes of a stacked Q-network learner with ``head`` outputs: replay (M rows of 2 obs + 2
    + ``action_columns`` float32, and a member's copy at a checkpoint, pickled to the writer
    when apart); networks and optimizer (policy, target, gradients, two Adam moments, and a
    checkpoint's copies); every layer's output for a batch, forward and backward."""
    agent = scenario.agent
    obs = observation_size_of(scenario)
    sizes = [obs, *agent.hidden_sizes]
    params = float(sum((a + 1) * b for a, b in pairwise(sizes)))
    params += (sizes[-1] + 1) * head
    replay_row = (2 * obs + 2 + action_columns) * FLOAT32
    hidden = float(sum(agent.hidden_sizes))
    return {
        "replay": (seeds + (3 if workers > 1 else 1)) * agent.memory_size * replay_row,
        "networks and optimizer": (5 * seeds + 2 * seeds + 8) * params * FLOAT32,
        "batch activations": seeds * agent.batch_size * (4 * (obs + hidden) + 8 * head)
        * FLOAT32,
    }
