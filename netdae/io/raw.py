"""ngspice raw files: read and write, binary and ascii.

A raw file is a sequence of *plots*, each a text header followed by its data::

    Title: rc test
    Date: Sat Nov 21 06:06:04  2026
    Plotname: Transient Analysis
    Flags: real
    No. Variables: 3
    No. Points: 126
    Variables:
    \t0\ttime\ttime
    \t1\tv(out)\tvoltage
    \t2\ti(v1)\tcurrent
    Binary:
    <126 rows of 3 little-endian doubles>

``Values:`` instead of ``Binary:`` announces ascii rows (``index<TAB>value``
then one ``<TAB>value`` line per further variable; ``re,im`` when complex).
In a ``complex`` plot every variable, the scale included, is stored as a
(real, imaginary) pair. The first variable is the plot's *scale* (``time``,
``frequency``, ``v(v-sweep)``); an operating point has no scale, its first
variable is an ordinary signal.

Each plot becomes one :class:`~netdae.results.Result`, named in netdae's
scheme (ngspice's own, lower case):

==============================  =========  =====================================
Plotname                        analysis   axis
==============================  =========  =====================================
``Operating Point``             ``op``     none
``Transient Analysis``          ``tran``   ``time``
``AC Analysis``                 ``ac``     ``frequency`` (real part)
``DC transfer characteristic``  ``dc``     ``v-sweep``, ``i-sweep``, ``res-sweep``,
                                           ``temp-sweep`` (ngspice does not say which
                                           source it swept)
==============================  =========  =====================================

Signals: ``v(node)`` and ``i(element)`` are kept; a bare node name of type
``voltage`` (what ngspice's ``write`` command produces) becomes ``v(node)``
and ``name#branch`` becomes ``i(name)``; other names (``@r1[i]``) stay as
written, lower-cased.

Files netdae writes keep a swept source's own name (``v1``) for a dc axis;
further axes of a nested sweep are stored as the variables that follow the
scale and listed in an ``Option: netdae_axes = ( v1 v2 )`` header line, which
ngspice stores as a plot variable and otherwise ignores.

Examples
--------
>>> import numpy as np
>>> from netdae.results import Result
>>> r = Result("tran", axes={"time": np.array([0.0, 1e-3])},
...            signals={"v(out)": np.array([0.0, 0.5])})
>>> blob = format_raw([r], title="demo", date="today")
>>> [(p.analysis, p.names()) for p in parse_raw(blob)]
[('tran', ['v(out)'])]
"""

from __future__ import annotations

import datetime as _dt
import os
import re
from dataclasses import dataclass, field

import numpy as np

from ..errors import NetdaeError, ResultFileError
from ..metadata import NoiseInfo, Provenance
from ..results import Result
from .files import StreamedFile, write_bytes

__all__ = [
    "read_raw",
    "write_raw",
    "parse_raw",
    "format_raw",
    "signal_name",
    "quantity_name",
    "sens_name",
    "complex_from_parts",
    "PLOTNAMES",
    "PLOTNAME_OF",
    "FLAVOURS",
    "RawStream",
    "COUNT_WIDTH",
]

#: What a plot of integrated noise is read as before it joins its spectra's result (``noise.totals``).
_NOISE_TOTALS = "noise_total"
#: ngspice plot names and the netdae analysis each one holds.
PLOTNAMES = {
    "operating point": "op",
    "transient analysis": "tran",
    "ac analysis": "ac",
    "dc transfer characteristic": "dc",
    "pole-zero analysis": "pz",
    "transfer function": "tf",
    "noise spectral density curves": "noise",
    "integrated noise": _NOISE_TOTALS,
    "sensitivity analysis": "sens",
}
#: Plot names written for each analysis (ngspice's spelling).
PLOTNAME_OF = {
    "op": "Operating Point",
    "tran": "Transient Analysis",
    "ac": "AC Analysis",
    "dc": "DC transfer characteristic",
    "pz": "Pole-Zero Analysis",
    "tf": "Transfer Function",
    "noise": "Noise Spectral Density Curves",
    "sens": "Sensitivity Analysis",
}
#: Analyses whose plot has no scale: every vector is a result.
_NO_AXIS = frozenset({"op", "pz", "tf"})
#: Scale names ngspice writes for a dc sweep (``v(v-sweep)`` in a raw file,
#: ``v-sweep`` in the shared library) and netdae's name for them.
_SWEEP_NAMES = {
    "v(v-sweep)": "v-sweep",
    "v-sweep": "v-sweep",
    "i(i-sweep)": "i-sweep",
    "i-sweep": "i-sweep",
    "res-sweep": "res-sweep",
    "temp-sweep": "temp-sweep",
}
#: Header line announcing the axes of a nested dc sweep (netdae's files only).
_AXES_OPTION = "netdae_axes"
#: Lines ngspice prints in server mode (``ngspice -s``) around a plot's
#: header, and PySpice's reader requires: the temperatures and the count of
#: data columns after ``Variables:``.
_TEMPERATURES = re.compile(r"Doing analysis at TEMP = (\S+) and TNOM = (\S+)", re.I)
_DATA_COLUMNS = "No. of Data Columns"
#: The vector types PySpice's reader knows (any other is a KeyError there).
_PYSPICE_TYPES = ("time", "voltage", "current", "frequency")
#: Flavours of raw file netdae writes.
FLAVOURS = ("ngspice", "pyspice")
#: Bytes per stored double (ngspice writes native little-endian IEEE doubles).
_DOUBLE = np.dtype("<f8")
#: Digits written to ascii files: 17 significant digits round-trip any double
#: (ngspice itself writes 16, ``%.15e``, which is not always exact).
_ASCII_FORMAT = "%.16e"
_DATE_FORMAT = "%a %b %d %H:%M:%S  %Y"  # ngspice's datestring()
#: The header line of a plot's point count.
_POINTS_LABEL = "No. Points: "
#: Characters the point count is written in, left-aligned and padded with blanks (ngspice reserves 8),
#: so that the count of a file written while the run goes on is patched in place when it ends.
COUNT_WIDTH = 20


