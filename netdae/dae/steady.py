"""Steady state of a DAE: solve phi(x, t) = 0 (the DC operating point).

With ``d/dt q = 0`` the DAE ``d/dt q(x) = phi(x, t)`` reduces to the
nonlinear system ``phi(x, t) = 0`` (for circuits: capacitors open,
inductors shorted). This module solves it with Newton's method on the sparse
Jacobian ``dphi/dx``, using the homotopies SPICE uses when plain Newton fails:

1. plain Newton (with the devices' junction-voltage limiting),
2. *gmin stepping*: a conductance ``g`` from every voltage unknown to ground,
   decreased adaptively from ``GMIN_START`` to zero, each solution starting
   the next,
3. *source stepping*: every independent source scaled by ``s``, raised
   adaptively from 0 to 1.

Convergence follows SPICE: the Newton update is below
``reltol * max(|x_k|, |x_k+1|) + atol`` for every unknown (``vntol`` for
volts, ``abstol`` for amperes), no device limited its junction voltage in the
last iteration, and the residual of every equation is below ``reltol`` times
the magnitude of the terms that make it up plus the absolute tolerance of
that row (``abstol`` for current-law rows, ``vntol`` for voltage rows).

Failures are returned as data (:class:`SteadyResult` with ``converged=False``,
the unknowns that did not settle, and whether the Jacobian was singular),
never printed; the analysis layer turns them into circuit-level messages.

References
----------
.. [1] L. W. Nagel, *SPICE2: A computer program to simulate semiconductor
   circuits*, UCB/ERL M520, 1975 (Newton with limiting, convergence test).
.. [2] ngspice manual, Section 15.1 (gmin stepping, source stepping), and
   ``cktop.c`` for the adaptive schedules.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse.linalg as spla

from .system import KIND_CURRENT, KIND_OTHER, KIND_VOLTAGE, DaeSystem

__all__ = ["SteadyOptions", "SteadyResult", "Forcing", "solve_steady"]

#: gmin stepping starts one factor below this conductance [S] and, when a step
#: fails, moves back towards it (ngspice's dynamic gmin: OldGmin = 1e-2).
GMIN_ANCHOR = 1e-2
#: Conductance of the regularised start of source stepping [S].
GMIN_START = 1e-3
#: Initial and largest reduction factors of the gmin schedule.
GMIN_FACTOR_START = 10.0
GMIN_FACTOR_MAX = 1e3
#: Smallest useful reduction factor (below it the homotopy has stalled).
GMIN_FACTOR_MIN = 1.00005
#: First increment of source stepping and its smallest allowed value.
SOURCE_RAISE_START = 1e-3
SOURCE_RAISE_MIN = 1e-7
#: Growth of the source-stepping increment after a success.
SOURCE_RAISE_GROWTH = 1.5
#: Conductance that holds a node at its .ic/.nodeset value (ngspice uses 1e10 S).
FORCING_CONDUCTANCE = 1e10
#: Newton iteration limit inside each homotopy step (ngspice's itl3 default... itl1/4 is a fair share).
HOMOTOPY_MAXITER = 50
#: A Jacobian whose LU pivots span more than this ratio is treated as a failed
#: iteration (try the next homotopy), not as a singular circuit: badly scaled
#: regular Jacobians (1e10 S forcing next to 1e-12 S junctions) reach 1e-22.
SINGULAR_PIVOT_RATIO = 1e-30


@dataclass
class SteadyOptions:
    """Tolerances and limits of the steady-state solver (SPICE defaults)."""

    reltol: float = 1e-3
    vntol: float = 1e-6
    abstol: float = 1e-12
    atol_other: float = 1e-9
    gmin: float = 1e-12
    maxiter: int = 100
    gmin_stepping: bool = True
    source_stepping: bool = True


@dataclass
class Forcing:
    """Unknowns held at given values through a large conductance (``.ic``, ``.nodeset``).

    Attributes
    ----------
    index : ndarray of int
    value : ndarray of float
    conductance : float
    """

    index: np.ndarray
    value: np.ndarray
    conductance: float = FORCING_CONDUCTANCE


@dataclass
class SteadyResult:
    """Outcome of :func:`solve_steady`.

    Attributes
    ----------
    x : ndarray, shape (n,)
        The solution (or the last iterate on failure).
    converged : bool
    iterations : int
        Newton iterations over all strategies.
    factorizations : int
    strategy : str
        ``"newton"``, ``"gmin stepping"`` or ``"source stepping"``.
    message : str
    singular : bool
        The Jacobian was singular (structurally or numerically).
    null_vector : ndarray or None
        For a singular Jacobian of moderate size: a unit vector of its null
        space (which unknowns are undetermined).
    worst : list of int
        Unknowns that moved most (in tolerance units) in the last iteration, worst first.
    """

    x: np.ndarray
    converged: bool
    iterations: int = 0
    factorizations: int = 0
    strategy: str = "newton"
    message: str = ""
    singular: bool = False
    null_vector: np.ndarray | None = None
    worst: list[int] = field(default_factory=list)


class _Singular(Exception):
    """SuperLU found the Jacobian exactly singular."""


class _IllConditioned(Exception):
    """The LU pivots span more than SINGULAR_PIVOT_RATIO: a failed iteration."""


def _tolerances(kinds: np.ndarray, opts: SteadyOptions) -> tuple[np.ndarray, np.ndarray]:
    """Absolute tolerance per unknown and per equation row.

    Node rows are current-law equations (amperes) and branch rows voltage
    equations (volts), so the row tolerances swap the unknown's kinds.
    """
    x_atol = np.where(kinds == KIND_VOLTAGE, opts.vntol,
                      np.where(kinds == KIND_CURRENT, opts.abstol, opts.atol_other))
    r_atol = np.where(kinds == KIND_VOLTAGE, opts.abstol,
                      np.where(kinds == KIND_CURRENT, opts.vntol, opts.atol_other))
    return x_atol, r_atol


class _Newton:
    """Newton iterations on phi(x, t) = 0 for one homotopy parameter set."""

    def __init__(self, system: DaeSystem, t: float, opts: SteadyOptions, forcing: list[Forcing]):
        self.system = system
        self.t = t
        self.opts = opts
        self.forcing = forcing
        self.pattern = system.pattern
        self.volt = np.flatnonzero(system.kinds == KIND_VOLTAGE)
        if self.volt.size == 0:  # generic DAE: regularise every unknown
            self.volt = np.arange(system.n)
        self.x_atol, self.r_atol = _tolerances(system.kinds, opts)
        self.iterations = 0
        self.factorizations = 0
        self.last_used = 0
        self.last_dx = np.zeros(system.n)

    def _residual(self, x, gdiag, scale, state):
        ev = self.system.evaluate(x, self.t, jacobian=True, state=state, source_scale=scale)
        if not ev.ok:
            return None
        F = ev.phi.copy()
        jac = ev.dphi.copy()
        if gdiag:
            F[self.volt] -= gdiag * x[self.volt]
            jac[self.pattern.diag[self.volt]] -= gdiag
        for frc in self.forcing:
            F[frc.index] -= frc.conductance * (x[frc.index] - scale * frc.value)
            jac[self.pattern.diag[frc.index]] -= frc.conductance
        return ev, F, jac

    def _factor(self, jac):
        self.factorizations += 1
        mat = self.pattern.matrix(jac)
        try:
            lu = spla.splu(mat, permc_spec="COLAMD")
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise _Singular(str(exc)) from None
        d = np.abs(lu.U.diagonal())
        if d.size and d.min() <= SINGULAR_PIVOT_RATIO * d.max():
            raise _IllConditioned()
        return lu

    def _residual_small(self, F, jac, x) -> bool:
        absj = self.pattern.matrix(np.abs(jac))
        scale = absj @ np.abs(x)
        return bool(np.all(np.abs(F) <= self.opts.reltol * scale + self.r_atol))

    def solve(self, x, *, gdiag=0.0, scale=1.0, maxiter=None, init=False) -> tuple[np.ndarray, bool]:
        """Iterate from x; returns (x, converged). Raises _Singular.

        ``init`` starts the devices from their initial junction voltages
        (SPICE's MODEINITJCT), for a solve from scratch; otherwise they are
        evaluated at x (continuation from a previous solution).
        """
        maxiter = self.opts.maxiter if maxiter is None else maxiter
        state = self.system.initial_state() if init and hasattr(self.system, "initial_state") else None
        small_step = False
        x = np.array(x, dtype=float)
        for _ in range(maxiter):
            out = self._residual(x, gdiag, scale, state)
            if out is None:
                return x, False
            ev, F, jac = out
            if small_step and not ev.limited and self._residual_small(F, jac, x):
                return x, True
            self.iterations += 1
            try:
                lu = self._factor(jac)
            except _IllConditioned:
                return x, False
            dx = lu.solve(-F)
            if not np.all(np.isfinite(dx)):
                return x, False
            x_new = x + dx
            tol = self.opts.reltol * np.maximum(np.abs(x), np.abs(x_new)) + self.x_atol
            small_step = bool(np.all(np.abs(dx) <= tol))
            self.last_dx = np.abs(dx) / tol
            x = x_new
            state = ev.state
            if self.system.linear:
                # one Newton step solves a linear system; refine once and check the residual
                F = self._residual(x, gdiag, scale, None)[1]
                x = x + lu.solve(-F)
                ev, F, jac = self._residual(x, gdiag, scale, None)
                return x, self._residual_small(F, jac, x)
        return x, False


def _null_vector(system: DaeSystem, x, t) -> np.ndarray | None:
    """A null vector of dphi/dx at x (dense SVD, only for moderate sizes)."""
    if system.n > 3000:
        return None
    _, H = system.jacobians(x, t)
    _, s, vt = np.linalg.svd(H.toarray())
    return vt[-1] if s[-1] <= 1e-12 * max(s[0], 1e-300) else None


def solve_steady(system: DaeSystem, t: float = 0.0, x0: np.ndarray | None = None, *,
                 options: SteadyOptions | None = None, forcing: Forcing | None = None,
                 nodeset: Forcing | None = None) -> SteadyResult:
    """Solve ``phi(x, t) = 0``.

    Parameters
    ----------
    system : DaeSystem
    t : float
        Time at which the sources are evaluated.
    x0 : ndarray, shape (n,), optional
        Initial guess (default ``system.initial_guess()``).
    options : SteadyOptions, optional
    forcing : Forcing, optional
        Unknowns held at values for the whole solve (ngspice's ``.ic`` in the
        operating point of a transient).
    nodeset : Forcing, optional
        Unknowns held at values for a first solve only, whose solution is the
        initial guess of the free solve (``.nodeset``).

    Returns
    -------
    SteadyResult

    Notes
    -----
    Each Newton iteration costs one evaluation and one sparse LU. A linear
    system converges in one iteration plus one refinement step.
    """
    opts = options or SteadyOptions()
    x = np.asarray(system.initial_guess() if x0 is None else x0, dtype=float).copy()
    frc = [forcing] if forcing is not None else []
    total_it = total_fact = 0

    def result(x, ok, strategy, message, newton=None, singular=False):
        order = [] if newton is None else list(np.argsort(-newton.last_dx)[:5])
        null = _null_vector(system, x, t) if singular else None
        return SteadyResult(x, ok, total_it, total_fact, strategy, message, singular, null, order)

    def run(newton: _Newton, *args, **kw):
        nonlocal total_it, total_fact
        try:
            return newton.solve(*args, **kw)
        finally:
            total_it += newton.iterations
            total_fact += newton.factorizations
            newton.last_used = newton.iterations
            newton.iterations = newton.factorizations = 0

    newton = _Newton(system, t, opts, frc)
    init = x0 is None
    singular = None
    x_new = x
    try:
        if nodeset is not None:
            first = _Newton(system, t, opts, frc + [nodeset])
            x_ns, ok = run(first, x, init=init)
            if ok:
                x, init = x_ns, False
        x_new, ok = run(newton, x, init=init)
        if ok:
            return result(x_new, True, "newton", "converged", newton)
    except _Singular as exc:
        if system.linear:
            return result(x, False, "newton", f"singular Jacobian ({exc})", newton, singular=True)
        singular = exc  # a nonlinear Jacobian may be singular at this point only: try the homotopies
    try:
        if opts.gmin_stepping:
            x_g, ok = _gmin_stepping(newton, x, opts, run)
            if ok:
                return result(x_g, True, "gmin stepping", "converged with gmin stepping", newton)
        if opts.source_stepping:
            x_s, ok = _source_stepping(newton, x, opts, run)
            if ok:
                return result(x_s, True, "source stepping", "converged with source stepping", newton)
    except _Singular as exc:
        singular = singular or exc
    if singular is not None:
        return result(x, False, "newton", f"singular Jacobian ({singular})", newton, singular=True)
    return result(x_new, False, "newton", "no convergence (Newton, gmin stepping and source stepping failed)", newton)


def _gmin_stepping(newton: _Newton, x, opts: SteadyOptions, run):
    """Adaptive gmin homotopy (ngspice's dynamic gmin).

    Starts at ``GMIN_ANCHOR / factor``; after a success the conductance falls
    by a factor that grows while steps converge quickly; after a failure the
    factor shrinks to its fourth root and the conductance restarts from the
    last converged value (initially the anchor) divided by it, so a first
    failure *raises* the conductance towards the anchor. Ends with a solve
    without conductance from the solution at ``opts.gmin``.
    """
    factor = GMIN_FACTOR_START
    g_old = GMIN_ANCHOR
    gdiag = g_old / factor
    x_ok = np.asarray(x, dtype=float)
    fresh = True  # nothing converged yet: start the devices from scratch
    while True:
        x_new, ok = run(newton, x_ok, gdiag=gdiag, maxiter=HOMOTOPY_MAXITER, init=fresh)
        if ok:
            x_ok, fresh = x_new, False
            if gdiag <= opts.gmin:
                break
            used = newton.last_used
            if used <= HOMOTOPY_MAXITER // 4:
                factor = min(factor * np.sqrt(factor), GMIN_FACTOR_MAX)
            elif used > 3 * HOMOTOPY_MAXITER // 4:
                factor = np.sqrt(factor)
            g_old = gdiag
            gdiag = max(gdiag / factor, opts.gmin)
        else:
            factor = np.sqrt(np.sqrt(factor))
            if factor < GMIN_FACTOR_MIN:
                return x_ok, False
            gdiag = g_old / factor
    return run(newton, x_ok)


def _source_stepping(newton: _Newton, x, opts: SteadyOptions, run):
    """Adaptive ramp of every independent source from 0 to 1."""
    x0, ok = run(newton, np.zeros_like(x), scale=0.0, init=True)
    if not ok:
        x0, ok = _gmin_at_scale(newton, x0, opts, run, 0.0)
        if not ok:
            return x0, False
    done, raise_ = 0.0, SOURCE_RAISE_START
    cur = x0
    while done < 1.0:
        s = min(1.0, done + raise_)
        x_new, ok = run(newton, cur, scale=s, maxiter=HOMOTOPY_MAXITER)
        if ok:
            done, cur = s, x_new
            raise_ *= SOURCE_RAISE_GROWTH
        else:
            raise_ /= 10.0
            if raise_ < SOURCE_RAISE_MIN:
                return cur, False
    return cur, True


def _gmin_at_scale(newton: _Newton, x, opts, run, scale):
    """gmin stepping at a fixed source scale (used for the zero-source start)."""
    gdiag = GMIN_START
    cur = x
    while gdiag > opts.gmin:
        cur, ok = run(newton, cur, gdiag=gdiag, scale=scale, maxiter=HOMOTOPY_MAXITER)
        if not ok:
            return cur, False
        gdiag /= GMIN_FACTOR_START
    return run(newton, cur, scale=scale)
