"""A group swept over any scenario key reports each value apart (issue 35, item 6): its own
curve in the figure and its CSV, its own rows in report.md (mean ± std over that value's
seeds), its own SoA and oracle; and a layout-gains experiment compares each value with the
baselines at that value. Synthetic run files and evaluations: every number is known."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from adaptsky.experiment import runs
from adaptsky.experiment.evaluation import Evaluations
from adaptsky.experiment.plan import Plan, load_experiment, plan_experiment
from adaptsky.experiment.report import write_report
from adaptsky.scenario import parse_scenario
from adaptsky.store.run_file import EPISODE_METRICS, PER_USER_METRICS, append_checkpoint, create_run
from tests.conftest import ROOT

GBPS = 1e9
KEY = "users.speed_m_per_step"
EPISODES = 4


@pytest.fixture(autouse=True)
def stub_runs_are_done(monkeypatch: pytest.MonkeyPatch) -> None:
    """A run written here is done (its checkpoints are stubs, which the run-file validator
    refuses; the e2e tests report real runs)."""
    monkeypatch.setattr(runs, "run_state", lambda spec: runs.RunState(
        "done", EPISODES) if spec.path.exists() else runs.RunState("missing", 0))


def plan_of(tmp_path: Path, body: str) -> Plan:
    folder = tmp_path / "experiments"
    folder.mkdir()
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    path = folder / "sweep.toml"
    path.write_text(body)
    experiment, path = load_experiment(str(path))
    (tmp_path / "out").mkdir()
    return plan_experiment(experiment, path, tmp_path / "out", episodes=EPISODES, steps=20)


def write_run(plan: Plan, name: str, rate_bps: float, fairness: float) -> None:
    """The planned run ``name`` done: EPISODES episodes of a constant sum rate and fairness
    (its checkpoints are stubs: reporting reads curves only)."""
    spec = next(run for run in plan.runs if run.name == name)
    users = parse_scenario(spec.config, spec.name).num_users
    spec.path.parent.mkdir(parents=True, exist_ok=True)
    create_run(spec.path, "", spec.config, {}, seeds=[spec.seed], episodes=EPISODES,
               num_users=users)
    rows = {metric: np.zeros(EPISODES) for metric in EPISODE_METRICS}
    rows |= {metric: np.zeros((EPISODES, users)) for metric in PER_USER_METRICS}
    rows |= {"sum_rate_bps": np.full(EPISODES, rate_bps), "fairness": np.full(EPISODES, fairness)}
    append_checkpoint(spec.path, spec.seed, rows, {}, (EPISODES, {}), {"episode": EPISODES})


def level(rate_bps: float, fairness: float = 0.5) -> dict[str, np.ndarray]:
    """A baseline's metrics on the one training layout."""
    return {"mean_sum_rate_bps": np.array([rate_bps]), "fairness": np.array([fairness])}


CURVES = f"""
id = "sweep"
title = "speed sweep"
[[groups]]
name = "bdq"
scenario = "../scenarios/nyc_mmwave.toml"
runs = 2
[groups.sweep]
key = "{KEY}"
values = [0.0, 2.0]
[evaluation]
policy = "bdq"
baselines = ["soa", "oracle"]
[figure]
kind = "learning-curves"
[[claims]]
text = "sum rate"
quantity = "sum_rate_bps"
[[claims]]
text = "gain"
quantity = "gain_vs_soa_pct"
"""


