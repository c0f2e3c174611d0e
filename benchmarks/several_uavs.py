"""Speed of several UAVs against one (issue 23; docs/model.md §9), on one CPU thread.

(a) Links stepped per second (B x U x N per second) at B = 1024 environments: U = 4, N = 16
    must reach those of U = 1, N = 4, both on :class:`~adaptsky.sim.network.NetworkBatch`:
    the cost of a link does not grow with the
    number of UAVs. Best of eight timed blocks per scenario, the two scenarios alternated.
(b) Training seed-steps per second of a stack of S seeds (:class:`StackRun`, as training runs
    them): BDQ at U = 4 must reach half of the dense DQN's at U = 1 (the one-UAV scenario with
    ``agent.algorithm = "dqn"``). Whole episodes after a warm-up (so every timed step makes an
    update), the two stacks alternated, the best episode of each kept.

    .venv/bin/python benchmarks/several_uavs.py [--seconds 8] [--seeds 6] [--episodes 2]
        [--one scenarios/one_uav_200m_mmwave.toml] [--four scenarios/four_uavs_mmwave.toml]
        [--skip-training]

Times are this process's CPU time (``time.process_time``, one thread): what a core spends,
not what a neighbour's load takes from the wall clock (the machine may be shared). Runs in
under a minute by default (most of it the training part); prints a table of the
figures and the ratios against the thresholds (PASS / FAIL), and the load average.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import torch  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

from adaptsky.scenario import Scenario, load_scenario  # noqa: E402
from adaptsky.sim.network import NetworkBatch  # noqa: E402
from adaptsky.training.api import load_with_overrides  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/stepping.py
from stepping import random_steps  # noqa: E402

from adaptsky.training.host import pin_threads  # noqa: E402
from adaptsky.training.stack_run import Member, StackRun  # noqa: E402

LINK_ENVS = 1024
LINK_THRESHOLD = 1.0      # (a): U = 4 links/s over U = 1 links/s
TRAINING_THRESHOLD = 0.5  # (b): BDQ U = 4 seed-steps/s over dense DQN U = 1


def links_per_step(scenario: Scenario) -> int:
    """U x N: the links of one environment."""
    return scenario.uav.count * scenario.num_users


def endless(scenario: Scenario) -> Scenario:
    """``scenario`` whose time limit never ends a benchmark episode."""
    return scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"steps": 10**9})})


def stepping(scenario: Scenario, num_envs: int) -> Callable[[int], None]:
    """A function that steps ``num_envs`` environments of ``scenario`` (per-environment
    seeds, as training makes them) ``count`` times, after a warm-up."""
    env = NetworkBatch(endless(scenario), num_envs,
                       seed=[np.random.SeedSequence([s, 0]) for s in range(num_envs)])
    return random_steps(env, num_envs)[0]


def link_rates(one: Scenario, four: Scenario, seconds: float, rounds: int = 8
               ) -> tuple[float, float]:
    """Links per second of ``one`` and ``four`` at B = LINK_ENVS: the best of ``rounds``
    blocks of about ``seconds`` / (2 ``rounds``) each, the two alternated so that drift in
    the machine's speed (a neighbour's load) hits both alike."""
    scenarios = (one, four)
    runs = [stepping(scenario, LINK_ENVS) for scenario in scenarios]
    steps = [1, 1]
    best = [0.0, 0.0]
    for _ in range(rounds):
        for index, (scenario, run) in enumerate(zip(scenarios, runs, strict=True)):
            start = time.process_time()
            run(steps[index])
            elapsed = time.process_time() - start
            rate = steps[index] / elapsed
            best[index] = max(best[index], rate * LINK_ENVS * links_per_step(scenario))
            # the next block of this scenario lasts about seconds / (2 rounds)
            steps[index] = max(1, round(rate * seconds / (2 * rounds)))
    return best[0], best[1]


def warm_stack(scenario: Scenario, seeds: int) -> StackRun:
    """A stack of ``seeds`` seeds on this CPU thread whose memories hold a batch, so that
    every timed step makes an update (as benchmarks/train_throughput.py)."""
    run = StackRun([Member(scenario, seed) for seed in range(seeds)], torch.device("cpu"))
    while run.algorithm.memory.size < scenario.agent.batch_size + 1 or run.episodes_done < 1:
        run.run_episode()
    return run


def training_rates(one: Scenario, four: Scenario, seeds: int, episodes: int
                   ) -> tuple[float, float]:
    """Seed-steps per second of stacks of ``seeds`` seeds of ``one`` and ``four``: whole
    episodes timed in alternation (``episodes`` each), the best of each kept."""
    runs = [warm_stack(one, seeds), warm_stack(four, seeds)]
    best = [0.0, 0.0]
    for _ in range(episodes):
        for index, run in enumerate(runs):
            start = time.process_time()
            run.run_episode()
            rate = seeds * run.scenario.train.steps / (time.process_time() - start)
            best[index] = max(best[index], rate)
    return best[0], best[1]


def verdict(ratio: float, threshold: float) -> str:
    return "PASS" if ratio >= threshold else "FAIL"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", default="scenarios/one_uav_200m_mmwave.toml",
                        help="the scenario of one UAV (U = 1)")
    parser.add_argument("--four", default="scenarios/four_uavs_mmwave.toml",
                        help="the scenario of several UAVs (U = 4)")
    parser.add_argument("--seconds", type=float, default=8.0,
                        help="time of the timed blocks of (a), both scenarios, seconds")
    parser.add_argument("--seeds", type=int, default=6, help="seeds in a stack for (b)")
    parser.add_argument("--episodes", type=int, default=2,
                        help="timed episodes per scenario for (b), best kept")
    parser.add_argument("--skip-training", action="store_true", help="measure (a) only")
    args = parser.parse_args()
    pin_threads()
    one, four = load_scenario(args.one), load_scenario(args.four)
    console = Console(width=120)
    table = Table("item", "measure", f"U = {one.uav.count}, N = {one.num_users}",
                  f"U = {four.uav.count}, N = {four.num_users}", "ratio", "threshold",
                  "verdict",
                  title=f"several UAVs against one: torch {torch.__version__}, "
                        f"{torch.get_num_threads()} thread")
    one_rate, four_rate = link_rates(one, four, args.seconds)
    ratio = four_rate / one_rate
    table.add_row("(a)", f"links/s at B = {LINK_ENVS}", f"{one_rate:,.0f}", f"{four_rate:,.0f}",
                  f"{ratio:.2f}", f">= {LINK_THRESHOLD:g}", verdict(ratio, LINK_THRESHOLD))
    if not args.skip_training:
        dense = load_with_overrides(Path(args.one), ["agent.algorithm=dqn"])[0]
        one_train, four_train = training_rates(dense, four, args.seeds, args.episodes)
        ratio = four_train / one_train
        table.add_row("(b)", f"seed-steps/s, {args.seeds} seeds",
                      f"{one_train:,.0f} ({dense.agent.algorithm})",
                      f"{four_train:,.0f} ({four.agent.algorithm})", f"{ratio:.2f}",
                      f">= {TRAINING_THRESHOLD:g}", verdict(ratio, TRAINING_THRESHOLD))
    console.print(table)
    load = os.getloadavg()
    print(f"load average: {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f}")


if __name__ == "__main__":
    main()
