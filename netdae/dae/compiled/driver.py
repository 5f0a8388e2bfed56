"""Python side of the compiled transient engine: pack, run in chunks, report.

:func:`integrate_compiled` takes the same arguments as
:func:`netdae.dae.bdf.integrate` and returns the same
:class:`~netdae.dae.bdf.IntegrationResult`, computed by the compiled step
loop of :mod:`netdae.dae.compiled.linear_bdf`. It serves a linear MNA
system (constant ``E``, ``H``, ``B`` and the independent sources'
waveforms, which compile); for anything else it returns ``None`` and the
caller uses the Python integrator.

Python is entered once per output chunk: when the output buffers are full
(they double), and after a bounded number of steps (about
``PROGRESS_INTERVAL`` of wall time) so that a progress callback runs and
Ctrl-C is honoured. An interrupted run keeps what it computed: the
``KeyboardInterrupt`` propagates with the partial result attached as its
``partial`` attribute.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import linear_bdf as L
from .control import NORM_MAX, NORM_RMS, RELREF_LOCAL, RELREF_MIXED, RELREF_SIGNAL, set_weights
from .lu import PIVOT_REL_THRESHOLD, SparseLU
from .sources import pack_sources

__all__ = ["integrate_compiled", "supports"]

#: Options the compiled engine implements (any other keyword sends the call to the Python integrator).
_SUPPORTED = frozenset({"rtol", "atol", "vntol", "abstol", "index", "maxord", "max_step", "min_step",
                        "first_step", "breakpoints", "save", "norm", "relref", "max_steps"})
#: Initial capacity of the output buffers (they double when full).
BUFFER_START = 1024
#: Wall time between two returns to Python [s] (progress, Ctrl-C).
PROGRESS_INTERVAL = 0.1
#: Steps of the first chunk (later chunks are sized from the measured rate).
FIRST_CHUNK = 64


def supports(system, options: dict) -> bool:
    """True when :func:`integrate_compiled` can run ``system`` with ``options``."""
    if not getattr(system, "linear", False) or set(options) - _SUPPORTED:
        return False
    if getattr(system, "sources", None) is None or getattr(system, "B", None) is None:
        return False
    if getattr(system.sources, "mode", None) != "tran":
        return False
    if system.n == 0:
        return False
    return True


def integrate_compiled(system, t_span, x0, *, progress=None, raise_on_failure=False, **options):
    """Integrate a linear MNA system with the compiled engine (see the module docstring).

    Returns
    -------
    IntegrationResult or None
        ``None`` when the system or an option is not supported.

    Raises
    ------
    ValueError
        For invalid arguments (as :class:`netdae.dae.bdf.BDF`).
    ConvergenceError
        With ``raise_on_failure=True`` on failure.
    """
    from ...errors import ConvergenceError
    from ...results import STATUS_FAILED, STATUS_OK
    from ..bdf import (
        BREAKPOINT_MERGE,
        MAX_ORDER,
        IntegrationResult,
        absolute_tolerances,
        check_arguments,
        index_mask,
        save_indices,
    )
    from ..bdf_kernels import merge_breakpoints
    from ..dense import Interpolant

    if not supports(system, options):
        return None
    wall0 = time.perf_counter()
    n = int(system.n)
    t0, t_bound = (float(v) for v in t_span)
    rtol = float(options.get("rtol", 1e-3))
    maxord = int(options.get("maxord", MAX_ORDER))
    max_step = float(options.get("max_step", math.inf))
    min_step = float(options.get("min_step", 0.0))
    first_step = options.get("first_step")
    norm_name = options.get("norm", "rms")
    relref_name = options.get("relref", "local")
    max_steps = options.get("max_steps")
    x0 = check_arguments(t0, t_bound, x0, n, rtol=rtol, maxord=maxord, norm=norm_name, relref=relref_name,
                         max_step=max_step, min_step=min_step, first_step=first_step)
    norm = NORM_MAX if norm_name == "max" else NORM_RMS
    relref = {"local": RELREF_LOCAL, "signal": RELREF_SIGNAL, "mixed": RELREF_MIXED}[relref_name]
    vntol = float(options.get("vntol", 1e-6))
    abstol = float(options.get("abstol", 1e-12))
    atol, atol_label = absolute_tolerances(system.kinds, n, options.get("atol", 1e-6), vntol, abstol)
    high, factor, excluded = index_mask(system.names, n, options.get("index"), norm_name)
    mask = np.ones(n) if factor is None else factor
    save_idx = save_indices(n, options.get("save"))
    extra = [np.asarray(system.breakpoints(t0, t_bound), dtype=float).ravel()]
    if options.get("breakpoints") is not None:
        extra.append(np.asarray(options["breakpoints"], dtype=float).ravel())
    bps = merge_breakpoints(t0, t_bound, np.concatenate(extra), BREAKPOINT_MERGE * (t_bound - t0))

    pattern = system.pattern
    indptr = np.asarray(pattern.indptr, dtype=np.int64)
    indices = np.asarray(pattern.indices, dtype=np.int64)
    e_data = np.array(pattern.data_of(system.E), dtype=float)
    h_data = np.array(pattern.data_of(system.H), dtype=float)
    B = system.B.tocoo()
    b_rows, b_cols, b_vals = B.row.astype(np.int64), B.col.astype(np.int64), B.data.astype(float)
    skind, spar, spwl_t, spwl_v, spwl_n = pack_sources(system.sources)

    F = np.zeros(L.N_F)
    I = np.zeros(L.N_I, dtype=np.int64)
    F[L.F_T] = t0
    F[L.F_RTOL] = rtol
    F[L.F_MAX_STEP] = max_step
    F[L.F_MIN_STEP] = min_step
    F[L.F_H_MIN] = math.inf
    F[L.F_LU_TAG] = math.nan
    F[L.F_LAST_CJ_ATTEMPT] = math.nan
    I[L.I_MAXORD] = maxord
    I[L.I_NORM] = norm
    I[L.I_RELREF] = relref
    I[L.I_MAX_STEPS] = 0 if max_steps is None else int(max_steps)
    I[L.I_K] = 1
    I[L.I_EVALUATIONS] = 1       # the evaluation at t0 (as the Python integrator counts it)
    I[L.I_JAC_EVALUATIONS] = 1
    P = np.zeros((maxord + 1, n))
    P[0] = x0
    psi = np.zeros(MAX_ORDER + 1)
    coef = [np.zeros(MAX_ORDER + 1) for _ in range(5)]
    xmax = np.abs(x0)
    w = np.empty(n)
    w_err = np.empty(n)
    set_weights(x0, rtol, atol, relref, xmax, mask, w, w_err)
    restart_times = np.zeros(bps.size + 1)
    a_data = np.zeros(e_data.size)
    sysd = (indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n)
    # the first pivot order: of the first probe's matrix E / eps - H (any degraded pivot later
    # sends the loop back here for a new one)
    F[L.F_PIVOT_THRESHOLD] = PIVOT_REL_THRESHOLD
    lu = SparseLU(pattern, threshold=PIVOT_REL_THRESHOLD)
    identity = np.where(pattern.rows == pattern.cols, 1.0, 0.0)
    eps0 = L.PROBE_FRACTION * min(L.H0_FRACTION * (bps[0] - t0), max_step)
    if not lu.factor(e_data / eps0 - h_data):
        # a singular matrix shows again in the loop, which reports it; a plan in the
        # identity order keeps the loop's arguments defined until then
        lu.factor(identity)
    swork = np.zeros(n)
    # fixed pseudo-random signs of the rounding floor's second right-hand side (as BDF's)
    signs = np.where(np.random.default_rng(1).random(n) < 0.5, -1.0, 1.0)
    jump_t = np.zeros(bps.size + 1)
    jump_count = np.zeros(bps.size + 1, dtype=np.int64)
    jump_idx = np.zeros((bps.size + 1, L.JUMP_NAMES), dtype=np.int64)
    segments = np.zeros(2 * bps.size + 3, dtype=np.int64)
    I[L.I_NSEGMENTS] = 1  # segments[0] = 0: the start

    def lus():
        plan = lu.plan
        return (*plan.refactor_args(), plan.perm_r, plan.perm_c, lu._l, lu._u, lu._x, swork)

    cap = BUFFER_START
    buf_t = np.empty(cap)
    buf_k = np.zeros(cap, dtype=np.int8)
    buf_x = np.empty((cap, save_idx.size))
    fs = float(first_step) if first_step is not None else 0.0

    chunk = FIRST_CHUNK
    last = time.perf_counter()
    status = L.RUNNING
    interrupted = None
    try:
        while True:
            tic = time.perf_counter()
            status = L.run(F, I, P, psi, coef[0], coef[1], coef[2], coef[3], coef[4], bps, fs,
                           atol, mask, high, xmax, w, w_err, save_idx, restart_times, sysd, lus(), signs,
                           buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, chunk)
            if status == L.NEED_PIVOTS:
                # a degraded pivot: new pivots for the matrix in a_data (SuperLU), then resume
                if lu.factor(a_data):
                    I[L.I_FACTORIZATIONS] += 1
                    F[L.F_LU_TAG] = F[L.F_PENDING_TAG]
                else:
                    I[L.I_PIVOTS_FAILED] = 1
                    F[L.F_PIVOT_TAG] = F[L.F_PENDING_TAG]
                    lu.factor(identity)
            elif status == L.BUFFER_FULL:
                cap *= 2
                buf_t = np.resize(buf_t, cap)
                buf_k = np.resize(buf_k, cap)
                buf_x = np.resize(buf_x, (cap, save_idx.size))
            elif status == L.CHUNK_DONE:
                spent = time.perf_counter() - tic
                chunk = int(min(max(chunk * PROGRESS_INTERVAL / max(spent, 1e-6), 16), 1 << 22))
            else:
                break
            now = time.perf_counter()
            if progress is not None and now - last >= PROGRESS_INTERVAL:
                progress(F[L.F_T], t_bound, int(I[L.I_STEPS]))
                last = now
    except KeyboardInterrupt as exc:  # keep what was computed
        interrupted = exc
    if progress is not None:
        progress(F[L.F_T], t_bound, int(I[L.I_STEPS]))

    m = int(I[L.I_M])
    t = buf_t[:m].copy()
    x = buf_x[:m].copy()
    k = buf_k[:m].copy()
    names = tuple(system.names[i] for i in save_idx)
    stats = {
        "steps": int(I[L.I_STEPS]), "rejected": int(I[L.I_REJECTED]), "newton_iterations": int(I[L.I_NEWTON]),
        "newton_failures": int(I[L.I_NEWTON_FAILURES]), "factorizations": int(I[L.I_FACTORIZATIONS]),
        "evaluations": int(I[L.I_EVALUATIONS]), "jacobian_evaluations": int(I[L.I_JAC_EVALUATIONS]),
        "cj_changes": int(I[L.I_CJ_CHANGES]), "restarts": int(I[L.I_RESTARTS]), "probes": int(I[L.I_PROBES]),
        "max_order_used": int(I[L.I_MAX_ORDER_USED]), "h_min": float(F[L.F_H_MIN]), "h_max": float(F[L.F_H_MAX]),
        "wall_time": time.perf_counter() - wall0, "engine": "compiled",
    }
    tolerances = {"rtol": rtol, "vntol": vntol, "abstol": abstol, "atol": atol_label, "norm": norm_name,
                  "relref": relref_name, "newton_tol": 0.33, "maxord": maxord, "index_excluded": excluded}
    failure = None
    if status == L.FINISHED:
        message = (f"reached t={t_bound:.9g} in {stats['steps']} steps ({stats['rejected']} rejected, "
                   f"{stats['newton_failures']} Newton failures, {stats['factorizations']} factorizations)")
        code = STATUS_OK
    elif status == L.FAILED:
        failure = _failure(system, F, I)
        message = (f"BDF failed: {failure['what']} at t={failure['t']:.9g}, h={failure['h']:.3g}"
                   + (f", worst unknown {failure['worst']}" if failure["worst"] else "")
                   + f" (hint: {failure['hint']})")
        code = STATUS_FAILED
    else:
        message = f"stopped at t={F[L.F_T]:.9g} before t_bound={t_bound:.9g}"
        code = STATUS_FAILED
    jumps = []
    for j in range(int(I[L.I_NJUMPS])):
        shown = jump_idx[j, : min(int(jump_count[j]), L.JUMP_NAMES)]
        jumps.append((float(jump_t[j]), tuple(system.names[i] for i in shown)))
    seg = segments[: int(I[L.I_NSEGMENTS])].copy()
    result = IntegrationResult(
        t=t, x=x, order=k, names=names, save=save_idx.copy(), dense=Interpolant(t, k, x, names, segments=seg),
        stats=stats, status=code, message=message, tolerances=tolerances, failure=failure,
        restarts=restart_times[: int(I[L.I_NRESTART_TIMES])].copy(), jumps=jumps,
    )
    if interrupted is not None:
        interrupted.partial = result
        raise interrupted
    if raise_on_failure and not result.ok:
        f = result.failure or {}
        raise ConvergenceError(f.get("what", result.message), t=f.get("t"), h=f.get("h"),
                               worst=f.get("worst"), hint=f.get("hint"))
    return result


def _failure(system, F, I) -> dict:
    """The failure record (what, t, h, worst, hint) from the engine's codes."""
    from ..bdf import BDF

    code = int(I[L.I_FAIL_CODE])
    outer, rest = divmod(code, 256) if code >= 256 else (0, code)
    kind, reason = divmod(rest, 16)
    info = "singular" if reason == L.REASON_SINGULAR else "nonfinite"
    what_kind = "Newton failures" if kind == 1 else "error-test failures"
    h = float(F[L.F_FAIL_H])
    if outer == L.FAIL_MIN_STEP:
        what = (f"step size {h:.3g} at min_step {F[L.F_MIN_STEP]:.3g} and the "
                + ("Newton iteration fails" if kind == 1 else "error test fails"))
        hint = BDF._newton_hint(info) if kind == 1 else BDF._error_hint()
    elif outer == L.FAIL_ROUNDOFF:
        what = f"step size below the roundoff of t ({what_kind})"
        hint = BDF._newton_hint(info) if kind == 1 else BDF._error_hint()
    elif outer == L.FAIL_MAX_STEPS:
        what = f"reached max_steps={int(I[L.I_MAX_STEPS])}"
        hint = "raise max_steps, or loosen the tolerances"
    elif code == L.FAIL_PROBE_SINGULAR:
        what = "the Newton matrix (alpha/h) dq/dx - dphi/dx is singular"
        hint = BDF._newton_hint("singular")
    elif code == L.FAIL_PROBE_NONFINITE:
        what = "the system evaluation right after t is not finite"
        hint = "the model is undefined at the initial/restart point"
    elif kind == 1:
        what = f"Newton iteration failed {L.MAX_NEWTON_FAILURES} times ({info})"
        hint = BDF._newton_hint(info)
    else:
        what = f"error test failed {L.MAX_ERROR_FAILURES} times"
        hint = BDF._error_hint()
    wi = int(I[L.I_FAIL_WORST])
    worst = system.names[wi] if 0 <= wi < system.n else None
    return {"t": float(F[L.F_FAIL_T]), "h": h, "worst": worst, "hint": hint, "what": what}
