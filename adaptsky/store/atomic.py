"""Atomic rewriting of files: changes are made in memory and written to a copy that replaces
the file in one rename, so a writer killed or failing at any moment leaves the file as it was.

HDF5 itself never writes to disk here (it works on an in-memory image): a full disk or a
read-only folder fails one plain ``write``, never HDF5's own flush, which cannot close a file
whose flush failed (the process then dies in a segmentation fault at exit).
"""

from __future__ import annotations

import errno
import io
import os
import re
import shutil
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from datetime import UTC, datetime
from pathlib import Path

import h5py

from adaptsky.errors import AdaptskyError
from adaptsky.store.checksums import seal
from adaptsky.store.links import target

_ADVICE = {
    errno.ENOSPC: "free space on its disk or write elsewhere",
    errno.EDQUOT: "free space within your quota or write elsewhere",
    errno.EFBIG: "the file may not grow larger here: write elsewhere",
    errno.EROFS: "the file system is read-only: write elsewhere",
    errno.EACCES: "check the permissions of the file and its folder, or write elsewhere",
    errno.EPERM: "check the permissions of the file and its folder, or write elsewhere",
    errno.ENOTDIR: "a part of the path is a file, not a folder: choose another path",
    errno.ENOENT: "check the path",
    errno.EISDIR: "it is a folder: give a file name",
    errno.EIO: "the disk reported an input/output error: check it, or write elsewhere",
}


class StorageError(AdaptskyError):
    """The file system refused a read or write: one line naming the path, what failed, the
    system's reason and what to do."""

    def __init__(self, path: Path, action: str, reason: str, advice: str,
                 code: int | None = None) -> None:
        self.path, self.action, self.reason, self.advice, self.code = (
            path, action, reason, advice, code)
        super().__init__(f"{path}: {action} ({reason}); {advice}")

    def with_advice(self, advice: str) -> StorageError:
        """The same failure with other advice (the caller knows better what to do)."""
        return StorageError(self.path, self.action, self.reason, advice, self.code)

    def named(self, path: Path) -> StorageError:
        """The same failure said of ``path`` (the link the caller gave, not its target)."""
        return StorageError(path, self.action, self.reason, self.advice, self.code)


def error_code(error: BaseException) -> int | None:
    """The errno of an OS error, also of HDF5's errors that carry it only in their text."""
    code = getattr(error, "errno", None)
    if isinstance(code, int) and code:
        return code
    found = re.search(r"errno = (\d+)", str(error))
    return int(found.group(1)) if found else None


def error_path(error: BaseException) -> str | None:
    """The file an OS error is about, also of HDF5's errors that name it only in their text."""
    name = getattr(error, "filename", None)
    if name:
        return os.fsdecode(name)
    found = re.search(r"name = '([^']*)'", str(error))
    return found.group(1) if found else None


def storage_error(path: Path | str, action: str, error: BaseException) -> StorageError:
    """``error`` (an OSError, or h5py's wrapper of one) as one line about ``path``."""
    code = error_code(error)
    reason = os.strerror(code) if code else (str(error).splitlines() or ["unknown error"])[0]
    advice = _ADVICE.get(code or 0, "check the path and its file system")
    return StorageError(Path(path), action, reason, advice, code)


def make_parent(path: Path) -> None:
    """Create ``path``'s folder (and its parents) if missing; faults as :class:`StorageError`."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # a part of the path is a file
        raise storage_error(path.parent, "cannot create the folder",
                            OSError(errno.ENOTDIR, os.strerror(errno.ENOTDIR))) from None
    except OSError as error:
        raise storage_error(path.parent, "cannot create the folder", error) from None


def _copy_name(path: Path, pid: int | str) -> Path:
    return path.with_name(f".{path.name}.tmp-{pid}")


class FileGoneError(AdaptskyError):
    """The file being updated was removed or replaced by another while adaptsky worked on it:
    nothing is written (neither over another file nor as a new one)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        super().__init__(f"{path}: the file was removed or replaced while adaptsky was "
                         "updating it; nothing was written, and what it would have stored "
                         "is lost")


# which file a path names and its version: (st_dev, st_ino, st_size, st_mtime_ns); a file
# overwritten in place (cp) changes the last two
Identity = tuple[int, int, int, int]


def _identity_of(info: os.stat_result) -> Identity:
    return info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns


