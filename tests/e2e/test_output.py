"""What eval, inspect and train print and write: unique method labels, one-line refusals
before any work, progress where stdout is not a terminal, summary formatting, the eval file's
provenance, and commands that start without importing torch."""

from __future__ import annotations

import io
import json
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import h5py
import pytest
from rich.console import Console

from adaptsky import progress as work_progress
from adaptsky.evaluation.labels import distinct_labels
from adaptsky.report.eval_table import methods_table
from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky.training.progress import TrainingProgress
from adaptsky_cli.cli.main import main
from adaptsky_cli.cli.progress_display import RichReporter
from tests.conftest import ROOT, SCENARIOS

STAMP = r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d "


def tiny_scenario(folder: Path, **changes: dict) -> Path:
    """nyc_mmwave with a tiny network and a coarse lattice (the oracle takes milliseconds)."""
    data = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
    data["name"] = "tiny"
    data["uav"] |= {"step_m": [10.0, 10.0, 10.0], "max_height_m": 60.0}
    data["agent"] |= {"hidden_sizes": [8, 8], "batch_size": 4, "memory_size": 100}
    for section, values in changes.items():
        data[section] |= values
    path = folder / "tiny.toml"
    path.write_text(dumps(data))
    return path


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    """A 2-episode run of 5 steps, trained in-process."""
    folder = tmp_path_factory.mktemp("output")
    out = folder / "run.h5"
    assert main(["train", str(tiny_scenario(folder)), "--seeds", "0", "--episodes", "2",
                 "--steps", "5", "--workers", "1", "--out", str(out), "--quiet"]) == 0
    return out


def _eval(run: Path, out: Path, *extra: str) -> int:
    return main(["eval", "--checkpoint", str(run), "--steps", "5", "--out", str(out), *extra])


def _one_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, lines                 # no progress lines: refused before any work
    assert "Traceback" not in captured.err and captured.out == ""
    return lines[0]


# --- labels ---------------------------------------------------------------------------------


def test_a_method_given_twice_is_refused_before_any_work(run, tmp_path, capsys):
    """`--compare soa,soa` used to end in an h5py traceback after all the work."""
    out = tmp_path / "e.h5"
    assert _eval(run, out, "--compare", "soa,oracle,soa") == 1
    assert _one_line(capsys) == "--compare: 'soa' is given twice; name each method once"
    assert _eval(run, out, "--compare", f"{run},{run.parent}/../{run.parent.name}/run.h5") == 1
    assert "is given twice (as " in _one_line(capsys)
    assert not out.exists()


def test_run_files_with_one_name_get_the_shortest_distinguishing_paths(run, tmp_path, capsys):
    """Two run.h5 in different folders used to share the label 'run.h5' and crash the write."""
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        shutil.copy(run, tmp_path / folder / "run.h5")
    out = tmp_path / "e.h5"
    assert _eval(run, out, "--compare", f"soa,{tmp_path}/a/run.h5,{tmp_path}/b/run.h5",
                 "--json") == 0
    results = json.loads(capsys.readouterr().out)
    assert list(results["methods"]) == ["policy", "soa", "a/run.h5", "b/run.h5"]
    assert set(results["comparison"]) == {"soa", "a/run.h5", "b/run.h5"}
    assert results["compared_runs"]["b/run.h5"]["path"] == str(tmp_path / "b" / "run.h5")
    _, methods = read_eval_metrics(out)
    assert list(methods) == ["a/run.h5", "b/run.h5", "policy", "soa"]   # HDF5 sorts names
    assert methods["a/run.h5"]["mean_sum_rate_bps"].shape == (1,)


def test_long_labels_stay_whole_and_distinct_at_80_columns():
    """Rich cut two default-named runs to the same 'nyc_mmwave-2026…' at 80 columns."""
    labels = ["policy", "soa", "nyc_mmwave-20261123-144028.h5", "nyc_mmwave-20261123-151502.h5"]
    summary = {"mean_sum_rate_bps": 4.77e10, "median_sum_rate_bps": 4.77e10,
               "steady_sum_rate_bps": 4.8e10, "fairness": 0.581, "satisfied_share": 1.0}
    versus = {"beats_share": 1.0, "mean_improvement_pct": 50.1,
              "median_improvement_pct": 50.1, "max_improvement_pct": 50.1}
    results = {"scenario": "nyc_mmwave", "layouts": 1, "layout_seed": None, "steps": 1000,
               "los": "always", "min_se": 0.0,
               "methods": {label: {"summary": summary} for label in labels},
               "comparison": {label: versus for label in labels[1:]}}
    console = Console(file=io.StringIO(), width=80)
    console.print(methods_table(results))
    lines = console.file.getvalue().splitlines()
    assert "…" not in "\n".join(lines) and max(map(len, lines)) <= 80
    header = next(line for line in lines if line.lstrip().startswith("method"))
    width = header.index("mean")
    cells: list[str] = []
    for line in lines[lines.index(header) + 2:]:
        if not line.strip():
            break
        first, rest = line[:width].strip(), line[width:].strip()
        if rest:
            cells.append(first)
            assert rest.split()[:2] == ["47.70", "47.70"]      # numbers are never cut
        else:
            cells[-1] += first                                  # a label folded onto more lines
    assert cells == labels


