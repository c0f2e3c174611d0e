"""The library's progress (:class:`adaptsky.progress.Reporter`) on a Rich console: live bars
and rows on a terminal, the library's plain lines elsewhere."""

from __future__ import annotations

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from adaptsky.progress import Layout, Reporter


def _columns(layout: Layout) -> tuple[list[ProgressColumn], bool]:
    """The columns of ``layout``'s stages, and whether they vanish when the display ends."""
    if layout == "work":
        return [TextColumn("{task.fields[name]}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("{task.fields[unit]}s"), TimeElapsedColumn(),
                TimeRemainingColumn(), TextColumn("{task.fields[detail]}")], True
    if layout == "seeds":
        return [TextColumn("seed {task.fields[seed]:>3}"), MofNCompleteColumn(),
                TextColumn("R {task.fields[rate]} J {task.fields[fairness]} "
                           "out {task.fields[outage]} {task.fields[epsilon]} "
                           "greedy {task.fields[greedy]}"),
                TextColumn("{task.fields[left]}")], False
    if layout == "trials":
        return [TextColumn("{task.fields[status]}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("trials  {task.fields[eta]}")], False
    return [TextColumn("{task.fields[status]}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("episodes  {task.fields[eta]}")], False


class RichReporter(Reporter):
    """Stages drawn live on ``console`` where it is a terminal (and not ``quiet``)."""

    def __init__(self, console: Console, *, quiet: bool = False) -> None:
        self.console, self.quiet = console, quiet
        self.live = console.is_terminal and not quiet
        self.progress: Progress | None = None
        self.tasks: dict[object, TaskID] = {}

    def print(self, text: str) -> None:
        self.console.print(text, markup=False, highlight=False, soft_wrap=True)

    def open(self, layout: Layout) -> None:
        if self.live:
            columns, transient = _columns(layout)
            self.progress = Progress(*columns, console=self.console, transient=transient)
            self.progress.start()

    def close(self) -> None:
        if self.progress is not None:
            self.progress.stop()
        self.progress, self.tasks = None, {}

    def start(self, key: object, total: int, done: int = 0, **fields: object) -> None:
        if self.progress is not None:
            # detail: where a stage is within its next unit (a search's round and UAV)
            self.tasks[key] = self.progress.add_task("", total=total, completed=done,
                                                     **{"detail": "", **fields})

    def advance(self, key: object, done: float, **fields: object) -> None:
        if self.progress is not None:
            self.progress.update(self.tasks[key], completed=done, **fields)

    def finish(self, key: object) -> None:
        if self.progress is not None:
            self.progress.remove_task(self.tasks.pop(key))
