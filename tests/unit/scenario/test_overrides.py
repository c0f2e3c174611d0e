"""``--set section.key=value``: parsing, applying, validation like the file, the run file's
record."""

from __future__ import annotations

import json

import h5py
import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.loading import load_scenario_with_overrides, parse_toml
from adaptsky.scenario.models import Fading
from adaptsky.scenario.overrides import apply_overrides, overridden, override_notes, parse_value
from adaptsky.scenario.switches import FADING_KEYS
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS


@pytest.mark.parametrize(("text", "value"), [
    ("1.5", 1.5), ("3", 3), ("true", True), ("[0, 1]", [0, 1]), ('"x y"', "x y"),
    ("sampled", "sampled"), ("1e-4", 1e-4), ("mmwave-nyc", "mmwave-nyc")])
def test_values_are_toml_or_plain_strings(text, value):
    assert parse_value(text) == value


def test_overrides_apply_in_order_to_a_copy():
    data = {"reward": {"min_se": 0.0}, "name": "a"}
    result = apply_overrides(data, ["reward.min_se=1.5", "channel.params.carrier_hz=3e9",
                                    "reward.min_se=2"], "f.toml")
    assert result == {"reward": {"min_se": 2}, "name": "a",
                      "channel": {"params": {"carrier_hz": 3e9}}}
    assert data == {"reward": {"min_se": 0.0}, "name": "a"}


@pytest.mark.parametrize(("item", "message"), [
    ("noequals", "expected section.key=value"),
    ("name.x=1", "name is a value, not a table"),
    ("reward..min_se=1", "expected section.key=value")])
def test_malformed_overrides_are_one_line(item, message):
    with pytest.raises(ScenarioError) as error:
        apply_overrides({"name": "a"}, [item], "f.toml")
    assert len(error.value.lines) == 1 and message in error.value.lines[0]


def test_train_records_overrides_and_validates_them(tmp_path, capsys):
    out = tmp_path / "run.h5"
    code = main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--episodes", "1", "--steps",
                 "5", "--out", str(out), "--quiet", "--set", "reward.min_se=1.5",
                 "--set", "channel.los=sampled"])
    assert code == 0
    with h5py.File(out, "r") as file:
        assert json.loads(file["overrides"][()]) == ["reward.min_se=1.5", "channel.los=sampled"]
        config = json.loads(file["config"][()])
    assert config["reward"]["min_se"] == 1.5 and config["channel"]["los"] == "sampled"
    capsys.readouterr()
    assert main(["inspect", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["overrides"] == ["reward.min_se=1.5",
                                                                "channel.los=sampled"]
    for item, message in (("agent.lr=abc", "agent.lr: Input should be a valid number"),
                          ("agent.nope=1", "agent.nope: unknown key"),
                          ("reward.min_se=-1", "reward.min_se: Input should be greater")):
        code = main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--out",
                     str(tmp_path / "bad.h5"), "--set", item])
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 1 and len(lines) == 1, lines
        assert "nyc_mmwave.toml with --set: " + message in lines[0]
        assert not (tmp_path / "bad.h5").exists()


# issue 52, item 6: a --set that changes a model drops the keys the new one does not read

RICIAN = {"name": "f", "channel": {"los": "always", "fading": {
    "model": "rician", "k0_db": 0.0, "k90_db": 15.0, "correlation": 0.9}}}


def test_a_changed_model_drops_the_keys_it_does_not_read_and_says_which():
    result, notes = overridden(RICIAN, ["channel.fading.model=none"], "f.toml with --set")
    assert result["channel"] == {"los": "always", "fading": {"model": "none"}}
    assert RICIAN["channel"]["fading"]["k0_db"] == 0.0   # the input is left as it was
    assert notes == ["f.toml with --set: dropped channel.fading.k0_db, channel.fading.k90_db "
                     "and channel.fading.correlation: channel.fading.model = 'none' does not "
                     "read them ('rician' did)"]
    assert parse_scenario(result, "f").channel.fading.model == "none"
    rayleigh = parse_scenario(apply_overrides(RICIAN, ["channel.fading.model=rayleigh"], "f"),
                              "f").channel.fading
    assert (rayleigh.model, rayleigh.correlation, rayleigh.k0_db) == ("rayleigh", 0.9, None)


