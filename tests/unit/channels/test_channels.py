"""Built-in channel models against scalar formulas written from the paper (eq. 4-7), and one
contract test over every discovered channel model."""

import math

import numpy as np
import pytest

from adaptsky.channels import LinkGeometry
from adaptsky.channels.registry import discover, get_model_class

C_LIGHT = 299_792_458.0
POINTS = [(0.0, 0.0, 10.0), (30.0, 40.0, 50.0), (-44.0, -49.0, 50.0), (70.0, -70.0, 12.0),
          (1.0, 2.0, 200.0)]


def _geometry(points):
    """One UAV per point, one user at the origin: horizontal = hypot(x, y), height h."""
    uav_m = np.array(points, dtype=float)
    users_m = np.zeros((len(points), 1, 2))
    return LinkGeometry.between(uav_m, users_m)


def _elevation_deg(x, y, h):
    return math.degrees(math.asin(h / math.sqrt(x * x + y * y + h * h)))


# --- mmWave NYC, eq. 4 and 5, Table I -------------------------------------------------------

def mmwave_scalar(x, y, h):
    d = math.sqrt(x * x + y * y + h * h)
    theta = _elevation_deg(x, y, h)
    c, big_y = 9.6117, 0.1581
    p_los = 1 / (1 + c * math.exp(-big_y * (theta - c)))
    return p_los, 10**-6.4 * d**-2, 10**-7.2 * d**-2.92


def test_mmwave_nyc_by_hand():
    # d = 50 m straight below: g_LoS = 10^-6.4 / 2500 = 1.5924e-10;
    # theta = 90 deg: P_LoS = 1 / (1 + 9.6117 exp(-12.7094)) = 1 / (1 + 2.9052e-5) = 0.99997095
    model = get_model_class("mmwave-nyc")()
    geometry = _geometry([(0.0, 0.0, 50.0)])
    assert model.gain_los(geometry)[0, 0] == pytest.approx(1.5924e-10, rel=1e-4, abs=0.0)
    assert model.los_probability(geometry)[0, 0] == pytest.approx(0.99997095, abs=1e-8)


# --- sub-6 Al-Hourani, eq. 6 and 7, Table I -------------------------------------------------

def sub6_scalar(x, y, h):
    d = math.sqrt(x * x + y * y + h * h)
    theta = _elevation_deg(x, y, h)
    p_los = 0.6 * (theta - 15) ** 0.11 if theta >= 15 else 0.0
    p_los = min(max(p_los, 0.0), 1.0)
    free_space = (C_LIGHT / (4 * math.pi * 2e9 * d)) ** 2
    return p_los, free_space * 10 ** (-1 / 10), free_space * 10 ** (-20 / 10)


@pytest.mark.parametrize(("name", "scalar"), [("mmwave-nyc", mmwave_scalar),
                                             ("sub6-al-hourani", sub6_scalar)])
def test_builtin_model_matches_scalar_formula(name, scalar):
    model = get_model_class(name)()
    geometry = _geometry(POINTS)
    computed = (model.los_probability(geometry), model.gain_los(geometry),
                model.gain_nlos(geometry))
    for i, point in enumerate(POINTS):
        for value, expected in zip(computed, scalar(*point), strict=True):
            assert value[i, 0] == pytest.approx(expected, rel=1e-12, abs=0.0)


def test_sub6_below_theta0_is_never_los():
    # h = 12 m at 99 m horizontal: theta = 6.9 deg < 15 deg
    model = get_model_class("sub6-al-hourani")()
    assert model.los_probability(_geometry([(70.0, -70.0, 12.0)]))[0, 0] == 0.0


def test_sub6_by_hand():
    # d = 50 m, f_c = 2 GHz: free-space gain (0.149896 / (4 pi 50))^2 = 5.6912e-8,
    # times 10^-0.1 (eta_LoS 1 dB) = 4.5209e-8
    model = get_model_class("sub6-al-hourani")()
    assert model.gain_los(_geometry([(0.0, 0.0, 50.0)]))[0, 0] == pytest.approx(4.5209e-8, abs=0.0,
                                                                                 rel=1e-4)


# --- the contract, for every discovered model (built-in and third-party) -------------------

WORKING = [name for name, info in discover().items() if info.status == "ok"]


@pytest.mark.parametrize("name", WORKING)
def test_channel_contract(name):
    model = get_model_class(name)()
    rng = np.random.default_rng(0)
    uav_m = np.column_stack([rng.uniform(-50, 50, 6), rng.uniform(-50, 50, 6),
                             rng.uniform(10, 200, 6)])
    users_m = rng.uniform(-50, 50, size=(6, 5, 2))
    geometry = LinkGeometry.between(uav_m, users_m)
    p_los = model.los_probability(geometry)
    g_los, g_nlos = model.gain_los(geometry), model.gain_nlos(geometry)
    for values in (p_los, g_los, g_nlos):
        assert values.shape == (6, 5)
        assert np.all(np.isfinite(values))
    assert np.all((p_los >= 0) & (p_los <= 1))
    assert np.all(g_los > 0) and np.all(g_nlos > 0)
    assert np.all(g_nlos <= g_los)
    expected = model.expected_gain(geometry)
    assert np.all((expected >= g_nlos * (1 - 1e-12)) & (expected <= g_los * (1 + 1e-12)))
    # same generator state, same draws
    draws_a = model.sample_los(geometry, np.random.default_rng(7))
    draws_b = model.sample_los(geometry, np.random.default_rng(7))
    assert draws_a.dtype == bool and np.array_equal(draws_a, draws_b)


@pytest.mark.parametrize("name", WORKING)
def test_gain_falls_with_distance(name):
    model = get_model_class(name)()
    horizontal_m = np.linspace(0.0, 140.0, 30)
    users_m = np.column_stack([horizontal_m, np.zeros_like(horizontal_m)])[None]
    for height_m in (30.0, 60.0, 150.0):
        geometry = LinkGeometry.between(np.array([[0.0, 0.0, height_m]]), users_m)
        assert np.all(np.diff(model.gain_los(geometry)[0]) < 0)
        assert np.all(np.diff(model.gain_nlos(geometry)[0]) < 0)


def test_builtins_are_discovered_through_entry_points():
    plugins = discover()
    for name in ("mmwave-nyc", "sub6-al-hourani"):
        assert plugins[name].status == "ok"
        assert plugins[name].package == "adaptsky"
