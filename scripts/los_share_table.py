"""The share of LoS links of generated cities against ITU-R P.1410 and Al-Hourani's sigmoid
(docs/model.md §12): prints the table of that section.

    .venv/bin/python scripts/los_share_table.py [--links 100000] [--seed 0]

For each preset and UAV height, ``--links`` random links of a generated city (the grid and
heights of ``adaptsky.sim.city``, the slab test of ``adaptsky.sim.blockage``): a user uniform
over the streets of the city's middle, the UAV at a ground distance uniform in (0, 500] m in a
uniform direction (drawn again where it would stand inside a building). Per distance bin of
50 m, the share of LoS links is compared with the mean over the bin's links of P.1410's
P_LoS(r) and of the sigmoid at each link's elevation angle; the table gives the largest gap
over the bins to each, and the largest excess of the share over P.1410's (signed).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from adaptsky.scenario.models import CITY_PRESETS
from adaptsky.sim.blockage import Blockage, inside_buildings
from adaptsky.sim.city import City, grid_footprints, grid_geometry_m, street_layouts

SIGMOID = {"suburban": (4.88, 0.43), "urban": (9.61, 0.16), "dense-urban": (12.08, 0.11),
           "high-rise": (27.23, 0.08)}
"""Al-Hourani, Kandeepan, Lardner (2014): (a, b) of each environment."""
HEIGHTS_M = (50.0, 100.0, 200.0)
MAX_DISTANCE_M = 500.0
BIN_M = 50.0
USERS_HALF_M = 100.0     # users stand in the streets of |x|, |y| <= this
USERS_PER_CITY = 200     # users of one city; every user has links // USERS_PER_CITY UAVs
USER_HEIGHT_M = 0.0


def p1410(r_m: float, h_tx_m: float, h_rx_m: float, alpha: float, beta: float,
          gamma_m: float) -> float:
    """ITU-R P.1410's P_LoS of one link (plain scalar formula)."""
    m = math.floor(r_m / 1000.0 * math.sqrt(alpha * beta) - 1)
    p = 1.0
    for n in range(m + 1):
        h = h_tx_m - (n + 0.5) * (h_tx_m - h_rx_m) / (m + 1)
        p *= 1.0 - math.exp(-h * h / (2.0 * gamma_m * gamma_m))
    return p


def sigmoid(theta_deg: float, a: float, b: float) -> float:
    """Al-Hourani's fit 1 / (1 + a exp(-b (theta - a)))."""
    return 1.0 / (1.0 + a * math.exp(-b * (theta_deg - a)))


@dataclass(frozen=True)
class Row:
    city: str
    height_m: float
    links: int
    share: float
    gap_p1410: float
    gap_sigmoid: float
    gap_either: float        # the largest over the bins of the smaller of the two gaps
    excess_p1410: float      # the largest over the bins of the share less P.1410's


def _city(params: tuple[float, float, float], rng: np.random.Generator) -> City:
    """One city of side 2 (MAX_DISTANCE_M + USERS_HALF_M), its grid offset uniform."""
    alpha, beta, gamma_m = params
    side_m, pitch_m = grid_geometry_m(alpha, beta)
    footprints = grid_footprints(side_m, pitch_m, rng.uniform(0, pitch_m, 2),
                                 MAX_DISTANCE_M + USERS_HALF_M + pitch_m)
    return City(footprints, rng.rayleigh(gamma_m, size=(1, len(footprints))))


