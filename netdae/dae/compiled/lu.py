"""Sparse LU that refactors on a fixed pivot order (compiled kernels and their plan).

A circuit simulator factors matrices of one sparsity pattern thousands of
times with slowly changing values. Choosing the pivots (and the fill-reducing
column order) is the expensive, data-dependent part; redoing the arithmetic of
the elimination in a pivot order already chosen is cheap. This module splits
the two, as KLU's ``klu_refactor`` [2]_ and Sparse 1.3's ``spFactor`` [3]_ do:

- **Symbolic phase** (:func:`make_plan`, Python with one compiled helper,
  once per pivot order): SuperLU (``scipy.sparse.linalg.splu`` with the
  column ordering ``permc_spec``, threshold partial pivoting) factors a first
  matrix; its row and column permutations ``Pr A Pc = L U`` are the pivot
  order. The patterns of ``L`` and ``U`` are then computed here by a symbolic
  factorisation of the permuted *pattern* (the reach of every column in the
  graph of ``L``, Gilbert and Peierls [1]_), not taken from SuperLU's numeric
  factors, which drop entries that happen to cancel. Every index map the
  numeric phase needs is precomputed into a frozen :class:`LuPlan` of int
  arrays.
- **Numeric phase** (:func:`refactor`, :func:`solve`,
  :func:`solve_transposed`: compiled kernels taking only arrays and scalars,
  allocating nothing): a left-looking column-by-column elimination in the
  plan's order into the ``L`` and ``U`` value arrays, and the triangular
  solves. :func:`refactor` checks each pivot against the largest magnitude of
  its column of the active submatrix (Sparse 1.3's relative pivot threshold,
  ngspice's ``pivrel``, default 1e-3) and returns a status instead of a bad
  factorisation: then the caller must choose new pivots.
- :class:`SparseLU` wraps the two: :meth:`SparseLU.factor` refactors when it
  can and falls back to fresh pivoting (SuperLU, a new plan) on the first call
  and whenever a pivot degrades; it counts both.

Storage
-------
``L`` is unit lower triangular, stored without its diagonal in CSC
(``l_ptr``, ``l_rows`` ascending, values ``l_data``); ``U`` is upper triangular
in CSC with the rows of each column ascending, its diagonal the last entry of
the column (``u_ptr``, ``u_rows``, ``u_data``). Rows and columns are those of
the permuted matrix ``B = Pr A Pc``: ``B[perm_r[i], perm_c[j]] = A[i, j]``.

Examples
--------
>>> import numpy as np
>>> from netdae.dae.sparse import SparsePattern
>>> a = np.array([[0.0, 1.0, 0.0], [1.0, 2.0, 1.0], [0.0, 1.0, 3.0]])   # zero (0, 0): a V source
>>> pat = SparsePattern.from_matrices(a)
>>> lu = SparseLU(pat)
>>> lu.factor(pat.data_of(a)), lu.factor(pat.data_of(2.0 * a))
(True, True)
>>> np.allclose(2.0 * a @ lu.solve(np.array([1.0, 2.0, 3.0])), [1.0, 2.0, 3.0])
True
>>> lu.fresh_factorizations, lu.refactorizations
(1, 1)

References
----------
.. [1] J. R. Gilbert and T. Peierls, "Sparse partial pivoting in time
   proportional to arithmetic operations", SIAM J. Sci. Stat. Comput. 9(5),
   1988 (left-looking LU, the reach of a column in the graph of L).
.. [2] T. A. Davis and E. Palamadai Natarajan, "Algorithm 907: KLU, a direct
   sparse solver for circuit simulation problems", ACM TOMS 37(3), 2010
   (``klu_refactor``: numeric factorisation in an existing pivot order).
.. [3] K. S. Kundert, *Sparse 1.3*, University of California, Berkeley, 1988,
   as used in ngspice (``spFactor`` reuses the pivot order; ``RelThreshold``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..sparse import SparsePattern
from . import allocating_kernel, kernel

__all__ = [
    "DEFAULT_PERMC_SPEC",
    "PIVOT_REL_THRESHOLD",
    "STATUS_OK",
    "STATUS_SMALL_PIVOT",
    "STATUS_ZERO_PIVOT",
    "STATUS_NONFINITE",
    "LuPlan",
    "SparseLU",
    "make_plan",
    "fresh_pivots",
    "refactor",
    "solve",
    "solve_transposed",
]

#: SuperLU column ordering of the fresh factorisations. Minimum degree on A^T + A suits
#: MNA matrices, which are structurally (nearly) symmetric: on a 300x300 RC mesh it factors
#: in 0.41 s with 5.0e6 fill against 0.72-0.85 s and 8.9e6 for COLAMD, and ties on RC
#: ladders (docs/integrator.md, the column-ordering table).
DEFAULT_PERMC_SPEC = "MMD_AT_PLUS_A"
#: A refactorisation's pivot must be at least this fraction of the largest magnitude in
#: its column of the active submatrix, else the pivot order is redone (Sparse 1.3's
#: RelThreshold, ngspice's ``.options pivrel`` default). The growth of the entries is
#: then bounded by 1 / threshold per elimination step, as for SuperLU's threshold pivoting.
PIVOT_REL_THRESHOLD = 1e-3

#: :func:`refactor` statuses.
STATUS_OK = 0
#: A pivot below ``threshold`` times the largest magnitude of its column: choose new pivots.
STATUS_SMALL_PIVOT = 1
#: A pivot exactly zero (the matrix may still be non-singular in another order).
STATUS_ZERO_PIVOT = 2
#: A non-finite value met in the elimination (non-finite matrix entries or overflow).
STATUS_NONFINITE = 3


# ------------------------------------------------------------------------------ kernels
@kernel
def refactor(b_ptr, b_rows, b_slots, l_ptr, l_rows, u_ptr, u_rows, a_data, l_data, u_data, work,
             threshold):
    """Numeric LU of ``B = Pr A Pc`` in the plan's pivot order (left-looking).

    Parameters
    ----------
    b_ptr : ndarray of int64, shape (n + 1,)
    b_rows, b_slots : ndarray of int32, shape (nnz,)
        Column ``j`` of ``B`` holds ``a_data[b_slots[p]]`` at row ``b_rows[p]``
        for ``p`` in ``b_ptr[j]:b_ptr[j + 1]``.
    l_ptr, l_rows, u_ptr, u_rows : ndarray
        Patterns of ``L`` and ``U`` (see the module docstring).
    a_data : ndarray of float64 (or complex128), shape (nnz,)
        Values of ``A`` on its pattern.
    l_data, u_data : ndarray of a_data's type
        Output: the factors' values (overwritten).
    work : ndarray of a_data's type, shape (n,)
        All zero on entry; all zero on return (whatever the status).
    threshold : float
        Relative pivot threshold (:data:`PIVOT_REL_THRESHOLD`); 0 accepts any
        non-zero finite pivot.

    Returns
    -------
    int
        ``STATUS_OK``, ``STATUS_SMALL_PIVOT``, ``STATUS_ZERO_PIVOT`` or
        ``STATUS_NONFINITE``; on any but the first the factors are incomplete.

    Notes
    -------
    Column ``j``: scatter ``B[:, j]`` into ``work``, apply the columns ``k`` of
    ``L`` for the rows ``k < j`` of ``U[:, j]`` in ascending order (a valid
    topological order of the triangular solve), gather ``U[:, j]`` and
    ``L[:, j] = work[j+1:] / pivot``. Cost: the flops of the factorisation
    plus one pass over the patterns; no allocation, no search.
    """
    n = b_ptr.size - 1
    for j in range(n):
        for p in range(b_ptr[j], b_ptr[j + 1]):
            work[b_rows[p]] = a_data[b_slots[p]]
        bad = False
        last = u_ptr[j + 1] - 1
        for p in range(u_ptr[j], last):
            k = u_rows[p]
            xk = work[k]
            work[k] = 0.0
            u_data[p] = xk
            if xk != 0.0:
                if xk - xk != 0.0:
                    bad = True
                for q in range(l_ptr[k], l_ptr[k + 1]):
                    work[l_rows[q]] -= l_data[q] * xk
        piv = work[j]
        work[j] = 0.0
        apiv = abs(piv)
        colmax = apiv
        for q in range(l_ptr[j], l_ptr[j + 1]):
            a = abs(work[l_rows[q]])
            if a > colmax:
                colmax = a
            elif a != a:
                bad = True
        status = STATUS_OK
        if bad or apiv != apiv or colmax - colmax != 0.0:
            status = STATUS_NONFINITE
        elif apiv == 0.0:
            status = STATUS_ZERO_PIVOT
        elif apiv < threshold * colmax:
            status = STATUS_SMALL_PIVOT
        if status != STATUS_OK:
            for q in range(l_ptr[j], l_ptr[j + 1]):
                work[l_rows[q]] = 0.0
            return status
        u_data[last] = piv
        inv = 1.0 / piv
        for q in range(l_ptr[j], l_ptr[j + 1]):
            i = l_rows[q]
            l_data[q] = work[i] * inv
            work[i] = 0.0
    return STATUS_OK


@kernel
def solve(perm_r, perm_c, l_ptr, l_rows, u_ptr, u_rows, l_data, u_data, b, work):
    """Solve ``A y = b`` in place with the factors of :func:`refactor`.

    ``A = Pr^T L U Pc^T``: ``work[perm_r] = b``, ``L`` forward and ``U``
    backward substitution (column-oriented), ``b = work[perm_c]``.

    Parameters
    ----------
    perm_r, perm_c : ndarray of int32, shape (n,)
    l_ptr, l_rows, u_ptr, u_rows, l_data, u_data : ndarray
        The plan's patterns and the factors' values.
    b : ndarray of float64 (or complex128, with complex factors), shape (n,)
        Right-hand side; overwritten by the solution.
    work : ndarray of b's type, shape (n,)
        Scratch (any content).
    """
    n = b.size
    for i in range(n):
        work[perm_r[i]] = b[i]
    for k in range(n):
        xk = work[k]
        if xk != 0.0:
            for q in range(l_ptr[k], l_ptr[k + 1]):
                work[l_rows[q]] -= l_data[q] * xk
    for k in range(n - 1, -1, -1):
        last = u_ptr[k + 1] - 1
        xk = work[k] / u_data[last]
        work[k] = xk
        if xk != 0.0:
            for q in range(u_ptr[k], last):
                work[u_rows[q]] -= u_data[q] * xk
    for i in range(n):
        b[i] = work[perm_c[i]]


@kernel
def solve_transposed(perm_r, perm_c, l_ptr, l_rows, u_ptr, u_rows, l_data, u_data, b, work):
    """Solve ``A^T y = b`` in place with the factors of :func:`refactor`.

    ``A^T = Pc U^T L^T Pr``: ``work[perm_c] = b``, ``U^T`` forward and ``L^T``
    backward substitution (row-oriented on the CSC factors),
    ``b = work[perm_r]``. Arguments as for :func:`solve`.
    """
    n = b.size
    for i in range(n):
        work[perm_c[i]] = b[i]
    for k in range(n):
        last = u_ptr[k + 1] - 1
        s = work[k]
        for q in range(u_ptr[k], last):
            s -= u_data[q] * work[u_rows[q]]
        work[k] = s / u_data[last]
    for k in range(n - 1, -1, -1):
        s = work[k]
        for q in range(l_ptr[k], l_ptr[k + 1]):
            s -= l_data[q] * work[l_rows[q]]
        work[k] = s
    for i in range(n):
        b[i] = work[perm_r[i]]


@allocating_kernel
def _symbolic(b_ptr, b_rows):
    """Patterns of ``L`` (without diagonal) and ``U`` (diagonal last) of ``B`` without pivoting.

    The pattern of column ``j`` of ``L + U`` is the set of rows reachable from
    the rows of ``B[:, j]`` in the graph with edges ``k -> i`` for the entries
    ``L[i, k]``, ``k < j`` (Gilbert and Peierls), plus the diagonal.
    Returns ``l_ptr, l_rows, u_ptr, u_rows``.
    """
    n = b_ptr.size - 1
    cap = max(16, 2 * b_rows.size)
    l_rows = np.empty(cap, np.int32)
    u_rows = np.empty(cap, np.int32)
    l_ptr = np.zeros(n + 1, np.int64)
    u_ptr = np.zeros(n + 1, np.int64)
    mark = np.full(n, -1, np.int64)
    stack = np.empty(n, np.int64)
    found = np.empty(n, np.int64)
    nl = 0
    nu = 0
    for j in range(n):
        nf = 0
        top = 0
        mark[j] = j
        for p in range(b_ptr[j], b_ptr[j + 1]):
            r = b_rows[p]
            if mark[r] != j:
                mark[r] = j
                stack[top] = r
                top += 1
        while top > 0:
            top -= 1
            k = stack[top]
            found[nf] = k
            nf += 1
            if k < j:
                for q in range(l_ptr[k], l_ptr[k + 1]):
                    i = l_rows[q]
                    if mark[i] != j:
                        mark[i] = j
                        stack[top] = i
                        top += 1
        rows = np.sort(found[:nf])
        need_u = nu + nf + 1
        if need_u > u_rows.size:
            grown = np.empty(max(2 * u_rows.size, need_u), np.int32)
            grown[:nu] = u_rows[:nu]
            u_rows = grown
        need_l = nl + nf
        if need_l > l_rows.size:
            grown = np.empty(max(2 * l_rows.size, need_l), np.int32)
            grown[:nl] = l_rows[:nl]
            l_rows = grown
        for r in rows:
            if r < j:
                u_rows[nu] = r
                nu += 1
            elif r > j:
                l_rows[nl] = r
                nl += 1
        u_rows[nu] = j
        nu += 1
        u_ptr[j + 1] = nu
        l_ptr[j + 1] = nl
    return l_ptr, l_rows[:nl].copy(), u_ptr, u_rows[:nu].copy()


# ------------------------------------------------------------------------------ the plan
@dataclass(frozen=True, eq=False)
class LuPlan:
    """Pivot order, factor patterns and index maps of one symbolic factorisation.

    Attributes
    ----------
    n : int
    perm_r, perm_c : ndarray of int32, shape (n,)
        ``Pr A Pc = L U``: row ``i`` of ``A`` is row ``perm_r[i]`` of ``B``,
        column ``j`` of ``A`` is column ``perm_c[j]``.
    b_ptr : ndarray of int64, shape (n + 1,)
    b_rows, b_slots : ndarray of int32, shape (nnz,)
        ``B`` by columns: row in ``B`` and slot in ``A``'s ``data``.
    l_ptr, l_rows, u_ptr, u_rows : ndarray
        Patterns of ``L`` (strictly lower) and ``U`` (diagonal last per column).
    """

    n: int
    perm_r: np.ndarray
    perm_c: np.ndarray
    b_ptr: np.ndarray
    b_rows: np.ndarray
    b_slots: np.ndarray
    l_ptr: np.ndarray
    l_rows: np.ndarray
    u_ptr: np.ndarray
    u_rows: np.ndarray

    @property
    def l_nnz(self) -> int:
        """Stored entries of ``L`` (without its unit diagonal)."""
        return int(self.l_rows.size)

    @property
    def u_nnz(self) -> int:
        """Stored entries of ``U`` (with its diagonal)."""
        return int(self.u_rows.size)

    def refactor_args(self) -> tuple:
        """The plan's leading arguments of :func:`refactor`."""
        return (self.b_ptr, self.b_rows, self.b_slots, self.l_ptr, self.l_rows, self.u_ptr, self.u_rows)

    def solve_args(self) -> tuple:
        """The plan's leading arguments of :func:`solve` and :func:`solve_transposed`."""
        return (self.perm_r, self.perm_c, self.l_ptr, self.l_rows, self.u_ptr, self.u_rows)


