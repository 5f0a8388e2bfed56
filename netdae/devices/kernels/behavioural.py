"""Behavioural sources as one compiled kernel (the twin of :class:`netdae.devices.behavioral.BehaviouralFamily`).

Every source's expression is a tape (:mod:`netdae.devices.kernels.tape`);
the kernel runs the tapes of all instances, each register carrying its value
and its derivatives to the instance's leaves (forward mode), with the rules
of :mod:`netdae.devices.autodiff` (ngspice's semantics: ``a ** b`` is
``|a|^b``, ``exp`` saturates at 1e99, ``ln(0) = -1e99`` ...).

Layout (packed by ``BehaviouralFamily.compiled``)
-------------------------------------------------
``prog``: int64[M, 4], the instructions ``(op, a, b, c)`` of all tapes one
after the other; ``const``: float64[C]; ``inst``: int64[N, N_INST], per
instance the columns ``B_*`` (tape start and length, first leaf and number
of leaves, first constant, kind, the extended nodes ``n+``, ``n-`` and, for a
voltage source, its branch unknown, and the two slot quadruples of a voltage
source's fixed entries); ``leaf``: int64[Lt, N_LEAF], per leaf its control
nodes ``(p, m)`` and the four slots of the source's output on it; ``val``,
``der``: float64[R] and float64[R, Lmax], the registers (work arrays, R and
Lmax the largest tape and leaf count).

Equations: a current source adds ``expr`` from n+ to n-; a charge-defined
capacitor adds the charge ``expr`` on n+ (``-expr`` on n-); a voltage source
has the branch equation ``v(n+) - v(n-) - expr = 0`` in the row of its
branch current ``i``, which flows from n+ to n-.

Locked outcomes (events)
------------------------
A comparison or jump of the circuit's state (:data:`~netdae.devices.kernels.tape.LOCKED`
instructions) has a *slot*: instance ``k`` owns the ``inst[k, B_NLOCK]``
slots from ``inst[k, B_LOCK]``, numbered in tape order (none for a
charge-defined capacitor, ``KIND_CHARGE``: a charge is continuous, so its
comparisons select between regions that meet, and are evaluated from the point). ``lock``:
float64[N_LOCK_ROWS, S + 1] holds per slot the held outcome (row
``LOCK_HELD``), the outcome of the last probe (``LOCK_PROBED``), the outcome
just past a located change (``LOCK_NEXT``) and the time of that change
(``LOCK_TIME``); ``lock[LOCK_HELD, S]`` is the hold flag. An operating point
evaluates every outcome from the iterate (the flag is 0); a transient holds
them through each step (:func:`lock_record` at its start) and
:func:`lock_step` locates, after each accepted step, where an outcome
changed on the step's interpolant, as :func:`netdae.devices.kernels.switch.switch_step`
does for the switches: the step ends there, the outcomes change
(:func:`lock_flip`) and the method restarts at order 1 from the right limit.
Held, a source is smooth within each step (no Newton iteration meets the
jump) and its jump is at the located instant, not at whichever step end
first sees it. A change that leaves the source's value continuous (a
piecewise law whose regions meet: a MOS charge's regions, ``v > 0 ? v : 0``)
is a corner, not a jump: the step ends there as at a jump (past it the held
branch was extrapolated), but its outcomes are not held from then on (row
``LOCK_HELD`` NaN) and the error test sees the later corners, as without
locks (restarting at every corner cost the Test Set's NAND gate 1.4 of its 6
digits at 1e-4). A change that leaves the value as it was, at the change and
at the step's end, is *masked* (``(v(a) > 1) && (v(b) < 0.5)`` while v(b) is
high): the outcome changes without an event and stays held, since a later
change of the other operand may make it count.
"""

from __future__ import annotations

import math

import numpy as np

from ...dae.compiled import kernel
from ...dae.compiled.events import (CROSSING_ITERATIONS, CROSSING_SAMPLES, EVENT_MIN_GAP, EVENT_TOGETHER,
                                    interpolate_state, ulp)
from ...netlist.expr import TABLE_DOMAIN  # the smoothing domain of a TABLE's corners
from ..autodiff import (  # ngspice's PTexp saturation, PTlog(0), PTdivide's fudge; a comparison's tie
    DIVISION_FUDGE, EXP_ARG_MAX, EXP_SATURATED, LOG_OF_ZERO, ROUNDING_TIE,
)
from . import FLAG_NONFINITE
from .scatter import add_charge, add_charge_slope, add_current, add_current_slope
from .tape import (
    OP_ADD, OP_AND, OP_CONST, OP_CPOW, OP_DIV, OP_EQ, OP_FUNC1, OP_GE, OP_GT, OP_LE, OP_LEAF, OP_LIMIT, OP_LT,
    OP_MAX, OP_MIN, OP_MOD, OP_MUL, OP_NE, OP_NEG, OP_NOT, OP_OR, OP_POW, OP_PWL, OP_PWR, OP_SELECT, OP_SUB,
    OP_TABLE, OP_TIME, LOCKED,
)

