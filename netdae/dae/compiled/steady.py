"""Newton's method for the DC operating point, compiled: the steady-state solver's first phase.

The kernel is here; its Python side (packing, the pivot orders, the call) is
:mod:`netdae.dae.compiled.steady_driver`.

:func:`netdae.dae.steady.solve_steady` starts with plain Newton (the devices'
junction limiting, SPICE's convergence test) and turns to gmin and source
stepping only when it fails. For an MNA system of the compiled engine that
first phase runs here, in one compiled call per solve, with the transient
loop's own device evaluation (``bdf_loop._evaluate``) and sparse LU
(``lu.py``, refactored in a kept pivot order): a diode bridge's operating
point takes about 0.1 ms instead of 10 ms of numpy calls. The iteration is
the Python one step for step; only where the Python solver would stop plain
Newton (a near-singular Jacobian, a non-finite value, no convergence) does
the compiled call give up and the Python solver run from the start, with its
homotopies and its diagnostics. The singularity judgement of the solution
stays in Python (:func:`netdae.dae.steady._judge`).

Equilibrated pivots
-------------------
Python factors the Jacobian scaled by powers of two so that every row, then
every column, has its largest entry in (1/2, 1], and calls a pivot below
``PIVOT_SAFETY * n * eps`` ill-conditioned. Scaling rows and columns does not
change a factorisation in a fixed pivot order except by the same scales, so
the equilibrated pivots here are the refactored pivots times the row and
column scales of their positions.
"""

from __future__ import annotations

import math

from ...devices.kernels import FLAG_LIMITED, FLAG_NONFINITE
from . import entry_kernel, kernel
from . import bdf_loop as L
from .control import RESIDUAL_ROUNDING, row_magnitudes

__all__ = ["newton_dc", "sweep_dc", "CONVERGED", "NOT_CONVERGED", "NEED_PIVOTS", "ILL_CONDITIONED", "S_ITER", "S_FIRST", "N_S"]

CONVERGED = 0
NOT_CONVERGED = 1       # maxiter reached, a non-finite value: the Python solver takes over
NEED_PIVOTS = 2         # a degraded pivot: Python chooses new pivots for a_data, then calls again
ILL_CONDITIONED = 3     # a near-singular Jacobian: the Python solver (homotopies, diagnostics) takes over

# integer state of a solve (kept across NEED_PIVOTS returns)
S_ITER = 0       # iterations done
S_SMALL = 1      # the last update was small
S_FIRST = 2      # 1 until the first evaluation
N_S = 3


@kernel
def _pow2_scale(m):
    """``2**-ceil(log2(m))`` for m > 0, else 1 (the Python solver's :func:`_power_of_two_scale`)."""
    if m > 0.0:
        return math.ldexp(1.0, -int(math.ceil(math.log2(m))))
    return 1.0


@kernel
def _min_equilibrated_pivot(indptr, indices, a_data, lus, r, c):
    """Smallest pivot of the last factorisation of ``a_data``, rows then columns scaled by powers of two."""
    b_ptr, b_rows_, b_slots, l_ptr, l_rows, u_ptr, u_rows, perm_r, perm_c, l_data, u_data, lwork, swork = lus
    n = r.size
    for i in range(n):
        r[i] = 0.0
        c[i] = 0.0
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            a = abs(a_data[p])
            if a > r[indices[p]]:
                r[indices[p]] = a
    for i in range(n):
        r[i] = _pow2_scale(r[i])
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            a = abs(a_data[p]) * r[indices[p]]
            if a > c[j]:
                c[j] = a
    for j in range(n):
        c[j] = _pow2_scale(c[j])
    # B = Pr A Pc: B[perm_r[i], perm_c[j]] = A[i, j]; the pivot of B's column k is U[k, k]
    best = math.inf
    for i in range(n):
        lwork[perm_r[i]] = r[i]
    for j in range(n):
        k = perm_c[j]
        piv = abs(u_data[u_ptr[k + 1] - 1]) * lwork[k] * c[j]
        if piv < best:
            best = piv
    return best


