"""A file a command reads that the user may not read is that command's error, one line and
exit code 1 (README: every error but a usage error), not a usage error with exit code 2: the
parser does not check whether a path can be read (Typer's ``readable`` check, turned off in
adaptsky_cli.cli.main), the command's own reading says it.

Tests run as root here, and root reads a file without read permission: there the refusal is
simulated where a user meets it, ``os.access`` (the parser's check) and ``os.open`` (every
reader of run and scenario files) failing with EACCES for that one path. As any other user
the file is really made unreadable (chmod 000) and the simulation is skipped."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest

from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.cli import one_line


def _really_locked(path: Path) -> bool:
    path.chmod(0)
    return not os.access(path, os.R_OK)


@pytest.fixture(params=["chmod", "simulated"])
def lock(request, monkeypatch):
    """``lock(path)``: make ``path`` unreadable to the commands."""
    def really(path: Path) -> None:
        if not _really_locked(path):
            pytest.skip("this user (root) reads files without read permission")

    def simulated(path: Path) -> None:
        if _really_locked(path):
            pytest.skip("the file is really unreadable here (the chmod case tests it)")
        locked = path.resolve()
        access, opened = os.access, os.open

        def denied_access(name, mode, *args, **kwargs):
            if Path(name).resolve() == locked and mode & os.R_OK:
                return False
            return access(name, mode, *args, **kwargs)

        def denied_open(name, flags, *args, **kwargs):
            if Path(os.fsdecode(name)).resolve() == locked:
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(name))
            return opened(name, flags, *args, **kwargs)

        monkeypatch.setattr(os, "access", denied_access)
        monkeypatch.setattr(os, "open", denied_open)

    return really if request.param == "chmod" else simulated


RUN_LINE = "{}: cannot read run file (Permission denied); check its permissions"
SCENARIO_LINE = "{}: cannot read scenario file: Permission denied"


@pytest.mark.parametrize("args", [
    ["inspect", "RUN"], ["eval", "RUN"], ["eval", "--checkpoint", "RUN"],
    ["show", "RUN", "--out", "FIG"], ["plot", "RUN"], ["train", "--resume", "RUN"],
    ["inspect", "--json", "RUN"]],
    ids=" ".join)
def test_an_unreadable_run_file_is_one_line_and_exit_1(args, lock, tiny_run, tmp_path,
                                                       capsys):
    run = Path(shutil.copyfile(tiny_run, tmp_path / "locked.h5"))
    lock(run)
    named = {"RUN": str(run), "FIG": str(tmp_path / "fig.png")}
    assert main([named.get(a, a) for a in args]) == 1
    assert one_line(capsys) == RUN_LINE.format(run)
    assert [p.name for p in tmp_path.iterdir()] == ["locked.h5"]  # nothing written beside it


@pytest.mark.parametrize("args", [
    ["scenario", "validate", "TOML"], ["scenario", "show", "TOML"],
    ["train", "TOML", "--episodes", "1", "--steps", "2", "--quiet"],
    ["baseline", "TOML", "--method", "soa", "--steps", "2"]], ids=" ".join)
def test_an_unreadable_scenario_file_is_one_line_and_exit_1(args, lock, tmp_path, capsys):
    scenario = Path(shutil.copyfile(SCENARIOS / "nyc_mmwave.toml", tmp_path / "locked.toml"))
    lock(scenario)
    assert main([str(scenario) if a == "TOML" else a for a in args]) == 1
    assert one_line(capsys) == SCENARIO_LINE.format(scenario)
    assert [p.name for p in tmp_path.iterdir()] == ["locked.toml"]


def test_eval_on_an_unreadable_scenario(lock, tiny_run, tmp_path, capsys):
    scenario = Path(shutil.copyfile(SCENARIOS / "nyc_mmwave.toml", tmp_path / "locked.toml"))
    lock(scenario)
    assert main(["eval", str(tiny_run), "--scenario", str(scenario), "--steps", "2",
                 "--out", str(tmp_path / "e.h5")]) == 1
    assert one_line(capsys) == SCENARIO_LINE.format(scenario)
    assert not (tmp_path / "e.h5").exists()
