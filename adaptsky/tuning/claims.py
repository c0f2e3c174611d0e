"""Which process works on which trial: an OS lock on ``.trial-NNNN.claim`` in the study's
folder, held while a process trains that trial.

``fcntl.flock`` is released by the kernel when its holder dies (kill -9 included), so a trial
that the study calls running but whose claim anyone can take has lost its process: the taker
continues it from its run file's last checkpoint (:mod:`adaptsky.tuning.study`). Processes
on several machines share claims where they share the folder.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

from adaptsky.store.atomic import storage_error


def claim_path(folder: Path, number: int) -> Path:
    return folder / f".trial-{number:04d}.claim"


class Claim:
    """The lock of one trial, held from :meth:`take` until :meth:`release`."""

    def __init__(self, folder: Path, number: int) -> None:
        self.path, self.number = claim_path(folder, number), number
        self._fd: int | None = None

    def take(self) -> bool:
        """True if this process now holds the trial (nobody else does)."""
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            raise storage_error(self.path, "cannot create a trial's claim", error) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return False
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self._fd = fd
        return True

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> Claim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def is_held(folder: Path, number: int) -> bool | None:
    """True while a process holds trial ``number``; False where its claim is free; None where
    it has no claim file (a process that has just asked for it, or one on a machine that does
    not share the folder)."""
    path = claim_path(folder, number)
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
    return False
