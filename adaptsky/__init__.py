"""adaptsky: a simulator and deep-reinforcement-learning framework for NOMA-UAV networks.

This package is the library: scenarios, channel models (plugin authors import
``adaptsky.channels``), the simulation, environments, algorithms, training, run files,
evaluation, experiments and reports (``docs/architecture.md``). The ``adaptsky`` command lives
in ``adaptsky_cli``. The public names below are loaded on first use, so ``import adaptsky``
imports no torch; it registers ``adaptsky/NomaUav-v0`` with Gymnasium (when Gymnasium is
imported: ``envs.registration``).
"""

from importlib import import_module
from typing import Any

from adaptsky.envs.registration import ENV_ID, register_when_gymnasium_is_imported

register_when_gymnasium_is_imported()

# public name -> module that defines it
_EXPORTS = {
    "AdaptskyError": "adaptsky.errors",
    "Scenario": "adaptsky.scenario",
    "load_scenario": "adaptsky.scenario",
    "NetworkBatch": "adaptsky.sim.network",
    "NomaUavBatch": "adaptsky.sim.batch",        # deprecated: NetworkBatch
    "MultiUavBatch": "adaptsky.sim.multi_batch",  # deprecated: NetworkBatch
    "network_batch": "adaptsky.sim.multi_batch",  # deprecated: NetworkBatch
    "NomaUavEnv": "adaptsky.envs.gym_env",
    "NomaUavVectorEnv": "adaptsky.envs.gym_env",
    "NomaUavParallelEnv": "adaptsky.envs.parallel_env",
    "train": "adaptsky.training.api",
    "resume": "adaptsky.training.api",
    "evaluate": "adaptsky.evaluation.api",
    "baseline": "adaptsky.evaluation.api",
    "evaluate_policy": "adaptsky.evaluation.outside",
}

_DEPRECATED = {"NomaUavBatch", "MultiUavBatch", "network_batch"}

__all__ = ["ENV_ID", "__version__", *_EXPORTS]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("adaptsky")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "0.0.0+unknown"


def __getattr__(name: str) -> Any:
    if name == "__version__":
        value: Any = _version()
    elif name in _EXPORTS:
        value = getattr(import_module(_EXPORTS[name]), name)
    else:
        raise AttributeError(f"module 'adaptsky' has no attribute {name!r}; "
                             f"it exports {', '.join(__all__)}")
    if name not in _DEPRECATED:   # deprecated names warn on every use
        globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public API and the module's own dunder names: no helpers (``Any``,
    ``import_module``), no subpackages imported on the way (``envs``)."""
    dunders = {name for name in globals() if name.startswith("__") and name.endswith("__")}
    return sorted(dunders | set(__all__))
