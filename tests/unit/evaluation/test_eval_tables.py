"""Tables to take away: each user's steady-state rate per method (``eval``, ``inspect EVAL.h5``:
table and JSON), each seed's last-episode rate per user (``inspect RUN.h5``), and ``--csv``,
every method's per-layout numbers. The numbers are checked against the arrays of the files,
computed here with numpy; bad options are one line and exit code 1, before any work."""

from __future__ import annotations

import csv
import json
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.store.eval_file import group_name
from adaptsky_cli.cli.main import main
from tests.helpers.cli import one_line

STEPS = 130  # more than the steady state's 100 steps: the first 30 are left out
METRICS = ("mean_sum_rate_bps", "steady_sum_rate_bps", "fairness", "min_user_se",
           "satisfied_share", "steady_satisfied_share", "outage_share", "mean_least_rate_bps",
           "p5_rate_bps")


@pytest.fixture(scope="module")
def evaluated(tiny_run: Path, tmp_path_factory: pytest.TempPathFactory):
    """``eval`` of the tiny run on 2 layouts against SoA and random, with ``--csv`` and
    ``--json``: the eval file, the CSV and the printed results."""
    folder = tmp_path_factory.mktemp("tables")
    out, table = folder / "e.h5", folder / "e.csv"
    code = main(["eval", str(tiny_run), "--layouts", "2", "--steps", str(STEPS), "--compare",
                 "soa,random", "--out", str(out), "--csv", str(table), "--json"])
    assert code == 0
    return out, table


def steady_user_rates(eval_file: Path) -> dict[str, np.ndarray]:
    """Method -> (L, N): each user's mean rate over the last 100 steps, from the trajectory."""
    with h5py.File(eval_file, "r") as file:
        return {str(group.attrs["label"]): group["trajectory/rate_bps"][()][-100:].mean(axis=0)
                for group in file["methods"].values()}


def stored_metrics(eval_file: Path) -> dict[str, dict[str, np.ndarray]]:
    with h5py.File(eval_file, "r") as file:
        return {str(g.attrs["label"]): {m: g[m][()] for m in METRICS}
                for g in file["methods"].values()}


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))



