"""``adaptsky tune``: a study of small trainings that ends with exactly its trials finished or
pruned, whether it runs through, is killed with kill -9 halfway and run again, or is shared by
two processes; the best trial as a scenario; a study refuses another search."""

from __future__ import annotations

import io
import re
import signal
import subprocess
import time
from pathlib import Path

import optuna
import pytest
from optuna.trial import TrialState

from adaptsky.progress import LogLines
from adaptsky.scenario import load_scenario
from adaptsky.store.run_file import RunReader
from adaptsky.tuning.api import _TrialLog, tune
from adaptsky.tuning.space import load_space
from adaptsky.tuning.study import StudyError, open_storage
from adaptsky.tuning.trial import TrialOutcome, objective_of
from adaptsky_cli.cli.main import main
from tests.helpers.cli import ADAPTSKY
from tests.helpers.training import small_scenario

SPACE = """
[space]
"agent.lr" = { low = 1e-4, high = 3e-3, log = true }
"agent.batch_size" = { choices = [16, 32] }
"agent.hidden_sizes" = { choices = [[16, 16], [32, 32]] }

[study]
startup_trials = 3
warmup_evaluations = 1
"""
# trials of 4 episodes of 40 steps, greedy evaluations every 2 episodes, one seed
FAST = ["--episodes", "4", "--steps", "40", "--set", "train.eval_every=2",
        "--set", "train.eval_steps=100", "--set", "train.seeds=[0]",
        "--set", "train.checkpoint_every=1"]


@pytest.fixture()
def files(tmp_path: Path) -> tuple[Path, Path]:
    scenario = small_scenario(tmp_path)
    space = tmp_path / "space.toml"
    space.write_text(SPACE)
    return scenario, space


def _study(folder: Path, name: str = "small") -> optuna.study.Study:
    # through tune's own opening: the test reads while the process under test may be making
    # the database's tables
    return optuna.load_study(study_name=name,
                             storage=open_storage(f"sqlite:///{folder / 'study.db'}"))


def _settled(study: optuna.study.Study) -> list[optuna.trial.FrozenTrial]:
    return study.get_trials(states=(TrialState.COMPLETE, TrialState.PRUNED))


def _sessions(path: Path) -> list[str]:
    with RunReader(path, needs="curves") as run:
        return [session["kind"] for session in run.sessions]


def _command(scenario: Path, space: Path, out: Path, trials: int) -> list[str]:
    return [str(ADAPTSKY), "tune", str(scenario), "--space", str(space), "--trials",
            str(trials), "--out", str(out), "--quiet", *FAST]


def test_a_study_runs_its_trials_and_writes_the_best_as_a_scenario(files, tmp_path):
    scenario, space = files
    out = tmp_path / "study"
    assert main(["tune", str(scenario), "--space", str(space), "--trials", "4",
                 "--out", str(out), "--quiet", *FAST]) == 0
    study = _study(out)
    settled = _settled(study)
    assert len(settled) == 4 and len(study.trials) == 4
    best = study.best_trial
    # the objective is the last greedy evaluation's score, read back from the trial's file
    assert best.value == pytest.approx(objective_of(out / f"trial-{best.number:04d}.h5",
                                                    "last"))
    written = load_scenario(out / "best.toml")  # a scenario that validates
    assert written.agent.lr == pytest.approx(best.params["agent.lr"])
    assert written.agent.batch_size == int(best.params["agent.batch_size"])
    assert list(written.agent.hidden_sizes) == eval(best.params["agent.hidden_sizes"])
    assert written.train.episodes == load_scenario(scenario).train.episodes  # not --episodes
    # the same command again: the study is complete, nothing runs
    assert main(["tune", str(scenario), "--space", str(space), "--trials", "4",
                 "--out", str(out), "--quiet", *FAST]) == 0
    assert len(_study(out).trials) == 4


def _checkpointed(path: Path) -> bool:
    try:
        with RunReader(path, needs="curves") as run:
            return run.has_checkpoint(0)
    except Exception:  # not written yet
        return False


def _wait_for(study_folder: Path, settled: int, process: subprocess.Popen,
              timeout_s: float = 240.0) -> None:
    """Until the study has ``settled`` trials finished or pruned and one running past its
    first checkpoint."""
    deadline = time.monotonic() + timeout_s
    while True:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline
        if (study_folder / "study.db").exists():
            try:
                study = _study(study_folder)
                running = study.get_trials(states=(TrialState.RUNNING,))
                if len(_settled(study)) >= settled and running and _checkpointed(
                        study_folder / f"trial-{running[0].number:04d}.h5"):
                    return
            except (KeyError, optuna.exceptions.StorageInternalError):
                pass  # not made yet
        time.sleep(0.1)


