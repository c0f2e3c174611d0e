"""The two learner families and what they share: every registered learner is an off-policy
or an on-policy one, the protocol holds only what every learner does, the trainer imports no
agent's config, the loss means, and the one stacked-parameter mechanism's two Adam kernels
against torch's own Adam."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
import torch

from adaptsky.algos.off_policy import OffPolicyLearner, RunningMeans
from adaptsky.algos.on_policy import OnPolicyLearner
from adaptsky.algos.protocol import Algorithm, EpsilonGreedy
from adaptsky.algos.registry import ALGORITHMS
from adaptsky.algos.shared.stacked import StackedParameters
from adaptsky.training.stack_run import Member, StackRun
from tests.conftest import make_scenario

ROOT = Path(__file__).resolve().parents[3]
FAMILIES = {"dqn": OffPolicyLearner, "bdq": OffPolicyLearner, "sac": OffPolicyLearner,
            "ppo": OnPolicyLearner, "mappo": OnPolicyLearner, "ippo": OnPolicyLearner}
SETTINGS = {
    "dqn": {},
    "bdq": {"uav": {"count": 2}},
    "sac": {"uav": {"actions": "continuous"}, "agent": {"learning_starts": 3}},
    "ppo": {"agent": {"envs_per_seed": 2, "minibatches": 2, "epochs": 1}},
    "mappo": {"uav": {"count": 2}, "agent": {"envs_per_seed": 2, "minibatches": 2}},
    "ippo": {"uav": {"count": 2}, "agent": {"envs_per_seed": 2, "minibatches": 2}},
}


def _learner(name: str) -> StackRun:
    settings = SETTINGS[name]
    agent = {"algorithm": name, "hidden_sizes": [8], **settings.get("agent", {})}
    if FAMILIES[name] is OffPolicyLearner:
        agent |= {"batch_size": 4, "memory_size": 40}
    scenario = make_scenario(name=name, agent=agent, uav=settings.get("uav", {}),
                             train={"steps": 6, "episodes": 2, "eval_every": 0})
    return StackRun([Member(scenario, 3)])


def test_every_registered_learner_has_a_family():
    assert set(FAMILIES) == set(ALGORITHMS)


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_each_learner_is_of_its_family_and_only_the_dqns_explore_epsilon_greedily(name):
    run = _learner(name)
    learner = run.algorithm
    assert isinstance(learner, FAMILIES[name])
    assert isinstance(learner, EpsilonGreedy) == (name in ("dqn", "bdq"))
    assert not hasattr(learner, "update")  # the off-policy family updates in observe
    results = [run.run_episode()[0] for _ in range(2)]
    losses = [result.metrics["loss"] for result in results]
    # off-policy: the memory holds a batch of 4 within the first episode; on-policy: every
    # episode ends with an update
    assert np.isfinite(losses).all(), losses
    epsilon = results[-1].metrics["epsilon"]
    assert np.isfinite(epsilon) == (name in ("dqn", "bdq"))


def test_the_protocol_holds_only_what_every_learner_does():
    members = {name for name in vars(Algorithm) if not name.startswith("_")}
    assert {"update", "epsilon"}.isdisjoint(members)
    assert {"act", "observe", "end_episode", "checkpoint", "restore"} <= members


def test_the_trainer_imports_no_agent_config_and_no_learner():
    """The training package reaches learners through the registry and the protocol only."""
    for path in (ROOT / "adaptsky" / "training").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert node.module != "adaptsky.scenario.agents", path.name
                assert node.module in ("adaptsky.algos.registry", "adaptsky.algos.protocol",
                                       "adaptsky.algos.device_step") \
                    or not node.module.startswith("adaptsky.algos"), (path.name, node.module)


def test_running_means_per_member_since_taken():
    means = RunningMeans(2, torch.device("cpu"))
    assert means.take("loss") is None
    means.add("loss", torch.tensor([1.0, 4.0]))
    means.add("loss", torch.tensor([2.0, 8.0]))
    assert means.take("loss").tolist() == [1.5, 6.0]
    assert means.take("loss") is None
    outside = torch.zeros(2, dtype=torch.float64)
    means.buffer("td", outside)
    outside += torch.tensor([3.0, 5.0], dtype=torch.float64)  # an update adds in place
    means.added("td")
    assert means.take("td").tolist() == [3.0, 5.0] and outside.tolist() == [0.0, 0.0]


@pytest.mark.parametrize("fused", [False, True])
def test_one_adam_two_kernels_against_torch_s(fused):
    """Both kernels step as ``torch.optim.Adam`` (fused: its fused kernel; written out: its
    arithmetic), each member alone, ``clip_grad_norm_`` included (to rounding: the clip sums
    the squares in another order)."""
    rng = np.random.default_rng(0)
    shapes = {"w": (3, 5), "b": (3,)}
    rows = [{"w": rng.normal(size=(3, 5)), "b": rng.normal(size=3)} for _ in range(2)]
    stack = StackedParameters(shapes, rows, 1e-5, fused=fused)
    for member, named in enumerate(rows):
        params = [torch.tensor(named[k], dtype=torch.float32, requires_grad=True)
                  for k in ("w", "b")]
        optimizer = torch.optim.Adam(params, lr=0.01, eps=1e-5, fused=fused or None)
        grads = [rng.normal(size=(4, *shape)).astype(np.float32) for shape in shapes.values()]
        for step in range(4):
            for param, grad in zip(params, grads, strict=True):
                param.grad = torch.tensor(grad[step] * 10.0)
            torch.nn.utils.clip_grad_norm_(params, 1.0)
            optimizer.step()
        mine = StackedParameters(shapes, [rows[member]], 1e-5, fused=fused)
        for step in range(4):
            grad = torch.zeros_like(mine.params)
            grad[0, :mine.used] = torch.from_numpy(mine.row_from_named(
                {k: g[step] * 10.0 for k, g in zip(shapes, grads, strict=True)}))
            if fused:
                mine.apply_fused(grad, 0.01, 1.0)
            else:
                mine.params.grad = grad
                mine.apply_gradients(0.01, 1.0)
        got = mine.named(0)
        for name, param in zip(shapes, params, strict=True):
            torch.testing.assert_close(torch.from_numpy(got[name]), param.detach(),
                                       rtol=0, atol=1e-6)
        assert mine.steps() == 4 and stack.steps() == 0
