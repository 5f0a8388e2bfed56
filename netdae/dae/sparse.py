"""A fixed sparsity pattern with precomputed scatter maps.

Assembly in netdae never builds a sparse matrix from scratch inside a Newton
iteration. The pattern (CSC, with the full diagonal) is computed once from the
coordinates of every possible contribution; each contribution gets a *slot*
(its position in the CSC ``data`` array), and assembling values is one
``numpy.bincount`` (or ``numpy.add.at``) over those slots.

Examples
--------
>>> import numpy as np
>>> rows = np.array([0, 0, 1, 1]); cols = np.array([0, 1, 0, 1])
>>> pat = SparsePattern.from_coo(3, [rows], [cols])
>>> slots = pat.slots(rows, cols)
>>> m = pat.matrix(pat.scatter(slots, np.array([1.0, -1.0, -1.0, 1.0])))
>>> m.toarray()
array([[ 1., -1.,  0.],
       [-1.,  1.,  0.],
       [ 0.,  0.,  0.]])
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["SparsePattern", "residual_small", "residual_tolerance", "RESIDUAL_ROUNDING", "bipartite_components"]

#: The rounding of a residual row's sum, per ``|J| |x|``: SPICE's residual test allows it beside
#: ``reltol`` times the row's currents (:func:`residual_small`), since a row whose branch currents
#: are all zero (two nodes at one potential) still sums terms of ``g |x|`` in floating point.
RESIDUAL_ROUNDING = 64 * 2.220446049250313e-16


class SparsePattern:
    """CSC sparsity pattern of an ``n x n`` matrix that always includes the diagonal.

    Parameters
    ----------
    n : int
        Matrix dimension.
    indptr, indices : ndarray of int
        CSC structure (sorted row indices within each column, no duplicates).

    Attributes
    ----------
    nnz : int
        Number of stored entries.
    diag : ndarray of int, shape (n,)
        Slot of each diagonal entry in the ``data`` array.
    rows, cols : ndarray of int, shape (nnz,)
        Row and column of every slot.
    """

    def __init__(self, n: int, indptr: np.ndarray, indices: np.ndarray) -> None:
        self.n = int(n)
        self.indptr = np.asarray(indptr, dtype=np.int32)
        self.indices = np.asarray(indices, dtype=np.int32)
        self.nnz = int(self.indices.size)
        self.cols = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self.indptr))
        self.rows = self.indices.astype(np.int64)
        # key = col * n + row is sorted because CSC is column-major with sorted rows
        self._keys = self.cols * self.n + self.rows
        self.diag = self.slots(np.arange(self.n), np.arange(self.n))

    @classmethod
    def from_coo(cls, n: int, rows_list, cols_list) -> "SparsePattern":
        """Union pattern of the given coordinate arrays plus the diagonal.

        Parameters
        ----------
        n : int
        rows_list, cols_list : sequence of array_like of int
            Coordinates of every possible non-zero, in any order, duplicates allowed.

        Notes
        -----
        Cost O(m log m) for m coordinates (one sort).
        """
        rows = [np.arange(n, dtype=np.int64)] + [np.asarray(r, dtype=np.int64).ravel() for r in rows_list]
        cols = [np.arange(n, dtype=np.int64)] + [np.asarray(c, dtype=np.int64).ravel() for c in cols_list]
        r = np.concatenate(rows)
        c = np.concatenate(cols)
        if r.size and (r.min() < 0 or c.min() < 0 or r.max() >= n or c.max() >= n):
            raise ValueError("coordinates out of range for the pattern")
        keys = np.unique(c * n + r)
        cols_u = keys // n
        rows_u = keys % n
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(cols_u, minlength=n), out=indptr[1:])
        return cls(n, indptr, rows_u)

    @classmethod
    def from_matrices(cls, *mats) -> "SparsePattern":
        """Union pattern of sparse (or dense) matrices, plus the diagonal."""
        rows, cols = [], []
        n = None
        for m in mats:
            coo = sp.coo_matrix(m)
            n = coo.shape[0] if n is None else n
            rows.append(coo.row)
            cols.append(coo.col)
        return cls.from_coo(n, rows, cols)

    def slots(self, rows, cols) -> np.ndarray:
        """Slots in ``data`` of the entries at (rows, cols).

        Raises
        ------
        ValueError
            When a coordinate is not part of the pattern.
        """
        rows = np.asarray(rows, dtype=np.int64)
        cols = np.asarray(cols, dtype=np.int64)
        keys = cols * self.n + rows
        pos = np.searchsorted(self._keys, keys)
        pos_c = np.minimum(pos, max(self.nnz - 1, 0))
        if keys.size and (self.nnz == 0 or np.any(self._keys[pos_c] != keys)):
            raise ValueError("entry not in the sparsity pattern")
        return pos_c.astype(np.int64)

    def scatter(self, slots: np.ndarray, values: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Sum ``values`` into a ``data`` array at ``slots`` (duplicates add up)."""
        acc = np.bincount(slots, weights=values, minlength=self.nnz)
        if out is None:
            return acc
        out += acc
        return out

    def zeros(self) -> np.ndarray:
        """A zero ``data`` array."""
        return np.zeros(self.nnz)

    def row_magnitudes(self, data: np.ndarray, x: np.ndarray, paired: np.ndarray | None = None) -> np.ndarray:
        """The magnitude of the terms that make up each row of ``A x``, shape (n,).

        Without ``paired``, ``|A| |x|``. With it, a row ``i`` paired with unknown
        ``i`` (a node's current law and the node's potential) measures the
        entries of the paired columns from its own potential, as the branch
        currents they stand for:

        ``sum_{j paired, j != i} |a_ij| |x_j - x_i| + |sum_{j paired} a_ij| |x_i|
        + sum_{j not paired} |a_ij| |x_j|``.

        A conductance ``g`` between nodes ``i`` and ``j`` contributes ``|g (x_j -
        x_i)|``, its current, and one to ground ``|g x_i|``; ``|A| |x|`` would
        count ``g (|x_i| + |x_j|)``, which at a common potential of 50 V exceeds
        a junction's current by orders of magnitude and lets a residual test
        pass an iterate whose current law is off by milliamperes. The measure
        does not change when every node potential moves by the same amount
        except through the conductances to ground, and it is at most ``|A| |x|``
        on a row of an M-matrix (a passive node).

        Parameters
        ----------
        data : ndarray, shape (nnz,)
            Values of ``A`` on this pattern.
        x : ndarray, shape (n,)
        paired : ndarray of bool, shape (n,), optional
            Whether row ``i`` is the current law of the node whose potential is
            unknown ``i`` (an MNA node; ``kinds == KIND_VOLTAGE``).

        Returns
        -------
        ndarray, shape (n,)

        Notes
        -----
        Cost: O(nnz). The compiled engine's operating-point Newton has the same
        measure (:func:`netdae.dae.compiled.control.row_magnitudes`).
        """
        a = np.abs(data)
        if paired is None:
            return np.bincount(self.rows, weights=a * np.abs(x[self.cols]), minlength=self.n)
        both = paired[self.rows] & paired[self.cols]
        xc = x[self.cols]
        mag = np.bincount(self.rows, weights=a * np.abs(np.where(both, xc - x[self.rows], xc)), minlength=self.n)
        total = np.bincount(self.rows, weights=np.where(both, data, 0.0), minlength=self.n)
        mag += np.where(paired, np.abs(total) * np.abs(x), 0.0)
        return mag

    def matrix(self, data: np.ndarray) -> sp.csc_matrix:
        """A CSC matrix sharing this pattern (``data`` is not copied)."""
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def data_of(self, matrix) -> np.ndarray:
        """Values of ``matrix`` laid out in this pattern.

        Raises
        ------
        ValueError
            When ``matrix`` has a non-zero outside the pattern.
        """
        if sp.issparse(matrix) and matrix.format == "csc" and matrix.shape == (self.n, self.n):
            # read the CSC arrays directly (a COO copy through scipy costs ~0.1 ms)
            data = np.asarray(matrix.data)
            cols = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(matrix.indptr))
            rows = np.asarray(matrix.indices, dtype=np.int64)
        else:
            coo = sp.coo_matrix(matrix)
            data, rows, cols = coo.data, coo.row, coo.col
        mask = data != 0
        return self.scatter(self.slots(rows[mask], cols[mask]), data[mask])


