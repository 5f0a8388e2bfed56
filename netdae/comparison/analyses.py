"""Compare one analysis: netdae's Result against ngspice's, at ngspice's points.

Each function takes netdae's and ngspice's :class:`~netdae.results.Result`
of the same analysis and returns an
:class:`~netdae.comparison.model.AnalysisComparison`. Nothing runs a simulator
here, so every function can be tested on synthetic results.

- :func:`compare_transient` evaluates netdae's dense output (the integrator's
  interpolating polynomial, ``Result.dense``) at ngspice's accepted time
  points: neither side is resampled linearly.
- :func:`compare_ac` expects netdae's phasors at ngspice's frequencies.
- :func:`compare_dc` expects the same sweep points on both sides.
- :func:`compare_op` compares every unknown.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import NetdaeError
from ..results import Result
from .header import Tolerance
from .metrics import (
    ABSOLUTE_FLOOR,
    JUMP_WINDOW_FRACTION,
    ac_metrics,
    floored_scales,
    initial_jump,
    point_metrics,
    signal_kind,
    waveform_metrics,
    within,
)
from .model import AnalysisComparison, SignalComparison

__all__ = [
    "DETECTION_TOLERANCE",
    "AC_DYNAMIC_RANGE",
    "select_signals",
    "compare_transient",
    "compare_dc",
    "compare_ac",
    "compare_op",
]

#: Tolerance used to detect an initial jump when the analysis has none to judge by.
DETECTION_TOLERANCE = Tolerance(1e-3)
#: An AC phasor's relative error is measured against its magnitude at that
#: frequency, but never against less than this fraction of the largest
#: magnitude of its kind in the analysis (1e-9: -180 dB): both simulators solve
#: the same linear system in double precision, so agreement is expected far
#: down a filter's stopband, and only rounding noise lies below this.
AC_DYNAMIC_RANGE = 1e-9
#: Relative slack for ngspice's time points at the ends of netdae's interval.
_END_SLACK = 1e-12
#: An ngspice time point this close (relative to the interval) to a time where netdae's
#: solution jumps is compared with the closer of netdae's two values there.
JUMP_MATCH = 1e-12


def select_signals(netdae: list[str], ngspice: list[str], wanted=None, exclude=()) -> tuple[list, list, list, list]:
    """Split signal names into compared, netdae-only, ngspice-only and excluded.

    Parameters
    ----------
    netdae, ngspice : list of str
        The names each simulator produced.
    wanted : sequence of str, optional
        Compare only these (case-insensitive); default: every common name.
    exclude : sequence of str
        Leave these out.

    Returns
    -------
    compared, only_netdae, only_ngspice, excluded : list of str
        ``compared`` in netdae's order.

    Raises
    ------
    NetdaeError
        When a wanted or excluded name is produced by neither simulator.

    Examples
    --------
    >>> select_signals(["v(a)", "v(b)", "i(e1)"], ["v(a)", "v(b)", "i(v1)"], exclude=["v(b)"])
    (['v(a)'], ['i(e1)'], ['i(v1)'], ['v(b)'])
    """
    theirs = set(ngspice)
    ours = set(netdae)
    every = ours | theirs
    for name in [*(wanted or ()), *exclude]:
        if name.lower() not in every:
            raise NetdaeError(
                f"signal {name!r} is produced by neither simulator; have: {', '.join(sorted(every))}"
            )
    keep = None if wanted is None else {w.lower() for w in wanted}
    drop = {e.lower() for e in exclude}

    def chosen(name):
        return keep is None or name in keep

    compared = [n for n in netdae if n in theirs and chosen(n) and n not in drop]
    excluded = [n for n in netdae if n in theirs and chosen(n) and n in drop]
    only_netdae = [n for n in netdae if n not in theirs and chosen(n)]
    only_ngspice = [n for n in ngspice if n not in ours and chosen(n) and not _PAR_HELPER.match(n)]
    return compared, only_netdae, only_ngspice, excluded


#: The node and source ngspice adds for each ``par('...')`` of a ``.meas`` card (``Bpa_00 pa_00 0
#: V=...``): its own means of measuring an expression, not a signal of the circuit.
_PAR_HELPER = re.compile(r"^(?:v\(pa_\d+\)|i\(bpa_\d+\))$")


def _signals_or_error(item: AnalysisComparison, compared: list[str]) -> bool:
    if compared:
        return True
    item.error = "no signal is produced by both simulators (see only_netdae / only_ngspice)"
    return False


def _sorted(signals: list[SignalComparison]) -> list[SignalComparison]:
    return sorted(signals, key=lambda s: (-s.max_rel, s.name))


def _verdict(tol: Tolerance | None, max_abs: float, scale: float) -> bool | None:
    if tol is None:
        return None
    return bool(within(max_abs, scale, tol.rel, tol.abs))


def _ranges(names, a_values, b_values):
    own = np.array([max(np.ptp(a_values[n]), np.ptp(b_values[n])) for n in names], dtype=float)
    scales, floored = floored_scales(names, own)
    return scales, floored


def _time_points(nd: Result, t: np.ndarray, item: AnalysisComparison) -> np.ndarray:
    """Mask of ngspice's times inside netdae's computed interval (not empty)."""
    t_nd = nd.t
    slack = _END_SLACK * max(abs(t_nd[-1]), abs(t_nd[0]), 1.0)
    inside = (t >= t_nd[0] - slack) & (t <= t_nd[-1] + slack)
    if not np.all(inside):
        outside = t[~inside]
        item.notes.append(
            f"{outside.size} of ngspice's {t.size} time points lie outside netdae's interval "
            f"[{t_nd[0]:.6g}, {t_nd[-1]:.6g}] s and are not compared"
        )
    return inside


def _jump_reason(nd: Result, t0: float, t_from: float, t_end: float) -> str:
    share = 100.0 * (t_from - t0) / (t_end - t0) if t_end > t0 else 0.0
    base = (
        f"the simulators disagree at t = {t0:.6g} s and agree within tolerance from t = {t_from:.6g} s "
        f"on ({share:.2g} % of the interval): an inconsistent initial value decays (a jump at the start); "
        f"the metrics are computed from t = {t_from:.6g} s"
    )
    correction = nd.transient.initial_correction if nd.transient is not None else None
    if correction:
        base += f"; netdae computed consistent initial values: {_correction_text(correction)}"
    return base


def _correction_text(correction) -> str:
    """``{"reason": ..., "changed": {name: [old, new]}}`` (netdae's transient) as one line."""
    if not isinstance(correction, dict):
        return str(correction)
    changed = correction.get("changed") or {}
    parts = [f"{name} {old:.6g} -> {new:.6g}" for name, (old, new) in changed.items()]
    reason = correction.get("reason")
    return (f"{reason}: " if reason else "") + ", ".join(parts)


def compare_transient(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=(),
                      window: float = JUMP_WINDOW_FRACTION) -> AnalysisComparison:
    """Compare two transient results at ngspice's accepted time points.

    Parameters
    ----------
    nd : Result
        netdae's transient, with ``dense`` (its interpolant).
    ng : Result
        ngspice's transient (its accepted points, ``.options interp`` off).
    tol : Tolerance or None
        Pass criterion; None to compare without judging.
    wanted, exclude
        Signal selection (:func:`select_signals`).
    window : float
        Longest initial jump, as a fraction of the interval (:func:`~netdae.comparison.metrics.initial_jump`).

    Returns
    -------
    AnalysisComparison

    Notes
    -----
    Per signal: the scale is the larger of the two peak-to-peak ranges over
    the whole interval (netdae's at its own accepted points, ngspice's at its
    points), floored per kind. A signal *jumps* when it is out of tolerance at
    the first point and within tolerance from some point no later than
    ``window`` of the interval; then every signal's metrics are computed from
    the latest such point on, and the whole-interval errors are kept in
    ``whole``. Cost: one dense evaluation at m points, O(m) per signal.
    """
    item = AnalysisComparison("tran", tolerance=tol, axis="time")
    # netdae's own failure comes first: whatever else goes wrong follows from it
    failed = f"netdae's transient failed: {nd.message}" if nd.status < 0 else None
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(
        nd.names(), ng.names(), wanted, exclude)
    if not _signals_or_error(item, compared):
        return _failed_first(item, failed)
    if nd.t is None or nd.t.size == 0:
        item.error = "netdae's transient result has no time points"
        return _failed_first(item, failed)
    if nd.dense is None:
        item.error = "netdae's transient result has no dense output to evaluate at ngspice's time points"
        return _failed_first(item, failed)
    t_all = ng.t
    inside = _time_points(nd, t_all, item)
    t = t_all[inside]
    if t.size == 0:
        item.error = "no ngspice time point lies inside netdae's computed interval"
        return _failed_first(item, failed)
    t = np.clip(t, nd.t[0], nd.t[-1])
    dense = nd.dense(t)
    missing = [n for n in compared if n not in dense]
    if missing:
        item.notes.append(f"netdae's dense output lacks {', '.join(missing)}: not compared")
        item.only_ngspice += missing
        compared = [n for n in compared if n in dense]
        if not _signals_or_error(item, compared):
            return item
    a = {n: np.asarray(dense[n], dtype=float) for n in compared}
    b = {n: np.asarray(ng.signals[n], dtype=float)[inside] for n in compared}
    on_jumps = _either_side_of_jumps(nd, t, a, b)
    if on_jumps:
        item.notes.append(f"{on_jumps} ngspice point(s) fall on times where netdae's solution jumps (a switch, an "
                          "input step): compared with the closer of netdae's left and right values there")
    own_nd = {n: np.asarray(nd.signals[n], dtype=float) if n in nd.signals else a[n] for n in compared}
    scales, floored = _ranges(compared, own_nd, b)
    judge = tol or DETECTION_TOLERANCE
    jumps = {
        name: initial_jump(t, a[name], b[name], scale=scales[k], rel=judge.rel, abs_tol=judge.abs, window=window)
        for k, name in enumerate(compared)
    }
    start = max((j.settle for j in jumps.values() if j is not None), default=0)
    if start:
        item.window = {"from": float(t[start]), "index": int(start),
                       "reason": _jump_reason(nd, float(t[0]), float(t[start]), float(t[-1]))}
    item.points = int(t.size)
    item.curves = {"axis": t, "start": start, "values": {n: (a[n], b[n]) for n in compared}}
    signals = []
    for k, name in enumerate(compared):
        m = waveform_metrics(t[start:], a[name][start:], b[name][start:], scale=scales[k])
        worst = start + m.worst
        sig = SignalComparison(
            name, m.max_abs, m.max_rel, m.rms, {"time": float(t[worst])}, float(scales[k]),
            "floor" if floored[k] else "range", _verdict(tol, m.max_abs, scales[k]),
            netdae=float(a[name][worst]), ngspice=float(b[name][worst]),
        )
        jump = jumps[name]
        if jump is not None:
            sig.jump = {"netdae": jump.netdae, "ngspice": jump.ngspice, "settle_time": float(t[jump.settle])}
        if start:
            whole = waveform_metrics(t, a[name], b[name], scale=scales[k])
            sig.whole = {"max_abs": whole.max_abs, "max_rel": whole.max_rel, "rms": whole.rms,
                         "at": {"time": float(t[whole.worst])}}
        signals.append(sig)
    item.signals = _sorted(signals)
    at_events = _at_events(nd, t, [sig for sig in signals if sig.passed is False])
    if at_events:
        item.notes.append(at_events)
    item.error = failed
    return item


#: A difference is at an event when it lies within this many of ngspice's steps after it.
EVENT_STEPS = 2


def _at_events(nd: Result, t: np.ndarray, failed: list[SignalComparison]) -> str:
    """A note when the failed signals' largest differences follow netdae's located events, else ``""``.

    netdae places a switch's change, or a behavioural source's comparison's, at the
    instant its control crosses (located on the step's interpolant); ngspice changes it at
    the first of its time points that sees the crossing, so its edge comes up to one of its
    steps late and the two waveforms differ there by the edge's height. A failed signal's
    worst point counts when it lies within :data:`EVENT_STEPS` of ngspice's steps after an
    event.
    """
    events = [float(te) for te, _ in (nd.transient.events if nd.transient is not None else [])]
    if not events or not failed or t.size < 2:
        return ""
    times = np.asarray(events)
    names = []
    lags = []
    for sig in failed:
        tw = sig.at["time"]
        before = times[times <= tw]
        if before.size == 0:
            continue
        te = float(before[-1])
        k = int(np.searchsorted(t, te, side="right"))
        if k >= t.size:
            continue
        reach = t[min(k + EVENT_STEPS - 1, t.size - 1)]
        if tw <= reach:
            names.append(sig.name)
            lags.append(float(t[k] - te))
    if not names:
        return ""
    who = {w for _, ws in nd.transient.events for w in ws}
    return (f"the largest differences of {', '.join(names[:5])}{' ...' if len(names) > 5 else ''} follow "
            f"netdae's located changes of {', '.join(sorted(who)[:5])} (switches or behavioural comparisons, "
            f"{len(events)} event(s)): netdae changes them where the control crosses, ngspice at its first "
            f"time point after the crossing (there up to {max(lags):.3g} s later), so its edges lag by up to "
            "a step; compare --tight narrows the lag")


def _either_side_of_jumps(nd: Result, t: np.ndarray, a: dict, b: dict) -> int:
    """At ngspice's points on netdae's jump times, netdae's value closer to ngspice's (in ``a``, in place).

    Where the solution jumps (a switch changes, an input steps), netdae records
    the value from the left and the right limit at the same time, and its dense
    output returns the left one there (and the right one a rounding after it); a
    simulator that reports a point at that very time, or a rounding off it, may give
    either (ngspice's switch at a control exactly on its
    threshold, for one, is already switched when the hysteresis is not
    positive). Returns how many points were affected.
    """
    times = [float(tj) for tj, _ in (nd.transient.jumps if nd.transient is not None else [])]
    if not times or t.size == 0:
        return 0
    own_t = np.asarray(nd.axes.get("time", ()), dtype=float)
    span = max(float(t[-1] - t[0]), abs(float(t[-1])), 1e-300)
    count = 0
    for tj in times:
        pts = np.flatnonzero(np.abs(t - tj) <= JUMP_MATCH * span)
        right = np.flatnonzero(own_t == tj)
        if pts.size == 0 or right.size < 2:
            continue
        for name in a:
            if name not in nd.signals:
                continue
            for side in (right[0], right[-1]):  # the left value, the right limit
                alt = float(np.asarray(nd.signals[name])[side])
                closer = np.abs(alt - b[name][pts]) < np.abs(a[name][pts] - b[name][pts])
                a[name][pts[closer]] = alt
        count += pts.size
    return count


def _failed_first(item: AnalysisComparison, failed: str | None) -> AnalysisComparison:
    """``item`` with netdae's failure in front of the reason the comparison stopped."""
    if failed is not None:
        item.error = f"{failed}; therefore: {item.error}" if item.error else failed
    return item


#: A .dc signal that disagrees at one point by this many times its difference at the points around, where
#: ngspice's sweep value is not netdae's, gets a note saying that an expression may jump there.
JUMP_RATIO = 100.0


def _sweep_point(axes: dict[str, np.ndarray], k: int) -> dict[str, float]:
    return {name: float(values[k]) for name, values in axes.items()}


def _same_point(a: float, b: float, span: float) -> bool:
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b)) + 1e-12 * max(span, 1.0)


