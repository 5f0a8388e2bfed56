"""Python side of the compiled transient engine: pack, run in chunks, report.

:func:`integrate_compiled` takes the same arguments as
:func:`netdae.dae.bdf.integrate` and returns the same
:class:`~netdae.dae.bdf.IntegrationResult`, computed by the compiled step
loop of :mod:`netdae.dae.compiled.bdf_loop`. It serves an MNA system whose
parts all compile: the constant ``E``, ``H``, ``B``, the independent
sources' waveforms, and device families with a compiled kernel (diode, BJT,
MOSFET, JFET, switch, behavioural source, VDMOS: :mod:`netdae.devices.kernels`); for
anything else (a user DAE) it returns ``None`` and the caller uses the Python
integrator.

The loop returns to Python for what does not belong in it: new pivots when
a refactorisation meets a degraded pivot (SuperLU), and the right limit of
a nonlinear system whose inputs jump or whose switches change (the
steady-state solver, with its gmin and source stepping:
:func:`netdae.dae.bdf.right_limit`, with the loop's switch states held).

Python is entered once per output chunk: when the output buffers are full
(they double), and after a bounded number of steps (about
``PROGRESS_INTERVAL`` of wall time) so that a progress callback runs and
Ctrl-C is honoured. An interrupted run keeps what it computed: the
``KeyboardInterrupt`` propagates with the partial result attached as its
``partial`` attribute.

The accepted points can also leave the driver as they are computed: an
``output(start, t, x)`` callback receives, at every return to Python and once
when the run ends (finished, failed, interrupted or out of memory), the points
recorded since its previous call (``start`` the position of the first of them
in the run, ``t`` their times, ``x`` the saved unknowns, views valid during the
call). It is where a caller writes a long transient to a file while it runs;
the driver itself writes nothing. A callback that returns a text stops the run
there, the text being the reason (a full disk).
"""

from __future__ import annotations

import math
import sys
import time
import weakref

import numpy as np

from . import bdf_loop as L
from .control import NORM_MAX, NORM_RMS, RELREF_LOCAL, RELREF_MIXED, RELREF_SIGNAL, set_weights
from .lu import PIVOT_REL_THRESHOLD, SparseLU
from ..bdf.constants import BUFFER_START, BUFFER_START_BYTES, RIGHT_LIMIT_RETRIES
from ..bdf.failures import IntegrationFailure, with_runaway
from ..newton import NewtonInfo
from .sources import pack_sources

__all__ = ["integrate_compiled", "supports"]

#: Options the compiled engine implements (any other keyword sends the call to the Python integrator).
_SUPPORTED = frozenset({"rtol", "atol", "vntol", "abstol", "index", "maxord", "max_step", "min_step",
                        "first_step", "breakpoints", "save", "norm", "relref", "max_steps", "newton_maxiter",
                        "output", "window"})
# The output buffers (BUFFER_START, BUFFER_START_BYTES: netdae.dae.bdf's, the Python integrator's too) start
# with room for the points the step bound implies (and a quarter more), BUFFER_START at least (and at most
# when ``output`` takes the points in blocks), within BUFFER_START_BYTES (but room for WINDOW_MIN points): a
# run rarely returns to Python to grow them, and a circuit of many unknowns that records few points does not
# reserve room for a thousand.
#: Wall time between two returns to Python [s] (progress, Ctrl-C).
PROGRESS_INTERVAL = 0.1
#: Bytes of output a bounded run keeps in memory at most (``window``), and the fewest points.
WINDOW_BYTES = 32 * 2**20
WINDOW_MIN = 16
#: Steps of the first chunk (later chunks are sized from the measured rate).
FIRST_CHUNK = 64
#: Why a run ended when a device kernel met a zero denominator in complex arithmetic (the MESA and HFET
#: kernels take their derivatives by complex steps; numba's complex division raises ZeroDivisionError
#: whatever the error model, where real arithmetic gives a non-finite value the loop handles).
MODEL_DIVISION = "a device model divided by zero (its parameters or this bias put it outside the model's domain)"
MODEL_DIVISION_HINT = ("check the model cards of the circuit's MESFETs (MESA levels 2-4) and HFETs, whose "
                       "derivatives are taken in complex arithmetic, for values far outside their usual range")


#: Position of the switches in the loop's families (after diode, BJT, MOSFET, JFET).
SWITCH_SLOT = 4
#: Position of the behavioural sources in the loop's families (after diode, BJT, MOSFET, JFET, switch).
BEHAVIOURAL_SLOT = 5
#: Position of the OSDI devices in the loop's families (after the behavioural sources).
OSDI_SLOT = 6
#: Position of the VDMOS transistors in the loop's families (their arrays follow the OSDI devices' states).
VDMOS_SLOT = 7
#: Position of the MESA MESFETs in the loop's families (their arrays follow the VDMOS transistors').
MESA_SLOT = 8
#: Position of the HFET1 devices in the loop's families (last; their arrays end ``devd``).
HFET_SLOT = 9
#: Arrays of one family of the standard interface in ``devd``: ``(par, idx, vacc, vtry, vnew)``.
_FAMILY_ARRAYS = 5
#: Position in ``devd`` of the behavioural sources' locked outcomes (after the five families of the standard
#: interface, the switches' crossing times and the behavioural sources' prog, const, inst, leaf, val, der).
LOCK_ARRAY = 5 * _FAMILY_ARRAYS + 1 + 6