__all__ = ["eval_behavioural", "lock_record", "lock_step", "lock_flip", "lock_changed", "B_LOCK", "B_NLOCK", "LOCK_HELD",
           "LOCK_PROBED", "LOCK_NEXT", "LOCK_TIME", "N_LOCK_ROWS", "lock_undefined", "lock_at", "B_PROG", "B_LEN", "B_LEAF", "B_NLEAF", "B_CONST", "B_KIND", "B_P", "B_M", "B_BR",
           "B_S_VPM", "B_S_IB", "N_INST", "L_P", "L_M", "L_S", "N_LEAF", "KIND_CURRENT", "KIND_VOLTAGE",
           "KIND_CHARGE"]

B_PROG, B_LEN, B_LEAF, B_NLEAF, B_CONST, B_KIND, B_P, B_M, B_BR, B_S_VPM, B_S_IB = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 13
B_LOCK, B_NLOCK = B_S_IB + 4, B_S_IB + 5
N_INST = B_NLOCK + 1
LOCK_HELD, LOCK_PROBED, LOCK_NEXT, LOCK_TIME = 0, 1, 2, 3
N_LOCK_ROWS = 4
#: How ``run_tape`` treats the locked instructions: evaluated, held, or evaluated into ``LOCK_PROBED``.
LOCK_FREE, LOCK_USE, LOCK_PROBE = 0, 1, 2
#: A change of outcomes is a corner, not a jump, when the value moves by at most this fraction of itself
#: there, or by at most this fraction of the difference the new outcomes make at the step's end.
CORNER_REL = 1e-9
CORNER_RATIO = 1e-3
#: Where the classification of a change looks just past it: this fraction of the rest of the step.
PAST_FRACTION = 1e-2
L_P, L_M, L_S = 0, 1, 2
N_LEAF = L_S + 4
KIND_CURRENT, KIND_VOLTAGE, KIND_CHARGE = 0, 1, 2

_LN10 = math.log(10.0)

# one-argument functions (the order of tape.FUNCTIONS_1)
F_SQRT, F_EXP, F_LN, F_LOG10, F_SIN, F_COS, F_TAN, F_ASIN, F_ACOS, F_ATAN, F_SINH, F_COSH = range(12)
F_TANH, F_ASINH, F_ACOSH, F_ATANH, F_ABS, F_URAMP, F_SGN, F_FLOOR, F_CEIL, F_INT, F_NINT, F_U = range(12, 24)


@kernel
def _exp(u):
    return EXP_SATURATED if u > EXP_ARG_MAX else math.exp(u)


@kernel
def _ln(u):
    return LOG_OF_ZERO if u == 0.0 else math.log(u)


@kernel
def _function(f, u):
    """Value and derivative of one-argument function ``f`` at ``u``; ``has_slope`` False for step-like ones."""
    if f == F_SQRT:
        s = math.sqrt(u)
        return s, 0.5 / s, True
    if f == F_EXP:
        e = _exp(u)
        return e, e, True
    if f == F_LN:
        return _ln(u), 1.0 / u, True
    if f == F_LOG10:
        return _ln(u) / _LN10, 1.0 / (u * _LN10), True
    if f == F_SIN:
        return math.sin(u), math.cos(u), True
    if f == F_COS:
        return math.cos(u), -math.sin(u), True
    if f == F_TAN:
        c = math.cos(u)
        return math.tan(u), 1.0 / (c * c), True
    if f == F_ASIN:
        return math.asin(u), 1.0 / math.sqrt(1.0 - u * u), True
    if f == F_ACOS:
        return math.acos(u), -1.0 / math.sqrt(1.0 - u * u), True
    if f == F_ATAN:
        return math.atan(u), 1.0 / (1.0 + u * u), True
    if f == F_SINH:
        return math.sinh(u), math.cosh(u), True
    if f == F_COSH:
        return math.cosh(u), math.sinh(u), True
    if f == F_TANH:
        th = math.tanh(u)
        return th, 1.0 - th * th, True
    if f == F_ASINH:
        return math.asinh(u), 1.0 / math.sqrt(u * u + 1.0), True
    if f == F_ACOSH:
        return math.acosh(u), 1.0 / math.sqrt(u * u - 1.0), True
    if f == F_ATANH:
        return math.atanh(u), 1.0 / (1.0 - u * u), True
    if f == F_ABS:
        return abs(u), np.sign(u), True
    if f == F_URAMP:
        return (u if u > 0.0 else 0.0), (1.0 if u > 0.0 else 0.0), True
    if f == F_SGN:
        return np.sign(u), 0.0, False
    if f == F_FLOOR:
        return np.floor(u), 0.0, False
    if f == F_CEIL:
        return np.ceil(u), 0.0, False
    if f == F_INT:
        return np.trunc(u), 0.0, False
    if f == F_NINT:
        return np.rint(u), 0.0, False
    # F_U: ngspice's step, u(0) = 0.5
    return (1.0 if u > 0.0 else (0.0 if u < 0.0 else 0.5)), 0.0, False


