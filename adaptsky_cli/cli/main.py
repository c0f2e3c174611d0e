"""Entry point of the ``adaptsky`` command.

Errors of the project's own kind print one line (per problem) and exit 1, usage errors (an
unknown option, a missing argument, a value of the wrong type) one line and exit 2;
``ADAPTSKY_DEBUG=1`` shows the traceback instead. A file a command reads that cannot be read
(missing, unreadable) is the command's error, exit 1, never a usage error. Output whose reader
went away (``adaptsky inspect RUN.h5 | head -1``) ends the command quietly, exit code 141
(``console.OUTPUT_CLOSED_EXIT``); a file it was writing is whole or not there (atomic writes).
"""

from __future__ import annotations

import os
import sys
from typing import Any

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
    tune_cmd,
)
from adaptsky_cli.cli.console import OUTPUT_CLOSED_EXIT, OutputClosed, err, stdout_closed
from adaptsky_cli.cli.usage import OneLineGroup, UsageLine, usage_line


class _Root(OneLineGroup):
    """The root group, whose commands open the files they are given themselves."""

    def make_context(self, info_name: str | None, args: list[str], parent: Any = None,
                     **extra: Any) -> Any:
        _opened_by_the_commands(self)
        return super().make_context(info_name, args, parent, **extra)


def _opened_by_the_commands(command: Any) -> None:
    """No path parameter of ``command`` or its subcommands is checked by the parser: Click
    refuses an existing path it may not read as a usage error (exit 2) before the command
    runs; the command's own reading says it in one line, ``FILE: cannot read ...``, exit 1."""
    for param in command.params:
        # Typer's own path type (0.2x, its ParameterInfo) or Click's Path (older Typer)
        info = getattr(getattr(param, "type_descriptor", None), "parameter_info", None)
        for checks in (info, getattr(param, "type", None)):
            if isinstance(getattr(checks, "readable", None), bool):
                checks.readable = False
    for sub in getattr(command, "commands", {}).values():
        _opened_by_the_commands(sub)


app = typer.Typer(name="adaptsky", no_args_is_help=True, pretty_exceptions_enable=False,
                  cls=_Root,
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
app.command()(tune_cmd.tune)


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


def _output_closed(done: SystemExit) -> bool:
    """Whether ``done`` is how Click (a plain ``print``) or Rich (Typer's help) ended a write
    to a stdout nobody reads any more (both exit 1 with no word)."""
    error: BaseException | None = done
    while error is not None and not isinstance(error, BrokenPipeError):
        error = error.__cause__ or error.__context__
    if error is None:
        return False
    frame = done.__traceback__
    while frame is not None and frame.tb_next is not None:
        frame = frame.tb_next
    # Rich has already put /dev/null in place of stdout: poll cannot tell any more
    by_rich = frame is not None and frame.tb_frame.f_code.co_name == "on_broken_pipe"
    return by_rich or stdout_closed()


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv``; return the exit code (never raises for user errors)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        app(args=argv, prog_name="adaptsky")  # standalone: ends with SystemExit
    except SystemExit as done:
        if _interrupted(done):
            err.print("interrupted")  # Typer ends a Ctrl-C with a silent exit 130
        if done.code == 1 and _output_closed(done):
            return OUTPUT_CLOSED_EXIT
        return done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    except UsageLine as usage:
        err.print(usage_line(usage, argv))
        return usage.exit_code
    except OutputClosed:
        return OUTPUT_CLOSED_EXIT
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

