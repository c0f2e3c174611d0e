"""The open ground of a world (docs/model.md §12): the share of the area that no building's
footprint covers, where users drawn in the streets can stand (docs/scenario-format.md)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

MIN_OPEN_SHARE = 0.01
"""The least share of the area left open for users drawn in the streets (``users.placement``
uniform, fresh or hotspots): a user is drawn until it stands off every footprint, 1 / share
draws on average; at 1% the bound of 10,000 draws fails with a chance below e^-100."""


def open_ground_share(footprints_m: Sequence[Sequence[float]], half_m: float) -> float:
    """The share of the square |x|, |y| <= ``half_m`` covered by no footprint
    [x_min, x_max, y_min, y_max], m (overlaps counted once; the parts outside the square left
    out): the exact area of the union, strip by strip between the footprints' x edges."""
    boxes = [(max(x0, -half_m), min(x1, half_m), max(y0, -half_m), min(y1, half_m))
             for x0, x1, y0, y1 in footprints_m]
    boxes = [b for b in boxes if b[0] < b[1] and b[2] < b[3]]
    edges = sorted({x for b in boxes for x in b[:2]})
    covered_m2 = 0.0
    for left, right in itertools.pairwise(edges):
        spans = sorted((b[2], b[3]) for b in boxes if b[0] <= left and b[1] >= right)
        length_m, top = 0.0, -half_m
        for low, high in spans:
            if high > top:
                length_m += high - max(low, top)
                top = high
        covered_m2 += (right - left) * length_m
    return max(0.0, 1.0 - covered_m2 / (2 * half_m) ** 2)