@kernel
def _table_x(const, p0, n, i):
    """x of point ``i`` of the extended table (0 and n + 1 added as ngspice's XSPICE pwl adds them)."""
    if i == 0:
        return 2.0 * const[p0] - const[p0 + 2]
    if i == n + 1:
        return 2.0 * const[p0 + 2 * n - 2] - const[p0 + 2 * n - 4]
    return const[p0 + 2 * i - 2]


@kernel
def _table_y(const, p0, n, i):
    return const[p0 + 2 * min(max(i, 1), n) - 1]


@kernel
def _table(u, const, p0, n):
    """Value and slope of an E/G TABLE (the twin of :func:`netdae.netlist.expr.table_point`)."""
    if u <= 0.5 * (_table_x(const, p0, n, 0) + _table_x(const, p0, n, 1)):
        return _table_y(const, p0, n, 0), 0.0
    if u >= 0.5 * (_table_x(const, p0, n, n) + _table_x(const, p0, n, n + 1)):
        return _table_y(const, p0, n, n + 1), 0.0
    i = 1
    while i < n and not u < 0.5 * (_table_x(const, p0, n, i) + _table_x(const, p0, n, i + 1)):
        i += 1
    xc = _table_x(const, p0, n, i)
    yc = _table_y(const, p0, n, i)
    lower = xc - _table_x(const, p0, n, i - 1)
    upper = _table_x(const, p0, n, i + 1) - xc
    s_lower = (yc - _table_y(const, p0, n, i - 1)) / lower
    s_upper = (_table_y(const, p0, n, i + 1) - yc) / upper
    d = TABLE_DOMAIN * min(lower, upper)
    if u < xc - d:
        return yc + (u - xc) * s_lower, s_lower
    if u < xc + d:
        a = (s_upper - s_lower) / (4.0 * d)
        w = u - (xc + d)
        return yc + s_upper * d + s_upper * w + a * w * w, s_upper + 2.0 * a * w
    return yc + (u - xc) * s_upper, s_upper


@kernel
def _pwl(u, const, p0, n):
    """Value and slope of a B source's pwl() (the twin of :func:`netdae.netlist.expr.pwl_point`)."""
    k0 = 0
    k1 = n - 1
    while k1 - k0 > 1:
        k = (k0 + k1) // 2
        if const[p0 + 2 * k] > u:
            k1 = k
        else:
            k0 = k
    x0 = const[p0 + 2 * k0]
    y0 = const[p0 + 2 * k0 + 1]
    slope = (const[p0 + 2 * k1 + 1] - y0) / (const[p0 + 2 * k1] - x0)
    return y0 + (u - x0) * slope, slope


@kernel
def _scaled(d, factor):
    """``d * factor`` with a structural zero kept zero (0 * inf = 0, as autodiff's _scale)."""
    return 0.0 if d == 0.0 else d * factor


@kernel
def _copy_der(der, dst, src, nl):
    for j in range(nl):
        der[dst, j] = der[src, j]


@kernel
def _zero_der(der, dst, nl):
    for j in range(nl):
        der[dst, j] = 0.0


@kernel
def _combine(der, dst, a, fa, b, fb, nl):
    """``der[dst] = fa der[a] + fb der[b]`` with structural zeros kept (fa or fb may be non-finite)."""
    for j in range(nl):
        der[dst, j] = _scaled(der[a, j], fa) + _scaled(der[b, j], fb)


