"""adaptsky: NOMA-UAV network simulator and dueling-DQN framework (AdaptSky paper)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("adaptsky")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

from adaptsky_cli.env.registration import register_envs

register_envs()
