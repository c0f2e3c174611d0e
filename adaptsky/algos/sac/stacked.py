"""SAC's networks for a stack of S members: the actor, the Q networks (``q1`` and ``q2`` in one
buffer) and the temperature, each a
:class:`~adaptsky.algos.shared.stacked.StackedParameters` with its own Adam state (CleanRL's
three optimizers, eps 1e-8 as ``torch.optim.Adam``'s default), and the Q networks' targets, a
buffer of the critics' layout. Initial weights are ``torch.nn.Linear``'s own under
``torch.manual_seed(seed)`` (the actor, then q1, then q2; CleanRL's networks keep them); the
targets start as copies; ``log_alpha`` at 0 (alpha 1, autotune) or log(alpha).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from adaptsky.algos.sac.parameters import (
    LOG_STD_MAX,
    LOG_STD_MIN,
    Q_NETWORKS,
    TEMPERATURE_SHAPES,
    actor_shapes,
    critic_shapes,
)
from adaptsky.algos.shared.heads import ActionHead
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.algos.shared.shapes import HeadShape
from adaptsky.algos.shared.stacked import Shapes, StackedParameters, activation, linear_layers

SQUASH_EPS = 1e-6  # CleanRL's log(1 - tanh(x)^2 + 1e-6)
_RELU, _HOST_RELU = activation("relu")


def initial_named(shapes: Shapes, seed: int) -> dict[str, np.ndarray]:
    """One member's initial actor and Q networks, torch-named (module docstring)."""
    torch.manual_seed(seed)
    named: dict[str, np.ndarray] = {}
    for prefix in ("actor_set", "actor", *(f"{q}{set_}" for q in Q_NETWORKS
                                            for set_ in ("_set", ""))):
        for weight, bias in linear_layers(shapes, prefix):
            layer = nn.Linear(shapes[weight][1], shapes[weight][0])
            named[weight] = layer.weight.detach().numpy().copy()
            named[bias] = layer.bias.detach().numpy().copy()
    return named


