"""Issue 35, item 7: a scenario takes the radio of its channel model's paper table for every
``[radio]`` key it does not give (the model's ``default_radio``); a model without one gets
adaptsky's defaults (the mmWave Table I), as before. The values below are the paper's Table I
(docs/model.md §2), written here rather than read from the code."""

from __future__ import annotations

import tomllib
from types import MappingProxyType

import numpy as np
import pytest

from adaptsky.channels import registry
from adaptsky.channels.registry import PluginInfo
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.toml_writer import dumps
from tests.conftest import SCENARIOS
from tests.unit.scenario.free_space import FreeSpaceAny

# Table I: f_c, P_T, N_UAV x N_UE, W per cluster, thermal noise (no noise figure)
SUB6_TABLE = {"carrier_hz": 2e9, "tx_power_dbm": 30.0, "antennas_uav": 1, "antennas_ue": 1,
              "bandwidth_hz": 50e6, "thermal_noise_dbm": -88.0, "noise_figure_db": 0.0}
MMWAVE_TABLE = {"carrier_hz": 28e9, "tx_power_dbm": 20.0, "antennas_uav": 8, "antennas_ue": 8,
                "bandwidth_hz": 2e9, "thermal_noise_dbm": -84.0, "noise_figure_db": 0.0}


def _radio(model: str, **radio) -> dict:
    data = {"name": "r", "channel": {"model": model}}
    if radio:
        data["radio"] = radio
    scenario = parse_scenario(data, "r.toml")
    return scenario.radio.model_dump(mode="json")


def _table_part(radio: dict) -> dict:
    return {key: radio[key] for key in SUB6_TABLE}


def test_sub6_without_a_radio_table_takes_the_sub6_column_of_table_i():
    radio = _radio("sub6-al-hourani")
    assert _table_part(radio) == SUB6_TABLE
    assert radio["reuse"] == "full"
    assert all(type(radio[key]) is type(value) for key, value in SUB6_TABLE.items())


def test_mmwave_without_a_radio_table_keeps_the_mmwave_column():
    assert _table_part(_radio("mmwave-nyc")) == MMWAVE_TABLE


def test_a_partial_radio_table_takes_the_models_values_for_the_keys_it_leaves_out():
    radio = _radio("sub6-al-hourani", thermal_noise_dbm=-53.0, antennas_uav=4)
    assert _table_part(radio) == SUB6_TABLE | {"thermal_noise_dbm": -53.0, "antennas_uav": 4}


def test_a_key_given_wins_even_when_it_equals_the_other_models_default():
    radio = _radio("sub6-al-hourani", bandwidth_hz=2e9, tx_power_dbm=20.0)
    assert (radio["bandwidth_hz"], radio["tx_power_dbm"]) == (2e9, 20.0)
    assert radio["antennas_uav"] == 1


def test_the_carrier_of_the_table_yields_to_the_models_carrier_parameter():
    scenario = parse_scenario({"name": "r", "channel": {"model": "sub6-al-hourani",
                                                        "params": {"carrier_hz": 3.5e9}}}, "r")
    assert scenario.radio.carrier_hz == 3.5e9 == scenario.channel.params["carrier_hz"]
    assert scenario.radio.bandwidth_hz == 50e6


def test_the_sub6_default_radio_gives_the_reference_rates_of_model_section_8():
    """docs/model.md §8: sub-6 with -88 dBm, UAV at (0, 0, 50), alpha 0.5: 13.667, 1.000, 13.553,
    1.000 bit/s/Hz -- from a file that names only the channel model."""
    from adaptsky.sim.network import NetworkBatch
    scenario = parse_scenario({"name": "r", "channel": {"model": "sub6-al-hourani"}}, "r")
    _, state = NetworkBatch(scenario, num_envs=1, seed=0).reset()
    rates = state.rate_bps[0] / scenario.radio.bandwidth_hz
    np.testing.assert_allclose(rates, [13.667, 1.000, 13.553, 1.000], atol=5e-4)


def test_scenario_show_of_a_sub6_file_reads_back_as_the_same_scenario(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('name = "s"\n[channel]\nmodel = "sub6-al-hourani"\n')
    scenario = load_scenario(path)
    shown = dumps(scenario.model_dump(mode="json"))
    assert tomllib.loads(shown)["radio"]["bandwidth_hz"] == 50e6
    assert parse_scenario(tomllib.loads(shown), "shown") == scenario


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_scenario_gives_its_whole_radio(path):
    """Shipped scenarios keep their numbers: each gives every key of the paper table, so no
    default of any model reaches them."""
    given = tomllib.loads(path.read_text())["radio"]
    # (the uplink reads no P_T of the UAV: docs/model.md §17)
    unread = {"carrier_hz"} | ({"tx_power_dbm"} if given.get("direction") == "uplink" else set())
    assert set(SUB6_TABLE) - unread <= set(given), path


# --- plugins: declaring a radio, or not ------------------------------------------------------

class WithRadio(FreeSpaceAny):
    default_radio = MappingProxyType({"carrier_hz": 3.5e9, "tx_power_dbm": 23.0,
                                      "bandwidth_hz": 20e6, "antennas_uav": 4})


class BrokenRadio(FreeSpaceAny):
    default_radio = MappingProxyType({"tx_power_dbm": 500.0})


class TypoRadio(FreeSpaceAny):
    default_radio = MappingProxyType({"bandwith_hz": 20e6})


@pytest.fixture
def register(monkeypatch):
    def add(name, model):
        monkeypatch.setitem(registry._loaded, name,
                            PluginInfo(name, "tests", "0", f"tests:{model.__name__}", model))
    return add


def test_a_plugin_without_a_default_radio_gets_the_defaults_as_before(register):
    register("free-space", FreeSpaceAny)
    radio = _radio("free-space")
    assert _table_part(radio) == MMWAVE_TABLE


def test_a_plugin_declares_its_radio_and_the_rest_stays_the_default(register):
    register("with-radio", WithRadio)
    radio = _radio("with-radio")
    assert _table_part(radio) == MMWAVE_TABLE | {"carrier_hz": 3.5e9, "tx_power_dbm": 23.0,
                                                 "bandwidth_hz": 20e6, "antennas_uav": 4}
    assert _radio("with-radio", carrier_hz=5e9)["carrier_hz"] == 5e9


@pytest.mark.parametrize(("model", "words"), [
    (BrokenRadio, "default_radio: tx_power_dbm: Input should be less than or equal to 80"),
    (TypoRadio, "default_radio: bandwith_hz: unknown key; did you mean 'bandwidth_hz'?"),
])
def test_a_plugins_invalid_radio_is_one_line_naming_the_model(register, model, words):
    register("odd-radio", model)
    with pytest.raises(ScenarioError) as error:
        _radio("odd-radio")
    (line,) = error.value.lines
    assert line.startswith("r.toml: channel model 'odd-radio': ")
    assert words in line and line.endswith("fix the plugin (docs/plugins.md)")