def signal_name(name: str, vtype: str) -> str:
    """Translate an ngspice vector name into netdae's signal name.

    Parameters
    ----------
    name : str
        The name as ngspice writes it (raw file) or stores it (shared library):
        ``v(out)``, ``out``, ``i(v1)``, ``v1#branch``, ``@r1[i]``.
    vtype : str
        ngspice's type name of the vector (``voltage``, ``current``, ...).

    Returns
    -------
    str
        Lower-case ``v(node)``, ``i(element)``, or the name itself when it is
        neither (internal device parameters ``@r1[i]``, other types).

    Examples
    --------
    >>> signal_name("L.XA.X1.L1#branch", "current"), signal_name("xa.x1.mid", "voltage")
    ('i(l.xa.x1.l1)', 'v(xa.x1.mid)')
    >>> signal_name("V(OUT)", "voltage"), signal_name("@r1[i]", "current")
    ('v(out)', '@r1[i]')
    >>> signal_name("i(@R1[i])", "current")  # ngspice -b wraps device quantities
    '@r1[i]'
    """
    key = name.strip().lower()
    if key[:3] in ("i(@", "v(@") and key.endswith(")"):
        return key[2:-1]
    if key.startswith("@") or (len(key) > 3 and key[1] == "(" and key.endswith(")")):
        return key
    if key.endswith("#branch"):
        return f"i({key[: -len('#branch')]})"
    if vtype == "voltage":
        return f"v({key})"
    if vtype == "current":
        return f"i({key})"
    return key


def sens_name(name: str) -> str:
    """netdae's name of a sensitivity vector as ngspice writes (``v(r1_m)``) or stores (``R1_m``) it.

    Examples
    --------
    >>> sens_name("v(d1:is)"), sens_name("R1_m"), sens_name("v1_acmag")
    ('d1:is', 'r1_m', 'v1_acmag')
    """
    key = name.strip().lower()
    if key.startswith("v(") and key.endswith(")"):
        return key[2:-1]
    return key


def quantity_name(name: str) -> str:
    """netdae's name of a ``.pz``, ``.tf`` or ``.noise`` vector as ngspice writes or stores it.

    ngspice's raw file wraps them in ``v(...)`` (they are of type voltage;
    an integrated input noise in ``i(...)`` when the input is a current);
    the shared library does not.

    Examples
    --------
    >>> quantity_name("v(pole(1))"), quantity_name("zero(2)"), quantity_name("v(output_impedance_at_V(out))")
    ('pole(1)', 'zero(2)', 'output_impedance_at_v(out)')
    >>> quantity_name("v(Transfer_function)"), quantity_name("V1#Input_impedance")
    ('transfer_function', 'v1#input_impedance')
    >>> quantity_name("v(onoise_total)"), quantity_name("i(inoise_total_r1)"), quantity_name("onoise_spectrum")
    ('onoise_total', 'inoise_total_r1', 'onoise_spectrum')
    """
    key = name.strip().lower()
    if key.startswith(("v(", "i(")) and key.endswith(")") and key[2:-1].count("(") == key[2:-1].count(")"):
        inner = key[2:-1]
        if inner.startswith(("pole(", "zero(", "transfer_function", "output_impedance", "onoise_", "inoise_")) \
                or "#" in inner:
            return inner
    return key


def _axis_name(name: str) -> str:
    key = name.strip().lower()
    return _SWEEP_NAMES.get(key, key)


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------


@dataclass
class _Header:
    title: str = ""
    date: str = ""
    plotname: str = ""
    flags: list[str] = field(default_factory=list)
    nvars: int | None = None
    npoints: int | None = None
    dimensions: str | None = None
    circuit: str | None = None
    temperatures: tuple[float, float] | None = None
    commands: list[str] = field(default_factory=list)
    options: list[str] = field(default_factory=list)
    unknown: list[str] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    types: list[str] = field(default_factory=list)
    lengths: list[int | None] = field(default_factory=list)
    names_read: bool = False  # 'Variables:' read with 'No. Variables: 0'

    @property
    def complex(self) -> bool:
        return "complex" in self.flags

    @property
    def padded(self) -> bool:
        return "unpadded" not in self.flags


