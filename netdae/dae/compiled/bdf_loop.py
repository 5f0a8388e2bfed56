"""The compiled FLC-BDF step loop of an MNA system ``d/dt q(x) = phi(x, t)``.

This is :class:`netdae.dae.bdf.BDF` (same phases, same constants, same step
and order decisions) run as one compiled function: the coefficients, the
predictor, the corrector, the error test, order and step selection,
breakpoints, order-1 restarts with their derivative probes and right limits,
and the recording of the output. Python enters it once per output chunk
(:mod:`netdae.dae.compiled.driver`).

Two correctors, one loop:

- a linear system ``E x' = H x + B u(t)`` (no device families): the exact
  corrector, one solve with the factorisation of ``cj E - H`` (refactored
  when ``cj`` changes);
- a nonlinear one (``q = E x + q_dev(x)``, ``phi = H x + B u + f_dev(x)``):
  modified Newton on the corrector, in charge form
  ``cj (q(x) - q_pred) + q'_pred - phi(x, t) = 0`` in the rows where a device
  family stores charge and in IDA's correction form
  ``cj E (x - x_pred) + E x'_pred - phi(x, t) = 0`` in the others (see
  :class:`netdae.dae.bdf.corrector.NonlinearCorrector`), with IDA's rate test,
  Jacobian reuse across steps while ``cj`` stays within ``DCJ``, one retry
  with a fresh Jacobian, the device families' limiting (the trial state of
  the iteration, the accepted state of the step) and the rounding floor of
  the weights; the history then holds the charges of those rows as well as
  the unknowns.

The device families are the compiled kernels of :mod:`netdae.devices.kernels`
(diode, BJT, MOSFET, JFET, switch, behavioural, VDMOS, MESA, HFET), each evaluating all its instances in one loop.

Switches hold their states through a step; after each accepted step
:func:`~netdae.devices.kernels.switch.switch_step` decides them at its end
and, when one would change conductance, cuts the step where its control
crossed the threshold (located on the step's interpolant): the point is
recorded there, the switches change, and the method restarts at order 1
(a jump of the solution then comes from its right limit, as at a breakpoint
where the inputs jump).

State
-----
All state lives in arrays so that a chunk can end and the next one resume
between two steps: the scalars in ``F`` (floats) and ``I`` (integers),
indexed by the ``F_*`` and ``I_*`` constants below; the divided differences
``P`` (maxord + 1, n + m): the unknowns, then the charges of the ``m`` rows
where a device family stores charge (``m = 0`` for a linear system); the
coefficient arrays; the device families' limiting states; the output buffers.
"""

from __future__ import annotations

import math

import numpy as np

from ...devices.kernels import FLAG_LIMITED, FLAG_NONFINITE, MODE_EVALUATE, MODE_INITIAL, MODE_LIMIT
from ...devices.kernels.behavioural import (LOCK_TIME, eval_behavioural, lock_at, lock_changed, lock_flip,
                                            lock_record, lock_step, lock_undefined)
from ...devices.kernels.bjt import eval_bjt
from ...devices.kernels.diode import eval_diode
from ...devices.kernels.jfet import eval_jfet
from ...devices.kernels.mosfet import eval_mosfet
from ...devices.kernels.osdi import W_BOUND, W_STOP, W_STOP_INST, eval_osdi
from ...devices.kernels.switch import eval_switch, switch_at, switch_step
from ...devices.kernels.mesa import eval_mesa
from ...devices.kernels.hfet import eval_hfet
from ...devices.kernels.vdmos import eval_vdmos
from .events import CHATTER_EVENTS, EVENT_MIN_GAP, EVENT_TOGETHER, interpolate_state, ulp
from .delays import add_delayed, record_waves
from .control import (NORM_MAX, charge_error_kp1, charge_error_norms, charge_newton_weights, charge_weights,
                      time_charge_residual,
                      error_norms, flc_coefficients,
                      conductance_fell, current_error_weights, landing_step, residual_stalled, set_weights,
                      update_differences, weighted_norm)
from . import entry_kernel, inlined_kernel, kernel
from .lu import STATUS_NONFINITE, STATUS_OK
from .lu import refactor as lu_refactor
from .lu import solve as lu_solve
from .sources import source_values

# the method's constants, owned by netdae.dae.bdf (where each is explained)
from ..bdf import (  # noqa: E402
    BREAKPOINT_STRETCH,
    DCJ,
    EPCON,
    EPS,
    ERROR_FLOOR,
    ETA_ERROR_FAIL_MIN,
    ETA_GROW_MAX,
    ETA_GROW_MIN,
    ETA_NEWTON_FAIL,
    ETA_SAFETY,
    ETA_SHRINK_MAX,
    ETA_SHRINK_MIN,
    EVENT_RIGHT_LIMIT_FRACTION,
    EVENT_RIGHT_LIMIT_TOL,
    EVENT_RIGHT_LIMIT_ULPS,
    IMPASSE_NEAR,
    IMPASSE_TRIES,
    JAC_AGE_MAX,
    H0_ERROR_TARGET,
    H0_FRACTION,
    JUMP_DETECT,
    JUMP_FIRST_STEP,
    JUMP_NEWTON_MAXITER,
    MAX_ERROR_FAILURES,
    MAX_NEWTON_FAILURES,
    PROBE_FRACTION,
    PROBE_MAX_RATIO,
    PROBE_RETRIES,
    REPROBE_ERROR_FAILURES,
    RATE_AFTER_SETUP,
    RATE_CJ_CHANGED,
    RATE_AGE_MAX,
    RIGHT_LIMIT_CANCELLATION,
    ROUNDING_FACTOR,
    ROUNDOFF_ULPS,
    UNDEFINED_TRIES,
)
from ..newton import (CONDUCTANCE_FALL, FRESH_RATE_MAX, RATE_MAX, RESIDUAL_NU_MAX, RESIDUAL_RATE_MAX,  # noqa: E402
                      TINY_CORRECTION)
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
F_CJLAST = 21           # cj of the previous attempt (Newton's rate guess)
F_RATE = 22             # Newton's contraction rate, carried from step to step
F_RL_EPS = 23           # probe step of a pending right-limit request
F_IMPASSE_T = 24        # the last t where Newton failures on every step size asked for a jump (impasse)
F_RESTART_H = 25        # the probe step a restart stopped at to ask for new pivots (0: start at the cap)
F_UNDEFINED_H = 26      # the step that first ended past a change where a held branch is undefined (0: none)
F_IMPASSE_EPS = 27      # the implicit-Euler step of the last impasse
N_F = 28

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
I_NEWTON_MAXITER = 32   # Newton iterations per attempt (nonlinear systems)
I_HAS_ACC = 33          # the families have an accepted limiting state
I_HAS_TRY = 34          # the families have a trial limiting state (inside a corrector)
I_RL_READY = 35         # Python has put the requested right limit into rl_given
I_HAS_ABSDQ = 36        # absdq holds |dq/dx| of a Jacobian evaluation
I_LINEAR = 37           # 1: a linear system (exact corrector)
I_EVENTS = 38           # steps cut (or ended) where switches change conductance
I_EVENT_RESTART = 39    # the pending restart follows a switching event (a finer right limit)
I_NEVENTS = 40          # events recorded
I_CHATTER = 41          # consecutive events in the first step after an event
I_AFTER_EVENT = 42      # the last restart was at an event
I_RESTART_CHECKED = 43  # the pending restart checked for a jump: 1; found one: 2 (kept across returns to Python)
I_IMPASSE = 44          # 1: the pending restart continues from the right limit Python solved (an impasse)
I_IMPASSE_TRIES = 45    # impasse restarts at F_IMPASSE_T so far
I_UNDEFINED_STEP = 46   # the current step met an attempt past a change where a held branch is undefined (kept
#                         across returns to Python: an attempt repeated with new pivots is the same step's)
I_JAC_AGE = 47          # accepted steps since the factorised Jacobian was evaluated
I_OSDI_END = 48         # an OSDI module's $finish / $stop at the last accepted point (EVAL_RET_FLAG_*; 0: none)
I_OSDI_END_INST = 49    # the OSDI instance that raised it
I_CHARGE_TIME = 50      # 1: a charge reads time itself (trows: the probe takes dq/dt at fixed x, their charge
#                         errors are tested)
I_FINAL_RESTART = 51    # 1: the pending restart is at t_bound (an event there): the run ends after it
I_RATE_AGE = 52         # Newton solves in a row that converged at the first correction (RATE_AGE_MAX)
N_I = 53

# statuses
RUNNING = 0
FINISHED = 1
FAILED = 2
BUFFER_FULL = 3   # the output buffers are full: grow them and call again
CHUNK_DONE = 4    # the chunk's step budget is used: call again
NEED_PIVOTS = 5   # a refactorisation met a degraded pivot: choose new pivots for a_data, call again
NEED_RIGHT_LIMIT = 6  # a nonlinear system's inputs jump: compute x(t+) (F_RL_EPS) into rl_given, call again

# results of _factor
FACTOR_OK = 0
FACTOR_SINGULAR = 1
FACTOR_NEED_PIVOTS = 2
FACTOR_NEED_RIGHT_LIMIT = 3

# failure codes
FAIL_NEWTON = 1          # too many Newton (linear-solve) failures
FAIL_ERROR = 2           # too many error-test failures
FAIL_MIN_STEP = 3        # step at min_step and still failing
FAIL_ROUNDOFF = 4        # step below the roundoff of t
FAIL_PROBE_SINGULAR = 5  # the probe's matrix E/eps - H is singular
FAIL_PROBE_NONFINITE = 6
FAIL_MAX_STEPS = 7
FAIL_START_NONFINITE = 8
FAIL_CHATTER = 9         # a switch switches back right after each event (I_FAIL_WORST: the switch)
FAIL_UNDEFINED = 10      # a behavioural source's held branch undefined past a change not located (I_FAIL_WORST)

# what failed last inside a step (for messages): the names of netdae.dae.newton's INFO_*
REASON_SINGULAR = 1
REASON_NONFINITE = 2
REASON_DIVERGED = 3
REASON_MAXITER = 4
REASON_EVALUATION = 5

# Newton outcomes
NEWTON_CONVERGED = 0
NEWTON_FAILED = 1
NEWTON_PIVOTS = 2

# which limiting state an evaluation uses
STATE_NONE = 0      # evaluate every device at x (no limiting)
STATE_ACCEPTED = 1  # limit against the last accepted step's voltages
STATE_TRIAL = 2     # limit against the corrector's previous iterate (and keep the new voltages)
STATE_INITIAL = 3   # SPICE's MODEINITJCT: start from the accepted (initial) voltages when x is zero


@kernel
def _matvec_add(indptr, indices, data, x, scale, out):
    """``out += scale * A x`` for the CSC matrix A."""
    for j in range(x.size):
        xj = x[j] * scale
        if xj != 0.0:
            for p in range(indptr[j], indptr[j + 1]):
                out[indices[p]] += data[p] * xj


