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
    with pytest.raises(ValueError, match="tol"):  # no tolerance and no stopping rule: no silent default
        newton(fun, np.zeros(2), LuCache(pat), W, jacobian="always")


# ------------------------------------------------------------------ the stopping rules
def test_spice_test_accepts_only_a_small_update_and_a_small_residual():
    """SPICE's rule: the accepted iterate's last update is within reltol * max(|x_k|, |x_k+1|) + atol, and the
    residual there within reltol of its terms plus r_atol; one more iteration than the update alone needs."""
    from netdae.dae.newton import SpiceTest

    pat, fun = circle_line()
    reltol, atol = 1e-3, np.array([1e-9, 1e-9])
    seen = []

    def watched(v, jac):
        seen.append(np.array(v))
        return fun(v, jac)

    stop = SpiceTest(pat, reltol, atol, np.array([1e-12, 1e-12]))
    res = newton(watched, np.array([3.0, 1.0]), LuCache(pat), np.ones(2), maxiter=20, jacobian="always", stop=stop)
    assert res.converged and res.info == INFO_CONVERGED
    x_prev, x = seen[-2], seen[-1]
    assert np.array_equal(res.x, x)  # the accepted iterate is the last evaluated one
    assert np.all(np.abs(x - x_prev) <= reltol * np.maximum(np.abs(x), np.abs(x_prev)) + atol)
    r = fun(x, False)[0]
    j = np.abs(np.array([[2 * x[0], 2 * x[1]], [1.0, -1.0]])) @ np.abs(x)
    assert np.all(np.abs(r) <= reltol * j + 1e-12)
    assert np.allclose(res.x, np.sqrt(2.0), rtol=10 * reltol ** 2)  # quadratic: error ~ (last update)^2
    assert stop.last_dx.max() <= 1.0  # |dx| / tolerance of the last update


def test_spice_test_never_accepts_a_limited_iterate():
    """A device that limited its junction voltage in the last evaluation keeps the iteration going."""
    from netdae.dae.newton import SpiceTest

    pat = dense_pattern(1)

    def fun(v, jac):  # x = 1, reporting limiting at every evaluation
        return v - 1.0, (np.ones(1) if jac else None), True, True

    stop = SpiceTest(pat, 1e-3, np.array([1e-9]), np.array([1e-12]))
    res = newton(fun, np.array([5.0]), LuCache(pat), np.ones(1), maxiter=6, jacobian="always", stop=stop)
    assert not res.converged and res.info == INFO_MAXITER and res.iterations == 6
    assert float(res.x[0]) == 1.0


def test_rate_test_is_the_default_rule():
    """newton() without a rule and with RateTest(tol) give the same iterates (IDA's test)."""
    from netdae.dae.newton import RateTest

    pat, fun = circle_line()
    x0 = np.array([2.0, 1.0])
    w = np.array([1e3, 1e3])
    a = newton(fun, x0, LuCache(pat), w, tol=0.33, maxiter=10, jacobian="always")
    b = newton(fun, x0, LuCache(pat), w, maxiter=10, jacobian="always", stop=RateTest(0.33, fresh=True))
    assert a.converged and b.converged
    assert np.array_equal(a.x, b.x) and a.iterations == b.iterations and a.rate == b.rate


# ------------------------------------------------------------------ the homotopies over it
def test_homotopies_reach_the_plain_newton_solution():
    """gmin stepping and source stepping are continuations to the same root that plain Newton finds."""
    import netdae
    from netdae.dae.steady import GminStepping, SourceStepping, SteadyOptions, _Newton
    from netdae.mna import assemble

    ckt = netdae.load("t\nV1 a 0 5\nR1 a b 1k\nD1 b 0 dm\nD2 b c dm\nR2 c 0 2k\n.model dm d is=1e-14 n=1.2\n.op\n.end\n")
    system = assemble(ckt)
    opts = SteadyOptions()
    plain = _Newton(system, 0.0, opts, [])
    x_p, ok = plain.solve(system.initial_guess(), init=True)
    assert ok
    for homotopy in (GminStepping(opts.gmin), SourceStepping(opts.gmin)):
        nt = _Newton(system, 0.0, opts, [])
        x_h, ok = homotopy(nt, system.initial_guess())
        assert ok, homotopy.name
        tol = opts.reltol * np.abs(x_p) + nt.x_atol
        assert np.all(np.abs(x_h - x_p) <= tol), homotopy.name
        assert nt.iterations > plain.iterations  # a continuation takes several solves
