"""One writer per run file: an OS-level lock on a sidecar ``.NAME.h5.lock``.

The run file itself is replaced by a rename at every checkpoint, so the lock lives beside it.
``fcntl.flock`` is released by the kernel when its holder dies (kill -9 included), so a lock
is never stale; the file holds the writer's PID for the message a second writer gets.
Readers (``inspect``, ``eval``) do not lock; :func:`writer_of` tells them whether a writer is
at work. A run file reached through a symbolic link is locked at the link's target, beside it
(``store.links``): a writer through the link and one through the file's own path exclude each
other.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from adaptsky.errors import AdaptskyError
from adaptsky.store.atomic import remove_stale_copies, storage_error
from adaptsky.store.links import pinned, target


class RunLockedError(AdaptskyError):
    """Another process writes the run file."""


def lock_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.lock")


def _holder(lock: Path) -> str:
    try:
        pid = lock.read_text().strip()
    except OSError:
        pid = ""
    return f"process {pid}" if pid.isdigit() else "another process"


def writer_of(path: Path) -> str | None:
    """"process PID" (or "another process") while a writer holds the lock of ``path``, else
    None; the lock file is never created here."""
    lock = lock_path(target(path))
    try:
        fd = os.open(lock, os.O_RDONLY)
    except OSError:
        return None  # no lock file: no writer (or one we cannot see; then it says so itself)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return _holder(lock)
    except OSError:
        return None
    finally:
        os.close(fd)  # releases the shared lock taken to look
    return None


def _acquire(path: Path, real: Path) -> int:
    """An open descriptor holding the lock of ``real``, the file ``path`` names (refuses one
    held elsewhere; messages name ``path``)."""
    lock = lock_path(real)
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            raise storage_error(path, f"cannot create its lock file {lock.name}", error) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise RunLockedError(
                f"{path}: in use by {_holder(lock)} (a train, --resume or reproduce writing "
                "it); wait for it to end or stop it, then try again") from None
        try:  # the holder before us may have removed the file we locked: lock the new one
            same = os.path.samestat(os.fstat(fd), os.stat(lock))
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)


@contextmanager
def run_lock(path: Path) -> Iterator[None]:
    """Hold the writer's lock of the run file ``path`` while the block runs; copies left by a
    writer killed earlier (only the lock holder writes them) are removed first. Through a
    symbolic link, the file locked is its target, and ``path`` names that file until the block
    ends (:func:`adaptsky.store.links.pinned`)."""
    with pinned(path) as real:
        fd = _acquire(path, real)
        try:
            try:
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode())
            except OSError:
                pass  # a full disk: the lock holds all the same, only its message lacks the PID
            remove_stale_copies(real)
            yield
        finally:
            lock_path(real).unlink(missing_ok=True)
            os.close(fd)
