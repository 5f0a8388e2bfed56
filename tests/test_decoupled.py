"""Weierstrass form (2.9), decoupled solution (2.11)/(2.12), consistency and classification."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import block_diag
from test_pencil_examples import cascade_solution, differentiator_cascade, semi_explicit, sine_derivative
from test_pencil_oracle import CASES, eig_error, structured_pencil

from netdae.dae.decoupled import solve_nilpotent_stein
from netdae.dae.pencil import analyze_pencil, weierstrass_form

#: Residuals of the decoupling relative to ||U|| ||E|| ||V|| are rounding-level;
#: asserted in units of this tolerance.
FORM_RTOL = 1e-12

#: Closed-form waveforms are reproduced to this relative accuracy (of the
#: largest value of each waveform).
WAVE_RTOL = 1e-10


def form_residuals(wf, E, H):
    nf = wf.n_finite
    target_E = block_diag(np.eye(nf), wf.N)
    target_H = block_diag(wf.C, np.eye(wf.n_infinite))
    scale_E = np.linalg.norm(wf.U) * np.linalg.norm(E) * np.linalg.norm(wf.V)
    scale_H = np.linalg.norm(wf.U) * np.linalg.norm(H) * np.linalg.norm(wf.V)
    return (
        np.linalg.norm(wf.U @ E @ wf.V - target_E) / scale_E,
        np.linalg.norm(wf.U @ H @ wf.V - target_H) / scale_H,
    )


# ---------------------------------------------------------------------------
# the form itself
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["qz", "schur"])
@pytest.mark.parametrize("nf, sizes", CASES)
def test_weierstrass_form_of_random_pencils(nf, sizes, method):
    E, H, eigs = structured_pencil(7, nf, sizes)
    wf = weierstrass_form(E, H, finite_method=method)
    assert wf.n_finite == nf and wf.index == max(sizes, default=0)
    res_E, res_H = form_residuals(wf, E, H)
    assert res_E / FORM_RTOL < 1 and res_H / FORM_RTOL < 1
    # N exactly strictly upper triangular and nilpotent of the right index
    assert np.all(np.tril(wf.N) == 0.0)
    if wf.index:
        assert np.all(np.linalg.matrix_power(wf.N, wf.index) == 0.0)
        assert np.any(np.linalg.matrix_power(wf.N, wf.index - 1) != 0.0)
    # C in real Schur form with the known eigenvalues
    assert np.all(np.tril(wf.C, -2) == 0.0)
    assert eig_error(wf.eigenvalues, eigs) < 1e-10
    assert eig_error(np.linalg.eigvals(wf.C), eigs) < 1e-9
    n = E.shape[0]
    assert np.linalg.norm(wf.V @ wf.V_inv - np.eye(n)) / np.linalg.cond(wf.V) < 1e-13
    if nf:
        assert wf.finite_method == method


def test_nilpotent_stein_against_kronecker_vectorization():
    rng = np.random.default_rng(2)
    blocks = (3, 2, 2)
    p = sum(blocks)
    N = np.triu(rng.standard_normal((p, p)), 1)
    bounds = np.cumsum((0,) + blocks)
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        N[lo:hi, lo:hi] = 0.0  # strictly block upper triangular
    q = 4
    C = rng.standard_normal((q, q))
    F = rng.standard_normal((p, q))
    X = solve_nilpotent_stein(N, C, F, blocks)
    # vec(X - N X C) = (I - C^T kron N) vec(X), column-major vec
    A = np.eye(p * q) - np.kron(C.T, N)
    X_ref = np.linalg.solve(A, F.flatten(order="F")).reshape((p, q), order="F")
    assert np.max(np.abs(X - X_ref)) / np.max(np.abs(X_ref)) < 1e-13


# ---------------------------------------------------------------------------
# the decoupled solution (2.12)
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_cascade_waveforms_from_the_nilpotent_part(k):
    # L G omega = 2: every stage's output has amplitude 2^j (currents G 2^j)
    G, L, omega = 1e-3, 4.0, 500.0
    E, H, B, names = differentiator_cascade(k, G, L)
    wf = weierstrass_form(E, H)
    assert wf.n_finite == 0 and wf.index == k + 1
    t = np.linspace(0.0, 0.2, 41)
    # c^(l)(t) = B V^(l)(t), stacked as (k+1, n, len(t))
    c_derivs = np.array([B @ sine_derivative(omega, t, l)[None, :] for l in range(wf.index)])
    x = wf.combine(np.zeros((0, t.size)), wf.nilpotent_from_inputs(c_derivs))
    exact = cascade_solution(k, G, L, omega, t)
    scale = np.max(np.abs(exact), axis=1, keepdims=True)
    zero = scale[:, 0] == 0  # the inverting inputs m_j are identically zero
    assert np.all(zero == np.array([nm.startswith("m") for nm in names]))
    assert np.max(np.abs(x[~zero] - exact[~zero]) / scale[~zero]) / WAVE_RTOL < 1
    assert np.max(np.abs(x[zero])) / np.max(scale) / WAVE_RTOL < 1
    # u3 = o1 = -L G V' (the notes' closed form)
    assert np.max(np.abs(x[names.index("o1")] + L * G * omega * np.cos(omega * t))) / (L * G * omega) < WAVE_RTOL


def test_semi_explicit_index_three_needs_second_derivatives():
    E, H, B = semi_explicit(3)
    wf = weierstrass_form(E, H)
    t = np.linspace(0.0, 1.0, 5)
    u = [np.exp(2 * t), 2 * np.exp(2 * t), 4 * np.exp(2 * t)]
    c = np.array([B @ ul[None, :] for ul in u])
    x = wf.combine(np.zeros((0, t.size)), wf.nilpotent_from_inputs(c))
    assert np.allclose(x, np.array(u), rtol=1e-13, atol=0)
    with pytest.raises(ValueError, match="derivatives"):
        wf.nilpotent_from_inputs(c[:2])


def test_finite_gain_differentiator_step_response_through_the_decoupled_system():
    """y' = C y + delta solved exactly; x = V1 y + V2 z against the circuit's closed form."""
    G, L, A, V0 = 1e-3, 1e-3, 50.0, 2.0
    E, H, B, names = differentiator_cascade(1, G, L, gain=A)
    wf = weierstrass_form(E, H)
    assert wf.n_finite == 1 and wf.index == 1
    c = (B * V0)[:, 0]
    il0 = 0.0
    x0 = np.zeros(6)
    x0[names.index("il1")] = il0
    y0, _ = wf.split(x0)
    lam = wf.C[0, 0]
    delta = wf.U1 @ c
    t = np.linspace(0.0, 5.0 / abs(lam), 11)
    y = np.exp(lam * t) * y0[0] + (np.exp(lam * t) - 1.0) / lam * delta[0]
    z = wf.nilpotent_from_inputs(np.repeat(c[None, :, None], t.size, axis=2))
    x = wf.combine(y[None, :], z)
    # hand solution: il' = lam il + (1 + A) V0 / L, lam = -(1 + A) / (L G)
    lam_exact = -(1 + A) / (L * G)
    il = G * V0 * (1.0 - np.exp(lam_exact * t))
    m = V0 - il / G
    exact = {"u1": V0 + 0 * t, "m1": m, "o1": -A * m, "ia1": -il, "il1": il, "iv": -il}
    for nm, want in exact.items():
        got = x[names.index(nm)]
        assert np.max(np.abs(got - want)) / np.max(np.abs(want)) / WAVE_RTOL < 1, nm


# ---------------------------------------------------------------------------
# consistent initial values
# ---------------------------------------------------------------------------
def test_index_two_consistency_explicit_and_hidden_constraint():
    E, H, B = semi_explicit(2)  # y' = -y + z, 0 = y - u: y = u, z = u' + u
    wf = weierstrass_form(E, H)
    t0 = 0.3

    def c_derivs(l):
        return (B @ [sine_derivative(1.0, t0, l)]).ravel()

    exact = np.array([np.sin(t0), np.cos(t0) + np.sin(t0)])
    ok = wf.check_consistency(exact, c_derivs)
    assert ok.consistent and ok.affected == ()
    assert np.max(np.abs(ok.dx)) < 1e-15

    bad_z = wf.check_consistency(exact - [0.0, 0.25], c_derivs)  # violates the hidden constraint
    assert not bad_z.consistent and bad_z.affected == (1,)
    assert bad_z.affected_by_order == ((), (1,))
    assert bad_z.violation_by_order[1] == pytest.approx(0.25, rel=1e-14)
    assert np.allclose(bad_z.x_consistent, exact, rtol=1e-15)

    bad_y = wf.check_consistency(exact + [0.1, 0.0], c_derivs)  # violates the explicit constraint
    assert bad_y.affected == (0,) and bad_y.affected_by_order == ((0,), ())
    assert bad_y.violation_by_order[0] == pytest.approx(0.1, rel=1e-14)
    assert np.allclose(wf.consistent_initial_value(exact + [0.1, 0.0], c_derivs), exact, rtol=1e-15)


def test_differentiator_operating_point_is_inconsistent_when_the_source_moves():
    G, L, omega, t0 = 1e-3, 1e-3, 100.0, 0.002
    E, H, B, names = differentiator_cascade(1, G, L)
    wf = weierstrass_form(E, H)

    def c_derivs(l):
        return (B @ [sine_derivative(omega, t0, l)]).ravel()

    exact = cascade_solution(1, G, L, omega, t0)[:, 0]
    dc_like = exact.copy()
    dc_like[names.index("o1")] = 0.0  # a DC operating point ignores V'(t0)
    rep = wf.check_consistency(dc_like, c_derivs)
    o1 = names.index("o1")
    assert not rep.consistent and rep.affected == (o1,)
    assert rep.affected_by_order == ((), (o1,))
    assert rep.violation_by_order[1] == pytest.approx(L * G * omega * abs(np.cos(omega * t0)), rel=1e-12)
    assert np.max(np.abs(rep.x_consistent - exact)) < 1e-12 * np.max(np.abs(exact))
    assert wf.check_consistency(exact, c_derivs).consistent


def test_a_steady_start_violates_only_what_the_input_derivatives_make():
    # an operating point solves the DC equations up to its solver's residual; judged as a steady state
    # (steady=True) only the inputs' derivatives at t0 can make it inconsistent
    G, L, omega, t0 = 1e-3, 1e-3, 100.0, 0.002
    E, H, B, names = differentiator_cascade(1, G, L)
    wf = weierstrass_form(E, H)
    o1 = names.index("o1")

    def moving(l):
        return (B @ [sine_derivative(omega, t0, l)]).ravel()

    exact = cascade_solution(1, G, L, omega, t0)[:, 0]
    dc_like = exact.copy()
    dc_like[o1] = 0.0  # the DC operating point of the source's value at t0: a steady state
    full = wf.check_consistency(dc_like, moving)
    steady = wf.check_consistency(dc_like, moving, steady=True)
    assert steady.affected == full.affected == (o1,) and steady.affected_by_order == ((), (o1,))
    assert np.max(np.abs(steady.x_consistent - full.x_consistent)) < 1e-12 * np.max(np.abs(exact))

    value = moving(0)

    def constant(l):  # the same value at t0, not changing there
        return value if l == 0 else np.zeros_like(value)

    # the steady state off by a residual in an explicit constraint (a Newton tolerance's worth): the
    # full check measures it, the steady one leaves it (it is no hidden constraint the inputs impose)
    off = dc_like.copy()
    off[names.index("u1")] += 1e-7
    assert not wf.check_consistency(off, constant).consistent
    rep = wf.check_consistency(off, constant, steady=True)
    assert rep.consistent and rep.violation_by_order == (0.0, 0.0) and np.all(rep.dx == 0.0)


def test_index_one_consistency_keeps_the_inductor_flux():
    G, L, A, V0 = 1e-3, 1e-3, 20.0, 1.5
    E, H, B, names = differentiator_cascade(1, G, L, gain=A)
    wf = weierstrass_form(E, H)
    c = (B * V0)[:, 0]
    rng = np.random.default_rng(4)
    x0 = rng.standard_normal(6)
    rep = wf.check_consistency(x0, lambda l: c)
    xc = rep.x_consistent
    il = names.index("il1")
    assert xc[il] == pytest.approx(x0[il], rel=1e-14)  # the state (flux L il) is kept
    m = V0 - x0[il] / G
    want = {"u1": V0, "m1": m, "o1": -A * m, "ia1": -x0[il], "iv": -x0[il]}
    for nm, v in want.items():
        # backward-stable transformations: a few thousand eps, depending on the BLAS's rounding
        assert xc[names.index(nm)] == pytest.approx(v, rel=1e-10, abs=1e-15), nm
    # the algebraic equations hold to rounding (normwise backward error)
    algebraic_rows = np.flatnonzero(~E.any(axis=1))
    size = np.linalg.norm(H, np.inf) * np.max(np.abs(xc)) + np.max(np.abs(c))
    assert np.max(np.abs((H @ xc + c)[algebraic_rows])) / size < 1e-15
    assert set(rep.affected) == {names.index(nm) for nm in ("u1", "m1", "o1", "ia1", "iv")}
    assert rep.affected_by_order[0] == rep.affected  # index 1: explicit constraints only
    assert wf.check_consistency(xc, lambda l: c).consistent


# ---------------------------------------------------------------------------
# classification with an input matrix
# ---------------------------------------------------------------------------
def test_classification_counts_only_excited_directions():
    # y' = -y + z + u, 0 = y: the constraint is not driven, so z = -u (no derivative)
    E, H, _ = semi_explicit(2)
    B = np.array([[1.0], [0.0]])
    driven = analyze_pencil(E, H, B=B)
    every = analyze_pencil(E, H)
    assert driven.index == every.index == 2
    assert every.labels == ("algebraic", "index2")
    assert driven.labels == ("algebraic", "algebraic")
    assert list(driven.derivative_order) == [0, 0]
    assert driven.classification.excited_only and not every.classification.excited_only


def test_classification_weights_are_reported_in_threshold_units():
    E, H, B, names = differentiator_cascade(2)
    rep = analyze_pencil(E, H, B=B, names=names)
    w = rep.classification.weights
    assert w.shape == (len(names), rep.index + 1)
    o2 = names.index("o2")
    # o2 = (L G)^2 V'': its m = 2 column is far above the threshold, higher ones absent
    assert w[o2, 3] > 1e6 and rep.derivative_order[o2] == 2
    m1 = names.index("m1")
    assert np.all(w[m1] <= 1.0)  # m1 = 0 identically


def test_decoupling_of_a_dae_with_sparse_input():
    E, H, B, names = differentiator_cascade(1)
    wf = weierstrass_form(sp.csc_matrix(E), sp.csc_matrix(H))
    res_E, res_H = form_residuals(wf, E, H)
    assert res_E / FORM_RTOL < 1 and res_H / FORM_RTOL < 1
    assert sla.norm(wf.N @ wf.N) == 0.0 and wf.index == 2
