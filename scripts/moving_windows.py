"""Where in a long greedy rollout a policy trained on moving users wins or loses against the
tracking baseline (REPRODUCTION.md, E7): each seed's policy and tracking on the same draws
(seed 0, as ``adaptsky eval`` runs them) for ``--steps`` steps from the training layout, the
policy's gain over tracking in windows of ``--window`` steps, and how far the users stand from
their layout at the end of each window (the training episodes are ``train.steps`` long, and
the users return to their layout at every reset: later windows hold user positions training
never reached).

    .venv/bin/python scripts/moving_windows.py RUN.h5 [--policy best|last] [--steps 1000]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from adaptsky.evaluation.api import read_trained
from adaptsky.rollouts.rollout import greedy_policy, rollout
from adaptsky.rollouts.tracking import track
from adaptsky.sim.layout import user_layouts
from adaptsky.store.run_file import RunReader


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--policy", default="best", choices=("best", "last"))
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--window", type=int, default=100)
    args = parser.parse_args()
    with RunReader(args.run) as run:
        seeds, scenario = run.seeds, run.scenario
    layout = user_layouts(scenario, 1)
    tracked = track(scenario, args.steps, layout, seed=0)
    users = tracked.users_m[:, 0]                                   # (T, N, 2)
    drift = np.hypot(*(users - layout[0]).transpose(2, 0, 1)).mean(axis=1)  # (T,)
    windows = range(0, args.steps, args.window)
    print(f"{args.run}: {scenario.name}, training episodes of {scenario.train.steps} steps; "
          f"{args.policy} policies against tracking, gain over tracking (%) per window")
    print("window      " + " ".join(f"{f'{w}-{w + args.window}':>11}" for w in windows))
    print("users' mean distance from their layout at the window's end (m)")
    print("            " + " ".join(f"{drift[w + args.window - 1]:>11.1f}" for w in windows))
    tracking = tracked.sum_rate_bps[:, 0]
    gains = []
    for seed in seeds:
        trained = read_trained(args.run, seed, args.policy)
        policy = greedy_policy(trained.scenario, trained.policy)
        rates = rollout(scenario, policy, args.steps, layout, seed=0).sum_rate_bps[:, 0]
        gain = [100 * (rates[w:w + args.window].mean() / tracking[w:w + args.window].mean()
                       - 1) for w in windows]
        gains.append(gain)
        print(f"seed {seed:<6} " + " ".join(f"{g:>+11.1f}" for g in gain))
    table = np.array(gains)
    print("mean        " + " ".join(f"{g:>+11.1f}" for g in table.mean(axis=0)))
    ahead = (table > 0).sum(axis=0)
    print("seeds ahead " + " ".join(f"{f'{count}/{len(seeds)}':>11}" for count in ahead))


if __name__ == "__main__":
    main()
