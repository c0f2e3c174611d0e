"""Run files are validated on opening (docs/file-format.md "Checks on reading"): every damaged
copy of a real run file is refused by ``inspect``, ``eval`` and ``train --resume`` with one
line naming the problem and exit 1, before anything is read in bulk or written; provenance,
sessions and units are recorded."""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.store import run_file
from adaptsky.store.checksums import seal
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky_cli.cli.main import main
from tests.helpers.run_files import DAMAGES, POLICY, check_all_refuse


@pytest.fixture
def run(tiny_run: Path) -> Path:
    """The session's tiny run (tests/conftest.py): nyc_mmwave, 2 seeds, 2 episodes of 5 steps,
    trained in-process with one worker. Read only: every test that damages it copies it."""
    return tiny_run


def _nan_weight(f: h5py.File) -> None:
    """A NaN written as a writer writes it (with its checksum: a diverged training)."""
    f[f"{POLICY}/advantage.bias"][3] = np.nan
    _reseal(f[f"{POLICY}/advantage.bias"])


def _reseal(dataset: h5py.Dataset) -> None:
    """The dataset's CRC-32 made current after an edit in place (store.checksums)."""
    seal(dataset, dataset[()])


@pytest.mark.parametrize("case", sorted(DAMAGES))
def test_damaged_copy_is_refused_in_one_line(case, run, tmp_path, capsys):
    damage, message = DAMAGES[case]
    path = tmp_path / f"{case}.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        damage(f)
    start = time.perf_counter()
    check_all_refuse(path, tmp_path, capsys, message)
    assert time.perf_counter() - start < 5, "validation read more than the layout"


def test_terabyte_replay_file_stays_small_and_is_never_read(run, tmp_path):
    path = tmp_path / "huge.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        DAMAGES["replay_terabytes"][0](f)
    assert path.stat().st_size < 2 * run.stat().st_size
    with pytest.raises(RunFileError, match=r"shape \(68719476736, 17\)"):
        RunReader(path)


def test_nan_weight_is_refused_where_the_weights_are_read(run, tmp_path, capsys):
    # inspect reads no weights (header and curves only), so it still summarises the run
    path = tmp_path / "nan.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        _nan_weight(f)
    check_all_refuse(path, tmp_path, capsys,
                      f"/{POLICY}/advantage.bias: 1 value is NaN or infinite "
                      "(expected finite numbers)", commands=("eval", "resume"))
    assert main(["inspect", str(path)]) == 0


def test_nan_in_learning_curve_is_refused_by_inspect(run, tmp_path, capsys):
    path = tmp_path / "nan_curve.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        f["seeds/1/episodes/sum_rate_bps"][0] = np.inf
        _reseal(f["seeds/1/episodes/sum_rate_bps"])
    check_all_refuse(path, tmp_path, capsys, "/seeds/1/episodes/sum_rate_bps: 1 value is "
                      "NaN or infinite", commands=("inspect",))


def test_file_that_links_to_itself(tmp_path, capsys):
    path = tmp_path / "loop.h5"
    path.symlink_to(path.name)
    check_all_refuse(path, tmp_path, capsys, "is a symbolic link that points to itself")


def test_directory_is_not_a_run_file(tmp_path, capsys):
    path = tmp_path / "dir.h5"
    path.mkdir()
    check_all_refuse(path, tmp_path, capsys, "not a run file")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files without read permission")
def test_unreadable_file(run, tmp_path, capsys):
    path = tmp_path / "unreadable.h5"
    shutil.copyfile(run, path)
    path.chmod(0o200)
    check_all_refuse(path, tmp_path, capsys, "cannot read run file (Permission denied)")


