"""The PettingZoo env's rewards per agent (``reward_split``, docs/agent.md "A reward per UAV"):
the team reward is the Gymnasium env's; per-UAV parts add up to it, each one UAV's own
users' rate term; the difference reward charges each UAV its interference; the default is
the scenario's agent's split."""

import numpy as np
import pytest

from adaptsky.envs.gym_env import NomaUavEnv
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from adaptsky.scenario import load_scenario, parse_scenario
from tests.conftest import SCENARIOS, make_scenario

TWO_UAVS = load_scenario(SCENARIOS / "two_uavs_mmwave.toml")
"""The shipped E4 scenario: sum-rate reward (w_rate 10, R_min = 0, no energy term), full
reuse, BDQ with ``reward_split = "difference"``."""


def _with(scenario, **sections):
    """``scenario`` with its sections updated by ``sections`` (dicts), validated again."""
    data = scenario.model_dump(mode="json")
    for name, values in sections.items():
        data[name] |= values
    return parse_scenario(data, scenario.name)


COUPLED = _with(TWO_UAVS, reward={"min_se": 0.9, "w_fairness": 2.0, "w_gain": 1e6,
                                  "w_satisfied": 0.5, "w_unsatisfied": 3.0, "w_energy": 0.7})
"""Every term of eq. 13 and the energy term weighted, with a minimum rate some users miss."""


def _steps(env, seed=0, steps=4):
    """Reset ``env`` (a parallel env, or a Gymnasium env taking the agents' joint action)
    with ``seed`` and take ``steps`` seeded random steps: each step's (rewards, info)."""
    parallel = isinstance(env, NomaUavParallelEnv)
    agents = NomaUavParallelEnv(env.scenario, reward_split="team")
    agents.reset(seed=seed)
    for offset, agent in enumerate(agents.possible_agents):
        agents.action_space(agent).seed(seed + offset)
    env.reset(seed=seed)
    trace = []
    for _ in range(steps):
        actions = {agent: agents.action_space(agent).sample() for agent in agents.agents}
        if parallel:
            _, rewards, _, _, infos = env.step(actions)
            trace.append((rewards, infos["uav_0"]))
        else:
            joint = np.concatenate([actions[agent] for agent in agents.possible_agents])
            _, reward, _, _, info = env.step(joint)
            trace.append((reward, info))
    return trace


def _rewards(env):
    """The rewards of :func:`_steps`."""
    return [rewards for rewards, _ in _steps(env)]


def test_team_gives_every_agent_the_gym_reward():
    team = _steps(NomaUavParallelEnv(TWO_UAVS, reward_split="team"))
    gym = _steps(NomaUavEnv(TWO_UAVS))
    for (rewards, _), (reward, _) in zip(team, gym, strict=True):
        assert rewards == {"uav_0": reward, "uav_1": reward}


def test_per_uav_parts_are_each_uavs_own_users_rate_term_and_add_up():
    env = NomaUavParallelEnv(TWO_UAVS, reward_split="per-uav")
    serving = env.env.batch.association.serving_uav[0]
    assert sorted(np.bincount(serving)) == [4, 4]             # k-means: 4 users per UAV
    bandwidth_hz, w_rate = TWO_UAVS.radio.bandwidth_hz, TWO_UAVS.reward.w_rate
    for (rewards, info), (reward, _) in zip(_steps(env), _steps(NomaUavEnv(TWO_UAVS)),
                                            strict=True):
        for u in range(2):
            # eq. 13 with only w_r and R_min = 0: w_r sum_{i of u} R_i / W, user by user
            own = [rate / bandwidth_hz for rate, uav in zip(info["rate_bps"], serving,
                                                             strict=True) if uav == u]
            assert rewards[f"uav_{u}"] == pytest.approx(w_rate * sum(own), rel=1e-12)
        # r = r_1 + ... + r_U up to rounding (docs/agent.md)
        assert rewards["uav_0"] + rewards["uav_1"] == pytest.approx(reward, rel=1e-12)
        assert rewards["uav_0"] != rewards["uav_1"]