@kernel
def run_tape(prog, p0, m, const, c0, x, leaf, l0, nl, t, val, der, lock, s0, lockmode):
    """Run one tape: every register's value and derivatives; returns the result register's value.

    The locked instructions use slots ``s0, s0 + 1, ...`` of ``lock`` by ``lockmode``: ``LOCK_FREE``
    evaluates them, ``LOCK_USE`` reads their held outcomes, ``LOCK_PROBE`` evaluates them and writes
    the outcomes into row ``LOCK_PROBED``.

    ``val`` holds two registers per instruction: the value in ``val[r]`` and, in ``val[h + r]``
    (``h = val.size // 2``), the magnitude of the terms it was computed from (the rules of
    :data:`netdae.devices.autodiff.ROUNDING_TIE`). A comparison of the circuit's state (locked)
    whose operands differ by less than ``ROUNDING_TIE`` times their magnitudes is a tie.
    """
    h = val.size // 2
    slot = s0
    for r in range(m):
        op = prog[p0 + r, 0]
        a = prog[p0 + r, 1]
        b = prog[p0 + r, 2]
        c = prog[p0 + r, 3]
        if op == OP_CONST:
            val[r] = const[c0 + a]
            val[h + r] = 0.0
            _zero_der(der, r, nl)
        elif op == OP_TIME:
            val[r] = t
            val[h + r] = 0.0
            _zero_der(der, r, nl)
        elif op == OP_LEAF:
            val[r] = x[leaf[l0 + a, L_P]] - x[leaf[l0 + a, L_M]]
            val[h + r] = 0.0
            _zero_der(der, r, nl)
            der[r, a] = 1.0
        elif op == OP_NEG:
            val[r] = -val[a]
            val[h + r] = val[h + a]
            for j in range(nl):
                der[r, j] = -der[a, j]
        elif op == OP_NOT:
            val[r] = 1.0 if val[a] == 0.0 else 0.0
            val[h + r] = 0.0
            _zero_der(der, r, nl)
        elif op == OP_ADD:
            val[r] = val[a] + val[b]
            val[h + r] = val[h + a] + val[h + b] + abs(val[r])
            _combine(der, r, a, 1.0, b, 1.0, nl)
        elif op == OP_SUB:
            val[r] = val[a] - val[b]
            val[h + r] = val[h + a] + val[h + b] + abs(val[r])
            _combine(der, r, a, 1.0, b, -1.0, nl)
        elif op == OP_MUL:
            val[r] = val[a] * val[b]
            val[h + r] = val[h + a] * abs(val[b]) + abs(val[a]) * val[h + b] + abs(val[r])
            _combine(der, r, a, val[b], b, val[a], nl)
        elif op == OP_DIV:  # ngspice's fudged division (netdae.devices.autodiff: DIVISION_FUDGE)
            va = val[a]
            vb = val[b]
            square = vb * vb + DIVISION_FUDGE
            den = vb + (DIVISION_FUDGE if vb >= 0.0 else -DIVISION_FUDGE)
            val[r] = va / den
            val[h + r] = (val[h + a] + abs(val[r]) * val[h + b]) / abs(den) + abs(val[r])
            _combine(der, r, a, vb / square, b, -va / square, nl)
        elif op == OP_POW or op == OP_PWR:
            va = val[a]
            vb = val[b]
            absa = abs(va)
            v = absa ** vb
            fa = vb * (v / absa if absa != 0.0 else 0.0) * np.sign(va)
            fb = v * math.log(absa) if absa != 0.0 else 0.0
            sign = -1.0 if (op == OP_PWR and va < 0.0) else 1.0
            val[r] = sign * v
            val[h + r] = abs(fa) * val[h + a] + abs(fb) * val[h + b] + v
            _combine(der, r, a, sign * fa, b, sign * fb, nl)
        elif op == OP_CPOW:
            va = val[a]
            vb = val[b]
            v = va ** vb
            val[r] = v
            fa = vb * va ** (vb - 1.0)
            fb = v * (math.log(va) if va > 0.0 else math.nan)
            val[h + r] = abs(fa) * val[h + a] + (abs(fb) * val[h + b] if math.isfinite(fb) else 0.0) + abs(v)
            _combine(der, r, a, fa, b, fb, nl)
        elif op == OP_MOD:
            val[r] = np.fmod(val[a], val[b])
            quotient = np.trunc(val[a] / val[b])
            val[h + r] = val[h + a] + abs(quotient) * val[h + b] + abs(val[r])
            _combine(der, r, a, 1.0, b, -quotient, nl)
        elif op == OP_SELECT:
            src = b if val[a] != 0.0 else c
            val[r] = val[src]
            val[h + r] = val[h + src]
            _copy_der(der, r, src, nl)
        elif op == OP_MIN or op == OP_MAX:
            take_b = (val[a] > val[b]) if op == OP_MIN else (val[a] <= val[b])
            src = b if take_b else a
            val[r] = val[src]
            val[h + r] = val[h + src]
            _copy_der(der, r, src, nl)
        elif op == OP_LIMIT:
            lo, hi = (b, c) if val[b] <= val[c] else (c, b)
            src = a
            if val[a] < val[lo]:
                src = lo
            if val[a] > val[hi]:
                src = hi
            val[r] = val[src]
            val[h + r] = val[h + src]
            _copy_der(der, r, src, nl)
        elif op == OP_TABLE or op == OP_PWL:
            if op == OP_TABLE:
                v, slope = _table(val[a], const, c0 + b, c)
            else:
                v, slope = _pwl(val[a], const, c0 + b, c)
            val[r] = v
            val[h + r] = abs(v)  # a looked-up value (the autodiff reference's rule)
            for j in range(nl):
                der[r, j] = _scaled(der[a, j], slope)
        elif op >= OP_FUNC1:
            f = op - OP_FUNC1
            if c == LOCKED and f >= F_SGN:
                # a jump of the state (u, sgn, floor, ceil, int, nint): held or probed
                if lockmode == LOCK_USE and not math.isnan(lock[LOCK_HELD, slot]):
                    val[r] = lock[LOCK_HELD, slot]
                    val[h + r] = 0.0
                    _zero_der(der, r, nl)
                    slot += 1
                    continue
                v, slope, has_slope = _function(f, val[a])
                if lockmode == LOCK_PROBE:
                    lock[LOCK_PROBED, slot] = v
                slot += 1
            else:
                v, slope, has_slope = _function(f, val[a])
            val[r] = v
            if has_slope:
                val[h + r] = abs(slope) * val[h + a] + abs(v)
                for j in range(nl):
                    der[r, j] = _scaled(der[a, j], slope)
            else:
                val[h + r] = 0.0
                _zero_der(der, r, nl)
        else:
            # comparisons and logic: 0/1 without slope
            locked = c == LOCKED and op >= OP_LT
            val[h + r] = 0.0
            if locked and lockmode == LOCK_USE and not math.isnan(lock[LOCK_HELD, slot]):
                val[r] = lock[LOCK_HELD, slot]
                _zero_der(der, r, nl)
                slot += 1
                continue
            va = val[a]
            vb = val[b]
            if op == OP_AND:
                res = va != 0.0 and vb != 0.0
            elif op == OP_OR:
                res = va != 0.0 or vb != 0.0
            elif op == OP_EQ:
                res = va == vb
            elif op == OP_NE:
                res = va != vb
            elif locked and abs(va - vb) <= ROUNDING_TIE * (val[h + a] + val[h + b]):
                res = op == OP_LE or op == OP_GE  # a tie within the operands' rounding
            elif op == OP_LT:
                res = va < vb
            elif op == OP_LE:
                res = va <= vb
            elif op == OP_GT:
                res = va > vb
            else:  # OP_GE
                res = va >= vb
            val[r] = 1.0 if res else 0.0
            _zero_der(der, r, nl)
            if locked:
                if lockmode == LOCK_PROBE:
                    lock[LOCK_PROBED, slot] = val[r]
                slot += 1
    return val[m - 1]


