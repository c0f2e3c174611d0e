"""``adaptsky plot --metric`` draws every per-episode series a run file stores
(docs/file-format.md, ``/seeds/<S>/episodes/``): the numbers drawn are the stored ones (read
here with h5py), the loss's NaN episodes (before the first update) are gaps, not a poisoned
curve, and an unknown name is one line listing every allowed one."""

from __future__ import annotations

import csv
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.report.plot_metrics import METRICS
from adaptsky.report.plot_runs import runs_figure
from adaptsky.store.checksums import seal
from adaptsky.store.layout import ENERGY_EPISODES, EPISODES, SERVICE_EPISODES
from adaptsky_cli.cli.main import main
from tests.helpers.cli import one_line
from tests.helpers.report import line_of, make_run, stored

SERIES = {"sum-rate": "sum_rate_bps", "fairness": "fairness",
          "energy-efficiency": "energy_efficiency_bpj", "reward": "reward",
          "height": "mean_height_m", "epsilon": "epsilon", "loss": "loss", "energy": "energy_j",
          "outage": "outage_share", "least-rate": "mean_least_rate_bps",
          "p5-rate": "p5_rate_bps"}


@pytest.fixture
def run(tmp_path: Path) -> Path:
    # 12 and 15 episodes: cut to 12, window curve_window(12) = 1 (each episode as stored)
    return make_run(tmp_path / "run.h5", {0: 12, 1: 15})


def set_stored(path: Path, seed: int, name: str, values: np.ndarray) -> None:
    with h5py.File(path, "r+") as file:
        dataset = file[f"seeds/{seed}/episodes/{name}"]
        dataset[: len(values)] = values
        seal(dataset, dataset[()])  # its checksum made current (store.checksums)


def test_every_scalar_per_episode_series_of_the_file_is_a_metric():
    scalar = {f.name for f in (*EPISODES, *ENERGY_EPISODES, *SERVICE_EPISODES)
              if len(f.shape) == 1}
    assert set(SERIES.values()) == scalar
    assert set(METRICS) == {*SERIES, "greedy"}


@pytest.mark.parametrize(("metric", "label"), [
    ("reward", "return (sum of the episode's rewards)"), ("height", "mean UAV height (m)"),
    ("epsilon", r"exploration rate $\epsilon$"), ("loss", "mean TD loss"),
    ("energy", "energy per episode (J)"), ("outage", "share of user-steps in outage")])
def test_the_other_series_draw_what_is_stored(run, metric, label):
    (axes,) = runs_figure(run_paths=[run], metric=metric).figure.axes
    x, y = line_of(axes)
    name = SERIES[metric]
    np.testing.assert_array_equal(x, np.arange(1, 13))
    np.testing.assert_allclose(y, np.mean([stored(run, 0, name), stored(run, 1, name)[:12]],
                                          axis=0), rtol=1e-12)
    assert axes.get_ylabel() == label


def test_energy_is_shown_in_kj_when_large(run):
    for seed, episodes in ((0, 12), (1, 15)):
        set_stored(run, seed, "energy_j", np.linspace(1500.0, 2500.0, episodes))
    (axes,) = runs_figure(run_paths=[run], metric="energy").figure.axes
    assert axes.get_ylabel() == "energy per episode (kJ)"
    expected = (np.linspace(1500.0, 2500.0, 12) + np.linspace(1500.0, 2500.0, 15)[:12]) / 2
    np.testing.assert_allclose(line_of(axes)[1] * 1e3, expected, rtol=1e-12)


def test_loss_nan_before_the_first_update_is_a_gap(tmp_path):
    run = make_run(tmp_path / "long.h5", {0: 40, 1: 40})  # window curve_window(40) = 4
    for seed in (0, 1):
        set_stored(run, seed, "loss", np.full(3, np.nan))  # no update in episodes 1-3
    x, y = line_of(runs_figure(run_paths=[run], metric="loss").figure.axes[0])
    loss = np.mean([stored(run, 0, "loss"), stored(run, 1, "loss")], axis=0)
    np.testing.assert_array_equal(x, np.arange(4, 41))
    assert np.isnan(y[:3]).all()  # the windows ending at episodes 4-6 hold a NaN
    np.testing.assert_allclose(y[3:], np.convolve(loss[3:], np.ones(4) / 4, mode="valid"),
                               rtol=1e-12)
    out = tmp_path / "loss.svg"
    assert main(["plot", str(run), "--metric", "loss", "--out", str(out)]) == 0
    with out.with_suffix(".csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["episode"] for r in rows[:4]] == ["4", "5", "6", "7"]
    assert [r["alpha_loss_mean"] for r in rows[:3]] == ["", "", ""]  # no point: empty cells
    assert float(rows[3]["alpha_loss_mean"]) == pytest.approx(float(y[3]), rel=1e-12)


def test_a_loss_not_yet_learnt_is_one_line(tmp_path, capsys):
    run = make_run(tmp_path / "fresh.h5", {0: 5})
    set_stored(run, 0, "loss", np.full(5, np.nan))
    assert main(["plot", str(run), "--metric", "sum-rate,loss", "--out",
                 str(tmp_path / "f.png")]) == 1
    assert one_line(capsys) == (f"{run}: no seed has a loss yet (NaN until the first update, "
                                "once the replay memory holds a batch, agent.batch_size "
                                "steps); nothing to plot for --metric loss")
    assert not (tmp_path / "f.png").exists()


@pytest.mark.parametrize(("name", "guess"), [
    ("los", "did you mean 'loss'? "), ("mean_height_m", "did you mean 'height'? "),
    ("sum_rate_bps", "did you mean 'sum-rate'? "), ("mean_rate_bps", "")])
def test_an_unknown_metric_lists_every_allowed_one(run, tmp_path, capsys, name, guess):
    assert main(["plot", str(run), "--metric", f"epsilon,{name}", "--out",
                 str(tmp_path / "f.png")]) == 2
    assert one_line(capsys) == (
        f"adaptsky plot: --metric: unknown metric '{name}'; {guess}choose from sum-rate, "
        "fairness, greedy, energy-efficiency, reward, height, epsilon, loss, energy, outage, "
        "least-rate, p5-rate, or several comma-separated (e.g. sum-rate,fairness); see "
        "'adaptsky plot --help'")


def test_a_real_run(tiny_run, tmp_path):
    """The session's tiny run (2 seeds of 2 episodes: no update, so no loss)."""
    out = tmp_path / "all.png"
    assert main(["plot", str(tiny_run), "--metric", "reward,height,epsilon,energy", "--out",
                 str(out)]) == 0
    with out.with_suffix(".csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["episode"] for r in rows] == ["1", "2"]
    for metric in ("reward", "height", "epsilon", "energy"):
        expected = np.mean([stored(tiny_run, s, SERIES[metric]) for s in (0, 1)], axis=0)
        np.testing.assert_allclose([float(r[f"nyc_mmwave_{metric}_mean"]) for r in rows],
                                   expected, rtol=1e-12)