def _common_points(mine: dict[str, np.ndarray], theirs: dict[str, np.ndarray]) -> np.ndarray | None:
    """netdae's sweep points at ngspice's, in order (None: some point of ngspice's is not netdae's).

    ngspice adds its step repeatedly and drops a stop value the accumulated
    rounding passed (``dc vd 0 60 0.1``: 600 points); netdae computes each
    point and keeps it.
    """
    names = list(theirs)
    if any(n not in mine for n in names):
        return None
    spans = {n: float(np.ptp(theirs[n])) if theirs[n].size else 0.0 for n in names}
    take, k, count = [], 0, mine[names[0]].size
    for j in range(theirs[names[0]].size):
        while k < count and not all(_same_point(mine[n][k], theirs[n][j], spans[n]) for n in names):
            k += 1
        if k == count:
            return None
        take.append(k)
        k += 1
    return np.array(take, dtype=np.int64)


def compare_dc(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=()) -> AnalysisComparison:
    """Compare two DC sweeps point by point.

    The scale is the larger of the two ranges over the sweep, floored per
    kind; the RMS is over the points. The sweep points must agree (ngspice's
    outer axis of a nested sweep is rebuilt by the bridge), or ngspice's be
    netdae's without the stop values its accumulated step passed (compared
    at ngspice's points, with a note). A netdae sweep that stopped at a failed point (its
    points before it) is the comparison's error, first.
    """
    item = AnalysisComparison("dc", tolerance=tol, axis=", ".join(ng.axes) or None)
    # netdae's own failure comes first: a sweep of fewer points follows from it
    failed = f"netdae's .dc failed: {nd.message}" if nd.status < 0 else None
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(
        nd.names(), ng.names(), wanted, exclude)
    if not _signals_or_error(item, compared):
        return _failed_first(item, failed)
    m = ng.axis.size if ng.axis is not None else 0
    take = None
    if nd.axis is not None and nd.axis.size > m > 0:
        take = _common_points(nd.axes, ng.axes)
    if take is not None:
        item.notes.append(f"compared at ngspice's {m} points: its sweep leaves out {nd.axis.size - m} of netdae's "
                          "(it adds the step repeatedly and drops a stop value the rounding passed)")
        nd = Result("dc", axes={n: np.asarray(v)[take] for n, v in nd.axes.items()},
                    signals={n: np.asarray(nd.signals[n])[take] for n in compared})
    elif nd.axis is None or nd.axis.size != m:
        item.error = (f"the sweeps differ: netdae has {0 if nd.axis is None else nd.axis.size} points, "
                      f"ngspice {m}")
        return _failed_first(item, failed)
    for name, values in ng.axes.items():
        mine = nd.axes.get(name)
        if mine is None or not np.allclose(mine, values, rtol=1e-9, atol=1e-12 * max(np.ptp(values), 1.0)):
            item.error = f"the sweeps differ in {name}: netdae's points are not ngspice's"
            return _failed_first(item, failed)
    a = {n: np.asarray(nd.signals[n], dtype=float) for n in compared}
    b = {n: np.asarray(ng.signals[n], dtype=float) for n in compared}
    scales, floored = _ranges(compared, a, b)
    index = np.arange(m, dtype=float)
    item.points = int(m)
    item.curves = {"axis": ng.axis, "axes": ng.axes, "start": 0, "values": {n: (a[n], b[n]) for n in compared}}
    signals = []
    shifted: dict[int, list[str]] = {}
    for k, name in enumerate(compared):
        mm = waveform_metrics(index, a[name], b[name], scale=scales[k], weighted=False)
        verdict = _verdict(tol, mm.max_abs, scales[k])
        signals.append(SignalComparison(
            name, mm.max_abs, mm.max_rel, mm.rms, _sweep_point(ng.axes, mm.worst), float(scales[k]),
            "floor" if floored[k] else "range", verdict,
            netdae=float(a[name][mm.worst]), ngspice=float(b[name][mm.worst]),
        ))
        j = int(mm.worst)
        if verdict is False and any(nd.axes[n][j] != ng.axes[n][j] for n in ng.axes):
            around = float(np.max(np.abs(a[name] - b[name])[[i for i in (j - 1, j + 1) if 0 <= i < m]],
                                  initial=0.0))
            if _verdict(tol, around, scales[k]) and mm.max_abs > JUMP_RATIO * around:  # one point off: a jump
                shifted.setdefault(j, []).append(name)
    for j, names in shifted.items():
        values = ", ".join(f"{n} = {ng.axes[n][j]:.17g} where netdae's is {nd.axes[n][j]:.17g}"
                           for n in ng.axes if nd.axes[n][j] != ng.axes[n][j])
        item.notes.append(f"{', '.join(names)}: at ngspice's point {values} (ngspice adds the step repeatedly, "
                          "netdae computes start + k step): an expression that jumps at that value (u(), sgn(), "
                          "a comparison, floor, ceil, nint) can be on different sides of its jump in each, while the points "
                          "around agree")
    item.signals = _sorted(signals)
    item.error = failed
    return item


