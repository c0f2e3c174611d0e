"""PPO as an :class:`~adaptsky.algos.protocol.Algorithm` (docs/agent.md), CleanRL's ``ppo.py``
order stacked over S seeds: every episode is one rollout of T steps from E environments per
seed (:meth:`act` samples and keeps log pi and V; :meth:`observe` keeps the reward), then
:meth:`end_episode` computes GAE(lambda), bootstrapping the truncated last step with
V(s_T), and runs ``epochs`` epochs of ``minibatches`` minibatches per seed (each seed its own
permutation from its generator): the clipped surrogate, the (clipped) value loss, the entropy
bonus, advantages normalised per minibatch, the gradient clipped to ``max_grad_norm`` per seed,
one Adam step. The learning rate falls linearly to 0 over ``train.episodes`` (``anneal_lr``).
Rewards are multiplied by ``reward_scale`` and, with ``norm_reward``, divided by a running
standard deviation of the return (:mod:`adaptsky.algos.ppo.reward_norm`) as they come.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from adaptsky.algos.device_step import describe
from adaptsky.algos.ppo.heads import ActionHead
from adaptsky.algos.ppo.parameters import HeadShape
from adaptsky.algos.ppo.reward_norm import RewardNormaliser
from adaptsky.algos.ppo.stacked import StackedActorCritic
from adaptsky.algos.stacked_params import padded, padded_rows
from adaptsky.arrays import Tree
from adaptsky.scenario.agents import PpoAgent

STATS = ("loss", "policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction")


def gae(rewards: np.ndarray, values: np.ndarray, last_value: np.ndarray, gamma: float,
        lam: float) -> tuple[np.ndarray, np.ndarray]:
    """GAE(lambda) advantages and returns (T, ...) of one rollout without terminal states:
    delta_t = r_t + gamma V(s_{t+1}) - V(s_t), with V(s_T) = ``last_value`` (the truncation
    bootstrapped), A_t = delta_t + gamma lambda A_{t+1}, returns A_t + V(s_t)."""
    advantages = np.zeros_like(values)
    running = np.zeros_like(last_value)
    steps = len(values)
    for t in reversed(range(steps)):
        following = last_value if t == steps - 1 else values[t + 1]
        delta = rewards[t] + gamma * following - values[t]
        running = delta + gamma * lam * running
        advantages[t] = running
    return advantages, advantages + values


class PpoLearner:
    """Actor, critic, Adam and the rollout of S members of E environments each; ``rngs[s]``
    draws member s's actions and minibatch permutations.

    A rollout row is one environment (PPO) or one agent of one (MAPPO: ``agents`` rows per
    environment, :mod:`adaptsky.algos.mappo`); :meth:`_inputs`, :meth:`_joint` and
    :meth:`_row_rewards` map environments onto rows and back."""

    reward_parts = 1
    agents = 1  # rollout rows per environment

    def __init__(self, config: PpoAgent, head: HeadShape, observation_size: int,
                 seeds: list[int], rngs: list[np.random.Generator], steps: int, episodes: int,
                 device: Any = "cpu", critic_size: int | None = None) -> None:
        """``observation_size``: the actor's inputs; ``critic_size`` the critic's where they
        differ (its inputs then come from :meth:`_inputs`)."""
        self.config, self.rngs = config, rngs
        self.size, self.envs = len(seeds), config.envs_per_seed
        self.rows = self.envs * self.agents
        self.steps, self.episodes = steps, episodes
        self.net = StackedActorCritic(observation_size, config.hidden_sizes, head, seeds,
                                      config.activation, config.init_log_std, device,
                                      critic_size)
        self.head = ActionHead(head)
        self.device = self.net.device
        self.epsilon = math.nan  # no epsilon: progress leaves it out
        self.lr = config.lr
        shape = (steps, self.size, self.rows)
        self.observations = np.zeros((*shape, observation_size), dtype=np.float32)
        self.critic_observations = (None if critic_size is None else
                                    np.zeros((*shape, critic_size), dtype=np.float32))
        self.actions = np.zeros((*shape, *self.head.stored_shape),
                                dtype=np.float32 if head.kind == "gaussian" else np.int64)
        self.log_probs = np.zeros(shape, dtype=np.float32)
        self.values = np.zeros(shape, dtype=np.float32)
        self.rewards = np.zeros(shape, dtype=np.float64)
        self.last_observations: np.ndarray | None = None  # the environments' (S, E, obs)
        self.normaliser = (RewardNormaliser(self.size, self.rows, config.gamma)
                           if config.norm_reward else None)
        self.t = 0
        self.stats: dict[str, NDArray[np.float64]] | None = None

    # ---- environments and rows --------------------------------------------------------------

    def _inputs(self, observations: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The actor's inputs (S, n R, obs) for the environments' observations (S, n, ...)
        and the critic's where they differ (None: the actor's); R = :attr:`agents`."""
        return observations, None

    def _joint(self, actions: np.ndarray) -> np.ndarray:
        """The environments' actions (S, n, ...) from every row's (S, n R, ...)."""
        return actions

    def _row_rewards(self, rewards: np.ndarray) -> np.ndarray:
        """Every row's reward (S, E R) from the environments' (S E,) (or (S E, G) parts)."""
        return np.asarray(rewards).reshape(self.size, self.envs)

    def _padded(self, inputs: np.ndarray) -> torch.Tensor:
        """Rows (S, m, width) on the device, zero rows after each member's m (PAD rows: each
        member's block the size it has alone)."""
        x = torch.zeros((self.size, padded(inputs.shape[1]), inputs.shape[-1]),
                        device=self.device)
        x[:, :inputs.shape[1]] = torch.tensor(inputs, device=self.device)
        return x

    # ---- acting ---------------------------------------------------------------------------

    def _outputs(self, observations: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Head outputs (S, n, width) and the log std (S, 1, D) or None, as numpy."""
        with torch.no_grad():
            x = torch.tensor(observations, device=self.device)
            out = self.net.actor(x).cpu().numpy()
            log_std = (self.net.log_std().cpu().numpy() if self.head.head.kind == "gaussian"
                       else None)
        return out, log_std

    def begin_episode(self, global_step: int) -> None:
        self.t = 0
        if self.normaliser is not None:
            self.normaliser.begin_episode()
        if self.config.anneal_lr:
            done = global_step // self.steps
            self.lr = self.config.lr * max(0.0, 1.0 - done / self.episodes)

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
            log_prob, value = log_prob[:, :rows], value[:, :rows]
        t = self.t
        self.observations[t], self.actions[t] = inputs, stored
        if critic_inputs is not None:
            assert self.critic_observations is not None
            self.critic_observations[t] = critic_inputs
        self.log_probs[t], self.values[t] = log_prob.cpu().numpy(), value.cpu().numpy()
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
            out, _ = self._outputs(inputs)
        return self._joint(self.head.env_actions(self.head.mode(out)))

    def observe(self, observations: NDArray[np.float32], actions: np.ndarray,
                rewards: NDArray[np.float64], next_observations: NDArray[np.float32]) -> None:
        """The step's rewards (S E,) (or parts (S E, G)) and the observations after it."""
        scaled = self._row_rewards(rewards) * self.config.reward_scale
        self.rewards[self.t] = scaled if self.normaliser is None else self.normaliser(scaled)
        self.last_observations = np.array(next_observations, dtype=np.float32).reshape(
            self.size, self.envs, -1)
        self.t += 1

    def update(self) -> None:
        """Nothing per step: PPO learns at the end of its rollout (:meth:`end_episode`)."""

    # ---- learning -------------------------------------------------------------------------

    def _advantages(self) -> tuple[np.ndarray, np.ndarray]:
        """GAE(lambda) advantages and returns (T, S, E); the last step is a truncation,
        bootstrapped with V(s_T)."""
        config = self.config
        assert self.last_observations is not None
        inputs, critic_inputs = self._inputs(self.last_observations)
        x = self._padded(inputs if critic_inputs is None else critic_inputs)  # as in act
        with torch.no_grad():
            last = self.net.critic(x)[:, :self.rows].cpu().numpy().astype(np.float64)
        return gae(self.rewards, self.values.astype(np.float64), last,
                   config.gamma, config.gae_lambda)

    def _per_member(self, array: np.ndarray) -> torch.Tensor:
        """(T, S, R, ...) -> (S, T R, ...) on the device (R rows per member)."""
        moved = np.moveaxis(array, 1, 0)
        flat = moved.reshape(self.size, self.steps * self.rows, *array.shape[3:])
        return torch.tensor(flat, device=self.device)  # a copy in torch's aligned memory

    def end_episode(self, episodes_before: int) -> None:
        """GAE, then the epochs of minibatch updates (module docstring)."""
        config, net = self.config, self.net
        advantages, returns = self._advantages()
        obs = self._per_member(self.observations)
        critic_obs = (obs if self.critic_observations is None
                      else self._per_member(self.critic_observations))
        actions = self._per_member(self.actions)
        old_log_probs = self._per_member(self.log_probs)
        old_values = self._per_member(self.values)
        adv = self._per_member(advantages.astype(np.float32))
        ret = self._per_member(returns.astype(np.float32))
        count = self.steps * self.rows
        parts = np.array_split(np.arange(count), min(config.minibatches, count))
        # each minibatch padded to a multiple of PAD rows (repeats of its first row, masked)
        layouts = {len(part): padded_rows(len(part)) for part in parts}
        sums = {name: torch.zeros(self.size, dtype=torch.float64) for name in STATS}
        updates = 0
        for _ in range(config.epochs):
            order = torch.from_numpy(np.stack([rng.permutation(count) for rng in self.rngs]))
            for part in parts:
                where, mask = layouts[len(part)]
                index = order[:, part[where]].to(self.device)             # (S, m padded)
                stats = self._minibatch(index, mask.to(self.device), len(part), obs,
                                        critic_obs, actions, old_log_probs, old_values, adv,
                                        ret)
                net.apply_gradients(self.lr, config.max_grad_norm)
                for name, value in stats.items():
                    sums[name] += value.detach().cpu().double()
                updates += 1
        self.stats = {name: (value / updates).numpy() for name, value in sums.items()}

    def _minibatch(self, index: torch.Tensor, mask: torch.Tensor, rows: int,
                   obs: torch.Tensor, critic_obs: torch.Tensor, actions: torch.Tensor,
                   old_log_probs: torch.Tensor,
                   old_values: torch.Tensor, adv: torch.Tensor, ret: torch.Tensor
                   ) -> dict[str, torch.Tensor]:
        """The loss of one minibatch of ``rows`` rows per member (S, padded indices; ``mask``
        1 on the real rows), its gradient computed; the per-member statistics of
        :data:`STATS`."""
        config, net = self.config, self.net

        def mean(values: torch.Tensor) -> torch.Tensor:
            return (values * mask).sum(dim=1) / rows

        def take(values: torch.Tensor) -> torch.Tensor:
            shape = (*index.shape, *values.shape[2:])
            where = index.reshape(*index.shape, *([1] * (values.dim() - 2))).expand(shape)
            return torch.gather(values, 1, where)

        out = net.actor(take(obs))
        log_std = net.log_std() if self.head.head.kind == "gaussian" else None
        log_prob, entropy = self.head.log_prob_entropy(out, log_std, take(actions))
        log_ratio = log_prob - take(old_log_probs)
        ratio = log_ratio.exp()
        advantage = take(adv)
        if config.norm_adv:  # mean and (unbiased) std over the real rows
            centred = advantage - mean(advantage)[:, None]
            std = (mean(centred * centred) * rows / max(rows - 1, 1)).sqrt()
            advantage = centred / (std[:, None] + 1e-8)
        clip = config.clip_coef
        policy_loss = mean(torch.max(-advantage * ratio,
                                     -advantage * ratio.clamp(1 - clip, 1 + clip)))
        value = net.critic(take(critic_obs))
        target = take(ret)
        if config.clip_vloss:
            before = take(old_values)
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

    def take_mean_loss(self) -> NDArray[np.float64] | None:
        """Each member's mean loss over the last update's minibatches, None before one."""
        return None if self.stats is None else self.stats["loss"]

    def take_stats(self) -> dict[str, NDArray[np.float64]]:
        """The last update's per-member means of :data:`STATS` (NaN before one) and its
        learning rate (``lr``)."""
        lr = {"lr": np.full(self.size, self.lr)}  # this episode's (annealed)
        if self.stats is None:
            return {name: np.full(self.size, np.nan) for name in STATS} | lr
        return dict(self.stats) | lr

    # ---- checkpoints ----------------------------------------------------------------------

    def device_name(self) -> str:
        return describe(self.device)

    def checkpoint(self, member: int) -> Tree:
        agent: dict[str, object] = self.net.state_arrays(member)
        if self.normaliser is not None:
            agent["reward_norm"] = self.normaliser.state(member)
        return {"agent": agent}

    def restore(self, member: int, checkpoint: Tree) -> None:
        self.net.load_state_arrays(member, checkpoint["agent"])
        if self.normaliser is not None:
            self.normaliser.load(member, checkpoint["agent"]["reward_norm"])

    def policy(self, member: int) -> Tree:
        return self.net.policy_arrays(member)
