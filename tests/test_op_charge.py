"""Nodes attached only through capacitors: the operating point by charge conservation.

Such nodes have no DC path to ground, so the DC matrix is singular and
ngspice stops ("singular matrix"); their total charge at t = 0 is zero, which
fixes them. Checked against closed forms (capacitive dividers: a series chain
carries one charge ``Q = V / sum(1/C_k)``) and against ngspice on the
*compensated* divider, where a resistor ``R_k = tau / C_k`` across every
capacitor gives a DC path whose resistive divider equals the capacitive one
for any ``tau`` (ngspice runs; the values must agree to rounding).
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.analyses.dc import dc_sweep
from netdae.analyses.index import analyze_index
from netdae.analyses.op import operating_point
from netdae.analyses.tran import transient
from netdae.errors import CircuitError, NgspiceError

#: Linear solves agree with closed forms and with ngspice to rounding.
REL = 1e-9


def _close(a: float, b: float, scale: float) -> bool:
    return abs(a - b) <= REL * scale


def test_capacitive_divider_by_charge_conservation():
    r = operating_point(netdae.load("divider\nV1 a 0 10\nC1 a b 1u\nC2 b 0 3u\nR1 a 0 1k\n.op\n.end\n"))
    assert _close(r["v(b)"][0], 10.0 * 1 / (1 + 3), 10.0)
    assert any("node 'b' has no DC path to ground (attached only through c1, c2)" in n
               and "charge conservation" in n for n in r.notes)


def test_series_chain_carries_one_charge():
    c1, c2, c3, v = 1e-6, 2.2e-6, 4.7e-7, 5.0
    text = f"chain\nV1 a 0 {v}\nC1 a b {c1}\nC2 b c {c2}\nC3 c 0 {c3}\n.op\n.end\n"
    r = operating_point(netdae.load(text))
    q = v / (1 / c1 + 1 / c2 + 1 / c3)
    assert _close(r["v(b)"][0], v - q / c1, v) and _close(r["v(c)"][0], q / c3, v)
    assert sum("charge conservation" in n for n in r.notes) == 2  # two groups, one line each


def test_group_with_internal_resistor_and_dc_sweep():
    text = "grp\nV1 a 0 1\nC1 a b 1u\nR1 b d 1k\nC2 d 0 4u\n.dc V1 0 2 1\n.end\n"
    circuit = netdae.load(text)
    res = dc_sweep(circuit, circuit.analyses[0])
    np.testing.assert_allclose(res["v(b)"], np.array([0.0, 1.0, 2.0]) * 0.2, rtol=0, atol=REL)
    np.testing.assert_allclose(res["v(d)"], res["v(b)"], rtol=0, atol=REL)


def test_transient_starts_from_the_conserved_charge():
    # the divider follows the source at every instant: v(b) = v(a) C1 / (C1 + C2)
    text = ("tran\nV1 a 0 PULSE(4 0 1m 1u 1u 1 2)\nC1 a b 1u\nC2 b 0 3u\nR1 a 0 1k\n"
            ".tran 10u 3m\n.end\n")
    res = transient(netdae.load(text))
    assert _close(res["v(b)"][0], 1.0, 4.0)
    np.testing.assert_allclose(res["v(b)"], res["v(a)"] / 4, rtol=0, atol=1e-6)
    assert any("charge conservation" in n for n in res.notes)


def test_ic_holds_the_group_in_a_transient():
    # .ic fixes the node (ngspice's rule), so charge conservation does not apply there
    text = "ic\nV1 a 0 4\nC1 a b 1u\nC2 b 0 3u\n.ic v(b)=2\n.tran 10u 100u\n.end\n"
    res = transient(netdae.load(text))
    assert _close(res["v(b)"][0], 2.0, 4.0)
    assert not any("charge conservation" in n for n in res.notes)


def test_net_current_into_the_group_is_refused():
    with pytest.raises(CircuitError, match=r"no DC operating point: i1 drives a net DC current of .* into node "
                                           r"'b'.*only through c1, i1") as info:
        operating_point(netdae.load("q\nV1 a 0 1\nC1 a b 1u\nI1 0 b 1m\nR1 a 0 1\n.op\n.end\n"))
    assert info.value.elements == ("c1", "i1") and "uic" in info.value.hint


def test_zero_net_current_into_the_group_is_fine():
    r = operating_point(netdae.load("q\nV1 a 0 8\nC1 a b 1u\nC2 b 0 1u\nI1 0 b 1m\nI2 b 0 1m\n.op\n.end\n"))
    assert _close(r["v(b)"][0], 4.0, 8.0)


def test_index_reports_the_charge_group_in_one_line():
    rep = analyze_index(netdae.load("d\nV1 a 0 SIN(0 1 1k)\nC1 a b 1u\nC2 b 0 3u\nR1 a 0 1k\n.tran 1u 1m\n.end\n"))
    assert rep.index == 2 and rep.regular
    lines = [m for m in rep.messages if "charge conservation" in m]
    assert len(lines) == 1 and "node 'b'" in lines[0]


@pytest.mark.ngspice
def test_compensated_divider_agrees_with_ngspice():
    from netdae.ngspice import run_ngspice

    c1, c2, c3, v, tau = 1e-6, 2.2e-6, 4.7e-7, 5.0, 1e6
    caps = f"V1 a 0 {v}\nC1 a b {c1}\nC2 b c {c2}\nC3 c 0 {c3}\n"
    leaks = f"R1 a b {tau / c1}\nR2 b c {tau / c2}\nR3 c 0 {tau / c3}\n"
    ours = operating_point(netdae.load("chain\n" + caps + ".op\n.end\n"))
    theirs = run_ngspice("chain\n" + caps + leaks + ".op\n.end\n").result("op")
    for name in ("v(b)", "v(c)"):
        assert _close(float(ours[name][0]), float(theirs[name][0]), v), name
    with pytest.raises(NgspiceError, match="singular matrix"):  # without the leaks ngspice gives up
        run_ngspice("chain\n" + caps + ".op\n.end\n").result("op")


# -- combinations of charges that controlled sources make conserved ----------------------------------------------
def _transformer(n: float, c1: float, c2: float, v: float, extra: str = "", analysis: str = ".op") -> str:
    """An ideal transformer of controlled sources between nodes attached only through capacitors.

    E1 sets v(e) = n v(s); the current of E1 (through VS, V1 and R1 into C1 at node a) is fed to
    node s by F1, so ``C2 v(s)' = n C1 v(a)'``: no node group is attached only through capacitors,
    the DC matrix is singular, and ``C2 v(s) - n C1 v(a)`` is conserved. At DC ``v(a) = n v(s) - V``;
    with the combination zero at t = 0, ``v(s) = -n C1 V / (C2 - n^2 C1)``.
    """
    return (f"transformer\nE1 e 0 s 0 {n}\nVS e p 0\nV1 p m {v}\nR1 m a 1k\nC1 a 0 {c1}\nF1 0 s VS {n}\n"
            f"C2 s 0 {c2}\n{extra}{analysis}\n.end\n")


@pytest.mark.parametrize("n, c1, c2, v", [(2.0, 1e-6, 3e-6, 1.0), (3.0, 2e-6, 5e-6, 1.5), (0.5, 1e-9, 1e-9, -2.0)])
def test_conserved_combination_of_charges_fixes_the_operating_point(n, c1, c2, v):
    r = operating_point(netdae.load(_transformer(n, c1, c2, v)))
    vs = -n * c1 * v / (c2 - n * n * c1)
    assert _close(r["v(s)"][0], vs, abs(v) + abs(vs)) and _close(r["v(a)"][0], n * vs - v, abs(v) + abs(vs))
    assert any("are dependent" in note and "charge conservation" in note and "f1" in note for note in r.notes)
    rep = analyze_index(netdae.load(_transformer(n, c1, c2, v)), check_consistency=False)
    assert rep.regular and rep.index == 1


def test_conserved_combination_holds_through_a_transient():
    # the start is the operating point by the conservation law; the transient, driven by a pulse on V1,
    # keeps the combination C2 v(s) - n C1 v(a) at zero (an invariant of the equations, not of netdae)
    n, c1, c2 = 2.0, 1e-6, 3e-6
    text = _transformer(n, c1, c2, "PULSE(1 3 1m 0.2m 0.2m 2m 5m)", analysis=".tran 10u 8m")
    res = transient(netdae.load(text), reltol=1e-6)
    s, a = res["v(s)"], res["v(a)"]
    assert _close(s[0], 2.0, 3.0) and _close(a[0], 3.0, 3.0)
    assert np.max(np.abs(c2 * s - n * c1 * a)) <= 1e-6 * c2 * np.max(np.abs(s))
    assert np.ptp(s) > 1.0  # it moved


def test_a_net_current_into_a_conserved_combination_is_refused():
    with pytest.raises(CircuitError) as info:
        operating_point(netdae.load(_transformer(2.0, 1e-6, 3e-6, 1.0, extra="I1 0 a 1m\n")))
    assert "no DC path" in str(info.value) and "f1" in str(info.value)


def test_an_inductor_loop_conserves_its_flux():
    # the dual of a node set attached only through capacitors: the flux around a loop of inductors alone is
    # conserved (ngspice refuses the singular matrix; netdae did too). v(b) = v(c) = 0.5 V and i(l1) - i(l2) =
    # 0.5 mA through the dividers; zero flux around b -l1- c -l2- b: 1m i(l1) + 2m i(l2) = 0
    res = operating_point(netdae.load("lloop\nV1 a 0 1\nR1 a b 1k\nL1 b c 1m\nL2 c b 2m\nR2 c 0 1k\n.op\n.end\n"))
    assert res["v(b)"][0] == pytest.approx(0.5, rel=1e-9) and res["v(c)"][0] == pytest.approx(0.5, rel=1e-9)
    assert res["i(l1)"][0] == pytest.approx(1e-3 / 3, rel=1e-9)
    assert res["i(l2)"][0] == pytest.approx(-1e-3 / 6, rel=1e-9)
    assert any("flux conservation, total flux zero at t = 0" in note for note in res.notes)


def test_inductor_loops_with_a_coupling_keep_their_flux_through_a_transient():
    # three inductors in parallel, two of them coupled (k = 0.5): two loops, each of zero flux at the start
    # (L1 i1 + M i2 = L2 i2 + M i1 = L3 i3), and so at every time; the total current is a first-order step
    # response of R1 and the parallel inductance 1 / sum(inverse inductance matrix)
    text = ("three\nV1 in 0 PULSE(0 1 0 1n 1n 1 2)\nR1 in b 1k\nL1 b 0 1m\nL2 b 0 2m\nL3 b 0 3m\n"
            "K1 L1 L2 0.5\n.tran 10n 3u\n.end\n")
    r = netdae.simulate(netdae.load(text))
    assert r.ok and any("l1, l2, l3 form 2 loops" in note for note in r.notes)
    M = 0.5 * np.sqrt(1e-3 * 2e-3)
    i1, i2, i3 = r["i(l1)"], r["i(l2)"], r["i(l3)"]
    f1, f2, f3 = 1e-3 * i1 + M * i2, 2e-3 * i2 + M * i1, 3e-3 * i3
    assert np.max(np.abs(f1 - f2)) < 1e-12 * np.max(np.abs(f1)) and np.max(np.abs(f1 - f3)) < 1e-12 * np.max(np.abs(f1))
    tau = 1.0 / (np.linalg.inv([[1e-3, M], [M, 2e-3]]).sum() + 1.0 / 3e-3) / 1e3
    tr = 1e-9

    def ramp(t):  # the response to a unit ramp of slope 1/tr
        t = np.maximum(t, 0.0)
        return (t - tau * (1.0 - np.exp(-t / tau))) / tr

    exact = (ramp(r.t) - ramp(r.t - tr)) / 1e3
    assert np.max(np.abs(i1 + i2 + i3 - exact)) < 0.1 * r.tolerances["reltol"] * 1e-3  # of the final 1 mA


def test_a_loop_of_inductors_and_a_source_stays_refused():
    # a voltage source in the loop: its voltage drives the loop's flux without bound at DC (no operating point)
    with pytest.raises(CircuitError, match="l1 and l2 form a loop with the source v2"):
        operating_point(netdae.load("vl\nV1 a 0 1\nR1 a b 1k\nL1 b c 1m\nV2 c d 1\nL2 d b 2m\nR2 c 0 1k\n"
                                    ".op\n.end\n"))


# -- random linear circuits against a dense oracle of the conservation laws -------------------------------------
def _random_capacitive_circuit(rng: np.random.Generator):
    """R, C, V, I and one to three VCVS/VCCS on up to five nodes: capacitors often, resistors rarely, so that
    networks attached only through capacitors and controlled sources are frequent."""
    from helpers import circuit, mk

    nodes = ["0", "n1", "n2", "n3", "n4", "n5"][: rng.integers(2, 7)]

    def pair():
        a, b = rng.choice(nodes, 2, replace=False)
        return str(a), str(b)

    elements = []
    for k in range(rng.integers(1, 8)):
        kind = str(rng.choice(["capacitor", "capacitor", "resistor", "vsource", "isource"]))
        value = float(rng.uniform(-2.0, 2.0)) if kind in ("vsource", "isource") else float(
            rng.choice([0.5, 1.0, 2.0, 3.0]))
        elements.append(mk(f"{kind[0]}{k}", kind, pair(), value))
    for k in range(rng.integers(1, 4)):
        kind = str(rng.choice(["vcvs", "vccs"]))
        elements.append(mk(f"{'e' if kind == 'vcvs' else 'g'}x{k}", kind, pair() + pair(),
                           float(rng.choice([0.5, 1.0, 2.0, -1.0]))))
    return circuit(*elements)


def _conservation_oracle(c):
    """``(verdict, x by name)``: the operating point of a linear circuit whose DC matrix ``H`` may be singular.

    Regular ``H``: ``x = -H^-1 c``. Singular: ``Y`` its left null space; when ``Y^T E`` has full row rank,
    ``Y^T c = 0`` and ``[H; Y^T E]`` full column rank, the unique ``x`` with ``H x = -c`` and ``Y^T E x = 0``
    ("determined"); otherwise "refused"; close calls None (no claim). Independent of netdae: the dense MNA of
    tests/test_topology_helpers.py and numpy's SVD.
    """
    from test_topology_helpers import reference_mna

    E, H, B, names = reference_mna(c)
    if H.shape[0] == 0:
        return None, {}
    u = np.array([el.source.dc for el in c.elements if el.kind in ("vsource", "isource")])
    rhs = -(B @ u) if B.size else np.zeros(H.shape[0])
    U, s, _ = np.linalg.svd(H)
    if s[-1] > 1e-8 * s[0]:
        return "determined", dict(zip(names, np.linalg.solve(H, rhs)))
    if s[-1] > 1e-12 * s[0]:
        return None, {}
    d = int(np.count_nonzero(s <= 1e-12 * s[0]))
    Y = U[:, -d:]
    ye = np.linalg.svd(Y.T @ E, compute_uv=False)
    if ye[0] == 0.0 or ye[-1] <= 1e-12 * ye[0]:
        return "refused", {}
    if ye[-1] < 1e-6 * ye[0]:
        return None, {}
    balance = np.abs(Y.T @ rhs).max()
    if balance > 1e-6 * (np.abs(rhs).max() + 1.0):
        return "refused", {}
    if balance > 1e-12 * (np.abs(rhs).max() + 1.0):
        return None, {}
    A = np.vstack([H, Y.T @ E])
    sa = np.linalg.svd(A, compute_uv=False)
    if sa[-1] <= 1e-12 * sa[0]:
        return "refused", {}
    if sa[-1] < 1e-8 * sa[0]:
        return None, {}
    x = np.linalg.lstsq(A, np.concatenate([rhs, np.zeros(d)]), rcond=None)[0]
    return "determined", dict(zip(names, x))


def test_random_capacitive_circuits_against_the_conservation_oracle():
    rng = np.random.default_rng(20261128)
    seen = {"determined": 0, "refused": 0, "laws": 0}
    for _ in range(400):
        c = _random_capacitive_circuit(rng)
        verdict, ref = _conservation_oracle(c)
        if verdict is None:
            continue
        seen[verdict] += 1
        if verdict == "refused":
            with pytest.raises(CircuitError):
                operating_point(c)
            continue
        res = operating_point(c)
        scale = max(1.0, max(abs(v) for v in ref.values()))
        for name, v in ref.items():
            assert abs(res[name][0] - v) <= 1e-6 * scale, (name, res[name][0], v, [str(e) for e in c.elements])
        seen["laws"] += any("are dependent" in n for n in res.notes)
    # the draw exercises every branch: plain, topological groups and laws, refusals
    assert seen["determined"] > 100 and seen["refused"] > 20 and seen["laws"] >= 3, seen
