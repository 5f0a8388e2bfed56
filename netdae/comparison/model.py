"""The outcome of a comparison: per signal, per analysis, per netlist.

Plain data with a JSON form (:meth:`Comparison.to_dict`); the numbers are
defined in :mod:`netdae.comparison.metrics`, the text table is in
:mod:`netdae.comparison.report`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .header import Tolerance

__all__ = ["SignalComparison", "AnalysisComparison", "MeasureComparison", "Comparison", "jsonable"]


def jsonable(value: Any) -> Any:
    """``value`` with numpy scalars/arrays turned into Python and non-finite floats into None."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, complex):
        return [jsonable(value.real), jsonable(value.imag)]
    return value


@dataclass
class SignalComparison:
    """The errors of one signal in one analysis.

    Attributes
    ----------
    name : str
        ``v(node)`` or ``i(element)``.
    max_abs, max_rel, rms : float
        As defined in :mod:`netdae.comparison.metrics`, over the compared window.
    at : dict of str to float
        Where ``max_rel`` occurs: ``{"time": t}``, ``{"frequency": f}``,
        ``{"v1": ..., "i1": ...}``; empty for an operating point.
    scale : float
        The denominator of ``max_rel`` (for AC the floor; the per-frequency
        scale is the larger magnitude at each frequency).
    scale_from : str
        ``"range"``, ``"magnitude"`` or ``"floor"``.
    passed : bool or None
        Within tolerance; None when the analysis has no tolerance.
    netdae, ngspice : float or None
        The two values (operating point), or the two values at ``at``.
    max_db, max_phase_deg : float or None
        AC only: the magnitude error in dB and the phase error in degrees.
    jump : dict or None
        Transient only, when the signal jumps at t0: ``netdae`` (consistent
        value), ``ngspice`` (its value at t0), ``settle_time``.
    whole : dict or None
        When the window starts after t0: ``max_abs``, ``max_rel``, ``at`` over
        the whole interval.
    """

    name: str
    max_abs: float
    max_rel: float
    rms: float
    at: dict[str, float]
    scale: float
    scale_from: str
    passed: bool | None
    netdae: float | None = None
    ngspice: float | None = None
    max_db: float | None = None
    max_phase_deg: float | None = None
    jump: dict[str, float] | None = None
    whole: dict[str, Any] | None = None

    def to_dict(self) -> dict:
        out = {
            "signal": self.name,
            "max_abs": self.max_abs,
            "max_rel": self.max_rel,
            "rms": self.rms,
            "at": self.at,
            "scale": self.scale,
            "scale_from": self.scale_from,
            "pass": self.passed,
            "netdae": self.netdae,
            "ngspice": self.ngspice,
        }
        for key in ("max_db", "max_phase_deg", "jump", "whole"):
            value = getattr(self, key)
            if value is not None:
                out[key] = value
        return jsonable(out)


@dataclass
class AnalysisComparison:
    """One analysis of the netlist, run by both simulators and compared.

    Attributes
    ----------
    analysis : str
        ``"op"``, ``"dc"``, ``"ac"`` or ``"tran"``.
    occurrence : int
        0 for the first analysis of its kind in the netlist, 1 for the second ...
    tolerance : Tolerance or None
        The pass criterion; None: compared but not judged.
    signals : list of SignalComparison
        Worst first.
    only_netdae, only_ngspice : list of str
        Signals one simulator produced and the other did not (not compared).
    excluded : list of str
        Signals in both that the caller left out.
    points : int
        Number of points compared (ngspice's).
    axis : str or None
        ``"time"``, ``"frequency"``, the swept source(s), None for op.
    window : dict or None
        Transient: ``{"from": t, "index": k, "reason": ...}`` when the metrics
        start after t0 because of an initial jump.
    notes : list of str
        What else the reader should know (points outside netdae's interval ...).
    error : str or None
        Why the analysis could not be compared (a simulator failed ...).
    netdae_tolerances, ngspice_tolerances : dict
        The tolerances each side used.
    curves : dict
        For plots: ``axis`` (ngspice's points) and per signal ``(netdae,
        ngspice)`` arrays at those points. Not part of the JSON.
    """

    analysis: str
    occurrence: int = 0
    tolerance: Tolerance | None = None
    signals: list[SignalComparison] = field(default_factory=list)
    only_netdae: list[str] = field(default_factory=list)
    only_ngspice: list[str] = field(default_factory=list)
    excluded: list[str] = field(default_factory=list)
    points: int = 0
    axis: str | None = None
    window: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    error: str | None = None
    netdae_tolerances: dict[str, Any] = field(default_factory=dict)
    ngspice_tolerances: dict[str, Any] = field(default_factory=dict)
    curves: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def judged(self) -> bool:
        """True when a tolerance applies (the analysis counts for the verdict)."""
        return self.tolerance is not None

    @property
    def passed(self) -> bool | None:
        """Verdict: every signal within tolerance and nothing failed; None when not judged."""
        if self.error is not None:
            return False
        if not self.judged:
            return None
        return bool(self.signals) and all(s.passed for s in self.signals)

    @property
    def worst(self) -> SignalComparison | None:
        """The signal with the largest relative error."""
        return self.signals[0] if self.signals else None

    def to_dict(self) -> dict:
        tol = None if self.tolerance is None else {"rel": self.tolerance.rel, "abs": self.tolerance.abs}
        return jsonable({
            "analysis": self.analysis,
            "occurrence": self.occurrence,
            "pass": self.passed,
            "tolerance": tol,
            "axis": self.axis,
            "points": self.points,
            "window": self.window,
            "initial_jump": {s.name: s.jump for s in self.signals if s.jump is not None},
            "signals": [s.to_dict() for s in self.signals],
            "only_netdae": self.only_netdae,
            "only_ngspice": self.only_ngspice,
            "excluded": self.excluded,
            "netdae_tolerances": self.netdae_tolerances,
            "ngspice_tolerances": self.ngspice_tolerances,
            "notes": self.notes,
            "error": self.error,
        })


