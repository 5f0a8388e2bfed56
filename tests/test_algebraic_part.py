"""The sparse analysis of the algebraic part (netdae.dae.algebraic): index <= 2 and the index-2 unknowns.

Oracles: closed forms of small pencils (a nilpotent chain of known index, the impulse of a
capacitor-source loop), the dense Kronecker analysis on every bundled netlist, and a transient above
the dense limit whose index-2 current has a closed form.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import netdae
from netdae.analyses import tran as tran_module
from netdae.analyses.index import analyze_index
from netdae.analyses.prepared import prepare
from netdae.analyses.tran import TRAN_PENCIL_LIMIT, transient
from netdae.dae.algebraic import algebraic_part
from netdae.mna import MODE_TRAN

from conftest import NETLISTS


def _nilpotent(k: int):
    """``E x' = x + c`` with ``E`` one nilpotent Jordan block of size ``k``: index ``k``."""
    return sp.eye(k, k=1, format="csr"), -sp.eye(k, format="csr")


def test_an_ode_has_index_0_and_an_index_1_pencil_no_impulsive_direction():
    ode = algebraic_part(np.diag([1.0, 2.0]), np.array([[-1.0, 0.5], [0.0, -3.0]]))
    assert (ode.index, ode.kernel_dim, ode.impulsive_dim) == (0, 0, 0)
    # x1' = -x1 + x2, 0 = x1 - 2 x2: the algebraic Jacobian (-2) is nonsingular
    one = algebraic_part(np.diag([1.0, 0.0]), np.array([[-1.0, 1.0], [1.0, -2.0]]))
    assert (one.index, one.kernel_dim, one.impulsive_dim, one.support.size) == (1, 1, 0, 0)


@pytest.mark.parametrize("k", [2, 3, 4])
def test_a_nilpotent_chain_is_index_2_or_left_undetermined(k):
    E, H = _nilpotent(k)
    part = algebraic_part(E, H)
    assert part.determined and part.impulsive_dim == 1
    assert part.index == (2 if k == 2 else None)  # 3 or more is told from 2, not counted
    if k == 2:
        # x2 = -c2, x1 = -c1 - x2' = -c1 + c2': only x1 carries a derivative
        assert part.support.tolist() == [0]


def test_a_floating_capacitor_group_and_its_source_loop():
    """Nodes a, b joined by C only, a driven by V (current j), b to ground by R: E's group {a, b} is
    rank 1, its kernel the common mode; the loop V-C-R has index 1; a second source on b makes a
    capacitor-source loop, and the two source currents carry the inputs' derivative."""
    C, G = 1e-12, 1e-3
    E = np.array([[C, -C, 0.0], [-C, C, 0.0], [0.0, 0.0, 0.0]])
    H = np.array([[0.0, 0.0, -1.0], [0.0, -G, 0.0], [-1.0, 0.0, 0.0]])  # rows: KCL a, KCL b, V: v(a) = u
    assert algebraic_part(E, H).index == 1
    E2 = np.zeros((4, 4))
    E2[:3, :3] = E
    H2 = np.zeros((4, 4))
    H2[:3, :3] = H
    H2[1, 3], H2[3, 1] = -1.0, -1.0  # a source on b: v(b) = u2, its current in KCL b
    B = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    part = algebraic_part(E2, H2, B)
    assert part.index == 2 and part.impulsive_dim == 1
    assert part.support.tolist() == [2, 3]


