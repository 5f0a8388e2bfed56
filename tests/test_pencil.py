"""Structure of known linear(ized) DAEs: index, blocks, eigenvalues, classification.

Expected values come from hand derivations (see test_pencil_examples.py) and
from SLICOT's ag08bd (through slycot) as an independent oracle.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp
import slycot

import netdae
from test_pencil_examples import (
    PEND_OMEGA,
    complex_step_jacobian,
    differentiator_cascade,
    pendulum_E,
    pendulum_hanging_state,
    pendulum_pencil,
    pendulum_residual,
    semi_explicit,
)

from netdae.dae.pencil import (
    analyze_dae,
    analyze_pencil,
    drazin_index,
    svd_form,
    weierstrass_form,
)
from netdae.dae.system import FunctionDae, LinearDae
from netdae.errors import SingularPencilError

#: Eigenvalues of these small, well-conditioned examples are accurate to a few
#: ulps; the assertion allows this relative error (errors are divided by it).
EIG_RTOL = 1e-10


def ag08bd_structure(E, H):
    """Infinite blocks (descending), number of finite eigenvalues and minimal indices from SLICOT."""
    E = np.asarray(E, dtype=float)
    H = np.asarray(H, dtype=float)
    n = E.shape[0]
    out = slycot.ag08bd(
        n, n, 0, 0, np.asfortranarray(H), np.asfortranarray(E), np.zeros((n, 1)), np.zeros((1, n)), np.zeros((1, 1))
    )
    Af, Ef, _nrank, _niz, _infz, kronr, infe, kronl = out
    return {
        "infe": tuple(sorted(infe.tolist(), reverse=True)),
        "nfz": Af.shape[0],
        "kronr": tuple(sorted(kronr.tolist())),
        "kronl": tuple(sorted(kronl.tolist())),
    }


def index_from_infe(infe) -> int:
    """ag08bd's infe lists the sizes of all infinite Jordan blocks (size-1 blocks included)."""
    return max(infe, default=0)


def rel_err(a, b):
    return abs(a - b) / max(abs(b), 1.0)


# ---------------------------------------------------------------------------
# trivial cases
# ---------------------------------------------------------------------------
def test_identity_E_is_an_ode():
    rng = np.random.default_rng(3)
    H = rng.standard_normal((7, 7))
    rep = analyze_pencil(np.eye(7), H)
    assert rep.regular and rep.index == 0 and rep.infinite_blocks == ()
    assert rep.n_dynamic == 7 and rep.rank_E == 7
    expected = np.sort_complex(np.linalg.eigvals(H))
    assert np.max(np.abs(rep.finite_eigenvalues - expected)) / np.max(np.abs(expected)) < EIG_RTOL
    assert set(rep.labels) == {"differential"}
    assert drazin_index(np.eye(7), H).index == 0


def test_zero_E_is_index_one():
    rng = np.random.default_rng(4)
    H = rng.standard_normal((5, 5)) + 5 * np.eye(5)
    rep = analyze_pencil(np.zeros((5, 5)), H)
    assert rep.regular and rep.index == 1 and rep.infinite_blocks == (1,) * 5
    assert rep.n_dynamic == 0 and rep.finite_eigenvalues.size == 0
    assert set(rep.labels) == {"algebraic"}


def test_empty_pencil():
    rep = analyze_pencil(np.zeros((0, 0)), np.zeros((0, 0)))
    assert rep.regular and rep.index == 0 and rep.n == 0


def test_sparse_input_equals_dense():
    E, H, B, names = differentiator_cascade(2)
    dense = analyze_pencil(E, H, B=B)
    sparse = analyze_pencil(sp.csc_matrix(E), sp.csr_matrix(H), B=B)
    assert dense.index == sparse.index == 3
    assert dense.infinite_blocks == sparse.infinite_blocks
    assert dense.labels == sparse.labels


