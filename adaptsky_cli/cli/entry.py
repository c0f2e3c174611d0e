"""Console-script entry point: a Ctrl-C (SIGINT) or a SIGTERM (``kill``, ``timeout``, a batch
scheduler) at any moment, also while the command's modules are still being imported, ends with
one line and exit code 130, never a traceback; during training both checkpoint first. Once the
exit code is known, further signals are ignored: a Ctrl-C during the interpreter's shutdown
(torch's exit handlers, say) would print a traceback no one can act on."""

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
        _ignore_stop_signals()
        print("interrupted", file=sys.stderr)
        code = 130
    _ignore_stop_signals()
    sys.exit(code)


def _ignore_stop_signals() -> None:
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_IGN)
