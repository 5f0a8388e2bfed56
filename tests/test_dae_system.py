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


def _vdp(**changed):
    """Van der Pol's limit in Liénard coordinates (the user guide's example) with callables replaced."""
    parts = dict(q=lambda x: np.array([x[0], 0.0]), dq=lambda x: np.diag([1.0, 0.0]),
                 phi=lambda x, t: np.array([x[1], x[0] - x[1] ** 3 / 3 + x[1]]),
                 dphi=lambda x, t: np.array([[0.0, 1.0], [1.0, 1.0 - x[1] ** 2]]))
    parts.update(changed)
    return FunctionDae(2, names=["y", "z"], **parts)


@pytest.mark.parametrize("changed, message", [
    # phi of the wrong length reached the compiled LU's solve, which wrote past its arrays: a segmentation fault
    (dict(phi=lambda x, t: np.zeros(3)), r"phi\(x, t\) must return an array of shape \(2,\), not shape \(3,\)"),
    (dict(q=lambda x: np.zeros(1)), r"q\(x\) must return an array of shape \(2,\), not shape \(1,\)"),
    # a Jacobian of the wrong size was reported as a singular Newton matrix
    (dict(dphi=lambda x, t: np.zeros((3, 3))), r"dphi\(x, t\) must return an array of shape \(2, 2\)"),
    (dict(dq=lambda x: np.eye(1)), r"dq\(x\) must return an array of shape \(2, 2\)"),
])
def test_callables_of_the_wrong_shape_are_named(changed, message):
    from netdae.dae.bdf import integrate

    with pytest.raises(ValueError, match=message):
        integrate(_vdp(**changed), (0.0, 1.0), np.array([2.0 / 3.0, 2.0]))


def test_a_linear_dae_refuses_what_it_cannot_integrate():
    from netdae.dae.bdf import integrate

    E, H = np.diag([1.0, 0.0]), np.array([[0.0, 1.0], [1.0, 0.0]])
    with pytest.raises(ValueError, match="E and H must be finite"):
        LinearDae(np.diag([np.nan, 0.0]), H)
    wrong = LinearDae(E, H, lambda t, derivative=0: np.zeros(3))
    with pytest.raises(ValueError, match=r"c\(t\) must return an array of shape \(2,\), not shape \(3,\)"):
        integrate(wrong, (0.0, 1.0), np.zeros(2))
    good = LinearDae(E, H, lambda t, derivative=0: np.array([0.0, -np.sin(t + derivative * np.pi / 2)]))
    with pytest.raises(ValueError, match="breakpoints must be finite times, got nan"):  # was dropped silently
        integrate(good, (0.0, 1.0), np.array([0.0, 1.0]), index=np.array([1, 2]), breakpoints=[0.5, np.nan])


def test_the_pencil_of_complex_matrices_is_refused_not_cast():
    from netdae.dae.pencil import analyze_dae, analyze_pencil

    # a cast to float dropped the imaginary part with only numpy's ComplexWarning: the structure of another pencil
    with pytest.raises(ValueError, match="E must be real"):
        analyze_pencil(np.diag([1j, 0.0]), np.eye(2))
    assert analyze_pencil(np.diag([1.0 + 0j, 0.0]), np.eye(2)).index == 1  # a zero imaginary part is real
    with pytest.raises(ValueError, match=r"x must hold one value per unknown, shape \(2,\), not shape \(5,\)"):
        analyze_dae(_vdp(), np.zeros(5), 0.0)
