"""What fuzzing the command line found after the hardening of issues 9 and 13: each case
ended in a traceback, an out-of-memory kill, a hang, a changed file or garbled output."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import h5py
import pytest

from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

SCENARIO = str(SCENARIOS / "nyc_mmwave.toml")


@pytest.fixture
def run(tiny_run: Path) -> Path:
    """The session's tiny run (tests/conftest.py), read only; tests that change it take
    tiny_run_copy."""
    return tiny_run


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def one_line(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    return lines[0]


def test_a_resume_refused_for_memory_leaves_the_file_as_it_was(tiny_run_copy, capsys):
    # the new episode target was written into the file before the memory check refused it
    path = tiny_run_copy
    with h5py.File(path, "r+") as f:
        config = json.loads(f["config"][()])
        config["agent"]["memory_size"] = 2**53
        del f["config"]
        f["config"] = json.dumps(config)
    before = digest(path)
    assert main(["train", "--resume", str(path), "--episodes", "3", "--quiet"]) == 1
    assert "of memory" in one_line(capsys)
    assert digest(path) == before


def test_an_attribute_a_later_version_adds_to_a_seed_is_left_alone(tiny_run_copy, capsys):
    # seed_attrs made every attribute an int: 'damaged' for inspect, and a resume that failed
    # after training
    path = tiny_run_copy
    with h5py.File(path, "r+") as f:
        f["seeds/0"].attrs["note"] = "hello"
    assert main(["inspect", str(path)]) == 0
    assert main(["train", "--resume", str(path), "--episodes", "3", "--workers", "1",
                 "--quiet"]) == 0
    with h5py.File(path, "r") as f:
        assert f["seeds/0"].attrs["episodes_done"] == 3 and f["seeds/0"].attrs["note"] == "hello"


@pytest.mark.parametrize("argv", [
    ["eval", "--checkpoint", "RUN", "--steps", str(10**20), "--compare", "soa"],
    ["baseline", SCENARIO, "--method", "soa", "--layouts", str(10**8), "--steps", "1"]])
def test_rollouts_no_machine_holds_are_refused_before_any_work(argv, run, capsys):
    # eval --steps 1e20 promised "2712688085666 h left"; baseline --layouts 1e8 grew until
    # the kernel killed it
    argv = [str(run) if item == "RUN" else item for item in argv]
    assert main(argv) == 1
    line = one_line(capsys)
    assert "of memory, this machine has" in line and "lower --steps or --layouts" in line


def test_plot_titles_are_literal_text(run, tmp_path, capsys):
    # a '$' started TeX math: "internal error (ValueError: )"
    out = tmp_path / "curves.png"
    assert main(["plot", str(run), "--title", r"$\foo{$ 100$", "--out", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"


def test_reproduce_out_that_is_a_file(tmp_path, capsys):
    # "cannot access it (File exists); check the path and its file system"
    out = tmp_path / "notes.txt"
    out.write_text("x")
    assert main(["reproduce", "e3", "--out", str(out), "--runs", "1", "--episodes", "1"]) == 1
    assert one_line(capsys) == (f"{out}: is a file; --out names the folder the experiment's "
                                "runs, evaluations and report go to")


def test_user_text_in_messages_is_printed_as_it_is(capsys):
    # Rich turned ':thumbs_up:' into an emoji and 'cuda:-1:' into 'cuda👎'
    assert main(["plugins", "show", ":thumbs_up:"]) == 1
    assert one_line(capsys).startswith("unknown channel model ':thumbs_up:'")
