"""E/G ``LAPLACE``: a rational transfer function realised as a linear state-space block.

``Ename n+ n- LAPLACE {expr} = {H(s)}`` (G: a current) is netdae's extension, in PSpice's
syntax: ngspice 39 reads no ``LAPLACE`` form of E or G (its XSPICE ``s_xfer`` model is an
``A`` element). The output is ``H(s)`` applied to the controlling expression ``u`` (any
behavioural expression). ``H`` must be a proper rational function of ``s`` (numbers,
parameters, ``+ - * /`` and integer powers): numerator degree m <= denominator degree n.

Realisation (controllable canonical form, time-scaled)
------------------------------------------------------
With ``s = w p`` (``w`` the scale of the poles, :func:`time_scale`) and the denominator made
monic, ``H = (sum b_k p^k) / (p^n + sum_{k<n} a_k p^k)``; the states ``z_1 .. z_n`` are
internal nodes ``<name>#s1 ..`` obeying, in the element kinds netdae already has,

* a capacitor of ``1/w`` farad from each ``z_i`` to ground (so ``z_i' / w`` is its current),
* ``z_i' / w = z_(i+1)`` (i < n): a VCCS ``<name>#g<i>`` of gain 1,
* ``z_n' / w = u - sum a_k z_(k+1)``: a behavioural current ``<name>#g<n>``,
* the output ``y = sum (b_k - a_k b_n) z_(k+1) + b_n u``: the element itself, a behavioural
  voltage (E, branch current ``i(<name>)``) or current (G) source.

Every equation is linear in the states, so the pencil, the index analysis and ``.ac``
(``H(j omega)`` exactly) see the transfer function as it is; the scaling keeps the states
of the order of ``u`` whatever the frequencies. A constant ``H`` has no state.

Examples
--------
>>> from netdae.netlist.expr import parse_expression, transform, Param, Time
>>> tree = transform(parse_expression("2/(1 + s/1k)"), lambda n: Time() if n == Param("s") else None)
>>> num, den = rational(tree)
>>> num.tolist(), den.tolist()
([2000.0], [1000.0, 1.0])
"""

from __future__ import annotations

import math

import numpy as np

from ..circuit import Element
from ..kinds import KINDS
from . import expr as ex

__all__ = ["LAPLACE_KINDS", "rational", "time_scale", "realise", "LaplaceError"]

#: The element kinds this module realises (``ElementKind.realised_by``): E/G LAPLACE.
LAPLACE_KINDS = frozenset(k for k, spec in KINDS.items() if spec.realised_by == __name__)


class LaplaceError(ValueError):
    """``H(s)`` is not a proper rational function of ``s`` (the message says why)."""


def _trim(p: np.ndarray) -> np.ndarray:
    nz = np.flatnonzero(p)
    return p[: nz[-1] + 1] if nz.size else np.zeros(1)


