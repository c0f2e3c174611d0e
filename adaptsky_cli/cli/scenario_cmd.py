"""``adaptsky scenario validate|show``."""

import typer

from adaptsky.errors import ScenarioError
from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import ScenarioFile, ScenarioFiles
from adaptsky_cli.cli.plausibility import warn_scenario

app = typer.Typer(help="Check and print scenario files.", no_args_is_help=True)


@app.command()
def validate(files: ScenarioFiles) -> None:
    """Validate scenario files and check that this machine can train them: one 'ok' line
    each, or one line per problem (exit 1)."""
    from adaptsky.scenario import load_scenario
    from adaptsky.training.resources import check_fits, format_bytes
    failed = 0
    for path in files:
        try:
            scenario = load_scenario(path)
            needed = check_fits(scenario, str(path))
        except ScenarioError as error:
            failed += 1
            for line in error.lines:
                err.print(line)
            continue
        warn_scenario(scenario, str(path))
        out.print(f"ok  {path}  ({scenario.name}: {scenario.num_users} users, "
                  f"channel {scenario.channel.model}, LoS {scenario.channel.los}, "
                  f"about {format_bytes(needed.total)} of memory to train)",
                  markup=False, soft_wrap=True)
    if failed:
        raise typer.Exit(1)


@app.command()
def show(file: ScenarioFile) -> None:
    """Print the resolved scenario, every default filled in (the [radio] keys the file leaves
    out from its channel model's paper table), as TOML."""
    from adaptsky.scenario import load_scenario
    from adaptsky.scenario.toml_writer import dumps
    scenario = load_scenario(file)
    warn_scenario(scenario, str(file))
    print(dumps(scenario.model_dump(mode="json")), end="")
