"""Argument and option aliases shared by several commands."""

from pathlib import Path
from typing import Annotated

import typer

ScenarioFile = Annotated[Path, typer.Argument(help="scenario file (TOML)", show_default=False)]
ScenarioFiles = Annotated[list[Path], typer.Argument(help="scenario files (TOML)",
                                                     show_default=False)]
PluginName = Annotated[str, typer.Argument(help="channel-model name, as in 'plugins list'",
                                           show_default=False)]
Json = Annotated[bool, typer.Option("--json", help="print JSON on stdout, nothing else")]
Device = Annotated[str, typer.Option(
    "--device", help="where to train: cpu, cuda (or cuda:N) or auto (cuda when available); "
    "on cuda all seeds train as one stack, recorded as CUDA graphs")]
