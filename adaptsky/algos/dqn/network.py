"""Q-networks of sec. IV-A: an MLP torso with a dueling head (AdaptSky) or a plain head (the
paper's "DRL" baseline)."""

from __future__ import annotations

from itertools import pairwise

import torch
from torch import nn
from torch.nn import functional

from adaptsky.algos.dqn.forward import head_output
from adaptsky.algos.shared.set_layout import SetEncoder


def mlp(sizes: list[int]) -> nn.Sequential:
    """Linear layers with ReLU after each, ``sizes`` = [in, hidden..., last hidden]."""
    layers: list[nn.Module] = []
    for size_in, size_out in pairwise(sizes):
        layers += [nn.Linear(size_in, size_out), nn.ReLU()]
    return nn.Sequential(*layers)


class QNetwork(nn.Module):
    """Q(s, .) for every action.

    Dueling: Q = V + A - mean_a A, the mean taken per sample (the released code subtracts one
    mean over the whole batch, a bug; docs/model.md §4). Plain: Q from one linear head.
    ``values`` > 1 makes a value head of that many outputs (the BDQ's per-UAV values; its
    forward is :class:`adaptsky.algos.bdq.stacked.StackedBdq`'s, not this one's).
    """

    def __init__(self, observation_size: int, num_actions: int, hidden_sizes: list[int],
                 dueling: bool, values: int = 1, encoder: SetEncoder | None = None) -> None:
        super().__init__()
        self.dueling = dueling
        self.encoder = encoder
        self.torso = mlp([observation_size if encoder is None else encoder.width,
                          *hidden_sizes])
        last = hidden_sizes[-1]
        if dueling:
            self.value = nn.Linear(last, values)
            self.advantage = nn.Linear(last, num_actions)
        else:
            self.q = nn.Linear(last, num_actions)
        if encoder is not None:   # the users' shared network (docs/agent.md), drawn last
            self.set = mlp([encoder.layout.per_user.shape[1], *encoder.sizes])

    def layers(self) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(weight (out, in), bias) of every linear layer, the head last ([V | A] if
        dueling)."""
        torso = [(layer.weight, layer.bias) for layer in self.torso
                 if isinstance(layer, nn.Linear)]
        if not self.dueling:
            return [*torso, (self.q.weight, self.q.bias)]
        return [*torso, (torch.cat([self.value.weight, self.advantage.weight]),
                         torch.cat([self.value.bias, self.advantage.bias]))]

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        if self.encoder is not None:   # each user's features, pooled by mean and max
            layout = self.encoder.layout
            users = self.set(observations[:, layout.per_user])       # (n, slots, H)
            observations = torch.cat([users.mean(dim=1), users.amax(dim=1),
                                      observations[:, layout.rest]], dim=-1)
        out = head_output(self.layers(), observations, functional.linear, torch.relu)
        if not self.dueling:
            return out
        value, advantage = out[:, :1], out[:, 1:]
        return value + advantage - advantage.mean(dim=1, keepdim=True)