@dataclass
class MeasureComparison:
    """One ``.meas`` card: netdae's value against ngspice's.

    Measurements are reported, not judged: ngspice prints them with 7
    significant digits, reads signals on straight lines between its points
    (netdae on its interpolant), and ngspice 39 cannot make some of them
    (``DERIV``, ``INTEGRAL``, ``v(a,b)``): a difference here says how the two
    measurements differ, not that a waveform is wrong.

    Attributes
    ----------
    name, analysis : str
    netdae, ngspice : Measure
        Each side's measurement (value or failure with its reason).
    """

    name: str
    analysis: str
    netdae: Any
    ngspice: Any

    @property
    def difference(self) -> float | None:
        """netdae's value minus ngspice's (None unless both were made)."""
        if self.netdae.ok and self.ngspice.ok:
            return float(self.netdae.value - self.ngspice.value)
        return None

    @property
    def relative(self) -> float | None:
        """``|difference|`` over the larger magnitude of the two (None: not both made, or both zero)."""
        diff = self.difference
        if diff is None:
            return None
        scale = max(abs(self.netdae.value), abs(self.ngspice.value))
        return abs(diff) / scale if scale > 0 else 0.0

    def to_dict(self) -> dict:
        return jsonable({"name": self.name, "analysis": self.analysis, "netdae": self.netdae.to_dict(),
                         "ngspice": self.ngspice.to_dict(), "difference": self.difference,
                         "relative": self.relative})


@dataclass
class Comparison:
    """netdae against ngspice on one netlist.

    Attributes
    ----------
    source : str
        The netlist's file name (``"<string>"`` for text).
    title : str
        Its title line.
    analyses : list of AnalysisComparison
        In netlist order.
    tight : bool
        Both simulators ran with tight tolerances (``--tight``).
    tolerance_source : str
        ``"argument"``, ``"header"`` (the netlist's ``* compare tolerance:``)
        or ``"default"``.
    ngspice_version, backend : str
        ``"ngspice-39"``, ``"shared"``/``"subprocess"`` (empty when ngspice failed).
    translations : list of str
        Every change the ngspice bridge made to the netlist (and every
        option it overrode), from :attr:`netdae.ngspice.NgspiceRun.notes`.
    ngspice_warnings : list of str
        ngspice's own warnings.
    ngspice_options : dict
        Options overridden in ngspice (empty: the netlist's own).
    netdae_options : dict
        Tolerance overrides passed to netdae (empty: the netlist's own).
    opamp_gain : float
        Gain of the VCVS that stands for netdae's ideal op-amp in ngspice.
    ngspice_error : str or None
        ngspice failed on the netlist (its message).
    measures : list of MeasureComparison
        The ``.meas`` cards, netdae against ngspice (reported, not judged).
    point : dict of str to float
        For one point of a stepped netlist: the value of each ``.step``.
    points : list of Comparison
        For a stepped netlist: one comparison per point (this one then has
        no analyses of its own); it passes when every point passes.
    """

    source: str
    title: str
    analyses: list[AnalysisComparison] = field(default_factory=list)
    tight: bool = False
    tolerance_source: str = "default"
    ngspice_version: str = ""
    backend: str = ""
    translations: list[str] = field(default_factory=list)
    ngspice_warnings: list[str] = field(default_factory=list)
    ngspice_options: dict[str, Any] = field(default_factory=dict)
    netdae_options: dict[str, Any] = field(default_factory=dict)
    opamp_gain: float = 0.0
    ngspice_error: str | None = None
    measures: list[MeasureComparison] = field(default_factory=list)
    point: dict[str, float] = field(default_factory=dict)
    points: list["Comparison"] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """True when ngspice ran, every analysis was compared and every judged one passed (every point's)."""
        if self.points:
            return all(p.passed for p in self.points)
        if self.ngspice_error is not None or not self.analyses:
            return False
        return all(a.passed is not False for a in self.analyses) and any(a.judged for a in self.analyses)

    def analysis(self, kind: str, occurrence: int = 0) -> AnalysisComparison:
        """The comparison of an analysis (``"tran"``, ...).

        Raises
        ------
        KeyError
            When the netlist has no such analysis.
        """
        for item in self.analyses:
            if item.analysis == kind and item.occurrence == occurrence:
                return item
        raise KeyError(f"no {kind} analysis #{occurrence} in this comparison")

    def to_dict(self) -> dict:
        """Everything in the report, as JSON-ready data."""
        return jsonable({
            "netlist": self.source,
            "title": self.title,
            "pass": self.passed,
            "tight": self.tight,
            "tolerance_source": self.tolerance_source,
            "ngspice": {
                "version": self.ngspice_version,
                "backend": self.backend,
                "options": self.ngspice_options,
                "opamp_gain": self.opamp_gain,
                "translations": self.translations,
                "warnings": self.ngspice_warnings,
                "error": self.ngspice_error,
            },
            "netdae": {"options": self.netdae_options},
            "analyses": [a.to_dict() for a in self.analyses],
            "measures": [m.to_dict() for m in self.measures],
            **({"point": self.point} if self.point else {}),
            **({"points": [p.to_dict() for p in self.points]} if self.points else {}),
        })
