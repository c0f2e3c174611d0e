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



def refusal_of_scenario(tmp_path: Path, capsys: pytest.CaptureFixture[str], body: str) -> str:
    """The one line ``scenario validate`` gives, with exit 1, for a scenario file named
    "bad" of the TOML ``body`` after its name."""
    from adaptsky_cli.cli.main import main

    path = tmp_path / "bad.toml"
    path.write_text(f'name = "bad"\n{body}\n')
    assert main(["scenario", "validate", str(path)]) == 1
    return one_line(capsys)
