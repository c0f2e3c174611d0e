"""Algorithm 1 for a stack of members (seeds) in lockstep: collect, learn, log, checkpoint.

What learns is the scenario's algorithm (``[agent] algorithm``), reached only through
:class:`~adaptsky.algos.protocol.Algorithm`; this loop owns the environment, the generators,
the greedy evaluations, the best policies and the checkpoints' envelope.

Every member is a whole independent run: its own environment generator (LoS draws, user
moves; seeded with (seed, 0)), its own agent generator (exploration, replay sampling; (seed,
1)), its own initial weights (torch seeded with the seed), memory and Adam state, and its own
reward weights, and with ``users.placement = "fresh"`` its own layout every episode (from
(seed, 2, episode)). Nothing a member computes reads another member's numbers, so a seed
trained in a stack of four gives the numbers it gives alone (on a CPU, bit for bit;
docs/training.md says what holds on a GPU). Members of one stack are at the same episode; every
checkpoint is per member and holds everything needed to continue bit for bit, its best policy
of the greedy evaluations (``train.evaluation``) included.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import torch

from adaptsky.algos.protocol import EpsilonGreedy
from adaptsky.algos.registry import algorithm_of, observation_size_of
from adaptsky.arrays import Tree
from adaptsky.envs.observations import AgentView
from adaptsky.errors import NonFiniteError
from adaptsky.rollouts.metrics import service_metrics
from adaptsky.scenario.models import Scenario
from adaptsky.sim.energy import episode_energy
from adaptsky.sim.lattice import exploring_positions, exploring_shares
from adaptsky.sim.layout import episode_layouts, user_layouts
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.noma import jain_fairness
from adaptsky.sim.reward import reward_weights
from adaptsky.training.evaluation import EVALUATION_KEYS, EvaluationSet, GreedyEvaluator

STATE_FIELDS = ("uav_m", "alpha", "gain", "los", "rate_bps", "energy_j")
# what members of one stack may differ in; everything else must be equal
PER_MEMBER = {"name", "description", "reward", "train"}
# the scenario keys each checked quantity depends on (named when it is not finite)
_GAIN_KEYS = "channel.model, channel.params, uav.*, users.*, area.side_m"
DEPENDS_ON = {
    "gain": _GAIN_KEYS,
    "rate_bps": f"radio.*, {_GAIN_KEYS}",
    "reward": f"reward.*, radio.*, {_GAIN_KEYS}",
    "loss": "agent.lr, agent.gamma, agent.hidden_sizes, agent.loss, agent.grad_clip_norm, "
            "agent.observation, reward.*",
}


@dataclass(frozen=True)
class Member:
    """One run of a stack: a scenario, a seed, and what it evaluates on during training
    (None: no evaluation)."""

    scenario: Scenario
    seed: int
    evaluation: EvaluationSet | None = None


@dataclass
class EpisodeResult:
    """Learning-curve values of one episode of one member, and its trajectory (time-major)."""

    episode: int  # 1-based count of episodes done after this one
    metrics: dict[str, Any]
    trajectory: dict[str, np.ndarray]
    evaluation: dict[str, float] | None = None  # a greedy evaluation after this episode
    # the learner's statistics of the episode (Algorithm.take_stats: losses, learning rate...),
    # for logs and progress only: the run file keeps the metrics
    stats: dict[str, float] = field(default_factory=dict)


def stack_key(scenario: Scenario) -> str:
    """Scenarios with equal keys can train in one stack (they differ at most in PER_MEMBER
    sections, and share the number of steps per episode)."""
    data = {k: v for k, v in scenario.model_dump(mode="json").items() if k not in PER_MEMBER}
    data["steps"] = scenario.train.steps
    return json.dumps(data, sort_keys=True)


def _evaluators(members: list[Member]) -> list[tuple[int, list[int], GreedyEvaluator]]:
    """(eval_every, member indices, evaluator) for each set of members that evaluate alike;
    members without an evaluation are in none."""
    groups: dict[tuple[object, ...], list[int]] = {}
    for index, member in enumerate(members):
        if member.evaluation is not None:
            settings = tuple(getattr(member.scenario.train, key) for key in EVALUATION_KEYS)
            groups.setdefault(settings, []).append(index)
    evaluators = []
    for indices in groups.values():
        train = members[indices[0]].scenario.train
        evaluations = [members[i].evaluation for i in indices]
        evaluators.append((train.eval_every, indices,
                           GreedyEvaluator(evaluations, train.eval_steps)))  # type: ignore[arg-type]
    return evaluators


class StackRun:
    """Environments, agent, memories and generators of a stack of members on ``device``."""

    def __init__(self, members: list[Member], device: str | torch.device = "cpu",
                 graphs: bool | None = None) -> None:
        keys = {stack_key(member.scenario) for member in members}
        if len(keys) != 1:
            raise ValueError("members of a stack may differ only in "
                             f"{sorted(PER_MEMBER)}; got {len(keys)} different scenarios")
        self.members = members
        self.scenario = scenario = members[0].scenario
        seeds = [member.seed for member in members]
        spec = algorithm_of(scenario)
        # E environments per member (PPO's rollout), member-major; environment e of seed s
        # draws from (s, 0) where E = 1, else (s, 0, e), and stands on layout e of the
        # scenario's (every member on the layouts it has alone, wherever it is in the stack)
        self.envs = envs = spec.envs_per_member(scenario)
        self.env = NetworkBatch(scenario, num_envs=len(members) * envs,
                                 seed=[np.random.SeedSequence([s, 0] if envs == 1 else [s, 0, e])
                                       for s in seeds for e in range(envs)],
                                 weights=[reward_weights(m.scenario) for m in members
                                          for _ in range(envs)],
                                 users_m=np.tile(user_layouts(scenario, envs),
                                                 (len(members), 1, 1)),
                                 view=AgentView.of(scenario))
        self.rngs = [np.random.default_rng([s, 1]) for s in seeds]
        controls = self.env.controls
        self.algorithm = spec.build(
            scenario, seeds, self.rngs, observation_size_of(scenario),
            controls.count if controls.form == "index" else controls.num_components,
            torch.device(device), graphs)
        self._seeds = seeds
        self.episodes_done = 0
        self.evaluators = _evaluators(members)
        # the best policy so far of every member: its score, episode and policy arrays
        self.best_score = np.full(len(members), -np.inf)
        self.best_episode = np.zeros(len(members), dtype=np.int64)
        self.best_policy: list[Tree | None] = [None] * len(members)

    def run_episode(self) -> list[EpisodeResult]:
        """One episode of T steps; the algorithm learns from every step."""
        algorithm, steps = self.algorithm, self.scenario.train.steps
        start = self.episodes_done * steps
        states, users, rewards, chosen = [], [], [], []
        # the reward per UAV where the algorithm learns from its parts (agent.reward_split
        # of the BDQ, MAPPO and IPPO with several UAVs)
        split = None
        if algorithm.reward_parts > 1:
            split = functools.partial(self.env.reward_parts, split=algorithm.reward_split)
        algorithm.begin_episode(start)
        if self.scenario.users.placement == "fresh":
            self.env.set_layouts(np.repeat(episode_layouts(
                self.scenario, self._seeds, self.episodes_done), self.envs, axis=0))
        # a NaN or infinity is reported once, by _check_finite, not as numpy warnings
        with np.errstate(all="ignore"):
            obs, _ = self.env.reset(**self._exploring_starts())
            for tau in range(steps):
                actions = algorithm.act(obs, start + tau)
                next_obs, reward, _, state = self.env.step(actions)
                algorithm.observe(obs, actions, reward if split is None else split(state),
                                  next_obs)  # off-policy: stored, and learnt from
                states.append(state)
                users.append(self.env.users_m)
                rewards.append(reward)
                chosen.append(actions)
                obs = next_obs
        algorithm.end_episode(self.episodes_done)
        self.episodes_done += 1
        losses = algorithm.take_mean_loss()
        trajectory = {name: np.stack([getattr(state, name) for state in states])
                      for name in STATE_FIELDS}  # time-major, (T, S E, ...)
        trajectory["reward"], trajectory["action"] = np.stack(rewards), np.stack(chosen)
        trajectory["users_m"] = np.stack(users)        # (T, S E, N, 2): every user's position
        self._check_finite(trajectory, losses)
        if losses is None:  # no update yet: not an error
            losses = np.full(len(self.members), np.nan)
        stats = algorithm.take_stats()
        entropy = stats.get("entropy", np.full(len(self.members), np.nan))
        evaluations = self._evaluate()
        eps = algorithm.epsilon if isinstance(algorithm, EpsilonGreedy) else math.nan
        envs = self.envs
        return [replace(self._result([{name: values[:, index * envs + e]
                                       for name, values in trajectory.items()}
                                      for e in range(envs)],
                                     eps, losses[index], float(entropy[index]),
                                     evaluations[index]),
                        stats={name: float(values[index]) for name, values in stats.items()})
                for index in range(len(self.members))]

    def _exploring_starts(self) -> dict[str, np.ndarray]:
        """Where a training episode starts, as ``reset``'s keywords: nothing (every UAV at
        its start, every share at ``start_alpha``), or with ``train.exploring_starts`` each
        member's first users' shares (``"shares"``), UAV positions (``"positions"``) or both
        (shares drawn first), drawn by its environments' generators, so that a seed draws the
        same alone, in a stack and resumed."""
        kind = self.scenario.train.exploring_starts
        if kind == "none":
            return {}
        env = self.env
        assert env.rngs is not None  # seeded with one sequence per member
        starts: dict[str, np.ndarray] = {}
        if kind in ("shares", "both"):
            # one member's shares: (K,) for one UAV, (U, K) for several
            starts["alpha_first"] = exploring_shares(self.scenario, env.rngs,
                                                     env.alpha_first.shape[1:])
        if kind in ("positions", "both"):
            starts["uav_m"] = exploring_positions(self.scenario, env.rngs)
        return starts

    def _evaluate(self) -> list[dict[str, float] | None]:
        """A greedy evaluation of every member when one is due (``train.eval_every``), and
        the best policies kept; None per member otherwise."""
        found: list[dict[str, float] | None] = [None] * len(self.members)
        for every, indices, evaluator in self.evaluators:
            if self.episodes_done % every:
                continue
            for index, row in zip(indices, evaluator.run(self._greedy_of(indices)),
                                  strict=True):
                row["episode"] = self.episodes_done
                found[index] = row
                if row["score"] > self.best_score[index]:  # a NaN score is never the best
                    self.best_score[index] = row["score"]
                    self.best_episode[index] = self.episodes_done
                    self.best_policy[index] = self.algorithm.policy(index)
        return found

    def _greedy_of(self, indices: list[int]) -> Callable[[np.ndarray], np.ndarray]:
        """The greedy actions of the members ``indices`` for their observations (k, n, obs)."""
        if len(indices) == len(self.members):
            return self.algorithm.greedy

        def greedy(observations: np.ndarray) -> np.ndarray:
            every = np.zeros((len(self.members), *observations.shape[1:]), dtype=np.float32)
            every[indices] = observations
            return self.algorithm.greedy(every)[indices]
        return greedy

    def _check_finite(self, trajectory: dict[str, np.ndarray], losses: np.ndarray | None
                      ) -> None:
        """Raise :class:`NonFiniteError` for the first NaN or infinity among the episode's
        gains, rates, rewards (T, S, ...) and losses (S,): nothing of the episode is stored."""
        checked = {name: trajectory[name] for name in ("gain", "rate_bps", "reward")}
        if losses is not None:
            checked["loss"] = np.asarray(losses)[None]
        for name, values in checked.items():
            if np.isfinite(values).all():
                continue
            where = tuple(int(i) for i in np.argwhere(~np.isfinite(values))[0])
            seed = self.members[where[1] // self.envs].seed  # axis 1: the member's envs
            value = values[where]
            step = "" if name == "loss" else f", step {where[0] + 1}"
            user = f" of user {where[2] + 1}" if len(where) > 2 else ""
            raise NonFiniteError(
                f"{self.scenario.name}: seed {seed}, episode {self.episodes_done}{step}: "
                f"{name}{user} is {value}; it depends on {DEPENDS_ON[name]}. Training stopped; "
                "the run file keeps its last checkpoint")

    def _result(self, trajectories: list[dict[str, np.ndarray]], eps: float, loss: float,
                entropy: float, evaluation: dict[str, float] | None) -> EpisodeResult:
        """One member's episode from its E environments' trajectories: the learning-curve
        values averaged over them, the first one's trajectory."""
        trajectories = [{name: np.ascontiguousarray(values) for name, values in t.items()}
                        for t in trajectories]
        each = [self._metrics(t) for t in trajectories]
        metrics = each[0] if len(each) == 1 else {
            name: np.mean([m[name] for m in each], axis=0) for name in each[0]}
        metrics |= {"epsilon": eps, "loss": float(loss), "entropy": entropy}
        trajectory = trajectories[0]
        return EpisodeResult(self.episodes_done, metrics, trajectory, evaluation)

    def _metrics(self, trajectory: dict[str, np.ndarray]) -> dict[str, Any]:
        """The learning-curve values of one environment's episode (but epsilon and loss)."""
        rates = trajectory["rate_bps"]
        return {
            "sum_rate_bps": rates.sum(axis=1).mean(),
            "fairness": float(np.mean(jain_fairness(rates))),
            "reward": trajectory["reward"].sum(),
            "mean_height_m": trajectory["uav_m"][..., 2].mean(),   # over every UAV
            "mean_rate_bps": rates.mean(axis=0),
            "mean_alpha": trajectory["alpha"].mean(axis=0),
            **episode_energy(rates.sum(axis=1), trajectory["energy_j"],
                             self.scenario.uav.step_s),
            **{name: float(value[0]) for name, value in service_metrics(
                rates[:, None], self.scenario.radio.bandwidth_hz,
                self.scenario.metrics.outage_se).items()},
        }

    def best(self, index: int) -> Tree | None:
        """Member ``index``'s best policy so far (None before it has one): the episode that
        made it, its score, and its policy's arrays."""
        policy = self.best_policy[index]
        if policy is None:
            return None
        return {"episode": int(self.best_episode[index]),
                "score": np.float64(self.best_score[index]), "policy": policy}

    def checkpoint(self, index: int) -> Tree:
        """Everything member ``index`` needs to continue bit for bit, as arrays and JSON (and
        its best policy so far, when it has one)."""
        best = self.best(index)
        return ({"best": best} if best is not None else {}) | {
            "episode": self.episodes_done,
            "global_step": self.episodes_done * self.scenario.train.steps,
            "seed": self.members[index].seed,
            "device": self.algorithm.device_name(),
            **self.algorithm.checkpoint(index),
            "rng": {"numpy_agent_json": json.dumps(self.rngs[index].bit_generator.state),
                    "numpy_env_json": json.dumps(self._env_rng_states(index))},
        }

    def _env_rngs(self, index: int) -> list[np.random.Generator]:
        """Member ``index``'s environments' generators (E of them)."""
        assert self.env.rngs is not None
        return self.env.rngs[index * self.envs:(index + 1) * self.envs]

    def _env_rng_states(self, index: int) -> object:
        """Its generators' states: one (E = 1), else a list."""
        states = [rng.bit_generator.state for rng in self._env_rngs(index)]
        return states[0] if self.envs == 1 else states

    def restore(self, index: int, checkpoint: Tree) -> None:
        """Inverse of :meth:`checkpoint` for member ``index``; every member of a stack must be
        restored to the same episode."""
        episode = int(checkpoint["episode"])
        if index and episode != self.episodes_done:
            raise ValueError(f"members of a stack must be at one episode: member {index} is at "
                             f"{episode}, member 0 at {self.episodes_done}")
        self.algorithm.restore(index, checkpoint)
        self.rngs[index].bit_generator.state = json.loads(checkpoint["rng"]["numpy_agent_json"])
        states = json.loads(checkpoint["rng"]["numpy_env_json"])
        for rng, state in zip(self._env_rngs(index), states if self.envs > 1 else [states],
                              strict=True):
            rng.bit_generator.state = state
        best = checkpoint.get("best")
        if best is not None:
            self.best_score[index] = float(best["score"])
            self.best_episode[index] = int(best["episode"])
            self.best_policy[index] = best["policy"]
        self.episodes_done = episode
