"""MAPPO and IPPO (docs/agent.md): the rows of the shared actor and of the critics against
hand-made arrays, the joint action against ActionSet's decoding, the environment's local view
against the PettingZoo env's local observations, each UAV's reward, eval's greedy policy, and
the refusals (what every learner does: tests/contract/test_learners.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from adaptsky.algos.mappo.rows import actor_rows, critic_rows, joint_actions
from adaptsky.algos.mappo.spec import input_sizes, uav_head
from adaptsky.algos.registry import algorithm_of, check_actions
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.envs.observations import AgentView, observation_bounds_of
from adaptsky.envs.parallel_env import NomaUavParallelEnv
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.network import NetworkBatch
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

MAPPO = {"algorithm": "mappo", "hidden_sizes": [16, 16], "envs_per_seed": 2,
         "minibatches": 2, "epochs": 2}
TWO_UAVS = SCENARIOS / "two_uavs_mmwave.toml"


def mappo_data(base: Path = TWO_UAVS, **changes: dict) -> dict:
    data = load_scenario(base).model_dump(mode="json")
    data["name"] = "mappo"
    data["agent"] = dict(MAPPO)
    data["train"] |= {"episodes": 12, "steps": 30, "checkpoint_every": 3, "eval_every": 0}
    for section, values in changes.items():
        data[section] = {**data.get(section, {}), **values}
    return data


def mappo_scenario(tmp_path: Path, **changes: dict) -> Path:
    """two_uavs_mmwave with a small MAPPO: 12 episodes of 30 steps, checkpoints every 3."""
    path = tmp_path / "mappo.toml"
    path.write_text(dumps(mappo_data(**changes)))
    return path


# ---- rows and joint actions -------------------------------------------------------------


def test_rows_are_each_uav_s_local_observation_and_id():
    """Two environments of U = 2 and L = 3: observation [a0 | a1] gives actor rows [a0, 1, 0]
    and [a1, 0, 1]; the centralised critic's rows [a0 a1, 1, 0] and [a0 a1, 0, 1]."""
    obs = np.arange(12, dtype=np.float32).reshape(2, 6)
    actor = actor_rows(obs, 2)
    assert actor.shape == (4, 5)
    assert actor.tolist() == [[0, 1, 2, 1, 0], [3, 4, 5, 0, 1],
                              [6, 7, 8, 1, 0], [9, 10, 11, 0, 1]]
    critic = critic_rows(obs[None], 2)[0]
    assert critic.shape == (4, 8)
    assert critic[1].tolist() == [0, 1, 2, 3, 4, 5, 0, 1]
    assert critic[2].tolist() == [6, 7, 8, 9, 10, 11, 1, 0]


@pytest.mark.parametrize("mode", ["paper", "with-hover"])
def test_the_joint_index_decodes_to_each_uav_s_own_moves(mode):
    """Every UAV's index a_u in [0, b^D) (D = 5: x, y, h and two clusters) is its own moves:
    the joint index decodes (ActionSet of 2 UAVs) to UAV 0's decoding, then UAV 1's."""
    one, two = ActionSet(2, mode, 1), ActionSet(2, mode, 2)
    rng = np.random.default_rng(0)
    own = rng.integers(0, one.count, size=(3, 4, 2))            # (S, n, U)
    joint = joint_actions(own.reshape(3, 8), 2, one.count)
    assert joint.shape == (3, 4)
    assert np.array_equal(two.decode(joint),
                          np.concatenate([one.decode(own[..., 0]), one.decode(own[..., 1])],
                                         axis=-1))
    controls = np.arange(3 * 4 * 2 * 5, dtype=np.float32).reshape(3, 8, 5)
    assert np.array_equal(joint_actions(controls, 2, None),
                          controls.reshape(3, 4, 10))


# ---- the environment's local view -------------------------------------------------------


@pytest.mark.parametrize("base", ["two_uavs_mmwave", "three_uavs_mmwave"])
def test_the_environment_observes_every_uav_s_local_observation(base):
    """A MAPPO scenario's observation (B, U L) is the PettingZoo env's local observations of
    the same network, one UAV after the other, step by step; its bounds hold them."""
    data = mappo_data(SCENARIOS / f"{base}.toml", agent={"user_order": "clusters"})
    mappo = parse_scenario(data, "mappo")
    data["agent"] = {"algorithm": "bdq", "user_order": "clusters"}
    plain = parse_scenario(data, "bdq")
    pettingzoo = NomaUavParallelEnv(plain, observation="local")
    batch = NetworkBatch(mappo, num_envs=1, seed=3, view=AgentView.of(mappo))
    local, _ = pettingzoo.reset(seed=3)
    obs, _ = batch.reset()
    low, high = observation_bounds_of(mappo)
    assert obs.shape == (1, observation_size_of(mappo)) == (1, len(low))
    actions = ActionSet.of(mappo)
    rng = np.random.default_rng(1)
    for _ in range(4):
        expected = np.concatenate([local[agent] for agent in pettingzoo.possible_agents])
        assert np.array_equal(obs[0], expected)
        assert np.all((low <= obs[0]) & (obs[0] <= high))
        directions = actions.decode(rng.integers(actions.count))
        step, start = {}, 0
        for agent in pettingzoo.possible_agents:
            width = pettingzoo.components[agent]
            step[agent] = (directions[start:start + width] + 1) // 2
            start += width
        local, *_ = pettingzoo.step(step)
        obs, *_ = batch.step(actions.encode(directions)[None])


