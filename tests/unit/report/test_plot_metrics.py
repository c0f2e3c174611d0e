"""``adaptsky plot --metric``: each metric draws the numbers the run file stores (read here with
h5py, not through the code under test), several metrics draw a panel each, and a metric that
is unknown, repeated or absent from the files is one line and exit code 1 with no file
written."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from adaptsky.report.plot_metrics import METRICS
from adaptsky.report.plot_runs import runs_figure
from adaptsky_cli.cli.main import main
from tests.helpers.cli import one_line
from tests.helpers.report import line_of, make_run, stored


@pytest.fixture
def run(tmp_path: Path) -> Path:
    # 12 and 15 episodes: cut to 12, window curve_window(12) = 1 (each episode as stored)
    return make_run(tmp_path / "run.h5", {0: 12, 1: 15}, {0: [10], 1: [10]})


@pytest.mark.parametrize(("metric", "name", "scale"), [
    ("sum-rate", "sum_rate_bps", 1e9), ("fairness", "fairness", 1.0),
    ("energy-efficiency", "energy_efficiency_bpj", 1e6)])
def test_learning_curve_metrics_draw_the_stored_episodes(run, metric, name, scale):
    figure = runs_figure(run_paths=[run], metric=metric).figure
    (axes,) = figure.axes
    x, y = line_of(axes)
    expected = np.mean([stored(run, 0, name), stored(run, 1, name)[:12]], axis=0)
    np.testing.assert_array_equal(x, np.arange(1, 13))
    np.testing.assert_allclose(y, expected / scale, rtol=1e-12)
    assert axes.get_ylabel() == {"sum-rate": r"$R_e^{\mathrm{tot}}$ (Gbit/s)",
                                 "fairness": "Jain's fairness $J_e$",
                                 "energy-efficiency": "energy efficiency (Mbit/J)"}[metric]


def test_curves_are_smoothed_like_r_e_tot(tmp_path):
    run = make_run(tmp_path / "long.h5", {0: 40})  # window curve_window(40) = 4
    x, y = line_of(runs_figure(run_paths=[run], metric="fairness").figure.axes[0])
    fairness = stored(run, 0, "fairness")
    np.testing.assert_array_equal(x, np.arange(4, 41))
    np.testing.assert_allclose(y, np.convolve(fairness, np.ones(4) / 4, mode="valid"),
                               rtol=1e-12)


def test_greedy_draws_the_stored_evaluations_with_their_episodes(tmp_path):
    run = make_run(tmp_path / "greedy.h5", {0: 30, 1: 40}, {0: [10, 20, 30], 1: [10, 20, 30, 40]})
    drawn = runs_figure(run_paths=[run], metric="greedy")
    (axes,) = drawn.figure.axes
    x, y = line_of(axes)
    (e0, s0), (e1, s1) = stored(run, 0, "score"), stored(run, 1, "score")
    np.testing.assert_array_equal(x, e0)  # the episodes both seeds were evaluated at
    np.testing.assert_array_equal(e1[:3], e0)
    np.testing.assert_allclose(y, (s0 + s1[:3]) / 2, rtol=1e-12)
    assert axes.get_ylabel() == "greedy score (% of oracle)"
    assert axes.get_lines()[0].get_marker() == "o"  # points, not a smoothed curve
    assert drawn.names == ["alpha_greedy"] and drawn.series[0].runs == 2


def test_greedy_without_an_oracle_is_a_rate(tmp_path):
    run = make_run(tmp_path / "sampled.h5", {0: 20}, {0: [10, 20]}, channel={"los": "sampled"})
    axes = runs_figure(run_paths=[run], metric="greedy").figure.axes[0]
    assert axes.get_ylabel() == r"greedy steady $R^{\mathrm{tot}}$ (bit/s)"


def test_several_metrics_draw_a_panel_each_and_one_csv(run, tmp_path):
    out = tmp_path / "figs" / "panels.svg"
    assert main(["plot", str(run), "--metric", "sum-rate,fairness,greedy", "--out",
                 str(out)]) == 0
    with out.with_suffix(".csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == ["episode", *(f"alpha{m}_{c}" for m in ("", "_fairness", "_greedy")
                                          for c in ("mean", "low", "high", "runs"))]
    assert [int(r["episode"]) for r in rows] == list(range(1, 13))
    tenth = rows[9]
    assert float(tenth["alpha_greedy_mean"]) == (60.0 + 61.0) / 2  # 50 + 10 + seed
    assert all(r["alpha_greedy_mean"] == "" for r in rows if r["episode"] != "10")
    fairness = np.mean([stored(run, 0, "fairness"), stored(run, 1, "fairness")[:12]], axis=0)
    np.testing.assert_allclose([float(r["alpha_fairness_mean"]) for r in rows], fairness,
                               rtol=1e-12)
    figure = runs_figure(run_paths=[run], metric="sum-rate,fairness,greedy").figure
    assert [a.get_ylabel() for a in figure.axes] == [
        r"$R_e^{\mathrm{tot}}$ (Gbit/s)", "Jain's fairness $J_e$", "greedy score (% of oracle)"]
    assert all(a.get_shared_x_axes().joined(a, figure.axes[0]) for a in figure.axes)


def test_sum_rate_csv_keeps_its_columns(run, tmp_path):
    out = tmp_path / "curves.png"
    assert main(["plot", str(run), "--out", str(out)]) == 0
    header = out.with_suffix(".csv").read_text().splitlines()[0]
    assert header == "episode,alpha_mean,alpha_low,alpha_high,alpha_runs"


def test_bad_metrics_are_one_line_and_write_nothing(tmp_path, capsys):
    bare = make_run(tmp_path / "bare.h5", {0: 12})  # no greedy evaluation
    out = tmp_path / "out" / "fig.png"
    every = ("sum-rate, fairness, greedy, energy-efficiency, reward, height, epsilon, loss, "
             "energy, outage, least-rate, p5-rate")
    cases = {"sum-rate,power": f"--metric: unknown metric 'power'; choose from {every}, or "
                               "several comma-separated (e.g. sum-rate,fairness)",
             "fairness,fairness": "--metric: fairness given more than once; name each metric "
                                  f"once (from {every})",
             "greedy": f"{bare}: no seed has a greedy evaluation during training "
                       "(train.eval_every is 0, the runs are shorter than it, or they were made "
                       "before evaluations existed); nothing to plot for --metric greedy"}
    for metric, line in cases.items():
        usage = metric != "greedy"  # a malformed value is a usage error (issue 52)
        assert main(["plot", str(bare), "--metric", metric, "--out", str(out)]) == 1 + usage
        assert one_line(capsys) == (f"adaptsky plot: {line}; see 'adaptsky plot --help'"
                                    if usage else line)
    assert main(["plot", str(bare), "--out", str(tmp_path / "fig.jpg")]) == 1
    assert one_line(capsys).endswith("a figure file must end in .png, .pdf or .svg (it has "
                                     "'.jpg')")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bare.h5"]


def test_runs_measured_differently_share_no_panel(tmp_path, capsys):
    pct = make_run(tmp_path / "pct.h5", {0: 20}, {0: [10]})
    rate = make_run(tmp_path / "rate.h5", {0: 20}, {0: [10]}, channel={"los": "sampled"})
    assert main(["plot", str(pct), str(rate), "--metric", "greedy",
                 "--out", str(tmp_path / "g.png")]) == 1
    assert one_line(capsys) == ("--metric greedy: pct.h5 and rate.h5 measure it differently "
                                "(greedy score, % of oracle; greedy steady "
                                r"$R^{\mathrm{tot}}$, bit/s); plot them apart").replace(
        "pct.h5", str(pct)).replace("rate.h5", str(rate))
    assert not (tmp_path / "g.png").exists()


def test_help_lists_every_metric(capsys):
    assert main(["plot", "--help"]) == 0
    shown = " ".join(capsys.readouterr().out.split())
    for name in METRICS:
        assert name in shown


def test_real_run_curves(tiny_run):
    # the session's tiny run: 2 seeds of 2 episodes (window 1)
    figure = runs_figure(run_paths=[tiny_run], metric="sum-rate,fairness").figure
    for axes, name, scale in zip(figure.axes, ("sum_rate_bps", "fairness"), (1e9, 1.0),
                                 strict=True):
        _, y = line_of(axes)
        expected = np.mean([stored(tiny_run, s, name) for s in (0, 1)], axis=0) / scale
        np.testing.assert_allclose(y, expected, rtol=1e-12)


def test_profile_draws_the_share_of_seeds_above_each_threshold(tmp_path):
    # four seeds evaluated at episodes 10 and 20: last scores 50 + 20 + seed = 70, 71, 72, 73
    run = make_run(tmp_path / "four.h5", dict.fromkeys(range(4), 20),
                   {seed: [10, 20] for seed in range(4)})
    out = tmp_path / "profile.png"
    assert main(["plot", str(run), "--profile", "last", "--out", str(out)]) == 0
    with out.with_suffix(".csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    last = [stored(run, seed, "score")[1][-1] for seed in range(4)]
    assert sorted(last) == [70.0, 71.0, 72.0, 73.0]
    for row in rows:
        tau = float(row["tau"])
        assert float(row["alpha_mean"]) == sum(s > tau for s in last) / 4  # by hand
        assert float(row["alpha_low"]) <= float(row["alpha_mean"]) <= float(row["alpha_high"])
        assert row["alpha_runs"] == "4"
    assert float(rows[0]["alpha_mean"]) == 1.0 and float(rows[-1]["alpha_mean"]) == 0.0
    assert out.is_file()


def test_profile_refuses_an_unknown_policy_and_curve_options(tmp_path, capsys):
    run = make_run(tmp_path / "run.h5", {0: 20}, {0: [10, 20]})
    assert main(["plot", str(run), "--profile", "first"]) == 2
    assert "--profile: unknown policy 'first'; choose from last, best" in one_line(capsys)
    assert main(["plot", str(run), "--profile", "last", "--metric", "fairness"]) == 2
    assert "without --metric and --band" in one_line(capsys)
    assert not list(tmp_path.glob("*.png"))