def test_bad_shapes_raise_value_error():
    with pytest.raises(ValueError, match="square"):
        analyze_pencil(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="same shape"):
        analyze_pencil(np.eye(2), np.eye(3))
    with pytest.raises(ValueError, match="non-finite"):
        analyze_pencil(np.eye(2), np.array([[np.nan, 0], [0, 1]]))
    with pytest.raises(ValueError, match="B must have shape"):
        analyze_pencil(np.eye(2), np.eye(2), B=np.ones((3, 1)))
    with pytest.raises(ValueError, match="names"):
        analyze_pencil(np.eye(2), np.eye(2), names=["a"])


# ---------------------------------------------------------------------------
# semi-explicit systems of index 1, 2, 3
# ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "index, blocks, eigs, labels",
    [
        (1, (1,), [-1.5], ("differential", "differential")),
        (2, (2,), [], ("algebraic", "index2")),
        (3, (3,), [], ("algebraic", "index2", "index3")),
    ],
)
def test_semi_explicit(index, blocks, eigs, labels):
    E, H, B = semi_explicit(index)
    rep = analyze_pencil(E, H, B=B)
    assert rep.regular and rep.index == index and rep.infinite_blocks == blocks
    assert rep.n_dynamic == len(eigs)
    for got, want in zip(rep.finite_eigenvalues, eigs):
        assert rel_err(got, want) / EIG_RTOL < 1
    assert rep.labels == labels
    assert list(rep.derivative_order) == [max(int(lb[5:]) - 1, 0) if lb.startswith("index") else 0 for lb in labels]
    assert drazin_index(E, H).index == index
    assert index_from_infe(ag08bd_structure(E, H)["infe"]) == index


def test_svd_form_split_of_index_one_system():
    E, H, _ = semi_explicit(1)
    form = svd_form(E, H, balance=False)
    assert form.orthogonal and form.n_y == 1 and form.n_z == 1
    assert np.allclose(form.U @ E @ form.V, np.diag([form.sigma[0], 0.0]), atol=1e-15)
    assert np.allclose(form.U @ H @ form.V, form.UHV, atol=1e-15)
    A11, A12, A21, A22 = form.semi_explicit()
    # index 1 <=> H22 invertible; eliminating z gives y' = (A11 - A12 A22^-1 A21) y
    assert abs(A22[0, 0]) > 0.1
    reduced = A11 - A12 @ np.linalg.solve(A22, A21)
    assert rel_err(reduced[0, 0], -1.5) / EIG_RTOL < 1


def test_svd_form_with_balancing_keeps_the_block_structure():
    E, H, B, _ = differentiator_cascade(1)
    form = svd_form(E, H)
    assert form.n_y == 1 and form.n_z == 5
    UEV = form.U @ E @ form.V
    target = np.zeros_like(E)
    target[0, 0] = form.sigma[0]
    assert np.max(np.abs(UEV - target)) <= 1e-15 * np.abs(form.sigma[0])
    assert np.allclose(form.U @ H @ form.V, form.UHV, rtol=1e-13, atol=1e-13 * np.abs(form.UHV).max())


# ---------------------------------------------------------------------------
# the differentiator circuit of Section 1.3
# ---------------------------------------------------------------------------
def test_ideal_differentiator():
    E, H, B, names = differentiator_cascade(1, G=1e-3, L=1e-3)
    rep = analyze_pencil(E, H, B=B, names=names)
    assert rep.regular and rep.index == 2
    assert rep.infinite_blocks == (2, 1, 1, 1, 1)
    assert rep.rank_E == 1
    # the inductor current is fixed by G V(t): no dynamic state at all
    assert rep.n_dynamic == 0
    labels = dict(zip(names, rep.labels))
    # u3 = o1 = -L G V' is the only unknown that depends on V'; the op-amp
    # output current ia1 = -il1 = -G V depends on V only
    assert labels == {
        "u1": "algebraic",
        "m1": "algebraic",
        "o1": "index2",
        "ia1": "algebraic",
        "il1": "algebraic",
        "iv": "algebraic",
    }
    oracle = ag08bd_structure(E, H)
    assert oracle["infe"] == rep.infinite_blocks and oracle["nfz"] == 0
    assert drazin_index(E, H).index == 2


