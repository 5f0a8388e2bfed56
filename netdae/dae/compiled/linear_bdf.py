"""The compiled FLC-BDF step loop for linear DAEs ``E x' = H x + B u(t)``.

This is :class:`netdae.dae.bdf.BDF` for a linear system (same phases, same
constants, same step and order decisions) run as one compiled function: the
coefficients, the predictor, the exact corrector (one solve with the
factorisation of ``cj E - H``, refactored when ``cj`` changes), the error
test, order and step selection, breakpoints, order-1 restarts with their
derivative probes, and the recording of the output. Python enters it once
per output chunk (:mod:`netdae.dae.compiled.driver`).

State
-----
All state lives in arrays so that a chunk can end and the next one resume
between two steps: the scalars in ``F`` (floats) and ``I`` (integers),
indexed by the ``F_*`` and ``I_*`` constants below; the divided differences
``P`` (maxord + 1, n); the coefficient arrays; the output buffers.
"""

from __future__ import annotations

import math

import numpy as np

from .control import error_norms, flc_coefficients, landing_step, set_weights, update_differences, weighted_norm
from . import kernel
from .lu import STATUS_NONFINITE, STATUS_OK
from .lu import refactor as lu_refactor
from .lu import solve as lu_solve
from .sources import source_values

# the method's constants, owned by netdae.dae.bdf (where each is explained)
from ..bdf import (  # noqa: E402
    BREAKPOINT_STRETCH,
    EPS,
    ERROR_FLOOR,
    ETA_ERROR_FAIL_MIN,
    ETA_GROW_MAX,
    ETA_GROW_MIN,
    ETA_NEWTON_FAIL,
    ETA_SAFETY,
    ETA_SHRINK_MAX,
    ETA_SHRINK_MIN,
    H0_ERROR_TARGET,
    H0_FRACTION,
    JUMP_DETECT,
    MAX_ERROR_FAILURES,
    MAX_NEWTON_FAILURES,
    MAX_ORDER,
    PROBE_FRACTION,
    PROBE_MAX_RATIO,
    PROBE_RETRIES,
    ROUNDING_FACTOR,
    ROUNDOFF_ULPS,
)
#: Unknowns named per recorded jump (the rest are counted).
JUMP_NAMES = 32

# --- float scalars F[...] ------------------------------------------------------------
F_T = 0           # current time
F_H = 1           # next step size
F_HUSED = 2
F_CJ = 3
F_LU_TAG = 5      # cj of the current factorisation (nan: none)
F_RTOL = 6
F_MAX_STEP = 7
F_MIN_STEP = 8
F_H_MIN = 9       # statistics
F_H_MAX = 10
F_FAIL_T = 11
F_FAIL_H = 12
F_LAST_CJ_ATTEMPT = 13
F_H_REQUEST = 15
F_RESTART_CAP = 16      # the pending restart's step cap
F_RESTART_FIXED = 17    # 1.0: the pending restart keeps its cap (a given first step)
F_PENDING_TAG = 18      # tag of the matrix that needs fresh pivots (a_data holds it)
F_PIVOT_TAG = 19        # tag of the matrix fresh pivoting found singular
F_PIVOT_THRESHOLD = 20  # relative pivot threshold of the refactorisations
N_F = 21

# --- integer scalars I[...] ----------------------------------------------------------
I_K = 0
I_KUSED = 1
I_NS = 2
I_PHASE = 3
I_NST = 4
I_IBP = 5
I_GROWTH_FAILED = 6
I_STATUS = 7
I_STEPS = 8
I_REJECTED = 9
I_NEWTON = 10
I_NEWTON_FAILURES = 11
I_FACTORIZATIONS = 12
I_EVALUATIONS = 13
I_JAC_EVALUATIONS = 14
I_CJ_CHANGES = 15
I_RESTARTS = 16
I_PROBES = 17
I_MAX_ORDER_USED = 18
I_M = 19          # records written
I_FAIL_CODE = 20
I_FAIL_WORST = 21
I_MAXORD = 22
I_NORM = 23
I_RELREF = 24
I_MAX_STEPS = 25  # 0: no limit
I_NRESTART_TIMES = 26
I_STARTED = 27          # 0: nothing done; 1: running
I_PENDING_RESTART = 28  # an order-1 restart (with probes) is due before the next step
I_PIVOTS_FAILED = 29    # fresh pivoting found the matrix tagged F_PIVOT_TAG singular
I_NJUMPS = 30           # jumps recorded
I_NSEGMENTS = 31        # segment starts recorded (restarts and jumps)
N_I = 32