@contextmanager
def rewrite(path: Path, fresh: bool = False) -> Iterator[h5py.File]:
    """Open ``path`` as an in-memory HDF5 image for writing (with ``fresh``, a new file at a
    path that must not exist yet); on success the image replaces ``path`` in one rename. A
    symbolic link is followed: its target is replaced, the link stays (``store.links``). Disk
    faults raise :class:`StorageError` and leave ``path`` as it was; a file removed or
    replaced meanwhile raises :class:`FileGoneError` (it is never created again). Errors name
    ``path`` as given."""
    real = path if fresh else target(path)
    data, identity = b"", None
    if not fresh:
        try:
            with open(real, "rb") as handle:
                identity = _identity_of(os.fstat(handle.fileno()))
                data = handle.read()
        except FileNotFoundError:
            raise FileGoneError(path) from None
        except OSError as error:
            raise storage_error(path, "cannot read it", error) from None
    image = io.BytesIO(data)
    del data
    with h5py.File(image, "a" if image.getbuffer().nbytes else "w") as file:
        yield file
    with image.getbuffer() as view:
        _write_named(real, view, identity, path)


def _write_named(real: Path, data: memoryview, identity: Identity | None, path: Path) -> None:
    """:func:`write_bytes_atomic` of ``real``, its failures said of ``path``."""
    failure: AdaptskyError | None = None
    try:
        write_bytes_atomic(real, data, replaces=identity)
    except FileGoneError:
        failure = FileGoneError(path)
    except StorageError as error:
        failure = error.named(path)
    if failure is not None:
        raise failure  # outside the handler, as in write_bytes_atomic


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # it exists, owned by another user
    return True


def remove_stale_copies(path: Path) -> None:
    """Delete copies of ``path`` left by writers that were killed (their process is gone);
    readers never open them."""
    prefix = _copy_name(path, "").name
    for stale in path.parent.glob(f"{glob_escape(prefix)}*"):
        pid = stale.name[len(prefix):]
        if not pid.isdigit() or not _alive(int(pid)):
            stale.unlink(missing_ok=True)


def glob_escape(text: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", text)


def string_dataset(group: h5py.Group, name: str, text: str) -> None:
    """A text dataset, with its CRC-32 (``store.checksums``)."""
    seal(group.create_dataset(name, data=text, dtype=h5py.string_dtype()), text)


def utc_timestamp() -> str:
    """Now, as stored in ``created_utc`` attributes: 2026-11-22T03:04:15Z."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def fresh_path(directory: Path, prefix: str) -> Path:
    """<directory>/<prefix>-<local time>.h5, with a -2, -3, ... suffix rather than an
    existing file's name."""
    stem = f"{prefix}-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    path, n = directory / f"{stem}.h5", 1
    while path.exists():
        n += 1
        path = directory / f"{stem}-{n}.h5"
    return path


def _check_free_space(path: Path, size_bytes: int) -> None:
    """Refuse at once (ENOSPC) a write that cannot fit (one ``statvfs``, no bytes written)."""
    try:
        free = shutil.disk_usage(path.parent).free
    except OSError:
        return  # the write itself will say what is wrong
    if free < size_bytes:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


def _identity(path: Path) -> Identity | None:
    try:
        return _identity_of(os.stat(path))
    except FileNotFoundError:
        return None


def write_bytes_atomic(path: Path, data: bytes | memoryview,
                       replaces: Identity | None = None) -> None:
    """Write ``data`` to a copy that replaces ``path`` in one rename: never half written.
    Disk faults raise :class:`StorageError`; the copy is removed and ``path`` kept. With
    ``replaces``, only that file, unchanged, is replaced (:class:`FileGoneError` if ``path``
    names another file, a changed one or none by the time of the rename)."""
    tmp = _copy_name(path, os.getpid())
    failure: AdaptskyError | None = None
    try:
        _check_free_space(path, len(data))
        with open(tmp, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        if replaces is not None and _identity(path) != replaces:
            failure = FileGoneError(path)
        else:
            os.replace(tmp, path)
    except OSError as error:
        failure = storage_error(path, "cannot write it", error)
    finally:
        with suppress(OSError):  # never created (a read-only folder): nothing to remove
            tmp.unlink(missing_ok=True)
    if failure is not None:
        raise failure  # outside the handler: no traceback holds the failed write's frames


def write_text_atomic(path: Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


@contextmanager
def written_in_place_of(path: Path) -> Iterator[Path]:
    """A hidden path beside ``path``, with its suffix (for a writer that needs a file name and
    tells the format by it: ffmpeg), that replaces ``path`` in one rename when the block ends
    without error, and is removed when it fails: never a half-written ``path``."""
    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        with open(tmp, "rb") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as error:
        raise storage_error(path, "cannot write it", error) from None
    finally:
        with suppress(OSError):
            tmp.unlink(missing_ok=True)
