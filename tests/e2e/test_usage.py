"""The command line as a new user meets it (issue 22): usage errors in one line with the fix,
every documented command answering a wrong flag, a missing argument and a misspelt key in one
line, help a person reads, one meaning of ``--seeds``, ``eval RUN.h5``, ``inspect EVAL.h5``,
``plot`` beside eval files, and ``eval`` on a full disk."""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest
import typer

from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import app, main
from adaptsky_cli.cli.options import parse_seeds
from tests.conftest import ROOT, SCENARIOS
from tests.helpers.cli import one_line

SCENARIO = str(SCENARIOS / "nyc_mmwave.toml")
DOC_PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


# ---- usage errors: one line, exit 2, the fix where it is obvious ---------------------------

@pytest.mark.parametrize(("argv", "expected"), [
    (["eval"], "adaptsky eval: missing argument RUN.h5"),
    (["train"], "adaptsky train: missing argument SCENARIO.toml (or --resume RUN.h5"),
    (["train", SCENARIO, "--set", "reward.min_se", "1"],
     "adaptsky train: unexpected argument '1'; did you mean --set reward.min_se=1?"),
    (["plugins", "check", "mmwave-nyc", "--param", "shadowing", "true"],
     "adaptsky plugins check: unexpected argument 'true'; did you mean --param "
     "shadowing=true?"),
    (["train", SCENARIO, "--episdoes", "3"],
     "adaptsky train: unknown option --episdoes; did you mean --episodes?"),
    (["trian"], "adaptsky: no such command 'trian'; did you mean 'train'?"),
    (["train", SCENARIO, "--episodes", "zero"], "adaptsky train: --episodes: "),
    (["plot", "x.h5", "--band", "sem"], "adaptsky plot: --band: 'sem' is not one of"),
    (["train", SCENARIO, "--out"], "adaptsky train: option '--out' requires an argument"),
    (["scenario", "show"], "adaptsky scenario show: missing argument SCENARIO.toml"),
    (["--bogus"], "adaptsky: unknown option --bogus; see 'adaptsky --help'"),
])
def test_usage_errors_are_one_line_with_exit_2(argv, expected, capsys):
    # they were five-line Rich boxes ("Got unexpected extra argument(s) (1)" for --set)
    assert main(argv) == 2
    assert one_line(capsys).startswith(expected)


