"""MNA assembly and the DC operating point against hand-written equations and closed forms."""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.circuit import Element
from netdae.errors import CircuitError
from netdae.mna import assemble

from helpers import circuit, mk


def op(*elements):
    r = operating_point(circuit(*elements))
    return {k: float(v[0]) for k, v in r.signals.items()}


def test_divider_and_source_current_sign():
    x = op(mk("v1", "vsource", ("a", "0"), 12.0), mk("r1", "resistor", ("a", "b"), 2e3),
           mk("r2", "resistor", ("b", "0"), 1e3))
    assert x["v(b)"] == pytest.approx(4.0, rel=1e-12)
    # i(v1) flows from + through the source to -: the source delivers 4 mA, so i(v1) = -4 mA
    assert x["i(v1)"] == pytest.approx(-4e-3, rel=1e-12)


def test_unbalanced_wheatstone_bridge_closed_form():
    # V across the bridge, R5 between the mid nodes; solve the 2-node system by hand (Cramer)
    V, R1, R2, R3, R4, R5 = 10.0, 1e3, 2e3, 3e3, 4e3, 5e3
    x = op(mk("v1", "vsource", ("t", "0"), V), mk("r1", "resistor", ("t", "a"), R1),
           mk("r2", "resistor", ("a", "0"), R2), mk("r3", "resistor", ("t", "b"), R3),
           mk("r4", "resistor", ("b", "0"), R4), mk("r5", "resistor", ("a", "b"), R5))
    g1, g2, g3, g4, g5 = 1 / R1, 1 / R2, 1 / R3, 1 / R4, 1 / R5
    a11, a12, a22 = g1 + g2 + g5, -g5, g3 + g4 + g5
    b1, b2 = g1 * V, g3 * V
    det = a11 * a22 - a12 * a12
    va, vb = (b1 * a22 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det
    assert x["v(a)"] == pytest.approx(va, rel=1e-12)
    assert x["v(b)"] == pytest.approx(vb, rel=1e-12)


def test_current_source_direction():
    # I1 a 0 1m: 1 mA from a through the source to ground, drawn out of node a
    x = op(mk("i1", "isource", ("a", "0"), 1e-3), mk("r1", "resistor", ("a", "0"), 1e3))
    assert x["v(a)"] == pytest.approx(-1.0, rel=1e-12)


def test_vcvs_vccs_cccs_ccvs():
    x = op(
        mk("v1", "vsource", ("in", "0"), 0.5),
        mk("r0", "resistor", ("in", "0"), 1e3),
        mk("e1", "vcvs", ("e", "0", "in", "0"), 4.0),
        mk("re", "resistor", ("e", "0"), 1e3),
        mk("g1", "vccs", ("0", "g", "in", "0"), 2e-3),  # 1 mA into node g
        mk("rg", "resistor", ("g", "0"), 2e3),
        mk("vs", "vsource", ("s", "0"), 0.0),  # sense: current through rs
        mk("v2", "vsource", ("p", "0"), 3.0),
        mk("rs", "resistor", ("p", "s"), 1e3),  # 3 mA from p to s, i(vs) = +3 mA
        mk("f1", "cccs", ("0", "f"), 2.0, controls=("vs",)),  # 6 mA into f
        mk("rf", "resistor", ("f", "0"), 1e3),
        mk("h1", "ccvs", ("h", "0"), 500.0, controls=("vs",)),
        mk("rh", "resistor", ("h", "0"), 1e3),
    )
    assert x["v(e)"] == pytest.approx(2.0, rel=1e-12)
    assert x["v(g)"] == pytest.approx(2.0, rel=1e-12)
    assert x["i(vs)"] == pytest.approx(3e-3, rel=1e-12)
    assert x["v(f)"] == pytest.approx(6.0, rel=1e-12)
    assert x["v(h)"] == pytest.approx(1.5, rel=1e-12)


@pytest.mark.parametrize("rin,rf", [(1e3, 10e3), (2.2e3, 4.7e3)])
def test_ideal_opamp_inverting_and_noninverting(rin, rf):
    vin = 0.3
    inv = op(mk("v1", "vsource", ("in", "0"), vin), mk("r1", "resistor", ("in", "m"), rin),
             mk("r2", "resistor", ("m", "out"), rf), mk("e1", "opamp", ("out", "0", "0", "m")))
    assert inv["v(out)"] == pytest.approx(-rf / rin * vin, rel=1e-12)
    assert inv["v(m)"] == pytest.approx(0.0, abs=1e-15)
    non = op(mk("v1", "vsource", ("in", "0"), vin), mk("rg", "resistor", ("m", "0"), rin),
             mk("r2", "resistor", ("m", "out"), rf), mk("e1", "opamp", ("out", "0", "in", "m")))
    assert non["v(out)"] == pytest.approx((1 + rf / rin) * vin, rel=1e-12)


def test_coupled_inductors_are_shorts_in_dc():
    x = op(mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "b"), 100.0),
           mk("l1", "inductor", ("b", "0"), 1e-3), mk("r2", "resistor", ("c", "0"), 50.0),
           mk("l2", "inductor", ("c", "0"), 4e-3),
           Element("k1", "coupling", (), 0.5, controls=("l1", "l2")))
    assert x["i(l1)"] == pytest.approx(0.01, rel=1e-12)
    assert x["i(l2)"] == pytest.approx(0.0, abs=1e-15)
    assert x["v(b)"] == pytest.approx(0.0, abs=1e-15)


