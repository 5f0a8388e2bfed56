"""A dense LU with partial pivoting on a sparse pattern's values, in compiled code.

The compiled engine's linear solves go through :func:`factor` and
:func:`solve`. This dense version serves small systems (up to
``DENSE_MAX`` unknowns), where it is as fast as a sparse one.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["factor", "solve", "DENSE_MAX", "workspace"]

#: Largest system the dense LU serves.
DENSE_MAX = 300


def workspace(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The arrays :func:`factor` fills: the (n, n) factors and the pivot rows."""
    return np.zeros((n, n)), np.zeros(n, dtype=np.int64)


@njit(cache=True)
def factor(indptr, indices, data, lu, piv):
    """Factor the CSC matrix ``(indptr, indices, data)`` into ``lu``/``piv``.

    Returns
    -------
    bool
        False when a pivot is zero or not finite (singular matrix).
    """
    n = piv.size
    lu[:, :] = 0.0
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            lu[indices[p], j] += data[p]
    for k in range(n):
        best = k
        big = abs(lu[k, k])
        for i in range(k + 1, n):
            a = abs(lu[i, k])
            if a > big:
                big = a
                best = i
        piv[k] = best
        if not (big > 0.0) or big == np.inf:
            return False
        if best != k:
            for j in range(n):
                tmp = lu[k, j]
                lu[k, j] = lu[best, j]
                lu[best, j] = tmp
        inv = 1.0 / lu[k, k]
        for i in range(k + 1, n):
            f = lu[i, k] * inv
            if f != 0.0:
                lu[i, k] = f
                for j in range(k + 1, n):
                    lu[i, j] -= f * lu[k, j]
            else:
                lu[i, k] = 0.0
    return True


@njit(cache=True)
def solve(lu, piv, b):
    """Solve in place with the factors of :func:`factor`."""
    n = piv.size
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= lu[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= lu[i, j] * b[j]
        b[i] = s / lu[i, i]
