"""SAC as an off-policy learner (:mod:`adaptsky.algos.off_policy`; docs/agent.md), CleanRL's
``sac_continuous_action.py`` order stacked over S seeds: uniform random actions for
``learning_starts`` steps, then tanh-squashed Gaussian samples; every step stored in the
member's replay memory (the time limit is a truncation: every row bootstraps); after
``learning_starts`` steps one critic update a step (the soft target of the smaller target Q),
every ``policy_frequency``-th step that many actor and temperature updates, every
``target_network_frequency``-th step the Polyak average of the targets.

Every random number of a member comes from its generator ``rngs[s]``: its exploring actions,
its replay samples and the reparameterisation noise of every update (standard normals drawn
with numpy, then moved to torch); each member's block of rows is padded to a multiple of
:data:`~adaptsky.algos.shared.stacked.PAD` (a seed then learns the same numbers alone, in a
stack and resumed).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from adaptsky.algos.off_policy import OffPolicyLearner
from adaptsky.algos.replay import Batch, StackedReplay
from adaptsky.algos.sac.parameters import Q_NETWORKS
from adaptsky.algos.sac.stacked import StackedSac, host_greedy
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.algos.shared.stacked import padded, padded_rows
from adaptsky.scenario.agents import SacAgent

STATS = ("q_loss", "actor_loss", "entropy")
"""Means since the last :meth:`SacLearner.take_stats` (``take_stats`` adds ``alpha``)."""


class ControlReplay(StackedReplay):
    """The replay memories with D float action columns (continuous controls), kept as floats."""

    def gather(self, index: torch.Tensor) -> Batch:
        stack, batch = index.shape
        flat = index.view(-1) if stack == 1 else (index + self._offsets).view(-1)
        rows = self._flat.index_select(0, flat).view(stack, batch, self.width)
        return Batch(*self._fields(rows))

    def arrays(self, member: int) -> dict[str, np.ndarray]:
        actions = self._fields(self.rows[member, :self.size])[1]
        return {**super().arrays(member), "actions": actions.cpu().numpy().copy()}


class SacLearner(OffPolicyLearner):
    """Networks, their Adam states and the replay memories of S members on ``device``;
    ``rngs[s]`` draws member s's actions, replay samples and noise."""

    def __init__(self, config: SacAgent, observation_size: int, components: int,
                 seeds: list[int], rngs: list[np.random.Generator], device: Any = "cpu",
                 encoder: SetEncoder | None = None) -> None:
        self.config, self.components, self.encoder = config, components, encoder
        log_alpha = 0.0 if config.autotune else math.log(config.alpha)
        self.net = StackedSac(observation_size, config.hidden_sizes, components, seeds,
                              log_alpha, device, encoder)
        self.device = self.net.device
        super().__init__(rngs, self.net, ControlReplay(len(seeds), config.memory_size,
                                                       observation_size, self.device,
                                                       action_width=components),
                         config.reward_scale)
        self.global_step = 0
        self._where, mask = padded_rows(config.batch_size)
        self._mask = mask.to(self.device)

    # ---- acting ---------------------------------------------------------------------------

    def _noise(self, rows: int) -> torch.Tensor:
        """Standard normals (S, padded rows, D), member s's ``rows`` from ``rngs[s]``, the
        padding 0."""
        noise = np.zeros((self.size, padded(rows), self.components), dtype=np.float32)
        for member, rng in enumerate(self.rngs):
            noise[member, :rows] = rng.standard_normal((rows, self.components))
        return torch.tensor(noise, device=self.device)

    def act(self, observations: NDArray[np.float32], global_step: int) -> NDArray[np.float32]:
        """Actions (S, D) in [-1, 1]^D for observations (S, obs): uniform before
        ``learning_starts`` steps, then sampled from the actor."""
        self.global_step = global_step
        if global_step < self.config.learning_starts:
            return np.stack([rng.uniform(-1.0, 1.0, self.components)
                             for rng in self.rngs]).astype(np.float32)
        x = torch.zeros((self.size, padded(1), observations.shape[-1]), device=self.device)
        x[:, 0] = torch.tensor(np.asarray(observations, dtype=np.float32), device=self.device)
        with torch.no_grad():
            actions, _ = self.net.sample(x, self._noise(1))
        return actions[:, 0].cpu().numpy()

    def greedy(self, observations: NDArray[np.float32]) -> NDArray[np.float32]:
        """tanh(mu) (S, n, D) for observations (S, n, obs)."""
        obs = np.asarray(observations, dtype=np.float32)
        if self.device.type == "cpu":
            return host_greedy(self.net.actor, obs, self.components, self.encoder)
        with torch.no_grad():
            return self.net.greedy(torch.tensor(obs, device=self.device)).cpu().numpy()

    # ---- learning -------------------------------------------------------------------------

    def _due(self) -> bool:
        """After ``learning_starts`` steps (CleanRL: global_step > learning_starts)."""
        return self.global_step > self.config.learning_starts

    def _update(self) -> None:
        """The updates due after this step (module docstring)."""
        config, step = self.config, self.global_step
        index = self.memory.sample_index(config.batch_size, self.rngs)[:, self._where]
        batch = self.memory.gather(torch.from_numpy(np.ascontiguousarray(index)).to(self.device))
        self._critic_update(batch)
        if step % config.policy_frequency == 0:
            for _ in range(config.policy_frequency):
                self._actor_update(batch.observations)
        if step % config.target_network_frequency == 0:
            self.net.soft_update(config.tau)

    def _mean(self, values: torch.Tensor) -> torch.Tensor:
        """Each member's mean (S,) over the real rows of a padded batch (S, B padded)."""
        return (values * self._mask).sum(dim=1) / self.config.batch_size

    def _critic_update(self, batch: Batch) -> None:
        """Both Q networks towards r + gamma (min target Q - alpha log pi) of s' (one Adam
        step over both)."""
        config, net = self.config, self.net
        with torch.no_grad():
            next_actions, next_log_pi = net.sample(batch.next_observations,
                                                   self._noise(config.batch_size))
            soft = (net.min_q(batch.next_observations, next_actions, net.targets)
                    - net.alpha() * next_log_pi)
            target = batch.rewards + batch.not_terminal * config.gamma * soft
        q1_error, q2_error = (net.q(name, batch.observations, batch.actions) - target
                              for name in Q_NETWORKS)
        q_loss = self._mean(q1_error * q1_error) + self._mean(q2_error * q2_error)
        q_loss.sum().backward()  # members' gradients are independent
        net.critics.apply_gradients(config.q_lr)
        self.losses.add("loss", q_loss)  # take_mean_loss's
        self.losses.add("q_loss", q_loss)  # take_stats'

    def _actor_update(self, observations: torch.Tensor) -> None:
        """The actor towards min Q - alpha log pi of its own samples, then (autotune) the
        temperature towards the target entropy -D."""
        config, net = self.config, self.net
        actions, log_pi = net.sample(observations, self._noise(config.batch_size))
        alpha = net.alpha().detach()
        q = net.min_q(observations, actions, net.critics.params.detach())
        actor_loss = self._mean(alpha * log_pi - q)
        actor_loss.sum().backward()
        net.actor.apply_gradients(config.policy_lr)
        self.losses.add("actor_loss", actor_loss)
        self.losses.add("entropy", -self._mean(log_pi.detach()))
        if config.autotune:
            with torch.no_grad():
                _, log_pi = net.sample(observations, self._noise(config.batch_size))
            alpha_loss = self._mean(-net.alpha() * (log_pi - self.components))
            alpha_loss.sum().backward()
            net.temperature.apply_gradients(config.q_lr)

    def take_stats(self) -> dict[str, NDArray[np.float64]]:
        """Each member's mean critic loss, actor loss and entropy estimate (-log pi of the
        actor's samples) since the last call (NaN without an update since), alpha now, and the
        (constant) learning rates ``policy_lr`` and ``q_lr``."""
        stats = {}
        for name in STATS:
            mean = self.losses.take(name)
            stats[name] = np.full(self.size, np.nan) if mean is None else mean
        with torch.no_grad():
            stats["alpha"] = self.net.alpha()[:, 0].double().cpu().numpy()
        config = self.config
        return stats | {"policy_lr": np.full(self.size, config.policy_lr),
                        "q_lr": np.full(self.size, config.q_lr)}
