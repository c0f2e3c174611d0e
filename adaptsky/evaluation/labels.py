"""Labels of compared run files: the file name, or the shortest tail of its path that tells it
apart from the other labels (``a/run.h5`` and ``b/run.h5``), so that no two methods of an
evaluation share a name in its table, its JSON or its eval file."""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Collection
from pathlib import Path


def distinct_labels(paths: list[Path], taken: Collection[str] = ()) -> list[str]:
    """One label per (distinct) path: its last 1, 2, ... components, as few as make it unique
    among the others and ``taken``."""
    parts = [Path(os.path.abspath(path)).parts for path in paths]  # links keep their names
    depth = [1] * len(paths)
    while True:
        labels = ["/".join(p[-d:]) for p, d in zip(parts, depth, strict=True)]
        counts = Counter(labels)
        clashing = [i for i, label in enumerate(labels)
                    if (counts[label] > 1 or label in taken) and depth[i] < len(parts[i])]
        if not clashing:
            return labels
        for i in clashing:
            depth[i] += 1
