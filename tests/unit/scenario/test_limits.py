"""Scenario limits (issue 13): every numeric field pushed to huge, tiny, negative, wrong-typed
and non-finite values is refused in one line or trains to finite numbers; sizes no machine
holds are refused with needed vs available; unreadable files and unsafe names are one line;
a non-finite step stops the run and leaves the last checkpoint."""

from __future__ import annotations

import copy
import math
import os
import tomllib
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from adaptsky.channels.registry import get_model_class
from adaptsky.errors import NonFiniteError, ResourceError, ScenarioError
from adaptsky.experiment.plan import load_experiment
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.models import max_users
from adaptsky.scenario.toml_writer import dumps
from adaptsky.training.resources import check_fits, estimate, format_bytes
from adaptsky.training.stack_run import Member, StackRun
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

MMWAVE = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
ODD_VALUES: dict[str, Any] = {"huge": 1e308, "huge_int": 2**62, "tiny": 1e-300, "negative": -1e3,
                              "text": "12", "nan": math.nan, "inf": math.inf, "zero": 0}


def numeric_fields(data: Any, path: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    """Paths of every number in the resolved scenario (a list's first entry stands for all)."""
    if isinstance(data, dict):
        return [p for key, value in data.items() for p in numeric_fields(value, (*path, key))]
    if isinstance(data, list):
        return numeric_fields(data[0], (*path, 0)) if data else []
    return [path] if isinstance(data, int | float) and not isinstance(data, bool) else []


FIELDS = numeric_fields(MMWAVE)


def with_value(path: tuple[str | int, ...], value: Any) -> dict[str, Any]:
    data = copy.deepcopy(MMWAVE)
    table = data
    for part in path[:-1]:
        table = table[part]
    table[path[-1]] = value
    return data


def validate(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    """``scenario validate path``: the exit code and the error lines (not the plausibility
    warnings of issue 35, item 7: an extreme value may well warn)."""
    code = main(["scenario", "validate", str(path)])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, [line for line in captured.err.strip().splitlines()
                  if not line.startswith("adaptsky: warning: ")]


def train_5_steps(path: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> int:
    code = main(["train", str(path), "--episodes", "1", "--steps", "5", "--out", str(out),
                 "--quiet"])
    assert "Traceback" not in capsys.readouterr().err
    return code


def stored_numbers(run: Path) -> dict[str, np.ndarray]:
    """Every reward, rate and gain a run file holds, and its episodes table."""
    with h5py.File(run, "r") as file:
        seed = file["seeds"][next(iter(file["seeds"]))]
        numbers = {f"trajectory/{name}": seed["trajectory"][name][()]
                   for name in ("reward", "rate_bps", "gain")}
        numbers |= {f"episodes/{name}": seed["episodes"][name][()]
                    for name in ("reward", "sum_rate_bps", "fairness", "mean_rate_bps", "loss")}
    return numbers


def test_the_corpus_covers_every_kind_of_number():
    assert len(FIELDS) >= 40
    assert ("radio", "tx_power_dbm") in FIELDS and ("agent", "hidden_sizes", 0) in FIELDS
    assert ("channel", "params", "intercept_los_db") in FIELDS


@pytest.mark.parametrize("path", FIELDS, ids=lambda path: ".".join(map(str, path)))
def test_every_odd_value_is_refused_in_one_line_or_in_range(path, tmp_path, capsys):
    """Before the limits, 1e308 in tx_power_dbm, 2**62 in memory_size and the like passed
    validate, then train ended in a traceback or wrote NaN and inf."""
    files = {}
    for label, value in ODD_VALUES.items():
        files[label] = tmp_path / f"{label}.toml"
        files[label].write_text(dumps(with_value(path, value)))
    code = main(["scenario", "validate", *map(str, files.values())])
    captured = capsys.readouterr()
    assert code in (0, 1) and "Traceback" not in captured.err
    # plausibility warnings of accepted values (issue 35, item 7) are not refusals
    errors = [line for line in captured.err.strip().splitlines()
              if not line.startswith("adaptsky: warning: ")]
    accepted = []
    for label, file in files.items():
        mine = [line for line in errors if line.startswith(f"{file}: ")]
        ok = f"ok  {file}  " in captured.out
        assert len(mine) + ok == 1, (label, mine)  # one line: refused, or ok
        if ok:
            accepted.append(label)
    assert len(errors) == len(files) - len(accepted)
    # non-finite, text and out-of-range values never pass; tiny or zero ones may
    assert not {"nan", "inf", "text"} & set(accepted), accepted
    if path not in (("users", "layout_seed"), ("train", "seeds", 0),
                    ("train", "eval_layout_seed"), ("world", "seed")):  # any int64 seed
        assert not {"huge", "huge_int"} & set(accepted), accepted


@pytest.mark.parametrize(("changes", "why"), [
    ({"radio": {"bandwidth_hz": 1e-300}, "channel": {"params": {"exponent_los": 1e-300}}},
     "tiny bandwidth and exponent"),
    ({"radio": {"tx_power_dbm": 80.0, "thermal_noise_dbm": -200.0, "antennas_uav": 4096,
                "antennas_ue": 4096},
      "channel": {"params": {"intercept_los_db": 0.0}},
      "uav": {"min_height_m": 1.0, "start_m": [4.0, 15.0, 1.0]},
      "reward": {"w_rate": 1e6, "w_gain": 1e12, "w_fairness": 1e6},
      "agent": {"batch_size": 2, "memory_size": 2, "lr": 1.0, "gamma": 1.0}},
     "largest SNR (UAV 1 m above a user), weights and learning rate, with updates"),
    ({"channel": {"los": "sampled", "params": {"intercept_los_db": -200.0,
                                                "intercept_nlos_db": -200.0,
                                                "exponent_los": 10.0, "exponent_nlos": 10.0,
                                                "los_c": 100.0, "los_y": 2.0}},
      "area": {"side_m": 100000.0}, "reward": {"min_se": 100.0, "w_unsatisfied": 1e6},
      "agent": {"observation": "raw", "batch_size": 1, "epsilon_decay_steps": 1e-300}},
     "smallest gains over the largest area, raw observations"),
    ({"train": {"seeds": [2**62]}, "users": {"positions_m": None, "count": 16,
                                            "layout_seed": 2**62, "speed_m_per_step": 1000.0}},
     "huge seeds, fast users"),
])
def test_accepted_extremes_train_to_finite_numbers(changes, why, tmp_path, capsys):
    data = copy.deepcopy(MMWAVE)
    for section, values in changes.items():
        for key, value in values.items():
            if isinstance(value, dict):
                data[section][key] |= value
            else:
                data[section][key] = value
    data["users"] = {k: v for k, v in data["users"].items() if v is not None}
    if "count" in changes.get("users", {}):
        data["users"].pop("placement"), data["users"].pop("pairing")
    file = tmp_path / "extreme.toml"
    file.write_text(dumps(data))
    assert validate(file, capsys) == (0, []), why
    run = tmp_path / "run.h5"
    assert train_5_steps(file, run, capsys) == 0, why
    numbers = stored_numbers(run)
    if data["agent"]["batch_size"] > 4:  # no update in 5 steps: the loss is NaN by design
        del numbers["episodes/loss"]
    for name, values in numbers.items():
        assert values.size and np.isfinite(values).all(), (why, name)


# ---- sizes no machine holds -------------------------------------------------------------

@pytest.mark.parametrize(("changes", "largest"), [
    ({"agent": {"memory_size": 2**40}}, "replay"),
    ({"users": {"count": 40}}, "dueling head"),
    ({"agent": {"hidden_sizes": [1_000_000_000]}}, "networks and optimizer"),
    ({"train": {"steps": 10**9}}, "trajectories"),
])
def test_validate_refuses_what_this_machine_cannot_hold(changes, largest, tmp_path, capsys):
    """These passed validate and ended train in a MemoryError or an overflow."""
    file = tmp_path / "big.toml"
    file.write_text(dumps({"name": "big", **changes}))
    code, lines = validate(file, capsys)
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith(f"{file}: needs about ")
    assert f"({largest} " in lines[0] and "this machine has " in lines[0]


def test_the_estimate_has_no_overflow_and_names_needed_and_available():
    scenario = parse_scenario({"name": "x", "agent": {"memory_size": 2**53}})
    needed = estimate(scenario)
    assert needed.parts["replay"] == pytest.approx(2 * 2**53 * (2 * 17 + 3) * 4)
    with pytest.raises(ResourceError) as error:
        check_fits(scenario, "f.toml", available=21 * 10**9)
    (line,) = error.value.lines
    assert line.startswith("f.toml: needs about 2.7 EB of memory (replay 2.7 EB)")
    assert "this machine has 21.0 GB available; lower agent.memory_size" in line
    small = parse_scenario({"name": "x"})
    assert check_fits(small, "f", available=10**12).total < 10**9  # the paper's set-up: < 1 GB
    assert [format_bytes(n) for n in (7, 2.3e12, 1e30, math.inf)] == [
        "7 B", "2.3 TB", "1.0e+06 YB", "more than 1e300 B"]


@pytest.mark.parametrize("count", [1000, 2**62])
def test_users_beyond_the_dense_action_space_name_the_limit(count, tmp_path, capsys):
    file = tmp_path / "users.toml"
    file.write_text(dumps({"name": "u", "users": {"count": count}}))
    code, lines = validate(file, capsys)
    assert code == 1 and len(lines) == 1
    assert f"{file}: users: {count} users give 2^{3 + count // 2} actions" in lines[0]
    assert "at most 42 users with uav.actions = 'paper' (24 with 'with-hover')" in lines[0]
    assert (max_users("paper"), max_users("with-hover")) == (42, 24)


def test_a_branching_agent_takes_dense_action_sets_up_to_an_int64_index(tmp_path, capsys):
    """The DQN's float32 replay index caps the dense set at 2^24 (no users at all for eight
    UAVs); the BDQ stores a sub-action per branch, so only the environment's int64 index
    caps it, at 2^62."""
    users = {"count": 64, "placement": "uniform"}
    eight = {"name": "e", "area": {"side_m": 400.0}, "users": users, "uav": {"count": 8}}
    assert parse_scenario({**eight, "agent": {"algorithm": "bdq"}}, "e").uav.count == 8
    assert (max_users("paper", 8), max_users("paper", 8, 2**62)) == (0, 76)
    file = tmp_path / "eight.toml"
    file.write_text(dumps(eight))
    code, lines = validate(file, capsys)
    assert code == 1 and len(lines) == 1
    assert lines[0] == (f"{file}: users: 64 users and 8 UAVs give 2^56 actions; the dense "
                        "action space holds at most 2^24, so at most 0 users with "
                        "uav.actions = 'paper' (0 with 'with-hover'); agent.algorithm = "
                        "'bdq' acts per component and allows 2^62")
    file.write_text(dumps({**eight, "users": {**users, "count": 80},
                           "agent": {"algorithm": "bdq"}}))
    code, lines = validate(file, capsys)
    assert code == 1 and len(lines) == 1
    assert lines[0] == (f"{file}: users: 80 users and 8 UAVs give 2^64 actions; an action "
                        "index of agent 'bdq' holds at most 2^62, so at most 76 users with "
                        "uav.actions = 'paper' (30 with 'with-hover')")


def test_memory_size_beyond_exact_sampling_and_float_layer_sizes_are_one_line(tmp_path, capsys):
    for text, message in (("[agent]\nmemory_size = 4611686018427387904", "agent.memory_size: "
                           "Input should be less than or equal to 9007199254740992"),
                          ("[agent]\nhidden_sizes = [1e9]", "agent.hidden_sizes.0: Input "
                           "should be a valid integer")):
        file = tmp_path / "size.toml"
        file.write_text(f'name = "s"\n{text}\n')
        code, lines = validate(file, capsys)
        assert code == 1 and len(lines) == 1 and lines[0].startswith(f"{file}: {message}")


# ---- files that are not TOML as expected ------------------------------------------------

def test_unreadable_files_are_one_line_with_the_file_name(tmp_path, capsys):
    nested = tmp_path / "nested.toml"
    nested.write_text('name = "n"\nx = ' + "[" * 500 + "]" * 500 + "\n")
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b'name = "\xff\xfe"\n')
    folder = tmp_path / "folder.toml"
    folder.mkdir()
    fifo = tmp_path / "fifo.toml"  # reading it blocked for ever; /dev/zero never ended
    os.mkfifo(fifo)
    huge = tmp_path / "huge.toml"
    huge.write_text("# " + "x" * (1 << 20) + "\nname = 'n'\n")
    run = tmp_path / "r.h5"
    for file, reason in ((nested, "nested too deeply"), (binary, "can't decode byte 0xff"),
                         (folder, "is a folder"), (fifo, "is not a regular file"),
                         (Path("/dev/zero"), "is not a regular file"),
                         (huge, "is too large (at most 1048576)")):
        for argv in (["scenario", "validate", str(file)], ["scenario", "show", str(file)],
                     ["train", str(file), "--out", str(run)]):
            assert main(argv) == 1
            captured = capsys.readouterr()
            lines = captured.err.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith(f"{file}: "), (argv, lines)
            assert reason in lines[0] and "Traceback" not in captured.err
    assert not run.exists()
    with pytest.raises(ScenarioError) as error:
        load_experiment(str(nested))
    assert error.value.lines == [f"{nested}: invalid TOML: nested too deeply for the parser; "
                                 "scenario and experiment files need a few levels"]


def test_a_nul_in_the_path_is_one_line(capsys):
    with pytest.raises(ScenarioError) as error:
        load_scenario("a\0b.toml")
    assert error.value.lines == ["a\\x00b.toml: cannot read scenario file: embedded null byte"]
    assert main(["scenario", "validate", "a\0b.toml"]) == 2  # Typer's usage error
    assert "Traceback" not in capsys.readouterr().err


# ---- names that become paths ------------------------------------------------------------

@pytest.mark.parametrize("name", ["../escape", "/abs/path", "a\0b", "x" * 300, ".hidden",
                                  "-option", "a b", ""])
def test_names_that_are_not_safe_file_names_are_refused(name, tmp_path, capsys):
    """'../escape' wrote the run outside runs/, '/abs/path' to that path; NUL and 300
    characters ended in tracebacks."""
    file = tmp_path / "named.toml"
    file.write_text(dumps({"name": name}))
    code, lines = validate(file, capsys)
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith(f"{file}: name: ")
    if name:
        assert "not a safe file name: use 1 to 64 letters or digits of any script" in lines[0]
    assert main(["train", str(file), "--episodes", "1", "--steps", "2", "--quiet"]) == 1
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_safe_names_pass():
    for name in ("nyc_mmwave", "E3.v2-run_1", "x" * 64):
        assert parse_scenario({"name": name}).name == name


def test_experiment_sweep_strings_become_safe_run_names(tmp_path):
    experiment = tmp_path / "e.toml"
    experiment.write_text(
        'id = "e"\ntitle = "t"\n[[groups]]\nname = "g"\nscenario = "s.toml"\nruns = 1\n'
        '[groups.sweep]\nkey = "description"\nvalues = ["../../x"]\n[evaluation]\n'
        'policy = "g"\n[figure]\nkind = "learning-curves"\n')
    with pytest.raises(ScenarioError, match=r"groups\.0\.sweep\.values: not a safe file name"):
        load_experiment(str(experiment))


# ---- scenario show writes TOML that reads back -------------------------------------------

def test_show_round_trips_a_description_with_control_characters(tmp_path, capsys):
    """The hand-written writer printed a raw control character: invalid TOML."""
    description = 'tab\there, unit\x1fsep, del\x7f, "quoted" \\ é 😀'
    file = tmp_path / "ctl.toml"
    file.write_text(dumps({"name": "ctl", "description": description}))
    assert main(["scenario", "show", str(file)]) == 0
    shown = tomllib.loads(capsys.readouterr().out)
    assert shown["description"] == description
    assert parse_scenario(shown, "shown") == load_scenario(file)
    assert dumps({"a b": {"c.d": 1}}) == '["a b"]\n"c.d" = 1\n'


# ---- a non-finite step stops the run, the last checkpoint stays ---------------------------

def test_a_non_finite_gain_stops_the_run_after_its_last_checkpoint(tmp_path, capsys,
                                                                   monkeypatch):
    """Before, inf gains were written into the run file and train exited 0."""
    model = get_model_class("mmwave-nyc")
    gain_los = model.gain_los
    calls = []

    def infinite_from_episode_3(self: Any, geometry: Any) -> np.ndarray:
        calls.append(1)  # 1 at construction, then 1 per reset and 1 per step (5 steps)
        gain = gain_los(self, geometry)
        if len(calls) > 1 + 2 * 6:
            gain = gain.copy()
            gain[..., 1] = np.inf
        return gain

    monkeypatch.setattr(model, "gain_los", infinite_from_episode_3)
    run = tmp_path / "run.h5"
    code = main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--episodes", "4", "--steps",
                 "5", "--checkpoint-every", "2", "--out", str(run), "--quiet"])
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith("nyc_mmwave: seed 0, episode 3, step 1: gain of user 2 is inf; "
                               "it depends on channel.model, channel.params")
    assert lines[0].endswith("the run file keeps its last checkpoint")
    numbers = stored_numbers(run)
    del numbers["episodes/loss"]  # NaN: 10 steps, no update
    assert numbers["episodes/reward"].shape == (2,)  # the checkpoint after episode 2
    assert all(np.isfinite(values).all() for values in numbers.values())
    with h5py.File(run, "r") as file:
        assert int(file["seeds/0"].attrs["episodes_done"]) == 2


def test_a_non_finite_loss_names_the_agent_keys():
    """A diverged network (NaN weights) gave NaN losses that were stored silently."""
    scenario = parse_scenario({"name": "nan", "agent": {"batch_size": 2, "memory_size": 2},
                               "train": {"steps": 4, "seeds": [7]}})
    run = StackRun([Member(scenario, 7)])
    run.algorithm.agent.params.fill_(math.nan)
    with pytest.raises(NonFiniteError) as error:
        run.run_episode()
    assert str(error.value).startswith("nan: seed 7, episode 1: loss is nan; it depends on "
                                       "agent.lr, agent.gamma")
