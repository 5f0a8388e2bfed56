"""The Newton kernel and the LU cache (netdae.dae.newton)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from netdae.dae.newton import (
    INFO_CONVERGED,
    INFO_DIVERGED,
    INFO_EVALUATION,
    INFO_MAXITER,
    INFO_NONFINITE,
    INFO_SINGULAR,
    LuCache,
    newton,
)
from netdae.dae.sparse import SparsePattern


def dense_pattern(n):
    return SparsePattern.from_matrices(np.ones((n, n)))


def circle_line(calls=None):
    """x^2 + y^2 = 4, x = y: root (sqrt 2, sqrt 2)."""
    pat = dense_pattern(2)

    def fun(v, jac):
        if calls is not None:
            calls.append(jac)
        x, y = v
        r = np.array([x * x + y * y - 4.0, x - y])
        if not jac:
            return r, None, True, False
        j = np.array([[2 * x, 2 * y], [1.0, -1.0]])
        return r, j[pat.rows, pat.cols], True, False

    return pat, fun


W = np.full(2, 1e8)  # weights 1/(rtol |x| + atol) of a tight tolerance


def test_lu_cache_factors_solves_and_counts():
    rng = np.random.default_rng(3)
    a = sp.random(30, 30, density=0.2, random_state=4) + sp.eye(30) * 5
    pat = SparsePattern.from_matrices(a)
    lu = LuCache(pat)
    assert not lu.ready
    data = pat.data_of(a)
    assert lu.factor(data, tag=1.5) and lu.ready and lu.tag == 1.5 and lu.factorizations == 1
    b = rng.normal(size=30)
    np.testing.assert_allclose(a @ lu.solve(b), b, atol=1e-12)
    # new values on the same pattern: the matrix object is reused
    assert lu.factor(2.0 * data, tag=3.0)
    np.testing.assert_allclose(2.0 * (a @ lu.solve(b)), b, atol=1e-12)
    assert lu.factorizations == 2
    lu.invalidate()
    assert not lu.ready and lu.tag is None


def test_lu_cache_reports_a_singular_matrix():
    pat = dense_pattern(2)
    lu = LuCache(pat)
    assert not lu.factor(np.zeros(pat.nnz))
    assert not lu.ready and lu.factorizations == 0


def test_full_newton_converges_quadratically():
    pat, fun = circle_line()
    res = newton(fun, np.array([1.0, 2.0]), LuCache(pat), W, tol=0.33, maxiter=10, jacobian="always")
    assert res.converged and res.info == INFO_CONVERGED
    np.testing.assert_allclose(res.x, [np.sqrt(2.0)] * 2, rtol=0, atol=1e-8)
    assert res.iterations <= 6 and res.rate < 0.05


def test_modified_newton_factors_once_and_converges_linearly():
    calls = []
    pat, fun = circle_line(calls)
    lu = LuCache(pat)
    res = newton(fun, np.array([1.3, 1.5]), lu, W, tol=0.33, maxiter=30, jacobian="first")
    assert res.converged
    assert lu.factorizations == 1 and calls.count(True) == 1
    np.testing.assert_allclose(res.x, [np.sqrt(2.0)] * 2, rtol=0, atol=1e-8)
    # a frozen Jacobian contracts linearly: more iterations than full Newton, a measurable rate
    assert res.iterations > 3 and 0.0 < res.rate < 0.5


def test_reused_factorisation_and_scale():
    pat, fun = circle_line()
    lu = LuCache(pat)
    newton(fun, np.array([1.3, 1.5]), lu, W, tol=0.33, maxiter=30, jacobian="first")
    res = newton(fun, np.array([1.4, 1.45]), lu, W, tol=0.33, maxiter=30, jacobian="never", scale=0.9)
    assert res.converged and lu.factorizations == 1
    np.testing.assert_allclose(res.x, [np.sqrt(2.0)] * 2, rtol=0, atol=1e-8)


def test_linear_problem_takes_one_solve():
    a = np.array([[4.0, 1.0], [2.0, 3.0]])
    b = np.array([1.0, 2.0])
    pat = dense_pattern(2)
    lu = LuCache(pat)
    lu.factor(a[pat.rows, pat.cols])
    evals = []

    def fun(x, jac):
        evals.append(1)
        return a @ x - b, None, True, False

    res = newton(fun, np.zeros(2), lu, W, tol=0.33, maxiter=4, jacobian="never", linear=True)
    assert res.converged and res.iterations == 1 and len(evals) == 1
    np.testing.assert_allclose(res.x, np.linalg.solve(a, b), rtol=1e-14)


def test_limited_evaluations_are_never_converged():
    pat, fun = circle_line()

    def limited_for(n_calls):
        count = [0]

        def limited_fun(x, jac):
            r, j, ok, _ = fun(x, jac)
            count[0] += 1
            return r, j, ok, count[0] <= n_calls

        return limited_fun

    root = np.array([np.sqrt(2.0)] * 2)
    # at the root the first correction is tiny, but the first three evaluations limited
    res = newton(limited_for(3), root, LuCache(pat), W, tol=0.33, maxiter=10, jacobian="always")
    assert res.converged and res.evaluations == 4
    res = newton(limited_for(100), root, LuCache(pat), W, tol=0.33, maxiter=5, jacobian="always")
    assert not res.converged and res.info == INFO_MAXITER


def test_failed_evaluation_is_reported():
    pat, fun = circle_line()

    def bad(x, jac):
        r, j, _, lim = fun(x, jac)
        return r, j, x[0] < 1.5, lim

    res = newton(bad, np.array([3.0, 3.0]), LuCache(pat), W, tol=0.33, maxiter=5, jacobian="always")
    assert not res.converged and res.info == INFO_EVALUATION


def test_singular_jacobian_is_reported():
    pat = dense_pattern(2)

    def fun(x, jac):
        return x - 1.0, (np.zeros(pat.nnz) if jac else None), True, False

    res = newton(fun, np.zeros(2), LuCache(pat), W, tol=0.33, jacobian="always")
    assert not res.converged and res.info == INFO_SINGULAR


def test_divergence_and_damping_on_arctan():
    # full Newton on arctan(x) = 0 diverges from |x0| > 1.39; Armijo backtracking converges
    pat = dense_pattern(1)

    def fun(x, jac):
        return np.arctan(x), (np.array([1.0 / (1.0 + x[0] ** 2)]) if jac else None), True, False

    plain = newton(fun, np.array([3.0]), LuCache(pat), np.array([1e6]), tol=0.33, maxiter=20, jacobian="always")
    assert not plain.converged and plain.info in (INFO_DIVERGED, INFO_NONFINITE, INFO_MAXITER)
    damped = newton(fun, np.array([3.0]), LuCache(pat), np.array([1e6]), tol=0.33, maxiter=30,
                    jacobian="always", max_backtracks=10)
    assert damped.converged and abs(damped.x[0]) < 1e-6


def test_slow_contraction_with_a_fresh_jacobian_is_not_trusted():
    # modified Newton from far up an exponential: corrections shrink by 1/e per iteration
    # while the iterate is still far from the root
    pat = dense_pattern(1)
    vt = 0.025

    def fun(x, jac):
        r = np.array([np.expm1(x[0] / vt) - 1.0])  # root at vt ln 2
        return r, (np.array([np.exp(x[0] / vt) / vt]) if jac else None), True, False

    res = newton(fun, np.array([1.0]), LuCache(pat), np.array([1.0 / (1e-3 * 1.0 + 1e-6)]), tol=0.33,
                 maxiter=4, jacobian="first")
    assert not res.converged


def test_arguments_are_checked():
    pat, fun = circle_line()
    with pytest.raises(ValueError):
        newton(fun, np.zeros(2), LuCache(pat), W, tol=0.33, jacobian="sometimes")
    with pytest.raises(ValueError):
        newton(fun, np.zeros(2), LuCache(pat), W, tol=0.33, jacobian="never")
