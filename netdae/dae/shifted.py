"""Solves of many small dense pencils at many shifts: ``(s_k E_r - H_r) x = b_r``.

The frequency response of linear DAEs ``E x' = H x + b u`` at the shifts
``s = j w`` (a sweep's rows, each at every frequency of its analysis). Per
pencil the generalized Schur form is computed once (LAPACK ``zgges``:
``H = Q S Z^H``, ``E = Q P Z^H``, ``S`` and ``P`` upper triangular, ``Q``
and ``Z`` unitary); every shift is then the triangular solve
``(s P - S) y = Q^H b``, ``x = Z y``, and the back substitution runs over
all pencils and shifts at once (numpy arrays of shape (pencils, shifts)).
Unitary transformations and a triangular solve are backward stable, and no
inverse of ``H`` is formed, so a pencil whose ``H`` is singular is solved as
well as any. Cost: O(n^3) per pencil plus O(n^2) per shift, where a dense
LU per shift costs O(n^3) and a LAPACK call (about 2 us) each.
"""

from __future__ import annotations

import numpy as np

__all__ = ["shifted_solves"]


def _no_ordering(alpha, beta):  # zgges's eigenvalue selection, unused (no ordering asked)
    return False


def shifted_solves(E: np.ndarray, H: np.ndarray, b: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``(s[k] E[r] - H[r]) X[r, k] = b[r]`` for every pencil r and shift k.

    Parameters
    ----------
    E, H : ndarray, shape (m, n, n)
        The pencils (real or complex).
    b : ndarray, shape (m, n)
        Right-hand sides.
    s : ndarray, shape (f,)
        The shifts (``2j pi f`` for a frequency response).

    Returns
    -------
    X : ndarray, shape (m, f, n), complex
        The solutions.
    failed : ndarray of bool, shape (m,)
        Pencils whose Schur form failed or that are singular at a shift (an
        exactly zero pivot, or a solution that is not finite): their rows of
        ``X`` are not solutions.

    Examples
    --------
    >>> E = np.array([[[1.0, 0.0], [0.0, 0.0]]]); H = np.array([[[-1.0, 0.0], [1.0, -1.0]]])
    >>> X, failed = shifted_solves(E, H, np.array([[1.0, 0.0]]), np.array([0.0, 1j]))
    >>> np.round(X[0], 12).tolist(), failed.tolist()
    ([[(1+0j), (1+0j)], [(0.5-0.5j), (0.5-0.5j)]], [False])
    """
    from scipy.linalg import lapack

    m, n = b.shape
    s = np.asarray(s, dtype=complex)
    S = np.zeros((m, n, n), dtype=complex)
    P = np.zeros((m, n, n), dtype=complex)
    Z = np.zeros((m, n, n), dtype=complex)
    c = np.zeros((m, n), dtype=complex)
    failed = np.zeros(m, dtype=bool)
    gges = lapack.get_lapack_funcs("gges", (S,))
    lwork = None
    for r in range(m):
        h, e = np.array(H[r], dtype=complex, order="F"), np.array(E[r], dtype=complex, order="F")
        if lwork is None:
            lwork = max(int(gges(_no_ordering, h, e, lwork=-1)[-2][0].real), 2 * n, 1)
        s_r, p_r, _, _, _, q, z, _, info = gges(_no_ordering, h, e, jobvsl=1, jobvsr=1, sort_t=0, lwork=lwork)
        if info != 0:
            failed[r] = True
            continue
        S[r], P[r], Z[r] = s_r, p_r, z
        c[r] = q.conj().T @ b[r]
    # back substitution, component by component over all pencils and shifts: arrays (m, f), in place
    Pt = np.ascontiguousarray(P.transpose(1, 2, 0))[..., None]  # (n, n, m, 1)
    St = np.ascontiguousarray(S.transpose(1, 2, 0))[..., None]
    Y = np.empty((n, m, s.size), dtype=complex)
    term = np.empty((m, s.size), dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for i in range(n - 1, -1, -1):
            acc = Y[i]
            acc[...] = c[:, i, None]
            for j in range(i + 1, n):
                np.multiply(s, Pt[i, j], out=term)
                np.subtract(term, St[i, j], out=term)
                np.multiply(term, Y[j], out=term)
                np.subtract(acc, term, out=acc)
            np.multiply(s, Pt[i, i], out=term)
            np.subtract(term, St[i, i], out=term)
            failed |= np.any(term == 0, axis=1)
            np.divide(acc, term, out=acc)
        X = np.matmul(Y.transpose(1, 2, 0), Z.transpose(0, 2, 1))
    failed |= ~np.all(np.isfinite(X), axis=(1, 2))
    return X, failed
