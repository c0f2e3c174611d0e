"""SAC (docs/agent.md): its squashed log-probability against a hand-written formula and torch's
transformed distribution, its Adam against torch.optim.Adam, its curves and replay, greedy =
tanh(mean), a damaged checkpoint refused, and the scenario's refusal of dense actions (what
every learner does: tests/contract/test_learners.py)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import torch

from adaptsky.algos.protocol import Algorithm
from adaptsky.algos.registry import check_actions
from adaptsky.algos.sac.learner import SacLearner
from adaptsky.algos.sac.parameters import LOG_STD_MAX, LOG_STD_MIN
from adaptsky.algos.sac.stacked import StackedSac, squashed
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS, make_scenario

# updates from step 41 of episode 2; the memory of 200 rows wraps in episode 7
SAC = {"algorithm": "sac", "hidden_sizes": [16, 16], "batch_size": 20, "memory_size": 200,
       "learning_starts": 40}


def sac_scenario(tmp_path: Path, name: str = "sac", episodes: int = 12) -> Path:
    """nyc_mmwave on continuous controls with a small SAC: episodes of 30 steps, checkpoints
    and greedy evaluations every 3."""
    data = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
    data["name"] = name
    data["agent"] = dict(SAC)
    data["uav"]["actions"] = "continuous"
    data["train"] |= {"episodes": episodes, "steps": 30, "checkpoint_every": 3,
                      "eval_every": 3, "eval_steps": 40}
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(data))
    return path


# ---- the squashed Gaussian --------------------------------------------------------------


def _inputs(dtype: torch.dtype) -> tuple[torch.Tensor, torch.Tensor]:
    """Actor outputs (2, 4, 2 D) and noise (2, 4, D), D = 3: means in [-0.3, 0.3], log std
    before squashing in [-0.5, 0] (sigma at most 0.22), noise in [-2, 2], so |x| <= 0.75 and
    1 - tanh(x)^2 >= 0.59: CleanRL's 1e-6 moves log pi by at most 5e-6."""
    generator = torch.Generator().manual_seed(0)
    mean = torch.rand(2, 4, 3, generator=generator, dtype=dtype) * 0.6 - 0.3
    raw = -0.5 * torch.rand(2, 4, 3, generator=generator, dtype=dtype)
    noise = torch.randn(2, 4, 3, generator=generator, dtype=dtype).clamp(-2, 2)
    return torch.cat([mean, raw], dim=-1), noise


def test_the_squashed_log_probability_is_the_formula_and_torch_s_tanh_normal():
    out, noise = _inputs(torch.float32)
    actions, log_pi = squashed(out, noise)
    for s in range(2):
        for i in range(4):
            total = 0.0
            for j in range(3):
                mean, raw, z = (float(out[s, i, j]), float(out[s, i, 3 + j]),
                                float(noise[s, i, j]))
                log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (math.tanh(raw) + 1)
                action = math.tanh(mean + math.exp(log_std) * z)
                assert float(actions[s, i, j]) == pytest.approx(action, abs=1e-6)
                total += (-0.5 * z * z - log_std - 0.5 * math.log(2 * math.pi)
                          - math.log(1 - action * action + 1e-6))
            assert float(log_pi[s, i]) == pytest.approx(total, abs=1e-5)
    out, noise = _inputs(torch.float64)
    actions, log_pi = squashed(out, noise)
    log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (torch.tanh(out[..., 3:]) + 1)
    reference = torch.distributions.TransformedDistribution(
        torch.distributions.Normal(out[..., :3], log_std.exp()),
        [torch.distributions.TanhTransform()])
    assert torch.allclose(log_pi, reference.log_prob(actions).sum(-1), atol=1e-5, rtol=0)


# ---- Adam ---------------------------------------------------------------------------------


def test_adam_is_torch_s_for_each_member():
    """Three steps of our Adam (no clip, eps 1e-8) equal torch.optim.Adam's defaults, member
    by member, on the Q networks and on the temperature."""
    net = StackedSac(5, [8], 2, seeds=[3, 4])
    rng = np.random.default_rng(0)
    for params, lr in ((net.critics, 1e-3), (net.temperature, 3e-4)):
        reference = [params.params.detach()[m, :params.used].clone().requires_grad_(True)
                     for m in range(2)]
        optimizers = [torch.optim.Adam([p], lr=lr) for p in reference]
        for _ in range(3):
            grad = torch.from_numpy(rng.normal(size=(2, params.used)).astype(np.float32))
            params.params.grad = torch.zeros_like(params.params)
            params.params.grad[:, :params.used] = grad
            params.apply_gradients(lr)
            for member, (param, optimizer) in enumerate(zip(reference, optimizers,
                                                            strict=True)):
                param.grad = grad[member].clone()
                optimizer.step()
        for member, param in enumerate(reference):
            assert torch.allclose(params.params.detach()[member, :params.used],
                                  param.detach(), atol=1e-6)


