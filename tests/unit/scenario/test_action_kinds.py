"""``uav.actions = "continuous"`` and ``uav.power`` in scenario files (docs/scenario-format.md):
what validates, and the one line for absolute power with a discrete kind."""

from __future__ import annotations

import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario
from tests.conftest import make_scenario


def test_continuous_actions_and_absolute_power_validate():
    scenario = make_scenario(uav={"actions": "continuous", "power": "absolute"})
    assert (scenario.uav.actions, scenario.uav.power) == ("continuous", "absolute")
    assert make_scenario().uav.power == "change"      # the default: every file before it
    # no dense index: more users than any discrete kind allows
    many = make_scenario(uav={"actions": "continuous"}, users={"placement": "uniform",
                                                               "count": 100})
    assert many.num_users == 100


@pytest.mark.parametrize("actions", ["paper", "with-hover"])
def test_absolute_power_with_a_discrete_kind_is_one_line(tmp_path, actions):
    path = tmp_path / "absolute.toml"
    path.write_text(f'name = "x"\n[uav]\nactions = "{actions}"\npower = "absolute"\n')
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert error.value.lines == [
        f"{path}: uav: power = 'absolute' needs actions = 'continuous' (it sets each share "
        f"from a continuous action), not '{actions}'; with 'paper' or 'with-hover' use "
        f"power = 'change'"]


def test_an_unknown_power_names_the_allowed_values(tmp_path):
    path = tmp_path / "power.toml"
    path.write_text('name = "x"\n[uav]\npower = "set"\n')
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    assert len(error.value.lines) == 1
    assert error.value.lines[0].startswith(f"{path}: uav.power: ")
    assert "'change'" in error.value.lines[0] and "'absolute'" in error.value.lines[0]
