"""The two-bit adding unit's netlist against the Test Set's own equations.

``tests/data/testset_tba.cir`` is the Test Set's problem tba written by hand as
a netlist (gates as subcircuits, junction charges as charge-defined
capacitors). ``tests/testset_tba_oracle.py`` writes the published equations
(f(U, t), g(U)) node by node, independently of netdae; these tests hold
netdae's assembled equations to it: with ``c(t)`` the inputs' share of g
(netdae's gate capacitors to the input sources carry ``-C V_in``), netdae's
node charges are ``q = g(U) - c(t)`` and its right-hand side
``phi = f(U, t) - c'(t)``, row by row for the 175 nodes, and their Jacobians
on the node columns equal the oracle's (complex-step) Jacobians entry by
entry, at the Test Set's U(0), at its reference at t = 320, at random states
near them and at times over [0, 320] (around the first input's corner at
t = 5 especially).

Tolerances: values to 1e-12 of the row's scale ``sum_j |J_ij| (|U_j| + 5)``
(the size of its largest terms; the rows are sums of currents up to 10^4 A
that cancel to 1e-7 A at a steady state), Jacobian entries to 1e-9 of
themselves plus 1e-18 (the junctions' conductances are near 1e-12, so an
absolute tolerance at the scale of the resistors' 500-1250 S would hide them).
The oracle itself is checked against the published reference: its g at the
published U(320) equals the published y(320).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.analyses.prepared import prepare

import testset_tba_oracle as oracle

DATA = Path(__file__).resolve().parent / "data"
NETLIST = DATA / "testset_tba.cir"
INPUTS = ("in1", "in2", "in3", "in4", "cin")


def _reference():
    """The published y(320) (charges) and U(320) (node voltages), shape (175,) each."""
    table = np.loadtxt(DATA / "testset_tba_reference.txt", comments="#")
    assert table.shape == (175, 3) and np.array_equal(table[:, 0], np.arange(1, 176))
    return table[:, 1], table[:, 2]


#: The junctions magnified (0.5 A saturation current, 2 V slope instead of 5e-11 A and 25.85 V), so
#: that a junction's current and conductance show above the rounding of the resistors' (500-1250 S).
LOUD_JUNCTIONS = {"curis": 0.5, "vth": 2.0}


def _system(text=None, constants=None):
    """netdae's MNA system of the netlist (``text``: another version of it; ``constants``: the
    junctions' ``curis``/``vth`` replaced in its ``.param`` line) and the netlist's U(0)."""
    text = NETLIST.read_text() if text is None else text
    if constants:
        text, n = re.subn(r"curis=\{[^}]*\} vth=[0-9.]+",
                          f"curis={constants['curis']!r} vth={constants['vth']!r}", text)
        assert n == 1
    circuit = netdae.load(text)
    system = prepare(circuit, mode="tran", tstep=0.5, tstop=320.0).system
    u0 = np.array([circuit.ic[str(k)] for k in range(1, 176)])
    return system, u0


@pytest.fixture(scope="module")
def tba():
    return _system()


@pytest.fixture(scope="module")
def tba_loud():
    return _system(constants=LOUD_JUNCTIONS)


def _state(system, U, t):
    names = list(system.names)
    x = np.zeros(system.n)
    x[[names.index(f"v({k})") for k in range(1, 176)]] = U
    x[names.index("v(vdd)")] = oracle.CONSTANTS["vdd"]
    x[names.index("v(vbb)")] = oracle.CONSTANTS["vbb"]
    values, _ = oracle.inputs(t)
    for name, v in zip(INPUTS, values):
        x[names.index(f"v({name})")] = v
    return x


def mismatches(system, U, t, constants=None):
    """{what: [(row, column) ...]} where netdae's q, phi, dq/dU, dphi/dU differ from the oracle's
    at node voltages ``U`` and time ``t`` (1-based node numbers; columns of the node unknowns);
    ``constants``: the oracle's overrides matching the system's netlist."""
    names = list(system.names)
    nodes = np.array([names.index(f"v({k})") for k in range(1, 176)])
    ev = system.evaluate(_state(system, U, t), t, jacobian=True)
    assert ev.ok
    c, dc = oracle.input_charges(t)
    g, f = oracle.charges(U, constants) - c, oracle.currents(U, t, constants) - dc
    jg = oracle.jacobian(lambda V: oracle.charges(V, constants), U)
    jf = oracle.jacobian(lambda V: oracle.currents(V, t, constants), U)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(jf))
    dq = system.pattern.matrix(ev.dq).toarray()[np.ix_(nodes, nodes)]
    dphi = system.pattern.matrix(ev.dphi).toarray()[np.ix_(nodes, nodes)]
    weight = np.abs(U) + 5.0
    checks = {
        "q": (np.asarray(ev.q)[nodes], g, 1e-12 * (np.abs(jg) @ weight + np.abs(c))),
        "phi": (np.asarray(ev.phi)[nodes], f, 1e-12 * (np.abs(jf) @ weight + np.abs(dc))),
        "dq": (dq, jg, 1e-9 * np.abs(jg) + 1e-18),
        "dphi": (dphi, jf, 1e-9 * np.abs(jf) + 1e-18),
    }
    out = {}
    for what, (got, want, tol) in checks.items():
        bad = np.argwhere(np.abs(got - want) > tol) + 1
        out[what] = [tuple(int(i) for i in b) for b in bad]
    return out


def _clean(result):
    return {k: v[:5] for k, v in result.items() if v}


def test_the_oracle_is_the_published_problem():
    y, U = _reference()
    # g(U(320)) is the published y(320) (RADAU5 solved 0 = y - g(U) to 1e-9 of y)
    assert np.allclose(oracle.charges(U), y, rtol=1e-7, atol=1e-9)
    # the published U(0) is a steady state at t = 0: f vanishes to 1e-6 A of currents up to 15 A
    _, u0 = _system()
    assert np.max(np.abs(oracle.currents(u0, 0.0))) < 1e-6
    assert np.max(np.abs(oracle.currents(u0 + 1e-3 * (np.arange(175) == 17), 0.0))) > 1.0
    # the inputs' share c(t) of g is what their slopes add to f
    for t in (2.5, 12.0, 33.0, 157.0):
        _, dc = oracle.input_charges(t)
        assert np.allclose(oracle.currents(U, t) - oracle.currents(U, t, input_slopes=False), dc, rtol=0,
                           atol=1e-12)
        h = 1e-6
        slope = (oracle.input_charges(t + h)[0] - oracle.input_charges(t - h)[0]) / (2 * h)
        assert np.allclose(slope, dc, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("t", [0.0, 2.5, 4.9, 5.0, 5.05, 5.3, 6.0, 7.5, 10.0, 12.5, 40.0, 77.0, 152.5, 320.0])
def test_netlist_equals_the_test_set_at_its_start_and_reference(tba, t):
    system, u0 = tba
    _, uref = _reference()
    assert _clean(mismatches(system, u0, t)) == {}
    assert _clean(mismatches(system, uref, t)) == {}


@pytest.mark.parametrize("loud", [False, True], ids=["published", "loud-junctions"])
def test_netlist_equals_the_test_set_at_random_states(tba, tba_loud, loud):
    # states within 0.1 V of the start and of the reference (every transistor's region and every
    # junction's branch is visited by some of them), times around the first corner and anywhere;
    # with the published constants and with the junctions magnified
    system, u0 = tba_loud if loud else tba
    constants = LOUD_JUNCTIONS if loud else None
    _, uref = _reference()
    rng = np.random.default_rng(20240)
    for k in range(16):
        base = uref if k % 2 else u0
        t = rng.uniform(4.0, 10.0) if k < 8 else rng.uniform(0.0, 320.0)
        U = base + rng.uniform(-0.1, 0.1, 175)
        assert _clean(mismatches(system, U, t, constants)) == {}, (k, t)


@pytest.mark.parametrize("old, new, rows", [
    # a junction's current reversed (1e-11 A against resistor currents of amperes)
    ("Bbs2 0 k7 I={ij(v(k7))}", "Bbs2 k7 0 I={ij(v(k7))}", {8, 39, 88}),
    # the NOR gates' irregular charge read at the gate's own output instead of node I+14
    ("Q={cbdbs(v(k12)-v(k4))*(v(k12)-v(n14))}", "Q={cbdbs(v(k12)-v(k4))*(v(k12)-v(k4))}", {13, 44, 93}),
    # a transistor's drain resistance to the wrong node
    ("Rgd6 168 166 {rgd}", "Rgd6 168 171 {rgd}", {166, 168, 171}),
])
def test_a_wrong_sign_or_node_is_found(old, new, rows):
    # the first occurrence: the NOR gate's subcircuit, which comes first
    text = NETLIST.read_text()
    assert old in text
    system, u0 = _system(text.replace(old, new, 1), constants=LOUD_JUNCTIONS)
    _, uref = _reference()
    found = set()
    for U, t in ((u0, 0.0), (uref, 5.5)):
        for pairs in mismatches(system, U, t, LOUD_JUNCTIONS).values():
            found |= {r for r, *_ in pairs}
    assert found == rows


def test_the_reference_tables_agree():
    # the netlist's U(0) is the published one, and its header quotes the published outputs
    _, u0 = _system()
    header = NETLIST.read_text()
    quoted = {int(k): float(v) for k, v in re.findall(r"v\((\d+)\) = ([0-9.]+)", header)}
    _, uref = _reference()
    assert quoted and all(uref[k - 1] == v for k, v in quoted.items())
    assert u0[4] == pytest.approx(4.999999999996514, rel=1e-15)


def _nor1_low(u0):
    """U(0) with the first NOR gate (nodes 1-13) switched: its first transistor on, its output low,
    its nodes as the same transistors' in the first ANDOI gate at U(0) (nodes 14-26), which holds
    that state; NOR1's rows of f vanish there at t = 8 (V1 high, V2 low)."""
    U = u0.copy()
    U[0:9] = u0[13:22]
    U[9], U[10], U[11], U[12] = 0.0, u0[17], oracle.CONSTANTS["vbb"], oracle.CONSTANTS["vbb"]
    return U


