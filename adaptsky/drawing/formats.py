"""The formats a figure is written in (PNG, PDF, SVG) and how: PDF and SVG without a creation
date and SVG's element ids salted with a fixed text, so that the same figure gives the same
bytes every time; PDF with TrueType (Type 42) fonts rather than Type 3, which journals' PDF
checkers (IEEE's PDF eXpress) refuse. Every figure of adaptsky is saved through
:func:`figure_bytes`."""

from __future__ import annotations

import io
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # matplotlib is imported by what draws, not by what checks a format
    from matplotlib.figure import Figure

FIGURE_FORMATS = ("png", "pdf", "svg")
"""What a figure can be written as; a file's suffix names it (``.png``, ``.pdf``, ``.svg``)."""

_METADATA: dict[str, dict[str, Any]] = {"png": {}, "pdf": {"CreationDate": None},
                                        "svg": {"Date": None}}
_RC = {"svg.hashsalt": "adaptsky", "pdf.fonttype": 42}


def figure_bytes(figure: Figure, fmt: str, dpi: float) -> bytes:
    """``figure`` as a file of format ``fmt`` (one of :data:`FIGURE_FORMATS`)."""
    import matplotlib

    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"format {fmt!r}: choose from {', '.join(FIGURE_FORMATS)}")
    data = io.BytesIO()
    with matplotlib.rc_context(_RC):
        figure.savefig(data, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
    return data.getvalue()
