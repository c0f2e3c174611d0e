"""A small PPO scenario, a run killed after a checkpoint, and run files compared dataset by
dataset and attribute by attribute: the learners' contract (tests/contract/test_learners.py),
their own tests (tests/unit/algos) and the logs' tests."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from tests.conftest import SCENARIOS

PPO = {"algorithm": "ppo", "hidden_sizes": [16, 16], "envs_per_seed": 2, "minibatches": 2,
       "epochs": 2}


def ppo_scenario(tmp_path: Path, name: str = "ppo", episodes: int = 12, **changes: dict
                 ) -> Path:
    """nyc_mmwave with a small PPO: 12 episodes of 30 steps, checkpoints every 3."""
    data = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
    data["name"] = name
    data["agent"] = dict(PPO)
    data["train"] |= {"episodes": episodes, "steps": 30, "checkpoint_every": 3,
                      "eval_every": 3, "eval_steps": 40}
    for section, values in changes.items():
        data[section] = {**data.get(section, {}), **values}
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(data))
    return path


# trains as `adaptsky train` does in one process, and kills that process with SIGKILL as soon
# as the checkpoint of episode argv[1] is in the run file
KILL_AFTER_CHECKPOINT = """
import os, signal, sys
from adaptsky.store import run_file
write = run_file.append_checkpoints
def write_then_die(path, items):
    write(path, items)
    if min(item.episode for item in items) >= int(sys.argv[1]):
        os.kill(os.getpid(), signal.SIGKILL)
run_file.append_checkpoints = write_then_die
from adaptsky_cli.cli.main import main
sys.exit(main(sys.argv[2:]))
"""
# what differs between any two runs, by design: the command that made the file, when, and the
# log of the commands that wrote it (times, command lines, episodes before and after)
VARYING = {"/@command_line", "/@created_utc", "sessions"}


def file_contents(path: Path) -> dict[str, object]:
    """Every dataset's value and every attribute (``name@attribute``) of the file at
    ``path`` but :data:`VARYING`."""
    found: dict[str, object] = {}
    with h5py.File(path) as f:
        def visit(name: str, node: h5py.Group | h5py.Dataset) -> None:
            if name in VARYING:
                return
            found.update({f"{name}@{key}": value for key, value in node.attrs.items()
                          if f"{name}@{key}" not in VARYING})
            if isinstance(node, h5py.Dataset):
                found[name] = node[()]
        visit("/", f)
        f.visititems(visit)
    return found


def assert_same_files(got: dict[str, object], expected: dict[str, object]) -> None:
    """Two :func:`file_contents` (or parts of them): the same names, each value of the same
    dtype and shape and equal bit for bit (NaN equal to NaN)."""
    assert got.keys() == expected.keys(), sorted(got.keys() ^ expected.keys())
    different = [name for name in got if not _equal(got[name], expected[name])]
    assert not different, different


def _equal(a: object, b: object) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind in "fc":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))