class _Reader:
    """Walks the bytes of a raw file, one plot at a time."""

    def __init__(self, data: bytes, source: str, partial: bool = False) -> None:
        self.data = data
        self.source = source
        self.partial = partial
        self.pos = 0
        self.line_no = 1

    def error(self, message: str, line: int | None = None) -> NetdaeError:
        where = f"{self.source}:{self.line_no if line is None else line}"
        return ResultFileError(f"{where}: not a readable ngspice raw file: {message}")

    def incomplete(self, head: _Header, found: int, line: int | None = None) -> str:
        """The note on a plot whose data do not hold the announced points; raises unless ``partial``."""
        what = (f"the header announces {head.npoints} points, the file holds {found} complete "
                f"point{'' if found == 1 else 's'}")
        if not self.partial:
            where = f"{self.source}:{self.line_no if line is None else line}"
            raise ResultFileError(
                f"{where}: plot '{head.plotname}' is incomplete: {what} (the run or the write was "
                "cut short); read_raw(..., partial=True) reads the complete points"
            )
        return f"{head.plotname}: {what} (the run was cut short); read those"

    def at_end(self) -> bool:
        rest = self.data[self.pos :]
        return not rest.strip()

    def skip_blank(self) -> None:
        while self.pos < len(self.data) and self.data[self.pos : self.pos + 1] in (b"\n", b"\r", b" ", b"\t"):
            if self.data[self.pos : self.pos + 1] == b"\n":
                self.line_no += 1
            self.pos += 1

    def next_line(self) -> str | None:
        if self.pos >= len(self.data):
            return None
        end = self.data.find(b"\n", self.pos)
        if end < 0:
            end = len(self.data)
        raw = self.data[self.pos : end]
        self.pos = end + 1
        self.line_no += 1
        try:
            return raw.decode("utf-8").rstrip("\r")
        except UnicodeDecodeError as exc:
            raise self.error(f"header line is not text ({exc.reason})", self.line_no - 1) from None

    def header(self) -> tuple[_Header, str]:
        """Read header lines up to and including ``Binary:``/``Values:``."""
        head = _Header()
        first_line = self.line_no
        while True:
            line = self.next_line()
            if line is None:
                raise self.error("header ends before 'Binary:' or 'Values:'", first_line)
            key, _, value = line.partition(":")
            key = key.strip().lower()
            value = value.strip()
            if not line.strip():
                continue
            if key == "title":
                head.title = value
            elif key == "date":
                head.date = value
            elif key == "plotname":
                head.plotname = value
            elif key == "flags":
                head.flags = value.lower().split()
            elif key == "no. variables":
                head.nvars = self._int(value, "No. Variables")
            elif key == "no. points":
                head.npoints = self._int(value, "No. Points")
            elif key == "dimensions":
                head.dimensions = value
            elif key == "command":
                head.commands.append(value)
            elif key == "circuit":
                head.circuit = value
            elif _TEMPERATURES.fullmatch(line.strip()):
                temp, tnom = _TEMPERATURES.fullmatch(line.strip()).groups()
                head.temperatures = (float(temp), float(tnom))
            elif key == "option":
                head.options.append(value)
            elif key == "variables":
                self._variables(head, value)
            elif key in ("binary", "values"):
                if not head.names and not head.names_read:
                    raise self.error(f"'{key}:' before 'Variables:'", self.line_no - 1)
                return head, key
            else:
                head.unknown.append(line)

    def _int(self, text: str, what: str) -> int:
        try:
            value = int(text.split()[0])
        except (ValueError, IndexError):
            raise self.error(f"{what}: expected a count, got {text!r}", self.line_no - 1) from None
        if value < 0:
            raise self.error(f"{what}: negative count {value}", self.line_no - 1)
        return value

    def _variables(self, head: _Header, rest: str) -> None:
        if head.nvars is None or head.npoints is None:
            raise self.error("'Variables:' before 'No. Variables:' and 'No. Points:'", self.line_no - 1)
        if head.nvars == 0:  # ngspice's .pz without finite poles or zeros: a plot of no vectors
            head.names_read = True
            return
        lines = [rest] if rest else []
        while len(lines) < head.nvars:
            line = self.next_line()
            if line is None:
                raise self.error(f"file ends inside the {head.nvars} variable lines")
            if line.lower().startswith(_DATA_COLUMNS.lower()):
                continue  # ngspice -s (and PySpice) only
            lines.append(line)
        for k, line in enumerate(lines):
            fields = line.split()
            if len(fields) < 3 or fields[0] != str(k):
                raise self.error(
                    f"variable line {k}: expected '<index> <name> <type>', got {line.strip()!r}",
                    self.line_no - len(lines) + k,
                )
            head.names.append(fields[1])
            head.types.append(fields[2].lower())
            head.lengths.append(_dims_length(fields[3:]))


def _dims_length(attributes: list[str]) -> int | None:
    for attr in attributes:
        key, _, value = attr.partition("=")
        if key.lower() == "dims" and value:
            length = 1
            for part in value.split(","):
                length *= int(part)
            return length
    return None


