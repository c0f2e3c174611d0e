"""Figures: the curve numbers against hand-computed values, every figure function writes a
readable PNG atomically, and ``adaptsky plot`` on tiny synthetic run files writes the trailing
means it draws to a CSV."""

from __future__ import annotations

import csv
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.report.curves import band, curve_window, gain_stats, trailing_mean
from adaptsky.report.figure_files import save_figure
from adaptsky.report.figures import (
    Level,
    Series,
    layout_gains,
    learning_curves,
    min_se_sweep,
)
from adaptsky.report.plot_runs import default_figure_path, plot_runs
from adaptsky.store.run_file import (
    EPISODE_METRICS,
    PER_USER_METRICS,
    append_checkpoint,
    create_run,
)
from adaptsky_cli.cli.main import main
from tests.conftest import make_scenario
from tests.helpers.report import two_series

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
GBPS = 1e9


# ---- curves ---------------------------------------------------------------------------------

@pytest.mark.parametrize(("episodes", "window"), [(5000, 100), (1000, 100), (999, 99),
                                                  (250, 25), (25, 2), (9, 1), (0, 1)])
def test_curve_window(episodes, window):
    assert curve_window(episodes) == window


def test_trailing_mean_by_hand():
    np.testing.assert_array_equal(trailing_mean(np.array([1.0, 2, 3, 4, 5]), 2),
                                  [1.5, 2.5, 3.5, 4.5])
    values = np.array([[1.0, 2, 3, 4], [0, 0, 3, 3]])
    np.testing.assert_array_equal(trailing_mean(values, 3), [[2.0, 3.0], [1.0, 2.0]])
    np.testing.assert_array_equal(trailing_mean(values, 1), values)
    np.testing.assert_array_equal(trailing_mean(values, 4), [[2.5], [1.5]])
    for window in (0, 5):
        with pytest.raises(ValueError, match="window"):
            trailing_mean(values, window)


def test_std_band_by_hand():
    mean, low, high = band(np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 9.0]]), "std")
    spread = np.sqrt([2 / 3, 26 / 3])  # ddof = 0: ((-1)² + 0² + 1²) / 3, (3² + 1² + 4²) / 3
    np.testing.assert_allclose(mean, [2.0, 5.0])
    np.testing.assert_allclose(low, np.array([2.0, 5.0]) - spread)
    np.testing.assert_allclose(high, np.array([2.0, 5.0]) + spread)
    np.testing.assert_allclose(high, [2.8165, 7.9439], atol=1e-4)
    one = band(np.array([[4.0, 7.0]]), "std")
    for values in one:
        np.testing.assert_array_equal(values, [4.0, 7.0])
    with pytest.raises(ValueError, match="no runs"):
        band(np.zeros((0, 3)), "std")
    with pytest.raises(ValueError, match="unknown band"):
        band(np.ones((2, 3)), "sem")  # type: ignore[arg-type]


def test_bootstrap_band():
    rng = np.random.default_rng(7)
    few, many = rng.normal(10.0, 1.0, (8, 5)), rng.normal(10.0, 1.0, (200, 5))
    mean, low, high = band(few, "bootstrap")
    np.testing.assert_allclose(mean, few.mean(axis=0))
    assert np.all(low <= mean) and np.all(mean <= high) and np.all(low < high)
    again = band(few, "bootstrap", seed=0)
    other = band(few, "bootstrap", seed=1)
    np.testing.assert_array_equal(np.stack(again), np.stack((mean, low, high)))
    assert not np.array_equal(other[1], low)
    _, low_many, high_many = band(many, "bootstrap")
    assert np.all(high_many - low_many < 0.5 * (high - low))  # ~ 1 / sqrt(runs): 5x narrower
    # two runs 0 and 1: resampled means are 0, 0.5, 1 with odds 1/4, 1/2, 1/4
    _, low_two, high_two = band(np.array([[0.0], [1.0]]), "bootstrap")
    assert (low_two[0], high_two[0]) == (0.0, 1.0)


def test_gain_stats():
    stats = gain_stats(np.array([-10.0, 5.0, 20.0, 30.0]))
    assert stats == {"share_positive": 0.75, "median_pct": 12.5, "max_pct": 30.0}


# ---- figures --------------------------------------------------------------------------------