@pytest.mark.parametrize("gain", [10.0, 1e5])
@pytest.mark.parametrize("G, L", [(1e-3, 1e-3), (1.0 / 4.7e3, 2.2e-6)])
def test_finite_gain_differentiator(gain, G, L):
    E, H, B, names = differentiator_cascade(1, G=G, L=L, gain=gain)
    rep = analyze_pencil(E, H, B=B, names=names)
    assert rep.regular and rep.index == 1 and rep.infinite_blocks == (1,) * 5
    assert rep.n_dynamic == 1
    # L il' = (1 + A) m and m = V - il/G  ->  lambda = -R (1 + A) / L
    want = -(1.0 + gain) / (G * L)
    assert rel_err(rep.finite_eigenvalues[0], want) / EIG_RTOL < 1
    labels = dict(zip(names, rep.labels))
    assert labels["u1"] == "algebraic"
    assert all(labels[nm] == "differential" for nm in ("m1", "o1", "ia1", "il1", "iv"))
    oracle = ag08bd_structure(E, H)
    assert oracle["infe"] == rep.infinite_blocks and oracle["nfz"] == 1


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_cascaded_ideal_differentiators(k):
    E, H, B, names = differentiator_cascade(k)
    rep = analyze_pencil(E, H, B=B, names=names)
    assert rep.regular and rep.index == k + 1 and rep.n_dynamic == 0
    assert rep.infinite_blocks[0] == k + 1 and sum(rep.infinite_blocks) == len(names)
    # hand derivation: o_j ~ V^(j), il_j ~ V^(j-1), ia_j ~ V^(j) (j < k), ia_k ~ V^(k-1)
    order = dict(zip(names, rep.derivative_order))
    for j in range(1, k + 1):
        assert order[f"o{j}"] == j
        assert order[f"il{j}"] == j - 1
        assert order[f"ia{j}"] == (j if j < k else k - 1)
        assert order[f"m{j}"] == 0
    assert order["u1"] == 0 and order["iv"] == 0
    assert rep.labels[names.index(f"o{k}")] == f"index{k + 1}"
    oracle = ag08bd_structure(E, H)
    assert oracle["infe"] == rep.infinite_blocks
    assert index_from_infe(oracle["infe"]) == rep.index
    assert drazin_index(E, H).index == k + 1


# ---------------------------------------------------------------------------
# the planar pendulum (1.15) and its formulations
# ---------------------------------------------------------------------------
PENDULUM = {
    # form: (index, infinite blocks, n_dynamic, number of zero eigenvalues)
    "index3": (3, (3, 3), 2, 0),
    "index1": (1, (1, 1), 6, 4),  # position and velocity drift: w'' = 0
    "index2": (2, (2, 2), 4, 2),  # position drift: w' = 0
    "ggl": (2, (2, 2, 2, 2), 2, 0),
}

#: Zero eigenvalues of the index-1 form sit in 2x2 Jordan blocks, so their
#: computed values are O(sqrt(eps)).
ZERO_EIG_ATOL = 1e-6


@pytest.mark.parametrize("form", list(PENDULUM))
def test_pendulum_at_the_hanging_equilibrium(form):
    index, blocks, n_dyn, n_zero = PENDULUM[form]
    E, H = pendulum_pencil(form, pendulum_hanging_state(form))
    rep = analyze_pencil(E, H)
    assert rep.regular and rep.index == index and rep.infinite_blocks == blocks
    assert rep.n_dynamic == n_dyn
    lam = rep.finite_eigenvalues
    small = np.abs(lam) < ZERO_EIG_ATOL
    assert np.count_nonzero(small) == n_zero
    osc = np.sort(lam[~small].imag)
    assert np.max(np.abs(lam[~small].real)) < EIG_RTOL * PEND_OMEGA
    assert np.max(np.abs(osc - [-PEND_OMEGA, PEND_OMEGA])) / PEND_OMEGA / EIG_RTOL < 1
    assert drazin_index(E, H).index == index
    oracle = ag08bd_structure(E, H)
    assert oracle["infe"] == blocks and oracle["nfz"] == n_dyn


