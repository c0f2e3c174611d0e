"""Consoles shared by the commands: results on stdout, messages on stderr (no markup, no
emoji codes: user text such as `cuda:-1:` or a path with `:smile:` is printed as it is).

When the reader of either goes away (``adaptsky inspect RUN.h5 | head -1``), the next write
raises :class:`OutputClosed`, and the command ends quietly with :data:`OUTPUT_CLOSED_EXIT`
(``main``); Rich's own way, exit code 1 with no word, is not taken."""

from __future__ import annotations

import select
import sys

from rich.console import Console

OUTPUT_CLOSED_EXIT = 141
"""The exit code of a command whose output was closed early: 128 + SIGPIPE, what a shell
reports for a Unix tool that a broken pipe ended (``seq 1000000 | head -1``)."""


class OutputClosed(Exception):
    """Nobody reads the command's output any more (the other end of its pipe is closed)."""


class _Console(Console):
    """A console that stops writing, and raises :class:`OutputClosed`, on a broken pipe."""

    def on_broken_pipe(self) -> None:
        self.quiet = True  # nothing more to write to a pipe nobody reads
        raise OutputClosed(f"the reader of {'stderr' if self.stderr else 'stdout'} is gone")


def stdout_closed() -> bool:
    """Whether stdout is a pipe (or socket) whose reader is gone: a write would fail with a
    broken pipe (poll reports an error or a hang-up on it). False where it cannot be told."""
    try:
        poller = select.poll()
        poller.register(sys.__stdout__.fileno(), select.POLLOUT)
        events = poller.poll(0)
    except (AttributeError, OSError, ValueError):  # no poll, no stdout, a closed one
        return False
    return any(mask & (select.POLLERR | select.POLLHUP) for _, mask in events)


out = _Console(highlight=False, emoji=False)
err = _Console(stderr=True, highlight=False, markup=False, emoji=False, soft_wrap=True)
