"""PPO's parameters by name and shape, torch-free (MLPs of :mod:`adaptsky.algos.shared.shapes`):
the one definition its stacked learner, its checkpoints and the run-file validator share
(docs/file-format.md).

Two MLPs read the observation: the actor (``actor.<i>.weight`` (out, in) and ``.bias``, its
last layer the head: the logits of the dense action set, of every branch one after the other,
or the Gaussian's mean) and the critic (``critic.<i>.*``, one output); a continuous actor adds
``log_std`` (D,), the state-independent log standard deviation.
"""

from __future__ import annotations

from adaptsky.algos.shared.shapes import HeadShape, mlp_shapes


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