# statuses
RUNNING = 0
FINISHED = 1
FAILED = 2
BUFFER_FULL = 3   # the output buffers are full: grow them and call again
CHUNK_DONE = 4    # the chunk's step budget is used: call again
NEED_PIVOTS = 5   # a refactorisation met a degraded pivot: choose new pivots for a_data, call again

# results of _factor
FACTOR_OK = 0
FACTOR_SINGULAR = 1
FACTOR_NEED_PIVOTS = 2

# failure codes
FAIL_NEWTON = 1          # too many Newton (linear-solve) failures
FAIL_ERROR = 2           # too many error-test failures
FAIL_MIN_STEP = 3        # step at min_step and still failing
FAIL_ROUNDOFF = 4        # step below the roundoff of t
FAIL_PROBE_SINGULAR = 5  # the probe's matrix E/eps - H is singular
FAIL_PROBE_NONFINITE = 6
FAIL_MAX_STEPS = 7
FAIL_START_NONFINITE = 8

# what failed last inside a step (for messages): singular or non-finite
REASON_SINGULAR = 1
REASON_NONFINITE = 2


@kernel
def _matvec_add(indptr, indices, data, x, scale, out):
    """``out += scale * A x`` for the CSC matrix A."""
    for j in range(x.size):
        xj = x[j] * scale
        if xj != 0.0:
            for p in range(indptr[j], indptr[j + 1]):
                out[indices[p]] += data[p] * xj


@kernel
def _phi(t, x, sysd, u, out):
    """``out = H x + B u(t)``."""
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n = sysd
    out[:] = 0.0
    _matvec_add(indptr, indices, h_data, x, 1.0, out)
    if skind.size:
        source_values(skind, spar, spwl_t, spwl_v, spwl_n, t, u)
        for e in range(b_rows.size):
            out[b_rows[e]] += b_vals[e] * u[b_cols[e]]


