"""PPO (docs/agent.md): GAE against hand-computed numbers, its distributions against torch's,
its Adam against torch.optim.Adam, its curves, greedy = the mode, and the scenario's refusals
(what every learner does, on every head: tests/contract/test_learners.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from adaptsky.algos.on_policy import gae
from adaptsky.algos.ppo.stacked import StackedActorCritic
from adaptsky.algos.registry import check_actions
from adaptsky.algos.shared.heads import ActionHead
from adaptsky.algos.shared.shapes import HeadShape
from adaptsky.errors import ScenarioError
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.conftest import make_scenario
from tests.helpers.learners import (
    ppo_scenario,
)

# ---- GAE --------------------------------------------------------------------------------


def test_gae_equals_the_hand_computed_recursion():
    """T = 3, gamma 0.5, lambda 0.8: deltas 1 + 0.5*3 - 2 = 0.5, 0 + 0.5*1 - 3 = -2.5,
    2 + 0.5*4 - 1 = 3 (V(s_3) = 4, the truncation bootstrapped); A_2 = 3,
    A_1 = -2.5 + 0.4*3 = -1.3, A_0 = 0.5 + 0.4*(-1.3) = -0.02."""
    rewards = np.array([[1.0], [0.0], [2.0]])
    values = np.array([[2.0], [3.0], [1.0]])
    advantages, returns = gae(rewards, values, np.array([4.0]), 0.5, 0.8)
    assert advantages[:, 0] == pytest.approx([-0.02, -1.3, 3.0], abs=1e-12)
    assert returns[:, 0] == pytest.approx([1.98, 1.7, 4.0], abs=1e-12)


# ---- distributions ----------------------------------------------------------------------


def test_dense_and_branch_log_probabilities_and_entropies_are_torch_categoricals():
    torch.manual_seed(0)
    dense = ActionHead(HeadShape("dense", 8))
    out = torch.randn(2, 5, 8)
    actions = torch.randint(0, 8, (2, 5))
    log_prob, entropy = dense.log_prob_entropy(out, None, actions)
    reference = torch.distributions.Categorical(logits=out)
    assert torch.allclose(log_prob, reference.log_prob(actions), atol=1e-6)
    assert torch.allclose(entropy, reference.entropy(), atol=1e-6)
    branches = ActionHead(HeadShape("branches", 6, branches=(3, 3)))
    out = torch.randn(2, 5, 6)
    actions = torch.randint(0, 3, (2, 5, 2))
    log_prob, entropy = branches.log_prob_entropy(out, None, actions)
    parts = [torch.distributions.Categorical(logits=out[..., 3 * j:3 * j + 3])
             for j in range(2)]
    assert torch.allclose(log_prob, sum(p.log_prob(actions[..., j])
                                        for j, p in enumerate(parts)), atol=1e-6)
    assert torch.allclose(entropy, sum(p.entropy() for p in parts), atol=1e-6)


def test_gaussian_log_probability_and_entropy_are_torch_normals():
    torch.manual_seed(1)
    head = ActionHead(HeadShape("gaussian", 3, components=3))
    mean, log_std = torch.randn(2, 4, 3), torch.randn(2, 1, 3) * 0.3
    actions = torch.randn(2, 4, 3)
    log_prob, entropy = head.log_prob_entropy(mean, log_std, actions)
    normal = torch.distributions.Normal(mean, log_std.exp())
    assert torch.allclose(log_prob, normal.log_prob(actions).sum(-1), atol=1e-5)
    assert torch.allclose(entropy, normal.entropy().sum(-1), atol=1e-5)


def test_samples_follow_the_distribution_and_the_branches_encode_the_dense_index():
    """20,000 draws per member (fixed seeds 0 and 1): every probability within 0.01 (about
    three standard errors, 0.0035 at p = 0.4); a branch choice is its component's digit of
    the dense index."""
    logits = np.log(np.array([[[0.1, 0.2, 0.3, 0.4]]] * 2, dtype=np.float32))
    logits = np.repeat(logits, 20_000, axis=1)
    head = ActionHead(HeadShape("dense", 4))
    drawn = head.sample(logits, None, [np.random.default_rng(0), np.random.default_rng(1)])
    for member in drawn:
        share = np.bincount(member, minlength=4) / len(member)
        assert share == pytest.approx([0.1, 0.2, 0.3, 0.4], abs=0.01)
    branches = ActionHead(HeadShape("branches", 6, branches=(2, 2, 2)))
    assert branches.env_actions(np.array([[1, 0, 1], [0, 1, 1]])).tolist() == [5, 6]
    gaussian = ActionHead(HeadShape("gaussian", 2, components=2))
    assert gaussian.env_actions(np.array([[1.7, -0.2]])).tolist() == [[1.0, -0.2]]
    assert gaussian.mode(np.array([[0.3, -0.2]], np.float32))[0] == \
        pytest.approx([0.3, -0.2])


# ---- Adam ---------------------------------------------------------------------------------


def test_adam_and_the_clip_are_torch_s_for_each_member():
    """Three steps of our Adam with a global-norm clip of 0.5 equal torch.optim.Adam (eps
    1e-5) after torch.nn.utils.clip_grad_norm_, member by member."""
    net = StackedActorCritic(5, [8], HeadShape("dense", 4), seeds=[3, 4])
    reference = [net.params.detach()[m, :net.used].clone().requires_grad_(True)
                 for m in range(2)]
    optimizers = [torch.optim.Adam([p], lr=1e-2, eps=1e-5) for p in reference]
    rng = np.random.default_rng(0)
    for _ in range(3):
        grad = torch.from_numpy(rng.normal(size=(2, net.used)).astype(np.float32))
        net.params.grad = torch.zeros_like(net.params)
        net.params.grad[:, :net.used] = grad
        net.apply_gradients(1e-2, 0.5)
        for member, (param, optimizer) in enumerate(zip(reference, optimizers, strict=True)):
            param.grad = grad[member].clone()
            torch.nn.utils.clip_grad_norm_([param], 0.5)
            optimizer.step()
    for member, param in enumerate(reference):
        assert torch.allclose(net.params.detach()[member, :net.used], param.detach(),
                              atol=1e-6)


# ---- training ---------------------------------------------------------------------------


def test_greedy_evaluation_takes_the_mode(tmp_path, capsys):
    """eval's greedy policy of a Gaussian PPO is its clipped mean: two evaluations agree, and
    its actions are the head's mean for the observation. Its curves have no epsilon, and an
    entropy and a loss every episode; its actions are floats, one per component. (A seed
    alone and in a stack, and kill -9 and resume: tests/contract/test_learners.py.)"""
    path = ppo_scenario(tmp_path, episodes=3, uav={"actions": "continuous"})
    run, _ = api.train(scenario_path=path, out=tmp_path / "g.h5", seeds=[0], workers=1,
                       quiet=True)
    with RunReader(run) as reader:
        curves, action = reader.episodes(0), reader.trajectory(0)["action"]
    assert np.isnan(curves["epsilon"]).all() and np.isfinite(curves["entropy"]).all()
    assert np.isfinite(curves["loss"]).all()
    assert action.shape == (30, 5) and action.dtype.kind == "f"
    from adaptsky.evaluation.api import read_trained
    from adaptsky.rollouts.rollout import greedy_policy
    trained = read_trained(run, 0, "last")
    policy = greedy_policy(trained.scenario, trained.policy)
    obs = np.random.default_rng(0).normal(size=(3, 17)).astype(np.float32)
    net = StackedActorCritic(17, [16, 16], HeadShape("gaussian", 5, components=5), [0])
    net.load_policy(0, trained.policy)
    with torch.no_grad():
        mean = net.actor(torch.from_numpy(obs)[None])[0].numpy()
    assert np.allclose(policy(obs), np.clip(mean, -1, 1), atol=1e-6)
    assert main(["eval", "--checkpoint", str(run), "--steps", "120", "--compare", "",
                 "--out", str(tmp_path / "e.h5")]) == 0


# ---- refusals ---------------------------------------------------------------------------


@pytest.mark.parametrize(("agent", "uav", "says"), [
    ({"algorithm": "ppo", "action_head": "gaussian"}, {},
     "agent.action_head: 'gaussian' does not fit uav.actions = 'paper'"),
    ({"algorithm": "ppo", "action_head": "branches"}, {"actions": "continuous"},
     "agent.action_head: 'branches' does not fit uav.actions = 'continuous'"),
    ({"algorithm": "dqn"}, {"actions": "continuous"},
     "agent.algorithm 'dqn' learns 'paper' or 'with-hover' actions, not 'continuous'; for "
     "'continuous' choose agent.algorithm 'ppo'"),
])
def test_heads_that_do_not_fit_the_actions_are_refused_in_one_line(agent, uav, says):
    scenario = make_scenario(agent=agent, uav=uav)
    with pytest.raises(ScenarioError) as error:
        check_actions(scenario, "s.toml")
    assert says in str(error.value) and len(str(error.value).splitlines()) == 1


def test_rewards_are_divided_by_the_running_deviation_of_the_return():
    """One member, two rows, gamma 0.5: returns (1, 3), then (0.5 + 2, 1.5 + 0) = (2.5, 1.5);
    the running statistics start at mean 0, variance 1, count 1e-4 and take each step's rows
    by the parallel update (a plain scalar version here); a reward beyond 10 deviations is
    clipped."""
    from adaptsky.algos.on_policy import RewardNormaliser

    norm = RewardNormaliser(1, 2, gamma=0.5)
    mean, var, count = 0.0, 1.0, 1e-4
    for rewards, returns in (([1.0, 3.0], [1.0, 3.0]), ([2.0, 0.0], [2.5, 1.5])):
        got = norm(np.array([rewards]))
        batch_mean = sum(returns) / 2
        batch_var = sum((g - batch_mean) ** 2 for g in returns) / 2
        delta, total = batch_mean - mean, count + 2
        mean = mean + delta * 2 / total
        var = (var * count + batch_var * 2 + delta**2 * count * 2 / total) / total
        count = total
        assert got[0] == pytest.approx([r / (var + 1e-8) ** 0.5 for r in rewards], rel=1e-12)
    state = norm.state(0)
    other = RewardNormaliser(1, 2, gamma=0.5)
    other.load(0, state)
    assert (other.mean, other.var, other.count) == (norm.mean, norm.var, norm.count)
    calm = RewardNormaliser(1, 2, gamma=0.5)   # 1000 steps of 0: variance about 1e-7
    for _ in range(1000):
        calm(np.zeros((1, 2)))
    assert calm(np.array([[1.0, -1.0]])).tolist() == [[10.0, -10.0]]
