"""Output files written whole or not at all, and result files written as the run goes on.

Every file netdae writes (raw, CSV, matrix exports, plots) goes through
:func:`atomic_output`, except a transient's result file streamed while the
run computes it (:class:`StreamedFile`, below): the bytes go to a temporary file in the target's own
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

__all__ = ["atomic_output", "write_bytes", "csv_text", "reason_of", "StreamedFile"]

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
    A target that exists and is not a regular file (a device such as
    ``/dev/full`` or ``/dev/null``, a FIFO) is written into directly, never
    replaced; a directory is refused. The data are flushed with ``fsync`` before the rename, so that a disk that
    fills up while the operating system writes its cache back is reported here
    rather than leaving a short file behind.
    """
    target = os.fspath(path)
    special = _special_file(target)
    if special is not None:
        yield from _write_through(target, special)
        return
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


def _special_file(target: str) -> str | None:
    """What ``target`` is when it exists and is not a regular file (None: a regular file or nothing yet).

    A device (``/dev/null``, ``/dev/full``, ``/dev/stdout``), a FIFO or a socket
    is written into, never renamed over: replacing ``/dev/full`` with a plot
    would break the system for everyone.
    """
    import stat

    try:
        mode = os.stat(target).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "directory"
    return "device"


def _write_through(target: str, special: str) -> Iterator[BinaryIO]:
    """:func:`atomic_output` on a device or FIFO: the bytes go straight into it, errors said as for a file."""
    if special == "directory":
        raise OutputFileError(target, reason_of(OSError(_errno.EISDIR, "Is a directory")), _errno.EISDIR)
    try:
        with open(target, "wb") as handle:
            yield handle
            handle.flush()
    except OSError as exc:
        if isinstance(exc, OutputFileError):
            raise
        raise OutputFileError(target, reason_of(exc), exc.errno) from None


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all (see :func:`atomic_output`).

    Raises
    ------
    OutputFileError
        When the file cannot be written; nothing is left under its name.
    """
    with atomic_output(path) as handle:
        handle.write(data)


def csv_text(columns, rows) -> str:
    """A header row ``columns`` and then ``rows`` as CSV text (the ``csv`` module's quoting, ``\\n`` line ends).

    Examples
    --------
    >>> print(csv_text(["name", "reason"], [["x", "never, at all"]]), end="")
    name,reason
    x,"never, at all"
    """
    import csv
    import io

    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows(rows)
    return out.getvalue()


def _remove(temporary: str) -> None:
    try:
        os.unlink(temporary)
    except OSError:
        pass  # already gone, or the directory itself vanished


class StreamedFile:
    """A result file written point by point while the run that computes the points goes on.

    The one exception to whole-or-nothing: a long transient's file holds what
    was computed however the run ends. The file is created under its own name
    when the first points arrive (an earlier file of that name is replaced
    then), each block of points is appended and handed to the operating
    system at once (a killed process leaves every block written before), and
    :meth:`close` patches the header (a raw file's point count) and flushes
    the file to the disk. A write that fails (the disk is full, the file-size
    limit) cuts the file back to its last complete point, keeps it, and
    records why in :attr:`error`; later blocks are refused with that reason.

    Subclasses format: :meth:`_header` (the bytes before the first point and
    where the count to patch is) and :meth:`_rows`.

    Attributes
    ----------
    path : str
    points : int
        Points written.
    last : float or None
        The axis value of the last point written.
    names : list of str
        The columns, fixed by the first block.
    error : str or None
        Why the file stopped taking points (``"the disk is full"``).
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.points = 0
        self.last: float | None = None
        self.names: list[str] = []
        self.error: str | None = None
        self._handle: BinaryIO | None = None
        self._end = 0  # bytes up to the end of the last complete point (0: the header is not written yet)
        self._head = b""
        self._count_at: int | None = None  # where the header's count is patched

    @property
    def opened(self) -> bool:
        """True once the file was created (its first points arrived)."""
        return self._handle is not None or self.points > 0 or self.error is not None

    def write(self, start: int, block) -> str | None:
        """Append the points of ``block`` (a Result) from position ``start`` on.

        Points already written (``start`` below :attr:`points`, a block handed
        over again after an interrupted call) are skipped.

        Returns
        -------
        str or None
            Why the file takes no more points (the run should stop), or None.

        Raises
        ------
        ValueError
            For a block that leaves a gap after the points written, or whose
            columns differ from the first block's (a caller's error).
        """
        if self.error is not None:
            return self.stop_reason()
        skip = self.points - start
        if skip < 0:
            raise ValueError(f"{self.path}: points {self.points} to {start - 1} were never handed over")
        axis = block.axis
        count = (0 if axis is None else axis.size) - skip
        if count <= 0:
            return None
        if skip:
            block = _tail(block, skip)
        if self._handle is None:
            self._head, self._count_at, self.names = self._header(block)
            try:
                self._handle = open(self.path, "wb", buffering=0)  # each write goes to the system at once
            except OSError as exc:
                return self._failed(exc)
        elif list(block.axes) + list(block.signals) != self.names:
            raise ValueError(f"{self.path}: a block's columns differ from the file's")
        data = self._rows(block, self.points)
        try:
            # from the end of the last complete point: what a Ctrl-C cut short is written again
            if self._handle.tell() != self._end:
                self._handle.truncate(self._end)
                self._handle.seek(self._end)
            if self._end == 0:
                _write_all(self._handle, self._head)
                self._end = len(self._head)
            _write_all(self._handle, data)
        except OSError as exc:
            return self._failed(exc)
        self._end += len(data)
        self.points += count
        self.last = float(block.axis[-1])
        return None

    def stop_reason(self) -> str:
        """What the run is told when the file takes no more points."""
        return f"cannot write {self.path}: {self.failure()}"

    def failure(self) -> str:
        """Why the file took no more points, and what it holds."""
        where = (f"it holds the {self.points:,} points up to {self.last:.9g}" if self.last is not None
                 else "nothing was left")
        return f"{self.error} ({where})"

    def close(self) -> None:
        """Patch the header's count and flush the file to the disk (nothing when it was never created).

        Raises
        ------
        OutputFileError
            When the file cannot be completed (its points stay, :attr:`error` says why).
        """
        handle, self._handle = self._handle, None
        if handle is None:
            return
        try:
            if self._count_at is not None:
                handle.seek(self._count_at)
                _write_all(handle, self._count(self.points))
            os.fsync(handle.fileno())
        except OSError as exc:
            self.error = self.error or reason_of(exc)
            raise OutputFileError(self.path, self.error, exc.errno) from None
        finally:
            handle.close()

    def _failed(self, exc: OSError) -> str:
        """Cut the file back to its last complete point and keep why (the run is then told to stop);
        a file that holds no point is removed."""
        self.error = reason_of(exc)
        if self._handle is not None and self.points == 0:
            self._handle.close()
            self._handle = None
            _remove(self.path)
        elif self._handle is not None:
            try:
                self._handle.truncate(self._end)
            except OSError:
                pass  # the file system refuses even that: read_raw tells a cut point from a complete one
        return self.stop_reason()

    def _header(self, block) -> tuple[bytes, int | None, list[str]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _rows(self, block, first: int) -> bytes:  # pragma: no cover - abstract
        raise NotImplementedError

    def _count(self, points: int) -> bytes:  # pragma: no cover - abstract
        raise NotImplementedError


def _write_all(handle, data: bytes) -> None:
    """Write all of ``data`` to an unbuffered file (a write may take only a part)."""
    view = memoryview(data)
    while view:
        done = handle.write(view)
        if not done:
            raise OSError(_errno.EIO, "nothing written")
        view = view[done:]


def _tail(block, skip: int):
    """A Result of the points of ``block`` from ``skip`` on."""
    from dataclasses import replace

    return replace(block, axes={k: v[skip:] for k, v in block.axes.items()},
                   signals={k: v[skip:] for k, v in block.signals.items()})
