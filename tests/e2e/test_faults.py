"""Faults while training: Ctrl-C while workers start, a second writer, a full disk, a
read-only or forbidden folder, runs stopped before (some of) their first checkpoints. Each
ends in exit 130 or one line and exit 1, with the run file at its last checkpoint and
resumable to the result of an uninterrupted run."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from adaptsky.store import atomic
from adaptsky.store.atomic import error_code, storage_error
from adaptsky.store.lock import lock_path, run_lock
from adaptsky.store.run_file import RunReader
from adaptsky.training.runner import RunFileWriter, SeedTask, train_stack
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.faults import assert_same_run, leftovers, resume, stub
from tests.helpers.training import small_scenario

ADAPTSKY = Path(sys.executable).with_name("adaptsky")
RUN = ["--seeds", "0,1", "--episodes", "2", "--steps", "10", "--checkpoint-every", "1",
       "--quiet"]


def train_args(scenario: Path, out: Path, workers: int = 1) -> list[str]:
    return ["train", str(scenario), *RUN, "--workers", str(workers), "--out", str(out)]


def test_sigterm_at_start_up_is_one_line_and_130(tmp_path):
    # SIGTERM's default action killed the process without a word (exit -15)
    process = subprocess.Popen([str(ADAPTSKY), "scenario", "validate", "--help"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    time.sleep(0.15)
    os.kill(process.pid, signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode in (0, 130), stderr  # 0 only if it finished first
    assert "Traceback" not in stderr
    if process.returncode == 130:
        assert stderr.strip() == "interrupted"


def one_line(captured: pytest.CaptureResult) -> str:
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    return lines[0]


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Path:
    return small_scenario(tmp_path_factory.mktemp("scenario"))


@pytest.fixture(scope="module")
def reference(scenario, tmp_path_factory) -> Path:
    """An uninterrupted run: seeds 0 and 1, 2 episodes of 10 steps, checkpoints after each."""
    out = tmp_path_factory.mktemp("reference") / "ref.h5"
    assert main(train_args(scenario, out)) == 0
    return out


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_to_the_process_group_while_workers_start_exits_130(scenario, reference,
                                                                   tmp_path, signum):
    # the terminal's Ctrl-C reaches every process; workers still importing used to print
    # KeyboardInterrupt tracebacks, die with -2, and the run ended "seed N failed", exit 1.
    # A batch scheduler's SIGTERM to the job killed every process without a checkpoint.
    out = tmp_path / "startup.h5"
    process = subprocess.Popen([str(ADAPTSKY), *train_args(scenario, out, workers=2)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    deadline = time.monotonic() + 60
    while not lock_path(out).exists():  # the writer holds the run: workers start next
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)
    time.sleep(0.3)
    os.killpg(process.pid, signum)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr and "failed" not in stderr, stderr
    assert leftovers(out) == []
    if out.exists():  # interrupted after the file was made: it continues to the same result
        assert main(resume(out)) == 0
        assert_same_run(out, reference)


def test_second_writer_is_refused_naming_the_holder(scenario, reference, tmp_path, capsys):
    # two --resume (or a --resume during train) both wrote the run: 8 differences
    path = tmp_path / "held.h5"
    path.write_bytes(reference.read_bytes())
    before = path.read_bytes()
    with run_lock(path):
        assert main([*resume(path), "--episodes", "6"]) == 1
        line = one_line(capsys.readouterr())
        assert line.startswith(f"{path}: in use by process {os.getpid()} ")
        assert main(train_args(scenario, tmp_path / "new.h5")) == 0  # other runs are free
        assert main(["inspect", str(path)]) == 0  # readers do not lock
    assert path.read_bytes() == before and leftovers(path) == []
    capsys.readouterr()
    with run_lock(tmp_path / "fresh.h5"):  # being created by another train
        assert main(train_args(scenario, tmp_path / "fresh.h5")) == 1
        assert "in use by process" in one_line(capsys.readouterr())


def test_lock_of_a_killed_writer_is_released(tmp_path):
    # an OS lock dies with its process: kill -9 never leaves a stale lock
    path = tmp_path / "killed.h5"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from pathlib import Path; from adaptsky.store.lock import "
        "run_lock\nwith run_lock(Path(sys.argv[1])):\n print('held', flush=True); "
        "time.sleep(60)"), str(path)], stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    holder.kill()
    holder.wait()
    with run_lock(path):
        assert lock_path(path).read_text().strip() == str(os.getpid())
    assert not lock_path(path).exists()


def failing_writes(monkeypatch: pytest.MonkeyPatch, code: int, after: int) -> None:
    """Every file written by the store after the first ``after`` fails with ``code``."""
    written = [0]

    def fake_open(file, mode="r", *args, **kwargs):
        if "w" in mode:
            written[0] += 1
            if written[0] > after:
                raise OSError(code, os.strerror(code), str(file))
        return open(file, mode, *args, **kwargs)

    monkeypatch.setattr(atomic, "open", fake_open, raising=False)


@pytest.mark.parametrize(("code", "advice"), [
    (errno.ENOSPC, "free space on its disk"), (errno.EROFS, "read-only"),
    (errno.EACCES, "check the permissions")])
def test_disk_fault_mid_run_is_one_line_and_resumes_identically(
        scenario, reference, tmp_path, capsys, monkeypatch, code, advice):
    # writes: the new file, then seeds 0 and 1 at episode 1 (one write for the stack); the
    # write at episode 2 fails
    out = tmp_path / "fault.h5"
    failing_writes(monkeypatch, code, after=2)
    assert main(train_args(scenario, out)) == 1
    line = one_line(capsys.readouterr())
    assert line == (f"{out}: cannot write it ({os.strerror(code)}); {line.split('; ')[1]}; "
                    f"{out} keeps its last checkpoints: continue it with adaptsky train "
                    f"--resume {out}")
    assert advice in line
    assert leftovers(out) == []
    with RunReader(out) as run:
        assert [run.seed_attrs(seed)["episodes_done"] for seed in run.seeds] == [1, 1]
    monkeypatch.undo()
    assert main(resume(out)) == 0
    assert_same_run(out, reference)


def test_stack_checkpoints_cost_one_write_per_round_and_a_late_fault_only_warns(
        scenario, reference, tmp_path, capsys, monkeypatch):
    """Both seeds of the stack checkpoint in one rewrite of the file (creation + 2 rounds = 3
    writes; it was 1 + 2 x 2), and a disk that fills after the last checkpoint costs only the
    session record: exit 0, a warning, the run complete and equal to the reference."""
    out = tmp_path / "late.h5"
    failing_writes(monkeypatch, errno.ENOSPC, after=3)
    assert main(train_args(scenario, out)) == 0
    err = capsys.readouterr().err
    assert "warning: the session history was not recorded" in err and "Traceback" not in err
    monkeypatch.undo()
    assert leftovers(out) == []
    assert_same_run(out, reference)
    with RunReader(out) as run:
        assert run.sessions == []


def test_disk_fault_on_the_first_write_leaves_no_file(scenario, tmp_path, capsys,
                                                      monkeypatch):
    out = tmp_path / "never.h5"
    failing_writes(monkeypatch, errno.ENOSPC, after=0)
    assert main(train_args(scenario, out)) == 1
    assert one_line(capsys.readouterr()).startswith(f"{out}: cannot write it (No space left")
    assert not out.exists() and leftovers(out) == []


def test_real_full_disk_exits_1_not_a_segfault(scenario, reference, tmp_path):
    # the disk filling during training used to end in exit 139 (HDF5 cannot close a file
    # whose flush failed) or a traceback, with stale copies; RLIMIT_FSIZE fails every write
    # past the limit as a full disk would (EFBIG instead of ENOSPC)
    out = tmp_path / "full.h5"
    limit = reference.stat().st_size // 2
    code = (f"import resource, signal, sys\nsignal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
            f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))\n"
            "from adaptsky_cli.cli.main import main\nsys.exit(main(sys.argv[1:]))")
    done = subprocess.run([sys.executable, "-c", code, *train_args(scenario, out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{out}: cannot write it (File too large)")
    assert leftovers(out) == []
    assert main(resume(out)) == 0
    assert_same_run(out, reference)


def test_run_killed_before_its_first_checkpoint_resumes(scenario, reference, tmp_path,
                                                        capsys):
    # the stub used to be refused by --resume ("no checkpoint") and to block its --out
    path = tmp_path / "stub.h5"
    stub(scenario, path)
    assert main(train_args(scenario, path)) == 1
    assert one_line(capsys.readouterr()).endswith(f"continue it with --resume {path}")
    assert main(resume(path)) == 0
    assert_same_run(path, reference)


def test_seeds_checkpointed_or_not_each_continue_from_where_they_are(scenario, reference,
                                                                     tmp_path):
    # seed 0 checkpointed at episode 1, seed 1 not yet: "no checkpoint for some seed" lost
    # seed 0's work; now seed 0 continues from 1 and seed 1 starts from zero
    path = tmp_path / "half.h5"
    loaded = stub(scenario, path)
    errors: list[str] = []
    task = SeedTask(loaded, 0, 1, 1, loaded.train.trajectory_every)
    train_stack([task], RunFileWriter(path, {0: 0}, errors), lambda: False)
    assert not errors
    with RunReader(path) as run:
        assert run.has_checkpoint(0) and not run.has_checkpoint(1)
    assert main(resume(path)) == 0
    assert_same_run(path, reference)


def test_stale_copies_of_dead_writers_are_removed(reference, tmp_path):
    path = tmp_path / "stale.h5"
    path.write_bytes(reference.read_bytes())
    stale = path.with_name(f".{path.name}.tmp-{2**22 + 12345}")  # above any pid_max
    stale.write_bytes(b"half a copy")
    live = path.with_name(f".{path.name}.tmp-{os.getppid()}")
    live.write_bytes(b"being written")
    with run_lock(path):
        pass
    assert not stale.exists() and live.exists()


def test_command_line_lines(scenario, reference, tmp_path, capsys):
    out = tmp_path / "x.h5"
    cases = [
        (["--seeds", "0,,1"], "adaptsky train: --seeds: '0,,1' is not a list of seeds; give "
                                "integers >= 0 and ranges, e.g. 0,1,2 or 0-5 or 0-2,7"),
        (["--seeds", "0,1,0"], "adaptsky train: --seeds: 0 given more than once; give each "
                                 "seed once"),
    ]
    for extra, expected in cases:  # usage errors (issue 52)
        assert main(["train", str(scenario), *extra, "--out", str(out)]) == 2
        assert one_line(capsys.readouterr()).startswith(expected)
    assert main(train_args(scenario, tmp_path)) == 1  # a folder: not "--resume DIR"
    assert one_line(capsys.readouterr()) == (f"{tmp_path}: is a folder; give a run file "
                                             f"name, e.g. --out {tmp_path / 'run.h5'}")
    blocker = tmp_path / "file.txt"
    blocker.write_text("")
    assert main(train_args(scenario, blocker / "run.h5")) == 1
    assert one_line(capsys.readouterr()) == (
        f"{blocker}: cannot create the folder (Not a directory); a part of the path is a "
        "file, not a folder: choose another path")
    assert not out.exists()


def test_resume_of_a_finished_run_says_so_and_quiet_is_quiet(reference, tmp_path, capsys):
    path = tmp_path / "done.h5"
    path.write_bytes(reference.read_bytes())
    assert main(resume(path)) == 0
    assert one_line(capsys.readouterr()) == (
        f"{path}: already complete (2 episodes per seed), nothing trained; to train it "
        "further give --episodes with more than 2")
    assert main([*resume(path), "--episodes", "3"]) == 0
    assert capsys.readouterr().err == ""  # --quiet: only the table (on stdout)


def test_h5py_errors_name_their_errno_and_file():
    error = OSError("Can't synchronously write data (file write failed: time = x, filename "
                    "= '/d/.r.h5.tmp-7', file descriptor = 5, errno = 28, error message = "
                    "'No space left on device')")
    assert error_code(error) == errno.ENOSPC
    assert str(storage_error(Path("/d/r.h5"), "cannot write it", error)) == (
        "/d/r.h5: cannot write it (No space left on device); free space on its disk or "
        "write elsewhere")


def test_commands_that_do_not_train_start_without_torch():
    # every command took 3-4.5 s to start: torch was imported up front
    code = ("import sys\nfrom adaptsky_cli.cli.main import main\n"
            "for argv in (['--help'], ['plugins', 'list'], ['train', '--help'],\n"
            "             ['scenario', 'validate', sys.argv[1]]):\n"
            "    main(argv)\n"
            "print('torch' in sys.modules, file=sys.stderr)")
    done = subprocess.run([sys.executable, "-c", code,
                           str(SCENARIOS / "nyc_mmwave.toml")],
                          capture_output=True, text=True, timeout=60)
    assert done.stderr.strip().splitlines()[-1] == "False", done.stderr


def test_pin_threads_limits_blas_after_numpy_is_imported():
    from threadpoolctl import threadpool_info

    from adaptsky.training.host import pin_threads

    pin_threads()
    assert {pool["num_threads"] for pool in threadpool_info()} == {1}


@pytest.mark.parametrize(("error", "expected"), [
    (TypeError("boom"), "adaptsky: internal error (TypeError: boom); this is a bug: run again "
                        "with ADAPTSKY_DEBUG=1 for the traceback and report it"),
    (MemoryError(), "adaptsky: out of memory; use a smaller scenario")])
def test_an_unforeseen_error_is_one_line_and_debug_shows_it(error, expected, reference,
                                                            capsys, monkeypatch):
    # a bug (or an allocation no estimate foresaw) ended in a traceback of dozens of lines
    def broken(self, *args, **kwargs):
        raise error

    monkeypatch.setattr(RunReader, "__init__", broken)
    assert main(["inspect", str(reference)]) == 1
    assert one_line(capsys.readouterr()).startswith(expected)
    monkeypatch.setenv("ADAPTSKY_DEBUG", "1")
    with pytest.raises(type(error)):
        main(["inspect", str(reference)])
