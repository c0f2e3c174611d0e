"""PPO's parameters by name and shape, torch-free: the one definition its stacked learner, its
checkpoints and the run-file validator share (docs/file-format.md).

Two MLPs read the observation: the actor (``actor.<i>.weight`` (out, in) and ``.bias``, its
last layer the head: the logits of the dense action set, of every branch one after the other,
or the Gaussian's mean) and the critic (``critic.<i>.*``, one output); a continuous actor adds
``log_std`` (D,), the state-independent log standard deviation.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from typing import Literal

Head = Literal["dense", "branches", "gaussian"]


@dataclass(frozen=True)
class HeadShape:
    """What the actor's head outputs: ``kind``; ``width`` its outputs; ``branches`` the
    number of choices of each branch (branches only), ``components`` D (gaussian)."""

    kind: Head
    width: int
    branches: tuple[int, ...] = ()
    components: int = 0


def mlp_shapes(prefix: str, sizes: list[int]) -> dict[str, tuple[int, ...]]:
    """Linear layers ``sizes`` = [in, hidden..., out], named as ``torch.nn.Sequential`` of
    Linear and activation layers names them (``<prefix>.0``, ``<prefix>.2`` ...)."""
    shapes: dict[str, tuple[int, ...]] = {}
    for index, (size_in, size_out) in enumerate(pairwise(sizes)):
        shapes[f"{prefix}.{2 * index}.weight"] = (size_out, size_in)
        shapes[f"{prefix}.{2 * index}.bias"] = (size_out,)
    return shapes


def policy_shapes(obs: int, hidden_sizes: list[int], head: HeadShape
                  ) -> dict[str, tuple[int, ...]]:
    """The greedy policy's parameters: the actor (and ``log_std`` for a Gaussian)."""
    shapes = mlp_shapes("actor", [obs, *hidden_sizes, head.width])
    if head.kind == "gaussian":
        shapes["log_std"] = (head.components,)
    return shapes


def critic_shapes(obs: int, hidden_sizes: list[int]) -> dict[str, tuple[int, ...]]:
    """The critic's parameters."""
    return mlp_shapes("critic", [obs, *hidden_sizes, 1])


def parameter_count(shapes: dict[str, tuple[int, ...]]) -> int:
    count = 0
    for shape in shapes.values():
        size = 1
        for n in shape:
            size *= n
        count += size
    return count
