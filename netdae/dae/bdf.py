"""Variable-order, variable-step BDF for DAEs in charge form ``d/dt q(x) = phi(x, t)``.

The method
----------
netdae integrates with the backward differentiation formulas of orders 1 to 5
in the *fixed-leading-coefficient* (FLC) form of DASSL and SUNDIALS IDA
[1]_ [2]_ [3]_, applied to the charges:

    cj (q(x_{n+1}) - q_pred) + q'_pred = phi(x_{n+1}, t_{n+1}),     cj = (sum_{j<=k} 1/j) / h

where ``q_pred`` and ``q'_pred`` come from the predictor polynomial through
the last ``k + 1`` charge values. This is the residual
``(alpha/h)(q(x) - q-history) - phi(x, t)`` with ``alpha = sum 1/j`` and a
history that combines past *charges*, not past unknowns, so linear
invariants of the charges (the charge of an isolated node, the flux of an
inductor loop) are preserved by the discretisation: nonlinear capacitors
conserve charge. For ``q = E x`` with a constant ``E`` this is the ordinary
FLC-BDF on ``E x' = phi``. The unknowns keep their own history for the
predictor (Newton's starting point), the local error estimate and the dense
output.

Why FLC and not the quasi-constant-step (Nordsieck/difference-array) form of
ode15s and scipy [4]_: (i) the Newton matrix ``cj dq/dx - dphi/dx`` depends
on ``h`` and the order only, so for a linear circuit the number of sparse LU
factorisations is bounded by the number of step-size and order changes,
and a step-size change needs no re-interpolation of the history; (ii) the
FLC form keeps the stability of the variable-coefficient BDF under frequent
step changes (Jackson and Sacks-Davis [5]_), which the interpolation of the
quasi-constant-step form loses; (iii) DASSL/IDA are the reference codes
for index-1 and index-2 DAEs and netdae's tests compare against IDA itself;
(iv) the interpolant of the method, the polynomial through the last
``k + 1`` computed points, is the natural dense output and needs no extra
storage. Step-size changes remain rare as in IDA: the step grows only when
it can double, shrinks only when the error estimate asks for it, and
Newton's matrix is refactored (nonlinear systems) only when ``cj`` moved by
more than a factor 1.67 or convergence failed. Beyond IDA, a step that
needed a retry is not followed by a larger one (CVODE's rule), and after a
larger step failed the error test the step grows again only after ``k + 2``
steps at constant size and order: this keeps a tight absolute tolerance on
an unknown crossing zero from trapping the method at order 1 in a cycle of
growth and rejection.

A step is made of named phases (IDA's ``IDAStep``): set coefficients,
predict, Newton on the corrector, error test, restore and retry on failure,
complete the step (order and step selection, history update).

Index-aware error control
-------------------------
Unknowns marked ``index >= 2`` (the current of a voltage source parallel to
a capacitor, an output driven by an ideal differentiator, the multipliers
of the GGL pendulum) are left out of the local error test (IDA's
``suppressalg``, restricted to the index-2 unknowns). Their local error
estimate is O(1) wherever the derivative of the inputs jumps (they are
derivatives of the other unknowns), so testing them would drive the step
size to zero; their accuracy follows from the accuracy of the unknowns they
are derivatives of. The weighted RMS norm of the error test is taken over the
tested unknowns only. They stay in the Newton convergence norm: the corrector
equations must be solved for them too, and since an index-2 unknown responds
to the others' Newton residual like 1/h, leaving it out let a modified Newton
iteration stop with it far from the solution (measured on a CMOS ring
oscillator: supply-current spikes of 2,700 A where the current is 1 mA;
with it in the norm, within 5e-4 A of ngspice). Unknowns of index 0 and 1
are tested as usual. Index 3 and higher is refused: the BDF does not
converge there.

Starting and restarting
-----------------------
At t0 and after every breakpoint the method restarts at order 1. The
derivative from the right, x'(t+), is measured by an implicit-Euler *probe*
of a tiny step ``eps`` (one factorisation of ``dq/eps - dphi``, one solve),
and x''(t+) by a second probe step with the same factorisation; the first
step is then ``sqrt(2 * 0.25 / |x''|_w)`` (a quarter of the tolerance for
the order-1 local error ``h^2/2 x''``), capped by 0.001 of the distance to the
next breakpoint at t0 (IDA's cap) and by the last step size at a
breakpoint. A caller-given ``xp0`` replaces the probe at t0 and then IDA's
first-order rule ``h |x'(t0)|_w <= 1/2`` bounds the first step. The probes
make the first error estimates after a corner of the input meaningful (with
the derivative from the left, every unknown whose slope jumps would look
like an error of order ``h``).

Breakpoints
-----------
Steps land exactly on every breakpoint (the system's, the caller's and
``t_bound``), never step across one, stretch a step by up to 10 % or split
the rest of an interval in two equal steps rather than leave a sliver.
Inputs must be continuous at breakpoints (their derivatives may jump); a
jump of an input *value* needs new consistent initial values (a new call).

Linear systems
--------------
For ``system.linear`` the corrector is solved exactly by one solve with the
factorisation of ``cj E - H``, which is refactored exactly when ``cj``
changes: the number of factorisations is at most the number of changes of
``cj`` plus one per probe (restart). The residual is one matrix-vector
product ``E x'_pred - H x_pred`` (dense below 48 unknowns, where numpy beats
the sparse call overhead) and one call of ``system.source(t)``.

References
----------
.. [1] K. E. Brenan, S. L. Campbell, L. R. Petzold, *Numerical Solution of
   Initial-Value Problems in Differential-Algebraic Equations*, SIAM 1996,
   Chapters 3 and 5.
.. [2] L. R. Petzold, A description of DASSL: a differential/algebraic system
   solver, in *Scientific Computing*, North-Holland 1983, 65-68.
.. [3] A. C. Hindmarsh et al., SUNDIALS: Suite of nonlinear and
   differential/algebraic equation solvers, *ACM TOMS* 31 (2005) 363-396;
   IDA source ``src/ida/ida.c``.
.. [4] L. F. Shampine, M. W. Reichelt, The MATLAB ODE suite, *SIAM J. Sci.
   Comput.* 18 (1997) 1-22.
.. [5] K. R. Jackson, R. Sacks-Davis, An alternative implementation of
   variable step-size multistep formulas for stiff ODEs, *ACM TOMS* 6 (1980)
   295-318.
.. [6] E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II*,
   Springer 1996, Section VII.3 (error control of index-2 components).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import scipy.sparse as sp

from ..errors import ConvergenceError
from ..results import STATUS_FAILED, STATUS_OK
from .bdf_kernels import (
    differences_from_samples,
    error_norms,
    flc_coefficients,
    landing_step,
    max_norm,
    merge_breakpoints,
    predictor_weights,
    update_differences,
    wrms,
)
from .dense import Interpolant
from .newton import (
    DEFAULT_PERMC_SPEC,
    INFO_EVALUATION,
    INFO_NONFINITE,
    INFO_SINGULAR,
    LuCache,
    newton,
)
from .steady import SteadyOptions, solve_steady
from .system import KIND_CURRENT, KIND_VOLTAGE, DaeSystem, Evaluation

__all__ = ["BDF", "ImplicitEulerStep", "IntegrationResult", "integrate", "check_arguments", "absolute_tolerances",
           "index_mask", "save_indices"]

#: With relref="mixed" the relative tolerance refers to at least this fraction
#: of the largest magnitude the unknown has had.
MIXED_FLOOR = 0.1
#: Highest order (BDF6 and beyond are not zero-stable).
MAX_ORDER = 5
#: Newton iterations per step (IDA's maxcor).
NEWTON_MAXITER = 4
#: Newton convergence tolerance as a fraction of the error-test bound 1 (IDA's EPCON).
EPCON = 0.33
#: Contraction rate assumed right after a factorisation: rate/(1-rate) = 20 (IDA).
RATE_AFTER_SETUP = 20.0 / 21.0
#: Rate assumed when cj changed but the old factorisation is reused: rate/(1-rate) = 100 (IDA).
RATE_CJ_CHANGED = 100.0 / 101.0
#: A nonlinear system keeps its factorisation while cj/cj_lu stays in
#: [(1-DCJ)/(1+DCJ), (1+DCJ)/(1-DCJ)] = [0.6, 1.67] (IDA's dcj).
DCJ = 0.25
#: The step grows only when the error allows at least this factor (IDA's eta_max_fx) ...
ETA_GROW_MIN = 2.0
#: ... and then by at most this factor (IDA's eta_max).
ETA_GROW_MAX = 2.0
#: After an accepted step the step shrinks when the error asks for a factor <= 1,
#: to between ETA_SHRINK_MIN and ETA_SHRINK_MAX of its size (IDA's eta_min, eta_low).
ETA_SHRINK_MIN = 0.5
ETA_SHRINK_MAX = 0.9
#: Smallest reduction after an error-test failure (IDA's eta_min_ef) ...
ETA_ERROR_FAIL_MIN = 0.25
#: ... and the reduction after a Newton failure (IDA's eta_cf).
ETA_NEWTON_FAIL = 0.25
#: Safety factor of the step-size formula after an error-test failure.
ETA_SAFETY = 0.9
#: Small term keeping the step-size formula finite for a zero error estimate (IDA).
ERROR_FLOOR = 1e-4
#: Failures allowed within one step before giving up (IDA's maxncf, maxnef).
MAX_NEWTON_FAILURES = 10
MAX_ERROR_FAILURES = 10
#: First step at t0: at most this fraction of the distance to the first breakpoint (IDA's 0.001 * tout).
H0_FRACTION = 1e-3
#: The first order-1 step aims at this fraction of the error-test bound.
H0_ERROR_TARGET = 0.25
#: With a caller-given x'(t0): h |x'(t0)|_w <= H0_DERIVATIVE_BOUND (IDA's first-order rule).
H0_DERIVATIVE_BOUND = 0.5
#: The implicit-Euler probe for the (re)start derivatives uses this fraction of the step cap ...
PROBE_FRACTION = 1e-3
#: ... and is repeated (at most PROBE_RETRIES times) when the step came out smaller
#: than probe / PROBE_MAX_RATIO (its error estimate needs probe << step).
PROBE_MAX_RATIO = 0.02
PROBE_RETRIES = 3
#: At a (re)start the right limit x(t+) is measured by the probe (two implicit-Euler
#: steps of size eps, extrapolated to eps = 0). An unknown whose right limit differs
#: from the value reached by more than JUMP_DETECT tolerances (weighted, with the
#: tolerances raised to the rounding level of the probe) means the inputs jumped, an
#: index-2 unknown jumped at a corner, or the start is inconsistent: the method
#: restarts from the right limit.
JUMP_DETECT = 1.0
#: Newton iterations allowed for each implicit-Euler step of the right-limit solve.
JUMP_NEWTON_MAXITER = 25
#: A step may be stretched by this fraction to land on a breakpoint.
BREAKPOINT_STRETCH = 0.1
#: Breakpoints closer than this fraction of the interval are merged (no sliver steps).
BREAKPOINT_MERGE = 1e-9
#: A step smaller than this many ulps of t cannot advance time.
ROUNDOFF_ULPS = 16.0
#: The corrector residual ``cj (q(x) - q_pred) + q'_pred - phi`` is computed with an
#: absolute error of about ``eps (cj |dq/dx| |x| + |q'_pred|)`` per row; a tolerance
#: below this many times that level, propagated to the unknowns, is not attainable
#: and is raised to it (see ``BDF._rounding_weights``).
ROUNDING_FACTOR = 10.0
EPS = float(np.finfo(float).eps)
#: Linear systems up to this size form their residual with a dense matrix-vector product.
DENSE_MATVEC_MAX = 48
#: Initial capacity of the output buffers (they double when full).
BUFFER_START = 1024
#: Least wall time between two progress callbacks [s].
PROGRESS_INTERVAL = 0.1


class ImplicitEulerStep(DaeSystem):
    """One implicit-Euler step as a steady-state problem: ``phi(x, t) - (q(x) - q0)/h = 0``.

    Parameters
    ----------
    system : DaeSystem
    q0 : ndarray, shape (n,)
        Charges at the start of the step.
    h : float
        Step size.
    t : float
        Time at which the inputs are taken (whatever time the solver passes).

    Notes
    -----
    Used for consistent values after a jump of the inputs (:class:`BDF`) and
    for a ``uic`` start (:mod:`netdae.analyses.tran`): as ``h -> 0`` the
    solution keeps the charges ``q0`` and satisfies the algebraic equations
    at ``t``.
    """

    def __init__(self, system: DaeSystem, q0, h: float, t: float):
        self.inner = system
        self.q0, self.h, self.t = q0, h, t
        self.n, self.names, self.kinds, self.pattern = system.n, system.names, system.kinds, system.pattern
        self.linear = system.linear

    def evaluate(self, x, t, *, jacobian=True, state=None, source_scale=1.0):
        ev = self.inner.evaluate(x, self.t, jacobian=jacobian, state=state, source_scale=source_scale)
        return Evaluation(
            q=ev.q, phi=ev.phi - (ev.q - self.q0) / self.h,
            dq=ev.dq, dphi=None if ev.dphi is None else ev.dphi - ev.dq / self.h,
            limited=ev.limited, state=ev.state, ok=ev.ok,
        )

    def initial_state(self):
        return self.inner.initial_state() if hasattr(self.inner, "initial_state") else None


def check_arguments(t0: float, t_bound: float, x0, n: int, *, rtol: float, maxord: int, norm: str, relref: str,
                    max_step: float, min_step: float, first_step) -> np.ndarray:
    """Validate the integrator's arguments; returns ``x0`` as a float array.

    Raises
    ------
    ValueError
        Naming the argument that is out of range.
    """
    if not (math.isfinite(t0) and math.isfinite(t_bound)) or t_bound <= t0:
        raise ValueError(f"need finite t0 < t_bound, got t0={t0!r}, t_bound={t_bound!r}")
    x0 = np.array(x0, dtype=float)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite array of shape ({n},)")
    if not (0.0 < rtol < 1.0):
        raise ValueError(f"rtol must lie in (0, 1), got {rtol!r}")
    if not (1 <= int(maxord) <= MAX_ORDER):
        raise ValueError(f"maxord must be 1..{MAX_ORDER}, got {maxord!r}")
    if norm not in ("rms", "max"):
        raise ValueError("norm must be 'rms' or 'max'")
    if relref not in ("local", "signal", "mixed"):
        raise ValueError("relref must be 'local', 'signal' or 'mixed'")
    if not (max_step > 0.0) or min_step < 0.0 or min_step > max_step:
        raise ValueError("need 0 <= min_step <= max_step and max_step > 0")
    if first_step is not None and not (first_step > 0.0):
        raise ValueError("first_step must be positive")
    return x0


def absolute_tolerances(kinds, n: int, atol, vntol: float, abstol: float) -> tuple[np.ndarray, Any]:
    """Per-unknown absolute tolerances and their label for reports.

    ``atol`` is one value per unknown, or a scalar for ``KIND_OTHER`` unknowns
    (voltages then take ``vntol``, currents ``abstol``).

    Raises
    ------
    ValueError
    """
    a = np.asarray(atol, dtype=float)
    if a.ndim == 1:
        if a.shape != (n,):
            raise ValueError(f"atol must be a scalar or have shape ({n},)")
        vec, label = a.copy(), "per-unknown"
    elif a.ndim == 0:
        kinds = np.asarray(kinds)
        vec = np.where(kinds == KIND_VOLTAGE, float(vntol), np.where(kinds == KIND_CURRENT, float(abstol), float(a)))
        label = float(a)
    else:
        raise ValueError("atol must be a scalar or a 1-D array")
    if np.any(~np.isfinite(vec)) or np.any(vec <= 0.0):
        raise ValueError("absolute tolerances must be positive and finite")
    return vec, label


def index_mask(names, n: int, index, norm: str) -> tuple[np.ndarray, np.ndarray | None, int]:
    """Which unknowns are index 2, and the factor that leaves them out of the error test.

    Returns
    -------
    (high, factor, excluded)
        ``high`` bool (n,); ``factor`` (n,) multiplying the error weights, or
        None when every unknown is tested (with "rms" the RMS is over the
        tested unknowns only); the number of unknowns left out.

    Raises
    ------
    ValueError
        For a malformed ``index`` or an index of 3 or more.
    """
    high = np.zeros(n, dtype=bool)
    if index is None:
        return high, None, 0
    idx = np.asarray(index)
    if idx.shape != (n,) or idx.dtype.kind not in "iu" or np.any(idx < 0):
        raise ValueError(f"index must be a non-negative integer array of shape ({n},)")
    if np.any(idx > 2):
        worst = names[int(np.argmax(idx))]
        raise ValueError(
            f"unknown {worst} has index {int(idx.max())}: the BDF method does not converge for "
            "index >= 3; solve such (linear) problems through their decoupled (Weierstrass) form"
        )
    high = idx >= 2
    tested = int(np.count_nonzero(~high))
    if tested == n:
        return high, None, 0
    factor = (~high).astype(float)
    if tested == 0:
        # every unknown is a derivative of the inputs (a source driving only
        # capacitors): nothing to error-test, the steps follow max_step and
        # the breakpoints
        return high, factor, n
    if norm == "rms":
        # the RMS over the tested unknowns only: sqrt(sum_tested (e w)^2 / tested)
        factor *= math.sqrt(n / tested)
    return high, factor, n - tested


def save_indices(n: int, save) -> np.ndarray:
    """Positions of the unknowns to record (all when ``save`` is None).

    Raises
    ------
    ValueError
    """
    if save is None:
        return np.arange(n, dtype=np.int64)
    s = np.asarray(save)
    if s.ndim != 1 or s.dtype.kind not in "iu" or (s.size and (s.min() < 0 or s.max() >= n)):
        raise ValueError(f"save must be a 1-D integer array of unknown positions in [0, {n})")
    return s.astype(np.int64)


def right_limit(system: DaeSystem, t: float, x, eps: float, high, rtol: float, vntol: float, abstol: float, *,
                state=None) -> tuple[np.ndarray | None, int, int, str]:
    """x(t+) of a nonlinear system: two converged implicit-Euler steps of size eps, extrapolated.

    The charges are continuous across t (no impulse), so the steps start from
    ``q(x)``; the inputs are those right of t. Each step is solved by the
    steady-state solver (damped Newton with device limiting, then gmin and
    source stepping): after a jump of the inputs the start can be far from
    the solution (a diode switched on by a step). Index-2 unknowns (``high``)
    take the second step's value (they carry an impulse in the first).

    Returns
    -------
    (x_right, iterations, evaluations, message)
        ``x_right`` is None when a step did not converge (``message`` says why).
    """
    opts = SteadyOptions(reltol=rtol, vntol=vntol, abstol=abstol, judge_singular=False)
    iterations = 0
    evaluations = 0
    y = np.asarray(x, dtype=float)
    ys = []
    for step in (1, 2):
        q0 = system.evaluate(y, t + (step - 1) * eps, jacobian=False, state=state).q
        evaluations += 1
        res = solve_steady(ImplicitEulerStep(system, q0, eps, t + step * eps), t + step * eps, y, options=opts)
        iterations += res.iterations
        evaluations += res.iterations
        if not res.converged:
            return None, iterations, evaluations, ("the inputs jump at t, and no values consistent with them "
                                                   f"right of it were found ({res.message})")
        y = res.x
        ys.append(y)
    out = 2.0 * ys[0] - ys[1]
    high = np.asarray(high, dtype=bool)
    out[high] = ys[1][high]
    return out, iterations, evaluations, ""


@dataclass
class IntegrationResult:
    """Output of :func:`integrate` (and of :meth:`BDF.result`).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Accepted step times, ``t[0] = t0``.
    x : ndarray, shape (m, ns)
        Saved components at those times.
    order : ndarray of int8, shape (m,)
        Order of the step ending at each time (0 at t0).
    names : tuple of str, length ns
        Names of the saved components.
    save : ndarray of int, shape (ns,)
        Their positions among the unknowns.
    dense : Interpolant
        ``dense(t, components=None) -> ndarray (p, nc)``: the method's
        interpolant anywhere in ``[t[0], t[-1]]``.
    stats : dict
        ``steps``, ``rejected`` (error-test failures), ``newton_iterations``,
        ``newton_failures``, ``factorizations``, ``evaluations``,
        ``jacobian_evaluations``, ``cj_changes`` (changes of the Newton-matrix
        coefficient between attempts), ``restarts``, ``probes`` (derivative
        probes at the start and at restarts, one factorisation each),
        ``max_order_used``, ``h_min``, ``h_max``, ``wall_time`` [s].
    status : int
        0 on success, -1 on failure (``netdae.results`` conventions).
    message : str
        What happened; on failure with t, h, the worst unknown and a hint.
    tolerances : dict
        ``rtol``, ``vntol``, ``abstol``, ``atol`` (or ``"per-unknown"``),
        ``norm``, ``relref``, ``newton_tol``, ``index_excluded`` (number of
        unknowns left out of the error test), ``maxord``.
    failure : dict or None
        ``t``, ``h``, ``worst``, ``hint``, ``what`` of a failure.
    restarts : ndarray, shape (r,)
        Breakpoints at which the method restarted at order 1.
    jumps : list of (float, tuple of str)
        Times at which the solution jumped (an input value or an index-2
        unknown at a corner of the inputs, or an inconsistent start) and the
        unknowns that jumped by more than their tolerance. At each such time
        ``t`` holds two equal entries: the value reached from the left, then
        the right limit the method continued from.
    """

    t: np.ndarray
    x: np.ndarray
    order: np.ndarray
    names: tuple
    save: np.ndarray
    dense: Interpolant
    stats: dict
    status: int
    message: str
    tolerances: dict
    failure: dict | None = None
    restarts: np.ndarray = field(default_factory=lambda: np.empty(0))
    jumps: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when the integration reached ``t_bound``."""
        return self.status >= 0

    def __getitem__(self, name: str) -> np.ndarray:
        """Waveform of the saved component called ``name`` (case-insensitive)."""
        key = name.lower()
        for i, nm in enumerate(self.names):
            if nm.lower() == key:
                return self.x[:, i]
        raise KeyError(f"no saved component {name!r}")


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
    status : {"running", "finished", "failed"}
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
        self._normf = max_norm if norm == "max" else wrms
        self.newton_maxiter = int(newton_maxiter)
        self.max_steps = max_steps
        self._linear = bool(getattr(system, "linear", False))

        self._atol, atol_label = absolute_tolerances(system.kinds, n, atol, vntol, abstol)
        self._tolerances = {
            "rtol": self.rtol, "vntol": float(vntol), "abstol": float(abstol), "atol": atol_label,
            "norm": norm, "relref": relref, "newton_tol": EPCON, "maxord": self.maxord,
        }
        self._high, self._mask_factor, self._tolerances["index_excluded"] = index_mask(system.names, n, index,
                                                                                         norm)
        self._save = save_indices(n, save)
        self._save_all = save is None
        extra = [np.asarray(system.breakpoints(self.t0, self.t_bound), dtype=float).ravel()]
        if breakpoints is not None:
            extra.append(np.asarray(breakpoints, dtype=float).ravel())
        self._breakpoints = merge_breakpoints(self.t0, self.t_bound, np.concatenate(extra),
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

        # state of the method: P holds the differences of x (and of q for a nonlinear system)
        self._width = n if self._linear else 2 * n
        self._P = np.zeros((self.maxord + 1, self._width))
        self._psi = [0.0] * (self.maxord + 1)
        self._psi_saved = self._psi
        self._coef = None
        self._W = None
        self._k = 1
        self._kused = 0
        self._hused = 0.0
        self._ns = 0
        self._phase = 0
        self._nst = 0
        self._cj = 0.0
        self._cjlast = 0.0
        self._last_cj_attempt = None
        self._rate = RATE_AFTER_SETUP
        self._state = None
        self._state_try = None
        self._ee = None
        self.h = 0.0
        self._h_request = 0.0
        self._growth_failed = False
        self._lu = LuCache(system.pattern, permc_spec=permc_spec)
        self._abs_dq = None  # |dq/dx| at the last Jacobian evaluation (a CSC matrix)
        self._noise_signs = None  # fixed +-1 signs and the (n, 2) right-hand sides of the rounding floor
        self._noise_rhs = None
        self._w = np.empty(n)
        self._w_err = np.empty(n)
        self._w_step_err = self._w_err
        self._xmax = np.abs(x0)
        self._failure = None
        self.status = "running"
        self.message = ""
        self.stats = {
            "steps": 0, "rejected": 0, "newton_iterations": 0, "newton_failures": 0,
            "factorizations": 0, "evaluations": 0, "jacobian_evaluations": 0, "cj_changes": 0,
            "restarts": 0, "probes": 0, "max_order_used": 0, "h_min": math.inf, "h_max": 0.0,
            "wall_time": 0.0,
        }
        self._restart_times: list[float] = []
        self._jumps: list[tuple[float, tuple[str, ...]]] = []
        self._segments: list[int] = [0]  # record positions where a restart begins

        self._buf_t = np.empty(BUFFER_START)
        self._buf_k = np.zeros(BUFFER_START, dtype=np.int8)
        self._buf_x = np.empty((BUFFER_START, self._save.size))
        self._m = 0

        self.t = self.t0
        if n == 0:
            # nothing to integrate (a circuit of ideal sources only, or none)
            self._record(self.t0, x0, 0)
            self._record(self.t_bound, x0, 0)
            self.t = self.t_bound
            self.status = "finished"
            self.message = f"reached t={self.t_bound:.9g}: the system has no unknowns"
            return
        self._set_weights(x0)
        ev = self._evaluate(x0, self.t0, jacobian=self._linear)
        if not ev.ok or not np.all(np.isfinite(ev.q)) or not np.all(np.isfinite(ev.phi)):
            raise ValueError(f"the system evaluation at t0={self.t0:g} is not finite (check x0)")
        if self._linear:
            self._setup_linear(ev)
        self._P[0, :n] = x0
        if not self._linear:
            self._P[0, n:] = ev.q
        self._record(self.t0, x0, 0)
        if history is not None:
            self._start_from_history(history, x0)
        else:
            self._start(x0, ev, first_step, xp0)
        self.stats["wall_time"] = time.perf_counter() - wall0

    # ------------------------------------------------------------------ setup
    def _setup_linear(self, ev):
        """Constant E, H of a linear system and the residual operator [-H | E]."""
        pattern = self.system.pattern
        self._e_data = np.array(ev.dq, dtype=float)
        self._h_data = np.array(ev.dphi, dtype=float)
        stacked = sp.hstack([-pattern.matrix(self._h_data), pattern.matrix(self._e_data)]).tocsr()
        self._residual_op = stacked.toarray() if self.n <= DENSE_MATVEC_MAX else stacked

    def _set_weights(self, x):
        w = self._w
        np.abs(x, out=w)
        if self.relref == "signal":
            np.maximum(self._xmax, w, out=self._xmax)
            w[:] = self._xmax
        elif self.relref == "mixed":
            np.maximum(self._xmax, w, out=self._xmax)
            np.maximum(w, MIXED_FLOOR * self._xmax, out=w)
        w *= self.rtol
        w += self._atol
        np.reciprocal(w, out=w)
        if self._mask_factor is None:
            self._w_err = w
        else:
            np.multiply(w, self._mask_factor, out=self._w_err)

    def _evaluate(self, x, t, jacobian=False):
        ev = self.system.evaluate(x, t, jacobian=jacobian, state=self._state)
        self.stats["evaluations"] += 1
        if jacobian:
            self.stats["jacobian_evaluations"] += 1
        return ev

    # --------------------------------------------------------------- (re)start
    def _start(self, x0, ev0, first_step, xp0):
        """Derivatives and first step at t0 (order 1)."""
        cap = min(H0_FRACTION * (self._breakpoints[0] - self.t0), self.max_step)
        if self._fixed:
            probe = self._probe_or_fail(self.t0, x0, PROBE_FRACTION * self._fixed_h)
            if probe is not None:
                self._initialise_history(self._fixed_h, probe[0], probe[1])
            return
        if xp0 is not None:
            xp = np.array(xp0, dtype=float)
            if xp.shape != (self.n,) or not np.all(np.isfinite(xp)):
                raise ValueError(f"xp0 must be a finite array of shape ({self.n},)")
            h = first_step
            if h is None:
                ypnorm = self._normf(xp, self._w_err)
                h = cap if ypnorm * cap <= H0_DERIVATIVE_BOUND else H0_DERIVATIVE_BOUND / ypnorm
            self._initialise_history(max(h, self.min_step), xp, ev0.phi)
            return
        h = first_step if first_step is not None else cap
        self._restart_at(x0, h, fixed=first_step is not None)

    def _restart_at(self, x, cap, fixed=False):
        """Probe the derivatives at (t, x) and start at order 1 with a step <= cap.

        The first probe also measures the right limit x(t+); where it differs
        from ``x`` (the inputs jumped at t, an index-2 unknown jumped at a
        corner, or the start is inconsistent) the method continues from the
        right limit (:meth:`_jump`).
        """
        h = cap
        checked = False
        retries = 0
        while True:
            eps = PROBE_FRACTION * h
            probe = self._probe_or_fail(self.t, x, eps)
            if probe is None:
                return
            xp, qp, xpp, x_right, w_floor = probe
            if not checked:
                checked = True
                jump = self._jump(x, x_right, w_floor, eps)
                if jump is None:
                    return
                x, again = jump
                if again:
                    continue  # derivatives from the right limit
            if fixed:
                break
            curv = self._normf(xpp, self._w_err)
            h_new = cap if curv * cap * cap <= 2.0 * H0_ERROR_TARGET else math.sqrt(2.0 * H0_ERROR_TARGET / curv)
            h_new = max(h_new, self.min_step)
            converged = eps <= PROBE_MAX_RATIO * h_new
            h = h_new
            retries += 1
            if converged or retries >= PROBE_RETRIES:
                break
        self._initialise_history(h, xp, qp)

    def _probe_or_fail(self, t, x, eps):
        """x'(t+), q'(t+), x''(t+) and the right limit x(t+) from two implicit-Euler steps of size ``eps``.

        Each step is one Newton iteration (exact for a linear system; for a
        nonlinear one the residual at a consistent x is O(eps)). The right
        limit is the extrapolation of the two steps to eps = 0,
        ``2 x_1 - x_2`` (error O(eps^2)), returned with ``x_2`` (for index-2
        unknowns, which carry an impulse in ``x_1`` when an input value
        jumps: :meth:`_jump` chooses). Also returns the
        weights with every tolerance raised to the rounding level of the
        probe (``1/eps`` times the charges' rounding error), against which a
        jump is judged.

        Returns None after recording a failure when the Newton matrix is singular or
        the evaluation is not finite.
        """
        self.stats["probes"] += 1
        ev = self._evaluate(x, t + eps, jacobian=True)
        if not ev.ok or not np.all(np.isfinite(ev.phi)):
            self._fail(t, eps, "the system evaluation right after t is not finite", self._nonfinite_worst(ev),
                       "the model is undefined at the initial/restart point")
            return None
        if not self._lu.factor(ev.dq / eps - ev.dphi, tag=1.0 / eps):
            self._fail(t, eps, "the Newton matrix (alpha/h) dq/dx - dphi/dx is singular", None,
                       self._newton_hint(INFO_SINGULAR))
            return None
        self._keep_abs_dq(ev.dq)
        xp = self._lu.solve(ev.phi) / eps
        x1 = x + eps * xp
        ev1 = self._evaluate(x1, t + 2.0 * eps)
        xp1 = self._lu.solve(ev1.phi) / eps if ev1.ok else xp
        xpp = (xp1 - xp) / eps
        if not (np.all(np.isfinite(xp)) and np.all(np.isfinite(xpp))):
            self._fail(t, eps, "the derivative estimate at the (re)start is not finite", None,
                       self._newton_hint(INFO_SINGULAR))
            return None
        x_right = (x1 - eps * xp1, x1 + eps * xp1)
        w_floor = self._rounding_weights(x, np.asarray(ev.phi, dtype=float), 1.0 / eps)
        xp[self._high] = 0.0
        xpp[self._high] = 0.0
        return xp, np.array(ev.phi, dtype=float), xpp, x_right, w_floor

    def _jump(self, x, x_right, w_floor, eps):
        """Continue from the right limit where it differs from ``x``.

        Returns ``(x_new, reprobe)``, or None after recording a failure.
        ``x_new`` is ``x`` itself when nothing jumped. Otherwise every
        unknown takes its right limit (a partial replacement would break the
        algebraic relations between them), the point ``(t, x_new)`` is recorded a second time (the left
        and the right value at the same t, so the dense output never
        interpolates across the jump) and ``reprobe`` says whether the
        derivatives must be measured again (an unknown that is not index 2
        jumped: the inputs' values jumped or the start was inconsistent). For
        a nonlinear system the right limit is then recomputed by converged
        Newton iterations (the one-iteration probe is accurate only near a
        consistent point).
        """
        n = self.n
        x_right, x_2 = x_right
        moved = np.abs(x_right - x) * w_floor
        if not moved.max() > JUMP_DETECT:
            return x, False
        value_jump = bool(np.any(moved[~self._high] > JUMP_DETECT))
        if value_jump:
            # an input value jumped: the index-2 unknowns carry an impulse in the first
            # probe step, their right limit is the value after the second
            x_right[self._high] = x_2[self._high]
            if not self._linear:
                x_right = self._right_limit(x, eps)
                if x_right is None:
                    return None
            moved = np.abs(x_right - x) * w_floor
        # every unknown takes its right limit: replacing only those that moved much would
        # break the algebraic relations between them (differential unknowns move by
        # O(eps^2) only)
        x_new = x_right
        names = tuple(self.system.names[i] for i in np.flatnonzero(moved > JUMP_DETECT))
        self._jumps.append((float(self.t), names))
        self._P[0, :n] = x_new
        if not self._linear:
            ev = self._evaluate(x_new, self.t)
            self._P[0, n:] = ev.q
        self._set_weights(x_new)
        self._record(self.t, x_new, 0)
        self._segments.append(self._m - 1)
        return x_new, value_jump

    def _right_limit(self, x, eps):
        """x(t+) of a nonlinear system (:func:`right_limit`); None after recording a failure."""
        tol = self._tolerances
        out, iterations, evaluations, message = right_limit(self.system, self.t, x, eps, self._high, self.rtol,
                                                            tol["vntol"], tol["abstol"], state=self._state)
        self.stats["newton_iterations"] += iterations
        self.stats["evaluations"] += evaluations
        if out is None:
            self._fail(self.t, eps, message, None, self._newton_hint(None))
        return out

    def _initialise_history(self, h, xp, qp):
        n = self.n
        self._P[1:] = 0.0
        self._P[1, :n] = h * xp
        if not self._linear:
            self._P[1, n:] = h * qp
        self._psi[0] = h
        self._k = 1
        self._kused = 0
        self._hused = 0.0
        self._ns = 0
        self._phase = 0
        self._nst = 0
        self._cj = 1.0 / h
        self._coef = None
        self._rate = RATE_AFTER_SETUP
        self._growth_failed = False
        self.h = h

    def _start_from_history(self, history, x0):
        t_hist, x_hist = history
        t_hist = np.asarray(t_hist, dtype=float)
        x_hist = np.asarray(x_hist, dtype=float)
        k = t_hist.size - 1
        n = self.n
        if not (1 <= k <= self.maxord) or x_hist.shape != (k + 1, n):
            raise ValueError(f"history needs 2..{self.maxord + 1} times and values of shape (times, {n})")
        steps = np.diff(t_hist)
        h = float(steps[0])
        if h <= 0.0 or not np.allclose(steps, h, rtol=1e-10, atol=0.0) or t_hist[-1] != self.t0:
            raise ValueError("history times must be equally spaced, increasing and end at t0")
        if not np.array_equal(x_hist[-1], x0):
            raise ValueError("the last history value must equal x0")
        if self._fixed and (k != self._fixed_order or not math.isclose(h, self._fixed_h, rel_tol=1e-10)):
            raise ValueError("history must have fixed_order + 1 points spaced by fixed_step")
        self._P[: k + 1, :n] = differences_from_samples(x_hist)
        if not self._linear:
            q_hist = np.array([self._evaluate(x_hist[i], t_hist[i]).q for i in range(k + 1)])
            self._P[: k + 1, n:] = differences_from_samples(q_hist)
        self._psi = [(i + 1) * h for i in range(self.maxord + 1)]
        self._k = self._kused = k
        self._hused = h
        self._ns = 0
        self._phase = 1
        self._nst = k
        self.h = h

    # ------------------------------------------------------------- properties
    @property
    def x(self) -> np.ndarray:
        """Current solution (a copy), shape (n,)."""
        return self._P[0, : self.n].copy()

    @property
    def order(self) -> int:
        """Order of the next step."""
        return self._k

    # ------------------------------------------------------------------- step
    def step(self) -> str | None:
        """Advance by one accepted step.

        Returns
        -------
        str or None
            ``None`` on success, the failure message otherwise (then
            ``status == "failed"``).

        Raises
        ------
        RuntimeError
            When called after the integration finished or failed.
        """
        if self.status != "running":
            raise RuntimeError(f"the integration is {self.status}; no further steps")
        wall = time.perf_counter()
        self._step_impl()
        self.stats["wall_time"] += time.perf_counter() - wall
        return self.message if self.status == "failed" else None

    def _step_impl(self):
        """One step: the attempt loop of IDA's IDAStep."""
        ncf = nef = 0
        t = self.t
        h = self._fixed_h if self._fixed else self.h
        while True:
            self._h_request = h
            h, landing = landing_step(min(h, self.max_step), self._breakpoints[self._ibp] - t,
                                      BREAKPOINT_STRETCH, not self._fixed)
            self._set_coefficients(h)
            t_new = self._breakpoints[self._ibp] if landing else t + h
            accepted, kind, info = self._attempt(t_new)
            if accepted:
                break
            self._restore()
            self._phase = 1
            if kind == "newton":
                ncf += 1
                self.stats["newton_failures"] += 1
                eta = self._newton_failure(t, h, ncf, info)
            else:
                nef += 1
                self.stats["rejected"] += 1
                if h > self._hused:
                    self._growth_failed = True
                eta = self._error_failure(t, h, nef, info)
            if eta is None:
                return
            h_new = self._reduced_step(t, h, eta, kind, info)
            if h_new is None:
                return
            if self._nst == 0:
                # first step after a (re)start: rescale the derivative term (IDA's IDAReset)
                self._psi[0] = h_new
                self._P[1] *= h_new / h
            h = h_new
        self._complete_step(t_new, h, landing, info, ncf + nef > 0)

    def _newton_failure(self, t, h, ncf, info):
        """Step-size factor after a Newton failure, or None after recording a final failure."""
        reason = info["info"]
        if self._fixed:
            self._fail(t, h, f"Newton iteration failed in fixed-step mode ({reason})", info.get("worst"),
                       "fixed-step mode cannot reduce the step; choose a smaller fixed_step")
            return None
        if ncf >= MAX_NEWTON_FAILURES:
            self._fail(t, h, f"Newton iteration failed {ncf} times ({reason})", info.get("worst"),
                       self._newton_hint(reason))
            return None
        return ETA_NEWTON_FAIL

    def _error_failure(self, t, h, nef, info):
        """Step-size factor (and new order) after an error-test failure (IDA's IDAHandleNFlag)."""
        if nef >= MAX_ERROR_FAILURES:
            self._fail(t, h, f"error test failed {nef} times", info.get("worst"), self._error_hint())
            return None
        knew = info["knew"]
        if nef == 1:
            err_knew = info["err_k"] if knew == self._k else info["err_km1"]
            self._k = knew
            eta = ETA_SAFETY * (2.0 * err_knew + ERROR_FLOOR) ** (-1.0 / (knew + 1))
            return max(ETA_ERROR_FAIL_MIN, min(ETA_SHRINK_MAX, eta))
        self._k = knew if nef == 2 else 1
        return ETA_ERROR_FAIL_MIN

    def _reduced_step(self, t, h, eta, kind, info):
        """``h * eta`` bounded by min_step and roundoff, or None after recording a failure."""
        h_new = h * eta
        worst = info.get("worst")
        if h_new < self.min_step:
            if h > self.min_step * (1.0 + 1e-12):
                return self.min_step
            what = (f"step size {h:.3g} at min_step {self.min_step:.3g} and the "
                    + ("Newton iteration fails" if kind == "newton" else "error test fails"))
            hint = self._newton_hint(info.get("info")) if kind == "newton" else self._error_hint()
            self._fail(t, h, what, worst, hint)
            return None
        if h_new <= ROUNDOFF_ULPS * np.spacing(abs(t)) or t + h_new == t:
            what = "step size below the roundoff of t (" + ("Newton failures" if kind == "newton" else
                                                             "error-test failures") + ")"
            hint = self._newton_hint(info.get("info")) if kind == "newton" else self._error_hint()
            self._fail(t, h, what, worst, hint)
            return None
        return h_new

    def _set_coefficients(self, h):
        """Phase 1: coefficients of the step and the predicted differences phi* (IDASetCoeffs)."""
        k = self._k
        if h != self._hused or k != self._kused:
            self._ns = 0
        self._ns = min(self._ns + 1, self._kused + 2)
        self._psi_saved = list(self._psi)
        if k + 1 >= self._ns or self._coef is None:
            c = flc_coefficients(h, k, self._psi)
            self._psi[: k + 1] = c.psi
            self._coef = c
            self._W = predictor_weights(c.gamma, k)
        self._cjlast = self._cj
        self._cj = self._coef.cj
        if self._ns <= k:
            self._P[self._ns : k + 1] *= np.asarray(self._coef.beta[self._ns : k + 1])[:, None]

    def _restore(self):
        """Undo phase 1 after a failed attempt (IDA's IDARestore)."""
        k = self._k
        self._psi = self._psi_saved
        if self._ns <= k:
            self._P[self._ns : k + 1] /= np.asarray(self._coef.beta[self._ns : k + 1])[:, None]
        self._coef = None

    def _attempt(self, t_new):
        """Phases 2-4: predict, solve the corrector, test the error.

        Returns
        -------
        (accepted, kind, info)
            ``kind`` is ``"newton"`` or ``"error"`` for a failure; ``info`` holds
            the order proposal and error norms, or the failure details.
        """
        n = self.n
        k = self._k
        pred = self._W @ self._P[: k + 1]
        cj = self._cj
        if cj != self._last_cj_attempt:
            self.stats["cj_changes"] += 1
            self._last_cj_attempt = cj
        self._w_step_err = self._w_err
        if self._linear:
            x_new = self._corrector_linear(t_new, pred, cj)
            if x_new is None:
                return False, "newton", self._linear_failure
            ee = x_new - pred[0]
        else:
            ok, out = self._corrector_nonlinear(t_new, pred, cj)
            if not ok:
                return False, "newton", out
            x_new, q_new = out
            ee = np.empty(2 * n)
            np.subtract(x_new, pred[0, :n], out=ee[:n])
            np.subtract(q_new, pred[0, n:], out=ee[n:])
        self._ee = ee
        if self._fixed:
            return True, "", {"knew": k, "err_k": 0.0, "err_km1": 0.0}
        return self._error_test(ee[:n], k)

    def _error_test(self, ee_x, k):
        """Phase 4: local error test and order-lowering proposal (IDA's IDATestError)."""
        c = self._coef
        norms = error_norms(ee_x, self._P[:, : self.n], k, self._w_step_err, self.norm)
        enorm_k = norms[0]
        err_k = c.sigma[k] * enorm_k
        terr_k = (k + 1) * err_k
        knew = k
        err_km1 = 0.0
        if k > 1:
            err_km1 = c.sigma[k - 1] * norms[1]
            terr_km1 = k * err_km1
            if k > 2:
                terr_km2 = (k - 1) * c.sigma[k - 2] * norms[2]
                if max(terr_km1, terr_km2) <= terr_k:
                    knew = k - 1
            elif terr_km1 <= 0.5 * terr_k:
                knew = k - 1
        info = {"knew": knew, "err_k": err_k, "err_km1": err_km1}
        if c.ck * enorm_k <= 1.0:
            return True, "", info
        if not math.isfinite(enorm_k):
            return False, "newton", {"info": INFO_NONFINITE, "worst": self._worst(ee_x, self._w)}
        info["worst"] = self._worst(ee_x, self._w_err)
        return False, "error", info

    def _corrector_linear(self, t_new, pred, cj):
        """Phase 3 for a linear system: one exact solve with the factorisation of cj E - H.

        Returns x_{n+1}, or None (with ``self._linear_failure`` set).
        """
        lu = self._lu
        if lu.tag != cj:
            if not lu.factor(cj * self._e_data - self._h_data, tag=cj):
                self._linear_failure = {"info": INFO_SINGULAR, "worst": None}
                return None
        # residual E x'_pred - phi(x_pred) = [-H | E] (x_pred, x'_pred) - c(t)
        r = self._residual_op @ pred.reshape(-1)
        r -= self.system.source(t_new)
        d = lu.solve(r)
        st = self.stats
        st["evaluations"] += 1
        st["newton_iterations"] += 1
        st["factorizations"] = lu.factorizations
        x_new = pred[0] - d
        if self._fixed and not np.all(np.isfinite(x_new)):
            self._linear_failure = {"info": INFO_NONFINITE, "worst": self._worst(d, self._w)}
            return None
        # otherwise a non-finite solution shows in the error norm (NaN propagates through
        # the weights, also the zero weights of untested unknowns)
        return x_new

    def _corrector_nonlinear(self, t_new, pred, cj):
        """Phase 3 for a nonlinear system: modified Newton on the charge-form corrector.

        Returns (True, (x_new, q_new)) or (False, failure info).
        """
        n = self.n
        x_pred = pred[0, :n]
        q_pred = pred[0, n:]
        qp_pred = pred[1, n:]
        system = self.system
        st = self.stats
        last = {}

        def fun(x, jacobian):
            ev = system.evaluate(x, t_new, jacobian=jacobian, state=self._state_try)
            st["evaluations"] += 1
            self._state_try = ev.state
            last["ev"] = ev
            last["x"] = x
            if jacobian:
                self._keep_abs_dq(ev.dq)
            r = ev.q - q_pred
            r *= cj
            r += qp_pred
            r -= ev.phi
            if not jacobian:
                return r, None, ev.ok, ev.limited
            st["jacobian_evaluations"] += 1
            return r, cj * ev.dq - ev.dphi, ev.ok, ev.limited

        lu = self._lu
        self._state_try = self._state
        setup = (not lu.ready) or self._nst == 0
        if not setup:
            ratio = cj / lu.tag
            setup = ratio < (1.0 - DCJ) / (1.0 + DCJ) or ratio > (1.0 + DCJ) / (1.0 - DCJ)
        w_newton = self._rounding_weights(x_pred, qp_pred, cj)
        res = self._newton(fun, x_pred, cj, setup, w_newton)
        if not res.converged and not setup and res.info != INFO_EVALUATION:
            # stale Jacobian: retry once with a fresh one at the same step size
            st["newton_failures"] += 1
            st["newton_iterations"] += res.iterations
            self._state_try = self._state
            res = self._newton(fun, x_pred, cj, True, w_newton)
        st["newton_iterations"] += res.iterations
        st["factorizations"] = lu.factorizations
        if not res.converged:
            worst = system.names[res.worst] if res.worst >= 0 else None
            if res.info == INFO_EVALUATION and "ev" in last:
                worst = self._nonfinite_worst(last["ev"]) or worst
            return False, {"info": res.info, "worst": worst}
        self._rate = res.rate
        # The charges at the new point, evaluated exactly (no limiting): the
        # history must hold q(x_new) itself, or every step injects the
        # linearisation error into the charge of floating node groups. One
        # device pass without Jacobian per step.
        ev_new = system.evaluate(res.x, t_new, jacobian=False, state=None)
        st["evaluations"] += 1
        if not ev_new.ok:
            return False, {"info": INFO_EVALUATION, "worst": self._nonfinite_worst(ev_new)}
        return True, (res.x, ev_new.q)

    def _keep_abs_dq(self, dq):
        if self._abs_dq is None:
            self._abs_dq = self.system.pattern.matrix(np.abs(dq))
        else:
            np.abs(dq, out=self._abs_dq.data)

    def _rounding_weights(self, x_pred, qp_pred, cj):
        """Newton and error-test weights with every tolerance raised to the rounding level.

        The corrector residual holds ``cj (q(x) - q_pred)``: its rounding error
        ``eps cj |q|`` grows like ``1/h``. An unknown that only such a row fixes
        (the current of a voltage source driving a capacitor,
        ``i = cj (q - q_pred) + ...``) carries noise of ``eps |q| / h`` in every
        Newton correction and in every accepted value. Where that noise reaches
        the requested tolerance (a current near zero, whose tolerance is
        ``abstol``) the corrections stop contracting on a converged iterate, the
        step is cut, and a smaller step only raises the noise: the integration
        dies with the step size at the roundoff of t. The rounding error of the
        residual, ``eps (cj |dq/dx| |x| + |q'_pred|)`` per row, propagated to the
        unknowns through the current factorisation (one solve, two right-hand
        sides), is a floor below which no tolerance is attainable; both tests
        use it (``ROUNDING_FACTOR`` times it) where it exceeds the requested
        tolerance.
        This is the same accuracy limit as the backward error of the corrector
        (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 2002,
        Section 7.1); where the tolerance is attainable the weights are unchanged.

        Returns ``self._w`` itself when no floor applies (the common case), else a
        new array; then also replaces ``self._w_step_err`` (which ``_attempt``
        resets to ``self._w_err``) for the error test.
        """
        lu = self._lu
        if self._abs_dq is None or not lu.ready:
            return self._w
        noise = self._abs_dq @ np.abs(x_pred)
        noise *= cj
        noise += np.abs(qp_pred)
        noise *= ROUNDING_FACTOR * EPS
        # |J^-1| b is out of reach; rounding errors have no fixed sign, so take the
        # larger response to b and to b with fixed pseudo-random signs (a single
        # non-negative b can cancel, e.g. across a capacitor between two nodes)
        rhs = self._noise_rhs
        if rhs is None:
            rhs = self._noise_rhs = np.empty((self.n, 2))
            self._noise_signs = np.where(np.random.default_rng(1).random(self.n) < 0.5, -1.0, 1.0)
        rhs[:, 0] = noise
        np.multiply(noise, self._noise_signs, out=rhs[:, 1])
        floor = np.abs(lu.solve(rhs)).max(axis=1)
        w = self._w
        low = floor * w > 1.0
        if not low.any():
            return w
        w = w.copy()
        w[low] = 1.0 / floor[low]
        w_err = self._w_err.copy()
        w_err[low] = np.minimum(w_err[low], w[low])
        self._w_step_err = w_err
        return w

    def _newton(self, fun, x_pred, cj, setup, weights):
        if setup:
            rate, jac, scale = RATE_AFTER_SETUP, "first", 1.0
        else:
            rate = RATE_CJ_CHANGED if cj != self._cjlast else self._rate
            jac, scale = "never", 2.0 / (1.0 + cj / self._lu.tag)
        return newton(fun, x_pred, self._lu, weights, tol=EPCON, maxiter=self.newton_maxiter,
                      jacobian=jac, rate=rate, scale=scale, norm=self.norm, tag=cj)

    def _complete_step(self, t_new, h, landing, info, retried):
        """Phase 5: order and step-size selection, history update (IDA's IDACompleteStep).

        Two rules beyond IDA keep the step from oscillating: a step that needed a
        retry is not followed by a larger step (CVODE's rule), and after a larger
        step failed the error test the step grows again only after ``k + 2``
        steps at constant size and order, when the order-raise test has run too.
        Without them a tight absolute tolerance on an algebraic unknown crossing
        zero (a current, abstol = 1e-12 A) traps the method at order 1 in a
        cycle "grow, fail, shrink, grow" in which the order can never rise (it
        needs k + 2 constant steps) and every step costs a factorisation.
        """
        k = self._k
        self._nst += 1
        st = self.stats
        st["steps"] += 1
        if h < st["h_min"]:
            st["h_min"] = h
        if h > st["h_max"]:
            st["h_max"] = h
        if k > st["max_order_used"]:
            st["max_order_used"] = k
        kdiff = k - self._kused
        self._kused = k
        self._hused = h
        eta = self._select_order_and_step(k, kdiff, info)
        if eta > 1.0:
            if retried or (self._growth_failed and self._ns < k + 2):
                eta = 1.0
            else:
                self._growth_failed = False
        update_differences(self._P, self._ee, k, self.maxord)
        self.t = t_new
        x_new = self._P[0, : self.n]
        self._state = self._state_try
        self._set_weights(x_new)
        self._record(t_new, x_new, k)
        self.h = max(min(h * eta, self.max_step), self.min_step)
        if landing and self._ibp == self._breakpoints.size - 1:
            self.status = "finished"
            self.message = self._success_message()
            return
        if self.max_steps is not None and st["steps"] >= self.max_steps:
            self._fail(t_new, self.h, f"reached max_steps={self.max_steps}", None,
                       "raise max_steps, or loosen the tolerances")
            return
        if landing:
            self._ibp += 1
            self._restart(max(h, self._h_request))

    def _select_order_and_step(self, k, kdiff, info):
        """Order for the next step and the step-size factor eta (IDA's IDACompleteStep)."""
        if self._fixed:
            if self._nst > 1 and k < self._fixed_order:
                self._k = k + 1
            return 1.0
        knew = info["knew"]
        if knew == k - 1 or k == self.maxord:
            self._phase = 1
        if self._phase == 0:
            # start-up: raise the order and double the step after every step but the first
            if self._nst > 1:
                self._k = k + 1
                return 2.0
            return 1.0
        err_k, err_km1 = info["err_k"], info["err_km1"]
        err_new = err_k
        if knew == k - 1:
            self._k = k - 1
            err_new = err_km1
        elif k < self.maxord and self._ns >= k + 2 and kdiff != 1:
            n = self.n
            err_kp1 = self._normf(self._ee[:n] - self._P[k + 1, :n], self._w_err) / (k + 2)
            terr_k = (k + 1) * err_k
            terr_kp1 = (k + 2) * err_kp1
            if k == 1:
                if terr_kp1 < 0.5 * terr_k:
                    self._k, err_new = 2, err_kp1
            elif k * err_km1 <= min(terr_k, terr_kp1):
                self._k, err_new = k - 1, err_km1
            elif terr_kp1 < terr_k:
                self._k, err_new = k + 1, err_kp1
        tmp = (2.0 * err_new + ERROR_FLOOR) ** (-1.0 / (self._k + 1))
        if tmp >= ETA_GROW_MIN:
            return min(tmp, ETA_GROW_MAX)
        if tmp <= 1.0:
            return max(ETA_SHRINK_MIN, min(tmp, ETA_SHRINK_MAX))
        return 1.0

    def _restart(self, h_last):
        """Order-1 restart on a breakpoint: derivatives from the right by a probe."""
        self.stats["restarts"] += 1
        self._restart_times.append(self.t)
        self._segments.append(self._m - 1)
        x = self._P[0, : self.n].copy()
        if self._fixed:
            probe = self._probe_or_fail(self.t, x, PROBE_FRACTION * self._fixed_h)
            if probe is not None:
                self._initialise_history(self._fixed_h, probe[0], probe[1])
            return
        cap = max(min(h_last, self.max_step, self._breakpoints[self._ibp] - self.t), self.min_step)
        self._restart_at(x, cap)

    # --------------------------------------------------------------- output
    def _record(self, t, x, k):
        m = self._m
        if m == self._buf_t.size:
            cap = 2 * m
            self._buf_t = np.resize(self._buf_t, cap)
            self._buf_k = np.resize(self._buf_k, cap)
            self._buf_x = np.resize(self._buf_x, (cap, self._save.size))
        self._buf_t[m] = t
        self._buf_k[m] = k
        self._buf_x[m] = x if self._save_all else x[self._save]
        self._m = m + 1

    def result(self) -> IntegrationResult:
        """The integration so far as an :class:`IntegrationResult`."""
        m = self._m
        t = self._buf_t[:m].copy()
        x = self._buf_x[:m].copy()
        k = self._buf_k[:m].copy()
        names = tuple(self.system.names[i] for i in self._save)
        stats = dict(self.stats)
        stats["factorizations"] = self._lu.factorizations
        status = STATUS_OK if self.status == "finished" else STATUS_FAILED
        message = self.message or f"stopped at t={self.t:.9g} before t_bound={self.t_bound:.9g}"
        return IntegrationResult(
            t=t, x=x, order=k, names=names, save=self._save.copy(),
            dense=Interpolant(t, k, x, names, segments=np.array(self._segments, dtype=np.int64)),
            stats=stats, status=status, message=message,
            tolerances=dict(self._tolerances), failure=self._failure,
            restarts=np.array(self._restart_times), jumps=list(self._jumps),
        )

    # -------------------------------------------------------------- failure
    def _worst(self, v, w):
        s = np.abs(v * w)
        if not np.any(s > 0):
            s = np.abs(v * self._w)
        return self.system.names[int(np.argmax(np.where(np.isfinite(s), s, np.inf)))]

    def _nonfinite_worst(self, ev):
        bad = ~np.isfinite(np.asarray(ev.phi, dtype=float))
        if ev.q is not None:
            bad |= ~np.isfinite(np.asarray(ev.q, dtype=float))
        return self.system.names[int(np.argmax(bad))] if np.any(bad) else None

    @staticmethod
    def _newton_hint(reason):
        if reason == INFO_EVALUATION:
            return ("the system evaluation is not finite (ok=False) at every step size tried: "
                    "the model is undefined beyond this time")
        if reason == INFO_SINGULAR:
            return ("the Newton matrix is singular: the DAE is singular or of index > 2 "
                    "(a floating node, a loop of voltage sources, a cutset of current sources?)")
        return ("Newton does not converge even on small steps: a discontinuity in the model, "
                "an inconsistent initial value, or too few newton_maxiter")

    @staticmethod
    def _error_hint():
        return ("the solution is not smooth here: an input discontinuity without a breakpoint, "
                "an inconsistent initial value, or an index-2 unknown not marked in `index`")

    def _fail(self, t, h, what, worst, hint):
        self.status = "failed"
        text = f"BDF failed: {what} at t={t:.9g}, h={h:.3g}"
        if worst:
            text += f", worst unknown {worst}"
        self.message = text + f" (hint: {hint})"
        self._failure = {"t": float(t), "h": float(h), "worst": worst, "hint": hint, "what": what}

    def _success_message(self):
        st = self.stats
        return (f"reached t={self.t_bound:.9g} in {st['steps']} steps ({st['rejected']} rejected, "
                f"{st['newton_failures']} Newton failures, {self._lu.factorizations} factorizations)")


def _compiled_engine_enabled() -> bool:
    """The compiled engine serves what it supports unless ``NETDAE_ENGINE=python``."""
    return os.environ.get("NETDAE_ENGINE", "compiled").lower() != "python"


def integrate(
    system: DaeSystem,
    t_span,
    x0,
    *,
    progress: Callable[[float, float, int], Any] | None = None,
    raise_on_failure: bool = False,
    **options,
) -> IntegrationResult:
    """Integrate ``d/dt q(x) = phi(x, t)`` over ``t_span`` with the FLC-BDF method.

    Parameters
    ----------
    system : DaeSystem
    t_span : (float, float)
        ``(t0, t_bound)``.
    x0 : ndarray, shape (n,)
        Consistent initial values.
    progress : callable, optional
        ``progress(t, t_bound, steps)``, called at most every 0.1 s of wall
        time and once at the end.
    raise_on_failure : bool
        Raise :class:`~netdae.errors.ConvergenceError` instead of returning a
        failed result.
    **options
        Passed to :class:`BDF` (``rtol``, ``atol``, ``vntol``, ``abstol``,
        ``index``, ``maxord``, ``max_step``, ``min_step``, ``first_step``,
        ``breakpoints``, ``xp0``, ``save``, ``norm``, ...).

    Returns
    -------
    IntegrationResult

    Raises
    ------
    ConvergenceError
        Only with ``raise_on_failure=True``, carrying t, h, the worst unknown
        and a hint.
    ValueError
        For invalid arguments.

    Examples
    --------
    The RC circuit ``C v' = -v/R`` from 1 V, with R C = 1 ms:

    >>> import numpy as np
    >>> from netdae.dae.system import LinearDae
    >>> rc = LinearDae([[1e-6]], [[-1e-3]])
    >>> res = integrate(rc, (0.0, 5e-3), np.array([1.0]), rtol=1e-6, atol=1e-9)
    >>> res.ok, bool(abs(res.x[-1, 0] - np.exp(-5.0)) < 1e-5)
    (True, True)
    """
    if _compiled_engine_enabled():
        from .compiled.driver import integrate_compiled

        res = integrate_compiled(system, t_span, x0, progress=progress, raise_on_failure=raise_on_failure,
                                 **options)
        if res is not None:
            return res
    t0, tf = (float(v) for v in t_span)
    solver = BDF(system, t0, x0, tf, **options)
    last = time.perf_counter()
    while solver.status == "running":
        solver.step()
        if progress is not None:
            now = time.perf_counter()
            if now - last >= PROGRESS_INTERVAL:
                progress(solver.t, tf, solver.stats["steps"])
                last = now
    if progress is not None:
        progress(solver.t, tf, solver.stats["steps"])
    result = solver.result()
    if raise_on_failure and not result.ok:
        f = result.failure or {}
        raise ConvergenceError(f.get("what", result.message), t=f.get("t"), h=f.get("h"),
                               worst=f.get("worst"), hint=f.get("hint"))
    return result
