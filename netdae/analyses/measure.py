"""Evaluate ``.meas`` measurements on analysis results (pure numerics: nothing printed, nothing read).

:func:`evaluate_measures` takes the elaborated cards
(:class:`~netdae.measures.MeasureSpec`, from ``circuit.measures``) and the
results of the analyses they name, and returns one
:class:`~netdae.measures.Measure` per card, in netlist order. A measurement
that cannot be made (a crossing that never happens, a time outside the
analysis, a signal the result does not hold, a ``PARAM`` of a failed
measurement) is a *failed* measure with the reason, as ngspice prints
``name = failed``.

How a signal is read between points
-----------------------------------
- ``tran``: on the integrator's interpolant (``Result.dense``), not on
  straight lines between output points. Crossings are bracketed on the
  accepted steps (each step sampled at its ends and three inner points) and
  solved on the interpolant to rounding (Brent's method); where the solution
  jumps (two points at one time: the left value and the right limit) a
  crossing inside the jump is at that time. ``AVG``, ``RMS`` and ``INTEG``
  integrate the interpolant with six-point Gauss-Legendre rules per step
  (exact for the method's polynomials, order <= 5, and their squares);
  ``MIN``/``MAX`` are refined between samples; ``DERIV`` differentiates the
  step's polynomial.
- ``ac`` and ``dc`` (any result without dense output): straight lines
  between the analysis points, as ngspice (``vdb``, ``vm``, ``vp`` ... are
  formed at the points, then interpolated linearly in frequency); ``AVG`` is
  the mean of those lines, ``INTEG`` and ``RMS`` integrate the points by
  ngspice 39's rule (Simpson's 3/8 and 1/3 rules where the points are evenly
  spaced, trapezoids elsewhere, ``y**2`` formed at the points:
  :meth:`_Lines.panels`). These are evaluated for many rows at once
  (:func:`evaluate_measure_rows`: the signals of a sweep's rows stacked,
  shape (rows, points)); one result is the case of one row, so a sweep's
  batched measures and a single run's are the same code.

A transient that failed part way is measured on what it computed where the
measurement needs nothing after its last point (:func:`_measure_partial`).

Crossings are counted as ngspice counts them: a rise is reaching the value
(``>=``) from below, a fall reaching it (``<=``) from above, so a signal that
ends on the value has crossed it (:func:`_events`); a point within 32
roundings of the value (:data:`~netdae.devices.autodiff.ROUNDING_TIE` times the
larger magnitude) is on it, and the crossing is where the signal first gets
that close. A stretch on the value is one arrival (ngspice 39 counts its later
points as crossings back and forth). Without ``RISE``/``FALL``/``CROSS`` the
first crossing of either kind counts. ``FROM`` and ``TO`` bound the window
(``TD`` starts the search of a crossing only, as in ngspice 39); window edges
are interpolated (ngspice 39 takes ``MIN``, ``MAX`` and ``AVG`` over the points
inside the window only).

Examples
--------
>>> import numpy as np
>>> from netdae.results import Result
>>> from netdae.netlist import load
>>> c = load("t\\nV1 a 0 1\\nR1 a 0 1\\n.dc V1 0 4 1\\n.meas dc x WHEN v(a)=2.5\\n.meas dc y PARAM='x*2'\\n")
>>> r = Result("dc", axes={"v1": np.arange(5.0)}, signals={"v(a)": np.arange(5.0)})
>>> [(m.name, m.value) for m in evaluate_measures(c.measures, {"dc": r})]
[('x', 2.5), ('y', 5.0)]
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ..devices.autodiff import ROUNDING_TIE
from ..measures import LAST, STATUS_FAILED, Condition, Measure, MeasureSpec, Probe, leaf_signal
from ..netlist import expr as ex
from ..results import Result

__all__ = ["evaluate_measures", "evaluate_measure_rows", "evaluate_measure_columns", "MeasureColumn", "MeasureFailure"]

#: Inner sample points per step of a transient (fractions of the step).
_INNER = np.array([0.25, 0.5, 0.75])
#: Gauss-Legendre nodes and weights on [0, 1] by power of the integrand: three points are exact
#: to degree 5 (a step's polynomial), six to degree 11 (its square).
_GL = {p: (0.5 * (x + 1.0), 0.5 * w) for p, (x, w) in ((1, np.polynomial.legendre.leggauss(3)),
                                                       (2, np.polynomial.legendre.leggauss(6)))}
#: Chebyshev points in (0, 1). A transient's dense output is one polynomial of degree at most 5
#: per step (BDF order <= 5), so its values at these six points give that polynomial exactly.
_CHEB = 0.5 - 0.5 * np.cos(np.pi * (np.arange(6) + 0.5) / 6)
#: Values at _CHEB -> coefficients (highest power first) of the degree-5 interpolant: its Vandermonde inverse.
_CHEB_FIT = np.linalg.inv(np.vander(_CHEB, 6))


class MeasureFailure(Exception):
    """A measurement that cannot be made; the message is the reason."""


# ---------------------------------------------------------------------------
# a real quantity along the axis
# ---------------------------------------------------------------------------
def _part(values: np.ndarray, part: str, analysis: str) -> np.ndarray:
    if analysis != "ac":
        return np.asarray(values, dtype=float).real
    z = np.asarray(values, dtype=complex)
    if part in ("", "r"):
        return z.real
    if part == "i":
        return z.imag
    if part == "m":
        return np.abs(z)
    if part == "p":
        return np.angle(z)
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(z))


def _values(result: Result, probe: Probe) -> np.ndarray:
    """The probe's real values at the points of ``result`` (its signals' shape).

    Raises
    ------
    MeasureFailure
        A signal the result does not hold; an expression that is not finite at a point.
    """
    if probe.expression is None:
        try:
            return _part(result[probe.signal.name], probe.part, result.analysis)
        except KeyError:
            raise MeasureFailure(f"{probe.signal.name} is not in the {result.analysis} result "
                                 "(not saved: add it to .save)") from None

    def lookup(leaf):
        if isinstance(leaf, ex.Time):
            return np.asarray(result.axis, dtype=float)
        name = leaf_signal(leaf).name
        try:
            return np.asarray(result[name], dtype=float)
        except KeyError:
            raise MeasureFailure(f"{name} (in {probe.name}) is not in the {result.analysis} result "
                                 "(not saved: add it to .save)") from None

    y = ex.evaluate_arrays(probe.expression, lookup)
    y = np.broadcast_to(y, np.shape(result.axis) if y.ndim == 0 else y.shape)
    bad = ~np.isfinite(y)
    if bad.any():
        x = np.broadcast_to(np.asarray(result.axis, dtype=float), y.shape)[bad].ravel()[0]
        raise MeasureFailure(f"{probe.name} is not finite at {result.axis_name}={x:g}")
    return y


class _Traces:
    """The traces of one evaluation, one per result and quantity: a quantity that several measurements
    read (``MAX``, ``MIN``, ``PP``, a ``WHEN`` of ``v(out)``) is read and sampled once."""

    def __init__(self) -> None:
        self._traces: dict = {}

    def get(self, result: Result, probe: Probe) -> "_Trace":
        key = (id(result), probe.name)
        trace = self._traces.get(key)
        if trace is None:
            trace = self._traces[key] = _Trace(result, probe)
        return trace


class _Trace:
    """One real quantity of a transient with dense output: its values at the steps and between them.

    (Results without dense output are read on straight lines by :class:`_Lines`.)
    """

    def __init__(self, result: Result, probe: Probe) -> None:
        self.name = probe.name
        self.x = np.asarray(result.axis, dtype=float)
        self.y = _values(result, probe)
        self._whole: tuple[np.ndarray, np.ndarray] | None = None

        def dense(t, _r=result, _p=probe):
            t = np.atleast_1d(np.asarray(t, dtype=float))
            signals = _r.dense(t)
            if _p.expression is None and _p.signal.name in signals:  # what _values reads, without a Result
                return _part(signals[_p.signal.name], _p.part, "tran")
            return _values(Result("tran", axes={"time": t}, signals=signals), _p)
        self.dense = dense

    @property
    def span(self) -> tuple[float, float]:
        return float(self.x[0]), float(self.x[-1])

    def at(self, xq) -> np.ndarray:
        """Values at ``xq`` (left values at a jump)."""
        return self.dense(np.atleast_1d(np.asarray(xq, dtype=float)))

    def samples(self, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
        """Points in [lo, hi] in order (ends included, and inner points of every step).

        The sample grid of the whole run is made once and kept (the measurements of a quantity
        that look at all of it share it); a window inside the run samples its own steps.
        """
        x, y = self.x, self.y
        ends = None
        if x.size > 1:
            # only the steps that overlap [lo, hi]
            first = max(int(np.searchsorted(x, lo, side="right")) - 1, 0)
            last = min(int(np.searchsorted(x, hi, side="left")) + 1, x.size)
            if first == 0 and last == x.size:
                if self._whole is None:
                    self._whole = self._grid(x, y)[:2]
                x, y = self._whole
            else:  # the window's ends in the same dense evaluation as its steps' inner points
                x, y, ends = self._grid(x[first:last], y[first:last], np.array([lo, hi], dtype=float))
        keep = (x > lo) & (x < hi)
        if ends is None:
            ends = self.at([lo, hi])
        return np.concatenate([[lo], x[keep], [hi]]), np.concatenate([[ends[0]], y[keep], [ends[1]]])

    def _grid(self, x: np.ndarray, y: np.ndarray,
              extra: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The points ``x`` and the inner points of every step between them, with their values; and the
        values at the times ``extra`` (None without them), from the same dense evaluation (point by point:
        the values are those of separate evaluations)."""
        more = 0 if extra is None else extra.size
        at_extra = None
        if x.size > 1:
            h = np.diff(x)
            xs = (x[:-1, None] + h[:, None] * np.concatenate([[0.0], _INNER])[None, :])
            ys = np.empty_like(xs)
            ys[:, 0] = y[:-1]
            inner = h > 0
            if inner.any():
                tq = xs[inner, 1:].ravel()
                values = self.dense(tq if not more else np.concatenate([tq, extra]))
                ys[inner, 1:] = values[:tq.size].reshape(-1, _INNER.size)
                at_extra = values[tq.size:] if more else None
            ys[~inner, 1:] = y[:-1][~inner, None]
            x = np.append(xs.ravel(), x[-1])
            y = np.append(ys.ravel(), y[-1])
        if more and at_extra is None:
            at_extra = self.at(extra)
        return x, y, at_extra

    def integral(self, lo: float, hi: float, power: int) -> float:
        """The integral of ``y**power`` over [lo, hi]."""
        knots = np.unique(np.concatenate([[lo], self.x[(self.x > lo) & (self.x < hi)], [hi]]))
        a, b = knots[:-1], knots[1:]
        gl_x, gl_w = _GL[power]
        nodes = a[:, None] + (b - a)[:, None] * gl_x[None, :]
        values = self.dense(nodes.ravel()).reshape(nodes.shape) ** power
        return float(np.sum((b - a) * (values @ gl_w)))

    def polynomials(self, steps: np.ndarray) -> np.ndarray:
        """The dense output on each step ``[x[i-1], x[i]]`` as a polynomial in ``s = (t - x[i-1]) / h``.

        Parameters
        ----------
        steps : ndarray of int, shape (m,)
            Indices ``i`` of steps of positive length.

        Returns
        -------
        ndarray, shape (m, 6)
            Coefficients, highest power first (``np.polyval``); one dense
            evaluation for all steps.
        """
        a, b = self.x[steps - 1], self.x[steps]
        values = self.dense((a[:, None] + (b - a)[:, None] * _CHEB[None, :]).ravel()).reshape(-1, _CHEB.size)
        return values @ _CHEB_FIT.T

    def derivative(self, xq: float) -> float:
        """The slope at ``xq``: of its step's polynomial."""
        x = self.x
        i = int(np.clip(np.searchsorted(x, xq, side="left"), 1, x.size - 1))
        while i < x.size - 1 and x[i] == x[i - 1]:
            i += 1
        a, b = x[i - 1], x[i]
        if b == a:
            raise MeasureFailure(f"{self.name} jumps at {xq:g}: no derivative there")
        coef = self.polynomials(np.array([i]))[0]
        return float(np.polyval(np.polyder(coef), (xq - a) / (b - a)) / (b - a))


