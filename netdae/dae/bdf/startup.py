"""Starting and restarting the FLC-BDF method: derivative probes, right limits of jumps.

At t0 and after every breakpoint the method restarts at order 1. The
derivative from the right, x'(t+), is measured by an implicit-Euler *probe*
of a tiny step ``eps`` (one factorisation of ``dq/eps - dphi``, one solve),
and x''(t+) by a second probe step with the same factorisation
(:func:`probe`); the first step then follows from x''
(:func:`netdae.dae.bdf.controller.first_step_from_curvature`). The probe
also gives the right limit ``x(t+) = 2 x_1 - x_2``: where it differs from the
value reached (:func:`jump_of`), the inputs jumped, an index-2 unknown
jumped at a corner, or the start is inconsistent, and the method continues
from it; a nonlinear system's right limit is solved to convergence, first by
full Newton from the left value (:func:`event_right_limit`, the compiled
loop's ``_event_right_limit``; after a switching event with much shorter
steps), failing that by the steady-state solver with its homotopies
(:func:`right_limit`, also used by the compiled engine).

A group of nodes attached to the rest only through capacitors and tiny
conductances (a capacitor between two open switches) has a common mode that
no charge holds: the implicit-Euler steps set it through the group's current
balance, whose conductances (1e-12 S) vanish in the rounding of ``C / eps``
(2e5 S). Full Newton gives up on such a matrix (:func:`cancelling_rows`) and
:func:`right_limit` solves the steps with each group's first equation
replaced by the sum of the group's equations, in which the charges cancel
exactly (:func:`conserved_charge_groups`, ``ImplicitEulerStep(groups=...)``).
"""

from __future__ import annotations

import numpy as np

from ..newton import INFO_SINGULAR
from ..sparse import SparsePattern, bipartite_components
from ..steady import SteadyOptions, solve_steady
from ..system import DaeSystem, Evaluation
from .constants import (CONSERVED_CHARGE_RTOL, EVENT_RIGHT_LIMIT_TOL, JUMP_DETECT, JUMP_FIRST_STEP,
                        JUMP_NEWTON_MAXITER, RIGHT_LIMIT_CANCELLATION, RIGHT_LIMIT_STRETCH)
from .failures import Failure, newton_hint, nonfinite_unknown

__all__ = ["ImplicitEulerStep", "right_limit", "event_right_limit", "conserved_charge_groups", "cancelling_rows",
           "Probe", "probe", "jump_of"]


def conserved_charge_groups(pattern: SparsePattern, dq) -> list[np.ndarray]:
    """Groups of rows whose charges add up to a constant: the nodes of capacitors attached to nothing else.

    Rows linked through the entries of ``dq`` (a row and the columns it has a charge
    derivative in) form a group; the group's total charge ``sum(q[rows])`` is conserved
    when ``sum(dq[rows, j])`` vanishes in every column ``j`` (up to
    ``CONSERVED_CHARGE_RTOL`` of the group's largest ``|dq|``). Then the sum of the group's
    implicit-Euler equations ``(q - q0) / eps - phi`` is ``-sum(phi[rows])`` exactly: the
    current balance of the group, free of ``1 / eps``.

    Parameters
    ----------
    pattern : SparsePattern
    dq : ndarray, shape (nnz,)
        ``dq/dx`` on the pattern.

    Returns
    -------
    list of ndarray of int64
        Each group's rows, sorted (rows without charge belong to none).

    Examples
    --------
    >>> pat = SparsePattern.from_coo(3, [[0, 0, 1, 1, 2]], [[0, 1, 0, 1, 2]])
    >>> dq = np.zeros(pat.nnz); c = 1e-12
    >>> dq[pat.slots([0, 0, 1, 1, 2], [0, 1, 0, 1, 2])] = [c, -c, -c, c, c]
    >>> [g.tolist() for g in conserved_charge_groups(pat, dq)]
    [[0, 1]]
    """
    n = pattern.n
    dq = np.asarray(dq, dtype=float)[:pattern.nnz]
    nz = np.flatnonzero(dq != 0.0)
    if nz.size == 0:
        return []
    r, c = pattern.rows[nz], pattern.cols[nz]
    count, label, _ = bipartite_components(r, c, n, n)
    comp = label[r]
    keys, inverse = np.unique(comp * n + c, return_inverse=True)
    column_sums = np.bincount(inverse, weights=dq[nz])
    biggest = np.zeros(count)
    np.maximum.at(biggest, comp, np.abs(dq[nz]))
    leaks = np.zeros(count, dtype=bool)
    kc = keys // n
    leaks[kc[np.abs(column_sums) > CONSERVED_CHARGE_RTOL * biggest[kc]]] = True
    charged = np.zeros(n, dtype=bool)
    charged[r] = True
    rows = np.flatnonzero(charged)
    return [rows[label[rows] == k] for k in np.unique(label[rows]) if not leaks[k]]


