"""Output files written whole or not at all.

Every file netdae writes (raw, CSV, matrix exports, plots) goes through
:func:`atomic_output`: the bytes go to a temporary file in the target's own
directory, which is flushed to the disk and renamed over the target only when
everything was written. A write that fails (the disk is full, the file-size
limit of ``ulimit -f`` is reached, the directory is read-only) removes the
temporary file, leaves any earlier file of that name untouched, and raises
:class:`~netdae.errors.OutputFileError` naming the file and the reason.

Examples
--------
>>> import os, tempfile
>>> folder = tempfile.mkdtemp()
>>> path = os.path.join(folder, "hello.txt")
>>> write_bytes(path, b"hello\\n")
>>> open(path).read(), os.listdir(folder)
('hello\\n', ['hello.txt'])
>>> write_bytes(os.path.join(folder, "missing", "x.txt"), b"")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
netdae.errors.OutputFileError: cannot write .../missing/x.txt: the directory does not exist
"""

from __future__ import annotations

import errno as _errno
import os
import secrets
from contextlib import contextmanager
from typing import BinaryIO, Iterator

from ..errors import OutputFileError

__all__ = ["atomic_output", "write_bytes", "reason_of"]

#: Plain words for the operating system's reasons a write fails.
_REASONS = {
    _errno.ENOSPC: "the disk is full",
    _errno.EDQUOT: "the disk quota is exceeded",
    _errno.EFBIG: "the file-size limit was reached (see 'ulimit -f')",
    _errno.EACCES: "permission denied",
    _errno.EPERM: "permission denied",
    _errno.EROFS: "the file system is read-only",
    _errno.ENOENT: "the directory does not exist",
    _errno.ENOTDIR: "a part of the path is not a directory",
    _errno.EISDIR: "it is a directory",
    _errno.ENAMETOOLONG: "the name is too long",
    _errno.EIO: "input/output error",
}
#: Attempts at a fresh temporary name before giving up (names are random).
_NAME_ATTEMPTS = 16
#: New files get these permissions, less the umask (like ``open(path, "w")``).
_FILE_MODE = 0o666


def reason_of(exc: OSError) -> str:
    """The reason a write failed, in words (``"the disk is full"``).

    Examples
    --------
    >>> import errno
    >>> reason_of(OSError(errno.EFBIG, "File too large"))
    "the file-size limit was reached (see 'ulimit -f')"
    """
    reason = _REASONS.get(exc.errno)
    if reason is None:
        reason = exc.strerror or str(exc) or type(exc).__name__
    return reason


def _create_temporary(path: str) -> tuple[str, int]:
    folder, name = os.path.split(path)
    for _ in range(_NAME_ATTEMPTS):
        temporary = os.path.join(folder, f".{name}.{secrets.token_hex(4)}.tmp")
        try:
            return temporary, os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, _FILE_MODE)
        except FileExistsError:
            continue
    raise OSError(_errno.EEXIST, "no free temporary name")


@contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[BinaryIO]:
    """Open a binary handle whose contents replace ``path`` only on success.

    Parameters
    ----------
    path : str or path-like
        The file to write (overwritten when the block succeeds).

    Yields
    ------
    file object
        A binary file opened on a temporary file next to ``path``.

    Raises
    ------
    OutputFileError
        When the temporary file cannot be created, written, flushed or
        renamed; the temporary file is removed and ``path`` is unchanged.
        Other exceptions raised inside the block also remove the temporary
        file and propagate unchanged.

    Notes
    -----
    The data are flushed with ``fsync`` before the rename, so that a disk that
    fills up while the operating system writes its cache back is reported here
    rather than leaving a short file behind.
    """
    target = os.fspath(path)
    try:
        temporary, descriptor = _create_temporary(target)
    except OSError as exc:
        raise OutputFileError(target, reason_of(exc), exc.errno) from None
    try:
        with os.fdopen(descriptor, "wb") as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, target)
    except OSError as exc:
        _remove(temporary)
        if isinstance(exc, OutputFileError):
            raise
        raise OutputFileError(target, reason_of(exc), exc.errno) from None
    except BaseException:
        _remove(temporary)
        raise


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all (see :func:`atomic_output`).

    Raises
    ------
    OutputFileError
        When the file cannot be written; nothing is left under its name.
    """
    with atomic_output(path) as handle:
        handle.write(data)


def _remove(temporary: str) -> None:
    try:
        os.unlink(temporary)
    except OSError:
        pass  # already gone, or the directory itself vanished
