"""An experiment of the ``conditions`` kind (E6's) end to end on a small scenario: three SIC
residuals of one UAV over 20 m x 20 m, one run each, trained, evaluated against SoA, the oracle
and OMA on each group's layout, and reported (figure, CSV, report.md rows and the crossover
note checked against the eval files by the plain formulas)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main

RESIDUALS = (0.0, 0.1, 1.0)

SCENARIO = {"name": "small", "area": {"side_m": 20.0},
            "users": {"positions_m": [[-8.0, 6.0], [-3.0, -7.0], [7.0, 5.0], [9.0, -8.0]],
                      "pairing": "near-far"},
            "uav": {"start_m": [0.0, 0.0, 15.0], "min_height_m": 10.0, "max_height_m": 20.0,
                    "step_m": [2.0, 2.0, 2.0], "power_step": 0.1},
            "reward": {"w_rate": 10.0},
            "agent": {"hidden_sizes": [16, 16], "batch_size": 16, "memory_size": 200},
            "train": {"episodes": 3, "steps": 10, "eval_every": 1, "eval_steps": 20}}


def _experiment() -> str:
    groups = "".join(
        f'[[groups]]\nname = "sic{i}"\nlabel = "epsilon = {eps:g}"\nscenario = "s.toml"\n'
        f'runs = 1\nset = ["radio.sic_residual={eps}"]\npanel = "imperfect SIC"\n'
        for i, eps in enumerate(RESIDUALS))
    also = ", ".join(f'"sic{i}"' for i in range(1, len(RESIDUALS)))
    return f"""id = "small-e6"
