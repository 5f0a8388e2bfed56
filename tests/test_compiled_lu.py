"""The sparse LU refactored in a kept pivot order (netdae.dae.compiled.lu).

Oracles: LAPACK's dense solve (numpy), SuperLU (scipy's splu), and a dense
boolean elimination for the symbolic patterns. Errors are measured in units of
``eps * cond`` (forward error) and ``eps`` (normwise backward error).
"""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import netdae
from netdae.dae import compiled
from netdae.dae.compiled import choose_cache_dir
from netdae.dae.compiled.lu import (
    PIVOT_REL_THRESHOLD,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_SMALL_PIVOT,
    STATUS_ZERO_PIVOT,
    SparseLU,
    make_plan,
    refactor,
    solve,
    solve_transposed,
)
from netdae.dae.newton import LuCache
from netdae.dae.sparse import SparsePattern
from netdae.mna import assemble

EPS = np.finfo(float).eps
NETLISTS = sorted((Path(__file__).resolve().parent.parent / "netlists").glob("*.cir"))
#: Forward error bound in units of eps * cond_inf(A): threshold pivoting's growth and the
#: reference's own error fit well inside; a wrong factor is off by O(1), i.e. 1e6+ units.
FORWARD_UNITS = 100.0
#: Normwise backward error bound in units of eps (per unknown: the classic n eps bound).
BACKWARD_UNITS = 10.0


def backward_error(a, x, b):
    """Normwise backward error ||A x - b|| / (||A|| ||x|| + ||b||) (inf norms), in units of eps."""
    r = np.abs(a @ x - b).max()
    return r / (np.abs(a).sum(axis=1).max() * np.abs(x).max() + np.abs(b).max()) / EPS


def forward_units(a, x, b):
    """||x - x_ref|| / ||x_ref|| in units of eps * cond_inf(A) (x_ref: LAPACK)."""
    ref = np.linalg.solve(a, b)
    cond = np.linalg.cond(a, np.inf)
    return np.abs(x - ref).max() / np.abs(ref).max() / (EPS * cond)


def random_matrix(rng, n, density, *, zero_diag_fraction=0.0, cond_target=None):
    """A random sparse matrix that needs off-diagonal pivots.

    Generic ``D + R`` (non-zero diagonal, random sparse ``R``) with the rows of
    a random subset cyclically exchanged, so that a fraction of the diagonal is
    (mostly) structurally zero, as in MNA's voltage-source rows, while the
    matrix stays structurally non-singular. ``cond_target`` scales rows and
    columns geometrically (graded like conductances from micro- to
    kilo-siemens) for a badly conditioned matrix.
    """
    r = sp.random(n, n, density=density, random_state=int(rng.integers(1 << 30)), format="csr",
                  data_rvs=rng.standard_normal)
    diag = rng.standard_normal(n) + np.sign(rng.standard_normal(n)) * 2.0
    a = (r + sp.diags(diag)).tocsr()
    perm = np.arange(n)
    moved = np.flatnonzero(rng.random(n) < zero_diag_fraction)
    if moved.size > 1:
        perm[moved] = np.roll(moved, 1)
    a = a[perm]
    if cond_target is not None:
        s = np.geomspace(1.0, cond_target, n)
        a = sp.diags(rng.permutation(s)) @ a @ sp.diags(rng.permutation(s) ** 0.5)
    return sp.csc_matrix(a)


def nonsingular(a, limit=1e13):
    return np.linalg.cond(a) < limit


def dense_symbolic(mask):
    """Boolean elimination without pivoting: the structural pattern of L + U."""
    m = mask.copy()
    n = m.shape[0]
    for k in range(n):
        rows = np.flatnonzero(m[k + 1:, k]) + k + 1
        cols = np.flatnonzero(m[k, k + 1:]) + k + 1
        m[np.ix_(rows, cols)] = True
    return m


