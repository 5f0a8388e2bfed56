"""The DAE interface and the fixed sparsity pattern."""

import numpy as np
import pytest
import scipy.sparse as sp

from netdae.dae.sparse import SparsePattern
from netdae.dae.system import FunctionDae, LinearDae


def test_pattern_scatter_sums_duplicates_and_keeps_diagonal():
    rng = np.random.default_rng(0)
    n = 7
    rows = rng.integers(0, n, 40)
    cols = rng.integers(0, n, 40)
    vals = rng.normal(size=40)
    pat = SparsePattern.from_coo(n, [rows], [cols])
    data = pat.scatter(pat.slots(rows, cols), vals)
    expected = sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).toarray()
    np.testing.assert_allclose(pat.matrix(data).toarray(), expected, rtol=0, atol=1e-14)
    assert np.all(pat.rows[pat.diag] == np.arange(n))
    assert np.all(pat.cols[pat.diag] == np.arange(n))


def test_pattern_rejects_entries_outside():
    pat = SparsePattern.from_coo(3, [[0]], [[1]])
    with pytest.raises(ValueError):
        pat.slots([2], [0])


def test_linear_dae_evaluates_pencil_and_source():
    E = np.array([[1.0, 0.0], [0.0, 0.0]])
    H = np.array([[-1.0, 1.0], [1.0, -2.0]])
    dae = LinearDae(E, H, lambda t, derivative=0: np.array([np.sin(t), 0.0]) if derivative == 0
                    else np.array([np.cos(t), 0.0]))
    x = np.array([0.5, -0.25])
    ev = dae.evaluate(x, 0.3)
    np.testing.assert_allclose(ev.q, E @ x)
    np.testing.assert_allclose(ev.phi, H @ x + [np.sin(0.3), 0.0])
    Ej, Hj = dae.jacobians(x, 0.3)
    np.testing.assert_array_equal(Ej.toarray(), E)
    np.testing.assert_array_equal(Hj.toarray(), H)
    np.testing.assert_allclose(dae.source(0.3, derivative=1), [np.cos(0.3), 0.0])


def test_function_dae_matches_callables():
    def q(x):
        return np.array([x[0] ** 2, 0.0])

    def dq(x):
        return np.array([[2 * x[0], 0.0], [0.0, 0.0]])

    def phi(x, t):
        return np.array([x[1], x[0] - t])

    def dphi(x, t):
        return np.array([[0.0, 1.0], [1.0, 0.0]])

    dae = FunctionDae(2, q, dq, phi, dphi)
    Ej, Hj = dae.jacobians(np.array([3.0, 1.0]), 2.0)
    np.testing.assert_array_equal(Ej.toarray(), [[6.0, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(Hj.toarray(), [[0.0, 1.0], [1.0, 0.0]])
