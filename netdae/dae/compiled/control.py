"""The FLC-BDF method's formulas as compiled kernels: coefficients, norms, order and step control.

These are the pure functions of the method (DASSL/IDA's ``IDASetCoeffs``,
``IDATestError``, ``IDACompleteStep`` [1]_), written once, with every
argument explicit, for the compiled transient engine. They are ordinary
numba functions: callable from compiled code and, more slowly, from Python.
The constants are those of :mod:`netdae.dae.bdf`, where each is explained.

References
----------
.. [1] A. C. Hindmarsh et al., SUNDIALS IDA, ``src/ida/ida.c``.
"""

from __future__ import annotations

import math

from . import kernel
from ..sparse import RESIDUAL_ROUNDING

__all__ = ["flc_coefficients", "weighted_norm", "error_norms", "charge_weights", "time_charge_residual",
           "charge_newton_weights",
           "charge_error_norms",
           "charge_error_kp1", "update_differences", "landing_step",
           "set_weights", "current_error_weights", "residual_stalled", "conductance_fell", "row_magnitudes",
           "NORM_RMS", "NORM_MAX",
           "RELREF_LOCAL", "RELREF_SIGNAL", "RELREF_MIXED", "RESIDUAL_ROUNDING"]

NORM_RMS = 0
NORM_MAX = 1
RELREF_LOCAL = 0
RELREF_SIGNAL = 1
RELREF_MIXED = 2
#: See :data:`netdae.dae.bdf.MIXED_FLOOR`.
MIXED_FLOOR = 0.1
#: The fraction of the largest magnitude a charge has had below which :func:`charge_newton_weights` measures
#: it as that fraction (a gate charge through zero would otherwise ask its unknowns for ``atol``).
CHARGE_FLOOR = 0.01
#: :func:`current_error_weights` raises a current's error tolerance only where the bound its rows give is
#: more than this many times its own: a current whose own test asks the voltages for ten thousand times
#: their accuracy is a small difference of its row's terms (about 1e-4 of them); a larger one keeps its own
#: test, which also holds the voltages to its accuracy.
CANCELLATION = 1.0e4


@kernel
def row_magnitudes(indptr, indices, data, x, paired, mag, absjx):
    """The magnitude of each row's terms (into ``mag``) and ``|J| |x|`` (into ``absjx``).

    The compiled twin of :meth:`netdae.dae.sparse.SparsePattern.row_magnitudes` with
    ``paired``: a paired row measures the entries of its paired columns from its own
    potential, ``sum_{j != i} |a_ij| |x_j - x_i| + |sum_j a_ij| |x_i|``, an unpaired
    column or row as ``|a_ij| |x_j|``.

    Parameters
    ----------
    indptr, indices : ndarray of int
        The CSC pattern.
    data : ndarray, shape (>= nnz,)
    x : ndarray, shape (n,)
    paired : ndarray of int8, shape (n,)
        1 where row ``i`` is the current law of the node whose potential is unknown ``i``.
    mag, absjx : ndarray, shape (n,)
        Written. ``absjx`` first holds the paired rows' sums over the paired columns (work),
        then ``|J| |x|``.
    """
    n = x.size
    for i in range(n):
        mag[i] = 0.0
        absjx[i] = 0.0
    # the paired rows' sums over paired columns first (into absjx, moved below)
    for j in range(n):
        if paired[j] != 0:
            for p in range(indptr[j], indptr[j + 1]):
                if paired[indices[p]] != 0:
                    absjx[indices[p]] += data[p]
    for i in range(n):
        mag[i] = abs(absjx[i]) * abs(x[i]) if paired[i] != 0 else 0.0
        absjx[i] = 0.0
    for j in range(n):
        xj = x[j]
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            a = abs(data[p])
            absjx[i] += a * abs(xj)
            if paired[i] != 0 and paired[j] != 0:
                mag[i] += a * abs(xj - x[i])
            else:
                mag[i] += a * abs(xj)