@kernel
def eval_behavioural(x, t, prog, const, inst, leaf, val, der, lock, q, phi, dq, dphi, jacobian):
    """Add every behavioural source's currents (charges) and, when ``jacobian``, derivatives.

    Parameters
    ----------
    x : float64[n + 1]
        The extended iterate (``x[n] == 0``).
    t : float
        Time (the expressions' ``time``).
    prog, const, inst, leaf, val, der
        The packed tapes and work registers (module docstring).
    lock : float64[N_LOCK_ROWS, S + 1]
        The locked outcomes: held when ``lock[LOCK_HELD, S] != 0`` (a transient), else evaluated;
        a source whose value is not finite with its held outcomes is evaluated with the point's.
    q, phi : float64[n + 1]
    dq, dphi : float64[nnz + 1]
    jacobian : bool

    Returns
    -------
    flags, bad : int, int
        ``FLAG_NONFINITE`` and the first instance whose value is not finite
        (-1: none). A non-finite derivative of a finite value enters the
        Jacobian as 0 (the residual, not the Jacobian, decides convergence).
    """
    bad = -1
    last = lock.shape[1] - 1
    lockmode = LOCK_USE if lock[LOCK_HELD, last] != 0.0 else LOCK_FREE
    lock[LOCK_TIME, last] = 0.0  # set below when a held branch is undefined at x
    for k in range(inst.shape[0]):
        nl = inst[k, B_NLEAF]
        l0 = inst[k, B_LEAF]
        m = inst[k, B_LEN]
        value = _value(x, t, k, prog, const, inst, leaf, val, der, lock,
                       lockmode if inst[k, B_NLOCK] > 0 else LOCK_FREE)
        if lockmode == LOCK_USE and inst[k, B_NLOCK] > 0 and not math.isfinite(value):
            # the held branch is undefined here (sqrt(v(a)) held past v(a) > 0): the outcomes of the
            # point instead, and the flag tells the step loop that its end is past a change
            # (it ends the step there: :func:`lock_ahead`)
            value = _value(x, t, k, prog, const, inst, leaf, val, der, lock, LOCK_FREE)
            if lock[LOCK_TIME, last] == 0.0:
                lock[LOCK_TIME, last] = k + 1.0
        if bad < 0 and not math.isfinite(value):
            bad = k
        p = inst[k, B_P]
        mi = inst[k, B_M]
        kind = inst[k, B_KIND]
        if kind == KIND_CHARGE:
            add_charge(q, p, mi, value)
        elif kind == KIND_CURRENT:
            add_current(phi, p, mi, value)
        else:
            br = inst[k, B_BR]
            add_current(phi, br, x.size - 1, value - (x[p] - x[mi]))
            add_current(phi, p, mi, x[br])
        if jacobian:
            for j in range(nl):
                g = der[m - 1, j]
                if not math.isfinite(g):
                    g = 0.0
                if kind == KIND_CHARGE:
                    add_charge_slope(dq, leaf, l0 + j, L_S, g)
                else:
                    add_current_slope(dphi, leaf, l0 + j, L_S, g)
            if kind == KIND_VOLTAGE:
                add_current_slope(dphi, inst, k, B_S_VPM, -1.0)
                add_current_slope(dphi, inst, k, B_S_IB, 1.0)
    return (FLAG_NONFINITE if bad >= 0 else 0), bad


