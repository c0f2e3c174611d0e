"""Run files damaged one way each, the commands that must refuse them, and the legacy files
of earlier formats."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky_cli.cli.main import main
from tests.conftest import ROOT

LEGACY = ROOT / "tests" / "data" / "legacy"
POLICY = "seeds/0/checkpoint/agent/policy"
REPLAY = "seeds/0/checkpoint/replay"


def set_attr(name: str, value: object) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        if value is None:
            del f.attrs[name]
        else:
            f.attrs[name] = value
    return damage


def delete(name: str) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        del f[name]
    return damage


def recreate(name: str, **dataset: object) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        del f[name]
        f.create_dataset(name, **dataset)
    return damage


def config_without_train(f: h5py.File) -> None:
    config = json.loads(f["config"][()].decode())
    del config["train"]
    del f["config"]
    f.create_dataset("config", data=json.dumps(config), dtype=h5py.string_dtype())


def rng_state_out_of_range(f: h5py.File) -> None:
    rng = f["seeds/0/checkpoint/rng"]
    state = json.loads(rng.attrs["numpy_agent_json"])
    state["state"]["state"] = 2**200
    rng.attrs["numpy_agent_json"] = json.dumps(state)


def soft_link(f: h5py.File) -> None:
    del f[f"{POLICY}/torso.0.bias"]
    f[f"{POLICY}/torso.0.bias"] = h5py.SoftLink("/seeds/1/checkpoint/agent/policy/torso.0.bias")


# damage -> what the one line must say; every case is refused by inspect, eval and --resume
DAMAGES: dict[str, tuple[Callable[[h5py.File], None], str]] = {
    "version_0": (set_attr("format_version", 0),
                  "/@format_version: is 0 (expected 1 or 2 or 3 or 4 or 5)"),
    "version_negative": (set_attr("format_version", -1),
                         "/@format_version: is -1 (expected 1 or 2 or 3 or 4 or 5)"),
    "version_fraction": (set_attr("format_version", 1.5),
                         "/@format_version: is 1.5 (expected an integer)"),
    "version_text": (set_attr("format_version", "1"),
                     "/@format_version: is '1' (expected an integer)"),
    "version_missing": (set_attr("format_version", None), "/@format_version: missing"),
    "version_newer": (set_attr("format_version", 99),
                      "format version 99 is newer than this adaptsky"),
    "not_a_run": (set_attr("kind", "adaptsky-eval"), "not an adaptsky run file"),
    "seed_group": (delete("seeds/1"), "/seeds/1: missing (expected a group for every seed"),
    "episodes_table": (delete("seeds/0/episodes/fairness"),
                       "/seeds/0/episodes/fairness: missing"),
    "short_table": (recreate("seeds/0/episodes/reward", data=np.zeros(1)),
                    "/seeds/0/episodes/reward: has 1 rows (expected 2 to 2"),
    "target_network": (delete("seeds/0/checkpoint/agent/target"),
                       "/seeds/0/checkpoint/agent/target: missing"),
    "optimizer": (delete("seeds/0/checkpoint/agent/optimizer"),
                  "/seeds/0/checkpoint/agent/optimizer: missing"),
    "optimizer_moment": (delete("seeds/1/checkpoint/agent/optimizer/state/3/exp_avg_sq"),
                         "/seeds/1/checkpoint/agent/optimizer/state/3/exp_avg_sq: missing"),
    "rng_state": (delete("seeds/0/checkpoint/rng"), "/seeds/0/checkpoint/rng: missing"),
    "rng_json": (lambda f: f["seeds/0/checkpoint/rng"].attrs.__setitem__(
        "numpy_env_json", '{"bit_generator": "PCG64"}'),
        "/seeds/0/checkpoint/rng/@numpy_env_json: is not valid"),
    "replay_array": (delete(f"{REPLAY}/actions"), f"/{REPLAY}/actions: missing"),
    "policy_weight": (delete(f"{POLICY}/torso.2.weight"), f"/{POLICY}/torso.2.weight: missing"),
    "weight_shape": (recreate(f"{POLICY}/torso.0.weight", data=np.zeros((64, 17), np.float32)),
                     f"/{POLICY}/torso.0.weight: shape (64, 17) (expected (128, 17)"),
    "weight_dtype": (recreate(f"{POLICY}/value.bias", data=np.zeros(1, np.int64)),
                     f"/{POLICY}/value.bias: dtype int64 (expected float)"),
    # declared 2**36 rows: 4.7 TB if read; HDF5 allocates nothing, so the file stays small
    "replay_terabytes": (recreate(f"{REPLAY}/observations", shape=(2**36, 17), dtype="f4",
                                  chunks=(1024, 17)),
                         f"/{REPLAY}/observations: shape (68719476736, 17) (expected (10, 17)"),
    "replay_position": (lambda f: f[REPLAY].attrs.__setitem__("position", 3),
                        f"/{REPLAY}/@position: is 3 (expected 10"),
    "config_without_train": (config_without_train,
                             "/config: section 'train' is missing"),
    "config_invalid": (lambda f: f["config"].parent.__delitem__("config") or f.create_dataset(
        "config", data="{not json", dtype=h5py.string_dtype()), "/config: is not JSON"),
    "soft_link": (soft_link, f"/{POLICY}/torso.0.bias: is a soft link to /seeds/1/"),
    "checkpoint_of_other_episode": (
        lambda f: f["seeds/1/checkpoint"].attrs.__setitem__("episode", 1),
        "/seeds/1/checkpoint/@episode: is 1 (expected 2)"),
    "no_checkpoint_after_episodes": (delete("seeds/0/checkpoint"),
                                     "/seeds/0/checkpoint: missing, but episodes_done is 2"),
    # found by fuzzing: numpy raised OverflowError on an RNG state out of uint64's range, and
    # a learning-curve table that cannot grow passed until --resume tried to append to it
    "rng_state_out_of_range": (rng_state_out_of_range,
                               "/seeds/0/checkpoint/rng/@numpy_agent_json: is not valid"),
    "table_that_cannot_grow": (recreate("seeds/0/episodes/loss", data=np.zeros(2)),
                               "/seeds/0/episodes/loss: cannot grow"),
}


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def assert_refused(args: list[str], capsys: pytest.CaptureFixture[str], path: Path,
             message: str) -> None:
    assert main(args) == 1, args
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, (args, captured.err)
    assert lines[0].startswith(f"{path}: ") and message in lines[0], (args, lines[0])
    assert "Traceback" not in captured.err + captured.out


def run_commands(path: Path, eval_out: Path) -> dict[str, list[str]]:
    return {"inspect": ["inspect", str(path)],
            "eval": ["eval", "--checkpoint", str(path), "--steps", "5", "--compare", "",
                     "--out", str(eval_out)],
            "resume": ["train", "--resume", str(path), "--workers", "1", "--quiet"]}


def check_all_refuse(path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                      message: str, commands: tuple[str, ...] = ("inspect", "eval", "resume")
                      ) -> None:
    before = sha256(path) if path.is_file() and not path.is_symlink() else None
    eval_out = tmp_path / "eval.h5"
    for name, args in run_commands(path, eval_out).items():
        if name in commands:
            assert_refused(args, capsys, path, message)
    assert not eval_out.exists(), "eval wrote an eval file from a damaged run"
    if before is not None:
        assert sha256(path) == before, "--resume changed the damaged file"