def plan_mask(plan):
    n = plan.n
    m = np.zeros((n, n), dtype=bool)
    lc = np.repeat(np.arange(n), np.diff(plan.l_ptr))
    uc = np.repeat(np.arange(n), np.diff(plan.u_ptr))
    m[plan.l_rows, lc] = True
    m[plan.u_rows, uc] = True
    return m


# ------------------------------------------------------------------------------ accuracy
@pytest.mark.parametrize("seed", range(12))
def test_random_matrices_against_lapack_and_superlu(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 120))
    a = random_matrix(rng, n, float(rng.uniform(0.01, 0.2)), zero_diag_fraction=0.3,
                      cond_target=[None, 1e4, 1e8][seed % 3])
    dense = a.toarray()
    if not nonsingular(dense):
        pytest.skip("singular draw")
    pat = SparsePattern.from_matrices(a)
    lu = SparseLU(pat)
    assert lu.factor(pat.data_of(a))
    b = rng.standard_normal(n)
    x = lu.solve(b)
    assert backward_error(dense, x, b) <= BACKWARD_UNITS * n
    assert forward_units(dense, x, b) <= FORWARD_UNITS
    # SuperLU agrees within the same units
    ref = splu(a).solve(b)
    assert np.abs(x - ref).max() / np.abs(ref).max() <= FORWARD_UNITS * EPS * np.linalg.cond(dense, np.inf)
    xt = lu.solve(b, trans=True)
    assert backward_error(dense.T, xt, b) <= BACKWARD_UNITS * n
    assert forward_units(dense.T, xt, b) <= FORWARD_UNITS


@pytest.mark.parametrize("seed", range(6))
def test_complex_shifted_matrices_refactored_across_frequencies(seed):
    """``j w E - H`` on one pattern (an .ac sweep): complex refactorisations in the first frequency's
    order, each against LAPACK in units of eps * cond, solve and transposed solve."""
    rng = np.random.default_rng(300 + seed)
    n = int(rng.integers(5, 90))
    h = random_matrix(rng, n, 0.08, zero_diag_fraction=0.3, cond_target=[None, 1e5][seed % 2])
    e = sp.diags(np.where(rng.random(n) < 0.6, rng.uniform(0.1, 2.0, n), 0.0)).tocsc()
    pat = SparsePattern.from_matrices(e, h)
    ed, hd = pat.data_of(e), pat.data_of(h)
    lu = SparseLU(pat, dtype=complex)
    b = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    checked = 0
    for w in np.geomspace(1e-3, 1e3, 13):
        data = 1j * w * ed - hd
        dense = pat.matrix(data).toarray()
        if not nonsingular(dense):
            continue
        assert lu.factor(data)
        checked += 1
        x = lu.solve(b)
        assert x.dtype == complex
        assert backward_error(dense, x, b) <= BACKWARD_UNITS * n
        assert forward_units(dense, x, b) <= FORWARD_UNITS
        xt = lu.solve(b, trans=True)
        assert backward_error(dense.T, xt, b) <= BACKWARD_UNITS * n
    assert checked >= 10 and lu.refactorizations >= 1
    assert lu.fresh_factorizations + lu.refactorizations == checked


def test_complex_lu_refuses_a_singular_matrix_and_another_dtype():
    pat = SparsePattern.from_matrices(np.ones((2, 2)))
    lu = SparseLU(pat, dtype=complex)
    assert not lu.factor(pat.data_of(np.ones((2, 2))) * (1 + 1j))
    with pytest.raises(ValueError, match="float or complex"):
        SparseLU(pat, dtype=np.float32)