# ------------------------------------------------------------------ events of the locked outcomes
@kernel
def _probe(x, t, k, prog, const, inst, leaf, val, der, lock):
    """Instance ``k``'s outcomes at ``(x, t)`` into row ``LOCK_PROBED``; True when one differs from the held."""
    _value(x, t, k, prog, const, inst, leaf, val, der, lock, LOCK_PROBE)
    s0 = inst[k, B_LOCK]
    for s in range(s0, s0 + inst[k, B_NLOCK]):
        if lock[LOCK_PROBED, s] != lock[LOCK_HELD, s] and not math.isnan(lock[LOCK_HELD, s]):
            return True
    return False


@kernel
def _value(x, t, k, prog, const, inst, leaf, val, der, lock, lockmode):
    """Instance ``k``'s tape run at ``(x, t)``, its locked instructions by ``lockmode`` (:func:`run_tape`)."""
    return run_tape(prog, inst[k, B_PROG], inst[k, B_LEN], const, inst[k, B_CONST], x, leaf, inst[k, B_LEAF],
                    inst[k, B_NLEAF], t, val, der, lock, inst[k, B_LOCK], lockmode)


#: How a located change of outcomes acts on the source's value (:func:`_classify`).
CHANGE_JUMP, CHANGE_CORNER, CHANGE_MASKED = 0, 1, 2


