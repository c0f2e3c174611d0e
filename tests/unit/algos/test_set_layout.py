"""The set layout (adaptsky/algos/shared/set_layout.py): every component of an observation
placed once, of the width the networks take, and each row one user's features: listing the
users in another order permutes the rows and leaves the rest as it is."""

from __future__ import annotations

import numpy as np
import pytest

from adaptsky.algos.shared.set_layout import set_layout
from adaptsky.algos.shared.shapes import local_input_size, observation_size_of
from adaptsky.envs.observations import AgentView
from adaptsky.scenario import load_scenario
from adaptsky.scenario.variants import with_values
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SCENARIOS, make_scenario


@pytest.mark.parametrize("name, agent", [
    ("nyc_mmwave.toml", {}),
    ("nyc_mmwave.toml", {"observe": ["los"]}),
    ("city_sub6.toml", {"observe": ["heights", "los"], "raster_cells": 3}),
    ("moving_users_sub6.toml", {"observe": ["velocity", "los"]}),
    ("two_uavs_moving_mmwave.toml", {"observe": ["velocity"]}),
    ("two_uavs_moving_mmwave.toml", {"algorithm": "mappo", "observe": ["velocity"]}),
    ("city_two_uavs_mmwave.toml", {"algorithm": "ippo", "observe": ["heights", "los"]}),
])
def test_every_component_once_at_the_networks_width(name, agent):
    base = load_scenario(SCENARIOS / name)
    if "algorithm" in agent:
        scenario = with_values(base, "agent", agent, "test", replace=True)
    else:
        scenario = with_values(base, "agent", agent, "test")
    layout = set_layout(scenario)
    local = getattr(scenario.agent, "local_view", False)
    assert layout.width == (local_input_size(scenario) if local
                            else observation_size_of(scenario))
    slots = scenario.users_per_uav if local else scenario.num_users
    assert layout.per_user.shape[0] == slots


def test_rows_follow_the_users():
    users_m = [[30.0, 0.0], [-30.0, 0.0], [5.0, 25.0], [-10.0, -20.0]]
    swapped = [users_m[i] for i in (2, 3, 0, 1)]      # the same pairs, listed otherwise

    def observed(positions):
        scenario = make_scenario(
            area={"side_m": 80.0}, channel={"model": "sub6-al-hourani", "los": "geometric"},
            radio={"tx_power_dbm": 30.0, "bandwidth_hz": 50e6, "thermal_noise_dbm": -88.0,
                   "noise_figure_db": 0.0, "antennas_uav": 1, "antennas_ue": 1},
            world={"buildings": "listed", "building": [
                {"x_m": 15.0, "y_m": 0.0, "width_m": 4.0, "depth_m": 10.0,
                 "height_m": 40.0}]},
            users={"positions_m": positions, "pairing": "listed"},
            uav={"start_m": [0.0, 0.0, 20.0]},
            agent={"observe": ["los", "heights"], "raster_cells": 3})
        obs, _ = NetworkBatch(scenario, seed=0, view=AgentView.of(scenario)).reset()
        return obs[0], set_layout(scenario)

    obs, layout = observed(users_m)
    other, _ = observed(swapped)
    rows, rows_swapped = obs[layout.per_user], other[layout.per_user]
    assert rows.shape == (4, 5)                          # dx, dy, alpha, g, LoS
    np.testing.assert_array_equal(rows_swapped, rows[[2, 3, 0, 1]])
    np.testing.assert_array_equal(other[layout.rest], obs[layout.rest])
    assert rows[0, 4] == 0.0 and rows[1, 4] == 1.0      # the box hides user 1
