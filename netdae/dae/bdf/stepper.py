"""The :class:`BDF` driver: IDA's step loop composed of the history, controller, correctors, start-up and recorder.

It holds the integration's state (time, step, weights, counters, status) and
strings the parts together into IDA's phases (``IDAStep``): set coefficients
(:class:`~netdae.dae.bdf.history.History`), predict, correct
(:mod:`~netdae.dae.bdf.corrector`), test the error and choose order and step
(:mod:`~netdae.dae.bdf.controller`, on norms from the compiled kernels of
:mod:`netdae.dae.compiled.control`), restore and retry on failure, complete
the step, record it (:class:`~netdae.dae.bdf.recorder.Recorder`); restarts
probe the derivatives and right limits (:mod:`~netdae.dae.bdf.startup`).
The compiled engine (:mod:`netdae.dae.compiled.bdf_loop`) runs the same
phases on the same kernels for MNA systems; this driver serves every
``DaeSystem`` (user DAEs written with ``FunctionDae``, behavioural sources).
"""

from __future__ import annotations

import math
import time
from enum import StrEnum

import numpy as np

from ..bdf_kernels import merge_breakpoints
from ..compiled.control import (
    NORM_MAX,
    NORM_RMS,
    RELREF_LOCAL,
    RELREF_MIXED,
    RELREF_SIGNAL,
    charge_error_kp1,
    charge_error_norms,
    charge_newton_weights,
    charge_weights,
    current_error_weights,
    time_charge_residual,
    error_norms,
    landing_step,
    set_weights,
    weighted_norm,
)
from ..newton import DEFAULT_PERMC_SPEC, INFO_NONFINITE, LuCache, NewtonInfo
from ...results import STATUS_FAILED, STATUS_OK
from ..system import DaeSystem
from . import controller as ctl
from .arguments import (absolute_tolerances, breakpoint_times, charge_columns, charge_rows, check_arguments,
                        current_rows, index_mask,
                        time_charge_rows,
                        row_tolerances, save_indices)
from .constants import (
    BREAKPOINT_MERGE,
    BREAKPOINT_STRETCH,
    EPCON,
    ETA_NEWTON_FAIL,
    EVENT_RIGHT_LIMIT_FRACTION,
    EVENT_RIGHT_LIMIT_ULPS,
    IMPASSE_NEAR,
    IMPASSE_TRIES,
    H0_FRACTION,
    JUMP_DETECT,
    MAX_ERROR_FAILURES,
    MAX_NEWTON_FAILURES,
    MAX_ORDER,
    NEWTON_MAXITER,
    PROBE_FRACTION,
    PROBE_MAX_RATIO,
    PROBE_RETRIES,
    REPROBE_ERROR_FAILURES,
    RATE_AFTER_SETUP,
    RIGHT_LIMIT_RETRIES,
    ROUNDOFF_ULPS,
    UNDEFINED_TRIES,
)
from .corrector import LinearCorrector, NonlinearCorrector, RoundingFloor, point_state
from .failures import Failure, error_hint, failure_record, newton_hint, with_runaway, worst_unknown
from .history import History, sampled_history
from .recorder import Recorder
from .result import IntegrationResult
from .startup import event_right_limit, jump_of, probe, right_limit
from ..compiled.events import CHATTER_EVENTS, EVENT_MIN_GAP, EVENT_TOGETHER, chatter_message, interpolate_state, ulp
from .statistics import count_step, new_statistics

__all__ = ["BDF", "RunState"]

_RELREF = {"local": RELREF_LOCAL, "signal": RELREF_SIGNAL, "mixed": RELREF_MIXED}



class RunState(StrEnum):
    """Where an integration stands (compares equal to its lower-case name)."""

    RUNNING = "running"
    FINISHED = "finished"
    FAILED = "failed"

