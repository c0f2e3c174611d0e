"""What the trainer, the evaluation and the run-file validator need of a learning algorithm.

An algorithm has two halves. Its :class:`AlgorithmSpec` is torch-free and always importable: it
declares and checks the algorithm's part of a checkpoint, estimates its memory and builds a
learner or a greedy policy (importing torch only then). Its :class:`Algorithm` is the learner of
a stack of S members (seeds), each a whole independent run, stepped in lockstep by
``adaptsky.training``. ``adaptsky.algos.registry`` maps ``[agent] algorithm`` to the spec.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, NoReturn, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from adaptsky.arrays import Field, Tree
from adaptsky.scenario.models import Scenario

Policy = Callable[[NDArray[np.float32]], NDArray[np.int64]]
"""Greedy actions (L,) for observations (L, obs) of L environments."""


class Algorithm(Protocol):
    """The learner of S members: what the trainer does with every learner, whatever its
    family (:mod:`adaptsky.algos.off_policy`, :mod:`adaptsky.algos.on_policy`). Observations
    are float32 with a leading member axis S; every member draws only from its own generator
    (``rngs[s]``, given when it is built)."""

    size: int
    reward_parts: int
    """1: :meth:`observe` takes eq. 13's reward (S,); G > 1: its parts per UAV (S, G), split
    as :attr:`reward_split` says (the environment's ``reward_parts``)."""
    reward_split: str
    """How the reward is split where :attr:`reward_parts` > 1 (``agent.reward_split`` of the
    BDQ, MAPPO and IPPO: "per-uav" or "difference"); "team" otherwise."""

    def begin_episode(self, global_step: int) -> None:
        """A new episode starts at ``global_step`` (its schedules move on)."""

    def act(self, observations: NDArray[np.float32], global_step: int) -> NDArray[Any]:
        """Exploring actions (S E,) (continuous: (S E, D)) for one observation per
        environment (S E, obs), member-major: E environments per member
        (:meth:`AlgorithmSpec.envs_per_member`, 1 off-policy)."""
        ...

    def greedy(self, observations: NDArray[np.float32]) -> NDArray[Any]:
        """Greedy actions (S, n) (continuous: (S, n, D)) for n observations per member
        (S, n, obs)."""
        ...

    def observe(self, observations: NDArray[np.float32], actions: NDArray[Any],
                rewards: NDArray[np.float64], next_observations: NDArray[np.float32]) -> None:
        """One step of every environment (S E, ...): rewards (S E,), or (S, G) with
        :attr:`reward_parts` G > 1. Off-policy: stored, and the updates due after it made;
        on-policy: kept for the rollout."""

    def end_episode(self, episodes_before: int) -> None:
        """The episode after ``episodes_before`` episodes is over (on-policy: the update from
        its rollout; off-policy: what the learner does per episode, the DQN's target copy)."""

    def take_mean_loss(self) -> NDArray[np.float64] | None:
        """Each member's mean loss since the last call (S,), None without an update."""
        ...

    def take_stats(self) -> dict[str, NDArray[np.float64]]:
        """Each member's statistics of its last update (S,) by name (PPO: entropy, policy
        and value loss, approximate KL, clip fraction; every learner its learning rate)."""
        ...

    def device_name(self) -> str:
        """Where it computes, as checkpoints record it (``cpu``, ``cuda (NAME)``)."""
        ...

    def checkpoint(self, member: int) -> Tree:
        """Everything of ``member`` needed to continue bit for bit, under the algorithm's
        checkpoint members (:attr:`AlgorithmSpec.checkpoint_members`)."""
        ...

    def restore(self, member: int, checkpoint: Tree) -> None:
        """Inverse of :meth:`checkpoint`, from a checkpoint that holds those members."""

    def policy(self, member: int) -> Tree:
        """The arrays of ``member``'s greedy policy now (a copy: kept as the best policy)."""
        ...


@runtime_checkable
class EpsilonGreedy(Protocol):
    """A learner that explores epsilon-greedily (the DQN and the BDQ): its exploration rate
    is a learning-curve column (NaN for every other learner)."""

    epsilon: float
    """The exploration rate of the last :meth:`Algorithm.act`."""


class Node(Protocol):
    """A group or dataset of a stored file, named by its path."""

    name: str

    def __len__(self) -> int: ...


class LayoutCheck(Protocol):
    """What the run-file validator offers an algorithm to check its part of a checkpoint;
    every failure is one line naming the path, what is wrong and what was expected."""

    def group(self, parent: Node, name: str, optional: bool = False) -> Any: ...

    def dataset(self, group: Node, field: Field, symbols: dict[str, int],
                shape: tuple[int, ...] | None = None) -> Any: ...

    def attr(self, obj: Node, name: str, kind: str, optional: bool = False) -> Any: ...

    def exact_members(self, group: Node, names: Iterable[str],
                      extra_ok: tuple[str, ...] = ()) -> None: ...

    def fail(self, where: str, what: str, expected: str = "") -> NoReturn: ...


class AlgorithmSpec(Protocol):
    """The torch-free half of an algorithm (module docstring)."""

    name: str
    action_kinds: tuple[str, ...]
    """The ``uav.actions`` kinds it learns (the DQN and the BDQ: the dense ones)."""
    min_uavs: int
    """The fewest UAVs it learns (MAPPO and IPPO act per UAV: 2)."""
    checkpoint_members: tuple[str, ...]
    """The groups of a checkpoint the algorithm writes and checks (the envelope holds the
    rest: attributes, ``rng``, ``best``)."""
    config_keys: tuple[str, ...]
    """``[agent]`` keys a run file's stored config must hold."""
    fields: tuple[Field, ...]
    """Its stored datasets, for their units."""
    remedies: dict[str, str]
    """What to lower when one of its memory parts is the largest."""

    def check_checkpoint(self, check: LayoutCheck, group: Node, scenario: Scenario,
                         episodes_done: int) -> None:
        """Check the algorithm's members of a checkpoint after ``episodes_done`` episodes."""

    def check_policy(self, check: LayoutCheck, group: Node, scenario: Scenario) -> None:
        """Check a stored greedy policy (a checkpoint's best policy)."""

    def check_scenario(self, scenario: Scenario, source: str) -> None:
        """A one-line ScenarioError where the algorithm's settings do not fit the scenario
        (after its action kind is known to be learnt)."""

    def envs_per_member(self, scenario: Scenario) -> int:
        """E, the environments each member collects from at once (1 for off-policy)."""
        ...

    def memory_parts(self, scenario: Scenario, seeds: int, workers: int) -> dict[str, float]:
        """Bytes it needs at its peak by part, for ``seeds`` members in ``workers`` processes
        (``training.resources`` adds the simulation's and the runtime's)."""
        ...

    def build(self, scenario: Scenario, seeds: list[int], rngs: list[np.random.Generator],
              observation_size: int, num_actions: int, device: Any = "cpu",
              graphs: bool | None = None) -> Algorithm:
        """A learner of one member per seed (imports torch)."""
        ...

    def policy_of(self, checkpoint: Tree) -> Tree:
        """The greedy policy's arrays in a checkpoint (the last one, not the best)."""
        ...

    def greedy_policy(self, scenario: Scenario, policy: Tree) -> Policy:
        """argmax_a of a stored policy, for evaluation (imports torch)."""
        ...
