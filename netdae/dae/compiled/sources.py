"""Independent-source waveforms in compiled code: u(t) for the transient engine.

The compiled engine evaluates every time-dependent source at every Newton
iteration, so the waveforms are packed once into plain arrays
(:func:`pack_sources`) and evaluated by :func:`source_values` inside the
compiled loop. The formulas are those of :mod:`netdae.netlist.waveforms`
(ngspice 39's ``vsrcload.c``), which stays the reference: the tests compare
both on random times, corners included.

Packing
-------
``kind[j]`` is one of the ``KIND_*`` codes, ``par[j, :]`` the resolved
parameters in card order (see :mod:`netdae.netlist.waveforms`), and for PWL
sources ``pwl_t[j, :pwl_n[j]]`` / ``pwl_v[j, :pwl_n[j]]`` the points, with
``par[j] = (delay, repeat?, t_start, period)``. Sources without a transient
function are ``KIND_DC`` with ``par[j, 0]`` the value.
"""

from __future__ import annotations

import math

import numpy as np
from . import kernel

__all__ = ["pack_sources", "source_values", "KIND_DC", "KIND_PULSE", "KIND_SIN", "KIND_EXP",
           "KIND_PWL", "KIND_SFFM", "KIND_AM"]

KIND_DC = 0
KIND_PULSE = 1
KIND_SIN = 2
KIND_EXP = 3
KIND_PWL = 4
KIND_SFFM = 5
KIND_AM = 6
#: Parameters per source row (SFFM and AM have the most: seven).
N_PAR = 8

_TWO_PI = 2.0 * math.pi
_DEG = math.pi / 180.0
#: A PWL time within this many ulps of a point is on the point (ngspice's AlmostEqualUlps).
_PWL_EQUAL_ULPS = 3.0


def pack_sources(sources) -> tuple:
    """Pack a :class:`~netdae.mna.sources.SourceVector` (transient mode) into arrays.

    Returns
    -------
    (kind, par, pwl_t, pwl_v, pwl_n)
        ``kind`` int64 (m,), ``par`` float (m, N_PAR), PWL points float
        (m, p) padded, ``pwl_n`` int64 (m,).
    """
    from ...netlist import waveforms as wf

    m = int(sources.m)
    kind = np.zeros(m, dtype=np.int64)
    par = np.zeros((m, N_PAR))
    par[:, 0] = np.asarray(sources.u0, dtype=float).reshape(m)
    codes = {wf.Pulse: KIND_PULSE, wf.Sin: KIND_SIN, wf.Exp: KIND_EXP, wf.Sffm: KIND_SFFM, wf.Am: KIND_AM}
    groups = sources.bank._groups if sources.bank is not None else []
    width = 1
    for cls, _, P in groups:
        if cls is wf.Pwl:
            width = max(width, P[0].shape[1])
    pwl_t = np.zeros((m, width))
    pwl_v = np.zeros((m, width))
    pwl_n = np.zeros(m, dtype=np.int64)
    for cls, idx, P in groups:
        rows = np.asarray(sources.timed)[idx]
        if cls is wf.Pwl:
            times, values, delay, rep, tstart, period = P
            for c, row in enumerate(rows):
                k = times.shape[1]  # padded with the last point: the same function
                kind[row] = KIND_PWL
                pwl_t[row, :k], pwl_v[row, :k] = times[c], values[c]
                pwl_t[row, k:], pwl_v[row, k:] = times[c, -1], values[c, -1]
                pwl_n[row] = width
                par[row, :4] = (delay[c], 1.0 if rep[c] else 0.0, tstart[c], period[c])
        else:
            for c, row in enumerate(rows):
                kind[row] = codes[cls]
                par[row, : P.shape[0]] = P[:, c]
    return kind, par, pwl_t, pwl_v, pwl_n


