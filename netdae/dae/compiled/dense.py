"""Dense output evaluated in compiled code: the kernel of :class:`netdae.dae.dense.Interpolant`.

At each requested time, the step it falls in (``t[i-1] <= tq <= t[i]``, the
step ending at a repeated time for a time on a boundary) and the Lagrange
weights of its polynomial through ``x[i - k .. i]`` in scalar arithmetic, as
:meth:`~netdae.dae.dense.Interpolant._evaluate_one` (the reference) forms
them: a few tens of nanoseconds per time and unknown where the vectorised
numpy form costs about a microsecond per time in temporaries.
"""

from __future__ import annotations

import math

from . import kernel

__all__ = ["lagrange_eval", "lagrange_weight", "locate", "polynomial_peaks"]


@kernel
def locate(t, m, v):
    """The step of ``t[:m]`` (m >= 2) that covers ``v``: ``searchsorted(t[:m], v, "left")`` within [1, m - 1]."""
    lo = 0
    hi = m
    while lo < hi:
        mid = (lo + hi) // 2
        if t[mid] < v:
            lo = mid + 1
        else:
            hi = mid
    return min(max(lo, 1), m - 1)


@kernel
def lagrange_weight(t, i, k, a, v):
    """The weight of the point ``i - a`` in the polynomial through the points ``i - k .. i`` of ``t``, at ``v``.

    Times are taken relative to ``t[i]`` in units of the step ``t[i] - t[i - 1]`` (1 for a
    repeated time), which keeps the products well scaled.
    """
    ti = t[i]
    scale = ti - t[i - 1]
    if not scale > 0.0:
        scale = 1.0
    s = (v - ti) / scale
    ua = (t[i - a] - ti) / scale
    w = 1.0
    for b in range(k + 1):
        if b != a:
            ub = (t[i - b] - ti) / scale
            d = ua - ub
            w *= (s - ub) / (d if d != 0.0 else 1.0)
    return w


@kernel
def lagrange_eval(t, orders, x, cols, tq, out):
    """``out[p, c] = `` the interpolant of column ``cols[c]`` of ``x`` at ``tq[p]``.

    Parameters
    ----------
    t : ndarray, shape (m,), m >= 2
        Step times, non-decreasing.
    orders : ndarray of int64, shape (m,)
        The order of the step ending at each time (already limited to its segment).
    x : ndarray, shape (m, ns)
    cols : ndarray of int64, shape (nc,)
    tq : ndarray, shape (p,)
    out : ndarray, shape (p, nc)
    """
    for p in range(tq.size):
        v = tq[p]
        i = locate(t, t.size, v)
        k = orders[i]
        for c in range(cols.size):
            out[p, c] = 0.0
        for a in range(k + 1):
            w = lagrange_weight(t, i, k, a, v)
            for c in range(cols.size):
                out[p, c] += w * x[i - a, cols[c]]


@kernel
def _horner(coef, i, x, order):
    """``p(x)`` (order 0), ``p'(x)`` (1) or ``p''(x)`` (2) of the polynomial ``coef[i]`` (highest power
    first), the derivatives' coefficients formed as a list of Python floats would form them."""
    deg = coef.shape[1] - 1
    out = 0.0
    for k in range(deg + 1 - order):
        c = coef[i, k]
        if order >= 1:
            c = c * (deg - k)
        if order == 2:
            c = c * (deg - 1 - k)
        out = out * x + c
    return out


@kernel
def polynomial_peaks(coef, s_lo, s_hi, sign, grid, out):
    """The largest ``sign * p_i(s)`` of each polynomial ``p_i`` on ``[s_lo[i], s_hi[i]]``: ``out[i]``.

    The best of the ``grid`` points (fractions of the interval), refined by up to eight Newton
    steps on ``p'`` kept inside the interval; the grid's best stands where Newton ends lower (a
    flat or degenerate peak). :func:`netdae.analyses.measure._peaks` is its caller.

    Parameters
    ----------
    coef : ndarray, shape (m, d + 1)
        Coefficients, highest power first.
    s_lo, s_hi : ndarray, shape (m,)
    sign : float
        +1 for a maximum, -1 for a minimum.
    grid : ndarray, shape (g,)
        Points in [0, 1].
    out : ndarray, shape (m,)
    """
    for i in range(coef.shape[0]):
        lo = s_lo[i]
        hi = s_hi[i]
        start = lo
        best = -math.inf
        for u in grid:
            x = lo + (hi - lo) * u
            v = sign * _horner(coef, i, x, 0)
            if v > best:
                start = x
                best = v
        x = start
        for _ in range(8):
            curve = _horner(coef, i, x, 2)
            if curve == 0.0 or not math.isfinite(curve):
                break
            y = x - _horner(coef, i, x, 1) / curve
            if lo > y:  # max(y, lo), then min(., hi), as Python's builtins order them
                y = lo
            if hi < y:
                y = hi
            x = y
        out[i] = x if sign * _horner(coef, i, x, 0) >= best else start
