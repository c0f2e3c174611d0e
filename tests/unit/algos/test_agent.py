"""Agent pieces: dueling head, stacked replay, epsilon schedule, the hand-written TD update
(checked against torch autograd and torch.optim.Adam), stacks, state round trip."""

import math

import numpy as np
import pytest
import torch

from adaptsky.algos.dqn.network import QNetwork
from adaptsky.algos.dqn.stacked import StackedDqn
from adaptsky.algos.replay import StackedReplay
from adaptsky.algos.schedule import epsilon
from adaptsky.scenario.agents import DqnAgent as Agent

CPU = torch.device("cpu")


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


def _add(memory, i, members=1, terminated=False):
    obs = np.full((members, memory.obs_size), i, dtype=np.float32)
    memory.add(obs, np.full(members, i), np.full(members, float(i)), obs + 1,
               np.full(members, terminated))


def test_replay_memory_overwrites_oldest_and_keeps_terminated():
    memory = StackedReplay(1, capacity=3, observation_size=2, device=CPU)
    for i in range(5):
        _add(memory, i, terminated=(i == 4))
    assert memory.size == 3 and memory.position == 2
    assert sorted(memory.arrays(0)["actions"].tolist()) == [2, 3, 4]
    index = memory.sample_index(50, [np.random.default_rng(0)])
    batch = memory.gather(torch.from_numpy(index))
    assert batch.observations.dtype == torch.float32 and batch.actions.dtype == torch.int64
    actions = batch.actions[0].numpy()
    assert set(actions.tolist()) == {2, 3, 4}
    assert np.all(batch.not_terminal[0].numpy() == (actions != 4))
    assert np.all(batch.next_observations[0, :, 0].numpy() == actions + 1)
    assert np.all(batch.rewards[0].numpy() == actions)


def test_replay_members_are_apart_and_round_trip_keeps_storage_order():
    memory = StackedReplay(2, 4, 1, CPU)
    for i in range(6):
        memory.add(np.array([[i], [10 + i]], np.float32), np.array([i, 10 + i]),
                   np.zeros(2), np.zeros((2, 1), np.float32), np.zeros(2, bool))
    assert sorted(memory.arrays(1)["actions"].tolist()) == [12, 13, 14, 15]
    copy = StackedReplay(2, 4, 1, CPU)
    for member in range(2):
        copy.load(member, memory.arrays(member), memory.position)
    for store in (memory, copy):
        store.add(np.array([[9], [19]], np.float32), np.array([9, 19]), np.zeros(2),
                  np.zeros((2, 1), np.float32), np.zeros(2, bool))
    assert torch.equal(memory.rows, copy.rows)
    index = torch.tensor([[0, 3], [1, 2]])
    assert memory.gather(index).actions.tolist() == [[4, 3], [15, 19]]  # slots: 4 5 9 3


def test_epsilon_schedule_of_algorithm_1():
    assert epsilon(0, 0.9, 0.1, 200) == pytest.approx(0.9)
    assert epsilon(200, 0.9, 0.1, 200) == pytest.approx(0.1 + 0.8 / math.e)
    assert epsilon(10**6, 0.9, 0.1, 200) == pytest.approx(0.1)


def _batch(rng, members=1, n=32, size=3, actions=4):
    def normal(*shape):
        return torch.from_numpy(rng.normal(size=shape).astype(np.float32))
    return (normal(members, n, size), torch.from_numpy(rng.integers(0, actions, (members, n))),
            normal(members, n), normal(members, n, size), torch.ones(members, n))


@pytest.mark.parametrize("options", [{}, {"dueling": False}, {"double_dqn": True},
                                     {"loss": "huber"}, {"grad_clip_norm": 0.5}])
def test_hand_written_update_equals_autograd_and_torch_adam(options):
    """Five steps of member 1 of a stack of 2 against QNetwork + autograd + torch.optim.Adam."""
    config = Agent(hidden_sizes=[16, 8], gamma=0.9, lr=1e-2, **options)
    agent = StackedDqn(config, 3, 5, seeds=[7, 8])
    torch.manual_seed(8)
    net = QNetwork(3, 5, [16, 8], config.dueling)
    target = QNetwork(3, 5, [16, 8], config.dueling)
    target.load_state_dict(net.state_dict())
    optimizer = torch.optim.Adam(net.parameters(), lr=1e-2)
    loss_fn = torch.nn.MSELoss() if config.loss == "mse" else torch.nn.SmoothL1Loss()
    rng = np.random.default_rng(0)
    losses = []
    for _ in range(5):
        obs, act, rew, next_obs, not_terminal = _batch(rng, members=2, actions=5)
        q = net(obs[1]).gather(1, act[1][:, None]).squeeze(1)
        with torch.no_grad():
            next_q = target(next_obs[1])
            if config.double_dqn:
                next_v = next_q.gather(1, net(next_obs[1]).argmax(1, keepdim=True)).squeeze(1)
            else:
                next_v = next_q.max(dim=1).values
        loss = loss_fn(q, rew[1] + 0.9 * next_v)
        optimizer.zero_grad()
        loss.backward()
        if config.grad_clip_norm:
            torch.nn.utils.clip_grad_norm_(net.parameters(), config.grad_clip_norm)
        optimizer.step()
        losses.append(loss.item())
        agent.update(obs, act, rew, next_obs, not_terminal)
    mine = agent.state_arrays(1)
    for name, value in net.state_dict().items():
        np.testing.assert_allclose(mine["policy"][name], value.numpy(), atol=2e-6)
    state = optimizer.state_dict()["state"]
    for index in range(len(mine["policy"])):
        np.testing.assert_allclose(mine["optimizer"]["state"][str(index)]["exp_avg"],
                                   state[index]["exp_avg"].numpy(), atol=1e-6)
    assert agent.loss_sum[1].item() / len(losses) == pytest.approx(np.mean(losses), rel=1e-5)


