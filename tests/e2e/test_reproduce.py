"""``adaptsky reproduce`` end to end on tiny experiments: files written, numbers that match
the run files, a second call that only redraws, kill -9 and Ctrl-C with a restart that loses
at most one checkpoint interval."""

from __future__ import annotations

import csv
import os
import re
import signal
import time

import numpy as np
import pytest

from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main
from tests.helpers.reproduce import (
    EPISODES,
    SMALL_AGENT,
    STEPS,
    assert_equal_to_uninterrupted,
    curves_experiment,
    episodes_trained,
    last_mean,
    start_adaptsky,
    wait_for,
    write_experiment,
)


def test_reproduce_writes_report_figure_csv_and_then_only_redraws(tmp_path, capsys):
    experiment = curves_experiment(tmp_path)
    out = tmp_path / "out"
    args = ["reproduce", str(experiment), "--out", str(out), "--episodes", "4", "--steps",
            "40", "--workers", "2"]
    assert main(args) == 0
    for name in ("report.md", "tiny.png", "tiny.csv", "plan.json", "runs/agent-seed0.h5",
                 "runs/agent-seed1.h5", "evals/soa.h5", "evals/oracle.h5"):
        assert (out / name).is_file(), name
    assert (out / "tiny.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (out / "report.md").read_text()
    # R_e^tot in the report: the mean over runs of each run's mean of its last 100 episodes
    rates = [last_mean(out / "runs" / f"agent-seed{s}.h5") for s in (0, 1)]
    expected = f"{np.mean(rates) / 1e6:.2f} Mbit/s ± {np.std(rates) / 1e6:.2f} Mbit/s (n = 2)"
    assert "--episodes 4 --steps 40" in report
    assert "means of the last 4 episodes' per-episode means" in report  # not "last 100"
    # the reachable column: the oracle's sum rate, read from its eval file
    _, methods = read_eval_metrics(out / "evals" / "oracle.h5")
    oracle = float(np.mean(next(iter(methods.values()))["mean_sum_rate_bps"]))
    assert f"| sum rate | 400.00 Mbit/s | agent | {expected} | {oracle / 1e6:.2f} Mbit/s |" \
        in report
    with (out / "tiny.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 4 and rows[0]["episode"] == "1"  # window 1 for 4 episodes
    assert float(rows[-1]["agent_runs"]) == 2
    stamps = {p: p.stat().st_mtime_ns for p in (out / "runs").iterdir()}
    evals = {p: p.stat().st_mtime_ns for p in (out / "evals").iterdir()}
    capsys.readouterr()
    start = time.perf_counter()
    assert main(args) == 0
    assert time.perf_counter() - start < 10
    assert {p: p.stat().st_mtime_ns for p in (out / "runs").iterdir()} == stamps
    assert {p: p.stat().st_mtime_ns for p in (out / "evals").iterdir()} == evals
    assert "evaluating" not in capsys.readouterr().err
    # more episodes on the same folder: the runs continue, the evaluations are redone
    assert main([*args[:5], "6", *args[6:]]) == 0
    assert "resumed from episode 4" in capsys.readouterr().err


def test_another_configuration_in_the_folder_is_refused(tmp_path, capsys):
    experiment = curves_experiment(tmp_path, runs=1)
    out = tmp_path / "out"
    base = ["reproduce", str(experiment), "--out", str(out), "--episodes", "2"]
    assert main([*base, "--steps", "10", "--runs-only"]) == 0
    capsys.readouterr()
    assert main([*base, "--steps", "20"]) == 1
    line = capsys.readouterr().err.strip()
    assert "made with another configuration (train.steps is 10 there, 20 here)" in line


def test_kill_and_interrupt_lose_at_most_one_checkpoint_interval(tmp_path, uninterrupted):
    """kill -9 of the whole process group, then Ctrl-C, then a restart: every run ends equal,
    bit for bit, to an uninterrupted run of the same spec."""
    experiment = curves_experiment(tmp_path)
    out = tmp_path / "out"
    args = ["reproduce", str(experiment), "--out", str(out), "--episodes", str(EPISODES),
            "--steps", str(STEPS), "--workers", "2", "--set", "train.checkpoint_every=2",
            "--runs-only"]
    runs = [out / "runs" / f"agent-seed{s}.h5" for s in (0, 1)]
    process = start_adaptsky(args, tmp_path / "first.log")
    wait_for(lambda: min(episodes_trained(r) for r in runs) >= 4)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    at_kill = [episodes_trained(r) for r in runs]
    time.sleep(1.0)  # orphaned workers notice their parent is gone and stop
    assert [episodes_trained(r) for r in runs] == at_kill  # no writer is left behind

    process = start_adaptsky(args, tmp_path / "second.log")
    wait_for(lambda: all(episodes_trained(r) >= min(done + 4, EPISODES)
                          for r, done in zip(runs, at_kill, strict=True)))
    os.killpg(process.pid, signal.SIGINT)
    assert process.wait(timeout=60) in (0, 130)  # 0 if both happened to finish first
    log = (tmp_path / "second.log").read_text()
    resumed = [int(n) for n in re.findall(r"resumed from episode (\d+)", log)]
    unfinished = [done for done in at_kill if done < EPISODES]
    assert sorted(resumed) == sorted(unfinished)  # each continued from its checkpoint
    if min(episodes_trained(r) for r in runs) < EPISODES:
        assert "interrupted; every run keeps its last checkpoint" in log

    process = start_adaptsky(args, tmp_path / "third.log")
    assert process.wait(timeout=120) == 0
    assert [episodes_trained(r) for r in runs] == [EPISODES, EPISODES]
    assert_equal_to_uninterrupted(experiment, runs, tmp_path / "fresh", uninterrupted)


def test_min_se_sweep_marks_what_soa_serves(tmp_path):
    """At -79 dBm SoA meets R_min = 0 and not 3.5 bit/s/Hz (its weak user's share is capped
    at 1: docs/model.md section 5)."""
    experiment = write_experiment(tmp_path / "experiments", f"""
id = "sweep"
title = "tiny sweep"
[[groups]]
name = "agent"
scenario = "../scenarios/nyc_mmwave_released_code.toml"
runs = 2
set = [{", ".join(SMALL_AGENT)}, "reward.w_satisfied=100"]
[groups.sweep]
key = "reward.min_se"
values = [0.0, 3.5]
[evaluation]
policy = "agent"
steps = 120
baselines = ["soa", "oracle"]
[figure]
kind = "min-se-sweep"
[[claims]]
text = "SoA serves"
quantity = "soa_max_min_se_served"
paper = 2.5
""")
    out = tmp_path / "out"
    assert main(["reproduce", str(experiment), "--out", str(out), "--episodes", "2",
                 "--steps", "30"]) == 0
    with (out / "sweep.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["min_se"], r["runs"], r["soa_serves"]) for r in rows] == [
        ("0.0", "2", "True"), ("3.5", "2", "False")]
    for row, value in zip(rows, (0.0, 3.5), strict=True):
        rates = [last_mean(out / "runs" / f"agent-min_se-{value:g}-seed{s}.h5") for s in (0, 1)]
        assert float(row["policy_mean_bps"]) == pytest.approx(np.mean(rates), rel=1e-12)
        assert float(row["oracle_bps"]) >= float(row["soa_bps"])
    assert "| SoA serves | 2.5 bit/s/Hz | SoA | 0 bit/s/Hz | - | - |" in (
        out / "report.md").read_text()


def test_layout_gains_pairs_runs_by_seed(tmp_path):
    experiment = write_experiment(tmp_path / "experiments", f"""
id = "gains"
title = "tiny gains"
[[groups]]
name = "duel"
scenario = "../scenarios/nyc_mmwave.toml"
runs = 2
set = [{", ".join(SMALL_AGENT)}, "train.eval_every=1", "train.eval_steps=20"]
[[groups]]
name = "plain"
scenario = "../scenarios/nyc_mmwave.toml"
runs = 2
set = [{", ".join(SMALL_AGENT)}, "agent.dueling=false", "train.eval_every=1",
       "train.eval_steps=20"]
[evaluation]
policy = "duel"
layouts = 3
steps = 20
baselines = ["soa", "oracle"]
compare_groups = ["plain"]
policies = ["last", "best"]
[figure]
kind = "layout-gains"
[[claims]]
text = "beats SoA"
quantity = "beats_share_pct_vs_soa"
[[claims]]
text = "beats plain"
quantity = "mean_gain_pct_vs_plain"
""")
    out = tmp_path / "out"
    assert main(["reproduce", str(experiment), "--out", str(out), "--episodes", "2",
                 "--steps", "30"]) == 0
    with (out / "gains.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["policy"], r["seed"], r["layout"]) for r in rows] == [
        (p, s, str(k)) for p in ("last", "best") for s in ("0", "1") for k in range(3)]
    report = (out / "report.md").read_text()
    for policy in ("last", "best"):
        mine = [r for r in rows if r["policy"] == policy]
        beats = [100 * np.mean([float(r["policy_bps"]) > float(r["soa_bps"]) for r in mine
                                if r["seed"] == s]) for s in ("0", "1")]
        gains = [np.mean([100 * (float(r["policy_bps"]) - float(r["plain_bps"]))
                          / float(r["plain_bps"]) for r in mine if r["seed"] == s])
                 for s in ("0", "1")]
        label = f"duel, {policy} policy"
        first = "beats SoA | -" if policy == "last" else " | "
        assert re.search(rf"\| {re.escape(first)} \| {label} \| {np.mean(beats):.1f}% ± "
                         rf"{np.std(beats):.1f}% \(n = 2\) \| 100.0% \|",
                         report), report
        assert f"| {label} | {np.mean(gains):+.1f}% ± {np.std(gains):.1f}% (n = 2) |" in report
    assert all(float(r["oracle_bps"]) >= float(r["soa_bps"]) for r in rows)
    # the best rows evaluate the weights `adaptsky eval --policy best` picks
    from adaptsky.evaluation.api import evaluate
    results, methods = evaluate(checkpoint=out / "runs" / "duel-seed1.h5", layouts=3,
                                layout_seed=0, steps=20, compare_with=[], policy="best")
    assert results["policy"]["policy"] == "best"
    _, stored = read_eval_metrics(out / "evals" / "duel-seed1-best.h5")
    assert np.array_equal(methods[0].metrics["mean_sum_rate_bps"],
                          next(iter(stored.values()))["mean_sum_rate_bps"])
    assert "had no greedy evaluation" not in report
