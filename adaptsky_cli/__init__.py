"""adaptsky: NOMA-UAV network simulator and dueling-DQN framework (AdaptSky paper).

This package holds the code and the ``adaptsky`` command; ``import adaptsky`` gives the
public API (the ``adaptsky`` package re-exports it) and registers ``adaptsky/NomaUav-v0`` with
Gymnasium, as does importing ``adaptsky_cli.env.gym_env``. This module imports nothing: the
console script imports it before it can catch a Ctrl-C, so ``__version__`` is looked up on
first use.
"""

from typing import Any


def __getattr__(name: str) -> Any:
    if name != "__version__":
        raise AttributeError(f"module 'adaptsky_cli' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("adaptsky")
    except PackageNotFoundError:  # running from a source tree that is not installed
        value = "0.0.0+unknown"
    globals()["__version__"] = value
    return value
