"""docs/model.md section 8's reference numbers: training layout, UAV at (0, 0, 50), all LoS,
alpha = 0.5 in both clusters, spectral efficiency per user in bit/s/Hz, listed order."""

import numpy as np
import pytest

from adaptsky.sim.network import NetworkBatch
from tests.conftest import SUB6_RADIO, make_scenario


def _spectral_efficiency(scenario):
    env = NetworkBatch(scenario, num_envs=1, seed=0)
    _, state = env.reset()
    return state.rate_bps[0] / scenario.radio.bandwidth_hz, state.fairness[0]


def test_mmwave_with_5db_noise_figure():
    se, fairness = _spectral_efficiency(make_scenario(radio={"noise_figure_db": 5.0}))
    assert se == pytest.approx([5.245, 0.954, 5.134, 0.952], abs=5e-4)
    assert se.sum() == pytest.approx(12.284, abs=5e-4)
    assert fairness == pytest.approx(0.678, abs=5e-4)


def test_sub6_with_paper_noise():
    se, _ = _spectral_efficiency(make_scenario(radio=SUB6_RADIO,
                                               channel={"model": "sub6-al-hourani"}))
    assert se == pytest.approx([13.667, 1.000, 13.553, 1.000], abs=5e-4)
    assert se.sum() == pytest.approx(29.22, abs=5e-3)


def test_every_environment_of_a_batch_sees_the_same_listed_layout():
    env = NetworkBatch(make_scenario(radio={"noise_figure_db": 5.0}), num_envs=3, seed=0)
    _, state = env.reset()
    assert np.all(state.rate_bps == state.rate_bps[0])