@kernel
def flc_coefficients(h, k, psi_old, psi, alpha, beta, gamma, sigma):
    """Coefficients of a step of size ``h`` and order ``k`` (IDA's IDASetCoeffs).

    ``psi_old`` (length >= k) describes the previous steps; ``psi``, ``alpha``,
    ``beta``, ``gamma``, ``sigma`` (length >= k + 1) are written. ``psi`` may be
    the same array as ``psi_old``.

    Returns
    -------
    (cj, ck) : (float, float)
        The leading coefficient of the corrector and the error constant.
    """
    alpha[0] = 1.0
    beta[0] = 1.0
    gamma[0] = 0.0
    sigma[0] = 1.0
    temp1 = h
    for i in range(1, k + 1):
        temp2 = psi_old[i - 1]
        psi[i - 1] = temp1
        beta[i] = beta[i - 1] * temp1 / temp2
        temp1 = temp2 + h
        alpha[i] = h / temp1
        sigma[i] = i * sigma[i - 1] * alpha[i]
        gamma[i] = gamma[i - 1] + alpha[i - 1] / h
    psi[k] = temp1
    alpha_s = 0.0
    alpha_0 = 0.0
    for j in range(1, k + 1):
        alpha_s -= 1.0 / j
        alpha_0 -= alpha[j - 1]
    ck = max(abs(alpha[k] + alpha_s - alpha_0), alpha[k])
    return -alpha_s / h, ck


@kernel
def weighted_norm(v, w, kind):
    """Weighted RMS (``kind`` 0) or maximum (1) norm of ``v * w``."""
    n = v.size
    if n == 0:
        return 0.0
    if kind == NORM_MAX:
        m = 0.0
        for i in range(n):
            a = abs(v[i] * w[i])
            if a != a:
                return a  # NaN propagates
            if a > m:
                m = a
        return m
    s = 0.0
    for i in range(n):
        a = v[i] * w[i]
        s += a * a
    return math.sqrt(s / n)


@kernel
def _norm_sum(ee, P, col0, rows_from, k, sign, w, kind, n, count):
    """Norm of ``ee[col0:col0+n] + sign * sum_{i=rows_from}^{k} P[i, col0:col0+n]`` weighted by w.

    ``count`` is the number of entries the RMS norm averages over: ``n`` for the unknowns
    (every weight used), the number of non-zero weights for the charges of
    :func:`charge_weights` (entries with weight 0 are skipped).
    """
    s = 0.0
    m = 0.0
    skip = count != n
    for j in range(n):
        if skip and w[j] == 0.0:
            continue
        a = ee[col0 + j]
        for i in range(rows_from, k + 1):
            a += sign * P[i, col0 + j]
        a *= w[j]
        if kind == NORM_MAX:
            a = abs(a)
            if a != a or m != m:
                m = math.nan
            elif a > m:
                m = a
        else:
            s += a * a
    if kind == NORM_MAX:
        return m
    return math.sqrt(s / count) if count else 0.0


@kernel
def error_norms(ee, P, k, w, kind, n):
    """``|ee|``, ``|ee + P[k]|``, ``|ee + P[k] + P[k-1]|`` (as far as k allows; else 0).

    The local error estimates at orders k, k-1, k-2 (IDA's IDATestError);
    ``P`` holds the predicted differences of the step, columns ``:n`` used.
    """
    e0 = _norm_sum(ee, P, 0, k + 1, k, 1.0, w, kind, n, n)
    e1 = _norm_sum(ee, P, 0, k, k, 1.0, w, kind, n, n) if k >= 2 else 0.0
    e2 = _norm_sum(ee, P, 0, k - 1, k, 1.0, w, kind, n, n) if k >= 3 else 0.0
    return e0, e1, e2


@kernel
def charge_weights(qrows, absdq, indptr, indices, w, wq):
    """Weights of the charge errors of the rows coupled to index-2 unknowns, in volts.

    Row ``r`` with ``qrows[r] = c >= 0`` (a node row in which an index-2 unknown appears,
    such as the source current of a capacitor-source loop, whose charge is column ``c``
    of the charge history) gets ``wq[c] = w[r] / C_r``, ``C_r = sum_j |dq_r/dx_j|`` from
    ``absdq`` (``|dq/dx|`` on the CSC pattern ``indptr``, ``indices``): a charge error
    counts as the voltage error it would make on the row's capacitance. Other columns,
    and rows without capacitance, get 0. Returns the number of weighted columns.
    """
    n = w.size
    for c in range(wq.size):
        wq[c] = 0.0
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            c = qrows[indices[p]]
            if c >= 0:
                wq[c] += absdq[p]
    count = 0
    for i in range(n):
        c = qrows[i]
        if c >= 0 and wq[c] > 0.0:
            wq[c] = w[i] / wq[c]
            count += 1
    return count


