"""Argument and option aliases shared by several commands, and the ``--seeds`` syntax."""

from pathlib import Path
from typing import Annotated, Any

import typer

from adaptsky_cli.cli.values import MAX_SEEDS, device_value, parse_seeds, seeds_value, set_value

__all__ = ["MAX_SEEDS", "parse_seeds"]  # their home before the values module

ScenarioFile = Annotated[Path, typer.Argument(help="scenario file (TOML)", show_default=False,
                                              metavar="SCENARIO.toml")]
ScenarioFiles = Annotated[list[Path], typer.Argument(help="scenario files (TOML)",
                                                     show_default=False,
                                                     metavar="SCENARIO.toml...")]
PluginName = Annotated[str, typer.Argument(help="channel-model name, as in 'plugins list'",
                                           show_default=False, metavar="NAME")]
Json = Annotated[bool, typer.Option("--json", help="print JSON on stdout, nothing else")]
Layout = Annotated[int | None, typer.Option(
    min=0, metavar="L", show_default=False,
    help="an evaluation's layout (0, 1, ...) whose per-user rates are shown (default: the "
    "first)")]
CsvFile = Annotated[Path | None, typer.Option(
    "--csv", metavar="FILE.csv", show_default=False,
    help="an evaluation's per-layout numbers and per-user rates, every method and layout, to "
    "this CSV")]
Device = Annotated[str, typer.Option(
    "--device", metavar="cpu|cuda|auto", callback=device_value,
    help="where to train: cpu, cuda (or cuda:N) or auto (cuda when available); on cuda all "
    "seeds train as one stack, recorded as CUDA graphs")]
Episodes = Annotated[int | None, typer.Option(min=1, metavar="N", help="episodes per seed",
                                              show_default=False)]
Steps = Annotated[int | None, typer.Option(min=1, metavar="N", help="steps per episode",
                                           show_default=False)]
SetValues = Annotated[list[str] | None, typer.Option(
    "--set", metavar="KEY=VALUE", show_default=False, callback=set_value,
    help="override a scenario key, section.key=value (repeatable), e.g. --set "
    "reward.min_se=1.5 --set agent.dueling=false; recorded in the run file")]
SEEDS_HELP = "seeds: a list or ranges, e.g. 0,1,2 or 0-5 or 0-2,7 (or the option repeated)"
"""How ``--seeds`` is written, for every command's help."""


def seeds_option(help_text: str) -> Any:
    """The ``--seeds`` option: comma-separated, repeated or both, checked by the parser."""
    return typer.Option("--seeds", metavar="SEEDS", show_default=False, callback=seeds_value,
                        help=help_text)


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
