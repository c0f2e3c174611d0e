"""The share of LoS links of a generated city (docs/model.md §12) against ITU-R P.1410's
P_LoS and Al-Hourani's sigmoid, both written here as plain scalar formulas.

The links come from scripts/los_share_table.py (the city of ``adaptsky.sim.city`` and the slab
test of ``adaptsky.sim.blockage``, users uniform over the streets, 100,000 links per preset
and height, fixed seeds). The check of docs/model.md §12: in every 50 m bin of ground distance
the share lies within 0.1 of the bin's mean P.1410 P_LoS or of its mean sigmoid. It holds for
high-rise at 100 m only: the geometric city has buildings next to the users, which neither
formula has (section 12 gives the table and why), so the other cells are expected failures
(strict: a change that makes one pass is seen)."""

from __future__ import annotations

import importlib.util
import math
import sys

import numpy as np
import pytest

from tests.conftest import ROOT

LINKS = 100_000
TOLERANCE = 0.1
BIN_M = 50.0
SIGMOID = {"suburban": (4.88, 0.43), "urban": (9.61, 0.16), "dense-urban": (12.08, 0.11),
           "high-rise": (27.23, 0.08)}
CITIES = {"suburban": (0.1, 750.0, 8.0), "urban": (0.3, 500.0, 15.0),
          "dense-urban": (0.5, 300.0, 20.0), "high-rise": (0.5, 300.0, 50.0)}
PASSING = {("high-rise", 100.0)}


def _script():
    spec = importlib.util.spec_from_file_location("los_share_table",
                                                  ROOT / "scripts" / "los_share_table.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def p1410(r_m: float, h_tx_m: float, h_rx_m: float, alpha: float, beta: float,
          gamma_m: float) -> float:
    m = math.floor(r_m / 1000 * math.sqrt(alpha * beta) - 1)
    p = 1.0
    for n in range(m + 1):
        p *= 1 - math.exp(-(h_tx_m - (n + 0.5) * (h_tx_m - h_rx_m) / (m + 1)) ** 2
                          / (2 * gamma_m ** 2))
    return p


def sigmoid(theta_deg: float, a: float, b: float) -> float:
    return 1 / (1 + a * math.exp(-b * (theta_deg - a)))


def _cases():
    for name in CITIES:
        for height_m in (50.0, 100.0, 200.0):
            marks = () if (name, height_m) in PASSING else pytest.mark.xfail(
                strict=True, reason="buildings next to street users (docs/model.md §12)")
            yield pytest.param(name, height_m, marks=marks, id=f"{name}-{height_m:g}m")


@pytest.mark.parametrize(("name", "height_m"), list(_cases()))
def test_the_los_share_lies_near_p1410_or_the_sigmoid(name, height_m):
    los, r_m = _script().random_links(name, height_m, LINKS, seed=0)
    assert len(los) >= LINKS
    a, b = SIGMOID[name]
    bins = np.minimum(r_m // BIN_M, 9).astype(int)
    for k in range(10):
        chosen = bins == k
        share = los[chosen].mean()
        formula = np.mean([p1410(r, height_m, 0.0, *CITIES[name]) for r in r_m[chosen]])
        fit = np.mean([sigmoid(math.degrees(math.atan2(height_m, r)), a, b)
                       for r in r_m[chosen]])
        assert min(abs(share - formula), abs(share - fit)) < TOLERANCE, (k, share, formula, fit)


def test_the_geometric_city_is_never_clearer_than_p1410():
    # the direction of the gap: the city's buildings next to the users only take LoS away
    for name in CITIES:
        los, r_m = _script().random_links(name, 100.0, 20_000, seed=1)
        formula = np.mean([p1410(r, 100.0, 0.0, *CITIES[name]) for r in r_m])
        assert los.mean() < formula + 0.01, name