def test_sizes_of_the_actor_and_the_critics():
    """two_uavs_mmwave: K = 2, L = 5 * 4 + 3 * 2 = 26; the actor reads L + U = 28, MAPPO's
    critic U L + U = 54, IPPO's L + U = 28; each UAV has 2^5 = 32 moves."""
    mappo = parse_scenario(mappo_data(), "m")
    ippo = parse_scenario(mappo_data(agent={"algorithm": "ippo"}), "i")
    assert observation_size_of(mappo) == 52
    assert input_sizes(mappo) == (28, 54) and input_sizes(ippo) == (28, 28)
    assert uav_head(mappo)[0].width == 32 and uav_head(mappo)[1] == 32


# ---- each UAV's reward --------------------------------------------------------------------


@pytest.mark.parametrize("split", ["team", "per-uav", "difference"])
def test_every_uav_learns_from_its_reward(tmp_path, split):
    """After one episode of 30 steps the rollout's rewards are, per UAV row, the team's
    reward (the run file's) or the network's reward_parts of every step."""
    scenario = parse_scenario(mappo_data(agent={"reward_split": split, "norm_reward": False},
                                         train={"episodes": 1}), "m")
    from adaptsky.training.stack_run import Member, StackRun

    stack = StackRun([Member(scenario, 0)])
    rewards = []
    original = stack.env.step

    def recording(actions):
        result = original(actions)
        team = result[1]
        parts = stack.env.reward_parts(result[3], split=split) if split != "team" else None
        rewards.append(np.repeat(team[:, None], 2, axis=1) if parts is None else parts)
        return result
    stack.env.step = recording
    end = stack.algorithm.end_episode
    kept = []
    stack.algorithm.end_episode = lambda done: kept.append(stack.algorithm.rewards.copy())
    stack.run_episode()
    stack.algorithm.end_episode = end
    expected = np.stack(rewards).reshape(30, 1, 4)   # (T, S, E U): env 0's UAVs, env 1's
    assert np.array_equal(kept[0], expected)
    assert stack.algorithm.reward_parts == (1 if split == "team" else 2)
    if split != "team":
        assert not np.array_equal(expected[..., 0], expected[..., 1])


# ---- training -----------------------------------------------------------------------------


def test_eval_flies_the_greedy_policy_of_every_uav(tmp_path):
    """eval of a MAPPO run file: its greedy policy gives one joint action per step; the
    greedy policy of the spec equals the learner's; an entropy every episode."""
    path = mappo_scenario(tmp_path, train={"episodes": 3})
    run, _ = api.train(scenario_path=path, out=tmp_path / "m.h5", seeds=[0], workers=1,
                       quiet=True)
    from adaptsky.store.run_file import RunReader
    with RunReader(run) as reader:
        assert np.isfinite(reader.episodes(0)["entropy"]).all()
    from adaptsky.evaluation.api import read_trained
    from adaptsky.rollouts.rollout import greedy_policy
    from adaptsky.training.stack_run import Member, StackRun

    trained = read_trained(run, 0, "last")
    policy = greedy_policy(trained.scenario, trained.policy)
    stack = StackRun([Member(trained.scenario, 0)])
    stack.algorithm.restore(0, {"agent": _checkpoint_agent(run)})
    obs = np.random.default_rng(0).normal(size=(5, 52)).astype(np.float32)
    actions = policy(obs)
    assert actions.shape == (5,) and actions.dtype == np.int64
    assert np.array_equal(actions, stack.algorithm.greedy(obs[None])[0])
    assert main(["eval", "--checkpoint", str(run), "--steps", "40", "--compare", "",
                 "--out", str(tmp_path / "e.h5")]) == 0


def _checkpoint_agent(run: Path) -> dict:
    from adaptsky.store.run_file import RunReader

    with RunReader(run) as reader:
        return reader.checkpoint(0)["agent"]


# ---- refusals ---------------------------------------------------------------------------


@pytest.mark.parametrize(("base", "changes", "says"), [
    ("nyc_mmwave", {}, "agent.algorithm: 'mappo' acts per UAV and needs uav.count >= 2, "
     "got 1; for one UAV choose 'ppo'"),
    ("two_uavs_mmwave", {"users": {"uav": [0, 0, 0, 0, 0, 0, 1, 1], "association": "listed"}},
     "users.uav: 'mappo' shares one actor among the UAVs, which needs as many clusters on "
     "each; the UAVs have 3, 1"),
    ("two_uavs_mmwave", {"agent": {"action_head": "gaussian"}},
     "agent.action_head: 'gaussian' does not fit uav.actions = 'paper'"),
])
def test_scenarios_mappo_cannot_learn_are_refused_in_one_line(base, changes, says):
    data = mappo_data(SCENARIOS / f"{base}.toml", **changes)
    scenario = parse_scenario(data, "m")
    assert algorithm_of(scenario).name == "mappo"
    with pytest.raises(ScenarioError) as error:
        check_actions(scenario, "s.toml")
    assert says in str(error.value) and len(str(error.value).splitlines()) == 1
