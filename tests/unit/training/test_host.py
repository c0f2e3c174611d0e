"""The one host of local worker processes (``train`` and ``reproduce``): jobs, typed messages,
stops and quits; and reproduce's second Ctrl-C, which quits at once like train's."""

from __future__ import annotations

import os
import signal
import time

import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.training.host import Job, ProcessHost
from adaptsky.training.messages import Done, Failed, WorkerLost
from tests.helpers.reproduce import curves_experiment, episodes_trained, start_adaptsky, wait_for


def _answer(value: object, emit, stop, orphaned) -> None:
    emit(Done("answer", value))


def _fail(emit, stop, orphaned) -> None:
    raise AdaptskyError("no such thing")


def _die(emit, stop, orphaned) -> None:
    os._exit(3)


def _until_stopped(key: str, emit, stop, orphaned) -> None:
    while not stop():
        time.sleep(0.05)
    emit(Done(key, "stopped"))


def _drain(host: ProcessHost) -> list[object]:
    heard: list[object] = []
    while host.pump(heard.append, timeout_s=1.0):
        pass
    return heard


def test_jobs_report_results_failures_and_lost_processes(tmp_path):
    host = ProcessHost(workers=2)
    host.submit([Job(_answer, (42,), ("answer",)), Job(_fail, (), ("fail",)),
                 Job(_die, (), ("die",))])
    try:
        heard = _drain(host)
    finally:
        host.close(5.0)
    assert Done("answer", 42) in heard
    assert Failed("fail", "no such thing") in heard
    assert WorkerLost(("die",), 3) in heard


def test_a_stop_ends_running_jobs_and_drops_queued_ones():
    dropped = []
    host = ProcessHost(workers=1, on_drop=dropped.append)
    first, second = (Job(_until_stopped, (key,), (key,)) for key in ("first", "second"))
    host.submit([first, second])
    try:
        host.pump(lambda message: None, timeout_s=0.5)
        host.request_stop()
        heard = _drain(host)
    finally:
        host.close(5.0)
    assert heard == [Done("first", "stopped")] and dropped == [second]


def test_reproduce_quits_at_once_on_a_second_ctrl_c(tmp_path):
    # the second Ctrl-C waited for every running stack to reach its checkpoint
    experiment = curves_experiment(tmp_path)
    out = tmp_path / "out"
    runs = [out / "runs" / f"agent-seed{s}.h5" for s in (0, 1)]
    # episodes of seconds: a checkpoint at the end of the current one would take that long
    process = start_adaptsky(["reproduce", str(experiment), "--out", str(out), "--episodes", "10",
                      "--steps", "20000", "--workers", "2", "--runs-only"], tmp_path / "log")
    wait_for(lambda: all(run.exists() for run in runs))
    time.sleep(2.0)
    os.killpg(process.pid, signal.SIGINT)
    time.sleep(0.3)
    os.killpg(process.pid, signal.SIGINT)
    began = time.monotonic()
    code = process.wait(timeout=30)
    log = (tmp_path / "log").read_text()
    assert code == 130, log
    assert time.monotonic() - began < 5.0, log
    assert "quit: the run files keep agent-seed0 " in log and "Traceback" not in log, log
    assert [episodes_trained(run) for run in runs] == [0, 0]  # no checkpoint was waited for


def test_a_second_ctrl_c_that_python_dropped_is_raised_again():
    """An exception raised by a signal handler inside a weakref callback or __del__ is printed
    and dropped by Python (seen in CI: the second Ctrl-C then waited for the checkpoints); the
    loops that wait call check(), which raises it again."""
    from adaptsky.training.interrupts import StopOnInterrupt

    stops = []
    interrupts = StopOnInterrupt(lambda: stops.append(1), lambda text: None, "stopping")
    interrupts._handle(signal.SIGINT, None)
    interrupts.check()  # one Ctrl-C: the work checkpoints, nothing raised
    assert stops == [1]
    with pytest.raises(KeyboardInterrupt):
        interrupts._handle(signal.SIGINT, None)  # the second, here "dropped" by the caller
    with pytest.raises(KeyboardInterrupt):
        interrupts.check()


def test_a_second_ctrl_c_inside_a_finaliser_waits_for_the_loop():
    """A second Ctrl-C that comes while a ``__del__`` or a callback of weakref.py runs (in CI:
    WeakValueDictionary's remove) is not raised there (Python would print "Exception ignored"
    and a traceback) but by the waiting loop's next check()."""
    import sys
    import weakref

    from adaptsky.training.interrupts import StopOnInterrupt

    interrupts = StopOnInterrupt(lambda: None, lambda text: None, "stopping")
    interrupts._handle(signal.SIGINT, None)
    returned: list[str] = []

    def second_ctrl_c(where: str) -> None:
        interrupts._handle(signal.SIGINT, sys._getframe())
        returned.append(where)  # reached only if the handler did not raise

    class Finalised:
        def __del__(self) -> None:
            second_ctrl_c("__del__")

    class Target:
        pass

    Finalised()  # unreferenced: its __del__ runs at once
    target = Target()
    weakref.finalize(target, second_ctrl_c, "weakref callback")
    del target
    assert returned == ["__del__", "weakref callback"]
    with pytest.raises(KeyboardInterrupt):
        interrupts.check()
    with pytest.raises(KeyboardInterrupt):  # elsewhere it is raised at once
        second_ctrl_c("plain code")
