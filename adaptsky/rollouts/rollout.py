"""Rollouts over L layouts at once: a policy stepping from the episode start, or a fixed
configuration held (baselines). Both give a time-major :class:`Trace`. Every rollout runs on
:class:`~adaptsky.sim.network.NetworkBatch`, for one UAV as for several."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from adaptsky.algos.protocol import Policy
from adaptsky.algos.registry import algorithm_of
from adaptsky.arrays import Tree
from adaptsky.envs.observations import AgentView
from adaptsky.scenario.models import Scenario
from adaptsky.sim.controls import BOX_HIGH, BOX_LOW, Controls, DenseControls
from adaptsky.sim.interference import oma_rates_bps
from adaptsky.sim.network import NetworkBatch, NetworkState
from adaptsky.sim.state import users_move

Tick = Callable[[int], None]
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Trace:
    """Per step and layout: rates (T, L, N), UAV positions (T, L, 3) for one UAV and
    (T, L, U, 3) for U > 1, every user's power share (T, L, N), each UAV's energy of the
    step (T, L) or (T, L, U), J (docs/model.md §10), the LoS state of each user's serving
    link (T, L, N) (None where a search computed the rates: OMA), and every user's position
    (T, L, N, 2), m, where the users move (None where they stand: their layout)."""

    rate_bps: FloatArray
    uav_m: FloatArray
    alpha: FloatArray
    energy_j: FloatArray
    los: NDArray[np.bool_] | None = None
    users_m: FloatArray | None = None

    @property
    def sum_rate_bps(self) -> FloatArray:
        return self.rate_bps.sum(axis=-1)

    @classmethod
    def of(cls, states: list[NetworkState],
           users_m: list[FloatArray] | None = None) -> Trace:
        """The trace of the states of a rollout, with the users' positions of each step
        (``users_m``: none where they stand)."""
        return cls(np.array([s.rate_bps for s in states]), np.array([s.uav_m for s in states]),
                   np.array([s.alpha for s in states]), np.array([s.energy_j for s in states]),
                   np.array([s.los for s in states]),
                   None if users_m is None else np.array(users_m))


def _env(scenario: Scenario, users_m: FloatArray, seed: int, view: AgentView | None = None
         ) -> NetworkBatch:
    return NetworkBatch(scenario, num_envs=len(users_m), seed=seed, users_m=users_m, view=view)


def rollout(scenario: Scenario, policy: Policy, steps: int, users_m: FloatArray,
            seed: int = 0, on_step: Tick | None = None) -> Trace:
    """Run ``policy`` for ``steps`` steps from the episode start, with no time limit;
    ``on_step`` hears the number of steps done after each."""
    env = _env(scenario, users_m, seed, AgentView.of(scenario))   # what the agent observes
    obs, _ = env.reset()
    states = []
    walked: list[FloatArray] | None = [] if users_move(scenario) else None
    for step in range(steps):  # the batch core reports truncation but never enforces it
        obs, _, _, state = env.step(policy(obs))
        states.append(state)
        if walked is not None:
            walked.append(env.users_m)
        if on_step is not None:
            on_step(step + 1)
    return Trace.of(states, walked)


def hold(scenario: Scenario, uav_m: FloatArray,
         alpha_first: FloatArray | Callable[[NetworkBatch], FloatArray], steps: int,
         users_m: FloatArray, seed: int = 0, on_step: Tick | None = None, oma: bool = False
         ) -> Trace:
    """Keep the UAV at ``uav_m`` (L, 3) with shares ``alpha_first`` (L, K) for ``steps``
    steps, or for U > 1 every UAV at ``uav_m`` (L, U, 3) with ``alpha_first`` (L, U, K_u),
    while the users move as they do under a policy with the same ``seed`` (the same
    headings and LoS draws, step by step: ``hold_step``); ``alpha_first`` may instead plan
    each step's shares from the environment before it (SoA on channel estimates). With
    ``oma`` the rates are OMA's (:func:`oma_rates`) at each step's gains, not NOMA's."""
    env = _env(scenario, users_m, seed)
    env.reset()
    states = []
    walked: list[FloatArray] | None = [] if users_move(scenario) else None
    for step in range(steps):
        shares = alpha_first(env) if callable(alpha_first) else alpha_first
        state = env.hold_step(uav_m, shares)
        if oma:     # OMA's rates, and every user's share of its cluster's power: 1/M
            state = replace(state, rate_bps=oma_rates(scenario, state),
                            alpha=np.full(state.alpha.shape, 1 / scenario.cluster_size))
        states.append(state)
        if walked is not None:
            walked.append(env.users_m)
        if on_step is not None:
            on_step(step + 1)
    return Trace.of(states, walked)


def held_trace(scenario: Scenario, uav_m: FloatArray, alpha_first: FloatArray,
               users_m: FloatArray, seed: int = 0) -> Trace:
    """A configuration held for one step at a time: at step t the UAVs at ``uav_m[t]`` with
    ``alpha_first[t]`` (as :func:`hold` takes them), the users moving as under a policy with
    the same ``seed``; a hovering step's energy at each (the per-step searches' rollouts)."""
    env = _env(scenario, users_m, seed)
    env.reset()
    states, walked = [], []
    for step_uav_m, step_alpha in zip(uav_m, alpha_first, strict=True):
        states.append(env.hold_step(step_uav_m, step_alpha))
        walked.append(env.users_m)
    return Trace.of(states, walked)


def oma_rates(scenario: Scenario, state: NetworkState) -> FloatArray:
    """Every user's OMA rate (B, N), bit/s, at the gains of ``state`` (docs/model.md §9 and
    §15: 1/M of the band and of the power of its cluster each; the interference of several
    UAVs as the state heard it)."""
    radio = scenario.radio
    return oma_rates_bps(state.gain, state.interference_w, tx_power_w=radio.tx_power_w,
                         antenna_gain=radio.antenna_gain, noise_w=radio.noise_w,
                         bandwidth_hz=radio.bandwidth_hz, cluster_size=scenario.cluster_size)


def random_policy(num_actions: int, seed: int = 0) -> Policy:
    rng = np.random.default_rng(seed)
    return lambda obs: rng.integers(0, num_actions, size=len(obs))


def random_controls_policy(controls: Controls, seed: int = 0) -> Policy:
    """Uniformly random actions of the adapter ``controls``' kind: an index of its dense set,
    or a uniform point of [-1, 1]^D (docs/model.md §3)."""
    if isinstance(controls, DenseControls):
        return random_policy(controls.count, seed)
    rng = np.random.default_rng(seed)
    shape = (controls.num_components,)
    return lambda obs: rng.uniform(BOX_LOW, BOX_HIGH, size=(len(obs), *shape))


def greedy_policy(scenario: Scenario, policy: Tree) -> Policy:
    """argmax_a of a stored greedy policy (the arrays of a checkpoint's ``policy_of`` or of
    its best policy), by the scenario's algorithm."""
    return algorithm_of(scenario).greedy_policy(scenario, policy)