def test_the_impulse_a_step_puts_into_a_loop_current_matches_the_resolvent():
    """V1 across C1 with a CCVS copying the source current onto a resistor: the impulse of a unit step
    is -C1 in i(v1) and -r C1 in the copy's node, as ``-(sE - H)^-1 b / s`` for large s says."""
    net = netdae.load("""loop
V1 in 0 PULSE(0 1 1n 1n 1n 5n 20n)
C1 in 0 2p
H1 b 0 V1 1k
R1 b 0 10k
.tran 0.1n 10n
""")
    p = prepare(net, mode=MODE_TRAN, tstep=1e-10, tstop=1e-8)
    E, H = p.system.jacobians(np.zeros(p.system.n), 0.0)
    part = algebraic_part(E, H, p.system.B)
    names = [p.system.names[i] for i in part.support]
    assert part.index == 2 and set(names) == {"i(v1)", "v(b)", "i(h1)"}
    s = 1e20
    lu = splu(sp.csc_matrix(s * sp.csr_matrix(E) - H))
    grow = -lu.solve(np.asarray(p.system.B.todense() if sp.issparse(p.system.B) else p.system.B, float)) / s
    i_v1 = p.system.names.index("i(v1)")
    assert grow[i_v1].max() == pytest.approx(2e-12, rel=1e-6)  # i(v1) = -C1 u'  (impulse -C1 per volt)


@pytest.mark.parametrize("path", sorted(NETLISTS.glob("*.cir")), ids=lambda p: p.stem)
def test_the_bundled_netlists_agree_with_the_dense_analysis(path):
    """Index and index-2 unknowns as the dense Kronecker analysis finds them, at the transient's start."""
    circuit = netdae.load(path)
    card = next((a for a in circuit.analyses if type(a).__name__ == "TranAnalysis"), None)
    if card is None:
        pytest.skip("no .tran")
    p = prepare(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop)
    dense = analyze_index(p, method="kronecker", check_consistency=False, at="t0")
    E, H = p.system.jacobians(dense.x, 0.0)
    part = algebraic_part(E, H, p.system.B)
    assert part.index == dense.index
    assert {p.system.names[i] for i in part.support} == {nm for nm, d in dense.derivative_order.items() if d >= 1}


LADDER_SECTIONS = 340


def _ladder() -> str:
    lines = ["CV loop before a long RC ladder behind a buffer",
             "V1 in 0 PULSE(0 1 1n 1n 1n 5n 20n)", "C0 in 0 1p", "E1 a 0 in 0 1", "R0 a n1 1k"]
    for k in range(1, LADDER_SECTIONS + 1):
        lines.append(f"C{k} n{k} 0 1p")
        if k < LADDER_SECTIONS:
            lines.append(f"R{k} n{k} n{k + 1} 100")
    lines += [".tran 0.1n 4n", ".end"]
    return "\n".join(lines) + "\n"


def test_a_transient_above_the_dense_limit_names_its_index_2_current(monkeypatch):
    """344 unknowns, a controlled source (the topological statement does not apply): the index (2) and
    the index-2 current come from the algebraic part, as the dense analysis would give them, and the
    current follows its closed form on the ramp, i(v1) = -C0 dV/dt = -1 mA."""
    text = _ladder()
    res = transient(netdae.load(text))
    assert res.ok
    info = res.transient
    assert info.index == 2 and info.index_method == "sparse" and info.index2 == ["i(v1)"]
    assert any("index 2 from the algebraic part" in note for note in res.notes)
    t = np.asarray(res.t)
    i = np.asarray(res.i("v1"))
    ramp = (t > 1.1e-9) & (t < 1.9e-9)
    assert ramp.any()
    np.testing.assert_allclose(i[ramp], -1e-3, rtol=1e-6)
    # the same run with the dense analysis forced: the same structure, the same steps
    monkeypatch.setattr(tran_module, "TRAN_PENCIL_LIMIT", 10_000)
    dense = transient(netdae.load(text))
    assert dense.transient.index_method == "kronecker" and dense.transient.index2 == ["i(v1)"]
    np.testing.assert_array_equal(np.asarray(dense.t), t)
    assert TRAN_PENCIL_LIMIT < LADDER_SECTIONS + 4


LOOP = """source loop copied by a CCVS
V1 in 0 PULSE(0 1 1n 1n 1n 5n 20n)
C1 in 0 2p
H1 b 0 V1 1k
R1 b 0 10k
.tran 0.1n 10n
"""