def test_unreadable_file_even_as_root(run, tmp_path, capsys, monkeypatch):
    """The permission check itself, simulated where the tests run as root."""
    path = tmp_path / "unreadable.h5"
    shutil.copyfile(run, path)
    real_open = os.open

    def refuse(name, *args, **kwargs):  # type: ignore[no-untyped-def]
        if Path(name) == path:
            raise PermissionError(13, "Permission denied")
        return real_open(name, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    assert main(["inspect", str(path)]) == 1
    assert capsys.readouterr().err.strip() == (f"{path}: cannot read run file (Permission "
                                               "denied); check its permissions")


def test_seed_without_checkpoint_yet_is_valid(run, tmp_path):
    """A run killed before a seed's first checkpoint: episodes_done 0, no checkpoint."""
    path = tmp_path / "fresh_seed.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        seed = f["seeds/1"]
        for name in ("checkpoint", "trajectory"):
            del seed[name]
        for table in seed["episodes"].values():
            table.resize(0, axis=0)
            _reseal(table)
        seed.attrs["episodes_done"] = 0
    with RunReader(path) as reader:
        assert reader.has_checkpoint(0) and not reader.has_checkpoint(1)
        assert len(reader.episodes(1)["sum_rate_bps"]) == 0


def test_file_without_provenance_units_or_sessions_still_opens(run, tmp_path, capsys):
    """Files written before provenance, units, sessions and the checkpoints' device existed
    stay readable, and resume (the old trainer's runs were refused as damaged)."""
    path = tmp_path / "old.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        for name in run_file.environment() | {"command_line": ""}:
            del f.attrs[name]
        del f["overrides"]
        if "sessions" in f:  # recorded by train since this test was written
            del f["sessions"]
        for seed in f["seeds"].values():
            del seed["checkpoint"].attrs["device"]
        f.visititems(lambda _, item: item.attrs.pop("units", None)
                     if isinstance(item, h5py.Dataset) else None)
    with RunReader(path) as reader:
        assert reader.sessions == [] and reader.overrides == []
        assert reader.checkpoint(1)["episode"] == 2
    assert main(["train", "--resume", str(path), "--episodes", "3", "--workers", "1",
                 "--quiet"]) == 0, capsys.readouterr().err
    with RunReader(path) as reader:
        assert [reader.seed_attrs(seed)["episodes_done"] for seed in reader.seeds] == [3, 3]


def test_curve_readers_need_no_checkpoint(run, tmp_path):
    path = tmp_path / "curves.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        del f["seeds/0/checkpoint/agent/target"]
    with RunReader(path, needs="curves") as reader:
        assert reader.episodes(0)["sum_rate_bps"].shape == (2,)
    with pytest.raises(RunFileError, match="agent/target: missing"):
        RunReader(path)


def test_provenance_and_units_are_recorded(run):
    with h5py.File(run, "r") as f:
        attrs = dict(f.attrs)
        assert attrs["python_version"].count(".") == 2
        assert attrs["numpy_version"] == np.__version__ and attrs["h5py_version"]
        assert attrs["torch_version"] and attrs["platform"]
        # the argv of the process that created the file (in-process here: pytest's)
        assert json.loads(attrs["command_line"]) == sys.argv
        units: dict[str, str] = {}
        f.visititems(lambda name, item: units.__setitem__(name, item.attrs.get("units"))
                     if isinstance(item, h5py.Dataset) and item.dtype.kind != "O" else None)
    missing = [name for name, unit in units.items() if unit is None]
    assert not missing, f"datasets without units: {missing}"
    assert units["seeds/0/episodes/sum_rate_bps"] == "bit/s"
    assert units["seeds/0/episodes/mean_height_m"] == "m"
    assert units["seeds/1/trajectory/uav_m"] == "m"
    assert units[f"{POLICY}/torso.0.weight"] == "1"


def test_sessions_are_appended(run, tmp_path):
    """train records its session; record_session appends the next one (as --resume does)."""
    path = tmp_path / "sessions.h5"
    shutil.copyfile(run, path)
    run_file.record_session(path, "resume", ["adaptsky", "train", "--resume", str(path)],
                            "2026-11-23T16:00:00Z", 0.5, {0: 2, 1: 2})
    with RunReader(path) as reader:
        sessions = reader.sessions
    assert [s["kind"] for s in sessions] == ["train", "resume"]
    assert sessions[0]["episodes_before"] == {"0": 0, "1": 0}
    assert sessions[0]["episodes_after"] == {"0": 2, "1": 2} and sessions[0]["wall_s"] > 0
    assert sessions[1]["episodes_after"] == {"0": 2, "1": 2}
    assert sessions[1]["wall_s"] == 0.5 and sessions[1]["command_line"][2] == "--resume"
    assert sessions[0]["torch_version"] == run_file.environment()["torch_version"]