@pytest.mark.parametrize("form", list(PENDULUM))
def test_pendulum_at_a_moving_configuration(form):
    index, blocks, n_dyn, _ = PENDULUM[form]
    x = pendulum_hanging_state(form)
    x = x + np.array([0.1, 0.2, 0.9, 0.4, -0.3, 0.7, 0.5, 0.1, 0.2, 0.3])[: x.size]
    E, H = pendulum_pencil(form, x)
    rep = analyze_pencil(E, H)
    assert rep.regular and rep.index == index and rep.infinite_blocks == blocks
    assert rep.n_dynamic == n_dyn
    assert drazin_index(E, H).index == index
    assert ag08bd_structure(E, H)["infe"] == blocks


def test_pendulum_through_a_dae_system():
    form = "index3"
    x0 = pendulum_hanging_state(form)
    E = pendulum_E(form, x0)
    system = FunctionDae(
        8,
        q=lambda x: E @ x,
        dq=lambda x: E,
        phi=lambda x, t: pendulum_residual(form, x),
        dphi=lambda x, t: complex_step_jacobian(lambda z: pendulum_residual(form, z), x),
        names=["r1", "r2", "alpha", "v1", "v2", "v3", "lambda1", "lambda2"],
    )
    rep = analyze_dae(system, x0, 0.0)
    assert rep.index == 3 and rep.infinite_blocks == (3, 3) and rep.n_dynamic == 2
    assert rep.names[-1] == "lambda2"
    # the multipliers depend on second derivatives of the constraint inputs
    assert rep.labels[-2:] == ("index3", "index3")


def test_linear_dae_system():
    E, H, B, names = differentiator_cascade(1)
    system = LinearDae(E, H, names=names)
    rep = analyze_dae(system, np.zeros(6), 0.0, B=B)
    assert rep.index == 2 and rep.labels[names.index("o1")] == "index2"


# ---------------------------------------------------------------------------
# singular pencils
# ---------------------------------------------------------------------------
def test_common_null_vector_is_singular():
    rng = np.random.default_rng(7)
    A = rng.standard_normal((5, 5))
    A[:, 2] = A[:, 0] - A[:, 4]  # null vector (1, 0, -1, 0, -1)
    rep = analyze_pencil(A, A)
    assert not rep.regular and rep.index is None
    assert rep.normal_rank == 4
    assert rep.right_indices == (0,) and rep.left_indices == (0,)
    assert rep.classification is None and rep.weierstrass is None
    assert rep.shift_check is not None and rep.shift_check.normal_rank == 4
    # the regular part: det(lambda A - A) restricted has the eigenvalue 1 four times
    assert rep.n_dynamic == 4
    oracle = ag08bd_structure(A, A)
    assert oracle["kronr"] == rep.right_indices and oracle["kronl"] == rep.left_indices
    with pytest.raises(SingularPencilError, match="singular"):
        weierstrass_form(A, A)
    with pytest.raises(SingularPencilError):
        drazin_index(A, A)


def test_singular_pencil_with_higher_minimal_indices():
    # blocks L_1 (1x2), L_1^T (2x1), a 2x2 infinite Jordan block and one finite eigenvalue -2
    from scipy.linalg import block_diag

    E0 = block_diag([[1.0, 0.0]], [[1.0], [0.0]], [[0.0, 1.0], [0.0, 0.0]], [[1.0]])
    H0 = block_diag([[0.0, 1.0]], [[0.0], [1.0]], np.eye(2), [[-2.0]])
    rng = np.random.default_rng(11)
    n = E0.shape[0]
    P = np.linalg.qr(rng.standard_normal((n, n)))[0]
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    rep = analyze_pencil(P @ E0 @ Q, P @ H0 @ Q)
    assert not rep.regular
    assert rep.right_indices == (1,) and rep.left_indices == (1,)
    assert rep.infinite_blocks == (2,)
    assert rep.n_dynamic == 1 and rel_err(rep.finite_eigenvalues[0], -2.0) / 1e-8 < 1
    oracle = ag08bd_structure(P @ E0 @ Q, P @ H0 @ Q)
    assert oracle["kronr"] == (1,) and oracle["kronl"] == (1,) and oracle["infe"] == (2,)


