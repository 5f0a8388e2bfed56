"""Behavioural sources: expression derivatives, grouping, signs and failure reporting."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from netdae.analyses.op import operating_point
from netdae.devices.autodiff import ExpressionGroup, group_by_structure, leaves
from netdae.errors import CircuitError
from netdae.mna import assemble
from netdae.netlist import load
from netdae.netlist.expr import parse_expression

from test_devices_diode import assert_jacobians_match

TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}


def expr(text: str):
    return parse_expression(text, context="behavioural")


def op(text: str) -> dict[str, float]:
    r = operating_point(load(text), **TIGHT)
    return {k: float(v[0]) for k, v in r.signals.items()}


SMOOTH = [
    "2*V(a) - 3*V(b) + 1",
    "V(a)*V(b)/(1 + V(a)*V(a))",
    "V(a)**3 + V(b)**2.5",
    "abs(V(a))**V(b)",
    "pwr(V(a), 3) - pwr(V(b), 0.5)",
    "exp(V(a)) + ln(V(b)) + log10(V(b))",
    "sqrt(V(b)) + sin(V(a)) * cos(V(b)) + tan(0.3*V(a))",
    "asin(0.5*V(b)) + acos(0.4*V(a)) + atan(V(a))",
    "sinh(V(a)) + cosh(V(b)) + tanh(V(a,b))",
    "asinh(V(a)) + acosh(1 + V(b)) + atanh(0.5*V(b))",
    "min(V(a), V(b)) + max(V(a), 2*V(b))",
    "V(a) > 0.5 ? V(a)*V(b) : -V(b)",
    "if(V(b) < 1, exp(V(b)), 1/V(a))",
    "uramp(V(a) - 0.2) + limit(V(b), 0, 0.7) + u(V(a))*V(b)",
    "I(vx)*V(a) + time*V(b)",
]


@pytest.mark.parametrize("text", SMOOTH + ["V(a) % 0.3 + V(b)"])
def test_forward_mode_derivatives_match_finite_differences(text):
    rng = np.random.default_rng(7)
    n = 50
    group = ExpressionGroup([expr(text)] * n)
    values = {"V(a)": rng.uniform(0.25, 0.95, n), "V(b)": rng.uniform(0.3, 0.9, n), "I(vx)": rng.uniform(-1, 1, n)}
    # leaf values: V(a, b) is a voltage difference, computed from a and b
    refs = leaves(expr(text))
    leaf_values = []
    for ref in refs:
        if type(ref).__name__ == "Current":
            leaf_values.append(values["I(vx)"])
        elif ref.neg is None:
            leaf_values.append(values[f"V({ref.pos})"])
        else:
            leaf_values.append(values["V(a)"] - values["V(b)"])
    lv = np.array(leaf_values)
    value, deriv = group.evaluate(lv, 0.25)
    h = 1e-7
    for k in range(lv.shape[0]):
        up, dn = lv.copy(), lv.copy()
        up[k] += h
        dn[k] -= h
        fd = (group.evaluate(up, 0.25)[0] - group.evaluate(dn, 0.25)[0]) / (2 * h)
        np.testing.assert_allclose(deriv[k], fd, rtol=1e-6, atol=1e-7)


def test_values_follow_ngspice_semantics():
    g = ExpressionGroup([expr("(-2)**2 + pwr(-2, 2) + u(V(a)) + exp(1000*V(a)) * 0 + ln(V(a)) * 0")])
    value, _ = g.evaluate(np.array([[0.0]] * 3), 0.0)
    # |-2|^2 = 4, pwr(-2, 2) = -4, u(0) = 0.5, exp saturates at 1e99 (finite), ln(0) = -1e99
    assert value[0] == pytest.approx(0.5)
    big, _ = ExpressionGroup([expr("exp(V(a))")]).evaluate(np.array([[500.0]]), 0.0)
    assert big[0] == pytest.approx(1e99, rel=1e-9)


def test_grouping_by_structure_and_vectorised_agreement():
    texts = [f"{k}*V(a)*V(b) + {k / 2}" for k in range(1, 40)] + ["V(a) + 1", "V(b) + 7"]
    groups = group_by_structure([expr(t) for t in texts])
    assert sorted(len(g) for g in groups) == [2, 39]
    big = ExpressionGroup([expr(t) for t in texts[:39]])
    lv = np.vstack([np.linspace(0, 1, 39), np.linspace(1, 2, 39)])
    value, deriv = big.evaluate(lv, 0.0)
    for i, t in enumerate(texts[:39]):
        v1, d1 = ExpressionGroup([expr(t)]).evaluate(lv[:, i:i + 1], 0.0)
        assert value[i] == v1[0]
        np.testing.assert_array_equal(deriv[:, i], d1[:, 0])


def test_current_source_sign_and_voltage_source_branch():
    # I flows from n+ through the source to n-: drawn out of node n
    x = op("t\nB1 n 0 I={1m}\nR1 n 0 1k\n.end\n")
    assert x["v(n)"] == pytest.approx(-1.0, rel=1e-12)
    # V source: v(n) = 2 V(a) + 1 and i(b2) flows from n+ through the source: the source delivers 5 mA
    x = op("t\nV1 a 0 2\nB2 n 0 V={2*V(a) + 1}\nR2 n 0 1k\n.end\n")
    assert x["v(n)"] == pytest.approx(5.0, rel=1e-12)
    assert x["i(b2)"] == pytest.approx(-5e-3, rel=1e-12)


def test_current_reference_and_time():
    text = "t\nV1 a 0 1\nVX a b 0\nR1 b 0 500\nB1 c 0 V={1k*I(vx)*sin(time)}\nR2 c 0 1k\n.end\n"
    system = assemble(circuit := load(text))
    x = np.array([float(operating_point(circuit)[n][0]) for n in system.names])
    ev = system.evaluate(x, 0.3)
    row = system.names.index("i(b1)")
    # branch equation: v(c) - 1k * i(vx) * sin(t)
    assert ev.phi[row] == pytest.approx(x[system.names.index("v(c)")] - 1e3 * 2e-3 * math.sin(0.3), rel=1e-12)


def test_jacobian_of_a_circuit_with_both_kinds():
    text = ("t\nV1 a 0 1.2\nR1 a b 1k\nB1 b 0 I={1m*tanh(2*V(b)) + 0.1m*V(a,b)**2}\n"
            "VS c d 0\nR2 d 0 2k\nB2 c 0 V={exp(V(b)) + 100*I(vs)*V(b)}\n"
            "B3 e 0 V={V(c)*V(c)/(1+V(b))}\nR3 e 0 1k\nG1 0 f value={V(e)*1m}\nR4 f 0 1k\n.end\n")
    system = assemble(circuit := load(text))
    sol = operating_point(circuit)
    x = np.array([float(sol[n][0]) for n in system.names]) + 1e-2 * np.sin(np.arange(system.n))
    assert_jacobians_match(system, x, rtol=1e-6)


def test_identical_structures_are_one_group_in_the_family():
    cards = "\n".join(f"B{k} n{k} 0 I={{{k}m*V(n{k})**3 - 1m}}\nR{k} n{k} 0 1k" for k in range(1, 31))
    system = assemble(load(f"t\n{cards}\n.end\n"))
    (family,) = system.families
    assert len(family.groups) == 1 and len(family.groups[0].elements) == 30


def test_current_of_an_element_without_branch_is_an_error():
    # the reader rejects I(r1) in a netlist; a circuit built otherwise is checked by the family
    circuit = load("t\nV1 a 0 1\nR1 a 0 1k\nB1 b 0 V={I(v1)}\nR2 b 0 1k\n.end\n")
    circuit.element("b1").expr = expr("I(r1)")
    with pytest.raises(CircuitError, match=r"I\(r1\)"):
        assemble(circuit)


def test_non_finite_value_fails_the_evaluation_without_warnings():
    system = assemble(load("t\nV1 a 0 -1\nB1 b 0 V={sqrt(V(a))}\nR1 b 0 1k\n.end\n"))
    x = np.zeros(system.n)
    x[system.names.index("v(a)")] = -1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ev = system.evaluate(x, 0.0)
    assert not ev.ok


def test_infinite_slope_at_a_finite_value_enters_as_zero():
    # sqrt(V(a)) at V(a) = 0: value 0, slope infinite -> 0 in the Jacobian, evaluation ok
    system = assemble(load("t\nV1 a 0 0\nB1 b 0 V={sqrt(V(a)) + V(a)}\nR1 b 0 1k\n.end\n"))
    ev = system.evaluate(np.zeros(system.n), 0.0)
    assert ev.ok
    H = system.pattern.matrix(ev.dphi).toarray()
    assert H[system.names.index("i(b1)"), system.names.index("v(a)")] == -1.0
