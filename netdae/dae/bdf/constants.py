"""The FLC-BDF method's constants: one owner for each (IDA's names in parentheses).

:mod:`netdae.dae.compiled.bdf_loop` imports them from :mod:`netdae.dae.bdf`,
so both integrators take the same decisions.
"""

from __future__ import annotations

import numpy as np

from ...circuit import MAX_ORDER  # noqa: F401  (owned by netdae.circuit, which the reader reads too)

#: With relref="mixed" the relative tolerance refers to at least this fraction
#: of the largest magnitude the unknown has had.
MIXED_FLOOR = 0.1
#: Newton iterations per step (IDA's maxcor).
NEWTON_MAXITER = 4
#: Newton convergence tolerance as a fraction of the error-test bound 1 (IDA's EPCON).
EPCON = 0.33
#: Contraction rate assumed right after a factorisation: rate/(1-rate) = 20 (IDA).
RATE_AFTER_SETUP = 20.0 / 21.0
#: Rate assumed when cj changed but the old factorisation is reused: rate/(1-rate) = 100 (IDA).
RATE_CJ_CHANGED = 100.0 / 101.0
#: Solves in a row that converged at their first correction, after which the carried rate is assumed again.
RATE_AGE_MAX = 10
#: A nonlinear system keeps its factorisation while cj/cj_lu stays in
#: [(1-DCJ)/(1+DCJ), (1+DCJ)/(1-DCJ)] = [0.6, 1.67] (IDA's dcj).
DCJ = 0.25
#: ... and for at most this many accepted steps: a Jacobian evaluated longer ago is renewed
#: (CVODE's msbp, 20 there). IDA renews only when cj leaves its window or Newton fails; a step
#: held constant (a slow input, an error estimate that allows no growth) then keeps one
#: Jacobian for thousands of steps while the devices drift from it, and the iterates it
#: accepts carry errors that hold the step where it is (docs/integrator.md, "Known
#: limitations": a Schmitt-trigger oscillator took 137,000 steps instead of 12,300, a VDMOS
#: gate ramp failed its error test). 50 did as well but moved three of ngspice's lossy-line examples
#: (docs/integrator.md, "Newton and the sparse LU").
JAC_AGE_MAX = 100
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
#: Impasse restarts at one t after the attempts failed on every step size (each from implicit-Euler
#: steps ten times longer than the last; BDF._impasse, the compiled loop's _impasse).
IMPASSE_TRIES = 4
#: A failure within this many of the last impasse's implicit-Euler steps after it is "at one t" with
#: it: the tries escalate rather than restart at 1, so a crawl of impasses a few ulps apart (no
#: progress between them) ends in a failure message instead of running forever.
IMPASSE_NEAR = 100.0
MAX_ERROR_FAILURES = 10
#: Error-test failures of the first step from a (re)start after which its derivatives are probed again
#: on the shorter step (BDF._reprobe, the compiled loop's _reprobe): a mode faster than the probe's steps.
REPROBE_ERROR_FAILURES = 3
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
#: ... and, in a linear system, only when the probe's first Euler step carries it: a jump of an unknown that is not
#: index 2 moves it by the jump in the first step and by about eps x' in the second, where a
#: continuous solution moves by comparable amounts in both (the extrapolation's O(eps^2 x'')
#: error then passes JUMP_DETECT only because x'' is large: an RC node at the corner of a
#: PULSE whose slope is 1e4 times its time constant's scale). A jump counts when the second
#: step moves the unknown by at most JUMP_FIRST_STEP of the first.
JUMP_FIRST_STEP = 0.5
#: A nonlinear system's right limit that moves the solution at a restart that is not a switching
#: event is confirmed with the short steps of EVENT_RIGHT_LIMIT_FRACTION: a mode faster than the
#: probe's step moves nothing within them (a base current cut at a PULSE corner,
#: tests/test_fast_mode_at_corner.py; a collector node 10 ps from its source at the start,
#: tests/test_fast_mode_at_start.py), and one growing faster than the probe's step (implicit Euler
#: damps it with a negative factor ``1 / (1 - h lambda)``: an op-amp loop at its unstable operating
#: point, -0.48) gives no right limit by the probe's extrapolation.
#: Newton iterations allowed for each implicit-Euler step of the right-limit solve.
JUMP_NEWTON_MAXITER = 25
#: After a switching event the right limit is solved with implicit-Euler steps of this
#: fraction of the probe's step, and at least EVENT_RIGHT_LIMIT_ULPS units in the last place
#: of t: a switch into a stiff node (RON = 0.05 ohm against a diode's junction capacitance,
#: picoseconds) starts a transient as fast as the probe's step, which two probe-sized
#: steps extrapolated to zero would mistake for part of the jump (the charges must stay).
EVENT_RIGHT_LIMIT_FRACTION = 1e-6
EVENT_RIGHT_LIMIT_ULPS = 1000.0
#: The right limit after an event is first solved by full Newton on the two implicit-Euler
#: steps (from the left value; a switch changes a conductance, rarely more), converged when
#: the last correction is below this fraction of the tolerances (maximum norm); failing that,
#: by the steady-state solver with its gmin and source stepping.
EVENT_RIGHT_LIMIT_TOL = 1e-3
#: A right limit whose implicit-Euler steps fail is tried again up to this many times, with steps this many
#: times longer each time: steps so short that ``C / eps`` and ``L / eps`` swamp every conductance give a
#: matrix singular in floating point (the index-2 node voltages of an inductor cutset, fixed only through
#: the inductors' derivatives, at a switch's event with steps of 1e-19 s).
RIGHT_LIMIT_RETRIES = 3
RIGHT_LIMIT_STRETCH = 1000.0
#: A row of the right limit's implicit-Euler matrix ``dq/eps - dphi`` whose charge entries
#: (``sum |dq| / eps``) exceed what is left of the row once the charges of a capacitor attached
#: to nothing else cancel (``|sum dq| / eps + sum |dphi|``) by more than this factor loses the
#: equation that sets the nodes' common mode to rounding (a pair of nodes held only by the
#: 1e-12 S of open switches, against C / eps = 2e5 S: the LU pivot of the common mode rounds to
#: zero). Full Newton on that matrix then gives up, and the right limit is solved with the
#: charge balance of each such group of nodes (:class:`~netdae.dae.bdf.startup.ImplicitEulerStep`
#: with ``groups``): 1e10 keeps the common mode to 1e-6 of its value.
RIGHT_LIMIT_CANCELLATION = 1e10
#: Rows whose charges add up to a constant (``sum dq`` over the rows below this fraction of
#: their largest ``|dq|`` in every column): the nodes of capacitors attached to nothing else.
CONSERVED_CHARGE_RTOL = 1e-9
#: A step may be stretched by this fraction to land on a breakpoint.
BREAKPOINT_STRETCH = 0.1
#: Breakpoints closer than this fraction of the interval are merged (no sliver steps).
BREAKPOINT_MERGE = 1e-9
#: A step smaller than this many ulps of t cannot advance time.
ROUNDOFF_ULPS = 16.0
#: The corrector residual ``cj (q(x) - q_pred) + q'_pred - phi`` is computed with an
#: absolute error of about ``eps (cj |dq/dx| |x| + |q'_pred|)`` per row; a tolerance
#: below this many times that level, propagated to the unknowns, is not attainable
#: and is raised to it (see ``RoundingFloor.weights`` in corrector.py).
ROUNDING_FACTOR = 10.0
EPS = float(np.finfo(float).eps)
#: Linear systems up to this size form their residual with a dense matrix-vector product.
DENSE_MATVEC_MAX = 48
#: Initial capacity of the output buffers (they double when full), within BUFFER_START_BYTES (but 16 points
#: at least): a circuit of many unknowns that records few points does not reserve room for a thousand.
BUFFER_START = 1024
BUFFER_START_BYTES = 16 * 2**20
#: Least wall time between two progress callbacks [s].
PROGRESS_INTERVAL = 0.1
#: Attempts of one step that end past a change where a behavioural source's held branch is undefined
#: before the integration stops naming the source (the change is located on the predictor: a few suffice).
UNDEFINED_TRIES = 60
