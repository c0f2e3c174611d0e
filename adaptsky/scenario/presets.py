"""Named agent recipes (``[agent] preset = "..."``): values for the ``[agent]`` keys a scenario
does not give. docs/agent.md says how each was found and what it measured.

- ``paper``: the paper's agent (sec. V-A), every key at its default.
- ``tuned``: our recipe for reaching the oracle's optimum reliably (docs/agent.md).
"""

from __future__ import annotations

from typing import Any

PRESETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "tuned": {
        "double_dqn": True,
        "epsilon_end": 0.01,
        "epsilon_decay_steps": 30_000.0,
        "lr_end": 1e-4,
        "lr_decay_steps": 300_000.0,
        "user_order": "clusters",
    },
}


def preset_values(name: str) -> dict[str, Any]:
    """The ``[agent]`` values of preset ``name``; a ValueError names the presets there are."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset '{name}'; choose from {', '.join(PRESETS)}")
    return dict(PRESETS[name])