@kernel
def _factor(F, I, tag, eps, sysd, lus):
    """Factor ``tag E - H`` (``E / eps - H`` when eps > 0, tag = 1/eps) in the kept pivot order.

    Returns FACTOR_OK, FACTOR_SINGULAR, or FACTOR_NEED_PIVOTS (then ``a_data`` holds the
    matrix and F_PENDING_TAG its tag: the caller returns NEED_PIVOTS to Python).
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n = sysd
    if eps > 0.0:
        for p in range(a_data.size):
            a_data[p] = e_data[p] / eps - h_data[p]
    else:
        for p in range(a_data.size):
            a_data[p] = tag * e_data[p] - h_data[p]
    F[F_LU_TAG] = math.nan
    if I[I_PIVOTS_FAILED] != 0 and F[F_PIVOT_TAG] == tag:
        return FACTOR_SINGULAR
    b_ptr, b_rows_, b_slots, l_ptr, l_rows, u_ptr, u_rows, perm_r, perm_c, l_data, u_data, lwork, swork = lus
    status = lu_refactor(b_ptr, b_rows_, b_slots, l_ptr, l_rows, u_ptr, u_rows, a_data, l_data, u_data, lwork,
                         F[F_PIVOT_THRESHOLD])
    if status == STATUS_OK:
        I[I_FACTORIZATIONS] += 1
        F[F_LU_TAG] = tag
        return FACTOR_OK
    if status == STATUS_NONFINITE:
        return FACTOR_SINGULAR
    F[F_PENDING_TAG] = tag
    return FACTOR_NEED_PIVOTS


@kernel
def _solve(lus, b):
    """Solve in place with the current factorisation."""
    b_ptr, b_rows_, b_slots, l_ptr, l_rows, u_ptr, u_rows, perm_r, perm_c, l_data, u_data, lwork, swork = lus
    lu_solve(perm_r, perm_c, l_ptr, l_rows, u_ptr, u_rows, l_data, u_data, b, swork)


@kernel
def _worst(v, w):
    best = -1
    big = -1.0
    for i in range(v.size):
        a = abs(v[i] * w[i])
        if a != a:
            return i
        if a > big:
            big = a
            best = i
    return best


@kernel
def _fail(F, I, t, h, code, worst):
    I[I_STATUS] = FAILED
    I[I_FAIL_CODE] = code
    I[I_FAIL_WORST] = worst
    F[F_FAIL_T] = t
    F[F_FAIL_H] = h


@kernel
def _restore(P, psi, psi_saved, beta, ns, k):
    """Undo phase 1 of a failed attempt (IDA's IDARestore): psi and the beta-scaled differences."""
    psi[:] = psi_saved
    for i in range(ns, k + 1):
        for c in range(P.shape[1]):
            P[i, c] /= beta[i]


@kernel
def _initialise_history(F, I, P, psi, h, xp):
    n = xp.size
    P[1:, :] = 0.0
    for i in range(n):
        P[1, i] = h * xp[i]
    psi[0] = h
    I[I_K] = 1
    I[I_KUSED] = 0
    F[F_HUSED] = 0.0
    I[I_NS] = 0
    I[I_PHASE] = 0
    I[I_NST] = 0
    F[F_CJ] = 1.0 / h
    I[I_GROWTH_FAILED] = 0
    F[F_H] = h


@kernel
def _rounding_floor(x, qp, cj, sysd, lus, signs, w, w_out, b1, b2):
    """Weights with every tolerance raised to the corrector's rounding level (see
    :meth:`netdae.dae.bdf.BDF._rounding_weights`): ``w_out`` from ``w``."""
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n = sysd
    n = x.size
    b1[:] = 0.0
    for j in range(n):
        xj = abs(x[j])
        if xj != 0.0:
            for p in range(indptr[j], indptr[j + 1]):
                b1[indices[p]] += abs(e_data[p]) * xj
    for i in range(n):
        b1[i] = (b1[i] * cj + abs(qp[i])) * (ROUNDING_FACTOR * EPS)
        b2[i] = b1[i] * signs[i]
    _solve(lus, b1)
    _solve(lus, b2)
    for i in range(n):
        floor = max(abs(b1[i]), abs(b2[i]))
        w_out[i] = w[i]
        if floor * w[i] > 1.0:
            w_out[i] = 1.0 / floor


@kernel
def _probe(F, I, t, x, eps, high, sysd, lus, u, xp, xpp, xr, x2, wf, signs, w, b1, b2, work):
    """x'(t+) into ``xp``, x''(t+) into ``xpp`` by two implicit-Euler steps of size eps.

    Also the right limit ``xr`` (the two steps extrapolated to eps = 0), the second
    step's value ``x2`` and, in ``wf``, the weights raised to the probe's rounding level.
    Returns FACTOR_OK, FACTOR_NEED_PIVOTS, or FACTOR_SINGULAR after recording a failure.
    """
    I[I_PROBES] += 1
    I[I_EVALUATIONS] += 1
    I[I_JAC_EVALUATIONS] += 1
    _phi(t + eps, x, sysd, u, xp)
    for i in range(x.size):
        if not math.isfinite(xp[i]):
            _fail(F, I, t, eps, FAIL_PROBE_NONFINITE, i)
            return FACTOR_SINGULAR
    if F[F_LU_TAG] != 1.0 / eps:
        rc = _factor(F, I, 1.0 / eps, eps, sysd, lus)
        if rc == FACTOR_NEED_PIVOTS:
            I[I_PROBES] -= 1  # it will be repeated
            I[I_EVALUATIONS] -= 1
            I[I_JAC_EVALUATIONS] -= 1
            return rc
        if rc == FACTOR_SINGULAR:
            _fail(F, I, t, eps, FAIL_PROBE_SINGULAR, -1)
            return rc
    for i in range(x.size):
        x2[i] = xp[i]  # phi(x, t + eps), for the rounding floor
    _solve(lus, xp)
    for i in range(x.size):
        xp[i] /= eps
        work[i] = x[i] + eps * xp[i]
    I[I_EVALUATIONS] += 1
    _phi(t + 2.0 * eps, work, sysd, u, xpp)
    _solve(lus, xpp)
    _rounding_floor(x, x2, 1.0 / eps, sysd, lus, signs, w, wf, b1, b2)
    for i in range(x.size):
        xp1 = xpp[i] / eps
        xr[i] = work[i] - eps * xp1
        x2[i] = work[i] + eps * xp1
        xpp[i] = (xp1 - xp[i]) / eps
        if not (math.isfinite(xp[i]) and math.isfinite(xpp[i])):
            _fail(F, I, t, eps, FAIL_PROBE_SINGULAR, -1)
            return FACTOR_SINGULAR
        if high[i]:
            xp[i] = 0.0
            xpp[i] = 0.0
    return FACTOR_OK


@kernel
def _jump(F, I, t, x, xr, x2, wf, high, P, rtol, atol, mask, xmax, w, w_err, save,
          buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments):
    """Continue from the right limit where it differs from ``x`` (see ``BDF._jump``).

    Returns -1 when nothing jumped, else 1 when an unknown that is not index 2 jumped (the
    inputs' values jumped or the start was inconsistent: the derivatives must be probed
    again), 0 when only index-2 unknowns did. On a jump ``x`` becomes the right limit,
    which is recorded a second time at ``t`` and starts a new segment.
    """
    n = x.size
    big = 0.0
    value_jump = False
    for i in range(n):
        m = abs(xr[i] - x[i]) * wf[i]
        if m > big or m != m:
            big = m
        if m > JUMP_DETECT and not high[i]:
            value_jump = True
    if not (big > JUMP_DETECT):
        return -1
    if value_jump:
        # an input value jumped: the index-2 unknowns carry an impulse in the first probe
        # step, their right limit is the value after the second
        for i in range(n):
            if high[i]:
                xr[i] = x2[i]
    j = I[I_NJUMPS]
    jump_t[j] = t
    count = 0
    for i in range(n):
        if abs(xr[i] - x[i]) * wf[i] > JUMP_DETECT:
            if count < JUMP_NAMES:
                jump_idx[j, count] = i
            count += 1
    jump_count[j] = count
    I[I_NJUMPS] = j + 1
    for i in range(n):
        x[i] = xr[i]
        P[0, i] = xr[i]
    set_weights(x, rtol, atol, I[I_RELREF], xmax, mask, w, w_err)
    m = I[I_M]
    buf_t[m] = t
    buf_k[m] = 0
    for c in range(save.size):
        buf_x[m, c] = x[save[c]]
    I[I_M] = m + 1
    segments[I[I_NSEGMENTS]] = m
    I[I_NSEGMENTS] += 1
    return 1 if value_jump else 0


@kernel
def _restart_at(F, I, P, psi, t, x, cap, fixed, high, sysd, lus, u, xp, xpp, xr, x2, wf, signs, b1, b2, work,
                rtol, atol, mask, xmax, w, w_err, save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx,
                segments):
    """Probe the derivatives at (t, x), continue from the right limit where the solution
    jumps, and start at order 1 with a step <= cap (returns as _probe)."""
    h = cap
    checked = False
    retries = 0
    while True:
        eps = PROBE_FRACTION * h
        rc = _probe(F, I, t, x, eps, high, sysd, lus, u, xp, xpp, xr, x2, wf, signs, w, b1, b2, work)
        if rc != FACTOR_OK:
            return rc
        if not checked:
            checked = True
            again = _jump(F, I, t, x, xr, x2, wf, high, P, rtol, atol, mask, xmax, w, w_err, save,
                          buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments)
            if again == 1:
                continue  # derivatives from the right limit
        if fixed:
            break
        curv = weighted_norm(xpp, w_err, I[I_NORM])
        if curv * cap * cap <= 2.0 * H0_ERROR_TARGET:
            h_new = cap
        else:
            h_new = math.sqrt(2.0 * H0_ERROR_TARGET / curv)
        h_new = max(h_new, F[F_MIN_STEP])
        converged = eps <= PROBE_MAX_RATIO * h_new
        h = h_new
        retries += 1
        if converged or retries >= PROBE_RETRIES:
            break
    _initialise_history(F, I, P, psi, h, xp)
    return FACTOR_OK


@kernel
def run(F, I, P, psi, psi_saved, alpha, beta, gamma, sigma, bps, first_step,
        atol, mask, high, xmax, w, w_err, save, restart_times, sysd, lus, signs,
        buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, max_chunk_steps):
    """Advance the integration until it finishes, fails, fills the buffers or uses the chunk.

    Parameters
    ----------
    sysd : tuple
        The system: ``(indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals,
        skind, spar, spwl_t, spwl_v, spwl_n)`` (pattern, E and H on it, the work values
        of the Newton matrix, B in COO, the packed sources).
    lus : tuple
        The LU: the plan's arrays (:meth:`netdae.dae.compiled.lu.LuPlan.refactor_args`,
        ``perm_r``, ``perm_c``), the factors' values and two work vectors.

    Returns
    -------
    int
        A status code of this module (RUNNING is never returned).
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n = sysd
    n = P.shape[1]
    maxord = I[I_MAXORD]
    u = np.zeros(skind.size)
    xp = np.empty(n)
    xpp = np.empty(n)
    work = np.empty(n)
    r = np.empty(n)
    ee = np.empty(n)
    xr = np.empty(n)
    x2 = np.empty(n)
    wf = np.empty(n)
    b1 = np.empty(n)
    b2 = np.empty(n)
    x_pred = np.empty(n)
    xp_pred = np.empty(n)
    rtol = F[F_RTOL]
    norm = I[I_NORM]

    if I[I_STARTED] == 0:
        I[I_STARTED] = 1
        # the record at t0, then the start: an order-1 restart with probed derivatives
        for c in range(save.size):
            buf_x[0, c] = P[0, save[c]]
        buf_t[0] = F[F_T]
        buf_k[0] = 0
        I[I_M] = 1
        cap = min(H0_FRACTION * (bps[0] - F[F_T]), F[F_MAX_STEP])
        I[I_PENDING_RESTART] = 1
        F[F_RESTART_FIXED] = 1.0 if first_step > 0.0 else 0.0
        F[F_RESTART_CAP] = first_step if first_step > 0.0 else cap

    chunk = 0
    while I[I_STATUS] == RUNNING:
        if I[I_PENDING_RESTART] != 0:
            if I[I_M] + 1 >= buf_t.size:
                return BUFFER_FULL  # a jump records a second point
            x = P[0].copy()
            rc = _restart_at(F, I, P, psi, F[F_T], x, F[F_RESTART_CAP], F[F_RESTART_FIXED] != 0.0, high,
                             sysd, lus, u, xp, xpp, xr, x2, wf, signs, b1, b2, work, rtol, atol, mask, xmax, w,
                             w_err, save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments)
            if rc == FACTOR_NEED_PIVOTS:
                return NEED_PIVOTS
            if rc != FACTOR_OK:
                return I[I_STATUS]
            I[I_PENDING_RESTART] = 0
        if I[I_M] >= buf_t.size:
            return BUFFER_FULL
        if chunk >= max_chunk_steps:
            return CHUNK_DONE
        chunk += 1
        # ---------------------------------------------------------------- one step
        ncf = 0
        nef = 0
        t = F[F_T]
        h = F[F_H]
        accepted = False
        reason = 0
        knew = 0
        err_k = 0.0
        err_km1 = 0.0
        landing = False
        t_new = t
        while True:
            F[F_H_REQUEST] = h
            ibp = I[I_IBP]
            h, landing = landing_step(min(h, F[F_MAX_STEP]), bps[ibp] - t, BREAKPOINT_STRETCH, True)
            # phase 1: coefficients (IDASetCoeffs)
            k = I[I_K]
            if h != F[F_HUSED] or k != I[I_KUSED]:
                I[I_NS] = 0
            I[I_NS] = min(I[I_NS] + 1, I[I_KUSED] + 2)
            ns = I[I_NS]
            psi_saved[:] = psi
            cj, ck = flc_coefficients(h, k, psi_saved, psi, alpha, beta, gamma, sigma)
            F[F_CJ] = cj
            if ns <= k:
                for i in range(ns, k + 1):
                    for c in range(n):
                        P[i, c] *= beta[i]
            t_new = bps[ibp] if landing else t + h
            # phase 2: predict
            for c in range(n):
                s = 0.0
                sp = 0.0
                for i in range(k + 1):
                    s += P[i, c]
                    sp += gamma[i] * P[i, c]
                x_pred[c] = s
                xp_pred[c] = sp
            cj_counted = cj != F[F_LAST_CJ_ATTEMPT]
            if cj_counted:
                I[I_CJ_CHANGES] += 1
                F[F_LAST_CJ_ATTEMPT] = cj
            # phase 3: the corrector, one exact solve
            kind = 0  # 0 accepted, 1 newton failure, 2 error failure
            worst = -1
            rc = FACTOR_OK
            if F[F_LU_TAG] != cj:
                rc = _factor(F, I, cj, 0.0, sysd, lus)
            if rc == FACTOR_NEED_PIVOTS:
                # undo phase 1 and return for new pivots; the attempt is repeated on the next call
                _restore(P, psi, psi_saved, beta, ns, k)
                F[F_H] = h
                if cj_counted:  # counted again when the attempt is repeated
                    I[I_CJ_CHANGES] -= 1
                    F[F_LAST_CJ_ATTEMPT] = math.nan
                return NEED_PIVOTS
            if rc == FACTOR_SINGULAR:
                kind = 1
                reason = REASON_SINGULAR
            else:
                # r = E xp_pred - H x_pred - B u(t_new)
                _phi(t_new, x_pred, sysd, u, r)
                for c in range(n):
                    r[c] = -r[c]
                _matvec_add(indptr, indices, e_data, xp_pred, 1.0, r)
                _solve(lus, r)
                I[I_EVALUATIONS] += 1
                I[I_NEWTON] += 1
                for c in range(n):
                    ee[c] = -r[c]
                # phase 4: error test (IDATestError)
                e0, e1, e2 = error_norms(ee, P, k, w_err, norm, n)
                err_k = sigma[k] * e0
                terr_k = (k + 1) * err_k
                knew = k
                err_km1 = 0.0
                if k > 1:
                    err_km1 = sigma[k - 1] * e1
                    terr_km1 = k * err_km1
                    if k > 2:
                        terr_km2 = (k - 1) * sigma[k - 2] * e2
                        if max(terr_km1, terr_km2) <= terr_k:
                            knew = k - 1
                    elif terr_km1 <= 0.5 * terr_k:
                        knew = k - 1
                if ck * e0 <= 1.0:
                    accepted = True
                elif not math.isfinite(e0):
                    kind = 1
                    reason = REASON_NONFINITE
                    worst = _worst(ee, w)
                else:
                    kind = 2
                    worst = _worst(ee, w_err)
                    if worst >= 0 and w_err[worst] == 0.0:
                        worst = _worst(ee, w)
            if accepted:
                break
            _restore(P, psi, psi_saved, beta, ns, k)
            I[I_PHASE] = 1
            if kind == 1:
                ncf += 1
                I[I_NEWTON_FAILURES] += 1
                if ncf >= MAX_NEWTON_FAILURES:
                    _fail(F, I, t, h, FAIL_NEWTON * 16 + reason, worst)
                    return FAILED
                eta = ETA_NEWTON_FAIL
            else:
                nef += 1
                I[I_REJECTED] += 1
                if h > F[F_HUSED]:
                    I[I_GROWTH_FAILED] = 1
                if nef >= MAX_ERROR_FAILURES:
                    _fail(F, I, t, h, FAIL_ERROR * 16, worst)
                    return FAILED
                if nef == 1:
                    err_knew = err_k if knew == k else err_km1
                    I[I_K] = knew
                    eta = ETA_SAFETY * (2.0 * err_knew + ERROR_FLOOR) ** (-1.0 / (knew + 1))
                    eta = max(ETA_ERROR_FAIL_MIN, min(ETA_SHRINK_MAX, eta))
                else:
                    I[I_K] = knew if nef == 2 else 1
                    eta = ETA_ERROR_FAIL_MIN
            # reduced step
            h_new = h * eta
            code = kind * 16 + (reason if kind == 1 else 0)
            if h_new < F[F_MIN_STEP]:
                if h > F[F_MIN_STEP] * (1.0 + 1e-12):
                    h_new = F[F_MIN_STEP]
                else:
                    _fail(F, I, t, h, FAIL_MIN_STEP * 256 + code, worst)
                    return FAILED
            elif h_new <= ROUNDOFF_ULPS * (np.nextafter(abs(t), np.inf) - abs(t)) or t + h_new == t:
                _fail(F, I, t, h, FAIL_ROUNDOFF * 256 + code, worst)
                return FAILED
            if I[I_NST] == 0:
                psi[0] = h_new
                for c in range(n):
                    P[1, c] *= h_new / h
            h = h_new
        # phase 5: complete the step (IDACompleteStep)
        retried = ncf + nef > 0
        k = I[I_K]
        I[I_NST] += 1
        I[I_STEPS] += 1
        if h < F[F_H_MIN]:
            F[F_H_MIN] = h
        if h > F[F_H_MAX]:
            F[F_H_MAX] = h
        if k > I[I_MAX_ORDER_USED]:
            I[I_MAX_ORDER_USED] = k
        kdiff = k - I[I_KUSED]
        I[I_KUSED] = k
        F[F_HUSED] = h
        # order and step selection
        if knew == k - 1 or k == maxord:
            I[I_PHASE] = 1
        if I[I_PHASE] == 0:
            if I[I_NST] > 1:
                I[I_K] = k + 1
                eta = 2.0
            else:
                eta = 1.0
        else:
            err_new = err_k
            if knew == k - 1:
                I[I_K] = k - 1
                err_new = err_km1
            elif k < maxord and I[I_NS] >= k + 2 and kdiff != 1:
                for c in range(n):
                    work[c] = ee[c] - P[k + 1, c]
                err_kp1 = weighted_norm(work, w_err, norm) / (k + 2)
                terr_k = (k + 1) * err_k
                terr_kp1 = (k + 2) * err_kp1
                if k == 1:
                    if terr_kp1 < 0.5 * terr_k:
                        I[I_K] = 2
                        err_new = err_kp1
                elif k * err_km1 <= min(terr_k, terr_kp1):
                    I[I_K] = k - 1
                    err_new = err_km1
                elif terr_kp1 < terr_k:
                    I[I_K] = k + 1
                    err_new = err_kp1
            tmp = (2.0 * err_new + ERROR_FLOOR) ** (-1.0 / (I[I_K] + 1))
            if tmp >= ETA_GROW_MIN:
                eta = min(tmp, ETA_GROW_MAX)
            elif tmp <= 1.0:
                eta = max(ETA_SHRINK_MIN, min(tmp, ETA_SHRINK_MAX))
            else:
                eta = 1.0
        if eta > 1.0:
            if retried or (I[I_GROWTH_FAILED] != 0 and I[I_NS] < k + 2):
                eta = 1.0
            else:
                I[I_GROWTH_FAILED] = 0
        update_differences(P, ee, k, maxord)
        F[F_T] = t_new
        set_weights(P[0], rtol, atol, I[I_RELREF], xmax, mask, w, w_err)
        m = I[I_M]
        buf_t[m] = t_new
        buf_k[m] = k
        for c in range(save.size):
            buf_x[m, c] = P[0, save[c]]
        I[I_M] = m + 1
        F[F_H] = max(min(h * eta, F[F_MAX_STEP]), F[F_MIN_STEP])
        if landing and I[I_IBP] == bps.size - 1:
            I[I_STATUS] = FINISHED
            return FINISHED
        if I[I_MAX_STEPS] > 0 and I[I_STEPS] >= I[I_MAX_STEPS]:
            _fail(F, I, t_new, F[F_H], FAIL_MAX_STEPS * 256, -1)
            return FAILED
        if landing:
            I[I_IBP] += 1
            # order-1 restart on the breakpoint with probed derivatives
            I[I_RESTARTS] += 1
            restart_times[I[I_NRESTART_TIMES]] = t_new
            I[I_NRESTART_TIMES] += 1
            h_last = max(h, F[F_H_REQUEST])
            F[F_RESTART_CAP] = max(min(h_last, F[F_MAX_STEP], bps[I[I_IBP]] - t_new), F[F_MIN_STEP])
            F[F_RESTART_FIXED] = 0.0
            I[I_PENDING_RESTART] = 1
            segments[I[I_NSEGMENTS]] = I[I_M] - 1
            I[I_NSEGMENTS] += 1
    return I[I_STATUS]
    return I[I_STATUS]
