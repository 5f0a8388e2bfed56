"""The result of a sweep: a table of rows (axes, sample, measures, error) and waveforms over (row, point)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..results import canonical_or, optional_module
from ..stats import Statistics
from .plan import Plan
from .worker import Outcome

__all__ = ["SweepResult", "TABLE_COLUMNS", "reserved_columns"]

#: The columns of a sweep's table (:meth:`SweepResult.table`, ``measures.csv``) besides its axes and
#: measures, and ``reasons``, a key of its rows in ``measures.json`` (:meth:`SweepResult.to_dict`): what each holds.
TABLE_COLUMNS = {"row": "the row number", "sample": "the Monte Carlo sample", "error": "why a row failed",
                 "reasons": "the reasons of a row's failed measurements"}


def reserved_columns(plan: Plan) -> dict[str, str]:
    """The names a measure of a sweep cannot take: the table's own columns and the axes, with what each holds.

    Parameters
    ----------
    plan : Plan

    Returns
    -------
    dict of str to str
        Column name (lower case) to a description of it.
    """
    out = dict(TABLE_COLUMNS)
    out.update({a.name.lower(): f"the swept {a.target} {a.name}" for a in plan.axes})
    return out


@dataclass
class SweepResult:
    """Measures, parameters and waveforms of every row of a sweep.

    Attributes
    ----------
    plan : Plan
        The axes and rows.
    seed : int
        The Monte Carlo seed used.
    params : dict of str to ndarray, shape (rows,)
        The value of each axis per row.
    sample : ndarray of int, shape (rows,)
        The Monte Carlo sample index per row (-1: no Monte Carlo).
    measures : dict of str to ndarray, shape (rows,)
        Each measurement per row, NaN where it failed (see ``reasons``).
    reasons : dict of str to list of str
        Why each measurement failed, per row (``""`` where it did not).
    errors : list of str or None
        Why each row failed, None where it ran; a row not run (the sweep was
        interrupted) says so.
    waves : dict of (str, str) to ndarray, shape (rows, points)
        ``(analysis, signal)`` to the saved waveform of every row on the
        analysis's grid (NaN past the end of a row that stopped early).
    axes : dict of str to (str, ndarray)
        The grid of each analysis with waveforms: ``(name, values)``.
    stats : Statistics
        ``wall_time``, ``row_seconds`` (the rows' own wall times summed),
        ``executor``, ``workers``, ``completed`` (:class:`netdae.stats.Statistics`).
    notes : list of str
    """

    plan: Plan
    seed: int
    params: dict[str, np.ndarray] = field(default_factory=dict)
    sample: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    measures: dict[str, np.ndarray] = field(default_factory=dict)
    reasons: dict[str, list[str]] = field(default_factory=dict)
    errors: list[str | None] = field(default_factory=list)
    waves: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    axes: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)
    stats: Statistics = field(default_factory=Statistics)
    notes: list[str] = field(default_factory=list)

    @classmethod
    def collect(cls, plan: Plan, seed: int, outcomes: dict[int, Outcome], measure_names: list[str],
                save: tuple[str, ...]) -> "SweepResult":
        """Assemble the outcomes (by row index; missing rows were not run)."""
        n = len(plan.rows)
        res = cls(plan, seed)
        res.params = {a.name: np.array([r.point[k] for r in plan.rows], dtype=float)
                      for k, a in enumerate(plan.axes)}
        res.sample = np.array([-1 if r.sample is None else r.sample for r in plan.rows], dtype=np.int64)
        names = list(measure_names)
        for o in outcomes.values():
            names += [m for m in o.measures if m not in names]
        res.measures = {m: np.full(n, np.nan) for m in names}
        res.reasons = {m: [""] * n for m in names}
        res.errors = [None] * n
        for k in range(n):
            o = outcomes.get(k)
            if o is None:
                res.errors[k] = "not run (the sweep was interrupted)"
                for m in names:
                    res.reasons[m][k] = "not run"
                continue
            res.errors[k] = o.error
            for m in names:
                if m in o.measures:
                    res.measures[m][k] = o.measures[m]
                    res.reasons[m][k] = o.reasons.get(m, "")
                else:
                    res.reasons[m][k] = o.error or "not measured"
            for analysis, axis in o.axes.items():
                have = res.axes.get(analysis)
                if have is None or axis[1].size > have[1].size:
                    res.axes[analysis] = axis
        for analysis, (_, grid) in res.axes.items():
            for name in save:
                key = (analysis, name)
                rows = [(k, o.waves[key]) for k, o in outcomes.items() if key in o.waves]
                if not rows:
                    continue
                dtype = np.result_type(*[w.dtype for _, w in rows], np.float64)
                data = np.full((n, grid.size), np.nan, dtype=dtype)
                for k, w in rows:
                    data[k, : min(w.size, grid.size)] = w[: grid.size]
                res.waves[key] = data
        return res

    # -- views -------------------------------------------------------------------
    @property
    def rows(self) -> int:
        """Number of rows (simulations) in the sweep."""
        return len(self.plan.rows)

    @property
    def failed(self) -> int:
        """Rows that failed or were not run."""
        return sum(e is not None for e in self.errors)

    def failures(self) -> dict[str, int]:
        """How many rows failed, by reason (the first line of the message)."""
        counts: dict[str, int] = {}
        for e in self.errors:
            if e is not None:
                key = e.splitlines()[0]
                counts[key] = counts.get(key, 0) + 1
        return dict(sorted(counts.items(), key=lambda kv: -kv[1]))

    def measure_failures(self) -> dict[str, dict[str, int]]:
        """Per measure, how many rows that ran could not make it, by reason.

        A row that failed as a whole is counted by :meth:`failures`, not here.

        Returns
        -------
        dict of str to dict of str to int
            Only the measures that failed somewhere, their reasons most frequent first.
        """
        out: dict[str, dict[str, int]] = {}
        for name, why in self.reasons.items():
            counts: dict[str, int] = {}
            for k, reason in enumerate(why):
                if self.errors[k] is None and reason:
                    counts[reason] = counts.get(reason, 0) + 1
            if counts:
                out[name] = dict(sorted(counts.items(), key=lambda kv: -kv[1]))
        return out

    def table(self) -> list[dict[str, Any]]:
        """One dict per row: ``row``, each axis, ``sample`` (Monte Carlo), each measure, ``error``
        (no measure is named like another column: :func:`reserved_columns`)."""
        out = []
        for k in range(self.rows):
            row: dict[str, Any] = {"row": k}
            row.update({name: float(v[k]) for name, v in self.params.items()})
            if self.plan.samples is not None:
                row["sample"] = int(self.sample[k])
            row.update({name: (None if math.isnan(v[k]) else float(v[k])) for name, v in self.measures.items()})
            row["error"] = self.errors[k]
            out.append(row)
        return out

    def waveform(self, signal: str, analysis: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """A saved signal of every row: ``(grid, values)`` with values of shape (rows, points).

        Raises
        ------
        KeyError
            A signal that was not saved (the message lists the saved ones).
        """
        keys = [k for k in self.waves if k[1] in (signal, canonical_or(signal))
                and (analysis is None or k[0] == analysis)]
        if not keys:
            have = ", ".join(f"{a}:{s}" for a, s in self.waves) or "none"
            raise KeyError(f"no saved waveform {signal!r}{f' of {analysis}' if analysis else ''} (saved: {have})")
        key = keys[0]
        return self.axes[key[0]][1], self.waves[key]

    def summary(self) -> dict[str, dict[str, float]]:
        """Mean, standard deviation, min, max and count of each measure over its successful rows."""
        out = {}
        for name, v in self.measures.items():
            ok = v[np.isfinite(v)]
            out[name] = {"count": int(ok.size),
                         "mean": float(ok.mean()) if ok.size else math.nan,
                         "std": float(ok.std(ddof=1)) if ok.size > 1 else math.nan,
                         "min": float(ok.min()) if ok.size else math.nan,
                         "max": float(ok.max()) if ok.size else math.nan}
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: seed, axes, rows (the table; a row that ran with failed measurements also has
        ``reasons``, measure to why), failures, measure_failures, summary, stats, notes."""
        rows = self.table()
        for k, row in enumerate(rows):
            if self.errors[k] is None:
                why = {m: r[k] for m, r in self.reasons.items() if r[k]}
                if why:
                    row["reasons"] = why
        return {"seed": self.seed, "samples": self.plan.samples,
                "axes": [{"target": a.target, "name": a.name, "values": list(a.values)} for a in self.plan.axes],
                "rows": rows, "failed": self.failed, "failures": self.failures(),
                "measure_failures": self.measure_failures(),
                "summary": {k: {s: (None if isinstance(x, float) and math.isnan(x) else x) for s, x in v.items()}
                            for k, v in self.summary().items()},
                "stats": {k: v for k, v in self.stats.items() if isinstance(v, (int, float, str))},
                "notes": list(self.notes)}

    def to_pandas(self):
        """The table as a :class:`pandas.DataFrame` (one row per simulation).

        Raises
        ------
        ImportError
            When pandas is not installed (``pip install 'netdae[results]'``).
        """
        pd = optional_module("pandas", "SweepResult.to_pandas()")
        frame = pd.DataFrame(self.table()).set_index("row")
        frame.attrs.update(seed=self.seed, failed=self.failed)
        return frame

    def to_xarray(self):
        """The saved waveforms as an :class:`xarray.Dataset` over (row, grid), axes and measures per row.

        Raises
        ------
        ImportError
            When xarray is not installed (``pip install 'netdae[results]'``).
        """
        xr = optional_module("xarray", "SweepResult.to_xarray()")
        rows = np.arange(self.rows)
        coords: dict[str, Any] = {"row": rows}
        coords.update({name: ("row", v) for name, v in self.params.items()})
        if self.plan.samples is not None:
            coords["sample"] = ("row", self.sample)
        data: dict[str, Any] = {f"meas_{m}": ("row", v) for m, v in self.measures.items()}
        for analysis, (axis, grid) in self.axes.items():
            dim = axis if sum(a == axis for a, _ in self.axes.values()) == 1 else f"{analysis}_{axis}"
            coords[dim] = grid
            for (an, sig), values in self.waves.items():
                if an == analysis:
                    data[sig if len(self.axes) == 1 else f"{analysis}:{sig}"] = (("row", dim), values)
        return xr.Dataset(data, coords=coords, attrs={"seed": self.seed, "failed": self.failed})

    def __repr__(self) -> str:
        axes = ", ".join(f"{a.name} x{len(a.values)}" for a in self.plan.axes)
        mc = f"{self.plan.samples} Monte Carlo samples" if self.plan.samples else ""
        what = "; ".join(p for p in (axes, mc) if p) or "one point"
        meas = ", ".join(list(self.measures)[:4]) + (" ..." if len(self.measures) > 4 else "")
        return (f"<SweepResult {self.rows} rows ({what}); measures: {meas or 'none'}; "
                f"{len(self.waves)} waveform{'' if len(self.waves) == 1 else 's'}; {self.failed} failed>")
