"""Accumulators of matrix entries for assembly, with ground dropped.

Stamps are written as arrays of (row, column, value) with ground as index
``-1``; :class:`Triplets` drops every entry on a ground row or column, so the
element stamps need no branches.
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.sparse as sp

__all__ = ["Triplets", "CscSum"]


def _spread(values, shape: tuple) -> np.ndarray:
    """``values`` as floats of ``shape``, flat: a scalar repeated, an array of that shape as it is (a view)."""
    v = np.asarray(values, dtype=float)
    return v.ravel() if v.shape == shape else np.broadcast_to(v, shape).ravel()


class Triplets:
    """Growing lists of COO entries of an ``n x m`` matrix.

    Examples
    --------
    A 1 S conductance between node 0 and ground:

    >>> t = Triplets()
    >>> t.add_conductance(np.array([0]), np.array([-1]), np.array([1.0]))
    >>> t.matrix(1, 1).toarray()
    array([[1.]])
    """

    def __init__(self) -> None:
        self._rows: list[np.ndarray] = []
        self._cols: list[np.ndarray] = []
        self._vals: list[np.ndarray] = []
        self._recips: list[np.ndarray | None] = []

    def add(self, rows, cols, vals, recips=None) -> None:
        """Add entries; those with a ground (negative) row or column are dropped.

        ``recips``, optional: per entry a number ``w`` whose exact reciprocal the value stands for
        (``vals = 1 / w`` rounded: a resistor's conductance), NaN where the value is itself exact;
        only the exact structure reads it (:meth:`reciprocals`).
        """
        rows = np.asarray(rows, dtype=np.int64).ravel()
        cols = np.asarray(cols, dtype=np.int64).ravel()
        keep = (rows >= 0) & (cols >= 0)
        self._rows.append(rows[keep])
        self._cols.append(cols[keep])
        self._vals.append(_spread(vals, rows.shape)[keep])
        self._recips.append(None if recips is None else _spread(recips, rows.shape)[keep])

    def add_conductance(self, a, b, g, recip=None) -> None:
        """The symmetric two-terminal pattern ``[[g, -g], [-g, g]]`` between nodes a and b (``recip``: the
        ``w`` with ``g = 1 / w`` exactly where known, NaN elsewhere; see :meth:`add`)."""
        a = np.asarray(a, dtype=np.int64)
        b = np.asarray(b, dtype=np.int64)
        g = np.asarray(g, dtype=float)
        w = None if recip is None else np.broadcast_to(np.asarray(recip, dtype=float), g.shape)
        self.add(np.concatenate([a, a, b, b]), np.concatenate([a, b, a, b]), np.concatenate([g, -g, -g, g]),
                 None if w is None else np.concatenate([w, -w, -w, w]))

    def add_incidence(self, a, b, k, *, row_sign: float, col_sign: float) -> None:
        """Branch ``k`` between nodes a (+) and b (-).

        Adds ``col_sign * (+1 at (a, k), -1 at (b, k))`` (the branch current in
        the KCL rows) and ``row_sign * (+1 at (k, a), -1 at (k, b))`` (the node
        potentials in the branch row).
        """
        a = np.asarray(a, dtype=np.int64)
        b = np.asarray(b, dtype=np.int64)
        k = np.asarray(k, dtype=np.int64)
        one = np.ones(a.shape)
        if col_sign:
            self.add(np.concatenate([a, b]), np.concatenate([k, k]), col_sign * np.concatenate([one, -one]))
        if row_sign:
            self.add(np.concatenate([k, k]), np.concatenate([a, b]), row_sign * np.concatenate([one, -one]))

    def coordinates(self) -> tuple[np.ndarray, np.ndarray]:
        """All (row, column) coordinates added so far."""
        if not self._rows:
            return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        return np.concatenate(self._rows), np.concatenate(self._cols)

    def values(self) -> np.ndarray:
        """All values added so far, in the order of :meth:`coordinates`."""
        return np.concatenate(self._vals) if self._vals else np.empty(0)

    def reciprocals(self) -> np.ndarray:
        """Per value, in the order of :meth:`values`, the ``w`` whose exact reciprocal it stands for, or NaN."""
        if not self._vals:
            return np.empty(0)
        return np.concatenate([np.full(v.shape, np.nan) if w is None else w for v, w in zip(self._vals, self._recips)])

    def dense(self, n: int, m: int | None = None) -> np.ndarray:
        """The summed matrix as a dense array, shape (n, m) (m defaults to n); for small systems."""
        out = np.zeros((n, n if m is None else m))
        rows, cols = self.coordinates()
        np.add.at(out, (rows, cols), self.values())
        return out

    def matrix(self, n: int, m: int | None = None) -> sp.csc_matrix:
        """The summed matrix, shape (n, m) (m defaults to n)."""
        return self.summation(n, m).matrix(self.values())

    def summation(self, n: int, m: int | None = None) -> "CscSum":
        """How these coordinates sum into an ``n x m`` CSC matrix (m defaults to n): kept, it sums the
        values of any Triplets with the same coordinates (:class:`CscSum`).

        Raises
        ------
        ValueError
            An entry outside the matrix.
        """
        rows, cols = self.coordinates()
        return CscSum(rows, cols, n, n if m is None else m)


class CscSum:
    """How entries at fixed coordinates sum into a CSC matrix: made once, it sums any values given there.

    Parameters
    ----------
    rows, cols : ndarray of int, shape (k,)
        The entries' coordinates (duplicates allowed; they add up).
    n, m : int
        The matrix's shape.

    Raises
    ------
    ValueError
        An entry outside the matrix.

    Notes
    -----
    The matrix keeps every coordinate's entry, also where the values sum to zero, so its
    structure depends on the coordinates alone: matrices summed from the same coordinates
    share it (a sweep's rows, :func:`netdae.mna.assemble.reassemble`). Cost: one sort of the
    ``k`` keys here, then a ``bincount`` per :meth:`matrix`.
    """

    def __init__(self, rows: np.ndarray, cols: np.ndarray, n: int, m: int) -> None:
        self.shape = (int(n), int(m))
        self.size = int(rows.size)
        if rows.size and (rows.max() >= n or cols.max() >= m):
            raise ValueError(f"an entry lies outside the {n} x {m} matrix")
        # duplicates summed in one sort (what scipy's COO -> CSC does, without its checks and copies)
        keys, self._where = np.unique(cols * n + rows, return_inverse=True)
        self._indices = (keys % max(n, 1)).astype(np.int32)
        self._indptr = np.zeros(m + 1, dtype=np.int32)
        np.cumsum(np.bincount(keys // max(n, 1), minlength=m), out=self._indptr[1:])
        self._stored = int(keys.size)
        self._first: sp.csc_matrix | None = None  # the first matrix made, whose structure later ones copy

    def matrix(self, values: np.ndarray) -> sp.csc_matrix:
        """The matrix of ``values`` (shape (k,), in the coordinates' order), duplicates summed.

        The first matrix is made by scipy's constructor, which checks the structure; the later ones are
        shallow copies of it with their own data and their own copies of the index arrays (the same
        checked structure: 1-3 us instead of the constructor's 15-20 us, four times a sweep row).
        """
        data = np.bincount(self._where, weights=values, minlength=self._stored) if self.size else np.zeros(0)
        if self._first is None:
            self._first = (sp.csc_matrix((data, self._indices.copy(), self._indptr.copy()), shape=self.shape)
                           if self.size else sp.csc_matrix(self.shape))
            return self._first.copy()
        out = copy.copy(self._first)
        out.data, out.indices, out.indptr = data, self._first.indices.copy(), self._first.indptr.copy()
        return out
