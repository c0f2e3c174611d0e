"""SAC's parameters by name and shape, torch-free: the one definition its stacked learner, its
checkpoints and the run-file validator share (docs/file-format.md).

Three MLPs of ReLU hidden layers, named as ``torch.nn.Sequential`` names them: the actor
(``actor.<i>.weight`` (out, in) and ``.bias``) reads the observation and outputs 2 D numbers,
the Gaussian's mean (the first D) and its log standard deviation before squashing (the last
D); the Q networks ``q1.*`` and ``q2.*`` read the observation and the action (obs + D inputs)
and output one value. The temperature is ``log_alpha`` (a scalar). With ``agent.network =
"set"`` each reads the observation through its own set encoder (``actor_set.*``,
``q1_set.*``, ``q2_set.*``).
"""

from __future__ import annotations

from adaptsky.algos.shared.set_layout import SetEncoder, reading_shapes

LOG_STD_MIN, LOG_STD_MAX = -5.0, 2.0
"""The actor's log standard deviation, squashed into this range (CleanRL)."""
Q_NETWORKS = ("q1", "q2")
TEMPERATURE_SHAPES: dict[str, tuple[int, ...]] = {"log_alpha": ()}


def actor_shapes(obs: int, hidden_sizes: list[int], components: int,
                 encoder: SetEncoder | None = None) -> dict[str, tuple[int, ...]]:
    """The actor (the greedy policy) for D = ``components``; with a set ``encoder`` its
    shared network ``actor_set.*`` first, the actor reading its output."""
    return reading_shapes("actor", obs, [*hidden_sizes, 2 * components], encoder)


def q_shapes(name: str, obs: int, hidden_sizes: list[int], components: int,
             encoder: SetEncoder | None = None) -> dict[str, tuple[int, ...]]:
    """Q network ``name`` (``q1`` or ``q2``) of an observation and an action (with a set
    ``encoder``, its own ``<name>_set.*`` first, reading the observation)."""
    return reading_shapes(name, obs, [*hidden_sizes, 1], encoder, extra_inputs=components)


def critic_shapes(obs: int, hidden_sizes: list[int], components: int,
                  encoder: SetEncoder | None = None) -> dict[str, tuple[int, ...]]:
    """Both Q networks, ``q1`` then ``q2`` (one optimizer's parameters)."""
    return {name: shape for q in Q_NETWORKS
            for name, shape in q_shapes(q, obs, hidden_sizes, components, encoder).items()}
