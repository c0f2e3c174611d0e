"""The branching dueling Q-network (BDQ): its forward pass, greedy action and TD update against
plain loops written from its formulas (docs/agent.md, "BDQ"), identical numbers for the same
seed, resume to more episodes bit for bit, a damaged checkpoint refused in one line,
learning on the training layout, and the CUDA path (skipped without CUDA). A seed alone and in
a stack, kill -9 and resume: tests/contract/test_learners.py."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import torch

from adaptsky.algos import registry
from adaptsky.algos.bdq.learner import BdqLearner
from adaptsky.algos.bdq.spec import BDQ
from adaptsky.algos.bdq.stacked import StackedBdq
from adaptsky.algos.protocol import Algorithm
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.agents import BdqAgent
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.actions import ActionSet
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.helpers.gpu import assert_graphs_replay_eager
from tests.helpers.training import (
    assert_same_curves,
    checkpoint_policy,
    curves,
    greedy_over_random,
    small_scenario,
    stack_scenario,
)

BDQ_AGENT = {"algorithm": "bdq"}
cuda = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")


def _relu(x: list[float]) -> list[float]:
    return [max(v, 0.0) for v in x]


def _affine(weight: np.ndarray, bias: np.ndarray, x: list[float]) -> list[float]:
    """W x + b with (out, in) weights, one output at a time in float64."""
    return [float(bias[i]) + sum(float(weight[i, j]) * x[j] for j in range(len(x)))
            for i in range(len(bias))]


def plain_q(weights: dict[str, np.ndarray], observation: np.ndarray, branches: int,
            sub_actions: int, groups: int = 1) -> list[list[float]]:
    """Q_d(s, a_d) = V_g(s) + A_d(s, a_d) - mean_a' A_d(s, a') by loops, [d][a_d], g the
    group of branch d (one group: V(s); else the branches in ``groups`` equal runs)."""
    x = [float(v) for v in observation]
    layer = 0
    while f"torso.{2 * layer}.weight" in weights:
        x = _relu(_affine(weights[f"torso.{2 * layer}.weight"],
                          weights[f"torso.{2 * layer}.bias"], x))
        layer += 1
    values = _affine(weights["value.weight"], weights["value.bias"], x)
    assert len(values) == groups
    advantage = _affine(weights["advantage.weight"], weights["advantage.bias"], x)
    q = []
    for d in range(branches):
        branch = advantage[d * sub_actions:(d + 1) * sub_actions]
        mean = sum(branch) / sub_actions
        value = values[d // (branches // groups)]
        q.append([value + a - mean for a in branch])
    return q


def _argmax(values: list[float]) -> int:
    return max(range(len(values)), key=lambda index: (values[index], -index))


def _agent(mode: str = "paper", seeds: tuple[int, ...] = (0, 1), uavs: int = 1,
           **keys: object) -> tuple[StackedBdq, ActionSet]:
    """2 clusters per UAV, 5 branches each; with ``uavs`` > 1 a value per UAV."""
    split = {"reward_split": "per-uav"} if uavs > 1 else {}
    config = BdqAgent(**{"algorithm": "bdq", "hidden_sizes": [8, 6], **split, **keys})
    actions = ActionSet(2, mode, uavs)
    return StackedBdq(config, 9, actions, list(seeds)), actions


@pytest.mark.parametrize(("mode", "uavs"), [("paper", 1), ("with-hover", 1), ("paper", 2)])
def test_forward_pass_and_greedy_action_follow_the_formula(mode, uavs):
    agent, actions = _agent(mode, uavs=uavs)
    branches = 5 * uavs
    observations = np.random.default_rng(1).normal(size=(2, 5, 9)).astype(np.float32)
    q = agent.q_values(torch.from_numpy(observations)).numpy()
    assert q.shape == (2, 5, branches * actions.base)
    greedy_host = agent.greedy(observations)
    greedy_torch = agent.device_greedy(torch.from_numpy(observations)).numpy()
    for member in range(2):
        weights = agent.policy_arrays(member)
        assert weights["value.weight"].shape == (uavs, 6)
        for row in range(5):
            expected = plain_q(weights, observations[member, row], branches, actions.base,
                               uavs)
            np.testing.assert_allclose(q[member, row], np.concatenate(expected), rtol=1e-5,
                                       atol=1e-6)
            digits = [_argmax(branch) for branch in expected]
            dense = sum(digit * actions.base**d for d, digit in enumerate(digits))
            assert greedy_host[member, row] == dense == greedy_torch[member, row]
            assert list(actions.decode(dense)) == [
                2 * a - 1 if mode == "paper" else a - 1 for a in digits]


@pytest.mark.parametrize(("loss", "uavs"), [("mse", 1), ("huber", 1), ("mse", 2), ("huber", 3)])
def test_td_update_follows_the_shared_double_target_and_the_branch_mean_loss(loss, uavs):
    """One UAV (or ``reward_split = "team"``): one target for every branch; per UAV: UAV
    u's branches bootstrap from their own mean and learn from r_u."""
    gamma = 0.9
    agent, actions = _agent(gamma=gamma, loss=loss, uavs=uavs)
    other, _ = _agent(seeds=(7, 8), uavs=uavs)
    agent.target.copy_(other.params)  # a target network unlike the policy network
    rng = np.random.default_rng(2)
    batch, branches, base = 4, 5 * uavs, actions.base
    per_uav = branches // uavs
    observations = rng.normal(size=(2, batch, 9)).astype(np.float32)
    next_observations = rng.normal(size=(2, batch, 9)).astype(np.float32)
    chosen = rng.integers(base, size=(2, batch, branches))
    rewards = rng.normal(size=(2, batch, uavs)).astype(np.float32)
    not_terminal = np.array([[1, 0, 1, 1], [1, 1, 1, 0]], dtype=np.float32)
    policies = [agent.policy_arrays(member) for member in range(2)]
    targets = [agent.state_from_row(agent.target[member].numpy()) for member in range(2)]

    def target(member: int, i: int, u: int) -> float:
        """y_u = r_u + gamma (1/D_u) sum_{d of u} Q^-_d(s', argmax_a' Q_d(s', a')), by
        loops."""
        online_next = plain_q(policies[member], next_observations[member, i], branches, base,
                              uavs)
        target_next = plain_q(targets[member], next_observations[member, i], branches, base,
                              uavs)
        mine = range(u * per_uav, (u + 1) * per_uav)
        bootstrap = sum(target_next[d][_argmax(online_next[d])] for d in mine) / per_uav
        return (float(rewards[member, i, u])
                + gamma * float(not_terminal[member, i]) * bootstrap)

    expected_loss = []
    for member in range(2):
        total = 0.0
        for i in range(batch):
            q = plain_q(policies[member], observations[member, i], branches, base, uavs)
            for d in range(branches):
                error = target(member, i, d // per_uav) - q[d][chosen[member, i, d]]
                total += error**2 if loss == "mse" else (
                    0.5 * error**2 if abs(error) < 1 else abs(error) - 0.5)
        expected_loss.append(total / (batch * branches))

    agent.update(torch.from_numpy(observations), torch.from_numpy(chosen),
                 torch.from_numpy(rewards[..., 0] if uavs == 1 else rewards),
                 torch.from_numpy(next_observations), torch.from_numpy(not_terminal))
    np.testing.assert_allclose(agent.loss_sum.numpy(), expected_loss, rtol=1e-5)

    # the gradient of that loss by autograd through the same loops, the target held fixed
    for member in range(2):
        params = {name: torch.tensor(value, dtype=torch.float64, requires_grad=True)
                  for name, value in policies[member].items()}
        total = torch.zeros((), dtype=torch.float64)
        for i in range(batch):
            x = torch.from_numpy(observations[member, i]).double()
            layer = 0
            while f"torso.{2 * layer}.weight" in params:
                x = torch.relu(params[f"torso.{2 * layer}.weight"] @ x
                               + params[f"torso.{2 * layer}.bias"])
                layer += 1
            value = params["value.weight"] @ x + params["value.bias"]
            advantage = params["advantage.weight"] @ x + params["advantage.bias"]
            for d in range(branches):
                branch = advantage[d * base:(d + 1) * base]
                error = target(member, i, d // per_uav) - (
                    value[d // per_uav] + branch[chosen[member, i, d]] - branch.mean())
                total = total + (error**2 if loss == "mse" else torch.nn.functional.huber_loss(
                    error, torch.zeros_like(error), delta=1.0))
        (total / (batch * branches)).backward()
        grads = agent.state_from_row(agent.grads[member].numpy())
        for name, param in params.items():
            np.testing.assert_allclose(grads[name], param.grad.numpy(), rtol=1e-4,
                                       atol=1e-6, err_msg=name)


def test_replay_stores_a_sub_action_per_branch():
    agent, actions = _agent()
    dense = np.array([0, 31, 6])
    stored = agent.stored_actions(dense)
    assert stored.shape == (3, 5)
    assert np.array_equal(actions.encode(2 * stored - 1), dense)


def test_replay_keeps_the_reward_of_every_uav_apart():
    """Rows [s | s' | r_1 .. r_G | 1 - terminated | a_1 .. a_D]: what goes in comes out, in
    a batch, in a checkpoint's arrays and after loading them."""
    from adaptsky.algos.replay import StackedReplay

    memory = StackedReplay(2, 4, 3, torch.device("cpu"), action_width=5, reward_width=2)
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(3):
        row = (rng.normal(size=(2, 3)).astype(np.float32), rng.integers(2, size=(2, 5)),
               rng.normal(size=(2, 2)).astype(np.float32),
               rng.normal(size=(2, 3)).astype(np.float32), rng.random(2) < 0.5)
        memory.add(*row)
        rows.append(row)
    batch = memory.gather(torch.tensor([[2, 0], [1, 1]]))
    for member, index in ((0, 2), (0, 0), (1, 1)):
        at = [2, 0].index(index) if member == 0 else 0
        obs, actions, rewards, next_obs, terminated = rows[index]
        assert np.array_equal(batch.observations[member, at], obs[member])
        assert np.array_equal(batch.actions[member, at], actions[member])
        assert np.array_equal(batch.rewards[member, at], rewards[member])
        assert np.array_equal(batch.next_observations[member, at], next_obs[member])
        assert batch.not_terminal[member, at] == (not terminated[member])
    arrays = memory.arrays(1)
    assert arrays["rewards"].shape == (3, 2) and arrays["actions"].shape == (3, 5)
    assert np.array_equal(arrays["rewards"], np.stack([row[2][1] for row in rows]))
    other = StackedReplay(2, 4, 3, torch.device("cpu"), action_width=5, reward_width=2)
    other.load(1, arrays, memory.position)
    for name, value in other.arrays(1).items():
        assert np.array_equal(value, arrays[name]), name


def test_bdq_is_an_algorithm_with_its_own_keys():
    scenario = parse_scenario({"name": "x", "agent": BDQ_AGENT})
    assert isinstance(scenario.agent, BdqAgent) and registry.algorithm_of(scenario) is BDQ
    assert scenario.agent.gamma == 0.999 and scenario.agent.hidden_sizes == [128, 128]
    wanted = {name for name in dir(Algorithm) if not name.startswith("_")}
    assert wanted <= set(dir(BdqLearner)) | {"size", "epsilon"}
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "x", "agent": {**BDQ_AGENT, "dueling": False}}, "s.toml")
    assert str(error.value) == "s.toml: agent.dueling: unknown key"
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "x", "agent": {**BDQ_AGENT, "batchsize": 4}}, "s.toml")
    assert str(error.value) == "s.toml: agent.batchsize: unknown key; did you mean 'batch_size'?"