def assert_png(path: Path, folder: Path) -> None:
    assert path.read_bytes()[:8] == PNG_MAGIC
    pixels = matplotlib.image.imread(path)
    assert pixels.shape[:2] == (675, 1050)  # 4.5 x 7 inches at dpi 150
    assert pixels.std() > 0  # something is drawn
    assert sorted(p.name for p in folder.iterdir()) == [path.name]  # no temporary file left


def test_learning_curves_png(tmp_path):
    path = tmp_path / "fig2.png"
    levels = [Level("SoA", 31.8e9), Level("oracle", 49.1e9, ":")]
    save_figure(learning_curves(two_series(), levels, title="E3",
                                note="$J_e$ at the last episode: 0.61 ± 0.02; SoA 0.42"), path)
    assert_png(path, tmp_path)


def test_min_se_sweep_png(tmp_path):
    path = tmp_path / "fig3.png"
    se = np.array([0.5, 1.0, 2.0, 3.0, 4.0])
    lines = [Series(s.label, se, s.mean[:5], s.low[:5], s.high[:5], s.runs)
             for s in two_series()]
    save_figure(min_se_sweep(lines, {"dueling DQN": 3.0, "DQN": None}, title="E4"), path)
    assert_png(path, tmp_path)
    with pytest.raises(ValueError, match="SoA"):
        min_se_sweep(lines, {"SoA": 1.0}, title="E4")


def test_layout_gains_png(tmp_path):
    path = tmp_path / "fig4.png"
    rng = np.random.default_rng(0)
    save_figure(layout_gains({"vs SoA": rng.normal(20, 15, 100),
                              "vs DQN": rng.normal(5, 5, 100)},
                             title="E5", paper={"vs SoA": "paper: beats on 91%, median +30.25%, "
                                                          "max +90.25%"}), path)
    assert_png(path, tmp_path)


def test_series_shapes_are_checked():
    with pytest.raises(ValueError, match="one 1-D shape"):
        Series("bad", np.arange(3), np.zeros(3), np.zeros(2), np.zeros(3), runs=1)


# ---- plot_runs on synthetic run files -------------------------------------------------------

def make_run(path: Path, name: str, rates_bps: dict[int, np.ndarray]) -> Path:
    """A run file of scenario ``name`` whose seeds have the episode sum rates ``rates_bps``,
    each appended in two checkpoints (a seed with none stays at episode 0). Only its curves
    are real (its checkpoints are stubs): it is read as ``RunReader(path, needs="curves")``."""
    seeds = list(rates_bps)
    config = make_scenario(name=name, train={"seeds": seeds, "episodes": 100})
    create_run(path, f'name = "{name}"\n', config.model_dump(mode="json"), {}, seeds=seeds,
               episodes=100, num_users=config.num_users)
    for seed, rates in rates_bps.items():
        half = len(rates) // 2
        for start, stop in ((0, half), (half, len(rates))):
            if stop > start:
                rows = {metric: np.zeros(stop - start) for metric in EPISODE_METRICS}
                rows |= {metric: np.zeros((stop - start, config.num_users))
                         for metric in PER_USER_METRICS}
                append_checkpoint(path, seed, {**rows, "sum_rate_bps": rates[start:stop]}, {},
                                  (stop, {}), {"episode": stop})
    return path


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def ramp(episodes: int, factor: float) -> np.ndarray:
    """factor x 1, 2, ..., episodes Gbit/s."""
    return factor * GBPS * np.arange(1.0, episodes + 1)


def test_plot_runs_one_scenario(tmp_path):
    # seeds of 30, 25 and 0 episodes: cut to 25, window curve_window(25) = 2, so the trailing
    # means at episode e are (e - 1/2) and 2 (e - 1/2) Gbit/s: mean 1.5 (e - 1/2), std 0.5 (...)
    run = make_run(tmp_path / "a.h5", "alpha", {0: ramp(30, 1.0), 1: ramp(25, 2.0),
                                                2: np.zeros(0)})
    out = plot_runs(run_paths=[run], out=tmp_path / "figs" / "a.png")
    assert out == tmp_path / "figs" / "a.png"
    assert out.read_bytes()[:8] == PNG_MAGIC
    rows = read_csv(out.with_suffix(".csv"))
    assert list(rows[0]) == ["episode", "alpha_mean", "alpha_low", "alpha_high", "alpha_runs"]
    assert [int(r["episode"]) for r in rows] == list(range(2, 26))
    for r in rows:
        smoothed = (int(r["episode"]) - 0.5) * GBPS
        assert float(r["alpha_mean"]) == pytest.approx(1.5 * smoothed, rel=1e-12)
        assert float(r["alpha_low"]) == pytest.approx(smoothed, rel=1e-12)
        assert float(r["alpha_high"]) == pytest.approx(2 * smoothed, rel=1e-12)
        assert r["alpha_runs"] == "2"