def rational(tree: ex.Expr) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator (ascending powers of ``s``, not normalised) of an elaborated ``H(s)``.

    ``s`` is written as :class:`netdae.netlist.expr.Time` in the tree (the parser's marker);
    every parameter has been replaced by its value.

    Raises
    ------
    LaplaceError
        A function call, a comparison, a non-integer power of an expression in ``s``, or a
        circuit quantity.
    """
    t = type(tree)
    if t is ex.Const:
        return np.array([float(tree.value)]), np.ones(1)
    if t is ex.Time:
        return np.array([0.0, 1.0]), np.ones(1)
    if t is ex.Unary and tree.op == "-":
        n, d = rational(tree.operand)
        return -n, d
    if t is ex.Binary and tree.op in "+-*/":
        n1, d1 = rational(tree.left)
        n2, d2 = rational(tree.right)
        if tree.op == "*":
            return np.polymul(n1[::-1], n2[::-1])[::-1], np.polymul(d1[::-1], d2[::-1])[::-1]
        if tree.op == "/":
            if not _trim(n2).any():
                raise LaplaceError("the denominator of H(s) is zero (a division by zero)")
            return np.polymul(n1[::-1], d2[::-1])[::-1], np.polymul(d1[::-1], n2[::-1])[::-1]
        a = np.polymul(n1[::-1], d2[::-1])
        b = np.polymul(n2[::-1], d1[::-1])
        n = np.polyadd(a, b if tree.op == "+" else -b)[::-1]
        return n, np.polymul(d1[::-1], d2[::-1])[::-1]
    if t is ex.Binary and tree.op == "**" and type(tree.right) is ex.Const:
        k = tree.right.value
        if k == int(k) and abs(k) <= 64:
            n, d = rational(tree.left)
            k = int(k)
            if k < 0:
                n, d, k = d, n, -k
            pn, pd = np.ones(1), np.ones(1)
            for _ in range(k):
                pn, pd = np.polymul(pn, n[::-1]), np.polymul(pd, d[::-1])
            return np.asarray(pn)[::-1], np.asarray(pd)[::-1]
    raise LaplaceError(f"{ex.to_text(tree).replace('time', 's')} is not a rational function of s "
                       "(numbers, parameters, s, + - * / and integer powers)")


def time_scale(den: np.ndarray) -> float:
    """The scale ``w`` of the poles of a denominator (ascending coefficients, degree n >= 1).

    The largest ``|d_k / d_n| ** (1 / (n - k))``: the size of the largest root within a factor
    of two (Fujiwara's bound), 1 when all lower coefficients are zero (``1/s^n``).
    """
    n = den.size - 1
    ratios = [abs(den[k] / den[n]) ** (1.0 / (n - k)) for k in range(n) if den[k] != 0.0]
    w = max(ratios, default=1.0)
    return w if math.isfinite(w) and w > 0.0 else 1.0


def realise(el: Element, node_prefix: str) -> list[Element]:
    """The elements realising a ``laplace`` element (its ``expr`` is ``Call("laplace", (u, H))``).

    Parameters
    ----------
    el : Element
        Kind ``"laplace"``; its name's letter says E (voltage) or G (current).
    node_prefix : str
        Prefix of internal node names (``""`` at the top level, ``"x1."`` inside ``x1``).

    Returns
    -------
    list of Element
        The output source first (named as the card), then per state its capacitor, VCCS or
        behavioural current.

    Raises
    ------
    LaplaceError
        ``H`` is not a rational function of ``s``, is improper (its numerator's degree exceeds
        its denominator's) or has a zero denominator.
    """
    control, h = el.expr.args
    num, den = (_trim(p) for p in rational(h))
    if not den.any():
        raise LaplaceError("the denominator of H(s) is zero")
    m, n = (num.size - 1 if num.any() else 0), den.size - 1
    while num[0] == 0.0 and den[0] == 0.0 and num.size > 1:  # a common factor s (1/s written over 1/s)
        num, den = num[1:], den[1:]
        m, n = m - 1, n - 1
    if m > n:
        raise LaplaceError(f"H(s) is improper: its numerator has degree {m} in s, its denominator degree {n} "
                           "(a LAPLACE transfer function must be proper: numerator degree <= denominator degree)")
    out_kind = "bvoltage" if el.name.split(".")[-1][0] == "e" else "bcurrent"
    common = dict(location=el.location, instance_path=el.instance_path)
    if n == 0:
        return [Element(el.name, out_kind, el.nodes, expr=_times(num[0] / den[0], control) or ex.Const(0.0),
                        **common)]
    w = time_scale(den)
    scale = w ** np.arange(n + 1) / (den[n] * w**n)
    a = den * scale
    b = np.zeros(n + 1)
    b[: num.size] = num * scale[: num.size]
    states = [f"{node_prefix}{el.name.split('.')[-1]}#s{i + 1}" for i in range(n)]

    def v(i):
        return ex.Voltage(states[i], None)

    out = _times(b[n], control)
    for k in range(n):
        out = _plus(out, _times(b[k] - a[k] * b[n], v(k)))
    elements = [Element(el.name, out_kind, el.nodes, expr=out or ex.Const(0.0), **common)]
    for i in range(n):
        elements.append(Element(f"{el.name}#c{i + 1}", "capacitor", (states[i], "0"), value=1.0 / w, **common))
        if i < n - 1:
            elements.append(Element(f"{el.name}#g{i + 1}", "vccs", ("0", states[i], states[i + 1], "0"), value=1.0,
                                    **common))
    last = control
    for k in range(n):
        last = _plus(last, _times(-a[k], v(k)))
    elements.append(Element(f"{el.name}#g{n}", "bcurrent", ("0", states[n - 1]), expr=last, **common))
    return elements


def _times(c: float, node: ex.Expr) -> ex.Expr | None:
    if c == 0.0:
        return None
    return node if c == 1.0 else ex.Binary("*", ex.Const(float(c)), node)


def _plus(a: ex.Expr | None, b: ex.Expr | None) -> ex.Expr | None:
    if a is None:
        return b if b is not None else None
    return a if b is None else ex.Binary("+", a, b)