def make_plan(pattern: SparsePattern, perm_r, perm_c) -> LuPlan:
    """Symbolic factorisation of ``pattern`` in a given pivot order.

    Parameters
    ----------
    pattern : SparsePattern
    perm_r, perm_c : array_like of int, shape (n,)
        Row and column permutations with ``Pr A Pc = L U`` (SuperLU's
        ``perm_r``, ``perm_c``).

    Returns
    -------
    LuPlan

    Notes
    -----
    The patterns are structural: every entry that the elimination of any
    matrix on ``pattern`` can make non-zero in this order is kept. Cost: a
    stable sort of the ``nnz`` entries plus the reach of every column, about
    the flops of one factorisation.
    """
    n = pattern.n
    perm_r = np.asarray(perm_r, dtype=np.int32)
    perm_c = np.asarray(perm_c, dtype=np.int32)
    if perm_r.shape != (n,) or perm_c.shape != (n,):
        raise ValueError("permutations must have the pattern's dimension")
    new_rows = perm_r[pattern.rows]
    new_cols = perm_c[pattern.cols]
    order = np.lexsort((new_rows, new_cols))
    b_rows = np.ascontiguousarray(new_rows[order], dtype=np.int32)
    b_slots = np.ascontiguousarray(order, dtype=np.int32)
    b_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(new_cols, minlength=n), out=b_ptr[1:])
    l_ptr, l_rows, u_ptr, u_rows = _symbolic(b_ptr, b_rows)
    return LuPlan(n, perm_r, perm_c, b_ptr, b_rows, b_slots, l_ptr, l_rows, u_ptr, u_rows)


