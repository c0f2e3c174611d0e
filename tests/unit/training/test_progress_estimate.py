"""The time left of training and of a sweep comes from the latest episodes, the first (the
slowest: processes starting, imports) left out, and says "estimating" until some are timed:
a 6 s run announced "2.46 s/episode, about 1 min 11 s left" after its first episode."""

from __future__ import annotations

import io
import re
import threading
import time
from types import SimpleNamespace

import pytest
from rich.console import Console

from adaptsky.experiment import sweep
from adaptsky.progress import PACE_WINDOW, LogLines, Pace, Reporter
from adaptsky.training.progress import TrainingProgress
from adaptsky_cli.cli.progress_display import RichReporter

METRICS = {"sum_rate_bps": 4.1e10, "fairness": 0.5, "epsilon": 0.3}
FIRST_S, THEN_S = 2.46, 0.2  # the first episode's time (start-up included), the others'
ESTIMATING = "estimating time left"


class Clock:
    """time.monotonic, moved by hand."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> Clock:
    clock = Clock()
    monkeypatch.setattr(time, "monotonic", clock)
    return clock


def test_pace_leaves_the_first_unit_out_and_estimates_once_two_are_timed():
    pace = Pace(30)
    assert pace.left() == ESTIMATING and pace.text("episode") == ESTIMATING
    pace.update(1, now=FIRST_S)
    pace.update(2, now=FIRST_S + THEN_S)
    assert pace.per_unit_s() is None and pace.left(short=True) == "estimating"
    pace.update(3, now=FIRST_S + 2 * THEN_S)
    assert pace.per_unit_s() == pytest.approx(THEN_S)
    assert pace.text("episode") == "0.20 s/episode, about 5 s left"  # 27 x 0.2 s
    assert pace.left(short=True) == "0:00:05"
    pace.update(30, now=FIRST_S + 29 * THEN_S)
    assert pace.left() == "" and pace.text("episode") == "0.20 s/episode"


def test_pace_follows_the_latest_units():
    pace, now = Pace(1000), 0.0
    for done in range(1, 101):
        now += 0.1 if done < 50 else 1.0  # the episodes grow slower
        pace.update(done, now=now)
    assert pace.per_unit_s() == pytest.approx(1.0)  # the last PACE_WINDOW only
    assert PACE_WINDOW < 50


def _train(clock: Clock, view: TrainingProgress, episodes: int) -> None:
    view.add_seed(0, 0, episodes)
    for episode in range(1, episodes + 1):
        clock.sleep(FIRST_S if episode == 1 else THEN_S)
        view.episode(0, episode, METRICS)


def test_training_log_lines_say_estimating_then_the_latest_pace(clock):
    stream = io.StringIO()
    with TrainingProgress(LogLines(stream), log_every_s=0) as view:
        _train(clock, view, 30)
    lines = stream.getvalue().splitlines()
    assert lines[0].endswith("eps 0.300, estimating time left"), lines[0]
    assert lines[2].endswith("eps 0.300, 0.20 s/episode, about 5 s left"), lines[2]
    assert lines[-1].endswith("eps 0.300, 0.20 s/episode"), lines[-1]


def test_training_live_rows_say_estimating_then_the_latest_time_left(clock):
    buffer = io.StringIO()
    reporter = RichReporter(Console(file=buffer, force_terminal=True, width=100))
    rows = []
    with TrainingProgress(reporter) as view:
        view.add_seed(0, 0, 30)
        for episode in range(1, 4):
            clock.sleep(FIRST_S if episode == 1 else THEN_S)
            view.episode(0, episode, METRICS)
            assert reporter.progress is not None
            rows.append(reporter.progress.tasks[0].fields["left"])
    assert rows == ["estimating", "estimating", "0:00:05"]
    reporter.close()


class Recorder(Reporter):
    """The sweep's status texts."""

    def __init__(self) -> None:
        self.etas: list[str] = []

    def print(self, text: str) -> None:
        pass

    def advance(self, key: object, done: int, **fields: object) -> None:
        self.etas.append(str(fields["eta"]))


class Future:
    """Done after ``polls`` looks."""

    def __init__(self, polls: int, episodes: int) -> None:
        self.polls, self.episodes = polls, episodes

    def done(self) -> bool:
        self.polls -= 1
        return self.polls < 0

    def cancelled(self) -> bool:
        return False

    def result(self) -> SimpleNamespace:
        return SimpleNamespace(episodes_done=self.episodes, seconds=1.0, started_at_episode=0)


def test_sweep_estimates_from_the_latest_episodes_written(clock, monkeypatch):
    """One run of 30 episodes, polled every 2 s: its first checkpoint (episode 1) comes
    after 2.46 s of start-up, then one episode is written every 0.2 s."""
    spec = SimpleNamespace(path="run.h5", name="run", seed=0, episodes=30)
    written = iter(range(31))
    monkeypatch.setattr(sweep, "_episodes_in_file", lambda spec: next(written))
    sleeps = iter([FIRST_S] + [THEN_S] * 40)
    executor = SimpleNamespace(description="a test", capacity=1, request_stop=lambda: None,
                               close=lambda now=False: None,
                               submit_all=lambda specs: [Future(4, 30)],
                               wait_any=lambda futures, s: clock.sleep(next(sleeps)))
    recorder = Recorder()
    sweep.run_sweep([(spec, SimpleNamespace(episodes_done=0))], executor, recorder, 1)
    # polls see episodes 0, 1 (2.46 s), 2, 3 (0.2 s each): then 27 x 0.2 s are left
    assert recorder.etas[:4] == [ESTIMATING] * 3 + ["about 5 s left"], recorder.etas
    assert not any(re.search(r"1 min", eta) for eta in recorder.etas)


def test_the_sweep_waits_on_its_futures_and_never_sleeps(monkeypatch):
    """Between two looks the sweep waits on the executor (back as soon as a run ends), at
    most :data:`sweep.POLL_S`; it never sleeps a whole poll after the last run ended."""
    spec = SimpleNamespace(path="run.h5", name="run", seed=0, episodes=3)
    monkeypatch.setattr(sweep, "_episodes_in_file", lambda spec: 1)
    monkeypatch.setattr(sweep.time, "sleep", lambda s: pytest.fail("the sweep slept"))
    waits = []
    executor = SimpleNamespace(description="a test", capacity=1, request_stop=lambda: None,
                               close=lambda now=False: None,
                               submit_all=lambda specs: [Future(2, 3)],
                               wait_any=lambda futures, s: waits.append((len(futures), s)))
    outcome = sweep.run_sweep([(spec, SimpleNamespace(episodes_done=0))], executor,
                              Recorder(), 1)
    assert [report.episodes_done for report in outcome.reports] == [3]
    assert waits == [(1, sweep.POLL_S)] * 2   # two looks before the run is done, none after


def test_local_runs_wake_the_sweep_when_one_ends():
    """``LocalExecutor.wait_any`` returns once a future is done, not after its timeout."""
    from concurrent.futures import Future as RunFuture

    import torch

    from adaptsky.experiment.executors import LocalExecutor

    executor = LocalExecutor(1, torch.device("cpu"))
    future: RunFuture = RunFuture()
    timer = threading.Timer(0.05, future.set_result, args=("done",))
    began = time.monotonic()
    timer.start()
    executor.wait_any([future], timeout_s=600.0)
    assert future.done() and time.monotonic() - began < 300.0
    executor.close()
