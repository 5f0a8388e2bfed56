"""Many small dense solves of shifted pencils in one compiled call.

:func:`shifted_solves` solves ``(s_k E_r - H_r) x = b_r`` for every pencil
``r`` of a stack and every shift ``s_k``: the frequency response of many
small linear DAEs (a Monte Carlo sweep's rows, each at every frequency of
its analysis). numpy's batched ``solve`` calls LAPACK once per matrix, about
2 us each for a 5 x 5 system; here each system is formed in a work array and
factored in place (Gaussian elimination with partial pivoting, the pivot the
entry of largest ``|re| + |im|``, as LAPACK chooses), a few tenths of a microsecond each, and the stack
of matrices over all shifts is never stored.
"""

from __future__ import annotations

from . import kernel

__all__ = ["shifted_solves"]


@kernel
def shifted_solves(E, H, b, s, A, x, out, singular):  # pragma: no cover - compiled
    """Solve ``(s[k] E[r] - H[r]) out[r, k] = b[r]`` for every r and k.

    Parameters
    ----------
    E, H : ndarray, shape (m, n, n), float64
        The pencils.
    b : ndarray, shape (m, n), complex128
        Right-hand sides.
    s : ndarray, shape (f,), complex128
        The shifts (``j 2 pi f`` for a frequency response).
    A : ndarray, shape (n, n), complex128
        Work: one system.
    x : ndarray, shape (n,), complex128
        Work: its right-hand side.
    out : ndarray, shape (m, f, n), complex128
        The solutions (rows of a singular pencil are left unspecified).
    singular : ndarray, shape (m,), int64
        Set to 1 where a system of pencil r has an exactly zero pivot (the
        others are left as they were).
    """
    m, n = b.shape
    for r in range(m):
        for k in range(s.size):
            sr, si = s[k].real, s[k].imag
            for i in range(n):
                for j in range(n):
                    e = E[r, i, j]
                    A[i, j] = complex(sr * e - H[r, i, j], si * e)
                x[i] = b[r, i]
            failed = False
            for c in range(n):
                p = c
                best = abs(A[c, c].real) + abs(A[c, c].imag)
                for i in range(c + 1, n):
                    v = abs(A[i, c].real) + abs(A[i, c].imag)
                    if v > best:
                        best = v
                        p = i
                if best == 0.0:
                    failed = True
                    break
                if p != c:
                    for j in range(c, n):
                        t = A[c, j]
                        A[c, j] = A[p, j]
                        A[p, j] = t
                    t = x[c]
                    x[c] = x[p]
                    x[p] = t
                piv = A[c, c]
                for i in range(c + 1, n):
                    f = A[i, c] / piv
                    if f != 0.0:
                        for j in range(c + 1, n):
                            A[i, j] -= f * A[c, j]
                        x[i] -= f * x[c]
            if failed:
                singular[r] = 1
                break
            for i in range(n - 1, -1, -1):
                acc = x[i]
                for j in range(i + 1, n):
                    acc -= A[i, j] * out[r, k, j]
                out[r, k, i] = acc / A[i, i]