def compare_ac(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=()) -> AnalysisComparison:
    """Compare AC phasors at ngspice's frequencies.

    ``nd`` must hold netdae's phasors at exactly ngspice's frequencies. The
    relative error at each frequency is ``|A - B| / max(|A|, |B|, floor)``
    with the floor :data:`AC_DYNAMIC_RANGE` times the largest magnitude of the
    signal's kind (at least the kind's absolute floor); ``max_rel`` is its
    maximum over frequency and is what the tolerance judges.
    """
    item = AnalysisComparison("ac", tolerance=tol, axis="frequency")
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(
        nd.names(), ng.names(), wanted, exclude)
    if not _signals_or_error(item, compared):
        return item
    f = ng.axis
    if f is None or f.size == 0:
        item.error = "ngspice's AC analysis has no frequency points (nothing to compare)"
        return item
    if nd.axis is None or nd.axis.size != f.size or not np.array_equal(nd.axis, f):
        item.error = "netdae's phasors are not at ngspice's frequencies"
        return item
    a = {n: np.asarray(nd.signals[n], dtype=complex) for n in compared}
    b = {n: np.asarray(ng.signals[n], dtype=complex) for n in compared}
    empty = [n for n in compared if b[n].size != f.size or a[n].size != f.size]
    if empty:  # ngspice 39 writes device quantities such as @r1[i] as vectors without points in .ac
        item.notes.append("not compared (a vector without a value at every frequency): " + ", ".join(
            f"{n} ({'ngspice' if b[n].size != f.size else 'netdae'}: {min(a[n].size, b[n].size)} points)"
            for n in empty))
        compared = [n for n in compared if n not in empty]
        if not _signals_or_error(item, compared):
            return item
    peaks: dict[str, float] = {}
    for n in compared:
        kind = signal_kind(n)
        peaks[kind] = max(peaks.get(kind, 0.0), float(np.max(np.abs(a[n]))), float(np.max(np.abs(b[n]))))
    item.points = int(f.size)
    item.curves = {"axis": f, "start": 0, "values": {n: (a[n], b[n]) for n in compared}}
    signals = []
    for name in compared:
        kind = signal_kind(name)
        floor = max(ABSOLUTE_FLOOR[kind], AC_DYNAMIC_RANGE * peaks[kind])
        m = ac_metrics(a[name], b[name], floor=floor)
        scale = max(abs(a[name][m.worst]), abs(b[name][m.worst]), floor)
        signals.append(SignalComparison(
            name, m.max_abs, m.max_rel, m.rms, {"frequency": float(f[m.worst])}, float(scale),
            "floor" if scale == floor else "magnitude",
            _verdict(tol, m.max_rel * scale, scale),
            netdae=complex(a[name][m.worst]), ngspice=complex(b[name][m.worst]),
            max_db=m.max_db, max_phase_deg=m.max_phase_deg,
        ))
    item.signals = _sorted(signals)
    return item


def compare_op(nd: Result, ng: Result, *, tol: Tolerance | None, wanted=None, exclude=()) -> AnalysisComparison:
    """Compare two operating points unknown by unknown.

    The scale of each unknown is the larger of the two magnitudes, floored per
    kind; ``max_rel = |a - b| / scale``.
    """
    item = AnalysisComparison("op", tolerance=tol)
    compared, item.only_netdae, item.only_ngspice, item.excluded = select_signals(
        nd.names(), ng.names(), wanted, exclude)
    if not _signals_or_error(item, compared):
        return item
    a = np.array([float(nd.signals[n][0]) for n in compared])
    b = np.array([float(ng.signals[n][0]) for n in compared])
    scales, floored = floored_scales(compared, np.maximum(np.abs(a), np.abs(b)))
    item.points = 1
    signals = []
    for k, name in enumerate(compared):
        m = point_metrics(a[k], b[k], scale=scales[k])
        signals.append(SignalComparison(
            name, m.max_abs, m.max_rel, m.rms, {}, float(scales[k]), "floor" if floored[k] else "magnitude",
            _verdict(tol, m.max_abs, scales[k]), netdae=float(a[k]), ngspice=float(b[k]),
        ))
    item.signals = _sorted(signals)
    return item