def cancelling_rows(pattern: SparsePattern, dq, dphi, eps: float) -> np.ndarray:
    """Rows of ``dq/eps - dphi`` that lose their algebraic part to rounding.

    Row ``i`` does when ``sum_j |dq_ij| / eps`` exceeds ``|sum_j dq_ij| / eps + sum_j |dphi_ij|``
    by more than ``RIGHT_LIMIT_CANCELLATION``: the charge entries of capacitors between
    nodes of the row cancel in the common mode of those nodes, and what is left to set it
    (conductances, charges to ground) is below the rounding of the rest. Twin of the
    compiled loop's ``_cancels``.

    Returns
    -------
    ndarray of int64
        The rows (empty when the matrix keeps every row's information).
    """
    n = pattern.n
    m = pattern.nnz
    rows = pattern.rows
    dq = np.asarray(dq, dtype=float)[:m]
    dphi = np.asarray(dphi, dtype=float)[:m]
    charge = np.bincount(rows, weights=np.abs(dq), minlength=n) / eps
    rest = np.abs(np.bincount(rows, weights=dq, minlength=n)) / eps + np.bincount(rows, weights=np.abs(dphi),
                                                                                  minlength=n)
    return np.flatnonzero(charge > RIGHT_LIMIT_CANCELLATION * rest)


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
    groups : sequence of ndarray of int, optional
        Groups of rows whose total charge is conserved (:func:`conserved_charge_groups`):
        the first row of each becomes the sum of the group's equations, ``sum(phi[rows])``
        (the charge terms cancel exactly), on a pattern extended by the group's entries.

    Notes
    -----
    Used for consistent values after a jump of the inputs (:class:`BDF`) and
    for a ``uic`` start (:mod:`netdae.analyses.tran`): as ``h -> 0`` the
    solution keeps the charges ``q0`` and satisfies the algebraic equations
    at ``t``. Without ``groups`` the algebraic equation of a group's common mode is
    ``(c + g) - c^2 / (c + g)`` in the LU, ``c = C / h``: zero in floating point once
    ``g / c`` is below the rounding (1e-12 S of open switches against 1 pF / 5e-18 s).
    """

    def __init__(self, system: DaeSystem, q0, h: float, t: float, groups=()):
        self.inner = system
        self.q0, self.h, self.t = q0, h, t
        self.n, self.names, self.kinds, self.pattern = system.n, system.names, system.kinds, system.pattern
        self.linear = system.linear
        self.groups = [np.asarray(g, dtype=np.int64) for g in groups if len(g)]
        if self.groups:
            old = system.pattern
            target = np.full(self.n, -1, dtype=np.int64)  # row -> the first row of its group
            self._label = np.full(self.n, -1, dtype=np.int64)
            for k, g in enumerate(self.groups):
                target[g] = g[0]
                self._label[g] = k
            self._first = np.array([int(g[0]) for g in self.groups], dtype=np.int64)
            self._member = np.flatnonzero(self._label >= 0)
            self._src = np.flatnonzero(target[old.rows] >= 0)  # entries that add into a first row
            self.pattern = SparsePattern.from_coo(self.n, [old.rows, target[old.rows[self._src]]],
                                                  [old.cols, old.cols[self._src]])
            self._old_slots = self.pattern.slots(old.rows, old.cols)
            self._keep = ~np.isin(old.rows, self._first)  # the first rows' own entries are replaced
            self._dst = self.pattern.slots(target[old.rows[self._src]], old.cols[self._src])

    def evaluate(self, x, t, *, jacobian=True, state=None, source_scale=1.0):
        ev = self.inner.evaluate(x, self.t, jacobian=jacobian, state=state, source_scale=source_scale)
        phi = ev.phi - (ev.q - self.q0) / self.h
        dq, dphi = ev.dq, None if ev.dphi is None else ev.dphi - ev.dq / self.h
        if self.groups:
            phi[self._first] = np.bincount(self._label[self._member], weights=ev.phi[self._member],
                                           minlength=self._first.size)
            if dphi is not None:
                nnz = self.pattern.nnz
                m = self._old_slots.size
                dq = np.bincount(self._old_slots, weights=ev.dq[:m], minlength=nnz)
                dphi = (np.bincount(self._old_slots[self._keep], weights=dphi[:m][self._keep], minlength=nnz)
                        + np.bincount(self._dst, weights=ev.dphi[self._src], minlength=nnz))
        return Evaluation(q=ev.q, phi=phi, dq=dq, dphi=dphi, limited=ev.limited, state=ev.state, ok=ev.ok)

    def initial_state(self):
        return self.inner.initial_state() if hasattr(self.inner, "initial_state") else None


def right_limit(system: DaeSystem, t: float, x, eps: float, high, rtol: float, vntol: float, abstol: float, *,
                state=None, impasse: bool = False, retries: int = 0,
                timed: bool = False) -> tuple[np.ndarray | None, int, int, str]:
    """x(t+) of a nonlinear system: two converged implicit-Euler steps of size eps, extrapolated.

    The charges are continuous across t (no impulse), so the steps start from
    ``q(x)``; the inputs are those right of t. Each step is solved by the
    steady-state solver (damped Newton with device limiting, then gmin and
    source stepping): after a jump of the inputs the start can be far from
    the solution (a diode switched on by a step). Index-2 unknowns (``high``)
    take the second step's value (they carry an impulse in the first). The
    groups of rows whose total charge is conserved (:func:`conserved_charge_groups`,
    at ``x``) are solved through their current balance (``ImplicitEulerStep``'s
    ``groups``): their common mode is algebraic, set by conductances the rounding
    of ``C / eps`` would lose.

    With ``impasse`` (the integrator's attempts failed on every step size) a step the
    homotopies do not solve is solved again with pseudo-transient continuation: at a fold
    the left value sits where the branch ends, no solution is near it, and Newton, gmin and
    source stepping (whose continuation follows the same branch to the same fold) can all
    stall there; the pseudo-time's capacitors carry the unknowns off the fold as the
    circuit's own small capacitances would.

    Steps that do not converge are tried again up to ``retries`` times (the integrators pass
    ``RIGHT_LIMIT_RETRIES``; none at an impasse), ``RIGHT_LIMIT_STRETCH`` times longer each
    time: steps so short that ``C / eps`` and ``L / eps`` swamp every conductance give a matrix
    singular in floating point (the index-2 node voltages of an inductor cutset at a switch's
    event).

    Returns
    -------
    (x_right, iterations, evaluations, message)
        ``x_right`` is None when a step did not converge (``message`` says why).
    """
    iterations = evaluations = 0
    for attempt in range(1 + (0 if impasse else retries)):
        out, its, evals, message = _two_steps(system, t, x, eps * RIGHT_LIMIT_STRETCH ** attempt, high, rtol, vntol,
                                              abstol, state, impasse, timed)
        iterations += its
        evaluations += evals
        if out is not None:
            break
    return out, iterations, evaluations, message


def _two_steps(system: DaeSystem, t: float, x, eps: float, high, rtol: float, vntol: float, abstol: float, state,
               impasse: bool, timed: bool = False) -> tuple[np.ndarray | None, int, int, str]:
    """:func:`right_limit` with steps of ``eps``, tried once."""
    # an implicit-Euler step is itself a time step: no pseudo-time continuation on top of it (a failure
    # cuts the step instead)
    opts = SteadyOptions(reltol=rtol, vntol=vntol, abstol=abstol, judge_singular=False, pseudo_transient=False)
    last = SteadyOptions(reltol=rtol, vntol=vntol, abstol=abstol, judge_singular=False, pseudo_transient=True)
    iterations = 0
    evaluations = 0
    y = np.asarray(x, dtype=float)
    ys = []
    groups = ()
    for step in (1, 2):
        ev = system.evaluate(y, t + (step - 1) * eps, jacobian=step == 1, state=state)
        evaluations += 1
        if step == 1 and ev.dq is not None:
            groups = conserved_charge_groups(system.pattern, ev.dq)
        q0 = ev.q
        if timed and step == 1:  # a charge that reads time: from the charges just before t (event_right_limit)
            q0 = system.evaluate(y, np.nextafter(t, -np.inf), jacobian=False, state=state).q
            evaluations += 1
        problem = ImplicitEulerStep(system, q0, eps, t + step * eps, groups)
        res = solve_steady(problem, t + step * eps, y, options=opts)
        iterations += res.iterations
        evaluations += res.iterations
        if not res.converged and impasse:
            res = solve_steady(problem, t + step * eps, y, options=last)
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


def event_right_limit(system: DaeSystem, t: float, x, eps: float, high, lu, weights, *,
                      state=None, timed: bool = False) -> tuple[np.ndarray | None, int, int]:
    """x(t+) by full Newton: two implicit-Euler steps of size eps, extrapolated (tried first at every jump).

    Each step solves ``(q(y) - q0) / eps - phi(y, t + k eps) = 0`` from the left value (the
    devices limited against the previous iterate, from ``state``), converged when the last
    correction is below ``EVENT_RIGHT_LIMIT_TOL`` of the tolerances in the maximum norm
    (``weights``); the result is ``2 y1 - y2`` (``y2`` for the index-2 unknowns ``high``).
    A matrix that loses a row's algebraic part to rounding (:func:`cancelling_rows`: the
    common mode of nodes held by capacitors and tiny conductances) is not solved here.
    A switch changes one conductance, an input that moves little moves the solution little: from
    the left value Newton takes a few iterations, where :func:`right_limit`'s steady-state solver
    (with its homotopies) costs milliseconds.

    Returns
    -------
    (x_right, iterations, evaluations)
        ``x_right`` is None when a step does not converge (then use :func:`right_limit`).
    """
    y = np.array(x, dtype=float)
    y1 = y
    iterations = evaluations = 0
    for step in (1, 2):
        # with a charge that reads time (``timed``), the first step from the charges just before t: the
        # rows' charges are continuous where such a charge jumps
        t_q = np.nextafter(t, -np.inf) if timed and step == 1 else t + (step - 1) * eps
        q0 = system.evaluate(y, t_q, jacobian=False, state=state).q
        evaluations += 1
        current = state
        converged = False
        for _ in range(JUMP_NEWTON_MAXITER):
            ev = system.evaluate(y, t + step * eps, jacobian=True, state=current)
            evaluations += 1
            current = ev.state
            if not ev.ok or cancelling_rows(system.pattern, ev.dq, ev.dphi, eps).size:
                return None, iterations, evaluations
            if not lu.factor(ev.dq / eps - ev.dphi, tag=("right limit", eps)):
                return None, iterations, evaluations
            d = lu.solve((ev.q - q0) / eps - ev.phi)
            iterations += 1
            y = y - d
            dn = float(np.max(np.abs(d * weights))) if d.size else 0.0
            if not np.isfinite(dn):
                return None, iterations, evaluations
            if dn <= EVENT_RIGHT_LIMIT_TOL and not ev.limited:
                converged = True
                break
        if not converged:
            return None, iterations, evaluations
        if step == 1:
            y1 = y.copy()
    return np.where(np.asarray(high, dtype=bool), y, 2.0 * y1 - y), iterations, evaluations


class Probe:
    """What a probe measured at a (re)start point.

    Attributes
    ----------
    xp, qp, xpp : ndarray, shape (n,)
        x'(t+), q'(t+) (= phi), x''(t+); the derivatives of index-2 unknowns are zero.
    x_right : ndarray, shape (n,)
        The right limit ``2 x_1 - x_2``.
    x_2 : ndarray, shape (n,)
        The second Euler step (the right limit of index-2 unknowns when an input value jumps).
    w_floor : ndarray, shape (n,)
        The weights with every tolerance raised to the probe's rounding level.
    """

    __slots__ = ("xp", "qp", "xpp", "x_right", "x_2", "w_floor")

    def __init__(self, xp, qp, xpp, x_right, x_2, w_floor):
        self.xp, self.qp, self.xpp, self.x_right, self.x_2, self.w_floor = xp, qp, xpp, x_right, x_2, w_floor


def probe(evaluate, lu, floor, names, t: float, x, eps: float, high, w, w_err, *, after_jump: bool = False,
          timed: bool = False) -> Probe:
    """x'(t+), q'(t+), x''(t+) and the right limit x(t+) from two implicit-Euler steps of size ``eps``.

    Each step is one Newton iteration (exact for a linear system; for a
    nonlinear one the residual at a consistent x is O(eps)). The right limit
    is the extrapolation of the two steps to eps = 0, ``2 x_1 - x_2`` (error
    O(eps^2)), returned with ``x_2`` (for index-2 unknowns, which carry an
    impulse in ``x_1`` when an input value jumps: :func:`jump_of` chooses).

    Parameters
    ----------
    evaluate : callable
        ``evaluate(x, t, jacobian) -> Evaluation`` (counting evaluations).
    lu : LuCache
        Factorises ``dq/eps - dphi`` (tag ``1/eps``).
    floor : RoundingFloor
        Keeps ``|dq|`` and gives the weights raised to the probe's rounding level.
    names : sequence of str
    t : float
    x : ndarray, shape (n,)
    eps : float
    high : ndarray of bool, shape (n,)
        Index-2 unknowns.
    w, w_err : ndarray, shape (n,)
        The current weights.
    after_jump : bool
        ``x`` is a right limit just taken: q'(t+) is then ``phi`` linearised at the index-2 unknowns
        of the first Euler step ``x_1``, not at their right limit, which need not be consistent
        with the derivatives (after a corner of the inputs).
    timed : bool
        A charge reads time itself (``system.time_charge_rows()``): each Euler step's Newton step
        then has ``(q(x, t + eps) - q(x, t)) / eps`` on its right-hand side, the charge's change at
        fixed x, where a charge of the unknowns alone has none (``dq/dt = dq/dx x'``); the first
        step starts from the charges just before t (but after a jump): a charge that jumps in time
        moves the unknowns so that the row's charge is continuous.

    Returns
    -------
    Probe

    Raises
    ------
    Failure
        When the Newton matrix is singular or an evaluation is not finite.
    """
    ev = evaluate(x, t + eps, True)
    if not ev.ok or not np.all(np.isfinite(ev.phi)):
        raise Failure("the system evaluation right after t is not finite", nonfinite_unknown(names, ev),
                      "the model is undefined at the initial/restart point")
    if not lu.factor(ev.dq / eps - ev.dphi, tag=1.0 / eps):
        raise Failure("the Newton matrix (alpha/h) dq/dx - dphi/dx is singular", None, newton_hint(INFO_SINGULAR))
    floor.keep(ev.dq)
    rhs = ev.phi
    if timed:
        # the charges before t (a charge that jumps in time at t moves x: the row's charge is conserved),
        # at t itself after a right limit just taken
        rhs = ev.phi - (ev.q - evaluate(x, t if after_jump else np.nextafter(t, -np.inf), False).q) / eps
    xp = lu.solve(rhs) / eps
    x1 = x + eps * xp
    q1 = evaluate(x1, t + eps, False).q if timed else None
    ev1 = evaluate(x1, t + 2.0 * eps, False)
    rhs1 = ev1.phi
    if timed and ev1.ok:
        rhs1 = ev1.phi - (ev1.q - q1) / eps
    xp1 = lu.solve(rhs1) / eps if ev1.ok else xp
    xpp = (xp1 - xp) / eps
    if not (np.all(np.isfinite(xp)) and np.all(np.isfinite(xpp))):
        raise Failure("the derivative estimate at the (re)start is not finite", None, newton_hint(INFO_SINGULAR))
    x_right, x_2 = x1 - eps * xp1, x1 + eps * xp1
    qp = np.array(ev.phi, dtype=float)
    w_floor, _ = floor.weights(w, w_err, x, qp, 1.0 / eps)
    if after_jump:
        # phi with the index-2 unknowns the first Euler step solved, not their right limit, which
        # need not be consistent (an index-2 current's right limit after a corner of the inputs)
        pat = floor.pattern
        move = np.where(high, eps * xp, 0.0)
        qp += np.bincount(pat.indices, weights=ev.dphi * np.repeat(move, np.diff(pat.indptr)), minlength=x.size)
    xp[high] = 0.0
    xpp[high] = 0.0
    return Probe(xp, qp, xpp, x_right, x_2, w_floor)


def jump_of(x, x_right, x_2, w_floor, high, *, first_step: bool = True):
    """Whether the right limit differs from ``x``, and how.

    Parameters
    ----------
    x, x_right, x_2 : ndarray, shape (n,)
        The value reached, the probe's right limit and its second Euler step
        (the first is their mean).
    w_floor : ndarray, shape (n,)
        Weights at the probe's rounding level.
    high : ndarray of bool, shape (n,)
    first_step : bool
        An unknown that is not index 2 jumps only where the probe's first Euler
        step carries the move (:data:`JUMP_FIRST_STEP`): every restart but a
        switching event's. False after a switching event (phi itself changed:
        every move counts, and a nonlinear system's right limit is solved
        again).

    Returns
    -------
    (jumped, value_jump, x_right)
        ``jumped``: some unknown moved by more than ``JUMP_DETECT`` tolerances;
        ``value_jump``: one that is not index 2 did (an input value jumped, or
        the start is inconsistent), then the index-2 unknowns take ``x_2``
        (they carry an impulse in the first Euler step) in ``x_right``.
        Without a value jump the unknowns that are not index 2 keep ``x``
        (the extrapolation's error, not a jump, moved them).

    Examples
    --------
    >>> x = np.zeros(2); high = np.array([False, True])
    >>> jump_of(x, np.array([0.0, 5.0]), np.array([0.0, 4.0]), np.ones(2), high)[:2]
    (True, False)
    >>> jump_of(x, np.array([3.0, 5.0]), np.array([3.0, 4.0]), np.ones(2), high)[2].tolist()
    [3.0, 4.0]

    A move the second step repeats is the extrapolation's error, not a jump:

    >>> jump_of(x, np.array([-5e-6, 0.0]), np.array([1.5e-5, 0.0]), np.full(2, 1e6), high)[0]
    False
    """
    moved = np.abs(x_right - x) * w_floor
    if not moved.max() > JUMP_DETECT:
        return False, False, x_right
    beyond = moved > JUMP_DETECT
    if first_step:
        x_1 = 0.5 * (x_right + x_2)
        beyond &= high | (np.abs(x_2 - x_1) <= JUMP_FIRST_STEP * np.abs(x_1 - x))
    value_jump = bool(np.any(beyond[~high]))
    if value_jump:
        x_right[high] = x_2[high]
    elif first_step:
        x_right[~high] = x[~high]
        if not np.any(beyond):
            return False, False, x_right
    return True, value_jump, x_right