def _kill_halfway(study_folder: Path, settled: int, process: subprocess.Popen) -> None:
    """SIGKILL ``process`` while a trial runs past its first checkpoint, after ``settled``
    trials: the process is stopped (SIGSTOP) and the study read again before the kill, since
    a trial of a few episodes can end between a read and a kill."""
    while True:
        _wait_for(study_folder, settled, process)
        process.send_signal(signal.SIGSTOP)
        try:  # (stopped while it held the database's lock: let it go on and try again)
            running = _study(study_folder).get_trials(states=(TrialState.RUNNING,))
        except Exception:
            running = []
        if running and _checkpointed(study_folder / f"trial-{running[0].number:04d}.h5"):
            process.send_signal(signal.SIGKILL)
            return
        process.send_signal(signal.SIGCONT)


def test_kill_9_halfway_then_the_same_command_ends_with_every_trial_once(files, tmp_path):
    scenario, space = files
    out = tmp_path / "study"
    process = subprocess.Popen(_command(scenario, space, out, 8), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    _kill_halfway(out, 4, process)
    process.wait()
    killed = _study(out)
    running = [t.number for t in killed.get_trials(states=(TrialState.RUNNING,))]
    assert len(running) == 1
    done = subprocess.run(_command(scenario, space, out, 8), capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    study = _study(out)
    settled = _settled(study)
    assert len(settled) == 8 and len(study.trials) == 8       # none lost, none added
    assert sorted(t.number for t in settled) == list(range(8))
    # the killed trial was continued from its run file's last checkpoint, not trained again
    # from the start (a session is recorded when it ends: the killed one has none)
    with RunReader(out / f"trial-{running[0]:04d}.h5", needs="curves") as run:
        (continued,) = run.sessions
        assert run.seed_attrs(0)["episodes_done"] == 4
    assert continued["kind"] == "resume" and continued["episodes_before"]["0"] >= 1
    for t in settled:
        if t.number != running[0]:
            assert _sessions(out / f"trial-{t.number:04d}.h5") == ["train"]


def test_two_processes_on_one_study_run_distinct_trials(files, tmp_path):
    scenario, space = files
    out = tmp_path / "study"
    command = _command(scenario, space, out, 6)
    # the study made first: two processes creating one SQLite schema at once is not the test
    assert main([*command[1:4], command[4], "--trials", "1", *command[7:]]) == 0
    both = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True) for _ in range(2)]
    for process in both:
        _, stderr = process.communicate(timeout=600)
        assert process.returncode == 0, stderr
    study = _study(out)
    settled = _settled(study)
    assert len(settled) == 6
    counted = [t for t in study.trials if not t.user_attrs.get("surplus")]
    assert len(counted) == 6                      # a surplus trial never trains
    hosts = {t.user_attrs["host"] for t in settled[1:]}
    assert len(hosts) == 2                        # both processes ran trials
    for t in settled:                             # each trained once, by one process
        assert _sessions(out / f"trial-{t.number:04d}.h5") == ["train"]


def test_a_study_refuses_another_search(files, tmp_path, capsys):
    scenario, space = files
    out = tmp_path / "study"
    assert main(["tune", str(scenario), "--space", str(space), "--trials", "1",
                 "--out", str(out), "--quiet", *FAST]) == 0
    capsys.readouterr()
    other = tmp_path / "other.toml"
    other.write_text(SPACE.replace("3e-3", "1e-2"))
    assert main(["tune", str(scenario), "--space", str(other), "--trials", "2",
                 "--out", str(out), "--quiet", *FAST]) == 1
    line = capsys.readouterr().err.strip()
    assert "was made for another search" in line and "--study" in line