# ---- training ---------------------------------------------------------------------------


def test_the_learner_has_every_method_of_the_protocol():
    wanted = {name for name in dir(Algorithm) if not name.startswith("_")}
    assert wanted <= set(dir(SacLearner)) | {"size", "epsilon"}


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Seed 0 of :func:`sac_scenario` trained for 3 episodes (read only: copy to damage)."""
    folder = tmp_path_factory.mktemp("sac_run")
    run, _ = api.train(scenario_path=sac_scenario(folder, episodes=3), out=folder / "g.h5",
                       seeds=[0], workers=1, quiet=True)
    return run


def test_the_curves_and_the_replay_of_a_run(sac_run):
    """No update in episode 1 (learning starts after step 40), one every episode after; no
    epsilon; the replay keeps float actions within [-1, 1], none terminal. (A seed alone and
    in a stack, a replay that wraps, kill -9 and resume: tests/contract/test_learners.py.)"""
    with RunReader(sac_run) as run:
        curves, replay = run.episodes(0), run.checkpoint(0)["replay"]
    assert np.isnan(curves["epsilon"]).all()
    assert np.isnan(curves["loss"][0]) and np.isfinite(curves["loss"][1:]).all()
    assert np.isnan(curves["entropy"][0]) and np.isfinite(curves["entropy"][1:]).all()
    assert replay["actions"].shape == (90, 5) and replay["actions"].dtype == np.float32
    assert np.abs(replay["actions"]).max() <= 1 and not replay["terminated"].any()


def test_greedy_evaluation_takes_tanh_of_the_mean(sac_run, tmp_path):
    """eval's greedy policy is tanh of the actor's mean: the stored actor, read into a
    torch.nn.Sequential by its torch names, gives the same actions; eval runs."""
    run = sac_run
    from adaptsky.evaluation.api import read_trained
    from adaptsky.rollouts.rollout import greedy_policy
    trained = read_trained(run, 0, "last")
    policy = greedy_policy(trained.scenario, trained.policy)
    actor = torch.nn.Sequential(torch.nn.Linear(17, 16), torch.nn.ReLU(),
                                torch.nn.Linear(16, 16), torch.nn.ReLU(),
                                torch.nn.Linear(16, 10))
    actor.load_state_dict({name.removeprefix("actor."): torch.from_numpy(value)
                           for name, value in trained.policy.items()})
    obs = np.random.default_rng(0).normal(size=(3, 17)).astype(np.float32)
    with torch.no_grad():
        mean = actor(torch.from_numpy(obs))[:, :5].numpy()
    assert np.allclose(policy(obs), np.tanh(mean), atol=1e-6)
    assert main(["eval", "--checkpoint", str(run), "--steps", "120", "--compare", "",
                 "--out", str(tmp_path / "e.h5")]) == 0


def test_a_damaged_replay_is_refused_naming_it(sac_run, tmp_path):
    run = Path(shutil.copyfile(sac_run, tmp_path / "d.h5"))
    with h5py.File(run, "r+") as f:
        replay = f["seeds/0/checkpoint/replay"]
        del replay["actions"]
        replay["actions"] = np.zeros((90, 4), dtype=np.float32)
    with pytest.raises(RunFileError, match=r"replay/actions: shape \(90, 4\)"), \
            RunReader(run) as reader:
        reader.checkpoint(0)


# ---- refusals ---------------------------------------------------------------------------


def test_dense_actions_are_refused_in_one_line_naming_their_learners():
    scenario = make_scenario(agent={"algorithm": "sac"})
    with pytest.raises(ScenarioError) as error:
        check_actions(scenario, "s.toml")
    assert str(error.value) == ("s.toml: uav.actions: agent.algorithm 'sac' learns "
                                "'continuous' actions, not 'paper'; for 'paper' choose "
                                "agent.algorithm 'dqn', 'bdq', 'ppo'")
    check_actions(make_scenario(agent={"algorithm": "sac"}, uav={"actions": "continuous"}),
                  "s.toml")