@pytest.mark.parametrize("seed", range(8))
def test_refactorization_sequence_on_one_pattern(seed):
    """New values on the pattern: refactored in the kept order while the pivots stay good."""
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(5, 80))
    a = random_matrix(rng, n, 0.08, zero_diag_fraction=0.2)
    pat = SparsePattern.from_matrices(a)
    lu = SparseLU(pat)
    base = pat.data_of(a)
    done = 0
    for step in range(10):
        data = base * (1.0 + 0.05 * rng.standard_normal(pat.nnz))
        dense = pat.matrix(data).toarray()
        if not nonsingular(dense):
            continue
        assert lu.factor(data)
        done += 1
        b = rng.standard_normal((n, 3))
        x = lu.solve(b)
        assert x.shape == (n, 3)
        for k in range(3):
            assert backward_error(dense, x[:, k], b[:, k]) <= BACKWARD_UNITS * n
            assert forward_units(dense, x[:, k], b[:, k]) <= FORWARD_UNITS
    assert lu.fresh_factorizations + lu.refactorizations == done
    assert lu.fresh_factorizations >= 1 and lu.refactorizations >= 1


def test_one_by_one_and_diagonal():
    pat = SparsePattern.from_coo(1, [[0]], [[0]])
    lu = SparseLU(pat)
    assert lu.factor(np.array([4.0]))
    assert lu.solve(np.array([2.0]))[0] == 0.5
    pat = SparsePattern.from_coo(5, [], [])
    lu = SparseLU(pat)
    d = np.array([1.0, -2.0, 4.0, 8.0, 0.5])
    assert lu.factor(d)
    np.testing.assert_array_equal(lu.solve(np.ones(5)), 1.0 / d)
    np.testing.assert_array_equal(lu.solve(np.ones(5), trans=True), 1.0 / d)


# ------------------------------------------------------------------------------ symbolic phase
@pytest.mark.parametrize("seed", range(6))
def test_symbolic_pattern_is_the_structural_elimination(seed):
    rng = np.random.default_rng(200 + seed)
    n = int(rng.integers(3, 60))
    a = random_matrix(rng, n, 0.06, zero_diag_fraction=0.3)
    pat = SparsePattern.from_matrices(a)
    lu = splu(a, permc_spec="MMD_AT_PLUS_A")
    plan = make_plan(pat, lu.perm_r, lu.perm_c)
    # B = Pr A Pc from the plan's maps
    b_mask = np.zeros((n, n), dtype=bool)
    b_mask[plan.b_rows, np.repeat(np.arange(n), np.diff(plan.b_ptr))] = True
    a_mask = np.zeros((n, n), dtype=bool)
    a_mask[pat.rows, pat.cols] = True
    expect_b = np.zeros((n, n), dtype=bool)
    expect_b[np.asarray(lu.perm_r)[pat.rows], np.asarray(lu.perm_c)[pat.cols]] = True
    np.testing.assert_array_equal(b_mask, expect_b)
    np.testing.assert_array_equal(plan_mask(plan), dense_symbolic(b_mask) | np.eye(n, dtype=bool))
    # SuperLU's numeric factors fit inside the structural patterns
    m = plan_mask(plan)
    assert not np.any((lu.L.toarray() != 0) & ~m & ~np.eye(n, dtype=bool))
    assert not np.any((lu.U.toarray() != 0) & ~m)
    # rows sorted within columns, U's diagonal last
    for j in range(n):
        rows = plan.u_rows[plan.u_ptr[j]:plan.u_ptr[j + 1]]
        assert rows[-1] == j and np.all(np.diff(rows) > 0)
        lrows = plan.l_rows[plan.l_ptr[j]:plan.l_ptr[j + 1]]
        assert np.all(lrows > j) and np.all(np.diff(lrows) > 0)


def test_cancelled_fill_is_kept_for_later_matrices():
    """A fill entry that cancels to zero in the first matrix is needed by the next one."""
    # natural order, diagonal pivots: the fill at (2, 3) is -L20 U03 - L21 U13 = -0.1 + 0.1
    a1 = np.array([[10.0, 0.0, 0.0, 1.0],
                   [0.0, 10.0, 0.0, -1.0],
                   [1.0, 1.0, 10.0, 0.0],
                   [0.0, 0.0, 1.0, 10.0]])
    pat = SparsePattern.from_matrices(a1)
    assert (2, 3) not in set(zip(pat.rows.tolist(), pat.cols.tolist()))
    lu = SparseLU(pat, permc_spec="NATURAL")
    assert lu.factor(pat.data_of(a1))
    lower, upper = lu.factors()
    assert upper[2, 3] == 0.0
    a2 = a1.copy()
    a2[1, 3] = -2.0
    assert lu.factor(pat.data_of(a2))
    assert lu.refactorizations == 1
    assert lu.factors()[1][2, 3] == pytest.approx(0.1)
    b = np.array([1.0, -2.0, 0.5, 3.0])
    x = lu.solve(b)
    assert backward_error(a2, x, b) <= BACKWARD_UNITS * 4
    assert forward_units(a2, x, b) <= FORWARD_UNITS
    np.testing.assert_allclose((lower @ upper).toarray(), a1, rtol=0, atol=4 * EPS * 10)