def test_coupling_matrix_entries_and_non_positive_definite_error():
    els = [mk("v1", "vsource", ("a", "0"), 1.0), mk("l1", "inductor", ("a", "0"), 1e-3),
           mk("l2", "inductor", ("b", "0"), 4e-3), mk("r", "resistor", ("b", "0"), 1.0)]
    sysm = assemble(circuit(*els, Element("k1", "coupling", (), 0.5, controls=("l1", "l2"))))
    i1, i2 = sysm.index_of("i(l1)"), sysm.index_of("i(l2)")
    E = sysm.E.toarray()
    assert E[i1, i1] == pytest.approx(1e-3)
    assert E[i2, i2] == pytest.approx(4e-3)
    assert E[i1, i2] == pytest.approx(0.5 * np.sqrt(4e-6)) == E[i2, i1]
    with pytest.raises(CircuitError) as exc:
        assemble(circuit(*els, Element("k1", "coupling", (), 1.2, controls=("l1", "l2"))))
    assert "l1" in str(exc.value) and "l2" in str(exc.value)
    assert "positive definite" in str(exc.value)


@pytest.mark.parametrize("k", [1.0, -1.0])
def test_a_perfect_coupling_is_an_ideal_transformer(k):
    """|k| = 1 (ngspice 39 takes it): the inductance matrix is singular, one combination of the
    currents is algebraic, and the secondary's voltage is the primary's times k sqrt(L2/L1) at every
    instant (closed form); an indefinite matrix stays refused."""
    l1, l2, rl = 10e-3, 2.5e-3, 100.0
    text = (f"ideal transformer\nV1 in 0 SIN(0 10 1k)\nR1 in a 10\nL1 a 0 {l1:g}\nL2 b 0 {l2:g}\n"
            f"K1 L1 L2 {k:g}\nRL b 0 {rl:g}\n.tran 10u 3m\n")
    res = netdae.run(text)[0]
    assert res.ok, res.message
    ratio = k * np.sqrt(l2 / l1)
    va, vb = np.asarray(res["v(a)"]), np.asarray(res["v(b)"])
    np.testing.assert_allclose(vb, ratio * va, rtol=0, atol=1e-9 * np.max(np.abs(va)))
    assert np.ptp(va) > 1.0
    # three windings pairwise coupled by 0.9, 0.9 and -0.9: not a transformer (an eigenvalue of -0.8 L)
    with pytest.raises(CircuitError, match="positive definite") as exc:
        assemble(netdae.load("t\nL1 a 0 1m\nL2 b 0 1m\nL3 c 0 1m\nK1 L1 L2 0.9\nK2 L1 L3 0.9\nK3 L2 L3 -0.9\n"
                             "R1 a 0 1\nR2 b 0 1\nR3 c 0 1\n.op\n"))
    # located at the coupling written last (it had no file and line)
    assert str(exc.value).startswith("<string>:7:1: k3: the inductance matrix of the coupled inductors l1, l2, l3")


