"""Every seed of one or more run files, evaluated as ``adaptsky eval`` evaluates one: greedy
steady state over the last 100 of ``--steps`` steps against the oracle and SoA, with the
``best`` and the ``last`` policy. Baselines are computed once for all runs (the oracle costs
about 2 s per layout), so a table of six seeds on 100 layouts takes minutes, not an hour.

    python scripts/seed_table.py RUN.h5 [RUN.h5 ...] [--layouts 100 --layout-seed 0]

Prints one Markdown table per run (per seed: percent of the oracle, mean and median over
layouts, and the share of layouts where the policy's mean sum rate beats SoA's) and a JSON
line per run with every number. Used for docs/agent.md.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from adaptsky.evaluation.api import (
    eval_layouts,
    run_baseline,
    with_policy,
)
from adaptsky.rollouts.metrics import Method, compare, percent_of
from adaptsky.rollouts.rollout import greedy_policy, rollout
from adaptsky.scenario.variants import eval_scenario
from adaptsky.store.run_file import RunReader
from adaptsky.training.runner import pin_threads


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--layouts", type=int, default=None)
    parser.add_argument("--layout-seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=1000)
    args = parser.parse_args()
    pin_threads()
    baselines: dict[str, dict[str, Method]] = {}
    for path in args.runs:
        with RunReader(path) as run:
            trained = run.scenario
            policies = {seed: {name: with_policy(trained, run.checkpoint(seed), best)
                               for name, best in (("best", run.best(seed)), ("last", None))}
                        for seed in run.seeds}
            last_episode = {seed: int(run.checkpoint(seed)["episode"]) for seed in run.seeds}
            best_episode = {seed: (run.best(seed) or {}).get("episode") for seed in run.seeds}
        scenario = eval_scenario(trained, args.layouts, args.layout_seed)
        users_m = eval_layouts(scenario, args.layouts)
        # the baselines depend on the network, not on the agent or the run's name
        physics = {k: v for k, v in scenario.model_dump(mode="json").items()
                   if k not in ("name", "description", "agent", "train")}
        key = json.dumps(physics, sort_keys=True)
        if key not in baselines:
            baselines[key] = {name: run_baseline(scenario, name, args.steps, users_m)
                              for name in ("oracle", "soa")}
        oracle = baselines[key]["oracle"].metrics["mean_sum_rate_bps"]
        soa = baselines[key]["soa"].metrics
        print(f"\n{path} ({len(users_m)} layout(s)"
              + (f", layout seed {args.layout_seed}" if args.layouts else "") + ")\n")
        print("| seed | policy (episode) | % of oracle, mean | median | min | beats SoA |")
        print("|---|---|---|---|---|---|")
        record: dict[str, object] = {"run": str(path), "layouts": len(users_m), "seeds": {}}
        for seed, chosen in policies.items():
            for name, arrays in chosen.items():
                method = Method.of(name, scenario, rollout(
                    scenario, greedy_policy(trained, arrays), args.steps, users_m))
                pct = percent_of(method.metrics["steady_sum_rate_bps"], oracle)
                beats = compare(method.metrics, soa)["beats_share"]
                episode = best_episode[seed] if name == "best" else last_episode[seed]
                print(f"| {seed} | {name} ({episode}) | {np.nanmean(pct):.1f} | "
                      f"{np.nanmedian(pct):.1f} | {np.nanmin(pct):.1f} | {100 * beats:.0f}% |")
                record["seeds"][f"{seed}-{name}"] = {  # type: ignore[index]
                    "episode": episode, "pct_mean": float(np.nanmean(pct)),
                    "pct_median": float(np.nanmedian(pct)), "pct_min": float(np.nanmin(pct)),
                    "beats_soa": beats}
        for name in ("best", "last"):
            rows = [v for k, v in record["seeds"].items()  # type: ignore[attr-defined]
                    if k.endswith(name)]
            means = np.array([row["pct_mean"] for row in rows])
            medians = np.array([row["pct_median"] for row in rows])
            beats = np.array([row["beats_soa"] for row in rows])
            print(f"\n{name}, over {len(rows)} seeds: % of oracle (per-seed mean) "
                  f"{means.mean():.1f} ± {means.std():.1f} (population std), lowest seed "
                  f"{means.min():.1f}; "
                  f"per-seed median lowest {medians.min():.1f}; beats SoA on at least "
                  f"{100 * beats.min():.0f}% of layouts")
        print(json.dumps(record))


if __name__ == "__main__":
    main()