# ------------------------------------------------------------------------------ degraded pivots
def test_degraded_pivot_falls_back_to_fresh_pivoting():
    """A pivot order chosen for d = 2 goes bad as d shrinks; the wrapper repivots."""

    def mat(d):
        return np.array([[d, 1.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 3.0]])

    pat = SparsePattern.from_matrices(np.ones((3, 3)))
    lu = SparseLU(pat, permc_spec="NATURAL")
    b = np.array([1.0, 2.0, 3.0])
    assert lu.factor(pat.data_of(mat(2.0)))
    order = lu.plan.perm_r.copy()
    assert lu.factor(pat.data_of(mat(3.0)))
    assert (lu.fresh_factorizations, lu.refactorizations) == (1, 1)
    for d in (1e-14, 0.0):
        a = mat(d)
        assert lu.factor(pat.data_of(a))
        assert backward_error(a, lu.solve(b), b) <= BACKWARD_UNITS * 3
        assert forward_units(a, lu.solve(b), b) <= FORWARD_UNITS
    assert lu.fresh_factorizations == 2  # d = 1e-14 repivots; d = 0 reuses the new order
    assert not np.array_equal(order, lu.plan.perm_r)


def test_refactor_status_and_why_it_matters():
    """The kernel reports a degraded pivot; accepting it (threshold 0) loses the answer."""
    d0, d1 = 2.0, 1e-13

    def mat(d):
        return np.array([[d, 1.0], [1.0, 1.0 + 1e-3]])

    pat = SparsePattern.from_matrices(np.ones((2, 2)))
    first = splu(sp.csc_matrix(mat(d0)), permc_spec="NATURAL")
    plan = make_plan(pat, first.perm_r, first.perm_c)
    work = np.zeros(2)
    l_data, u_data = np.empty(plan.l_nnz), np.empty(plan.u_nnz)
    a = mat(d1)
    data = pat.data_of(a)
    assert refactor(*plan.refactor_args(), data, l_data, u_data, work, PIVOT_REL_THRESHOLD) == STATUS_SMALL_PIVOT
    assert np.all(work == 0.0)
    assert refactor(*plan.refactor_args(), data, l_data, u_data, work, 0.0) == STATUS_OK
    b = np.array([1.0, 1.0])
    x = b.copy()
    solve(*plan.solve_args(), l_data, u_data, x, np.empty(2))
    assert forward_units(a, x, b) > 1e3  # the unchecked refactorisation is far off
    lu = SparseLU(pat, permc_spec="NATURAL")
    assert lu.factor(pat.data_of(mat(d0))) and lu.factor(data)
    assert lu.fresh_factorizations == 2
    assert forward_units(a, lu.solve(b), b) <= FORWARD_UNITS


def test_zero_pivot_and_nonfinite_statuses():
    pat = SparsePattern.from_matrices(np.ones((2, 2)))
    a = np.array([[2.0, 1.0], [1.0, 1.0]])
    first = splu(sp.csc_matrix(a), permc_spec="NATURAL")
    plan = make_plan(pat, first.perm_r, first.perm_c)
    work = np.zeros(2)
    l_data, u_data = np.empty(plan.l_nnz), np.empty(plan.u_nnz)
    args = plan.refactor_args()
    zero = pat.data_of(np.array([[0.0, 1.0], [1.0, 1.0]]))
    assert refactor(*args, zero, l_data, u_data, work, PIVOT_REL_THRESHOLD) == STATUS_ZERO_PIVOT
    for bad in (np.nan, np.inf):
        data = pat.data_of(a)
        data[-1] = bad
        assert refactor(*args, data, l_data, u_data, work, PIVOT_REL_THRESHOLD) == STATUS_NONFINITE
        assert np.all(work == 0.0)