def test_differentiator_pencil_entry_by_entry():
    """The op-amp differentiator of the lecture notes, Section 1.3, written by hand.

    Unknowns (u1, u2, u3, I_A, I_L, I_V) = (v(in), v(minus), v(out), i(e1), i(l1), i(v1)).
    Equations in netdae's convention (node rows: currents entering the node):
      in:    0 = -G (u1 - u2) - I_V
      minus: 0 =  G (u1 - u2) - I_L
      out:   0 =  I_L - I_A
      e1:    0 =  0 - u2                      (ideal op-amp, + input grounded)
      l1:  L I_L' = u2 - u3
      v1:    0 = u1 - V(t)
    """
    G, L = 1 / 100.0, 10e-3
    ckt = circuit(
        mk("v1", "vsource", ("in", "0"), 1.0),
        mk("r1", "resistor", ("in", "minus"), 100.0),
        mk("l1", "inductor", ("minus", "out"), L),
        mk("e1", "opamp", ("out", "0", "0", "minus")),
    )
    sysm = assemble(ckt)
    order = ["v(in)", "v(minus)", "v(out)", "i(e1)", "i(l1)", "i(v1)"]
    p = [sysm.index_of(nm) for nm in order]
    E = sysm.E.toarray()[np.ix_(p, p)]
    H = sysm.H.toarray()[np.ix_(p, p)]
    c = sysm.source(0.0)[p]
    E_hand = np.zeros((6, 6))
    E_hand[4, 4] = L
    H_hand = np.array([
        [-G, G, 0, 0, 0, -1],
        [G, -G, 0, 0, -1, 0],
        [0, 0, 0, -1, 1, 0],
        [0, -1, 0, 0, 0, 0],
        [0, 1, -1, 0, 0, 0],
        [1, 0, 0, 0, 0, 0],
    ], dtype=float)
    c_hand = np.array([0, 0, 0, 0, 0, -1.0])
    np.testing.assert_array_equal(E, E_hand)
    np.testing.assert_allclose(H, H_hand, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(c, c_hand)
    assert sysm.linear
    x = op(*ckt.elements)
    assert x["v(out)"] == 0.0 and x["i(l1)"] == pytest.approx(G * 1.0, rel=1e-12)


def test_evaluate_matches_matrices_and_pattern_has_diagonal():
    ckt = circuit(mk("v1", "vsource", ("a", "0"), 2.0), mk("r1", "resistor", ("a", "b"), 1e3),
                  mk("c1", "capacitor", ("b", "0"), 1e-6), mk("l1", "inductor", ("b", "c"), 1e-3),
                  mk("r2", "resistor", ("c", "0"), 10.0))
    sysm = assemble(ckt)
    x = np.arange(1.0, sysm.n + 1.0)
    ev = sysm.evaluate(x, 0.0)
    np.testing.assert_allclose(ev.q, sysm.E @ x)
    np.testing.assert_allclose(ev.phi, sysm.H @ x + sysm.source(0.0))
    np.testing.assert_allclose(sysm.pattern.matrix(ev.dq).toarray(), sysm.E.toarray())
    np.testing.assert_allclose(sysm.pattern.matrix(ev.dphi).toarray(), sysm.H.toarray())
    assert np.all(sysm.pattern.rows[sysm.pattern.diag] == np.arange(sysm.n))
    assert sysm.kinds.tolist() == [0, 0, 0, 1, 1]


def test_zero_resistance_is_one_milliohm_as_ngspice():
    r = operating_point(circuit(mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "b"), 0.0),
                                mk("r2", "resistor", ("b", "0"), 1e3)))
    assert float(r["v(b)"][0]) == pytest.approx(1e3 / (1e3 + 1e-3), rel=1e-12)
    assert any("r1" in note for note in r.notes)