def parse_raw(data: bytes, source: str = "<bytes>", *, partial: bool = False) -> list[Result]:
    """Parse the contents of a raw file.

    Parameters
    ----------
    data : bytes
        The whole file.
    source : str
        Name used in error messages and notes (the file's path).
    partial : bool
        Read the complete points of a last plot that holds fewer (or more)
        points than its header announces, with a note, instead of raising.

    Returns
    -------
    list of Result
        One per plot, in file order. ``source``
        (:class:`netdae.metadata.Provenance`) holds ``path``, ``title``,
        ``date``, ``plotname``, ``flags``, ``commands`` and ``options`` (the
        ``Command:``/``Option:`` lines, never executed), ``variable_types``
        (signal name to ngspice's type), ``points_announced`` and the rest of
        the header; a noise result's integrated noise is in ``noise.totals``.

    Raises
    ------
    ResultFileError
        When the file is not a raw file, a plot is not one of op, tran, ac, dc,
        or the data of a plot do not hold the points its header announces
        (the message says how many were announced and found; with ``partial``
        only a plot other than the last raises).

    Notes
    -----
    A run that is cut short (killed, or stopped by an error) leaves a header
    whose ``No. Points`` is wrong: ngspice writes an estimate (often 0) and
    corrects it only when the analysis ends; a write that fails leaves a file
    shorter than its header says. Either file is refused unless ``partial`` is
    given: then the last plot is read up to the last complete point actually
    present, and a note says so. Cost: one pass over
    the data; binary data is converted with one ``numpy.frombuffer``.
    """
    reader = _Reader(data, source, partial)
    results: list[Result] = []
    while True:
        reader.skip_blank()
        if reader.at_end():
            break
        head, kind = reader.header()
        if kind == "binary":
            table, notes = _binary_table(reader, head)
        else:
            table, notes = _ascii_table(reader, head)
        res = _to_result(head, table, notes, source)
        if res.analysis == _NOISE_TOTALS:
            if not results or results[-1].analysis != "noise" or results[-1].noise is not None:
                raise ResultFileError(f"{source}: plot '{head.plotname}' does not follow a noise analysis's "
                                      "spectral densities")
            results[-1].noise = NoiseInfo(totals={k: float(v[0]) for k, v in res.signals.items()})
            continue
        results.append(res)
    if not results:
        raise ResultFileError(f"{source}: not a readable ngspice raw file: no plot in it")
    return results


def read_raw(path: str | os.PathLike, *, partial: bool = False) -> list[Result]:
    """Read an ngspice raw file (binary or ascii, one or more plots).

    Parameters
    ----------
    path : str or path-like
        The file.
    partial : bool
        Read what a run cut short left in its last plot (see :func:`parse_raw`).

    Returns
    -------
    list of Result
        One per plot, in file order (see :func:`parse_raw`).

    Raises
    ------
    ResultFileError
        When the file cannot be read, is not a raw file, or is incomplete
        (see :func:`parse_raw`).
    """
    try:
        with open(path, "rb") as handle:
            data = handle.read()
    except OSError as exc:
        raise ResultFileError(f"{path}: cannot read raw file: {exc.strerror}") from None
    return parse_raw(data, os.fspath(path), partial=partial)