@kernel
def time_charge_residual(ee, P, n, rows_from, k, sign, trows, cj, out):
    """The current error of the rows whose charge reads time itself, into ``out`` (shape (n,)).

    A charge ``q(x, t)`` that depends on time at fixed x (``Q={1n*sin(2*pi*1k*time) + 1p*v(a)}``)
    drives its row with ``dq/dt`` at fixed x, which the BDF takes from the charge history: no
    unknown's error estimate measures that differentiation's error (``v(a) = -R dq/dt`` across a
    resistor is algebraic, its own differences smooth for every history). Row ``r`` with
    ``trows[r] = c >= 0`` gets ``cj (ee[n + c] + sign * sum_{i=rows_from}^{k} P[i, n + c])``, the
    charge's error estimate (the combination :func:`charge_error_norms` takes at each order) as the
    residual it leaves in the corrector; the other rows 0. The caller solves the Newton matrix
    ``cj dq/dx - dphi/dx`` for it and measures the unknowns' error with their own weights: the
    voltage error on the row's capacitance where that dominates, ``cj dq`` through the row's
    conductance where that does, and further through what the row drives (a ``ddt()`` node read
    by a source).
    """
    for i in range(out.size):
        out[i] = 0.0
    for r in range(trows.size):
        c = trows[r]
        if c >= 0:
            a = ee[n + c]
            for i in range(rows_from, k + 1):
                a += sign * P[i, n + c]
            out[r] = cj * a


@kernel
def charge_newton_weights(q, qmax, qcol, absdq, indptr, indices, rtol, atol, w, den):
    """Newton weights raised to the accuracy of the charges of the charge-form rows.

    The corrector solves for ``x``, but a charge-form row integrates ``q(x)``: where a charge
    moves far faster than the unknowns it depends on, a correction within the unknowns'
    tolerances leaves the charge unconverged. A junction's diffusion charge ``tt Is exp(v/Vt)``
    changes by ``1/Vt`` of itself per volt, 35 times its share of ``reltol |v|`` at 0.9 V: a
    correction of 0.9 mV leaves the charge 3.5 % off, and iterates accepted so let the
    integrated charge drift (a diode with ``rs`` and ``tt`` between two inductors ran away to
    1e18 V). Row ``i`` (``qcol[i] = c >= 0``, its charge ``q[c]``) asks each unknown ``j`` it
    depends on for ``|dq_i/dx_j| / (rtol a_i + sum_k |dq_i/dx_k| atol_k)``, ``a_i = max(|q_i|,
    CHARGE_FLOOR qmax_i)``: a charge error of ``rtol`` of the charge, or of the fraction
    :data:`CHARGE_FLOOR` of the largest it has had (a charge that passes through zero, a
    gate's, is not asked for more there), and at least the charge of the unknowns' absolute
    tolerances. For a capacitor's linear charge this is at most the unknown's own weight, and
    nothing changes.

    Parameters
    ----------
    q : ndarray, shape (m,)
        The charges of the charge-form rows (the history's columns ``n:``).
    qmax : ndarray, shape (m,)
        Their largest magnitudes so far, updated in place.
    qcol : ndarray of int64, shape (n,)
        Each row's column among the charges (-1: a correction-form row).
    absdq : ndarray, shape (nnz,)
        ``|dq/dx|`` on the CSC pattern ``indptr``, ``indices``.
    rtol : float
    atol : ndarray, shape (n,)
    w : ndarray, shape (n,)
        The Newton weights, raised in place.
    den : ndarray, shape (n,)
        Work space.

    Notes
    -----
    Cost: two passes over the pattern. SPICE checks a junction's current for the same
    reason (``DIOconvTest``: the current predicted from the last linearisation against the
    one computed, to ``reltol``).
    """
    n = w.size
    for i in range(n):
        den[i] = 0.0
    for j in range(n):
        a = atol[j]
        for p in range(indptr[j], indptr[j + 1]):
            if qcol[indices[p]] >= 0:
                den[indices[p]] += absdq[p] * a
    for i in range(n):
        c = qcol[i]
        if c >= 0:
            a = abs(q[c])
            if a > qmax[c]:
                qmax[c] = a
            den[i] += rtol * max(a, CHARGE_FLOOR * qmax[c])
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            if qcol[i] >= 0 and den[i] > 0.0:
                v = absdq[p] / den[i]
                if v > w[j]:
                    w[j] = v


@kernel
def charge_error_norms(ee, P, k, wq, kind, n, count):
    """:func:`error_norms` of the charges (columns ``n:`` of the history, one per entry of
    ``wq``) weighted by ``wq`` (:func:`charge_weights`); ``count`` weighted columns (0: all zero)."""
    if count == 0:
        return 0.0, 0.0, 0.0
    m = wq.size
    e0 = _norm_sum(ee, P, n, k + 1, k, 1.0, wq, kind, m, count)
    e1 = _norm_sum(ee, P, n, k, k, 1.0, wq, kind, m, count) if k >= 2 else 0.0
    e2 = _norm_sum(ee, P, n, k - 1, k, 1.0, wq, kind, m, count) if k >= 3 else 0.0
    return e0, e1, e2