def test_netdae_index_sparse_names_the_copied_current_and_says_how(tmp_path, capsys):
    from netdae.cli import main

    rep = analyze_index(netdae.load(LOOP), method="sparse")
    assert (rep.method, rep.index, rep.regular) == ("sparse", 2, True)
    assert {nm for nm, d in rep.derivative_order.items() if d} == {"i(v1)", "v(b)", "i(h1)"}
    assert rep.algebraic.impulsive_dim == 1
    path = tmp_path / "loop.cir"
    path.write_text(LOOP)
    assert main(["index", "--method", "sparse", str(path)]) == 0
    out = capsys.readouterr().out
    assert "index: 2   method: sparse" in out and "the algebraic part does" in out


def test_index_3_is_left_undetermined_by_the_sparse_method():
    """A CCVS copies the current of a capacitor-source loop onto a capacitor measured by a 0 V source:
    i(vm) = C3 d/dt(1k i(v1)) = -1k C1 C3 V1'', index 3 (the dense analysis says so); the sparse
    method gives no index rather than a wrong one, and names the unknowns it found impulsive."""
    text = """index 3
V1 in 0 SIN(0 1 1k)
C1 in 0 1u
H2 y 0 V1 1k
VM y z 0
C3 z 0 1u
.tran 10u 1m
"""
    circuit = netdae.load(text)
    assert analyze_index(circuit, method="kronecker").index == 3
    sparse = analyze_index(circuit, method="sparse")
    assert sparse.index is None and sparse.regular is None
    assert sparse.algebraic.determined and sparse.algebraic.impulsive_dim >= 1 and not sparse.algebraic.index2
    assert any("no exact index can be given (the algebraic part has impulsive directions" in m
               for m in sparse.messages)


def test_two_cascaded_ideal_differentiators_are_not_reported_as_index_2():
    """Two ideal op-amp differentiators in cascade: v(o1) = -R C V1', v(o2) = R^2 C^2 V1'', index 3 (the
    dense analysis says so). The index-2 test's matrix S is 1 x 1 here and its exact value 0 came out as a
    rounding residue of 1e-13, which a rank decided against S's own norm counted as nonsingular: the
    sparse method reported index 2. It decides S on [M | z] now, with the scale of the entries rounding
    acts on, and gives no index rather than a wrong one."""
    text = """two nullor differentiators
V1 in 0 DC 0 SIN(0 1 1k)
C1 in n1 1u
R1 n1 o1 1k
E1 o1 0 0 n1 OPAMP
C2 o1 n2 1u
R2 n2 o2 1k
E2 o2 0 0 n2 OPAMP
.tran 1u 1m
"""
    circuit = netdae.load(text)
    assert analyze_index(circuit, method="kronecker").index == 3
    sparse = analyze_index(circuit, method="sparse")
    assert sparse.index is None
    assert sparse.algebraic.determined and sparse.algebraic.impulsive_dim == 1 and not sparse.algebraic.index2
    # the method line says what was asked for (it said 'topological (requested)' when sparse was)
    assert any(m.startswith("method: topological (sparse requested); no exact index") for m in sparse.messages)
    # one differentiator alone is index 2, and the sparse method still says so
    one = netdae.load(text.split("C2")[0] + ".tran 1u 1m\n")
    assert analyze_index(one, method="sparse").index == 2


def test_the_sparse_method_names_a_behavioural_sources_loop_current_as_the_dense_one_does():
    """A B source of time across a capacitor: i(b1) = -C V'(t), index 2. The source's time function is in its
    device law, not in the input matrix, so the algebraic part's impulse support (from B) was empty: the
    sparse method said index 2 and named no unknown (a transient above the dense limit then error-tests
    i(b1)). It adds the structure's index-2 unknowns where the index is 2, as the dense method does."""
    text = """b source of time on a capacitor
B1 1 0 V=sin(2*3.14159*1k*time)
C1 1 0 1u
R1 1 0 1k
.tran 1u 1m
"""
    circuit = netdae.load(text)
    dense = analyze_index(circuit, method="kronecker")
    sparse = analyze_index(circuit, method="sparse")
    assert dense.index == sparse.index == 2
    assert sparse.unknowns["i(b1)"] == dense.unknowns["i(b1)"] == "index2"
