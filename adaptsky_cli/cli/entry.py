"""Console-script entry point: a Ctrl-C at any moment, also while the command's modules are
still being imported, ends with one line and exit code 130, never a traceback."""

from __future__ import annotations

import sys


def run() -> None:
    try:
        from adaptsky_cli.cli.main import main

        code = main()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        code = 130
    sys.exit(code)