@kernel
def _classify(P, kord, psi, hi, t_cap, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
    """How instance ``k``'s value takes the change of its outcomes at ``hi``: ``CHANGE_*``.

    Its value with the held and with the new outcomes is compared at ``hi`` and just past it
    (``PAST_FRACTION`` of the rest of the step, before another outcome of the source is likely to move):
    equal at both, the change is *masked* (``a > b && c``, ``c`` false: the value does not depend on it
    now); a jump keeps its size; a corner's difference grows from zero with the distance from the change
    (at ``hi`` at most ``CORNER_RATIO`` of its growth over the rest of the step, extrapolated from the
    probe past it, or ``CORNER_REL`` of the value). Where the held branch is undefined past the change
    (``sqrt(v(a))`` held past ``v(a) > 0``) its value just before the change stands for it, and the
    difference is weighed against how the held value moves approaching the change; undefined before
    it too (an outcome changed early by the interpolant's error, taken back), the change is a jump.
    """
    interpolate_state(P, kord, psi, hi - t_new, n, xw)
    xw[n] = 0.0
    held = _value(xw, hi, k, prog, const, inst, leaf, val, der, lock, LOCK_USE)
    free = _value(xw, hi, k, prog, const, inst, leaf, val, der, lock, LOCK_FREE)
    back = hi
    for _ in range(8):
        if math.isfinite(held):
            break
        # the held branch is undefined past the change (sqrt(v(a)) held past v(a) > 0): its value just
        # before (the bisection brackets the change to 4 ulps of the time)
        back -= 4.0 * ulp(back)
        interpolate_state(P, kord, psi, back - t_new, n, xw)
        xw[n] = 0.0
        held = _value(xw, back, k, prog, const, inst, leaf, val, der, lock, LOCK_USE)
    if not math.isfinite(held):
        # undefined before the change too (an outcome that changed early by the interpolant's error,
        # taken back): a jump, held from now on (evaluated from the point, the change of the branch
        # that is defined would come inside a step)
        return CHANGE_JUMP
    step = abs(free - held)
    if back != hi:
        # the held branch is undefined past the change: the step against how the held value moves
        # approaching it (over the same fraction of the rest of the step, before the change)
        before = back - PAST_FRACTION * (t_cap - hi)
        interpolate_state(P, kord, psi, before - t_new, n, xw)
        xw[n] = 0.0
        moved = abs(held - _value(xw, before, k, prog, const, inst, leaf, val, der, lock, LOCK_USE))
        if step <= CORNER_REL * (abs(free) + abs(held)) or step <= CORNER_RATIO * moved / PAST_FRACTION:
            return CHANGE_CORNER
        return CHANGE_JUMP
    # just past the change (a fraction of the rest of the step: before the source's other outcomes move)
    past = hi + PAST_FRACTION * (t_cap - hi)
    interpolate_state(P, kord, psi, past - t_new, n, xw)
    xw[n] = 0.0
    after = abs(_value(xw, past, k, prog, const, inst, leaf, val, der, lock, LOCK_FREE)
                - _value(xw, past, k, prog, const, inst, leaf, val, der, lock, LOCK_USE))
    if step == 0.0 and after == 0.0:
        return CHANGE_MASKED
    if step <= CORNER_REL * (abs(free) + abs(held)) or step <= CORNER_RATIO * after / PAST_FRACTION:
        return CHANGE_CORNER
    return CHANGE_JUMP


@kernel
def lock_record(x, t, prog, const, inst, leaf, val, der, lock):
    """Hold the outcomes at the extended point ``x`` at ``t`` from now on (a transient's start)."""
    for k in range(inst.shape[0]):
        if inst[k, B_NLOCK] > 0:
            _probe(x, t, k, prog, const, inst, leaf, val, der, lock)
    last = lock.shape[1] - 1
    for s in range(last):
        lock[LOCK_HELD, s] = lock[LOCK_PROBED, s]
        lock[LOCK_TIME, s] = math.inf
    lock[LOCK_HELD, last] = 1.0


@kernel
def _changed_at(P, kord, psi, tau, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
    """Whether instance ``k``'s outcomes at ``tau`` on the step's interpolant differ from the held ones."""
    interpolate_state(P, kord, psi, tau - t_new, n, xw)
    xw[n] = 0.0
    return _probe(xw, tau, k, prog, const, inst, leaf, val, der, lock)


#: Masked changes of one source followed within a step before its search stops (the rest: next step).
MASKED_CHANGES = 4


@kernel
def _first_change(P, kord, psi, start, t_cap, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
    """The first time in ``[start, t_cap]`` where instance ``k``'s outcomes differ from the held ones.

    Its outcomes at ``t_cap`` differ; those at ``start`` are checked first (a cascade after an event:
    ``start`` itself), then :data:`~netdae.dae.compiled.events.CROSSING_SAMPLES` samples bracket the change
    and bisection narrows it to the roundoff of the time.
    """
    if _changed_at(P, kord, psi, start, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
        return start
    lo = start
    hi = t_cap
    for i in range(1, CROSSING_SAMPLES):
        tau = start + (t_cap - start) * i / CROSSING_SAMPLES
        if _changed_at(P, kord, psi, tau, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
            hi = tau
            break
        lo = tau
    for _ in range(CROSSING_ITERATIONS):
        if hi - lo <= 4.0 * ulp(hi):
            break
        mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            break
        if _changed_at(P, kord, psi, mid, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
            hi = mid
        else:
            lo = mid
    return hi


@kernel
def lock_step(P, kord, psi, t, t_new, t_cap, n, prog, const, inst, leaf, val, der, lock, xw):
    """After an accepted step from ``t`` to ``t_new``: the first time in ``(t, t_cap]`` where a held outcome changes.

    ``P`` holds the step's updated differences (order ``kord``) and ``psi``
    (:mod:`netdae.dae.compiled.events`); ``t_cap <= t_new`` is where the step
    ends otherwise (a switch's event). For every instance whose outcomes at
    ``t_cap`` differ from the held ones, the change is bracketed on
    :data:`~netdae.dae.compiled.events.CROSSING_SAMPLES` subintervals and
    bisected to the roundoff of the time (outcomes are discrete: no regula
    falsi), at least ``EVENT_MIN_GAP`` of the step after ``t``; row
    ``LOCK_TIME`` gets the time for the slots that change there and
    ``LOCK_NEXT`` their outcomes just past it.

    Parameters
    ----------
    xw : float64[n + 1]
        Work: the interpolated extended unknowns.

    Returns
    -------
    (t_ev, count) : (float, int)
        The event's time (``t_cap`` when none comes first, or one within
        ``EVENT_TOGETHER`` of the step before it) and how many instances
        change there (0: no event; then nothing in ``lock`` but the work rows
        was touched). Pass ``t_ev + EVENT_TOGETHER * (t_new - t)`` to
        :func:`lock_flip`.

    Notes
    -----
    Cost: per changing instance about 60 interpolations and tape runs; none
    for a step without a change (one tape run per instance with slots).
    """
    h = t_new - t
    t_ev = t_cap
    found = 0
    for k in range(inst.shape[0]):
        s0, nk = _unmarked(inst, lock, k)
        if nk == 0:
            continue
        start = t
        for _ in range(MASKED_CHANGES):
            if not _changed_at(P, kord, psi, t_cap, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw):
                break
            hi = _first_change(P, kord, psi, start, t_cap, t_new, n, k, prog, const, inst, leaf, val, der, lock,
                               xw)
            _changed_at(P, kord, psi, hi, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw)
            for s in range(s0, s0 + nk):
                lock[LOCK_NEXT, s] = lock[LOCK_PROBED, s]
            change = _classify(P, kord, psi, hi, t_cap, t_new, n, k, prog, const, inst, leaf, val, der, lock, xw)
            if change == CHANGE_MASKED:
                # the value does not depend on the changed outcomes now: they change without an event, and
                # the search goes on from there (another outcome of the source may change later in the step)
                for s in range(s0, s0 + nk):
                    if not math.isnan(lock[LOCK_HELD, s]):
                        lock[LOCK_HELD, s] = lock[LOCK_NEXT, s]
                start = hi
                continue
            if change == CHANGE_CORNER:
                # the source's value is continuous there (a piecewise law's regions meet): the step still ends
                # at the change (past it the held branch was extrapolated), but from then on the changed
                # outcomes are evaluated from the point (NaN held), the error test seeing the corners
                for s in range(s0, s0 + nk):
                    if lock[LOCK_NEXT, s] != lock[LOCK_HELD, s] and not math.isnan(lock[LOCK_HELD, s]):
                        lock[LOCK_NEXT, s] = math.nan
            tc = max(hi, t + EVENT_MIN_GAP * h)
            _mark_changes(inst, lock, k, tc)
            found += 1
            if tc < t_ev:
                t_ev = tc
            break
    if found == 0:
        return t_cap, 0
    if t_cap - t_ev <= EVENT_TOGETHER * h or not t_ev > t:
        t_ev = t_cap
    limit = t_ev + EVENT_TOGETHER * h
    count = 0
    for k in range(inst.shape[0]):
        if lock_changed(inst, lock, k, limit):
            count += 1
    return t_ev, count


@kernel
def lock_undefined(lock):
    """The first behavioural source (from 0) whose held branch was undefined at the last evaluation's
    point, whose outcomes it then took (:func:`eval_behavioural`); -1: none."""
    return int(lock[LOCK_TIME, lock.shape[1] - 1]) - 1


@kernel
def _unmarked(inst, lock, k):
    """Instance ``k``'s held slots, their change times cleared (``LOCK_TIME`` infinite): ``(first slot, count)``."""
    s0 = inst[k, B_LOCK]
    nk = inst[k, B_NLOCK]
    for s in range(s0, s0 + nk):
        lock[LOCK_TIME, s] = math.inf
    return s0, nk


@kernel
def _mark_changes(inst, lock, k, tc):
    """Instance ``k``'s held slots whose row ``LOCK_NEXT`` differs change at ``tc`` (row ``LOCK_TIME``)."""
    s0 = inst[k, B_LOCK]
    for s in range(s0, s0 + inst[k, B_NLOCK]):
        if lock[LOCK_NEXT, s] != lock[LOCK_HELD, s] and not math.isnan(lock[LOCK_HELD, s]):
            lock[LOCK_TIME, s] = tc


@kernel
def lock_at(x, t, prog, const, inst, leaf, val, der, lock):
    """The outcomes at the extended point ``x`` (at ``t``) that differ from the held ones change at ``t``.

    Rows ``LOCK_NEXT``/``LOCK_TIME`` of those slots (the rest: TIME infinite), as :func:`lock_step` leaves
    them for :func:`lock_flip`: where a held branch is undefined past a change the step loop could not
    bracket on the predictor (it met the change at a step of ``EVENT_MIN_GAP`` of the first). Returns
    how many sources change.
    """
    count = 0
    for k in range(inst.shape[0]):
        s0, nk = _unmarked(inst, lock, k)
        if nk == 0:
            continue
        if _probe(x, t, k, prog, const, inst, leaf, val, der, lock):
            count += 1
            for s in range(s0, s0 + nk):
                lock[LOCK_NEXT, s] = lock[LOCK_PROBED, s]
            _mark_changes(inst, lock, k, t)
    return count


@kernel
def lock_flip(lock, limit):
    """The outcomes that :func:`lock_step` found changing by ``limit`` take their new values."""
    for s in range(lock.shape[1] - 1):
        if lock[LOCK_TIME, s] <= limit:
            lock[LOCK_HELD, s] = lock[LOCK_NEXT, s]


@kernel
def lock_changed(inst, lock, k, limit):
    """Whether instance ``k`` has an outcome that :func:`lock_step` found changing by ``limit``."""
    s0 = inst[k, B_LOCK]
    for s in range(s0, s0 + inst[k, B_NLOCK]):
        if lock[LOCK_TIME, s] <= limit:
            return True
    return False