def test_td_target_by_hand_with_terminal_and_gamma():
    config = Agent(hidden_sizes=[4], gamma=0.5, lr=1e-3)
    agent = StackedDqn(config, 3, 2, seeds=[0])
    obs, act, rew, next_obs, _ = _batch(np.random.default_rng(0), n=2, actions=2)
    not_terminal = torch.tensor([[1.0, 0.0]])
    policy, target = agent.state_arrays(0)["policy"], agent.state_arrays(0)["target"]

    def q_of(weights, x):  # plain numpy forward of the dueling network
        h = np.maximum(x @ weights["torso.0.weight"].T + weights["torso.0.bias"], 0)
        v = h @ weights["value.weight"].T + weights["value.bias"]
        a = h @ weights["advantage.weight"].T + weights["advantage.bias"]
        return v + a - a.mean(axis=1, keepdims=True)

    q = q_of(policy, obs[0].numpy())[np.arange(2), act[0].numpy()]
    y = rew[0].numpy() + 0.5 * np.array([1.0, 0.0]) * q_of(target, next_obs[0].numpy()).max(1)
    agent.update(obs, act, rew, next_obs, not_terminal)
    assert agent.loss_sum[0].item() == pytest.approx(np.mean((q - y) ** 2), rel=1e-5)


def test_updates_fit_a_fixed_batch():
    agent = StackedDqn(Agent(hidden_sizes=[32], gamma=0.0, lr=1e-2), 3, 4, seeds=[0])
    batch = _batch(np.random.default_rng(1))
    losses = []
    for _ in range(201):
        agent.update(*batch)
        losses.append(agent.loss_sum[0].item())
        agent.loss_sum.zero_()
    assert losses[-1] < 0.05 * losses[0]


def test_a_member_does_not_depend_on_its_stack():
    """Member 2 of a stack of 4 and the same seed alone: the same weights, bit for bit."""
    config = Agent(hidden_sizes=[32, 16])
    stack = StackedDqn(config, 3, 4, seeds=[5, 6, 7, 8])
    alone = StackedDqn(config, 3, 4, seeds=[7])
    rng = np.random.default_rng(4)
    observations = rng.normal(size=(4, 1, 3)).astype(np.float32)
    for step in range(20):
        batch = _batch(rng, members=4)
        stack.update(*batch)
        alone.update(*(tensor[2:3] for tensor in batch))
        if step % 7 == 0:
            stack.sync_target()
            alone.sync_target()
        assert stack.greedy(observations)[2] == alone.greedy(observations[2:3])[0]
    assert torch.equal(stack.params[2], alone.params[0])
    assert torch.equal(stack.exp_avg_sq[2], alone.exp_avg_sq[0])


def test_agent_state_round_trip_continues_identically():
    config = Agent(hidden_sizes=[16])
    rng = np.random.default_rng(3)
    batches = [_batch(rng) for _ in range(6)]
    agent = StackedDqn(config, 3, 4, seeds=[5])
    for batch in batches[:3]:
        agent.update(*batch)
    clone = StackedDqn(config, 3, 4, seeds=[99])
    clone.load_state_arrays(0, agent.state_arrays(0))
    agent.loss_sum.zero_()
    for batch in batches[3:]:
        agent.update(*batch)
        clone.update(*batch)
    assert torch.equal(agent.params, clone.params) and torch.equal(agent.target, clone.target)
    assert torch.equal(agent.loss_sum, clone.loss_sum)


@pytest.mark.parametrize("dueling", [True, False])
def test_the_one_list_of_parameter_names_is_torch_s(dueling):
    # the names and shapes were written in three places (the network, the stacked trainer,
    # the run-file layout); now one function, checked against torch's own names here
    from adaptsky.algos.dqn.parameters import network_shapes

    torch_shapes = [(name, tuple(parameter.shape))
                    for name, parameter in QNetwork(17, 30, [64, 32], dueling).named_parameters()]
    assert list(network_shapes(17, 30, [64, 32], dueling).items()) == torch_shapes