def test_singular_and_nonfinite_matrices_are_refused_and_recovered_from():
    pat = SparsePattern.from_matrices(np.ones((3, 3)))
    lu = SparseLU(pat)
    good = np.array([[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]])
    singular = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert not lu.factor(pat.data_of(singular)) and not lu.ready
    with pytest.raises(RuntimeError):
        lu.solve(np.ones(3))
    assert lu.factor(pat.data_of(good))
    nan = pat.data_of(good)
    nan[4] = np.nan
    assert not lu.factor(nan) and not lu.ready
    assert not lu.factor(pat.data_of(singular))
    assert lu.factor(pat.data_of(good))
    b = np.array([1.0, 2.0, 3.0])
    assert backward_error(good, lu.solve(b), b) <= BACKWARD_UNITS * 3


# ------------------------------------------------------------------------------ MNA matrices
def mna_jacobians(path):
    system = assemble(netdae.load(path))
    ev = system.evaluate(np.zeros(system.n), 0.0, jacobian=True)
    return system.pattern, np.asarray(ev.dq, dtype=float), np.asarray(ev.dphi, dtype=float)


@pytest.mark.parametrize("path", NETLISTS, ids=lambda p: p.stem)
def test_mna_matrices_of_the_netlists(path):
    """cj E - dphi/dx over a sweep of cj (the BDF's sequence of matrices), one LU object."""
    pattern, dq, dphi = mna_jacobians(path)
    lu = SparseLU(pattern)
    rng = np.random.default_rng(7)
    checked = 0
    for cj in (1e9, 1e6, 1e3, 3e3, 1e7, 1e11):
        data = cj * dq - dphi
        dense = pattern.matrix(data).toarray()
        if not nonsingular(dense):
            continue
        assert lu.factor(data)
        b = rng.standard_normal(pattern.n)
        x = lu.solve(b)
        assert backward_error(dense, x, b) <= BACKWARD_UNITS * pattern.n, cj
        assert forward_units(dense, x, b) <= FORWARD_UNITS, cj
        checked += 1
    assert checked >= 3


def test_lu_cache_counts_and_solves_many_right_hand_sides():
    rng = np.random.default_rng(5)
    a = random_matrix(rng, 40, 0.1, zero_diag_fraction=0.25)
    pat = SparsePattern.from_matrices(a)
    cache = LuCache(pat)
    data = pat.data_of(a)
    assert cache.factor(data, tag=1.0) and cache.factor(1.01 * data, tag=2.0)
    assert (cache.factorizations, cache.fresh_factorizations, cache.refactorizations) == (2, 1, 1)
    assert cache.tag == 2.0
    b = rng.standard_normal((40, 2))
    y = cache.solve(b)
    dense = 1.01 * a.toarray()
    for k in range(2):
        assert forward_units(dense, y[:, k], b[:, k]) <= FORWARD_UNITS
    np.testing.assert_array_equal(cache.matrix.toarray(), pat.matrix(1.01 * data).toarray())


# ------------------------------------------------------------------------------ compiled callers
@numba.njit
def _factor_and_solve(plan_r, plan_s, a_data, l_data, u_data, work, b, threshold):
    b_ptr, b_rows, b_slots, l_ptr, l_rows, u_ptr, u_rows = plan_r
    perm_r, perm_c = plan_s
    status = refactor(b_ptr, b_rows, b_slots, l_ptr, l_rows, u_ptr, u_rows, a_data, l_data, u_data,
                      work, threshold)
    if status == 0:
        solve(perm_r, perm_c, l_ptr, l_rows, u_ptr, u_rows, l_data, u_data, b, work)
        solve_transposed(perm_r, perm_c, l_ptr, l_rows, u_ptr, u_rows, l_data, u_data, b, work)
    return status


