"""What every section of a scenario file shares: the strict base model, the limits that keep
every step of a run finite, and the field types used in several sections."""

from __future__ import annotations

import unicodedata
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

PAPER_TRAINING_LAYOUT_M = [[4.0, 15.0], [-44.0, -49.0], [-5.0, 21.0], [47.0, 49.0]]

# names become file names (runs/<name>-<time>.h5, DIR/runs/<group>-...): see safe_name
NAME_MAX_LENGTH = 64          # characters
NAME_MAX_BYTES = 128          # in UTF-8: with the longest suffix, well inside 255-byte names
NAME_PUNCTUATION = "-_."
# the DQN's replay memory stores an action index as float32, exact up to 2^24: its dense action
# space (2^(3+K) or 3^(3+K) actions per UAV) may not be larger
MAX_DENSE_ACTIONS = 2**24
# an agent that acts per component (the BDQ stores a sub-action per branch) still steps the
# environment by a dense index, an int64: base^D <= 2^62 keeps it, and every draw below it, exact
MAX_INDEX_ACTIONS = 2**62
MAX_SEED = 2**63 - 1          # seeds are stored as int64
MAX_COUNT = 10**9             # episodes, steps, periods
MAX_MEMORY = 2**53            # replay rows are drawn as floor(u * size), u a float64
AREA_MAX_SIDE_M = 100_000.0
MIN_HEIGHT_M = 1.0            # every link is then >= 1 m long: no gain above the 1 m intercept
MAX_HEIGHT_M = 10_000.0
MAX_ANTENNAS = 4096
MAX_UAVS = 64                 # U; association and separation are exact over pairs of UAVs
MAX_REWARD_WEIGHT = 1e6
MAX_GAIN_WEIGHT = 1e12        # linear gains are ~1e-12 .. 1e-5

Seed = Annotated[int, Field(ge=0, le=MAX_SEED)]
LayerSize = Annotated[int, Field(ge=1, le=2**31 - 1)]
StepM = Annotated[float, Field(ge=0.01, le=1000.0)]
CoordinateM = Annotated[float, Field(ge=-AREA_MAX_SIDE_M, le=AREA_MAX_SIDE_M)]


def max_users(mode: str, num_uavs: int = 1, limit: int = MAX_DENSE_ACTIONS,
              cluster_size: int = 2, per_cluster: int | None = None) -> int:
    """The most users whose dense action space (``uav.actions = mode``, ``num_uavs`` UAVs:
    3 U + (N / M) C components, M = ``cluster_size``, C = ``per_cluster`` components of a
    cluster, M - 1 by default: the downlink's) has at most ``limit`` actions: for one UAV,
    pairs and ``MAX_DENSE_ACTIONS`` 42 for ``paper``, 24 for ``with-hover``; 0 where the UAVs'
    moves leave no room (eight UAVs under ``MAX_DENSE_ACTIONS``)."""
    base, components = (2 if mode == "paper" else 3), 3 * num_uavs
    while base ** (components + 1) <= limit:
        components += 1
    per_cluster = cluster_size - 1 if per_cluster is None else per_cluster
    return cluster_size * ((components - 3 * num_uavs) // per_cluster)


def _name_character(char: str) -> bool:
    """A letter, digit or combining mark of any script (Unicode categories L, N, M), or one of
    ``- _ .``: never a path separator, control or format character, space or shell symbol."""
    return char in NAME_PUNCTUATION or unicodedata.category(char)[0] in "LNM"


def safe_name(value: str) -> str:
    """``value`` if it can be a file name's stem on every system, else a ValueError saying what
    is allowed: 1 to NAME_MAX_LENGTH letters, digits (any script), '-', '_' or '.', at most
    NAME_MAX_BYTES in UTF-8, starting with a letter or digit (so no leading dot or dash)."""
    if (not value or len(value) > NAME_MAX_LENGTH or not all(map(_name_character, value))
            or value[0] in NAME_PUNCTUATION
            or len(value.encode("utf-8", "surrogatepass")) > NAME_MAX_BYTES):
        raise ValueError(f"not a safe file name: use 1 to {NAME_MAX_LENGTH} letters or digits "
                         f"of any script, '-', '_' or '.' (at most {NAME_MAX_BYTES} bytes in "
                         "UTF-8), starting with a letter or digit")
    return value


class Section(BaseModel):
    """Strict base: unknown keys are errors and no string is silently turned into a number."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
