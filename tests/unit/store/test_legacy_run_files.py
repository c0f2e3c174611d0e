"""Run files written by earlier versions (tests/data/legacy/README.md): format 1 (before the
greedy evaluations) and format 2 (before ``[agent] algorithm``) open, resume to the numbers a
new run of the same scenario gives, bit for bit (without the energy that format 3 adds), and
evaluate as a new run's file does."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import main
from tests.conftest import ROOT

LEGACY = ROOT / "tests" / "data" / "legacy"
FILES = {  # file -> (format, the --set options it was trained with)
    "format1-f76bddf.h5": (1, []),
    "format2-4b487ea.h5": (2, ["--set", "train.eval_every=1", "--set", "train.eval_steps=20"]),
}
RUN = ["--workers", "1", "--quiet"]
SKIP = {"created_utc", "sessions", "command_line", "adaptsky_version", "wall_time_s",
        "config", "format_version"}


def seed_arrays(path: Path) -> dict[str, np.ndarray]:
    """Every dataset and attribute under /seeds (the numbers of a run)."""
    found: dict[str, np.ndarray] = {}

    def visit(name: str, item: h5py.HLObject) -> None:
        if isinstance(item, h5py.Dataset):
            found[name] = np.asarray(item[()])
        for key, value in item.attrs.items():
            if key not in SKIP:
                found[f"{name}@{key}"] = np.asarray(value)

    with h5py.File(path) as file:
        file["seeds"].visititems(visit)
    return found


def train(tmp_path: Path, name: str, sets: list[str], episodes: int) -> Path:
    out = tmp_path / name
    assert main(["train", str(LEGACY / "tiny.toml"), "--episodes", str(episodes), *sets,
                 *RUN, "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize("name", FILES)
def test_a_legacy_run_file_opens_and_resumes_to_a_new_runs_numbers(name, tmp_path, capsys):
    version, sets = FILES[name]
    legacy = tmp_path / name
    shutil.copyfile(LEGACY / name, legacy)
    with h5py.File(legacy) as file:
        assert file.attrs["format_version"] == version
        assert "algorithm" not in json.loads(file["config"][()])["agent"]
    with RunReader(legacy) as run:
        assert run.seeds == [3] and run.scenario.agent.algorithm == "dqn"
    assert main(["train", "--resume", str(legacy), "--episodes", "4", *RUN]) == 0
    fresh = train(tmp_path, "fresh.h5", sets, 4)
    resumed, new = seed_arrays(legacy), seed_arrays(fresh)
    # format 3 adds the energy of every episode and step; a resumed file keeps its format
    new = {k: v for k, v in new.items() if "energy" not in k}
    if version == 1:  # format 1 had no evaluations to resume
        new = {k: v for k, v in new.items() if "evaluations" not in k and "best" not in k}
        resumed = {k: v for k, v in resumed.items() if "evaluations" not in k}
    assert resumed.keys() == new.keys()
    for key in resumed:
        floats = resumed[key].dtype.kind == "f"
        assert np.array_equal(resumed[key], new[key], equal_nan=floats), key
    capsys.readouterr()


@pytest.mark.parametrize("name", FILES)
def test_a_legacy_run_file_evaluates_as_a_new_runs_file(name, tmp_path, capsys):
    _, sets = FILES[name]
    fresh = train(tmp_path, "fresh.h5", sets, 2)
    legacy = tmp_path / name  # eval writes its file beside the run: never into the repository
    shutil.copyfile(LEGACY / name, legacy)
    results = []
    for path in (legacy, fresh):
        capsys.readouterr()
        assert main(["eval", "--checkpoint", str(path), "--steps", "30", "--layouts", "2",
                     "--compare", "soa", "--json"]) == 0
        printed = json.loads(capsys.readouterr().out)
        results.append({key: printed[key] for key in ("methods", "policy")
                        if key in printed})
    assert results[0]["methods"] == results[1]["methods"]
