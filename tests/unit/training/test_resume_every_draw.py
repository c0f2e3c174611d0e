"""The greedy evaluations during training draw alike at every episode (common random numbers,
issue 52, item 2; docs/training.md): for every seed, alone or in a stack, and as ``adaptsky
eval`` draws. (A run killed with kill -9 and resumed, wherever something is drawn, for every
learner: tests/contract/test_learners.py.)"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.training.evaluation import COLUMNS, GreedyEvaluator, evaluation_set
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

RUN = ["--seeds", "0,1", "--workers", "1", "--quiet"]
TRAIN = {"episodes": 4, "steps": 10, "checkpoint_every": 2, "eval_every": 1,
         "eval_steps": 12}
DQN = {"hidden_sizes": [16, 16], "batch_size": 8, "memory_size": 50,
       "target_update_episodes": 1}


def small_scenario(tmp_path: Path, name: str, changes: dict[str, dict]) -> Path:
    """The shipped scenario ``name`` with its ``changes`` (a new ``agent`` replaces its
    own) and the small :data:`TRAIN`, as a file."""
    data = load_scenario(SCENARIOS / name).model_dump(mode="json")
    data["agent"] = {}
    for section, values in ({"train": TRAIN} | changes).items():
        data[section] = {**data[section], **values}
    path = tmp_path / name
    path.write_text(dumps(data))
    return path


def test_greedy_evaluations_of_one_policy_draw_alike_at_every_episode():
    """A frozen policy evaluated after episodes 1, 2 and 3 of a stack that trains in between
    (moving users, fading): every row equal; both seeds of the stack see the same draws, and
    a seed evaluated alone gets its row in the stack."""
    scenario = load_scenario(SCENARIOS / "moving_users_fading_sub6.toml")
    scenario = scenario.model_copy(update={"train": scenario.train.model_copy(update={
        "steps": 10, "episodes": 3, "eval_every": 1, "eval_steps": 30})})
    evaluation = evaluation_set(scenario)
    run = StackRun([Member(scenario, seed, evaluation) for seed in (0, 1)])
    frozen = np.random.default_rng(7).standard_normal((observation_size_of(scenario), 1))

    def greedy(observations: np.ndarray) -> np.ndarray:  # (S, n, obs) -> (S, n) indices
        count = run.env.controls.count
        return (np.floor(np.abs(observations @ frozen)[..., 0] * 1e3) % count).astype(int)

    run.algorithm.greedy = greedy  # type: ignore[method-assign]
    rows = [[result.evaluation for result in run.run_episode()] for _ in range(3)]
    columns = [c for c in COLUMNS if c != "episode"]
    first = rows[0][0]
    assert np.isfinite([first["sum_rate_bps"], first["tracking_bps"]]).all()
    for episode in rows:
        for row in episode:
            np.testing.assert_equal({c: row[c] for c in columns},
                                    {c: first[c] for c in columns})
    alone = GreedyEvaluator([evaluation], 30).run(greedy)[0]
    np.testing.assert_equal({c: alone[c] for c in columns}, {c: first[c] for c in columns})
    # the draws matter here: other draws, other numbers
    other = GreedyEvaluator([evaluation], 30)
    other.seeds = [[np.random.SeedSequence(1)]]
    assert other.run(greedy)[0]["sum_rate_bps"] != first["sum_rate_bps"]


def test_eval_gives_back_every_seed_s_best_score_and_tracking(tmp_path, capsys):
    """Users that move: the training layout's evaluations draw what ``adaptsky eval`` draws
    (seed 0), so eval of each seed's best policy gives back its stored best score, and its
    tracking the stored tracking, bit for bit."""
    scenario = small_scenario(tmp_path, "moving_users_sub6.toml",
                              {"agent": {"algorithm": "dqn", **DQN}})
    run = tmp_path / "run.h5"
    assert main(["train", str(scenario), *RUN, "--out", str(run)]) == 0
    for seed in (0, 1):
        capsys.readouterr()
        assert main(["eval", str(run), "--seed", str(seed), "--steps", str(TRAIN["eval_steps"]),
                     "--compare", "tracking", "--out", str(tmp_path / f"eval{seed}.h5"),
                     "--json"]) == 0
        methods = json.loads(capsys.readouterr().out)["methods"]
        with h5py.File(run) as f:
            best = f[f"seeds/{seed}/checkpoint/best"].attrs["score"]
            tracking = f[f"seeds/{seed}/evaluations/tracking_bps"][()]
        assert methods["policy"]["summary"]["steady_sum_rate_bps"] == best
        assert (tracking == methods["tracking"]["summary"]["steady_sum_rate_bps"]).all()


def _frozen(weights: list[np.ndarray], count: int) -> Callable[[np.ndarray], np.ndarray]:
    """A fixed greedy policy per member: indices (S, n) from observations (S, n, obs)."""
    def greedy(observations: np.ndarray) -> np.ndarray:
        return np.stack([(np.floor(np.abs(obs @ w)[..., 0] * 1e3) % count).astype(int)
                         for obs, w in zip(observations, weights, strict=True)])
    return greedy


@pytest.mark.parametrize(("name", "train"), [
    ("nyc_mmwave.toml", {}),                                       # nothing drawn
    ("moving_users_sub6.toml", {}),                                 # users move
    ("nyc_mmwave_any_layout.toml", {"eval_layouts": 3}),            # held-out layouts
])
def test_a_seed_s_evaluation_is_the_same_alone_and_in_a_stack(name, train):
    """Each member's row of a stack of two equals its row evaluated alone, bit for bit (the
    steady means are taken member by member)."""
    scenario = load_scenario(SCENARIOS / name)
    scenario = scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"eval_steps": 120, **train})})
    # a stored reference (no search): 30 Gbit/s on every layout
    evaluation = evaluation_set(scenario, [np.full(train.get("eval_layouts", 1), 3e10)])
    rng = np.random.default_rng(3)
    weights = [rng.standard_normal((observation_size_of(scenario), 1)) for _ in range(2)]
    stacked = GreedyEvaluator([evaluation] * 2, 120).run(_frozen(weights, 10))
    for member in range(2):
        alone = GreedyEvaluator([evaluation], 120).run(_frozen(weights[member:member + 1], 10))
        np.testing.assert_equal(stacked[member], alone[0])
    assert stacked[0]["score"] != stacked[1]["score"]  # two policies, two numbers
