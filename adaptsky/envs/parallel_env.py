"""The network as a PettingZoo ``ParallelEnv``: one agent per UAV (docs/model.md §9).

Agents
    ``"uav_0"`` .. ``"uav_{U-1}"`` (one for U = 1), all acting at every step.
Action Space
    Per agent ``MultiDiscrete([base] * (3 + K_u))``: its own UAV's components x, y, h,
    alpha_1 .. alpha_K, sub-action v meaning direction 2 v - 1 (``paper``) or v - 1
    (``with-hover``); for ``uav.actions = "continuous"`` per agent ``Box([-1, 1]^(3 + K_u))``.
    The agents' actions, in UAV order, are the Gymnasium env's MultiDiscrete (or Box) action
    (:mod:`adaptsky.envs.action_spaces`).
Observation Space
    ``observation="global"`` (the default): every agent observes the whole network, the
    Gymnasium env's observation (U > 1: 5 N + 3 U values, U = 1: 4 N + 1), the same for all
    agents. ``"local"``: UAV u observes its own users and every UAV's position, 5 S + 3 U
    values, S = 2 K_max user slots, zeros past its own users
    (:class:`adaptsky.envs.observations.LocalObserver`); one ``Box`` for all agents. Either way
    ``state()`` is the global observation and ``state_space`` its ``Box`` (for centralised
    critics).
Rewards
    ``reward_split="team"``: every agent gets the network's reward (eq. 13 over all users,
    the Gymnasium env's). ``"per-uav"``: UAV u's agent gets the part of eq. 13 from its own
    users plus its own energy term; ``"difference"``: that part plus what its interference
    costs the other UAVs' users in eq. 13's rate term (at most 0); both are
    ``NetworkBatch.reward_parts`` of the step's state (docs/agent.md, "A reward per UAV").
    The default is the scenario's ``agent.reward_split`` where its agent has one (the BDQ;
    the shipped several-UAV scenarios: ``"difference"``), else ``"team"``. With one UAV every
    split gives the network's reward.
Episode End
    Every agent truncated after ``train.steps`` steps, then ``agents`` is empty until
    :meth:`reset`; never terminated.
Arguments
    Those of :class:`adaptsky.envs.gym_env.NomaUavEnv` but ``action_space``: ``scenario``,
    ``users_m``, ``render_mode`` (``None``, ``"ansi"`` or ``"rgb_array"``), ``layout_index``;
    ``observation``, ``"global"`` or ``"local"``; and ``reward_split``, ``"team"``,
    ``"per-uav"`` or ``"difference"`` (None: the scenario's, above).
    Seeds, layouts and ``info`` (the same dict for every agent, copied) are the Gymnasium
    env's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from adaptsky.envs.action_spaces import per_component_kind, uav_action_space
from adaptsky.envs.gym_env import RENDER_FPS, RENDER_MODES, NomaUavEnv, resolve_scenario
from adaptsky.envs.observations import (
    LocalObserver,
    local_bounds_of,
    local_user_slots,
    user_order_of,
    users_in_order,
)
from adaptsky.envs.world_observation import WorldObserver
from adaptsky.scenario import Scenario

AgentID = str
OBSERVATIONS = ("global", "local")
REWARD_SPLITS = ("team", "per-uav", "difference")


class NomaUavParallelEnv(ParallelEnv[AgentID, np.ndarray, np.ndarray]):
    """One agent per UAV over one layout, given the network's reward or its own part of it
    (``reward_split``)."""

    metadata: ClassVar[dict[str, Any]] = {
        "name": "adaptsky_noma_uav_v0", "render_modes": RENDER_MODES,
        "render_fps": RENDER_FPS, "is_parallelizable": True}

    def __init__(self, scenario: Scenario | str | Path | None = None,
                 users_m: np.ndarray | None = None, render_mode: str | None = None,
                 layout_index: int = 0, observation: str = "global",
                 reward_split: str | None = None) -> None:
        if observation not in OBSERVATIONS:
            raise ValueError(f"observation must be 'global' or 'local', got {observation!r}")
        if reward_split is not None and reward_split not in REWARD_SPLITS:
            raise ValueError(f"reward_split must be 'team', 'per-uav' or 'difference' (None: "
                             f"the scenario's agent.reward_split), got {reward_split!r}")
        scenario = resolve_scenario(scenario)
        # the scenario's agent's split where it has one (BDQ, MAPPO, IPPO), else one reward for all
        self.reward_split: str = (getattr(scenario.agent, "reward_split", "team")
                                  if reward_split is None else reward_split)
        self.env = NomaUavEnv(scenario, users_m=users_m, render_mode=render_mode,
                              layout_index=layout_index,
                              action_space=per_component_kind(scenario))
        self.scenario = self.env.scenario
        self.render_mode = self.env.render_mode
        num_uavs = self.scenario.uav.count
        self.possible_agents: list[AgentID] = [f"uav_{u}" for u in range(num_uavs)]
        self.agents: list[AgentID] = []          # none until reset()
        actions = self.env.batch.controls
        # 3 + K_u sub-actions of every UAV (its own number of clusters)
        self.components = {agent: actions.components_of(u)
                           for u, agent in enumerate(self.possible_agents)}
        box = self.env.observation_space
        self.state_space = spaces.Box(box.low, box.high, dtype=np.float32)
        self._local = LocalObserver(self.scenario) if observation == "local" else None
        self._world = WorldObserver.of(self.scenario)
        low, high = ((box.low, box.high) if self._local is None else
                     local_bounds_of(self.scenario, self.env.batch.gain_bounds()))
        self.observation_spaces = {agent: spaces.Box(low, high, dtype=np.float32)
                                   for agent in self.possible_agents}
        self.action_spaces = {
            agent: uav_action_space(self.env.action_space, self.components[agent])
            for agent in self.possible_agents}
        self._observation: np.ndarray | None = None

    def _known(self, agent: AgentID) -> AgentID:
        if agent not in self.observation_spaces:
            raise ValueError(f"unknown agent {agent!r}; agents: "
                             f"{', '.join(self.possible_agents)}")
        return agent

    def observation_space(self, agent: AgentID) -> spaces.Box:
        """The ``Box`` of every agent's observation, global or local (the same for all)."""
        return self.observation_spaces[self._known(agent)]

    def action_space(self, agent: AgentID) -> spaces.MultiDiscrete | spaces.Box:
        """The sub-actions of ``agent``'s UAV's 3 + K_u components."""
        return self.action_spaces[self._known(agent)]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[AgentID, np.ndarray], dict[AgentID, dict[str, Any]]]:
        observation, info = self.env.reset(seed=seed, options=options)
        self._observation = observation
        self.agents = list(self.possible_agents)
        return self._observations(self.agents), {agent: dict(info) for agent in self.agents}

    def step(self, actions: dict[AgentID, np.ndarray]) -> tuple[
            dict[AgentID, np.ndarray], dict[AgentID, float], dict[AgentID, bool],
            dict[AgentID, bool], dict[AgentID, dict[str, Any]]]:
        """Every agent's sub-actions (3 + K_u,) at once; all agents act at every step."""
        if not self.agents:
            raise RuntimeError("no episode is running: call reset()")
        missing = [agent for agent in self.agents if agent not in actions]
        unknown = [str(agent) for agent in actions if agent not in self.agents]
        if missing or unknown:
            raise ValueError(f"actions must name every agent ({', '.join(self.agents)}); "
                             f"missing: {', '.join(missing) or '-'}, unknown: "
                             f"{', '.join(unknown) or '-'}")
        for agent in self.agents:
            shape = (self.components[agent],)
            if np.shape(actions[agent]) != shape:
                raise ValueError(f"the action of {agent} must have shape {shape}, got "
                                 f"{np.shape(actions[agent])}")
        joint = np.concatenate([np.asarray(actions[agent]) for agent in self.possible_agents])
        observation, reward, terminated, truncated, info = self.env.step(joint)
        self._observation = observation
        agents = self.agents
        if terminated or truncated:
            self.agents = []
        return (self._observations(agents), self._rewards(agents, reward),
                dict.fromkeys(agents, terminated), dict.fromkeys(agents, truncated),
                {agent: dict(info) for agent in agents})

    def _rewards(self, agents: list[AgentID], reward: float) -> dict[AgentID, float]:
        """Every agent's reward of the step just taken: the network's ``reward`` (``team``,
        or one UAV), or its UAV's part of it from the network's state after the step
        (:meth:`NetworkBatch.reward_parts`, docs/agent.md)."""
        if self.reward_split == "team" or len(self.possible_agents) == 1:
            return dict.fromkeys(agents, reward)
        batch = self.env.batch
        assert batch.state is not None
        parts = batch.reward_parts(batch.state, split=self.reward_split)[0]
        return {agent: float(parts[u]) for u, agent in enumerate(self.possible_agents)
                if agent in agents}

    def _observations(self, agents: list[AgentID]) -> dict[AgentID, np.ndarray]:
        """Every agent's observation of the last state: the global one, or its own local one
        (from the network's state and association, docs/model.md §9)."""
        assert self._observation is not None
        if self._local is None:
            return {agent: self._observation.copy() for agent in agents}
        batch = self.env.batch
        state = batch.state
        assert state is not None
        order = users_in_order(batch.association, user_order_of(self.scenario))
        local = self._local(state.uav_m.reshape(1, batch.num_uavs, 3), batch.users_m,
                            batch.association.serving_uav, state.alpha, state.gain,
                            state.interference_w, order)[0]
        if self._world is not None:     # its users' slots and its raster (agent.observe)
            assert batch.world_data is not None
            slots = local_user_slots(batch.association, user_order_of(self.scenario),
                                     self.scenario.users_per_uav)
            local = np.concatenate([local, self._world.local(batch.world_data, slots)[0]],
                                   axis=1)
        return {agent: local[u] for u, agent in enumerate(self.possible_agents)
                if agent in agents}

    def state(self) -> np.ndarray:
        """The whole network's observation (``state_space``), for centralised critics."""
        if self._observation is None:
            raise RuntimeError("call reset() before state()")
        return self._observation.copy()

    def render(self) -> str | np.ndarray | None:
        """The Gymnasium env's ``render()``: text for ``"ansi"``, the picture of the episode
        so far (H, W, 3) for ``"rgb_array"``, nothing without a render mode."""
        return self.env.render()

    def close(self) -> None:
        self.env.close()
