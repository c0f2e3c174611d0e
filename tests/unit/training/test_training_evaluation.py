"""Greedy evaluations during training (docs/training.md): their rows, the best policy kept,
``eval --policy best|last``, ``inspect``, resume, run-file format 2 and its checks. Scores are
checked against rollouts and oracles computed here, and against ``adaptsky eval``."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.network import NetworkBatch
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.training import api
from adaptsky.training.evaluation import (
    EVALUATION_KEYS,
    GreedyEvaluator,
    evaluation_set,
    percent_of,
    score,
)
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import TRAINING_LAYOUT_M, make_scenario

SEEDS = (0, 1)
EVERY, EVAL_STEPS, EPISODES = 2, 30, 6
# a coarse UAV lattice (11 x 11 x 20 points) keeps the oracle cheap; lr 1e-2 and a fast
# epsilon decay make the greedy policy change between evaluations
SECTIONS = {
    "uav": {"step_m": [10.0, 10.0, 10.0]},
    "agent": {"hidden_sizes": [16, 16], "batch_size": 8, "memory_size": 200,
              "target_update_episodes": 2, "lr": 1e-2, "epsilon_decay_steps": 40.0},
    "train": {"steps": 20, "episodes": EPISODES, "checkpoint_every": 2, "seeds": list(SEEDS),
              "eval_every": EVERY, "eval_steps": EVAL_STEPS},
}


def sections(**changes: dict) -> dict:
    merged = {name: dict(values) for name, values in SECTIONS.items()}
    for name, values in changes.items():
        merged[name] = {**merged.get(name, {}), **values}
    return merged


def write(tmp_path: Path, name: str, **changes: dict) -> Path:
    data = make_scenario(**sections(**changes)).model_dump(mode="json")
    data["name"] = name
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(data))
    return path


def train(tmp_path: Path, name: str, episodes: int = EPISODES, **changes: dict) -> Path:
    path, _ = api.train(scenario_path=write(tmp_path, name, **changes),
                        out=tmp_path / f"{name}.h5", episodes=episodes, workers=1, quiet=True)
    return path


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Seeds 0 and 1, 6 episodes of 20 steps, a greedy evaluation every 2 episodes."""
    return train(tmp_path_factory.mktemp("full"), "full")


