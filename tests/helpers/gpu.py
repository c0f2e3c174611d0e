"""The CUDA checks of the training tests: a mark that skips without a device, and the
CUDA-graph update against the eager one. Apart from tests/helpers/training.py so that a module
importing only those helpers does not import torch (a spawned child imports its test module)."""

from __future__ import annotations

import pytest
import torch

from adaptsky.training.stack_run import Member, StackRun
from tests.helpers.training import assert_same_results

cuda = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")


def assert_graphs_replay_eager(base: object, episodes: int = 3) -> None:
    """Four seeds of ``base`` on the GPU: the CUDA-graph update equals the eager one."""
    members = [Member(base, seed) for seed in range(4)]
    graphed = StackRun(members, "cuda", graphs=True)
    eager = StackRun(members, "cuda", graphs=False)
    for _ in range(episodes):
        for a, b in zip(graphed.run_episode(), eager.run_episode(), strict=True):
            assert_same_results(a, b)
    assert torch.equal(graphed.algorithm.agent.params, eager.algorithm.agent.params)
