"""Where the ground user stands against the LoS-share check of docs/model.md §12: an
independent ray march (not the slab test of ``adaptsky.sim.blockage``) through the P.1410 grid
of each preset, for three placements of the user, printing the largest gap over 50 m bins of
ground distance to ITU-R P.1410's P_LoS, to Al-Hourani's sigmoid and to the nearer of the two.

    .venv/bin/python scripts/los_placements.py streets|anywhere|centre [--links 4000] [--seed 0]

``streets``: uniform over the streets (the city of §12); ``anywhere``: uniform over the whole
area, the square it stands on left open; ``centre``: at the centre of an open square. The UAV
is at a ground distance uniform in (0, 500] m in a uniform direction, at 50, 100 and 200 m;
each link is walked in steps of 0.5 m and blocked where a step lies inside a square below its
roof (heights Rayleigh(gamma), one per square of an endless grid). Slow (a Python loop per
link): about two minutes per placement at 4,000 links per cell.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

SIGMOID = {"suburban": (4.88, 0.43), "urban": (9.61, 0.16), "dense-urban": (12.08, 0.11),
           "high-rise": (27.23, 0.08)}
CITIES = {"suburban": (0.1, 750.0, 8.0), "urban": (0.3, 500.0, 15.0),
          "dense-urban": (0.5, 300.0, 20.0), "high-rise": (0.5, 300.0, 50.0)}
HEIGHTS_M = (50.0, 100.0, 200.0)
TABLE = 4096                 # heights of the endless grid: square (i, j) has TABLE[i % K, j % K]


def p1410(r_m: float, h_m: float, alpha: float, beta: float, gamma_m: float) -> float:
    """ITU-R P.1410's P_LoS for a user on the ground (plain scalar formula)."""
    m = math.floor(r_m / 1000 * math.sqrt(alpha * beta) - 1)
    p = 1.0
    for n in range(m + 1):
        height = h_m - (n + 0.5) * h_m / (m + 1)
        p *= 1 - math.exp(-height * height / (2 * gamma_m * gamma_m))
    return p


def sigmoid(r_m: float, h_m: float, a: float, b: float) -> float:
    """Al-Hourani's fit at the link's elevation angle."""
    theta = math.degrees(math.atan2(h_m, r_m))
    return 1 / (1 + a * math.exp(-b * (theta - a)))


def gaps(name: str, height_m: float, placement: str, links: int, seed: int,
         step_m: float = 0.5) -> tuple[float, float, float]:
    """The largest gap over the bins to P.1410, to the sigmoid and to the nearer."""
    alpha, beta, gamma_m = CITIES[name]
    side = 1000 * math.sqrt(alpha / beta)
    pitch = 1000 / math.sqrt(beta)
    rng = np.random.default_rng(seed)
    table = rng.rayleigh(gamma_m, (TABLE, TABLE))
    if placement == "streets":
        users = rng.uniform(0, pitch, (links * 3, 2))
        users = users[~((users[:, 0] < side) & (users[:, 1] < side))][:links]
    elif placement == "anywhere":
        users = rng.uniform(0, pitch, (links, 2))
    else:
        users = np.full((links, 2), side / 2)
    r_m = 500 * (1 - rng.random(links))
    phi = rng.uniform(0, 2 * np.pi, links)
    los = np.ones(links, dtype=bool)
    distances = np.arange(0, 500, step_m)
    open_own = placement in ("anywhere", "centre")
    for i in range(links):
        d = distances[distances < r_m[i]]
        x = users[i, 0] + d * math.cos(phi[i])
        y = users[i, 1] + d * math.sin(phi[i])
        z = height_m * d / r_m[i]
        column, row = np.floor(x / pitch).astype(int), np.floor(y / pitch).astype(int)
        inside = ((x - column * pitch) < side) & ((y - row * pitch) < side)
        if open_own:
            inside &= ~((column == 0) & (row == 0))
        if (inside & (z < table[column % TABLE, row % TABLE])).any():
            los[i] = False
    a, b = SIGMOID[name]
    bins = np.minimum((r_m // 50).astype(int), 9)
    found = []
    for k in range(10):
        chosen = bins == k
        share = los[chosen].mean()
        formula = np.mean([p1410(r, height_m, alpha, beta, gamma_m) for r in r_m[chosen]])
        fit = np.mean([sigmoid(r, height_m, a, b) for r in r_m[chosen]])
        found.append((abs(share - formula), abs(share - fit)))
    gap = np.array(found)
    return float(gap[:, 0].max()), float(gap[:, 1].max()), float(gap.min(axis=1).max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("placement", choices=("streets", "anywhere", "centre"))
    parser.add_argument("--links", type=int, default=4000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print("| city | UAV height | largest gap to P.1410 | to the sigmoid | to the nearer |")
    print("|---|---|---|---|---|")
    for name in CITIES:
        for height_m in HEIGHTS_M:
            to_formula, to_fit, to_nearer = gaps(name, height_m, args.placement, args.links,
                                                 args.seed)
            print(f"| {name} | {height_m:g} m | {to_formula:.3f} | {to_fit:.3f} | "
                  f"{to_nearer:.3f} |", flush=True)


if __name__ == "__main__":
    main()
