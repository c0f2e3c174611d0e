"""Training throughput against its floor, for the paper's configuration.

Times a few episodes of algorithm 1 (one environment step, one action choice and one gradient
update per step) and, in the same process, the floor: the same number of bare Adam updates of
the same network on random batches. Prints both and their ratio (training time / floor time).

    .venv/bin/python benchmarks/train_throughput.py [--scenario FILE] [--episodes 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from rich.console import Console
from rich.table import Table

from adaptsky_cli.agent.replay import Batch
from adaptsky_cli.scenario import load_scenario
from adaptsky_cli.train.runner import pin_threads
from adaptsky_cli.train.seed_run import SeedRun


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/nyc_mmwave.toml")
    parser.add_argument("--episodes", type=int, default=3, help="timed episodes")
    args = parser.parse_args()
    pin_threads()
    scenario = load_scenario(args.scenario)
    run = SeedRun(scenario, seed=0)
    # warm up: fill the memory past one batch so every timed step makes an update
    while len(run.memory) < scenario.agent.batch_size:
        run.run_episode()
    steps = args.episodes * scenario.train.steps
    start = time.perf_counter()
    for _ in range(args.episodes):
        run.run_episode()
    train_s = time.perf_counter() - start

    rng = np.random.default_rng(0)
    size, batch = run.memory.observations.shape[1], scenario.agent.batch_size
    batches = [Batch(rng.normal(size=(batch, size)).astype(np.float32),
                     rng.integers(0, run.env.actions.count, batch),
                     rng.normal(size=batch).astype(np.float32),
                     rng.normal(size=(batch, size)).astype(np.float32),
                     np.zeros(batch, dtype=bool)) for _ in range(64)]
    start = time.perf_counter()
    for i in range(steps):
        run.agent.update(batches[i % len(batches)])
    floor_s = time.perf_counter() - start

    table = Table("", "steps", "seconds", "steps/s", "updates/s",
                  title=f"{scenario.name}: hidden {scenario.agent.hidden_sizes}, batch {batch}, "
                        f"torch {torch.__version__}, {torch.get_num_threads()} thread")
    table.add_row("training (env + act + update)", str(steps), f"{train_s:.2f}",
                  f"{steps / train_s:,.0f}", f"{steps / train_s:,.0f}")
    table.add_row("floor (bare Adam updates)", str(steps), f"{floor_s:.2f}", "-",
                  f"{steps / floor_s:,.0f}")
    Console().print(table)
    print(f"ratio training / floor: {train_s / floor_s:.3f}")


if __name__ == "__main__":
    main()
