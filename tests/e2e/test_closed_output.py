"""Output whose reader went away (``adaptsky inspect RUN.h5 | head -1``): the command ends
quietly with exit code 141 (128 + SIGPIPE, as a shell reports a Unix tool a broken pipe
ended), no message and no traceback, and a file it writes is whole (adaptsky_cli.cli.entry)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from adaptsky.report.eval_summary import read_eval_file
from adaptsky_cli.cli.console import OUTPUT_CLOSED_EXIT
from tests.conftest import SCENARIOS

ADAPTSKY = Path(sys.executable).with_name("adaptsky")
NOISE = ("Traceback", "Exception ignored", "Broken pipe", "BrokenPipe", "error", "Errno")


def with_stdout_closed(args: list[str], cwd: Path) -> tuple[int, str]:
    """Run ``adaptsky ARGS`` with the reading end of its stdout closed before it writes
    anything (it takes a second to start): its exit code and stderr."""
    proc = subprocess.Popen([str(ADAPTSKY), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=cwd)
    assert proc.stdout is not None
    proc.stdout.close()
    _, stderr = proc.communicate(timeout=120)
    return proc.returncode, stderr.decode()


def quiet(stderr: str) -> bool:
    return not any(word in stderr for word in NOISE)


@pytest.mark.parametrize("args", [
    ["inspect", "RUN"],            # Rich tables on stdout
    ["inspect", "RUN", "--json"],  # a plain print, flushed at exit
    ["plugins", "list"],
    ["plugins", "show", "mmwave-nyc"],
    ["scenario", "show", str(SCENARIOS / "nyc_mmwave.toml")],
    ["train", "--help"],           # Typer's own console
    ["--version"],
], ids=lambda args: " ".join(a if "/" not in a else Path(a).name for a in args))
def test_closed_stdout_ends_quietly_with_141(args, tiny_run, tmp_path):
    code, stderr = with_stdout_closed([str(tiny_run) if a == "RUN" else a for a in args],
                                      tmp_path)
    assert (code, stderr) == (OUTPUT_CLOSED_EXIT, "")


def test_eval_with_stdout_closed_writes_its_eval_file_whole(tiny_run, tmp_path):
    out = tmp_path / "eval.h5"
    code, stderr = with_stdout_closed(["eval", str(tiny_run), "--steps", "5", "--out",
                                       str(out)], tmp_path)
    assert code == OUTPUT_CLOSED_EXIT and quiet(stderr), stderr
    assert "eval file:" not in stderr  # ended at the table, before its last line
    _, results = read_eval_file(out)  # whole: it reads and holds every method
    assert list(results["methods"]) == ["policy", "soa", "random"] and results["steps"] == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval.h5"]  # no temporary left


def test_a_shell_pipe_into_head(tiny_run, tmp_path):
    """What a person types: the first line arrives; the exit status is 141 where the pipe
    closed before adaptsky finished writing, 0 where it had already written everything."""
    done = subprocess.run(["bash", "-c", f'"{ADAPTSKY}" plugins list | head -1; '
                           'echo "status ${PIPESTATUS[0]}" >&2'],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.stdout.split()[:4] == ["name", "status", "contract", "package"]
    assert done.stdout.count("\n") == 1
    assert done.stderr.strip() in ("status 0", f"status {OUTPUT_CLOSED_EXIT}")


def test_an_error_line_nobody_reads_ends_quietly_too(tmp_path):
    """stderr closed (``adaptsky ... 2>&1 | head -0``): the error's one line cannot be said;
    141, as for stdout, not a traceback into the void and exit 1."""
    proc = subprocess.Popen([str(ADAPTSKY), "plugins", "show", "mmwave-nyk"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=tmp_path)
    assert proc.stderr is not None
    proc.stderr.close()
    assert proc.wait(timeout=120) == OUTPUT_CLOSED_EXIT
