"""Run files are validated on opening (docs/file-format.md "Checks on reading"): every damaged
copy of a real run file is refused by ``inspect``, ``eval`` and ``train --resume`` with one
line naming the problem and exit 1, before anything is read in bulk or written; provenance,
sessions and units are recorded."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.store import run_file
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky_cli.cli.main import main

POLICY = "seeds/0/checkpoint/agent/policy"
REPLAY = "seeds/0/checkpoint/replay"


@pytest.fixture
def run(tiny_run: Path) -> Path:
    """The session's tiny run (tests/conftest.py): nyc_mmwave, 2 seeds, 2 episodes of 5 steps,
    trained in-process with one worker. Read only: every test that damages it copies it."""
    return tiny_run


def _attr(name: str, value: object) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        if value is None:
            del f.attrs[name]
        else:
            f.attrs[name] = value
    return damage


def _delete(name: str) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        del f[name]
    return damage


def _replace(name: str, **dataset: object) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        del f[name]
        f.create_dataset(name, **dataset)
    return damage


def _config_without_train(f: h5py.File) -> None:
    config = json.loads(f["config"][()].decode())
    del config["train"]
    del f["config"]
    f.create_dataset("config", data=json.dumps(config), dtype=h5py.string_dtype())


def _nan_weight(f: h5py.File) -> None:
    f[f"{POLICY}/advantage.bias"][3] = np.nan


def _rng_state_out_of_range(f: h5py.File) -> None:
    rng = f["seeds/0/checkpoint/rng"]
    state = json.loads(rng.attrs["numpy_agent_json"])
    state["state"]["state"] = 2**200
    rng.attrs["numpy_agent_json"] = json.dumps(state)


def _soft_link(f: h5py.File) -> None:
    del f[f"{POLICY}/torso.0.bias"]
    f[f"{POLICY}/torso.0.bias"] = h5py.SoftLink("/seeds/1/checkpoint/agent/policy/torso.0.bias")


# damage -> what the one line must say; every case is refused by inspect, eval and --resume
DAMAGES: dict[str, tuple[Callable[[h5py.File], None], str]] = {
    "version_0": (_attr("format_version", 0), "/@format_version: is 0 (expected 1 or 2 or 3)"),
    "version_negative": (_attr("format_version", -1),
                         "/@format_version: is -1 (expected 1 or 2 or 3)"),
    "version_fraction": (_attr("format_version", 1.5),
                         "/@format_version: is 1.5 (expected an integer)"),
    "version_text": (_attr("format_version", "1"),
                     "/@format_version: is '1' (expected an integer)"),
    "version_missing": (_attr("format_version", None), "/@format_version: missing"),
    "version_newer": (_attr("format_version", 99),
                      "format version 99 is newer than this adaptsky"),
    "not_a_run": (_attr("kind", "adaptsky-eval"), "not an adaptsky run file"),
    "seed_group": (_delete("seeds/1"), "/seeds/1: missing (expected a group for every seed"),
    "episodes_table": (_delete("seeds/0/episodes/fairness"),
                       "/seeds/0/episodes/fairness: missing"),
    "short_table": (_replace("seeds/0/episodes/reward", data=np.zeros(1)),
                    "/seeds/0/episodes/reward: has 1 rows (expected 2 to 2"),
    "target_network": (_delete("seeds/0/checkpoint/agent/target"),
                       "/seeds/0/checkpoint/agent/target: missing"),
    "optimizer": (_delete("seeds/0/checkpoint/agent/optimizer"),
                  "/seeds/0/checkpoint/agent/optimizer: missing"),
    "optimizer_moment": (_delete("seeds/1/checkpoint/agent/optimizer/state/3/exp_avg_sq"),
                         "/seeds/1/checkpoint/agent/optimizer/state/3/exp_avg_sq: missing"),
    "rng_state": (_delete("seeds/0/checkpoint/rng"), "/seeds/0/checkpoint/rng: missing"),
    "rng_json": (lambda f: f["seeds/0/checkpoint/rng"].attrs.__setitem__(
        "numpy_env_json", '{"bit_generator": "PCG64"}'),
        "/seeds/0/checkpoint/rng/@numpy_env_json: is not valid"),
    "replay_array": (_delete(f"{REPLAY}/actions"), f"/{REPLAY}/actions: missing"),
    "policy_weight": (_delete(f"{POLICY}/torso.2.weight"), f"/{POLICY}/torso.2.weight: missing"),
    "weight_shape": (_replace(f"{POLICY}/torso.0.weight", data=np.zeros((64, 17), np.float32)),
                     f"/{POLICY}/torso.0.weight: shape (64, 17) (expected (128, 17)"),
    "weight_dtype": (_replace(f"{POLICY}/value.bias", data=np.zeros(1, np.int64)),
                     f"/{POLICY}/value.bias: dtype int64 (expected float)"),
    # declared 2**36 rows: 4.7 TB if read; HDF5 allocates nothing, so the file stays small
    "replay_terabytes": (_replace(f"{REPLAY}/observations", shape=(2**36, 17), dtype="f4",
                                  chunks=(1024, 17)),
                         f"/{REPLAY}/observations: shape (68719476736, 17) (expected (10, 17)"),
    "replay_position": (lambda f: f[REPLAY].attrs.__setitem__("position", 3),
                        f"/{REPLAY}/@position: is 3 (expected 10"),
    "config_without_train": (_config_without_train,
                             "/config: section 'train' is missing"),
    "config_invalid": (lambda f: f["config"].parent.__delitem__("config") or f.create_dataset(
        "config", data="{not json", dtype=h5py.string_dtype()), "/config: is not JSON"),
    "soft_link": (_soft_link, f"/{POLICY}/torso.0.bias: is a soft link to /seeds/1/"),
    "checkpoint_of_other_episode": (
        lambda f: f["seeds/1/checkpoint"].attrs.__setitem__("episode", 1),
        "/seeds/1/checkpoint/@episode: is 1 (expected 2)"),
    "no_checkpoint_after_episodes": (_delete("seeds/0/checkpoint"),
                                     "/seeds/0/checkpoint: missing, but episodes_done is 2"),
    # found by fuzzing: numpy raised OverflowError on an RNG state out of uint64's range, and
    # a learning-curve table that cannot grow passed until --resume tried to append to it
    "rng_state_out_of_range": (_rng_state_out_of_range,
                               "/seeds/0/checkpoint/rng/@numpy_agent_json: is not valid"),
    "table_that_cannot_grow": (_replace("seeds/0/episodes/loss", data=np.zeros(2)),
                               "/seeds/0/episodes/loss: cannot grow"),
}


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _refused(args: list[str], capsys: pytest.CaptureFixture[str], path: Path,
             message: str) -> None:
    assert main(args) == 1, args
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, (args, captured.err)
    assert lines[0].startswith(f"{path}: ") and message in lines[0], (args, lines[0])
    assert "Traceback" not in captured.err + captured.out


def _commands(path: Path, eval_out: Path) -> dict[str, list[str]]:
    return {"inspect": ["inspect", str(path)],
            "eval": ["eval", "--checkpoint", str(path), "--steps", "5", "--compare", "",
                     "--out", str(eval_out)],
            "resume": ["train", "--resume", str(path), "--workers", "1", "--quiet"]}


def _check_all_refuse(path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                      message: str, commands: tuple[str, ...] = ("inspect", "eval", "resume")
                      ) -> None:
    before = _sha256(path) if path.is_file() and not path.is_symlink() else None
    eval_out = tmp_path / "eval.h5"
    for name, args in _commands(path, eval_out).items():
        if name in commands:
            _refused(args, capsys, path, message)
    assert not eval_out.exists(), "eval wrote an eval file from a damaged run"
    if before is not None:
        assert _sha256(path) == before, "--resume changed the damaged file"


@pytest.mark.parametrize("case", sorted(DAMAGES))
def test_damaged_copy_is_refused_in_one_line(case, run, tmp_path, capsys):
    damage, message = DAMAGES[case]
    path = tmp_path / f"{case}.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        damage(f)
    start = time.perf_counter()
    _check_all_refuse(path, tmp_path, capsys, message)
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
    _check_all_refuse(path, tmp_path, capsys,
                      f"/{POLICY}/advantage.bias: 1 value is NaN or infinite "
                      "(expected finite numbers)", commands=("eval", "resume"))
    assert main(["inspect", str(path)]) == 0


def test_nan_in_learning_curve_is_refused_by_inspect(run, tmp_path, capsys):
    path = tmp_path / "nan_curve.h5"
    shutil.copyfile(run, path)
    with h5py.File(path, "a") as f:
        f["seeds/1/episodes/sum_rate_bps"][0] = np.inf
    _check_all_refuse(path, tmp_path, capsys, "/seeds/1/episodes/sum_rate_bps: 1 value is "
                      "NaN or infinite", commands=("inspect",))


def test_file_that_links_to_itself(tmp_path, capsys):
    path = tmp_path / "loop.h5"
    path.symlink_to(path.name)
    _check_all_refuse(path, tmp_path, capsys, "is a symbolic link that points to itself")


def test_directory_is_not_a_run_file(tmp_path, capsys):
    path = tmp_path / "dir.h5"
    path.mkdir()
    _check_all_refuse(path, tmp_path, capsys, "not a run file")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files without read permission")
def test_unreadable_file(run, tmp_path, capsys):
    path = tmp_path / "unreadable.h5"
    shutil.copyfile(run, path)
    path.chmod(0o200)
    _check_all_refuse(path, tmp_path, capsys, "cannot read run file (Permission denied)")


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
