"""A small two-UAV scenario file on which every search takes a fraction of a second."""

from __future__ import annotations

from pathlib import Path

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from tests.conftest import SCENARIOS


def small_two_uavs(tmp_path: Path, name: str = "two", uavs: int = 2, **sections: dict) -> Path:
    """two_uavs_mmwave.toml on a 20 m area (heights 10-16 m on a 2 m lattice, alpha grid 0.1
    ... 0.9), 4 users: every search is a fraction of a second."""
    data = load_scenario(SCENARIOS / "two_uavs_mmwave.toml").model_dump(mode="json")
    data["name"] = name
    data["area"]["side_m"] = 20.0
    data["users"] |= {"count": 4,
                      "positions_m": [[-8.0, -6.0], [-3.0, -9.0], [7.0, 8.0], [2.0, 4.0]]}
    data["uav"] |= {"count": uavs, "start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0,
                    "max_height_m": 16.0, "step_m": [2.0, 2.0, 2.0], "power_step": 0.1}
    data["agent"] |= {"hidden_sizes": [16], "batch_size": 8, "memory_size": 200}
    data["train"] |= {"episodes": 2, "steps": 20}
    for section, values in sections.items():
        data[section] |= values
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(data))
    return path