def eval_json(capsys, run: Path, out: Path, *extra: str) -> dict:
    capsys.readouterr()
    assert main(["eval", "--checkpoint", str(run), "--json", "--out", str(out),
                 *extra]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def assert_same_tree(a, b, where: str = "") -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for key in a:
            assert_same_tree(a[key], b[key], f"{where}/{key}")
    else:
        assert np.array_equal(np.asarray(a), np.asarray(b),
                              equal_nan=np.asarray(a).dtype.kind == "f"), where


def everything(path: Path) -> dict:
    """Per seed: curves, evaluations, best policy and the checkpoint's agent, replay, rng."""
    with RunReader(path) as run:
        result = {}
        for seed in run.seeds:
            checkpoint = run.checkpoint(seed)
            result[seed] = {"episodes": run.episodes(seed), "evaluations": run.evaluations(seed),
                            "best": run.best(seed) or {},
                            **{key: checkpoint[key] for key in ("agent", "replay", "rng")}}
        return result


def brute_force_oracle(layout_m: list, min_se: float = 0.0) -> float:
    """The best sum rate over every lattice point (x, y in -50..50, h in 10..200, step 10)
    and alpha grid (0.01..0.99): with R_min = 0 each cluster's share is chosen on its own."""
    scenario = make_scenario(**sections())
    xs, hs = np.arange(-50.0, 51.0, 10.0), np.arange(10.0, 201.0, 10.0)
    points = np.array([(x, y, h) for x in xs for y in xs for h in hs])
    env = NetworkBatch(scenario, num_envs=len(points),
                       users_m=np.broadcast_to(np.array(layout_m), (len(points), 4, 2)).copy())
    best = np.full((len(points), 2), -np.inf)
    for alpha in np.round(np.arange(1, 100) * 0.01, 10):
        rates = env.evaluate_at(points, np.full((len(points), 2), alpha)).rate_bps
        best = np.maximum(best, rates.reshape(-1, 2, 2).sum(axis=2))  # clusters (1,2), (3,4)
    assert min_se == 0.0
    return float(best.sum(axis=1).max())


# ---- the rows and the best policy ----------------------------------------------------------

def test_evaluation_rows_are_percent_of_the_oracle_and_the_best_is_their_maximum(full):
    oracle = brute_force_oracle(TRAINING_LAYOUT_M)
    with h5py.File(full, "r") as f:
        assert f.attrs["format_version"] == 5
        assert np.array_equal(f["evaluation/training_layouts_m"][()], [TRAINING_LAYOUT_M])
        stored = f["evaluation/training_oracle_bps"][()]
        assert "heldout_oracle_bps" not in f["evaluation"]
    assert stored == pytest.approx([oracle], rel=1e-9)
    with RunReader(full) as run:
        for seed in SEEDS:
            rows, best = run.evaluations(seed), run.best(seed)
            assert list(rows["episode"]) == [2, 4, 6]
            assert rows["pct_oracle"] == pytest.approx(100 * rows["sum_rate_bps"] / oracle,
                                                       rel=1e-9)
            assert np.array_equal(rows["score"], rows["pct_oracle"])
            assert (rows["pct_oracle"] > 0).all() and (rows["pct_oracle"] <= 100).all()
            assert ((rows["fairness"] > 0) & (rows["fairness"] <= 1)).all()
            for column in ("heldout_sum_rate_bps", "heldout_pct_oracle",
                           "heldout_pct_oracle_median"):
                assert np.isnan(rows[column]).all()
            first_best = int(np.argmax(rows["score"]))        # ties: the earliest stays
            assert best["episode"] == rows["episode"][first_best]
            assert best["score"] == rows["score"].max()
        # measured: seed 0 scores equal at episodes 4 and 6, seed 1 best at 6
        assert run.best(0)["episode"] == 4 and run.best(1)["episode"] == 6


def _constant(action: int) -> Callable[[np.ndarray], np.ndarray]:
    return lambda obs: np.full(obs.shape[:2], action)


def test_steady_state_is_the_mean_of_the_last_100_steps_and_sampled_los_scores_in_bit_s():
    steps, action = 130, 5
    scenario = make_scenario(**sections(channel={"los": "sampled"},
                                        train={"eval_steps": steps}))
    evaluation = evaluation_set(scenario)
    assert np.isnan(evaluation.training.oracle_bps).all()     # no oracle to compare with
    row = GreedyEvaluator([evaluation], steps).run(_constant(action))[0]
    env = NetworkBatch(scenario, num_envs=1, seed=0, users_m=np.array([TRAINING_LAYOUT_M]))
    env.reset()
    rates = [env.step(np.array([action]))[3].rate_bps[0] for _ in range(steps)]
    sums = np.array(rates).sum(axis=1)
    assert row["sum_rate_bps"] == pytest.approx(sums[-100:].mean(), rel=1e-12)
    assert row["sum_rate_bps"] != pytest.approx(sums.mean(), rel=1e-6)   # not every step
    assert row["score"] == row["sum_rate_bps"]
    assert np.isnan(row["pct_oracle"])
    jain = [r.sum() ** 2 / (4 * (r**2).sum()) for r in rates[-100:]]
    assert row["fairness"] == pytest.approx(np.mean(jain), rel=1e-9)


MOVING = {"mobility": {"model": "gauss-markov", "mean_speed_mps": 3.0}}


def _tracking_steady(scenario, layouts_m: np.ndarray, steps: int) -> np.ndarray:
    """The tracking baseline's steady sum rate (L,) run alone from seed 0, as ``baseline``
    runs it (its rule is tested in tests/unit/rollouts)."""
    from adaptsky.rollouts.tracking import track
    return track(scenario, steps, layouts_m, seed=0).sum_rate_bps[-100:].mean(axis=0)


def test_moving_users_evaluations_fly_tracking_through_the_same_draws():
    """Where users move, each evaluation also flies tracking on its environments re-seeded
    alike, with the greedy rollout's draws: every evaluation of one member equals tracking
    run alone from seed 0 (the same user moves: every evaluation draws alike), and the
    policy's numbers are those of an evaluator that does not fly tracking."""
    steps, action = 130, 5
    scenario = make_scenario(**sections(users=MOVING, train={"eval_steps": steps}))
    evaluation = evaluation_set(scenario)
    evaluator = GreedyEvaluator([evaluation], steps)
    first, second = (evaluator.run(_constant(action))[0] for _ in range(2))
    alone = _tracking_steady(scenario, np.array([TRAINING_LAYOUT_M]), steps)
    assert first["tracking_bps"] == pytest.approx(alone[0], rel=1e-12)
    np.testing.assert_equal(second, first)  # each evaluation: the same draws (NaN = NaN)
    plain = GreedyEvaluator([evaluation], steps)
    plain.tracks = [False]
    rows = [plain.run(_constant(action))[0] for _ in range(2)]
    assert [r["sum_rate_bps"] for r in rows] == [first["sum_rate_bps"], second["sum_rate_bps"]]
    assert all(np.isnan(r["tracking_bps"]) for r in rows)
    assert first["score"] == first["sum_rate_bps"]          # tracking does not score
    static = make_scenario(**sections(train={"eval_steps": steps}))
    row = GreedyEvaluator([evaluation_set(static)], steps).run(_constant(action))[0]
    assert np.isnan(row["tracking_bps"]) and np.isnan(row["heldout_tracking_bps"])


def test_greedy_text_gives_the_gain_over_tracking():
    from adaptsky.training.progress import greedy_text
    row = {"pct_oracle": float("nan"), "heldout_pct_oracle": float("nan"),
           "sum_rate_bps": 2.75e9, "heldout_sum_rate_bps": float("nan"),
           "tracking_bps": 2.5e9, "heldout_tracking_bps": float("nan")}
    assert greedy_text(row) == "2.75 Gbit/s, +10.0% over tracking"
    assert greedy_text(row, short=True) == "2.75 Gbit/s +10.0% tr"
    assert greedy_text(row | {"tracking_bps": float("nan")}, short=True) == "2.75 Gbit/s"


def test_held_out_layouts_score_the_mean_percent_of_their_oracles():
    """users.placement = "fresh": no training layout; 3 held-out uniform layouts from
    eval_layout_seed, paired near-far."""
    steps, action = 40, 9
    scenario = make_scenario(**sections(users={"count": 4, "placement": "fresh"},
                                        train={"eval_layouts": 3, "eval_layout_seed": 5,
                                               "eval_steps": steps}))
    evaluation = evaluation_set(scenario)
    assert evaluation.training is None
    layouts = np.random.default_rng(5).uniform(-50.0, 50.0, (3, 4, 2))
    assert np.array_equal(evaluation.held_out.layouts_m, layouts)
    oracle = np.array([brute_force_oracle_near_far(layout) for layout in layouts])
    assert evaluation.held_out.oracle_bps == pytest.approx(oracle, rel=1e-9)
    row = GreedyEvaluator([evaluation], steps).run(_constant(action))[0]
    near_far = make_scenario(**sections(users={"count": 4, "placement": "uniform",
                                               "layout_seed": 5, "pairing": "near-far"}))
    env = NetworkBatch(near_far, num_envs=3, seed=0, users_m=layouts)
    env.reset()
    sums = np.array([env.step(np.full(3, action))[3].sum_rate_bps for _ in range(steps)])
    steady = sums[-100:].mean(axis=0)
    pct = 100 * steady / oracle
    assert row["heldout_sum_rate_bps"] == pytest.approx(steady.mean(), rel=1e-12)
    assert row["heldout_pct_oracle"] == pytest.approx(pct.mean(), rel=1e-9)
    assert row["heldout_pct_oracle_median"] == pytest.approx(np.median(pct), rel=1e-9)
    assert row["score"] == row["heldout_pct_oracle"]
    assert np.isnan(row["sum_rate_bps"]) and np.isnan(row["pct_oracle"])


def brute_force_oracle_near_far(layout_m: np.ndarray) -> float:
    """:func:`brute_force_oracle` with the users paired near-far from the start (0, 0, 50):
    the nearest with the farthest (LoS always: the gain falls with distance)."""
    distance = np.hypot(np.hypot(*np.asarray(layout_m).T), 50.0)
    order = np.argsort(distance)
    paired = np.asarray(layout_m)[[order[0], order[3], order[1], order[2]]]
    return brute_force_oracle(paired.tolist())


def test_percent_of_is_nan_where_the_oracle_is_zero_or_missing():
    pct = percent_of(np.array([50.0, 10.0, 7.0, 3.0]), np.array([200.0, 0.0, np.nan, 4.0]))
    assert pct[0] == 25.0 and pct[3] == 75.0
    assert np.isnan(pct[1]) and np.isnan(pct[2])


def test_a_nan_score_is_never_the_best():
    scenario = make_scenario(**sections(train={"eval_every": 1, "eval_steps": 5}))
    evaluation = evaluation_set(scenario, [np.array([0.0])])   # an oracle of 0: no % of it
    row = GreedyEvaluator([evaluation], 5).run(_constant(0))[0]
    assert np.isnan(score(row, evaluation)) and row["sum_rate_bps"] > 0
    run = StackRun([Member(scenario, 0, evaluation)])
    results = [run.run_episode()[0] for _ in range(2)]
    assert [r.evaluation["episode"] for r in results] == [1, 2]
    assert all(np.isnan(r.evaluation["score"]) for r in results)
    assert run.best(0) is None and "best" not in run.checkpoint(0)


# ---- evaluation changes nothing of training --------------------------------------------------

def test_evaluation_does_not_change_training(full, tmp_path):
    quiet = train(tmp_path, "full", train={"eval_every": 0})
    with_evaluation, without = everything(full), everything(quiet)
    for seed in SEEDS:
        assert len(without[seed]["evaluations"]["episode"]) == 0
        assert without[seed]["best"] == {}
        for key in ("episodes", "agent", "replay", "rng"):
            assert_same_tree(with_evaluation[seed][key], without[seed][key], f"{seed}/{key}")


def test_evaluation_settings_are_the_four_train_keys():
    assert set(EVALUATION_KEYS) == {"eval_every", "eval_steps", "eval_layouts",
                                    "eval_layout_seed"}


# ---- adaptsky eval --policy ------------------------------------------------------------------

@pytest.mark.parametrize("seed", SEEDS)
def test_eval_reports_the_in_training_score_of_the_best_and_last_policy(full, tmp_path, capsys,
                                                                        seed):
    with RunReader(full) as run:
        best, rows = run.best(seed), run.evaluations(seed)
    args = ["--seed", str(seed), "--compare", "oracle", "--steps", str(EVAL_STEPS)]
    results = eval_json(capsys, full, tmp_path / "best.h5", *args)
    assert results["policy_steady_pct_of_oracle"]["mean"] == pytest.approx(best["score"],
                                                                           rel=1e-12)
    used = results["policy"]
    assert (used["policy"], used["policy_asked"]) == ("best", "best")
    assert (used["episode"], used["last_episode"]) == (best["episode"], EPISODES)
    assert results["training_evaluations"]["episode"] == [2, 4, 6]
    assert results["training_evaluations"]["score"] == pytest.approx(list(rows["score"]))
    assert results["training_evaluations"]["heldout_pct_oracle"] == [None] * 3
    last = eval_json(capsys, full, tmp_path / "last.h5", *args, "--policy", "last")
    assert (last["policy"]["policy"], last["policy"]["policy_asked"]) == ("last", "last")
    assert last["policy"]["episode"] == EPISODES
    # the evaluation after episode 6 used the weights of the last checkpoint
    assert last["policy_steady_pct_of_oracle"]["mean"] == pytest.approx(rows["score"][-1],
                                                                        rel=1e-12)


def test_eval_human_output_names_the_best_policy(full, tmp_path, capsys):
    capsys.readouterr()
    assert main(["eval", "--checkpoint", str(full), "--seed", "0", "--compare", "",
                 "--steps", "5", "--out", str(tmp_path / "e.h5")]) == 0
    out = capsys.readouterr().out
    words = " ".join(out.split())  # rich wraps long lines and titles
    assert "best greedy evaluation during training, episode 4" in words
    assert "the last checkpoint is episode 6 (--policy last)" in words
    assert "seed 0: greedy evaluations during training (3)" in words
    marked = [line.split() for line in out.splitlines()            # the table's rows
              if line.rstrip().endswith(" best") and line.split()[0].isdigit()]
    assert len(marked) == 1 and marked[0][0] == "4"


def test_eval_refuses_an_unknown_policy(full, tmp_path, capsys):
    assert main(["eval", "--checkpoint", str(full), "--compare", "", "--steps", "5",
                 "--policy", "middle", "--out", str(tmp_path / "e.h5")]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == [
        "adaptsky eval: --policy: unknown policy 'middle'; choose from best, last; see "
        "'adaptsky eval --help'"]
    assert not (tmp_path / "e.h5").exists()


def test_a_run_without_evaluations_answers_best_with_its_last_policy(tmp_path, capsys):
    run = train(tmp_path, "short", episodes=2, train={"eval_every": 10})
    results = eval_json(capsys, run, tmp_path / "e.h5", "--compare", "", "--steps", "5")
    used = results["policy"]
    assert (used["policy"], used["policy_asked"]) == ("last", "best")
    assert used["episode"] == used["last_episode"] == 2 and "best_score" not in used
    assert results["training_evaluations"]["episode"] == []
    assert main(["eval", "--checkpoint", str(run), "--compare", "", "--steps", "5",
                 "--out", str(tmp_path / "e2.h5")]) == 0
    words = " ".join(capsys.readouterr().out.split())
    assert "last checkpoint, episode 2" in words and "stands in for the best" in words
    assert "greedy evaluations during training (" not in words
    assert main(["inspect", str(run)]) == 0
    assert "best greedy" not in " ".join(capsys.readouterr().out.split())
    assert main(["inspect", str(run), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert [s["best"] for s in summary["seeds"]] == [None, None]
    assert [s["evaluations"]["episode"] for s in summary["seeds"]] == [[], []]


# ---- inspect ---------------------------------------------------------------------------------

def test_inspect_shows_the_best_greedy_evaluation_and_the_curves(full, capsys):
    capsys.readouterr()
    assert main(["inspect", str(full)]) == 0
    out = capsys.readouterr().out
    words = " ".join(out.split())  # rich wraps long lines and titles
    assert "best greedy" in words and "(episode)" in words  # a header cell, maybe wrapped
    assert "best greedy: the best greedy evaluation during training" in words
    for seed in SEEDS:
        assert f"seed {seed}: greedy evaluations during training (3)" in words
    assert main(["inspect", str(full), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    with RunReader(full) as run:
        for index, seed in enumerate(SEEDS):
            best, rows = run.best(seed), run.evaluations(seed)
            entry = summary["seeds"][index]
            assert entry["seed"] == seed
            assert entry["best"] == {"episode": best["episode"], "score": best["score"]}
            assert entry["evaluations"]["episode"] == [2, 4, 6]
            assert entry["evaluations"]["pct_oracle"] == list(rows["pct_oracle"])
    best_0 = summary["seeds"][0]["best"]
    assert f"{best_0['score']:.1f}% ({best_0['episode']})" in words


# ---- resume --------------------------------------------------------------------------------

@pytest.mark.parametrize("stopped_at", [3, 4])
def test_resumed_run_equals_the_uninterrupted_one_evaluations_and_best_included(
        full, tmp_path, capsys, stopped_at):
    part = train(tmp_path, "full", episodes=stopped_at)
    before = everything(part)
    expected = everything(full)
    for seed in SEEDS:
        count = stopped_at // EVERY
        assert_same_tree(before[seed]["evaluations"],
                         {k: v[:count] for k, v in expected[seed]["evaluations"].items()})
    # seed 0's best (episode 4) is the policy of the checkpoint at episode 4
    if stopped_at == 4:
        with RunReader(part) as run:
            policy = run.checkpoint(0)["agent"]["policy"]
        assert_same_tree(policy, expected[0]["best"]["policy"])
    assert main(["train", "--resume", str(part), "--episodes", str(EPISODES), "--workers", "1",
                 "--quiet"]) == 0, capsys.readouterr().err
    after = everything(part)
    for seed in SEEDS:
        assert_same_tree(after[seed], expected[seed], str(seed))


# ---- run-file format 2 -----------------------------------------------------------------------

def _as_format_1(f: h5py.File) -> None:
    """What a run file written before the evaluations holds."""
    f.attrs["format_version"] = 1
    del f["evaluation"]
    for seed in f["seeds"].values():
        del seed["evaluations"]
        for name in ("episodes/energy_j", "episodes/energy_efficiency_bpj",
                     "trajectory/energy_j", "episodes/outage_share",
                     "episodes/mean_least_rate_bps", "episodes/p5_rate_bps",
                     "trajectory/users_m"):
            del seed[name]
        if "best" in seed["checkpoint"]:
            del seed["checkpoint/best"]
    config = json.loads(f["config"][()])
    for key in EVALUATION_KEYS:
        del config["train"][key]
    del f["config"]
    f.create_dataset("config", data=json.dumps(config), dtype=h5py.string_dtype())


def test_format_1_files_open_without_evaluations_and_resume(full, tmp_path, capsys):
    path = tmp_path / "old.h5"
    shutil.copyfile(full, path)
    with h5py.File(path, "a") as f:
        _as_format_1(f)
    with RunReader(path) as run:
        assert run.scenario.train.eval_every == 0
        assert run.best(0) is None
        assert len(run.evaluations(0)["score"]) == 0
    results = eval_json(capsys, path, tmp_path / "e.h5", "--compare", "", "--steps", "5")
    assert (results["policy"]["policy"], results["policy"]["policy_asked"]) == ("last", "best")
    assert main(["inspect", str(path)]) == 0
    assert "best greedy" not in " ".join(capsys.readouterr().out.split())
    assert main(["train", "--resume", str(path), "--episodes", "7", "--workers", "1",
                 "--quiet"]) == 0, capsys.readouterr().err
    with RunReader(path) as run:
        assert [run.seed_attrs(seed)["episodes_done"] for seed in SEEDS] == [7, 7]
        assert len(run.evaluations(0)["score"]) == 0 and run.best(0) is None


def test_format_4_files_without_the_tracking_columns_open_and_resume(full, tmp_path):
    """Files of format 4 made before the tracking columns: NaN there, resumed without them."""
    path = tmp_path / "before.h5"
    shutil.copyfile(full, path)
    with h5py.File(path, "a") as f:
        for seed in SEEDS:
            for name in ("tracking_bps", "heldout_tracking_bps"):
                del f[f"seeds/{seed}/evaluations/{name}"]
    with RunReader(path) as run:
        rows = run.evaluations(0)
        assert len(rows["score"]) == 3 and np.isnan(rows["tracking_bps"]).all()
    assert main(["train", "--resume", str(path), "--episodes", "8", "--workers", "1",
                 "--quiet"]) == 0
    with RunReader(path) as run, h5py.File(path) as f:
        assert len(run.evaluations(0)["score"]) == 4
        assert "tracking_bps" not in f["seeds/0/evaluations"]


def _replace(name: str, **dataset: object) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        del f[name]
        f.create_dataset(name, **dataset)
    return damage


def _resize_all(rows: int) -> Callable[[h5py.File], None]:
    def damage(f: h5py.File) -> None:
        for column in f["seeds/0/evaluations"].values():
            column.resize(rows, axis=0)
    return damage


def _best_attr(name: str, value: object) -> Callable[[h5py.File], None]:
    return lambda f: f["seeds/1/checkpoint/best"].attrs.__setitem__(name, value)


def _delete(name: str) -> Callable[[h5py.File], None]:
    return lambda f: f.__delitem__(name)


EVALS = "/seeds/0/evaluations"
BEST = "/seeds/1/checkpoint/best"
DAMAGES = {
    "column_too_short": (_replace(f"{EVALS[1:]}/score", data=np.zeros(2), maxshape=(None,),
                                  chunks=True),
                         f"{EVALS}/score: shape (2,) (expected (3,)"),
    "more_rows_than_evaluations": (_resize_all(4),
                                   f"{EVALS}/episode: shape (4,) (expected at most 3 rows: "
                                   "one per 2 episodes)"),
    "column_that_cannot_grow": (_replace(f"{EVALS[1:]}/fairness", data=np.zeros(3)),
                                f"{EVALS}/fairness: cannot grow"),
    "column_missing": (_delete(f"{EVALS[1:]}/heldout_pct_oracle"),
                       f"{EVALS}/heldout_pct_oracle: missing"),
    "table_missing": (_delete(EVALS[1:]), f"{EVALS}: missing"),
    "one_tracking_column_of_two": (_delete(f"{EVALS[1:]}/heldout_tracking_bps"),
                                   f"{EVALS}/heldout_tracking_bps: missing (expected both of "
                                   "tracking_bps and heldout_tracking_bps or neither)"),
    "best_episode_0": (_best_attr("episode", 0), f"{BEST}/@episode: is 0 (expected 1 to 6)"),
    "best_after_the_checkpoint": (_best_attr("episode", 7),
                                  f"{BEST}/@episode: is 7 (expected 1 to 6)"),
    "best_score_nan": (_best_attr("score", np.nan), f"{BEST}/@score: is nan"),
    "best_without_policy": (_delete(f"{BEST[1:]}/policy"), f"{BEST}/policy: missing"),
    "best_weight_shape": (_replace(f"{BEST[1:]}/policy/torso.0.weight",
                                   data=np.zeros((16, 3), np.float32)),
                          f"{BEST}/policy/torso.0.weight: shape (16, 3) (expected (16, 17)"),
    "oracle_shape": (_replace("evaluation/training_oracle_bps", data=np.zeros((1, 2))),
                     "/evaluation/training_oracle_bps: shape (1, 2)"),
}


@pytest.mark.parametrize("case", sorted(DAMAGES))
def test_damaged_evaluations_are_refused_in_one_line(case, full, tmp_path, capsys):
    damage, message = DAMAGES[case]
    path = tmp_path / f"{case}.h5"
    shutil.copyfile(full, path)
    with h5py.File(path, "a") as f:
        damage(f)
    with pytest.raises(RunFileError) as error:
        RunReader(path)
    assert str(error.value).startswith(f"{path}: damaged run file: {message}")
    capsys.readouterr()
    for args in (["inspect", str(path)],
                 ["eval", "--checkpoint", str(path), "--compare", "", "--steps", "5",
                  "--out", str(tmp_path / "e.h5")]):
        assert main(args) == 1
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"{path}: ") and message in lines[0], (
            args, captured.err)
        assert "Traceback" not in captured.err
    assert not (tmp_path / "e.h5").exists()


def test_fresh_run_scores_its_held_out_layouts_as_eval_does_and_resumes(tmp_path, capsys):
    fresh = {"users": {"count": 4, "placement": "fresh"},
             "train": {"seeds": [3], "eval_layouts": 2, "episodes": 4}}
    run = train(tmp_path, "fresh", episodes=4, **fresh)
    with h5py.File(run, "r") as f:
        assert sorted(f["evaluation"]) == ["heldout_layouts_m", "heldout_oracle_bps"]
        assert np.array_equal(f["evaluation/heldout_layouts_m"][()],
                              np.random.default_rng(1).uniform(-50.0, 50.0, (2, 4, 2)))
    with RunReader(run) as reader:
        rows, best = reader.evaluations(3), reader.best(3)
    assert list(rows["episode"]) == [2, 4]
    assert np.isnan(rows["sum_rate_bps"]).all() and np.isnan(rows["pct_oracle"]).all()
    assert np.array_equal(rows["score"], rows["heldout_pct_oracle"])
    results = eval_json(capsys, run, tmp_path / "e.h5", "--layouts", "2", "--layout-seed", "1",
                        "--compare", "oracle", "--steps", str(EVAL_STEPS))
    assert results["policy"]["episode"] == best["episode"]
    assert results["policy_steady_pct_of_oracle"]["mean"] == pytest.approx(best["score"],
                                                                           rel=1e-12)
    assert results["policy_steady_pct_of_oracle"]["median"] == pytest.approx(
        rows["heldout_pct_oracle_median"][list(rows["episode"]).index(best["episode"])],
        rel=1e-12)
    part = tmp_path / "part"
    part.mkdir()
    half = train(part, "fresh", episodes=2, **fresh)
    assert main(["train", "--resume", str(half), "--episodes", "4", "--workers", "1",
                 "--quiet"]) == 0
    assert_same_tree(everything(half), everything(run))


def test_sampled_los_run_scores_in_bit_per_second(tmp_path, capsys):
    run = train(tmp_path, "sampled", episodes=2, channel={"los": "sampled"},
                train={"seeds": [0], "eval_every": 1, "eval_steps": 10})
    with h5py.File(run, "r") as f:
        assert np.isnan(f["evaluation/training_oracle_bps"][()]).all()
    with RunReader(run) as reader:
        rows, best = reader.evaluations(0), reader.best(0)
    assert list(rows["episode"]) == [1, 2]
    assert np.array_equal(rows["score"], rows["sum_rate_bps"]) and (rows["score"] > 1e9).all()
    assert np.isnan(rows["pct_oracle"]).all()
    assert best["score"] == rows["score"].max()
    capsys.readouterr()
    assert main(["inspect", str(run), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["score_kind"] == "rate"
    assert main(["inspect", str(run)]) == 0
    words = " ".join(capsys.readouterr().out.split())
    assert f"{best['score'] / 1e9:.2f} Gbit/s ({best['episode']})" in words
