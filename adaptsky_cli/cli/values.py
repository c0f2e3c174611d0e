"""Option values as the parser checks them, before any work: every list option takes its items
comma-separated, repeated or both (``--log tensorboard,csv`` = ``--log tensorboard --log csv``),
and a value that is malformed, out of its range or not among its choices is a usage error (one
line, exit 2), as an unknown option is. What only the files can tell (a seed a run lacks, a
layout an evaluation lacks, a scenario key) is the command's error, exit 1.

Each ``*_value`` is a Typer callback: it returns the value as given (provenance repeats it) or
raises :func:`usage_error`; the command reads the value with :func:`split_list` and the
library's own functions.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable

from adaptsky.errors import AdaptskyError
from adaptsky_cli.cli.usage import click_errors

_DEVICE = re.compile(r"cpu|cuda(?::\d+)?|auto")
_STUDY = re.compile(r"[A-Za-z0-9_.-]+")


MAX_SEEDS = 1000
"""The most seeds one run trains (``train.seeds``, docs/scenario-format.md)."""
_SEEDS_ITEM = re.compile(r"(\d+)(?:-(\d+))?")


def parse_seeds(text: str | list[str] | None) -> list[int] | None:
    """``--seeds``: integers >= 0 and ranges ``a-b`` (both ends included), comma-separated
    (or given as several words: the option repeated), each seed once, in the order given:
    ``0-2,7`` -> [0, 1, 2, 7]; None where not given."""
    if text is None or (not isinstance(text, str) and not text):
        return None
    text = ",".join(split_list(text))
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


def split_list(values: Iterable[str] | str | None) -> list[str]:
    """The items of a list option, comma-separated, repeated or both, in order:
    ``["tensorboard,csv"]`` and ``["tensorboard", "csv"]`` -> ``["tensorboard", "csv"]``;
    blanks around items are dropped."""
    if values is None:
        return []
    words = [values] if isinstance(values, str) else list(values)
    return [item.strip() for word in words for item in word.split(",")]


def usage_error(message: str) -> Exception:
    """A malformed or out-of-range option value: one line and exit 2 (the parser adds the
    command and the option: ``adaptsky train: --seeds: ...``)."""
    return click_errors.BadParameter(message)


def _refused(check: Callable[[], object], option: str) -> None:
    """Run a library check of an option's value; its one-line refusal (``--opt: why``)
    becomes a usage error."""
    try:
        check()
    except (AdaptskyError, ValueError) as error:
        raise usage_error(str(error).removeprefix(f"{option}: ")) from None


def _choices(values: list[str], allowed: Iterable[str], what: str) -> None:
    allowed = list(allowed)
    for item in values:
        if item not in allowed:
            raise usage_error(f"unknown {what} '{item}'; choose from {', '.join(allowed)}")


def _each_once(values: list[str], what: str) -> None:
    repeated = sorted({item for item in values if values.count(item) > 1})
    if repeated:
        raise usage_error(f"{', '.join(repeated)} given more than once; give each {what} "
                          "once")


def seeds_value(value: list[str] | None) -> list[str] | None:
    """``--seeds``: integers >= 0 and ranges (``options.parse_seeds``)."""
    if value:
        _refused(lambda: parse_seeds(",".join(value)), "--seeds")
    return value


def log_value(value: list[str] | None) -> list[str] | None:
    """``--log``: tensorboard, csv or both."""
    if value:
        from adaptsky.training.logs import LOG_KINDS

        _choices(split_list(value), LOG_KINDS, "kind")
    return value


def metric_value(value: list[str] | None) -> list[str] | None:
    """``--metric``: known metrics, each once."""
    if value:
        from adaptsky.report.plot_metrics import parse_metrics

        _refused(lambda: parse_metrics(",".join(split_list(value))), "--metric")
    return value


def method_value(value: str) -> str:
    """``baseline --method``: one of the baselines."""
    from adaptsky.evaluation.api import BASELINES

    _choices([value], BASELINES, "method")
    return value


def policy_value(value: str | None) -> str | None:
    """``--policy``: best or last."""
    if value is not None:
        _choices([value], ("best", "last"), "policy")
    return value


def profile_value(value: str | None) -> str | None:
    """``plot --profile``: last or best."""
    if value is not None:
        _choices([value], ("last", "best"), "policy")
    return value


def format_value(value: str | None) -> str | None:
    """``--format``: a figure format (png, pdf, svg; case aside)."""
    if value is not None:
        from adaptsky.drawing.formats import FIGURE_FORMATS

        if value.lower() not in FIGURE_FORMATS:
            raise usage_error(f"'{value}' is not a figure format; choose from "
                              f"{', '.join(FIGURE_FORMATS)}")
    return value


def device_value(value: str) -> str:
    """``--device``: cpu, cuda, cuda:N or auto (whether CUDA is here: the command says)."""
    if not _DEVICE.fullmatch(value):
        raise usage_error(f"'{value}' is not a device; give cpu, cuda, cuda:N or auto")
    return value


def _key_values(value: list[str] | None, shape: str, example: str) -> list[str] | None:
    for item in value or []:
        key, sep, _ = item.partition("=")
        if not sep or not all(part.strip() for part in key.split(".")):
            raise usage_error(f"'{item}' is not {shape}; e.g. {example}")
    return value


def set_value(value: list[str] | None) -> list[str] | None:
    """``--set``: section.key=value (or section=table), repeatable (a value may hold commas:
    never split)."""
    return _key_values(value, "section.key=value", "reward.min_se=1.5")


def param_value(value: list[str] | None) -> list[str] | None:
    """``plugins check --param``: KEY=VALUE, repeatable."""
    return _key_values(value, "KEY=VALUE", "carrier_hz=3.5e9")


def study_value(value: str | None) -> str | None:
    """``tune --study``: a name of letters, digits, '.', '_' and '-'."""
    if value is not None and not _STUDY.fullmatch(value):
        raise usage_error(f"'{value}' is not a study name; use letters, digits, '.', '_' "
                          "and '-'")
    return value


def conflict(message: str) -> Exception:
    """Options that exclude each other: a usage error, one line, exit 2."""
    return click_errors.UsageError(message)
