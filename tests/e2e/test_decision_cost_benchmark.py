"""benchmarks/decision_cost.py (issue 55, item 4): it runs on one unseen layout and prints
the policy's and the oracle's figures, its ratios the quotients of the figures it printed.
No time is asserted: the benchmark is a script."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from tests.conftest import ROOT


def test_the_decision_cost_prints_figures_and_their_ratios():
    printed = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "decision_cost.py"), "--layouts", "1",
         "--steps", "5"], cwd=ROOT, capture_output=True, text=True, check=True, timeout=600,
        env={**os.environ, "ADAPTSKY_CACHE_DIR": "off"}).stdout
    decision_us = float(re.search(r"policy: ([\d.]+) us per decision", printed).group(1))
    episode_s = float(re.search(r"episode .*: ([\d.]+) ms per layout", printed).group(1)) / 1e3
    search_s = float(re.search(r"oracle: ([\d.]+) s per layout", printed).group(1))
    decisions = float(re.search(r"one oracle search = ([\d,]+) decisions", printed)
                      .group(1).replace(",", ""))
    episodes = float(re.search(r"= ([\d.,]+) episodes", printed).group(1).replace(",", ""))
    assert "nyc_mmwave_any_layout, 1 unseen layouts, a fresh dqn policy" in printed
    assert decision_us > 0 and episode_s > 0 and search_s > 0
    # the ratios are of the unrounded figures (4 digits printed): within their rounding
    assert decisions == pytest.approx(search_s / (decision_us * 1e-6), rel=1e-3)
    assert episodes == pytest.approx(search_s / episode_s, rel=1e-3)
    assert re.search(r"optimum's mean ([\d.]+) Gbit/s", printed)