def test_a_preset_gives_the_keys_bdq_has_under_the_keys_given():
    tuned = parse_scenario({"name": "x", "agent": {**BDQ_AGENT, "preset": "tuned",
                                                   "epsilon_end": 0.05}}).agent
    assert (tuned.epsilon_end, tuned.epsilon_decay_steps, tuned.lr_end, tuned.user_order) == (
        0.05, 30_000.0, 1e-4, "clusters")
    paper = parse_scenario({"name": "x", "agent": BDQ_AGENT}).agent
    assert (paper.preset, paper.epsilon_end, paper.epsilon_decay_steps, paper.lr_end) == (
        "paper", 0.1, 200.0, None)
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "x", "agent": {**BDQ_AGENT, "preset": "fast"}}, "s.toml")
    assert str(error.value) == "s.toml: agent: unknown preset 'fast'; choose from paper, tuned"


def _bdq_scenario(tmp_path: Path, name: str = "bdq", train: dict | None = None,
                  **agent: object) -> Path:
    """The DQN's small training scenario (tests/unit/training/test_train.py) with a BDQ of the
    same sizes; ``train`` updates its ``[train]``."""
    path = small_scenario(tmp_path, name)
    data = load_scenario(path).model_dump(mode="json")
    data["agent"] = {"algorithm": "bdq", **{key: data["agent"][key] for key in (
        "hidden_sizes", "batch_size", "memory_size", "target_update_episodes")}, **agent}
    data["train"] |= train or {}
    path.write_text(dumps(data))
    return path


