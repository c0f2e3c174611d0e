"""``adaptsky reproduce`` gives the same files however its runs are grouped: one process
training both runs as one stack (``--workers 1``) and two processes of one run each
(``--workers 2``) write the same CSV, run files and eval files, bit for bit (issue 52, item
9: the grouping follows the cores and the runs left to train, and a seed's numbers once hung
on it)."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from adaptsky_cli.cli.main import main
from tests.helpers.reproduce import SMALL_AGENT, write_experiment

# what says when and how a file was made, not what it holds
MADE = {"created_utc", "command_line"}
TIMINGS = {"seconds_per_layout", "wall_time_s"}


def moving_experiment(tmp_path: Path) -> Path:
    """Two runs of users that move over a drawn layout, evaluated greedily during training
    (the draws of both, and the layout of the second member of a stack, once differed)."""
    return write_experiment(tmp_path / "experiments", f"""
id = "grouped"
title = "one stack or two"
[[groups]]
name = "agent"
scenario = "../scenarios/moving_users_sub6.toml"
runs = 2
set = [{", ".join(SMALL_AGENT)}, "train.eval_every=2", "train.eval_steps=15"]
[evaluation]
policy = "agent"
steps = 20
baselines = ["soa"]
[figure]
kind = "learning-curves"
[[claims]]
text = "sum rate"
quantity = "sum_rate_bps"
""")


def _without_timings(text: str) -> object:
    def strip(value: object) -> object:
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if k not in TIMINGS}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value
    return strip(json.loads(text))


def contents(path: Path) -> dict[str, object]:
    """Every dataset and attribute of an HDF5 file by name (``group@attribute``), as bytes
    (JSON text without its timings), leaving out when and by which command it was made."""
    found: dict[str, object] = {}

    def value(name: str, data: object) -> object:
        if name.endswith("_json"):
            text = data.decode() if isinstance(data, bytes) else str(data)
            return _without_timings(text)
        array = np.asarray(data)
        return (array.dtype.str, array.shape, array.tobytes()) if array.dtype.kind != "O" \
            else repr(array.tolist())

    def visit(name: str, item: h5py.Group | h5py.Dataset) -> None:
        for key, attribute in item.attrs.items():
            if key not in MADE:
                found[f"{name}@{key}"] = value(key, attribute)
        if isinstance(item, h5py.Dataset):
            found[name] = value(name, item[()])

    with h5py.File(path, "r") as file:
        visit("", file)
        file.visititems(visit)
    return found


def test_one_stack_and_two_processes_write_the_same_files(tmp_path):
    experiment = moving_experiment(tmp_path)
    outs = {workers: tmp_path / f"workers{workers}" for workers in (1, 2)}
    for workers, out in outs.items():
        assert main(["reproduce", str(experiment), "--out", str(out), "--episodes", "4",
                     "--steps", "10", "--workers", str(workers), "--quiet"]) == 0
    one, two = outs[1], outs[2]
    assert (one / "grouped.csv").read_bytes() == (two / "grouped.csv").read_bytes()
    files = sorted(p.relative_to(one) for p in one.glob("*/*.h5"))
    assert [str(p) for p in files] == ["evals/agent-seed0.h5", "evals/agent-seed1.h5",
                                       "evals/soa.h5", "runs/agent-seed0.h5",
                                       "runs/agent-seed1.h5"]
    for name in files:
        mine, theirs = contents(one / name), contents(two / name)
        assert mine.keys() == theirs.keys(), name
        differ = [key for key in mine if mine[key] != theirs[key]]
        assert not differ, (name, differ)
    # the runs learnt and were evaluated, and the two seeds differ
    with h5py.File(one / "runs/agent-seed1.h5", "r") as run:
        evaluations = run["seeds/1/evaluations"]
        assert list(evaluations["episode"][()]) == [2, 4]
        assert np.isfinite(evaluations["tracking_bps"][()]).all()
    assert contents(one / "runs/agent-seed0.h5").get("seeds/0/episodes/sum_rate_bps") != \
        contents(one / "runs/agent-seed1.h5").get("seeds/1/episodes/sum_rate_bps")
