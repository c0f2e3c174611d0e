"""Small trainings and their comparisons bit for bit: small scenarios, learning curves,
stacked results and checkpoints, the CUDA-graph check."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from adaptsky.algos.protocol import Policy
from adaptsky.algos.registry import algorithm_of
from adaptsky.arrays import Tree
from adaptsky.rollouts.rollout import greedy_policy, random_policy, rollout
from adaptsky.scenario import Scenario, load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.layout import user_layouts
from adaptsky.store.run_file import RunReader
from adaptsky.training import api
from tests.conftest import SCENARIOS, TRAINING_LAYOUT_M, make_scenario


def three(tmp_path: Path) -> Path:
    """three_uavs_mmwave.toml shrunk ten times (20 m area, 2 m lattice, heights 10-16 m):
    a best response of three UAVs in a fraction of a second; greedy evaluations every
    episode on the training layout and two held-out layouts."""
    data = load_scenario(SCENARIOS / "three_uavs_mmwave.toml").model_dump(mode="json")
    data["name"] = "three"
    data["area"]["side_m"] = 20.0
    data["users"]["positions_m"] = [[x / 10, y / 10] for x, y in data["users"]["positions_m"]]
    data["uav"] |= {"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0, "max_height_m": 16.0,
                    "step_m": [2.0, 2.0, 2.0], "min_separation_m": 2.0, "power_step": 0.1}
    data["agent"] |= {"hidden_sizes": [16], "batch_size": 8, "memory_size": 200}
    data["train"] |= {"episodes": 1, "steps": 3, "eval_every": 1, "eval_steps": 3,
                      "eval_layouts": 2}
    path = tmp_path / "three.toml"
    path.write_text(dumps(data))
    return path


def small_scenario(tmp_path: Path, name: str = "small", **agent: object) -> Path:
    """nyc_mmwave with a small, fast agent: the shape of the paper's set-up at a fraction of
    its cost."""
    data = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
    data["name"] = name
    data["agent"] |= {"hidden_sizes": [32, 32], "batch_size": 32, "memory_size": 2000,
                      "target_update_episodes": 2, **agent}
    data["train"] |= {"episodes": 12, "steps": 100, "checkpoint_every": 3}
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(data))
    return path


def curves(path: Path) -> dict[int, dict[str, np.ndarray]]:
    with RunReader(path) as run:
        return {seed: run.episodes(seed) for seed in run.seeds}


def assert_same_curves(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for seed in a:
        assert a[seed].keys() == b[seed].keys()
        for name in a[seed]:
            assert np.array_equal(a[seed][name], b[seed][name], equal_nan=True), (seed, name)


def checkpoint_policy(scenario: Scenario, checkpoint: Tree) -> Policy:
    """The greedy policy of a checkpoint's last weights."""
    return greedy_policy(scenario, algorithm_of(scenario).policy_of(checkpoint))


def greedy_over_random(scenario_path: Path, out: Path, episodes: int) -> float:
    """Train seed 0 for ``episodes``; its greedy sum rate over a random policy's, 100 steps on
    the training layout."""
    run_path, _ = api.train(scenario_path=scenario_path, out=out, seeds=[0],
                            episodes=episodes, workers=1, quiet=True)
    scenario = load_scenario(scenario_path)
    with RunReader(run_path) as run:
        policy = checkpoint_policy(scenario, run.checkpoint(0))
    layout = user_layouts(scenario, 1)
    greedy = rollout(scenario, policy, 100, layout).sum_rate_bps.mean()
    random = rollout(scenario, random_policy(32, seed=0), 100, layout).sum_rate_bps.mean()
    return float(greedy / random)


AGENT = {"hidden_sizes": [16, 16], "batch_size": 16, "memory_size": 300,
         "target_update_episodes": 2}


def stack_scenario(**sections):
    """A fast scenario that draws: sampled LoS and moving users (every member's generator is
    used every step)."""
    base = {"agent": AGENT, "train": {"steps": 40, "episodes": 4},
            "channel": {"los": "sampled"},
            "users": {"positions_m": [list(p) for p in TRAINING_LAYOUT_M],
                      "speed_m_per_step": 1.0}}
    for name, values in sections.items():
        base[name] = {**base.get(name, {}), **values}
    return make_scenario(**base)


def assert_same_results(a, b) -> None:
    for name in a.metrics:
        assert np.array_equal(a.metrics[name], b.metrics[name], equal_nan=True), name
    for name in a.trajectory:
        assert np.array_equal(a.trajectory[name], b.trajectory[name]), name


def assert_same_checkpoints(a, b) -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            assert_same_checkpoints(a[key], b[key])
    else:
        assert np.array_equal(a, b), (a, b)