# ---------------------------------------------------------------------------
# tolerance and evidence
# ---------------------------------------------------------------------------
def test_tolerance_option_changes_a_close_rank_decision():
    E = np.array([[1.0, 1.0], [1.0, 1.0 + 1e-7]])
    H = np.eye(2)
    default = analyze_pencil(E, H)
    assert default.index == 0 and default.n_dynamic == 2
    loose = analyze_pencil(E, H, tol=1e-4)
    assert loose.index == 1 and loose.n_dynamic == 1
    first = loose.evidence[0]
    assert first.rank == 1 and first.dropped[0] < first.tol < first.kept[-1]
    assert loose.rtol == 1e-4


def test_evidence_records_every_rank_decision():
    E, H, B, names = differentiator_cascade(2)
    rep = analyze_pencil(E, H, B=B, names=names)
    # staircase: (E rank, H rank) per step; no finite part, so no final E check
    staircase = [d for d in rep.evidence if "staircase" in d.what]
    assert len(staircase) == 2 * rep.index
    for d in rep.evidence:
        assert d.tol > 0
        if d.dropped:
            assert d.dropped[0] <= d.tol
        if d.kept:
            assert d.kept[-1] > d.tol
    # clear decisions: the smallest kept singular value is far above the largest dropped one
    assert min(d.gap for d in staircase) > 1e10
    assert rep.balancing.applied


def test_report_to_dict_is_json():
    E, H, B, names = differentiator_cascade(1, gain=100.0)
    rep = analyze_pencil(E, H, B=B, names=names)
    data = json.loads(json.dumps(rep.to_dict()))
    assert data["index"] == 1 and data["n_dynamic"] == 1 and data["regular"] is True
    assert data["finite_eigenvalues"][0][0] == pytest.approx(rep.finite_eigenvalues[0].real)
    assert [u["name"] for u in data["classification"]["unknowns"]] == list(names)
    assert data["method"] == "kronecker"
    assert all("tol" in d and "kept" in d for d in data["evidence"])


# ---------------------------------------------------------------------------
# an MNA pencil with element values over 30 decades
# ---------------------------------------------------------------------------
def star_rc_with_cv_loop(m: int, seed: int):
    """Source node 1 (v1 = V, with C_x from node 1 to ground: a CV loop), and
    m - 1 nodes k each joined to node 1 by G_k and to ground by C_k.

    Unknowns v1..vm, iv. Exact eigenvalues -G_k / C_k; index 2 (iv = ... C_x V').
    Capacitances 1e-15..1e-3 F, time constants 1e-12..1e-2 s, so resistances
    span about 1e-9..1e13 ohm.
    """
    rng = np.random.default_rng(seed)
    C = 10.0 ** rng.uniform(-15, -3, m - 1)
    tau = 10.0 ** rng.uniform(-12, -2, m - 1)
    G = C / tau
    cx = 1e-15
    n = m + 1
    E = np.zeros((n, n))
    H = np.zeros((n, n))
    B = np.zeros((n, 1))
    E[0, 0] = cx  # KCL node 1: cx v1' = -sum G_k (v1 - v_k) - iv
    H[0, 0] = -G.sum()
    H[0, 1:m] = G
    H[0, m] = -1.0
    idx = np.arange(1, m)
    E[idx, idx] = C  # KCL node k: C_k v_k' = -G_k (v_k - v1)
    H[idx, idx] = -G
    H[idx, 0] = G
    H[m, 0] = 1.0  # source: 0 = v1 - V
    B[m, 0] = -1.0
    names = tuple(f"v{k}" for k in range(1, m + 1)) + ("iv",)
    return E, H, B, names, -G / C


