"""Training throughput: one seed against its floor, and stacks of seeds on a CPU or a GPU.

Part 1 (one seed, this device): times whole episodes of algorithm 1 (environment step, action
choice, replay sample and one gradient update per step) and, in the same process, the floor:
the same number of bare updates of the same network on random rows of a full replay memory.
Prints both and their ratio (training time / floor time).

Part 2 (``--seeds``): stacks of S seeds trained together in this one process (one CPU thread,
or one GPU); prints seed-steps per second and the ratio to one seed.

    .venv/bin/python benchmarks/train_throughput.py [--scenario FILE] [--episodes 3]
    .venv/bin/python benchmarks/train_throughput.py --seeds 1,2,4,8
    python benchmarks/train_throughput.py --device cuda --seeds 1,8,64,256,1024
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from rich.console import Console
from rich.table import Table

from adaptsky.algos.device_step import describe, resolve_device
from adaptsky.scenario import Scenario, load_scenario
from adaptsky.training.runner import pin_threads
from adaptsky.training.stack_run import Member, StackRun


def warm_stack(scenario: Scenario, seeds: int, device: torch.device) -> StackRun:
    """A stack whose memories hold a batch, so every timed step makes an update (and, on
    CUDA, whose graphs are recorded)."""
    run = StackRun([Member(scenario, seed) for seed in range(seeds)], device)
    while run.algorithm.memory.size < scenario.agent.batch_size + 1 or run.episodes_done < 1:
        run.run_episode()
    return run


def timed_episodes(run: StackRun, episodes: int) -> float:
    start = time.perf_counter()
    for _ in range(episodes):
        run.run_episode()
    if run.algorithm.agent.device.type == "cuda":
        torch.cuda.synchronize()
    return time.perf_counter() - start


def floor_seconds(run: StackRun, updates: int, rng: np.random.Generator) -> float:
    """Bare updates (replay gather, TD update, Adam) on random rows of the memory."""
    batch = run.scenario.agent.batch_size
    indices = [rng.integers(0, run.algorithm.memory.size, size=(len(run.members), batch))
               for _ in range(64)]
    if run.algorithm.agent.device.type == "cuda":
        torch.cuda.synchronize()
    start = time.perf_counter()
    for step in range(updates):
        run.algorithm.device_step.update(indices[step % len(indices)])
    if run.algorithm.agent.device.type == "cuda":
        torch.cuda.synchronize()
    return time.perf_counter() - start


def one_seed(scenario: Scenario, device: torch.device, episodes: int) -> None:
    """Training and floor in alternation, an episode's worth each, so that drift in the
    machine's speed hits both alike; medians over the rounds."""
    run = warm_stack(scenario, 1, device)
    steps, rng = scenario.train.steps, np.random.default_rng(0)
    floor_seconds(run, steps, rng)  # warm the floor's code path too
    rounds = [(timed_episodes(run, 1), floor_seconds(run, steps, rng))
              for _ in range(episodes)]
    train_s = float(np.median([t for t, _ in rounds]))
    floor_s = float(np.median([f for _, f in rounds]))
    ratio = float(np.median([t / f for t, f in rounds]))
    table = Table("one seed, per episode (median)", "steps", "seconds", "steps/s", "us/step",
                  title=f"{scenario.name}: hidden {scenario.agent.hidden_sizes}, batch "
                        f"{scenario.agent.batch_size}, torch {torch.__version__}, "
                        f"{describe(device)}, {torch.get_num_threads()} thread, "
                        f"{episodes} rounds")
    for label, seconds in (("training (env + act + sample + update)", train_s),
                           ("floor (bare updates)", floor_s)):
        table.add_row(label, str(steps), f"{seconds:.3f}", f"{steps / seconds:,.0f}",
                      f"{seconds / steps * 1e6:,.0f}")
    Console().print(table)
    spread = [t / f for t, f in rounds]
    print(f"ratio training / floor: {ratio:.3f} (median of {episodes} rounds; "
          f"min {min(spread):.3f}, max {max(spread):.3f})")


def stacked(scenario: Scenario, device: torch.device, sizes: list[int], episodes: int) -> None:
    table = Table("seeds", "episodes", "seconds", "seed-steps/s", "vs one seed",
                  "wall per step",
                  title=f"stacks of seeds in one process, {describe(device)}")
    steps = episodes * scenario.train.steps
    if device.type != "cpu":  # the CPU figure alongside: one seed on one thread
        seconds = timed_episodes(warm_stack(scenario, 1, torch.device("cpu")), episodes)
        table.add_row("1 (cpu)", str(episodes), f"{seconds:.2f}", f"{steps / seconds:,.0f}",
                      "-", f"{seconds / steps * 1e3:.2f} ms")
    base = None
    for size in sizes:
        run = warm_stack(scenario, size, device)
        seconds = timed_episodes(run, episodes)
        rate = size * steps / seconds
        base = base or rate / size
        table.add_row(str(size), str(episodes), f"{seconds:.2f}", f"{rate:,.0f}",
                      f"{rate / base:.2f}x", f"{seconds / steps * 1e3:.2f} ms")
        Console().print(f"  {size} seeds: {rate:,.0f} seed-steps/s", highlight=False)
    Console().print(table)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/nyc_mmwave.toml")
    parser.add_argument("--episodes", type=int, default=5,
                        help="timed episodes (rounds of episode + floor for one seed)")
    parser.add_argument("--device", default="cpu", help="cpu, cuda or auto")
    parser.add_argument("--seeds", default="", help="stack sizes, e.g. 1,8,64 (part 2)")
    args = parser.parse_args()
    pin_threads()
    device = resolve_device(args.device)
    scenario = load_scenario(args.scenario)
    if args.seeds:
        stacked(scenario, device, [int(size) for size in args.seeds.split(",")], args.episodes)
    else:
        one_seed(scenario, device, args.episodes)


if __name__ == "__main__":
    main()
