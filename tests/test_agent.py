"""Agent pieces: dueling head, replay memory, epsilon schedule, TD update, state round trip."""

import math

import numpy as np
import pytest
import torch

from adaptsky_cli.agent.dqn import DqnAgent
from adaptsky_cli.agent.network import QNetwork
from adaptsky_cli.agent.replay import ReplayMemory
from adaptsky_cli.agent.schedule import epsilon
from adaptsky_cli.scenario.models import Agent


def test_dueling_subtracts_the_mean_advantage_per_sample():
    torch.manual_seed(0)
    net = QNetwork(5, 4, [8], dueling=True)
    obs = torch.randn(3, 5)
    features = net.torso(obs)
    value, advantage = net.value(features), net.advantage(features)
    q = net(obs)
    # per sample: mean over actions of Q equals V (not one mean over the whole batch)
    assert torch.allclose(q.mean(dim=1, keepdim=True), value, atol=1e-6)
    assert torch.allclose(q - value, advantage - advantage.mean(dim=1, keepdim=True), atol=1e-6)
    # a single sample's Q does not depend on which other samples share its batch
    assert torch.allclose(net(obs[:1]), q[:1], atol=1e-6)


def test_plain_network_has_no_value_head():
    net = QNetwork(5, 4, [8, 8], dueling=False)
    assert not hasattr(net, "value") and net(torch.zeros(2, 5)).shape == (2, 4)


def test_replay_memory_overwrites_oldest_and_keeps_terminated():
    memory = ReplayMemory(capacity=3, observation_size=2)
    for i in range(5):
        memory.add(np.full(2, i), i, float(i), np.full(2, i + 1), terminated=(i == 4))
    assert len(memory) == 3 and memory.position == 2
    assert sorted(memory.actions.tolist()) == [2, 3, 4]
    batch = memory.sample(50, np.random.default_rng(0))
    assert batch.observations.dtype == np.float32 and batch.actions.dtype == np.int64
    assert set(batch.actions.tolist()) == {2, 3, 4}
    assert np.all(batch.terminated == (batch.actions == 4))
    assert np.all(batch.next_observations[:, 0] == batch.actions + 1)


def test_replay_memory_round_trip_keeps_storage_order():
    memory = ReplayMemory(4, 1)
    for i in range(6):
        memory.add(np.array([i]), i, 0.0, np.array([i]), False)
    copy = ReplayMemory(4, 1)
    copy.load(memory.arrays(), memory.position)
    rng_a, rng_b = np.random.default_rng(1), np.random.default_rng(1)
    assert np.array_equal(memory.sample(10, rng_a).actions, copy.sample(10, rng_b).actions)
    copy.add(np.array([9]), 9, 0.0, np.array([9]), False)
    memory.add(np.array([9]), 9, 0.0, np.array([9]), False)
    assert np.array_equal(memory.actions, copy.actions)


def test_epsilon_schedule_of_algorithm_1():
    assert epsilon(0, 0.9, 0.1, 200) == pytest.approx(0.9)
    assert epsilon(200, 0.9, 0.1, 200) == pytest.approx(0.1 + 0.8 / math.e)
    assert epsilon(10**6, 0.9, 0.1, 200) == pytest.approx(0.1)


def _batch(rng, n=32, size=3, actions=4):
    from adaptsky_cli.agent.replay import Batch
    return Batch(rng.normal(size=(n, size)).astype(np.float32), rng.integers(0, actions, n),
                 rng.normal(size=n).astype(np.float32),
                 rng.normal(size=(n, size)).astype(np.float32), np.zeros(n, dtype=bool))


def test_td_target_by_hand_with_terminal_and_gamma():
    config = Agent(hidden_sizes=[4], gamma=0.5, lr=1e-3)
    agent = DqnAgent(config, 3, 2, seed=0)
    batch = _batch(np.random.default_rng(0), n=2, actions=2)
    batch = batch._replace(terminated=np.array([False, True]))
    with torch.no_grad():
        q = agent.policy(torch.from_numpy(batch.observations))
        q = q[torch.arange(2), torch.from_numpy(batch.actions)]
        next_max = agent.target(torch.from_numpy(batch.next_observations)).max(dim=1).values
    target = batch.rewards + 0.5 * np.array([1.0, 0.0]) * next_max.numpy()
    expected = float(np.mean((q.numpy() - target) ** 2))
    assert agent.update(batch) == pytest.approx(expected, rel=1e-5)


def test_updates_fit_a_fixed_batch():
    agent = DqnAgent(Agent(hidden_sizes=[32], gamma=0.0, lr=1e-2), 3, 4, seed=0)
    batch = _batch(np.random.default_rng(1))
    first = agent.update(batch)
    for _ in range(200):
        last = agent.update(batch)
    assert last < 0.05 * first


@pytest.mark.parametrize("options", [{"double_dqn": True}, {"loss": "huber"},
                                     {"grad_clip_norm": 0.5}, {"dueling": False}])
def test_options_run_and_learn(options):
    agent = DqnAgent(Agent(hidden_sizes=[32], gamma=0.0, lr=1e-2, **options), 3, 4, seed=0)
    batch = _batch(np.random.default_rng(2))
    first = agent.update(batch)
    for _ in range(200):
        last = agent.update(batch)
    assert last < 0.2 * first


def test_agent_state_round_trip_continues_identically():
    config = Agent(hidden_sizes=[16])
    rng = np.random.default_rng(3)
    batches = [_batch(rng) for _ in range(6)]
    agent = DqnAgent(config, 3, 4, seed=5)
    for batch in batches[:3]:
        agent.update(batch)
    clone = DqnAgent(config, 3, 4, seed=99)
    clone.load_state_arrays(agent.state_arrays())
    losses_a = [agent.update(b) for b in batches[3:]]
    losses_b = [clone.update(b) for b in batches[3:]]
    assert losses_a == losses_b
