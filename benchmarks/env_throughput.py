"""Environment throughput: batched steps per second at B = 1, 64 and 1024 (one process, one
thread), with user-steps per second (B x N per batched step).

    .venv/bin/python benchmarks/env_throughput.py [--scenario FILE] [--seconds S]
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

from adaptsky.scenario import load_scenario  # noqa: E402
from adaptsky.sim.network import NetworkBatch  # noqa: E402


def measure(scenario, num_envs: int, seconds: float) -> float:
    """Batched steps per second, best of three timed blocks of about ``seconds`` / 3 each."""
    env = NetworkBatch(scenario, num_envs=num_envs, seed=0)
    env.reset()
    actions = np.random.default_rng(0).integers(0, env.actions.count, size=(256, num_envs))
    for a in actions[:20]:  # warm up
        env.step(a)
    best = 0.0
    for _ in range(3):
        count, start = 0, time.perf_counter()
        while (elapsed := time.perf_counter() - start) < seconds / 3:
            env.step(actions[count % len(actions)])
            count += 1
        best = max(best, count / elapsed)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/nyc_mmwave.toml")
    parser.add_argument("--seconds", type=float, default=3.0, help="time per batch size")
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    # the time limit never ends a benchmark episode
    scenario = scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"steps": 10**9})})
    table = Table("B", "batched steps/s", "env steps/s", "user-steps/s", "vs B=1",
                  title=f"{scenario.name}: {scenario.num_users} users, "
                        f"{scenario.channel.model}, LoS {scenario.channel.los}")
    base = None
    for num_envs in (1, 64, 1024):
        rate = measure(scenario, num_envs, args.seconds)
        env_steps = rate * num_envs
        base = base or env_steps
        table.add_row(str(num_envs), f"{rate:,.0f}", f"{env_steps:,.0f}",
                      f"{env_steps * scenario.num_users:,.0f}", f"{env_steps / base:.1f}x")
    Console().print(table)


if __name__ == "__main__":
    main()
