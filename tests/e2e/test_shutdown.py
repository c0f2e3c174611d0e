"""Ending a training of several seeds in worker processes under faults: a second Ctrl-C, a
full disk, the run file deleted. Each ends within seconds (never a hang), in exit 130 or one
line and exit 1, with every checkpoint written before intact and a resume that gives the
uninterrupted run, bit for bit. (docs/training.md, "Stopping and faults".)

The many-trial versions are marked slow; the default run has a few trials of each."""

from __future__ import annotations

import multiprocessing
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from adaptsky.store import atomic
from adaptsky.store.atomic import FileGoneError, rewrite
from adaptsky.store.lock import lock_path, run_lock, writer_of
from adaptsky.store.run_file import RunReader
from adaptsky.training import host, interrupts
from adaptsky_cli.cli import entry
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.faults import assert_same_run, leftovers, resume, stub
from tests.helpers.training import small_scenario

ADAPTSKY = Path(sys.executable).with_name("adaptsky")
SCENARIO = SCENARIOS / "nyc_mmwave.toml"
EPISODES, STEPS = 6, 50  # the paper's network: checkpoints of about 400 kB, more than a pipe holds


def train_args(scenario: Path, out: Path, seeds: int) -> list[str]:
    return ["train", str(scenario), "--seeds", ",".join(map(str, range(seeds))),
            "--episodes", str(EPISODES), "--steps", str(STEPS), "--checkpoint-every", "1",
            "--workers", str(seeds), "--out", str(out), "--quiet"]


@pytest.fixture(scope="module")
def scenario() -> Path:
    return SCENARIO