title = "conditions"
{groups}
[evaluation]
policy = "sic0"
also = [{also}]
steps = 30
baselines = ["soa", "oracle", "oma"]
policies = ["last"]
[figure]
kind = "conditions"
[[claims]]
text = "share of the bound"
quantity = "pct_of_bound"
[[claims]]
text = "the bound over OMA"
quantity = "bound_over_oma_pct"
"""


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    folder = tmp_path_factory.mktemp("conditions")
    (folder / "s.toml").write_text(dumps(SCENARIO))
    (folder / "e.toml").write_text(_experiment())
    out = folder / "out"
    assert main(["reproduce", str(folder / "e.toml"), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    return out


def _mean(path, key="mean_sum_rate_bps") -> float:
    return float(np.mean(next(iter(read_eval_metrics(path)[1].values()))[key]))


def test_each_condition_has_its_baselines_and_the_report_reads_them(reproduced):
    out = reproduced
    report = (out / "report.md").read_text()
    assert (out / "small-e6.png").stat().st_size > 10_000
    bounds = []
    for i, eps in enumerate(RESIDUALS):
        oracle = _mean(out / "evals" / f"oracle-sic{i}.h5")
        oma = _mean(out / "evals" / f"oma-sic{i}.h5")
        bounds.append(oracle)
        gain = 100 * (oracle - oma) / oma
        assert f"| oracle, epsilon = {eps:g} | {gain:+.1f}% |" in report.replace(
            " | - | -", "").replace("|  |  | ", "| ")
        policy = _mean(out / "evals" / f"sic{i}-seed0.h5", "steady_sum_rate_bps")
        assert f"| epsilon = {eps:g} | {100 * policy / oracle:.1f}% | 100.0% |" in report
        over_oma = 100 * (policy - oma) / oma
        assert f"epsilon = {eps:g}: policy {over_oma:+.1f}%, bound {gain:+.1f}%" in report
    # the residual costs the bound; OMA has no SIC and does not change
    assert bounds[0] > bounds[1] > bounds[2]
    omas = [_mean(out / "evals" / f"oma-sic{i}.h5") for i in range(len(RESIDUALS))]
    assert omas[0] == omas[1] == omas[2]
    # without any cancellation (epsilon = 1) NOMA no longer beats OMA: the note says where
    assert bounds[2] < omas[2]
    first = next(f"epsilon = {eps:g}" for eps, b, o in zip(RESIDUALS, bounds, omas, strict=True)
                 if b <= o)
    assert f"the bound no longer beats OMA from {first} on" in report
    assert "| claim | paper | policy | ours | reachable (bound) | per run |" in report
    with open(out / "small-e6.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {row["condition"] for row in rows} == {f"epsilon = {eps:g}" for eps in RESIDUALS}
    assert {row["method"] for row in rows} == {"SoA", "oracle", "OMA (best found)",
                                               "agent, last policy"}


MOVING_EXPERIMENT = """id = "small-e7"
title = "moving"
[[groups]]
name = "standing"
label = "0 m/s"
scenario = "s.toml"
runs = 1
panel = "moving"
[[groups]]
name = "walking"
label = "3 m/s"
scenario = "s.toml"
runs = 1
set = ['users.mobility={model="gauss-markov", mean_speed_mps=3.0}']
panel = "moving"
[evaluation]
policy = "standing"
also = ["walking"]
steps = 150
baselines = ["soa", "tracking"]
policies = ["last"]
[figure]
kind = "conditions"
[[claims]]
text = "gain over tracking"
quantity = "gain_vs_tracking_pct"
"""


def test_moving_users_baselines_are_valued_over_the_policies_window(tmp_path):
    """Where the users move, SoA and tracking are valued over the policies' window (the last
    100 of 150 steps); standing users' held baselines over every step, as before."""
    (tmp_path / "s.toml").write_text(dumps(SCENARIO | {"name": "small"}))
    (tmp_path / "e.toml").write_text(MOVING_EXPERIMENT)
    out = tmp_path / "out"
    assert main(["reproduce", str(tmp_path / "e.toml"), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    with open(out / "small-e7.csv", newline="") as handle:
        rows = {(row["condition"], row["method"]): float(row["mean"])
                for row in csv.DictReader(handle)}
    for method, name in (("SoA", "soa"), ("tracking", "tracking")):
        steady = _mean(out / "evals" / f"{name}-walking.h5", "steady_sum_rate_bps")
        whole = _mean(out / "evals" / f"{name}-walking.h5")
        assert steady != pytest.approx(whole, rel=1e-6)   # the windows differ here
        assert rows[("3 m/s", method)] == steady
        assert rows[("0 m/s", method)] == _mean(out / "evals" / f"{name}-standing.h5")
    policy = _mean(out / "evals" / "walking-seed0.h5", "steady_sum_rate_bps")
    tracking = rows[("3 m/s", "tracking")]
    report = (out / "report.md").read_text()
    assert f"{100 * (policy - tracking) / tracking:+.1f}%" in report


def test_groups_own_layouts_and_baselines_and_one_baseline_per_network(tmp_path):
    """Two learners on one network share its SoA (one eval file); a group with its own
    ``eval_layouts`` and ``baselines`` is evaluated on so many uniform layouts, with those."""
    (tmp_path / "s.toml").write_text(dumps(SCENARIO))
    (tmp_path / "e.toml").write_text("""id = "own"
title = "own layouts"
[[groups]]
name = "a"
label = "learner A"
scenario = "s.toml"
runs = 1
panel = "one layout"
[[groups]]
name = "b"
label = "learner B"
scenario = "s.toml"
runs = 1
set = ["agent.lr=0.001"]
panel = "one layout"
[[groups]]
name = "c"
label = "learner A, unseen layouts"
scenario = "s.toml"
runs = 1
panel = "three layouts"
eval_layouts = 3
baselines = ["soa"]
[evaluation]
policy = "a"
also = ["b", "c"]
steps = 20
baselines = ["soa", "oracle"]
policies = ["last"]
[figure]
kind = "conditions"
[[claims]]
text = "share of the bound"
quantity = "pct_of_bound"
""")
    out = tmp_path / "out"
    assert main(["reproduce", str(tmp_path / "e.toml"), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    evals = sorted(path.name for path in (out / "evals").glob("*.h5"))
    # a's SoA and oracle serve b (same network, another agent); c has only its SoA
    assert evals == ["a-seed0.h5", "b-seed0.h5", "c-seed0.h5", "oracle-a.h5", "soa-a.h5",
                     "soa-c.h5"]
    record, metrics = read_eval_metrics(out / "evals" / "c-seed0.h5")
    assert record["layouts"] == 3
    assert len(next(iter(metrics.values()))["mean_sum_rate_bps"]) == 3
    assert read_eval_metrics(out / "evals" / "a-seed0.h5")[0]["layouts"] is None
    report = (out / "report.md").read_text()
    assert "| share of the bound | - | learner A |" in report
    assert "|  |  | learner B |" in report
