"""The FLC-BDF method's formulas (the compiled kernels both integrators call), its helpers and dense output."""

from __future__ import annotations

import numpy as np
import pytest

from netdae.dae.bdf.history import History
from netdae.dae.bdf_kernels import differences_from_samples, merge_breakpoints, predictor_weights
from netdae.dae.compiled.control import (
    NORM_MAX,
    NORM_RMS,
    error_norms,
    flc_coefficients,
    landing_step,
    set_weights,
    weighted_norm,
)
from netdae.dae.dense import Interpolant

MAXORD = 5


def _coefficients(h, k, psi_old):
    psi = np.array(psi_old, dtype=float)
    alpha, beta, gamma, sigma = (np.zeros(MAXORD + 1) for _ in range(4))
    cj, ck = flc_coefficients(h, k, psi, psi, alpha, beta, gamma, sigma)
    return psi, alpha, beta, gamma, sigma, cj, ck


@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_constant_step_coefficients_are_the_classical_bdf(k):
    h = 0.3
    psi, alpha, beta, gamma, sigma, cj, ck = _coefficients(h, k, [(i + 1) * h for i in range(MAXORD + 1)])
    np.testing.assert_allclose(beta[: k + 1], 1.0)
    np.testing.assert_allclose(psi[: k + 1], [(i + 1) * h for i in range(k + 1)])
    assert cj == pytest.approx(sum(1.0 / j for j in range(1, k + 1)) / h)
    assert ck == pytest.approx(1.0 / (k + 1))
    assert sigma[k] == pytest.approx(1.0 / (k + 1))


def _run_flc_on_polynomial(k, degree, steps, seed=0):
    """March x' = p'(t) with the FLC formulas over variable steps; return max |x - p|."""
    rng = np.random.default_rng(seed)
    p = np.polynomial.Polynomial(rng.normal(size=degree + 1))
    dp = p.deriv()
    h0 = 0.1
    t = 0.0
    hist = History(1, 1, MAXORD)
    hist.from_samples(h0, p(h0 * np.arange(-k, 1))[:, None])
    worst = 0.0
    for h in steps:
        hist.set_coefficients(h)
        x_pred, xp_pred = hist.predict()[:, 0]
        # corrector for x' = f(t): cj (x - x_pred) + x'_pred = f(t_new)
        x_new = x_pred + (dp(t + h) - xp_pred) / hist.cj
        hist.accept(h)
        hist.update(np.array([x_new - x_pred]), k)
        t += h
        worst = max(worst, abs(x_new - p(t)), abs(hist.P[0, 0] - p(t)))
    return worst


@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_flc_bdf_is_exact_for_polynomials_of_its_order_with_variable_steps(k):
    steps = [0.1, 0.13, 0.07, 0.2, 0.05, 0.11, 0.3, 0.09]
    assert _run_flc_on_polynomial(k, k, steps) < 1e-11
    # and not for one degree more (the test can fail)
    assert _run_flc_on_polynomial(k, k + 1, steps) > 1e-8


@pytest.mark.parametrize("kind", [NORM_RMS, NORM_MAX])
def test_error_norms_match_direct_computation(kind):
    rng = np.random.default_rng(2)
    n = 7
    ee = rng.normal(size=2 * n)  # only the first n (the unknowns) count
    P = rng.normal(size=(6, 2 * n))
    w = rng.uniform(1, 2, size=n)
    k = 4
    d1 = ee[:n] + P[k, :n]
    d2 = d1 + P[k - 1, :n]
    direct = ((lambda v: np.sqrt(np.mean((v * w) ** 2))) if kind == NORM_RMS
              else (lambda v: np.max(np.abs(v * w))))
    np.testing.assert_allclose(error_norms(ee, P, k, w, kind, n), [direct(v) for v in (ee[:n], d1, d2)],
                               rtol=1e-14)
    assert error_norms(ee, P, 1, w, kind, n)[1:] == (0.0, 0.0)
    assert error_norms(ee, P, 2, w, kind, n)[2] == 0.0
    assert weighted_norm(ee[:n], w, kind) == pytest.approx(direct(ee[:n]), rel=1e-14)


def test_norms_propagate_nan_and_handle_empty_vectors():
    v = np.array([1.0, np.nan, 2.0])
    w = np.ones(3)
    assert np.isnan(weighted_norm(v, w, NORM_RMS)) and np.isnan(weighted_norm(v, w, NORM_MAX))
    assert weighted_norm(np.empty(0), np.empty(0), NORM_RMS) == 0.0


@pytest.mark.parametrize("relref", [0, 1, 2])
def test_set_weights_matches_the_formula(relref):
    rng = np.random.default_rng(3)
    x = rng.normal(size=5)
    xmax = np.abs(rng.normal(size=5)) * 3
    atol = np.full(5, 1e-6)
    mask = np.array([1.0, 1.0, 0.0, 1.0, 1.0])
    w, w_err, xm = np.empty(5), np.empty(5), xmax.copy()
    set_weights(x, 1e-3, atol, relref, xm, mask, w, w_err)
    ref = [np.abs(x), np.maximum(xmax, np.abs(x)), np.maximum(np.abs(x), 0.1 * np.maximum(xmax, np.abs(x)))][relref]
    np.testing.assert_array_equal(w, 1.0 / (1e-3 * ref + atol))
    np.testing.assert_array_equal(w_err, w * mask)


