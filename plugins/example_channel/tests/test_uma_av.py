"""The example third-party plugin ``uma-av`` (plugins/example_channel), 3GPP TR 36.777 Annex B.

The ``reference_*`` functions are plain scalar re-implementations written with ``math``
straight from TR 36.777 Tables B-1 and B-2 (and TR 38.901 Table 7.4.2-1 UMa for h <= 22.5 m);
they do not call the plugin's own helpers. The plugin must be installed
(``pip install -e "plugins/example_channel[test]"``): this module fails, it does not skip,
without it. Run from the plugin's folder: ``python -m pytest``; adaptsky's own test run
includes it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from adaptsky_example_channel.uma_av import UmaAv
from pydantic import ValidationError

from adaptsky.channels import LinkGeometry
from adaptsky.channels.checker import check_channel_model
from adaptsky.channels.registry import discover

HEIGHTS_M = (12.0, 20.0, 50.0, 150.0)  # C' = 0, C' > 0 (TR 38.901), UMa-AV, always LoS
HORIZONTALS_M = (0.0, 10.0, 30.0, 300.0)
CARRIERS_HZ = (2e9, 0.7e9, 3.5e9)
REL = 1e-12  # relative only: gains are ~1e-8 to 1e-14, below pytest.approx's default abs


def close(expected: float):
    return pytest.approx(expected, rel=REL, abs=0.0)


# --- scalar references, straight from the tables ------------------------------------------


def reference_p_los(h: float, d2d: float) -> float:
    """Table B-1 UMa-AV; TR 38.901 UMa for h <= 22.5 m; 1 above 100 m."""
    if h <= 22.5:
        if d2d <= 18:
            return 1.0
        c_prime = 0.0 if h <= 13 else ((h - 13) / 10) ** 1.5
        p = (18 / d2d + math.exp(-d2d / 63) * (1 - 18 / d2d)) * (
            1 + c_prime * 5 / 4 * (d2d / 100) ** 3 * math.exp(-d2d / 150))
    elif h <= 100:
        d1 = max(460 * math.log10(h) - 700, 18)
        p1 = 4300 * math.log10(h) - 3800
        if d2d <= d1:
            return 1.0
        p = d1 / d2d + math.exp(-d2d / p1) * (1 - d1 / d2d)
    else:
        return 1.0
    return min(max(p, 0.0), 1.0)


def reference_pl_los_db(d3d: float, fc_ghz: float) -> float:
    """Table B-2 UMa-AV LoS."""
    return 28.0 + 22 * math.log10(d3d) + 20 * math.log10(fc_ghz)


def reference_pl_nlos_db(h: float, d3d: float, fc_ghz: float) -> float:
    """Table B-2 UMa-AV NLoS, h clamped into [10, 100] m, never better than LoS."""
    h = min(max(h, 10.0), 100.0)
    pl = -17.5 + (46 - 7 * math.log10(h)) * math.log10(d3d) + 20 * math.log10(
        40 * math.pi * fc_ghz / 3)
    return max(pl, reference_pl_los_db(d3d, fc_ghz))


def gain(pl_db: float) -> float:
    return 10 ** (-pl_db / 10)


# --- geometry -----------------------------------------------------------------------------


def grid_geometry(heights_m, horizontals_m) -> LinkGeometry:
    """One UAV per height (B), one user per ground distance (N), in varied directions."""
    heights_m = np.asarray(heights_m, dtype=float)
    horizontals_m = np.asarray(horizontals_m, dtype=float)
    uav_m = np.stack([np.full_like(heights_m, 5.0), np.full_like(heights_m, -3.0), heights_m],
                     axis=1)  # (B, 3)
    angles = np.linspace(0.0, 2 * np.pi, horizontals_m.size, endpoint=False)
    offsets_m = horizontals_m[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    users_m = uav_m[:, None, :2] + offsets_m[None, :, :]  # (B, N, 2)
    return LinkGeometry.between(uav_m, users_m)


POINTS = [(h, d) for h in HEIGHTS_M for d in HORIZONTALS_M]


# --- registration and parameters ----------------------------------------------------------


def test_registered_as_uma_av():
    info = discover()["uma-av"]
    assert info.status == "ok", info.error
    assert info.model is UmaAv
    assert info.package == "adaptsky-example-channel"
    assert info.description


def test_default_params():
    model = UmaAv()
    assert isinstance(model.params, UmaAv.Params)
    assert model.params.carrier_hz == 2e9
    assert UmaAv(UmaAv.Params(carrier_hz=2e9)).params == model.params
    for name, field in UmaAv.Params.model_fields.items():
        assert field.description, name


@pytest.mark.parametrize("bad", [{"carrier_hz": -1}, {"carrier_hz": 0.0}, {"carrier_ghz": 2.0},
                                 {"carrier_hz": "2e9"}, {"carrier_hz": math.inf}])
def test_params_reject_bad_values_and_unknown_keys(bad):
    with pytest.raises(ValidationError):
        UmaAv.Params(**bad)


# --- formulas against the scalar references -----------------------------------------------


def test_los_probability_matches_table_b1():
    p_los = UmaAv().los_probability(grid_geometry(HEIGHTS_M, HORIZONTALS_M))
    for b, h in enumerate(HEIGHTS_M):
        for n, d in enumerate(HORIZONTALS_M):
            assert p_los[b, n] == close(reference_p_los(h, d)), (h, d)


@pytest.mark.parametrize("carrier_hz", CARRIERS_HZ)
def test_gains_match_table_b2(carrier_hz):
    geometry = grid_geometry(HEIGHTS_M, HORIZONTALS_M)
    model = UmaAv(UmaAv.Params(carrier_hz=carrier_hz))
    g_los, g_nlos = model.gain_los(geometry), model.gain_nlos(geometry)
    fc_ghz = carrier_hz / 1e9
    for b, h in enumerate(HEIGHTS_M):
        for n, d in enumerate(HORIZONTALS_M):
            d3d = math.hypot(h, d)
            assert g_los[b, n] == close(gain(reference_pl_los_db(d3d, fc_ghz))), (h, d)
            assert g_nlos[b, n] == close(gain(reference_pl_nlos_db(h, d3d, fc_ghz))), (h, d)


def test_hand_computed_values():
    model = UmaAv()
    # h = 100 m straight above the user: d3D = 100 m, f_c = 2 GHz.
    # PL_LoS = 28 + 22 * 2 + 20 log10(2) = 28 + 44 + 6.0206 = 78.0206 dB.
    # PL_NLoS = -17.5 + (46 - 7 * 2) * 2 + 20 log10(40 pi 2 / 3) = -17.5 + 64 + 38.4624
    #         = 84.9624 dB.
    above = grid_geometry([100.0], [0.0])
    assert 10 * math.log10(model.gain_los(above)[0, 0]) == pytest.approx(-78.0206, abs=1e-4)
    assert 10 * math.log10(model.gain_nlos(above)[0, 0]) == pytest.approx(-84.9624, abs=1e-4)
    # TR 38.901 UMa, h = 12 m (C' = 0), d2D = 30 m:
    # P = 18/30 + exp(-30/63) (1 - 18/30) = 0.6 + 0.621145 * 0.4 = 0.848458.
    # UMa-AV, h = 50 m, d2D = 300 m: d1 = 460 * 1.69897 - 700 = 81.526 m,
    # p1 = 4300 * 1.69897 - 3800 = 3505.57 m,
    # P = 81.526/300 + exp(-300/3505.57) (1 - 81.526/300) = 0.271754 + 0.917982 * 0.728246
    #   = 0.940270.
    p_los = model.los_probability(grid_geometry([12.0, 50.0], [30.0, 300.0]))
    assert p_los[0, 0] == pytest.approx(0.848458, abs=1e-6)
    assert p_los[1, 1] == pytest.approx(0.940270, abs=1e-6)


def test_nlos_never_better_than_los_even_below_the_clamp():
    # h = 5 m over the user: the NLoS formula (h clamped to 10 m) would beat LoS; max() applies.
    geometry = grid_geometry([5.0], [0.0])
    model = UmaAv()
    assert reference_pl_nlos_db(5.0, 5.0, 2.0) == reference_pl_los_db(5.0, 2.0)
    assert model.gain_nlos(geometry)[0, 0] == close(model.gain_los(geometry)[0, 0])


# --- properties over a dense grid ---------------------------------------------------------

DENSE_HEIGHTS_M = np.array([1.5, 5.0, 10.0, 13.0, 17.0, 22.5, 22.6, 40.0, 100.0, 100.1, 250.0,
                            400.0])
DENSE_HORIZONTALS_M = np.concatenate([[0.0], np.geomspace(0.5, 5000.0, 200)])


@pytest.mark.filterwarnings("error")  # no numpy divide/overflow warnings, even at d2D = 0
@pytest.mark.parametrize("carrier_hz", CARRIERS_HZ)
def test_shapes_finite_and_bounds(carrier_hz):
    geometry = grid_geometry(DENSE_HEIGHTS_M, DENSE_HORIZONTALS_M)
    model = UmaAv(UmaAv.Params(carrier_hz=carrier_hz))
    p_los = model.los_probability(geometry)
    g_los, g_nlos = model.gain_los(geometry), model.gain_nlos(geometry)
    for values in (p_los, g_los, g_nlos, model.expected_gain(geometry)):
        assert values.shape == geometry.shape
        assert values.dtype == np.float64
        assert np.all(np.isfinite(values))
    assert np.all((p_los >= 0) & (p_los <= 1))
    assert np.all(g_los > 0) and np.all(g_nlos > 0)
    assert np.all(g_nlos <= g_los)
    assert np.all(p_los[DENSE_HEIGHTS_M > 100.0] == 1.0)


def test_gains_decrease_with_distance():
    geometry = grid_geometry(DENSE_HEIGHTS_M, DENSE_HORIZONTALS_M)
    model = UmaAv()
    assert np.all(np.diff(model.gain_los(geometry), axis=1) < 0)
    assert np.all(np.diff(model.gain_nlos(geometry), axis=1) < 0)


def test_sample_los_is_seeded():
    geometry = grid_geometry(DENSE_HEIGHTS_M, DENSE_HORIZONTALS_M)
    model = UmaAv()
    first = model.sample_los(geometry, np.random.default_rng(7))
    again = model.sample_los(geometry, np.random.default_rng(7))
    assert first.shape == geometry.shape and first.dtype == np.bool_
    np.testing.assert_array_equal(first, again)
    assert np.all(first[DENSE_HEIGHTS_M > 100.0])  # P_LoS = 1 there


@pytest.mark.parametrize("carrier_hz", [0.5e9, 2e9, 100e9])  # the range's ends and the default
def test_follows_the_plugin_contract(carrier_hz):
    """Every rule of adaptsky's plugin contract (adaptsky plugins check uma-av), at the
    default carrier and at both ends of its allowed range."""
    assert check_channel_model(UmaAv, UmaAv.Params(carrier_hz=carrier_hz)) == []


def test_follows_the_plugin_contract_with_shadowing():
    assert UmaAv.contract_version == 2
    assert check_channel_model(UmaAv, UmaAv.Params(shadowing=True)) == []


# --- contract 2: user antennas above the ground, shadow fading -----------------------------


def test_gains_count_the_users_antenna_height():
    # h = 50 m, user antenna 1.5 m up, d2D = 30 m: d3D = sqrt(30^2 + 48.5^2) = 57.0285 m,
    # PL_LoS = 28 + 22 log10(57.0285) + 20 log10(2) = 28 + 22 * 1.756092 + 6.0206
    #        = 28 + 38.6340 + 6.0206 = 72.6546 dB
    uav_m = np.array([[0.0, 0.0, 50.0]])
    geometry = LinkGeometry.between(uav_m, np.array([[[30.0, 0.0]]]), user_height_m=1.5)
    d3d = math.hypot(30.0, 48.5)
    assert d3d == pytest.approx(57.0285, abs=1e-4)
    model = UmaAv()
    assert model.gain_los(geometry)[0, 0] == close(gain(reference_pl_los_db(d3d, 2.0)))
    assert -10 * math.log10(model.gain_los(geometry)[0, 0]) == pytest.approx(72.6546, abs=1e-4)
    assert model.gain_nlos(geometry)[0, 0] == close(gain(reference_pl_nlos_db(50.0, d3d, 2.0)))


def reference_shadowing_std_db(h: float, los: bool) -> float:
    """TR 36.777 Annex B, UMa-AV: 4.64 exp(-0.0066 h) LoS above 22.5 m (4 dB, TR 38.901 UMa,
    at or below), 6 dB NLoS."""
    if not los:
        return 6.0
    return 4.64 * math.exp(-0.0066 * h) if h > 22.5 else 4.0


def test_shadowing_std_follows_tr_36777():
    # by hand: h = 100 m LoS, 4.64 exp(-0.66) = 4.64 * 0.516851 = 2.398190 dB
    geometry = grid_geometry([20.0, 50.0, 100.0], [0.0, 30.0])
    los = np.array([[True, False]] * 3)
    std_db = UmaAv().shadowing_std_db(geometry, los)
    assert std_db[2, 0] == pytest.approx(2.398190, abs=1e-6)
    for b, h in enumerate((20.0, 50.0, 100.0)):
        for n in range(2):
            assert std_db[b, n] == close(reference_shadowing_std_db(h, bool(los[b, n])))


def test_shadowing_draws_have_the_standards_spread():
    """200,000 draws per link: the spread of 10 log10(factor) is sigma_SF within 1% (the
    standard error of a sample std is sigma / sqrt(2 n) = 0.16%), its mean 0 dB within 0.05 dB."""
    model = UmaAv(UmaAv.Params(shadowing=True))
    assert model.fading_enabled() and not UmaAv().fading_enabled()
    geometry = grid_geometry(np.full(200_000, 100.0), [30.0, 60.0])  # 200,000 UAVs at 100 m
    los = np.zeros(geometry.shape, dtype=bool)
    los[:, 0] = True
    draws_db = -10 * np.log10(model.sample_fading(geometry, los, np.random.default_rng(3)))
    assert draws_db[:, 0].std() == pytest.approx(2.398190, rel=0.01)
    assert draws_db[:, 1].std() == pytest.approx(6.0, rel=0.01)
    assert np.abs(draws_db.mean(axis=0)).max() < 0.05
    geometry, los = grid_geometry([100.0], [30.0, 60.0]), los[:1]
    again = model.sample_fading(geometry, los, np.random.default_rng(5))
    np.testing.assert_array_equal(again, model.sample_fading(geometry, los,
                                                             np.random.default_rng(5)))