@pytest.mark.parametrize(("text", "expected"), [
    ('[space]\n"agent.lr" = { low = 3e-3, high = 1e-4 }', 'space."agent.lr": low (0.003) '
     "must be below high (0.0001)"),
    ('[space]\n"agent.lr" = { low = 0, high = 1e-3, log = true }', "log = true needs low > 0"),
    ('[space]\n"agent.lr" = { low = 1e-4 }', "needs low and high"),
    ('[space]\n"agent.lr" = { low = 1e-4, high = 1e-3, spread = 2 }', "unknown field 'spread'"),
    ('[space]\n"agent.batch_size" = { choices = [] }', "non-empty list"),
    ('[space]\n"agent.lrr" = { low = 1e-4, high = 1e-3 }', 'space."agent.lrr"'),
    ('[space]\n"agent.batch_size" = { choices = [16, -4] }', "-4 is not a valid value"),
    ('[space]\n"train.seeds" = { choices = [[0], [1]] }', "cannot be searched"),
    ('[space]\n"lr" = { low = 1e-4, high = 1e-3 }', "expected a scenario key"),
    ('[spaces]\n"agent.lr" = { low = 1e-4, high = 1e-3 }', "unknown table 'spaces'"),
    ('[space]\n"agent.lr" = { low = 1e-4, high = 1e-3 }\n[study]\npruner = "hyperband"',
     "study.pruner: 'hyperband' is not allowed; allowed: median, none"),
    ("[space", "not valid TOML"),
])
def test_a_bad_space_gets_one_line(files, tmp_path, capsys, text, expected):
    scenario, _ = files
    space = tmp_path / "bad.toml"
    space.write_text(text)
    assert main(["tune", str(scenario), "--space", str(space), "--trials", "2",
                 "--out", str(tmp_path / "study")]) == 1
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert lines[0].startswith(str(space)) and expected in lines[0], lines[0]
    assert not (tmp_path / "study").exists()  # nothing made before the space is checked


def test_tune_needs_greedy_evaluations(files, tmp_path, capsys):
    scenario, space = files
    assert main(["tune", str(scenario), "--space", str(space), "--trials", "2",
                 "--out", str(tmp_path / "study"), "--set", "train.eval_every=0"]) == 1
    line = capsys.readouterr().err.strip()
    assert "train.eval_every = 0" in line and "--set train.eval_every=" in line


def test_episodes_below_the_evaluation_period_set_it_and_say_so(files, tmp_path):
    """tune --episodes 2 with train.eval_every = 5 was refused (issue 52): the trials are
    evaluated at their end, one line says so, and best.toml keeps the scenario's period."""
    scenario, space = files
    out, said = tmp_path / "study", io.StringIO()
    outcome = tune(scenario_path=scenario, space_path=space, trials=1, out=out, episodes=2,
                   steps=10, set_values=["train.eval_every=5", "train.eval_steps=20",
                                         "train.seeds=[0]"],
                   progress=LogLines(said, quiet=True))
    assert [line.split(" ", 2)[2] for line in said.getvalue().splitlines()] == [
        "tune: train.eval_every = 5 is more than the 2 episodes of a trial: set to 2 (one "
        "greedy evaluation, at each trial's end; the pruner needs more: --set "
        "train.eval_every=N)"]
    assert outcome.counts.complete == 1
    with RunReader(out / "trial-0000.h5", needs="curves") as run:
        assert run.config["train"]["eval_every"] == 2
        assert run.evaluations(0)["episode"].tolist() == [2]
    assert load_scenario(out / "best.toml").train.eval_every == 5


def test_a_trial_says_its_episodes_as_it_trains(files, tmp_path):
    """A trial printed nothing from its start to its end (about 30 s, issue 52): in a log,
    a line at its first episode, then at most one every 30 s, with the time left."""
    scenario, space = files
    said = io.StringIO()
    tune(scenario_path=scenario, space_path=space, trials=1, out=tmp_path / "study",
         episodes=3, steps=10, set_values=["train.eval_every=3", "train.eval_steps=20",
                                           "train.seeds=[0]"], progress=LogLines(said))
    lines = [line.split(" ", 2)[2] for line in said.getvalue().splitlines()]  # no time stamp
    start = next(i for i, line in enumerate(lines) if line.startswith("trial 0 starts: "))
    assert lines[start + 1] == "trial 0: episode 1/3, estimating time left"
    assert lines[start + 2].startswith("trial 0: ") and "episode" not in lines[start + 2]


