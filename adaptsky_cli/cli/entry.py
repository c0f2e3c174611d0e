"""Console-script entry point: a Ctrl-C (SIGINT) or a SIGTERM (``kill``, ``timeout``, a batch
scheduler) at any moment, also while the command's modules are still being imported, ends with
one line and exit code 130, never a traceback; during training both checkpoint first."""

from __future__ import annotations

import signal
import sys
from types import FrameType


def _terminate(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt  # SIGTERM takes the way of a Ctrl-C


def run() -> None:
    try:
        signal.signal(signal.SIGTERM, _terminate)
        from adaptsky_cli.cli.main import main

        code = main()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        code = 130
    sys.exit(code)
