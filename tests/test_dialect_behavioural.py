"""E/G ``TABLE``, the B-source ``pwl()`` function and behavioural R, C, L, as ngspice 39 reads them.

Each construct is checked three ways: the netlist runs in ngspice 39 and in netdae and gives the
same values (ngspice run by the test; skipped without it), the values equal a closed form, and a
bad card is a located error naming its cause.

ngspice 39 realises ``E|G ... TABLE {expr} = (x0, y0) ...`` with the XSPICE ``pwl`` code model
(``inpcom.c``: ``input_domain=0.1 fraction=TRUE limit=TRUE``): linear between the points, flat
beyond the ends, every corner rounded by a parabola within a tenth of the shorter adjacent
segment. A B source's ``pwl(x, x0, y0, ...)`` is ngspice's ``PTpwl``: linear, extrapolated
beyond the ends. ``R={expr}``, ``C={expr}``, ``L={expr}`` whose expression uses ``V()``,
``I()`` or ``time`` become behavioural sources (``inp_compat``): ``i = V/R``, ``i = C dV/dt``,
``v = L dI/dt``; ``C n+ n- {expr}`` without ``C=`` is a charge. A ``.func`` whose body reads the
circuit (``V()``, ``I()``, ``time``) is expanded where a behavioural expression calls it, its node and
element names those of the calling card (ngspice 39's macro expansion).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError
from netdae.netlist import load
from netdae.netlist.expr import pwl_point, table_point

TABLE_SWEEP = np.round(np.arange(-1.0, 3.0001, 0.05), 10)


def ngspice_results(text: str, **options):
    """ngspice 39's results of ``text`` (every analysis), with ``options`` overriding its own."""
    from netdae.ngspice import run_ngspice

    return run_ngspice(text, backend="subprocess", options=options or None).results


def netdae_result(text: str, analysis: str):
    return next(r for r in netdae.run(load(text)) if r.analysis == analysis)


# --------------------------------------------------------------------------- TABLE
TABLE_FORMS = """table forms
V1 in 0 0.5
E1 o1 0 TABLE {V(in)} = (0,0) (1,1) (2,1)
E2 o2 0 TABLE {V(in)} = (0,0), (1,1), (2,1)
E3 o3 0 TABLE {V(in)} (0,0) (1,1) (2,1)
E4 o4 0 TABLE {V(in)} = 0,0 1,1 2,1
E5 o5 0 TABLE {V(in)} = (0 0) (1 1) (2 1)
E6 o6 0 TABLE = {V(in)} (0,0) (1,1) (2,1)
E7 o7 0 table 'V(in)' = (0,0) (1,1) (2,1)
E8 o8 0 TABLE {2*V(in)+0.1} = (-1k, -1) (0, 0) (0.5, 2) (1meg, 3)
G1 0 g1 TABLE {V(in)} = (0,0) (1,1m) (2,1m)
R1 g1 0 1k
G2 0 g2 TABLE {V(in)} = (0,0) (1,{a}) (2,b) m=3
R2 g2 0 1
E9 o9 0 TABLE {V(in)} = (0.3, 4)
.param a=2m b=3m
.dc V1 -1 3 0.05
"""
TABLE_SIGNALS = ["v(o1)", "v(o2)", "v(o3)", "v(o4)", "v(o5)", "v(o6)", "v(o7)", "v(o8)", "v(g1)", "v(g2)", "v(o9)"]


def test_table_forms_read_alike():
    res = netdae_result(TABLE_FORMS + ".end\n", "dc")
    for s in TABLE_SIGNALS[1:7]:
        np.testing.assert_array_equal(res.signals[s], res.signals["v(o1)"])


