"""The DQN agent of algorithm 1: epsilon-greedy action choice and the TD update of eq. 12.

State in and out of :meth:`DqnAgent.state_arrays` / :meth:`DqnAgent.load_state_arrays` is
plain numpy arrays and JSON-able values, so checkpoints hold no pickle.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import torch
from torch import nn

from adaptsky_cli.agent.network import QNetwork
from adaptsky_cli.agent.replay import Batch
from adaptsky_cli.scenario.models import Agent


class DqnAgent:
    """Policy and target networks, Adam, and the options of ``[agent]``."""

    def __init__(self, config: Agent, observation_size: int, num_actions: int,
                 seed: int) -> None:
        self.config = config
        self.num_actions = num_actions
        torch.manual_seed(seed)
        self.policy = QNetwork(observation_size, num_actions, config.hidden_sizes,
                               config.dueling)
        self.target = QNetwork(observation_size, num_actions, config.hidden_sizes,
                               config.dueling)
        self.target.load_state_dict(self.policy.state_dict())
        self.target.requires_grad_(False)
        self.optimizer = torch.optim.Adam(self.policy.parameters(), lr=config.lr)
        self.loss_fn = nn.MSELoss() if config.loss == "mse" else nn.SmoothL1Loss()

    def greedy(self, observations: np.ndarray) -> np.ndarray:
        """argmax_a Q(s, a) for a batch of observations (B, obs)."""
        with torch.inference_mode():
            return self.policy(torch.from_numpy(observations)).argmax(dim=1).numpy()

    def act(self, observation: np.ndarray, epsilon: float, rng: np.random.Generator) -> int:
        """Epsilon-greedy (alg. 1 line 6); always one uniform draw, then one more to explore."""
        if rng.random() < epsilon:
            return int(rng.integers(self.num_actions))
        return int(self.greedy(observation[None])[0])

    def update(self, batch: Batch) -> float:
        """One gradient step on the TD loss of eq. 12; returns the loss."""
        observations = torch.from_numpy(batch.observations)
        actions = torch.from_numpy(batch.actions)
        rewards = torch.from_numpy(batch.rewards)
        next_observations = torch.from_numpy(batch.next_observations)
        not_terminal = torch.from_numpy(~batch.terminated).float()
        q = self.policy(observations).gather(1, actions[:, None]).squeeze(1)
        with torch.no_grad():
            next_q = self.target(next_observations)
            if self.config.double_dqn:
                best = self.policy(next_observations).argmax(dim=1, keepdim=True)
                next_value = next_q.gather(1, best).squeeze(1)
            else:
                next_value = next_q.max(dim=1).values
            target = rewards + self.config.gamma * not_terminal * next_value
        loss = self.loss_fn(q, target)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if self.config.grad_clip_norm > 0:
            nn.utils.clip_grad_norm_(self.policy.parameters(), self.config.grad_clip_norm)
        self.optimizer.step()
        return float(loss.item())

    def sync_target(self) -> None:
        """Hard copy theta' <- theta (alg. 1, last lines)."""
        self.target.load_state_dict(self.policy.state_dict())

    def state_arrays(self) -> dict[str, Any]:
        """Weights, optimizer state and torch RNG state as numpy arrays and JSON text."""
        optimizer = self.optimizer.state_dict()
        return {
            "policy": {k: v.numpy().copy() for k, v in self.policy.state_dict().items()},
            "target": {k: v.numpy().copy() for k, v in self.target.state_dict().items()},
            "optimizer": {
                "param_groups_json": json.dumps(optimizer["param_groups"]),
                "state": {str(i): {k: v.numpy().copy() for k, v in s.items()}
                          for i, s in optimizer["state"].items()},
            },
            "torch_rng": torch.get_rng_state().numpy().copy(),
        }

    def load_state_arrays(self, state: dict[str, Any]) -> None:
        """Inverse of :meth:`state_arrays`."""
        self.policy.load_state_dict({k: torch.from_numpy(np.asarray(v))
                                     for k, v in state["policy"].items()})
        self.target.load_state_dict({k: torch.from_numpy(np.asarray(v))
                                     for k, v in state["target"].items()})
        optimizer = state["optimizer"]
        self.optimizer.load_state_dict({
            "param_groups": json.loads(optimizer["param_groups_json"]),
            "state": {int(i): {k: torch.from_numpy(np.asarray(v)) for k, v in s.items()}
                      for i, s in optimizer["state"].items()},
        })
        torch.set_rng_state(torch.from_numpy(np.asarray(state["torch_rng"], dtype=np.uint8)))