@kernel
def charge_error_kp1(ee, P, k, wq, kind, n, count):
    """The charge part of the order-raise estimate: norm of ``ee[n:] - P[k+1, n:]``."""
    if count == 0:
        return 0.0
    return _norm_sum(ee, P, n, k + 1, k + 1, -1.0, wq, kind, wq.size, count)


@kernel
def update_differences(P, ee, k, maxord):
    """After an accepted step: ``P[k+1] = ee`` and ``P[j] <- ee + sum_{i=j}^{k} P[i]``, in place."""
    m = ee.size
    if k < maxord:
        for c in range(m):
            P[k + 1, c] = ee[c]
    for c in range(m):
        acc = ee[c]
        for j in range(k, -1, -1):
            acc += P[j, c]
            P[j, c] = acc


@kernel
def landing_step(h, remaining, stretch, split):
    """Step that lands on a breakpoint ``remaining`` ahead without a sliver: (h, lands)."""
    if h * (1.0 + stretch) >= remaining:
        return remaining, True
    if split and 2.0 * h > remaining:
        return 0.5 * remaining, False
    return h, False


@kernel
def set_weights(x, rtol, atol, relref, xmax, mask, w, w_err):
    """Error weights ``1 / (rtol |x|_ref + atol)``; ``w_err = w * mask`` (index-2 unknowns out)."""
    for i in range(x.size):
        a = abs(x[i])
        if relref == RELREF_SIGNAL:
            if a > xmax[i]:
                xmax[i] = a
            a = xmax[i]
        elif relref == RELREF_MIXED:
            if a > xmax[i]:
                xmax[i] = a
            a = max(a, MIXED_FLOOR * xmax[i])
        w[i] = 1.0 / (rtol * a + atol[i])
        w_err[i] = w[i] * mask[i]


@kernel
def current_error_weights(w, w_err, mask, cur):
    """Raise the error tolerance of algebraic currents to the accuracy their resistive rows give them.

    A current that a charge-free row ties to the other unknowns through the circuit's linear
    conductances, ``H_ri i + sum_j H_rj x_j + ... = 0``, is as accurate as they are: its error is
    at most ``sum_{j != i} |H_rj / H_ri| tol_j``, the tightest over its rows (a device's current
    in the row would add to the bound: leaving it out keeps the bound below the truth). Its own
    tolerance (``reltol |i| + abstol``) can be far tighter: a source's current through 10 ohm into
    1 pF is the 63 uV difference of two 10 V node voltages over 10 ohm, and its own test asked
    those voltages for 6e-11 V at reltol 1e-6 (310,308 steps of the 10 ps mode, where ngspice,
    which tests charges only, takes about 400). Where the bound is more than
    :data:`CANCELLATION` times the current's own tolerance, the error test takes the bound,
    ``w_err_i = mask_i / bound``; a current that is more than a small difference of its row's
    terms keeps its own test, which also holds the voltages to its accuracy (a rectifier's source
    current, a ladder's after a pulse edge). A row with another such current in it is used in a
    second pass, with that current's bound from the first where it had one (a 0 V ammeter source in
    series with the source: the ammeter's bound from the resistor, the source's from it).

    Parameters
    ----------
    w : ndarray, shape (n,)
        The Newton weights ``1 / tol``.
    w_err : ndarray, shape (n,)
        The error-test weights, lowered in place.
    mask : ndarray, shape (n,)
        The error test's factor per unknown (:func:`set_weights`).
    cur : tuple
        ``(cand, rptr, eptr, ecol, ecand, gain, tolc)`` of
        :func:`netdae.dae.bdf.arguments.current_rows`; ``tolc`` (float64, one per candidate) is work.

    Notes
    -----
    Cost: one pass over the candidates' rows, twice; nothing when there are none.
    """
    cand, rptr, eptr, ecol, ecand, gain, tolc = cur
    nc = cand.size
    for sweep in range(2):
        for c in range(nc):
            i = cand[c]
            best = math.inf
            for rr in range(rptr[c], rptr[c + 1]):
                s = 0.0
                usable = True
                for e in range(eptr[rr], eptr[rr + 1]):
                    k = ecand[e]
                    if k >= 0:
                        if sweep == 0 or tolc[k] < 0.0:  # another current, bounded in the first sweep only
                            usable = False
                            break
                        s += gain[e] * tolc[k]
                    else:
                        s += gain[e] / w[ecol[e]]
                if usable and s > 0.0:
                    best = min(best, s)
            own = 1.0 / w[i]
            if sweep == 0:
                tolc[c] = max(own, best) if best < math.inf else -1.0
            elif best < math.inf and best > CANCELLATION * own:
                w_err[i] = min(w_err[i], mask[i] / best)


