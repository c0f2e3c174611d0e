"""Usage errors in one line, and help a person reads.

A usage error (an unknown option, a missing argument or value, a value of the wrong type) is
one line, ``adaptsky train: unknown option --episdoes; did you mean --episodes?``, with exit
code 2 and the fix where one is obvious; :class:`OneLineGroup` turns the parser's errors into
:class:`UsageLine` for ``main`` to print. The help shows metavars (``SEEDS``, ``RUN.h5``),
flags without a type and every command's summary on one line (:func:`readable`).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from difflib import get_close_matches
from types import SimpleNamespace
from typing import Any

from typer.core import TyperGroup

try:  # typer 0.22 and later vendor click
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - older typer uses click itself
    from click import exceptions as click_errors  # type: ignore[no-redef]


class UsageLine(Exception):
    """A usage error of the parser, to be said in one line (:func:`usage_line`)."""

    def __init__(self, error: Any, root: Any) -> None:
        super().__init__(error.format_message())
        self.error, self.root = error, root
        self.exit_code = int(error.exit_code)


@contextmanager
def one_line_usage(root: Any) -> Iterator[None]:
    """Raise the parser's usage errors as :class:`UsageLine` (no help is printed with them);
    a command group called without a command still prints its help."""
    try:
        yield
    except click_errors.UsageError as error:
        if type(error).__name__ == "NoArgsIsHelpError":
            raise
        raise UsageLine(error, root) from None


class OneLineGroup(TyperGroup):
    """The root group: its own and every subcommand's usage errors become :class:`UsageLine`,
    and its help (and every subcommand's) is made :func:`readable` before use."""

    def make_context(self, info_name: str | None, args: list[str], parent: Any = None,
                     **extra: Any) -> Any:
        readable(self)
        with one_line_usage(self):
            return super().make_context(info_name, args, parent, **extra)

    def invoke(self, ctx: Any) -> Any:
        with one_line_usage(self):
            return super().invoke(ctx)


def readable(command: Any) -> None:
    """Help a person reads, for ``command`` and every subcommand: flags (``--help`` too) show
    no type, other parameters a metavar (their name in capitals where none is declared), and a
    command's summary (the first paragraph of its help) is one line."""
    for param in command.params:
        if getattr(param, "is_flag", False) and not getattr(param, "count", False):
            param.metavar = param.metavar or ""
        elif param.metavar is None:
            param.metavar = (param.name or "value").upper()
        if param.param_type_name == "argument":
            _plain_argument(param)
    if hasattr(command, "_help_option"):  # typer's click makes --help once, when first asked
        help_option = command.get_help_option(SimpleNamespace(help_option_names=["--help"]))
        if help_option is not None:
            help_option.metavar = ""
    if command.help and not command.short_help:
        command.short_help = " ".join(command.help.split("\n\n")[0].split())
    for sub in getattr(command, "commands", {}).values():
        readable(sub)


def _plain_argument(param: Any) -> None:
    """An argument shown by its metavar alone: ``RUN.h5``, ``[SCENARIO.toml]`` in the usage
    line, no type beside it (typer 0.2x writes ``{run}`` and ``<path>``)."""
    many = "..." if param.nargs != 1 and not param.metavar.endswith("...") else ""
    usage = f"{param.metavar}{many}" if param.required else f"[{param.metavar}]{many}"
    param._usage_display_name = lambda: usage
    param.display_type_rich = lambda ctx: None


# ---- the one line ------------------------------------------------------------------------

def usage_line(usage: UsageLine, argv: list[str]) -> str:
    """A usage error of the parser as one line: the command, what is wrong, and the fix where
    it is obvious, else where the help is."""
    error, ctx = usage.error, usage.error.ctx
    command = ctx.command_path if ctx is not None else _command_path(usage.root, argv)
    see = f"see '{command} --help'"
    if isinstance(error, click_errors.NoSuchOption):
        fix = _closest(error.option_name, _option_names(ctx))
        return (f"{command}: unknown option {error.option_name}; "
                + (f"did you mean {fix}?" if fix else see))
    extra = re.fullmatch(r"Got unexpected extra argument(?:s|\(s\))? \((.*)\)", error.message)
    if extra:
        return f"{command}: unexpected argument '{extra.group(1)}'; " + (
            _key_value_fix(argv, extra.group(1).split(), _key_value_options(ctx)) or see)
    if isinstance(error, click_errors.MissingParameter):
        return f"{command}: missing {_param_words(error)}; {see}"
    if isinstance(error, click_errors.BadParameter) and error.param is not None:
        split = _split_key_value(argv, error.param)
        if split:
            return f"{command}: {split}"
        return f"{command}: {_hint(error.param)}: {_sentence(error.message)}; {see}"
    said = _sentence(error.format_message())
    return f"{command}: {said}" if "did you mean" in said else f"{command}: {said}; {see}"


def _command_path(root: Any, argv: list[str]) -> str:
    """The command ``argv`` names (``adaptsky scenario show``), as far as it names one."""
    words, command = [root.name or "adaptsky"], root
    for word in argv:
        sub = getattr(command, "commands", {}).get(word)
        if sub is None:
            if not word.startswith("-"):
                break
            continue
        words.append(word)
        command = sub
    return " ".join(words)


def _sentence(text: str) -> str:
    """Sentences as clauses of one line: ``No such command 'x'. Did you mean 'y'?`` ->
    ``no such command 'x'; did you mean 'y'?`` ("e.g." ends no sentence)."""
    text = re.sub(r"^value error, ", "", " ".join(text.split()), flags=re.IGNORECASE)
    parts = [part.strip() for part in re.split(r"(?<=\.)(?<!e\.g\.)(?<!i\.e\.)\s+", text)]
    clauses = [part[:1].lower() + part[1:].rstrip(".") for part in parts if part]
    return "; ".join(clauses)


def _hint(param: Any) -> str:
    """How a person names a parameter: its longest option, or an argument's metavar."""
    if param.param_type_name == "option":
        return max(param.opts, key=len)
    return str(param.metavar or (param.name or "").upper())


def _param_words(error: Any) -> str:
    param = error.param
    if param is None:
        return _sentence(error.format_message()).removeprefix("missing ")
    kind = "option" if param.param_type_name == "option" else "argument"
    return f"{kind} {_hint(param)}"


def _option_names(ctx: Any) -> list[str]:
    if ctx is None:
        return []
    return [name for param in ctx.command.get_params(ctx) if param.param_type_name == "option"
            for name in (*param.opts, *param.secondary_opts)]


def _closest(word: str, choices: list[str]) -> str | None:
    """The choice ``word`` most likely misspells (a letter or two off), if any."""
    found = get_close_matches(word.split("=", 1)[0], choices, n=1, cutoff=0.75)
    return found[0] if found else None


def _key_value_options(ctx: Any) -> set[str]:
    """The options that take ``KEY=VALUE`` in one word (``--set``, ``--param``)."""
    if ctx is None:
        return {"--set"}
    return {name for param in ctx.command.get_params(ctx) if param.metavar == "KEY=VALUE"
            for name in param.opts}


def _split_key_value(argv: list[str], param: Any) -> str | None:
    """``--set reward.min_se 1``, refused by ``--set``'s check of its value: said as the word
    too many, with the fix."""
    if param.metavar != "KEY=VALUE":
        return None
    for index, word in enumerate(argv[:-2]):
        key, value = argv[index + 1], argv[index + 2]
        if word in param.opts and "=" not in key and not value.startswith("-"):
            return f"unexpected argument '{value}'; did you mean {word} {key}={value}?"
    return None


def _key_value_fix(argv: list[str], extra: list[str], options: set[str]) -> str | None:
    """``--set reward.min_se 1``: the value was given as a word of its own."""
    for index, word in enumerate(argv[:-2]):
        key, value = argv[index + 1], argv[index + 2]
        if word in options and "=" not in key and value == (extra or [None])[0]:
            return f"did you mean {word} {key}={value}?"
    return None
