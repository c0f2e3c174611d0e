"""``adaptsky plugins show`` on a narrow terminal: the keys a user types are never cut."""

from __future__ import annotations

import pytest

from adaptsky.channels.registry import get_model_class
from adaptsky_cli.cli.console import out
from adaptsky_cli.cli.main import main


@pytest.mark.parametrize("width", [80, 60])
@pytest.mark.parametrize("name", ["sub6-al-hourani", "mmwave-nyc", "uma-av"])
def test_parameter_names_are_whole_and_descriptions_wrap(name, width, monkeypatch, capsys):
    monkeypatch.setattr(out, "width", width)
    assert main(["plugins", "show", name]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(map(len, lines)) <= width
    first_cells = {line.split("│")[1].strip() for line in lines if line.startswith("│")}
    assert set(get_model_class(name).Params.model_fields) <= first_cells
    assert not any("…" in line for line in lines)
    table = [line for line in lines if line[:1] in "┏┃┡│└"]
    assert all(line[-1] in "┓┃┩│┘" for line in table)  # not cropped at the right edge