@pytest.fixture(scope="module")
def references(scenario, tmp_path_factory) -> dict[int, tuple[Path, float]]:
    """Uninterrupted runs of 2 and 4 seeds, and how long each took as a command."""
    made = {}
    for seeds in (2, 4):
        out = tmp_path_factory.mktemp("reference") / f"ref{seeds}.h5"
        start = time.monotonic()
        done = subprocess.run([str(ADAPTSKY), *train_args(scenario, out, seeds)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        made[seeds] = (out, time.monotonic() - start)
    return made


def start(args: list[str], preexec=None) -> subprocess.Popen:
    return subprocess.Popen([str(ADAPTSKY), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=preexec)


def wait_for_writer(process: subprocess.Popen, out: Path) -> None:
    """Until the run file exists (the writer holds it; its workers start next)."""
    deadline = time.monotonic() + 120
    while not out.exists():
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)


def finish(process: subprocess.Popen, within_s: float) -> tuple[int, str, float]:
    """Exit code, stderr and seconds to exit; a process still running after ``within_s`` is
    killed and the test fails."""
    began = time.monotonic()
    try:
        _, stderr = process.communicate(timeout=within_s)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"still running {within_s} s later: a hang")
    return process.returncode, stderr, time.monotonic() - began


def checkpoints(path: Path) -> dict[int, int]:
    """Each seed's episode at its checkpoint, every checkpoint read in full (0: none)."""
    with RunReader(path) as run:
        return {seed: int(run.checkpoint(seed)["episode"]) if run.has_checkpoint(seed) else 0
                for seed in run.seeds}


def double_ctrl_c(scenario: Path, reference: Path, out: Path, seeds: int, rng: random.Random,
                  check_resume: bool) -> None:
    """One trial: Ctrl-C to the process group at a random moment of the training, again a
    random 0.05 to 0.5 s later."""
    process = start(train_args(scenario, out, seeds))
    wait_for_writer(process, out)
    time.sleep(rng.uniform(0.0, 4.0))
    os.killpg(process.pid, signal.SIGINT)
    seen = checkpoints(out) if out.exists() else {}
    time.sleep(rng.uniform(0.05, 0.5))
    os.killpg(process.pid, signal.SIGINT)
    code, stderr, _ = finish(process, within_s=5.0)
    assert "Traceback" not in stderr and "Exception ignored" not in stderr, stderr
    if code == 0:  # it had finished before the first Ctrl-C reached it
        assert process.returncode == 0
    else:
        assert code == 130, stderr
    assert leftovers(out) == []
    after = checkpoints(out)  # every checkpoint reads back in full
    assert all(after[seed] >= seen.get(seed, 0) for seed in after)
    if check_resume:
        assert main(resume(out)) == 0
        assert_same_run(out, reference)


@pytest.mark.parametrize("seeds", [2, 4])
def test_double_ctrl_c_exits_130_within_5_s(scenario, references, tmp_path, seeds):
    # a second Ctrl-C used to hang in 4 of 10 trials: the parent stopped reading, SIGTERMed
    # workers that ignore SIGTERM and joined them, one blocked sending its checkpoint
    rng = random.Random(seeds)
    for trial in range(2):
        double_ctrl_c(scenario, references[seeds][0], tmp_path / f"t{trial}.h5", seeds, rng,
                      check_resume=trial == 0 and seeds == 2)


@pytest.mark.slow
@pytest.mark.parametrize("seeds", [2, 4])
def test_double_ctrl_c_20_trials(scenario, references, tmp_path, seeds):
    rng = random.Random(100 + seeds)
    for trial in range(20):
        double_ctrl_c(scenario, references[seeds][0], tmp_path / f"t{trial}.h5", seeds, rng,
                      check_resume=trial % 5 == 0)


def file_size_limit(limit: int):
    def apply() -> None:  # in the child: writes past ``limit`` fail as on a full disk (EFBIG)
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def full_disk(scenario: Path, reference_s: float, out: Path, seeds: int,
              preexec=None) -> str:
    """Train until a write fails: one line, exit 1, no stale copies, and at most 10 s longer
    than the whole uninterrupted run took (``reference_s``); the line is returned."""
    process = start(train_args(scenario, out, seeds), preexec)
    code, stderr, _ = finish(process, within_s=reference_s + 10.0)
    lines = stderr.strip().splitlines()
    assert code == 1 and len(lines) == 1, stderr
    assert leftovers(out) == []
    return lines[0]


@pytest.mark.parametrize("seeds", [2, 4])
def test_full_disk_is_one_line_and_exit_1(scenario, references, tmp_path, seeds):
    # with two seeds the writer's error used to leave workers training into a pipe nobody read:
    # the command printed nothing and sat at 0% CPU until killed
    ref = references[seeds][0]
    for fraction in (0.5,) if seeds == 2 else (0.3,):
        out = tmp_path / f"full-{fraction}.h5"
        line = full_disk(scenario, references[seeds][1], out, seeds,
                         file_size_limit(int(ref.stat().st_size * fraction)))
        assert line.startswith(f"{out}: cannot write it (File too large)"), line
        if out.exists():
            assert main(resume(out)) == 0
            assert_same_run(out, ref)


def mount_tmpfs(where: Path, size_kib: int) -> bool:
    where.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kib}k", "tmpfs",
                           str(where)], capture_output=True)
    return done.returncode == 0


@pytest.mark.slow
@pytest.mark.parametrize("seeds", [2, 4])
def test_full_tmpfs_at_several_sizes(scenario, references, tmp_path, seeds):
    ref = references[seeds][0]
    size_kib = ref.stat().st_size // 1024
    for fraction in (0.4, 0.8, 1.2, 1.6):
        disk = tmp_path / f"disk-{fraction}"
        if not mount_tmpfs(disk, int(size_kib * fraction)):
            pytest.skip("cannot mount a tmpfs here (needs root)")
        try:
            out = disk / "run.h5"
            line = full_disk(scenario, references[seeds][1], out, seeds)
            assert line.startswith(f"{out}: cannot write it (No space left on device)"), line
            if out.exists():  # space freed: the file moved to a disk with room
                moved = tmp_path / f"moved-{fraction}.h5"
                shutil.copy(out, moved)
                assert main(resume(moved)) == 0
                assert_same_run(moved, ref)
        finally:
            subprocess.run(["umount", str(disk)], check=True)


