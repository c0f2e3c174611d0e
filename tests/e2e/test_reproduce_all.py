"""``adaptsky reproduce all --episodes 2 --steps 20 --seeds 1`` (seed 1 of every group), as a
user types it, once for the module (3 to 5 min on 2 cores, most of it E3's oracle on 100
layouts, so marked slow: ``pytest -m slow``): every shipped experiment reported, the index, the
last and best rows, the oracle's bound computed here from the eval files, the fresh-layout group
of E3, and the calls recorded. The default run reproduces single experiments
(tests/e2e/test_reproduce.py)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from adaptsky.experiment.plan import paper_experiments
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def everything(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("all")
    code = main(["reproduce", "all", "--episodes", "2", "--steps", "20", "--seeds", "1",
                 "--out", str(out), "--quiet"])
    assert code == 0
    return out


def _rates(path: Path) -> np.ndarray:
    record, methods = read_eval_metrics(path)
    assert record is not None and len(methods) == 1
    return next(iter(methods.values()))["mean_sum_rate_bps"]


def _row(report: str, claim: str) -> list[list[str]]:
    """The table rows of ``claim`` (its first row and the unlabelled ones after it)."""
    rows, inside = [], False
    for line in report.splitlines():
        if not line.startswith("|"):
            continue
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if cells[0] == claim:
            inside = True
        elif cells[0]:
            inside = False
        if inside:
            rows.append(cells)
    return rows


def test_every_experiment_is_reported_and_indexed(everything):
    index = (everything / "report.md").read_text()
    assert paper_experiments() == ["e1a", "e1b", "e2", "e3"]
    assert not (everything / "e4").exists() and not (everything / "bdq").exists()
    for name in paper_experiments():
        assert (everything / name / "report.md").is_file()
        assert f"[{name}/report.md]({name}/report.md)" in index
        assert (everything / name / f"{name}.png").stat().st_size > 10_000
    assert re.search(r"wall time of this call: (\d+ min )?\d+ s in all", index)
    # each experiment's claims table is in the index, word for word
    e3 = (everything / "e3" / "report.md").read_text()
    table = [line for line in e3.splitlines() if line.startswith("| ")]
    assert table and all(line in index for line in table)


def test_every_call_is_recorded_with_its_wall_time(everything):
    for name in paper_experiments():
        calls = json.loads((everything / name / "calls.json").read_text())
        assert len(calls) == 1
        assert calls[0]["wall_s"] > 0 and calls[0]["runs_trained"] >= 1
        assert "wall time: " in (everything / name / "report.md").read_text()


def test_e3_oracle_bound_is_the_oracles_gain_on_the_same_layouts(everything):
    """The reachable column: the oracle's share of layouts above SoA and its largest gain,
    computed here from the eval files by the plain formula."""
    evals = everything / "e3" / "evals"
    oracle, soa = _rates(evals / "oracle.h5"), _rates(evals / "soa.h5")
    gain = 100 * (oracle - soa) / soa
    report = (everything / "e3" / "report.md").read_text()
    largest = _row(report, "largest gain over SoA (%)")
    assert {row[4] for row in largest} == {f"{gain.max():+.1f}%"}
    beats = _row(report, "layouts where AdaptSky beats SoA (%)")
    assert {row[4] for row in beats} == {f"{100 * np.mean(oracle > soa):.1f}%"}
    if gain.max() < 90.25:  # the paper's +90.25%
        assert ("largest gain over SoA (%): the paper's +90.25% lies beyond the oracle's "
                f"{gain.max():+.1f}%") in report


def test_e3_has_last_best_and_fresh_layout_rows(everything):
    report = (everything / "e3" / "report.md").read_text()
    evals = everything / "e3" / "evals"
    soa = _rates(evals / "soa.h5")
    rows = _row(report, "median gain over SoA (%)")
    assert [row[2] for row in rows] == [
        "AdaptSky (dueling DQN), last policy", "AdaptSky (dueling DQN), best policy",
        "AdaptSky trained on fresh layouts (ours), last policy",
        "AdaptSky trained on fresh layouts (ours), best policy"]
    for row, name in zip(rows, ("adaptsky-seed1", "adaptsky-seed1-best", "generalist-seed1",
                                "generalist-seed1-best"), strict=True):
        mine = _rates(evals / f"{name}.h5")
        assert row[3] == f"{np.median(100 * (mine - soa) / soa):+.1f}%"
    # the fresh-layout group is measured against the baselines only, not the DQN
    assert len(_row(report, "mean gain over the DQN (%)")) == 2
    record, _ = read_eval_metrics(evals / "adaptsky-seed1-best.h5")
    assert record["policy"] == "best"


def test_a_best_row_without_greedy_evaluations_says_it_is_the_last(everything):
    """Two episodes hold no greedy evaluation (train.eval_every = 10): the best rows are the
    last policies, and the report says so."""
    evals = everything / "e3" / "evals"
    assert np.array_equal(_rates(evals / "adaptsky-seed1-best.h5"),
                          _rates(evals / "adaptsky-seed1.h5"))
    report = (everything / "e3" / "report.md").read_text()
    assert ("best policy: 3 runs had no greedy evaluation during training (train.eval_every), "
            "so their best policy is their last: adaptsky-seed1, dqn-seed1, generalist-seed1"
            ) in report


def test_e1a_and_e2_bounds(everything):
    e1a = (everything / "e1a" / "report.md").read_text()
    _, methods = read_eval_metrics(everything / "e1a" / "evals" / "oracle.h5")
    oracle = float(np.mean(next(iter(methods.values()))["mean_sum_rate_bps"]))
    soa = float(np.mean(_rates(everything / "e1a" / "evals" / "soa.h5")))
    bound = 100 * (oracle - soa) / soa
    assert _row(e1a, "gain over SoA")[0][4] == f"{bound:+.1f}%"
    assert f"gain over SoA: the paper's +163% lies beyond the oracle's {bound:+.1f}%" in e1a
    e2 = (everything / "e2" / "report.md").read_text()
    served = _row(e2, "highest minimum SE that AdaptSky serves for every user (bit/s/Hz)")
    assert [row[2] for row in served] == ["AdaptSky (dueling DQN), last policy",
                                          "AdaptSky (dueling DQN), best policy"]
    assert all(row[4].endswith("bit/s/Hz") for row in served)
    assert _row(e2, "highest minimum SE that SoA serves for every user (bit/s/Hz)")[0][2] \
        == "SoA"
