"""The CUDA path: graphs replay exactly what the eager update does, a run trained on a GPU
evaluates on a CPU, and asking for CUDA where there is none is one clear line. The GPU tests
skip on machines without CUDA (CI)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from adaptsky.scenario import parse_scenario
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.helpers.gpu import assert_graphs_replay_eager, cuda
from tests.helpers.training import checkpoint_policy, small_scenario, stack_scenario


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has CUDA")
def test_device_cuda_without_cuda_is_one_line(tmp_path, capsys):
    code = main(["train", str(small_scenario(tmp_path)), "--device", "cuda",
                 "--out", str(tmp_path / "x.h5")])
    err = capsys.readouterr().err
    assert code == 1 and "--device cuda" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "x.h5").exists()


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has CUDA")
def test_reproduce_on_cuda_without_cuda_is_one_line(tmp_path, capsys):
    code = main(["reproduce", "e1a", "--device", "cuda", "--out", str(tmp_path / "e1a")])
    err = capsys.readouterr().err
    assert code == 1 and "--device cuda" in err and "Traceback" not in err
    assert not (tmp_path / "e1a").exists()


def test_unknown_device_is_one_line(tmp_path, capsys):
    code = main(["train", str(small_scenario(tmp_path)), "--device", "tpu",
                 "--out", str(tmp_path / "x.h5")])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and "cpu, cuda" in err  # a usage error


@cuda
def test_graphs_replay_the_eager_update_exactly():
    assert_graphs_replay_eager(stack_scenario())


@cuda
def test_a_gpu_member_starts_as_the_cpu_member():
    """One update on the GPU and on the CPU agree to float32 rounding (not bit for bit:
    cuBLAS and MKL sum in different orders)."""
    base = stack_scenario()
    gpu = StackRun([Member(base, seed) for seed in range(8)], "cuda")
    cpu = StackRun([Member(base, 3)], "cpu")
    gpu.run_episode()
    cpu.run_episode()
    np.testing.assert_allclose(gpu.algorithm.agent.params[3].cpu().numpy(),
                               cpu.algorithm.agent.params[0].numpy(), atol=1e-3)


@cuda
def test_train_on_cuda_resume_and_evaluate_on_cpu(tmp_path):
    scenario_path = small_scenario(tmp_path)
    path, outcome = api.train(scenario_path=scenario_path, out=tmp_path / "gpu.h5",
                              seeds=[0, 1, 2], episodes=4, device="cuda", quiet=True)
    assert not outcome.interrupted
    api.resume(run_path=path, episodes=6, device="cuda", quiet=True)
    with RunReader(path) as run:
        checkpoint = run.checkpoint(1)
        config = run.config
        assert run.seed_attrs(1)["episodes_done"] == 6
    assert checkpoint["device"].startswith("cuda")
    policy = checkpoint_policy(parse_scenario(config), checkpoint)
    actions = policy(np.zeros((2, 17), dtype=np.float32))
    assert actions.shape == (2,)
