"""Console-script entry point: a Ctrl-C (SIGINT) or a SIGTERM (``kill``, ``timeout``, a batch
scheduler) at any moment, also while the command's modules are still being imported, ends with
one line and exit code 130, never a traceback; during training both checkpoint first. Once the
exit code is known, further signals are ignored: a Ctrl-C during the interpreter's shutdown
(torch's exit handlers, say) would print a traceback no one can act on. Output whose reader
went away (``adaptsky eval RUN.h5 | head -1``) ends quietly with exit code 141, as a Unix tool
that SIGPIPE ended: no message, no traceback (``main`` and ``console.OutputClosed``)."""

from __future__ import annotations

import os
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
    except Exception as error:  # nobody reads stderr either: its one line could not be said
        from adaptsky_cli.cli.console import OUTPUT_CLOSED_EXIT, OutputClosed

        if not isinstance(error, OutputClosed):
            raise
        code = OUTPUT_CLOSED_EXIT
    _ignore_stop_signals()
    sys.exit(_flushed(code))


def _flushed(code: int) -> int:
    """``code`` once what stdout still holds is written; where nobody reads it any more, 141
    (for a command that succeeded) and stdout put on /dev/null, so that the interpreter's own
    flush at exit neither fails nor says so (it would print a traceback and exit 120)."""
    from adaptsky_cli.cli.console import OUTPUT_CLOSED_EXIT

    try:
        sys.stdout.flush()
    except (BrokenPipeError, ValueError):  # ValueError: stdout was closed
        code = OUTPUT_CLOSED_EXIT if code == 0 else code
    if code == OUTPUT_CLOSED_EXIT:
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            os.close(devnull)
        except (AttributeError, OSError, ValueError):
            pass
    return code


def _ignore_stop_signals() -> None:
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_IGN)
