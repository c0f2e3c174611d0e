"""A run file reached through a symbolic link (``latest.h5 -> run-....h5``) is read, evaluated
and resumed as the file itself (docs/file-format.md "Checks on reading"): a resume rewrites
the target and leaves the link, locks the target, and keeps to the file it locked if the link
is moved meanwhile. Links inside the file are still refused."""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import h5py
import pytest

from adaptsky.store import run_file
from adaptsky.store.lock import lock_path, run_lock, writer_of
from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import main
from tests.helpers.run_files import DAMAGES, check_all_refuse, run_commands


def _link(tmp_path: Path, run: Path) -> Path:
    """``tmp_path/links/latest.h5`` -> ``run``, relative, in another folder than the run."""
    link = tmp_path / "links" / "latest.h5"
    link.parent.mkdir(exist_ok=True)
    link.symlink_to(os.path.relpath(run, link.parent))
    return link


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_inspect_and_eval_read_a_run_through_a_link(tiny_run, tmp_path, capsys):
    link = _link(tmp_path, tiny_run)
    commands = run_commands(link, tmp_path / "eval.h5")
    for name in ("inspect", "eval"):
        assert main(commands[name]) == 0, (name, capsys.readouterr().err)
    assert "nyc" in capsys.readouterr().out
    assert (tmp_path / "eval.h5").is_file()


def test_resume_through_a_link_rewrites_the_target_and_keeps_the_link(tiny_run_copy, tmp_path,
                                                                     capsys):
    link = _link(tmp_path, tiny_run_copy)
    pointed = os.readlink(link)
    assert main(["train", "--resume", str(link), "--episodes", "3", "--workers", "1",
                 "--quiet"]) == 0, capsys.readouterr().err
    assert link.is_symlink() and os.readlink(link) == pointed
    with RunReader(tiny_run_copy) as run:
        assert {run.seed_attrs(seed)["episodes_done"] for seed in run.seeds} == {3}
        assert run.sessions[-1]["kind"] == "resume"
    left = sorted(p.name for folder in (link.parent, tiny_run_copy.parent)
                  for p in folder.iterdir())
    assert left == sorted(["latest.h5", "links", tiny_run_copy.name]), left  # no lock, no copy


def test_the_lock_is_on_the_target(tiny_run_copy, tmp_path, capsys):
    link = _link(tmp_path, tiny_run_copy)
    with run_lock(tiny_run_copy):
        assert writer_of(link) == f"process {os.getpid()}"
        assert main(["train", "--resume", str(link), "--episodes", "3", "--workers", "1",
                     "--quiet"]) == 1
        assert capsys.readouterr().err.startswith(f"{link}: in use by process {os.getpid()}")
    with run_lock(link):
        assert lock_path(tiny_run_copy).exists() and not lock_path(link).exists()
    assert not lock_path(tiny_run_copy).exists()


def test_a_writer_keeps_to_the_file_it_locked_when_the_link_moves(tiny_run_copy, tmp_path):
    other = Path(shutil.copyfile(tiny_run_copy, tmp_path / "other.h5"))
    before = sha256(other)
    link = _link(tmp_path, tiny_run_copy)
    with run_lock(link):
        link.unlink()
        link.symlink_to(other)  # ln -sf other.h5 latest.h5, while the writer works
        run_file.record_session(link, "resume", ["adaptsky"], "2026-01-01T00:00:00Z", 1.0,
                                {0: 2, 1: 2})
    assert sha256(other) == before
    with RunReader(tiny_run_copy) as run:
        assert run.sessions[-1]["command_line"] == ["adaptsky"]


def test_a_link_to_nothing_is_one_line(tmp_path, capsys):
    link = tmp_path / "latest.h5"
    link.symlink_to("run-gone.h5")
    check_all_refuse(link, tmp_path, capsys,
                      "is a symbolic link to run-gone.h5, which does not exist")


def test_a_link_to_a_folder_is_not_a_run_file(tmp_path, capsys):
    link = _link(tmp_path, tmp_path / "folder.h5")
    (tmp_path / "folder.h5").mkdir()
    check_all_refuse(link, tmp_path, capsys, "is a directory, not a run file")


@pytest.mark.parametrize("case", ["soft_link", "not_a_run"])
def test_a_damaged_file_behind_a_link_is_refused(case, tiny_run, tmp_path, capsys):
    damage, message = DAMAGES[case]
    path = Path(shutil.copyfile(tiny_run, tmp_path / f"{case}.h5"))
    with h5py.File(path, "a") as f:
        damage(f)
    before = sha256(path)
    check_all_refuse(_link(tmp_path, path), tmp_path, capsys, message)
    assert sha256(path) == before, "--resume changed the damaged file"


def test_an_external_link_inside_the_file_is_refused_through_a_link(tiny_run, tmp_path,
                                                                    capsys):
    path = Path(shutil.copyfile(tiny_run, tmp_path / "external.h5"))
    shutil.copyfile(tiny_run, tmp_path / "donor.h5")
    with h5py.File(path, "a") as f:
        del f["seeds/0/checkpoint/rng"]
        f["seeds/0/checkpoint/rng"] = h5py.ExternalLink("donor.h5", "/seeds/0/checkpoint/rng")
    check_all_refuse(_link(tmp_path, path), tmp_path, capsys,
                      "/seeds/0/checkpoint/rng: is an external link")
