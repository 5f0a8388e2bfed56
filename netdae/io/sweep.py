"""Sweep results on disk: the table as ``measures.csv`` / ``measures.json``, waveforms as ``waveforms.npz``.

``measures.csv`` has one row per simulation: ``row``, one column per swept
quantity, ``sample`` (Monte Carlo), one column per measurement (empty where
it failed) and ``error`` (empty where the row ran). ``measures.json`` holds
the same rows plus the seed, the axes, a summary of each measure (count,
mean, std, min, max) and the failures counted by reason.
``waveforms.npz`` holds, per saved signal and analysis, an array over (row,
point) named ``<analysis>:<signal>`` and the grid as ``<analysis>:<axis>``.
Every file is written whole or not at all (:mod:`netdae.io.files`).
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from .files import csv_text, write_bytes

__all__ = ["format_table", "write_sweep"]


def format_table(result) -> str:
    """The sweep's table as CSV text (see the module docstring)."""
    rows = result.table()
    columns = list(rows[0]) if rows else ["row", "error"]
    return csv_text(columns, (["" if row[c] is None else (repr(row[c]) if isinstance(row[c], float) else row[c])
                               for c in columns] for row in rows))


def write_sweep(out_dir: str | os.PathLike, result, *, waveforms: bool = False) -> list[str]:
    """Write ``measures.csv``, ``measures.json`` and, when asked and saved, ``waveforms.npz``.

    Returns
    -------
    list of str
        The files written.

    Raises
    ------
    OutputFileError
        When a file cannot be written (the reason in words).
    """
    out = Path(out_dir)
    files = []
    path = out / "measures.csv"
    write_bytes(path, format_table(result).encode("utf-8"))
    files.append(str(path))
    path = out / "measures.json"
    write_bytes(path, (json.dumps(result.to_dict(), indent=1) + "\n").encode("utf-8"))
    files.append(str(path))
    if waveforms and result.waves:
        arrays = {}
        for analysis, (axis, grid) in result.axes.items():
            arrays[f"{analysis}:{axis}"] = grid
        for (analysis, signal), values in result.waves.items():
            arrays[f"{analysis}:{signal}"] = values
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        path = out / "waveforms.npz"
        write_bytes(path, buf.getvalue())
        files.append(str(path))
    return files
