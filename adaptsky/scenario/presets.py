"""Named agent recipes (``[agent] preset = "..."``): values for the ``[agent]`` keys a scenario
does not give, per algorithm family. docs/agent.md says how each was found and what it measured.

- DQN and BDQ: ``paper``, the paper's agent (sec. V-A), every key at its default; ``tuned``,
  our recipe for reaching the oracle's optimum reliably.
- PPO, SAC, MAPPO and IPPO: ``cleanrl``, every key at its default (CleanRL's values, and
  Yu et al.'s where MAPPO has its own); ``tuned``, tuned on the shipped scenarios the learner
  fits (PPO and SAC on ``nyc_mmwave.toml``, MAPPO and IPPO on the two- and four-UAV ones).
"""

from __future__ import annotations

from typing import Any

PRESETS: dict[str, dict[str, dict[str, Any]]] = {
    "dqn": {  # the dueling DQN and the BDQ (which takes the keys it has)
        "paper": {},
        "tuned": {
            "double_dqn": True,
            "epsilon_end": 0.01,
            "epsilon_decay_steps": 30_000.0,
            "lr_end": 1e-4,
            "lr_decay_steps": 300_000.0,
            "user_order": "clusters",
        },
    },
    "ppo": {
        "cleanrl": {},
        "tuned": {"lr": 1e-3},  # one seed of six stalls at 78% of the oracle with 3e-4
    },
    "sac": {
        "cleanrl": {},
        # rewards of about 220 a step left the critic behind: 78-82% of the oracle
        "tuned": {"hidden_sizes": [64, 64], "reward_scale": 0.01},
    },
    "mappo": {  # MAPPO and IPPO
        "cleanrl": {},
        "tuned": {"lr": 1e-3},
    },
}
DEFAULT_PRESET: dict[str, str] = {"dqn": "paper", "ppo": "cleanrl", "sac": "cleanrl",
                                  "mappo": "cleanrl"}


def preset_values(name: str, family: str = "dqn") -> dict[str, Any]:
    """The ``[agent]`` values of preset ``name`` of an algorithm ``family`` (a key of
    :data:`PRESETS`); a ValueError names the presets there are."""
    presets = PRESETS[family]
    if name not in presets:
        raise ValueError(f"unknown preset '{name}'; choose from {', '.join(presets)}")
    return dict(presets[name])
