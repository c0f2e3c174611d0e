"""Another learner's policies on E3's 100 uniform layouts beside the dueling DQN's (issue 39):
reads eval CSVs (``adaptsky eval --layouts 100 --layout-seed 0 --steps 1000 --compare soa
--csv FILE``) and E3's per-layout numbers (docs/results/e3/e3.csv, the same layouts: SoA's rates
are checked equal), and prints one markdown row per policy kind (last, best) and learner: the
mean sum rate's share of the per-layout oracle, the layouts where it beats SoA, its median and
mean gain over SoA, each as mean ± population standard deviation over the seeds (n).

    .venv/bin/python scripts/e3_compare.py [LABEL:last:FILE.csv ...]
        [--experiment LABEL:GROUP:EXPERIMENT.csv ...] [--e3 docs/results/e3/e3.csv]
        [--group adaptsky]

``--experiment`` reads a group's every policy and seed from a ``reproduce`` CSV of E3's
layouts (a layout-gains experiment with ``layouts = 100``, ``layout_seed = 0``, such as
``experiments/ppo.toml``), in E3's own CSV format.
"""

from __future__ import annotations

import argparse
import csv
from collections import defaultdict

import numpy as np


def e3_rows(path: str, group: str) -> tuple[dict, np.ndarray, np.ndarray]:
    """E3's policies {(policy, seed): per-layout rates}, SoA's and the oracle's rates."""
    policies: dict[tuple[str, int], dict[int, float]] = defaultdict(dict)
    soa, oracle = {}, {}
    with open(path) as f:
        for row in csv.DictReader(f):
            if row["group"] != group:
                continue
            layout = int(row["layout"])
            policies[(row["policy"], int(row["seed"]))][layout] = float(row["policy_bps"])
            soa[layout], oracle[layout] = float(row["soa_bps"]), float(row["oracle_bps"])
    layouts = sorted(soa)
    rates = {key: np.array([values[i] for i in layouts]) for key, values in policies.items()}
    return rates, np.array([soa[i] for i in layouts]), np.array([oracle[i] for i in layouts])


def eval_rates(path: str) -> tuple[np.ndarray, np.ndarray]:
    """The policy's and SoA's mean sum rates per layout of an eval CSV."""
    found: dict[str, dict[int, float]] = defaultdict(dict)
    with open(path) as f:
        for row in csv.DictReader(f):
            found[row["method"]][int(row["layout"])] = float(row["mean_sum_rate_bps"])
    layouts = sorted(found["policy"])
    return (np.array([found["policy"][i] for i in layouts]),
            np.array([found["soa"][i] for i in layouts]))


def measures(policy: np.ndarray, soa: np.ndarray, oracle: np.ndarray) -> list[float]:
    gain = 100 * (policy - soa) / soa
    return [100 * float(np.mean(policy / oracle)), 100 * float(np.mean(policy > soa)),
            float(np.median(gain)), float(np.mean(gain))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("evals", nargs="*", help="LABEL:POLICY:FILE.csv")
    parser.add_argument("--experiment", action="append", default=[],
                        help="LABEL:GROUP:EXPERIMENT.csv (repeatable)")
    parser.add_argument("--e3", default="docs/results/e3/e3.csv")
    parser.add_argument("--group", default="adaptsky")
    args = parser.parse_args()
    e3, soa, oracle = e3_rows(args.e3, args.group)
    table: dict[tuple[str, str], list[list[float]]] = defaultdict(list)
    for (policy, _seed), rates in sorted(e3.items()):
        table[(f"dueling DQN (E3, group {args.group})", policy)].append(
            measures(rates, soa, oracle))
    for item in args.evals:
        label, policy, path = item.split(":", 2)
        rates, their_soa = eval_rates(path)
        if not np.array_equal(their_soa, soa):
            raise SystemExit(f"{path}: SoA's rates differ from E3's: not E3's layouts "
                             "(--layouts 100 --layout-seed 0 --steps 1000)")
        table[(label, policy)].append(measures(rates, soa, oracle))
    for item in args.experiment:
        label, group, path = item.split(":", 2)
        rows, their_soa, _ = e3_rows(path, group)
        if not rows:
            raise SystemExit(f"{path}: no rows of group '{group}'")
        if not np.array_equal(their_soa, soa):
            raise SystemExit(f"{path}: SoA's rates differ from E3's: not E3's layouts")
        for (policy, _seed), rates in sorted(rows.items()):
            table[(label, policy)].append(measures(rates, soa, oracle))
    print("| learner | policy | n | % of the oracle | layouts beating SoA | median gain over "
          "SoA | mean gain over SoA |")
    print("|---|---|---|---|---|---|---|")
    for (label, policy), rows in table.items():
        values = np.array(rows)
        cells = [f"{m:.1f}{u} ± {s:.1f}{u}" for m, s, u in
                 zip(values.mean(axis=0), values.std(axis=0), ("%", "%", "%", "%"),
                     strict=True)]
        print(f"| {label} | {policy} | {len(rows)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
