"""The ``adaptsky`` command line: the Typer app and its commands (``adaptsky_cli.cli``) over
the library ``adaptsky``. This module imports nothing: the console script imports it before it
can catch a Ctrl-C. ``adaptsky_cli.channels`` is an alias of ``adaptsky.channels`` for plugins
written before the library moved.
"""

from typing import Any


def __getattr__(name: str) -> Any:
    if name != "__version__":
        raise AttributeError(f"module 'adaptsky_cli' has no attribute {name!r}")
    import adaptsky

    value = adaptsky.__version__
    globals()["__version__"] = value
    return value