#: The smallest of eigenvalues spread over ten decades keep this relative accuracy.
WIDE_EIG_RTOL = 1e-11


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_wide_range_element_values(seed):
    E, H, B, names, eigs = star_rc_with_cv_loop(12, seed)
    rep = analyze_pencil(E, H, B=B, names=names)
    assert rep.balancing.spread_before > 12
    assert rep.regular and rep.index == 2 and rep.infinite_blocks == (2,)
    assert rep.balancing.applied
    # only the (weaker) random-shift cross-check may object at this spread
    assert all(w.startswith("random-shift") for w in rep.warnings)
    assert rep.n_dynamic == len(eigs)
    got = np.sort(rep.finite_eigenvalues.real)
    assert np.max(np.abs(rep.finite_eigenvalues.imag)) == 0.0
    assert np.max(np.abs(got - np.sort(eigs)) / np.abs(np.sort(eigs))) / WIDE_EIG_RTOL < 1
    labels = dict(zip(names, rep.labels))
    assert labels["iv"] == "index2" and labels["v1"] == "algebraic"
    assert all(labels[f"v{k}"] == "differential" for k in range(2, 13))


#: Two PMOS transistors and a diode with series resistance between the inputs (a random circuit of
#: tests/test_random_nonlinear.py): the voltage-source-capacitor loops give index 2, whatever the overlap
#: capacitances. At cgso = cgdo = 0.2n (8e-16 F on m1) the balanced pencil drops a staircase singular
#: value 16 times below its tolerance (index 3); the unbalanced one keeps it by a factor 5e9.
OVERLAP = """random nonlinear circuit 44
vdd vdd 0 dc 5
vin in 0 dc 0 pulse(0 3.41 0.2u 8.87e-09 6.32e-08 1u 2.5u)
r1 n1 0 1.744e+04
r2 n2 n1 6150
r3 n3 0 421.8
c1 n2 vdd 3.9e-11
m1 0 in n1 vdd mp w=4.01e-06 l=2.95e-06
d1 n1 in dx
m2 in n1 n3 vdd mp w=1.81e-05 l=2.49e-06
.model dx d (is=1e-14 n=1.05 rs=10 cjo=2p vj=0.7 m=0.4 tt=5n bv=50 ibv=1e-6)
.model mp pmos (level=1 vto=-0.7 kp=50u gamma=0.5 lambda=0.05 phi=0.7 cgso={ov} cgdo={ov} cbd=10f cbs=10f)
.tran 10n 5u
.end
"""


@pytest.mark.parametrize("overlap", ["0.2n", "2n", "20n"])
def test_small_overlap_capacitance_does_not_raise_the_index(overlap):
    from netdae.analyses.index import analyze_index
    rep = analyze_index(netdae.load(OVERLAP.replace("{ov}", overlap)))
    assert rep.index == 2
    assert rep.unknowns["i(vdd)"] == "index2" and rep.unknowns["i(vin)"] == "index2"
    assert rep.unknowns["v(d1#internal)"] == "differential"


def test_close_call_is_not_won_by_a_rounding_value_the_unbalanced_tolerance_cannot_see():
    """A V source and a CCVS reading it in parallel (n2-n4), tied by R6 and V5 to node n3, which an
    inductor alone joins to ground: the cutset {L1} forces i(l1) = 0 and v(n3) = L1 i(l1)' = 0, so
    the pencil has index 2 and no finite eigenvalue (SLICOT agrees). Balanced, the last E block's
    singular value is rounding 4 times below the tolerance (a close call); the unbalanced re-decision
    kept 4.3e-17 (143 eps of ||E||, leaked from the compression of H, whose entries span 1513 ohm to
    2 mS) as an inductance with margin 17.9 and was reported: index 1, a pole at -1.2e16 1/s.
    """
    L, g, r = 0.001342, 1 / 483.1, 1513.0
    # unknowns v(n3) v(n2) v(n4) v(n1) i(l1) i(v3) i(h4) i(v5); node rows are the currents entering
    E = np.zeros((8, 8))
    E[4, 4] = L  # L1 from 0 to n3: L i' = v(0) - v(n3)
    H = np.zeros((8, 8))
    H[0, 4], H[0, 7] = 1, -1                              # n3: i(l1) in, i(v5) out
    H[1, [1, 3, 5, 6]] = -g, g, -1, -1                    # n2: R6 to n1, V3 and H4 out
    H[2, [5, 6]] = 1, 1                                   # n4: V3 and H4 in
    H[3, [1, 3, 7]] = g, -g, 1                            # n1: R6, i(v5) in
    H[4, 0] = -1                                          # L1: L i' = -v(n3)
    H[5, [1, 2]] = 1, -1                                  # V3: v(n2) - v(n4) = V
    H[6, [1, 2, 5]] = 1, -1, -r                           # H4: v(n2) - v(n4) = r i(v3)
    H[7, [0, 3]] = 1, -1                                  # V5: v(n3) - v(n1) = V
    ref = ag08bd_structure(E, H)
    assert index_from_infe(ref["infe"]) == 2 and ref["nfz"] == 0
    rep = analyze_pencil(E, H)
    assert rep.regular and rep.index == 2 and rep.n_dynamic == 0, rep.warnings
    assert rep.finite_eigenvalues.size == 0