def test_eval_json_and_file_hold_each_users_steady_rate(evaluated, capsys):
    eval_file, _ = evaluated
    expected = steady_user_rates(eval_file)
    assert set(expected) == {"policy", "soa", "random"}
    with h5py.File(eval_file, "r") as file:
        results = json.loads(file["results_json"][()])
        for label, rates in expected.items():
            dataset = file[f"methods/{group_name(label)}/steady_user_rate_bps"]
            assert dataset.shape == (2, 4) and dataset.attrs["units"] == "bit/s"
            np.testing.assert_allclose(dataset[()], rates, rtol=1e-12)
            np.testing.assert_allclose(
                results["methods"][label]["layouts"]["steady_user_rate_bps"], rates, rtol=1e-12)
    assert main(["inspect", str(eval_file), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    for label, rates in expected.items():
        np.testing.assert_allclose(shown["methods"][label]["layouts"]["steady_user_rate_bps"],
                                   rates, rtol=1e-12)


def table_rows(text: str, title: str) -> list[list[str]]:
    """The data rows (user, numbers...) of the Rich table under ``title`` in ``text``."""
    block = text[text.index(title):]
    rows = []
    for line in block.splitlines()[1:]:
        cells = line.split()
        if cells and re.fullmatch(r"\d+", cells[0]):
            rows.append(cells)
        elif rows:
            break
    return rows


@pytest.mark.parametrize("layout", [0, 1])
def test_inspect_prints_one_layouts_users(evaluated, capsys, layout):
    eval_file, _ = evaluated
    expected = steady_user_rates(eval_file)
    args = ["inspect", str(eval_file)] + (["--layout", str(layout)] if layout else [])
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "method" in text  # the comparison table comes first, as eval printed it
    rows = table_rows(text, f"per-user rate, layout {layout} (Gbit/s)")
    assert len(rows) == 4  # one row per user, not per layout and user
    header = text[text.index(f"per-user rate, layout {layout}"):].splitlines()[2].split()
    assert header == ["user", "policy", "soa", "random"]
    for user, row in enumerate(rows):
        assert row == [str(user), *(f"{expected[m][layout, user] / 1e9:.2f}"
                                    for m in ("policy", "soa", "random"))]
    assert "another layout: --layout 0..1; all: --csv FILE" in " ".join(text.split())


def test_csv_holds_every_method_and_layout(evaluated):
    eval_file, table = evaluated
    rows = read_csv(table)
    users = [f"steady_rate_bps_user_{i}" for i in range(4)]
    assert list(rows[0]) == ["method", "layout", *METRICS, *users]  # no reference compared
    assert [(r["method"], r["layout"]) for r in rows] == [
        (m, str(layout)) for m in ("policy", "soa", "random") for layout in (0, 1)]
    metrics, rates = stored_metrics(eval_file), steady_user_rates(eval_file)
    for row in rows:
        method, layout = row["method"], int(row["layout"])
        for name in METRICS:
            assert float(row[name]) == metrics[method][name][layout]  # every digit
        np.testing.assert_allclose([float(row[u]) for u in users], rates[method][layout],
                                   rtol=1e-12)


def test_inspect_csv_is_evals_csv(evaluated, tmp_path, capsys):
    eval_file, table = evaluated
    again = tmp_path / "again.CSV"
    assert main(["inspect", str(eval_file), "--csv", str(again)]) == 0
    assert again.read_bytes() == table.read_bytes()
    assert capsys.readouterr().err.strip() == f"CSV: {again}"


def test_percent_of_the_oracle_per_method_and_layout(tiny_run, tmp_path, capsys):
    out, table = tmp_path / "o.h5", tmp_path / "o.csv"
    assert main(["eval", str(tiny_run), "--steps", "101", "--compare", "oracle,soa",
                 "--out", str(out), "--csv", str(table), "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert results["csv_file"] == str(table) and results["eval_file"] == str(out)
    rows = {r["method"]: r for r in read_csv(table)}
    metrics = stored_metrics(out)
    oracle = metrics["oracle"]["mean_sum_rate_bps"][0]
    for method in ("policy", "oracle", "soa"):
        pct = float(rows[method]["steady_pct_of_oracle"])
        assert pct == pytest.approx(100 * metrics[method]["steady_sum_rate_bps"][0] / oracle,
                                    rel=1e-12)
    assert float(rows["policy"]["steady_pct_of_oracle"]) == \
        results["policy_steady_pct_of_oracle"]["layouts"][0]
    assert float(rows["oracle"]["steady_pct_of_oracle"]) == pytest.approx(100.0)


def test_inspect_run_shows_each_seeds_last_episode_per_user(tiny_run, capsys):
    with h5py.File(tiny_run, "r") as file:
        expected = {seed: file[f"seeds/{seed}/episodes/mean_rate_bps"][
            file[f"seeds/{seed}"].attrs["episodes_done"] - 1] for seed in (0, 1)}
    assert main(["inspect", str(tiny_run), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    for seed in summary["seeds"]:
        np.testing.assert_array_equal(seed["last_episode_user_rate_bps"],
                                      expected[seed["seed"]])
    assert main(["inspect", str(tiny_run)]) == 0
    text = capsys.readouterr().out
    assert "seed 0 (ep. 2)" in text and "seed 1 (ep. 2)" in text
    rows = table_rows(text, "per-user rate, last episode (Gbit/s)")
    assert rows == [[str(u), f"{expected[0][u] / 1e9:.2f}", f"{expected[1][u] / 1e9:.2f}"]
                    for u in range(4)]


def test_eval_files_written_before_user_rates_show_them(evaluated, tmp_path, capsys):
    eval_file, _ = evaluated
    old = Path(shutil.copyfile(eval_file, tmp_path / "old.h5"))
    with h5py.File(old, "a") as file:  # as eval wrote it before steady_user_rate_bps existed
        results = json.loads(file["results_json"][()])
        for label, entry in results["methods"].items():
            del entry["layouts"]["steady_user_rate_bps"]
            del file[f"methods/{group_name(label)}/steady_user_rate_bps"]
        del file["results_json"]
        file.create_dataset("results_json", data=json.dumps(results), dtype=h5py.string_dtype())
    assert main(["inspect", str(old), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    for label, rates in steady_user_rates(eval_file).items():
        np.testing.assert_allclose(shown["methods"][label]["layouts"]["steady_user_rate_bps"],
                                   rates, rtol=1e-12)


def test_bad_tables_are_one_line_before_any_work(tiny_run, evaluated, tmp_path, capsys):
    eval_file, _ = evaluated
    out = tmp_path / "e.h5"
    evaluate = ["eval", str(tiny_run), "--steps", "5", "--out", str(out)]
    cases = [
        ([*evaluate, "--layouts", "2", "--layout", "2"],
         "--layout 2: the evaluation has layouts 0 to 1"),
        ([*evaluate, "--layout", "1"], "--layout 1: the evaluation has only layout 0"),
        ([*evaluate, "--csv", str(tmp_path / "table.h5")],
         f"--csv {tmp_path / 'table.h5'}: a CSV file must end in .csv (it has '.h5')"),
        ([*evaluate, "--csv", str(tmp_path / "no" / "t.csv")],
         f"--csv {tmp_path / 'no' / 't.csv'}: the folder {tmp_path / 'no'} does not exist; "
         "create it or choose another --csv"),
        (["inspect", str(eval_file), "--layout", "5"],
         "--layout 5: the evaluation has layouts 0 to 1"),
        (["inspect", str(tiny_run), "--csv", str(tmp_path / "t.csv")],
         f"--csv {tmp_path / 't.csv'}: {tiny_run} is not an eval file; --csv applies to eval "
         "files (adaptsky eval writes them)"),
        (["inspect", str(tiny_run), "--layout", "0"],
         f"--layout 0: {tiny_run} is not an eval file; --layout applies to eval files "
         "(adaptsky eval writes them)"),
    ]
    for argv, line in cases:
        assert main(argv) == 1, argv
        assert one_line(capsys) == line
    # what the command line alone gets wrong is a usage error (exit 2, issue 52)
    usage = [([*evaluate, "--layout", "-1"],
              "adaptsky eval: --layout: input should be greater than or equal to 0; see "
              "'adaptsky eval --help'"),
             ([*evaluate, "--layout", "0", "--json"],
              "adaptsky eval: --layout 0: picks the layout of the per-user table, which --json "
              "does not print (its steady_user_rate_bps holds every layout); leave out one of "
              "them; see 'adaptsky eval --help'")]
    for argv, line in usage:
        assert main(argv) == 2, argv
        assert one_line(capsys) == line
    assert list(tmp_path.iterdir()) == []  # no eval file, no CSV, no temporary copy