def test_table_equals_the_closed_form():
    """Linear away from the corners, flat outside, the parabola yi + (s_right - s_left) d / 4 at a corner."""
    res = netdae_result(TABLE_FORMS + ".end\n", "dc")
    x = TABLE_SWEEP
    pts = (0, 0, 1, 1, 2, 1)
    want = [table_point(v, pts)[0] for v in x]
    np.testing.assert_allclose(res.signals["v(o1)"], want, rtol=1e-12, atol=1e-15)
    at = {round(v, 6): y for v, y in zip(x, res.signals["v(o1)"])}
    # d = 0.1 at both corners: y(0) = 0 + (1 - 0) 0.1 / 4, y(1) = 1 + (0 - 1) 0.1 / 4, y(0.5) = 0.5, flat beyond
    assert at[0.0] == pytest.approx(0.025, rel=1e-12) and at[1.0] == pytest.approx(0.975, rel=1e-12)
    assert at[0.5] == pytest.approx(0.5, rel=1e-12) and at[-1.0] == 0.0 and at[3.0] == 1.0
    assert at[-0.05] == pytest.approx(0.025 / 4, rel=1e-12)  # the parabola's quarter point: (d/2)^2 / (4 d)
    want2 = [3 * table_point(v, (0, 0, 1, 2e-3, 2, 3e-3))[0] for v in x]
    np.testing.assert_allclose(res.signals["v(g2)"], want2, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(res.signals["v(g1)"], want, rtol=1e-12, atol=1e-15)  # 1 mA x 1k
    np.testing.assert_allclose(res.signals["v(o9)"], 4.0)


def test_table_slope_is_the_newton_derivative_and_the_ac_gain():
    """.ac of a TABLE source is the slope of the table at the operating point (a segment's, or the parabola's)."""
    text = ("table ac\nV1 in 0 dc 0.5 ac 1\nE1 o1 0 TABLE {V(in)} = (0,0) (1,2) (2,1)\n"
            "V2 in2 0 dc 0.98 ac 1\nE2 o2 0 TABLE {V(in2)} = (0,0) (1,2) (2,1)\n.ac lin 3 1 100\n.end\n")
    res = netdae_result(text, "ac")
    assert np.allclose(res.signals["v(o1)"], 2.0, rtol=1e-12)
    slope = table_point(0.98, (0, 0, 1, 2, 2, 1))[1]
    assert -1.0 < slope < 2.0
    assert np.allclose(res.signals["v(o2)"], slope, rtol=1e-12)


def test_table_in_a_transient_runs_in_the_compiled_engine():
    text = ("table tran\nV1 in 0 SIN(1 1.5 1k)\nE1 o1 0 TABLE {V(in)} = (0,0) (1,1) (2,1)\nR1 o1 0 1k\n"
            ".options reltol=1e-6\n.tran 10u 2m\n.end\n")
    res = netdae_result(text, "tran")
    assert res.stats["integrator"]["engine"] == "compiled"
    want = [table_point(v, (0, 0, 1, 1, 2, 1))[0] for v in res.signals["v(in)"]]
    np.testing.assert_allclose(res.signals["v(o1)"], want, atol=1e-6)  # Newton's tolerance on an algebraic output


@pytest.mark.ngspice
def test_table_agrees_with_ngspice():
    text = TABLE_FORMS + ".end\n"
    (ref,) = ngspice_results(text)
    res = netdae_result(text, "dc")
    np.testing.assert_allclose(ref.axis, TABLE_SWEEP, atol=1e-12)
    for s in TABLE_SIGNALS:
        np.testing.assert_allclose(res.signals[s], ref.signals[s], rtol=1e-9, atol=1e-12, err_msg=s)


@pytest.mark.ngspice
def test_table_transient_agrees_with_ngspice():
    text = ("table tran\nV1 in 0 SIN(1 1.5 1k)\nE1 o1 0 TABLE {V(in)} = (0,0) (1,1) (2,1)\nR1 o1 a 1k\n"
            "C1 a 0 100n\n.options reltol=1e-6\n.tran 10u 2m\n.end\n")
    (ref,) = ngspice_results(text, maxstep=2e-6)
    res = netdae_result(text, "tran")
    got = np.ravel(res.dense(ref.axis)["v(a)"])
    assert np.max(np.abs(got - ref.signals["v(a)"])) < 5e-5  # measured: 2.6e-5 (ngspice's own spread 6e-5)


# (card, the text the error points at, the message)
TABLE_ERRORS = [
    ("E1 o 0 TABLE V(in) = (0,0) (1,1)", "V(in)", "expected the controlling expression in braces after TABLE"),
    ("E1 o 0 TABLE {V(in)} = (0,0) (1,1) (2)", "2)", "the table needs (x, y) pairs: '2' has no y value"),
    ("E1 o 0 TABLE {V(in)} = (0,0) (2,1) (1,1)", "1,1)", "the table's x values must increase strictly: 1 follows 2"),
    ("E1 o 0 TABLE {V(in)} = (0,0) (1,1) (1,2)", "1,2)", "the table's x values must increase strictly: 1 follows 1"),
    ("E1 o 0 TABLE {V(in)} =", None, "TABLE without (x, y) pairs"),
    ("E1 o 0 in 0 TABLE = (0,0, 1,1)", "TABLE", "expected 2 nodes before TABLE"),
    ("E1 o 0 TABLE {V(in)} = (0,0) (1,1) m=2", "m=2", "unexpected parameter 'm=' in the table"),
    ("G1 o 0 TABLE {V(in)} = (0,0) (1,1) m=2 3", "3", "unexpected '3' after the table"),
    ("E1 o 0 TABLE {V(in} = (0,0) (1,1)", "V(in}", "V(...): missing ')'"),
    ("E1 o 0 TABLE {V(in)} = (0,0) (x,1) (2,2)", "TABLE", "table: the x values must increase strictly: x2 = 2 "
     "follows x1 = 3"),
]


def column(card: str, at: str | None) -> int:
    """The 1-based column of ``at`` in ``card`` (its end when None); searched from the right."""
    return len(card) + 1 if at is None else card.rindex(at) + 1


@pytest.mark.parametrize("card, at, message", TABLE_ERRORS)
def test_bad_table_cards_are_located_errors(card, at, message):
    with pytest.raises(NetlistError) as info:
        load(f"t\nV1 in 0 1\n{card}\nR1 o 0 1k\n.param x=3\n.op\n.end\n")
    err = info.value
    assert message in err.message, err.message
    assert (err.location.line, err.location.column) == (3, column(card, at)), err.location


def test_table_function_in_an_expression_names_pspice():
    with pytest.raises(NetlistError, match=r"table\(\) \(a table lookup, PSpice's form"):
        load("t\nV1 in 0 1\nE1 o 0 value={table(V(in), 0, 0, 1, 1)}\n.op\n.end\n")


# --------------------------------------------------------------------------- pwl()
PWL_NETLIST = """pwl function
V1 in 0 0
B1 o1 0 V = pwl(V(in), -1, 0.5, 0, 0, 0.5, 2, 2, 2.5)
B2 o2 0 V = 2*pwl(V(in)+0.25, 0, 0, 1, -1)
B3 0 g3 I = pwl(V(in), {a}, 0, 1, 1m)
R3 g3 0 1k
.param a=-1
.dc V1 -2 3 0.25
"""


def test_pwl_function_equals_the_closed_form():
    res = netdae_result(PWL_NETLIST + ".end\n", "dc")
    x = np.asarray(res.axis)
    pts = (-1, 0.5, 0, 0, 0.5, 2, 2, 2.5)
    np.testing.assert_allclose(res.signals["v(o1)"], [pwl_point(v, pts)[0] for v in x], rtol=1e-12, atol=1e-15)
    # extrapolated beyond the ends: the first segment's slope -0.5 below -1, the last's 1/3 above 2
    assert res.signals["v(o1)"][0] == pytest.approx(1.0) and res.signals["v(o1)"][-1] == pytest.approx(2.5 + 1 / 3)
    np.testing.assert_allclose(res.signals["v(o2)"], -2 * (x + 0.25), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(res.signals["v(g3)"], (x + 1) / 2, rtol=1e-12, atol=1e-15)


@pytest.mark.ngspice
def test_pwl_function_agrees_with_ngspice():
    text = PWL_NETLIST.replace("{a}", "-1") + ".end\n"  # ngspice 39 takes only literal points
    (ref,) = ngspice_results(text)
    res = netdae_result(text, "dc")
    for s in ("v(o1)", "v(o2)", "v(g3)"):
        np.testing.assert_allclose(res.signals[s], ref.signals[s], rtol=1e-9, atol=1e-12, err_msg=s)


@pytest.mark.parametrize("expr, message", [
    ("pwl(V(in), 0, 0)", "pwl() takes the input and at least two (x, y) pairs, got 3 argument(s)"),
    ("pwl(V(in), 0, 0, 1)", "pwl() takes the input and at least two (x, y) pairs, got 4 argument(s)"),
    ("pwl(V(in), 1, 0, 0, 1)", "the x values must increase strictly: x1 = 0 follows x0 = 1"),
    ("pwl(V(in), 0, 0, V(in), 1)", "the points of pwl() must be constants"),
])
def test_bad_pwl_calls_are_errors(expr, message):
    with pytest.raises(NetlistError) as info:
        load(f"t\nV1 in 0 1\nB1 o 0 V = {expr}\nR1 o 0 1k\n.op\n.end\n")
    assert message in info.value.message
    assert info.value.location.line == 3


def test_pwl_stays_refused_in_parameters():
    with pytest.raises(NetlistError, match=r"pwl\(\) is only available in behavioural sources"):
        load("t\n.param p={pwl(1, 0, 0, 2, 2)}\nV1 a 0 1\nR1 a 0 1k\n.op\n.end\n")


# --------------------------------------------------------------------------- behavioural R, C, L
def test_behavioural_resistor_operating_point_closed_form():
    """R = 1k (1 + V(a)) from 1 V through 1k: v = (1 + v) / (2 + v), so v^2 + v - 1 = 0."""
    text = "br\nV1 in 0 1\nR1 in a 1k\nR2 a 0 R={1k*(1+V(a))}\n.op\n.end\n"
    c = load(text)
    assert [e.kind for e in c.elements] == ["vsource", "resistor", "bcurrent"]
    res = netdae_result(text, "op")
    assert float(res.signals["v(a)"][-1]) == pytest.approx((math.sqrt(5) - 1) / 2, rel=1e-10)


RC_FORMS = """behavioural rc
V1 in 0 PULSE(0 1 0 1n 1n 1 2)
R1 in a 1k
C1 a 0 C={1u*(1+V(a))}
R2 in b 1k
C2 b 0 {1u*(1+0.5*V(b))} m=2
R3 in c r='1k + 500*V(c)'
C3 c 0 c = '1u'
V4 in4 0 PULSE(0 1 0 1n 1n 1 2)
R4 in4 d 1k
L1 d 0 L={1*(1+1000*I(L1))}
.tran 10u 3m
"""


def test_behavioural_elements_as_elaborated():
    c = load(RC_FORMS + ".end\n")
    kinds = {e.name: e.kind for e in c.elements}
    assert kinds["c1"] == "bcurrent" and kinds["c1#q"] == "bcharge" and kinds["c1#r"] == "resistor"
    assert kinds["c2"] == "bcharge" and kinds["r3"] == "bcurrent" and kinds["c3"] == "capacitor"
    assert kinds["l1"] == "bvoltage" and kinds["l1#q"] == "bcharge"
    assert c.element("c3").value == 1e-6 and "c1#ddt" in c.nodes


def test_behavioural_capacitor_and_inductor_follow_their_closed_forms():
    """RC with C = C0 (1 + v): t = R C0 (-2 ln(1 - v) - v); charge C2: Q = 2u (1 + v/2), C = 1u;
    RL with L = L0 (1 + k i): t = L0/R ((-1 - k/R) ln(1 - R i) - k i) for a 1 V step."""
    res = netdae_result(RC_FORMS + ".end\n", "tran")
    t = np.asarray(res.axis)
    late = t > 2e-5
    v = res.signals["v(a)"][late]
    np.testing.assert_allclose(1e3 * 1e-6 * (-2 * np.log(1 - v) - v), t[late], rtol=2e-3)
    np.testing.assert_allclose(res.signals["v(b)"][late], 1 - np.exp(-t[late] / 1e-3), atol=1e-3)
    i = -res.signals["i(v4)"][late]
    k, r = 1000.0, 1e3
    np.testing.assert_allclose(1 / r * ((-1 - k / r) * np.log(1 - r * i) - k * i), t[late], rtol=2e-3)
    # the derivative node: v(c1#ddt) = dv(a)/dt = (1 - v) / (R C0 (1 + v))
    np.testing.assert_allclose(res.signals["v(c1#ddt)"][late], (1 - v) / (1e-3 * (1 + v)), rtol=5e-3)


@pytest.mark.ngspice
def test_behavioural_rcl_agree_with_ngspice():
    text = RC_FORMS + ".options reltol=1e-6\n.end\n"
    (ref,) = ngspice_results(text, maxstep=2e-6)
    res = netdae_result(text, "tran")
    # ngspice's realisation of the charge form (G, a 1 H inductor, B) rings for a few steps after the 1 ns edge
    after = np.asarray(ref.axis) > 1e-5
    dense = res.dense(ref.axis[after])
    for s in ("v(a)", "v(b)", "v(c)", "v(d)", "i(v4)"):
        got = np.ravel(dense[s])
        span = float(np.ptp(ref.signals[s]))
        assert np.max(np.abs(got - ref.signals[s][after])) < 1e-5 * span, s  # measured: 1.2e-6 of the span


def test_behavioural_capacitor_ac_is_its_capacitance_at_the_operating_point():
    """C = 1u (1 + V(a)) at v(a) = 1 is 2 uF: the RC divider's corner at 1 / (2 pi 1k 2u)."""
    text = "bc ac\nV3 in3 0 dc 1 ac 1\nR3 in3 c 1k\nC1 c 0 C={1u*(1+V(c))}\n.ac dec 5 10 10k\n.end\n"
    res = netdae_result(text, "ac")
    f = np.asarray(res.axis)
    w = 2 * np.pi * f
    np.testing.assert_allclose(res.signals["v(c)"], 1 / (1 + 1j * w * 1e3 * 2e-6), rtol=1e-9)


def test_constant_values_stay_ordinary_elements():
    c = load("t\n.param k=2\nV1 a 0 1\nR1 a b R={1k*k}\nC1 b 0 c={1u*k}\nL1 b 0 l=1m\nR2 a 0 {temper*10}\n.op\n.end\n")
    assert [(e.kind, e.value) for e in c.elements[1:]] == [("resistor", 2000.0), ("capacitor", 2e-6),
                                                          ("inductor", 1e-3), ("resistor", 270.0)]


BEHAVIOURAL_ERRORS = [
    ("C1 a 0 C={V(a)*1u} tc1=1m", "tc1", "unexpected parameter 'tc1': a capacitor whose value depends on V(), I() "
     "or time takes only m="),
    ("C1 a 0 C={V(a)*1u} ic=0", "ic", "unexpected parameter 'ic'"),
    ("L1 a 0 {1m*(1+I(V1))} lmod", "lmod", "unexpected 'lmod'"),
    ("R1 a 0 R={hertz*V(a)}", "hertz", "'hertz' is not supported by netdae"),
    ("C1 a 0 C={V(a)*1u} 2u", "2u", "unexpected '2u'"),
    ("C1 a 0 1u c=2u", "1u", "capacitor value given twice (as c= and '1u')"),
    ("L1 a 0 L={1m*I(V9)}", "{", "I(v9) names no element"),
]


@pytest.mark.parametrize("card, at, message", BEHAVIOURAL_ERRORS)
def test_bad_behavioural_rcl_cards_are_located_errors(card, at, message):
    with pytest.raises(NetlistError) as info:
        load(f"t\nV1 a 0 1\n{card}\nR9 a 0 1k\n.op\n.end\n")
    err = info.value
    assert message in err.message, err.message
    assert (err.location.line, err.location.column) == (3, column(card, at)), err.location


MULTIPLIERS = """m on behavioural elements
V1 in 0 PULSE(0 1 0 1n 1n 1 2)
R1 in a R={2k*(1+V(a))} m=2
C1 a 0 C={1u*(1+V(a))} m=2
R2 in b 1k
L1 b 0 L={1*(1+1000*I(L1))} m=2
R3 in c 1k
R4 c 0 R={1k*(1+V(c))} m=3
.options reltol=1e-6
.tran 10u 3m
.end
"""


@pytest.mark.ngspice
def test_multipliers_agree_with_ngspice():
    """m parallel elements: R/m, m C, L/m (measured: within 1.6e-6 of the span)."""
    (ref,) = ngspice_results(MULTIPLIERS, maxstep=2e-6)
    res = netdae_result(MULTIPLIERS, "tran")
    after = np.asarray(ref.axis) > 1e-5
    dense = res.dense(ref.axis[after])
    for s in ("v(a)", "v(b)", "v(c)"):
        got = np.ravel(dense[s])
        assert np.max(np.abs(got - ref.signals[s][after])) < 1e-5 * float(np.ptp(ref.signals[s])), s
    # R4 = 1k (1 + v) / 3 from 1 V through 1k: 3v = (1 - v)(1 + v), v = (-3 + sqrt(13)) / 2
    assert float(res.signals["v(c)"][-1]) == pytest.approx((math.sqrt(13) - 3) / 2, rel=1e-9)


def test_behavioural_capacitor_keeps_the_index_of_a_capacitor():
    """A C={x} across a voltage source is a CV loop: index 2 (its current needs the input's derivative);
    behind a resistor, index 1."""
    loop = netdae.analyze_index(load("i\nV1 a 0 SIN(0 1 1k)\nC1 a 0 C={1u*(1+V(a))}\n.tran 1u 1m\n.end\n"))
    assert loop.index == 2 and loop.unknowns["i(v1)"] == "index2" and loop.unknowns["v(c1#ddt)"] == "index2"
    rc = netdae.analyze_index(load("i\nV1 in 0 SIN(0 1 1k)\nR1 in a 1k\nC1 a 0 C={1u*(1+V(a))}\n.tran 1u 1m\n"
                                   ".end\n"))
    assert rc.index == 1


# --------------------------------------------------------------------------- LAPLACE (netdae's extension)
LAPLACE = """laplace
.param tau=1m
V1 in 0 dc 0 ac 1 PULSE(0 1 0 1n 1n 1 2)
E1 o1 0 LAPLACE {V(in)} = {1/(1+s*tau)}
E2 o2 0 LAPLACE {V(in)} {1e12/(s**2 + 2*0.3*1e6*s + 1e12)}
G3 0 o3 LAPLACE {V(in)} = {(1 + s/1k)/(1 + s/10k)}
R3 o3 0 1
E4 o4 0 LAPLACE {2*V(in)} = {3}
E5 o5 0 LAPLACE {V(in)} = {1/(s*1m)**2/(1 + 1/(s*1m) + 1/(s*1m)**2)}
.options reltol=1e-6
"""


def _closed_forms(s):
    return {"v(o1)": 1 / (1 + s * 1e-3), "v(o2)": 1e12 / (s**2 + 0.6e6 * s + 1e12),
            "v(o3)": (1 + s / 1e3) / (1 + s / 1e4), "v(o4)": 6 + 0 * s, "v(o5)": 1 / ((s * 1e-3)**2 + s * 1e-3 + 1)}


def test_laplace_is_a_state_space_block():
    c = load(LAPLACE + ".op\n.end\n")
    kinds = {e.name: e.kind for e in c.elements}
    assert kinds["e1"] == "bvoltage" and kinds["g3"] == "bcurrent" and kinds["e2#g1"] == "vccs"
    assert [n for n in c.nodes if n.startswith("e2#")] == ["e2#s1", "e2#s2"]
    assert c.element("e2#c1").value == pytest.approx(1e-6)  # states scaled by the poles' size, 1e6 rad/s
    assert "e4#s1" not in c.nodes  # a constant H has no state
    assert any("LAPLACE is netdae's extension" in d.message for d in c.diagnostics)


def test_laplace_ac_is_the_transfer_function():
    res = netdae_result(LAPLACE + ".ac dec 5 10 10meg\n.end\n", "ac")
    s = 2j * np.pi * np.asarray(res.axis)
    for name, h in _closed_forms(s).items():
        np.testing.assert_allclose(res.signals[name], h, rtol=1e-12, err_msg=name)


def test_laplace_step_responses():
    res = netdae_result(LAPLACE + ".tran 0.1u 5m\n.end\n", "tran")
    t = np.asarray(res.axis)
    late = t > 1e-7  # after the input's 1 ns edge
    t = t[late]
    wn, z = 1e6, 0.3
    wd = wn * math.sqrt(1 - z * z)
    steps = {"v(o1)": 1 - np.exp(-t / 1e-3),
             "v(o2)": 1 - np.exp(-z * wn * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t)),
             "v(o3)": 1 + 9 * np.exp(-t * 1e4), "v(o4)": 6 + 0 * t,
             "v(o5)": 1 - np.exp(-t / 2e-3) * (np.cos(t * math.sqrt(3) / 2e-3) + np.sin(t * math.sqrt(3) / 2e-3)
                                               / math.sqrt(3))}
    for name, want in steps.items():
        # the 1 ns ramp delays the response by 0.5 ns: 5e-4 of the 1e6 rad/s resonance's swing
        np.testing.assert_allclose(res.signals[name][late], want, atol=1e-3, err_msg=name)


def test_laplace_index_and_operating_point():
    """H(0) at DC; the block is an ODE in its states: index 1 (the output source's branch) like an E."""
    res = netdae_result(LAPLACE.replace("dc 0 ac 1", "dc 0.5 ac 1") + ".op\n.end\n", "op")
    for name, h in _closed_forms(0.0).items():
        assert float(res.signals[name][-1]) == pytest.approx(0.5 * h, rel=1e-12), name
    report = netdae.analyze_index(load(LAPLACE + ".tran 1u 1m\n.end\n"))
    assert report.index == 1


@pytest.mark.ngspice
def test_laplace_equals_ngspice_s_xfer():
    """ngspice 39 has no E/G LAPLACE; its XSPICE s_xfer model (an A element, which netdae does not read)
    realises the same H: .ac equal to rounding."""
    from netdae.ngspice import batch

    xfer = ("s_xfer\nV1 in 0 dc 0 ac 1\na2 %v(in) %v(o2) filt2\n"
            ".model filt2 s_xfer(num_coeff=[1e12] den_coeff=[1 0.6e6 1e12] int_ic=[0 0])\n"
            "a3 %v(in) %v(o3) filt3\n.model filt3 s_xfer(num_coeff=[1e-3 1] den_coeff=[1e-4 1] int_ic=[0])\n"
            ".ac dec 5 10 10meg\n.end\n")
    (ref,) = batch.run(xfer, timeout=120).results
    res = netdae_result(LAPLACE + ".ac dec 5 10 10meg\n.end\n", "ac")
    for name in ("v(o2)", "v(o3)"):
        np.testing.assert_allclose(res.signals[name], ref.signals[name], rtol=1e-12, err_msg=name)


LAPLACE_ERRORS = [
    ("E1 o 0 LAPLACE {V(in)} = {s/(1+s)*s}", "LAPLACE", "H(s) is improper: its numerator has degree 2 in s, its "
     "denominator degree 1"),
    ("E1 o 0 LAPLACE {V(in)} = {exp(-s*1m)}", "LAPLACE", "exp((-s) * 0.001) is not a rational function of s"),
    ("E1 o 0 LAPLACE {V(in)} = {1/(1+s*V(in))}", "{1/", "H(s) must be a function of s alone, not of v(in)"),
    ("E1 o 0 LAPLACE V(in) = {1/(1+s)}", "V(in)", "expected the controlling expression and H(s), each in braces"),
    ("E1 o 0 LAPLACE {V(in)} = {0/(1+s)} {1}", "{1}", "expected the controlling expression and H(s)"),
    ("G1 o 0 LAPLACE {V(in)} = {1/(s-s)}", "LAPLACE", "the denominator of H(s) is zero"),
]


@pytest.mark.parametrize("card, at, message", LAPLACE_ERRORS)
def test_bad_laplace_cards_are_located_errors(card, at, message):
    with pytest.raises(NetlistError) as info:
        load(f"t\nV1 in 0 1\n{card}\nR1 o 0 1k\n.op\n.end\n")
    err = info.value
    assert message in err.message, err.message
    assert (err.location.line, err.location.column) == (3, column(card, at)), err.location


def test_realisation_elements_are_not_counted_as_cards():
    c = load("t\nV1 in 0 1\nR1 in a 1k\nC1 a 0 C={1u*(1+V(a))}\nE1 o 0 LAPLACE {V(a)} = {1/(1+s)**2}\n.op\n.end\n")
    assert c.count_by_letter() == {"c": 1, "e": 1, "r": 1, "v": 1}


# --------------------------------------------------------------------------- .func reading the circuit
# ngspice's regression test func-1: a .func body may read node voltages and branch currents; a call
# in a B source expands it in place, the arguments replacing the parameters of the body but never a
# name inside V() or I(): with a node p and an argument p, 'v(p)+p' is node p's voltage plus the argument
CIRCUIT_FUNC = """circuit .func
vnp p 0 102
vnn n 0 101
vp 1 0 105
rp 1 0 1
.func bar2(p) 'v(p)+p'
.func baz1(n,vp) 'n+i(vp)+vp'
.func baz2(p,n) {v(p)+p+v(n)}
.func twice(x) = '2*bar2(x)'
.func gain(x) 'v(in)*x + v(mid)'
B1 o1 0 V = bar2(17.0)
B2 o2 0 V = baz1(17.0, 10000)
B3 o3 0 V = baz2(1000.0, 1e20)
B4 o4 0 V = twice(1) + 1
E5 o5 0 value = {baz2(1, 2)}
G6 0 o6 cur = {bar2(0)/1k}
R6 o6 0 1k
X1 in o7 stage
V2 in 0 3
.subckt stage in out
R1 in mid 1k
R2 mid 0 2k
B1 out 0 V = gain(10)
.ends
R7 mid 0 1k
V3 mid2 0 9
"""
CIRCUIT_FUNC_SIGNALS = ["v(o1)", "v(o2)", "v(o3)", "v(o4)", "v(o5)", "v(o6)", "v(o7)"]


def test_circuit_functions_equal_the_closed_form():
    res = netdae_result(CIRCUIT_FUNC + ".op\n.end\n", "op")
    got = {s: float(res.signals[s][-1]) for s in CIRCUIT_FUNC_SIGNALS}
    # i(vp) = -105 A (105 V across 1 ohm, the current into vp's + terminal); x1's mid is 2 V (3 V over 1k, 2k),
    # not the top-level node mid the stage never sees
    want = {"v(o1)": 119.0, "v(o2)": 17 - 105 + 10000, "v(o3)": 102 + 1000 + 101, "v(o4)": 2 * 103 + 1,
            "v(o5)": 102 + 1 + 101, "v(o6)": 102.0, "v(o7)": 3 * 10 + 2}
    for s, v in want.items():
        assert got[s] == pytest.approx(v, rel=1e-12), s


@pytest.mark.ngspice
def test_circuit_functions_agree_with_ngspice():
    text = CIRCUIT_FUNC + ".op\n.end\n"
    ref = next(r for r in ngspice_results(text) if r.analysis == "op")
    res = netdae_result(text, "op")
    for s in CIRCUIT_FUNC_SIGNALS:
        assert float(res.signals[s][-1]) == pytest.approx(float(ref.signals[s][-1]), rel=1e-9), s


@pytest.mark.ngspice
def test_a_circuit_function_of_time_agrees_with_ngspice():
    text = ("time .func\nV1 p 0 SIN(0 1 1k)\nR1 p 0 1k\n.func ramp(x) 'v(p)*time*x'\nB1 o 0 V = ramp(1k)\n"
            "R2 o 0 1k\n.tran 10u 2m\n.end\n")
    ref = next(r for r in ngspice_results(text, reltol=1e-6) if r.analysis == "tran")
    res = netdae_result(text, "tran")
    t = np.asarray(ref.axis)
    got = np.ravel(res.dense(t)["v(o)"])
    # closed form: sin(2 pi 1k t) t 1k, of amplitude up to 2 over the run
    np.testing.assert_allclose(got, np.sin(2e3 * np.pi * t) * t * 1e3, rtol=0, atol=2e-3 * 2)
    np.testing.assert_allclose(got, ref.signals["v(o)"], rtol=0, atol=2e-3 * 2)


@pytest.mark.parametrize("card, line, what", [
    (".param y = bar2(1)\nV2 q 0 {y}\n", 3, "parameter 'y'"),
    ("V2 q 0 {bar2(1)}\n", 3, "DC value"),
])
@pytest.mark.ngspice
def test_a_circuit_function_where_a_number_is_needed_is_refused_as_ngspice_refuses_it(card, line, what):
    from netdae.errors import NgspiceError

    text = f"t\n.func bar2(p) 'v(p)+p'\n{card}R1 q 0 1k\nV1 p 0 2\n.op\n.end\n"
    with pytest.raises(NgspiceError):  # ngspice 39: "Undefined parameter [v]", the expression cannot be evaluated
        ngspice_results(text)
    pattern = (rf"cannot evaluate {re.escape(what)}: function bar2\(\) reads the circuit \(v\(p\), \.func at "
               r"<string>:2\): ngspice 39 expands it only into behavioural expressions")
    with pytest.raises(NetlistError, match=pattern) as info:
        load(text)
    assert info.value.location.line == line


@pytest.mark.ngspice
def test_an_rcl_value_calling_a_circuit_function_is_behavioural_as_in_ngspice():
    # ngspice expands the call before it looks for V(), I() or time in the value: R = 2 (v(p) + 1) = 6 ohm
    text = ("t\n.func bar2(p) 'v(p)+p'\n.func via(x) 'bar2(x)'\nR2 q 0 {2*bar2(1)}\nV2 q 0 1\n"
            "R3 r 0 R={via(2)}\nV3 r 0 1\nV1 p 0 2\n.op\n.end\n")
    ref = next(r for r in ngspice_results(text) if r.analysis == "op")
    res = netdae_result(text, "op")
    for s, want in (("i(v2)", -1 / 6), ("i(v3)", -1 / 4)):
        assert float(res.signals[s][-1]) == pytest.approx(want, rel=1e-12), s
        assert float(res.signals[s][-1]) == pytest.approx(float(ref.signals[s][-1]), rel=1e-9), s


def test_ddt_in_a_function_body_is_refused_at_the_function():
    with pytest.raises(NetlistError, match=r"ddt\(\) in a \.func body is not supported by netdae") as info:
        load("t\n.func d(x) 'ddt(v(a))*x'\nV1 a 0 1\nB1 o 0 V = d(2)\nR1 o 0 1\n.op\n.end\n")
    assert info.value.location.line == 2
