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

Layout
------
The package is the method in small parts, each testable alone; the
formulas that the compiled engine also runs are the compiled kernels of
:mod:`netdae.dae.compiled.control` (``flc_coefficients``, ``error_norms``,
``weighted_norm``, ``update_differences``, ``landing_step``,
``set_weights``), called here from Python, so they exist once.

=====================  ====================================================
``constants``          the method's constants (one owner; the compiled
                       engine imports them from here)
``arguments``          argument checks, tolerances, the index-2 mask
``history``            ``History``: divided differences, ``psi``, the
                       step's coefficients (IDASetCoeffs, IDARestore)
``controller``         pure decisions: error test, order selection, step
                       factors after success and failure, first steps
``corrector``          ``LinearCorrector`` (one exact solve),
                       ``NonlinearCorrector`` (modified Newton),
                       ``RoundingFloor`` (tolerances at the rounding level)
``startup``            probes, right limits, ``ImplicitEulerStep``
``recorder``           ``Recorder``: output buffers, restarts, jumps,
                       dense-output segments
``statistics``         the counters; ``failures``: failure messages
``result``             ``IntegrationResult``
``stepper``            ``BDF``: the driver composing the parts
``run``                ``integrate``
=====================  ====================================================

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

from .arguments import (absolute_tolerances, breakpoint_times, charge_columns, charge_rows, check_arguments,
                        current_rows, index_mask,
                        rounding_signs, row_tolerances, save_indices, time_charge_rows)
from .constants import (
    BREAKPOINT_MERGE,
    BREAKPOINT_STRETCH,
    BUFFER_START,
    DCJ,
    DENSE_MATVEC_MAX,
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
    H0_DERIVATIVE_BOUND,
    H0_ERROR_TARGET,
    H0_FRACTION,
    IMPASSE_NEAR,
    IMPASSE_TRIES,
    JAC_AGE_MAX,
    JUMP_DETECT,
    JUMP_FIRST_STEP,
    JUMP_NEWTON_MAXITER,
    MAX_ERROR_FAILURES,
    MAX_NEWTON_FAILURES,
    MAX_ORDER,
    MIXED_FLOOR,
    NEWTON_MAXITER,
    PROBE_FRACTION,
    PROBE_MAX_RATIO,
    PROBE_RETRIES,
    REPROBE_ERROR_FAILURES,
    PROGRESS_INTERVAL,
    RATE_AFTER_SETUP,
    RATE_CJ_CHANGED,
    RATE_AGE_MAX,
    RIGHT_LIMIT_CANCELLATION,
    ROUNDING_FACTOR,
    ROUNDOFF_ULPS,
    UNDEFINED_TRIES,
)
from .result import IntegrationResult
from .run import _compiled_engine_enabled, integrate
from .startup import ImplicitEulerStep, right_limit
from .stepper import BDF

__all__ = ["BDF", "ImplicitEulerStep", "IntegrationResult", "integrate", "check_arguments", "absolute_tolerances",
           "index_mask", "row_tolerances", "charge_columns", "charge_rows", "save_indices", "right_limit",
           "rounding_signs", "breakpoint_times", "time_charge_rows", "current_rows"]