def test_close_call_is_not_won_by_a_rounding_value_in_an_h_block():
    """Nodes n1, n2, n3 reach ground only through the current source I3 (G1 between n3 and n1 reads
    v(n2) against ground, L4 from n3 to n2, R2 between n2 and n1, I5 between n1 and n2): the three
    current laws add up to a row without unknowns, 0 = I3, so the pencil is singular for any element
    values. Balanced, that is a close call (margin 8); unbalanced, the H block of staircase step 2 kept
    5.3e-13 (rounding of 1/R2 - g1, turned by a compression of H whose kept singular values go down to
    4.9e-4) with margin 300, and the pencil was reported regular of index 2.
    """
    g, G, L = 0.0006335, 1 / 1101, 0.004111
    # unknowns v(n3) v(n1) v(n2) i(l4); node rows are the currents entering
    E = np.zeros((4, 4))
    E[3, 3] = L
    H = np.array([
        [0.0, 0.0, g, -1.0],       # n3: G1 (g v(n2) in), L4 out (I3 in: a source term)
        [0.0, -G, G - g, 0.0],     # n1: R2, G1 (-g v(n2) in)
        [0.0, G, -G, 1.0],         # n2: R2, L4 in
        [1.0, 0.0, -1.0, 0.0],     # L4: L i' = v(n3) - v(n2)
    ])
    assert abs(H[:3].sum(axis=0)).max() < 1e-18  # the cutset's current laws add up to zero (to rounding)
    rep = analyze_pencil(E, H)
    assert rep.regular is False and rep.index is None, rep.warnings


def test_unexcited_nilpotent_part_does_not_label_unknowns_index2():
    """Nodes n1, n2, n4 reach the rest only through L1 (n3-n4): the cutset forces i(l1) = 0, so
    v(n4) = v(n3), v(n2) = v(n4) (R3 carries no current) and v(n1) = v(n2) - (the C6-L5 loop's state),
    where v(n3) = integral of I8 / C4: index 2, three states, but no unknown depends on an input's
    derivative (I7 runs inside the cut-off set, I8 outside it). The classification measured
    V2 N U2 B against a threshold scaled by ||U2 B||, which is rounding when no input excites the
    nilpotent part, and labelled v(n4), v(n2), v(n1) index2 (weights 1e11 to 3e11).
    """
    C4, C6, L1, L5, g = 3.309e-08, 4.805e-06, 0.3096, 0.09246, 1 / 8.858
    # unknowns v(n3) v(n4) v(n2) v(n1) i(l1) i(l5); node rows are the currents entering; inputs I7, I8
    E = np.zeros((6, 6))
    E[0, 0] = C4
    E[2:4, 2:4] = [[C6, -C6], [-C6, C6]]
    E[4, 4], E[5, 5] = L1, L5
    H = np.zeros((6, 6))
    H[0, 4] = -1                        # n3: L1 out (C4 to ground, I8 in)
    H[1, [1, 2, 4]] = -g, g, 1          # n4: R3, L1 in
    H[2, [1, 2, 5]] = g, -g, -1         # n2: R3, L5 out (C6, I7 out)
    H[3, 5] = 1                         # n1: L5 in (C6, I7 in)
    H[4, [0, 1]] = 1, -1                # L1: L i' = v(n3) - v(n4)
    H[5, [2, 3]] = 1, -1                # L5: L i' = v(n2) - v(n1)
    B = np.zeros((6, 2))
    B[2, 0], B[3, 0], B[0, 1] = -1, 1, 1
    names = ["v(n3)", "v(n4)", "v(n2)", "v(n1)", "i(l1)", "i(l5)"]
    rep = analyze_pencil(E, H, B=B, names=names)
    assert rep.regular and rep.index == 2 and rep.n_dynamic == 3
    labels = dict(zip(names, rep.labels))
    assert labels == {"v(n3)": "differential", "v(n4)": "differential", "v(n2)": "differential",
                      "v(n1)": "differential", "i(l1)": "algebraic", "i(l5)": "differential"}, labels