def _buffer_start(span: float, max_step: float, columns: int, most: int | None = None) -> int:
    """Points the output buffers start with (they double when full).

    Room for the fewest points the step bound implies, ``span / max_step``,
    a quarter more and 64 (a power of two), and for :data:`BUFFER_START`
    at least, at most ``most`` points; all within
    :data:`BUFFER_START_BYTES` bytes of rows of ``columns`` doubles, but at
    least :data:`WINDOW_MIN` points. The bytes decide for a circuit of many
    unknowns: its first allocation follows what it records, not a fixed
    count of rows it could not afford.

    Examples
    --------
    >>> _buffer_start(1e-3, 1e-5, 2)  # a small circuit, 100 steps at least
    1024
    >>> _buffer_start(1e-3, 1e-5, 400_000)  # 400,000 saved unknowns: the byte budget decides
    16
    """
    fewest = span / max_step if 0.0 < max_step < math.inf else 0.0
    want = BUFFER_START if fewest > 1e12 else max(BUFFER_START, 1 << math.ceil(math.log2(1.25 * fewest + 64)))
    if most is not None:
        want = min(want, most)
    return max(WINDOW_MIN, min(want, BUFFER_START_BYTES // (8 * (columns + 2))))


def _grow(buf_t: np.ndarray, buf_k: np.ndarray, buf_x: np.ndarray, cap: int) -> tuple[np.ndarray, ...]:
    """The output buffers with room for ``cap`` points (the old ones intact when it fails).

    Raises
    ------
    MemoryError
        When the memory for the larger buffers cannot be had.
    """
    return np.resize(buf_t, cap), np.resize(buf_k, cap), np.resize(buf_x, (cap, buf_x.shape[1]))


def _family_slot(family) -> int | None:
    """Position of a device family in the loop's ``devd`` (diode, BJT, MOSFET, JFET, switch, behavioural, OSDI,
    VDMOS, MESA, HFET), or None."""
    kind = type(family)
    if kind not in _SLOTS:
        _SLOTS[kind] = _slot_of(kind)
    return _SLOTS[kind]


#: :func:`_family_slot` by family class.
_SLOTS: dict = {}


def _slot_of(kind) -> int | None:
    """:func:`_family_slot` of a family class."""
    from ...devices.behavioral import BehaviouralFamily
    from ...devices.bjt import BjtFamily
    from ...devices.diode import DiodeFamily
    from ...devices.hfet import HfetFamily
    from ...devices.jfet import JfetFamily
    from ...devices.mesa import MesaFamily
    from ...devices.mosfet import MosfetFamily
    from ...devices.switch import SwitchFamily
    from ...devices.vdmos import VdmosFamily

    osdi = sys.modules.get("netdae.devices.osdi.family")  # imported only by circuits with N elements
    classes = (DiodeFamily, BjtFamily, MosfetFamily, JfetFamily, SwitchFamily, BehaviouralFamily,
               osdi.OsdiFamily if osdi is not None else None, VdmosFamily, MesaFamily,
               HfetFamily)
    for slot, cls in enumerate(classes):
        if kind is cls:
            return slot
    return None


def supports(system, options: dict) -> bool:
    """True when :func:`integrate_compiled` can run ``system`` with ``options``."""
    if set(options) - _SUPPORTED:
        return False
    families = getattr(system, "families", None)
    if families is None or not hasattr(system, "pattern"):
        return False
    slots = [_family_slot(f) for f in families]
    if None in slots or len(set(slots)) != len(slots):
        return False
    if getattr(system, "sources", None) is None or getattr(system, "B", None) is None:
        return False
    if getattr(system.sources, "mode", None) != "tran":
        return False
    if system.n == 0:
        return False
    return True


def integrate_compiled(system, t_span, x0, *, progress=None, raise_on_failure=False, **options):
    """Integrate an MNA system with the compiled engine (see the module docstring).

    Parameters
    ----------
    system, t_span, x0, progress, raise_on_failure
        As for :func:`netdae.dae.bdf.integrate`.
    **options
        As for :class:`netdae.dae.bdf.BDF` (the subset in ``_SUPPORTED``), and
        ``output``: ``output(start, t, x) -> str | None``, called with the
        accepted points recorded since its previous call (``start``: the
        position of ``t[0]`` among all points; ``t`` shape (m,), ``x`` shape
        (m, len(save)): views of the output buffers, valid during the call) at
        every return of the loop to Python and once when the run ends however
        it ends; a text returned stops the run with that reason. And
        ``window``: with ``output``, ``True`` keeps only the last points in
        memory (at most :data:`WINDOW_BYTES` of them, at least
        :data:`WINDOW_MIN`): the result then holds those (its dense output
        covers them), ``output`` has had them all. Ignored for a system with
        transmission lines (the loop reads their recorded waves).

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
        BDF,
        BREAKPOINT_MERGE,
        MAX_ORDER,
        NEWTON_MAXITER,
        IntegrationResult,
        absolute_tolerances,
        breakpoint_times,
        charge_columns,
        charge_rows,
        check_arguments,
        current_rows,
        time_charge_rows,
        index_mask,
        right_limit,
        rounding_signs,
        row_tolerances,
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
    newton_maxiter = int(options.get("newton_maxiter", NEWTON_MAXITER))
    if newton_maxiter < 1:
        raise ValueError("newton_maxiter must be at least 1")
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
    bps = merge_breakpoints(t0, t_bound, breakpoint_times(system, t0, t_bound, options.get("breakpoints")),
                            BREAKPOINT_MERGE * (t_bound - t0))

    pattern = system.pattern
    linear = not system.families
    indptr, indices, e_data, h_data, b_rows, b_cols, b_vals = pack_matrices(system)
    skind, spar, spwl_t, spwl_v, spwl_n = pack_sources(system.sources)
    switching = getattr(system, "switching", None)
    locks = None  # the Python side of the behavioural sources' held comparisons, made when a right limit needs it
    devd = _pack_families(system, x0, switching, bypass=(rtol, vntol, abstol))

    F = np.zeros(L.N_F)
    I = np.zeros(L.N_I, dtype=np.int64)
    F[L.F_IMPASSE_T] = np.nan  # no impasse yet (t0 included)
    F[L.F_T] = t0
    F[L.F_RTOL] = rtol
    F[L.F_MAX_STEP] = max_step
    F[L.F_MIN_STEP] = min_step
    F[L.F_H_MIN] = math.inf
    F[L.F_LU_TAG] = math.nan
    F[L.F_LAST_CJ_ATTEMPT] = math.nan
    F[L.F_RATE] = L.RATE_AFTER_SETUP
    I[L.I_MAXORD] = maxord
    I[L.I_NORM] = norm
    I[L.I_RELREF] = relref
    I[L.I_MAX_STEPS] = 0 if max_steps is None else int(max_steps)
    I[L.I_NEWTON_MAXITER] = newton_maxiter
    I[L.I_LINEAR] = 1 if linear else 0
    I[L.I_K] = 1
    I[L.I_EVALUATIONS] = 1       # the evaluation at t0 (as the Python integrator counts it)
    I[L.I_JAC_EVALUATIONS] = 1 if linear else 0
    # the history: the unknowns, then the charges of the rows where a device family stores charge
    crows, qcol = charge_columns(system, linear)
    P = np.zeros((maxord + 1, n + crows.size))
    P[0, :n] = x0
    if not linear:
        ev0 = system.evaluate(x0, t0, jacobian=False, state=None)
        if not ev0.ok or not np.all(np.isfinite(ev0.q)) or not np.all(np.isfinite(ev0.phi)):
            raise ValueError(f"the system evaluation at t0={t0:g} is not finite (check x0)")
        P[0, n:] = ev0.q[crows]
    psi = np.zeros(MAX_ORDER + 1)
    coef = [np.zeros(MAX_ORDER + 1) for _ in range(5)]
    # the largest magnitudes so far: of the unknowns, then of the charges (charge_newton_weights)
    xmax = np.concatenate([np.abs(x0), np.abs(P[0, n:])])
    x_start = np.array(x0, dtype=float)
    w = np.empty(n)
    w_err = np.empty(n)
    set_weights(x0, rtol, atol, relref, xmax, mask, w, w_err)
    a_data = np.zeros(e_data.size)
    sysd = (indptr, indices, e_data, h_data, a_data, b_rows, b_cols, b_vals, skind, spar, spwl_t, spwl_v, spwl_n)
    delays = pack_delays(system)
    ns = save_idx.size
    signs = rounding_signs(n)  # of the rounding floor's second right-hand side (as BDF's)
    # rows whose charge error joins the error test (coupled to index-2 unknowns): their charge columns
    qrows = charge_rows(indptr, indices, high, qcol)
    # rows whose charge reads time itself: their charge errors are tested, the probe takes dq/dt at fixed x
    trows = time_charge_rows(system, qcol)
    I[L.I_CHARGE_TIME] = 1 if (trows >= 0).any() else 0
    tol = (atol, mask, high, xmax, w, w_err, signs, qrows, crows, qcol, trows, current_rows(system, mask, crows))
    nnz = e_data.size
    evb = (np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1), np.zeros(nnz + 1), np.zeros(nnz + 1),
           np.abs(e_data))
    rl_given = np.zeros(n)
    # u, xp, xpp, xr, x2, wf, b1, b2, work, qpb, rl_given
    ws = (np.zeros(skind.size), *(np.zeros(n) for _ in range(9)), rl_given)
    # ee, pred0, pred1 (the history's width), r, d, xn, w_newton, w_se, xs (n), wq (the charge columns), vw (n),
    # then the rows' absolute tolerances of the corrector's check and dphi/dx of the factorisation's Jacobian
    wk = (*(np.zeros(P.shape[1]) for _ in range(3)), *(np.zeros(n) for _ in range(6)), np.zeros(crows.size),
          np.zeros(n), row_tolerances(system.kinds, atol, vntol, abstol), np.zeros(e_data.size + 1))
    # the first pivot order: of the first probe's matrix dq/dx / eps - dphi/dx (any degraded
    # pivot later sends the loop back here for a new one)
    F[L.F_PIVOT_THRESHOLD] = PIVOT_REL_THRESHOLD
    lu = SparseLU(pattern, threshold=PIVOT_REL_THRESHOLD)
    identity = np.where(pattern.rows == pattern.cols, 1.0, 0.0)
    eps0 = L.PROBE_FRACTION * min(L.H0_FRACTION * (bps[0] - t0), max_step)
    if linear:
        first = e_data / eps0 - h_data
    else:
        ev = system.evaluate(x0, t0 + eps0, jacobian=True, state=None)
        first = ev.dq / eps0 - ev.dphi
    if not (np.all(np.isfinite(first)) and lu.factor(first)):
        # a singular matrix shows again in the loop, which reports it; a plan in the
        # identity order keeps the loop's arguments defined until then
        lu.factor(identity)
    swork = np.zeros(n)
    restart_times = np.zeros(bps.size + 4)
    jump_t = np.zeros(bps.size + 4)
    jump_count = np.zeros(bps.size + 4, dtype=np.int64)
    jump_idx = np.zeros((bps.size + 4, L.JUMP_NAMES), dtype=np.int64)
    segments = np.zeros(2 * bps.size + 8, dtype=np.int64)
    event_t = np.zeros(8)
    event_count = np.zeros(8, dtype=np.int64)
    event_idx = np.zeros((8, L.JUMP_NAMES), dtype=np.int64)
    I[L.I_NSEGMENTS] = 1  # segments[0] = 0: the start

    def lus():
        plan = lu.plan
        return (*plan.refactor_args(), plan.perm_r, plan.perm_c, lu._l, lu._u, lu._x, swork)

    window = bool(options.get("window")) and options.get("output") is not None and delays[0].size == 0
    if window:
        cap = max(WINDOW_MIN, min(BUFFER_START, WINDOW_BYTES // (8 * (ns + 2))))
    else:  # with output: blocks of at most BUFFER_START points to write as they come
        most = BUFFER_START if options.get("output") is not None else None
        cap = _buffer_start(t_bound - t0, max_step, ns + delays[0].size, most)
    buf_t = np.empty(cap)
    buf_k = np.zeros(cap, dtype=np.int8)
    buf_x = np.empty((cap, ns + delays[0].size))  # the saved unknowns, then the lines' waves
    fs = float(first_step) if first_step is not None else 0.0

    # a first call of no steps when the loop is not yet loaded in this process: it loads the
    # machine code from numba's cache (or compiles it). Everything until it returns (numba's
    # initialisation at the first compiled call above, the packing, the first pivot order, the
    # load) is timed apart from the integration as load_time
    fresh = not _LOADED and not getattr(L.run, "signatures", True)  # (a wrapped loop: no load to time)
    chunk = 0 if fresh else FIRST_CHUNK
    load_time = 0.0
    last = time.perf_counter()
    status = L.RUNNING
    interrupted = None
    failure = None
    out_of_memory = None  # bytes the output buffers could not grow to
    output = options.get("output")
    sent = 0  # points of the buffers handed to output so far
    dropped = 0  # points a bounded run (window) no longer holds, before the buffers' first
    stopped_by_output = None  # the reason output gave to stop

    def send() -> str | None:
        """Hand the points recorded since the last call to ``output``."""
        nonlocal sent
        m_now = int(I[L.I_M])
        if output is None or m_now == sent:
            return None
        reason = output(dropped + sent, buf_t[sent:m_now], buf_x[sent:m_now, :ns])
        sent = m_now
        return reason

    def slide() -> None:
        """A bounded run's full buffers: the points handed over leave them, but the last one."""
        nonlocal sent, dropped
        m_now = int(I[L.I_M])
        d = m_now - 1
        buf_t[0], buf_k[0], buf_x[0] = buf_t[d], buf_k[d], buf_x[d]
        kept = [0] + [int(j) - d for j in segments[: int(I[L.I_NSEGMENTS])] if j > d]
        segments[: len(kept)] = kept
        I[L.I_NSEGMENTS] = len(kept)
        I[L.I_M] = 1
        sent -= d
        dropped += d
    impasses: list[float] = []  # where Newton failed on every step size and the solution jumped
    pivoted_tag = None  # (tag, steps): the matrix new pivots were chosen for on the last return
    stalled, stalled_at = 0, -1  # returns for pivots or right limits since the step count last moved
    try:
        while True:
            tic = time.perf_counter()
            rec = (save_idx, buf_t, buf_k, buf_x, jump_t, jump_count, jump_idx, segments, restart_times,
                   event_t, event_count, event_idx, *delays[4:])
            sysd_c = (*sysd, delay_args(delays, I, buf_t, buf_k, buf_x, segments, ns))
            try:
                status = L.run(F, I, P, psi, coef[0], coef[1], coef[2], coef[3], coef[4], bps, fs, tol, sysd_c,
                               devd, lus(), evb, ws, wk, rec, chunk)
            except ZeroDivisionError:  # the points accepted so far are kept
                failure = IntegrationFailure(float(F[L.F_T]), float(F[L.F_H]), MODEL_DIVISION, None,
                                             MODEL_DIVISION_HINT)
                I[L.I_STATUS] = L.FAILED
                status = L.FAILED
                break
            if not _LOADED:
                _loaded()
            if fresh:
                fresh = False
                load_time = time.perf_counter() - wall0
                chunk = FIRST_CHUNK
                if status == L.CHUNK_DONE:
                    continue
            if status in (L.NEED_PIVOTS, L.NEED_RIGHT_LIMIT) and int(I[L.I_STEPS]) == stalled_at:
                stalled += 1
                if stalled > MAX_RETURNS_WITHOUT_STEP:
                    # new pivots or right limits asked for again and again without a step: stop, do not hang
                    failure = IntegrationFailure(
                        float(F[L.F_T]), float(F[L.F_H]),
                        f"no step after {stalled} returns for new pivots or a right limit (the restart's matrices "
                        "lose their pivots again at once, or its right limit does not settle)",
                        None, "loosen the tolerances or give the circuit's fastest nodes some capacitance")
                    I[L.I_STATUS] = L.FAILED
                    status = L.FAILED
                    break
            else:
                stalled, stalled_at = 0, int(I[L.I_STEPS])
            repivoted, pivoted_tag = pivoted_tag, None
            if status == L.NEED_PIVOTS:
                # a degraded pivot: new pivots for the matrix in a_data (SuperLU), then resume; the same
                # matrix degraded again right after its new pivots is near-singular: judged singular (the
                # attempt then fails and the step is cut), never asked for again and again
                pivoted_tag = (float(F[L.F_PENDING_TAG]), int(I[L.I_STEPS]))
                if repivoted == pivoted_tag:  # the same matrix, no step in between
                    I[L.I_PIVOTS_FAILED] = 1
                    F[L.F_PIVOT_TAG] = F[L.F_PENDING_TAG]
                    lu.factor(identity)
                elif lu.factor(a_data):
                    I[L.I_FACTORIZATIONS] += 1
                    F[L.F_LU_TAG] = F[L.F_PENDING_TAG]
                else:
                    I[L.I_PIVOTS_FAILED] = 1
                    F[L.F_PIVOT_TAG] = F[L.F_PENDING_TAG]
                    lu.factor(identity)
            elif status == L.NEED_RIGHT_LIMIT:
                # the inputs of a nonlinear system jump (or its switches changed): x(t+) by converged
                # implicit-Euler steps, the switches held in the loop's states
                eps = float(F[L.F_RL_EPS])
                if switching is not None:
                    switching.hold(devd[SWITCH_SLOT * 5 + 2])
                if devd[LOCK_ARRAY].shape[1] > 1:  # the behavioural sources' comparisons as the loop holds them
                    locks = system.behavioural_events
                    locks.hold(devd[LOCK_ARRAY])
                if delays[0].size:
                    system.delay_history = _history(buf_t, buf_k, buf_x, segments, I, ns)
                try:
                    x_right, its, evals, what = right_limit(system, float(F[L.F_T]), P[0, :n].copy(), eps, high,
                                                            rtol, vntol, abstol, impasse=I[L.I_IMPASSE] != 0,
                                                            retries=RIGHT_LIMIT_RETRIES,
                                                            timed=I[L.I_CHARGE_TIME] != 0)
                finally:
                    if delays[0].size:
                        system.delay_history = None
                I[L.I_NEWTON] += its
                I[L.I_EVALUATIONS] += evals
                if x_right is None:
                    if I[L.I_IMPASSE] != 0:  # no jump found either: the Newton failure stands
                        failure = _failure(system, F, I, atol)
                    else:
                        failure = IntegrationFailure(float(F[L.F_T]), eps, what, None, BDF._newton_hint(None))
                    I[L.I_STATUS] = L.FAILED
                    status = L.FAILED
                    break
                if I[L.I_IMPASSE] != 0:
                    impasses.append(float(F[L.F_T]))
                rl_given[:] = x_right
                I[L.I_RL_READY] = 1
            elif status == L.BUFFER_FULL:
                if window and I[L.I_M] + 1 >= cap:
                    stopped_by_output = send()
                    if stopped_by_output is not None:
                        break
                    slide()
                elif I[L.I_M] + 1 >= cap:
                    try:
                        grown = _grow(buf_t, buf_k, buf_x, 2 * cap)
                    except MemoryError:  # keep what was computed; say how to need less
                        out_of_memory = (2 * cap) * (save_idx.size + 2) * 8
                        break
                    cap *= 2
                    buf_t, buf_k, buf_x = grown
                if I[L.I_NJUMPS] + 1 >= jump_t.size:
                    jump_t = np.resize(jump_t, 2 * jump_t.size)
                    jump_count = np.resize(jump_count, jump_t.size)
                    jump_idx = np.resize(jump_idx, (jump_t.size, L.JUMP_NAMES))
                if I[L.I_NRESTART_TIMES] + 2 >= restart_times.size:
                    restart_times = np.resize(restart_times, 2 * restart_times.size)
                if I[L.I_NSEGMENTS] + 3 >= segments.size:
                    segments = np.resize(segments, 2 * segments.size)
                if I[L.I_NEVENTS] + 1 >= event_t.size:
                    event_t = np.resize(event_t, 2 * event_t.size)
                    event_count = np.resize(event_count, event_t.size)
                    event_idx = np.resize(event_idx, (event_t.size, L.JUMP_NAMES))
            elif status == L.CHUNK_DONE:
                spent = time.perf_counter() - tic
                chunk = int(min(max(chunk * PROGRESS_INTERVAL / max(spent, 1e-6), 16), 1 << 22))
            else:
                break
            stopped_by_output = send()
            if stopped_by_output is not None:
                break
            now = time.perf_counter()
            if progress is not None and now - last >= PROGRESS_INTERVAL:
                progress(F[L.F_T], t_bound, int(I[L.I_STEPS]))
                last = now
        if progress is not None:
            progress(F[L.F_T], t_bound, int(I[L.I_STEPS]))
    except KeyboardInterrupt as exc:  # keep what was computed
        interrupted = exc
    finally:
        if switching is not None:
            switching.release()
        if locks is not None:
            locks.release()
    if stopped_by_output is None:
        try:
            stopped_by_output = send()  # the rest (a run that ended, failed or was interrupted in a chunk)
        except KeyboardInterrupt as exc:
            interrupted = interrupted or exc

    m = int(I[L.I_M])
    if out_of_memory is None:
        t, x, k = buf_t[:m].copy(), buf_x[:m, :ns].copy(), buf_k[:m].copy()
    else:  # no second copy of what fills the memory
        t, x, k = buf_t[:m], buf_x[:m, :ns], buf_k[:m]
    names = tuple(system.names[i] for i in save_idx)
    stats = {
        "steps": int(I[L.I_STEPS]), "rejected": int(I[L.I_REJECTED]), "newton_iterations": int(I[L.I_NEWTON]),
        "newton_failures": int(I[L.I_NEWTON_FAILURES]), "factorizations": int(I[L.I_FACTORIZATIONS]),
        "evaluations": int(I[L.I_EVALUATIONS]), "jacobian_evaluations": int(I[L.I_JAC_EVALUATIONS]),
        "cj_changes": int(I[L.I_CJ_CHANGES]), "restarts": int(I[L.I_RESTARTS]), "probes": int(I[L.I_PROBES]),
        "max_order_used": int(I[L.I_MAX_ORDER_USED]), "h_min": float(F[L.F_H_MIN]), "h_max": float(F[L.F_H_MAX]),
        "events": int(I[L.I_EVENTS]), "impasses": len(impasses),
        "wall_time": time.perf_counter() - wall0, "load_time": load_time, "engine": "compiled",
    }
    tolerances = {"rtol": rtol, "vntol": vntol, "abstol": abstol, "atol": atol_label, "norm": norm_name,
                  "relref": relref_name, "newton_tol": 0.33, "maxord": maxord, "index_excluded": excluded}
    if status == L.FINISHED and I[L.I_OSDI_END] != 0:
        message = _osdi_end_message(system, F, I, stats)
        code = STATUS_OK
    elif status == L.FINISHED:
        message = (f"reached t={t_bound:.9g} in {stats['steps']} steps ({stats['rejected']} rejected, "
                   f"{stats['newton_failures']} Newton failures, {stats['factorizations']} factorizations)")
        code = STATUS_OK
    elif status == L.FAILED:
        if failure is None:
            failure = _failure(system, F, I, atol)
        failure = with_runaway(failure, system.names, system.kinds, x_start, P[0, :n], int(I[L.I_MAX_ORDER_USED]))
        message = failure.message
        code = STATUS_FAILED
    elif out_of_memory is not None:
        message = (f"stopped at t={F[L.F_T]:.9g} before t_bound={t_bound:.9g}: not enough memory to keep more "
                   f"output ({m:,} points of {save_idx.size:,} unknowns kept; the next buffer needs "
                   f"{out_of_memory / 2**20:,.0f} MiB) (hint: save fewer signals (--save, .save) or simulate a "
                   "shorter interval)")
        code = STATUS_FAILED
    elif stopped_by_output is not None:
        message = f"stopped at t={F[L.F_T]:.9g} before t_bound={t_bound:.9g}: {stopped_by_output}"
        code = STATUS_FAILED
    else:
        message = f"stopped at t={F[L.F_T]:.9g} before t_bound={t_bound:.9g}"
        code = STATUS_FAILED
    jumps = []
    for j in range(int(I[L.I_NJUMPS])):
        shown = jump_idx[j, : min(int(jump_count[j]), L.JUMP_NAMES)]
        jumps.append((float(jump_t[j]), tuple(system.names[i] for i in shown)))
    events = []
    if int(I[L.I_NEVENTS]):
        event_names = _event_elements(system)
        for j in range(int(I[L.I_NEVENTS])):
            shown = event_idx[j, : min(int(event_count[j]), L.JUMP_NAMES)]
            events.append((float(event_t[j]), tuple(event_names[i] for i in shown)))
    seg = segments[: int(I[L.I_NSEGMENTS])].copy()
    result = IntegrationResult(
        t=t, x=x, order=k, names=names, save=save_idx.copy(), dense=Interpolant(t, k, x, names, segments=seg),
        stats=stats, status=code, message=message, tolerances=tolerances, failure=failure,
        restarts=restart_times[: int(I[L.I_NRESTART_TIMES])].copy(), jumps=jumps, events=events,
    )
    if interrupted is not None:
        interrupted.partial = result
        raise interrupted
    if raise_on_failure and not result.ok:
        if result.failure is None:
            raise ConvergenceError(result.message)
        raise result.failure.error()
    return result


#: The loop's REASON_* codes as netdae.dae.newton's INFO_* names (the Python integrator's words).
_REASONS = {L.REASON_SINGULAR: NewtonInfo.SINGULAR, L.REASON_NONFINITE: NewtonInfo.NONFINITE,
            L.REASON_DIVERGED: NewtonInfo.DIVERGED, L.REASON_MAXITER: NewtonInfo.MAXITER,
            L.REASON_EVALUATION: NewtonInfo.EVALUATION}


def pack_matrices(system) -> tuple:
    """The loop's matrices of an MNA system: ``(indptr, indices, e_data, h_data, b_rows, b_cols, b_vals)``.

    ``E`` and ``H`` as values on the system's fixed CSC pattern, ``B`` as
    coordinates (the inputs' columns). Packed once per system (:func:`_packed`)
    and shared by its operating point and its transient: the loops only read them.
    """
    return _packed(system).matrices


class _Packed:
    """What the compiled loops read of a system and never change: its matrices and its families'
    compiled arrays (:meth:`DeviceFamily.compiled`, in slot order), made at the first need."""

    __slots__ = ("matrices", "families", "__weakref__")

    def __init__(self, system):
        from ...devices.base import SlotMap

        pattern = system.pattern
        e = getattr(system, "_dq_lin", None)  # an MnaSystem keeps E and H on its pattern already
        h = getattr(system, "_dphi_lin", None)
        B = system.B
        if B.format == "csc":  # its entries in storage order, as tocoo() gives them
            b_rows = B.indices.astype(np.int64)
            b_cols = np.repeat(np.arange(B.shape[1], dtype=np.int64), np.diff(B.indptr))
            b_vals = B.data.astype(float)
        else:
            B = B.tocoo()
            b_rows, b_cols, b_vals = B.row.astype(np.int64), B.col.astype(np.int64), B.data.astype(float)
        self.matrices = (np.asarray(pattern.indptr, dtype=np.int64), np.asarray(pattern.indices, dtype=np.int64),
                         np.array(pattern.data_of(system.E) if e is None else e, dtype=float),
                         np.array(pattern.data_of(system.H) if h is None else h, dtype=float),
                         b_rows, b_cols, b_vals)
        self.families = []
        if system.families:
            slots = None
            for f in system.families:
                compiled = _COMPILED.get(f) if f.shareable else None
                if compiled is None:
                    slots = SlotMap(pattern) if slots is None else slots
                    compiled = f.compiled(slots, system.n)
                    if f.shareable:  # the systems sharing it share its pattern (netdae.mna.assemble.reassemble)
                        _COMPILED[f] = compiled
                self.families.append((_family_slot(f), f, compiled))


#: The compiled arrays of each shareable family (:attr:`DeviceFamily.shareable`), for every system sharing it.
_COMPILED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


#: The loop has run in this process (its machine code is loaded: no first call of no steps).
_LOADED = False


def _loaded() -> None:
    """Remember that the loop is loaded (asking numba for its signatures costs about 0.3 ms a run)."""
    global _LOADED
    _LOADED = True


#: Each system's :class:`_Packed` (kept while the system lives).
_PACKED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _packed(system) -> _Packed:
    """The system's :class:`_Packed`, made at the first call."""
    try:
        packed = _PACKED.get(system)
    except TypeError:  # not weakly referenceable: pack every time
        return _Packed(system)
    if packed is None:
        packed = _PACKED[system] = _Packed(system)
    return packed


def pack_delays(system) -> tuple:
    """The transmission lines' arrays: ``(rows, tau, w0, t0, w_ptr, w_idx, w_val)``.

    The delayed rows, their delays, the waves before the start ``t0``
    (:meth:`~netdae.mna.system.MnaSystem.start_delays`) and the rows of ``D``
    as CSR (what the loop records as the waves). Empty arrays without lines.
    """
    d = getattr(system, "delays", None)
    if d is None:
        return (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0), 0.0, np.zeros(1, dtype=np.int64),
                np.zeros(0, dtype=np.int64), np.zeros(0))
    rows = d.W
    w0 = system.delay_start if system.delay_start is not None else np.zeros(d.rows.size)
    return (d.rows.astype(np.int64), np.asarray(d.tau, dtype=float), np.asarray(w0, dtype=float),
            float(system._delay_t0), rows.indptr.astype(np.int64), rows.indices.astype(np.int64),
            rows.data.astype(float))


def delay_args(delays: tuple, I, buf_t, buf_k, buf_x, segments, col0: int) -> tuple:
    """The loop's ``dl`` (the last member of ``sysd``): the lines' arrays and the buffers their
    waves are recorded in (columns from ``col0``), which change when the buffers grow."""
    rows, tau, w0, t0 = delays[:4]
    return (rows, tau, w0, float(t0), I, buf_t, buf_k, buf_x, segments, int(col0))


def no_delays(I) -> tuple:
    """A ``dl`` without lines (the operating-point Newton's)."""
    return delay_args(pack_delays(None), I, np.zeros(1), np.zeros(1, dtype=np.int8), np.zeros((1, 1)),
                      np.zeros(1, dtype=np.int64), 0)


def _history(buf_t, buf_k, buf_x, segments, I, col0: int):
    """``history(tq)`` of the recorded waves so far, for the Python right limit (the loop's rule).

    A time past the last recorded point gets the last recorded wave: the right limit at an
    impasse takes implicit-Euler steps ten times longer at each try, and they can outgrow a
    line's delay (``t + 2 eps - tau`` past ``t``, where nothing is recorded yet). The delayed
    input is then held at its latest value for the right limit, as the limit ``eps -> 0``
    reads it near ``t - tau``; the step loop's own steps never exceed the shortest delay.
    """
    from ..dense import Interpolant

    m = int(I[L.I_M])
    nw = buf_x.shape[1] - col0
    ip = Interpolant(buf_t[:m].copy(), buf_k[:m].astype(np.int64), buf_x[:m, col0:].copy(),
                     [f"w{r}" for r in range(nw)], segments=segments[: int(I[L.I_NSEGMENTS])].copy())
    t_last = float(buf_t[m - 1])

    def history(tq):
        return np.diagonal(ip(np.minimum(np.asarray(tq, dtype=float), t_last))).copy()

    return history


def limiting_states(devd: tuple) -> tuple[int, ...]:
    """Positions in :func:`_pack_families`'s ``devd`` of the limiting states (``vacc``, ``vtry``,
    ``vnew`` of the diodes, BJTs, MOSFETs, JFETs and switches, of the OSDI devices, and of the VDMOS
    transistors, the MESA MESFETs and the HFETs, which end it): what a new solve from the initial state must
    copy rather than share."""
    end = len(devd) - 3 * _FAMILY_ARRAYS
    return (*(_FAMILY_ARRAYS * slot + k for slot in range(SWITCH_SLOT + 1) for k in (2, 3, 4)),
            *range(end - 3, end), *(end + k for k in (2, 3, 4)),
            *(end + _FAMILY_ARRAYS + k for k in (2, 3, 4)),
            *(end + 2 * _FAMILY_ARRAYS + k for k in (2, 3, 4)))


def _pack_families(system, x0, switching, bypass=None) -> tuple:
    """The loop's ``devd``: ``(par, idx, vacc, vtry, vnew)`` for diodes, BJTs, MOSFETs, JFETs and switches,
    the switches' crossing times (work), then the behavioural sources' ``(prog, const, inst, leaf,
    val, der, lock, xw)`` (``lock`` copied, its outcomes not held; ``xw`` work of length n + 1), then
    the OSDI devices' arrays (:meth:`~netdae.devices.osdi.family.OsdiFamily.compiled`) and limiting states, then ``(par, idx, vacc, vtry, vnew)`` of the VDMOS transistors, of the MESA
    MESFETs and of the HFETs.

    An absent family gets empty arrays (its kernel is then skipped). The switches start held in
    the operating point's states at ``x0`` (:meth:`~netdae.devices.switch.SwitchEvents.start`).
    ``bypass``: the analysis' ``(reltol, vntol, abstol)`` for the OSDI devices' bypass, None: no
    bypass (:func:`netdae.devices.osdi.family.set_bypass`).
    """
    from ...devices.kernels import behavioural as kbh
    from ...devices.kernels import bjt as kb
    from ...devices.kernels import diode as kd
    from ...devices.kernels import hfet as kf
    from ...devices.kernels import jfet as kj
    from ...devices.kernels import mesa as kz
    from ...devices.kernels import mosfet as km
    from ...devices.kernels import osdi as ko
    from ...devices.kernels import switch as ksw
    from ...devices.kernels import vdmos as kv

    shapes = ((kd.N_PAR, kd.N_IDX, kd.N_STATE), (kb.N_PAR, kb.N_IDX, kb.N_STATE), (km.N_PAR, km.N_IDX, km.N_STATE),
              (kj.N_PAR, kj.N_IDX, kj.N_STATE), (ksw.N_PAR, ksw.N_IDX, ksw.N_STATE))
    packed = [(np.zeros((0, p)), np.zeros((0, i), dtype=np.int64), np.zeros((0, v))) for p, i, v in shapes]
    vdmos = (np.zeros((0, kv.N_PAR)), np.zeros((0, kv.N_IDX), dtype=np.int64), np.zeros((0, kv.N_STATE)))
    mesa = (np.zeros((0, kz.N_PAR)), np.zeros((0, kz.N_IDX), dtype=np.int64), np.zeros((0, kz.N_STATE)))
    hfet = (np.zeros((0, kf.N_PAR)), np.zeros((0, kf.N_IDX), dtype=np.int64), np.zeros((0, kf.N_STATE)))
    behavioural = (np.zeros((0, 4), dtype=np.int64), np.zeros(0), np.zeros((0, kbh.N_INST), dtype=np.int64),
                   np.zeros((0, kbh.N_LEAF), dtype=np.int64), np.zeros(1), np.zeros((1, 1)),
                   np.zeros((kbh.N_LOCK_ROWS, 1)))
    info = np.zeros(ko.INFO_WORDS, dtype=np.int64)
    osdi = (np.zeros((0, ko.N_INST), dtype=np.int64), np.zeros((0, ko.N_FNS), dtype=np.int64),
            np.zeros(0, dtype=np.int64), info, info.view(np.float64), np.zeros(1), np.zeros(1), np.zeros(1),
            np.zeros(0), np.zeros(0))
    osdi_states = 1
    if system.families:
        for slot, family, compiled in _packed(system).families:
            if slot == BEHAVIOURAL_SLOT:
                behavioural = compiled
                continue
            if slot == OSDI_SLOT:
                osdi = compiled
                osdi_states = max(1, family.nstates)
                if not family.bypass_allowed:  # .options bypass=0
                    bypass = None
                continue
            par, idx, vold0 = compiled
            if slot == SWITCH_SLOT:
                vold0 = switching.start(x0)
            arrays = (np.ascontiguousarray(par, dtype=float), np.ascontiguousarray(idx, dtype=np.int64),
                      np.ascontiguousarray(vold0, dtype=float))
            if slot == VDMOS_SLOT:
                vdmos = arrays
            elif slot == MESA_SLOT:
                mesa = arrays
            elif slot == HFET_SLOT:
                hfet = arrays
            else:
                packed[slot] = arrays
    out = []
    for par, idx, vold0 in packed:
        out += [par, idx, vold0.copy(), vold0.copy(), vold0.copy()]
    out.append(np.zeros(packed[SWITCH_SLOT][0].shape[0]))
    # the OSDI modules' limiting states (accepted, trial, new): none before the first accepted step
    par, idx, vold0 = vdmos
    zpar, zidx, zvold0 = mesa
    fpar, fidx, fvold0 = hfet
    # the locked outcomes: a fresh copy per analysis, not held (a transient's loop holds them at its start),
    # and the work vector of their event location
    behavioural = (*behavioural[:6], behavioural[6].copy(), np.zeros(system.n + 1))
    # no $bound_step or $finish / $stop from an earlier analysis on the family's shared words
    osdi[4][ko.W_BOUND] = 0.0
    osdi[3][ko.W_STOP] = 0
    if osdi[0].shape[0]:
        from ...devices.osdi.family import set_bypass

        set_bypass(osdi, bypass)
    return (tuple(out) + tuple(behavioural) + tuple(osdi)
            + tuple(np.zeros(osdi_states) for _ in range(3))
            + (par, idx, vold0.copy(), vold0.copy(), vold0.copy())
            + (zpar, zidx, zvold0.copy(), zvold0.copy(), zvold0.copy())
            + (fpar, fidx, fvold0.copy(), fvold0.copy(), fvold0.copy()))


def _osdi_end_message(system, F, I, stats) -> str:
    """The message of a run an OSDI module ended (``$finish`` or ``$stop`` at an accepted point)."""
    from ...devices.osdi.family import OsdiFamily, end_message

    family = next(f for f in system.families if isinstance(f, OsdiFamily))
    ended = end_message(int(I[L.I_OSDI_END]), family.elements[int(I[L.I_OSDI_END_INST])].name)
    return f"stopped at t={float(F[L.F_T]):.9g}: {ended}, after {stats['steps']} steps"


def _event_elements(system) -> list[str]:
    """Names of what the loop's events number: the switches, then the behavioural sources."""
    from ...devices.behavioral import BehaviouralFamily

    names = [el.name for el in system.switching.family.elements] if system.switching is not None else []
    for family in system.families:
        if type(family) is BehaviouralFamily:
            names += [el.name for el in family.elements]
    return names


#: Returns to Python for new pivots or a right limit without a step in between before the run stops.
MAX_RETURNS_WITHOUT_STEP = 50


def _failure(system, F, I, atol) -> IntegrationFailure:
    """The failure record (what, t, h, worst, hint) from the engine's codes (``atol``: the unknowns'
    absolute tolerances, for the hint of an error-test failure)."""
    from ..bdf import BDF

    wi = int(I[L.I_FAIL_WORST])
    worst_atol = float(atol[wi]) if 0 <= wi < atol.size else None
    code = int(I[L.I_FAIL_CODE])
    outer, rest = divmod(code, 256) if code >= 256 else (0, code)
    kind, reason = divmod(rest, 16)
    info = _REASONS.get(reason, NewtonInfo.NONFINITE)
    what_kind = "Newton failures" if kind == 1 else "error-test failures"
    h = float(F[L.F_FAIL_H])
    if outer == L.FAIL_MIN_STEP:
        what = (f"step size {h:.3g} at min_step {F[L.F_MIN_STEP]:.3g} and the "
                + ("Newton iteration fails" if kind == 1 else "error test fails"))
        hint = BDF._newton_hint(info) if kind == 1 else BDF._error_hint(worst_atol)
    elif outer == L.FAIL_ROUNDOFF:
        what = f"step size below the roundoff of t ({what_kind})"
        hint = BDF._newton_hint(info) if kind == 1 else BDF._error_hint(worst_atol)
    elif outer == L.FAIL_CHATTER:
        from .events import chatter_message

        names = _event_elements(system)
        k = int(I[L.I_FAIL_WORST])
        switch_count = len(system.switching.family.elements) if system.switching is not None else 0
        what, hint = chatter_message(names[k], behavioural=k >= switch_count)
        return IntegrationFailure(float(F[L.F_FAIL_T]), h, what, None, hint)
    elif outer == L.FAIL_UNDEFINED:
        name = _event_elements(system)[int(I[L.I_FAIL_WORST])]
        what = (f"the held branch of {name} is undefined past the change of one of its comparisons (its value "
                "there is not finite), and the step could not end at the change")
        hint = (f"write {name}'s branches so that each is defined a little past its condition "
                "(e.g. sqrt(max(v(a), 0)) for v(a) > 0 ? sqrt(v(a)) : ...)")
        return IntegrationFailure(float(F[L.F_FAIL_T]), h, what, None, hint)
    elif outer == L.FAIL_MAX_STEPS:
        what = f"reached max_steps={int(I[L.I_MAX_STEPS])}"
        hint = "raise max_steps, or loosen the tolerances"
    elif code == L.FAIL_PROBE_SINGULAR:
        what = "the Newton matrix (alpha/h) dq/dx - dphi/dx is singular"
        hint = BDF._newton_hint(NewtonInfo.SINGULAR)
    elif code == L.FAIL_PROBE_NONFINITE:
        what = "the system evaluation right after t is not finite"
        hint = "the model is undefined at the initial/restart point"
    elif kind == 1:
        what = f"Newton iteration failed {L.MAX_NEWTON_FAILURES} times ({info})"
        hint = BDF._newton_hint(info)
    else:
        what = f"error test failed {L.MAX_ERROR_FAILURES} times"
        hint = BDF._error_hint(worst_atol)
    worst = system.names[wi] if 0 <= wi < system.n else None
    return IntegrationFailure(float(F[L.F_FAIL_T]), h, what, worst, hint)