def _links(city: City, height_m: float, per_user: int, rng: np.random.Generator
           ) -> tuple[np.ndarray, np.ndarray]:
    """LoS states and ground distances (users, per_user) of one city's links."""
    users = street_layouts(rng, 1, USERS_PER_CITY, USERS_HALF_M, city.footprints_m)
    r_m = MAX_DISTANCE_M * (1.0 - rng.random((USERS_PER_CITY, per_user)))   # (0, 500]
    phi = rng.uniform(0, 2 * np.pi, (USERS_PER_CITY, per_user))
    uav = np.empty((USERS_PER_CITY, per_user, 3))
    uav[..., 0] = users[0, :, 0, None] + r_m * np.cos(phi)
    uav[..., 1] = users[0, :, 1, None] + r_m * np.sin(phi)
    uav[..., 2] = height_m
    inside = inside_buildings(uav.reshape(1, -1, 3), city).reshape(r_m.shape)
    while inside.any():    # a UAV never stands inside a building
        count = int(inside.sum())
        r_m[inside] = MAX_DISTANCE_M * (1.0 - rng.random(count))
        phi_new = rng.uniform(0, 2 * np.pi, count)
        uav[inside, 0] = users[0, :, 0, None].repeat(per_user, 1)[inside] + r_m[inside] * np.cos(
            phi_new)
        uav[inside, 1] = users[0, :, 1, None].repeat(per_user, 1)[inside] + r_m[inside] * np.sin(
            phi_new)
        inside = inside_buildings(uav.reshape(1, -1, 3), city).reshape(r_m.shape)
    blockage = Blockage(city, USER_HEIGHT_M)
    los = np.concatenate([blockage.los(uav[i:i + 1], users[:, i:i + 1])[0, :, 0][None]
                          for i in range(USERS_PER_CITY)])
    return los, r_m


def random_links(name: str, height_m: float, links: int, seed: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """LoS states and ground distances, m, of about ``links`` random links of a city of preset
    ``name`` with the UAVs at ``height_m`` (module doc), flat."""
    rng = np.random.default_rng([seed, int(height_m), list(CITY_PRESETS).index(name)])
    per_user = math.ceil(links / USERS_PER_CITY)
    los, r_m = _links(_city(CITY_PRESETS[name], rng), height_m, per_user, rng)
    return los.ravel(), r_m.ravel()


def measure(name: str, height_m: float, links: int, seed: int) -> Row:
    """The row of one preset and UAV height (module doc)."""
    params = CITY_PRESETS[name]
    los, r_m = random_links(name, height_m, links, seed)
    a, b = SIGMOID[name]
    formula = np.array([p1410(r, height_m, USER_HEIGHT_M, *params) for r in r_m])
    theta = np.degrees(np.arctan2(height_m - USER_HEIGHT_M, r_m))
    fit = np.array([sigmoid(t, a, b) for t in theta])
    bins = np.minimum((r_m // BIN_M).astype(int), int(MAX_DISTANCE_M // BIN_M) - 1)
    gaps, excess = [], []
    for k in range(int(MAX_DISTANCE_M // BIN_M)):
        chosen = bins == k
        share = los[chosen].mean()
        gaps.append((abs(share - formula[chosen].mean()), abs(share - fit[chosen].mean())))
        excess.append(share - formula[chosen].mean())
    gap = np.array(gaps)
    return Row(name, height_m, len(los), float(los.mean()), float(gap[:, 0].max()),
               float(gap[:, 1].max()), float(gap.min(axis=1).max()), float(max(excess)))


def table(links: int, seed: int) -> list[Row]:
    """Every preset at every height of HEIGHTS_M."""
    return [measure(name, h, links, seed) for name in CITY_PRESETS for h in HEIGHTS_M]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print("| city | UAV height | links | LoS share | largest gap to P.1410 | largest gap to "
          "the sigmoid | largest gap to the nearer | largest excess over P.1410 |")
    print("|---|---|---|---|---|---|---|---|")
    for row in table(args.links, args.seed):
        print(f"| {row.city} | {row.height_m:g} m | {row.links} | {row.share:.3f} | "
              f"{row.gap_p1410:.3f} | {row.gap_sigmoid:.3f} | {row.gap_either:.3f} | "
              f"{row.excess_p1410:+.3f} |")


if __name__ == "__main__":
    main()