def test_a_kept_value_within_the_leak_of_rounding_is_a_close_call():
    """V1 (n3-n4) and a VCVS E6 (n4-n3, reading v(n4) - v(n1)) in a loop, a CCVS H2 reading i(v1): the two
    voltage laws fix v(n1) - v(n4) = V / g, so the current law of n1 fixes i(l7) = -V / (g R8) while L7
    needs L i(l7)' = V (1/g - 1): no solution for a generic V, a singular pencil. Balanced, the staircase
    kept a step-2 E singular value of 2.1e-12 with margin 178 against the tolerance, but the compression of
    H before it can leak 6.8e-10 of rounding into that block; no close call was seen, the unbalanced pencil
    (singular, margin 11.9) was not consulted, and the pencil was reported regular of index 1.
    """
    G3, C5, g, L, G8, r = 1 / 2.093e4, 3.953e-07, 0.05568, 0.01229, 1 / 3.216e4, 10.22
    # unknowns v(n1) v(n2) v(n3) v(n4) i(v1) i(h2) i(e6) i(l7); node rows are the currents entering
    E = np.zeros((8, 8))
    E[2, 2], E[7, 7] = C5, L
    H = np.zeros((8, 8))
    H[0, [0, 3, 7]] = -G8, G8, -1                 # n1: R8, L7 out
    H[1, [1, 5]] = -G3, -1                        # n2: R3, H2 out
    H[2, [4, 6, 7]] = -1, 1, 1                    # n3: V1 out, E6 in, L7 in (C5 to ground)
    H[3, [0, 3, 4, 5, 6]] = G8, -G8, 1, 1, -1     # n4: R8, V1 in, H2 in, E6 out
    H[4, [2, 3]] = 1, -1                          # V1: v(n3) - v(n4) = V
    H[5, [1, 3, 4]] = 1, -1, -r                   # H2: v(n2) - v(n4) = r i(v1)
    H[6, [0, 2, 3]] = g, -1, 1 - g                # E6: v(n4) - v(n3) = g (v(n4) - v(n1))
    H[7, [0, 2]] = 1, -1                          # L7: L i' = v(n1) - v(n3)
    out = slycot.ag08bd(8, 8, 0, 0, np.asfortranarray(H), np.asfortranarray(E), np.zeros((8, 1)),
                        np.zeros((1, 8)), np.zeros((1, 1)))
    assert out[2] == 7  # SLICOT: normal rank 7, a singular pencil
    assert analyze_pencil(E, H).regular is False
    # the same circuit as netdae assembles it (its own scaling of rows and unknowns)
    from netdae.analyses.index import analyze_index

    rep = analyze_index(netdae.load("""loop of V1 and E6, H2 reading i(v1)
V1 n3 n4 SIN(0 1 1k)
H2 n2 n4 V1 10.22
R3 n2 0 2.093e+04
C5 n3 0 3.953e-07
E6 n4 n3 n4 n1 0.05568
L7 n1 n3 0.01229
R8 n1 n4 3.216e+04
.end
"""))
    assert rep.regular is False and rep.index is None, rep.pencil.warnings
