"""Experiment files: every shipped one validates and plans the paper's runs; malformed ones
get one line and exit 1."""

from __future__ import annotations

import inspect
import re

import pytest

from adaptsky.experiment.plan import load_experiment, plan_experiment, shipped_experiments
from adaptsky_cli.cli.main import main
from adaptsky_cli.cli.reproduce_cmd import reproduce
from tests.conftest import ROOT

# runs per shipped experiment: E1a and E1b 10, E2 6 x 8 thresholds, E3 6 + 6 + 6
# (docs/model.md §5); ours: E4 6 per number of UAVs, 1 to 4; E5 6 x 5 weights; E6 6 x 5
# SIC residuals; E9 6 x 10 conditions x 2 learners; bdq 6 + 6 + 6; ppo 6 + 6, sac 6,
# mappo 6 + 6; the suite 22 cells x 5 (four learners on each one-UAV task of four, three on
# each of two and four UAVs)
RUNS = {"e1a": 10, "e1b": 10, "e2": 48, "e3": 18, "e4": 24, "e5": 30, "e6": 78, "e7": 24, "e9": 120,
        "bdq": 18,
        "ppo": 12, "sac": 6, "mappo": 12, "suite": 110}
EPISODES = {"suite": 150}  # the suite's runs: a budget of 150 episodes


def test_every_shipped_experiment_validates_and_plans(tmp_path):
    assert set(shipped_experiments()) == set(RUNS)
    for name, count in RUNS.items():
        experiment, path = load_experiment(name)
        plan = plan_experiment(experiment, path, tmp_path / name)
        assert len(plan.runs) == count
        assert len({run.path for run in plan.runs}) == count
        for run in plan.runs:
            assert run.config["train"]["seeds"] == [run.seed]
            assert (run.config["train"]["episodes"], run.config["train"]["steps"]) == (
                EPISODES.get(name, 1000), 300)


def test_plan_applies_sweeps_sets_and_shrinking(tmp_path):
    experiment, path = load_experiment("e2")
    plan = plan_experiment(experiment, path, tmp_path, runs=2, episodes=3, steps=20,
                           set_values=["agent.lr=0.0005"])
    assert len(plan.runs) == 16
    run = plan.run("adaptsky", 1, 2.5)
    assert run is not None and run.name == "adaptsky-min_se-2.5-seed1"
    config = run.config
    assert config["reward"] | {} == {**config["reward"], "min_se": 2.5, "w_rate": 10.0,
                                      "w_satisfied": 100.0, "w_unsatisfied": 10.0}
    assert (config["train"]["episodes"], config["train"]["steps"]) == (3, 20)
    assert config["agent"]["lr"] == 0.0005
    assert config["radio"]["noise_figure_db"] == 5.0  # the released code's -79 dBm
    e3, e3_path = load_experiment("e3")
    dqn = plan_experiment(e3, e3_path, tmp_path).run("dqn", 0)
    assert dqn is not None and dqn.config["agent"]["dueling"] is False


GOOD = (ROOT / "experiments" / "e1a.toml").read_text()


@pytest.mark.parametrize(("change", "message"), [
    (lambda t: t + "\nunknown_key = 1\n", "unknown_key: unknown key"),
    (lambda t: t.replace("steps = ", "stesp = ", 1), "stesp: unknown key; did you mean 'steps'?"),
    (lambda t: t.replace("runs = 10", 'runs = "ten"'), "groups.0.runs: Input should be a "
                                                       "valid integer"),
    (lambda t: t.replace('policy = "adaptsky"', 'policy = "nobody"'),
     "evaluation names group 'nobody'"),
    (lambda t: t.replace('quantity = "fairness"', 'quantity = "happiness"'),
     "unknown quantity 'happiness'"),
    (lambda t: t.replace('kind = "learning-curves"', 'kind = "pie"'), "figure.kind"),
    (lambda t: t.replace("../scenarios/sub6", "../nowhere/sub6"), "no such file"),
    (lambda t: t + "\n[[[broken\n", "invalid TOML"),
    (lambda t: t.replace('policy = "adaptsky"', 'policy = "adaptsky"\nalso = ["adaptsky"]'),
     "a group is named twice"),
    (lambda t: t.replace('policy = "adaptsky"', 'policy = "adaptsky"\nalso = ["x"]'),
     "evaluation names group 'x'"),
    (lambda t: t.replace('[[claims]]', '[[groups]]\nname = "b"\nscenario = '
                         '"../scenarios/nyc_mmwave.toml"\nruns = 1\n\n[[claims]]', 1)
     .replace('policy = "adaptsky"', 'policy = "adaptsky"\nalso = ["b"]'),
     "other groups are measured in a layout-gains, uav-count or conditions figure only"),
    (lambda t: t.replace('policy = "adaptsky"', 'policy = "adaptsky"\n'
                         'policies = ["best", "best"]'), "policies must be distinct"),
    (lambda t: t.replace("runs = 10", 'runs = 10\npanel = "cities"', 1),
     "groups.adaptsky.panel: panels are drawn in a conditions figure only"),
    (lambda t: t.replace('policy = "adaptsky"', 'policy = "adaptsky"\npolicies = ["first"]'),
     "evaluation.policies.0: Input should be 'last' or 'best'"),
    (lambda t: t.replace("runs = 10", "runs = 10\neval_layouts = 20", 1),
     "groups.adaptsky.eval_layouts: a group's own eval_layouts are for conditions and uav-count"),
    (lambda t: t.replace("runs = 10", 'runs = 10\nbaselines = ["soa"]', 1),
     "groups.adaptsky.baselines: a group's own baselines are for conditions and uav-count"),
    (lambda t: t.replace('[[claims]]', '[[groups]]\nname = "b"\nlabel = "AdaptSky (dueling DQN)"\n'
                         'scenario = '
                         '"../scenarios/nyc_mmwave.toml"\nruns = 1\n\n[[claims]]', 1),
     "groups 'adaptsky' and 'b' have the same label 'AdaptSky (dueling DQN)'"),
])
def test_malformed_experiment_is_one_line(tmp_path, capsys, change, message):
    folder = tmp_path / "experiments"
    folder.mkdir()
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    bad = folder / "bad.toml"
    bad.write_text(change(GOOD))
    code = main(["reproduce", str(bad), "--out", str(tmp_path / "out")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(lines) == 1 and lines[0].startswith(str(bad)) and message in lines[0], lines
    assert not (tmp_path / "out").exists()


def test_unknown_experiment_names_the_shipped_ones(capsys):
    assert main(["reproduce", "e99"]) == 1
    line = capsys.readouterr().err.strip()
    assert line.startswith("e99: no such experiment") and "bdq, e1a, e1b, e2, e3, e4" in line


def test_reproduce_help_names_every_shipped_experiment():
    metadata = inspect.signature(reproduce).parameters["experiment"].annotation.__metadata__
    named = set(re.findall(r"\b[a-z][a-z0-9]*\b", metadata[0].help))
    assert set(shipped_experiments()) <= named
