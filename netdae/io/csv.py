"""Results as CSV files, named as ngspice names signals, exact to the last bit.

Layout
------
One header row of column names, then one row per point, comma separated:

- the axis columns first: ``time`` (tran), ``frequency`` (ac), or the swept
  sources of a ``.dc`` (``v1``, then ``v2`` for a nested sweep);
- then the signals in the result's order: ``v(node)``, ``i(element)``; a name
  holding a comma (a differential voltage ``v(in,out)``) in double quotes;
- ac signals are complex and written losslessly as two columns,
  ``re(v(out))`` and ``im(v(out))``;
- an operating point has no axis: its file is the header and **one row**, a
  column per signal;
- a ``.pz`` result is one row per root, ``root,re,im`` (``pole(1)``,
  ``pole(2)`` ..., ``zero(1)`` ...); a ``.tf`` result one row per quantity,
  ``quantity,value`` (``transfer_function``, ``v1#input_impedance``,
  ``output_impedance_at_v(out)``), a name holding a comma written in double
  quotes (``"output_impedance_at_v(a,b)"``);
- a ``.noise`` result is its spectral densities against frequency (real); its
  integrated noise goes into a file of its own, one row per total,
  ``total,value`` (:func:`write_noise_totals`), read back as a ``noise``
  result whose ``noise.totals`` holds them.

Numbers are written with Python's ``repr`` (the shortest text that reads back
as the same double), so :func:`read_csv` returns bit-identical arrays;
``nan`` and ``inf`` are written as such.

:func:`read_csv` tells the analysis from the header: ``time`` first means
tran, ``frequency`` first means ac; otherwise the leading columns whose names
carry no parenthesis are the axes of a dc sweep, and a header whose first
column already has one (``v(out)``) is an operating point.

Examples
--------
>>> import io, numpy as np
>>> from netdae.results import Result
>>> r = Result("ac", axes={"frequency": np.array([1.0, 10.0])},
...            signals={"v(out)": np.array([1 + 0.1j, 0.5 - 0.5j])})
>>> print(format_csv(r), end="")
frequency,re(v(out)),im(v(out))
1.0,1.0,0.1
10.0,0.5,-0.5
>>> parse_csv(format_csv(r)).signals["v(out)"]
array([1. +0.1j, 0.5-0.5j])
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import NetdaeError, ResultFileError
from ..metadata import NoiseInfo, Provenance
from ..results import Result
from .files import StreamedFile, write_bytes

__all__ = ["write_csv", "read_csv", "format_csv", "parse_csv", "format_noise_totals", "write_noise_totals",
           "CsvStream"]

_SEPARATOR = ","


def format_csv(result: Result) -> str:
    """Format one result as CSV text (see the module docstring for the layout).

    Parameters
    ----------
    result : Result
        An ``op``, ``dc``, ``ac`` or ``tran`` result.

    Returns
    -------
    str
        The text, ending with a newline.

    Raises
    ------
    NetdaeError
        When axes and signals have different lengths, an op result has an
        axis, or a name is empty or contains a line break or a double quote
        (a name with a comma is written in double quotes).
    """
    if result.analysis in ("pz", "tf"):
        return _format_long(result)
    columns = _columns(result)
    header = _header_line(columns)
    return "\n".join([header, *_rows(columns)]) + "\n"


def _header_line(columns: list[tuple[str, np.ndarray]]) -> str:
    """The header row: a name holding a comma (``v(in,out)``, a differential voltage) written in double quotes."""
    import csv
    import io

    out = io.StringIO()
    csv.writer(out, lineterminator="").writerow([name for name, _ in columns])
    return out.getvalue()


def _rows(columns: list[tuple[str, np.ndarray]]) -> list[str]:
    """One text row per point."""
    table = np.column_stack([values.astype(np.float64) for _, values in columns])
    return [_SEPARATOR.join(map(repr, row)) for row in table.tolist()]


def _columns(result: Result) -> list[tuple[str, np.ndarray]]:
    """The columns ``(name, values)`` of a result with an axis or an op (checked, see :func:`format_csv`)."""
    columns: list[tuple[str, np.ndarray]] = []
    for name, values in result.axes.items():
        values = np.asarray(values)
        if np.iscomplexobj(values):
            raise NetdaeError(f"cannot write CSV: the axis {name!r} is complex")
        columns.append((name, values))
    if result.analysis == "op" and columns:
        raise NetdaeError("cannot write CSV: an op result has no axis, this one has " + ", ".join(result.axes))
    for name, values in result.signals.items():
        values = np.asarray(values)
        if np.iscomplexobj(values):
            columns += [(f"re({name})", values.real), (f"im({name})", values.imag)]
        else:
            columns.append((name, values))
    if not columns:
        raise NetdaeError(f"cannot write CSV: the {result.analysis} result has no data")
    length = len(columns[0][1])
    for name, values in columns:
        if "\n" in name or "\r" in name or '"' in name or not name:
            raise NetdaeError(f"cannot write CSV: column name {name!r} is empty or contains a line break or a quote")
        if values.ndim != 1 or len(values) != length:
            raise NetdaeError(
                f"cannot write CSV: {name!r} has shape {values.shape}, expected ({length},) "
                f"like {columns[0][0]!r}"
            )
    return columns


def write_csv(path: str | os.PathLike, result: Result) -> None:
    """Write one result to a CSV file (layout in the module docstring).

    Parameters
    ----------
    path : str or path-like
        Output file (overwritten).
    result : Result
        An ``op``, ``dc``, ``ac`` or ``tran`` result.

    Raises
    ------
    NetdaeError
        When the result cannot be written (see :func:`format_csv`).
    OutputFileError
        When the file cannot be written (disk full, file-size limit, no
        permission); nothing is left under its name.
    """
    write_bytes(path, format_csv(result).encode("utf-8"))


def parse_csv(text: str, source: str = "<string>", *, analysis: str | None = None) -> Result:
    """Parse CSV text written by :func:`format_csv`.

    Parameters
    ----------
    text : str
        The whole file.
    source : str
        Name used in error messages.
    analysis : str, optional
        ``"op"``, ``"dc"``, ``"ac"`` or ``"tran"``; inferred from the header
        when omitted.

    Returns
    -------
    Result

    Raises
    ------
    NetdaeError
        With ``source:line`` when a row has the wrong number of fields, a
        field is not a number, or ``re(x)``/``im(x)`` columns do not pair up.
    """
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise ResultFileError(f"{source}:1: empty CSV file, expected a header row")
    if lines[0].strip().lower() in (_PZ_HEADER, _TF_HEADER):
        return _parse_long(lines, source)
    if lines[0].strip().lower() == _TOTALS_HEADER:
        res = _parse_long([_TF_HEADER] + lines[1:], source)
        return Result("noise", source=Provenance(path=source),
                      noise=NoiseInfo(totals={k: float(v[0]) for k, v in res.signals.items()}))
    import csv

    names = [n.strip().lower() for n in next(csv.reader([lines[0]]))]
    if len(set(names)) != len(names) or not all(names):
        raise ResultFileError(f"{source}:1: empty or repeated column names in the header: {lines[0]!r}")
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split(_SEPARATOR)
        if len(fields) != len(names):
            raise ResultFileError(f"{source}:{number}: {len(fields)} fields, expected {len(names)} as in the header")
        try:
            rows.append([float(f) for f in fields])
        except ValueError as exc:
            raise ResultFileError(f"{source}:{number}: not a number ({exc})") from None
    table = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    kind, n_axes = _layout(names, analysis, source)
    if kind == "op" and len(rows) != 1:
        raise NetdaeError(f"{source}: an op result has one row, this file has {len(rows)}")
    axes = {names[k]: table[:, k].copy() for k in range(n_axes)}
    signals: dict[str, np.ndarray] = {}
    k = n_axes
    while k < len(names):
        name = names[k]
        if name.startswith("re(") and name.endswith(")"):
            inner = name[3:-1]
            if k + 1 >= len(names) or names[k + 1] != f"im({inner})":
                raise NetdaeError(f"{source}:1: column {name!r} is not followed by 'im({inner})'")
            value = np.empty(table.shape[0], dtype=np.complex128)  # re + 1j * im would lose a -0.0 imaginary part
            value.real, value.imag = table[:, k], table[:, k + 1]
            signals[inner] = value
            k += 2
        elif name.startswith("im(") and name.endswith(")"):
            raise NetdaeError(f"{source}:1: column {name!r} is not preceded by 're({name[3:-1]})'")
        else:
            signals[name] = table[:, k].copy()
            k += 1
    return Result(kind, axes=axes, signals=signals, source=Provenance(path=source))


_PZ_HEADER = "root,re,im"
_TF_HEADER = "quantity,value"
_TOTALS_HEADER = "total,value"


def format_noise_totals(totals: dict) -> str:
    """A noise result's integrated noise as CSV: ``total,value``, one row per total.

    >>> print(format_noise_totals({"onoise_total": 5.8e-08, "inoise_total": 2.2e-07}), end="")
    total,value
    onoise_total,5.8e-08
    inoise_total,2.2e-07
    """
    lines = [_TOTALS_HEADER] + [f"{name},{float(value)!r}" for name, value in totals.items()]
    return "\n".join(lines) + "\n"


def write_noise_totals(path: str | os.PathLike, totals: dict) -> None:
    """Write :func:`format_noise_totals` to ``path`` (whole or not at all).

    Raises
    ------
    OutputFileError
        When the file cannot be written.
    """
    write_bytes(path, format_noise_totals(totals).encode("utf-8"))


def _format_long(result: Result) -> str:
    """A ``.pz`` or ``.tf`` result: one row per root or quantity."""
    import csv
    import io

    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    pz = result.analysis == "pz"
    out.write((_PZ_HEADER if pz else _TF_HEADER) + "\n")
    for name, values in result.signals.items():
        value = np.asarray(values).ravel()
        if value.size != 1:
            raise NetdaeError(f"cannot write CSV: {name!r} has {value.size} values, a {result.analysis} result one")
        v = complex(value[0]) if pz else float(value[0].real)
        writer.writerow([name, repr(v.real), repr(v.imag)] if pz else [name, repr(v)])
    return out.getvalue()


def _parse_long(lines: list[str], source: str) -> Result:
    import csv

    pz = lines[0].strip().lower() == _PZ_HEADER
    signals: dict[str, np.ndarray] = {}
    for number, row in enumerate(csv.reader(lines[1:]), start=2):
        if not row:
            continue
        if len(row) != (3 if pz else 2):
            raise ResultFileError(f"{source}:{number}: {len(row)} fields, expected {3 if pz else 2} as in the header")
        try:
            value = complex(float(row[1]), float(row[2])) if pz else float(row[1])
        except ValueError as exc:
            raise ResultFileError(f"{source}:{number}: not a number ({exc})") from None
        signals[row[0].strip().lower()] = np.array([value])
    return Result("pz" if pz else "tf", signals=signals, source=Provenance(path=source))


def read_csv(path: str | os.PathLike, *, analysis: str | None = None) -> Result:
    """Read a CSV file written by :func:`write_csv`.

    Parameters
    ----------
    path : str or path-like
        The file.
    analysis : str, optional
        Overrides the analysis inferred from the header.

    Returns
    -------
    Result
        Bit-identical to the result that was written.

    Raises
    ------
    NetdaeError
        When the file cannot be read or is malformed (see :func:`parse_csv`).
    """
    try:
        with open(path, encoding="utf-8") as handle:
            text = handle.read()
    except OSError as exc:
        raise NetdaeError(f"{path}: cannot read CSV file: {exc.strerror}") from None
    return parse_csv(text, os.fspath(path), analysis=analysis)


def _layout(names: list[str], analysis: str | None, source: str) -> tuple[str, int]:
    """The analysis and number of axis columns of a header."""
    leading = 0
    while leading < len(names) and "(" not in names[leading] and not names[leading].startswith("@"):
        leading += 1
    if analysis is None:
        if names[0] == "time":
            analysis = "tran"
        elif names[0] == "frequency":
            analysis = "ac" if any(n.startswith(("re(", "im(")) for n in names[1:]) or len(names) == 1 else "noise"
        elif leading == 0:
            analysis = "op"
        else:
            analysis = "dc"
    if analysis in ("tran", "ac", "noise"):
        return analysis, 1
    if analysis == "op":
        return analysis, 0
    if analysis == "dc":
        if leading == 0:
            raise NetdaeError(f"{source}:1: a dc result needs its swept source(s) first, e.g. 'v1'")
        return analysis, leading
    raise NetdaeError(f"{source}: unknown analysis {analysis!r} (op, dc, ac, tran, noise)")


class CsvStream(StreamedFile):
    """A CSV file written while the run computes its points.

    The header row is written with the first points, then every block's
    rows at once; a completed run's file equals :func:`write_csv`'s of the same
    result, byte for byte. A run that stopped leaves the rows computed; a
    process killed while writing may leave a last row cut short, which
    :func:`read_csv` refuses naming its line.

    Examples
    --------
    >>> import os, tempfile
    >>> t = np.linspace(0.0, 1e-3, 5)
    >>> path = os.path.join(tempfile.mkdtemp(), "tran.csv")
    >>> stream = CsvStream(path)
    >>> for start in (0, 3):
    ...     stream.write(start, Result("tran", axes={"time": t[start:start + 3]},
    ...                                signals={"v(out)": t[start:start + 3] * 1e3}))
    >>> stream.close()
    >>> open(path).read() == format_csv(Result("tran", axes={"time": t}, signals={"v(out)": t * 1e3}))
    True
    """

    def _header(self, block: Result) -> tuple[bytes, None, list[str]]:
        header = _header_line(_columns(block)) + "\n"
        return header.encode("utf-8"), None, list(block.axes) + list(block.signals)

    def _rows(self, block: Result, first: int) -> bytes:
        return "".join(row + "\n" for row in _rows(_columns(block))).encode("utf-8")