def _binary_table(reader: _Reader, head: _Header) -> tuple[np.ndarray, list[str]]:
    """Read binary rows; returns an (m, nvars) float or complex array."""
    nvars = head.nvars
    width = 2 if head.complex else 1
    lengths = [head.npoints if n is None else n for n in head.lengths]
    start = reader.pos
    available = len(reader.data) - start
    notes: list[str] = []
    if head.padded:
        row = nvars * width * _DOUBLE.itemsize
        announced_end = start + head.npoints * row
        follows = reader.data[announced_end:].lstrip()
        if announced_end <= len(reader.data) and (not follows or _starts_plot(follows)):
            npoints = head.npoints
        else:
            following = _next_plot(reader.data, start)
            if following is not None:
                raise reader.error(f"plot '{head.plotname}' is incomplete and another plot follows")
            npoints = available // row
            notes.append(reader.incomplete(head, npoints))
        flat = np.frombuffer(reader.data, dtype=_DOUBLE, count=npoints * nvars * width, offset=start)
        # a plot cut short is the last one: a trailing partial point is dropped
        reader.pos = start + npoints * row if npoints == head.npoints else len(reader.data)
        mask = np.ones((npoints, nvars), dtype=bool)
    else:
        npoints = max(lengths) if lengths else 0
        mask = np.arange(npoints)[:, None] < np.asarray(lengths)[None, :]
        count = int(mask.sum()) * width
        have = min(count, available // _DOUBLE.itemsize)
        if have < count:
            npoints = _complete_rows(mask, have // width)
            notes.append(reader.incomplete(head, npoints))
            mask = mask[:npoints]
            have = int(mask.sum()) * width
        flat = np.frombuffer(reader.data, dtype=_DOUBLE, count=have, offset=start)
        reader.pos = start + have * _DOUBLE.itemsize if have == count else len(reader.data)
    values = complex_from_parts(flat[0::2], flat[1::2]) if head.complex else flat
    table = np.full(mask.shape, np.nan, dtype=values.dtype)
    table[mask] = values
    return table, notes


def _complete_rows(mask: np.ndarray, values: int) -> int:
    """Number of leading rows of ``mask`` whose entries fit in ``values``."""
    per_row = np.cumsum(mask.sum(axis=1))
    return int(np.searchsorted(per_row, values, side="right"))


#: The first header line of a plot: ``Title:``, or ``Circuit:`` in the
#: flavour ngspice prints in server mode (``ngspice -s``, read by PySpice).
_PLOT_START = re.compile(rb"(?:Title|Circuit):[^\n]*\n(?:[^\n]*\n){0,8}?Plotname:")


def _starts_plot(data: bytes) -> bool:
    return _PLOT_START.match(data) is not None


def _next_plot(data: bytes, pos: int) -> int | None:
    """Offset of the next plot's header at or after ``pos``, if any."""
    match = _PLOT_START.search(data, pos)
    return None if match is None else match.start()


_HEADER_START = re.compile(rb"^[A-Za-z]", re.M)


def _ascii_table(reader: _Reader, head: _Header) -> tuple[np.ndarray, list[str]]:
    """Read ``Values:`` rows up to the next header line or the end."""
    start = reader.pos
    match = _HEADER_START.search(reader.data, start)
    end = match.start() if match else len(reader.data)
    text = reader.data[start:end].decode("ascii", errors="replace")
    first_line = reader.line_no
    reader.line_no += text.count("\n")
    reader.pos = end
    nvars = head.nvars
    width = 2 if head.complex else 1
    tokens = text.replace(",", " ").split() if head.complex else text.split()
    per_point = 1 + nvars * width
    npoints = len(tokens) // per_point
    notes: list[str] = []
    if not head.padded and len(set(n for n in head.lengths if n is not None)) > 1:
        raise reader.error("unpadded ascii plots with vectors of different lengths", first_line)
    if npoints != head.npoints or len(tokens) % per_point:
        if match is not None and npoints < head.npoints:
            raise reader.error(f"plot '{head.plotname}' is incomplete and another plot follows", first_line)
        if npoints and not len(tokens) % per_point and not text.endswith("\n"):
            npoints -= 1  # a file cut inside the last point's last number: that number may be short
        notes.append(reader.incomplete(head, npoints, first_line))
    grid = np.asarray(tokens[: npoints * per_point], dtype=object).reshape(npoints, per_point)
    try:
        index = grid[:, 0].astype(np.int64) if npoints else np.zeros(0, dtype=np.int64)
        numbers = grid[:, 1:].astype(np.float64)
    except ValueError as exc:
        raise reader.error(f"bad number in 'Values:' ({exc})", first_line) from None
    if not np.array_equal(index, np.arange(npoints)):
        bad = int(np.argmax(index != np.arange(npoints)))
        raise reader.error(f"point {bad} is numbered {index[bad]} in 'Values:'", first_line)
    table = complex_from_parts(numbers[:, 0::2], numbers[:, 1::2]) if head.complex else numbers
    return table, notes


def complex_from_parts(re: np.ndarray, im: np.ndarray) -> np.ndarray:
    """``re + j im`` part by part, shape of ``re``.

    ``re + 1j * im`` makes the real part NaN where ``im`` is infinite (``1j * inf`` is
    ``nan + inf j``), and ngspice 39 leaves the imaginary part of an ac scale uninitialised,
    sometimes infinite: its frequencies read as NaN (raw files, and the shared library's vectors).

    Examples
    --------
    >>> complex_from_parts(np.array([10.0]), np.array([np.inf]))
    array([10.+infj])
    """
    out = np.empty(np.shape(re), dtype=complex)
    out.real = re
    out.imag = im
    return out


def _to_result(head: _Header, table: np.ndarray, notes: list[str], source: str) -> Result:
    analysis = PLOTNAMES.get(head.plotname.lower())
    if analysis is None:
        raise ResultFileError(
            f"{source}: plot '{head.plotname}' is not an analysis netdae reads "
            f"(it reads: {', '.join(PLOTNAME_OF.values())})"
        )
    names = [n.lower() for n in head.names]
    lengths = [table.shape[0] if n is None else min(n, table.shape[0]) for n in head.lengths]
    columns = [table[: lengths[k], k] for k in range(len(names))]
    n_axes = 0 if analysis in _NO_AXIS or analysis == _NOISE_TOTALS else _count_axes(head.options, names)
    if analysis == "sens":  # a DC sensitivity has no scale, an AC one its frequency
        n_axes = int(bool(names) and names[0] == "frequency")
    axes: dict[str, np.ndarray] = {}
    signals: dict[str, np.ndarray] = {}
    types: dict[str, str] = {}
    for k, (name, vtype, column) in enumerate(zip(names, head.types, columns)):
        if k < n_axes:
            key = _axis_name(name)
            if np.iscomplexobj(column):
                if np.any(column.imag != 0.0):
                    notes.append(f"{head.plotname}: the imaginary part of the scale '{key}' is not zero "
                                 "(ngspice writes uninitialised values there); its real part is used")
                column = column.real.copy()
            axes[key] = column
        else:
            if analysis == "sens":
                key = sens_name(name)
            elif analysis in ("pz", "tf", "noise", _NOISE_TOTALS):
                key = quantity_name(name)
            else:
                key = signal_name(name, vtype)
            if key in signals:
                raise ResultFileError(f"{source}: plot '{head.plotname}' has two vectors named {key!r}")
            signals[key] = column.copy()
        types[key] = vtype
    if head.unknown:
        notes.append(f"{head.plotname}: header lines netdae does not know were kept in "
                     f"source.unknown_header_lines: {head.unknown}")
    prov = Provenance(
        path=source, title=head.title, date=head.date, plotname=head.plotname, flags=list(head.flags),
        commands=list(head.commands), options=list(head.options), dimensions=head.dimensions,
        circuit=head.circuit, temp=head.temperatures[0] if head.temperatures else None,
        tnom=head.temperatures[1] if head.temperatures else None, variable_types=types,
        points_announced=head.npoints, unknown_header_lines=list(head.unknown) if head.unknown else None)
    return Result(analysis, axes=axes, signals=signals, notes=notes, source=prov)


def _count_axes(options: list[str], names: list[str]) -> int:
    for option in options:
        key, _, value = option.partition("=")
        if key.strip().lower() == _AXES_OPTION:
            listed = value.replace("(", " ").replace(")", " ").lower().split()
            if listed and listed == names[: len(listed)]:
                return len(listed)
    return 1


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------


#: ngspice's vector type of a dc axis, by the first letter of the swept name.
_SWEEP_TYPES = {"v": "voltage", "i": "current", "r": "res-sweep"}


def _vector_type(name: str, axis: bool) -> str:
    """ngspice's type name for a vector netdae writes."""
    if name in ("time", "frequency", "res-sweep", "temp-sweep"):
        return name
    if axis:
        # a dc sweep axis is named by what it sweeps: v1, i2, r3 or temp
        return "temp-sweep" if name == "temp" else _SWEEP_TYPES.get(name[:1], "notype")
    if name.startswith("v("):
        return "voltage"
    if name.startswith("i("):
        return "current"
    return "notype"


def format_raw(
    results: Result | list[Result],
    *,
    binary: bool = True,
    title: str = "netdae",
    date: str | None = None,
    flavour: str = "ngspice",
    temp: float = 27.0,
    tnom: float = 27.0,
) -> bytes:
    """Format results as the bytes of an ngspice raw file.

    Parameters
    ----------
    results : Result or list of Result
        Analyses ``op``, ``tran``, ``ac`` or ``dc``; one plot each, in order.
    binary : bool
        Little-endian doubles (ngspice's default, exact) or ascii ``Values:``
        with 17 significant digits (also exact).
    title : str
        The ``Title:`` line.
    date : str, optional
        The ``Date:`` line; now, in ngspice's format, by default.
    flavour : {"ngspice", "pyspice"}
        ``"ngspice"``: the file ``ngspice -r`` writes and ngspice's ``load``
        reads. ``"pyspice"``: the text ``ngspice -s`` prints, which PySpice's
        ``RawFile`` parses (see Notes); ngspice's ``load`` refuses it.
    temp, tnom : float
        Circuit and nominal temperature in degrees Celsius, written on the
        ``Doing analysis at TEMP = ...`` line of the ``"pyspice"`` flavour.

    Returns
    -------
    bytes

    Raises
    ------
    NetdaeError
        When a result is not an analysis a raw file can hold, or its axes and
        signals have different lengths; for the ``"pyspice"`` flavour also
        when asked for ascii, more than one result, or a vector whose type
        PySpice does not know (a resistance or temperature sweep, ``@``
        parameters).

    Notes
    -----
    PySpice 1.5's ``PySpice.Spice.NgSpice.RawFile.RawFile(data, points)``
    expects exactly the lines ngspice prints in server mode: ``Circuit:``,
    ``Doing analysis at TEMP = ... and TNOM = ...``, ``Title:``, ``Date:``,
    ``Plotname:``, ``Flags:``, ``No. Variables:``, ``No. Points:``,
    ``Variables:``, ``No. of Data Columns : n``, one tab-separated line per
    vector whose type is ``time``, ``voltage``, ``current`` or ``frequency``,
    and ``Binary:``; it reads one plot, binary only, and counts every
    occurrence of ``Warning`` in the text as a warning line it must find, so
    the title's ``Warning`` is written in lower case. A dc sweep's scale is
    named ``v(v-sweep)`` or ``i(i-sweep)`` as ngspice names it (netdae's
    reader then calls the axis ``v-sweep``). PySpice converts the data with
    ``numpy.fromstring``, which NumPy 2 no longer accepts for binary data;
    the header parses with any NumPy.
    """
    if isinstance(results, Result):
        results = [results]
    if flavour not in FLAVOURS:
        raise NetdaeError(f"unknown raw file flavour {flavour!r} (one of {', '.join(FLAVOURS)})")
    title, date = _title_and_date(title, date)
    if flavour == "pyspice":
        if not binary:
            raise NetdaeError("PySpice reads binary raw files only: write the 'pyspice' flavour with binary=True")
        if len(results) != 1:
            raise NetdaeError(f"PySpice reads one plot per raw file; {len(results)} results were given")
        title = title.replace("Warning", "warning")
        preamble = f"Circuit: {title}\n\nDoing analysis at TEMP = {temp:f} and TNOM = {tnom:f}\n\n"
        return preamble.encode("utf-8") + _format_plot(results[0], binary, title, date, pyspice=True)
    return b"".join(_format_plot(r, binary, title, date) + _format_noise_totals(r, binary, title, date)
                    for r in results)


def _title_and_date(title: str, date: str | None) -> tuple[str, str]:
    """The ``Title:`` (on one line) and ``Date:`` (now, as ngspice writes it, by default) of a file."""
    if date is None:
        date = _dt.datetime.now().strftime(_DATE_FORMAT)
    return " ".join(title.split()), date


def _variable_types(result: Result) -> dict[str, str]:
    """The vector types a result was read with (empty for netdae's own results)."""
    return (result.source.variable_types or {}) if result.source is not None else {}


def _noise_unit_types(result: Result) -> tuple[str, str]:
    """The input noise's vector types (density, integrated) of a noise result: a V or an I source's."""
    unit = result.noise.input_unit if result.noise is not None else None
    if unit is None:  # a result read back: the types it was written with
        unit = "A" if _variable_types(result).get("inoise_spectrum") == "current-density" else "V"
    return ("current-density", "current") if unit == "A" else ("voltage-density", "voltage")


def _format_noise_totals(result: Result, binary: bool, title: str, date: str) -> bytes:
    """ngspice's "Integrated Noise" plot after a noise result's spectra (nothing without totals)."""
    totals = result.noise_totals if result.analysis == "noise" else None
    if not totals:
        return b""
    types = {name: ("voltage" if name.startswith("onoise") else _noise_unit_types(result)[1]) for name in totals}
    plot = Result("noise", signals={name: np.array([value]) for name, value in totals.items()},
                  source=Provenance(variable_types=types, plotname="Integrated Noise"))
    return _format_plot(plot, binary, title, date)


def _pyspice_columns(result: Result, columns: list) -> list:
    """Columns renamed and checked for PySpice: a dc scale named as ngspice names it."""
    out = []
    for k, (name, values, axis) in enumerate(columns):
        vtype = _vector_type(name, axis)
        if axis and k == 0 and result.analysis == "dc" and vtype in ("voltage", "current"):
            name = "v(v-sweep)" if vtype == "voltage" else "i(i-sweep)"
        if vtype not in _PYSPICE_TYPES:
            raise NetdaeError(
                f"cannot write {name!r} for PySpice: its vector type '{vtype}' is not one PySpice reads "
                f"({', '.join(_PYSPICE_TYPES)})"
            )
        out.append((name, values, axis))
    return out


def _format_plot(result: Result, binary: bool, title: str, date: str, pyspice: bool = False) -> bytes:
    head, columns = _plot_header(result, binary, title, date, pyspice)
    return head + _plot_rows(columns, binary)


def _plot_header(result: Result, binary: bool, title: str, date: str, pyspice: bool = False,
                 npoints: int | None = None) -> tuple[bytes, list]:
    """A plot's header up to and including ``Binary:``/``Values:``, and its columns ``(name, values, axis)``.

    ``npoints`` is the count announced (default: the result's own); it is
    written left-aligned in a field of :data:`COUNT_WIDTH` characters, so
    that a file written while the run goes on has its count patched in place.
    """
    plotname = PLOTNAME_OF.get(result.analysis)
    totals = result.analysis == "noise" and not result.axes  # the integrated noise of _format_noise_totals
    if totals:
        plotname = "Integrated Noise"
    if plotname is None:
        raise NetdaeError(f"cannot write a '{result.analysis}' result to a raw file (op, tran, ac, dc, pz, tf, noise, "
                          "sens only)")
    if not result.signals and not result.axes:
        raise NetdaeError(f"cannot write an empty '{result.analysis}' result to a raw file")
    known_types = _variable_types(result)
    columns = [(name, np.asarray(v), True) for name, v in result.axes.items()]
    columns += [(name, np.asarray(v), False) for name, v in result.signals.items()]
    length = len(columns[0][1])
    for name, values, _ in columns:
        if values.ndim != 1 or len(values) != length:
            raise NetdaeError(
                f"cannot write '{result.analysis}' result: {name!r} has shape {values.shape}, "
                f"expected ({length},) like {columns[0][0]!r}"
            )
        if any(c.isspace() for c in name) or not name:
            raise NetdaeError(f"cannot write a vector named {name!r} to a raw file (no blanks allowed)")
    if pyspice:
        columns = _pyspice_columns(result, columns)
        known_types = {}
    is_complex = any(np.iscomplexobj(v) for _, v, _ in columns)
    lines = [
        f"Title: {title}",
        f"Date: {date}",
        f"Plotname: {plotname}",
        f"Flags: {'complex' if is_complex else 'real'}",
        f"No. Variables: {len(columns)}",
        f"{_POINTS_LABEL}{length if npoints is None else npoints:<{COUNT_WIDTH}}",
    ]
    if len(result.axes) > 1 and not pyspice:
        lines.append(f"Option: {_AXES_OPTION} = ( {' '.join(result.axes)} )")
    lines.append("Variables:")
    if pyspice:
        lines.append(f"{_DATA_COLUMNS} : {len(columns)}")
    for k, (name, _, axis) in enumerate(columns):
        if result.analysis in ("pz", "tf"):  # ngspice writes them as voltages: v(pole(1))
            name, vtype = f"v({name})", "voltage"
        elif totals:  # v(onoise_total), i(inoise_total) for a current input
            vtype = known_types[name]
            name = f"{'i' if vtype == 'current' else 'v'}({name})"
        elif result.analysis == "noise" and not axis:  # densities: V/sqrt(Hz), the input's V or A/sqrt(Hz)
            vtype = _noise_unit_types(result)[0] if name.startswith("inoise") else "voltage-density"
        else:
            vtype = known_types.get(name) or _vector_type(name, axis)
        lines.append(f"\t{k}\t{name}\t{vtype}")
    lines.append("Binary:" if binary else "Values:")
    return ("\n".join(lines) + "\n").encode("utf-8"), columns


def _plot_rows(columns: list, binary: bool, first: int = 0) -> bytes:
    """The data of a plot's points (``columns`` as :func:`_plot_header` returns them), numbered from ``first``.

    The rows of consecutive blocks of points, each numbered from where the
    last ended, join to the rows of all of them.
    """
    npoints = len(columns[0][1])
    is_complex = any(np.iscomplexobj(v) for _, v, _ in columns)
    width = 2 if is_complex else 1
    table = np.empty((npoints, len(columns) * width), dtype=_DOUBLE)
    for k, (_, values, _) in enumerate(columns):
        if is_complex:
            table[:, 2 * k] = values.real
            table[:, 2 * k + 1] = values.imag if np.iscomplexobj(values) else 0.0
        else:
            table[:, k] = values
    if binary:
        return table.tobytes()
    body = []
    for i in range(npoints):
        cells = [_ASCII_FORMAT % x for x in table[i]]
        if is_complex:
            cells = [f"{cells[2 * k]},{cells[2 * k + 1]}" for k in range(len(columns))]
        body.append(f" {first + i}\t" + "".join(f"\t{c}\n" for c in cells) + "\n")
    return ("".join(body) if body else ("\n" if first == 0 else "")).encode("utf-8")


def write_raw(
    path: str | os.PathLike,
    results: Result | list[Result],
    *,
    binary: bool = True,
    title: str = "netdae",
    date: str | None = None,
    flavour: str = "ngspice",
    temp: float = 27.0,
    tnom: float = 27.0,
) -> None:
    """Write results to an ngspice raw file that ngspice's ``load`` (or PySpice) reads.

    Parameters
    ----------
    path : str or path-like
        Output file (overwritten).
    results, binary, title, date, flavour, temp, tnom
        As for :func:`format_raw`.

    Raises
    ------
    NetdaeError
        When a result cannot be written (see :func:`format_raw`).
    OutputFileError
        When the file cannot be written (disk full, file-size limit, no
        permission); nothing is left under its name.
    """
    write_bytes(path, format_raw(results, binary=binary, title=title, date=date, flavour=flavour,
                                 temp=temp, tnom=tnom))


class RawStream(StreamedFile):
    """One plot of a raw file written while the run computes its points.

    The header is written with the first points, announcing 0 points (as
    ngspice does while it runs); every block's rows follow at once, and
    :meth:`~netdae.io.files.StreamedFile.close` patches the count in place.
    A completed run's file equals :func:`write_raw`'s of the same result,
    byte for byte (with the same ``date``); a run that stopped (Ctrl-C, a
    failed step, a full disk) leaves a valid file of the points computed; a
    process killed while it runs leaves a file that announces 0 points, which
    :func:`read_raw` refuses with both counts unless ``partial=True``.

    Parameters
    ----------
    path : str or path-like
        The file (replaced when the first points arrive).
    binary : bool
        Little-endian doubles, or ascii ``Values:`` (as :func:`format_raw`).
    title : str
        The ``Title:`` line.
    date : str, optional
        The ``Date:`` line; when the stream is made, by default.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1e-3, 5)
    >>> whole = Result("tran", axes={"time": t}, signals={"v(out)": t * 1e3})
    >>> path = os.path.join(tempfile.mkdtemp(), "tran.raw")
    >>> stream = RawStream(path, title="demo", date="today")
    >>> for start in (0, 2):  # two blocks of points, as a run hands them over
    ...     stream.write(start, Result("tran", axes={"time": t[start:start + 3]},
    ...                                signals={"v(out)": t[start:start + 3] * 1e3}))
    >>> stream.close()
    >>> open(path, "rb").read() == format_raw(whole, title="demo", date="today")
    True
    """

    def __init__(self, path: str | os.PathLike, *, binary: bool = True, title: str = "netdae",
                 date: str | None = None) -> None:
        super().__init__(path)
        self.binary = binary
        self.title, self.date = _title_and_date(title, date)

    def _header(self, block: Result) -> tuple[bytes, int, list[str]]:
        head, _ = _plot_header(block, self.binary, self.title, self.date, npoints=0)
        count_at = head.index(_POINTS_LABEL.encode()) + len(_POINTS_LABEL)
        return head, count_at, list(block.axes) + list(block.signals)

    def _rows(self, block: Result, first: int) -> bytes:
        columns = [(name, np.asarray(v), True) for name, v in block.axes.items()]
        columns += [(name, np.asarray(v), False) for name, v in block.signals.items()]
        return _plot_rows(columns, self.binary, first)

    def _count(self, points: int) -> bytes:
        return f"{points:<{COUNT_WIDTH}}".encode()