def test_kernels_are_callable_from_compiled_code():
    rng = np.random.default_rng(11)
    a = random_matrix(rng, 30, 0.1, zero_diag_fraction=0.3)
    pat = SparsePattern.from_matrices(a)
    first = splu(a)
    plan = make_plan(pat, first.perm_r, first.perm_c)
    b = rng.standard_normal(30)
    x = b.copy()
    status = _factor_and_solve(plan.refactor_args(), (plan.perm_r, plan.perm_c), pat.data_of(a),
                               np.empty(plan.l_nnz), np.empty(plan.u_nnz), np.zeros(30), x,
                               PIVOT_REL_THRESHOLD)
    assert status == STATUS_OK
    dense = a.toarray()
    # x = A^-T A^-1 b
    ref = np.linalg.solve(dense.T, np.linalg.solve(dense, b))
    assert np.abs(x - ref).max() / np.abs(ref).max() <= FORWARD_UNITS * EPS * np.linalg.cond(dense, np.inf) ** 2


# ------------------------------------------------------------------------------ numba's cache
def test_cache_directory_choice():
    env = {"HOME": "/home/u"}
    every = lambda p: True  # noqa: E731
    assert choose_cache_dir("/pkg", {**env, "NUMBA_CACHE_DIR": "/mine"}, writable=lambda p: False) == "/mine"
    assert choose_cache_dir("/pkg", env, writable=every) == "/pkg/__pycache__"
    not_pkg = lambda p: not p.startswith("/pkg")  # noqa: E731
    assert choose_cache_dir("/pkg", env, writable=not_pkg) == "/home/u/.cache/netdae/numba"
    assert choose_cache_dir("/pkg", {**env, "XDG_CACHE_HOME": "/xdg"}, writable=not_pkg) == "/xdg/netdae/numba"
    tmp = choose_cache_dir("/pkg", env, writable=lambda p: "netdae-numba-" in p)
    assert tmp is not None and Path(tmp).name.startswith("netdae-numba-")
    assert choose_cache_dir("/pkg", env, writable=lambda p: False) is None


def test_cache_directory_in_use_is_writable():
    assert compiled.CACHE_DIR is not None
    probe = Path(compiled.CACHE_DIR) / ".netdae-probe"
    probe.write_text("")
    probe.unlink()