def test_a_run_file_named_like_a_baseline_gets_its_folder():
    assert distinct_labels([Path("/x/soa"), Path("/x/a/r.h5"), Path("/y/a/r.h5")],
                           taken={"policy", "soa"}) == ["x/soa", "x/a/r.h5", "y/a/r.h5"]


def test_unknown_method_names_the_valid_ones(run, tmp_path, capsys):
    assert _eval(run, tmp_path / "e.h5", "--compare", "soa,orcale") == 1
    assert _one_line(capsys) == ("--compare: unknown method 'orcale'; choose from soa, "
                                 "tracking, oracle, best-response, oma, random, centroid or a "
                                 "run file (.h5)")
    assert _eval(run, tmp_path / "e.h5", "--compare", str(tmp_path / "gone.h5")) == 1
    assert _one_line(capsys) == f"{tmp_path / 'gone.h5'}: no such run file"


def test_oracle_on_sampled_los_is_refused_before_the_rollouts(run, tmp_path, capsys):
    sampled = tiny_scenario(tmp_path, channel={"los": "sampled"})
    assert _eval(run, tmp_path / "e.h5", "--scenario", str(sampled), "--compare",
                 "oracle") == 1
    assert "channel.los is 'sampled'; the oracle needs deterministic gains" in _one_line(capsys)


def test_scaling_mismatch_names_the_key(run, tmp_path, capsys):
    wide = tiny_scenario(tmp_path, area={"side_m": 250.0})
    assert _eval(run, tmp_path / "e.h5", "--scenario", str(wide)) == 1
    line = _one_line(capsys)
    assert "area.side_m is 250.0, the policy was trained with 100.0" in line, line


def test_folders_missing_files_and_out_folders_are_refused_in_one_line(run, tmp_path, capsys):
    assert main(["inspect", str(run.parent)]) == 1
    assert _one_line(capsys).startswith(f"{run.parent}: is a directory, not a run file")
    assert main(["eval", "--checkpoint", str(tmp_path)]) == 1
    assert _one_line(capsys).startswith(f"{tmp_path}: is a directory, not a run file")
    assert main(["eval", "--checkpoint", str(tmp_path / "gone" / "r.h5")]) == 1
    assert _one_line(capsys) == f"{tmp_path / 'gone' / 'r.h5'}: no such run file"
    assert _eval(run, tmp_path / "no" / "e.h5") == 1
    assert _one_line(capsys) == (f"{tmp_path / 'no' / 'e.h5'}: the folder {tmp_path / 'no'} "
                                 "does not exist; create it or choose another --out")


# --- progress -------------------------------------------------------------------------------


def test_train_logs_progress_where_stderr_is_no_terminal(tmp_path, capsys):
    """Under nohup or CI `train` printed nothing until its final table."""
    out = tmp_path / "r.h5"
    assert main(["train", str(tiny_scenario(tmp_path)), "--seeds", "0", "--episodes", "3",
                 "--steps", "5", "--workers", "1", "--out", str(out)]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if "seed 0: episode" in line]
    assert len(lines) >= 2                     # the first and the last episode at least
    assert re.match(STAMP + r"seed 0: episode 1/3, mean of the last 1: sum rate [\d.]+ "
                    r"[kMG]?bit/s, J [\d.]+, outage [\d.]+%, least [\d.]+ [kMG]?bit/s; "
                    r"eps [\d.]+, estimating time left$", lines[0])
    assert "episode 3/3, mean of the last 3" in lines[-1] and "left" not in lines[-1]
    assert re.search(r"eps [\d.]+, [\d.]+ m?s/episode$", lines[-1])  # episodes 2 and 3


def test_plain_training_log_is_periodic_not_per_episode():
    buffer = io.StringIO()
    metrics = {"sum_rate_bps": 4.1e10, "fairness": 0.5, "epsilon": 0.3}
    with TrainingProgress(RichReporter(Console(file=buffer)), log_every_s=3600) as view:
        view.add_seed(0, 0, 1000)
        view.add_seed(1, 0, 1000)
        for episode in range(1, 1001):
            view.episode(0, episode, metrics)
            view.episode(1, episode, metrics)
    lines = buffer.getvalue().splitlines()
    assert [line.split(": episode ")[1].split(",")[0] for line in lines] == [
        "1/1000", "1/1000", "1000/1000", "1000/1000"]
    assert "mean of the last 100: sum rate 41.00 Gbit/s" in lines[-1]


