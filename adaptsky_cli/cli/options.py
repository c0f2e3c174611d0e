"""Argument and option aliases shared by several commands, and the ``--seeds`` syntax."""

import re
from pathlib import Path
from typing import Annotated

import typer

from adaptsky.errors import AdaptskyError

ScenarioFile = Annotated[Path, typer.Argument(help="scenario file (TOML)", show_default=False,
                                              metavar="SCENARIO.toml")]
ScenarioFiles = Annotated[list[Path], typer.Argument(help="scenario files (TOML)",
                                                     show_default=False,
                                                     metavar="SCENARIO.toml...")]
PluginName = Annotated[str, typer.Argument(help="channel-model name, as in 'plugins list'",
                                           show_default=False, metavar="NAME")]
Json = Annotated[bool, typer.Option("--json", help="print JSON on stdout, nothing else")]
Layout = Annotated[int | None, typer.Option(
    metavar="L", show_default=False,
    help="an evaluation's layout (0, 1, ...) whose per-user rates are shown (default: the "
    "first)")]
CsvFile = Annotated[Path | None, typer.Option(
    "--csv", metavar="FILE.csv", show_default=False,
    help="an evaluation's per-layout numbers and per-user rates, every method and layout, to "
    "this CSV")]
Device = Annotated[str, typer.Option(
    "--device", metavar="cpu|cuda|auto", help="where to train: cpu, cuda (or cuda:N) or auto "
    "(cuda when available); on cuda all seeds train as one stack, recorded as CUDA graphs")]
Episodes = Annotated[int | None, typer.Option(min=1, metavar="N", help="episodes per seed",
                                              show_default=False)]
Steps = Annotated[int | None, typer.Option(min=1, metavar="N", help="steps per episode",
                                           show_default=False)]
SetValues = Annotated[list[str] | None, typer.Option(
    "--set", metavar="KEY=VALUE", show_default=False,
    help="override a scenario key, section.key=value (repeatable), e.g. --set "
    "reward.min_se=1.5 --set agent.dueling=false; recorded in the run file")]
SEEDS_HELP = "seeds: a list or ranges, e.g. 0,1,2 or 0-5 or 0-2,7"
"""How ``--seeds`` is written, for every command's help."""

MAX_SEEDS = 1000
"""The most seeds one run trains (``train.seeds``, docs/scenario-format.md)."""
_SEEDS_ITEM = re.compile(r"(\d+)(?:-(\d+))?")


def parse_seeds(text: str | None) -> list[int] | None:
    """``--seeds``: integers >= 0 and ranges ``a-b`` (both ends included), comma-separated,
    each seed once, in the order given: ``0-2,7`` -> [0, 1, 2, 7]; None where not given."""
    if text is None:
        return None
    seeds: list[int] = []
    for item in text.split(","):
        found = _SEEDS_ITEM.fullmatch(item.strip())
        if found is None:
            raise AdaptskyError(f"--seeds: '{text}' is not a list of seeds; give integers >= 0 "
                                "and ranges, e.g. 0,1,2 or 0-5 or 0-2,7")
        low, high = int(found.group(1)), int(found.group(2) or found.group(1))
        if high < low:
            raise AdaptskyError(f"--seeds: the range {item.strip()} ends before it starts; "
                                f"write it low-high, e.g. {high}-{low}")
        if len(seeds) + high - low + 1 > MAX_SEEDS:
            raise AdaptskyError(f"--seeds: '{text}' names more than {MAX_SEEDS} seeds; "
                                "a run trains at most that many")
        seeds += range(low, high + 1)
    repeated = sorted({seed for seed in seeds if seeds.count(seed) > 1})
    if repeated:
        raise AdaptskyError(f"--seeds: {', '.join(map(str, repeated))} given more than once; "
                            "give each seed once, e.g. 0,1,2")
    return seeds



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
