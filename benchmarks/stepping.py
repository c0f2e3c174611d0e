"""What the step benchmarks share (one_simulator.py, fading_step.py, city_step.py): one BLAS
and one torch thread, and random dense steps of a batch of environments, calibrated."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

CALIBRATION_S = 0.2      # CPU seconds of stepping that size a timed block


def pin_one_thread() -> None:
    """One BLAS and one torch thread (threadpoolctl: environment variables set after numpy
    is imported have no effect)."""
    import torch
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    torch.set_num_threads(1)


def random_steps(env: Any, num_envs: int) -> tuple[Callable[[int], None], float]:
    """``step(count)``: ``count`` steps of ``env`` (``num_envs`` environments, reset here)
    with random dense actions (64 drawn from seed 0, in turn), warmed up by five steps; and
    its steps per CPU second over about ``CALIBRATION_S``."""
    import numpy as np

    env.reset()
    actions = np.random.default_rng(0).integers(0, env.actions.count, size=(64, num_envs))

    def step(count: int) -> None:
        for index in range(count):
            env.step(actions[index % len(actions)])

    step(5)
    count, start = 0, time.process_time()
    while (elapsed := time.process_time() - start) < CALIBRATION_S:
        step(1)
        count += 1
    return step, count / elapsed
