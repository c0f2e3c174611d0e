"""Algorithm 1 for one seed: collect, update, log, checkpoint at episode boundaries.

Randomness: the environment's generator (LoS draws, user moves) is seeded with (seed, 0), the
agent's (exploration, replay sampling) with (seed, 1), torch (initial weights) with the seed.
All three are saved in every checkpoint, so a resumed run continues bit for bit.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from adaptsky_cli.agent.dqn import DqnAgent
from adaptsky_cli.agent.replay import ReplayMemory
from adaptsky_cli.agent.schedule import epsilon
from adaptsky_cli.env.batch import NomaUavBatch
from adaptsky_cli.env.noma import jain_fairness
from adaptsky_cli.env.observation import observation_size
from adaptsky_cli.scenario.models import Scenario
from adaptsky_cli.store.tree import Tree


@dataclass
class EpisodeResult:
    """Learning-curve values of one episode and its trajectory (time-major arrays)."""

    episode: int  # 1-based count of episodes done after this one
    metrics: dict[str, Any]
    trajectory: dict[str, np.ndarray]


class SeedRun:
    """Environment, agent, replay memory and generators of one seed."""

    def __init__(self, scenario: Scenario, seed: int) -> None:
        self.scenario = scenario
        self.seed = seed
        self.env = NomaUavBatch(scenario, num_envs=1, seed=np.random.SeedSequence([seed, 0]))
        self.rng = np.random.default_rng([seed, 1])
        obs_size = observation_size(scenario.num_users)
        self.agent = DqnAgent(scenario.agent, obs_size, self.env.actions.count, seed)
        self.memory = ReplayMemory(scenario.agent.memory_size, obs_size)
        self.episodes_done = 0

    def run_episode(self) -> EpisodeResult:
        """One episode of T steps with an update per step once the memory holds a batch."""
        config, steps = self.scenario.agent, self.scenario.train.steps
        n_users = self.scenario.num_users
        trajectory = {
            "uav_m": np.zeros((steps, 3)), "alpha": np.zeros((steps, n_users)),
            "gain": np.zeros((steps, n_users)), "los": np.zeros((steps, n_users), dtype=bool),
            "rate_bps": np.zeros((steps, n_users)), "reward": np.zeros(steps),
            "action": np.zeros(steps, dtype=np.int64)}
        losses = []
        obs, _ = self.env.reset()
        eps = config.epsilon_start
        for tau in range(steps):
            eps = epsilon(self.episodes_done * steps + tau, config.epsilon_start,
                          config.epsilon_end, config.epsilon_decay_steps)
            action = self.agent.act(obs[0], eps, self.rng)
            next_obs, reward, _, state = self.env.step(np.array([action]))
            # no terminal states: the time limit is a truncation and still bootstraps
            self.memory.add(obs[0], action, reward[0], next_obs[0], terminated=False)
            if len(self.memory) >= config.batch_size:
                losses.append(self.agent.update(self.memory.sample(config.batch_size,
                                                                   self.rng)))
            for name in ("uav_m", "alpha", "gain", "los", "rate_bps"):
                trajectory[name][tau] = getattr(state, name)[0]
            trajectory["reward"][tau], trajectory["action"][tau] = reward[0], action
            obs = next_obs
        if self.episodes_done % config.target_update_episodes == 0:  # alg. 1: ep multiple of delta
            self.agent.sync_target()
        self.episodes_done += 1
        rates = trajectory["rate_bps"]
        metrics = {
            "sum_rate_bps": rates.sum(axis=1).mean(),
            "fairness": float(np.mean(jain_fairness(rates))),
            "reward": trajectory["reward"].sum(),
            "mean_height_m": trajectory["uav_m"][:, 2].mean(),
            "epsilon": eps,
            "loss": float(np.mean(losses)) if losses else float("nan"),
            "mean_rate_bps": rates.mean(axis=0),
            "mean_alpha": trajectory["alpha"].mean(axis=0),
        }
        return EpisodeResult(self.episodes_done, metrics, trajectory)

    def checkpoint(self) -> Tree:
        """Everything needed to continue bit for bit, as arrays and JSON text."""
        return {
            "episode": self.episodes_done,
            "global_step": self.episodes_done * self.scenario.train.steps,
            "seed": self.seed,
            "agent": self.agent.state_arrays(),
            "replay": {**self.memory.arrays(), "position": self.memory.position},
            "rng": {"numpy_agent_json": json.dumps(self.rng.bit_generator.state),
                    "numpy_env_json": json.dumps(self.env.rng.bit_generator.state)},
        }

    def restore(self, checkpoint: Tree) -> None:
        """Inverse of :meth:`checkpoint`."""
        self.agent.load_state_arrays(checkpoint["agent"])
        replay = dict(checkpoint["replay"])
        position = int(replay.pop("position"))
        self.memory.load(replay, position)
        self.rng.bit_generator.state = json.loads(checkpoint["rng"]["numpy_agent_json"])
        self.env.rng.bit_generator.state = json.loads(checkpoint["rng"]["numpy_env_json"])
        self.episodes_done = int(checkpoint["episode"])
