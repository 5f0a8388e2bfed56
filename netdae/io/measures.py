"""Measurements (``.meas``) as a CSV file: ``measures.csv`` next to the analyses' files.

One header row, then one row per measurement in netlist order::

    name,analysis,function,value,status,at,from,to,trig,targ,reason

Numbers are Python's ``repr`` (the shortest text that reads back as the same
double), empty where a field does not apply or the measurement failed; the
reason of a failed measurement is quoted as CSV quotes text (``csv`` module).
Written whole or not at all (:func:`netdae.io.files.write_bytes`).

Examples
--------
>>> from netdae.measures import Measure
>>> print(format_measures([Measure("tr", "tran", "trig", 2.2e-3, extra={"trig": 1e-4, "targ": 2.3e-3}),
...                        Measure("x", "tran", "when", None, status="failed", reason="never, at all")]), end="")
name,analysis,function,value,status,at,from,to,trig,targ,reason
tr,tran,trig,0.0022,ok,,,,0.0001,0.0023,
x,tran,when,,failed,,,,,,"never, at all"
"""

from __future__ import annotations

import os

from .files import csv_text, write_bytes

__all__ = ["format_measures", "write_measures", "COLUMNS"]

#: The columns, in order.
COLUMNS = ("name", "analysis", "function", "value", "status", "at", "from", "to", "trig", "targ", "reason")


def _number(value) -> str:
    return "" if value is None else repr(float(value))


def format_measures(measures) -> str:
    """The measurements as CSV text (see the module docstring)."""
    return csv_text(COLUMNS, ([m.name, m.analysis, m.function, _number(m.value), m.status, _number(m.at),
                               *(_number(m.extra.get(k)) for k in ("from", "to", "trig", "targ")), m.reason]
                              for m in measures))


def write_measures(path: str | os.PathLike, measures) -> None:
    """Write :func:`format_measures` to ``path`` (whole or not at all).

    Raises
    ------
    OutputFileError
        When the file cannot be written (the reason in words).
    """
    write_bytes(path, format_measures(measures).encode("utf-8"))
