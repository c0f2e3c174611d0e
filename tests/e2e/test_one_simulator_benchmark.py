"""benchmarks/one_simulator.py (issue 36): a side measures stepping and training at a tiny
size, a side's process answers over its pipe, and the table's verdicts follow the figures.
No time is asserted: the benchmark is a script."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

from tests.conftest import ROOT

BENCHMARK = ROOT / "benchmarks" / "one_simulator.py"


def _benchmark() -> ModuleType:
    spec = importlib.util.spec_from_file_location("one_simulator", BENCHMARK)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


bench = _benchmark()


def test_a_side_measures_stepping_and_training_at_a_tiny_size():
    side = bench.Side()
    for path, links in ((bench.ONE_UAV, 4), (bench.MANY_LINKS, 8 * 64)):
        request = {"kind": "env", "scenario": str(path), "num_envs": 2, "seconds": 0.01}
        reply = side.block(request)
        assert reply["rate"] > 0 and reply["links_per_env"] == links
    assert side.block(request)["rate"] > 0  # the environments built once, kept
    reply = side.block({"kind": "train", "scenario": str(bench.ONE_UAV), "seeds": 1,
                        "steps": 5})
    assert reply["rate"] > 0


def test_a_side_process_says_where_adaptsky_came_from_and_answers_every_request(tmp_path):
    requests = [{"kind": "env", "scenario": str(bench.FEW_LINKS), "num_envs": 2,
                 "seconds": 0.01},
                {"kind": "env", "scenario": str(tmp_path / "missing.toml"), "num_envs": 2,
                 "seconds": 0.01}]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "plugins" /
                                                                          "builtin")])}
    done = subprocess.run([sys.executable, str(BENCHMARK), "--serve"], cwd=ROOT, env=env,
                          input="".join(json.dumps(r) + "\n" for r in requests),
                          capture_output=True, text=True, timeout=300, check=True)
    hello, measured, refused = [json.loads(line) for line in done.stdout.splitlines()]
    assert Path(hello["adaptsky"]) == ROOT / "adaptsky" and hello["threads"] == 1
    assert measured["rate"] > 0 and measured["links_per_env"] == 4
    assert "missing.toml" in refused["error"] and "\n" not in refused["error"]
    assert str(tmp_path) not in refused["error"]  # the file's name, not its path


class FakeSide:
    """A side that answers every block with a fixed rate per scenario (or an error)."""

    def __init__(self, rates: dict[str, Any]) -> None:
        self.rates = rates

    def block(self, request: dict[str, Any]) -> dict[str, Any]:
        name = Path(request["scenario"]).name
        rate = self.rates[f"train {name}" if request["kind"] == "train" else name]
        if isinstance(rate, str):
            return {"error": rate}
        links = {"nyc_mmwave.toml": 4, "one_uav_200m_mmwave.toml": 4,
                 "eight_uavs_mmwave.toml": 512}[name]
        return {"rate": rate, "links_per_env": links}


def test_the_verdicts_compare_new_with_old_and_eight_uavs_with_one():
    old = FakeSide({"nyc_mmwave.toml": 1000.0, "train nyc_mmwave.toml": 2000.0,
                    "one_uav_200m_mmwave.toml": 4000.0,
                    "eight_uavs_mmwave.toml": "ScenarioError: users: 64 users and 8 UAVs"})
    new = FakeSide({"nyc_mmwave.toml": 949.0, "train nyc_mmwave.toml": 1900.0,
                    "one_uav_200m_mmwave.toml": 4000.0, "eight_uavs_mmwave.toml": 32.0})
    rows = bench.measure([old, new], seconds=0.01, seeds=2, steps=5, rounds=2)
    assert [(row[0], row[-1]) for row in rows] == [
        ("(a)", "FAIL"), ("(b)", "PASS"), ("(c)", ""), ("(c)", ""), ("(c)", "PASS")]
    assert rows[0][2:5] == ("1,024,000", "971,776", "0.949 (spread 0%)")
    assert rows[3][2].startswith("n/a (ScenarioError: users: 64 users")
    assert rows[3][3] == f"{32 * 256 * 512:,}"  # B x U x N per batched step
    assert rows[4][2:4] == ("-", "1.02")
    assert [row[0] for row in bench.measure([old, new], 0.01, 2, 5, 1, items="c")] == ["(c)"] * 3


def test_a_figure_keeps_its_best_block_and_the_spread_of_all():
    figure = bench.Figure()
    for rate in (90.0, 100.0, 95.0):
        figure.add({"rate": rate, "links_per_env": 4})
    assert (figure.rate, round(figure.spread, 12)) == (100.0, 0.1)
    assert bench.ratio_cell(0.9, [figure, bench.Figure()]) == "0.900 (spread 10%)"