def test_the_documented_override_equals_the_whole_table():
    """``--set channel.fading.model=none`` is the scenario ``--set 'channel.fading={model=
    "none"}'`` gives (docs/evaluation.md), on every shipped fading scenario."""
    for name in ("moving_users_fading_sub6", "city_sub6", "city_two_uavs_mmwave"):
        path = SCENARIOS / f"{name}.toml"
        short, _ = load_scenario_with_overrides(path, ["channel.fading.model=none"])
        whole, _ = load_scenario_with_overrides(path, ['channel.fading={model="none"}'])
        assert short == whole and short.channel.fading.model == "none"
        assert load_scenario(path).channel.fading.model == "rician"


@pytest.mark.parametrize("items", [
    ["channel.fading.k0_db=3", "channel.fading.model=none"],
    ["channel.fading.model=none", "channel.fading.k0_db=3"]])
def test_a_key_typed_with_the_change_is_still_refused(items):
    result, notes = overridden(RICIAN, items, "f")
    assert result["channel"]["fading"] == {"model": "none", "k0_db": 3}
    assert notes == ["f: dropped channel.fading.k90_db and channel.fading.correlation: "
                     "channel.fading.model = 'none' does not read them ('rician' did)"]
    with pytest.raises(ScenarioError) as error:
        parse_scenario(result, "f")
    assert error.value.lines == [
        "f: channel.fading: k0_db given with model = 'none', which ignores it ('none' reads "
        "none of them; 'rician' reads k0_db, k90_db and correlation); remove it or choose "
        "another model"]


@pytest.mark.parametrize(("item", "fading"), [
    ("channel.fading.model=rician", RICIAN["channel"]["fading"]),  # the model it has
    ("channel.fading.correlation=0.5",                               # no model changed
     {**RICIAN["channel"]["fading"], "correlation": 0.5}),
    ('channel.fading={model="none", k0_db=1.0}', {"model": "none", "k0_db": 1.0}),  # typed
    ('channel={fading={model="none", k90_db=2.0}}', {"model": "none", "k90_db": 2.0})])
def test_nothing_is_dropped_where_no_model_changes_or_the_table_is_typed(item, fading):
    result, notes = overridden(RICIAN, [item], "f")
    assert notes == [] and result["channel"]["fading"] == fading


@pytest.mark.parametrize(("scenario", "items", "dropped", "check"), [
    ("moving_users_fading_sub6", ["users.mobility.model=static"],
     "users.mobility.mean_speed_mps, users.mobility.memory, users.mobility.speed_sigma_mps and "
     "users.mobility.heading_sigma_deg: users.mobility.model = 'static' does not read them "
     "('gauss-markov' did)",
     lambda s: s.users.mobility.model == "static" and s.users.mobility.memory is None),
    ("two_uavs_moving_mmwave", ["users.mobility.model=random-walk",
                                "users.mobility.speed_mps=1.5"],
     "users.mobility.speed_min_mps, users.mobility.speed_max_mps and "
     "users.mobility.pause_max_s: users.mobility.model = 'random-walk' does not read them "
     "('random-waypoint' did)",
     lambda s: s.users.mobility.speed_mps == 1.5 and s.users.mobility.speed_max_mps is None),
    ("two_uavs_mmwave", ["agent.algorithm=ppo"],
     "agent.reward_split: agent.algorithm = 'ppo' does not read it ('bdq' did)",
     lambda s: s.agent.algorithm == "ppo" and s.agent.hidden_sizes == [64, 64]),
    ("city_sub6", ["world.buildings=none", "channel.los=always"],
     "world.city: world.buildings = 'none' does not read it ('generated' did)",
     lambda s: s.world.buildings == "none" and s.world.city is None),
    ("sub6_al_hourani", ["channel.model=mmwave-nyc"],
     "channel.params.carrier_hz: channel.model = 'mmwave-nyc' does not read it "
     "('sub6-al-hourani' did)",
     lambda s: s.channel.model == "mmwave-nyc" and s.radio.carrier_hz == 28e9
     and "carrier_hz" not in s.channel.params),
])
def test_every_model_switch_drops_what_its_new_model_does_not_read(scenario, items, dropped,
                                                                   check):
    path = SCENARIOS / f"{scenario}.toml"
    loaded, source = load_scenario_with_overrides(path, items)
    assert check(loaded)
    notes = override_notes(parse_toml(path.read_text(), str(path)), items, source)
    assert notes == [f"{path} with --set: dropped {dropped}"]


