"""The command line as the tests see it: the installed script and its one-line errors."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ADAPTSKY = Path(sys.executable).with_name("adaptsky")  # the installed command


def one_line(capsys: pytest.CaptureFixture[str]) -> str:
    """The one line on stderr (nothing on stdout, no traceback)."""
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert captured.out == "" and "Traceback" not in captured.err
    return lines[0]

