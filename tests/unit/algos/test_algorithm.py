"""The algorithm plug-in point: ``[agent] algorithm`` as a tagged union, the registry, and the
trainer, the evaluation and the run-file validator going through the Algorithm protocol; the
Q-network's one forward pass on torch, numpy and the torch module alike."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import torch

from adaptsky.algos import registry
from adaptsky.algos.dqn.forward import head_output
from adaptsky.algos.dqn.learner import DqnLearner
from adaptsky.algos.dqn.network import QNetwork
from adaptsky.algos.dqn.spec import DQN, DqnSpec
from adaptsky.algos.dqn.stacked import StackedDqn
from adaptsky.algos.protocol import Algorithm
from adaptsky.errors import ScenarioError
from adaptsky.scenario import parse_scenario
from adaptsky.scenario.agents import AGENT_MODELS, DqnAgent
from adaptsky.store.layout import validate_run
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import make_scenario
from tests.helpers.training import checkpoint_policy

TINY = {"agent": {"hidden_sizes": [8], "batch_size": 4, "memory_size": 40},
        "train": {"steps": 6, "episodes": 2, "eval_every": 0}}


def test_a_scenario_without_algorithm_is_a_dqn_and_says_so():
    scenario = make_scenario(name="x")
    assert scenario.agent.algorithm == "dqn" and isinstance(scenario.agent, DqnAgent)
    assert scenario.model_dump()["agent"]["algorithm"] == "dqn"
    assert registry.algorithm_of(scenario) is DQN
    explicit = parse_scenario({"name": "x", "agent": {"algorithm": "dqn", "preset": "tuned"}})
    assert explicit.agent.double_dqn is True  # the preset still applies under a tag


@pytest.mark.parametrize(("agent", "line"), [
    ({"algorithm": "a2c"},
     "s.toml: agent.algorithm: unknown algorithm 'a2c'; choose from dqn, bdq, ppo, sac, "
     "mappo, ippo"),
    ({"algorithm": 3},
     "s.toml: agent.algorithm: unknown algorithm 3; choose from dqn, bdq, ppo, sac, mappo, "
     "ippo"),
    ({"lr": "fast"}, "s.toml: agent.lr: Input should be a valid number (got 'fast')"),
    ({"algorithm": "dqn", "gamma": 2.0}, "s.toml: agent.gamma: Input should be less than or "
                                         "equal to 1 (got 2.0)"),
])
def test_agent_errors_name_the_key_without_the_union_tag(agent, line):
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "x", "agent": agent}, "s.toml")
    assert str(error.value) == line


def test_validate_refuses_an_unknown_algorithm_in_one_line(tmp_path: Path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\n[agent]\nalgorithm = "a2c"\n')
    assert main(["scenario", "validate", str(path)]) == 1
    printed = capsys.readouterr()
    lines = (printed.out + printed.err).strip().splitlines()
    assert lines == [f"{path}: agent.algorithm: unknown algorithm 'a2c'; choose from dqn, "
                     "bdq, ppo, sac, mappo, ippo"]


def test_every_agent_model_has_its_algorithm_and_back():
    """The [agent] models (scenario layer) and the algorithms (algos layer) name the same set."""
    assert set(AGENT_MODELS) == set(registry.ALGORITHMS)
    for name, spec in registry.ALGORITHMS.items():
        assert spec.name == name


def test_unknown_algorithm_lookup_names_the_known_ones():
    with pytest.raises(KeyError, match="choose from dqn, bdq, ppo, sac, mappo, ippo"):
        registry.algorithm_named("a2c")


def test_the_dqn_learner_has_every_method_of_the_protocol():
    wanted = {name for name in dir(Algorithm) if not name.startswith("_")}
    assert wanted <= set(dir(DqnLearner)) | {"size", "epsilon"}


class Recording(DqnSpec):
    """The DQN with every call of the protocol recorded: what goes through it."""

    def __init__(self) -> None:
        self.calls: list[str] = []

    def build(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        self.calls.append("build")
        learner = super().build(*args, **kwargs)
        calls = self.calls

        class Spy:
            def __getattr__(self, name: str):  # type: ignore[no-untyped-def]
                calls.append(name)
                return getattr(learner, name)
        return Spy()

    def check_checkpoint(self, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        self.calls.append("check_checkpoint")
        super().check_checkpoint(*args, **kwargs)

    def greedy_policy(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        self.calls.append("greedy_policy")
        return super().greedy_policy(*args, **kwargs)


def test_training_validation_and_evaluation_go_through_the_registry(monkeypatch, tmp_path):
    spy = Recording()
    monkeypatch.setitem(registry.ALGORITHMS, "dqn", spy)
    scenario = make_scenario(name="spy", **TINY)
    run = StackRun([Member(scenario, 3)])
    for _ in range(2):
        run.run_episode()
    assert {"build", "begin_episode", "act", "observe", "end_episode",
            "take_mean_loss"} <= set(spy.calls)
    checkpoint = run.checkpoint(0)
    assert set(checkpoint) >= {"agent", "replay", "rng", "episode"}
    assert "checkpoint" in spy.calls
    policy = checkpoint_policy(scenario, checkpoint)
    assert "greedy_policy" in spy.calls
    observations = np.zeros((3, run.algorithm.agent.observation_size), dtype=np.float32)
    assert policy(observations).shape == (3,)


def test_the_validator_delegates_the_checkpoint_to_the_algorithm(monkeypatch, tiny_run):
    spy = Recording()
    monkeypatch.setitem(registry.ALGORITHMS, "dqn", spy)
    with h5py.File(tiny_run) as file:
        validate_run(file, tiny_run)
    assert spy.calls.count("check_checkpoint") == 2  # one checkpoint per seed (0 and 1)


# ---- one forward pass ----------------------------------------------------------------------

@pytest.mark.parametrize("dueling", [True, False])
def test_one_forward_pass_gives_one_q_on_torch_numpy_and_the_module(dueling):
    config = DqnAgent(hidden_sizes=[16, 8], dueling=dueling)
    agent = StackedDqn(config, 5, 6, seeds=[4])  # QNetwork's weights under manual_seed(4)
    torch.manual_seed(4)
    net = QNetwork(5, 6, [16, 8], dueling)
    observations = torch.randn(1, 9, 5)
    stacked = agent.q_values(observations)[0]
    module = net(observations[0]).detach()
    torch.testing.assert_close(stacked, module, atol=1e-5, rtol=1e-5)
    # the numpy pass on the host chooses the argmax of those Q values
    assert np.array_equal(agent.greedy(observations.numpy()), stacked.argmax(-1)[None].numpy())


def test_head_output_by_hand():
    """Two inputs through a 2-2-1 network written out: relu(x W1 + b1) W2 + b2."""
    w1, b1 = np.array([[1.0, -1.0], [2.0, 0.5]]), np.array([0.0, -1.0])
    w2, b2 = np.array([[3.0], [-2.0]]), np.array([0.25])
    x = np.array([[1.0, 1.0], [-1.0, 0.0]])
    # row 1: hidden [3, -1.5] -> relu [3, 0] -> 9.25; row 2: [-1, 0] -> [0, 0] -> 0.25
    out = head_output([(w1, b1), (w2, b2)], x, lambda v, w, b: v @ w + b,
                      lambda v: np.maximum(v, 0.0))
    assert out.ravel().tolist() == [9.25, 0.25]
