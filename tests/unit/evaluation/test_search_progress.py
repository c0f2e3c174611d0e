"""Progress of the long searches (issue 35): best response reports its round, its UAV and
how much of that UAV's lattice it searched within a layout, and the numbers it finds do not
change; a stage off a terminal prints a line every ``log_every_s`` even where no tick comes,
and a live row shows the detail; a training of several UAVs says that it computes best
response before its first episode, with progress, and its rows and lines name best response
(the oracle for one UAV)."""

from __future__ import annotations

import io
import itertools
import math
import re
import time

import numpy as np
from rich.console import Console

from adaptsky import progress as work_progress
from adaptsky.progress import LogLines, WorkProgress
from adaptsky.rollouts import several_uavs
from adaptsky.scenario import load_scenario
from adaptsky.sim.layout import user_layouts
from adaptsky.training.evaluation import reference_name
from adaptsky.training.progress import TrainingProgress
from adaptsky_cli.cli.main import main
from adaptsky_cli.cli.progress_display import RichReporter
from tests.conftest import SCENARIOS
from tests.helpers.training import three

STAMP = r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d "
PACE = r"; [\d.]+ m?s/layout, (about [\w ]+|under 1 s) left$"


def _err(capsys) -> list[str]:
    return capsys.readouterr().err.splitlines()


def test_best_response_of_three_uavs_logs_round_and_uav_between_layouts(tmp_path, capsys,
                                                                        monkeypatch):
    """A three-UAV best response printed nothing for 12 minutes: lines came only when a
    whole layout was done. Off a terminal (capsys: a file) it now logs within a layout."""
    monkeypatch.setattr(work_progress, "LOG_EVERY_S", 0.0)  # a line at every tick
    monkeypatch.setattr(several_uavs, "POINTS_PER_CHUNK", 250)  # a UAV's lattice in chunks
    assert main(["baseline", str(three(tmp_path)), "--method", "best-response", "--layouts",
                 "2", "--steps", "2"]) == 0
    lines = [line for line in _err(capsys) if " best-response: " in line]
    assert all(re.match(STAMP, line) for line in lines)
    assert re.search(r"best-response: 2 layouts \.\.\.$", lines[0])
    assert re.search(r"best-response: done in [\d.]+ s$", lines[-1])
    first_done = next(i for i, line in enumerate(lines) if "best-response: 1/2 layouts" in line)
    within = lines[1:first_done]
    assert within and all(re.search(r"best-response: layout 1/2, round \d+, UAV [123]/3: "
                                    r"\d+%" + PACE, line) for line in within), within
    details = " ".join(within)
    assert all(f"round 1, UAV {u}/3" in details for u in (1, 2, 3))
    assert re.search(r"UAV 1/3: (?!100%)\d+%", details)  # part of a lattice
    assert any("best-response: layout 2/2, round 1, UAV 1/3" in line
               for line in lines[first_done:])