def test_predictor_weights_rows():
    np.testing.assert_array_equal(predictor_weights(np.array([0.0, 2.0, 3.0, 9.0]), 2), [[1, 1, 1], [0, 2, 3]])


def test_backward_differences_of_samples():
    y = np.array([[1.0, 0.0], [2.0, 1.0], [4.0, 4.0], [8.0, 9.0]])
    d = differences_from_samples(y)
    np.testing.assert_array_equal(d[:, 0], [8.0, 4.0, 2.0, 1.0])
    np.testing.assert_array_equal(d[:, 1], [9.0, 5.0, 2.0, 0.0])


def test_breakpoint_helpers():
    bp = merge_breakpoints(0.0, 10.0, [3.0, -1.0, 3.0, 12.0, 5.0, 5.0 + 1e-12, 1e-12], 1e-9)
    np.testing.assert_array_equal(bp, [3.0, 5.0 + 1e-12, 10.0])
    assert merge_breakpoints(0.0, 1.0, [], 1e-9).tolist() == [1.0]
    assert landing_step(1.0, 1.1, 0.1, True) == (1.1, True)
    assert landing_step(1.0, 0.4, 0.1, True) == (0.4, True)
    assert landing_step(1.0, 1.8, 0.1, True) == (0.9, False)
    assert landing_step(1.0, 1.8, 0.1, False) == (1.0, False)


# --------------------------------------------------------------------------- dense output
def _interpolant_for(poly, t, order):
    orders = np.minimum(np.arange(t.size), order)
    return Interpolant(t, orders, np.column_stack([poly(t), 2.0 * poly(t)]), ("a", "b"))


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5])
def test_interpolant_is_exact_for_polynomials_of_its_order(order):
    rng = np.random.default_rng(order)
    t = np.cumsum(np.concatenate([[0.0], rng.uniform(0.05, 0.3, 25)]))
    poly = np.polynomial.Polynomial(rng.normal(size=order + 1))
    f = _interpolant_for(poly, t, order)
    tq = rng.uniform(t[order], t[-1], 500)
    np.testing.assert_allclose(f(tq)[:, 0], poly(tq), rtol=0, atol=1e-9 * np.abs(poly(tq)).max())
    np.testing.assert_allclose(f(tq, ["B"])[:, 0], 2.0 * poly(tq), rtol=0, atol=2e-9 * np.abs(poly(tq)).max())


def test_interpolant_uses_the_step_ending_at_a_boundary_and_only_its_points():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    x = np.array([[0.0], [1.0], [0.0], [5.0]])
    # order 1 everywhere: piecewise linear, a step boundary returns the stored value
    f = Interpolant(t, np.array([0, 1, 1, 1]), x, ("y",))
    np.testing.assert_allclose(f([1.0, 1.5, 2.5])[:, 0], [1.0, 0.5, 2.5])
    # the third step is order 2: the parabola through t = 1, 2, 3
    g = Interpolant(t, np.array([0, 1, 1, 2]), x, ("y",))
    assert g(2.5)[0] == pytest.approx(1.75)
    assert g(1.5)[0] == pytest.approx(0.5)


def test_interpolant_vectorised_matches_pointwise_and_checks_range():
    rng = np.random.default_rng(7)
    t = np.cumsum(np.concatenate([[0.0], rng.uniform(0.1, 0.2, 40)]))
    x = rng.normal(size=(t.size, 3))
    orders = np.minimum(np.arange(t.size), rng.integers(1, 6, t.size))
    f = Interpolant(t, orders, x, ("a", "b", "c"))
    tq = np.sort(rng.uniform(t[0], t[-1], 300))
    np.testing.assert_allclose(f(tq), np.array([f(s) for s in tq]), rtol=0, atol=1e-13)
    with pytest.raises(ValueError, match="available"):
        f([t[-1] + 1.0])
    with pytest.raises(ValueError, match="no saved component"):
        f(tq, ["d"])


def test_compiled_dense_output_is_the_numpy_reference():
    """The compiled evaluation (``compiled/dense.py``) against the vectorised numpy form, with jumps and
    segments: the same polynomials to rounding, the left value at a repeated time."""
    rng = np.random.default_rng(11)
    steps = rng.uniform(0.05, 0.2, 60)
    t = np.cumsum(np.concatenate([[0.0], steps]))
    t = np.insert(t, 30, t[29])  # a jump: t[29] recorded twice (left value, right limit)
    x = rng.normal(size=(t.size, 4))
    orders = rng.integers(1, 6, t.size)
    f = Interpolant(t, orders, x, ("a", "b", "c", "d"), segments=[12, 45])
    tq = np.concatenate([rng.uniform(t[0], t[-1], 2000), t, [t[29]]])
    reference = f._evaluate(tq, f.x)
    np.testing.assert_allclose(f(tq), reference, rtol=1e-12, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(f(tq, ["c", "a"]), reference[:, [2, 0]], rtol=1e-12, atol=1e-12 * np.abs(x).max())
    assert f(t[29])[1] == x[29, 1]  # at the jump: the left value
