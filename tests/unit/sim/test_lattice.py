"""The lattice the actions reach and exploring starts drawn on it (docs/training.md,
"Exploring starts"), against values listed by hand."""

from __future__ import annotations

import numpy as np

from adaptsky.sim.lattice import (
    axis_lattice,
    exploring_positions,
    exploring_shares,
    share_lattice,
)
from tests.conftest import make_scenario


def test_axis_lattice_is_the_start_plus_whole_steps_inside_the_bounds():
    np.testing.assert_allclose(axis_lattice(0.3, 0.25, 0.25, 0.75), [0.3, 0.55])
    np.testing.assert_allclose(axis_lattice(50.0, 1.0, 48.0, 51.5), [48.0, 49.0, 50.0, 51.0])
    # a bound met to within 1e-9 is inside
    np.testing.assert_allclose(axis_lattice(0.0, 0.1, -0.3 + 1e-12, 0.2), [-0.3, -0.2, -0.1,
                                                                        0.0, 0.1, 0.2])


def test_the_paper_share_lattice_is_0_01_to_0_99():
    shares = share_lattice(make_scenario())
    assert len(shares) == 99
    np.testing.assert_allclose(shares, np.arange(1, 100) / 100, atol=1e-12)


def test_exploring_shares_are_uniform_on_the_lattice_one_generator_per_environment():
    scenario = make_scenario(uav={"start_alpha": 0.3, "power_step": 0.25})
    draws = exploring_shares(scenario, [np.random.default_rng(s) for s in (1, 2)], (4000, 2))
    assert draws.shape == (2, 4000, 2)
    values, counts = np.unique(draws, return_counts=True)
    np.testing.assert_allclose(values, [0.3, 0.55])
    assert abs(counts[0] / counts.sum() - 0.5) < 0.02   # 16000 fair coin flips: sd 0.004
    # environment b draws from its generator alone
    again = exploring_shares(scenario, [np.random.default_rng(2)], (4000, 2))
    np.testing.assert_array_equal(again[0], draws[1])


def test_exploring_positions_one_uav_are_its_lattice_points_drawn_x_y_h():
    # area 100 m, steps (2, 5, 10) m from (1, 0, 50), heights 20 .. 90 m: by hand
    scenario = make_scenario(uav={"start_m": [1.0, 0.0, 50.0], "step_m": [2.0, 5.0, 10.0],
                                  "min_height_m": 20.0, "max_height_m": 90.0})
    xs, ys, hs = np.arange(-49, 50, 2.0), np.arange(-50, 51, 5.0), np.arange(20, 91, 10.0)
    assert (len(xs), len(ys), len(hs)) == (50, 21, 8)
    draws = exploring_positions(scenario, [np.random.default_rng(s) for s in (3, 4)])
    assert draws.shape == (2, 1, 3)
    for b, seed in enumerate((3, 4)):
        rng = np.random.default_rng(seed)
        expected = [xs[rng.integers(50)], ys[rng.integers(21)], hs[rng.integers(8)]]
        np.testing.assert_array_equal(draws[b, 0], expected)


def test_exploring_positions_keep_several_uavs_apart_and_cover_the_lattice():
    scenario = make_scenario(uav={"count": 3, "min_separation_m": 30.0},
                             users={"count": 6, "placement": "uniform"})
    rngs = [np.random.default_rng(s) for s in range(400)]
    draws = exploring_positions(scenario, rngs)
    assert draws.shape == (400, 3, 3)
    x_m, y_m = draws[..., 0], draws[..., 1]
    apart_m = np.hypot(x_m[:, :, None] - x_m[:, None, :], y_m[:, :, None] - y_m[:, None, :])
    assert (apart_m[:, ~np.eye(3, dtype=bool)] >= 30.0).all()
    starts = np.array(scenario.uav_start_positions_m)
    # whole 1 m steps from each UAV's own start, inside |x|, |y| <= 50 and 10 .. 200 m
    np.testing.assert_allclose(draws - starts, np.round(draws - starts), atol=1e-9)
    assert (np.abs(draws[..., :2]) <= 50 + 1e-9).all()
    assert ((draws[..., 2] >= 10) & (draws[..., 2] <= 200)).all()
    # 400 x 3 heights cover the 191 lattice heights' range
    assert draws[..., 2].min() < 20 and draws[..., 2].max() > 190


def test_exploring_positions_refused_with_buildings():
    import pytest

    from adaptsky.errors import ScenarioError

    with pytest.raises(ScenarioError, match="exploring_starts = 'positions' draws start "
                       "positions without regard to buildings"):
        make_scenario(train={"exploring_starts": "positions"}, channel={"los": "geometric"},
                      world={"buildings": "generated", "city": "urban"})
