"""Run files written by earlier versions (tests/data/legacy/README.md): format 1 (before the
greedy evaluations), format 2 (before ``[agent] algorithm``), 3 (before the service metrics)
and 4 (before the policy's entropy) open, resume to the asked
episodes and evaluate as a new run's file does.

The shipped files were written on another machine, and floats are reproducible on one machine
only (a torch build or CPU of its own rounds the networks' arithmetic otherwise): what the
tests compare bit for bit is therefore either computed on both sides here (two resumes of the
same file; a file in the legacy layout whose numbers a run here wrote, against a new run
here) or does not come from float arithmetic (the rows stored before the resume, the
counters, the random generators' states, the stored scenario and attributes)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.store.checksums import CRC_ATTR
from adaptsky.store.layout import added_after
from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import main
from tests.helpers.run_files import LEGACY

EVALUATING = ["--set", "train.eval_every=1", "--set", "train.eval_steps=20"]
FILES = {  # file -> (format, the --set options it was trained with)
    "format1-f76bddf.h5": (1, []),
    "format2-4b487ea.h5": (2, EVALUATING),
    "format3-f2c7d5a.h5": (3, EVALUATING),
    "format4-0e61058.h5": (4, EVALUATING),
}
RUN = ["--workers", "1", "--quiet"]
SKIP = {"created_utc", "sessions", "command_line", "adaptsky_version", "wall_time_s",
        "config", "format_version", CRC_ATTR}  # (a checksum: earlier files have none)
EPISODES, STEPS = 2, 8  # what the shipped files hold: tiny.toml's steps, --episodes 2
# Under /seeds, what counts rather than computes, the same on every machine: every attribute
# (counters, the random generators' states, which only the number of draws moves, optimizer
# settings, units) but the best policy's score and episode, which rank evaluation floats; the
# optimizer's update counts, the evaluations' episodes, the replay's terminal flags.
COMPUTED_ATTRS = re.compile(r".*/best@(score|episode)")
COUNTED_DATA = re.compile(r".*/(optimizer/state/\d+/step|evaluations/episode|replay/terminated)")


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


def counted(key: str) -> bool:
    """Whether ``key`` (of :func:`seed_arrays`) counts rather than computes."""
    if "@" in key:
        return COMPUTED_ATTRS.fullmatch(key) is None
    return COUNTED_DATA.fullmatch(key) is not None


def added(key: str, version: int) -> bool:
    """Whether ``key`` (a path, maybe with ``@attribute``) is a dataset that formats after
    ``version`` add (the energy from format 3, the service metrics and the users' positions
    from format 4, the policy's entropy from format 5)."""
    return key.split("@")[0].rsplit("/", 1)[-1] in added_after(version)


def in_format(arrays: dict[str, np.ndarray], version: int) -> dict[str, np.ndarray]:
    """A new run's ``arrays`` without what a file of format ``version`` does not have: format 5
    adds the policy's entropy, format 4 the service metrics, the users' positions and the
    tracking columns, format 3 the energy of every episode and step (a resumed file keeps
    its format), format 2 the greedy evaluations."""
    arrays = {k: v for k, v in arrays.items() if not added(k, version)}
    if version == 1:
        arrays = {k: v for k, v in arrays.items() if "evaluations" not in k and "best" not in k}
    return arrays


def assert_same_bits(got: dict[str, np.ndarray], expected: dict[str, np.ndarray]) -> None:
    assert got.keys() == expected.keys()
    for key in got:
        floats = got[key].dtype.kind == "f"
        assert np.array_equal(got[key], expected[key], equal_nan=floats), key


def train(tmp_path: Path, name: str, sets: list[str], episodes: int) -> Path:
    out = tmp_path / name
    assert main(["train", str(LEGACY / "tiny.toml"), "--episodes", str(episodes), *sets,
                 *RUN, "--out", str(out)]) == 0
    return out


def resume(path: Path, episodes: int) -> None:
    assert main(["train", "--resume", str(path), "--episodes", str(episodes), *RUN]) == 0


def shipped(name: str, tmp_path: Path, copy: str | None = None) -> Path:
    """A copy of the shipped file (tests never write into the repository)."""
    path = tmp_path / (copy or name)
    shutil.copyfile(LEGACY / name, path)
    return path


def nodes(path: Path) -> dict[str, tuple]:
    """Every group and dataset of the file: its kind, shape, dtype and attribute names (but a
    dataset's checksum, which files of earlier versions lack: store.checksums)."""
    with h5py.File(path) as file:
        found = {"/": ("group", None, None, sorted(file.attrs))}

        def visit(name: str, item: h5py.HLObject) -> None:
            dataset = isinstance(item, h5py.Dataset)
            found[name] = ("dataset" if dataset else "group", getattr(item, "shape", None),
                           str(item.dtype) if dataset else None,
                           sorted(key for key in item.attrs if key != CRC_ATTR))
        file.visititems(visit)
    return found


def written_here(name: str, tmp_path: Path) -> Path:
    """The shipped file ``name`` (its layout, format, /config without ``[agent] algorithm``,
    provenance and sessions) with every number under /seeds and /evaluation replaced by those
    of a new run of the same scenario trained here: a legacy file as it would be had the old
    version run on this machine (whose first two episodes this machine computes alike)."""
    version, sets = FILES[name]
    fresh = train(tmp_path, f"fresh-{EPISODES}.h5", sets, EPISODES)
    legacy = shipped(name, tmp_path, f"here-{name}")
    old, new = nodes(legacy), nodes(fresh)
    new = {k: v for k, v in new.items() if not added(k, version)}
    if version == 1:
        new = {k: v for k, v in new.items() if "evaluations" not in k}
    under = ("seeds", "evaluation")
    assert {k: v for k, v in new.items() if k.startswith(under)} \
        == {k: v for k, v in old.items() if k.startswith(under)}  # the same layout
    with h5py.File(legacy, "r+") as target, h5py.File(fresh) as source:
        for name_ in old:
            if not name_.startswith(under):
                continue
            if old[name_][0] == "dataset":
                target[name_][()] = source[name_][()]
            for key in old[name_][3]:
                target[name_].attrs[key] = source[name_].attrs[key]
        assert target.attrs["format_version"] == version
    assert_same_bits(seed_arrays(legacy), in_format(seed_arrays(fresh), version))  # all of it
    return legacy


@pytest.mark.parametrize("name", FILES)
def test_a_legacy_run_file_opens_and_resumes_to_the_asked_episodes(name, tmp_path, capsys):
    """The shipped file (numbers of another machine) resumes to 4 episodes in its own format:
    its stored rows kept bit for bit, the new ones finite and of a new run's shapes, and
    every counter and random generator state where a new run here has them."""
    version, sets = FILES[name]
    legacy = shipped(name, tmp_path)
    with h5py.File(legacy) as file:
        assert file.attrs["format_version"] == version
        # [agent] algorithm came after format 2
        assert ("algorithm" in json.loads(file["config"][()])["agent"]) == (version >= 3)
    with RunReader(legacy) as run:
        assert run.seeds == [3] and run.scenario.agent.algorithm == "dqn"
        assert run.seed_attrs(3)["episodes_done"] == EPISODES
        before = run.episodes(3)
        evaluations_before = run.evaluations(3)
    assert all(len(column) == EPISODES for column in before.values())
    assert len(evaluations_before["episode"]) == (EPISODES if version >= 2 else 0)

    resume(legacy, 4)
    with h5py.File(legacy) as file:
        assert file.attrs["format_version"] == version  # a resumed file keeps its format
        assert ("evaluations" in file["seeds/3"]) == (version >= 2)
    with RunReader(legacy) as run:  # validated again; every array read is checked finite
        assert run.seed_attrs(3) == {"seed": 3, "episodes_done": 4, "episodes_planned": 4}
        after, evaluations = run.episodes(3), run.evaluations(3)
        checkpoint = run.checkpoint(3)
        trajectory = run.trajectory(3)
        sessions = run.sessions
    assert before.keys() == after.keys() and not any(added(key, version) for key in after)
    for key, column in after.items():
        assert len(column) == 4 and np.isfinite(column).all(), key
        assert np.array_equal(column[:EPISODES], before[key]), key  # appended, not rewritten
    assert int(checkpoint["episode"]) == 4 and int(checkpoint["global_step"]) == 4 * STEPS
    assert len(trajectory["reward"]) == STEPS and np.isfinite(trajectory["reward"]).all()
    assert [(s["kind"], s["episodes_before"], s["episodes_after"]) for s in sessions][-1] \
        == ("resume", {"3": EPISODES}, {"3": 4})
    if version >= 2:  # one greedy evaluation per episode, the first two as stored
        assert evaluations["episode"].tolist() == [1, 2, 3, 4]
        assert np.isfinite(evaluations["score"]).all()
        for key, column in evaluations_before.items():
            assert np.array_equal(evaluations[key][:EPISODES], column, equal_nan=True), key

    resumed = seed_arrays(legacy)
    new = in_format(seed_arrays(train(tmp_path, "fresh.h5", sets, 4)), version)
    assert resumed.keys() == new.keys()
    same = [key for key in resumed if counted(key)]
    for key in resumed.keys() - same:  # computed: another machine's floats, a new run's form
        assert resumed[key].shape == new[key].shape, key
        assert resumed[key].dtype == new[key].dtype, key
    assert any("rng@numpy_agent_json" in key for key in same)  # the states are compared
    assert any("optimizer/state/0/step" in key for key in same)
    assert_same_bits({k: resumed[k] for k in same}, {k: new[k] for k in same})
    capsys.readouterr()


@pytest.mark.parametrize("name", FILES)
def test_two_resumes_of_a_legacy_run_file_give_the_same_bits(name, tmp_path, capsys):
    """Both resumes compute here, from the same stored numbers: every number bit for bit."""
    first, second = shipped(name, tmp_path, "first.h5"), shipped(name, tmp_path, "second.h5")
    resume(first, 4)
    resume(second, 4)
    numbers = seed_arrays(first)
    assert any(key.endswith("checkpoint/agent/policy/torso.0.weight") for key in numbers)
    assert_same_bits(seed_arrays(second), numbers)
    capsys.readouterr()


@pytest.mark.parametrize("name", FILES)
def test_a_legacy_layout_file_written_here_resumes_to_a_new_runs_numbers(name, tmp_path,
                                                                          capsys):
    """A file in the legacy layout whose first two episodes were computed here resumes to
    the numbers a new run here gives, bit for bit (without what its format lacks): the
    upgrade of an old file (its config, its format) changes nothing of the training."""
    version, sets = FILES[name]
    legacy = written_here(name, tmp_path)
    resume(legacy, 4)
    new = in_format(seed_arrays(train(tmp_path, "fresh.h5", sets, 4)), version)
    resumed = seed_arrays(legacy)
    if version == 1:  # format 1 had no evaluations to resume
        assert not any("evaluations" in key for key in resumed)
    assert_same_bits(resumed, new)
    capsys.readouterr()


def evaluate(path: Path, capsys: pytest.CaptureFixture[str]) -> dict:
    capsys.readouterr()
    assert main(["eval", "--checkpoint", str(path), "--steps", "30", "--layouts", "2",
                 "--compare", "soa", "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("name", FILES)
def test_a_legacy_run_file_evaluates_as_a_new_runs_file(name, tmp_path, capsys):
    """The compared method (soa) is computed here from the stored scenario alone: bit for bit
    as for a new run's file. The shipped policy's own numbers are another machine's: it
    evaluates the stored checkpoint (its episode, as stored), on the same layouts, to finite
    numbers; the same file written here evaluates as the new run does, bit for bit."""
    _, sets = FILES[name]
    fresh = train(tmp_path, "fresh.h5", sets, EPISODES)
    legacy = shipped(name, tmp_path)  # eval writes its file beside the run
    old, new = evaluate(legacy, capsys), evaluate(fresh, capsys)
    assert old["methods"].keys() == new["methods"].keys() == {"policy", "soa"}
    assert old["methods"]["soa"] == new["methods"]["soa"]
    assert old["layouts_m"] == new["layouts_m"] and len(old["layouts_m"]) == 2
    with h5py.File(legacy) as file:
        best = file["seeds/3/checkpoint"].get("best")
        stored = int(best.attrs["episode"]) if best is not None else EPISODES
    assert old["policy"]["episode"] == stored and old["policy"]["last_episode"] == EPISODES
    summary = old["methods"]["policy"]["summary"]
    assert summary.keys() == new["methods"]["policy"]["summary"].keys()
    assert np.isfinite(list(summary.values())).all() and summary["mean_sum_rate_bps"] > 0
    here = evaluate(written_here(name, tmp_path), capsys)
    assert here["methods"] == new["methods"] and here["policy"]["episode"] \
        == new["policy"]["episode"]


@pytest.mark.parametrize("name", FILES)
def test_a_legacy_run_file_opens_with_inspect_eval_and_show(name, tmp_path, capsys):
    legacy = shipped(name, tmp_path)
    version, _ = FILES[name]
    assert main(["inspect", str(legacy)]) == 0
    assert f"format {version}," in capsys.readouterr().out
    assert main(["eval", str(legacy), "--compare", "soa", "--steps", "8",
                 "--out", str(tmp_path / "eval.h5")]) == 0
    assert main(["show", str(legacy), "--out", str(tmp_path / "episode.png")]) == 0
    assert (tmp_path / "episode.png").stat().st_size > 0
    capsys.readouterr()
