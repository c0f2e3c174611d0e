"""Entry point of the ``adaptsky`` command.

Errors of the project's own kind print one line (per problem) and exit 1, usage errors (an
unknown option, a missing argument, a value of the wrong type) one line and exit 2;
``ADAPTSKY_DEBUG=1`` shows the traceback instead.
"""

from __future__ import annotations

import os
import sys

import typer

from adaptsky import __version__
from adaptsky.errors import AdaptskyError
from adaptsky_cli.cli import (
    eval_cmd,
    inspect_cmd,
    plot_cmd,
    plugins_cmd,
    reproduce_cmd,
    scenario_cmd,
    show_cmd,
    train_cmd,
)
from adaptsky_cli.cli.console import err
from adaptsky_cli.cli.usage import OneLineGroup, UsageLine, usage_line

app = typer.Typer(name="adaptsky", no_args_is_help=True, pretty_exceptions_enable=False,
                  cls=OneLineGroup,
                  help="NOMA-UAV network simulator and dueling-DQN framework (AdaptSky).")
app.add_typer(scenario_cmd.app, name="scenario")
app.add_typer(plugins_cmd.app, name="plugins")
app.command()(train_cmd.train)
app.command()(inspect_cmd.inspect)
app.command("eval")(eval_cmd.evaluate)
app.command()(eval_cmd.baseline)
app.command()(reproduce_cmd.reproduce)
app.command()(plot_cmd.plot)
app.command()(show_cmd.show)


def _version(value: bool) -> None:
    if value:
        print(f"adaptsky {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="print the version and exit")) -> None:
    """NOMA-UAV network simulator and dueling-DQN framework (AdaptSky)."""


def _interrupted(done: SystemExit) -> bool:
    """Whether ``done`` is how Typer ended a KeyboardInterrupt."""
    error: BaseException | None = done
    while error is not None:
        if isinstance(error, KeyboardInterrupt):
            return True
        error = error.__cause__ or error.__context__
    return False


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv``; return the exit code (never raises for user errors)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        app(args=argv, prog_name="adaptsky")  # standalone: ends with SystemExit
    except SystemExit as done:
        if _interrupted(done):
            err.print("interrupted")  # Typer ends a Ctrl-C with a silent exit 130
        return done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    except UsageLine as usage:
        err.print(usage_line(usage, argv))
        return usage.exit_code
    except AdaptskyError as error:
        if os.environ.get("ADAPTSKY_DEBUG") == "1":
            raise
        err.print(str(error))
        return 1
    except OSError as error:  # a file-system fault no writer turned into its own line
        if os.environ.get("ADAPTSKY_DEBUG") == "1":
            raise
        from adaptsky.store.atomic import error_path, storage_error  # h5py: only when needed

        err.print(str(storage_error(error_path(error) or "adaptsky", "cannot access it",
                                    error)))
        return 1
    except MemoryError:
        if os.environ.get("ADAPTSKY_DEBUG") == "1":
            raise
        err.print("adaptsky: out of memory; use a smaller scenario (adaptsky scenario validate "
                  "estimates what it needs) or a machine with more memory")
        return 1
    except Exception as error:  # a bug: still one line, and the way to the traceback
        if os.environ.get("ADAPTSKY_DEBUG") == "1":
            raise
        reason = (str(error).splitlines() or [""])[0]
        err.print(f"adaptsky: internal error ({type(error).__name__}: {reason}); this is a bug: "
                  "run again with ADAPTSKY_DEBUG=1 for the traceback and report it")
        return 1
    return 0