def test_progress_leaves_the_searches_bit_for_bit(tmp_path):
    scenario = load_scenario(three(tmp_path))
    layouts = user_layouts(scenario, 2)
    heard: list[tuple[float, str]] = []
    for search in (several_uavs.best_response, several_uavs.best_oma):
        quiet = search(scenario, layouts)
        told = search(scenario, layouts, on_layout=lambda done: None,
                      on_search=lambda done, detail: heard.append((done, detail)))
        for name in ("objective_bps", "uav_m", "alpha_first", "rate_bps", "rounds",
                     "converged"):
            assert np.array_equal(getattr(quiet, name), getattr(told, name), equal_nan=True)
    done = [value for value, _ in heard[:len(heard) // 2]]  # best response's
    assert done == sorted(done) and done[0] > 0 and done[-1] < 2


def test_layout_share_rises_below_one():
    shares = [several_uavs.layout_share(x / 10, 3.0) for x in range(0, 101)]
    assert shares[0] == 0 and math.isclose(shares[30], 0.9)
    assert all(a < b for a, b in itertools.pairwise(shares)) and shares[-1] < 1


def test_a_stage_off_a_terminal_logs_every_interval_without_ticks():
    stream = io.StringIO()
    with WorkProgress(LogLines(stream), log_every_s=0.05) as work, \
            work.stage("best-response", 1, "layout") as tick:
        time.sleep(0.3)            # no tick: a chunk of a large lattice
        tick(0.4, "round 2, UAV 1/3: 40%")
        time.sleep(0.3)
    lines = stream.getvalue().splitlines()
    assert re.search(r"best-response: 1 layout \.\.\.$", lines[0])
    assert re.search(r"best-response: done in [\d.]+ s$", lines[-1])
    before = [line for line in lines[1:-1] if "0/1 layouts" in line]
    after = [line for line in lines[1:-1] if "layout 1/1, round 2, UAV 1/3: 40%" in line]
    assert len(before) >= 2 and len(after) >= 2 and len(before) + len(after) == len(lines) - 2
    assert re.search(r"best-response: layout 1/1, round 2, UAV 1/3: 40%" + PACE, after[0])


def test_a_live_row_shows_the_detail_and_other_stages_keep_their_row():
    buffer = io.StringIO()
    reporter = RichReporter(Console(file=buffer, force_terminal=True, width=100,
                                    color_system=None))
    with WorkProgress(reporter) as work, work.stage("best-response", 1, "layout") as tick:
        tick(0.4, "round 2, UAV 1/3: 40%")
        reporter.progress.refresh()  # type: ignore[union-attr]
    with WorkProgress(reporter) as work, work.stage("policy", 10, "step") as tick:
        tick(3)
        reporter.progress.refresh()  # type: ignore[union-attr]
    text = buffer.getvalue()
    assert "round 2, UAV 1/3: 40%" in text and "3/10 steps" in text
    assert not re.search(STAMP, text)


def test_training_of_three_uavs_says_it_computes_best_response_before_its_first_episode(
        tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(work_progress, "LOG_EVERY_S", 0.0)
    assert main(["train", str(three(tmp_path)), "--seeds", "0", "--workers", "1",
                 "--out", str(tmp_path / "run.h5")]) == 0
    lines = _err(capsys)
    first = next(i for i, line in enumerate(lines) if "seed 0: episode 1/1" in line)
    before = lines[:first]
    assert re.match(STAMP + r"computing best response on the training layout and 2 held-out "
                    r"layouts for the greedy evaluations \(3 UAVs\) \.\.\.$", before[0])
    assert re.search(r"best response: 3 layouts \.\.\.$", before[1])
    assert any(re.search(r"best response: layout 1/3, round 1, UAV 2/3: \d+%" + PACE, line)
               for line in before), before
    assert any(re.search(r"best response: layout 3/3, round \d+, UAV 3/3", line)
               for line in before), before
    assert re.search(r"best response: done in [\d.]+ s$", before[-1])
    assert "oracle" not in "\n".join(lines)
    assert re.search(r"greedy [\d.]+% of best response", lines[first])


def _greedy_rows(reference: str) -> tuple[str, str]:
    """A live row's text and a log line of a seed after a greedy evaluation."""
    greedy = {"pct_oracle": 97.4, "sum_rate_bps": 1e9, "fairness": 0.5,
              "heldout_pct_oracle": math.nan, "heldout_sum_rate_bps": math.nan}
    metrics = {"sum_rate_bps": 1e9, "fairness": 0.5, "epsilon": 0.3, "greedy": greedy}
    buffer, stream = io.StringIO(), io.StringIO()
    console = Console(file=buffer, force_terminal=True, width=100)
    for reporter in (RichReporter(console), LogLines(stream)):
        with TrainingProgress(reporter, log_every_s=0, reference=reference) as view:
            view.add_seed(0, 0, 2)
            view.episode(0, 1, metrics)
    return buffer.getvalue(), stream.getvalue()


def test_rows_and_lines_name_best_response_for_several_uavs_and_the_oracle_for_one(tmp_path):
    several = load_scenario(three(tmp_path))
    one = load_scenario(SCENARIOS / "nyc_mmwave.toml")
    assert reference_name(several) == "best response" and reference_name(one) == "oracle"
    row, line = _greedy_rows(reference_name(several))
    assert "greedy 97.4% BR" in row and "oracle" not in row
    assert "greedy 97.4% of best response" in line and "oracle" not in line
    row, line = _greedy_rows(reference_name(one))
    assert "greedy 97.4% oracle" in row and "greedy 97.4% of oracle" in line