def fresh_pivots(matrix: sp.csc_matrix, permc_spec: str = DEFAULT_PERMC_SPEC,
                 diag_pivot_thresh: float | None = None):
    """Pivot order of a fresh SuperLU factorisation of ``matrix``.

    Returns
    -------
    (perm_r, perm_c) or None
        ``None`` when SuperLU finds the matrix exactly singular.
    """
    try:
        lu = splu(matrix, permc_spec=permc_spec, diag_pivot_thresh=diag_pivot_thresh)
    except RuntimeError:
        return None
    return lu.perm_r, lu.perm_c


# ------------------------------------------------------------------------------ the wrapper
class SparseLU:
    """LU factorisations of matrices on one fixed pattern, refactored in a kept pivot order.

    Parameters
    ----------
    pattern : SparsePattern
    permc_spec : str
        SuperLU column ordering of the fresh factorisations
        (``"MMD_AT_PLUS_A"``, ``"COLAMD"``, ``"MMD_ATA"``, ``"NATURAL"``).
    diag_pivot_thresh : float, optional
        SuperLU's threshold for preferring a diagonal pivot in the fresh
        factorisations (default 1: partial pivoting).
    threshold : float
        Relative pivot threshold of the refactorisations
        (:data:`PIVOT_REL_THRESHOLD`).
    dtype : {float, complex}
        Of the matrices' values (complex: an ``.ac`` matrix ``j w E - H``; the
        kernels are compiled for each type at its first use).

    Attributes
    ----------
    plan : LuPlan or None
        The current pivot order and patterns (kept across failures).
    fresh_factorizations, refactorizations : int
        Successful factorisations that chose new pivots, and that reused them.
    status : int
        Status of the last :func:`refactor` (``STATUS_OK`` after success).

    Notes
    -----
    :meth:`factor` refactors in the plan's order; when a pivot degrades
    (below ``threshold`` of its column, zero or non-finite) it asks SuperLU for
    a new order on the same matrix, makes a new plan (or keeps the old one when
    the order is the same) and refactors again. Only the pivot order is taken
    from SuperLU; the factors used are always this module's.
    """

    def __init__(self, pattern: SparsePattern, *, permc_spec: str = DEFAULT_PERMC_SPEC,
                 diag_pivot_thresh: float | None = None, threshold: float = PIVOT_REL_THRESHOLD,
                 dtype=float) -> None:
        self.pattern = pattern
        self.permc_spec = permc_spec
        self.diag_pivot_thresh = diag_pivot_thresh
        self.threshold = float(threshold)
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.dtype(np.float64), np.dtype(np.complex128)):
            raise ValueError(f"dtype must be float or complex, not {self.dtype}")
        self.plan: LuPlan | None = None
        self.fresh_factorizations = 0
        self.refactorizations = 0
        self.status = STATUS_OK
        self._ok = False
        self._x = np.zeros(pattern.n, dtype=self.dtype)
        self._w = np.zeros(pattern.n, dtype=self.dtype)
        self._l = self._u = None

    @property
    def ready(self) -> bool:
        """True when a factorisation is available."""
        return self._ok

    def invalidate(self) -> None:
        """Forget the factorisation (the plan is kept)."""
        self._ok = False

    def _use(self, plan: LuPlan) -> None:
        if plan is not self.plan:
            self.plan = plan
            self._l = np.empty(plan.l_nnz, dtype=self.dtype)
            self._u = np.empty(plan.u_nnz, dtype=self.dtype)

    def _refactor(self, data: np.ndarray, threshold: float) -> int:
        plan = self.plan
        self.status = refactor(*plan.refactor_args(), data, self._l, self._u, self._x, threshold)
        return self.status

    def factor(self, data: np.ndarray) -> bool:
        """Factor the matrix with values ``data`` on the pattern.

        Parameters
        ----------
        data : ndarray, shape (nnz,)
            Of :attr:`dtype` (a real ``data`` for a complex LU is converted).

        Returns
        -------
        bool
            False when the matrix is singular (SuperLU finds no pivot order;
            or the elimination meets a zero pivot or a non-finite value in
            the order it chose); :attr:`ready` is then false.
        """
        data = np.ascontiguousarray(data, dtype=self.dtype)
        self._ok = False
        if self.plan is not None and self._refactor(data, self.threshold) == STATUS_OK:
            self.refactorizations += 1
            self._ok = True
            return True
        if self.status == STATUS_NONFINITE:
            return False
        pivots = fresh_pivots(self.pattern.matrix(data), self.permc_spec, self.diag_pivot_thresh)
        if pivots is None:
            return False
        perm_r, perm_c = pivots
        plan = self.plan
        if plan is None or not (np.array_equal(plan.perm_r, perm_r) and np.array_equal(plan.perm_c, perm_c)):
            plan = make_plan(self.pattern, perm_r, perm_c)
        self._use(plan)
        # SuperLU chose these pivots on this matrix: accept any non-zero finite one
        # (rounding may put a pivot a hair below the threshold, or a user's
        # diag_pivot_thresh below it)
        if self._refactor(data, 0.0) != STATUS_OK:
            return False
        self.fresh_factorizations += 1
        self._ok = True
        return True

    def solve(self, b: np.ndarray, trans: bool = False) -> np.ndarray:
        """Solve ``A y = b`` (``A^T y = b`` when ``trans``) with the current factorisation.

        Parameters
        ----------
        b : ndarray, shape (n,) or (n, k)
        trans : bool

        Returns
        -------
        ndarray
            ``y``, a new array of ``b``'s shape.
        """
        if not self._ok:
            raise RuntimeError("no factorisation: call factor() first")
        kern = solve_transposed if trans else solve
        args = self.plan.solve_args()
        y = np.array(b, dtype=self.dtype, order="F")
        if y.ndim == 1:
            kern(*args, self._l, self._u, y, self._w)
        else:
            for k in range(y.shape[1]):
                kern(*args, self._l, self._u, y[:, k], self._w)
        return y

    def pivots(self) -> np.ndarray:
        """Magnitudes of the pivots of the current factorisation, shape (n,), in elimination order."""
        if not self._ok:
            raise RuntimeError("no factorisation: call factor() first")
        return np.abs(self._u[self.plan.u_ptr[1:] - 1])

    def factors(self) -> tuple[sp.csc_matrix, sp.csc_matrix]:
        """``L`` (with its unit diagonal) and ``U`` as CSC matrices of the permuted matrix."""
        if not self._ok:
            raise RuntimeError("no factorisation: call factor() first")
        plan = self.plan
        n = plan.n
        cols = np.repeat(np.arange(n), np.diff(plan.l_ptr))
        lower = sp.csc_matrix((np.r_[self._l, np.ones(n)], (np.r_[plan.l_rows, np.arange(n)],
                                                             np.r_[cols, np.arange(n)])), shape=(n, n))
        upper = sp.csc_matrix((self._u.copy(), plan.u_rows.copy(), plan.u_ptr.copy()), shape=(n, n))
        return lower, upper
