"""``reproduce --scheduler``: a real Dask scheduler and workers started on this machine, a
tiny experiment through them, and a worker killed mid-run whose run continues elsewhere from
its last checkpoint."""

from __future__ import annotations

import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from adaptsky.experiment import executors
from adaptsky_cli.cli.main import main
from tests.helpers.reproduce import (
    EPISODES,
    STEPS,
    assert_equal_to_uninterrupted,
    curves_experiment,
    episodes_trained,
    wait_for,
)

pytest.importorskip("distributed")
BIN = Path(sys.executable).parent


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class Cluster:
    """A scheduler and ``workers`` one-thread workers without nannies (a killed worker stays
    dead), all on 127.0.0.1."""

    def __init__(self, tmp_path: Path, workers: int) -> None:
        port = _free_port()
        self.address = f"tcp://127.0.0.1:{port}"
        self.processes = [subprocess.Popen(
            [str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
             "--no-dashboard"], stdout=(tmp_path / "scheduler.log").open("w"),
            stderr=subprocess.STDOUT)]
        self.workers = [subprocess.Popen(
            [str(BIN / "dask"), "worker", self.address, "--nthreads", "1", "--no-nanny",
             "--no-dashboard", "--host", "127.0.0.1", "--name", f"w{i}"],
            stdout=(tmp_path / f"worker{i}.log").open("w"), stderr=subprocess.STDOUT)
            for i in range(workers)]
        self.processes += self.workers
        from distributed import Client

        with Client(self.address, timeout="60s") as client:
            client.wait_for_workers(workers, timeout=60)

    def close(self) -> None:
        """The workers, then the scheduler (a worker whose scheduler went first tries to
        reach it again for 20 s before it ends)."""
        for group in (self.workers, self.processes[:1]):
            for process in group:
                if process.poll() is None:
                    process.send_signal(signal.SIGTERM)
            for process in group:
                try:
                    process.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    process.kill()


@pytest.fixture
def cluster(tmp_path):
    started = Cluster(tmp_path, workers=2)
    yield started
    started.close()


def test_shipped_experiment_through_a_scheduler(cluster, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["reproduce", "e1a", "--episodes", "3", "--steps", "20", "--runs", "2",
                 "--scheduler", cluster.address, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "2 to run on Dask at" in err
    assert [episodes_trained(out / "runs" / f"adaptsky-seed{s}.h5") for s in (0, 1)] == [3, 3]
    assert (out / "report.md").is_file() and (out / "e1a.png").is_file()


def test_a_killed_worker_s_run_resumes_from_its_checkpoint(cluster, tmp_path, uninterrupted):
    experiment = curves_experiment(tmp_path)
    out = tmp_path / "out"
    runs = [out / "runs" / f"agent-seed{s}.h5" for s in (0, 1)]
    args = ["reproduce", str(experiment), "--out", str(out), "--episodes", str(EPISODES),
            "--steps", str(STEPS), "--set", "train.checkpoint_every=2", "--runs-only",
            "--scheduler", cluster.address]
    log = tmp_path / "reproduce.log"
    process = subprocess.Popen([str(BIN / "adaptsky"), *args], stdout=log.open("w"),
                               stderr=subprocess.STDOUT)
    # each worker holds one run; kill one once both have a checkpoint
    wait_for(lambda: min(episodes_trained(r) for r in runs) >= 2)
    cluster.workers[0].kill()
    cluster.workers[0].wait()
    assert process.wait(timeout=180) == 0, log.read_text()
    assert [episodes_trained(r) for r in runs] == [EPISODES, EPISODES]
    text = log.read_text()
    resumed = [int(n) for n in re.findall(r"resumed from episode (\d+)", text)]
    assert len(resumed) == 1 and 2 <= resumed[0] < EPISODES, text
    assert_equal_to_uninterrupted(experiment, runs, tmp_path / "fresh",  # bit for bit
                                  uninterrupted)


def test_unreachable_scheduler_is_one_line(tmp_path, capsys, monkeypatch):
    # the refusal after the connection's timeout, shortened from 20 s: the same line sooner
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT_S", 3.0)
    start = time.monotonic()
    code = main(["reproduce", "e1a", "--episodes", "1", "--steps", "5", "--runs", "1",
                 "--scheduler", f"tcp://127.0.0.1:{_free_port()}", "--out", str(tmp_path)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(lines) == 1 and "cannot connect" in lines[0], lines
    assert time.monotonic() - start < 60