# ---------------------------------------------------------------------------
# crossings
# ---------------------------------------------------------------------------
def _root(g, a: float, b: float, ga: float, gb: float) -> float:
    from scipy.optimize import brentq

    def wrapped(t):
        return ga if t == a else gb if t == b else float(g(t))

    return float(brentq(wrapped, a, b, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200))


def _sides(d: np.ndarray, tie: np.ndarray) -> np.ndarray:
    """Each point's side of the value: +1 above, -1 below, 0 on it (``|d| <= tie``)."""
    return np.where(d > tie, 1, np.where(d < -tie, -1, 0)).astype(np.int8)


def _events(side: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The crossings between consecutive points, from their sides (:func:`_sides`).

    A rise is reaching the value (``>=``) from below, a fall reaching it (``<=``)
    from above, as ngspice 39 counts them: a signal that ends on the value has
    crossed it. A stretch on the value is one arrival: where it leaves back to
    the side it came from, that is the opposite crossing (a touch from below is a
    rise and a fall); where it goes on to the other side, nothing more. A start on
    the value is no crossing.

    Parameters
    ----------
    side : ndarray of int, shape (rows, s)

    Returns
    -------
    kind : ndarray of int, shape (rows, s - 1)
        Between points k and k + 1: +1 a rise, -1 a fall, 0 none.
    where : ndarray of int, shape (rows, s - 1)
        Where that crossing is: 0 between the points, 1 where the signal
        reaches the value (at or before point k + 1), 2 where it leaves it
        (at or after point k).
    """
    prev, cur = side[:, :-1], side[:, 1:]
    n = side.shape[1]
    last = np.maximum.accumulate(np.where(side != 0, np.arange(n)[None, :], -1), axis=1)
    came = np.where(last >= 0, np.take_along_axis(side, np.maximum(last, 0), axis=1), 0)[:, :-1]
    through = (prev != 0) & (cur != 0) & (prev != cur)
    reach = (prev != 0) & (cur == 0)
    leave = (prev == 0) & (cur != 0) & (came == cur)
    kind = np.where(through | leave, cur, np.where(reach, -prev, 0)).astype(np.int8)
    where = np.where(reach, 1, np.where(leave, 2, 0)).astype(np.int8)
    return kind, where


def _tie(*values) -> np.ndarray:
    """Half the width of a tie with the value (:data:`~netdae.devices.autodiff.ROUNDING_TIE` times the
    larger magnitude)."""
    return ROUNDING_TIE * np.maximum.reduce([np.abs(np.asarray(v, dtype=float)) for v in values])


def _crossings(trace: _Trace, cond: Condition, lo: float, hi: float, other: _Trace | None):
    """Every crossing in [lo, hi], in order, and where one is.

    Returns
    -------
    events : list of (int, str)
        Each crossing's sample interval and ``"rise"`` or ``"fall"`` (:func:`_events`).
    locate : callable
        ``locate(event) -> float``: the crossing's axis value, solved on the interpolant. Only the
        crossing a measurement asks for is solved (a long transient crosses its value thousands of
        times, and counting them needs only the samples).
    """
    xs, ys = trace.samples(lo, hi)
    ref = other.at(xs) if other is not None else np.full_like(ys, cond.value)
    d = ys - ref
    kind, where = (a[0] for a in _events(_sides(d, _tie(ys, ref))[None, :]))

    def g(t, shift):
        value = trace.at([t])[0]
        ref = other.at([t])[0] if other is not None else cond.value
        return value - ref + shift * float(_tie(value, ref))

    def locate(event) -> float:
        k, edge = event
        a, b = xs[k], xs[k + 1]
        up = edge == "rise"
        if a == b:
            return float(a)
        # between: d's zero; reaching: the first point within the tie; leaving: the last
        shift = (0.0, 1.0 if up else -1.0, -1.0 if up else 1.0)[where[k]]
        ga, gb = g(a, shift), g(b, shift)
        if ga * gb > 0:  # the interpolant at the sample points disagrees with the samples by rounding
            return float(a if where[k] == 2 else b)
        return float(a if ga == 0 else b if gb == 0 else _root(lambda u: g(u, shift), a, b, ga, gb))

    events = [(k, "rise" if kind[k] > 0 else "fall") for k in np.flatnonzero(kind).tolist()]
    return events, locate


def _ordinal(n: int) -> str:
    return {1: "first", 2: "second", 3: "third"}.get(n, f"{n}th")


def _search_window(spec: MeasureSpec, cond: Condition, clause: str, span: tuple[float, float]) -> tuple[float, float]:
    """Where a condition is looked for: after its TD (a transient's only), within its FROM/TO, inside ``span``.

    A ``WHEN`` clause's ``FROM=``/``TO=`` are the measurement's; a ``TRIG`` or ``TARG`` clause's are
    written in it, and one without ``FROM=`` takes the other clause's (ngspice 39 does so: ``TRIG
    v(a) VAL=0.5 RISE=2 TARG v(b) VAL=0.5 RISE=1 FROM=30u`` counts the trigger's rises from 30 us too,
    while ``TO=`` stays the clause's own).

    Raises
    ------
    MeasureFailure
        The window is empty.
    """
    x0, x1 = span
    if clause == "WHEN":
        start, stop = spec.start, spec.stop
    else:  # TRIG, TARG: the clause's own FROM= (else the other clause's, as ngspice 39) and TO=
        other = spec.targ if clause == "TRIG" else spec.trig
        start = cond.start if cond.start is not None else other.start if other is not None else None
        stop = cond.stop
        if spec.analysis == "dc" and start is not None and stop is not None and stop < start:
            start, stop = stop, start  # as a dc measurement's window: ordered
    td = cond.td if spec.analysis == "tran" else -math.inf  # ngspice 39 reads TD= in transients only
    lo = max(x0, td, start if start is not None else x0)
    hi = min(x1, stop) if stop is not None else x1
    if lo > hi:
        raise MeasureFailure(f"{clause}: the window [{lo:g}, {hi:g}] is empty (the analysis covers {x0:g} to {x1:g})")
    return lo, hi


def _find_crossing(spec: MeasureSpec, result: Result, cond: Condition, clause: str,
                   traces: _Traces | None = None) -> float:
    if cond.at is not None:
        return cond.at
    traces = _Traces() if traces is None else traces
    trace = traces.get(result, cond.probe)
    other = traces.get(result, cond.other) if cond.other is not None else None
    lo, hi = _search_window(spec, cond, clause, trace.span)
    events, locate = _crossings(trace, cond, lo, hi, other)
    wanted = [e for e in events if cond.edge in ("", "cross") or e[1] == cond.edge]
    target = other.name if other is not None else f"{cond.value:g}"
    if not wanted:
        kind = {"rise": "rises through", "fall": "falls through"}.get(cond.edge, "crosses")
        raise MeasureFailure(f"{clause}: {trace.name} never {kind} {target} in [{lo:g}, {hi:g}]")
    if cond.count == LAST:
        return locate(wanted[-1])
    if cond.count > len(wanted):
        edge = cond.edge or "cross"
        raise MeasureFailure(f"{clause}: {trace.name} has {len(wanted)} {edge}(s) through {target} in "
                             f"[{lo:g}, {hi:g}], the {_ordinal(cond.count)} was asked")
    return locate(wanted[cond.count - 1])


def _inside(result: Result, x: float, what: str) -> None:
    x0, x1 = sorted((float(result.axis[0]), float(result.axis[-1])))
    fuzz = 1e-12 * max(abs(x0), abs(x1), x1 - x0)
    if not (x0 - fuzz <= x <= x1 + fuzz):
        raise MeasureFailure(f"{what}={x:g} is outside the {result.analysis} analysis ({x0:g} to {x1:g})")


# ---------------------------------------------------------------------------
# one measurement
# ---------------------------------------------------------------------------
def _window(spec: MeasureSpec, trace: _Trace) -> tuple[float, float]:
    x0, x1 = trace.span
    lo = x0 if spec.start is None else max(x0, spec.start)
    hi = x1 if spec.stop is None else min(x1, spec.stop)
    if not lo < hi:  # the window as written (FROM=2m TO=3m beyond a 1 ms run, not the clipped FROM=2m TO=1m)
        start = lo if spec.start is None else spec.start
        stop = hi if spec.stop is None else spec.stop
        raise MeasureFailure(f"the window FROM={start:g} TO={stop:g} holds no part of the analysis ({x0:g} to {x1:g})")
    return lo, hi


#: Points per step where :func:`_peaks` looks for the largest value before Newton refines it.
_PEAK_GRID = np.linspace(0.0, 1.0, 33)


def _peaks(coef: np.ndarray, s_lo: np.ndarray, s_hi: np.ndarray, sign: float) -> tuple[np.ndarray, np.ndarray]:
    """The largest ``sign * p(s)`` of each step polynomial on ``(s_lo, s_hi)``, where ``p' = 0`` inside.

    Parameters
    ----------
    coef : ndarray, shape (m, d + 1)
        Coefficients, highest power first (:meth:`_Trace.polynomials`).
    s_lo, s_hi : ndarray, shape (m,)
        The part of each step in the window, in ``s`` in [0, 1].
    sign : float
        +1 for a maximum, -1 for a minimum.

    Returns
    -------
    s : ndarray, shape (m,)
        The best of 33 points, refined by Newton on ``p'`` (quadratic
        convergence to rounding from there; kept only where it is better).
    inside : ndarray of bool, shape (m,)
        Where ``s`` lies strictly inside ``(s_lo, s_hi)`` (an extreme at an
        end is among the samples already).

    Notes
    -----
    In compiled code (:func:`netdae.dae.compiled.dense.polynomial_peaks`, a
    transient's measurement runs where the engine is loaded): about 1 us a
    step, where Python floats cost about 30 us and a polynomial root finder
    about 120 us.
    """
    from ..dae.compiled.dense import polynomial_peaks

    s_lo = np.ascontiguousarray(s_lo, dtype=float)
    s_hi = np.ascontiguousarray(s_hi, dtype=float)
    s_out = np.zeros(coef.shape[0])
    polynomial_peaks(np.ascontiguousarray(coef, dtype=float), s_lo, s_hi, float(sign), _PEAK_GRID, s_out)
    return s_out, (s_out > s_lo) & (s_out < s_hi)


def _extreme(trace: _Trace, lo: float, hi: float, sign: float, samples=None) -> tuple[float, float]:
    """(value, where) of the largest ``sign * y`` in [lo, hi].

    The best of the samples (:meth:`_Trace.samples`, or ``samples``), refined
    on a transient's dense output: the stationary points of the step
    polynomials next to it (:meth:`_Trace.polynomials`), each then evaluated on
    the dense output itself, so the value is always the solution's. Two dense
    evaluations in all. On a stretch at the extreme, where is where the stretch
    begins (:func:`_first_arrival`).
    """
    xs, ys = trace.samples(lo, hi) if samples is None else samples
    k = int(np.argmax(sign * ys))
    best, where = float(ys[k]), float(xs[k])
    if xs.size <= 2:
        return best, where
    a, b = xs[max(k - 1, 0)], xs[min(k + 1, xs.size - 1)]
    x = trace.x
    first = max(int(np.searchsorted(x, a, side="right")), 1)
    last = min(int(np.searchsorted(x, b, side="left")), x.size - 1)
    steps = np.array([i for i in range(first, last + 1) if x[i] > x[i - 1]], dtype=np.int64)
    if b <= a or steps.size == 0:
        return best, where
    t0, h = x[steps - 1], x[steps] - x[steps - 1]
    s_lo, s_hi = (np.maximum(a, t0) - t0) / h, (np.minimum(b, x[steps]) - t0) / h
    s, inside = _peaks(trace.polynomials(steps), s_lo, s_hi, sign)
    if inside.any():
        tc = (t0 + h * s)[inside]
        yc = trace.at(tc)
        j = int(np.argmax(sign * yc))
        if sign * yc[j] > sign * best:
            best, where = float(yc[j]), float(tc[j])
    return best, _first_arrival(xs, ys, best, where, sign)


def _first_arrival(xs: np.ndarray, ys: np.ndarray, best: float, where: float, sign: float) -> float:
    """Where the samples first come within rounding of the extreme ``best`` (found at ``where``).

    A stretch at the extreme (a pulse's plateau, a clipped output) is one value to rounding, and the
    interpolant's last bits on it decide which of its points is largest: the extreme is where the
    stretch begins, its first sample within :func:`_tie` of ``best``, ``where`` itself when no sample
    before it is that close. (ngspice 39 takes the point its last bits make largest: on a pulse's
    plateau of values 1.0 to 15 digits, its last point.)
    """
    close = np.flatnonzero(sign * ys >= sign * best - _tie(best))
    return float(xs[close[0]]) if close.size and xs[close[0]] < where else where


def _measure(spec: MeasureSpec, result: Result, traces: _Traces | None = None) -> Measure:
    """One measurement of a transient with dense output (:func:`_measure_rows` reads the others).

    ``traces`` holds the quantities read so far in this evaluation (:class:`_Traces`)."""
    traces = _Traces() if traces is None else traces
    f = spec.function
    out = Measure(spec.name, spec.analysis, f, None)
    if f == "trig":
        trig = _find_crossing(spec, result, spec.trig, "TRIG", traces)
        targ = _find_crossing(spec, result, spec.targ, "TARG", traces)
        out.value, out.extra = targ - trig, {"targ": targ, "trig": trig}
        return out
    if f == "when":
        out.value = out.at = _find_crossing(spec, result, spec.when, "WHEN", traces)
        return out
    trace = traces.get(result, spec.probe)
    if f in ("find", "deriv"):
        if spec.when is not None:
            x = _find_crossing(spec, result, spec.when, "WHEN", traces)
        else:
            x = spec.at
            _inside(result, x, "AT")
        out.at = x
        out.value = float(trace.at([x])[0]) if f == "find" else trace.derivative(x)
        return out
    lo, hi = _window(spec, trace)
    if f in ("min", "max"):
        out.value, out.at = _extreme(trace, lo, hi, 1.0 if f == "max" else -1.0)
    elif f in ("min_at", "max_at"):  # ngspice's MIN_AT/MAX_AT: where the extremum is, "with" its value
        value, out.at = _extreme(trace, lo, hi, 1.0 if f == "max_at" else -1.0)
        out.value, out.extra = out.at, {"with": value}
    elif f == "pp":
        samples = trace.samples(lo, hi)
        top, _ = _extreme(trace, lo, hi, 1.0, samples)
        bottom, _ = _extreme(trace, lo, hi, -1.0, samples)
        # a stretch constant to rounding (a pulse's plateau, whose interpolant's last bits wander) has
        # no swing: extremes within 32 roundings of each other are one value, as the crossings read them
        out.value = top - bottom if top - bottom > float(_tie(top, bottom)) else 0.0
    elif f == "integ":
        out.value = trace.integral(lo, hi, 1)
    elif f == "avg":
        out.value = trace.integral(lo, hi, 1) / (hi - lo)
    else:  # rms
        out.value = math.sqrt(max(trace.integral(lo, hi, 2), 0.0) / (hi - lo))
    if f in ("pp", "integ", "avg", "rms"):
        out.extra = {"from": lo, "to": hi}
    return out


# ---------------------------------------------------------------------------
# results without dense output: straight lines between the points, for many rows at once
# ---------------------------------------------------------------------------
def _interp(xq, x: np.ndarray, y: np.ndarray, per_row: bool = False) -> np.ndarray:
    """``np.interp(xq, x, row)`` for every row of ``y`` (shape (rows, points)), with numpy's arithmetic.

    ``xq`` is shared by the rows (shape (q,): the result has shape (rows, q))
    or, with ``per_row``, one point per row (shape (rows,): the result too).
    Outside the axis the end values; at a point its value; else
    ``slope * (xq - x[j]) + y[j]``, the slope ``(y[j+1] - y[j]) / (x[j+1] - x[j])``,
    as numpy's ``interp`` computes them.
    """
    xq = np.asarray(xq, dtype=float)
    j = np.clip(np.searchsorted(x, xq, side="right") - 1, 0, x.size - 2)
    if per_row:
        r = np.arange(y.shape[0])
        y0, y1, first, last = y[r, j], y[r, j + 1], y[:, 0], y[:, -1]
    else:
        y0, y1, first, last = y[:, j], y[:, j + 1], y[:, :1], y[:, -1:]
    x0 = x[j]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        out = (y1 - y0) / (x[j + 1] - x0) * (xq - x0) + y0
    out = np.where(xq == x0, y0, out)
    out = np.where(xq < x[0], first, out)
    return np.where(xq >= x[-1], last, out)


class _Lines:
    """One real quantity of one or many rows on straight lines between the points of the axis.

    The axis increases, or decreases (a ``.dc`` sweep written from its top, ``.dc v1 5 0 -0.1``):
    then the lines are kept on the increasing axis ``-x`` (``sense`` -1), every argument and
    result is in ``x``, and :meth:`samples` gives the points in the sweep's order, so that
    crossings are counted as the sweep meets them (as ngspice counts them).
    """

    def __init__(self, result: Result, probe: Probe) -> None:
        self.name = probe.name
        x = np.asarray(result.axis, dtype=float)
        self.sense = -1.0 if x.size > 1 and x[-1] < x[0] else 1.0
        self.x = self.sense * x  # increasing
        self.y = np.atleast_2d(_values(result, probe))

    @property
    def span(self) -> tuple[float, float]:
        """The axis's lowest and highest value."""
        ends = sorted((self.sense * float(self.x[0]), self.sense * float(self.x[-1])))
        return ends[0], ends[1]

    def at(self, xq, per_row: bool = False) -> np.ndarray:
        """Values at ``xq``: shape (rows, q), or (rows,) with one point per row (``per_row``)."""
        return _interp(self.sense * np.asarray(xq, dtype=float), self.x, self.y, per_row)

    def samples(self, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
        """The points in [lo, hi], ends included, in the sweep's order: axis (s,), values (rows, s)."""
        a, b = sorted((self.sense * lo, self.sense * hi))
        x = self.x
        keep = (x > a) & (x < b)
        ends = _interp([a, b], x, self.y)
        return (self.sense * np.concatenate([[a], x[keep], [b]]),
                np.concatenate([ends[:, :1], self.y[:, keep], ends[:, 1:]], axis=1))

    def integral(self, lo: float, hi: float) -> np.ndarray:
        """The integral over [lo, hi] of each row's lines (exact)."""
        lo, hi = sorted((self.sense * lo, self.sense * hi))
        knots = np.unique(np.concatenate([[lo], self.x[(self.x > lo) & (self.x < hi)], [hi]]))
        a, b = knots[:-1], knots[1:]
        ya, yb = _interp(a, self.x, self.y), _interp(b, self.x, self.y)
        return np.sum((b - a) * (ya + yb) / 2.0, axis=1)

    def panels(self, lo: float, hi: float, power: int) -> np.ndarray:
        """The integral of ``y**power`` over [lo, hi] of each row by ngspice 39's rule (INTEG, RMS).

        ngspice's ``measure_rms_integral`` integrates the points, not the lines:
        the first point at or after the window's start is moved to it (its value
        interpolated; not where it is within 100 ulps of it), the points follow
        up to the window's end, and the first point past the end is moved to
        it. Then, from the first point, three intervals of equal width
        (:func:`_same_width`) take Simpson's 3/8 rule, else two Simpson's 1/3
        rule, else one a trapezoid. ``y**power`` is formed at the points. Along
        the increasing axis (:attr:`x`): a sweep written from its top is
        integrated from its top, and :meth:`panels` of it is the negative of
        ngspice's value.
        """
        x = self.x
        a, b = sorted((self.sense * lo, self.sense * hi))
        first = int(np.searchsorted(x, a, side="left"))
        after = int(np.searchsorted(x, b, side="right"))  # the first point past the end
        keep = list(range(first, min(after, x.size)))
        xs = x[keep].astype(float)
        ys = self.y[:, keep]
        if keep and keep[0] > 0 and not _same_width(xs[0], a):
            xs[0], ys[:, 0] = a, _interp([a], x, self.y)[:, 0]
        if after < x.size:
            tail = (x[after], self.y[:, after]) if _same_width(x[after], b) else (b, _interp([b], x, self.y)[:, 0])
            xs, ys = np.append(xs, tail[0]), np.concatenate([ys, tail[1][:, None]], axis=1)
        if xs.size < 2:  # the window between two points: its interpolated ends
            xs = np.array([a, b])
            ys = _interp(xs, x, self.y)
        # summed row by row: a matrix product's rounding would depend on how many rows are stacked
        return np.sum(np.ascontiguousarray(ys) ** power * _panel_weights(xs), axis=1)

    def derivative(self, xq: np.ndarray) -> tuple[np.ndarray, list]:
        """The slope of the line at each row's ``xq``, and why a row has none (None: it has).

        At an inner point of the axis, where the line on its left and the line on its right meet,
        the slope is the derivative of the parabola through the point and its two neighbours
        (with equal spacing: the central difference), not the left line's.
        """
        x = self.x
        i = np.clip(np.searchsorted(x, self.sense * np.asarray(xq, dtype=float), side="left"), 1, x.size - 1)
        while True:
            same = (i < x.size - 1) & (x[i] == x[i - 1])
            if not same.any():
                break
            i = i + same
        a, b = x[i - 1], x[i]
        rows = np.arange(self.y.shape[0])
        y = self.y
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = self.sense * (y[rows, i] - y[rows, i - 1]) / (b - a)
            # on an inner point of the axis (to rounding) the lines have two slopes: take the derivative
            # of the parabola through the point and its neighbours, second order as a line's slope is
            # between two points
            xs = self.sense * np.asarray(xq, dtype=float)
            k = np.where(np.abs(xs - a) <= np.abs(xs - b), i - 1, i)
            km, kp = np.clip(k - 1, 0, x.size - 1), np.clip(k + 1, 0, x.size - 1)
            h1, h2 = x[k] - x[km], x[kp] - x[k]
            on = ((k > 0) & (k < x.size - 1) & (h1 > 0) & (h2 > 0)
                  & (np.abs(xs - x[k]) <= _tie(x[k], h1 + h2)))
            if np.any(on):
                d = (h1 ** 2 * (y[rows, kp] - y[rows, k]) + h2 ** 2 * (y[rows, k] - y[rows, km])) / (h1 * h2 * (h1 + h2))
                slope = np.where(on, self.sense * d, slope)
        reasons = [f"{self.name} jumps at {q:g}: no derivative there" if jump else None
                   for q, jump in zip(np.atleast_1d(xq).tolist(), (b == a).tolist())]
        return slope, reasons


def _same_width(a, b, ulps: int = 100) -> np.ndarray:
    """Whether ``a`` and ``b`` are within ``ulps`` units in the last place (ngspice's ``AlmostEqualUlps``:
    the doubles' bits as ordered integers)."""
    def ordered(v):
        i = np.asarray(v, dtype=float).view(np.int64)
        return np.where(i < 0, np.iinfo(np.int64).min - i, i)

    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    with np.errstate(over="ignore"):
        return (a == b) | (np.abs(ordered(a) - ordered(b)) <= ulps)


def _panel_weights(x: np.ndarray) -> np.ndarray:
    """The weights of ngspice 39's integration rule on the points ``x`` (:meth:`_Lines.panels`)."""
    h = np.concatenate([np.diff(x), [0.0, 0.0]])
    next1, next2 = _same_width(h[:-2], h[1:-1]).tolist(), _same_width(h[:-2], h[2:]).tolist()
    w = np.zeros(x.size + 3)  # a panel over the zero widths past the last point reaches beyond it (weight 0)
    i, n = 0, x.size - 1
    while i < n:
        if next1[i] and next2[i]:
            w[i:i + 4] += 3.0 * h[i] / 8.0 * np.array([1.0, 3.0, 3.0, 1.0])
            i += 3
        elif next1[i]:
            w[i:i + 3] += h[i] / 3.0 * np.array([1.0, 4.0, 1.0])
            i += 2
        else:
            w[i:i + 2] += h[i] / 2.0
            i += 1
    return w[:x.size]


def _crossing_rows(spec: MeasureSpec, result: Result, cond: Condition, clause: str,
                   rows: int) -> tuple[np.ndarray, list]:
    """Each row's crossing asked by ``cond`` (NaN where it fails) and why a row has none (None: it has).

    Crossings are counted as in the module docstring (:func:`_events`); one reaching the value is
    at the point that reaches it, one leaving it at the last point on it.

    Raises
    ------
    MeasureFailure
        What fails for every row (an empty window, a signal not in the result).
    """
    if cond.at is not None:
        return np.full(rows, float(cond.at)), [None] * rows
    trace = _Lines(result, cond.probe)
    other = _Lines(result, cond.other) if cond.other is not None else None
    lo, hi = _search_window(spec, cond, clause, trace.span)
    xs, ys = trace.samples(lo, hi)
    ref = other.at(xs) if other is not None else np.full_like(ys, cond.value)
    d = ys - ref
    edges, where = _events(_sides(d, _tie(ys, ref)))
    wanted = edges > 0 if cond.edge == "rise" else edges < 0 if cond.edge == "fall" else edges != 0
    counts = wanted.sum(axis=1)
    if cond.count == LAST:
        k = wanted.shape[1] - 1 - np.argmax(wanted[:, ::-1], axis=1)
    else:
        k = np.argmax(np.cumsum(wanted, axis=1) >= cond.count, axis=1)
    r = np.arange(d.shape[0])
    a, b, da, db, at = xs[k], xs[k + 1], d[r, k], d[r, k + 1], where[r, k]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = a + (0.0 - da) * (b - a) / (db - da)
    t = np.where((a == b) | (at == 2), a, np.where(at == 1, b, t))
    target = other.name if other is not None else f"{cond.value:g}"
    kind = {"rise": "rises through", "fall": "falls through"}.get(cond.edge, "crosses")
    reasons: list = []
    for n in counts.tolist():
        if n == 0:
            reasons.append(f"{clause}: {trace.name} never {kind} {target} in [{lo:g}, {hi:g}]")
        elif cond.count != LAST and cond.count > n:
            reasons.append(f"{clause}: {trace.name} has {n} {cond.edge or 'cross'}(s) through {target} in "
                           f"[{lo:g}, {hi:g}], the {_ordinal(cond.count)} was asked")
        else:
            reasons.append(None)
    return np.where([why is None for why in reasons], t, np.nan), reasons


def _extreme_rows(trace: _Lines, sign: float, samples) -> tuple[np.ndarray, np.ndarray]:
    """(value, where) of the largest ``sign * y`` among the samples of each row."""
    xs, ys = samples
    k = np.argmax(sign * ys, axis=1)
    return ys[np.arange(ys.shape[0]), k], xs[k]


def _measure_rows(spec: MeasureSpec, result: Result, rows: int) -> list[Measure]:
    """One measurement of every row of a result without dense output (signals shaped (rows, points)).

    Raises
    ------
    MeasureFailure
        What fails for every row.
    """
    f = spec.function
    value, at, extra, reasons = _measure_columns(spec, result, rows)
    out = []
    for r in range(rows):
        if reasons[r] is not None:
            out.append(Measure(spec.name, spec.analysis, f, None, status=STATUS_FAILED, reason=reasons[r]))
            continue
        m = Measure(spec.name, spec.analysis, f, float(value[r]))
        if at is not None:
            m.at = float(at[r])
        if extra:
            m.extra = {k: float(v) if np.ndim(v) == 0 else float(v[r]) for k, v in extra.items()}
        out.append(m)
    return out


def _measure_columns(spec: MeasureSpec, result: Result, rows: int) -> tuple[np.ndarray, np.ndarray | None, dict,
                                                                            list]:
    """The arrays of :func:`_measure_rows`: ``(value, at, extra, reasons)``, ``reasons[r]`` None where row r has
    its value.

    Raises
    ------
    MeasureFailure
        What fails for every row.
    """
    f = spec.function
    at = None
    extra: dict = {}
    reasons: list = [None] * rows
    if f == "trig":
        trig, why_trig = _crossing_rows(spec, result, spec.trig, "TRIG", rows)
        targ, why_targ = _crossing_rows(spec, result, spec.targ, "TARG", rows)
        value, extra = targ - trig, {"targ": targ, "trig": trig}
        reasons = [a or b for a, b in zip(why_trig, why_targ)]
    elif f == "when":
        value, reasons = _crossing_rows(spec, result, spec.when, "WHEN", rows)
        at = value
    else:
        trace = _Lines(result, spec.probe)
        if f in ("find", "deriv"):
            if spec.when is not None:
                at, reasons = _crossing_rows(spec, result, spec.when, "WHEN", rows)
            else:
                _inside(result, spec.at, "AT")
                at = np.full(rows, float(spec.at))
            if f == "find":
                value = trace.at(at, per_row=True)
            else:
                value, why = trace.derivative(at)
                reasons = [a or b for a, b in zip(reasons, why)]
        else:
            if trace.x.size == 1:
                value, at, extra = _one_point(spec, trace)
            else:
                lo, hi = _window(spec, trace)
                if f in ("min", "max"):
                    value, at = _extreme_rows(trace, 1.0 if f == "max" else -1.0, trace.samples(lo, hi))
                elif f in ("min_at", "max_at"):
                    top, at = _extreme_rows(trace, 1.0 if f == "max_at" else -1.0, trace.samples(lo, hi))
                    value, extra = at, {"with": top}
                elif f == "pp":
                    samples = trace.samples(lo, hi)
                    value = _extreme_rows(trace, 1.0, samples)[0] - _extreme_rows(trace, -1.0, samples)[0]
                elif f == "integ":  # along the sweep, as ngspice: a decreasing .dc sweep integrates from hi to lo
                    value = trace.sense * trace.panels(lo, hi, 1)
                elif f == "avg":
                    value = trace.integral(lo, hi) / (hi - lo)
                else:  # rms
                    value = np.sqrt(np.maximum(trace.panels(lo, hi, 2), 0.0) / (hi - lo))
                if f in ("pp", "integ", "avg", "rms"):
                    extra = {"from": lo, "to": hi} if trace.sense > 0 else {"from": hi, "to": lo}
    return value, at, extra, reasons


#: The functions ngspice 39 evaluates on a sweep of one point (AVG, RMS, FIND, WHEN fail there).
_ONE_POINT = ("min", "max", "min_at", "max_at", "pp", "integ")


def _one_point(spec: MeasureSpec, trace: _Lines) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """``(value, at, extra)`` of a window function on a sweep of one point (:data:`_ONE_POINT`), as
    ngspice 39 gives them: the extreme is the point's value, ``PP`` and ``INTEG`` are 0.

    Raises
    ------
    MeasureFailure
        The point is outside the window.
    """
    x = trace.sense * float(trace.x[0])
    if (spec.start is not None and x < spec.start) or (spec.stop is not None and x > spec.stop):
        start, stop = (x if v is None else v for v in (spec.start, spec.stop))
        raise MeasureFailure(f"the window FROM={start:g} TO={stop:g} holds no part of the analysis (one point, {x:g})")
    f, y, rows = spec.function, trace.y[:, 0], trace.y.shape[0]
    where = np.full(rows, x)
    if f in ("min", "max"):
        return y, where, {}
    if f in ("min_at", "max_at"):
        return where, where, {"with": y}
    return np.zeros(rows), None, {"from": x, "to": x}


def _param(spec: MeasureSpec, done: dict[str, Measure]) -> Measure:
    def lookup(name: str) -> float:
        m = done.get(name)
        if m is not None:
            if not m.ok:
                raise MeasureFailure(f"PARAM: measurement '{name}' failed")
            return m.value
        if name not in spec.params and name == spec.name:
            raise MeasureFailure(f"PARAM: '{name}' is this measurement itself: its expression cannot use its own "
                                 "value")
        if name not in spec.params:
            raise MeasureFailure(f"PARAM: '{name}' is a later PARAM measurement (PARAM= cards are measured in "
                                 "order, after all the others, as in ngspice)")
        return spec.params[name]

    try:
        value = ex.evaluate(spec.expression, lookup)
    except ValueError as exc:
        raise MeasureFailure(f"PARAM: {exc}") from None
    return Measure(spec.name, spec.analysis, "param", value)


def _check_axis(result: Result, function: str) -> None:
    if len(result.axes) > 1:
        raise MeasureFailure("a nested .dc sweep (two sources) is not measured by netdae")
    x = np.asarray(result.axis, dtype=float)
    if x.size < 2 and not (x.size == 1 and result.dense is None and function in _ONE_POINT):
        raise MeasureFailure(f"the {result.analysis} result has {x.size} point(s)")
    step = np.diff(x)
    if np.any(step < 0) and not (result.analysis == "dc" and np.all(step < 0)):
        raise MeasureFailure(f"the {result.axis_name} axis goes back (netdae measures a sweep that only increases "
                             "or, for .dc, only decreases)")


def evaluate_measures(specs: list[MeasureSpec], results: Mapping[str, Result]) -> list[Measure]:
    """Evaluate measurements on results.

    Parameters
    ----------
    specs : list of MeasureSpec
        ``circuit.measures``, in netlist order.
    results : mapping of str to Result
        The result each analysis kind is measured on (``"tran"``, ``"ac"``,
        ``"dc"``); a kind that is missing makes its measurements fail.

    Returns
    -------
    list of Measure
        One per spec, in order; failed ones have ``status == "failed"`` and a
        ``reason``. Nothing is raised for a measurement that cannot be made.
    """
    return [ms[0] for ms in _evaluate(specs, results, None)]


def evaluate_measure_rows(specs: list[MeasureSpec], results: Mapping[str, Result], rows: int) -> list[list[Measure]]:
    """Evaluate measurements on results that hold many rows (a sweep's rows solved together).

    Parameters
    ----------
    specs : list of MeasureSpec
    results : mapping of str to Result
        As for :func:`evaluate_measures`, each result without dense output
        (ac, dc) and its signals of shape (rows, points).
    rows : int

    Returns
    -------
    list of list of Measure
        Per row, one measure per spec in order: what :func:`evaluate_measures`
        gives on that row's result alone (the same code).
    """
    per_spec = _evaluate(specs, results, rows)
    return [[ms[r] for ms in per_spec] for r in range(rows)]


@dataclass
class MeasureColumn:
    """One measurement of many rows: the values and failures :func:`evaluate_measure_rows` gives, as arrays.

    Attributes
    ----------
    name, analysis, function : str
        As :class:`~netdae.measures.Measure`'s.
    values : ndarray of float, shape (rows,)
        Each row's value, NaN where it failed.
    reasons : list of (str or None)
        Why each row's measurement failed, None where it did not.
    """

    name: str
    analysis: str
    function: str
    values: np.ndarray
    reasons: list


def evaluate_measure_columns(specs: list[MeasureSpec], results: Mapping[str, Result], rows: int) -> list[MeasureColumn]:
    """:func:`evaluate_measure_rows` as one :class:`MeasureColumn` per spec, without a ``Measure`` per row.

    Parameters
    ----------
    specs : list of MeasureSpec
    results : mapping of str to Result
        Each result without dense output (ac, dc), its signals of shape (rows, points).
    rows : int

    Returns
    -------
    list of MeasureColumn
        One per spec, in order: row r's value and reason are those of the measure
        :func:`evaluate_measure_rows` gives row r (the same code, not a copy of it).
    """
    out: list = [None] * len(specs)
    done: dict[str, MeasureColumn] = {}
    for i in _measure_order(specs):
        spec = specs[i]
        try:
            if spec.function == "param":
                col = _param_column(spec, done, rows)
            else:
                result = _measured_result(spec, results, rows)
                value, _, _, reasons = _measure_columns(spec, result, rows)
                col = _finite_column(spec, np.asarray(value, dtype=float), reasons)
        except MeasureFailure as exc:
            col = MeasureColumn(spec.name, spec.analysis, spec.function, np.full(rows, np.nan), [str(exc)] * rows)
        done[spec.name] = col
        out[i] = col
    return out


def _finite_column(spec: MeasureSpec, value: np.ndarray, reasons: list) -> MeasureColumn:
    """The column of :func:`_finite` applied to each row's measure."""
    values = np.where([why is None for why in reasons], value, np.nan)
    reasons = list(reasons)
    for r in np.flatnonzero(~np.isfinite(values)).tolist():
        if reasons[r] is None:
            reasons[r] = _finite(Measure(spec.name, spec.analysis, spec.function, float(value[r]))).reason
    return MeasureColumn(spec.name, spec.analysis, spec.function, values, reasons)


def _param_column(spec: MeasureSpec, done: dict[str, MeasureColumn], rows: int) -> MeasureColumn:
    """A PARAM measurement of every row, each from the row's measures done before it."""
    values = np.full(rows, np.nan)
    reasons: list = [None] * rows
    for r in range(rows):
        row = {name: Measure(c.name, c.analysis, c.function, None, status=STATUS_FAILED, reason=c.reasons[r])
               if c.reasons[r] is not None else Measure(c.name, c.analysis, c.function, float(c.values[r]))
               for name, c in done.items()}
        m = _finite(_param_or_failure(spec, row))
        if m.ok:
            values[r] = m.value
        else:
            reasons[r] = m.reason
    return MeasureColumn(spec.name, spec.analysis, spec.function, values, reasons)


def _measure_order(specs: list[MeasureSpec]) -> list[int]:
    """The order ngspice measures in: every measurement but PARAM, in card order, then the PARAM cards."""
    return [i for i, s in enumerate(specs) if s.function != "param"] + \
        [i for i, s in enumerate(specs) if s.function == "param"]


def _from_tstart(result: Result) -> Result:
    """A transient's result read from its ``tstart`` on: with the point at ``tstart`` itself put first.

    A transient keeps the points its integrator accepted at or after ``tstart``, and the first of
    them lies a part of a step after it; the measurements are of the analysis from ``tstart`` on
    (``INTEG``, ``AVG``, ``RMS`` without ``FROM=``, ``FROM=`` before the first point, ``AT=tstart``),
    as ngspice's converge to when its steps shrink. The integrator's interpolant covers the whole
    run, so the value at ``tstart`` is the one the step through it computed.

    Parameters
    ----------
    result : Result
        Any result; only a transient with dense output whose first point is after its card's
        ``tstart`` is changed.

    Returns
    -------
    Result
        ``result`` itself, or a copy whose axis and signals start with the point at ``tstart``.

    Examples
    --------
    >>> import numpy as np
    >>> from netdae.circuit import TranAnalysis
    >>> r = Result("tran", axes={"time": np.array([1.5, 2.0])}, signals={"v(a)": np.array([3.0, 4.0])},
    ...            dense=lambda t: {"v(a)": 2.0 * np.asarray(t)}, card=TranAnalysis(0.1, 2.0, 1.0))
    >>> _from_tstart(r).signals["v(a)"].tolist(), _from_tstart(r).axis.tolist()
    ([2.0, 3.0, 4.0], [1.0, 1.5, 2.0])
    """
    card, x = result.card, result.axis
    tstart = float(getattr(card, "tstart", 0.0) or 0.0)
    if result.analysis != "tran" or result.dense is None or x is None or x.size == 0 or not x[0] > tstart:
        return result
    first = result.dense(np.array([tstart]))
    signals = {name: np.concatenate([np.atleast_1d(np.asarray(first[name]))[:1].astype(np.asarray(v).dtype),
                                     np.asarray(v)])
               for name, v in result.signals.items()}
    return replace(result, axes={result.axis_name: np.concatenate([[tstart], x])}, signals=signals)


def _measured_result(spec: MeasureSpec, results: Mapping[str, Result], rows: int | None) -> Result:
    """The result ``spec`` measures, checked: present, finished (or, one result of one row, a transient
    that failed part way: :func:`_partial`).

    Raises
    ------
    MeasureFailure
        No result of the analysis, a failed one, or one whose axis cannot be measured.
    """
    result = results.get(spec.analysis)
    if result is None:
        raise MeasureFailure(f"no {spec.analysis} result to measure")
    if not result.ok and not _partial(result, rows):
        raise MeasureFailure(f"the {spec.analysis} analysis failed: {result.message}")
    _check_axis(result, spec.function)
    return result


def _evaluate(specs: list[MeasureSpec], results: Mapping[str, Result], rows: int | None) -> list[list[Measure]]:
    """Per spec, the measure of each row (``rows`` None: one result of one row, dense output allowed)."""
    count = 1 if rows is None else rows
    done: list[dict[str, Measure]] = [{} for _ in range(count)]
    out: list = [None] * len(specs)
    started: dict[int, Result] = {}  # each transient read from its tstart (_from_tstart), once
    traces = _Traces()
    for i in _measure_order(specs):
        spec = specs[i]
        try:
            if spec.function == "param":
                ms = [_param_or_failure(spec, d) for d in done]
            else:
                result = _measured_result(spec, results, rows)
                if rows is None:
                    if id(result) not in started:
                        started[id(result)] = _from_tstart(result)
                    result = started[id(result)]
                if not result.ok:
                    ms = [_measure_partial(spec, result, traces)]
                elif rows is None and result.analysis == "tran" and result.dense is not None:
                    ms = [_measure(spec, result, traces)]
                else:
                    ms = _measure_rows(spec, result, count)
            ms = [_finite(m) for m in ms]
        except MeasureFailure as exc:
            ms = [Measure(spec.name, spec.analysis, spec.function, None, status=STATUS_FAILED, reason=str(exc))
                  for _ in range(count)]
        for d, m in zip(done, ms):
            d[spec.name] = m
        out[i] = ms
    return out


#: The measurements of a window (which runs to the end of the analysis unless TO= ends it).
_WINDOWED = ("min", "max", "min_at", "max_at", "pp", "avg", "rms", "integ")


def _partial(result: Result, rows: int | None) -> bool:
    """Whether a failed result holds a part of the analysis to measure: a transient that stopped
    after some steps (its dense output up to the failure)."""
    return (rows is None and result.analysis == "tran" and result.dense is not None
            and np.asarray(result.axis).size >= 2)


def _measure_partial(spec: MeasureSpec, result: Result, traces: _Traces | None = None) -> Measure:
    """A measurement of a transient that failed part way, made on what it computed when the
    measurement needs nothing after its last point: ``AT=`` before it, a crossing counted from
    the start and found before it (not ``LAST``), a window whose ``TO=`` is before it.
    The value is the one the whole transient would have given.

    Raises
    ------
    MeasureFailure
        The measurement needs what the analysis did not reach (the analysis's failure, and where it stopped).
    """
    end = float(result.axis[-1])
    failure = MeasureFailure(f"the {spec.analysis} analysis failed: {result.message} (it stopped at {end:g}, "
                             "before what this measurement needs)")
    conditions = [c for c in (spec.trig, spec.targ, spec.when) if c is not None and c.at is None]
    if any(c.count == LAST for c in conditions) or (spec.at is not None and spec.at > end) or \
            (spec.function in _WINDOWED and (spec.stop is None or spec.stop > end)):
        raise failure
    try:
        return _measure(spec, result, traces)
    except MeasureFailure:  # a crossing not found in the part computed may come after it
        raise failure from None


def _param_or_failure(spec: MeasureSpec, done: dict[str, Measure]) -> Measure:
    try:
        return _param(spec, done)
    except MeasureFailure as exc:
        return Measure(spec.name, spec.analysis, spec.function, None, status=STATUS_FAILED, reason=str(exc))


def _finite(m: Measure) -> Measure:
    """``m``, or its failure when its value is not a finite number."""
    if m.ok and (m.value is None or not math.isfinite(m.value)):
        return Measure(m.name, m.analysis, m.function, None, status=STATUS_FAILED, reason=f"the value is {m.value}")
    return m