def test_an_unreadable_run_file_is_one_line(tiny_run_copy, capsys, monkeypatch):
    """A mode-000 run file (simulated: the tests may run as root): ``eval RUN.h5`` said six
    lines of usage box with exit 2."""
    real_open = os.open

    def refuse(name, *args, **kwargs):  # type: ignore[no-untyped-def]
        if Path(name) == tiny_run_copy:
            raise PermissionError(13, "Permission denied")
        return real_open(name, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    for argv in (["eval", str(tiny_run_copy)], ["inspect", str(tiny_run_copy)],
                 ["plot", str(tiny_run_copy)],
                 ["show", str(tiny_run_copy), "--out", str(tiny_run_copy.with_suffix(".png"))]):
        assert main(argv) == 1
        assert one_line(capsys) == (f"{tiny_run_copy}: cannot read run file (Permission "
                                    "denied); check its permissions")


# ---- every documented command: a wrong flag, a missing argument, a misspelt key ------------

def _leaves(command: object, path: tuple[str, ...] = ()) -> dict[tuple[str, ...], object]:
    children = getattr(command, "commands", None)
    if not children:
        return {path: command}
    found: dict[tuple[str, ...], object] = {}
    for name, child in children.items():
        found |= _leaves(child, (*path, name))
    return found


COMMANDS = _leaves(typer.main.get_command(app))
DOC_TEXT = "\n".join(page.read_text() for page in DOC_PAGES)
DOCUMENTED = sorted(path for path in COMMANDS
                    if re.search(rf"\badaptsky {' '.join(path)}\b", DOC_TEXT))


def _options(command: object) -> list[str]:
    return [max(param.opts, key=len) for param in command.params  # type: ignore[attr-defined]
            if param.param_type_name == "option"]


def _misspelt(option: str) -> str:
    """``--episodes`` -> ``--episodse``: the last two letters swapped."""
    return option[:-2] + option[-1] + option[-2]


def _bad_calls(path: tuple[str, ...]) -> dict[str, list[str]]:
    command = COMMANDS[path]
    params = command.params  # type: ignore[attr-defined]
    required = any(param.required for param in params)
    valued = [max(p.opts, key=len) for p in params
              if p.param_type_name == "option" and not getattr(p, "is_flag", False)]
    missing = ([*path] if required or not valued else [*path, valued[0]])
    if not required and not valued:
        missing = [*path, "--json", "extra-argument"]  # nothing can be missing: one too many
    option = max([*_options(command), "--help"], key=len)
    calls = {"wrong flag": [*path, "--no-such-flag"], "missing argument": missing,
             "misspelt option": [*path, _misspelt(option)]}
    # (eval's --set needs a run file: tests/unit/evaluation/test_moving_users_and_sampled_los.py)
    if "--set" in _options(command) and path != ("eval",):
        target = "e1a" if path == ("reproduce",) else SCENARIO
        more = {("reproduce",): ["--report-only"], ("baseline",): ["--method", "soa"],
                ("tune",): ["--space", str(ROOT / "docs" / "spaces" / "ppo.toml"),
                            "--trials", "1"]}
        calls["misspelt key"] = [*path, target, "--set", "rewrd.min_se=1", *more.get(path, [])]
    return calls


def test_the_documented_commands_are_found():
    assert {("train",), ("eval",), ("inspect",), ("plot",), ("show",), ("reproduce",),
            ("baseline",), ("scenario", "validate"), ("plugins", "list")} <= set(DOCUMENTED)


@pytest.mark.parametrize("path", DOCUMENTED, ids=" ".join)
def test_every_documented_command_answers_mistakes_in_one_line(path, tmp_path, capsys,
                                                               monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing a mistake might write lands in the checkout
    for what, argv in _bad_calls(path).items():
        code = main(argv)
        line = one_line(capsys)
        assert code in (1, 2), (what, argv, line)
        assert line, (what, argv)
        if what == "misspelt option":
            assert "did you mean --" in line, (argv, line)
        if what == "misspelt key":
            assert "rewrd" in line, (argv, line)


# ---- help a person reads ----------------------------------------------------------------

INTERNAL = re.compile(r"<bool>|<list\[|<path>|<str>|<int|\{[a-z_]+\}|--no-[a-z]")


@pytest.mark.parametrize("path", [(), *sorted(COMMANDS), ("scenario",), ("plugins",)],
                         ids=lambda path: " ".join(path) or "adaptsky")
def test_help_shows_metavars_not_type_names(path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    assert main([*path, "--help"]) == 0
    text = capsys.readouterr().out
    assert not INTERNAL.findall(text), INTERNAL.findall(text)


def test_command_summaries_are_one_line_each(capsys, monkeypatch):
    # train's summary broke after "its" in the middle of a sentence; the top-level summaries
    # fit 100 columns, the others at least break no line of their own
    for path, columns in (((), "100"), (("scenario",), "200"), (("plugins",), "200")):
        monkeypatch.setenv("COLUMNS", columns)
        assert main([*path, "--help"]) == 0
        panel = capsys.readouterr().out.split("Commands")[1]
        rows = [line for line in panel.splitlines() if line.startswith("│")]
        continued = [row for row in rows if row[1:3] == "  "]  # no command name: a 2nd line
        assert rows and not continued, rows
    assert main(["train", "--help"]) == 0
    assert re.search(r"--seeds\s+SEEDS", capsys.readouterr().out)


# ---- --seeds: a list or range everywhere; --runs counts runs ------------------------------

@pytest.mark.parametrize(("text", "seeds"), [
    ("0,1,2", [0, 1, 2]), ("0-5", [0, 1, 2, 3, 4, 5]), ("0-2,7", [0, 1, 2, 7]), ("3", [3]),
    ("5-5", [5])])
def test_seeds_are_lists_and_ranges(text, seeds):
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize(("text", "message"), [
    ("0,x", "is not a list of seeds"), ("3-1", "ends before it starts"),
    ("0-2,1", "1 given more than once"), ("", "is not a list of seeds"),
    ("0-5000", "more than 1000 seeds"), ("-1", "is not a list of seeds")])
def test_bad_seeds_are_usage_errors(text, message, capsys):
    # they exited 1 while --episodes 0 exited 2 (issue 52): a bad option value is a usage error
    for argv in (["train", SCENARIO, "--seeds", text], ["reproduce", "e1a", "--seeds", text]):
        assert main(argv) == 2
        line = one_line(capsys)
        assert line.startswith(f"adaptsky {argv[0]}: --seeds: ") and message in line


def test_seeds_may_be_repeated_or_comma_separated():
    assert parse_seeds(["0-2", "7"]) == parse_seeds(["0-2,7"]) == parse_seeds("0-2,7") == [
        0, 1, 2, 7]
    assert parse_seeds([]) is None and parse_seeds(None) is None


# ---- one rule for every option's value: malformed, out of range, conflicting: exit 2 ------

RUN = "missing-run.h5"  # never read: the parser refuses first
BAD_VALUES = [
    (["train", SCENARIO, "--seeds", "0-"], "--seeds: '0-' is not a list of seeds"),
    (["train", SCENARIO, "--episodes", "0"], "--episodes: input should be greater than"),
    (["train", SCENARIO, "--steps", "-3"], "--steps: input should be greater than"),
    (["train", SCENARIO, "--workers", "0"], "--workers: input should be greater than"),
    (["train", SCENARIO, "--log", "tensorboard,wandb"], "--log: unknown kind 'wandb'; "
     "choose from tensorboard, csv"),
    (["train", SCENARIO, "--device", "gpu"], "--device: 'gpu' is not a device"),
    (["train", SCENARIO, "--set", "reward.min_se"], "--set: 'reward.min_se' is not "
     "section.key=value"),
    (["train", "--resume", RUN, "--seeds", "1"], "--resume continues a run as it was"),
    (["eval", RUN, "--policy", "worst"], "--policy: unknown policy 'worst'; choose from "
     "best, last"),
    (["eval", RUN, "--seed", "-1"], "--seed: input should be greater than or equal to 0"),
    (["eval", RUN, "--layout", "0", "--json"], "--layout 0: picks the layout"),
    (["eval", RUN, "--set", "=1"], "--set: '=1' is not section.key=value"),
    (["baseline", SCENARIO, "--method", "best"], "--method: unknown method 'best'"),
    (["plot", RUN, "--metric", "sum-rate", "--metric", "power"],
     "--metric: unknown metric 'power'"),
    (["plot", RUN, "--profile", "first"], "--profile: unknown policy 'first'"),
    (["plot", RUN, "--profile", "last", "--metric", "fairness"], "--profile draws the"),
    (["show", RUN, "--policy", "worst", "--out", "f.png"], "--policy: unknown policy"),
    (["show", RUN], "nothing to write"),
    (["reproduce", "e1a", "--seeds", "3-1"], "--seeds: the range 3-1 ends before it starts"),
    (["reproduce", "e1a", "--format", "bmp"], "--format: 'bmp' is not a figure format"),
    (["reproduce", "e1a", "--runs-only", "--report-only"],
     "--runs-only and --report-only exclude each other"),
    (["tune", SCENARIO, "--space", "s.toml", "--trials", "1", "--study", "a b"],
     "--study: 'a b' is not a study name"),
    (["tune", SCENARIO, "--space", "s.toml", "--trials", "0"], "--trials: input should be"),
    (["plugins", "check", "mmwave-nyc", "--param", "shadowing"],
     "--param: 'shadowing' is not KEY=VALUE"),
    (["plugins", "check", "mmwave-nyc", "--carrier-hz", "5"], "--carrier-hz: "),
]


@pytest.mark.parametrize(("argv", "expected"), BAD_VALUES,
                         ids=[" ".join(argv[:1] + argv[2:]) for argv, _ in BAD_VALUES])
def test_every_bad_option_value_is_one_usage_line_with_exit_2(argv, expected, capsys,
                                                              tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing is written, wherever it would go
    assert main(argv) == 2
    line = one_line(capsys)
    command = "adaptsky " + " ".join(argv[:2] if argv[0] == "plugins" else argv[:1])
    assert line.startswith(f"{command}: {expected}"), line
    assert line.endswith(f"; see '{command} --help'")
    assert list(tmp_path.iterdir()) == []


def test_what_only_the_files_tell_stays_exit_1(capsys):
    # a seed the experiment does not plan: its file says so, not the command line
    assert main(["reproduce", "e1a", "--seeds", "12", "--out", "x"]) == 1
    assert one_line(capsys).endswith("--seeds: 12 not planned; the experiment's seeds are 0-9")


# ---- list options: comma-separated, repeated, or both --------------------------------------

def test_list_options_take_commas_and_repetition_alike(tmp_path):
    """``train --log tensorboard,csv`` was refused (issue 52); --seeds, --log, --compare and
    --metric take either form, and both mixed."""
    pytest.importorskip("tensorboard")
    runs = {}
    for name, options in (("commas", ["--seeds", "0,1", "--log", "tensorboard,csv"]),
                          ("repeated", ["--seeds", "0", "--seeds", "1", "--log", "tensorboard",
                                        "--log", "csv"])):
        runs[name] = tmp_path / f"{name}.h5"
        assert main(["train", SCENARIO, *options, "--episodes", "1", "--steps", "2",
                     "--workers", "1", "--out", str(runs[name]), "--quiet"]) == 0
        logs = tmp_path / f"{name}.logs"
        assert (logs / "scalars.csv").is_file(), name
        assert sorted(p.name for p in logs.glob("seed*")) == ["seed0", "seed1"], name
        with RunReader(runs[name]) as run:
            assert run.seeds == [0, 1]
    for form in (["--compare", "soa,random"], ["--compare", "soa", "--compare", "random"]):
        out = tmp_path / f"eval-{len(form)}.json"
        assert main(["eval", str(runs["commas"]), "--steps", "3", *form, "--json",
                     "--out", str(out.with_suffix(".h5"))]) == 0
    from adaptsky_cli.cli.values import set_value, split_list
    assert split_list(["soa", "oracle,random"]) == ["soa", "oracle", "random"]
    assert set_value(['agent={algorithm="ppo"}']) == ['agent={algorithm="ppo"}']  # a table
    assert split_list(["tensorboard, csv"]) == ["tensorboard", "csv"]


def test_train_takes_a_range_of_seeds(tmp_path):
    out = tmp_path / "range.h5"
    assert main(["train", SCENARIO, "--seeds", "1-2", "--episodes", "1", "--steps", "2",
                 "--workers", "1", "--out", str(out), "--quiet"]) == 0
    with RunReader(out) as run:
        assert run.seeds == [1, 2]


def _planned(folder: Path) -> set[int]:
    return {run["seed"] for run in json.loads((folder / "plan.json").read_text())["runs"]}


def test_reproduce_seeds_chooses_planned_seeds_and_runs_counts_them(tmp_path, capsys):
    # reproduce --seeds 0,1 failed ("Input should be a valid integer"); --seeds 2 meant two
    # runs per group
    assert main(["reproduce", "e1a", "--seeds", "0,1", "--report-only", "--quiet",
                 "--out", str(tmp_path / "seeds")]) == 0
    assert _planned(tmp_path / "seeds") == {0, 1}
    assert f"adaptsky reproduce e1a --out {tmp_path / 'seeds'} --seeds 0,1`" in (
        tmp_path / "seeds" / "report.md").read_text()  # the report's command repeats them
    assert main(["reproduce", "e1a", "--seeds", "3", "--report-only", "--quiet",
                 "--out", str(tmp_path / "three")]) == 0
    assert _planned(tmp_path / "three") == {3}
    assert main(["reproduce", "e1a", "--runs", "2", "--report-only", "--quiet",
                 "--out", str(tmp_path / "runs")]) == 0
    assert _planned(tmp_path / "runs") == {0, 1}
    assert "--runs 2`" in (tmp_path / "runs" / "report.md").read_text()
    capsys.readouterr()
    assert main(["reproduce", "e1a", "--seeds", "1,12", "--out", str(tmp_path / "x")]) == 1
    assert one_line(capsys).endswith("--seeds: 12 not planned; the experiment's seeds are 0-9")
    assert main(["reproduce", "e1a", "--runs", "2", "--seeds", "4",
                 "--out", str(tmp_path / "x")]) == 1
    assert "seeds with --runs 2 are 0-1" in one_line(capsys)


# ---- eval RUN.h5, inspect EVAL.h5, plot beside eval files --------------------------------

@pytest.fixture
def eval_file(tiny_run_copy: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    """An eval file written by ``eval`` beside the run file."""
    out = tiny_run_copy.with_name("run-eval.h5")
    assert main(["eval", "--checkpoint", str(tiny_run_copy), "--steps", "5", "--out",
                 str(out)]) == 0
    capsys.readouterr()
    return out


def test_eval_takes_the_run_file_as_its_argument(tiny_run_copy, capsys):
    # as inspect RUN.h5 and plot RUN.h5 do; eval RUN.h5 said "Missing option '--checkpoint'"
    out = tiny_run_copy.with_name("positional.h5")
    assert main(["eval", str(tiny_run_copy), "--steps", "5", "--out", str(out), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["eval_file"] == str(out) and shown["checkpoint"] == str(tiny_run_copy.resolve())
    assert main(["eval", str(tiny_run_copy), "--checkpoint", str(tiny_run_copy)]) == 2
    assert "the run file is given twice" in one_line(capsys)


def test_inspect_summarises_an_eval_file(tiny_run_copy, eval_file, capsys):
    # inspect EVAL.h5 said "not an adaptsky run file"
    assert main(["inspect", str(eval_file)]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"{eval_file}: eval file of seed 0 of {tiny_run_copy.resolve()}")
    assert "policy: seed 0" in text and "soa" in text and "random" in text
    assert main(["inspect", str(eval_file), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert set(shown["methods"]) == {"policy", "soa", "random"}
    assert shown["header"]["adaptsky_version"]


def test_plot_skips_eval_files_with_a_note(tiny_run_copy, eval_file, tmp_path, capsys):
    # plot runs/*.h5 failed on the eval file beside the run and drew nothing
    figure = tmp_path / "curves.png"
    assert main(["plot", str(tiny_run_copy), str(eval_file), "--out", str(figure)]) == 0
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"{eval_file}: an eval file, not a run file: skipped (adaptsky inspect "
                     f"{eval_file} shows it)", f"figure: {figure}"]
    assert figure.is_file()
    assert main(["plot", str(eval_file)]) == 1
    assert one_line(capsys) == (f"no run file to plot: {eval_file} is an eval file; give the "
                                "run files (RUN.h5) that eval read")


def test_eval_on_a_full_disk_is_one_line(tiny_run_copy, tmp_path, capsys, monkeypatch):
    # it printed the rollouts' progress, then the error: five lines
    out = tmp_path / "full" / "e.h5"
    out.parent.mkdir()
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage",
                        lambda path: usage._replace(free=0))  # the disk is full
    assert main(["eval", "--checkpoint", str(tiny_run_copy), "--steps", "5", "--out",
                 str(out)]) == 1
    assert one_line(capsys) == (f"{out}: cannot write it (No space left on device); free space "
                                "on its disk or write elsewhere")
    assert os.listdir(out.parent) == []