def test_placement_and_association_switches_of_a_resolved_scenario():
    """A run's scenario has every key resolved (``eval --set`` on a run file): listed users
    made uniform keep their count and lose their positions; listed serving UAVs made
    k-means lose the list."""
    two = load_scenario(SCENARIOS / "two_uavs_mmwave.toml").model_dump(mode="json")
    two["users"]["association"], two["users"]["uav"] = "listed", [0, 1, 0, 1, 0, 1, 0, 1]
    data, notes = overridden(two, ["users.placement=uniform", "users.association=kmeans"],
                             "run")
    scenario = parse_scenario(data, "run")
    assert (scenario.users.placement, scenario.users.count) == ("uniform", 8)
    assert (scenario.users.association, scenario.users.uav) == ("kmeans", None)
    assert notes == [
        "run: dropped users.positions_m: users.placement = 'uniform' does not read it "
        "('listed' did)",
        "run: dropped users.uav: users.association = 'kmeans' does not read it ('listed' did)"]


def test_the_fading_keys_of_each_model_are_those_it_resolves():
    """switches.FADING_KEYS against models.Fading: a resolved table lists exactly the keys
    its model reads."""
    for model, keys in FADING_KEYS.items():
        resolved = Fading(model=model).model_dump(exclude_none=True)
        assert set(resolved) == {"model", *keys}


def test_the_command_line_takes_the_documented_fading_override(tmp_path, capsys, monkeypatch):
    """``baseline`` and ``eval`` of a run with ``--set channel.fading.model=none`` on a Rician
    scenario: exit 0, one note naming the dropped keys, the numbers of the whole-table form;
    a dropped key typed in the same command is refused in one line."""
    from adaptsky_cli.cli import plausibility
    monkeypatch.setattr(plausibility, "_printed", set())
    path = SCENARIOS / "moving_users_fading_sub6.toml"
    note = ("adaptsky: note: {source}: dropped channel.fading.k0_db, channel.fading.k90_db and "
            "channel.fading.correlation: channel.fading.model = 'none' does not read them "
            "('rician' did)")
    results = []
    for item in ("channel.fading.model=none", 'channel.fading={model="none"}'):
        code = main(["baseline", str(path), "--method", "soa", "--steps", "2", "--json",
                     "--set", item])
        captured = capsys.readouterr()
        assert code == 0
        results.append(json.loads(captured.out)["methods"]["soa"])
        assert [line for line in captured.err.splitlines() if "note" in line] == (
            [note.format(source=f"{path} with --set")] if "model=none" in item else [])
    assert results[0] == results[1]
    assert main(["baseline", str(path), "--method", "soa", "--steps", "2", "--set",
                 "channel.fading.model=none", "--set", "channel.fading.k0_db=3"]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "channel.fading: k0_db given with model = 'none'" in lines[0]
    run = tmp_path / "run.h5"
    assert main(["train", str(path), "--episodes", "1", "--steps", "2", "--out", str(run),
                 "--quiet", "--set", "train.eval_every=0"]) == 0
    capsys.readouterr()
    assert main(["eval", str(run), "--steps", "2", "--compare", "soa", "--json", "--out",
                 str(tmp_path / "eval.h5"), "--set", "channel.fading.model=none"]) == 0
    captured = capsys.readouterr()
    assert note.format(source="the run's scenario with --set") in captured.err.splitlines()
    assert 'model = "none"' in json.loads(captured.out)["scenario_toml"]