def residual_small(pattern: SparsePattern, r: np.ndarray, jac: np.ndarray, x: np.ndarray, reltol: float,
                   r_atol: np.ndarray, paired: np.ndarray | None = None) -> bool:
    """SPICE's residual test (:class:`netdae.dae.newton.SpiceTest`).

    Every row: ``|r| <= reltol m + RESIDUAL_ROUNDING |J| |x| + r_atol``, ``m`` the
    magnitude of the row's terms (:meth:`SparsePattern.row_magnitudes`).

    Parameters
    ----------
    pattern : SparsePattern
    r : ndarray, shape (n,)
        The residual at ``x``.
    jac : ndarray, shape (nnz,)
        Its Jacobian on ``pattern``.
    x : ndarray, shape (n,)
    reltol : float
    r_atol : ndarray, shape (n,)
    paired : ndarray of bool, shape (n,), optional
        See :meth:`SparsePattern.row_magnitudes`; without it ``m = |J| |x|`` and no
        rounding term.

    Returns
    -------
    bool
    """
    return bool(np.all(np.abs(r) <= residual_tolerance(pattern, jac, x, reltol, r_atol, paired)))


def residual_tolerance(pattern: SparsePattern, jac: np.ndarray, x: np.ndarray, reltol: float, r_atol: np.ndarray,
                       paired: np.ndarray | None = None) -> np.ndarray:
    """Each row's tolerance in :func:`residual_small`: ``reltol m + RESIDUAL_ROUNDING |J| |x| + r_atol``, shape (n,).

    Without ``paired``, ``reltol |J| |x| + r_atol`` (no rounding term). Arguments as
    :func:`residual_small`'s.
    """
    tol = reltol * pattern.row_magnitudes(jac, x, paired) + r_atol
    if paired is not None:
        tol += RESIDUAL_ROUNDING * pattern.row_magnitudes(jac, x)
    return tol


def bipartite_components(rows: np.ndarray, cols: np.ndarray, m: int, k: int) -> tuple[int, np.ndarray, np.ndarray]:
    """The independent groups of rows and columns of an ``m x k`` sparsity pattern.

    Connected components of the bipartite graph whose edges are the entries ``(rows[e], cols[e])``; a row
    or column without entries is a group of its own.

    Returns
    -------
    count : int
    row_label : ndarray of int, shape (m,)
    col_label : ndarray of int, shape (k,)
        The group of each row and column (labels in ``range(count)``).
    """
    from scipy.sparse.csgraph import connected_components

    rows = np.asarray(rows)
    graph = sp.coo_matrix((np.ones(rows.size), (rows, m + np.asarray(cols))), shape=(m + k, m + k))
    count, labels = connected_components(graph, directed=False)
    return count, labels[:m], labels[m:]
