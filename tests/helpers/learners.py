"""Run files compared array by array, a run killed after a checkpoint and resumed, and a small
PPO scenario: the learners' bit-for-bit tests (tests/unit/algos) and the logs' tests."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

ADAPTSKY = Path(sys.executable).with_name("adaptsky")

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


def _arrays(path: Path) -> dict[str, np.ndarray]:
    """Every array of every seed of a run file (curves, evaluations, trajectory, checkpoint
    with its best policy), by path."""
    found: dict[str, np.ndarray] = {}
    with h5py.File(path) as f:
        def visit(name: str, node: object) -> None:
            if isinstance(node, h5py.Dataset):
                found[name] = node[()]
        f["seeds"].visititems(visit)
    return found


def _assert_same_arrays(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert a.keys() == b.keys()
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


def _killed_and_resumed(tmp_path: Path, scenario_path: Path, episodes: int = 12) -> Path:
    out = tmp_path / "killed.h5"
    process = subprocess.Popen(
        [str(ADAPTSKY), "train", str(scenario_path), "--seeds", "0,1", "--workers", "1",
         "--out", str(out), "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while True:
        try:
            with RunReader(out) as run:
                if min(run.seed_attrs(s)["episodes_done"] for s in run.seeds) >= 3:
                    break
        except Exception:
            pass
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait()
    with RunReader(out) as run:
        done = run.seed_attrs(0)["episodes_done"]
    assert 3 <= done < episodes and done % 3 == 0
    assert main(["train", "--resume", str(out), "--workers", "2", "--quiet"]) == 0
    return out
