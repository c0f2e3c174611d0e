"""The BDQ for a stack of S members: the stacked DQN (:mod:`adaptsky.algos.dqn.stacked`: flat
per-member buffers, the hand-written backward pass, Adam) with a branching head and its target.

The head's output is [V | A_1 | ... | A_D], A_d of the b sub-actions of action component d (b = 2,
or 3 with hover), and ``Q_d(s, a_d) = V(s) + A_d(s, a_d) - mean_a' A_d(s, a')`` is again one
small matmul, [V | A] @ M with M block-diagonal (docs/agent.md, "BDQ"). Stored, the head is the
DQN's ``value`` and ``advantage`` with A = D b columns, branch d's in rows d b ... (d + 1) b - 1
of ``advantage.weight``. An action index of the dense action set (docs/model.md §3) is the
branches' sub-actions as digits in base b: a = sum_d a_d b^d.

With ``agent.reward_split`` "per-uav" or "difference" and U > 1 UAVs the head is [V_1 ..
V_U | A_1 .. A_D]: UAV u's branches (its 3 + K components, one after another) take V_u, and
learn from UAV u's part of the reward (``NetworkBatch.reward_parts``); the replay stores the
U parts of every reward.
"""

from __future__ import annotations

import numpy as np
import torch

from adaptsky.algos.bdq.groups import value_groups
from adaptsky.algos.dqn.stacked import SetKept, StackedDqn
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.scenario.agents import BdqAgent, DqnAgent
from adaptsky.sim.actions import ActionSet


class StackedBdq(StackedDqn):
    """Policy and target BDQs and Adam for S members on ``device``, one branch per action
    component of ``action_set``; initial weights are those of a dueling ``QNetwork`` with D b
    advantages under ``torch.manual_seed(seed)``."""

    def __init__(self, config: BdqAgent, observation_size: int, action_set: ActionSet,
                 seeds: list[int], device: str | torch.device = "cpu",
                 encoder: SetEncoder | None = None) -> None:
        self.branches, self.sub_actions = action_set.num_components, action_set.base
        self.action_width = self.branches
        self.values = value_groups(config, action_set)
        self._powers = self.sub_actions ** np.arange(self.branches, dtype=np.int64)
        super().__init__(config, observation_size, self.branches * self.sub_actions, seeds,
                         device, encoder)
        self._powers_device = torch.from_numpy(self._powers).to(self.device)

    @staticmethod
    def _dueling_head(config: DqnAgent | BdqAgent) -> bool:
        return True

    def _head_matrix(self) -> torch.Tensor:
        """M with M[g, j] = 1 where column j is of a branch of value group g (one group: V in
        every Q_d) and, per branch, I - 1/b (its own mean)."""
        b = self.sub_actions
        branch = torch.eye(b) - 1.0 / b
        groups = self.values
        per_group = self.num_actions // groups
        value_rows = torch.block_diag(*[torch.ones(1, per_group)] * groups)
        return torch.cat([value_rows, torch.block_diag(*[branch] * self.branches)])

    def _branches(self, q: torch.Tensor) -> torch.Tensor:
        """(..., D b) -> (..., D, b)."""
        return q.unflatten(-1, (self.branches, self.sub_actions))

    # ---- actions -------------------------------------------------------------------------

    def device_greedy(self, observations: torch.Tensor) -> torch.Tensor:
        """argmax of every branch, as a dense action index (S, n)."""
        digits = self._branches(self.q_values(observations)).argmax(dim=-1)
        return (digits * self._powers_device).sum(dim=-1)

    def _host_greedy(self, out: np.ndarray) -> np.ndarray:
        # V and each branch's mean do not change the branch's argmax
        digits = out[..., self.values:].reshape(*out.shape[:-1], self.branches,
                                                self.sub_actions)
        return (digits.argmax(axis=-1) * self._powers).sum(axis=-1)

    def stored_actions(self, actions: np.ndarray) -> np.ndarray:
        """Dense action indices (S,) as the sub-action of every branch (S, D)."""
        return (actions[:, None] // self._powers) % self.sub_actions

    # ---- the TD update -------------------------------------------------------------------

    def update(self, observations: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor,
               next_observations: torch.Tensor, not_terminal: torch.Tensor) -> None:
        """One Adam step per member on its batch: observations (S, B, obs), actions (S, B, D)
        (a sub-action per branch), rewards (S, B) (or (S, B, G) with G value groups) and
        not_terminal (S, B).

        Target shared by the branches, y = r + gamma^n (1/D) sum_d Q^-_d(s', argmax Q_d(s', .))
        (argmax by the policy network, value by the target network); with G groups, one per
        group, y_g = r_g + gamma^n (1/D_g) sum_{d in g} Q^-_d(s', argmax Q_d(s', .)), for
        the branches of group g. Loss the mean over the branches and the batch of
        (y - Q_d(s, a_d))^2 (or Huber). Fixed shapes, no host synchronisation: one CUDA graph
        on a GPU.
        """
        with torch.no_grad():
            next_q = self._branches(self._forward(self._target, next_observations))
            best = self._branches(self._forward(self._policy, next_observations)).argmax(
                dim=-1, keepdim=True)
            branch_value = next_q.gather(-1, best).squeeze(-1)
            if self.values == 1:
                next_value = branch_value.mean(dim=-1)
                target = rewards + self._discount * not_terminal * next_value
            else:
                groups = self.values
                next_value = branch_value.unflatten(-1, (groups, -1)).mean(dim=-1)
                target = rewards + (self._discount * not_terminal).unsqueeze(-1) * next_value
                target = target.repeat_interleave(self.branches // groups, dim=-1)
            inputs: list[torch.Tensor] = []
            self._set_kept = kept = SetKept() if self.encoder is not None else None
            q = self._forward(self._policy, observations, inputs, set_keep=kept)
            offsets = torch.arange(self.branches, device=self.device) * self.sub_actions
            chosen = actions + offsets  # the column of Q_d(s, a_d) in [Q_1 | ... | Q_D]
            error = q.gather(-1, chosen) - (target if self.values > 1 else
                                            target.unsqueeze(-1))
            stack, batch, branches = error.shape
            d_error = self._loss_gradient(error.view(stack, batch * branches))
            self._learn(inputs, self._d_head(chosen, d_error.view(stack, batch, branches)))
