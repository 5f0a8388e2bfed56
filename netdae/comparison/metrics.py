"""Error metrics between two simulations of the same circuit (pure numpy kernels).

Every metric compares netdae's value ``a`` with ngspice's value ``b`` at the
*same* points (ngspice's accepted time points, its frequencies, its sweep
points): ``e = a - b``. Nothing here runs a simulator or reads a file.

Scales
------
A relative error needs a scale. For a waveform (``.tran``, ``.dc``) it is the
signal's peak-to-peak range, the larger of the two simulators' ranges; for an
operating point the larger magnitude; for an AC phasor the larger magnitude at
each frequency. A scale is never smaller than the *floor* of its kind of signal
(:func:`kind_floors`): the larger of an absolute floor (:data:`ABSOLUTE_FLOOR`,
ngspice's default ``vntol`` for volts and ``abstol`` for amperes) and
:data:`FLOOR_FRACTION` of the largest scale among the signals of that kind in
the same analysis. So a signal that hardly moves (a supply rail, an op-amp's
virtual ground) is measured against the circuit's swing, not against its own
near-zero range.

A signal passes when ``max_abs <= rel * scale`` or, when an absolute
tolerance is given, ``max_abs <= abs``.

Examples
--------
A sine and a copy shifted by ``d`` in time differ by at most ``2 sin(w d / 2)``:

>>> import numpy as np
>>> t = np.linspace(0.0, 1.0, 20001)
>>> w, d = 2 * np.pi * 5, 1e-4
>>> m = waveform_metrics(t, np.sin(w * (t - d)), np.sin(w * t), scale=2.0)
>>> bool(abs(m.max_abs - 2 * np.sin(w * d / 2)) < 1e-9)
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..signals import signal_unit

__all__ = [
    "ABSOLUTE_FLOOR",
    "FLOOR_FRACTION",
    "JUMP_WINDOW_FRACTION",
    "signal_kind",
    "kind_floors",
    "floored_scales",
    "within",
    "ErrorMetrics",
    "waveform_metrics",
    "point_metrics",
    "AcMetrics",
    "ac_metrics",
    "InitialJump",
    "initial_jump",
]

#: Smallest scale per kind of signal: ngspice's default absolute tolerances,
#: ``vntol`` = 1 uV for node voltages and ``abstol`` = 1 pA for currents; a
#: signal below them is noise to both simulators.
ABSOLUTE_FLOOR = {"v": 1e-6, "i": 1e-12, "other": 1e-12,
                  # device quantities in other units (@q1[gm], @m1[cgs], @d1[charge], @r1[p])
                  "S": 1e-12, "F": 1e-18, "C": 1e-21, "W": 1e-15}
#: A signal's scale is at least this fraction of the largest scale of its kind
#: in the same analysis: an error of 1e-3 of one percent of the circuit's swing
#: (1e-5 of the swing) is below what either simulator resolves at its default
#: tolerances, whatever the signal's own range.
FLOOR_FRACTION = 1e-2
#: An initial jump must have decayed within this fraction of the simulated
#: interval to be taken for an inconsistent start (a jump absorbed by the first
#: steps); a difference that lasts longer is a real disagreement.
JUMP_WINDOW_FRACTION = 0.02


def signal_kind(name: str) -> str:
    """``"v"`` for ``v(...)``, ``"i"`` for ``i(...)``, a device quantity's by its unit, ``"other"`` otherwise.

    A device quantity in volts or amperes is a ``"v"`` or ``"i"``; the other
    units (``"S"``, ``"F"``, ``"C"``, ``"W"``) are kinds of their own, so
    that a capacitance's scale is not floored by a current's.

    Examples
    --------
    >>> signal_kind("v(out)"), signal_kind("i(l1)"), signal_kind("@r1[i]"), signal_kind("@q1[gm]")
    ('v', 'i', 'i', 'S')
    >>> signal_kind("@m1[vgs]"), signal_kind("@x1[zz]"), signal_kind("time")
    ('v', 'other', 'other')
    """
    head = name[:2].lower()
    if name.startswith("@"):
        unit = signal_unit(name)
        return {"V": "v", "A": "i"}.get(unit, unit if unit in ABSOLUTE_FLOOR else "other")
    return {"v(": "v", "i(": "i"}.get(head, "other")


def kind_floors(names, scales) -> dict[str, float]:
    """Floor of the scale for each kind of signal in one analysis.

    Parameters
    ----------
    names : sequence of str, length n
        Signal names (their kind is :func:`signal_kind`).
    scales : array_like, shape (n,)
        Each signal's own scale (range or magnitude), before flooring.

    Returns
    -------
    dict of str to float
        ``max(ABSOLUTE_FLOOR[kind], FLOOR_FRACTION * max scale of the kind)``
        for every kind present.

    Examples
    --------
    >>> kind_floors(["v(a)", "v(b)", "i(v1)"], [2.0, 1e-7, 1e-3])
    {'v': 0.02, 'i': 1e-05}
    """
    scales = np.asarray(scales, dtype=float)
    kinds = np.array([signal_kind(n) for n in names])
    floors: dict[str, float] = {}
    for kind in dict.fromkeys(kinds.tolist()):
        largest = float(np.max(scales[kinds == kind], initial=0.0))
        floors[kind] = max(ABSOLUTE_FLOOR[kind], FLOOR_FRACTION * largest)
    return floors


def floored_scales(names, scales) -> tuple[np.ndarray, np.ndarray]:
    """Scales raised to their kind's floor, and which ones were raised.

    Returns
    -------
    scales : ndarray, shape (n,)
    floored : ndarray of bool, shape (n,)
        True where the floor replaced the signal's own scale.
    """
    own = np.asarray(scales, dtype=float)
    floors = kind_floors(names, own)
    floor = np.array([floors[signal_kind(n)] for n in names], dtype=float)
    return np.maximum(own, floor), own < floor


def within(error, scale, rel: float, abs_tol: float | None = None):
    """True where ``|error| <= rel * scale`` (or ``<= abs_tol`` when given)."""
    error = np.abs(error)
    ok = error <= rel * np.asarray(scale)
    if abs_tol is not None:
        ok = ok | (error <= abs_tol)
    return ok


@dataclass(frozen=True)
class ErrorMetrics:
    """Errors of one real signal over a set of points.

    Attributes
    ----------
    max_abs : float
        ``max |e|``.
    max_rel : float
        ``max_abs / scale``.
    rms : float
        Root mean square of ``e`` (time-weighted for a transient, see
        :func:`waveform_metrics`).
    worst : int
        Index of the point where ``|e|`` is largest (first one on ties).
    scale : float
        The scale used.
    """

    max_abs: float
    max_rel: float
    rms: float
    worst: int
    scale: float


def waveform_metrics(x, a, b, *, scale: float, weighted: bool = True) -> ErrorMetrics:
    """Errors between two samplings of a waveform at the same points.

    Parameters
    ----------
    x : array_like, shape (m,)
        Increasing axis values (time [s], or sweep values).
    a, b : array_like, shape (m,)
        netdae's and ngspice's values at ``x``.
    scale : float
        Denominator of the relative error (positive).
    weighted : bool
        True: RMS over the axis, ``sqrt(int e^2 dx / (x[-1] - x[0]))`` by the
        trapezoidal rule (a transient: ngspice's points are dense where the
        signal moves fast, so a plain mean over points would overweight those
        stretches). False: ``sqrt(mean(e^2))`` over the points (a sweep).

    Returns
    -------
    ErrorMetrics

    Notes
    -----
    Cost O(m).
    """
    x = np.asarray(x, dtype=float)
    e = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    if e.size == 0:
        raise ValueError("no points to compare")
    mag = np.abs(e)
    worst = int(np.argmax(mag))
    span = x[-1] - x[0] if x.size > 1 else 0.0
    if weighted and span > 0:
        sq = e * e
        rms = float(np.sqrt(np.sum(0.5 * (sq[1:] + sq[:-1]) * np.diff(x)) / span))
    else:
        rms = float(np.sqrt(np.mean(e * e)))
    return ErrorMetrics(float(mag[worst]), float(mag[worst] / scale), rms, worst, float(scale))


def point_metrics(a: float, b: float, *, scale: float) -> ErrorMetrics:
    """Errors of one value (an operating point): ``|a - b|`` and ``|a - b| / scale``."""
    err = abs(float(a) - float(b))
    return ErrorMetrics(err, err / scale, err, 0, float(scale))


@dataclass(frozen=True)
class AcMetrics:
    """Errors of one AC phasor over frequency.

    Attributes
    ----------
    max_abs : float
        ``max_f |A(f) - B(f)|`` (same unit as the signal).
    max_rel : float
        ``max_f |A - B| / s(f)`` with ``s(f) = max(|A(f)|, |B(f)|, floor)``:
        bounds the relative magnitude error and the phase error in radians.
    rms : float
        ``sqrt(mean_f |A - B|^2)`` over the points.
    worst : int
        Frequency index of ``max_rel``.
    max_db : float
        ``max |20 log10(|A| / |B|)|`` over the frequencies where both
        magnitudes exceed the floor (0 when there is none).
    max_phase_deg : float
        ``max |angle(A / B)|`` in degrees, in [0, 180], over the same frequencies.
    floor : float
        The floor used.
    """

    max_abs: float
    max_rel: float
    rms: float
    worst: int
    max_db: float
    max_phase_deg: float
    floor: float


def ac_metrics(a, b, *, floor: float) -> AcMetrics:
    """Errors between netdae's phasors ``a`` and ngspice's ``b`` at the same frequencies.

    Parameters
    ----------
    a, b : array_like of complex, shape (m,)
    floor : float
        Smallest magnitude a relative error is measured against (positive); where both
        magnitudes are below it the two agree (rounding noise on both sides).

    Returns
    -------
    AcMetrics

    Examples
    --------
    >>> m = ac_metrics([1.0 + 0.0j], [np.exp(1j * np.radians(0.5)) * 1.01], floor=1e-6)
    >>> round(m.max_phase_deg, 12), round(m.max_db, 6)
    (0.5, 0.086427)
    """
    a = np.asarray(a, dtype=complex)
    b = np.asarray(b, dtype=complex)
    if a.size == 0:
        raise ValueError("no points to compare")
    diff = np.abs(a - b)
    ma, mb = np.abs(a), np.abs(b)
    rel = diff / np.maximum(np.maximum(ma, mb), floor)
    # both below the floor: each side's rounding noise (a current that cancels exactly), equal
    rel[(ma <= floor) & (mb <= floor)] = 0.0
    worst = int(np.argmax(rel))
    both = (ma > floor) & (mb > floor)
    if np.any(both):
        max_db = float(np.max(np.abs(20.0 * np.log10(ma[both] / mb[both]))))
        max_phase = float(np.max(np.abs(np.degrees(np.angle(a[both] / b[both])))))
    else:
        max_db = max_phase = 0.0
    return AcMetrics(
        float(np.max(diff)), float(rel[worst]), float(np.sqrt(np.mean(diff * diff))), worst,
        max_db, max_phase, float(floor),
    )


@dataclass(frozen=True)
class InitialJump:
    """A difference at the start of a transient that decays quickly.

    Attributes
    ----------
    netdae, ngspice : float
        The two values at the first compared point (t0).
    settle : int
        Index of the first point from which the error stays within tolerance.
    """

    netdae: float
    ngspice: float
    settle: int


def initial_jump(t, a, b, *, scale: float, rel: float, abs_tol: float | None = None,
                 window: float = JUMP_WINDOW_FRACTION) -> InitialJump | None:
    """Detect an initial jump: out of tolerance at t0, within it for good soon after.

    Parameters
    ----------
    t : array_like, shape (m,)
        Time points (increasing).
    a, b : array_like, shape (m,)
        netdae's and ngspice's values at ``t``.
    scale, rel, abs_tol : float
        The signal's scale and tolerances (as in :func:`within`).
    window : float
        The error must stay within tolerance from a time no later than
        ``t0 + window * (t[-1] - t0)``.

    Returns
    -------
    InitialJump or None
        None when the first point is within tolerance, or when the error does
        not settle within the window (a lasting disagreement, not a jump).

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> a = np.cos(t); b = np.cos(t) * (t > 0.005)    # b starts at 0, then agrees
    >>> j = initial_jump(t, a, b, scale=1.0, rel=1e-3)
    >>> (j.netdae, j.ngspice, j.settle)
    (1.0, 0.0, 1)
    """
    t = np.asarray(t, dtype=float)
    ok = within(np.asarray(a, dtype=float) - np.asarray(b, dtype=float), scale, rel, abs_tol)
    if ok.size < 2 or ok[0]:
        return None
    bad = np.flatnonzero(~ok)
    settle = int(bad[-1]) + 1
    if settle >= t.size or t[settle] - t[0] > window * (t[-1] - t[0]):
        return None
    return InitialJump(float(a[0]), float(b[0]), settle)