def test_a_two_value_sweep_draws_two_curves_and_fills_two_rows(tmp_path):
    plan = plan_of(tmp_path, CURVES)
    # speed 0: 1 and 3 Gbit/s (mean 2, std 1); speed 2: 5 and 9 Gbit/s (mean 7, std 2)
    for name, rate in (("bdq-speed_m_per_step-0-seed0", 1), ("bdq-speed_m_per_step-0-seed1", 3),
                       ("bdq-speed_m_per_step-2-seed0", 5), ("bdq-speed_m_per_step-2-seed1", 9)):
        write_run(plan, name, rate * GBPS, 0.5 + rate / 100)
    # SoA 1 Gbit/s at speed 0 and 2 Gbit/s at speed 2; the oracle at speed 0 only
    evaluations = Evaluations(baselines={("soa", 0.0): level(1 * GBPS),
                                         ("soa", 2.0): level(2 * GBPS, 0.25),
                                         ("oracle", 0.0): level(10 * GBPS)})
    written = write_report(plan, evaluations)
    with (plan.out / "sweep.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    slow, fast = f"bdq, {KEY} = 0", f"bdq, {KEY} = 2"
    assert list(rows[0]) == ["episode", *(f"{label}_{column}" for label in (slow, fast)
                                          for column in ("mean", "low", "high", "runs"))]
    assert [int(row["episode"]) for row in rows] == [1, 2, 3, 4]  # window 1 of 4 episodes
    for row in rows:
        assert [float(row[f"{slow}_{c}"]) for c in ("mean", "low", "high", "runs")] == [
            2 * GBPS, 1 * GBPS, 3 * GBPS, 2]
        assert [float(row[f"{fast}_{c}"]) for c in ("mean", "low", "high", "runs")] == [
            7 * GBPS, 5 * GBPS, 9 * GBPS, 2]
    report = written.path.read_text()
    assert (f"| sum rate | - | {slow} | 2.00 Gbit/s ± 1.00 Gbit/s (n = 2) | 10.00 Gbit/s | "
            "1.00 Gbit/s, 3.00 Gbit/s |") in report
    assert (f"|  |  | {fast} | 7.00 Gbit/s ± 2.00 Gbit/s (n = 2) | - | "
            "5.00 Gbit/s, 9.00 Gbit/s |") in report
    # each value against its own SoA: (1, 3) over 1 and (5, 9) over 2 Gbit/s
    assert f"| gain | - | {slow} | +100.0% ± 100.0% (n = 2) | +900.0% | +0.0%, +200.0% |" \
        in report
    assert f"|  |  | {fast} | +250.0% ± 100.0% (n = 2) | - | +150.0%, +350.0% |" in report
    assert f"SoA on the training layout at {KEY} = 0: 1.00 Gbit/s, J = 0.500" in report
    assert f"SoA on the training layout at {KEY} = 2: 2.00 Gbit/s, J = 0.250" in report
    assert f"power split) at {KEY} = 0: 10.00 Gbit/s" in report
    assert (plan.out / "sweep.png").is_file()


def test_a_value_without_a_finished_run_is_named_and_the_others_drawn(tmp_path):
    plan = plan_of(tmp_path, CURVES)
    write_run(plan, "bdq-speed_m_per_step-2-seed0", 4 * GBPS, 0.5)
    report = write_report(plan, Evaluations()).path.read_text()
    assert f"no run of 'bdq' at {KEY} = 0 has finished: no curve" in report
    assert f"| sum rate | - | bdq, {KEY} = 2 | 4.00 Gbit/s | - | - |" in report
    with (plan.out / "sweep.csv").open(newline="") as handle:
        header = next(csv.reader(handle))
    assert header == ["episode", *(f"bdq, {KEY} = 2_{c}" for c in ("mean", "low", "high",
                                                                  "runs"))]


GAINS = """
id = "gains"
title = "swept gains"
[[groups]]
name = "duel"
scenario = "../scenarios/nyc_mmwave.toml"
runs = 2
[groups.sweep]
key = "reward.w_rate"
values = [1.0, 10.0]
[[groups]]
name = "plain"
scenario = "../scenarios/nyc_mmwave.toml"
runs = 2
[evaluation]
policy = "duel"
layouts = 2
baselines = ["soa"]
compare_groups = ["plain"]
[figure]
kind = "layout-gains"
[[claims]]
text = "gain over SoA"
quantity = "mean_gain_pct_vs_soa"
[[claims]]
text = "gain over plain"
quantity = "mean_gain_pct_vs_plain"
"""


def test_layout_gains_compare_each_value_with_its_own_baselines(tmp_path):
    plan = plan_of(tmp_path, GAINS)

    def rates(*bps: float) -> dict[str, np.ndarray]:
        return {"mean_sum_rate_bps": np.array(bps)}

    # w_rate 1: 2 and 4 Gbit/s on both layouts, w_rate 10: 6 and 8; plain 2 Gbit/s (both
    # seeds): the unswept compared group pairs with every value by seed
    runs = {"duel-w_rate-1-seed0": rates(2e9, 2e9), "duel-w_rate-1-seed1": rates(4e9, 4e9),
            "duel-w_rate-10-seed0": rates(6e9, 6e9), "duel-w_rate-10-seed1": rates(8e9, 8e9),
            "plain-seed0": rates(2e9, 2e9), "plain-seed1": rates(2e9, 2e9)}
    evaluations = Evaluations(runs=runs, baselines={("soa", 1.0): rates(1e9, 1e9),
                                                    ("soa", 10.0): rates(4e9, 4e9)})
    report = write_report(plan, evaluations).path.read_text()
    low, high = "duel, reward.w_rate = 1", "duel, reward.w_rate = 10"
    assert f"| gain over SoA | - | {low} | +200.0% ± 100.0% (n = 2) | - | +100.0%, +300.0% |" \
        in report
    assert f"|  |  | {high} | +75.0% ± 25.0% (n = 2) | - | +50.0%, +100.0% |" in report
    assert f"| gain over plain | - | {low} | +50.0% ± 50.0% (n = 2) | - | +0.0%, +100.0% |" \
        in report
    assert f"|  |  | {high} | +250.0% ± 50.0% (n = 2) | - | +200.0%, +300.0% |" in report
    with (plan.out / "gains.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == ["group", "reward.w_rate", "policy", "seed", "layout", "policy_bps",
                             "soa_bps", "plain_bps"]
    assert [(r["reward.w_rate"], r["seed"], float(r["soa_bps"])) for r in rows[::2]] == [
        ("1.0", "0", 1e9), ("1.0", "1", 1e9), ("10.0", "0", 4e9), ("10.0", "1", 4e9)]


@pytest.mark.parametrize(("change", "message"), [
    (lambda t: t.replace('kind = "learning-curves"', 'kind = "min-se-sweep"'),
     "a min-se-sweep figure needs the evaluated group 'bdq' swept over reward.min_se"),
    (lambda t: t.replace('kind = "learning-curves"', 'kind = "uav-count"').split("[[claims]]")[0],
     "groups.bdq.sweep: a uav-count figure's groups are its x points"),
])
def test_kinds_a_sweep_cannot_apply_to_are_refused(tmp_path, change, message):
    from adaptsky.errors import ScenarioError

    with pytest.raises(ScenarioError, match=message):
        plan_of(tmp_path, change(CURVES))
