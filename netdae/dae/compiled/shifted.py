"""The back substitution of many triangular pencils at many shifts, compiled.

The second half of :func:`netdae.dae.shifted.shifted_solves`: after the generalized Schur form of
each pencil (``H = Q S Z^H``, ``E = Q P Z^H``), every shift ``s`` is the triangular solve
``(s P - S) y = Q^H b`` and ``x = Z y``. In numpy that is some ``2 n^2`` passes over arrays of
(pencils x shifts) complex numbers, memory-bound; here one pass of ``O(n^2)`` arithmetic per
pencil and shift, in registers.
"""

from __future__ import annotations

import math

from . import kernel

__all__ = ["triangular_pencil_solves"]


@kernel
def triangular_pencil_solves(S, P, Z, c, s, X, failed, y):
    """``X[r, k] = Z[r] (s[k] P[r] - S[r])^-1 c[r]`` for every pencil ``r`` not ``failed`` and shift ``k``.

    Parameters
    ----------
    S, P, Z : ndarray of complex, shape (m, n, n)
        Upper triangular ``S``, ``P`` and unitary ``Z`` of each pencil's generalized Schur form.
    c : ndarray of complex, shape (m, n)
        ``Q^H b`` of each pencil.
    s : ndarray of complex, shape (f,)
        The shifts.
    X : ndarray of complex, shape (m, f, n)
        Written: the solutions (rows of failed pencils untouched).
    failed : ndarray of bool, shape (m,)
        Read, and set where a pencil is singular at a shift (an exactly zero pivot) or a solution is
        not finite.
    y : ndarray of complex, shape (n,)
        Work space.

    Notes
    -----
    Cost: ``m f (n^2 / 2 + n^2)`` complex multiply-adds.
    """
    m, n = c.shape
    for r in range(m):
        if failed[r]:
            continue
        bad = False
        for k in range(s.size):
            sk = s[k]
            for i in range(n - 1, -1, -1):
                acc = c[r, i]
                for j in range(i + 1, n):
                    acc -= (sk * P[r, i, j] - S[r, i, j]) * y[j]
                d = sk * P[r, i, i] - S[r, i, i]
                if d == 0:
                    bad = True
                    y[i] = complex(math.nan, math.nan)
                else:
                    y[i] = acc / d
            for i in range(n):
                v = 0j
                for j in range(n):
                    v += Z[r, i, j] * y[j]
                if not (math.isfinite(v.real) and math.isfinite(v.imag)):
                    bad = True
                X[r, k, i] = v
        failed[r] = bad
