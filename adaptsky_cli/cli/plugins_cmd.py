"""``adaptsky plugins list|show|check``."""

import json
from typing import Any

import typer
from rich.table import Table

from adaptsky_cli.channels.registry import discover, get_model_class, load_class
from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import Json, PluginName

app = typer.Typer(help="Channel-model plugins (entry-point group adaptsky.channel_models).",
                  no_args_is_help=True)


@app.command("list")
def list_plugins(as_json: Json = False) -> None:
    """List every installed channel model, broken ones with their error."""
    plugins = discover().values()
    if as_json:
        print(json.dumps([{"name": p.name, "package": p.package, "version": p.version,
                           "status": p.status, "description": p.description,
                           "error": p.error} for p in plugins], indent=2))
        return
    table = Table("name", "package", "version", "status", "description")
    for column in table.columns[:3]:
        column.no_wrap = True
    for p in plugins:
        status = "[green]ok[/]" if p.status == "ok" else "[red]broken[/]"
        table.add_row(p.name, p.package, p.version, status,
                      p.description or "(see its error below)")
    out.print(table)
    for p in plugins:  # whole, on lines of their own: never cut to the table's width
        if p.error:
            out.print(f"{p.name}: {p.error}", markup=False, highlight=False, soft_wrap=True)


@app.command()
def show(name: PluginName, as_json: Json = False) -> None:
    """Print a channel model's parameters with defaults and units."""
    model = get_model_class(name)
    info = discover()[name]
    fields = model.Params.model_fields
    if as_json:
        print(json.dumps({"name": name, "package": info.package, "version": info.version,
                          "description": model.description,
                          "params": {key: {"type": _type_name(f.annotation),
                                           "default": f.default,
                                           "limits": _limits(f.metadata),
                                           "description": f.description}
                                     for key, f in fields.items()}}, indent=2))
        return
    out.print(f"[bold]{name}[/] ({info.package} {info.version}): {model.description}")
    table = Table("parameter", "type", "default", "allowed", "description (unit)")
    for key, field in fields.items():
        limits = _limits(field.metadata)
        allowed = ", ".join(f"{_SYMBOLS[bound]} {value:g}" for bound, value in limits.items())
        table.add_row(key, _type_name(field.annotation), repr(field.default), allowed or "any",
                      field.description or "")
    out.print(table)


_SYMBOLS = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}


def _limits(metadata: list[Any]) -> dict[str, float]:
    """A field's numeric bounds (Pydantic's gt/ge/lt/le constraints) as {"gt": 0, ...}."""
    return {bound: getattr(item, bound) for item in metadata for bound in _SYMBOLS
            if isinstance(getattr(item, bound, None), int | float)}


def _type_name(annotation: Any) -> str:
    return getattr(annotation, "__name__", None) or str(annotation).replace("typing.", "")


@app.command()
def check(name: PluginName) -> None:
    """Check a channel model against every rule of the plugin contract (docs/plugins.md):
    one line per failure, exit 1 if any."""
    from adaptsky_cli.channels.checker import check_channel_model

    failures = check_channel_model(load_class(name))
    if failures:
        for line in failures:
            err.print(f"{name}: {line}", markup=False, highlight=False, soft_wrap=True)
        raise typer.Exit(1)
    out.print(f"ok  {name}: follows the plugin contract", markup=False)