def squashed(out: torch.Tensor, noise: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Actions tanh(mu + sigma noise) (S, n, D) and their log pi (S, n) for actor outputs
    (S, n, 2 D) and standard normal ``noise`` (S, n, D): log sigma squashed into
    [LOG_STD_MIN, LOG_STD_MAX] by a tanh, log pi the Gaussian's log-density of the
    unsquashed sample minus sum_j log(1 - a_j^2 + 1e-6) (CleanRL's ``get_action``)."""
    components = noise.shape[-1]
    mean, raw = out[..., :components], out[..., components:]
    log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (torch.tanh(raw) + 1)
    unsquashed = mean + log_std.exp() * noise
    actions = torch.tanh(unsquashed)
    gaussian = ActionHead(HeadShape("gaussian", components, components=components))
    log_prob, _ = gaussian.log_prob_entropy(mean, log_std, unsquashed)
    return actions, log_prob - torch.log(1 - actions * actions + SQUASH_EPS).sum(dim=-1)


def host_greedy(actor: StackedParameters, observations: np.ndarray, components: int,
                encoder: SetEncoder | None = None) -> np.ndarray:
    """tanh(mu) (S, n, D) for observations (S, n, obs), in numpy (CPU), through the set
    ``encoder`` where the actor has one."""
    if encoder is not None:
        observations = actor.host_set_encoded("actor_set", observations,
                                              encoder.layout.per_user, encoder.layout.rest,
                                              _HOST_RELU)
    out = actor.host_mlp("actor", observations, _HOST_RELU)
    return np.tanh(out[..., :components]).astype(np.float32)


class StackedSac:
    """Actor, Q networks, targets and temperature of S members on ``device`` (module
    docstring), for D = ``components``."""

    def __init__(self, observation_size: int, hidden_sizes: list[int], components: int,
                 seeds: list[int], log_alpha: float = 0.0,
                 device: str | torch.device = "cpu", encoder: SetEncoder | None = None
                 ) -> None:
        self.size, self.components, self.encoder = len(seeds), components, encoder
        actor = actor_shapes(observation_size, hidden_sizes, components, encoder)
        critics = critic_shapes(observation_size, hidden_sizes, components, encoder)
        named = [initial_named({**actor, **critics}, seed) for seed in seeds]
        self.actor = StackedParameters(actor, named, device=device)
        self.critics = StackedParameters(critics, named, device=device)
        self.targets = self.critics.params.detach().clone()
        start = {"log_alpha": np.array(log_alpha, dtype=np.float32)}
        self.temperature = StackedParameters(TEMPERATURE_SHAPES, [start] * self.size,
                                             device=device)
        self.device = self.actor.device
        if encoder is not None:
            self._per_user = torch.as_tensor(encoder.layout.per_user, device=self.device)
            self._rest = torch.as_tensor(encoder.layout.rest, device=self.device)

    # ---- forward --------------------------------------------------------------------------

    def sample(self, observations: torch.Tensor, noise: torch.Tensor
               ) -> tuple[torch.Tensor, torch.Tensor]:
        """:func:`squashed` actions (S, n, D) and log pi (S, n) for observations (S, n, obs)."""
        return squashed(self._actor(observations), noise)

    def greedy(self, observations: torch.Tensor) -> torch.Tensor:
        """tanh(mu) (S, n, D) for observations (S, n, obs)."""
        return torch.tanh(self._actor(observations)[..., :self.components])

    def _actor(self, observations: torch.Tensor) -> torch.Tensor:
        """The actor's outputs (S, n, 2 D), through its set encoder where it has one."""
        return self.actor.mlp("actor", self._read(self.actor, "actor", observations), _RELU)

    def _read(self, net: StackedParameters, prefix: str, observations: torch.Tensor,
              flat: torch.Tensor | None = None) -> torch.Tensor:
        """What the MLP ``prefix`` of ``net`` reads: the observations, or their set
        encoding (over ``flat``, as :meth:`StackedParameters.mlp`)."""
        if self.encoder is None:
            return observations
        return net.set_encoded(f"{prefix}_set", observations, self._per_user, self._rest,
                               _RELU, flat)

    def q(self, name: str, observations: torch.Tensor, actions: torch.Tensor,
          flat: torch.Tensor | None = None) -> torch.Tensor:
        """Q network ``name``'s values (S, n) over ``flat`` (default the critics' parameters;
        :attr:`targets`)."""
        x = torch.cat([self._read(self.critics, name, observations, flat), actions], dim=2)
        return self.critics.mlp(name, x, _RELU, flat)[..., 0]

    def min_q(self, observations: torch.Tensor, actions: torch.Tensor,
              flat: torch.Tensor | None = None) -> torch.Tensor:
        """min(Q1, Q2) (S, n) over ``flat`` (as :meth:`q`)."""
        return torch.min(*(self.q(name, observations, actions, flat) for name in Q_NETWORKS))

    def alpha(self) -> torch.Tensor:
        """The temperature exp(log_alpha) (S, 1), with its gradient; exp is taken of the
        whole (padded) row, so that it takes the same lanes alone and stacked."""
        return self.temperature.params.exp()[:, :1]

    def soft_update(self, tau: float) -> None:
        """targets <- tau Q + (1 - tau) targets (CleanRL's arithmetic)."""
        with torch.no_grad():
            self.targets.copy_(tau * self.critics.params + (1 - tau) * self.targets)

    # ---- checkpoints ----------------------------------------------------------------------

    def policy_arrays(self, member: int) -> dict[str, np.ndarray]:
        """One member's actor, torch-named (copies)."""
        return self.actor.named(member)

    def state_arrays(self, member: int) -> dict[str, object]:
        """Everything of one member: actor, Q networks and targets, temperature and the three
        Adam states, torch-named."""
        critics = self.critics
        rows = {"": critics.row(critics.params, member),
                "_target": critics.row(self.targets, member)}
        return {"actor": self.actor.named(member),
                **{q + kind: critics.named_from_row(row, critics.names(q)
                                                    + critics.names(f"{q}_set"))
                   for kind, row in rows.items() for q in Q_NETWORKS},
                "alpha": self.temperature.named(member),
                "actor_optimizer": self.actor.optimizer_arrays(member),
                "q_optimizer": critics.optimizer_arrays(member),
                "alpha_optimizer": self.temperature.optimizer_arrays(member)}

    def load_state_arrays(self, member: int, state: dict[str, object]) -> None:
        """Inverse of :meth:`state_arrays`."""
        def both(kind: str) -> dict[str, np.ndarray]:
            return {name: value for q in Q_NETWORKS
                    for name, value in state[q + kind].items()}  # type: ignore[attr-defined]

        self.actor.load_named(member, state["actor"])  # type: ignore[arg-type]
        self.critics.load_named(member, both(""))
        self.critics.load_named(member, both("_target"), buffer=self.targets)
        self.temperature.load_named(member, state["alpha"])  # type: ignore[arg-type]
        for net, name in ((self.actor, "actor_optimizer"), (self.critics, "q_optimizer"),
                          (self.temperature, "alpha_optimizer")):
            net.load_optimizer(member, state[name])  # type: ignore[arg-type]
