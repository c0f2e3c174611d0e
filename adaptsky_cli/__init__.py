"""adaptsky: NOMA-UAV network simulator and dueling-DQN framework (AdaptSky paper).

This package holds the code and the ``adaptsky`` command; ``import adaptsky`` gives the
public API (the ``adaptsky`` package re-exports it) and registers ``adaptsky/NomaUav-v0`` with
Gymnasium, as does importing ``adaptsky_cli.env.gym_env``. This module imports nothing heavy:
the console script imports it before it can catch a Ctrl-C.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("adaptsky")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"