def test_the_trial_log_paces_its_episodes():
    said = io.StringIO()
    log = _TrialLog(LogLines(said), "process 1: ", log_every_s=0)
    log.event("start", {"number": 4, "params": {"agent.lr": 0.001}, "continued": False})
    for episode in (1, 2, 3, 4):
        log.event("episode", {"number": 4, "episode": episode, "episodes": 10})
    log.event("end", {"number": 4, "outcome": TrialOutcome("pruned", pruned_at=4)})
    lines = [line.split(" ", 2)[2] for line in said.getvalue().splitlines()]
    assert lines[:3] == ["process 1: trial 4 starts: agent.lr=0.001",
                         "process 1: trial 4: episode 1/10, estimating time left",
                         "process 1: trial 4: episode 2/10, estimating time left"]
    assert re.fullmatch(r"process 1: trial 4: episode 4/10, [0-9.]+ ms/episode, under 1 s "
                        r"left", lines[4]), lines[4]
    assert lines[5] == "process 1: trial 4: pruned at episode 4"
    quiet = io.StringIO()
    log = _TrialLog(LogLines(quiet), log_every_s=3600)
    for episode in (1, 2, 3):
        log.event("episode", {"number": 0, "episode": episode, "episodes": 3})
    assert len(quiet.getvalue().splitlines()) == 1  # the first, then none within the hour


def test_space_values_become_overrides(tmp_path):
    path = tmp_path / "space.toml"
    path.write_text(SPACE.replace("[study]", '"agent.target_update_episodes" = '
                                  "{ low = 1, high = 9, step = 2 }\n[study]"))
    space = load_space(path)
    assert space.overrides({"agent.lr": 0.00125, "agent.batch_size": "32",
                            "agent.hidden_sizes": "[32, 32]",
                            "agent.target_update_episodes": 5}) == [
        "agent.lr=0.00125", "agent.batch_size=32", "agent.hidden_sizes=[32, 32]",
        "agent.target_update_episodes=5"]
    distributions = space.distributions()
    assert distributions["agent.lr"].log and distributions["agent.lr"].low == 1e-4
    assert distributions["agent.hidden_sizes"].choices == ("[16, 16]", "[32, 32]")
    steps = distributions["agent.target_update_episodes"]
    assert (steps.low, steps.high, steps.step) == (1, 9, 2) and not steps.log


def test_the_shipped_ppo_space_fits_the_papers_scenario_with_ppo(tmp_path):
    from adaptsky.tuning.space import check_against

    root = Path(__file__).resolve().parents[3]
    space = load_space(root / "docs" / "spaces" / "ppo.toml")
    check_against(space, root / "docs" / "spaces" / "ppo.toml",
                  root / "scenarios" / "nyc_mmwave.toml", ['agent={algorithm="ppo"}'])
    assert [p.key for p in space.parameters][:2] == ["agent.lr", "agent.minibatches"]


def test_a_trial_killed_while_its_values_were_written_gets_the_missing_ones(tmp_path):
    """Optuna writes a new trial's values one by one: a process killed in between leaves a
    running trial with some of them; the process that continues it keeps those and draws the
    rest."""
    path = tmp_path / "space.toml"
    path.write_text(SPACE)
    space = load_space(path)
    study = optuna.create_study(direction="maximize")
    first = dict(list(space.distributions().items())[:1])  # agent.lr only
    partial = study.ask(first)
    kept = partial.params["agent.lr"]
    continued = optuna.trial.Trial(study, partial._trial_id)
    values = space.suggest(continued)
    assert values["agent.lr"] == kept
    assert set(values) == {"agent.lr", "agent.batch_size", "agent.hidden_sizes"}
    assert values["agent.hidden_sizes"] in ("[16, 16]", "[32, 32]")
    assert study.trials[0].params == values  # stored: the run file and the study agree


def test_opening_a_database_another_process_is_making_tries_again(tmp_path, monkeypatch):
    """Two processes opening a new SQLite study at once both create its tables; the loser's
    "already exists" is tried again, any other failure is one line."""
    made = optuna.storages.RDBStorage
    calls = []

    def racing(url, **kwargs):
        calls.append(url)
        if len(calls) == 1:
            raise RuntimeError("(sqlite3.OperationalError) table studies already exists")
        return made(url, **kwargs)

    monkeypatch.setattr("adaptsky.tuning.study.SCHEMA_WAIT_S", 0.0)
    monkeypatch.setattr(optuna.storages, "RDBStorage", racing)
    url = f"sqlite:///{tmp_path / 'study.db'}"
    assert isinstance(open_storage(url), made) and len(calls) == 2

    def broken(url, **kwargs):
        raise RuntimeError("no such driver\nmore")

    monkeypatch.setattr(optuna.storages, "RDBStorage", broken)
    with pytest.raises(StudyError, match=r"cannot open the study's storage: no such driver$"):
        open_storage(url)