@kernel
def residual_stalled(r_prev, r_new, mag, rtol, r_atol, rate_max, nu_max):
    """Whether a modified-Newton iterate left the corrector's residual where it was (a stale Jacobian).

    Each row of the residual is measured as SPICE measures a current (``NIconvTest``):
    against ``rtol mag + r_atol``, ``mag`` the magnitude of the terms that make the row up at
    the new iterate, ``nu_i = |r_i| / (rtol mag_i + r_atol_i)``. The iterate is stalled when
    a row's residual is not small (``nu_new_i > 1``) and did not fall below ``rate_max`` of its
    residual at the iterate the correction was computed from (``nu_new_i > rate_max
    nu_prev_i``). Row by row: a stale matrix can leave one row where it was while it moves
    another's residual, the current of a source into a node it overestimates; and a row whose
    residual the correction made (a node group's balance moved by a matrix stale in its common
    mode) is stalled as well. A row whose residual is more than ``nu_max`` times its tolerance
    is not converged however far it fell: a rate measured with a stale matrix (at a kink of a
    behavioural source's function) can be small while the iterate is still tolerances off.

    A correction ``A^-1 r`` with a matrix ``A`` far stiffer than the residual's own Jacobian
    ``J`` (a junction's conductance at a forward bias it has since left) is tiny in every
    weighted norm, and the rate test accepts an iterate whose current law is as far off as
    the prediction's. The residual shows it where the correction cannot: a Newton step with
    a fit matrix removes the residual's linear part, ``r_new = (I - J A^-1) r_prev``.

    Parameters
    ----------
    r_prev, r_new : ndarray, shape (n,)
        The residual at the iterate the accepted correction was computed from, and at the
        accepted iterate.
    mag : ndarray, shape (n,)
        The magnitude of each row's terms at the accepted iterate.
    rtol : float
    r_atol : ndarray, shape (n,)
        Absolute tolerance of each row (a node row's current: abstol; a branch row's voltage:
        vntol).
    rate_max : float
        Largest residual contraction of a fit matrix.
    nu_max : float
        Largest residual, in units of its tolerance, accepted whatever its contraction.

    Returns
    -------
    bool
    """
    for i in range(r_new.size):
        s = rtol * mag[i] + r_atol[i]
        a = abs(r_new[i])
        if a > s and (a > rate_max * abs(r_prev[i]) or a > nu_max * s):
            return True
    return False


@kernel
def conductance_fell(dphi_lu, dphi, dq, cj, indptr, indices, r_atol, x_atol, factor):
    """Whether an off-diagonal entry of ``dphi/dx`` the factorisation holds fell by more than ``factor`` since.

    Entry ``(i, j)``, ``i != j``, of the Jacobian the modified-Newton matrix was made from,
    ``dphi_lu``, is compared with the Jacobian at the accepted iterate: it fell when ``|dphi_lu|
    > factor (|dphi| + cj |dq|) + r_atol_i / x_atol_j``. An off-diagonal entry is the
    conductance of what joins the two unknowns (a junction between two nodes); a diagonal one
    sums every element at a node, and one that falls towards zero is a fold of the node's
    current law (an N-shaped conductance), where a fresh Jacobian is singular and the
    impasse's jump takes over, not a stale matrix. A junction that conducted when the
    matrix was made and is off now: its conductance (here with the charge's coupling
    ``cj dq``, what the entry keeps of the two) is more than ``factor`` times too large in the
    matrix, and the corrections understate the error in every direction it couples, the
    common mode of a node group that only junction capacitances hold included, which no
    single row's residual shows. ``r_atol_i / x_atol_j`` (abstol / vntol = 1e-6 S between two
    nodes) is the conductance below which a change moves no current past its tolerance.

    Parameters
    ----------
    dphi_lu, dphi, dq : ndarray, shape (>= nnz,)
        Values on the CSC pattern ``(indptr, indices)``.
    cj : float
    indptr, indices : ndarray of int64
    r_atol, x_atol : ndarray, shape (n,)
        The rows' and the unknowns' absolute tolerances.
    factor : float

    Returns
    -------
    bool
    """
    for j in range(indptr.size - 1):
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            if i != j and abs(dphi_lu[p]) > factor * (abs(dphi[p]) + cj * abs(dq[p])) + r_atol[i] / x_atol[j]:
                return True
    return False
