"""The set encoder (``agent.network = "set"``; docs/agent.md, "The set encoder"): PPO's actor
and critic read each user's features through one shared network, pooled by mean and max, so
listing the users in another order leaves what they output as it is (to float rounding of the
mean), where an MLP's changes; the numpy greedy path computes what torch does; the encoder's
parameters are named and checked in run files; its keys are refused where they mean nothing."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from adaptsky.algos.ppo.spec import head_of
from adaptsky.algos.ppo.stacked import StackedActorCritic
from adaptsky.algos.shared.set_layout import set_encoder_of
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.envs.observations import AgentView
from adaptsky.scenario import load_scenario
from adaptsky.scenario.variants import with_values
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SCENARIOS
from tests.helpers.cli import refusal_of_scenario


def ppo(network: str, **agent):
    scenario = load_scenario(SCENARIOS / "nyc_mmwave_any_layout.toml")
    return with_values(scenario, "agent", {"algorithm": "ppo", "network": network, **agent},
                       "test", replace=True)


def nets(scenario):
    return StackedActorCritic(observation_size_of(scenario), scenario.agent.hidden_sizes,
                              head_of(scenario), [0, 1], scenario.agent.activation,
                              encoder=set_encoder_of(scenario))


def observations(scenario, count=5):
    env = NetworkBatch(scenario, num_envs=count, seed=0, view=AgentView.of(scenario),
                       users_m=NetworkBatch(scenario, num_envs=count, seed=3).layouts_m)
    obs, _ = env.reset()
    return obs


@pytest.mark.parametrize("network", ["set", "mlp"])
def test_the_users_order_leaves_the_set_encoders_outputs(network):
    scenario = ppo(network)
    net = nets(scenario)
    obs = observations(scenario)                             # (5, 4 N + 1)
    num_users = scenario.num_users
    permutation = np.random.default_rng(0).permutation(num_users)
    assert (permutation != np.arange(num_users)).any()
    per_user = obs[:, :4 * num_users].reshape(len(obs), num_users, 4)
    permuted = obs.copy()
    permuted[:, :4 * num_users] = per_user[:, permutation].reshape(len(obs), -1)
    x = torch.from_numpy(np.stack([obs, obs]))
    y = torch.from_numpy(np.stack([permuted, permuted]))
    with torch.no_grad():
        same = [torch.allclose(f(x), f(y), rtol=1e-5, atol=1e-6) for f in (net.actor, net.critic)]
    assert same == ([True, True] if network == "set" else [False, False])


def test_numpy_greedy_path_is_torchs():
    scenario = ppo("set", set_sizes=[32, 16])
    net = nets(scenario)
    obs = np.stack([observations(scenario)] * 2)
    with torch.no_grad():
        device = net.actor(torch.from_numpy(obs)).numpy()
    np.testing.assert_allclose(net.host_actor(obs), device, rtol=1e-5, atol=1e-6)
    assert {"actor_set.0.weight", "actor_set.2.weight"} <= set(net.policy_names)
    assert net.slots["actor_set.2.weight"].shape == (16, 32)
    encoder = set_encoder_of(scenario)
    assert encoder.width == 2 * 16 + 1 and net.slots["actor.0.weight"].shape[1] == 33


@pytest.mark.parametrize("body, words", [
    ('[agent]\nalgorithm = "ppo"\nset_sizes = [32]', "agent.set_sizes given with "
                                                       "agent.network = 'mlp'"),
    ('[uav]\ncount = 2\n[agent]\nalgorithm = "mappo"\nnetwork = "set"',
     "agent.network: 'set' is not built for 'mappo' yet"),
])
def test_refusals_are_one_line(tmp_path, capsys, body, words):
    assert words in refusal_of_scenario(tmp_path, capsys, body)


def test_sacs_actor_and_q_networks_read_the_set_alike_in_any_order():
    """SAC's actor and both Q networks, each through its own set encoder: the users' order
    leaves them (to rounding); the numpy greedy path is torch's; the checkpoint's Q groups
    carry their encoders."""
    from adaptsky.algos.sac.stacked import StackedSac, host_greedy

    scenario = with_values(ppo("set"), "agent", {"algorithm": "sac", "network": "set",
                                                 "set_sizes": [32]}, "test", replace=True)
    scenario = with_values(scenario, "uav", {"actions": "continuous"}, "test")
    encoder = set_encoder_of(scenario)
    net = StackedSac(observation_size_of(scenario), scenario.agent.hidden_sizes, 3, [0, 1],
                     encoder=encoder)
    obs = observations(scenario)
    num_users = scenario.num_users
    permuted = obs.copy()
    per_user = obs[:, :4 * num_users].reshape(len(obs), num_users, 4)
    permuted[:, :4 * num_users] = per_user[:, ::-1].reshape(len(obs), -1)
    x, y = (torch.from_numpy(np.stack([o, o])) for o in (obs, permuted))
    actions = torch.zeros(2, len(obs), 3)
    with torch.no_grad():
        assert torch.allclose(net.greedy(x), net.greedy(y), rtol=1e-5, atol=1e-6)
        assert torch.allclose(net.min_q(x, actions), net.min_q(y, actions), rtol=1e-5,
                              atol=1e-5)
        device = net.greedy(x).numpy()
    np.testing.assert_allclose(host_greedy(net.actor, np.stack([obs, obs]), 3, encoder),
                               device, rtol=1e-5, atol=1e-6)
    state = net.state_arrays(0)
    assert {"q1_set.0.weight", "q1.0.weight"} <= set(state["q1"])
    assert {"q2_set.0.weight", "q2.0.weight"} <= set(state["q2_target"])


def test_the_dqns_written_out_backward_through_the_set_encoder_is_autograds():
    """The DQN's TD gradient of eq. 12, written out by hand through the torso, the pooling
    (the mean's share to every user, the maximum's to its user) and the users' shared
    layers, equals torch's autograd through ``QNetwork`` with the same weights and batch."""
    from adaptsky.algos.dqn.network import QNetwork
    from adaptsky.algos.dqn.stacked import SetKept, StackedDqn
    from adaptsky.sim.actions import ActionSet

    scenario = with_values(load_scenario(SCENARIOS / "nyc_mmwave_any_layout.toml"), "agent",
                           {"network": "set", "set_sizes": [16, 8]}, "test")
    encoder, obs_size = set_encoder_of(scenario), observation_size_of(scenario)
    actions = ActionSet.of(scenario).count
    agent = StackedDqn(scenario.agent, obs_size, actions, [3], encoder=encoder)
    rng = np.random.default_rng(0)
    batch = 12
    obs = torch.from_numpy(rng.normal(size=(1, batch, obs_size)).astype(np.float32))
    chosen = torch.from_numpy(rng.integers(actions, size=(1, batch, 1)))
    target = torch.from_numpy(rng.normal(size=(1, batch)).astype(np.float32))
    with torch.no_grad():
        inputs: list[torch.Tensor] = []
        agent._set_kept = kept = SetKept()
        q = agent._forward(agent._policy, obs, inputs, agent._policy_set, kept)
        d_chosen = agent._loss_gradient(q.gather(-1, chosen).squeeze(-1) - target)
        agent._backward(inputs, agent._d_head(chosen, d_chosen.unsqueeze(-1)))
    written = agent.grads[0, :agent.net.used].numpy()

    net = QNetwork(obs_size, actions, scenario.agent.hidden_sizes, True, 1, encoder)
    net.load_state_dict({name: torch.from_numpy(array) for name, array
                         in agent.policy_arrays(0).items()})
    q_auto = net(obs[0])
    loss = (q_auto.gather(-1, chosen[0]).squeeze(-1) - target[0]).square().mean()
    loss.backward()
    autograd = agent.row_from_state({name: parameter.grad.numpy()
                                     for name, parameter in net.named_parameters()})
    assert np.abs(autograd).max() > 0
    np.testing.assert_allclose(written, autograd, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(q.numpy()[0], q_auto.detach().numpy(), rtol=1e-5, atol=1e-6)
    # the encoder's own parameters learn (their gradient is not 0)
    named = agent.state_from_row(written)
    assert np.abs(named["set.0.weight"]).max() > 0 and np.abs(named["set.2.weight"]).max() > 0


def test_the_target_network_reads_through_the_targets_encoder():
    """Q^- of eq. 12 is the target's whole network, its set encoder included: changing only
    the target's encoder changes the target's Q values and not the policy's."""
    from adaptsky.algos.dqn.stacked import StackedDqn
    from adaptsky.sim.actions import ActionSet

    scenario = with_values(load_scenario(SCENARIOS / "nyc_mmwave_any_layout.toml"), "agent",
                           {"network": "set"}, "test")
    encoder, obs_size = set_encoder_of(scenario), observation_size_of(scenario)
    agent = StackedDqn(scenario.agent, obs_size, ActionSet.of(scenario).count, [0],
                       encoder=encoder)
    obs = torch.from_numpy(np.stack([observations(scenario)]))
    with torch.no_grad():
        policy_q = agent._forward(agent._policy, obs)
        assert torch.equal(agent._forward(agent._target, obs), policy_q)   # a copy at first
    # the numpy greedy path (through the encoder's numpy form) acts as torch's Q values say
    np.testing.assert_array_equal(agent.greedy(obs.numpy()), policy_q.argmax(dim=-1).numpy())
    with torch.no_grad():
        agent._target_set[0][0].mul_(0.5)                # the target's first shared layer
        assert not torch.equal(agent._forward(agent._target, obs), policy_q)
        assert torch.equal(agent._forward(agent._policy, obs), policy_q)