def test_cache_key_follows_every_kernel_source(tmp_path):
    """numba checks only the decorated function's own file: the engine's directory is keyed by all of them."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "loop.py").write_text("def run(): pass\n")
    (b / "kernel.py").write_text("def eval(): return 1\n")
    key = compiled.source_key((a, b))
    assert key == compiled.source_key((a, b)) and len(key) == 16
    (b / "kernel.py").write_text("def eval(): return 2\n")  # a callee changes, the loop's file does not
    assert compiled.source_key((a, b)) != key
    key = compiled.source_key((a, b))
    (a / "driver.py").write_text("x = 1\n")  # a module without kernels does not count
    assert compiled.source_key((a, b), skip={"driver.py"}) == key
    # the engine in use lives in the directory of its own sources' key
    assert Path(compiled.CACHE_DIR).name == compiled.ENGINE_PREFIX + compiled.source_key()


def test_cache_key_follows_the_constants_a_kernel_imports_and_only_them(tmp_path):
    """A kernel reads an imported constant when it is compiled: the key follows that definition (and what it is
    computed from), not the rest of the module it comes from."""
    pkg = tmp_path / "pkg"
    (pkg / "kernels").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kernels" / "__init__.py").write_text("")
    (pkg / "kernels" / "diode.py").write_text("from ..model import (KNEE,  # the knee\n    helper)\n"
                                              "def eval(v):\n    return v * KNEE\n")
    model = pkg / "model.py"
    model.write_text("BASE = 2.0\nKNEE = 1e-18 * BASE\n\n\ndef helper():\n    return 1\n\n\nOTHER = 3\n")
    key = compiled.source_key((pkg / "kernels",))
    model.write_text("BASE = 2.0\nKNEE = 1e-18 * BASE\n\n\ndef helper():\n    return 1\n\n\nOTHER = 4\n")
    assert compiled.source_key((pkg / "kernels",)) == key  # a definition no kernel imports
    model.write_text("BASE = 3.0\nKNEE = 1e-18 * BASE\n\n\ndef helper():\n    return 1\n\n\nOTHER = 4\n")
    assert compiled.source_key((pkg / "kernels",)) != key  # what the imported constant is computed from
    key = compiled.source_key((pkg / "kernels",))
    model.write_text("BASE = 3.0\nKNEE = 1e-18 * BASE\n\n\ndef helper():\n    return 2\n\n\nOTHER = 4\n")
    assert compiled.source_key((pkg / "kernels",)) != key  # an imported function


def test_the_key_is_kept_while_the_files_it_read_are_unchanged(tmp_path, monkeypatch):
    """The scan costs 0.1-0.2 s at each start: its result is kept with the state of every file it read, and
    computed again when one changed, a module appeared next to one, or a kept file went."""
    import os

    pkg, base = tmp_path / "pkg", tmp_path / "cache"
    (pkg / "kernels").mkdir(parents=True)
    base.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "kernels" / "__init__.py").write_text("")
    (pkg / "kernels" / "diode.py").write_text("from ..model import KNEE\ndef eval(v):\n    return v * KNEE\n")
    model = pkg / "model.py"
    model.write_text("KNEE = 2.0\n")
    sources = (pkg / "kernels",)
    scans = []
    real = compiled.source_key
    monkeypatch.setattr(compiled, "source_key", lambda *a, **k: scans.append(1) or real(*a, **k))
    key = compiled.cached_source_key(str(base), sources, frozenset())
    assert key == real(sources, frozenset()) and len(scans) == 1
    assert compiled.cached_source_key(str(base), sources, frozenset()) == key and len(scans) == 1  # kept
    model.write_text("KNEE = 3.0\n")  # the same size: the modification time tells
    st = os.stat(model)
    os.utime(model, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    changed = compiled.cached_source_key(str(base), sources, frozenset())
    assert changed != key and changed == real(sources, frozenset()) and len(scans) == 2
    (pkg / "kernels" / "mosfet.py").write_text("def eval(v):\n    return v\n")  # a new kernel module
    assert compiled.cached_source_key(str(base), sources, frozenset()) == real(sources, frozenset()) != changed
    assert len(scans) == 3
    (base / compiled.KEY_FILE).write_text("{not json")  # a damaged file is computed again, and replaced
    assert compiled.cached_source_key(str(base), sources, frozenset()) == real(sources, frozenset())
    assert len(scans) == 4 and compiled.cached_source_key(str(base), sources, frozenset()) and len(scans) == 4
    assert compiled.cached_source_key(None, sources, frozenset()) and len(scans) == 5  # nowhere to keep it


def test_child_processes_share_the_parents_cache_directory():
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", "from netdae.dae import compiled; print(compiled.CACHE_DIR)"],
                          capture_output=True, text=True, check=True)
    assert done.stdout.strip() == compiled.CACHE_DIR


def test_a_key_that_cannot_be_kept_leaves_no_partial_file(tmp_path, monkeypatch):
    """A write of the kept key that fails (a full disk) keeps nothing and leaves no temporary file behind."""
    import json

    (tmp_path / "k").mkdir()
    (tmp_path / "k" / "loop.py").write_text("def run(): pass\n")
    base = tmp_path / "cache"
    base.mkdir()

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(json, "dump", full)
    key = compiled.cached_source_key(str(base), (tmp_path / "k",), frozenset())
    assert key == compiled.source_key((tmp_path / "k",), frozenset())
    assert list(base.iterdir()) == []