@inlined_kernel
def _phi(t, x, sysd, u, out):
    """``out = H x + B u(t)``, plus the transmission lines' delayed waves."""
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    out[:] = 0.0
    _matvec_add(indptr, indices, h_data, x, 1.0, out)
    if skind.size:
        source_values(skind, spar, spwl_t, spwl_v, spwl_n, t, u)
        for e in range(b_rows.size):
            out[b_rows[e]] += b_vals[e] * u[b_cols[e]]
    dl_rows, dl_tau, dl_w0, dl_t0, dl_I, dl_t, dl_k, dl_x, dl_seg, dl_col0 = dl
    if dl_rows.size:
        add_delayed(t, dl_rows, dl_tau, dl_w0, dl_t0, dl_t, dl_k, dl_x, dl_col0, dl_I[I_M], dl_seg,
                    dl_I[I_NSEGMENTS], out)


@kernel
def _factor(F, I, tag, eps, dq, dphi, lus, a_data):
    """Factor ``tag dq - dphi`` (``dq / eps - dphi`` when eps > 0, tag = 1/eps) in the kept pivot order.

    ``dq``, ``dphi``: the values on the pattern (E and H for a linear system, the
    evaluated Jacobians for a nonlinear one; at least nnz entries).
    Returns FACTOR_OK, FACTOR_SINGULAR, or FACTOR_NEED_PIVOTS (then ``a_data`` holds the
    matrix and F_PENDING_TAG its tag: the caller returns NEED_PIVOTS to Python).
    """
    if eps > 0.0:
        for p in range(a_data.size):
            a_data[p] = dq[p] / eps - dphi[p]
    else:
        for p in range(a_data.size):
            a_data[p] = tag * dq[p] - dphi[p]
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
    """The unknown with the largest ``|v w|`` (a NaN first)."""
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
def _newton_worst(v, w):
    """The unknown with the largest ``|v w|``, non-finite values counting as infinite (Newton's choice)."""
    best = -1
    big = -1.0
    for i in range(v.size):
        a = abs(v[i] * w[i])
        if not math.isfinite(a):
            a = math.inf
        if a > big:
            big = a
            best = i
    return best


@kernel
def _nonfinite_worst(qe, phie, n):
    """The first unknown whose charge or current is not finite (-1: none)."""
    for i in range(n):
        if not (math.isfinite(qe[i]) and math.isfinite(phie[i])):
            return i
    return -1


@kernel
def _osdi_bound(devd):
    """The shortest ``$bound_step`` the OSDI modules asked for at their last evaluation (inf: none), the
    cap of the next step (ngspice's ``OSDItrunc``)."""
    o_inst, o_info_f = devd[34], devd[38]
    if o_inst.shape[0] == 0 or not o_info_f[W_BOUND] > 0.0:  # no module, or none evaluated yet
        return math.inf
    return o_info_f[W_BOUND]


@kernel
def _osdi_end(I, devd):
    """True when an OSDI module called ``$finish`` or ``$stop`` at its last evaluation (the accepted
    point's): the run ends there (ngspice pauses at a ``$stop``), the flags and instance kept in I."""
    o_inst, o_info_i = devd[34], devd[37]
    if o_inst.shape[0] == 0 or o_info_i[W_STOP] == 0:
        return False
    I[I_OSDI_END] = o_info_i[W_STOP]
    I[I_OSDI_END_INST] = o_info_i[W_STOP_INST]
    return True


@kernel
def _fail(F, I, t, h, code, worst):
    I[I_STATUS] = FAILED
    I[I_FAIL_CODE] = code
    I[I_FAIL_WORST] = worst
    F[F_FAIL_T] = t
    F[F_FAIL_H] = h


@kernel
def _impasse(F, I, t):
    """After the attempts from t failed on every step size (Newton, or the error test down to the
    rounding of t) in a nonlinear system: ask Python once per t for two implicit-Euler steps of the
    step the attempts began with, solved by its steady-state solver with its homotopies, and
    restart from them (recorded as a jump). No solution near the last one exists there, or one
    faster than t can resolve: an impasse, where the circuit snaps to another state (a latch, a
    trigger with feedback, a transistor without capacitances). Failing again right after, up to
    IMPASSE_TRIES times at one t with steps ten times longer each; a failure within IMPASSE_NEAR of
    the last impasse's steps after it counts as one at its t (no progress between them: a crawl of
    impasses a few ulps apart would otherwise never end). True when the request is made (the
    recorded failure stands when Python finds no such steps)."""
    if I[I_LINEAR] != 0:
        return False
    if F[F_IMPASSE_T] <= t <= F[F_IMPASSE_T] + IMPASSE_NEAR * F[F_IMPASSE_EPS]:
        if I[I_IMPASSE_TRIES] >= IMPASSE_TRIES:
            return False
        I[I_IMPASSE_TRIES] += 1  # still failing right after the jump: a ten times longer step
    else:
        I[I_IMPASSE_TRIES] = 1
    I[I_STATUS] = RUNNING
    F[F_IMPASSE_T] = t
    F[F_RL_EPS] = max(F[F_H] * 10.0 ** (I[I_IMPASSE_TRIES] - 1),
                      EVENT_RIGHT_LIMIT_ULPS * ulp(t))
    F[F_IMPASSE_EPS] = F[F_RL_EPS]
    I[I_IMPASSE] = 1
    I[I_PENDING_RESTART] = 1
    I[I_RESTART_CHECKED] = 0
    F[F_RESTART_H] = 0.0
    F[F_RESTART_FIXED] = 0.0
    F[F_RESTART_CAP] = F[F_RL_EPS]  # never a probe below the rounding of t
    return True


@kernel
def _schedule_restart(F, I, t, h, bps, restart_times, segments):
    """An order-1 restart at ``t`` (at an event or a breakpoint: probed derivatives, the right limit where
    the solution jumps), its probe capped by ``h``, the next breakpoint and the step bounds; the output's
    segment ends at the last recorded point."""
    I[I_RESTARTS] += 1
    restart_times[I[I_NRESTART_TIMES]] = t
    I[I_NRESTART_TIMES] += 1
    F[F_RESTART_CAP] = max(min(h, F[F_MAX_STEP], bps[I[I_IBP]] - t), F[F_MIN_STEP])
    F[F_RESTART_FIXED] = 0.0
    I[I_PENDING_RESTART] = 1
    segments[I[I_NSEGMENTS]] = I[I_M] - 1
    I[I_NSEGMENTS] += 1


@kernel
def _lock_event_names(h_inst, h_lock, limit, event_idx, j, count, first):
    """Name event ``j``'s behavioural sources (those changing by ``limit``), numbered from ``first`` (after
    the switches) in row ``j`` of ``event_idx`` from position ``count``; returns the new count."""
    for i in range(h_inst.shape[0]):
        if lock_changed(h_inst, h_lock, i, limit):
            if count < JUMP_NAMES:
                event_idx[j, count] = first + i
            count += 1
    return count


@kernel
def _copy2(dst, src):
    """``dst[:, :] = src`` for two 2-D arrays of one shape (no temporary, so no allocation)."""
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            dst[i, j] = src[i, j]


@kernel
def _restore(P, psi, psi_saved, beta, ns, k):
    """Undo phase 1 of a failed attempt (IDA's IDARestore): psi and the beta-scaled differences."""
    for i in range(psi.size):
        psi[i] = psi_saved[i]
    for i in range(ns, k + 1):
        for c in range(P.shape[1]):
            P[i, c] /= beta[i]


@kernel
def _initialise_history(F, I, P, psi, h, xp, qp, crows):
    """Order-1 history from the derivatives ``xp`` (and ``qp`` of the charges of the rows ``crows``)."""
    n = xp.size
    P[1:, :] = 0.0
    for i in range(n):
        P[1, i] = h * xp[i]
    for c in range(crows.size):
        P[1, n + c] = h * qp[crows[c]]
    psi[0] = h
    I[I_K] = 1
    I[I_KUSED] = 0
    F[F_HUSED] = 0.0
    I[I_NS] = 0
    I[I_PHASE] = 0
    I[I_NST] = 0
    F[F_CJ] = 1.0 / h
    F[F_RATE] = RATE_AFTER_SETUP
    I[I_RATE_AGE] = 0
    I[I_GROWTH_FAILED] = 0
    F[F_H] = h