def test_per_uav_parts_add_up_with_every_term_and_the_energy():
    """Fairness shared 1/U, the indicators over all users, each UAV's own energy
    (docs/agent.md; docs/model.md §10): still r = r_1 + ... + r_U."""
    trace = _steps(NomaUavParallelEnv(COUPLED, reward_split="per-uav"), steps=6)
    satisfied = set()
    for (rewards, info), (reward, _) in zip(trace, _steps(NomaUavEnv(COUPLED), steps=6),
                                            strict=True):
        assert sum(rewards.values()) == pytest.approx(reward, rel=1e-12, abs=1e-12)
        assert info["energy_j"].min() > 0
        satisfied.add(bool((info["rate_bps"] >= COUPLED.min_rate_bps).all()))
    assert satisfied == {False}                              # the threshold binds


def test_difference_charges_each_uav_its_interference():
    per_uav = NomaUavParallelEnv(TWO_UAVS, reward_split="per-uav")
    difference = NomaUavParallelEnv(TWO_UAVS, reward_split="difference")
    batch = difference.env.batch
    serving = batch.association.serving_uav[0]
    bandwidth_hz, w_rate = TWO_UAVS.radio.bandwidth_hz, TWO_UAVS.reward.w_rate
    agents = difference.possible_agents
    difference.reset(seed=1)
    per_uav.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(3):
        actions = {agent: rng.integers(0, 2, 5) for agent in agents}
        _, own, _, _, _ = per_uav.step(actions)
        _, charged, _, _, infos = difference.step(actions)
        for u, agent in enumerate(agents):
            # w_r sum_{i not of u} (R_i^{-u} - R_i) / W, R_i^{-u} without UAV u's signal
            # (R_min = 0: the indicator is 1)
            without = batch.rates_without(u)[0]
            cost = w_rate * sum((alone - rate) / bandwidth_hz for alone, rate, uav in zip(
                without, infos[agent]["rate_bps"], serving, strict=True) if uav != u)
            assert cost > 0                                   # full reuse: it interferes
            assert own[agent] - charged[agent] == pytest.approx(cost, rel=1e-9)


def test_one_uav_gets_the_network_reward_whatever_the_split():
    scenario = make_scenario(train={"steps": 5})
    gym = _rewards(NomaUavEnv(scenario, action_space="multi-discrete"))
    for split in ("per-uav", "difference"):
        env = NomaUavParallelEnv(scenario, reward_split=split)
        assert env.possible_agents == ["uav_0"]
        assert [rewards["uav_0"] for rewards in _rewards(env)] == gym


def test_the_default_is_the_scenarios_agent_split():
    assert TWO_UAVS.agent.algorithm == "bdq"
    assert NomaUavParallelEnv(TWO_UAVS).reward_split == "difference"
    per_uav = _with(TWO_UAVS, agent={"reward_split": "per-uav"})
    assert NomaUavParallelEnv(per_uav).reward_split == "per-uav"
    assert _rewards(NomaUavParallelEnv(per_uav)) == _rewards(
        NomaUavParallelEnv(TWO_UAVS, reward_split="per-uav"))
    # an explicit split overrides the scenario's
    assert NomaUavParallelEnv(TWO_UAVS, reward_split="team").reward_split == "team"
    # an agent without reward_split (the DQN): one reward for all
    data = TWO_UAVS.model_dump(mode="json")
    data["agent"] = {"algorithm": "dqn"}
    dqn = parse_scenario(data, "dqn")
    assert not hasattr(dqn.agent, "reward_split")
    assert NomaUavParallelEnv(dqn).reward_split == "team"


def test_an_unknown_split_is_one_clear_error():
    with pytest.raises(ValueError, match=r"^reward_split must be 'team', 'per-uav' or "
                                         r"'difference' \(None: the scenario's "
                                         r"agent.reward_split\), got 'shared'$"):
        NomaUavParallelEnv(TWO_UAVS, reward_split="shared")
