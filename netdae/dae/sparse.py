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

__all__ = ["SparsePattern"]


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

    def row_magnitudes(self, data: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``|A| |x|``, shape (n,): the magnitude of the terms that make up each row of ``A x``."""
        return np.bincount(self.rows, weights=np.abs(data) * np.abs(x[self.cols]), minlength=self.n)

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
