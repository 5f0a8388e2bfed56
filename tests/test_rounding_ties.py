"""Comparisons in behavioural sources decide operands equal within their rounding.

A law that is exactly zero on an interval but computed by cancellation, the memristor threshold
function of Pershin and Di Ventra (``beta y + (alpha - beta)/2 (|y + Vt| - |y - Vt|)``, ngspice's
``examples/memristor/memristor.sp``), evaluates to rounding noise of +-4e-4 there with ``beta = 2e12``.
Compared as signed, ``f(y) > 0`` changed at every evaluation, the source's current jumped between 0
and the noise, and the transient failed the error test at t = 3e-18 s ("error test failed 10 times",
h = 1e-32). Each intermediate of an expression now carries the magnitude of the terms it was computed
from, and a comparison within ``ROUNDING_TIE`` of them is a tie (netdae.devices.autodiff).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
from netdae.devices.autodiff import ROUNDING_TIE, ExpressionGroup
from netdae.netlist.expr import parse_expression

MEMRISTOR = """memristor with threshold (Pershin and Di Ventra), one period of a 3 V sine
Xmem 1 0 memristor
V1 0 1 DC 0 sin(0 3 100meg)
.subckt memristor plus minus PARAMS: Ron=1K Roff=10K Rinit=7.0K alpha=0 beta=2e12 Vt=1.6
Bx 0 x I='((f1(V(plus)-V(minus))> 0) && (V(x) < Roff)) ? {f1(V(plus)-V(minus))}: ((((f1(V(plus)-V(minus)) < 0) && (V(x)>Ron)) ? {f1(V(plus)-V(minus))}: 0)) '
Vx x x1 dc 0
Cx x1 0 1 IC={Rinit}
Rmem plus minus r={V(x)}
.func f1(y)={beta*y+0.5*(alpha-beta)*(abs(y+Vt)-abs(y-Vt))}
.ends
.tran 0.1n 10n uic
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_memristor_state_follows_the_closed_form(engine, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(netdae.load(MEMRISTOR), raise_on_failure=True)
    x = r["v(xmem.x)"]  # the memristance, the capacitor's voltage
    # dx/dt = f1(v) = beta (|v| - Vt) sgn(v) beyond the threshold, 0 inside it: each half period of the
    # sine moves x by beta (2 (3/w) cos(a) - Vt (pi - 2a)/w), a = asin(Vt/3); v = -3 sin(wt) (V1 is
    # reversed), so x falls through the first half and rises back (1,114 V stays above Ron)
    w = 2.0 * math.pi * 1e8
    a = math.asin(1.6 / 3.0)
    dx = 2e12 * (2.0 * (3.0 / w) * math.cos(a) - 1.6 * (math.pi - 2.0 * a) / w)
    assert np.interp(5e-9, r.t, x) == pytest.approx(7000.0 - dx, abs=2e-3 * dx)
    assert x[-1] == pytest.approx(7000.0, abs=2e-3 * dx)
    # inside the threshold the source's current is exactly zero (it was the noise before)
    inside = np.abs(r["v(1)"]) < 1.5
    assert inside.sum() > 20
    np.testing.assert_array_equal(r["i(v.xmem.vx)"][inside], 0.0)


def _evaluate(tree, y):
    """The expression at v(a) = each of ``y`` (every occurrence of v(a) is a leaf of its own)."""
    group = ExpressionGroup([tree])
    return np.array([group.evaluate(np.full((group.n_leaves, 1), v), 0.0)[0][0] for v in y])


def test_a_comparison_of_rounding_noise_is_a_tie():
    tree = parse_expression("2e12*v(a) - 1e12*(abs(v(a) + 1.6) - abs(v(a) - 1.6))", context="behavioural")
    y = np.linspace(-1.5, 1.5, 301)
    values = _evaluate(tree, y)
    assert np.any(values != 0.0)  # the law computes as noise inside its threshold
    assert np.max(np.abs(values)) < 32 * 2.3e-16 * 3.2e12  # within the tie's width
    for op, tie in ((">", 0.0), (">=", 1.0), ("<", 0.0), ("<=", 1.0)):
        cmp = parse_expression(f"(2e12*v(a) - 1e12*(abs(v(a) + 1.6) - abs(v(a) - 1.6))) {op} 0",
                               context="behavioural")
        got = _evaluate(cmp, y)
        np.testing.assert_array_equal(got, tie)
    # beyond the threshold the comparison is decided at once (1e-13 V past it)
    past = parse_expression("(2e12*v(a) - 1e12*(abs(v(a) + 1.6) - abs(v(a) - 1.6))) > 0", context="behavioural")
    assert _evaluate(past, np.array([1.6 + 1e-13]))[0] == 1.0
    assert ROUNDING_TIE == pytest.approx(32 * np.finfo(float).eps)
