"""PPO's parameters by name and shape, torch-free (MLPs of :mod:`adaptsky.algos.shared.shapes`):
the one definition its stacked learner, its checkpoints and the run-file validator share
(docs/file-format.md).

Two MLPs read the observation: the actor (``actor.<i>.weight`` (out, in) and ``.bias``, its
last layer the head: the logits of the dense action set, of every branch one after the other,
or the Gaussian's mean) and the critic (``critic.<i>.*``, one output); a continuous actor adds
``log_std`` (D,), the state-independent log standard deviation. With ``agent.network =
"set"`` each reads the output of its own set encoder (``actor_set.*``, ``critic_set.*``).
"""

from __future__ import annotations

from adaptsky.algos.shared.set_layout import SetEncoder, reading_shapes
from adaptsky.algos.shared.shapes import HeadShape


def policy_shapes(obs: int, hidden_sizes: list[int], head: HeadShape,
                  encoder: SetEncoder | None = None) -> dict[str, tuple[int, ...]]:
    """The greedy policy's parameters: the actor (and ``log_std`` for a Gaussian); with a
    set ``encoder`` its shared network ``actor_set.*`` first, the actor reading its output."""
    shapes = reading_shapes("actor", obs, [*hidden_sizes, head.width], encoder)
    if head.kind == "gaussian":
        shapes["log_std"] = (head.components,)
    return shapes


def critic_shapes(obs: int, hidden_sizes: list[int], encoder: SetEncoder | None = None
                  ) -> dict[str, tuple[int, ...]]:
    """The critic's parameters (with a set ``encoder``, its own ``critic_set.*`` first)."""
    return reading_shapes("critic", obs, [*hidden_sizes, 1], encoder)
