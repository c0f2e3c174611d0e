"""The on-policy family (PPO, MAPPO, IPPO; SB3's ``OnPolicyAlgorithm``): collect a rollout,
then learn from it. What its learners share is here, in CleanRL's ``ppo.py`` order: the
rollout storage of T steps of every member's rows, rewards normalised as they come
(:class:`RewardNormaliser`), GAE(lambda) at the episode's end, then ``epochs`` epochs of
``minibatches`` minibatches per member (each member its own permutation from its generator),
one Adam step each, with the per-member means of the loss's parts. A learner adds its networks
(``net``: an actor-critic of :class:`~adaptsky.algos.shared.stacked.StackedParameters`), how
it acts, and its loss (:meth:`OnPolicyLearner._minibatch`).

A rollout row is one environment (PPO) or one agent of one (MAPPO: ``agents`` rows per
environment); :meth:`OnPolicyLearner._inputs`, :meth:`~OnPolicyLearner._joint` and
:meth:`~OnPolicyLearner._row_rewards` map environments onto rows and back.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from adaptsky.algos.device_step import describe
from adaptsky.algos.shared.stacked import padded, padded_rows
from adaptsky.arrays import Tree
from adaptsky.scenario.agents import PpoAgent

EPSILON = 1e-8
COUNT_START = 1e-4  # Gymnasium's RunningMeanStd


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


class RewardNormaliser:
    """Rewards divided by a running standard deviation of the discounted return (CleanRL's PPO
    for continuous actions, through Gymnasium's ``NormalizeReward`` and a clip; Huang et al.
    2022, detail "reward scaling"): eq. 13's rewards are hundreds a step, a return tens of
    thousands, far beyond what a critic starting near 0 and a value clip of 0.2 per rollout
    can follow (docs/agent.md, PPO).

    Per member s: G_t = gamma G_{t-1} + r_t for every row (0 at an episode's start), the
    running mean and variance of every G_t seen (Chan et al.'s parallel update, a step's R rows
    at once, from mean 0, variance 1 and count 1e-4), and r_t / sqrt(var + 1e-8) clipped to
    [-clip, clip]."""

    def __init__(self, size: int, rows: int, gamma: float, clip: float = 10.0) -> None:
        self.gamma, self.clip = gamma, clip
        self.mean = np.zeros(size)
        self.var = np.ones(size)
        self.count = np.full(size, COUNT_START)
        self.returns = np.zeros((size, rows))

    def begin_episode(self) -> None:
        self.returns[...] = 0.0

    def __call__(self, rewards: np.ndarray) -> np.ndarray:
        """The normalised rewards (S, R) of one step's (S, R)."""
        self.returns = self.returns * self.gamma + rewards
        rows = self.returns.shape[1]
        batch_mean, batch_var = self.returns.mean(axis=1), self.returns.var(axis=1)
        delta = batch_mean - self.mean
        total = self.count + rows
        self.mean = self.mean + delta * rows / total
        self.var = (self.var * self.count + batch_var * rows
                    + delta * delta * self.count * rows / total) / total
        self.count = total
        scale = np.sqrt(self.var + EPSILON)[:, None]
        return np.clip(rewards / scale, -self.clip, self.clip)

    def state(self, member: int) -> dict[str, np.ndarray]:
        """Member ``member``'s running statistics (float64 scalars)."""
        return {name: np.array(getattr(self, name)[member])
                for name in ("mean", "var", "count")}

    def load(self, member: int, state: dict[str, np.ndarray]) -> None:
        for name in ("mean", "var", "count"):
            getattr(self, name)[member] = state[name]


class OnPolicyLearner:
    """The family's half of a learner of S members of E environments each (module docstring):
    its rollout of ``steps`` steps of ``observation_size`` actor inputs (and ``critic_size``
    critic inputs where they differ), actions of ``action_shape`` and ``action_dtype``; its
    ``net`` (set by the learner before it calls this) learns at ``self.lr``."""

    net: Any
    """The members' actor-critic (the learner's): ``actor``, ``critic``, ``apply_gradients``,
    its arrays per member."""
    reward_parts = 1
    reward_split = "team"
    agents = 1  # rollout rows per environment
    stat_names: tuple[str, ...] = ("loss",)
    """The per-member means :meth:`_minibatch` returns, ``loss`` among them."""

    def __init__(self, config: PpoAgent, rngs: list[np.random.Generator], steps: int,
                 observation_size: int, critic_size: int | None,
                 action_shape: tuple[int, ...], action_dtype: type) -> None:
        self.config, self.rngs = config, rngs
        self.size, self.envs = len(rngs), config.envs_per_seed
        self.rows = self.envs * self.agents
        self.steps = steps
        self.lr = config.lr
        shape = (steps, self.size, self.rows)
        self.observations = np.zeros((*shape, observation_size), dtype=np.float32)
        self.critic_observations = (None if critic_size is None else
                                    np.zeros((*shape, critic_size), dtype=np.float32))
        self.actions = np.zeros((*shape, *action_shape), dtype=action_dtype)
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

    @property
    def device(self) -> torch.device:
        return self.net.device

    # ---- the rollout ------------------------------------------------------------------------

    def begin_episode(self, global_step: int) -> None:
        """A new rollout (and a new return for the reward normaliser)."""
        self.t = 0
        if self.normaliser is not None:
            self.normaliser.begin_episode()

    def _keep(self, inputs: np.ndarray, critic_inputs: np.ndarray | None, actions: np.ndarray,
              log_probs: torch.Tensor, values: torch.Tensor) -> None:
        """Step t's rows of the rollout: the actor's (and critic's) inputs, the stored
        actions, their log pi and V (S, R)."""
        t = self.t
        self.observations[t], self.actions[t] = inputs, actions
        if critic_inputs is not None:
            assert self.critic_observations is not None
            self.critic_observations[t] = critic_inputs
        self.log_probs[t], self.values[t] = log_probs.cpu().numpy(), values.cpu().numpy()

    def observe(self, observations: NDArray[np.float32], actions: np.ndarray,
                rewards: NDArray[np.float64], next_observations: NDArray[np.float32]) -> None:
        """The step's rewards (S E,) (or parts (S E, G)), scaled by ``reward_scale`` and
        normalised, and the observations after it."""
        scaled = self._row_rewards(rewards) * self.config.reward_scale
        self.rewards[self.t] = scaled if self.normaliser is None else self.normaliser(scaled)
        self.last_observations = np.array(next_observations, dtype=np.float32).reshape(
            self.size, self.envs, -1)
        self.t += 1

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
        rollout = {
            "obs": obs,
            "critic_obs": (obs if self.critic_observations is None
                           else self._per_member(self.critic_observations)),
            "actions": self._per_member(self.actions),
            "old_log_probs": self._per_member(self.log_probs),
            "old_values": self._per_member(self.values),
            "adv": self._per_member(advantages.astype(np.float32)),
            "ret": self._per_member(returns.astype(np.float32)),
        }
        count = self.steps * self.rows
        parts = np.array_split(np.arange(count), min(config.minibatches, count))
        # each minibatch padded to a multiple of PAD rows (repeats of its first row, masked)
        layouts = {len(part): padded_rows(len(part)) for part in parts}
        sums = {name: torch.zeros(self.size, dtype=torch.float64) for name in self.stat_names}
        updates = 0
        for _ in range(config.epochs):
            order = torch.from_numpy(np.stack([rng.permutation(count) for rng in self.rngs]))
            for part in parts:
                where, mask = layouts[len(part)]
                index = order[:, part[where]].to(self.device)             # (S, m padded)
                stats = self._minibatch(index, mask.to(self.device), len(part), **rollout)
                net.apply_gradients(self.lr, config.max_grad_norm)
                for name, value in stats.items():
                    sums[name] += value.detach().cpu().double()
                updates += 1
        self.stats = {name: (value / updates).numpy() for name, value in sums.items()}

    def _minibatch(self, index: torch.Tensor, mask: torch.Tensor, rows: int,
                   **rollout: torch.Tensor) -> dict[str, torch.Tensor]:
        """The loss of one minibatch of ``rows`` rows per member (S, padded indices into the
        ``rollout``'s (S, T R, ...); ``mask`` 1 on the real rows), its gradient computed; the
        per-member means of :attr:`stat_names`."""
        raise NotImplementedError

    def take_mean_loss(self) -> NDArray[np.float64] | None:
        """Each member's mean loss over the last update's minibatches, None before one."""
        return None if self.stats is None else self.stats["loss"]

    def take_stats(self) -> dict[str, NDArray[np.float64]]:
        """The last update's per-member means of :attr:`stat_names` (NaN before one) and its
        learning rate (``lr``)."""
        lr = {"lr": np.full(self.size, self.lr)}  # this episode's (annealed)
        if self.stats is None:
            return {name: np.full(self.size, np.nan) for name in self.stat_names} | lr
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
