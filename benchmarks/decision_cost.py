"""The cost of a decision (docs/agent.md, "The cost of a decision"): how fast a trained policy
decides against the exact oracle's search, on unseen layouts, on this machine, one thread.

    python benchmarks/decision_cost.py [--checkpoint RUN.h5] [--layouts 20] [--steps 300]
        [--scenario scenarios/nyc_mmwave_any_layout.toml]

A policy decides from an observation by one forward pass of its network; the oracle searches
the lattice and the shares of every layout (branch and bound, docs/model.md §8). A policy
takes one decision per step and an episode's steps to fly to its place, so the figures are
given per decision, per batch of every layout's decision at once and per episode (the
rollout: decisions and the simulator's steps), beside the oracle's seconds per layout, with
their ratios. The layouts are evaluation's (``eval --layouts N --layout-seed 0``). Without
``--checkpoint`` the policy is a fresh one of the scenario's learner: the same network, so the
same cost (its decisions are not good ones). Process time, one torch and BLAS thread.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from adaptsky.envs.observations import AgentView
from adaptsky.evaluation.api import eval_layouts, load_policy
from adaptsky.rollouts.oracle import oracle
from adaptsky.rollouts.rollout import greedy_policy, rollout
from adaptsky.scenario import load_scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky.training.runner import pin_threads
from adaptsky.training.stack_run import Member, StackRun


def seconds_each(work, repeats: int) -> float:
    """Median process seconds of ``work()`` over ``repeats`` calls, after one warm-up."""
    work()
    times = []
    for _ in range(repeats):
        start = time.process_time()
        work()
        times.append(time.process_time() - start)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", type=Path,
                        default=Path("scenarios/nyc_mmwave_any_layout.toml"))
    parser.add_argument("--checkpoint", type=Path, default=None)
    parser.add_argument("--layouts", type=int, default=20)
    parser.add_argument("--steps", type=int, default=300)
    args = parser.parse_args()
    pin_threads()
    scenario = load_scenario(args.scenario)
    layouts = eval_layouts(scenario, args.layouts)
    if args.checkpoint is not None:
        policy, _ = load_policy(args.checkpoint, None, scenario)
        source = f"{args.checkpoint}'s best policy"
    else:
        policy = greedy_policy(scenario, StackRun([Member(scenario, 0)]).algorithm.policy(0))
        source = f"a fresh {scenario.agent.algorithm} policy (the trained network's size)"
    env = NetworkBatch(scenario, num_envs=len(layouts), users_m=layouts,
                       view=AgentView.of(scenario))
    observations, _ = env.reset()
    one = observations[:1]
    per_decision = seconds_each(lambda: [policy(one) for _ in range(100)], 5) / 100
    per_batch = seconds_each(lambda: policy(observations), 20)
    start = time.process_time()
    rollout(scenario, policy, args.steps, layouts)
    per_episode = (time.process_time() - start) / len(layouts)
    start = time.process_time()
    found = oracle(scenario, layouts)
    per_search = (time.process_time() - start) / len(layouts)
    print(f"{scenario.name}, {len(layouts)} unseen layouts, {source}; one thread, process "
          "time")
    print(f"  policy: {per_decision * 1e6:.4g} us per decision ({1 / per_decision:,.0f} per "
          f"second); {per_batch * 1e3:.4g} ms for the {len(layouts)} layouts' decisions at "
          f"once ({len(layouts) / per_batch:,.0f} per second)")
    print(f"  policy episode ({args.steps} steps, the simulator's included): "
          f"{per_episode * 1e3:.4g} ms per layout")
    print(f"  oracle: {per_search:.4g} s per layout (its optimum's mean "
          f"{found.objective_bps.mean() / 1e9:.2f} Gbit/s)")
    print(f"  ratios: one oracle search = {per_search / per_decision:,.0f} decisions = "
          f"{per_search / per_episode:,.4g} episodes of the policy")


if __name__ == "__main__":
    main()
