"""adaptsky's public Python API (``import adaptsky``); also registers
``adaptsky/NomaUav-v0`` with Gymnasium.

The code lives in ``adaptsky_cli`` (the package of the ``adaptsky`` command); this module
re-exports what a library user needs, each name loaded on first use, so that ``import
adaptsky`` does not import torch. Plugin authors import ``adaptsky_cli.channels``
(docs/plugins.md).
"""

from importlib import import_module
from typing import Any

from adaptsky_cli import __version__
from adaptsky_cli.env.registration import ENV_ID, register_envs

register_envs()

# public name -> module that defines it
_EXPORTS = {
    "AdaptskyError": "adaptsky_cli.errors",
    "Scenario": "adaptsky_cli.scenario",
    "load_scenario": "adaptsky_cli.scenario",
    "NomaUavBatch": "adaptsky_cli.env.batch",
    "NomaUavEnv": "adaptsky_cli.env.gym_env",
    "NomaUavVectorEnv": "adaptsky_cli.env.gym_env",
    "train": "adaptsky_cli.train.api",
    "resume": "adaptsky_cli.train.api",
    "evaluate": "adaptsky_cli.evaluate.api",
    "baseline": "adaptsky_cli.evaluate.api",
}

__all__ = ["ENV_ID", "__version__", *_EXPORTS]


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'adaptsky' has no attribute {name!r}; "
                             f"it exports {', '.join(__all__)}")
    value = getattr(import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