def test_same_seed_same_numbers_and_resume_equals_the_uninterrupted_run(tmp_path):
    # greedy evaluations every episode keep a best policy, which must resume as well
    scenario_path = _bdq_scenario(tmp_path, train={"eval_every": 1, "eval_steps": 100})
    args = {"scenario_path": scenario_path, "seeds": [0, 1], "workers": 1, "quiet": True}
    first, _ = api.train(out=tmp_path / "a.h5", episodes=4, **args)
    second, _ = api.train(out=tmp_path / "b.h5", episodes=4, **args)
    assert_same_curves(curves(first), curves(second))
    resumed, _ = api.train(out=tmp_path / "r.h5", episodes=2, **args)
    # one stack of both seeds, as before: training does not depend on the stack, but the
    # greedy evaluations' rates may differ in the last bit between stacks of 2 and of 1
    assert main(["train", "--resume", str(resumed), "--episodes", "4", "--workers", "1",
                 "--quiet"]) == 0
    assert_same_curves(curves(resumed), curves(first))
    with RunReader(first) as a, RunReader(resumed) as b:
        for seed in (0, 1):
            for name, value in a.checkpoint(seed)["agent"]["policy"].items():
                assert np.array_equal(value, b.checkpoint(seed)["agent"]["policy"][name])
            evaluations = a.evaluations(seed)
            assert list(evaluations["episode"]) == [1, 2, 3, 4]
            for name, value in evaluations.items():
                assert np.array_equal(value, b.evaluations(seed)[name], equal_nan=True), name
            best_a, best_b = a.best(seed), b.best(seed)
            assert best_a is not None and best_b is not None
            assert best_a["episode"] == best_b["episode"]
            for name, value in best_a["policy"].items():
                assert np.array_equal(value, best_b["policy"][name])
    assert main(["inspect", str(first)]) == 0
    eval_out = tmp_path / "eval.h5"
    assert main(["eval", "--checkpoint", str(first), "--steps", "5", "--compare", "random",
                 "--policy", "best", "--out", str(eval_out)]) == 0 and eval_out.exists()