# ------------------------------------------------------------------ device evaluation
@kernel
def _family(ev, par, idx, vacc, vtry, vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian):
    """One family's kernel with the chosen limiting state; returns its flags."""
    if par.shape[0] == 0:
        return 0
    if state == STATE_NONE:
        mode = MODE_EVALUATE
        vold = vacc
    elif state == STATE_INITIAL:
        mode = MODE_INITIAL
        vold = vacc
    elif state == STATE_ACCEPTED:
        mode = MODE_LIMIT
        vold = vacc
    else:
        mode = MODE_LIMIT
        vold = vtry
    if ev == 0:
        flags, bad = eval_diode(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    elif ev == 1:
        flags, bad = eval_bjt(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    elif ev == 2:
        flags, bad = eval_mosfet(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    elif ev == 3:
        flags, bad = eval_jfet(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    elif ev == 7:
        flags, bad = eval_vdmos(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    elif ev == 8:
        flags, bad = eval_mesa(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    elif ev == 9:
        flags, bad = eval_hfet(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    else:
        flags, bad = eval_switch(xe, mode, par, idx, vold, vnew, qe, phie, dqe, dphie, jacobian)
    if keep:
        _copy2(vtry, vnew)
    return flags


@kernel
def _evaluate(I, t, x, state, keep, jacobian, sysd, devd, u, evb):
    """``q(x)``, ``phi(x, t)`` and, with ``jacobian``, dq/dx and dphi/dx, into ``evb``.

    ``state`` chooses the families' limiting (``STATE_*``); ``keep`` stores the
    limited voltages as the trial state. Counts the evaluation. Returns the
    families' flags (``FLAG_LIMITED``, ``FLAG_NONFINITE``).
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    (d_par, d_idx, d_vacc, d_vtry, d_vnew, b_par, b_idx, b_vacc, b_vtry, b_vnew,
     m_par, m_idx, m_vacc, m_vtry, m_vnew, j_par, j_idx, j_vacc, j_vtry, j_vnew,
     s_par, s_idx, s_vacc, s_vtry, s_vnew, s_tc,
     h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock, h_xw,
     o_inst, o_fns, o_slots, o_info_i, o_info_f, o_xbuf, o_fbuf, o_qbuf, o_jr, o_jc, o_vacc, o_vtry, o_vnew,
     v_par, v_idx, v_vacc, v_vtry, v_vnew, z_par, z_idx, z_vacc, z_vtry, z_vnew,
     f_par, f_idx, f_vacc, f_vtry, f_vnew) = devd
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    for i in range(n):
        xe[i] = x[i]
    xe[n] = 0.0
    qe[:] = 0.0
    _matvec_add(indptr, indices, e_data, x, 1.0, qe)
    _phi(t, x, sysd, u, phie)
    if jacobian:
        nnz = e_data.size
        for p in range(nnz):
            dqe[p] = e_data[p]
            dphie[p] = h_data[p]
        dqe[nnz] = 0.0
        dphie[nnz] = 0.0
    flags = _family(0, d_par, d_idx, d_vacc, d_vtry, d_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(1, b_par, b_idx, b_vacc, b_vtry, b_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(2, m_par, m_idx, m_vacc, m_vtry, m_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(3, j_par, j_idx, j_vacc, j_vtry, j_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(4, s_par, s_idx, s_vacc, s_vtry, s_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(7, v_par, v_idx, v_vacc, v_vtry, v_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(8, z_par, z_idx, z_vacc, z_vtry, z_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    flags |= _family(9, f_par, f_idx, f_vacc, f_vtry, f_vnew, state, keep, xe, qe, phie, dqe, dphie, jacobian)
    if h_inst.shape[0] > 0:
        hflags, hbad = eval_behavioural(xe, t, h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock, qe, phie, dqe,
                                        dphie, jacobian)
        flags |= hflags
    if o_inst.shape[0] > 0:
        if state == STATE_NONE:
            omode, ovold = MODE_EVALUATE, o_vacc
        elif state == STATE_INITIAL:
            omode, ovold = MODE_INITIAL, o_vacc
        elif state == STATE_ACCEPTED:
            omode, ovold = MODE_LIMIT, o_vacc
        else:
            omode, ovold = MODE_LIMIT, o_vtry
        oflags, obad = eval_osdi(xe, t, omode, ovold, o_vnew, o_inst, o_fns, o_slots, o_info_i, o_info_f, o_xbuf,
                                 o_fbuf, o_qbuf, o_jr, o_jc, qe, phie, dqe, dphie, jacobian)
        if keep:
            for i in range(o_vnew.size):
                o_vtry[i] = o_vnew[i]
        flags |= oflags
    I[I_EVALUATIONS] += 1
    if jacobian:
        I[I_JAC_EVALUATIONS] += 1
        for p in range(absdq.size):
            absdq[p] = abs(dqe[p])
        I[I_HAS_ABSDQ] = 1
    return flags


#: :func:`_evaluate` inlined, for the calls of every Newton iteration and every step (a call of
#: :func:`_evaluate` copies the whole of ``sysd`` and ``devd`` onto the stack: :func:`inlined_kernel`)
_evaluate_inlined = inlined_kernel(_evaluate.py_func)


@kernel
def _accept_state(I, devd):
    """The trial limiting state becomes the accepted one (after an accepted step)."""
    (d_par, d_idx, d_vacc, d_vtry, d_vnew, b_par, b_idx, b_vacc, b_vtry, b_vnew,
     m_par, m_idx, m_vacc, m_vtry, m_vnew, j_par, j_idx, j_vacc, j_vtry, j_vnew,
     s_par, s_idx, s_vacc, s_vtry, s_vnew, s_tc,
     h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock, h_xw,
     o_inst, o_fns, o_slots, o_info_i, o_info_f, o_xbuf, o_fbuf, o_qbuf, o_jr, o_jc, o_vacc, o_vtry, o_vnew,
     v_par, v_idx, v_vacc, v_vtry, v_vnew, z_par, z_idx, z_vacc, z_vtry, z_vnew,
     f_par, f_idx, f_vacc, f_vtry, f_vnew) = devd
    if I[I_HAS_TRY] != 0:
        _copy2(d_vacc, d_vtry)
        _copy2(b_vacc, b_vtry)
        _copy2(m_vacc, m_vtry)
        _copy2(j_vacc, j_vtry)
        _copy2(s_vacc, s_vtry)
        _copy2(v_vacc, v_vtry)
        _copy2(z_vacc, z_vtry)
        _copy2(f_vacc, f_vtry)
        for i in range(o_vacc.size):
            o_vacc[i] = o_vtry[i]
        I[I_HAS_ACC] = 1


@kernel
def _point_state(devd):
    """The accepted limiting state of the junction families becomes their voltages at the point the last
    evaluation without limiting was made at (``vnew``). Called after a Newton failure with the accepted
    point evaluated: the next attempts limit from there (ngspice limits from the last converged point),
    not from the state the step accepted, that of its last Newton evaluation, the iterate its last
    correction was computed at. A boost converter's diode accepted after one correction from 0.29 V to
    0.69 V (tests/test_recovery.py) kept 0.29 V, and every later attempt limited the junction from
    there, about 0.1 V per iteration (0.41, 0.52, 0.62, 0.66 V, each limited, so never converged),
    failing on every step size. The switches keep their held states. The OSDI devices take the states
    their modules wrote at the point (``o_vnew``: every ``$limit`` call's value there, evaluated
    without limiting): with limiting enabled a module writes only the states of the branch it takes
    (a MOSFET's normal or reversed mode), so a state of the other branch keeps the value of the last
    evaluation that took it, however long ago, and a transistor entering that branch again limited
    its junction from there on every iteration. A level-3 CMOS Schmitt trigger (MOS3 as OSDI) failed
    Newton on every step size at t = 549.1273 ns, its states 1.5-3 V off the point's, and continued
    through 23,000 impasses without reaching 550 ns (tests/test_limit_state_rebase.py). The Python
    integrator gives its OSDI devices no limiting state in a transient
    (:func:`netdae.dae.bdf.corrector.point_state`)."""
    (d_par, d_idx, d_vacc, d_vtry, d_vnew, b_par, b_idx, b_vacc, b_vtry, b_vnew,
     m_par, m_idx, m_vacc, m_vtry, m_vnew, j_par, j_idx, j_vacc, j_vtry, j_vnew,
     s_par, s_idx, s_vacc, s_vtry, s_vnew, s_tc,
     h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock, h_xw,
     o_inst, o_fns, o_slots, o_info_i, o_info_f, o_xbuf, o_fbuf, o_qbuf, o_jr, o_jc, o_vacc, o_vtry, o_vnew,
     v_par, v_idx, v_vacc, v_vtry, v_vnew, z_par, z_idx, z_vacc, z_vtry, z_vnew,
     f_par, f_idx, f_vacc, f_vtry, f_vnew) = devd
    _copy2(d_vacc, d_vnew)
    _copy2(b_vacc, b_vnew)
    _copy2(m_vacc, m_vnew)
    _copy2(j_vacc, j_vnew)
    _copy2(v_vacc, v_vnew)
    _copy2(z_vacc, z_vnew)
    _copy2(f_vacc, f_vnew)
    if o_inst.shape[0] > 0:
        for i in range(o_vacc.size):
            o_vacc[i] = o_vnew[i]


@kernel
def _reset_trial(I, devd):
    """The corrector starts from the accepted limiting state."""
    (d_par, d_idx, d_vacc, d_vtry, d_vnew, b_par, b_idx, b_vacc, b_vtry, b_vnew,
     m_par, m_idx, m_vacc, m_vtry, m_vnew, j_par, j_idx, j_vacc, j_vtry, j_vnew,
     s_par, s_idx, s_vacc, s_vtry, s_vnew, s_tc,
     h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock, h_xw,
     o_inst, o_fns, o_slots, o_info_i, o_info_f, o_xbuf, o_fbuf, o_qbuf, o_jr, o_jc, o_vacc, o_vtry, o_vnew,
     v_par, v_idx, v_vacc, v_vtry, v_vnew, z_par, z_idx, z_vacc, z_vtry, z_vnew,
     f_par, f_idx, f_vacc, f_vtry, f_vnew) = devd
    _copy2(d_vtry, d_vacc)
    _copy2(b_vtry, b_vacc)
    _copy2(m_vtry, m_vacc)
    _copy2(j_vtry, j_vacc)
    _copy2(s_vtry, s_vacc)
    _copy2(v_vtry, v_vacc)
    _copy2(z_vtry, z_vacc)
    _copy2(f_vtry, f_vacc)
    for i in range(o_vtry.size):
        o_vtry[i] = o_vacc[i]
    I[I_HAS_TRY] = I[I_HAS_ACC]


@inlined_kernel
def _rounding_floor(x, xp, qp, cj, qcol, every, absdq, indptr, indices, lus, signs, w, w_out, b1, b2):
    """Weights with every tolerance raised to the corrector's rounding level (see
    :meth:`netdae.dae.bdf.corrector.RoundingFloor.weights`): ``w_out`` from ``w``. ``absdq``:
    ``|dq/dx|`` on the pattern. Row ``i`` is in charge form when ``every`` or ``qcol[i] >= 0``
    (``|q'_pred|`` is ``qp`` indexed by row when ``every``, by ``qcol`` otherwise), else in
    correction form (``|E| |xp|`` in its place, ``xp`` the predicted derivatives). Returns True
    when some weight was lowered."""
    n = w.size
    b1[:] = 0.0
    b2[:] = 0.0
    for j in range(n):
        xj = abs(x[j])
        xpj = 0.0 if every else abs(xp[j])
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            if xj != 0.0:
                b1[i] += absdq[p] * xj
            if xpj != 0.0 and qcol[i] < 0:
                b2[i] += absdq[p] * xpj
    for i in range(n):
        if every:
            b1[i] = (b1[i] * cj + abs(qp[i])) * (ROUNDING_FACTOR * EPS)
        elif qcol[i] >= 0:
            b1[i] = (b1[i] * cj + abs(qp[qcol[i]])) * (ROUNDING_FACTOR * EPS)
        else:
            b1[i] = (b1[i] * cj + b2[i]) * (ROUNDING_FACTOR * EPS)
        b2[i] = b1[i] * signs[i]
    _solve(lus, b1)
    _solve(lus, b2)
    low = False
    for i in range(n):
        floor = max(abs(b1[i]), abs(b2[i]))
        w_out[i] = w[i]
        if floor * w[i] > 1.0:
            w_out[i] = 1.0 / floor
            low = True
    return low


# ------------------------------------------------------------------ probes and jumps
@kernel
def _probe(F, I, t, x, eps, tol, sysd, devd, lus, evb, ws, after_jump):
    """x'(t+) into ``xp``, x''(t+) into ``xpp`` by two implicit-Euler steps of size eps.

    Also the right limit ``xr`` (the two steps extrapolated to eps = 0), the second
    step's value ``x2``, ``q'(t+) = phi(x, t + eps)`` into ``qpb`` (nonlinear systems; ``after_jump``
    with the index-2 unknowns of the first Euler step, see ``startup.probe``) and, in ``wf``, the
    weights raised to the probe's rounding level.
    Returns FACTOR_OK, FACTOR_NEED_PIVOTS, or FACTOR_SINGULAR after recording a failure.
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    linear = I[I_LINEAR] != 0
    # a charge that reads time (I_CHARGE_TIME, a nonlinear system): each Euler step's first Newton
    # step has (q(x, t + eps) - q(x, t)) / eps on its right-hand side, dq/dt at fixed x
    timed = I[I_CHARGE_TIME] != 0 and not linear
    I[I_PROBES] += 1
    state = STATE_ACCEPTED if I[I_HAS_ACC] != 0 else STATE_NONE
    if linear:
        I[I_EVALUATIONS] += 1
        I[I_JAC_EVALUATIONS] += 1
        _phi(t + eps, x, sysd, u, xp)
        for i in range(n):
            if not math.isfinite(xp[i]):
                _fail(F, I, t, eps, FAIL_PROBE_NONFINITE, i)
                return FACTOR_SINGULAR
    else:
        if timed:  # q(x, t-) into xr (free until the end); q(x, t) after a right limit just taken
            _evaluate(I, t if after_jump else np.nextafter(t, -np.inf), x, state, False, False, sysd, devd, u, evb)
            for i in range(n):
                xr[i] = qe[i]
        flags = _evaluate(I, t + eps, x, state, False, True, sysd, devd, u, evb)
        bad = -1
        for i in range(n):
            xp[i] = phie[i]
            if bad < 0 and not math.isfinite(phie[i]):
                bad = i
        if flags & FLAG_NONFINITE or bad >= 0:
            if bad < 0:
                bad = _nonfinite_worst(qe, phie, n)
            _fail(F, I, t, eps, FAIL_PROBE_NONFINITE, bad)
            return FACTOR_SINGULAR
    rc = FACTOR_OK
    if linear:
        if F[F_LU_TAG] != 1.0 / eps:
            rc = _factor(F, I, 1.0 / eps, eps, e_data, h_data, lus, a_data)
    else:
        rc = _factor(F, I, 1.0 / eps, eps, dqe, dphie, lus, a_data)
    if rc == FACTOR_NEED_PIVOTS:
        I[I_PROBES] -= 1  # it will be repeated
        I[I_EVALUATIONS] -= 2 if timed else 1
        I[I_JAC_EVALUATIONS] -= 1
        return rc
    if rc == FACTOR_SINGULAR:
        _fail(F, I, t, eps, FAIL_PROBE_SINGULAR, -1)
        return rc
    for i in range(n):
        x2[i] = xp[i]  # phi(x, t + eps), for the rounding floor
        qpb[i] = xp[i]
    if timed:
        for i in range(n):  # qe: q(x, t + eps) still
            xp[i] -= (qe[i] - xr[i]) / eps
    _solve(lus, xp)
    for i in range(n):
        xp[i] /= eps
        work[i] = x[i] + eps * xp[i]
    if after_jump and not linear:
        # q'(t+) = phi with the index-2 unknowns the first Euler step solved (startup.probe)
        for j in range(n):
            if high[j]:
                for p in range(indptr[j], indptr[j + 1]):
                    qpb[indices[p]] += dphie[p] * eps * xp[j]
    ok1 = True
    if linear:
        I[I_EVALUATIONS] += 1
        _phi(t + 2.0 * eps, work, sysd, u, xpp)
    else:
        if timed:  # q(x_1, t + eps) into xr
            _evaluate(I, t + eps, work, state, False, False, sysd, devd, u, evb)
            for i in range(n):
                xr[i] = qe[i]
        flags = _evaluate(I, t + 2.0 * eps, work, state, False, False, sysd, devd, u, evb)
        ok1 = (flags & FLAG_NONFINITE) == 0
        for i in range(n):
            xpp[i] = phie[i]
            if timed:
                xpp[i] -= (qe[i] - xr[i]) / eps
    if ok1:
        _solve(lus, xpp)
    else:
        for i in range(n):
            xpp[i] = xp[i] * eps
    _rounding_floor(x, x, x2, 1.0 / eps, qcol, True, absdq, indptr, indices, lus, signs, w, wf, b1, b2)
    for i in range(n):
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
def _record(I, t, k, x, rec):
    (save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, restart_times,
     event_t, event_count, event_idx, w_ptr, w_idx, w_val) = rec
    m = I[I_M]
    buf_t[m] = t
    buf_k[m] = k
    for c in range(save.size):
        buf_x[m, c] = x[save[c]]
    if w_ptr.size > 1:
        record_waves(x, w_ptr, w_idx, w_val, save.size, buf_x, m)
    I[I_M] = m + 1


@kernel
def _cancels(indptr, indices, dq, dphi, eps, charge, total, rest):
    """Whether a row of ``dq/eps - dphi`` loses its algebraic part to rounding.

    The twin of :func:`netdae.dae.bdf.startup.cancelling_rows`: row ``i`` does when
    ``sum |dq| / eps > RIGHT_LIMIT_CANCELLATION * (|sum dq| / eps + sum |dphi|)`` (a capacitor
    between nodes held only by tiny conductances: their common mode's pivot rounds to zero).
    ``charge``, ``total``, ``rest``: work vectors of size n.
    """
    n = indptr.size - 1
    charge[:] = 0.0
    total[:] = 0.0
    rest[:] = 0.0
    for j in range(n):
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            charge[i] += abs(dq[p])
            total[i] += dq[p]
            rest[i] += abs(dphi[p])
    for i in range(n):
        if charge[i] / eps > RIGHT_LIMIT_CANCELLATION * (abs(total[i]) / eps + rest[i]):
            return True
    return False


@kernel
def _event_right_limit(F, I, t, x, eps, tol, sysd, devd, lus, evb, ws):
    """x(t+) into ``xr``: two implicit-Euler steps of ``eps`` by full Newton (tried first at every jump).

    The twin of :func:`netdae.dae.bdf.startup.event_right_limit`. Each step solves
    ``(q(y) - q0) / eps - phi(y, t + k eps) = 0`` from the left value (the switches held,
    the devices limited against the previous iterate), converged when the last correction is
    below ``EVENT_RIGHT_LIMIT_TOL`` of the tolerances; ``xr = 2 y1 - y2`` (``y2`` for index-2
    unknowns). Returns False when a step does not converge, or when the matrix loses a row's
    algebraic part to rounding (``_cancels``; then Python's steady-state solver takes over, with
    the charge balance of the groups of nodes held by capacitors). Uses ``x2``, ``work``,
    ``b1``, ``b2`` of ``ws`` as work (and ``xr``, ``rl_given`` for ``_cancels``): the probe's ``xp``,
    ``xpp`` and ``qpb`` stay, for the restart when the converged right limit is ``x`` itself
    (nothing jumped; they are probed again only after a jump).
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    y = x2
    y1 = work
    q0 = b2
    d = b1
    for i in range(n):
        y[i] = x[i]
    start = STATE_ACCEPTED if I[I_HAS_ACC] != 0 else STATE_NONE
    for step in range(1, 3):
        t_q = t + (step - 1) * eps
        if step == 1 and I[I_CHARGE_TIME] != 0:
            t_q = np.nextafter(t, -np.inf)  # a charge that reads time: from the charges just before t
        _evaluate(I, t_q, y, start, False, False, sysd, devd, u, evb)
        for i in range(n):
            q0[i] = qe[i]
        state = start
        converged = False
        for _ in range(JUMP_NEWTON_MAXITER):
            flags = _evaluate(I, t + step * eps, y, state, True, True, sysd, devd, u, evb)
            I[I_HAS_TRY] = 1
            state = STATE_TRIAL
            if flags & FLAG_NONFINITE:
                return False
            if _cancels(indptr, indices, dqe, dphie, eps, xr, rl_given, d):  # xr, rl_given: free until the end
                return False
            for i in range(n):
                d[i] = (qe[i] - q0[i]) / eps - phie[i]
            if _factor(F, I, 1.0 / eps, eps, dqe, dphie, lus, a_data) != FACTOR_OK:
                return False
            _solve(lus, d)
            I[I_NEWTON] += 1
            for i in range(n):
                y[i] -= d[i]
            dn = weighted_norm(d, w, NORM_MAX)
            if not math.isfinite(dn):
                return False
            if dn <= EVENT_RIGHT_LIMIT_TOL and (flags & FLAG_LIMITED) == 0:
                converged = True
                break
        if not converged:
            return False
        if step == 1:
            for i in range(n):
                y1[i] = y[i]
    for i in range(n):
        xr[i] = y[i] if high[i] else 2.0 * y1[i] - y[i]
    return True


@kernel
def _jump(F, I, t, x, eps, P, rtol, tol, sysd, devd, lus, evb, ws, rec):
    """Continue from the right limit where it differs from ``x`` (see ``BDF._jump``).

    Returns -1 when nothing jumped, else 1 when an unknown that is not index 2 jumped (the
    inputs' values jumped or the start was inconsistent: the derivatives must be probed
    again) or a nonlinear system's unknowns jumped (its charge derivatives change), 0 when
    only index-2 unknowns of a linear system did, or FACTOR_NEED_RIGHT_LIMIT when a nonlinear
    system's right limit must be computed by Python first (``F_RL_EPS``; it comes back in
    ``rl_given``). On a jump ``x`` becomes the right limit, which is recorded a second time
    at ``t`` and starts a new segment.
    """
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    (save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, restart_times,
     event_t, event_count, event_idx, w_ptr, w_idx, w_val) = rec
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    # an unknown that is not index 2 jumps where the probe's first Euler step carries the move
    # (JUMP_FIRST_STEP; x1 is the mean of xr and x2): where the inputs are continuous the
    # extrapolation's error (a large x'', a sqrt(t)-like solution) moves nothing by a jump, and a
    # curvature taken for one is carried on by the transmission lines' delayed waves as a real
    # jump; after a switching event (phi itself changed) every move counts
    first_step = I[I_EVENT_RESTART] == 0
    big = 0.0
    value_jump = False
    for i in range(n):
        m = abs(xr[i] - x[i]) * wf[i]
        if first_step and not high[i] and m > JUMP_DETECT:
            x1 = 0.5 * (xr[i] + x2[i])
            if abs(x2[i] - x1) > JUMP_FIRST_STEP * abs(x1 - x[i]):
                m = 0.0  # the extrapolation's error, not a jump
        if m > big or m != m:
            big = m
        if m > JUMP_DETECT and not high[i]:
            value_jump = True
    if not (big > JUMP_DETECT):
        return -1
    if first_step and not value_jump:
        for i in range(n):
            if not high[i]:
                xr[i] = x[i]  # only index-2 unknowns move
    if value_jump:
        if I[I_LINEAR] != 0:
            # an input value jumped: the index-2 unknowns carry an impulse in the first probe
            # step, their right limit is the value after the second
            for i in range(n):
                if high[i]:
                    xr[i] = x2[i]
        else:
            # a nonlinear system: converged implicit-Euler steps, by full Newton here (steps much
            # shorter than the probe's after a switching event), failing that from Python's steady
            # solver with its homotopies
            short = max(EVENT_RIGHT_LIMIT_FRACTION * eps,
                        EVENT_RIGHT_LIMIT_ULPS * ulp(t))
            if I[I_RL_READY] == 0:
                F[F_RL_EPS] = short if I[I_EVENT_RESTART] != 0 else eps
                solved = _event_right_limit(F, I, t, x, F[F_RL_EPS], tol, sysd, devd, lus, evb, ws)
                if not solved:
                    return FACTOR_NEED_RIGHT_LIMIT
            else:
                I[I_RL_READY] = 0
                for i in range(n):
                    xr[i] = rl_given[i]
            if I[I_EVENT_RESTART] == 0 and F[F_RL_EPS] > short:
                # a move is confirmed with the short steps (see BDF._jump): a mode faster than the
                # probe's step (a base current cut at an input's corner, a collector node 10 ps from
                # its source at the start), or one growing faster (the probe's steps oscillated),
                # moves nothing within them; an input that jumps moves the solution within the first
                moved = False
                for i in range(n):
                    if abs(xr[i] - x[i]) * wf[i] > JUMP_DETECT:
                        moved = True
                if moved:
                    F[F_RL_EPS] = short
                    solved = _event_right_limit(F, I, t, x, short, tol, sysd, devd, lus, evb, ws)
                    if not solved:
                        return FACTOR_NEED_RIGHT_LIMIT
    count = 0
    for i in range(n):
        if abs(xr[i] - x[i]) * wf[i] > JUMP_DETECT:
            count += 1
    if count == 0 and I[I_EVENT_RESTART] == 0:
        return -1  # the converged right limit is x itself: nothing jumped (after a switching event the
        # right limit is still recorded and the derivatives probed again from it: the switch changed phi)
    _continue_from(F, I, t, x, P, rtol, tol, sysd, devd, evb, ws, rec)
    # a nonlinear system's history holds q'(t+) = phi(x(t+)): an index-2 unknown that
    # jumped changes it in the rows it enters (a source current into a gate charge)
    return 1 if (value_jump or I[I_LINEAR] == 0) else 0


@kernel
def _continue_from(F, I, t, x, P, rtol, tol, sysd, devd, evb, ws, rec):
    """Continue from the right limit ``xr`` (in ``ws``) at ``t``: record the unknowns that jump,
    make it ``x`` and the history's value (and charges), record it a second time at ``t`` and
    start a new segment."""
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    (save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, restart_times,
     event_t, event_count, event_idx, w_ptr, w_idx, w_val) = rec
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    j = I[I_NJUMPS]
    if j < jump_t.size:
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
    if I[I_LINEAR] == 0:
        state = STATE_ACCEPTED if I[I_HAS_ACC] != 0 else STATE_NONE
        _evaluate(I, t, x, state, False, False, sysd, devd, u, evb)
        for c in range(crows.size):
            P[0, n + c] = qe[crows[c]]
    set_weights(x, rtol, atol, I[I_RELREF], xmax, mask, w, w_err)
    if I[I_LINEAR] == 0 and I[I_HAS_ABSDQ] != 0:
        indptr, indices = sysd[0], sysd[1]
        charge_newton_weights(P[0, n:], xmax[n:], qcol, absdq, indptr, indices, rtol, atol, w, work)
    _record(I, t, 0, x, rec)
    if I[I_NSEGMENTS] < segments.size:
        segments[I[I_NSEGMENTS]] = I[I_M] - 1
        I[I_NSEGMENTS] += 1


@kernel
def _first_step_from_curvature(curv, cap, min_step):
    """The first order-1 step ``sqrt(2 H0_ERROR_TARGET / |x''|_w)``, at most ``cap``, at least ``min_step``
    (the loop's twin of :func:`netdae.dae.bdf.controller.first_step_from_curvature`)."""
    h = cap if curv * cap * cap <= 2.0 * H0_ERROR_TARGET else math.sqrt(2.0 * H0_ERROR_TARGET / curv)
    return max(h, min_step)


@kernel
def _restart_at(F, I, P, psi, t, x, cap, fixed, tol, sysd, devd, lus, evb, ws, rec):
    """Probe the derivatives at (t, x), continue from the right limit where the solution
    jumps, and start at order 1 with a step <= cap (returns as _probe, or
    FACTOR_NEED_RIGHT_LIMIT)."""
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    h = cap
    # a restart repeated after a return to Python for new pivots has checked already
    # (x is the right limit then): one check per restart, as in the Python driver
    checked = I[I_RESTART_CHECKED] != 0
    if checked and F[F_RESTART_H] > 0.0:
        # ... and resumes with the probe that asked for them: starting again from the cap would
        # factor the first probe's matrix again, whose pivots the new ones replaced, and two probe
        # matrices of very different steps (a corner of a stiff circuit) would take turns asking
        h = F[F_RESTART_H]
    retries = 0
    jumped = I[I_RESTART_CHECKED] == 2  # resumed after a jump found here: the probe's charge rate as after it
    while True:
        eps = PROBE_FRACTION * h
        rc = _probe(F, I, t, x, eps, tol, sysd, devd, lus, evb, ws, jumped)
        if rc == FACTOR_NEED_PIVOTS:
            F[F_RESTART_H] = h
        if rc != FACTOR_OK:
            return rc
        if not checked:
            checked = True
            again = _jump(F, I, t, x, eps, P, F[F_RTOL], tol, sysd, devd, lus, evb, ws, rec)
            if again == FACTOR_NEED_RIGHT_LIMIT:
                I[I_PROBES] -= 1  # repeated when Python returns the right limit
                I[I_EVALUATIONS] -= 2
                I[I_JAC_EVALUATIONS] -= 1
                return again
            I[I_RESTART_CHECKED] = 1
            if again == 1:
                jumped = True
                I[I_RESTART_CHECKED] = 2
                continue  # derivatives from the right limit
        if fixed:
            break
        h_new = _first_step_from_curvature(weighted_norm(xpp, w_err, I[I_NORM]), cap, F[F_MIN_STEP])
        converged = eps <= PROBE_MAX_RATIO * h_new
        h = h_new
        retries += 1
        if converged or retries >= PROBE_RETRIES:
            break
    _initialise_history(F, I, P, psi, h, xp, qpb, crows)
    I[I_RESTART_CHECKED] = 0
    F[F_RESTART_H] = 0.0
    return FACTOR_OK


@kernel
def _reprobe(F, I, P, psi, t, x, cap, tol, sysd, devd, lus, evb, ws):
    """The (re)start's derivatives probed again at (t, x) for a first step of at most ``cap``, after
    the first step from it failed the error test REPROBE_ERROR_FAILURES times: the probe's implicit-Euler
    steps (a thousandth of the step they were for) damp a mode faster than themselves, the predictor
    misses its contribution and the error shrinks only in proportion to the step (a 1-ohm source into
    1 pF at a PULSE corner). One probe on the shorter step (never below the rounding of t), the step
    from its curvature; no jump check (the point stays). Returns as _probe (the step in F_H)."""
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    eps = max(PROBE_FRACTION * cap, EVENT_RIGHT_LIMIT_ULPS * ulp(t))
    rc = _probe(F, I, t, x, eps, tol, sysd, devd, lus, evb, ws, False)
    if rc != FACTOR_OK:
        return rc
    h = _first_step_from_curvature(weighted_norm(xpp, w_err, I[I_NORM]), cap, F[F_MIN_STEP])
    _initialise_history(F, I, P, psi, h, xp, qpb, crows)
    return FACTOR_OK


# ------------------------------------------------------------------ the nonlinear corrector
@inlined_kernel
def _residual(F, I, t_new, cj, x, jacobian, pred0, pred1, crows, sysd, devd, u, evb, r, v):
    """The corrector's residual at ``x`` with the trial limiting state: ``cj (q(x) - q_pred) +
    q'_pred - phi(x, t_new)`` in the rows ``crows`` (charge form, the charges ``pred0[n:]``,
    ``pred1[n:]`` predicted from their own history), ``cj E (x - x_pred) + E x'_pred -
    phi(x, t_new)`` in the others (correction form, ``dq/dx = E`` constant there; ``v`` is work)."""
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    xe, qe, phie, dqe, dphie, absdq = evb
    state = STATE_TRIAL if I[I_HAS_TRY] != 0 else STATE_NONE
    flags = _evaluate_inlined(I, t_new, x, state, True, jacobian, sysd, devd, u, evb)
    I[I_HAS_TRY] = 1
    _residual_of(cj, x, pred0, pred1, crows, e_data, indptr, indices, qe, phie, r, v)
    return flags


@inlined_kernel
def _residual_of(cj, x, pred0, pred1, crows, e_data, indptr, indices, qe, phie, r, v):
    """Into ``r``: the corrector's residual at ``x`` from the evaluated ``q`` (``qe``) and ``phi``
    (``phie``): ``cj (q - q_pred) + q'_pred - phi`` in the rows ``crows`` (every row when they are all),
    ``cj E (x - x_pred) + E x'_pred - phi`` in the others (``v`` is work)."""
    n = x.size
    m = crows.size
    if m == n:
        for i in range(n):
            r[i] = cj * (qe[i] - pred0[n + i]) + pred1[n + i] - phie[i]
        return
    for j in range(n):
        v[j] = (x[j] - pred0[j]) * cj + pred1[j]
    r[:] = 0.0
    _matvec_add(indptr, indices, e_data, v, 1.0, r)
    for c in range(m):
        i = crows[c]
        r[i] = (qe[i] - pred0[n + c]) * cj + pred1[n + c]
    for i in range(n):
        r[i] -= phie[i]


@inlined_kernel
def _newton(F, I, t_new, cj, setup, full, x_pred, xp_pred, crows, weights, sysd, devd, lus, u, evb, x, d, r, v):
    """Modified Newton on the corrector (:func:`netdae.dae.newton.newton` with
    ``jacobian="first"`` when ``setup``, else ``"never"`` with IDA's ``cj`` scaling;
    ``"always"`` when ``full``: a Jacobian at every iterate, the last retry of an attempt).

    ``x_pred``, ``xp_pred``: the prediction (the unknowns, then the charges of the rows ``crows``:
    :func:`_residual`). ``x`` holds the iterate on return. Returns ``(outcome, reason, worst, iterations, rate)``
    with outcome ``NEWTON_*`` and reason ``REASON_*`` (0 when converged).
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    norm = I[I_NORM]
    maxiter = I[I_NEWTON_MAXITER]
    if full:
        setup = True
    if setup:
        rate = RATE_AFTER_SETUP
        scale = 1.0
    else:
        rate = RATE_CJ_CHANGED if cj != F[F_CJLAST] else F[F_RATE]
        scale = 2.0 / (1.0 + cj / F[F_LU_TAG])
    ss = rate / (1.0 - rate)
    rate_out = rate
    old = 0.0
    have_d = False
    for i in range(n):
        x[i] = x_pred[i]
    need = setup
    flags = _residual(F, I, t_new, cj, x, need, x_pred, xp_pred, crows, sysd, devd, u, evb, r, v)
    for m in range(maxiter):
        if flags & FLAG_NONFINITE:
            worst = _nonfinite_worst(qe, phie, n)
            if worst < 0 and have_d:
                worst = _newton_worst(d, weights)
            return NEWTON_FAILED, REASON_EVALUATION, worst, m, rate_out
        if need:
            rc = _factor(F, I, cj, 0.0, dqe, dphie, lus, a_data)
            if rc == FACTOR_NEED_PIVOTS:
                return NEWTON_PIVOTS, 0, -1, m, rate_out
            if rc == FACTOR_SINGULAR:
                return NEWTON_FAILED, REASON_SINGULAR, -1, m, rate_out
        for i in range(n):
            d[i] = r[i]
        _solve(lus, d)
        if scale != 1.0:
            for i in range(n):
                d[i] *= scale
        have_d = True
        dn = weighted_norm(d, weights, norm)
        finite = math.isfinite(dn)
        for i in range(n):
            if not math.isfinite(d[i]):
                finite = False
        if not finite:
            return NEWTON_FAILED, REASON_NONFINITE, _newton_worst(d, weights), m + 1, rate_out
        trusted = True
        done = dn <= TINY_CORRECTION * EPCON
        if m == 0:
            old = dn
        elif not done:
            rho = (dn / old) ** (1.0 / m) if old > 0.0 else 0.0
            if rho > RATE_MAX:
                for i in range(n):
                    x[i] -= d[i]
                return NEWTON_FAILED, REASON_DIVERGED, _newton_worst(d, weights), m + 1, rho
            rate_out = rho
            ss = rho / (1.0 - rho)
            trusted = (not setup) or rho <= FRESH_RATE_MAX
        for i in range(n):
            x[i] -= d[i]
        limited = (flags & FLAG_LIMITED) != 0
        if not limited and (done or (trusted and ss * dn <= EPCON)):
            return NEWTON_CONVERGED, 0, _newton_worst(d, weights), m + 1, rate_out
        need = full
        if m + 1 < maxiter:
            flags = _residual(F, I, t_new, cj, x, need, x_pred, xp_pred, crows, sysd, devd, u, evb, r, v)
    return NEWTON_FAILED, REASON_MAXITER, _newton_worst(d, weights), maxiter, rate_out


@inlined_kernel
def _stalled(I, t_new, cj, x, pred0, pred1, crows, rtol, ratol, atol, dphi_lu, sysd, devd, u, evb, r, rn, v):
    """The check of an iterate ``x`` accepted with a Jacobian from an earlier step (the Python
    corrector's ``stale``).

    Evaluates ``q``, ``phi`` and their Jacobian at ``x`` (the charges the history takes; the
    Jacobian is not factored) with the devices' limiting against the last iterate, not kept.
    Stale when a device limited (the correction moved a junction further than its limiting
    allows: a Jacobian from another step let a one-iteration correction carry a clamp diode
    from -0.8 V to +11 V), when an entry of ``dphi/dx`` the
    factorisation holds (``dphi_lu``) fell by more than ``CONDUCTANCE_FALL``
    (:func:`netdae.dae.compiled.control.conductance_fell`), or when a row's residual stalled
    (:func:`netdae.dae.compiled.control.residual_stalled`): the corrector residual at ``x``
    (into ``rn``; ``r`` is the residual the accepted correction was computed from, ``v`` work)
    against the magnitude of the row's terms, the charge terms, the currents and
    ``(cj |E| + |H| + cj |dq - E| + |dphi - H|) |x|`` (the linear elements' and the devices'
    apart). Returns ``(stale, flags)``, the flags of the evaluation; ``qe`` and
    ``phie`` hold ``q(x)`` and ``phi(x)`` on return.
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    xe, qe, phie, dqe, dphie, absdq = evb
    n = x.size
    # with the devices' limiting against the last iterate (not kept): a junction the accepted
    # correction moved further than its limiting allows is not converged, as in SPICE; unlimited,
    # the values are x's own
    state = STATE_TRIAL if I[I_HAS_TRY] != 0 else STATE_NONE
    flags = _evaluate_inlined(I, t_new, x, state, False, True, sysd, devd, u, evb)
    if flags & FLAG_NONFINITE:
        return False, flags
    if flags & FLAG_LIMITED:
        return True, flags
    if conductance_fell(dphi_lu, dphie, dqe, cj, indptr, indices, ratol, atol, CONDUCTANCE_FALL):
        return True, flags
    # the residual at x (as _residual, from these q and phi)
    _residual_of(cj, x, pred0, pred1, crows, e_data, indptr, indices, qe, phie, rn, v)
    # the magnitudes: the linear elements' terms and the devices' apart (a resistor's current and
    # a device's that cancel it in the Jacobian, at a fold, are both terms of the row)
    for i in range(n):
        v[i] = abs(rn[i] + phie[i]) + abs(phie[i])
    for j in range(n):
        ax = abs(x[j])
        for p in range(indptr[j], indptr[j + 1]):
            v[indices[p]] += (cj * (abs(e_data[p]) + abs(dqe[p] - e_data[p])) + abs(h_data[p])
                              + abs(dphie[p] - h_data[p])) * ax
    return residual_stalled(r, rn, v, rtol, ratol, RESIDUAL_RATE_MAX, RESIDUAL_NU_MAX), flags


@entry_kernel
def run(F, I, P, psi, psi_saved, alpha, beta, gamma, sigma, bps, first_step, tol, sysd, devd, lus, evb, ws, wk,
        rec, max_chunk_steps):
    """Advance the integration until it finishes, fails, fills the buffers or uses the chunk.

    Parameters
    ----------
    tol : tuple
        ``(atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur)`` (``xmax``: shape (n + m,), the
        unknowns' then the charges' largest magnitudes): absolute tolerances,
        the error-test mask and index-2 flags, the largest values so far, the weights,
        the rounding floor's fixed signs, the charge columns of the rows whose charge error
        is tested (-1: not tested; :func:`netdae.dae.bdf.charge_rows`), the charge-form rows
        and each row's column among them (-1: correction form;
        :func:`netdae.dae.bdf.charge_columns`), the rows that raise the algebraic currents'
        error tolerances (:func:`netdae.dae.bdf.arguments.current_rows`).
    sysd : tuple
        The system's linear part: ``(indptr, indices, e_data, h_data, a_data, b_rows,
        b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n)`` (pattern, E and H on it,
        the work values of the Newton matrix, B in COO, the packed sources).
    devd : tuple
        The device families, ``(par, idx, vacc, vtry, vnew)`` each for diodes, BJTs,
        MOSFETs, JFETs and switches (empty arrays for an absent family), the switches' work
        array of crossing times, then the behavioural sources' tapes, then the OSDI
        devices' arrays (:func:`netdae.devices.kernels.osdi.eval_osdi`) and their
        limiting states ``(vacc, vtry, vnew)``, then the VDMOS transistors' ``(par, idx, vacc,
        vtry, vnew)``.
    lus : tuple
        The LU: the plan's arrays (:meth:`netdae.dae.compiled.lu.LuPlan.refactor_args`,
        ``perm_r``, ``perm_c``), the factors' values and two work vectors.
    evb : tuple
        Evaluation buffers ``(xe, qe, phie, dqe, dphie, absdq)`` (n + 1 and nnz + 1).
    ws : tuple
        Work vectors ``(u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given)``.
    wk : tuple
        The step's work vectors ``(ee, pred0, pred1, r, d, xn, w_newton, w_se, xs, wq, vw)``
        (the first three of the history's width, ``wq`` of the number of charge columns,
        the others n), then ``ratol``, the rows' absolute tolerances of the corrector's check
        (:func:`netdae.dae.bdf.arguments.row_tolerances`), and ``dphi_lu`` (nnz + 1), ``dphi/dx``
        of the Jacobian the factorisation was made from.
    rec : tuple
        The output: ``(save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments,
        restart_times, event_t, event_count, event_idx)`` (the events: their times and the
        switches that changed, as the jumps); the loop returns ``BUFFER_FULL`` when any of them
        may not hold the next step (switching events add restarts, jumps and segments).

    Returns
    -------
    int
        A status code of this module (RUNNING is never returned).
    """
    indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n, dl = sysd
    atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, cur = tol
    u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given = ws
    (save, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, restart_times,
     event_t, event_count, event_idx, w_ptr, w_idx, w_val) = rec
    xe, qe, phie, dqe, dphie, absdq = evb
    width = P.shape[1]
    n = atol.size
    linear = I[I_LINEAR] != 0
    maxord = I[I_MAXORD]
    ee, pred0, pred1, r, d, xn, w_newton, w_se, xs, wq, vw, ratol, dphi_lu = wk
    wq_count = 0
    rtol = F[F_RTOL]
    norm = I[I_NORM]
    s_par = devd[20]
    s_idx = devd[21]
    s_vacc = devd[22]
    s_vtry = devd[23]
    s_tc = devd[25]
    switches = s_par.shape[0] > 0
    h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock, h_xw = devd[26:34]
    locks = h_lock.shape[1] > 1  # behavioural sources with comparisons of the state

    if I[I_STARTED] == 0:
        I[I_STARTED] = 1
        if not linear and (crows.size or devd[34].shape[0] > 0):  # (the OSDI modules' $bound_step at t0)
            # the history's charges at t0 from the loop's own evaluation, as everywhere after: Python's
            # sums them in another order (a dense product whose rounding depends on where BLAS finds its
            # arrays in memory), and a start's right limit divides them by steps of 1e-14 s
            for i in range(n):
                xs[i] = P[0, i]
            _evaluate(I, F[F_T], xs, STATE_NONE, False, False, sysd, devd, u, evb)
            for c in range(crows.size):
                P[0, n + c] = qe[crows[c]]
        if locks:
            # the behavioural sources' comparisons held from here on, in their outcomes at t0
            for i in range(n):
                xe[i] = P[0, i]
            xe[n] = 0.0
            lock_record(xe, F[F_T], h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock)
        # the record at t0, then the start: an order-1 restart with probed derivatives
        _record(I, F[F_T], 0, P[0], rec)
        cap = min(H0_FRACTION * (bps[0] - F[F_T]), F[F_MAX_STEP], _osdi_bound(devd))
        I[I_PENDING_RESTART] = 1
        F[F_RESTART_FIXED] = 1.0 if first_step > 0.0 else 0.0
        F[F_RESTART_CAP] = first_step if first_step > 0.0 else cap

    chunk = 0
    while I[I_STATUS] == RUNNING:
        if (I[I_NJUMPS] + 1 >= jump_t.size or I[I_NRESTART_TIMES] + 2 >= restart_times.size
                or I[I_NSEGMENTS] + 3 >= segments.size or I[I_NEVENTS] + 1 >= event_t.size):
            return BUFFER_FULL  # a step and a restart add at most one restart, one jump, two segments
        if I[I_PENDING_RESTART] != 0:
            if I[I_M] + 1 >= buf_t.size:
                return BUFFER_FULL  # a jump records a second point
            for i in range(n):
                xs[i] = P[0, i]
            if I[I_IMPASSE] != 0 and I[I_RL_READY] != 0:
                # Newton failed on every step size from t: continue from the solution of the
                # implicit-Euler steps Python's steady-state solver found right of t (a jump)
                I[I_IMPASSE] = 0
                I[I_RL_READY] = 0
                for i in range(n):
                    xr[i] = rl_given[i]
                _continue_from(F, I, F[F_T], xs, P, rtol, tol, sysd, devd, evb, ws, rec)
                I[I_RESTART_CHECKED] = 1
            rc = _restart_at(F, I, P, psi, F[F_T], xs, F[F_RESTART_CAP], F[F_RESTART_FIXED] != 0.0, tol,
                             sysd, devd, lus, evb, ws, rec)
            if rc == FACTOR_NEED_PIVOTS:
                return NEED_PIVOTS
            if rc == FACTOR_NEED_RIGHT_LIMIT:
                return NEED_RIGHT_LIMIT
            if rc != FACTOR_OK:
                return I[I_STATUS]
            I[I_PENDING_RESTART] = 0
            I[I_EVENT_RESTART] = 0
            if I[I_FINAL_RESTART] != 0:
                # the value after an event at t_bound is recorded (a jump's second point): the end
                I[I_STATUS] = FINISHED
                return FINISHED
        if I[I_M] >= buf_t.size:
            return BUFFER_FULL
        if chunk >= max_chunk_steps:
            return CHUNK_DONE
        chunk += 1
        # ---------------------------------------------------------------- one step
        ncf = 0
        nef = 0
        nud = 0  # attempts past a change where a held branch is undefined
        h_undefined = 0.0
        flip = False
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
            for i in range(psi.size):
                psi_saved[i] = psi[i]
            cj, ck = flc_coefficients(h, k, psi_saved, psi, alpha, beta, gamma, sigma)
            F[F_CJLAST] = F[F_CJ]
            F[F_CJ] = cj
            if ns <= k:
                for i in range(ns, k + 1):
                    for c in range(width):
                        P[i, c] *= beta[i]
            t_new = bps[ibp] if landing else t + h
            # a step landing on a breakpoint sees the inputs from the left (an expression of time
            # that jumps there, time < 1m ? a : b, takes its right value only at the restart)
            t_ev = np.nextafter(t_new, -np.inf) if landing else t_new
            # phase 2: predict
            for c in range(width):
                s = 0.0
                sp = 0.0
                for i in range(k + 1):
                    s += P[i, c]
                    sp += gamma[i] * P[i, c]
                pred0[c] = s
                pred1[c] = sp
            cj_counted = cj != F[F_LAST_CJ_ATTEMPT]
            if cj_counted:
                I[I_CJ_CHANGES] += 1
                F[F_LAST_CJ_ATTEMPT] = cj
            # phase 3: the corrector
            kind = 0  # 0 accepted, 1 newton failure, 2 error failure
            worst = -1
            pivots = False
            w_step = w_err
            if linear:
                rc = FACTOR_OK
                if F[F_LU_TAG] != cj:
                    rc = _factor(F, I, cj, 0.0, e_data, h_data, lus, a_data)
                if rc == FACTOR_NEED_PIVOTS:
                    pivots = True
                elif rc == FACTOR_SINGULAR:
                    kind = 1
                    reason = REASON_SINGULAR
                else:
                    # one exact solve: r = E xp_pred - H x_pred - B u(t_new)
                    _phi(t_ev, pred0, sysd, u, r)
                    for c in range(n):
                        r[c] = -r[c]
                    _matvec_add(indptr, indices, e_data, pred1, 1.0, r)
                    _solve(lus, r)
                    I[I_EVALUATIONS] += 1
                    I[I_NEWTON] += 1
                    for c in range(n):
                        ee[c] = -r[c]
            else:
                q_pred = pred0[n:]
                qp_pred = pred1[n:]
                _reset_trial(I, devd)
                ready = not math.isnan(F[F_LU_TAG])
                setup = (not ready) or I[I_NST] == 0
                if not setup:
                    ratio = cj / F[F_LU_TAG]
                    setup = ratio < (1.0 - DCJ) / (1.0 + DCJ) or ratio > (1.0 + DCJ) / (1.0 - DCJ)
                    setup = setup or I[I_JAC_AGE] >= JAC_AGE_MAX
                w_nt = w
                if I[I_HAS_ABSDQ] != 0 and ready:
                    if _rounding_floor(pred0[:n], pred1[:n], qp_pred, cj, qcol, False, absdq, indptr, indices, lus,
                                       signs, w, w_newton, b1, b2):
                        w_nt = w_newton
                        for i in range(n):
                            w_se[i] = min(w_err[i], w_newton[i]) if w_newton[i] != w[i] else w_err[i]
                        w_step = w_se
                # one call site of the inlined Newton: the first attempt, then (a stale Jacobian) once
                # with a fresh one at the same step size, then (a fresh Jacobian failed too) full Newton,
                # a model whose slope changes within the step (a MOS charge at its threshold), before a
                # smaller step
                # An iterate accepted with a Jacobian from an earlier step is checked on the Jacobian
                # there (_stalled): a matrix made at another operating point (a junction's conductance
                # at a bias it has left) understates the correction, and the attempt is solved again
                # with a fresh Jacobian, as after a failure
                fresh = setup
                full = False
                have_q = False  # qe, phie hold q and phi at xn (no limiting)
                flags = 0
                while True:
                    outcome, reason, worst, its, rate = _newton(F, I, t_ev, cj, fresh, full, pred0, pred1, crows,
                                                                w_nt, sysd, devd, lus, u, evb, xn, d, r, vw)
                    if fresh or full:
                        I[I_JAC_AGE] = 0
                        # dphi/dx of the Jacobian just factored (the last one _newton evaluated)
                        for p in range(dphi_lu.size):
                            dphi_lu[p] = dphie[p]
                    elif outcome == NEWTON_CONVERGED:
                        stalled, sflags = _stalled(I, t_ev, cj, xn, pred0, pred1, crows, rtol, ratol, atol, dphi_lu,
                                                   sysd, devd, u, evb, r, d, vw)
                        if stalled:
                            outcome = NEWTON_FAILED
                            reason = REASON_DIVERGED
                        else:
                            have_q = True
                            flags = sflags
                    if outcome != NEWTON_FAILED or full or reason == REASON_EVALUATION:
                        break
                    if fresh and reason == REASON_SINGULAR:
                        break
                    I[I_NEWTON_FAILURES] += 1
                    I[I_NEWTON] += its
                    _reset_trial(I, devd)
                    if fresh:
                        full = True
                    fresh = True
                I[I_NEWTON] += its
                if outcome == NEWTON_PIVOTS:
                    pivots = True
                elif outcome == NEWTON_FAILED:
                    kind = 1
                else:
                    # a rate carried by solves that converged at their first correction was measured
                    # with an older Jacobian at another point: after RATE_AGE_MAX of them it is assumed again
                    I[I_RATE_AGE] = I[I_RATE_AGE] + 1 if its <= 1 else 0
                    F[F_RATE] = rate
                    if I[I_RATE_AGE] >= RATE_AGE_MAX:
                        F[F_RATE] = RATE_AFTER_SETUP
                        I[I_RATE_AGE] = 0
                    # the charges at the new point, evaluated exactly (no limiting): the
                    # history must hold q(x_new) itself (a system whose devices store no
                    # charge has none to hold: its linear charges E x are in correction form)
                    if not have_q:
                        flags = 0
                        if crows.size > 0:
                            flags = _evaluate_inlined(I, t_ev, xn, STATE_NONE, False, False, sysd, devd, u, evb)
                    if flags & FLAG_NONFINITE:
                        kind = 1
                        reason = REASON_EVALUATION
                        worst = _nonfinite_worst(qe, phie, n)
                    else:
                        for c in range(n):
                            ee[c] = xn[c] - pred0[c]
                        for c in range(crows.size):
                            ee[n + c] = qe[crows[c]] - q_pred[c]
                        if locks and lock_undefined(h_lock) >= 0:
                            kind = 3  # past a change where a held branch is undefined: no error test
            if pivots:
                # undo phase 1 and return for new pivots; the attempt is repeated on the next call
                _restore(P, psi, psi_saved, beta, ns, k)
                F[F_CJ] = F[F_CJLAST]
                F[F_H] = h
                if cj_counted:  # counted again when the attempt is repeated
                    I[I_CJ_CHANGES] -= 1
                    F[F_LAST_CJ_ATTEMPT] = math.nan
                return NEED_PIVOTS
            if kind == 0:
                # phase 4: error test (IDATestError)
                e0, e1, e2 = error_norms(ee, P, k, w_step, norm, n)
                wq_count = 0
                if not linear and I[I_HAS_ABSDQ] != 0:
                    wq_count = charge_weights(qrows, absdq, indptr, indices, w, wq)
                    if wq_count > 0:
                        q0, q1, q2 = charge_error_norms(ee, P, k, wq, norm, n, wq_count)
                        e0 = max(e0, q0)
                        e1 = max(e1, q1)
                        e2 = max(e2, q2)
                if I[I_CHARGE_TIME] != 0:
                    # the charges that read time: the error of dq/dt at fixed x, the charge history's
                    # derivative, in the unknowns (time_charge_residual solved with the Newton matrix)
                    for j in range(min(k, 3)):
                        time_charge_residual(ee, P, n, k + 1 - j, k, 1.0, trows, cj, work)
                        _solve(lus, work)
                        ej = weighted_norm(work, w_step, norm)
                        if j == 0:
                            e0 = max(e0, ej)
                        elif j == 1:
                            e1 = max(e1, ej)
                        else:
                            e2 = max(e2, ej)
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
                    worst = _worst(ee[:n], w)
                else:
                    kind = 2
                    worst = _worst(ee[:n], w_err)
                    if worst >= 0 and w_err[worst] == 0.0:
                        worst = _worst(ee[:n], w)
            if accepted:
                break
            _restore(P, psi, psi_saved, beta, ns, k)
            I[I_PHASE] = 1
            if kind == 3:
                # a behavioural source's held branch is undefined at the attempt's end (sqrt(v(a)) held
                # past v(a) > 0): its comparison changed inside the step. The change located on the last
                # step's polynomial continued (the predictor's), the step ends there; a change closer than
                # EVENT_MIN_GAP of the first such attempt, or than the rounding of t, happens here and now
                # (an event at t)
                nud += 1
                I[I_UNDEFINED_STEP] = 1
                if F[F_UNDEFINED_H] == 0.0:
                    F[F_UNDEFINED_H] = h  # the approach to the change begins (it may take several steps)
                h_undefined = F[F_UNDEFINED_H]
                # (lock_step with t_new = t: the polynomial at t continued; its own step-relative floors
                # vanish, so the first change is read from the slots' times)
                t_lock, nlock = lock_step(P, I[I_KUSED], psi, t, t, t + h, n, h_prog, h_const, h_inst, h_leaf,
                                          h_val, h_der, h_lock, h_xw)
                if nlock > 0:
                    t_lock = t + h  # the first change (t itself when the continued polynomial is past it at t)
                    for sl in range(h_lock.shape[1] - 1):
                        t_lock = min(t_lock, h_lock[LOCK_TIME, sl])
                gap = t_lock - t
                # (no shorter step ends between t and the change: the reduced steps stop at ROUNDOFF_ULPS)
                at_t = max(EVENT_MIN_GAP * h_undefined, 4.0 * ROUNDOFF_ULPS * ulp(t))
                if nlock > 0 and gap <= at_t:
                    flip = True
                    break
                if nlock == 0 and h <= at_t:
                    # the continued polynomial does not see the change the corrector met within this
                    # short a step (the right limit at t left the control on the threshold's other
                    # side by its tolerance): it changes here, to the outcomes at the attempt's end
                    for i in range(n):
                        h_xw[i] = xn[i]
                    h_xw[n] = 0.0
                    if lock_at(h_xw, t, h_prog, h_const, h_inst, h_leaf, h_val, h_der, h_lock) > 0:
                        t_lock = t
                        flip = True
                        break
                if nud > UNDEFINED_TRIES:
                    _fail(F, I, t, h, FAIL_UNDEFINED * 256, s_par.shape[0] + lock_undefined(h_lock))
                    return FAILED
                I[I_REJECTED] += 1
                # to the change the continued polynomial puts first; past it still (that polynomial leads the
                # solution), just before it, then halving
                eta = gap / h if nlock > 0 and gap < h else (0.9 if nud == 2 else 0.5)
            elif kind == 1:
                ncf += 1
                I[I_NEWTON_FAILURES] += 1
                if ncf == 1 and not linear:
                    # the junctions are limited from the accepted point in the next attempts
                    _evaluate(I, t, P[0, :n], STATE_NONE, False, False, sysd, devd, u, evb)
                    _point_state(devd)
                if ncf >= MAX_NEWTON_FAILURES:
                    _fail(F, I, t, h, FAIL_NEWTON * 16 + reason, worst)
                    if reason != REASON_EVALUATION and _impasse(F, I, t):
                        return NEED_RIGHT_LIMIT
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
            if kind == 3 and (h_new < F[F_MIN_STEP] or h_new <= ROUNDOFF_ULPS * ulp(t)
                              or t + h_new == t):
                _fail(F, I, t, h, FAIL_UNDEFINED * 256, s_par.shape[0] + lock_undefined(h_lock))
                return FAILED
            if h_new < F[F_MIN_STEP]:
                if h > F[F_MIN_STEP] * (1.0 + 1e-12):
                    h_new = F[F_MIN_STEP]
                else:
                    _fail(F, I, t, h, FAIL_MIN_STEP * 256 + code, worst)
                    return FAILED
            elif h_new <= ROUNDOFF_ULPS * ulp(t) or t + h_new == t:
                _fail(F, I, t, h, FAIL_ROUNDOFF * 256 + code, worst)
                if (kind == 2 or reason != REASON_EVALUATION) and _impasse(F, I, t):
                    return NEED_RIGHT_LIMIT
                return FAILED
            if I[I_NST] == 0 and kind == 2 and nef >= REPROBE_ERROR_FAILURES:
                # the first step from a (re)start failed the error test again and again: its derivatives
                # probed again on the shorter step (_reprobe; BDF._reprobe)
                for i in range(n):
                    xs[i] = P[0, i]
                rc = _reprobe(F, I, P, psi, t, xs, h_new, tol, sysd, devd, lus, evb, ws)
                if rc == FACTOR_NEED_PIVOTS:  # resumed as a restart at t that has checked for a jump
                    I[I_PENDING_RESTART] = 1
                    I[I_RESTART_CHECKED] = 1
                    F[F_RESTART_CAP] = h_new
                    F[F_RESTART_FIXED] = 0.0
                    F[F_RESTART_H] = h_new
                    return NEED_PIVOTS
                if rc != FACTOR_OK:
                    return I[I_STATUS]
                h_new = F[F_H]
            elif I[I_NST] == 0:
                psi[0] = h_new
                for c in range(width):
                    P[1, c] *= h_new / h
            h = h_new
        if flip:
            # the change is here: the held outcomes take their new values at t (an event without a step),
            # and the method restarts at order 1 from the right limit
            F[F_UNDEFINED_H] = 0.0
            I[I_UNDEFINED_STEP] = 0
            lock_flip(h_lock, t_lock + EVENT_TOGETHER * h_undefined)
            I[I_EVENTS] += 1
            I[I_CHATTER] = I[I_CHATTER] + 1 if (I[I_NST] == 0 and I[I_AFTER_EVENT] != 0) else 0
            j = I[I_NEVENTS]
            event_t[j] = t
            count = 0
            if switches:
                # the switches settle at the change in the same event (one controlled by the same crossing
                # would otherwise change a rounding later, as a second event): decided at the change's point,
                # the continued polynomial's there (the attempt's end when that polynomial did not see it)
                if nlock > 0:
                    interpolate_state(P, I[I_KUSED], psi, t_lock - t, n, h_xw)
                h_xw[n] = 0.0
                if switch_at(h_xw, t, s_par, s_idx, s_vacc, s_vtry, s_tc) > 0:
                    for i in range(s_par.shape[0]):
                        if s_tc[i] <= t:
                            if count < JUMP_NAMES:
                                event_idx[j, count] = i
                            count += 1
            event_count[j] = _lock_event_names(h_inst, h_lock, t_lock + EVENT_TOGETHER * h_undefined, event_idx, j,
                                               count, s_par.shape[0])
            I[I_NEVENTS] = j + 1
            if I[I_CHATTER] >= CHATTER_EVENTS:
                _fail(F, I, t, h_undefined, FAIL_CHATTER * 256, event_idx[j, 0])
                return FAILED
            I[I_AFTER_EVENT] = 1
            I[I_EVENT_RESTART] = 1
            _schedule_restart(F, I, t, h_undefined, bps, restart_times, segments)
            F[F_H] = h_undefined
            continue
        # phase 5: complete the step (IDACompleteStep)
        if I[I_UNDEFINED_STEP] == 0:
            F[F_UNDEFINED_H] = 0.0  # an approach to a change where a held branch is undefined ended without it
        I[I_UNDEFINED_STEP] = 0
        retried = ncf + nef > 0
        k = I[I_K]
        I[I_NST] += 1
        I[I_STEPS] += 1
        I[I_JAC_AGE] += 1
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
                if wq_count > 0:
                    err_kp1 = max(err_kp1, charge_error_kp1(ee, P, k, wq, norm, n, wq_count) / (k + 2))
                if I[I_CHARGE_TIME] != 0:
                    time_charge_residual(ee, P, n, k + 1, k + 1, -1.0, trows, F[F_CJ], work)
                    _solve(lus, work)
                    err_kp1 = max(err_kp1, weighted_norm(work, w_err, norm) / (k + 2))
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
        # switching events: the states at the step's end, or the step cut where a control crossed
        # (a switch's threshold, or a behavioural source's comparison of the state)
        t_end = t_new
        nsw = 0
        nlock = 0
        if switches:
            # the new states go to s_vtry (every evaluation writes s_vnew; keep=False leaves s_vtry)
            t_end, nsw = switch_step(P, k, psi, t, t_new, n, s_par, s_idx, s_vacc, s_vtry, s_tc, xe, work)
        if locks:
            t_lock, nlock = lock_step(P, k, psi, t, t_new, t_end, n, h_prog, h_const, h_inst, h_leaf, h_val, h_der,
                                      h_lock, h_xw)
            if nlock > 0 and t_lock < t_end:
                # a comparison changes first: the switches keep their conductance to there
                if nsw > 0:
                    _copy2(s_vtry, s_vacc)
                    nsw = 0
                t_end = t_lock
                interpolate_state(P, k, psi, t_end - t_new, n, work)
        event = nsw > 0 or nlock > 0
        if t_end < t_new:
            for i in range(n):
                P[0, i] = work[i]
            # the charges at the event, exactly (the history holds q(x) itself), in the held states
            _evaluate(I, t_end, work, STATE_NONE, False, False, sysd, devd, u, evb)
            for c in range(crows.size):
                P[0, n + c] = qe[crows[c]]
        if nlock > 0:
            lock_flip(h_lock, t_end + EVENT_TOGETHER * h)
        F[F_T] = t_end
        if not linear:
            _accept_state(I, devd)
        if switches:
            _copy2(s_vacc, s_vtry)
        set_weights(P[0, :n], rtol, atol, I[I_RELREF], xmax, mask, w, w_err)
        if cur[0].size > 0:
            # algebraic currents: no stricter than their resistive rows make them (current_error_weights)
            current_error_weights(w, w_err, mask, cur)
        if not linear and I[I_HAS_ABSDQ] != 0:
            charge_newton_weights(P[0, n:], xmax[n:], qcol, absdq, indptr, indices, rtol, atol, w, work)
        _record(I, t_end, k, P[0], rec)
        F[F_H] = max(min(h * eta, F[F_MAX_STEP], _osdi_bound(devd)), F[F_MIN_STEP])
        if _osdi_end(I, devd):
            I[I_STATUS] = FINISHED
            return FINISHED
        landed = landing and t_end == t_new
        final = landed and I[I_IBP] == bps.size - 1
        if final and not event:
            I[I_STATUS] = FINISHED
            return FINISHED
        if not final and I[I_MAX_STEPS] > 0 and I[I_STEPS] >= I[I_MAX_STEPS]:
            _fail(F, I, t_end, F[F_H], FAIL_MAX_STEPS * 256, -1)
            return FAILED
        if event:
            I[I_EVENTS] += 1
            F[F_UNDEFINED_H] = 0.0
            # chattering: an event in the first step after an event's restart, again and again
            I[I_CHATTER] = I[I_CHATTER] + 1 if (I[I_NST] == 1 and I[I_AFTER_EVENT] != 0) else 0
            I[I_EVENT_RESTART] = 1
            j = I[I_NEVENTS]
            event_t[j] = t_end
            count = 0
            if nsw > 0:
                for i in range(s_par.shape[0]):
                    if s_tc[i] <= t_end + EVENT_TOGETHER * h:
                        if count < JUMP_NAMES:
                            event_idx[j, count] = i
                        count += 1
            if nlock > 0:
                count = _lock_event_names(h_inst, h_lock, t_end + EVENT_TOGETHER * h, event_idx, j, count,
                                          s_par.shape[0])
            event_count[j] = count
            I[I_NEVENTS] = j + 1
            if I[I_CHATTER] >= CHATTER_EVENTS:
                _fail(F, I, t_end, h, FAIL_CHATTER * 256, event_idx[j, 0])
                return FAILED
        if final:
            # a switch or a comparison changes at t_bound itself: the event is recorded above, the value
            # after it (the right limit) by the restart, which no breakpoint ahead bounds, then the run ends
            _schedule_restart(F, I, t_end, h, bps, restart_times, segments)
            F[F_RESTART_CAP] = max(min(h, F[F_MAX_STEP]), F[F_MIN_STEP])
            I[I_FINAL_RESTART] = 1
            continue
        if landed or event:
            I[I_AFTER_EVENT] = 1 if event else 0
        if event and not landed:
            # order-1 restart at the event with probed derivatives (and the right limit, where it jumps)
            _schedule_restart(F, I, t_end, h, bps, restart_times, segments)
        if landed:
            I[I_IBP] += 1
            # order-1 restart on the breakpoint with probed derivatives
            _schedule_restart(F, I, t_new, max(h, F[F_H_REQUEST]), bps, restart_times, segments)
    return I[I_STATUS]
