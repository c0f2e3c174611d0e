"""The one evaluation of the network (``NetworkBatch.evaluate``): a configuration, the users'
positions and the draws in, a ``NetworkState`` out. The baselines' entry points are calls of
it, the draws may be given explicitly, and the simulator reads no agent setting."""

from __future__ import annotations

import numpy as np
import pytest

from adaptsky.scenario import Scenario, parse_scenario
from adaptsky.sim.network import NetworkBatch, NetworkState
from tests.conftest import SUB6_RADIO, make_scenario
from tests.unit.envs.several_uavs import two_uavs

FIELDS = ("uav_m", "alpha", "gain", "interference_w", "los", "p_los", "strong", "rate_bps",
          "sum_rate_bps", "fairness", "reward", "energy_j")


def walking() -> Scenario:
    """Sub-6 GHz, sampled LoS, walking users: every step draws headings, then LoS."""
    return make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani",
                                                    "los": "sampled"},
                         users={"speed_m_per_step": 1.5})


def assert_same(first: NetworkState, second: NetworkState) -> None:
    for field in FIELDS:
        a, b = getattr(first, field), getattr(second, field)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), field


def pair(scenario: Scenario, num_envs: int = 3) -> tuple[NetworkBatch, NetworkBatch]:
    seeds = [np.random.SeedSequence([7, b]) for b in range(num_envs)]
    envs = (NetworkBatch(scenario, num_envs, seed=seeds),
            NetworkBatch(scenario, num_envs, seed=seeds))
    for env in envs:
        env.reset()
    return envs


@pytest.mark.parametrize("scenario", [walking(), two_uavs(moving=True)],
                         ids=["one-uav", "two-uavs"])
def test_the_entry_points_are_calls_of_evaluate(scenario: Scenario) -> None:
    """hold_step, fly_step and evaluate_at give, bit for bit, ``evaluate`` with the users'
    next positions and the step count they take, step after step (the same draws)."""
    named, plain = pair(scenario)
    uav_m, alpha = named.uav_m.copy(), named.alpha_first.copy()
    flown_m = uav_m + np.array([4.0, -3.0, 2.0])
    for t in range(3):
        assert_same(named.hold_step(uav_m, alpha),
                    plain.evaluate(uav_m, alpha, plain.next_users(), t=plain.t + 1))
        assert_same(named.fly_step(flown_m, alpha),
                    plain.evaluate(flown_m, alpha, plain.next_users(), t=plain.t + 1,
                                   flown=True))
        assert_same(named.evaluate_at(uav_m, alpha), plain.evaluate(uav_m, alpha))
        assert named.t == plain.t == 2 * (t + 1)
        np.testing.assert_array_equal(named.users_m, plain.users_m)
    assert not np.array_equal(named.users_m, named.layouts_m)      # the users walked


def test_held_hovers_and_flown_pays_the_move() -> None:
    """Held as given: a hovering step's energy wherever the UAV is; flown: the energy of
    the move from where it was (docs/model.md §10), another number."""
    env, _ = pair(walking(), 1)
    start_m = env.uav_m.copy()
    moved_m = start_m + np.array([5.0, 0.0, 0.0])
    held = env.evaluate(moved_m, env.alpha_first, t=env.t)
    np.testing.assert_array_equal(held.energy_j, env.hover_energy_j)
    np.testing.assert_array_equal(held.uav_m, moved_m)
    env.evaluate(start_m, env.alpha_first)                         # back, held
    flown = env.evaluate(moved_m, env.alpha_first, t=env.t + 1, flown=True)
    assert flown.energy_j[0] != env.hover_energy_j[0]
    np.testing.assert_array_equal(flown.uav_m, moved_m)


def test_explicit_draws_equal_the_networks_own() -> None:
    """LoS drawn from generators given to ``evaluate`` equal those of a network whose own
    generators are seeded alike; other generators draw other LoS states."""
    scenario = walking()
    own = NetworkBatch(scenario, 4, seed=[np.random.SeedSequence([3, b]) for b in range(4)])
    given = NetworkBatch(scenario, 4, seed=0)
    own.reset()
    given.reset()
    draws = [np.random.default_rng(np.random.SeedSequence([3, b])) for b in range(4)]
    uav_m, alpha = own.uav_m.copy(), own.alpha_first.copy()
    given.evaluate(uav_m, alpha, draws=draws)       # the draws of own's reset, at the start
    states = [(own.evaluate(uav_m, alpha), given.evaluate(uav_m, alpha, draws=draws))
              for _ in range(5)]
    for first, second in states:
        assert_same(first, second)
    los = np.array([state.los for state, _ in states])
    assert los.any() and not los.all()                        # LoS really was drawn
    other = given.evaluate(uav_m, alpha, draws=np.random.default_rng(99))
    assert not all(np.array_equal(other.los, state.los) for state, _ in states)


def test_the_network_reads_no_agent_setting() -> None:
    """Scenarios that differ only in the agent's users' order and local view give the same
    observations and states: what the agent sees is its adapter's (adaptsky.envs)."""
    base = two_uavs(moving=True)
    data = base.model_dump(mode="json")
    data["agent"] = {"algorithm": "mappo"}                     # local view, listed users
    mappo = parse_scenario(data, "mappo")
    assert base.agent.user_order == "clusters"
    first, second = (NetworkBatch(s, 2, seed=1) for s in (base, mappo))
    for env in (first, second):
        env.reset()
    actions = np.random.default_rng(0).integers(0, first.actions.count, size=(4, 2))
    for action in actions:
        obs, _, _, state = first.step(action)
        other_obs, _, _, other = second.step(action)
        np.testing.assert_array_equal(obs, other_obs)
        assert_same(state, other)
