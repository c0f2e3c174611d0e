"""Per seed of a reproduced E3 folder: how each run did on its training layout and how it
transfers to the 100 test layouts, for the paper's agent, the plain DQN and the agent trained
on fresh layouts (REPRODUCTION.md, why the numbers differ).

    python scripts/e3_seeds.py reproduce/e3
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from adaptsky.store.eval_file import read_eval_metrics
from adaptsky.store.run_file import RunReader


def rates(path: Path) -> np.ndarray:
    _, methods = read_eval_metrics(path)
    return next(iter(methods.values()))["mean_sum_rate_bps"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    folder = parser.parse_args().folder
    soa = rates(folder / "evals" / "soa.h5")
    oracle = rates(folder / "evals" / "oracle.h5")
    print("group       seed  R_e^tot train (Gbit/s)  beats SoA  median gain  "
          "mean rate / oracle (test)")
    for group in ("adaptsky", "dqn", "generalist"):
        for seed in range(6):
            run = folder / "runs" / f"{group}-seed{seed}.h5"
            evaluation = folder / "evals" / f"{group}-seed{seed}.h5"
            if not run.exists() or not evaluation.exists():
                continue
            with RunReader(run, needs="curves") as reader:
                curve = reader.episodes(seed)["sum_rate_bps"]
            mine = rates(evaluation)
            gain = 100 * (mine - soa) / soa
            print(f"{group:<11} {seed:>4}  {np.mean(curve[-100:]) / 1e9:>22.2f}  "
                  f"{100 * np.mean(mine > soa):>8.0f}%  {np.median(gain):>+10.1f}%  "
                  f"{100 * np.mean(mine / oracle):>10.1f}%")


if __name__ == "__main__":
    main()