@pytest.fixture(scope="module")
def bdq_run(tmp_path_factory) -> Path:
    tmp_path = tmp_path_factory.mktemp("bdq_run")
    path, _ = api.train(scenario_path=_bdq_scenario(tmp_path), out=tmp_path / "run.h5",
                        seeds=[0], episodes=3, workers=1, quiet=True)
    return path


@pytest.mark.parametrize(("damage", "message"), [
    (lambda f: f["seeds/0/checkpoint/replay/actions"].attrs, None),  # undamaged: opens
    (lambda f: f.__delitem__("seeds/0/checkpoint/replay/actions") or f.create_dataset(
        "seeds/0/checkpoint/replay/actions", data=np.zeros(300, dtype=np.int64)),
     "/seeds/0/checkpoint/replay/actions: shape (300,) (expected (300, 5)"),
    (lambda f: f.__delitem__("seeds/0/checkpoint/agent/target/advantage.bias") or
     f.create_dataset("seeds/0/checkpoint/agent/target/advantage.bias",
                      data=np.zeros(32, dtype=np.float32)),
     "/seeds/0/checkpoint/agent/target/advantage.bias: shape (32,) (expected (10,)"),
])
def test_a_damaged_bdq_checkpoint_is_refused_in_one_line(bdq_run, tmp_path, capsys, damage,
                                                         message):
    path = tmp_path / "damaged.h5"
    shutil.copyfile(bdq_run, path)
    with h5py.File(path, "a") as f:
        damage(f)
    code = main(["inspect", str(path)])
    err = capsys.readouterr().err.strip()
    if message is None:
        assert code == 0 and not err
        return
    assert code == 1 and len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith(f"{path}: ") and message in err, err


def test_learning_beats_random_on_the_training_layout(tmp_path):
    # 24 episodes x 100 steps, gamma 0.8, rewards scaled by 0.01 (about 9 s): measured greedy /
    # random sum rate on the training layout 1.40, 1.39, 1.36, 1.18, 1.38, 1.26 for seeds 0-5
    scenario_path = _bdq_scenario(tmp_path, hidden_sizes=[64, 64], batch_size=64,
                                  memory_size=5000, gamma=0.8, lr=1e-3, reward_scale=0.01)
    assert greedy_over_random(scenario_path, tmp_path / "learn.h5", episodes=24) > 1.15


@cuda
def test_graphs_replay_the_eager_update_exactly_and_cuda_runs_evaluate_on_a_cpu(tmp_path):
    assert_graphs_replay_eager(stack_scenario(agent=BDQ_AGENT))
    path, _ = api.train(scenario_path=_bdq_scenario(tmp_path), out=tmp_path / "gpu.h5",
                        seeds=[0, 1], episodes=4, device="cuda", quiet=True)
    api.resume(run_path=path, episodes=6, device="cuda", quiet=True)
    with RunReader(path) as run:
        checkpoint, config = run.checkpoint(1), run.config
    assert checkpoint["device"].startswith("cuda")
    policy = checkpoint_policy(parse_scenario(config), checkpoint)
    assert policy(np.zeros((2, 17), dtype=np.float32)).shape == (2,)
