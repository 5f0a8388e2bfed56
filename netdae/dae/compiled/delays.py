"""Delayed waves of transmission lines in the compiled step loop.

A lossless line couples each of its ports to the wave that left the other
port ``tau`` earlier: ``phi[row] += w_row(t - tau_row)`` with ``w = D x`` (see
:class:`netdae.mna.system.Delays`). The loop records ``w`` at every accepted
point next to the saved unknowns (extra columns of the output buffer), and
evaluates the delayed value on the solution's own interpolant: the
polynomial of the step that covered ``t - tau`` (through the points of that
step's order, never reaching back across a restart or a jump), as the dense
output (:class:`netdae.dae.dense.Interpolant`) does. Before the start the
wave is the start's (``w0``: the operating point's, or the lines' ``ic=``).

Steps never exceed the shortest delay, so ``t - tau`` lies at or before the
last accepted point and the delayed value is a known input of every step; the
corners of the sources, carried along the lines, are breakpoints
(:meth:`netdae.mna.system.Delays.breakpoints`), so no step's polynomial
straddles one.
"""

from __future__ import annotations

from . import kernel
from .dense import lagrange_weight, locate

__all__ = ["delayed_wave", "add_delayed", "record_waves"]


@kernel
def delayed_wave(tq, col, t, orders, x, m, segments, nseg):
    """Column ``col`` of the recorded ``x`` at ``t[0] < tq``, on the covering step's polynomial.

    Parameters
    ----------
    tq : float
    col : int
    t, orders, x : ndarray, shapes (cap,), (cap,), (cap, nc)
        The output buffers; the first ``m`` points are recorded.
    m : int
        Points recorded (at least 1).
    segments, nseg : ndarray of int64, int
        Recorded segment starts (positions in the buffers).
    """
    if m == 1:
        return x[0, col]
    i = locate(t, m, tq)
    # the start of the segment of point i - 1: the last listed start, or a repeated time
    a = 0
    b = nseg
    while a < b:  # the number of starts <= i - 1
        mid = (a + b) // 2
        if segments[mid] <= i - 1:
            a = mid + 1
        else:
            b = mid
    start = segments[a - 1] if a > 0 else 0
    k = orders[i]
    j = i - 1
    while j > start and j > i - 1 - k:
        if t[j] == t[j - 1]:
            start = j
            break
        j -= 1
    if t[i] == t[i - 1]:
        return x[i - 1, col]
    k = min(k, i - start)
    out = 0.0
    for p in range(k + 1):
        out += lagrange_weight(t, i, k, p, tq) * x[i - p, col]
    return out


@kernel
def add_delayed(tnow, rows, tau, w0, t0, t, orders, x, col0, m, segments, nseg, out):
    """``out[rows[r]] += w_r(tnow - tau[r])`` for every delayed row ``r``."""
    for r in range(rows.size):
        tq = tnow - tau[r]
        if tq <= t0 or m == 0:
            out[rows[r]] += w0[r]
        else:
            out[rows[r]] += delayed_wave(tq, col0 + r, t, orders, x, m, segments, nseg)


@kernel
def record_waves(x, ptr, idx, val, col0, buf_x, m):
    """``buf_x[m, col0 + r] = (D x)[rows[r]]``, ``D``'s rows as CSR (``ptr``, ``idx``, ``val``)."""
    for r in range(ptr.size - 1):
        acc = 0.0
        for p in range(ptr[r], ptr[r + 1]):
            acc += val[p] * x[idx[p]]
        buf_x[m, col0 + r] = acc
