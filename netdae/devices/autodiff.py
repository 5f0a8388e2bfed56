"""Vectorised evaluation of behavioural expressions with exact derivatives.

A behavioural source's expression (the tree of :mod:`netdae.netlist.expr`)
depends on circuit quantities, its *leaves*: ``V(a)``, ``V(a, b)``,
``I(vname)``, and on ``time``. :class:`ExpressionGroup` evaluates many
expressions of identical *structure* at once: the same tree shape with
possibly different constants and different leaves (the hundreds of B sources
of a subcircuit instantiated many times are one group). Constants become
per-instance arrays, leaves become per-instance control voltages, and one
walk over the shared tree computes the values of all instances together with
their derivatives to every leaf, by forward-mode automatic differentiation:
each intermediate carries ``(value (N,), derivative (L, N))``.

Semantics follow ngspice's B-source evaluator (``ptfuncs.c``): ``a ** b``
is ``|a|^b``, ``pwr(a, b)`` is ``sgn(a) |a|^b``, ``u(0) = 0.5``,
``exp`` saturates at ``1e99`` (argument 227.9559242), ``ln(0) = -1e99``.
Derivatives are exact where the function is differentiable; comparisons,
logical operators, ``u``, ``sgn``, ``int``/``floor``/``ceil``/``nint`` and the
condition of ``if``/``?:`` contribute zero (the derivative does not see the
switch), ``min``/``max``/``limit`` pass the derivative of the selected
argument, ``table``/``pwl`` the slope of the segment (or of the smoothed corner)
the argument is in. A division ``a / b`` moves its denominator away from zero
by ngspice's fudge (``DIVISION_FUDGE``: ``b + f`` for ``b >= 0``, ``b - f``
below) and differentiates as ``(a' b - a b') / (b**2 + f)``, as ngspice's
derivative tree does: at ``0 / 0`` (an expression of node voltages at the
zero initial guess) the value and its derivatives are zero, not undefined.
Where ngspice returns its ``HUGE`` marker (square root or log of a negative
number) the value here is not finite and the evaluation is reported as
failed.

Nothing is evaluated with Python's ``eval``: each evaluation walks the
shared tree once per group (never once per instance), applying numpy
operations to whole arrays.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..netlist.expr import (
    POINT_FUNCTIONS, Binary, Call, Const, Current, Expr, Param, Ternary, Time, Unary, Voltage, pwl_point, table_point,
)

__all__ = ["structure_key", "leaves", "ExpressionGroup", "group_by_structure"]

#: ngspice's PTexp returns EXP_SATURATED beyond this argument (e^227.9559242 = 1e99).
EXP_ARG_MAX = 227.9559242
EXP_SATURATED = 1e99
#: ngspice's PTlog(0).
LOG_OF_ZERO = -1e99
#: ngspice's PTfudge_factor (``gmin * 1e-20`` at the default gmin of 1e-12): what a division adds to a
#: non-negative denominator (subtracts from a negative one), and to the ``b**2`` of its derivative.
DIVISION_FUDGE = 1e-32
#: Relative width of a tie in a comparison ``<``, ``<=``, ``>``, ``>=``: operands
#: closer than this times the magnitude of the terms they were computed from (32 roundings) compare as
#: equal. A memristor's threshold law ``beta y + (alpha - beta)/2 (|y + Vt| - |y - Vt|)`` is exactly 0 for
#: ``|y| < Vt`` but computes as +-4e-4 with ``beta = 2e12``: compared as signed, ``f(y) > 0`` changed at
#: every evaluation (ngspice's ``memristor.sp`` failed at t = 3e-18 s). Each intermediate carries that
#: magnitude (first-order running error analysis): 0 for a number, ``time`` or a circuit quantity (the
#: inputs), ``m_a + m_b + |a +- b|`` for ``+``/``-``, ``m_a |b| + |a| m_b + |a b|`` for ``*``,
#: ``|f'| m + |f|`` for a function, the selected operand's for a choice, 0 for a logical value. Only
#: comparisons of the circuit's state are ties (those the transient holds and locates as events);
#: ``time`` comparisons, whose corners are computed exactly, and ``==``, ``!=``, ``u``, ``sgn`` keep
#: their exact definitions (a tie of ``u`` would be a third value, 0.5, and two events at each crossing).
ROUNDING_TIE = 32.0 * 2.220446049250313e-16


def structure_key(node: Expr) -> tuple:
    """The shape of a tree with constants and circuit references abstracted.

    Two expressions with the same key are evaluated by one :class:`ExpressionGroup`.

    Raises
    ------
    ValueError
        For an unresolved parameter (elaboration replaces every one).
    """
    t = type(node)
    if t is Const:
        return ("c",)
    if t is Time:
        return ("t",)
    if t is Voltage or t is Current:
        return ("x",)
    if t is Unary:
        return ("u", node.op, structure_key(node.operand))
    if t is Binary:
        return ("b", node.op, structure_key(node.left), structure_key(node.right))
    if t is Ternary:
        return ("?", structure_key(node.cond), structure_key(node.then), structure_key(node.other))
    if t is Call:
        return ("f", node.func) + tuple(structure_key(a) for a in node.args)
    if t is Param:
        raise ValueError(f"parameter '{node.name}' was not resolved")
    raise ValueError(f"unknown expression node {node!r}")


def _leaves_and_constants(node: Expr, leaf_out: list, const_out: list) -> None:
    """Circuit references and constants of a tree, in the order the compiler visits them."""
    t = type(node)
    if t is Const:
        const_out.append(node.value)
    elif t is Voltage or t is Current:
        leaf_out.append(node)
    elif t is Unary:
        _leaves_and_constants(node.operand, leaf_out, const_out)
    elif t is Binary:
        _leaves_and_constants(node.left, leaf_out, const_out)
        _leaves_and_constants(node.right, leaf_out, const_out)
    elif t is Ternary:
        for child in (node.cond, node.then, node.other):
            _leaves_and_constants(child, leaf_out, const_out)
    elif t is Call:
        for child in node.args:
            _leaves_and_constants(child, leaf_out, const_out)


def leaves(node: Expr) -> list:
    """The ``Voltage``/``Current`` leaves of a tree in evaluation order (repeats kept)."""
    out: list = []
    _leaves_and_constants(node, out, [])
    return out


def group_by_structure(exprs: list[Expr]) -> list[list[int]]:
    """Indices of ``exprs`` grouped by :func:`structure_key`, in order of first appearance."""
    groups: dict[tuple, list[int]] = {}
    for i, e in enumerate(exprs):
        groups.setdefault(structure_key(e), []).append(i)
    return list(groups.values())


# -- the differentiation rules ----------------------------------------------
# Every rule takes and returns (value, derivative); a derivative is an array
# of shape (L, N) or None when the operand does not depend on any leaf.


def _add(d1, d2, s2=1.0):
    if d1 is None:
        return None if d2 is None else (d2 if s2 == 1.0 else -d2)
    if d2 is None:
        return d1
    return d1 + d2 if s2 == 1.0 else d1 - d2


def _scale(d, factor):
    """``d * factor`` with the structural zeros of ``d`` kept zero (0 * inf = 0, not NaN)."""
    if d is None:
        return None
    out = d * factor
    if not np.isfinite(out).all():
        out = np.where(d == 0.0, 0.0, out)
    return out


def _power(a, da, b, db):
    absa = np.abs(a)
    val = absa ** b
    d = None
    if da is not None:
        d = _scale(da, b * np.where(absa != 0.0, val / np.where(absa != 0.0, absa, 1.0), 0.0) * np.sign(a))
    if db is not None:
        d = _add(d, _scale(db, np.where(absa != 0.0, val * np.log(np.where(absa != 0.0, absa, 1.0)), 0.0)))
    return val, d


def _binary_magnitude(op, a, ma, b, mb, val):
    """The magnitude of the terms of ``a op b`` (see :data:`ROUNDING_TIE`)."""
    if op == "+" or op == "-":
        return ma + mb + np.abs(val)
    if op == "*":
        return ma * np.abs(b) + np.abs(a) * mb + np.abs(val)
    if op == "/":
        den = b + np.where(b >= 0.0, DIVISION_FUDGE, -DIVISION_FUDGE)
        return (ma + np.abs(val) * mb) / np.abs(den) + np.abs(val)
    if op == "**":
        return _power_magnitude(a, ma, b, mb)
    if op == "%":
        return ma + np.abs(np.trunc(a / b)) * mb + np.abs(val)
    return np.zeros_like(np.asarray(val, dtype=float))


def _power_magnitude(a, ma, b, mb):
    """``|d/da| m_a + |d/db| m_b + |a|^b`` of ``|a| ** b``."""
    absa = np.abs(a)
    val = absa ** b
    safe = np.where(absa != 0.0, absa, 1.0)
    fa = np.where(absa != 0.0, b * val / safe, 0.0)
    fb = np.where(absa != 0.0, val * np.log(safe), 0.0)
    return np.abs(fa) * ma + np.abs(fb) * mb + val


def _tie(op, a, ma, b, mb, result):
    """``result`` of a comparison of the circuit's state, operands within their rounding (:data:`ROUNDING_TIE`)
    a tie."""
    if op not in ("<", "<=", ">", ">="):
        return result
    tie = np.abs(a - b) <= ROUNDING_TIE * (ma + mb)
    return np.where(tie, 1.0 if op in ("<=", ">=") else 0.0, result)


def _binary(op, a, da, b, db):
    if op == "+":
        return a + b, _add(da, db)
    if op == "-":
        return a - b, _add(da, db, -1.0)
    if op == "*":
        return a * b, _add(_scale(da, b), _scale(db, a))
    if op == "/":
        q = a / (b + np.where(b >= 0.0, DIVISION_FUDGE, -DIVISION_FUDGE))
        square = b * b + DIVISION_FUDGE
        return q, _add(_scale(da, b / square), _scale(db, -a / square))
    if op == "**":
        return _power(a, da, b, db)
    if op == "%":
        return np.fmod(a, b), _add(da, _scale(db, -np.trunc(a / b)))
    if op == "&&":
        return ((a != 0.0) & (b != 0.0)).astype(float), None
    if op == "||":
        return ((a != 0.0) | (b != 0.0)).astype(float), None
    compare = {"==": np.equal, "!=": np.not_equal, "<": np.less, "<=": np.less_equal, ">": np.greater,
               ">=": np.greater_equal}[op]
    return compare(a, b).astype(float), None


def _select(mask, v1, d1, v2, d2):
    val = np.where(mask, v1, v2)
    if d1 is None and d2 is None:
        return val, None
    zero = np.zeros_like(d1 if d1 is not None else d2)
    return val, np.where(mask, zero if d1 is None else d1, zero if d2 is None else d2)


def _exp(u):
    return np.where(u > EXP_ARG_MAX, EXP_SATURATED, np.exp(np.minimum(u, EXP_ARG_MAX)))


def _ln(u):
    return np.where(u == 0.0, LOG_OF_ZERO, np.log(u))


#: f(u) and f'(u) of the one-argument functions.
_UNARY: dict[str, tuple[Callable, Callable | None]] = {
    "sqrt": (np.sqrt, lambda u: 0.5 / np.sqrt(u)),
    "exp": (_exp, _exp),
    "ln": (_ln, lambda u: 1.0 / u),
    "log10": (lambda u: _ln(u) / math.log(10.0), lambda u: 1.0 / (u * math.log(10.0))),
    "sin": (np.sin, np.cos),
    "cos": (np.cos, lambda u: -np.sin(u)),
    "tan": (np.tan, lambda u: 1.0 / np.cos(u) ** 2),
    "asin": (np.arcsin, lambda u: 1.0 / np.sqrt(1.0 - u * u)),
    "acos": (np.arccos, lambda u: -1.0 / np.sqrt(1.0 - u * u)),
    "atan": (np.arctan, lambda u: 1.0 / (1.0 + u * u)),
    "sinh": (np.sinh, np.cosh),
    "cosh": (np.cosh, np.sinh),
    "tanh": (np.tanh, lambda u: 1.0 - np.tanh(u) ** 2),
    "asinh": (np.arcsinh, lambda u: 1.0 / np.sqrt(u * u + 1.0)),
    "acosh": (np.arccosh, lambda u: 1.0 / np.sqrt(u * u - 1.0)),
    "atanh": (np.arctanh, lambda u: 1.0 / (1.0 - u * u)),
    "abs": (np.abs, np.sign),
    "uramp": (lambda u: np.maximum(u, 0.0), lambda u: (u > 0.0).astype(float)),
    "sgn": (np.sign, None),
    "floor": (np.floor, None),
    "ceil": (np.ceil, None),
    "int": (np.trunc, None),
    "nint": (np.rint, None),
    "u": (lambda u: np.where(u > 0.0, 1.0, np.where(u < 0.0, 0.0, 0.5)), None),
}


def _call(func, args):
    if func in _UNARY:
        (u, du), = args
        f, df = _UNARY[func]
        val = f(u)
        return val, (None if df is None or du is None else _scale(du, df(u)))
    if func == "min" or func == "max":
        (a, da), (b, db) = args
        take_b = (a > b) if func == "min" else (a <= b)
        return _select(take_b, b, db, a, da)
    if func == "pow":
        (a, da), (b, db) = args
        val = np.power(a, b)
        d = _add(_scale(da, b * np.power(a, b - 1.0)),
                 _scale(db, val * np.log(np.where(a > 0.0, a, np.nan))))
        return val, d
    if func == "pwr":
        (a, da), (b, db) = args
        val, d = _power(a, da, b, db)
        sign = np.where(a < 0.0, -1.0, 1.0)
        return sign * val, _scale(d, sign)
    if func == "limit":
        (x, dx), (a, da), (b, db) = args
        lo_is_a = a <= b
        lo, dlo = _select(lo_is_a, a, da, b, db)
        hi, dhi = _select(lo_is_a, b, db, a, da)
        val, d = _select(x < lo, lo, dlo, x, dx)
        return _select(x > hi, hi, dhi, val, d)
    if func in POINT_FUNCTIONS:
        (x, dx), points = args[0], args[1:]
        if any(d is not None for _, d in points):
            raise ValueError(f"the points of {func}() must be constants")
        point = table_point if func == "table" else pwl_point
        table = np.broadcast_arrays(x, *(v for v, _ in points))
        val = np.empty(table[0].shape)
        slope = np.empty(table[0].shape)
        for i in range(val.size):  # a few instances, a few points: the compiled kernel is the fast path
            val.flat[i], slope.flat[i] = point(float(table[0].flat[i]), [float(p.flat[i]) for p in table[1:]])
        return val, _scale(dx, slope)
    raise ValueError(f"function {func}() cannot be evaluated in a behavioural source")


def _call_magnitude(func, args):
    """``_call`` on ``(value, derivative, magnitude)`` operands: its value, derivative and magnitude."""
    if func in _UNARY:
        (u, du, mu), = args
        f, df = _UNARY[func]
        val = f(u)
        if df is None:
            return val, None, np.zeros_like(np.asarray(val, dtype=float))
        return val, (None if du is None else _scale(du, df(u))), np.abs(df(u)) * mu + np.abs(val)
    if func in ("min", "max"):
        (a, da, ma), (b, db, mb) = args
        val, d = _call(func, [(a, da), (b, db)])
        take_b = (a > b) if func == "min" else (a <= b)
        return val, d, np.where(take_b, mb, ma)
    if func == "limit":
        (x, dx, mx), (a, da, ma), (b, db, mb) = args
        val, d = _call(func, [(x, dx), (a, da), (b, db)])
        lo_is_a = a <= b
        lo, hi = np.where(lo_is_a, a, b), np.where(lo_is_a, b, a)
        mlo, mhi = np.where(lo_is_a, ma, mb), np.where(lo_is_a, mb, ma)
        return val, d, np.where(x > hi, mhi, np.where(x < lo, mlo, mx))
    if func == "pow":
        (a, da, ma), (b, db, mb) = args
        val, d = _call(func, [(a, da), (b, db)])
        fa = b * np.power(a, b - 1.0)
        fb = val * np.log(np.where(a > 0.0, a, np.nan))
        return val, d, np.abs(fa) * ma + np.where(np.isfinite(fb), np.abs(fb) * mb, 0.0) + np.abs(val)
    if func == "pwr":
        (a, da, ma), (b, db, mb) = args
        val, d = _call(func, [(a, da), (b, db)])
        return val, d, _power_magnitude(a, ma, b, mb)
    val, d = _call(func, [(v, dv) for v, dv, _ in args])  # table, pwl: the looked-up value
    return val, d, np.abs(val)


def _state_comparisons(tree: Expr) -> set:
    """``id`` of every comparison ``<``, ``<=``, ``>``, ``>=`` in ``tree`` whose operands read a circuit quantity
    (the comparisons the compiled tape marks locked, :mod:`netdae.devices.kernels.tape`)."""
    out: set = set()

    def reads(node) -> bool:
        typ = type(node)
        if typ is Voltage or typ is Current:
            return True
        children = [getattr(node, name) for name in ("operand", "left", "right", "cond", "then", "other")
                    if hasattr(node, name)] + list(getattr(node, "args", ()) or ())
        found = False
        for child in children:
            found = reads(child) or found  # every child visited: comparisons deeper are marked too
        if found and typ is Binary and node.op in ("<", "<=", ">", ">="):
            out.add(id(node))
        return found

    reads(tree)
    return out


class ExpressionGroup:
    """Many expressions of one structure, evaluated together with their derivatives.

    Parameters
    ----------
    exprs : list of Expr
        Trees with the same :func:`structure_key` (one per instance).

    Attributes
    ----------
    n : int
        Number of instances N.
    leaves : list of list
        ``leaves[k][i]``: the k-th circuit reference (``Voltage``/``Current``)
        of instance i.
    constants : ndarray, shape (C, N)

    Raises
    ------
    ValueError
        When the trees differ in structure.

    Notes
    -----
    :meth:`evaluate` walks the shared tree once: its cost is a few numpy
    operations per tree node on arrays of N, whatever N.
    """

    def __init__(self, exprs: list[Expr]):
        if not exprs:
            raise ValueError("an expression group needs at least one expression")
        key = structure_key(exprs[0])
        per_leaf: list[list] = []
        per_const: list[list] = []
        for e in exprs:
            if structure_key(e) != key:
                raise ValueError("expressions of a group must have the same structure")
            lv: list = []
            cv: list = []
            _leaves_and_constants(e, lv, cv)
            per_leaf.append(lv)
            per_const.append(cv)
        self.n = len(exprs)
        self.tree = exprs[0]
        self.leaves = [list(col) for col in zip(*per_leaf)] if per_leaf[0] else []
        self.constants = np.array(per_const, dtype=float).T.reshape(len(per_const[0]), self.n)
        self._state_comparisons = _state_comparisons(self.tree)

    @property
    def n_leaves(self) -> int:
        return len(self.leaves)

    def evaluate(self, leaf_values: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Values and derivatives of every instance.

        Parameters
        ----------
        leaf_values : ndarray, shape (L, N)
            Value of every leaf (voltage or branch current) per instance.
        t : float
            Time.

        Returns
        -------
        value : ndarray, shape (N,)
        derivative : ndarray, shape (L, N)
            d value / d leaf.

        Notes
        -----
        Invalid operations (square root of a negative number ...) give
        non-finite values silently (numpy's warnings are suppressed here);
        the caller reports them.
        """
        n_leaves = self.n_leaves
        state = {"leaf": 0, "const": 0}

        def visit(node):
            typ = type(node)
            if typ is Const:
                k = state["const"]
                state["const"] += 1
                return self.constants[k], None, np.zeros(self.n)
            if typ is Voltage or typ is Current:
                k = state["leaf"]
                state["leaf"] += 1
                d = np.zeros((n_leaves, self.n))
                d[k] = 1.0
                return leaf_values[k], d, np.zeros(self.n)
            if typ is Time:
                return np.full(self.n, float(t)), None, np.zeros(self.n)
            if typ is Unary:
                v, d, m = visit(node.operand)
                if node.op == "-":
                    return -v, _scale(d, -1.0), m
                return (v == 0.0).astype(float), None, np.zeros(self.n)
            if typ is Binary:
                a, da, ma = visit(node.left)
                b, db, mb = visit(node.right)
                v, d = _binary(node.op, a, da, b, db)
                if id(node) in self._state_comparisons:
                    v = _tie(node.op, a, ma, b, mb, v)
                return v, d, _binary_magnitude(node.op, a, ma, b, mb, v)
            if typ is Ternary:
                c, _, _ = visit(node.cond)
                v1, d1, m1 = visit(node.then)
                v2, d2, m2 = visit(node.other)
                v, d = _select(c != 0.0, v1, d1, v2, d2)
                return v, d, np.where(c != 0.0, m1, m2)
            if typ is Call:
                return _call_magnitude(node.func, [visit(a) for a in node.args])
            raise ValueError(f"cannot evaluate {node!r}")

        with np.errstate(all="ignore"):
            value, deriv, _ = visit(self.tree)
        value = np.broadcast_to(np.asarray(value, dtype=float), (self.n,))
        if deriv is None:
            deriv = np.zeros((n_leaves, self.n))
        return value, deriv
