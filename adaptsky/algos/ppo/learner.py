"""PPO as an on-policy learner (:mod:`adaptsky.algos.on_policy`; docs/agent.md), CleanRL's
``ppo.py`` stacked over S seeds: the actor-critic (:mod:`adaptsky.algos.ppo.stacked`), its
head's distribution (:mod:`adaptsky.algos.shared.heads`), acting (sample, keep log pi and V),
then the loss of a minibatch: the clipped surrogate, the (clipped) value loss, the entropy
bonus, advantages normalised per minibatch; the family's loop clips each seed's gradient to
``max_grad_norm`` and makes one Adam step. The learning rate falls linearly to 0 over
``train.episodes`` (``anneal_lr``). Every episode is one rollout of T steps from E
environments per seed; rewards are multiplied by ``reward_scale`` and, with ``norm_reward``,
normalised as they come.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from adaptsky.algos.on_policy import OnPolicyLearner
from adaptsky.algos.ppo.stacked import StackedActorCritic
from adaptsky.algos.shared.heads import ActionHead
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.algos.shared.shapes import HeadShape
from adaptsky.scenario.agents import PpoAgent

STATS = ("loss", "policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction")


class PpoLearner(OnPolicyLearner):
    """Actor, critic, Adam and the rollout of S members of E environments each; ``rngs[s]``
    draws member s's actions and minibatch permutations (the family's rows: MAPPO maps the
    UAVs onto them, :mod:`adaptsky.algos.mappo`)."""

    stat_names = STATS

    def __init__(self, config: PpoAgent, head: HeadShape, observation_size: int,
                 seeds: list[int], rngs: list[np.random.Generator], steps: int, episodes: int,
                 device: Any = "cpu", critic_size: int | None = None,
                 encoder: SetEncoder | None = None) -> None:
        """``observation_size``: the actor's inputs; ``critic_size`` the critic's where they
        differ (its inputs then come from :meth:`_inputs`); ``encoder``: the set encoder
        (``agent.network = "set"``)."""
        self.net = StackedActorCritic(observation_size, config.hidden_sizes, head, seeds,
                                      config.activation, config.init_log_std, device,
                                      critic_size, encoder)
        self.head = ActionHead(head)
        self.episodes = episodes
        super().__init__(config, rngs, steps, observation_size, critic_size,
                         self.head.stored_shape,
                         np.float32 if head.kind == "gaussian" else np.int64)

    def begin_episode(self, global_step: int) -> None:
        """A new rollout, at the learning rate annealed to this episode."""
        super().begin_episode(global_step)
        if self.config.anneal_lr:
            done = global_step // self.steps
            self.lr = self.config.lr * max(0.0, 1.0 - done / self.episodes)

    # ---- acting ---------------------------------------------------------------------------

    def act(self, observations: NDArray[np.float32], global_step: int) -> np.ndarray:
        """Sampled actions (S E, ...) for observations (S E, obs), member-major; keeps the
        step's inputs, actions, log pi and V of every row."""
        obs = np.ascontiguousarray(observations, dtype=np.float32).reshape(
            self.size, self.envs, -1)
        inputs, critic_inputs = self._inputs(obs)
        rows = self.rows
        x = self._padded(inputs)
        with torch.no_grad():
            out = self.net.actor(x)
            log_std = self.net.log_std() if self.head.head.kind == "gaussian" else None
            host_out = out[:, :rows].cpu().numpy()
            stored = self.head.sample(host_out, None if log_std is None
                                      else log_std.cpu().numpy(), self.rngs)
            chosen = torch.zeros((self.size, x.shape[1], *self.head.stored_shape),
                                 dtype=torch.float32 if log_std is not None else torch.int64,
                                 device=self.device)
            chosen[:, :rows] = torch.tensor(stored, device=self.device)
            log_prob, _ = self.head.log_prob_entropy(out, log_std, chosen)
            value = self.net.critic(x if critic_inputs is None else
                                    self._padded(critic_inputs))
        self._keep(inputs, critic_inputs, stored, log_prob[:, :rows], value[:, :rows])
        return self._joint(self.head.env_actions(stored)).reshape(self.size * self.envs,
                                                                  *self._env_shape())

    def _env_shape(self) -> tuple[int, ...]:
        """The trailing shape of one environment's action: () for an index, (D,) for
        continuous controls."""
        if self.head.head.kind != "gaussian":
            return ()
        return (self.head.head.components * self.agents,)

    def greedy(self, observations: NDArray[np.float32]) -> np.ndarray:
        """The mode's environment actions (S, n, ...) for observations (S, n, obs)."""
        inputs, _ = self._inputs(np.asarray(observations, dtype=np.float32))
        if self.device.type == "cpu":
            out = self.net.host_actor(inputs)
        else:
            with torch.no_grad():
                out = self.net.actor(torch.tensor(inputs, device=self.device)).cpu().numpy()
        return self._joint(self.head.env_actions(self.head.mode(out)))

    # ---- the loss -------------------------------------------------------------------------

    def _minibatch(self, index: torch.Tensor, mask: torch.Tensor, rows: int,
                   **rollout: torch.Tensor) -> dict[str, torch.Tensor]:
        """PPO's loss of one minibatch (module docstring), its gradient computed; the
        per-member statistics of :data:`STATS`."""
        config, net = self.config, self.net

        def mean(values: torch.Tensor) -> torch.Tensor:
            return (values * mask).sum(dim=1) / rows

        def take(name: str) -> torch.Tensor:
            values = rollout[name]
            shape = (*index.shape, *values.shape[2:])
            where = index.reshape(*index.shape, *([1] * (values.dim() - 2))).expand(shape)
            return torch.gather(values, 1, where)

        out = net.actor(take("obs"))
        log_std = net.log_std() if self.head.head.kind == "gaussian" else None
        log_prob, entropy = self.head.log_prob_entropy(out, log_std, take("actions"))
        log_ratio = log_prob - take("old_log_probs")
        ratio = log_ratio.exp()
        advantage = take("adv")
        if config.norm_adv:  # mean and (unbiased) std over the real rows
            centred = advantage - mean(advantage)[:, None]
            std = (mean(centred * centred) * rows / max(rows - 1, 1)).sqrt()
            advantage = centred / (std[:, None] + 1e-8)
        clip = config.clip_coef
        policy_loss = mean(torch.max(-advantage * ratio,
                                     -advantage * ratio.clamp(1 - clip, 1 + clip)))
        value = net.critic(take("critic_obs"))
        target = take("ret")
        if config.clip_vloss:
            before = take("old_values")
            clipped = before + (value - before).clamp(-clip, clip)
            value_loss = 0.5 * mean(torch.max((value - target) ** 2,
                                              (clipped - target) ** 2))
        else:
            value_loss = 0.5 * mean((value - target) ** 2)
        mean_entropy = mean(entropy)
        loss = policy_loss - config.ent_coef * mean_entropy + config.vf_coef * value_loss
        loss.sum().backward()  # members' gradients are independent
        with torch.no_grad():
            approx_kl = mean((ratio - 1) - log_ratio)
            clipped_share = mean(((ratio - 1).abs() > clip).float())
        return {"loss": loss, "policy_loss": policy_loss, "value_loss": value_loss,
                "entropy": mean_entropy, "approx_kl": approx_kl,
                "clip_fraction": clipped_share}