def test_plot_runs_groups_by_scenario_name(tmp_path):
    a = make_run(tmp_path / "a.h5", "alpha", {0: ramp(30, 1.0), 1: ramp(25, 2.0)})
    b = make_run(tmp_path / "b.h5", "alpha", {5: ramp(40, 3.0)})
    c = make_run(tmp_path / "c.h5", "beta", {0: ramp(10, 1.0), 1: ramp(10, 1.0)})
    out = plot_runs(run_paths=[a, b, a, c], out=tmp_path / "all.png", band="bootstrap",
                    title="two scenarios")
    rows = read_csv(out.with_suffix(".csv"))
    # one window for all: curve_window(10) = 1, so the means are the raw episode values
    assert [int(r["episode"]) for r in rows] == list(range(1, 26))
    for r in rows:
        e = int(r["episode"])
        assert r["alpha_runs"] == "3"  # a.h5 given twice counts once
        assert float(r["alpha_mean"]) == pytest.approx(2.0 * e * GBPS, rel=1e-12)
        assert float(r["alpha_low"]) <= float(r["alpha_mean"]) <= float(r["alpha_high"])
        if e <= 10:
            assert float(r["beta_mean"]) == float(r["beta_low"]) == float(r["beta_high"]) \
                == e * GBPS
            assert r["beta_runs"] == "2"
        else:
            assert r["beta_mean"] == r["beta_runs"] == ""


def test_plot_runs_errors(tmp_path):
    empty = make_run(tmp_path / "empty.h5", "alpha", {0: np.zeros(0)})
    with pytest.raises(AdaptskyError, match="nothing to plot"):
        plot_runs(run_paths=[empty], out=tmp_path / "x.png")
    with pytest.raises(AdaptskyError, match="unknown band 'sem'"):
        plot_runs(run_paths=[empty], out=tmp_path / "x.png", band="sem")
    assert default_figure_path(Path("runs/e3.h5")) == Path("runs/e3-curves.png")


def test_plot_command(tmp_path, capsys):
    run = make_run(tmp_path / "e3.h5", "alpha", {0: ramp(20, 1.0)})
    assert main(["plot", str(run), "--band", "bootstrap", "--title", "E3"]) == 0
    figure = tmp_path / "e3-curves.png"
    assert capsys.readouterr().err.strip() == f"figure: {figure}"
    assert figure.read_bytes()[:8] == PNG_MAGIC
    assert len(read_csv(figure.with_suffix(".csv"))) == 20 - 2 + 1
    assert main(["plot", str(run), "--band", "sem"]) == 2
    capsys.readouterr()
    empty = make_run(tmp_path / "empty.h5", "alpha", {0: np.zeros(0)})
    assert main(["plot", str(empty)]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "nothing to plot" in lines[0]


def test_plot_never_writes_a_figure_over_a_file_that_is_not_one(tmp_path, capsys):
    # `plot RUN --out scenarios/nyc_mmwave.toml` wrote a PNG into the scenario file (and a CSV
    # beside it): found by fuzzing
    run = make_run(tmp_path / "e3.h5", "alpha", {0: ramp(20, 1.0)})
    scenario = tmp_path / "nyc_mmwave.toml"
    scenario.write_text('name = "x"\n')
    for out in (scenario, run, tmp_path / "figure"):
        assert main(["plot", str(run), "--out", str(out)]) == 1
        lines = capsys.readouterr().err.strip().splitlines()
        given = f"'{out.suffix}'" if out.suffix else "no suffix"
        assert lines == [f"--out {out}: a figure file must end in .png, .pdf or .svg (it has "
                         f"{given})"]
    assert scenario.read_text() == 'name = "x"\n' and not (tmp_path / "nyc_mmwave.csv").exists()
    assert main(["plot", str(run), "--out", str(tmp_path / "curves.png")]) == 0
    assert (tmp_path / "curves.png").read_bytes()[:8] == PNG_MAGIC