@kernel
def _pulse(p, t):
    v1, v2, td, tr, tf, pw, per, npulse = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    if npulse > 0 and t > td + npulse * per:
        return v1
    # the period t lies in, bounded as the breakpoints td + k*per are computed
    # (netdae.netlist.waveforms.pulse_period): a pulse cut by its period jumps exactly there
    time = t - td
    k = math.floor(time / per)
    if td + k * per > t:
        k -= 1
    elif td + (k + 1) * per <= t:
        k += 1
    if k >= 2 or (k == 1 and t != td + per):  # the first period ends at td + per inclusive, as in ngspice
        time = t - (td + k * per)
    top = tr + pw
    if time <= 0 or time >= top + tf:
        return v1
    if tr <= time <= top:
        return v2
    if time < tr:
        return v1 + (v2 - v1) * time / tr
    return v2 + (v1 - v2) * (time - top) / tf


@kernel
def _sin(p, t):
    vo, va, freq, td, theta, phase = p[0], p[1], p[2], p[3], p[4], p[5]
    tau = t - td
    ph = phase * _DEG
    if tau <= 0:
        return vo + va * math.sin(ph)
    return vo + va * math.sin(_TWO_PI * freq * tau + ph) * math.exp(-tau * theta)


@kernel
def _exp(p, t):
    v1, v2, td1, tau1, td2, tau2 = p[0], p[1], p[2], p[3], p[4], p[5]
    if t <= td1:
        return v1
    rise = (v2 - v1) * -math.expm1(-(t - td1) / tau1)
    if t <= td2:
        return v1 + rise
    return v1 + rise + (v1 - v2) * -math.expm1(-(t - td2) / tau2)


@kernel
def _sffm(p, t):
    vo, va, fc, mdi, fs, phc, phs = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    return vo + va * math.sin(_TWO_PI * fc * t + phc * _DEG + mdi * math.sin(_TWO_PI * fs * t + phs * _DEG))


@kernel
def _am(p, t):
    va, vo, mf, fc, td, phs = p[0], p[1], p[2], p[3], p[4], p[6]
    tau = t - td
    if tau <= 0:
        return 0.0
    ph = phs * _DEG
    return va * (vo + math.sin(_TWO_PI * mf * tau + ph)) * math.sin(_TWO_PI * fc * tau + ph)


@kernel
def _ulp(a):
    return np.nextafter(a, np.inf) - a


@kernel
def _pwl(p, times, values, n, t):
    delay, rep, tstart, period = p[0], p[1], p[2], p[3]
    tau = t - delay
    if rep != 0.0 and tau >= times[n - 1]:
        per = period if period > 0 else 1.0
        tau = tstart + np.fmod(max(tau - tstart, 0.0), per)
    tol = _PWL_EQUAL_ULPS * _ulp(abs(tau))
    # first point not before tau - tol (bisect_left)
    lo_i, hi_i = 0, n
    target = tau - tol
    while lo_i < hi_i:
        mid = (lo_i + hi_i) // 2
        if times[mid] < target:
            lo_i = mid + 1
        else:
            hi_i = mid
    left = lo_i
    li = min(left, n - 1)
    if left == 0 or (left < n and times[li] <= tau + tol):
        return values[li]
    if left >= n:
        return values[n - 1]
    lo = left - 1
    t_lo, t_hi = times[lo], times[li]
    span = t_hi - t_lo if t_hi > t_lo else 1.0
    return values[lo] + (tau - t_lo) / span * (values[li] - values[lo])


@kernel
def source_values(kind, par, pwl_t, pwl_v, pwl_n, t, out):
    """u(t) of every source into ``out`` (shape (m,)); no allocation."""
    for j in range(kind.size):
        k = kind[j]
        p = par[j]
        if k == KIND_DC:
            out[j] = p[0]
        elif k == KIND_PULSE:
            out[j] = _pulse(p, t)
        elif k == KIND_SIN:
            out[j] = _sin(p, t)
        elif k == KIND_EXP:
            out[j] = _exp(p, t)
        elif k == KIND_PWL:
            out[j] = _pwl(p, pwl_t[j], pwl_v[j], pwl_n[j], t)
        elif k == KIND_SFFM:
            out[j] = _sffm(p, t)
        else:
            out[j] = _am(p, t)