class BDF:
    """Fixed-leading-coefficient BDF stepper (orders 1..5) for ``d/dt q(x) = phi(x, t)``.

    Parameters
    ----------
    system : DaeSystem
    t0 : float
    x0 : ndarray, shape (n,)
        Consistent initial values (the caller computes them).
    t_bound : float
        End of the integration (a breakpoint).
    rtol : float
        Relative tolerance (SPICE's reltol).
    atol : float or ndarray, shape (n,)
        Absolute tolerance of ``KIND_OTHER`` unknowns, or one per unknown
        (then ``vntol``/``abstol`` are not used).
    vntol, abstol : float
        Absolute tolerances of voltages and currents (SPICE defaults).
    index : array_like of int, shape (n,), optional
        Per-unknown index: 0/1 differential or index-1 algebraic, 2 index-2.
        Index-2 unknowns are left out of the error test (not of the Newton norm).
    maxord : int
        Highest order, 1..5.
    max_step, min_step : float
        Bounds on the step size (SPICE's tmax; needing a step below
        ``min_step`` is a failure).
    first_step : float, optional
        First step size (estimated from x'(t0), x''(t0) and the tolerances
        otherwise).
    breakpoints : array_like, optional
        Times to land on exactly, besides ``system.breakpoints(t0, t_bound)``.
    xp0 : ndarray, shape (n,), optional
        x'(t0); estimated by an implicit-Euler probe otherwise.
    save : array_like of int, optional
        Unknowns to record (and interpolate); all by default.
    norm : {"rms", "max"}
        Weighted RMS norm (IDA) or maximum norm (every unknown within
        tolerance, as SPICE's per-device truncation-error test).
    relref : {"local", "signal", "mixed"}
        What the relative tolerance refers to: the current value
        ``|x_i(t_n)|`` (IDA: ``w_i = 1 / (rtol |x_i| + atol_i)``), the largest
        ``|x_i|`` so far (Spectre's ``relref=sigglobal``), or the larger of the
        current value and ``MIXED_FLOOR`` times the largest so far. With "local"
        the tolerance of an unknown collapses to its ``atol`` whenever it
        crosses zero; with SPICE's abstol = 1e-12 A for currents of milliamperes
        this can force thousands of order-1 steps at a zero crossing (whose
        local errors then add up). "signal" keeps the tolerance a fraction of
        the waveform's amplitude but loosens it wherever the waveform is
        small; "mixed" is local where the waveform is large and floors the
        tolerance near zero crossings.
    newton_maxiter : int
        Newton iterations per step attempt (nonlinear systems).
    fixed_step : float, optional
        Constant step without error control (for order studies); with
        ``fixed_order``.
    fixed_order : int, optional
        Order of the fixed-step mode (reached by raising the order one per
        step, or at once with ``history``).
    history : tuple (t_hist, x_hist), optional
        ``k + 1`` equally spaced past times ending at ``t0`` and the solution
        there (shape (k + 1, n)): start at order ``k`` with this history.
    permc_spec : str
        SuperLU column ordering.
    max_steps : int, optional
        Give up after this many accepted steps.

    Attributes
    ----------
    t : float
        Current time.
    x : ndarray, shape (n,)
        Current solution (a copy).
    h : float
        Size of the next step.
    order : int
        Order of the next step.
    status : RunState
    message : str
    stats : dict

    Raises
    ------
    ValueError
        For inconsistent arguments (shapes, tolerances, index >= 3, ...).

    Notes
    -----
    Memory: the ``(maxord + 1, n)`` history of the unknowns (and, for a
    nonlinear system, of the charges), the sparse LU, and the saved
    components at every step (``save`` limits it).
    """


    def __init__(
        self,
        system: DaeSystem,
        t0: float,
        x0,
        t_bound: float,
        *,
        rtol: float = 1e-3,
        atol=1e-6,
        vntol: float = 1e-6,
        abstol: float = 1e-12,
        index=None,
        maxord: int = MAX_ORDER,
        max_step: float = math.inf,
        min_step: float = 0.0,
        first_step: float | None = None,
        breakpoints=None,
        xp0=None,
        save=None,
        norm: str = "rms",
        relref: str = "local",
        newton_maxiter: int = NEWTON_MAXITER,
        fixed_step: float | None = None,
        fixed_order: int | None = None,
        history=None,
        permc_spec: str = DEFAULT_PERMC_SPEC,
        max_steps: int | None = None,
    ) -> None:
        wall0 = time.perf_counter()
        self.system = system
        n = self.n = int(system.n)
        self.t0 = float(t0)
        self.t_bound = float(t_bound)
        x0 = check_arguments(self.t0, self.t_bound, x0, n, rtol=rtol, maxord=maxord, norm=norm, relref=relref,
                             max_step=max_step, min_step=min_step, first_step=first_step)
        if int(newton_maxiter) < 1:
            raise ValueError("newton_maxiter must be at least 1")
        self.rtol = float(rtol)
        self.maxord = int(maxord)
        self.max_step = float(max_step)
        self.min_step = float(min_step)
        self.norm = norm
        self.relref = relref
        self._norm_kind = NORM_MAX if norm == "max" else NORM_RMS
        self.newton_maxiter = int(newton_maxiter)
        self.max_steps = max_steps
        self._linear = bool(getattr(system, "linear", False))

        self._atol, atol_label = absolute_tolerances(system.kinds, n, atol, vntol, abstol)
        self._tolerances = {
            "rtol": self.rtol, "vntol": float(vntol), "abstol": float(abstol), "atol": atol_label,
            "norm": norm, "relref": relref, "newton_tol": EPCON, "maxord": self.maxord,
        }
        self._high, mask_factor, self._tolerances["index_excluded"] = index_mask(system.names, n, index, norm)
        self._mask = np.ones(n) if mask_factor is None else mask_factor
        save_idx = save_indices(n, save)
        self._breakpoints = merge_breakpoints(self.t0, self.t_bound,
                                              breakpoint_times(system, self.t0, self.t_bound, breakpoints),
                                              BREAKPOINT_MERGE * (self.t_bound - self.t0))
        self._ibp = 0

        self._fixed = fixed_step is not None
        if self._fixed:
            if not (fixed_step > 0.0) or fixed_order is None or not (1 <= fixed_order <= self.maxord):
                raise ValueError("fixed_step needs a positive step and fixed_order in 1..maxord")
            self._fixed_order = int(fixed_order)
            self._fixed_h = float(fixed_step)
        elif fixed_order is not None:
            raise ValueError("fixed_order needs fixed_step")

        # the parts: P holds the differences of x, then of the charges of the rows whose charge
        # is nonlinear (every row of a system that does not say; none of a linear system)
        self._crows, self._qcol = charge_columns(system, self._linear)
        self._hist = History(n, n + self._crows.size, self.maxord)
        self.stats = new_statistics()
        self._rec = Recorder(system.names, save_idx, save is None)
        self._lu = LuCache(system.pattern, permc_spec=permc_spec)
        self._floor = RoundingFloor(system.pattern, self._lu)
        # rows whose charge error joins the error test (coupled to index-2 unknowns): their columns
        self._qrows = charge_rows(system.pattern.indptr, system.pattern.indices, self._high, self._qcol)
        # rows whose charge reads time itself: their charge errors join the error test too, and the probe
        # takes dq/dt at fixed x
        self._trows = time_charge_rows(system, self._qcol)
        self._t_tested = bool((self._trows >= 0).any())
        # the algebraic currents whose error tolerance their resistive rows raise
        self._cur = current_rows(system, self._mask, self._crows)
        self._q_tested = bool((self._qrows >= 0).any())
        self._tq = np.zeros(n)  # the current error of those rows, then the unknowns' error it makes
        self._wq = np.zeros(self._crows.size)
        self._wq_count = 0
        self._q_pattern = (np.asarray(system.pattern.indptr, dtype=np.int64),
                           np.asarray(system.pattern.indices, dtype=np.int64))
        self._corrector = None if self._linear else NonlinearCorrector(
            system, self._lu, self._floor, self.stats, self.newton_maxiter, norm, self._crows,
            rtol=self.rtol, row_atol=row_tolerances(system.kinds, self._atol, vntol, abstol), atol=self._atol)
        # the controller's state between steps
        self._phase = 0  # 0: start-up (order and step raised after every step), 1: normal
        self._nst = 0  # steps since the last (re)start
        self._growth_failed = False
        self._last_cj_attempt = None
        self._state = None  # the devices' limiting state at the last accepted point
        self._event_restart = False  # the pending restart follows a switching event
        self._impasse_t = math.nan  # the last t where Newton failed on every step size (an impasse)
        self._impasse_tries = 0
        self._impasse_eps = 0.0  # the implicit-Euler step of the last impasse
        self._after_event = False  # the last restart was at a switching event
        self._chatter = 0  # consecutive events in the first step after an event
        self._undefined_h = 0.0  # the step that first ended past a change where a held branch is undefined
        self._ee = None
        self.h = 0.0
        self._h_request = 0.0
        self._w = np.empty(n)
        self._w_err = np.empty(n)
        self._w_step_err = self._w_err
        self._xmax = np.zeros(n + self._crows.size)  # the unknowns', then the charges' largest magnitudes so far
        self._xmax[:n] = np.abs(x0)
        self._x_start = np.array(x0, dtype=float)
        self._failure = None
        self.status = RunState.RUNNING
        self.message = ""

        self.t = self.t0
        if n == 0:
            # nothing to integrate (a circuit of ideal sources only, or none)
            self._rec.record(self.t0, x0, 0)
            self._rec.record(self.t_bound, x0, 0)
            self.t = self.t_bound
            self.status = RunState.FINISHED
            self.message = f"reached t={self.t_bound:.9g}: the system has no unknowns"
            return
        self._set_weights(x0)
        # switches (netdae.devices.switch.SwitchEvents): held in the states of x0, changed at events
        self._switching = getattr(system, "switching", None)
        if self._switching is not None:
            self._switching.start(x0)
        # behavioural sources' comparisons of the state (netdae.devices.behavioral.BehaviouralEvents): the same
        self._locks = getattr(system, "behavioural_events", None)
        if self._locks is not None:
            self._locks.start(x0, self.t0)
        ev = self._evaluate(x0, self.t0, jacobian=self._linear)
        if not ev.ok or not np.all(np.isfinite(ev.q)) or not np.all(np.isfinite(ev.phi)):
            raise ValueError(f"the system evaluation at t0={self.t0:g} is not finite (check x0)")
        if self._linear:
            self._corrector = LinearCorrector(system, self._lu, ev, self.stats)
        P = self._hist.P
        P[0, :n] = x0
        if not self._linear:
            P[0, n:] = ev.q[self._crows]
        self._rec.record(self.t0, x0, 0)
        if history is not None:
            self._start_from_history(history, x0)
        else:
            self._start(x0, ev, first_step, xp0)
        self.stats["wall_time"] = time.perf_counter() - wall0

    # ------------------------------------------------------------- helpers
    def _set_weights(self, x, accepted=False):
        """Error weights at x (the compiled ``set_weights``): ``_w`` for Newton, ``_w_err`` for the error test.

        After an accepted step the algebraic currents' error tolerances are raised to what their
        resistive rows give them (:func:`~netdae.dae.compiled.control.current_error_weights`). A
        nonlinear system's Newton weights are raised to the accuracy of its charges
        (:func:`~netdae.dae.compiled.control.charge_newton_weights`, from the history's charges
        at x and the last Jacobian's ``|dq/dx|``).
        """
        set_weights(x, self.rtol, self._atol, _RELREF[self.relref], self._xmax, self._mask, self._w, self._w_err)
        if accepted and self._cur[0].size:
            current_error_weights(self._w, self._w_err, self._mask, self._cur)
        abs_dq = self._floor.abs_dq
        if not self._linear and abs_dq is not None and self._crows.size:
            charge_newton_weights(self._hist.P[0, self.n:], self._xmax[self.n:], self._qcol, abs_dq.data,
                                  abs_dq.indptr, abs_dq.indices, self.rtol, self._atol, self._w, np.empty(self.n))

    def _normf(self, v, w):
        return weighted_norm(v, w, self._norm_kind)

    def _evaluate_at(self, x, t):
        """An evaluation without limiting (no Jacobian), counted."""
        ev = self.system.evaluate(x, t, jacobian=False, state=None)
        self.stats["evaluations"] += 1
        return ev

    def _evaluate(self, x, t, jacobian=False):
        ev = self.system.evaluate(x, t, jacobian=jacobian, state=self._state)
        self.stats["evaluations"] += 1
        if jacobian:
            self.stats["jacobian_evaluations"] += 1
        return ev

    def _fail(self, t, h, what, worst, hint):
        self.status = RunState.FAILED
        _, failure = failure_record(t, h, what, worst, hint)
        # the last accepted point against the start: a mode grown without bound is named as such
        self._failure = with_runaway(failure, self.system.names, self.system.kinds, self._x_start,
                                     self._hist.P[0, : self.n], self.stats["max_order_used"])
        self.message = self._failure.message

    # Kept as static methods: the compiled engine's driver words its failures with them.
    _newton_hint = staticmethod(newton_hint)
    _error_hint = staticmethod(error_hint)

    # --------------------------------------------------------------- (re)start
    def _start(self, x0, ev0, first_step, xp0):
        """Derivatives and first step at t0 (order 1)."""
        cap = min(H0_FRACTION * (self._breakpoints[0] - self.t0), self.max_step, self.system.step_bound())
        if self._fixed:
            p = self._probe_or_fail(self.t0, x0, PROBE_FRACTION * self._fixed_h)
            if p is not None:
                self._initialise_history(self._fixed_h, p.xp, p.qp)
            return
        if xp0 is not None:
            xp = np.array(xp0, dtype=float)
            if xp.shape != (self.n,) or not np.all(np.isfinite(xp)):
                raise ValueError(f"xp0 must be a finite array of shape ({self.n},)")
            h = first_step
            if h is None:
                h = ctl.first_step_from_derivative(self._normf(xp, self._w_err), cap)
            self._initialise_history(max(h, self.min_step), xp, ev0.phi)
            return
        h = first_step if first_step is not None else cap
        self._restart_at(x0, h, fixed=first_step is not None)

    def _restart_at(self, x, cap, fixed=False):
        """Probe the derivatives at (t, x) and start at order 1 with a step <= cap.

        The first probe also measures the right limit x(t+); where it differs
        from ``x`` the method continues from the right limit (:meth:`_jump`).
        """
        h = cap
        checked = False
        retries = 0
        jumped = False
        while True:
            eps = PROBE_FRACTION * h
            p = self._probe_or_fail(self.t, x, eps, jumped)
            if p is None:
                return
            if not checked:
                checked = True
                jump = self._jump(x, p, eps)
                if jump is None:
                    return
                x, again = jump
                if again:
                    jumped = True
                    continue  # derivatives from the right limit
            if fixed:
                break
            h_new = ctl.first_step_from_curvature(self._normf(p.xpp, self._w_err), cap, self.min_step)
            converged = eps <= PROBE_MAX_RATIO * h_new
            h = h_new
            retries += 1
            if converged or retries >= PROBE_RETRIES:
                break
        self._initialise_history(h, p.xp, p.qp)

    def _reprobe(self, t, cap):
        """The (re)start's derivatives probed again at ``t`` for a first step of at most ``cap``.

        After the first step from a (re)start failed the error test
        ``REPROBE_ERROR_FAILURES`` times: the probe's two
        implicit-Euler steps (a thousandth of the step they were for) damp a mode faster
        than themselves, and the derivatives they give are the ones after it; the
        predictor then misses the mode's contribution and the error shrinks only in
        proportion to the step, never below the tolerance in ten failures (a 1-ohm source
        into 1 pF at a PULSE corner). Probed once more on the shorter step (never below the
        rounding of t), the curvature shows the mode and sets the step, at most ``cap``
        (:func:`~netdae.dae.bdf.controller.first_step_from_curvature`). Returns the step
        (None after recording a failure).
        """
        x = self._hist.P[0, : self.n].copy()
        eps = max(PROBE_FRACTION * cap, EVENT_RIGHT_LIMIT_ULPS * ulp(t))
        p = self._probe_or_fail(t, x, eps)
        if p is None:
            return None
        h = ctl.first_step_from_curvature(self._normf(p.xpp, self._w_err), cap, self.min_step)
        self._initialise_history(h, p.xp, p.qp)
        return h

    def _probe_or_fail(self, t, x, eps, after_jump=False):
        """:func:`~netdae.dae.bdf.startup.probe` at (t, x); None after recording a failure."""
        self.stats["probes"] += 1
        try:
            return probe(self._evaluate, self._lu, self._floor, self.system.names, t, x, eps, self._high, self._w,
                         self._w_err, after_jump=after_jump and not self._linear, timed=self._t_tested)
        except Failure as f:
            self._fail(t, eps, f.what, f.worst, f.hint)
            return None

    def _jump(self, x, p, eps):
        """Continue from the right limit where it differs from ``x``.

        Returns ``(x_new, reprobe)``, or None after recording a failure.
        ``x_new`` is ``x`` itself when nothing jumped. Otherwise every unknown
        takes its right limit (a partial replacement would break the algebraic
        relations between them), the point is recorded a second time (the left
        and the right value at the same t, so the dense output never
        interpolates across the jump) and ``reprobe`` says whether the
        derivatives must be measured again (an unknown that is not index 2
        jumped, or any unknown of a nonlinear system). A nonlinear system's right limit is then recomputed by
        converged Newton iterations (the one-iteration probe is accurate only
        near a consistent point).
        """
        # the first-step criterion holds in a nonlinear system too: where the inputs are continuous the
        # extrapolation's error (a large x'', a sqrt(t)-like solution) moves nothing by a jump; after a
        # switching event (phi itself changed) every move counts
        jumped, value_jump, x_right = jump_of(x, p.x_right, p.x_2, p.w_floor, self._high,
                                              first_step=not self._event_restart)
        if not jumped:
            return x, False
        if value_jump and not self._linear:
            x_right = self._right_limit(x, eps)
            if x_right is None:
                return None
            if (not self._event_restart
                    and np.any(np.abs(x_right - x) * p.w_floor > JUMP_DETECT)):
                # a move is confirmed with the short steps: a mode faster than the probe's step (a base
                # current cut at an input's corner, settling in 0.1 ns against the probe's 0.1 ns; a
                # collector node 10 ps from its source at the start), or one growing faster (implicit
                # Euler damps it with a negative factor), moves nothing within them; an input that
                # jumps, or an .ic released, moves the solution within the first of them
                x_right = self._right_limit(x, eps, short=True)
                if x_right is None:
                    return None
        moved = np.abs(x_right - x) * p.w_floor
        names = tuple(self.system.names[i] for i in np.flatnonzero(moved > JUMP_DETECT))
        if not names:
            return x, False  # the converged right limit is x itself: nothing jumped
        self._continue_from(x_right, names)
        # a nonlinear system's history holds q'(t+) = phi(x(t+)): an index-2 unknown that
        # jumped changes it in the rows it enters (a source current into a gate charge)
        return x_right, value_jump or not self._linear

    def _continue_from(self, x_right, names):
        """Make ``x_right`` the history's value at t (and its charges), record the unknowns ``names`` jumping."""
        n = self.n
        P = self._hist.P
        P[0, :n] = x_right
        if not self._linear:
            P[0, n:] = self._evaluate(x_right, self.t).q[self._crows]
        self._set_weights(x_right)
        if names:
            self._rec.jump(self.t, x_right, names)

    def _right_limit(self, x, eps, short=False):
        """x(t+) of a nonlinear system; None after a failure.

        Full Newton on the two implicit-Euler steps first
        (:func:`~netdae.dae.bdf.startup.event_right_limit`: a few iterations from the left
        value when the inputs or a switch change little), failing that the steady-state
        solver with its homotopies (:func:`~netdae.dae.bdf.startup.right_limit`: a diode
        switched on by a step). After a switching event, and with ``short`` (a start's move
        confirmed), the steps are much shorter than the probe's (``EVENT_RIGHT_LIMIT_*``).
        """
        if self._event_restart or short:
            eps = max(EVENT_RIGHT_LIMIT_FRACTION * eps,
                      EVENT_RIGHT_LIMIT_ULPS * ulp(self.t))
        out, iterations, evaluations = event_right_limit(self.system, self.t, x, eps, self._high, self._lu,
                                                         self._w, state=self._state, timed=self._t_tested)
        self.stats["newton_iterations"] += iterations
        self.stats["evaluations"] += evaluations
        self.stats["jacobian_evaluations"] += iterations
        if out is not None:
            return out
        tol = self._tolerances
        out, iterations, evaluations, message = right_limit(self.system, self.t, x, eps, self._high, self.rtol,
                                                            tol["vntol"], tol["abstol"], state=self._state,
                                                            retries=RIGHT_LIMIT_RETRIES, timed=self._t_tested)
        self.stats["newton_iterations"] += iterations
        self.stats["evaluations"] += evaluations
        if out is None:
            self._fail(self.t, eps, message, None, newton_hint(None))
        return out

    def _initialise_history(self, h, xp, qp):
        self._hist.initialise(h, xp, None if self._linear else qp[self._crows])
        self._phase = 0
        self._nst = 0
        if not self._linear:
            self._corrector.rate = RATE_AFTER_SETUP
            self._corrector.rate_age = 0
        self._growth_failed = False
        self.h = h

    def _start_from_history(self, history, x0):
        t_hist, x_hist, h = sampled_history(history, self.t0, x0, self.maxord)
        k = t_hist.size - 1
        if self._fixed and (k != self._fixed_order or not math.isclose(h, self._fixed_h, rel_tol=1e-10)):
            raise ValueError("history must have fixed_order + 1 points spaced by fixed_step")
        q_hist = None
        if not self._linear:
            q_hist = np.array([self._evaluate(x_hist[i], t_hist[i]).q[self._crows] for i in range(k + 1)])
        self._hist.from_samples(h, x_hist, q_hist)
        self._phase = 1
        self._nst = k
        self.h = h

    def _restart(self, h_last, final=False):
        """Order-1 restart on a breakpoint: derivatives from the right by a probe.

        ``final``: at ``t_bound`` itself (an event there), where no breakpoint lies ahead to bound the
        probe's step: ``h_last`` and the step bounds do."""
        self.stats["restarts"] += 1
        self._rec.restart(self.t)
        x = self._hist.P[0, : self.n].copy()
        if self._fixed:
            p = self._probe_or_fail(self.t, x, PROBE_FRACTION * self._fixed_h)
            if p is not None:
                self._initialise_history(self._fixed_h, p.xp, p.qp)
            return
        ahead = np.inf if final else self._breakpoints[self._ibp] - self.t
        cap = max(min(h_last, self.max_step, ahead), self.min_step)
        self._restart_at(x, cap)

    # ------------------------------------------------------------- properties
    @property
    def x(self) -> np.ndarray:
        """Current solution (a copy), shape (n,)."""
        return self._hist.P[0, : self.n].copy()

    @property
    def order(self) -> int:
        """Order of the next step."""
        return self._hist.k

    # ------------------------------------------------------------------- step
    def step(self) -> str | None:
        """Advance by one accepted step.

        Returns
        -------
        str or None
            ``None`` on success, the failure message otherwise (then
            ``status == RunState.FAILED``).

        Raises
        ------
        RuntimeError
            When called after the integration finished or failed.
        """
        if self.status != RunState.RUNNING:
            raise RuntimeError(f"the integration is {self.status}; no further steps")
        wall = time.perf_counter()
        self._step_impl()
        self.stats["wall_time"] += time.perf_counter() - wall
        return self.message if self.status == RunState.FAILED else None

    def _step_impl(self):
        """One step: the attempt loop of IDA's IDAStep."""
        hist = self._hist
        ncf = nef = nud = 0
        t = self.t
        h = self._fixed_h if self._fixed else self.h
        while True:
            self._h_request = h
            h, landing = landing_step(min(h, self.max_step), self._breakpoints[self._ibp] - t,
                                      BREAKPOINT_STRETCH, not self._fixed)
            hist.set_coefficients(h)
            t_new = self._breakpoints[self._ibp] if landing else t + h
            accepted, kind, info = self._attempt(t_new, landing)
            if accepted:
                break
            hist.restore()
            self._phase = 1
            if kind == "undefined":
                nud += 1
                eta = self._undefined_branch(t, h, nud, info)
                if eta is None:
                    return
            elif kind == "newton":
                ncf += 1
                self.stats["newton_failures"] += 1
                if ncf == 1 and not self._linear:
                    # the junctions are limited from the accepted point in the next attempts, not from
                    # the iterate its last correction was computed at (ngspice; the compiled loop's _point_state)
                    self._state = point_state(self.system, self._state,
                                              self._evaluate_at(hist.P[0, : self.n], t).state)
                eta = self._newton_failure(t, h, ncf, info)
            else:
                nef += 1
                self.stats["rejected"] += 1
                if h > hist.hused:
                    self._growth_failed = True
                eta = self._error_failure(t, h, nef, info)
            if eta is None:
                return
            h_new = self._reduced_step(t, h, eta, kind, info)
            if h_new is None:
                return
            if self._nst == 0 and kind == "error" and nef >= REPROBE_ERROR_FAILURES and not self._fixed:
                # the first step after a (re)start failed the error test again and again: the probe's
                # derivatives, measured on steps a thousandth of the longer step, may have missed a mode
                # faster than them (a stiff RC at an input's corner); measured again on the shorter step
                h_new = self._reprobe(t, h_new)
                if h_new is None:
                    return
            elif self._nst == 0:
                # first step after a (re)start: rescale the derivative term (IDA's IDAReset)
                hist.rescale_first_step(h_new, h)
            h = h_new
        if nud == 0:
            self._undefined_h = 0.0  # an approach to a change where a held branch is undefined ended without it
        self._complete_step(t_new, h, landing, info, ncf + nef > 0)

    def _undefined_branch(self, t, h, nud, info):
        """After an attempt whose end is past a change where a behavioural source's held branch is undefined.

        The twin of the compiled engine's (``bdf_loop.run``, docs/integrator.md): the change located on the
        last step's polynomial continued; the step retried to end there (then at 0.9 and half of it), until
        the change is within ``EVENT_MIN_GAP`` of the step that first met it, or within the rounding of ``t``
        (``4 ROUNDOFF_ULPS`` units in its last place: no reduced step ends before it): then it happens at
        ``t``, an event without a step (returns None after the restart, or after a failure).
        """
        if self._undefined_h == 0.0:
            self._undefined_h = h  # the approach to the change begins (it may take several steps)
        first = self._undefined_h
        hist = self._hist
        t_change, changed = self._locks.ahead(hist.P, hist.kused, hist.psi, t, h, EVENT_TOGETHER * first)
        x_change = None  # the change's point: on the continued polynomial, or the attempt's end
        # (no shorter step ends between t and the change: the reduced steps stop at ROUNDOFF_ULPS)
        at_t = max(EVENT_MIN_GAP * first, 4.0 * ROUNDOFF_ULPS * ulp(t))
        if not changed and h <= at_t:
            # the continued polynomial does not see the change the corrector met within this short a
            # step: it changes here, to the outcomes at the attempt's end
            t_change, changed = t, self._locks.at(info["x"], t)
            x_change = info["x"]
        if changed and t_change - t <= at_t:
            self._locks.flip()
            switched = ()
            if self._switching is not None:
                # the switches settle at the change in the same event (one controlled by the same crossing
                # would otherwise change a rounding later, as a second event): decided at the change's
                # point, the continued polynomial's there (the attempt's end when that polynomial did not see it)
                if x_change is None:
                    x_change = np.zeros(self.n)
                    interpolate_state(hist.P, hist.kused, hist.psi, t_change - t, self.n, x_change)
                switched = self._switching.at(x_change, t)
            if not self._count_event(t, switched + changed, self._nst == 0, first, not switched):
                return None
            self._after_event = True
            self._event_restart = True
            self._restart(first)
            self._event_restart = False
            return None
        if nud > UNDEFINED_TRIES:
            self._fail_undefined(t, h, info["source"])
            return None
        self.stats["rejected"] += 1
        gap = t_change - t if changed else h
        return gap / h if gap < h else (0.9 if nud == 2 else 0.5)

    def _count_event(self, t, names, fresh, h, behavioural) -> bool:
        """Record an event of ``names`` at ``t``; ``fresh``: in the first step after the last restart (an event
        there after an event's restart, again and again, is chattering: the run fails naming the first of
        ``names``, a behavioural source when ``behavioural``). False after that failure."""
        self.stats["events"] += 1
        self._undefined_h = 0.0
        self._rec.events.append((float(t), names))
        self._chatter = self._chatter + 1 if (fresh and self._after_event) else 0
        if self._chatter >= CHATTER_EVENTS:
            what, hint = chatter_message(names[0], behavioural=behavioural)
            self._fail(t, h, what, None, hint)
            return False
        return True

    def _fail_undefined(self, t, h, source):
        self._fail(t, h, f"the held branch of {source} is undefined past the change of one of its comparisons (its "
                   "value there is not finite), and the step could not end at the change", None,
                   f"write {source}'s branches so that each is defined a little past its condition "
                   "(e.g. sqrt(max(v(a), 0)) for v(a) > 0 ? sqrt(v(a)) : ...)")

    def _newton_failure(self, t, h, ncf, info):
        """Step-size factor after a Newton failure, or None after recording a final failure."""
        reason = info["info"]
        if self._fixed:
            self._fail(t, h, f"Newton iteration failed in fixed-step mode ({reason})", info.get("worst"),
                       "fixed-step mode cannot reduce the step; choose a smaller fixed_step")
            return None
        if ncf >= MAX_NEWTON_FAILURES:
            if reason != NewtonInfo.EVALUATION and self._impasse(t):
                return None  # continued from the jump: the step loop goes on from there
            self._fail(t, h, f"Newton iteration failed {ncf} times ({reason})", info.get("worst"),
                       newton_hint(reason))
            return None
        return ETA_NEWTON_FAIL

    def _impasse(self, t) -> bool:
        """After the attempts from t failed on every step size: continue from the solution right of t.

        Newton failed, or the error test down to the rounding of t, in a nonlinear
        system: no solution near the last one exists, or one faster than t can
        resolve (an impasse: the circuit snaps to another state, as a latch or a
        transistor without capacitances does). Two implicit-Euler steps of the step
        the attempts began with, solved by the steady-state solver with its homotopies
        (:func:`right_limit`), give the state right of t; it is recorded as a jump and
        the method restarts there at order 1. Failing again right after, up to
        ``IMPASSE_TRIES`` times at one t with steps ten times longer each; a failure
        within ``IMPASSE_NEAR`` of the last impasse's steps after it counts as one at
        its t (a crawl of impasses a few ulps apart would otherwise never end). Returns
        False (nothing changed) when that solve fails too, or for a linear system.
        """
        if self._linear:
            return False
        if self._impasse_t <= t <= self._impasse_t + IMPASSE_NEAR * self._impasse_eps:
            if self._impasse_tries >= IMPASSE_TRIES:
                return False
            self._impasse_tries += 1  # still failing right after the jump: a ten times longer step
        else:
            self._impasse_t, self._impasse_tries = t, 1
        n = self.n
        x = self._hist.P[0, :n].copy()
        eps = max(self.h * 10.0 ** (self._impasse_tries - 1),
                  EVENT_RIGHT_LIMIT_ULPS * ulp(t))
        self._impasse_eps = eps
        tol = self._tolerances
        out, iterations, evaluations, _ = right_limit(self.system, t, x, eps, self._high, self.rtol,
                                                      tol["vntol"], tol["abstol"], state=self._state, impasse=True)
        self.stats["newton_iterations"] += iterations
        self.stats["evaluations"] += evaluations
        if out is None:
            return False
        moved = np.abs(out - x) * self._w
        self._continue_from(out, tuple(self.system.names[i] for i in np.flatnonzero(moved > JUMP_DETECT)))
        self.stats["impasses"] += 1
        self.stats["restarts"] += 1
        self._rec.restart(t)
        self._restart_at(out, max(eps, self.min_step))  # never a probe below the rounding of t
        return self.status != RunState.FAILED

    def _error_failure(self, t, h, nef, info):
        """Step-size factor (and new order) after an error-test failure, or None after the last one."""
        if nef >= MAX_ERROR_FAILURES:
            self._fail(t, h, f"error test failed {nef} times", info.get("worst"), error_hint(self._worst_atol(info)))
            return None
        self._hist.k, eta = ctl.error_failure(nef, self._hist.k, info["knew"], info["err_k"], info["err_km1"])
        return eta

    def _worst_atol(self, info) -> float | None:
        """The absolute tolerance of the unknown a failure names (None: it names none)."""
        names = list(self.system.names)
        worst = info.get("worst")
        return float(self._atol[names.index(worst)]) if worst in names else None

    def _reduced_step(self, t, h, eta, kind, info):
        """``h * eta`` bounded by min_step and roundoff (:func:`controller.reduced_step`), or None after a failure."""
        h_new, limit = ctl.reduced_step(t, h, eta, self.min_step)
        if limit is None:
            return h_new
        if kind == "undefined":
            self._fail_undefined(t, h, info["source"])
            return None
        failures = "Newton failures" if kind == "newton" else "error-test failures"
        if limit == "min_step":
            what = (f"step size {h:.3g} at min_step {self.min_step:.3g} and the "
                    + ("Newton iteration fails" if kind == "newton" else "error test fails"))
        else:
            what = f"step size below the roundoff of t ({failures})"
        if (kind == "error" or info.get("info") != NewtonInfo.EVALUATION) and self._impasse(t):
            return None  # continued from the jump
        hint = newton_hint(info.get("info")) if kind == "newton" else error_hint(self._worst_atol(info))
        self._fail(t, h, what, info.get("worst"), hint)
        return None

    def _attempt(self, t_new, landing=False):
        """Predict, solve the corrector, test the error.

        A step ``landing`` on a breakpoint evaluates the equations just before
        it (``nextafter(t_new, -inf)``): the inputs from the left, as the step
        sees them; an expression of time that jumps there takes its right
        value at the restart.

        Returns
        -------
        (accepted, kind, info)
            ``kind`` is ``"newton"`` or ``"error"`` for a failure; ``info`` holds
            the order proposal and error norms, or the failure details.
        """
        n = self.n
        hist = self._hist
        k = hist.k
        pred = hist.predict()
        cj = hist.cj
        if cj != self._last_cj_attempt:
            self.stats["cj_changes"] += 1
            self._last_cj_attempt = cj
        self._w_step_err = self._w_err
        t_ev = np.nextafter(t_new, -np.inf) if landing else t_new
        if self._linear:
            ok, out = self._corrector.solve(t_ev, pred, cj, self._w, self._fixed)
            if not ok:
                return False, "newton", out
            ee = out - pred[0]
        else:
            w_newton, self._w_step_err = self._floor.weights(self._w, self._w_err, pred[0, :n], pred[1, n:], cj,
                                                             pred[1, :n], self._qcol)
            ok, out = self._corrector.solve(t_ev, pred, cj, hist.cjlast, self._nst == 0, self._state, w_newton)
            if not ok:
                return False, "newton", out
            x_new, q_new = out
            ee = np.empty(pred.shape[1])
            np.subtract(x_new, pred[0, :n], out=ee[:n])
            np.subtract(q_new, pred[0, n:], out=ee[n:])
            if self._locks is not None and self._locks.undefined() is not None:
                # past a change where a behavioural source's held branch is undefined: not an error test's
                return False, "undefined", {"source": self._locks.undefined(), "x": x_new}
        self._ee = ee
        if self._fixed:
            return True, "", {"knew": k, "err_k": 0.0, "err_km1": 0.0}
        norms = error_norms(ee, hist.P, k, self._w_step_err, self._norm_kind, n)
        self._wq_count = 0
        if self._q_tested and self._floor.abs_dq is not None:
            indptr, indices = self._q_pattern
            self._wq_count = charge_weights(self._qrows, self._floor.abs_dq.data, indptr, indices, self._w, self._wq)
            qn = charge_error_norms(ee, hist.P, k, self._wq, self._norm_kind, n, self._wq_count)
            norms = (max(norms[0], qn[0]), max(norms[1], qn[1]), max(norms[2], qn[2]))
        if self._t_tested:
            # at orders k, k-1, k-2 (error_norms' combinations)
            norms = tuple(max(norms[j], self._time_charge_norm(ee, k + 1 - j, k, 1.0, cj, self._w_step_err))
                          if k >= j + 1 else norms[j] for j in range(3))
        test = ctl.error_test(norms, hist.sigma, hist.ck, k)
        info = {"knew": test.knew, "err_k": test.err_k, "err_km1": test.err_km1}
        if test.passed:
            return True, "", info
        if not test.finite:
            return False, "newton", {"info": INFO_NONFINITE,
                                     "worst": worst_unknown(self.system.names, ee[:n], self._w, self._w)}
        info["worst"] = worst_unknown(self.system.names, ee[:n], self._w_err, self._w)
        return False, "error", info

    def _time_charge_norm(self, ee, rows_from, last, sign, cj, w):
        """The error the charges that read time make in the unknowns: the charge history's estimate
        ``ee + sign * sum(P[rows_from:last + 1])`` as the corrector's residual
        (:func:`~netdae.dae.compiled.control.time_charge_residual`) solved with the Newton matrix."""
        time_charge_residual(ee, self._hist.P, self.n, rows_from, last, sign, self._trows, cj, self._tq)
        return self._normf(self._lu.solve(self._tq), w)

    def _complete_step(self, t_new, h, landing, info, retried):
        """Order and step-size selection, history update, switching events, recording (IDA's IDACompleteStep).

        Where a switch changes conductance within the step, the step ends at the crossing
        (the unknowns interpolated there, :meth:`netdae.devices.switch.SwitchEvents.step`) and
        the method restarts at order 1, as on a breakpoint.
        """
        hist = self._hist
        k = hist.k
        t = self.t
        self._nst += 1
        if not self._linear:
            self._corrector.age += 1
        count_step(self.stats, h, k)
        kdiff = hist.accept(h)
        eta = self._select_order_and_step(k, kdiff, info)
        eta, self._growth_failed = ctl.hold_growth(eta, retried, self._growth_failed, hist.ns, k)
        hist.update(self._ee, k)
        t_end, event, switched, x_event = t_new, False, (), None
        if self._switching is not None:
            held_before = self._switching.states.copy()
            t_end, switched, x_event = self._switching.step(hist.P, k, hist.psi, t, t_new)
        changed = ()
        if self._locks is not None:
            t_lock, changed = self._locks.step(hist.P, k, hist.psi, t, t_new, t_end)
            if changed and t_lock < t_end:
                # a comparison changes first: the switches keep their states to there
                if switched or x_event is not None:
                    self._switching.hold(held_before)
                    switched = ()
                t_end = t_lock
                x_event = np.zeros(self.n)
                interpolate_state(hist.P, k, hist.psi, t_end - t_new, self.n, x_event)
        switched = tuple(switched) + tuple(changed)
        event = bool(switched)
        if x_event is not None:
            n = self.n
            hist.P[0, :n] = x_event
            # the charges at the event, exactly, in the held states and outcomes
            hist.P[0, n:] = self._evaluate(x_event, t_end).q[self._crows]
        if changed:
            self._locks.flip()
        self.t = t_end
        x_new = hist.P[0, : self.n]
        self._state = self._corrector.state_try
        self._set_weights(x_new, accepted=True)
        self._rec.record(t_end, x_new, k)
        self.h = max(min(h * eta, self.max_step, self.system.step_bound()), self.min_step)
        ended = self.system.ended()
        if ended is not None:
            self.status = RunState.FINISHED
            self.message = f"stopped at t={t_end:.9g}: {ended}, after {self.stats['steps']} steps"
            return
        landed = landing and t_end == t_new
        final = landed and self._ibp == self._breakpoints.size - 1
        if final and not event:
            self.status = RunState.FINISHED
            self.message = self._success_message()
            return
        if not final and self.max_steps is not None and self.stats["steps"] >= self.max_steps:
            self._fail(t_end, self.h, f"reached max_steps={self.max_steps}", None,
                       "raise max_steps, or loosen the tolerances")
            return
        if event and not self._count_event(t_end, switched, self._nst == 1, h, switched[0] in changed):
            return
        if final:
            # a switch or a comparison changes at the end itself: the event is recorded and so is the
            # value after it (the right limit at t_bound, a jump's second point), then the run ends
            self._event_restart = True
            self._restart(h, final=True)
            self._event_restart = False
            if self.status == RunState.RUNNING:
                self.status = RunState.FINISHED
                self.message = self._success_message()
            return
        if landed or event:
            self._after_event = event
        if landed:
            self._ibp += 1
            self._event_restart = event
            self._restart(max(h, self._h_request))
        elif event:
            self._event_restart = True
            self._restart(h)
        self._event_restart = False

    def _select_order_and_step(self, k, kdiff, info):
        """Order for the next step (set on the history) and the step-size factor eta."""
        hist = self._hist
        if self._fixed:
            if self._nst > 1 and k < self._fixed_order:
                hist.k = k + 1
            return 1.0
        knew = info["knew"]
        if knew == k - 1 or k == self.maxord:
            self._phase = 1
        if self._phase == 0:
            # start-up: raise the order and double the step after every step but the first
            if self._nst > 1:
                hist.k = k + 1
                return 2.0
            return 1.0
        err_new = info["err_k"]
        if knew == k - 1:
            hist.k, err_new = k - 1, info["err_km1"]
        elif ctl.raise_test_due(k, knew, self.maxord, hist.ns, kdiff):
            n = self.n
            err_kp1 = self._normf(self._ee[:n] - hist.P[k + 1, :n], self._w_err) / (k + 2)
            if self._wq_count:
                err_kp1 = max(err_kp1, charge_error_kp1(self._ee, hist.P, k, self._wq, self._norm_kind, n,
                                                        self._wq_count) / (k + 2))
            if self._t_tested:
                err_kp1 = max(err_kp1, self._time_charge_norm(self._ee, k + 1, k + 1, -1.0, hist.cj,
                                                              self._w_err) / (k + 2))
            hist.k, err_new = ctl.choose_order(k, info["err_km1"], info["err_k"], err_kp1)
        return ctl.step_factor(err_new, hist.k)

    # --------------------------------------------------------------- output
    def result(self) -> IntegrationResult:
        """The integration so far as an :class:`IntegrationResult`."""
        stats = dict(self.stats)
        stats["factorizations"] = self._lu.factorizations
        status = STATUS_OK if self.status == RunState.FINISHED else STATUS_FAILED
        message = self.message or f"stopped at t={self.t:.9g} before t_bound={self.t_bound:.9g}"
        return self._rec.result(stats=stats, status=status, message=message, tolerances=self._tolerances,
                                failure=self._failure)

    def _success_message(self):
        st = self.stats
        return (f"reached t={self.t_bound:.9g} in {st['steps']} steps ({st['rejected']} rejected, "
                f"{st['newton_failures']} Newton failures, {self._lu.factorizations} factorizations)")
