"""Event location on the BDF step's own interpolant: where a linear function of x crosses a threshold.

After an accepted step from ``t`` to ``t_new`` of order ``k`` and the update
of the modified divided differences (:func:`~netdae.dae.compiled.control.update_differences`),
the history ``P`` represents the polynomial of degree ``k`` through the
``k + 1`` last computed points, the method's dense output on ``[t, t_new]``
(IDA's ``IDAGetSolution``, the polynomial :class:`netdae.dae.dense.Interpolant`
rebuilds from the stored points). A *control* ``c(x) = x[a] - x[b]`` (``b``
may be ground) is linear in x, so its interpolant is the same combination of
the columns of ``P``; :func:`crossing_time` finds where it first crosses a
threshold in a given direction, :func:`interpolate_state` evaluates every
unknown there.

These are what the switches of a circuit need (:mod:`netdae.devices.kernels.switch`):
a step whose end finds a switch's control past its threshold is cut at the
crossing, located on the interpolant, instead of being repeated with smaller
steps until one lands near it. The kernels know nothing of circuits; both
integrators call them (the compiled loop directly, the Python ``BDF`` driver
through :class:`netdae.devices.switch.SwitchEvents`).
"""

from __future__ import annotations

import numpy as np

from . import kernel

__all__ = ["interpolate_column", "interpolate_state", "crossing_time", "CROSSING_SAMPLES", "CROSSING_ITERATIONS",
           "EVENT_MIN_GAP", "EVENT_TOGETHER", "CHATTER_EVENTS", "chatter_message", "ulp"]

#: The interpolant is sampled at this many equal subintervals of the step to bracket the first crossing.
CROSSING_SAMPLES = 8
#: Most iterations of the bracketing root finder (Illinois); it stops earlier at the time's roundoff.
CROSSING_ITERATIONS = 100
#: An event is placed at least this fraction of the step after the step's start, so that the
#: integration advances even when a control sits on its threshold at the start (a switch whose
#: own switching puts its control back across the threshold would otherwise switch forever at one time).
EVENT_MIN_GAP = 1e-6
#: Crossings within this fraction of the step of the first one happen together (one restart);
#: a crossing this close to the step's end ends the step there (the step is not cut).
EVENT_TOGETHER = 1e-9
#: A switch that switches back in the first step after each of this many consecutive events
#: chatters (a sliding mode: its control returns across the threshold as soon as it switches,
#: which no sequence of isolated instants resolves): the integration stops and says so
#: (ngspice stops with "timestep too small" there).
CHATTER_EVENTS = 100


@kernel
def ulp(t):
    """The spacing of doubles at ``|t|``: the rounding of a time ``t`` (``nextafter(|t|, inf) - |t|``).

    >>> ulp(1.0) == 2.0 ** -52
    True
    """
    a = abs(t)
    return np.nextafter(a, np.inf) - a


@kernel
def interpolate_column(P, k, psi, delt, a, b, n):
    """``x[a] - x[b]`` at ``t_new + delt`` on the step's interpolant (``b == n``: ground, 0).

    ``P`` holds the updated differences of the step just completed (order ``k``),
    ``psi`` the step's ``psi`` (``psi[j] = t_new - t_{n-j}``), ``delt <= 0``.
    """
    c = 1.0
    gam = delt / psi[0]
    value = P[0, a] - (P[0, b] if b < n else 0.0)
    for j in range(1, k + 1):
        c *= gam
        gam = (delt + psi[j - 1]) / psi[j]
        value += c * (P[j, a] - (P[j, b] if b < n else 0.0))
    return value


@kernel
def interpolate_state(P, k, psi, delt, n, out):
    """Every unknown (columns ``:n`` of ``P``) at ``t_new + delt`` into ``out``."""
    for i in range(n):
        out[i] = P[0, i]
    c = 1.0
    gam = delt / psi[0]
    for j in range(1, k + 1):
        c *= gam
        gam = (delt + psi[j - 1]) / psi[j]
        for i in range(n):
            out[i] += c * P[j, i]


@kernel
def _excess(P, k, psi, tau, t_new, a, b, n, theta, direction):
    return direction * (interpolate_column(P, k, psi, tau - t_new, a, b, n) - theta)


@kernel
def crossing_time(P, k, psi, t, t_new, a, b, n, theta, direction):
    """The first time in ``(t, t_new]`` where ``direction * (x[a] - x[b] - theta)`` becomes >= 0.

    On the step's interpolant (see the module docstring); ``direction`` is +1
    for a rising crossing, -1 for a falling one. The interpolant is sampled at
    :data:`CROSSING_SAMPLES` subintervals, the first that brackets a crossing is
    refined by the Illinois variant of regula falsi to the roundoff of the
    time. Returns ``t_new`` when the interpolant shows no crossing (the control
    reaches the threshold only at the step's end, to rounding).
    """
    f_lo = _excess(P, k, psi, t, t_new, a, b, n, theta, direction)
    if f_lo >= 0.0:
        return t  # already at (or past) the threshold at the step's start
    lo = t
    hi = t_new
    f_hi = 0.0
    found = False
    for i in range(1, CROSSING_SAMPLES + 1):
        tau = t_new if i == CROSSING_SAMPLES else t + (t_new - t) * i / CROSSING_SAMPLES
        f = _excess(P, k, psi, tau, t_new, a, b, n, theta, direction)
        if f >= 0.0:
            hi = tau
            f_hi = f
            found = True
            break
        lo = tau
        f_lo = f
    if not found:
        return t_new
    if f_hi == 0.0:
        return hi
    side = 0
    for _ in range(CROSSING_ITERATIONS):
        width = hi - lo
        if width <= 4.0 * ulp(hi):
            break
        tau = hi - f_hi * width / (f_hi - f_lo)
        if not (lo < tau < hi):
            tau = 0.5 * (lo + hi)
        f = _excess(P, k, psi, tau, t_new, a, b, n, theta, direction)
        if f >= 0.0:
            hi = tau
            f_hi = f
            if side == 1:
                f_lo *= 0.5
            side = 1
            if f == 0.0:
                break
        else:
            lo = tau
            f_lo = f
            if side == -1:
                f_hi *= 0.5
            side = -1
    return hi


def chatter_message(name: str, behavioural: bool = False) -> tuple[str, str]:
    """The failure's ``what`` and ``hint`` for a chattering switch or behavioural source's comparison
    (Python; both integrators use it)."""
    if behavioural:
        what = (f"behavioural source {name} chatters: a comparison in its expression changes back right after "
                f"each of {CHATTER_EVENTS} changes (a sliding mode)")
        hint = ("the source's own jump moves the operands of its comparison back across; give the comparison "
                "a hysteresis (positive feedback, or an S switch with VH > 0) or slow its input down")
        return what, hint
    what = (f"switch {name} chatters: its control crosses back over the threshold right after each of "
            f"{CHATTER_EVENTS} switchings (a sliding mode)")
    hint = ("the switch's own switching moves its control back across the threshold; give its model a "
            "hysteresis (VH > 0 for S, IH > 0 for W) wider than that move, or slow the control down")
    return what, hint
