"""Figure files: the formats a figure is written in (PNG, PDF, SVG), chosen by a path's suffix
or by name, and the one function that writes a drawn figure, whole or not at all.

PDF and SVG carry no creation date and SVG's element ids are salted with a fixed text, so the
same figure gives the same bytes every time; PDF embeds TrueType (Type 42) fonts rather than
Type 3, which journals' PDF checkers (IEEE's PDF eXpress) refuse.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from adaptsky.drawing.formats import FIGURE_FORMATS, figure_bytes
from adaptsky.errors import AdaptskyError
from adaptsky.store.atomic import write_bytes_atomic

if TYPE_CHECKING:  # matplotlib is imported by what draws, not by what checks a format
    from matplotlib.figure import Figure

DPI = 150
"""Pixels per inch of PNG figures (PDF and SVG are vector: their size is in inches)."""


def allowed_formats(prefix: str = "", formats: tuple[str, ...] = FIGURE_FORMATS) -> str:
    """'png, pdf or svg' (with ``prefix`` '.': '.png, .pdf or .svg'), or of ``formats``."""
    names = [f"{prefix}{name}" for name in formats]
    return f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else names[0]


def check_format(name: str, option: str = "--format") -> str:
    """``name`` as a figure format (case aside), or one line naming the option, what was given
    and what is allowed."""
    if name.lower() not in FIGURE_FORMATS:
        raise AdaptskyError(f"{option} {name}: not a figure format; choose {allowed_formats()}")
    return name.lower()


def format_of(path: Path, option: str = "--out", what: str = "a figure file",
              formats: tuple[str, ...] = FIGURE_FORMATS) -> str:
    """The format a path's suffix names (any case) among ``formats``, or one line: a figure
    (or an animation) is never written over a file of another kind (a scenario, a run
    file)."""
    suffix = path.suffix.lower().lstrip(".")
    if suffix not in formats:
        given = f"'{path.suffix}'" if path.suffix else "no suffix"
        raise AdaptskyError(f"{option} {path}: {what} must end in "
                            f"{allowed_formats('.', formats)} (it has {given})")
    return suffix


def save_figure(figure: Figure, path: Path, dpi: int = DPI) -> Path:
    """Write ``figure`` to ``path`` in the format its suffix names, atomically (a copy renamed
    over the file: never half written). Returns ``path``."""
    write_bytes_atomic(path, figure_bytes(figure, format_of(path), dpi))
    return path