@pytest.mark.parametrize("seeds", [1, 2])
def test_run_file_deleted_while_training_is_one_line_and_exit_1(scenario, tmp_path, seeds):
    # one seed ended in "internal error (KeyError ...)"; two sometimes wrote the file again
    out = tmp_path / "deleted.h5"
    args = train_args(scenario, out, seeds)
    args[args.index("--episodes") + 1] = "30"
    process = start(args)
    wait_for_writer(process, out)
    while process.poll() is None and not any(checkpoints(out).values()):
        time.sleep(0.05)
    out.unlink()
    code, stderr, _ = finish(process, within_s=15.0)
    lines = stderr.strip().splitlines()
    assert code == 1 and lines == [
        f"{out}: the run file was removed during training; training stopped and wrote nothing "
        "in its place (a copy of the run continues with adaptsky train --resume COPY)"], stderr
    assert not out.exists() and leftovers(out) == []


def test_a_file_removed_or_replaced_during_a_rewrite_is_never_written(tmp_path, monkeypatch):
    path = tmp_path / "run.h5"
    with rewrite(path, fresh=True) as file:
        file.attrs["n"] = 1
    with pytest.raises(FileGoneError):  # removed before the update starts
        other = tmp_path / "other.h5"
        with rewrite(other) as file:
            pass
    assert not other.exists()

    real = atomic._check_free_space

    def meanwhile(action):
        def check(target: Path, size: int) -> None:
            action()
            real(target, size)
        monkeypatch.setattr(atomic, "_check_free_space", check)

    meanwhile(lambda: path.unlink())  # removed while the update is being made
    with pytest.raises(FileGoneError), rewrite(path) as file:
        file.attrs["n"] = 2
    assert not path.exists() and leftovers(path) == []

    meanwhile(lambda: None)
    with rewrite(path, fresh=True) as file:
        file.attrs["n"] = 3
    meanwhile(lambda: path.write_bytes(b"someone else's"))  # replaced meanwhile
    with pytest.raises(FileGoneError), rewrite(path) as file:
        file.attrs["n"] = 4
    assert path.read_bytes() == b"someone else's"


def _sleep_forever(ready) -> None:
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_IGN)
    ready.set()
    time.sleep(3600)


def _send_forever(connection) -> None:
    interrupts.ignore_stop_signals()
    try:
        while True:
            connection.send(b"x" * 100_000)  # blocks: nobody reads
    except OSError:
        pass  # the parent closed its end


def test_workers_that_do_not_end_are_killed_after_the_grace():
    context = multiprocessing.get_context("spawn")
    ready = context.Event()
    stuck = context.Process(target=_sleep_forever, args=(ready,), daemon=True)
    reader, writer = context.Pipe(duplex=False)
    sending = context.Process(target=_send_forever, args=(writer,), daemon=True)
    stuck.start()
    sending.start()
    writer.close()
    # both have started, however loaded the machine: one ignores SIGTERM, one is sending
    assert ready.wait(60) and reader.poll(60)
    workers = [host._Worker(stuck, None, {0}), host._Worker(sending, reader, {1})]
    began = time.monotonic()
    host.end(workers, grace_s=1.0)
    assert time.monotonic() - began < 3.0
    assert stuck.exitcode == -signal.SIGKILL  # it ignores SIGTERM: killed
    assert sending.exitcode == 0  # its blocked send failed once the pipe closed: it ended


def test_eval_of_a_run_still_before_its_first_checkpoint_names_the_writer(tmp_path, capsys):
    # said "the run stopped before its first one; continue it with --resume", which the
    # writer's lock refuses
    path = tmp_path / "young.h5"
    stub(small_scenario(tmp_path), path)
    assert writer_of(path) is None
    with run_lock(path):
        assert writer_of(path) == f"process {os.getpid()}"
        assert main(["eval", "--checkpoint", str(path), "--steps", "5"]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"{path}: seed 0 has no checkpoint yet: process {os.getpid()} is "
                     "training it and writes the first after 1 episode; try again then"]
    assert not lock_path(path).exists()
    assert main(["eval", "--checkpoint", str(path), "--steps", "5"]) == 1
    assert "the run stopped before its first one" in capsys.readouterr().err


def test_signals_are_ignored_once_the_exit_code_is_known(monkeypatch):
    # a Ctrl-C in torch's exit handlers printed "Exception ignored in atexit callback"
    import adaptsky_cli.cli.main as cli_main

    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    monkeypatch.setattr(cli_main, "main", lambda: 0)
    try:
        with pytest.raises(SystemExit) as done:
            entry.run()
        assert done.value.code == 0
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
