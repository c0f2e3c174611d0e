"""``adaptsky plugins list|show|check``."""

import json
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from adaptsky.errors import PluginError
from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import Json, PluginName
from adaptsky_cli.cli.values import param_value

if TYPE_CHECKING:  # the registry (numpy, pydantic) is imported when a command runs
    from adaptsky.channels.registry import PluginInfo

app = typer.Typer(help="Channel-model plugins (entry-point group adaptsky.channel_models).",
                  no_args_is_help=True)


@app.command("list")
def list_plugins(as_json: Json = False) -> None:
    """List every installed channel model, broken ones with their error."""
    from adaptsky.channels.registry import discover

    plugins = discover().values()
    if as_json:
        print(json.dumps([{"name": p.name, "package": p.package, "version": p.version,
                           "status": p.status, "contract_version": p.contract_version,
                           "description": p.description, "error": p.error}
                          for p in plugins], indent=2))
        return
    # one line per plugin and its description below it, indented and wrapped to the
    # terminal: a table's description column is a dozen characters wide at 80 columns
    width = max([len("name"), *(len(p.name) for p in plugins)])
    out.print(Text(f"{'name':<{width}}  status  contract  package", style="bold"))
    for p in plugins:
        contract = "-" if p.contract_version is None else str(p.contract_version)
        line = Text(f"{p.name:<{width}}  ")
        line.append(f"{p.status:<6}", style="green" if p.status == "ok" else "red")
        line.append(f"  {contract:<8}  {p.package} {p.version}")
        out.print(line, overflow="fold")
        out.print(Padding(Text(p.description or "(broken: its error is below)", style="dim"),
                          (0, 0, 0, 4), expand=False))
    for p in plugins:  # whole, on lines of their own: never cut to the table's width
        if p.error:
            out.print(f"{p.name}: {p.error}", markup=False, highlight=False, soft_wrap=True)


@app.command()
def show(name: PluginName, as_json: Json = False) -> None:
    """Print a channel model's parameters with defaults and units."""
    from adaptsky.channels.contract import SHARED_SETTINGS, parameter_limits, supported_range
    from adaptsky.channels.registry import get_model_class, plugin

    model = get_model_class(name)
    info = plugin(name)
    fields = model.Params.model_fields
    supports = {setting: supported_range(model, setting) for setting in SHARED_SETTINGS}
    if as_json:
        print(json.dumps({"name": name, "package": info.package, "version": info.version,
                          "contract_version": info.contract_version,
                          "description": model.description, "supports": supports,
                          "params": {key: {"type": _type_name(f.annotation),
                                           "default": f.default,
                                           "limits": parameter_limits(model.Params, key),
                                           "description": f.description}
                                     for key, f in fields.items()}}, indent=2))
        return
    out.print(f"[bold]{name}[/] ({info.package} {info.version}): {model.description}")
    out.print(f"plugin contract {_contract(info)}", markup=False, highlight=False)
    out.print(f"supports {_supports(supports)}", markup=False, highlight=False)
    table = _parameter_table(list(fields))
    for key, field in fields.items():
        limits = parameter_limits(model.Params, key)
        allowed = ", ".join(f"{_SYMBOLS[bound]} {value:g}" for bound, value in limits.items())
        if not allowed and field.annotation is bool:
            allowed = "true, false"
        table.add_row(escape(key), escape(_type_name(field.annotation)),
                      escape(_shown(field.default)), allowed or "any",
                      escape(field.description or ""))
    out.print(table)


_SYMBOLS = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}


def _parameter_table(keys: list[str]) -> Table:
    """The columns of ``plugins show``: the keys a user types are never cut or wrapped (the
    column is as wide as the longest); the description wraps into what is left."""
    table = Table()
    table.add_column("parameter", no_wrap=True, min_width=max(map(len, keys), default=0))
    table.add_column("type", no_wrap=True)
    table.add_column("default", no_wrap=True)
    table.add_column("allowed", overflow="fold")
    table.add_column("description (unit)", ratio=1, overflow="fold")
    return table


def _supports(ranges: dict[str, tuple[float, float] | None]) -> str:
    """``carriers of 28 GHz only, any bandwidths, any user antenna heights``."""
    from adaptsky.channels.contract import supported_text
    return ", ".join(supported_text(setting, value) for setting, value in ranges.items())


def _params(name: str, model: Any, items: list[str]) -> Any:
    """The model's Params with ``--param KEY=VALUE`` items, or None for its defaults."""
    from adaptsky.channels.contract import ChannelParams
    if not items:
        return None
    from pydantic import ValidationError

    from adaptsky.scenario.overrides import parse_value

    values = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise PluginError(f"--param {item!r}: expected KEY=VALUE, e.g. carrier_hz=3.5e9")
        values[key.strip()] = parse_value(text.strip())
    params_class = getattr(model, "Params", None)
    if not (isinstance(params_class, type) and issubclass(params_class, ChannelParams)):
        raise PluginError(f"--param: '{name}' has no ChannelParams model to take parameters")
    try:
        return params_class.model_validate(values)
    except ValidationError as error:
        first = error.errors(include_url=False)[0]
        where = ".".join(str(part) for part in first["loc"])
        message = "unknown key" if first["type"] == "extra_forbidden" else first["msg"]
        raise PluginError(f"--param {where}: {message}") from None


def _shown(value: Any) -> str:
    """A default as a scenario file would write it: ``3.5e+09``, ``true``, ``"text"``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    return repr(value)


def _contract(info: "PluginInfo") -> str:
    """``2``, or ``1 (declares none)`` for a class written before contract versions."""
    return (str(info.contract_version) if info.contract_declared
            else f"{info.contract_version} (declares no contract_version)")


def _type_name(annotation: Any) -> str:
    return getattr(annotation, "__name__", None) or str(annotation).replace("typing.", "")


CarrierHz = Annotated[float | None, typer.Option(
    "--carrier-hz", min=1e8, max=1e12, help="carrier f_c of the checked links, Hz (default: "
    "the model's carrier_hz parameter, else 28e9)")]


Params = Annotated[list[str] | None, typer.Option(
    "--param", metavar="KEY=VALUE", callback=param_value,
    help="check with this parameter (a TOML value, e.g. "
    "shadowing=true); repeatable; the others keep their defaults")]


@app.command()
def check(name: PluginName, carrier_hz: CarrierHz = None, param: Params = None) -> None:
    """Check a channel model against every rule of the plugin contract (docs/plugins.md):
    one line per failure, exit 1 if any."""
    from adaptsky.channels.checker import check_channel_model, checked_conditions
    from adaptsky.channels.registry import load_class, plugin

    model = load_class(name)
    params = _params(name, model, param or [])
    failures = check_channel_model(model, params, carrier_hz=carrier_hz)
    if failures:
        for line in failures:
            err.print(f"{name}: {line}", markup=False, highlight=False, soft_wrap=True)
        raise typer.Exit(1)
    info = plugin(name)
    out.print(f"ok  {name}: follows plugin contract {info.contract_version} ("
              f"{checked_conditions(model, params, carrier_hz)})", markup=False,
              soft_wrap=True)
    from adaptsky.channels.checker import ignored_carrier_note
    note = ignored_carrier_note(model, params)
    if note:
        out.print(f"note: {name}: {note}", markup=False, soft_wrap=True)
    if not info.contract_declared:
        out.print(f"note: {name} declares no contract_version and is taken as contract 1 "
                  "(users on the ground, no fading); declare contract_version = 2 "
                  "(docs/plugins.md, contract versions)", markup=False, soft_wrap=True)
