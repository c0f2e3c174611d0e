"""The contract of every learner of the algorithm registry (issue 53, item 5), written once: a
seed alone equals the same seed in a stack, a checkpoint makes the round trip through the run
file, a run killed with kill -9 after a checkpoint and resumed is the uninterrupted run's file,
and ``adaptsky eval`` loads the greedy policy and gives back the stored evaluation. All bit for
bit, in worlds that draw: users that move, fading, a city, sampled LoS, two UAVs, channel
estimates (in clusters of three).

A learner added to ``adaptsky.algos.registry`` gets these tests without writing them: it runs in
the first world it can learn, with the small settings of :data:`SMALL` its ``[agent]`` has."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.algos.registry import ALGORITHMS, check_actions
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.run_file import RunReader
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.learners import KILL_AFTER_CHECKPOINT, assert_same_files, file_contents
from tests.helpers.training import assert_same_checkpoints, assert_same_results

EPISODES, KILLED_AT, SEEDS = 4, 2, (0, 1)
# a checkpoint every 2 episodes, a greedy evaluation after every episode
TRAIN = {"episodes": EPISODES, "steps": 10, "checkpoint_every": 2, "eval_every": 1,
         "eval_steps": 12}
# small settings of every kind of learner, each taken where the learner's [agent] has the key:
# off-policy memories of 16 rows wrap in episode 2, before the checkpoint the run is killed at
SMALL = {"hidden_sizes": [16, 16], "batch_size": 8, "memory_size": 16,
         "target_update_episodes": 1, "learning_starts": 10,
         "envs_per_seed": 2, "minibatches": 2, "epochs": 2}
# the worlds: a shipped scenario and its changed sections (TRAIN added), each drawing something
WORLDS = {
    "open-ground": ("nyc_mmwave.toml", {}),                       # nothing drawn
    "moving-users": ("moving_users_sub6.toml", {}),
    "moving-users-fading": ("moving_users_fading_sub6.toml", {}),
    "city-fading-geometric-los": ("city_sub6.toml", {}),
    # a fresh layout each episode, held-out layouts and exploring starts too
    "sampled-los-fresh": ("sub6_al_hourani.toml", {
        "channel": {"los": "sampled"}, "users": {"placement": "fresh", "positions_m": None},
        "train": {"eval_layouts": 2, "exploring_starts": "both"}}),
    "two-uavs-sampled-los": ("two_uavs_sub6.toml", {}),
    "two-uavs-moving": ("two_uavs_moving_mmwave.toml", {}),
    # clusters of three whose channels are known by estimates (docs/model.md §15-16)
    "csi-clusters-of-three": ("three_user_clusters_mmwave.toml", {
        "channel": {"csi": {"model": "gaussian", "nmse_db": -10.0}}}),
}


@dataclass(frozen=True)
class Case:
    """A learner in a world: its ``uav.actions`` (None: the world's) and ``[agent]`` keys
    beyond :data:`SMALL`; a slow case runs with ``-m slow``."""

    learner: str
    world: str
    actions: str | None = None
    agent: tuple[tuple[str, object], ...] = ()
    slow: bool = False

    @property
    def name(self) -> str:
        extra = [self.actions] if self.actions else []
        extra += [f"{key}={'+'.join(value) if isinstance(value, tuple) else value}"
                  for key, value in self.agent]
        return "-".join([self.learner, self.world, *extra])


# every learner and every world at least once, each head of PPO's family and each reward split
# of a team of UAVs (the BDQ's "difference": tests/unit/training/test_several_uavs_training.py)
NAMED = [
    Case("dqn", "moving-users"),
    Case("dqn", "city-fading-geometric-los"),
    Case("bdq", "moving-users"),
    Case("bdq", "two-uavs-sampled-los"),
    Case("bdq", "two-uavs-moving", agent=(("reward_split", "per-uav"),)),
    Case("bdq", "two-uavs-sampled-los", agent=(("network", "set"),)),      # the set encoder
    Case("ppo", "moving-users-fading"),                                  # the dense head
    Case("ppo", "open-ground", actions="continuous"),                    # the Gaussian head
    Case("ppo", "open-ground", agent=(("action_head", "branches"),), slow=True),
    Case("sac", "sampled-los-fresh", actions="continuous"),
    Case("sac", "moving-users", actions="continuous", agent=(("network", "set"),
                                                             ("observe", ("velocity",)))),
    Case("mappo", "two-uavs-moving", agent=(("reward_split", "per-uav"),)),
    Case("ippo", "two-uavs-moving", actions="continuous"),
    Case("dqn", "csi-clusters-of-three"),
    # the dueling DQN through its set encoder (written-out backward), fresh layouts
    Case("dqn", "sampled-los-fresh", agent=(("network", "set"),)),
    # observations of the world (docs/environment.md): a city's LoS and heights, users' moves
    # ... read by PPO's set encoder (docs/agent.md)
    Case("ppo", "city-fading-geometric-los", agent=(("observe", ("los", "heights")),
                                                    ("network", "set"))),
    Case("dqn", "moving-users", agent=(("observe", ("velocity",)),
                                       ("user_order", "clusters"))),
    Case("mappo", "two-uavs-moving", agent=(("observe", ("velocity",)),)),
]


def _learns(learner: str, world: str) -> bool:
    """Whether the registry accepts the learner in the world (its UAVs, its actions)."""
    try:
        check_actions(parse_scenario(_scenario_data(Case(learner, world)), "case"), "case")
    except ScenarioError:
        return False
    return True


def _cases() -> list[Case]:
    """:data:`NAMED`, and every other learner of the registry in the first world it learns."""
    named = {case.learner for case in NAMED}
    return NAMED + [Case(learner, next(world for world in WORLDS if _learns(learner, world)))
                    for learner in ALGORITHMS if learner not in named]


def _scenario_data(case: Case) -> dict:
    """The world's scenario with its changes, :data:`TRAIN` and the learner's small agent."""
    spec = ALGORITHMS[case.learner]
    base, changes = WORLDS[case.world]
    data = load_scenario(SCENARIOS / base).model_dump(mode="json")
    for section, values in (changes | {"train": TRAIN | changes.get("train", {})}).items():
        data[section] = {**data[section], **values}
    kind = case.actions or data["uav"]["actions"]
    data["uav"]["actions"] = kind if kind in spec.action_kinds else spec.action_kinds[0]
    keys = type(parse_scenario({**data, "agent": {"algorithm": case.learner}},
                               "keys").agent).model_fields
    data["agent"] = {"algorithm": case.learner,
                     **{key: value for key, value in SMALL.items() if key in keys},
                     **dict(case.agent)}
    return data


CASES = _cases()


@dataclass(frozen=True)
class Trained:
    """A case's scenario file and its run of seeds 0 and 1 trained as one stack, in one
    process, without a stop."""

    case: Case
    scenario: Path
    through: Path


@pytest.fixture(scope="module", params=[
    pytest.param(case, id=case.name, marks=[pytest.mark.slow] if case.slow else [])
    for case in CASES])
def trained(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
            ) -> Trained:
    case: Case = request.param
    folder = tmp_path_factory.mktemp(case.name)
    scenario = folder / "scenario.toml"
    scenario.write_text(dumps(_scenario_data(case)))
    through = folder / "through.h5"
    assert main(["train", str(scenario), *_run_args(SEEDS), "--out", str(through)]) == 0
    return Trained(case, scenario, through)


def _run_args(seeds: tuple[int, ...]) -> list[str]:
    return ["--seeds", ",".join(map(str, seeds)), "--workers", "1", "--quiet"]


def test_every_learner_and_every_world_is_checked():
    assert {case.learner for case in CASES} == set(ALGORITHMS)
    assert {case.world for case in CASES} == set(WORLDS)
    assert len({case.name for case in CASES}) == len(CASES)


def test_a_seed_alone_is_the_seed_in_a_stack(trained, tmp_path):
    """Seed 1 trained alone: everything of it in the stack's file (curves, trajectory,
    evaluations, checkpoint with the best policy) bit for bit; the two seeds learn apart."""
    alone = tmp_path / "alone.h5"
    assert main(["train", str(trained.scenario), *_run_args((1,)), "--out", str(alone)]) == 0
    seed = "seeds/1"
    stacked = {name: value for name, value in file_contents(trained.through).items()
               if name.startswith(seed)}
    by_itself = {name: value for name, value in file_contents(alone).items()
                 if name.startswith(seed)}
    assert_same_files(by_itself, stacked)
    with h5py.File(trained.through) as f:
        assert not np.array_equal(f["seeds/0/trajectory/action"][()],
                                  f["seeds/1/trajectory/action"][()])
        assert np.isfinite(f["seeds/1/episodes/loss"][()][1:]).all()


def test_a_checkpoint_makes_the_round_trip_and_continues_alone_as_in_the_stack(trained):
    """Each seed's last checkpoint, read from the run file, restored into a learner and taken
    again, is the stored one; restored alone and restored in the stack, seed 1's next
    episode is the same."""
    scenario = load_scenario(trained.scenario)
    with RunReader(trained.through) as run:
        stored = [run.checkpoint(seed) for seed in SEEDS]
    stack = StackRun([Member(scenario, seed) for seed in SEEDS])
    for index, checkpoint in enumerate(stored):
        stack.restore(index, checkpoint)
        assert_same_checkpoints(_comparable(stack.checkpoint(index)), _comparable(checkpoint))
    alone = StackRun([Member(scenario, 1)])
    alone.restore(0, stored[1])
    together, single = stack.run_episode(), alone.run_episode()
    assert together[1].episode == single[0].episode == EPISODES + 1
    assert_same_results(together[1], single[0])
    assert_same_checkpoints(_comparable(stack.checkpoint(1)), _comparable(alone.checkpoint(0)))


def _comparable(checkpoint: dict) -> dict:
    """A checkpoint with its generators' states as data (their JSON's key order may differ)."""
    rng = {key: json.loads(value) for key, value in checkpoint["rng"].items()}
    return {key: value for key, value in checkpoint.items() if key != "rng"} | {
        "rng": json.dumps(rng, sort_keys=True)}



def test_kill_9_and_resume_give_the_uninterrupted_file(trained, tmp_path):
    """``train`` killed with SIGKILL right after the checkpoint of episode 2, then ``train
    --resume``: every dataset and attribute of the uninterrupted run's file."""
    out = tmp_path / "resumed.h5"
    killed = subprocess.run([sys.executable, "-c", KILL_AFTER_CHECKPOINT, str(KILLED_AT),
                             "train", str(trained.scenario), *_run_args(SEEDS),
                             "--out", str(out)],
                            capture_output=True, text=True, timeout=300, check=False)
    assert killed.returncode == -9, killed.stderr
    with h5py.File(out) as f:
        assert [int(f[f"seeds/{s}"].attrs["episodes_done"]) for s in SEEDS] == [KILLED_AT] * 2
    assert main(["train", "--resume", str(out), "--workers", "1", "--quiet"]) == 0
    assert_same_files(file_contents(out), file_contents(trained.through))
    with h5py.File(trained.through) as f:  # the comparison holds evaluations after the resume
        assert f["seeds/0/evaluations/episode"][()].tolist() == list(range(1, EPISODES + 1))
        assert np.isfinite(f["seeds/1/evaluations/score"][()]).all()


def test_eval_loads_the_greedy_policy_and_gives_back_its_evaluation(trained, tmp_path, capsys):
    """``adaptsky eval`` of each seed's best policy runs; where training evaluates on the
    training layout, its steady sum rate is the one stored at the best episode, bit for bit
    (the evaluations draw what eval draws)."""
    for seed in SEEDS:
        capsys.readouterr()
        assert main(["eval", str(trained.through), "--seed", str(seed),
                     "--steps", str(TRAIN["eval_steps"]), "--compare", "",
                     "--out", str(tmp_path / f"eval{seed}.h5"), "--json"]) == 0
        policy = json.loads(capsys.readouterr().out)["methods"]["policy"]["summary"]
        with RunReader(trained.through) as run:
            best, evaluations = run.best(seed), run.evaluations(seed)
        assert best is not None
        got = policy["steady_sum_rate_bps"]
        if np.isfinite(evaluations["sum_rate_bps"]).all():  # NaN: no training layout (fresh)
            row = list(evaluations["episode"]).index(best["episode"])
            assert got == evaluations["sum_rate_bps"][row]
        assert np.isfinite(got) and got > 0
