"""Slow checks, left out of the default run: `pytest -m slow`."""

import pytest

from adaptsky.report.summary import summarize
from adaptsky.rollouts.oracle import oracle
from adaptsky.scenario import load_scenario
from adaptsky.sim.layout import user_layouts
from adaptsky.training import api
from tests.conftest import SCENARIOS


@pytest.mark.slow
def test_paper_length_training_comes_close_to_the_oracle(tmp_path):
    # measured: R_e^tot 47.07 Gbit/s against the oracle's 49.09 (95.9%), 11 minutes
    path = SCENARIOS / "nyc_mmwave.toml"
    run, _ = api.train(scenario_path=path, out=tmp_path / "paper.h5", seeds=[0], workers=1,
                       quiet=True)
    scenario = load_scenario(path)
    ceiling = oracle(scenario, user_layouts(scenario, 1)).objective_bps[0]
    assert summarize(run)["sum_rate_bps"]["mean"] >= 0.9 * ceiling
