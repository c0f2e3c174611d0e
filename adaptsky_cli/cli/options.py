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


def command_line(ctx: typer.Context) -> list[str]:
    """The running command with every parameter as parsed, defaults included (provenance:
    running it again repeats the work)."""
    words = ctx.command_path.split()
    options: list[str] = []
    for param in ctx.command.params:
        value = ctx.params.get(param.name or "")
        values = list(value) if isinstance(value, list | tuple) else [value]
        if value is None or param.name == "help":
            continue
        if param.param_type_name == "argument":
            words += [str(item) for item in values]
        elif getattr(param, "is_flag", False):
            flag = param.opts[0] if value else (param.secondary_opts or [None])[0]
            options += [flag] if flag else []
        else:
            for item in values:
                options += [param.opts[0], str(item)]
    return words + options
