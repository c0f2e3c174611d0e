"""PPO's actor and critic for a stack of S members, in one flat buffer (S, W)
(:class:`~adaptsky.algos.shared.stacked.StackedParameters`), named and laid out as
:mod:`adaptsky.algos.ppo.parameters` declares them. Initial weights are those of
``torch.nn.Linear`` layers under ``torch.manual_seed(seed)``, then orthogonal with gains
sqrt(2) (hidden layers), 0.01 (the actor's head) and 1 (the critic's head), biases 0
(CleanRL's ``layer_init``).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn

from adaptsky.algos.ppo.parameters import critic_shapes, policy_shapes
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.algos.shared.shapes import HeadShape
from adaptsky.algos.shared.stacked import Shapes, StackedParameters, linear_layers
from adaptsky.algos.shared.stacked import activation as activation_functions

ADAM_EPS = 1e-5  # CleanRL's PPO


def _initial_named(shapes: Shapes, seed: int, init_log_std: float) -> dict[str, np.ndarray]:
    """One member's initial parameters, torch-named (module docstring; a set encoder's
    layers are hidden ones, drawn before the network that reads them)."""
    torch.manual_seed(seed)
    named: dict[str, np.ndarray] = {}
    prefixes = (("actor_set", math.sqrt(2.0)), ("actor", 0.01), ("critic_set", math.sqrt(2.0)),
                ("critic", 1.0))
    for prefix, last_gain in prefixes:
        pairs = linear_layers(shapes, prefix)
        for index, (weight, bias) in enumerate(pairs):
            layer = nn.Linear(shapes[weight][1], shapes[weight][0])
            gain = last_gain if index == len(pairs) - 1 else math.sqrt(2.0)
            nn.init.orthogonal_(layer.weight, gain)
            named[weight] = layer.weight.detach().numpy().copy()
            named[bias] = np.zeros(shapes[bias], dtype=np.float32)
    if "log_std" in shapes:
        named["log_std"] = np.full(shapes["log_std"], init_log_std, np.float32)
    return named


class StackedActorCritic(StackedParameters):
    """Actor and critic of S members on ``device`` (module docstring)."""

    def __init__(self, observation_size: int, hidden_sizes: list[int], head: HeadShape,
                 seeds: list[int], activation: str = "tanh", init_log_std: float = 0.0,
                 device: str | torch.device = "cpu", critic_size: int | None = None,
                 encoder: SetEncoder | None = None) -> None:
        """``critic_size``: the critic's inputs where they differ from the actor's
        ``observation_size`` (MAPPO's centralised critic); ``encoder``: the set encoder
        both read the observation through (``agent.network = "set"``)."""
        self.observation_size, self.hidden_sizes, self.head = (observation_size,
                                                               list(hidden_sizes), head)
        self.encoder = encoder
        self.policy_names = list(policy_shapes(observation_size, hidden_sizes, head, encoder))
        shapes = {**policy_shapes(observation_size, hidden_sizes, head, encoder),
                  **critic_shapes(critic_size or observation_size, hidden_sizes, encoder)}
        super().__init__(shapes, [_initial_named(shapes, seed, init_log_std) for seed in seeds],
                         ADAM_EPS, device)
        self._act, self._act_host = activation_functions(activation)
        if encoder is not None:
            layout = encoder.layout
            self._per_user = torch.as_tensor(layout.per_user, device=self.device)
            self._rest = torch.as_tensor(layout.rest, device=self.device)

    # ---- forward --------------------------------------------------------------------------

    def actor(self, observations: torch.Tensor) -> torch.Tensor:
        """The head's outputs (S, n, width) for observations (S, n, obs)."""
        return self.mlp("actor", self._read("actor", observations), self._act)

    def critic(self, observations: torch.Tensor) -> torch.Tensor:
        """V(s) (S, n) for observations (S, n, obs)."""
        return self.mlp("critic", self._read("critic", observations), self._act)[..., 0]

    def _read(self, prefix: str, observations: torch.Tensor) -> torch.Tensor:
        """What the MLP ``prefix`` reads: the observations, or their set encoding."""
        if self.encoder is None:
            return observations
        return self.set_encoded(f"{prefix}_set", observations, self._per_user, self._rest,
                                self._act)

    def log_std(self) -> torch.Tensor:
        """The Gaussian's log standard deviation (S, 1, D)."""
        slot = self.slots["log_std"]
        return self.params[:, slot.at:slot.end].view(self.size, 1, slot.size)

    def host_actor(self, observations: np.ndarray) -> np.ndarray:
        """The head's outputs (S, n, width) in numpy over the weights' memory (CPU)."""
        if self.encoder is not None:
            layout = self.encoder.layout
            observations = self.host_set_encoded("actor_set", observations, layout.per_user,
                                                 layout.rest, self._act_host)
        return self.host_mlp("actor", observations, self._act_host)

    # ---- checkpoints ----------------------------------------------------------------------

    def policy_arrays(self, member: int) -> dict[str, np.ndarray]:
        """One member's greedy policy (actor, and log_std), torch-named (copies)."""
        return self.named(member, self.policy_names)

    def load_policy(self, member: int, policy: dict[str, np.ndarray]) -> None:
        """Put a stored policy into member ``member`` (greedy evaluation)."""
        self.load_named(member, policy, self.policy_names)

    def state_arrays(self, member: int) -> dict[str, object]:
        """Everything of one member: its policy, critic and Adam state, torch-named."""
        return {"policy": self.named(member, self.policy_names),
                "critic": self.named(member, [name for name in self.slots
                                              if name not in self.policy_names]),
                "optimizer": self.optimizer_arrays(member)}

    def load_state_arrays(self, member: int, state: dict[str, object]) -> None:
        """Inverse of :meth:`state_arrays`."""
        self.load_named(member, {**state["policy"], **state["critic"]})  # type: ignore[dict-item]
        self.load_optimizer(member, state["optimizer"])  # type: ignore[arg-type]
