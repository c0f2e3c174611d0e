"""Network shapes by name, torch-free: the one definition the stacked learners, their
checkpoints and the run-file validator share (docs/file-format.md).

An MLP's parameters are named as ``torch.nn.Sequential`` of Linear and activation layers names
them (``<prefix>.0.weight`` (out, in), ``<prefix>.0.bias``, ``<prefix>.2.weight`` ...). An
actor's head (:class:`HeadShape`) outputs the logits of the dense action set, of every branch
one after the other, or a Gaussian's mean.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise
from typing import Literal

from adaptsky.scenario.agents import world_observation_size
from adaptsky.scenario.models import Scenario
from adaptsky.sim.observation import local_observation_size, observation_size

Head = Literal["dense", "branches", "gaussian"]
Shapes = dict[str, tuple[int, ...]]


@dataclass(frozen=True)
class HeadShape:
    """What the actor's head outputs: ``kind``; ``width`` its outputs; ``branches`` the
    number of choices of each branch (branches only), ``components`` D (gaussian)."""

    kind: Head
    width: int
    branches: tuple[int, ...] = ()
    components: int = 0


def mlp_shapes(prefix: str, sizes: list[int]) -> Shapes:
    """Linear layers ``sizes`` = [in, hidden..., out], named as ``torch.nn.Sequential`` of
    Linear and activation layers names them (``<prefix>.0``, ``<prefix>.2`` ...)."""
    shapes: Shapes = {}
    for index, (size_in, size_out) in enumerate(pairwise(sizes)):
        shapes[f"{prefix}.{2 * index}.weight"] = (size_out, size_in)
        shapes[f"{prefix}.{2 * index}.bias"] = (size_out,)
    return shapes


def parameter_count(shapes: Shapes) -> int:
    """The numbers of every parameter of ``shapes``."""
    return sum(math.prod(shape) for shape in shapes.values())


def observation_size_of(scenario: Scenario) -> int:
    """The size of what ``scenario``'s agent observes, its networks' input: U local
    observations one after the other where it acts per UAV (``agent.local_view``: MAPPO,
    IPPO; docs/environment.md, "Local observations"), else the network's (4 N + 1 for one
    UAV, 5 N + 3 U for several)."""
    if getattr(scenario.agent, "local_view", False):
        return scenario.uav.count * local_input_size(scenario)
    return (observation_size(scenario.num_users, scenario.uav.count)
            + world_observation_size(scenario.agent, scenario.num_users, scenario.uav.count))


def local_input_size(scenario: Scenario) -> int:
    """One UAV's local observation L (docs/environment.md, "Local observations") and its
    observations of the world (``agent.observe``: its S user slots and its raster)."""
    return (local_observation_size(scenario)
            + world_observation_size(scenario.agent, scenario.users_per_uav, 1))