def test_terminal_shows_rich_progress_and_no_log_lines():
    buffer = io.StringIO()
    console = Console(file=buffer, force_terminal=True, width=100)
    with TrainingProgress(RichReporter(console), log_every_s=0) as view:
        view.add_seed(0, 0, 2)
        view.episode(0, 1, {"sum_rate_bps": 1e9, "fairness": 0.5, "epsilon": 0.3})
    assert "seed   0" in buffer.getvalue() and ": episode 1/2" not in buffer.getvalue()


def test_oracle_search_reports_progress(run, tmp_path, capsys, monkeypatch):
    """eval with the oracle printed nothing while it searched (minutes on 100 layouts)."""
    monkeypatch.setattr(work_progress, "LOG_EVERY_S", 0.0)
    assert _eval(run, tmp_path / "e.h5", "--compare", "oracle", "--layouts", "3") == 0
    lines = capsys.readouterr().err.splitlines()
    oracle = [line for line in lines if " oracle: " in line]
    assert re.match(STAMP + "oracle: 3 layouts ...$", oracle[0])
    assert any(re.search(r"oracle: [12]/3 layouts, [\d.]+ m?s/layout, (about|under)", line)
               for line in oracle), oracle
    assert re.search(r"oracle: done in [\d.]+ s$", oracle[-1])
    assert any(" policy: 5 steps ..." in line for line in lines)


# --- summaries ------------------------------------------------------------------------------


def test_inspect_summary_units_counts_and_spread(run, capsys):
    assert main(["inspect", str(run)]) == 0
    out = capsys.readouterr().out
    assert "R_e^tot (last 2)" in out and "last 100" not in out   # only 2 episodes exist
    assert "1 seed " in out and "1 seeds" not in out
    assert re.search(r"[\d.]+ ± 0\.00 [kMG]?bit/s", out) and "± 0.0 bit/s" not in out
    assert "population standard deviation" in out
    assert main(["inspect", str(run), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["sum_rate_bps"]["std_ddof"] == 0


# --- the eval file --------------------------------------------------------------------------


def test_eval_file_records_what_was_evaluated_and_how(run, tmp_path, capsys):
    wide = tiny_scenario(tmp_path)
    out = tmp_path / "e.h5"
    assert _eval(run, out, "--scenario", str(wide), "--compare", "soa,oracle", "--json") == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["eval_file"] == str(out)
    with h5py.File(out, "r") as f:
        attrs = dict(f.attrs)
        assert attrs["checkpoint"] == str(run.resolve()) and Path(attrs["checkpoint"]).is_absolute()
        assert attrs["seed"] == 0 and attrs["checkpoint_episode"] == 2
        assert attrs["scenario_file"] == str(wide.resolve())
        assert tomllib.loads(f["scenario"][()].decode())["name"] == "tiny"
        for key in ("python_version", "numpy_version", "torch_version", "h5py_version",
                    "platform"):
            assert attrs[key] and attrs[key] != "not installed", key
        command = json.loads(attrs["command_line"])
        assert command[:2] == ["adaptsky", "eval"] and "--checkpoint" in command
        assert command[command.index("--compare") + 1] == "soa,oracle"
        assert 0 < attrs["wall_time_s"] < 60
        units: dict[str, str | None] = {}

        def collect(name: str, item: object) -> None:
            if isinstance(item, h5py.Dataset):
                units[name] = item.attrs.get("units")
        f.visititems(collect)
    assert None not in units.values(), [k for k, v in units.items() if v is None]
    assert units["methods/policy/mean_sum_rate_bps"] == "bit/s"
    assert units["methods/oracle/trajectory/uav_m"] == "m"
    assert units["methods/soa/min_user_se"] == "bit/s/Hz"
    assert units["methods/soa/fairness"] == "1" and units["results_json"] == "text"


# --- start-up time --------------------------------------------------------------------------


@pytest.mark.parametrize("argv", [["--help"], ["plugins", "list"],
                                  ["scenario", "validate", "scenarios/nyc_mmwave.toml"]])
def test_commands_start_without_importing_torch(argv):
    """Every command took 3-4.5 s to start: torch was imported up front."""
    code = ("import sys; from adaptsky_cli.cli.main import main; "
            f"code = main({argv!r}); "
            "assert 'torch' not in sys.modules, 'torch imported'; sys.exit(code)")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, check=False)
    assert done.returncode == 0, done.stderr
