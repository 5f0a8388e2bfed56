"""Fourier analyses (``.four``) as a CSV file: ``fourier.csv`` next to the analyses' files.

One header row, then one row per signal and harmonic, in card order::

    signal,fundamental,harmonic,frequency,magnitude,phase_deg,norm_magnitude,norm_phase_deg,thd_percent,status,reason

Numbers are Python's ``repr`` (the shortest text that reads back as the same double), empty
where a value is not defined (no normalised values without a fundamental); a failed analysis
is one row with its status and reason. Written whole or not at all
(:func:`netdae.io.files.write_bytes`).

Examples
--------
>>> import numpy as np
>>> from netdae.fourier import Fourier
>>> f = Fourier("v(a)", 1e3, np.array([0.0, 1e3]), np.array([0.5, 1.0]), np.array([0.0, 90.0]),
...             np.array([0.0, 1.0]), np.array([0.0, 0.0]), 0.0, 200, 0.0, 1e-3)
>>> print(format_fourier_csv([f]), end="")
signal,fundamental,harmonic,frequency,magnitude,phase_deg,norm_magnitude,norm_phase_deg,thd_percent,status,reason
v(a),1000.0,0,0.0,0.5,0.0,0.0,0.0,0.0,ok,
v(a),1000.0,1,1000.0,1.0,90.0,1.0,0.0,0.0,ok,
"""

from __future__ import annotations

import math
import os

from .files import csv_text, write_bytes

__all__ = ["format_fourier_csv", "write_fourier", "COLUMNS"]

#: The columns, in order.
COLUMNS = ("signal", "fundamental", "harmonic", "frequency", "magnitude", "phase_deg", "norm_magnitude",
           "norm_phase_deg", "thd_percent", "status", "reason")


def _number(value) -> str:
    value = float(value)
    return repr(value) if math.isfinite(value) else ""


def _rows(f):
    if not f.ok:
        yield [f.signal, _number(f.fundamental), "", "", "", "", "", "", "", f.status, f.reason]
        return
    for k in range(f.frequency.size):
        yield [f.signal, _number(f.fundamental), k, _number(f.frequency[k]), _number(f.magnitude[k]),
               _number(f.phase[k]), _number(f.norm_magnitude[k]), _number(f.norm_phase[k]), _number(f.thd),
               f.status, ""]


def format_fourier_csv(fouriers) -> str:
    """The Fourier analyses (:class:`netdae.fourier.Fourier`) as CSV text (see the module docstring)."""
    return csv_text(COLUMNS, (row for f in fouriers for row in _rows(f)))


def write_fourier(path: str | os.PathLike, fouriers) -> None:
    """Write :func:`format_fourier_csv` to ``path`` (whole or not at all).

    Raises
    ------
    OutputFileError
        When the file cannot be written (the reason in words).
    """
    write_bytes(path, format_fourier_csv(fouriers).encode("utf-8"))
