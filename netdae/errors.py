"""netdae's exception hierarchy, organised by meaning.

Every error netdae raises on purpose derives from :class:`NetdaeError`, so a
caller (and the CLI) can catch one root class and show one readable message.

- :class:`NetlistError` (also a :class:`ValueError`): the text of a netlist is
  wrong. Carries the file, line and column, the expected form of the card and
  a hint.
- :class:`CircuitError`: the netlist is well formed but the circuit it
  describes cannot be simulated (a loop of voltage sources, a floating node,
  a singular coupling matrix ...). Names the elements and nodes involved.
- :class:`SingularPencilError`: the pencil (E, H) of a DAE is singular, so the
  DAE has no or infinitely many solutions.
- :class:`ConvergenceError` (also a :class:`RuntimeError`): a numerical
  method failed; carries the time, step size, worst unknown and a hint.
- :class:`NgspiceError`: the reference simulator is missing or failed.
- :class:`ResultFileError` (also a :class:`ValueError`): a result file (ngspice
  raw, CSV) cannot be read.
- :class:`OutputFileError` (also an :class:`OSError`): an output file (raw,
  CSV, matrices, plot) cannot be written; names the file and the reason.

Examples
--------
>>> from netdae.errors import NetlistError, SourceLocation
>>> err = NetlistError("C1: expected a value", SourceLocation("rc.cir", 12, 4),
...                    expected="Cname n+ n- value [ic=v0]", hint="add a capacitance, e.g. 1u")
>>> print(err)
rc.cir:12:4: C1: expected a value (expected: Cname n+ n- value [ic=v0]; hint: add a capacitance, e.g. 1u)
>>> isinstance(err, ValueError)
True
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "SourceLocation",
    "NetdaeError",
    "NetlistError",
    "CircuitError",
    "SingularPencilError",
    "ConvergenceError",
    "NgspiceError",
    "ResultFileError",
    "OutputFileError",
    "error_record",
    "count_text",
    "size_text",
]


def count_text(value: float) -> str:
    """A count or size for an error message: digits grouped up to 1e15, then in powers of ten.

    A refused sweep of ``1/1e-300`` points is shown as ``1e+300``, not as three
    hundred digits.

    Examples
    --------
    >>> count_text(1234567), count_text(2.5e30), count_text(float("inf"))
    ('1,234,567', '2.5e+30', 'infinitely many')
    """
    if value != value or value in (float("inf"), float("-inf")):
        return "infinitely many"
    return f"{value:,.0f}" if abs(value) < 1e15 else f"{value:.3g}"


#: Binary units of :func:`size_text`, each 1024 times the one before.
_SIZE_UNITS = ("bytes", "KiB", "MiB", "GiB")


def size_text(nbytes: float) -> str:
    """A size in bytes for an error message, in the largest unit (up to GiB) in which it is at least 1.

    A transient's file refused on a nearly full disk is shown as ``1.9 MiB``, not as ``0.0 GiB``.

    Examples
    --------
    >>> size_text(2_000_000), size_text(745.1 * 2**30), size_text(512), size_text(2.5e30)
    ('1.9 MiB', '745.1 GiB', '512 bytes', '2.33e+21 GiB')
    """
    if nbytes != nbytes or nbytes in (float("inf"), float("-inf")):
        return "infinitely many bytes"
    value, k = float(nbytes), 0
    while k < len(_SIZE_UNITS) - 1 and abs(value) >= 1024.0:
        value, k = value / 1024.0, k + 1
    if k == 0:
        return f"{value:,.0f} bytes"
    return f"{value:,.1f} {_SIZE_UNITS[k]}" if abs(value) < 1e15 else f"{value:.3g} {_SIZE_UNITS[k]}"


@dataclass(frozen=True, slots=True)
class SourceLocation:
    """A place in a netlist file.

    Parameters
    ----------
    file : str
        Path of the file as given by the user, or ``"<string>"`` for text.
    line : int
        1-based line number (of the first physical line of a card).
    column : int
        1-based column.
    """

    file: str
    line: int
    column: int = 1

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


class NetdaeError(Exception):
    """Root of every error netdae raises on purpose."""


class NetlistError(NetdaeError, ValueError):
    """The netlist text is wrong.

    Parameters
    ----------
    message : str
        What is wrong, starting with the element or card name when there is one.
    location : SourceLocation, optional
        Where it is wrong.
    expected : str, optional
        The expected form of the card, e.g. ``"Rname n+ n- value"``.
    hint : str, optional
        What the user might do about it.
    """

    def __init__(
        self,
        message: str,
        location: SourceLocation | None = None,
        *,
        expected: str | None = None,
        hint: str | None = None,
    ) -> None:
        self.message = _elide_quoted(message)
        self.location = location
        self.expected = expected
        self.hint = hint
        super().__init__(self._render())

    def _render(self) -> str:
        text = f"{self.location}: {self.message}" if self.location else self.message
        extra = []
        if self.expected:
            extra.append(f"expected: {self.expected}")
        if self.hint:
            extra.append(f"hint: {self.hint}")
        if extra:
            text += " (" + "; ".join(extra) + ")"
        return text

    def __reduce__(self):  # keep pickling (multiprocessing, pytest-xdist) working
        return (
            _rebuild_netlist_error,
            (self.message, self.location, self.expected, self.hint),
        )


#: Longest quoted text (a token, a file name) a message shows in full; a longer one, such as a
#: 200,000-digit number on a very long line, is shown by its ends and its length.
QUOTED_LIMIT = 500


def _elide_quoted(message: str) -> str:
    """``message`` with every quoted text or word longer than :data:`QUOTED_LIMIT` cut to its ends.

    >>> _elide_quoted("value '" + "1" * 1000 + "' is out of range")
    "value '1111111111111111111111111111111111111111...1111111111' (1,000 characters) is out of range"
    """
    import re

    def cut(m: re.Match) -> str:
        quoted = m.group(1) is not None
        text = m.group(1) if quoted else m.group(0)
        short = f"{text[:40]}...{text[-10:]}"
        return f"'{short}' ({len(text):,} characters)" if quoted else short

    if len(message) <= QUOTED_LIMIT:
        return message
    return re.sub(r"'([^'\n]{%d,})'|[^\s']{%d,}" % (QUOTED_LIMIT + 1, QUOTED_LIMIT + 1), cut, message)


def _rebuild_netlist_error(message, location, expected, hint):
    return NetlistError(message, location, expected=expected, hint=hint)


class CircuitError(NetdaeError):
    """The circuit cannot be simulated as described.

    Parameters
    ----------
    message : str
        The explanation in circuit terms.
    elements : sequence of str, optional
        Names of the elements involved (ngspice-style full names).
    nodes : sequence of str, optional
        Names of the nodes involved.
    hint : str, optional
        What the user might do about it.
    location : SourceLocation, optional
        Where the netlist writes what is wrong (the element's card, a model
        parameter's value); kept as ``location`` and shown in front of the
        message, as a :class:`NetlistError` shows its own.

    Examples
    --------
    >>> err = CircuitError("d1: model 'dx' is not defined", elements=("d1",), location=SourceLocation("a.cir", 4),
    ...                    hint="add a .model card of type d")
    >>> print(err)
    a.cir:4:1: d1: model 'dx' is not defined (hint: add a .model card of type d)
    >>> err.message, err.location.line
    ("d1: model 'dx' is not defined", 4)
    """

    def __init__(self, message: str, *, elements=(), nodes=(), hint: str | None = None,
                 location: SourceLocation | None = None):
        self.message = message
        self.elements = tuple(elements)
        self.nodes = tuple(nodes)
        self.hint = hint
        self.location = location
        text = self.located_message
        super().__init__(text if not hint else f"{text} (hint: {hint})")

    @property
    def located_message(self) -> str:
        """The message with its location in front and without the hint: what another message quotes."""
        return f"{self.location}: {self.message}" if self.location else self.message


def error_record(exc: NetdaeError) -> dict:
    """An error as JSON-ready data: ``type``, ``message``, ``file``, ``line``, ``column`` and what it names.

    The location is the error's own (:class:`NetlistError`, :class:`CircuitError`; ``None`` when it has
    none), never read back from its text; a :class:`NetlistError` adds ``expected`` and ``hint``, a
    :class:`CircuitError` ``hint``, ``elements`` and ``nodes``.

    Examples
    --------
    >>> err = NetlistError("R1: expected a value", SourceLocation("rc.cir", 2, 4), expected="Rname n+ n- value")
    >>> error_record(err)
    {'type': 'NetlistError', 'message': 'R1: expected a value', 'file': 'rc.cir', 'line': 2, 'column': 4, \
'expected': 'Rname n+ n- value', 'hint': None}
    >>> error_record(NetdaeError("nothing to run"))
    {'type': 'NetdaeError', 'message': 'nothing to run', 'file': None, 'line': None, 'column': None}
    >>> error_record(ConvergenceError("no convergence", t=1e-3))["message"]  # its text: the time is in it
    'no convergence, at t=0.001'
    """
    location = getattr(exc, "location", None)
    located = isinstance(exc, (NetlistError, CircuitError))  # the message without the location in front
    record = {"type": type(exc).__name__, "message": exc.message if located else str(exc),
              "file": location.file if location else None, "line": location.line if location else None,
              "column": location.column if location else None}
    if isinstance(exc, NetlistError):
        record.update(expected=exc.expected, hint=exc.hint)
    elif isinstance(exc, CircuitError):
        record.update(hint=exc.hint, elements=list(exc.elements), nodes=list(exc.nodes))
    return record


class SingularPencilError(CircuitError):
    """The matrix pencil (E, H) is singular: no or infinitely many solutions."""


class ConvergenceError(NetdaeError, RuntimeError):
    """A numerical method did not converge.

    Parameters
    ----------
    message : str
        What failed.
    t : float, optional
        Time at which it failed (transient analyses).
    h : float, optional
        Step size at failure.
    worst : str, optional
        Name of the unknown with the largest error or residual.
    hint : str, optional
        Likely cause and what to try.
    """

    def __init__(self, message: str, *, t=None, h=None, worst=None, hint=None):
        self.message = message
        self.t = t
        self.h = h
        self.worst = worst
        self.hint = hint
        parts = [message]
        if t is not None:
            parts.append(f"at t={t:.6g}")
        if h is not None:
            parts.append(f"h={h:.3g}")
        if worst:
            parts.append(f"worst unknown {worst}")
        text = ", ".join(parts)
        if hint:
            text += f" (hint: {hint})"
        super().__init__(text)


class NgspiceError(NetdaeError):
    """ngspice is missing or failed to run a netlist."""


class ResultFileError(NetdaeError, ValueError):
    """A result file (ngspice raw, CSV) is malformed or unreadable."""


class OutputFileError(NetdaeError, OSError):
    """An output file could not be written; nothing was left under its name.

    Parameters
    ----------
    path : str
        The file that was to be written.
    reason : str
        Why, in words (``"the disk is full"``, ``"permission denied"`` ...).
    errno : int, optional
        The operating system's error number.
    """

    def __init__(self, path: str, reason: str, errno: int | None = None) -> None:
        self.path = path
        self.reason = reason
        super().__init__(f"cannot write {path}: {reason}")
        self.errno = errno

    def __str__(self) -> str:
        return f"cannot write {self.path}: {self.reason}"

    def __reduce__(self):
        return (OutputFileError, (self.path, self.reason, self.errno))