def _fastest_growth(system, U, t):
    """The finite eigenvalue of netdae's pencil (dphi/dx, dq/dx) at (U, t) with the largest real part,
    and the node voltage its eigenvector is largest on. Eigenvalues beyond 1e10 are rounding of the
    pencil's infinite ones (the algebraic rows) and left out."""
    import scipy.linalg

    ev = system.evaluate(_state(system, U, t), t, jacobian=True)
    a = system.pattern.matrix(ev.dphi).toarray()
    b = system.pattern.matrix(ev.dq).toarray()
    w, vr = scipy.linalg.eig(a, b)
    keep = np.isfinite(w) & (np.abs(w) < 1e10)
    w, vr = w[keep], vr[:, keep]
    j = int(np.argmax(w.real))
    volts = [i for i, name in enumerate(system.names) if name.startswith("v(")]
    return w[j], system.names[volts[int(np.argmax(np.abs(vr[volts, j])))]]


def test_the_published_charge_of_node_13_makes_a_growing_oscillation(tba):
    # the Test Set's g(13) = CBDBS(U13 - U5) (U13 - U15) (NOR gate 1's node I+12 reading node
    # I+14) falls with U13 once the gate's output U5 is low: dg13/dU13 = CBDBS(V) + CBDBS'(V)
    # (U13 - U15) < 0 at V = U13 - U5 = -2.7 V, U13 - U15 = -7.5 V. Against the bulk resistance's
    # 500 S, the linearisation has a growing oscillation on node 13 (about 400 +- 2.7e4 i per unit
    # of the scaled time); with the charge read at the output (I+4) it has none
    system, u0 = tba
    U = _nor1_low(u0)
    assert np.max(np.abs(oracle.currents(U, 8.0)[:13])) < 1e-6
    jg = oracle.jacobian(oracle.charges, U)
    assert jg[12, 12] < 0 < oracle.jacobian(oracle.charges, u0)[12, 12]
    lam, where = _fastest_growth(system, U, 8.0)
    assert lam.real > 100 and 2e4 < abs(lam.imag) < 4e4 and where == "v(13)"
    lam0, _ = _fastest_growth(system, u0, 0.0)
    assert lam0.real < 1.0
    old = "Q={cbdbs(v(k12)-v(k4))*(v(k12)-v(n14))}"
    fixed, _ = _system(NETLIST.read_text().replace(old, "Q={cbdbs(v(k12)-v(k4))*(v(k12)-v(k4))}"))
    lam_fixed, _ = _fastest_growth(fixed, U, 8.0)
    assert lam_fixed.real < 1.0