@kernel
def _newton_dc(F, I, S, t, x, init, maxiter, reltol, x_atol, r_atol, paired, singular_pivot, sysd, devd, lus, u,
               evb, dx, absjx, pivot):
    """Newton iterations on ``phi(x, t) = 0`` in place on ``x`` (see the module docstring).

    Returns ``CONVERGED``, ``NOT_CONVERGED``, ``ILL_CONDITIONED`` or ``NEED_PIVOTS`` (then
    ``a_data`` holds the matrix; call again after new pivots: the state ``S`` resumes).
    Counts iterations in ``S[S_ITER]`` and evaluations and factorisations in ``I``;
    ``pivot[0]`` is the smallest equilibrated pivot of the last factorisation; ``paired``
    (int8, shape (n,)) marks the rows that are the current law of their unknown's node.
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    r_scale = dx  # work for the pivot judgement (dx is set after it)
    c_scale = absjx
    while S[S_ITER] < maxiter:
        if S[S_FIRST] != 0:
            state = L.STATE_INITIAL if init else L.STATE_NONE
        else:
            state = L.STATE_TRIAL
        flags = L._evaluate(I, t, x, state, True, True, sysd, devd, u, evb)
        S[S_FIRST] = 0
        I[L.I_HAS_TRY] = 1
        if flags & FLAG_NONFINITE:
            return NOT_CONVERGED
        for i in range(n):
            if not math.isfinite(phie[i]):
                return NOT_CONVERGED
        if S[S_SMALL] != 0 and (flags & FLAG_LIMITED) == 0:
            # SPICE's residual test: |phi| <= reltol m + RESIDUAL_ROUNDING |J| |x| + the row's
            # absolute tolerance, m the magnitude of the row's currents (netdae.dae.newton.residual_small)
            row_magnitudes(indptr, indices, dphie, x, paired, dx, absjx)
            small = True
            for i in range(n):
                if not (abs(phie[i]) <= reltol * dx[i] + RESIDUAL_ROUNDING * absjx[i] + r_atol[i]):
                    small = False
                    break
            if small:
                return CONVERGED
        status = L._factor(F, I, 0.0, 0.0, dqe, dphie, lus, a_data)
        if status == L.FACTOR_NEED_PIVOTS:
            S[S_FIRST] = 0
            return NEED_PIVOTS
        if status != L.FACTOR_OK:
            return ILL_CONDITIONED
        pivot[0] = _min_equilibrated_pivot(indptr, indices, a_data, lus, r_scale, c_scale)
        if pivot[0] <= singular_pivot:
            return ILL_CONDITIONED
        S[S_ITER] += 1
        # (-J) dx = phi: the update of J dx = -phi
        for i in range(n):
            dx[i] = phie[i]
        L._solve(lus, dx)
        small = True
        for i in range(n):
            d = dx[i]
            if not math.isfinite(d):
                return NOT_CONVERGED
            xn = x[i] + d
            tol = reltol * max(abs(x[i]), abs(xn)) + x_atol[i]
            if not (abs(d) <= tol):
                small = False
            x[i] = xn
        S[S_SMALL] = 1 if small else 0
    return NOT_CONVERGED



@entry_kernel
def newton_dc(F, I, S, t, x, init, maxiter, reltol, x_atol, r_atol, paired, singular_pivot, sysd, devd, lus, u,
              evb, dx, absjx, pivot):
    """:func:`_newton_dc` for Python callers (an entry kernel: its cache holds no IR for linking)."""
    return _newton_dc(F, I, S, t, x, init, maxiter, reltol, x_atol, r_atol, paired, singular_pivot, sysd, devd,
                      lus, u, evb, dx, absjx, pivot)


@entry_kernel
def sweep_dc(F, I, S, x, X, its, values, cols, p0, maxiter, reltol, x_atol, r_atol, paired, singular_pivot,
             clear_pivot, threshold, sysd, devd, lus, u, evb, dx, absjx, pivot):
    """A ``.dc`` sweep's points ``p0, p0 + 1, ...`` by plain Newton, each from the previous solution.

    Point ``p`` sets the swept sources' DC values (``spar[cols[s], 0] = values[p, s]``),
    runs :func:`newton_dc` from ``x`` and stores the solution in ``X[p]`` and its
    iterations in ``its[p]``. It stops at the first point whose solve is not clear,
    which Python then solves in full (homotopies, the singularity judgement): not
    converged, ill-conditioned, or converged with a smallest equilibrated pivot at or
    below ``clear_pivot`` (the judgement's threshold for a closer look).

    Returns
    -------
    (status, p)
        ``CONVERGED`` with ``p = len(values)`` when every point is done; else the
        status of point ``p`` (``NEED_PIVOTS``: ``a_data`` holds its matrix; call again
        with ``p0 = p`` after new pivots, the state ``S`` resumes the solve).
    """
    spar = sysd[9]
    for p in range(p0, values.shape[0]):
        if S[S_FIRST] != 0 and S[S_ITER] == 0:  # a fresh point (not a resumed one)
            for s in range(cols.size):
                spar[cols[s], 0] = values[p, s]
        status = _newton_dc(F, I, S, 0.0, x, False, maxiter, reltol, x_atol, r_atol, paired, singular_pivot, sysd,
                            devd, lus, u, evb, dx, absjx, pivot)
        if status != CONVERGED:
            return status, p
        if not pivot[0] > clear_pivot:
            return ILL_CONDITIONED, p
        for i in range(x.size):
            X[p, i] = x[i]
        its[p] = S[S_ITER]
        # the next point starts afresh (a new Newton solve from this solution)
        S[S_ITER] = 0
        S[S_SMALL] = 0
        S[S_FIRST] = 1
        F[L.F_LU_TAG] = math.nan
        F[L.F_PIVOT_THRESHOLD] = threshold
        pivot[0] = math.nan
    return CONVERGED, values.shape[0]
