"""The lattice the actions reach and exploring starts drawn on it (docs/training.md,
"Exploring starts"), against values listed by hand."""

from __future__ import annotations

import numpy as np

from adaptsky.sim.lattice import axis_lattice, exploring_shares, share_lattice
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
