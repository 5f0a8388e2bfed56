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

Each Newton solve is netdae's one Newton iteration
(:func:`netdae.dae.newton.newton`) under SPICE's stopping test
(:class:`~netdae.dae.newton.SpiceTest`), on the engine's sparse LU of the
equilibrated Jacobian; the homotopies are objects over it
(:class:`GminStepping`, :class:`SourceStepping`).

For an MNA system of the compiled engine's device families, the first phase
(plain Newton) runs in compiled code (:mod:`netdae.dae.compiled.steady`, the
same iteration step for step); where it would stop, this module's solver runs
from the start.

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
.. [3] C. T. Kelley and D. E. Keyes, "Convergence analysis of pseudo-transient
   continuation", SIAM J. Numer. Anal. 35(2), 1998 (the last strategy,
   :class:`PseudoTransient`).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from .kronecker import EPS, MatrixRank, default_rtol, matrix_rank, rank_decision
from .sparse import SparsePattern, residual_small
from .system import KIND_CURRENT, KIND_VOLTAGE, DaeSystem, Evaluation

__all__ = ["SteadyOptions", "SteadyResult", "Forcing", "ChargeGroup", "solve_steady", "jacobian_rank",
           "Homotopy", "GminStepping", "SourceStepping", "PseudoTransient", "PIVOT_SUSPECT", "PIVOT_SAFETY",
           "RANK_CHECK_LIMIT"]

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
#: Pseudo-transient continuation: the first capacitance-over-step conductance to the last pseudo-time
#: point [S], the largest it may rise to after failures, and its step factor's start, largest and
#: smallest values; a bound on pseudo-time steps and on their Newton iterations.
PTRAN_G_START = 1e-2
PTRAN_G_MAX = 1e4
PTRAN_FACTOR_START = 2.0
PTRAN_FACTOR_MAX = 16.0
PTRAN_FACTOR_MIN = 1.5
PTRAN_MAX_STEPS = 1000
PTRAN_MAX_ITERATIONS = 20_000
#: Newton iterations of one pseudo-time step (ngspice's ITL4 for a transient step is 10): a step is a
#: small move from a converged point and converges in a few where it converges at all; one where a
#: comparator or switch flips within it oscillates between the two states until cut
PTRAN_STEP_MAXITER = 15
#: Accepted points of the pseudo-transient kept to recognise a cycle (:func:`_returned`).
PTRAN_CYCLE_MEMORY = 64
#: A return counts only to a point at least this many accepted steps back ...
PTRAN_CYCLE_GAP = 4
#: ... with a point in between at least this many tolerances away from it.
PTRAN_CYCLE_EXCURSION = 100.0
#: An unknown that has turned back this many times, each after a swing of at least
#: PTRAN_CYCLE_EXCURSION tolerances, ...
PTRAN_SWING_REVERSALS = 8
#: ... its last swing at least this fraction of its largest: an oscillation that does not decay
#: (:class:`_Swings`).
PTRAN_SWING_SUSTAINED = 0.5
#: LU pivots are judged on the *equilibrated* Jacobian: every row, then every
#: column, scaled by a power of two so that its largest entry lies in (1/2, 1]
#: (so a 1e10 S forcing next to a 1e-12 S junction does not look singular,
#: and a matrix made singular by element values is not hidden by its scale).
#: A smallest pivot below ``PIVOT_SUSPECT`` calls for the SVD rank decision
#: (:func:`jacobian_rank`) when the system has at most ``RANK_CHECK_LIMIT``
#: unknowns.
PIVOT_SUSPECT = 1e-6
#: Above ``RANK_CHECK_LIMIT`` unknowns (or inside the iterations of a
#: nonlinear solve) a pivot below ``PIVOT_SAFETY * n * eps`` of the
#: equilibrated matrix counts as singular: n * eps is the rank tolerance of
#: the index analysis, and partial pivoting leaves the last pivot of a
#: rank-deficient matrix within a modest factor of it.
PIVOT_SAFETY = 1e3
#: Largest system whose suspicious Jacobian is judged by a dense SVD (about
#: a second at this size with one BLAS thread).
RANK_CHECK_LIMIT = 1500
#: Inside the iterations of a nonlinear solve, where a small pivot can recur at
#: every iteration, the SVD confirms it up to this size only (a few
#: milliseconds each); above it the pivot alone stops the iteration.
ITERATION_RANK_CHECK_LIMIT = 300


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
    #: After gmin and source stepping: pseudo-transient continuation (:class:`PseudoTransient`).
    pseudo_transient: bool = True
    #: Judge the Jacobian at the solution by an SVD rank decision when a pivot is small (a
    #: DC operating point). Off for an implicit-Euler step of a tiny size h, whose matrix
    #: ``dq/dx / h - dphi/dx`` spans many orders of magnitude while it is regular.
    judge_singular: bool = True


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
    rank : MatrixRank or None
        For a singular Jacobian judged by the SVD: the rank decision (tolerance,
        singular values) and both null spaces (``rank.left``: the dependent
        equations).
    min_pivot : float
        Smallest LU pivot of the equilibrated Jacobian at ``x`` (1 = perfectly
        conditioned diagonal; ``nan`` when not factored).
    notes : list of str
        Facts the caller reports with the result (filled by the analysis layer).
    not_finite : ndarray of int or None
        When the last solve stopped because the equations could not be
        evaluated (a non-finite residual or Jacobian entry, ``Evaluation.ok``
        false) at ``x``: the rows that were not finite there (empty when the
        system reported the failure without a non-finite row).
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
    rank: MatrixRank | None = None
    min_pivot: float = float("nan")
    notes: list[str] = field(default_factory=list)
    not_finite: np.ndarray | None = None


@dataclass
class ChargeGroup:
    """Equations whose right-hand sides add up to zero at steady state, and their conserved charge.

    When the rows ``rows`` of ``phi``, weighted by ``weights``, sum to zero
    identically (the current laws of a set of nodes attached to the rest only
    through capacitors, all weights 1: at DC no current enters the set; or a
    combination of current laws that controlled sources make dependent), the
    steady state is not unique; the weighted total ``sum(weights * q[rows])``,
    conserved by ``d/dt q = phi``, picks one. The first row's equation is
    replaced by ``sum(weights * q[rows]) = charge``.

    Attributes
    ----------
    rows : ndarray of int
        The group's rows; the first is the replaced one (distinct between groups; the other rows
        may be shared by several weighted groups).
    charge : float
    weights : ndarray of float, optional
        One per row (default: all 1).
    """

    rows: np.ndarray
    charge: float = 0.0
    weights: np.ndarray | None = None

    def row_weights(self) -> np.ndarray:
        """The weights, one per row (ones when none were given)."""
        return np.ones(len(self.rows)) if self.weights is None else np.asarray(self.weights, dtype=float)


class _Singular(Exception):
    """The Jacobian is singular (exactly, or by the rank decision carried as ``args[1]``)."""

    @property
    def rank(self) -> MatrixRank | None:
        return self.args[1] if len(self.args) > 1 else None


def _power_of_two_scale(m: np.ndarray) -> np.ndarray:
    """``2**-ceil(log2(m))`` for positive entries, 1 elsewhere."""
    m = np.asarray(m, dtype=float)
    out = np.ones_like(m)
    pos = m > 0
    out[pos] = np.ldexp(1.0, -np.ceil(np.log2(m[pos])).astype(int))
    return out


def _equilibrate(pattern: SparsePattern, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row scales, then column scales, by powers of two: largest entry of each in (1/2, 1]."""
    a = np.abs(data)
    rmax = np.zeros(pattern.n)
    np.maximum.at(rmax, pattern.rows, a)
    r = _power_of_two_scale(rmax)
    cmax = np.zeros(pattern.n)
    np.maximum.at(cmax, pattern.cols, a * r[pattern.rows])
    return r, _power_of_two_scale(cmax)


def _check_pivot(pattern: SparsePattern, data: np.ndarray, min_pivot: float, linear: bool) -> bool:
    """Judge the smallest equilibrated pivot of a factorisation of ``data``: False for an ill-conditioned
    nonlinear Jacobian (a failed iteration); raises :class:`_Singular` for a singular linear one.

    A pivot at or below ``PIVOT_SAFETY * n * eps`` is confirmed by the SVD rank decision
    (:func:`jacobian_rank`) up to ``RANK_CHECK_LIMIT`` unknowns, in a Newton iteration too (up to
    ``ITERATION_RANK_CHECK_LIMIT``, since it may recur at every iteration): a regular Jacobian can
    have such a pivot, as where a node reaches ground only through the 1e-12 S gmin of
    reverse-biased junctions next to a 1 S resistor (a pivot of 1e-12 against a threshold of
    8 * 1e3 * eps at eight unknowns), and refusing it would stop every iteration there.
    """
    n = pattern.n
    if min_pivot > PIVOT_SAFETY * n * EPS:
        return True
    # the SVD's decision where it is affordable, else the small pivot's
    # inside a nonlinear solve only the verdict is used (singular values alone: a third of the SVD's cost)
    rank = jacobian_rank(pattern.matrix(data), vectors=linear) \
        if n <= (RANK_CHECK_LIMIT if linear else ITERATION_RANK_CHECK_LIMIT) else None
    if rank is not None and not rank.deficient:
        return True
    if not linear:
        return False
    if rank is None:
        raise _Singular(f"smallest pivot {min_pivot:.3g} of the equilibrated matrix")
    raise _Singular(f"rank {rank.rank} of {n}", rank)


class _FreshLU:
    """One fresh SuperLU factorisation of ``diag(r) A diag(c)``, solving ``A x = b``.

    For a matrix factored once (a linear system's steady state, the
    singularity judgement at a solution): SuperLU's own factors, in the pivot
    order the engine's LU would take from it too. ``r`` and ``c`` scale every
    row, then every column, by a power of two so that its largest entry lies
    in (1/2, 1] (:func:`_equilibrate`). Raises :class:`_Singular` when
    SuperLU finds the matrix exactly singular.
    """

    def __init__(self, pattern: SparsePattern, data: np.ndarray):
        import scipy.sparse.linalg as spla

        self.r, self.c = _equilibrate(pattern, data)
        scaled = pattern.matrix(data * self.r[pattern.rows] * self.c[pattern.cols])
        try:
            self.lu = spla.splu(scaled, permc_spec="COLAMD")
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise _Singular(str(exc)) from None
        d = np.abs(self.lu.U.diagonal())
        self.min_pivot = float(d.min()) if d.size else 1.0

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.c * self.lu.solve(self.r * b)


def _lu_cache(system: DaeSystem):
    """The engine's LU kept for ``system``'s Newton iterations: its pivot order serves the next solves too
    (a ``.dc`` sweep's points, the homotopies' steps), chosen afresh only where a pivot degrades."""
    from .newton import LuCache  # the engine's LU (numba): not imported by `netdae check` / `index`

    try:
        cache = _LU_CACHES.get(system)
    except TypeError:  # a system that cannot be weakly referenced: a cache of this solve's own
        return LuCache(system.pattern, permc_spec="COLAMD")
    if cache is None or cache.pattern is not system.pattern:
        cache = _LU_CACHES[system] = LuCache(system.pattern, permc_spec="COLAMD")
    return cache


#: The LU of each system solved by Newton iterations (its pivot order), for its next solves.
_LU_CACHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class _EquilibratedLU:
    """The engine's LU (:class:`~netdae.dae.newton.LuCache`) of ``diag(r) A diag(c)`` for Newton iterations.

    ``A`` is given by its values on a pattern, scaled as in :class:`_FreshLU`;
    the pivot order is kept from one iteration to the next (and from one
    homotopy solve to the next) and refreshed when a pivot degrades.
    :meth:`factor` judges the smallest equilibrated pivot: at or below
    ``PIVOT_SAFETY * n * eps`` the (nonlinear) Jacobian is ill-conditioned: a
    failed iteration (returns False and sets :attr:`ill_conditioned`).

    Attributes
    ----------
    min_pivot : float
        Smallest equilibrated pivot of the last factorisation (nan: none).
    ill_conditioned : bool
        A factorisation met an ill-conditioned Jacobian.
    """

    def __init__(self, system: DaeSystem) -> None:
        self.pattern = system.pattern
        self.cache = _lu_cache(system)
        self.r = self.c = None
        self.min_pivot = float("nan")
        self.ill_conditioned = False

    @property
    def ready(self) -> bool:
        return self.cache.ready

    def factor(self, data: np.ndarray, tag=None) -> bool:
        """Factor the equilibrated matrix and judge its pivots. Raises _Singular when exactly singular."""
        self.min_pivot = float("nan")
        if not np.all(np.isfinite(data)):
            return False
        pat = self.pattern
        self.r, self.c = _equilibrate(pat, data)
        if not self.cache.factor(data * self.r[pat.rows] * self.c[pat.cols]):
            raise _Singular("Factor is exactly singular")
        piv = self.cache.lu.pivots()
        self.min_pivot = float(piv.min()) if piv.size else 1.0
        if not _check_pivot(pat, data, self.min_pivot, False):
            self.ill_conditioned = True
            return False
        return True

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.c * self.cache.solve(self.r * b)


#: A rank decision with a singular value within this factor of its tolerance is unclear: at the same rank,
#: the other scaling's clearer decision gives the null spaces (:func:`jacobian_rank`).
UNCLEAR_MARGIN = 10.0


def jacobian_rank(mat, what: str = "rank of the steady-state Jacobian", *, vectors: bool = True) -> MatrixRank:
    """The SVD rank decision of a steady-state Jacobian.

    First as the index analysis decides it (:func:`~netdae.dae.kronecker.matrix_rank`,
    Ward's balancing). A deficient verdict is checked on the max-equilibrated
    matrix too (every row, then every column, scaled by a power of two so
    that its largest entry lies in (1/2, 1], as the LU pivots are judged):
    when its singular values all exceed the same relative tolerance
    (``n * eps * ||.||_F``), the matrix is regular, since a diagonal scaling
    changes no entry's relative rounding error, and that verdict is returned
    (with empty null spaces). Ward's balancing brings every significant entry
    toward one; next to the 1e3 S contact resistances of a compact MOS model,
    the 1e-12 S gate slopes of an off transistor pull it to a scaling whose
    Frobenius norm hides a regular matrix (a BSIM-BULK inverter's DC matrix).
    When the max-equilibrated matrix is deficient too but has the higher
    rank, its verdict and null spaces are returned: singular values above the
    tolerance on either scaling are not rounding (ngspice's
    ``cpl_ibm1.sp``: 2 floating conductors, where Ward's scaling dropped 34);
    at the same rank, where Ward's decision is unclear (a
    :attr:`~netdae.dae.kronecker.RankDecision.margin` below
    :data:`UNCLEAR_MARGIN`), those of the clearer one.

    Parameters
    ----------
    mat : ndarray or sparse matrix, shape (n, n)
    what : str
        Description kept in the decision.
    vectors : bool
        Compute the null spaces (default); the verdict alone costs about a third.

    Returns
    -------
    MatrixRank
        Without ``vectors``, with empty null spaces.
    """
    rank = matrix_rank(mat, what=what, vectors=vectors)
    if not rank.deficient:
        return rank
    a = mat.toarray() if hasattr(mat, "toarray") else np.array(mat, dtype=float)
    n = a.shape[0]
    r = _power_of_two_scale(np.abs(a).max(axis=1))
    c = _power_of_two_scale(np.abs(r[:, None] * a).max(axis=0))
    scaled = r[:, None] * a * c[None, :]
    sigma = np.linalg.svd(scaled, compute_uv=False)
    decision = rank_decision(sigma, default_rtol(n) * float(np.linalg.norm(scaled)), what + " (max-equilibrated)",
                             a.shape)
    better = decision.rank > rank.rank or (decision.rank == rank.rank and rank.decision.margin < UNCLEAR_MARGIN
                                           and decision.margin > rank.decision.margin)
    if decision.rank == n or (better and not vectors):
        return MatrixRank(decision, np.zeros((n, 0)), np.zeros((n, 0)))
    if better:
        # fewer null directions on this scaling: the others are independent columns, whatever the scaling, and
        # the null spaces come from its SVD (a coupled line's two floating conductors, cpl_ibm1.sp: 2 null
        # directions where Ward's scaling, pulled by the line's modal sources, dropped 34). At the same rank
        # the clearer decision gives the null spaces: a kept singular value at the tolerance (a floating
        # conductor of tests/test_line_charge.py, 1.09 times it on Ward's scaling with one BLAS kernel, below
        # it with another) leaves the null vector mixed with its direction
        P, sigma, WT = np.linalg.svd(scaled)
        return MatrixRank(decision, c[:, None] * WT[decision.rank:].T, r[:, None] * P[:, decision.rank:])
    return rank


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
    """The steady state's Newton problem: ``phi(x, t) = 0`` at one homotopy parameter set per solve.

    Each :meth:`solve` runs netdae's one Newton iteration
    (:func:`netdae.dae.newton.newton`: full Newton, SPICE's stopping test
    :class:`~netdae.dae.newton.SpiceTest`) on ``phi`` plus the homotopy's
    conductance ``gdiag`` from every voltage unknown to ground, with the
    sources scaled by ``scale`` and the forced unknowns held by
    ``FORCING_CONDUCTANCE``; the LU is the engine's, equilibrated
    (:class:`_EquilibratedLU`), its pivot order kept across solves. A linear
    system is not iterated: one factorisation (:class:`_FreshLU`), the solve
    and one refinement, accepted when the residual is small.

    Attributes
    ----------
    iterations, factorizations : int
        Totals over all solves.
    last_used : int
        Iterations of the last solve (the gmin schedule adapts to it).
    """

    def __init__(self, system: DaeSystem, t: float, opts: SteadyOptions, forcing: list[Forcing]):
        self.system = system
        self.t = t
        self.opts = opts
        self.forcing = forcing
        self.pattern = system.pattern
        self.paired = np.asarray(system.kinds == KIND_VOLTAGE)  # a node's potential and its current law
        self.volt = np.flatnonzero(self.paired)
        if self.volt.size == 0:  # generic DAE: regularise every unknown
            self.volt = np.arange(system.n)
        self.x_atol, self.r_atol = _tolerances(system.kinds, opts)
        self.weights = 1.0 / self.x_atol
        self._lu = self._stop = None  # made at the first nonlinear solve
        self.iterations = 0
        self.factorizations = 0
        self.last_used = 0
        self.last_pivot = float("nan")  # smallest equilibrated pivot of the last factorization
        self.last_dx = np.zeros(system.n)  # |dx| / tolerance of the last update
        self.ill_conditioned = False  # an iteration met an ill-conditioned Jacobian
        self.not_finite = None  # rows not finite where the last solve could not evaluate its iterate (x, rows)

    def _residual(self, x, gdiag, scale, state, anchor=None):
        ev = self.system.evaluate(x, self.t, jacobian=True, state=state, source_scale=scale)
        if not ev.ok:
            self.not_finite = (np.array(x, dtype=float), _non_finite_rows(self.pattern, ev))
            return None
        F = ev.phi.copy()
        jac = ev.dphi.copy()
        if gdiag:  # a conductance from every node to ground, or to its value at ``anchor``
            F[self.volt] -= gdiag * (x[self.volt] if anchor is None else x[self.volt] - anchor[self.volt])
            jac[self.pattern.diag[self.volt]] -= gdiag
        for frc in self.forcing:
            F[frc.index] -= frc.conductance * (x[frc.index] - scale * frc.value)
            jac[self.pattern.diag[frc.index]] -= frc.conductance
        return ev, F, jac

    def _residual_small(self, F, jac, x) -> bool:
        return residual_small(self.pattern, F, jac, x, self.opts.reltol, self.r_atol, self.paired)

    def solve(self, x, *, gdiag=0.0, scale=1.0, maxiter=None, init=False, anchor=None) -> tuple[np.ndarray, bool]:
        """Iterate from x; returns (x, converged). Raises _Singular.

        ``init`` starts the devices from their initial junction voltages
        (SPICE's MODEINITJCT), for a solve from scratch; otherwise they are
        evaluated at x (continuation from a previous solution). ``gdiag`` adds
        a conductance from every node to ground, or with ``anchor`` (shape
        (n,)) to the node's value there (a pseudo-time step).
        """
        if self.system.linear:
            return self._solve_linear(np.array(x, dtype=float), gdiag, scale)
        from .newton import SpiceTest, newton

        if self._lu is None:
            self._lu = _EquilibratedLU(self.system)
            self._stop = SpiceTest(self.pattern, self.opts.reltol, self.x_atol, self.r_atol, self.paired)
        lu = self._lu
        maxiter = self.opts.maxiter if maxiter is None else maxiter
        self.not_finite = None
        state = [self.system.initial_state() if init and hasattr(self.system, "initial_state") else None]
        counted = lu.cache.factorizations

        def fun(xv, jacobian):
            out = self._residual(xv, gdiag, scale, state[0], anchor)
            if out is None:
                return None, None, False, False
            ev, F, jac = out
            state[0] = ev.state
            return F, jac, True, bool(ev.limited)

        try:
            res = newton(fun, x, lu, self.weights, maxiter=maxiter, jacobian="always", stop=self._stop)
        finally:
            self.factorizations += lu.cache.factorizations - counted
            self.ill_conditioned |= lu.ill_conditioned
        if math.isfinite(lu.min_pivot):
            self.last_pivot = lu.min_pivot
        self.iterations += res.iterations
        self.last_used = res.iterations
        self.last_dx = self._stop.last_dx
        return res.x, res.converged

    def _solve_linear(self, x, gdiag, scale) -> tuple[np.ndarray, bool]:
        """One factorisation (:class:`_FreshLU`, judged), the solve, one refinement, the residual test."""
        self.not_finite = None
        out = self._residual(x, gdiag, scale, None)
        if out is None:
            return x, False
        _, F, jac = out
        self.iterations += 1
        self.last_used = 1
        self.factorizations += 1
        lu = _FreshLU(self.pattern, jac)
        self.last_pivot = lu.min_pivot
        _check_pivot(self.pattern, jac, lu.min_pivot, True)
        dx = lu.solve(-F)
        if not np.all(np.isfinite(dx)):
            return x, False
        x_new = x + dx
        self.last_dx = np.abs(dx) / (self.opts.reltol * np.maximum(np.abs(x), np.abs(x_new)) + self.x_atol)
        x = x_new + lu.solve(-self._residual(x_new, gdiag, scale, None)[1])
        _, F, jac = self._residual(x, gdiag, scale, None)
        return x, self._residual_small(F, jac, x)


class _ChargeRows(DaeSystem):
    """``system`` with the first row of each :class:`ChargeGroup` replaced by its charge balance.

    Row ``r`` of a group becomes ``sum(w * q[rows]) - charge`` (scaled by the
    source scale, so that source stepping starts from zero charge); its
    Jacobian row is the weighted sum of the ``dq`` rows of the group, laid out
    on a pattern that extends the system's by those entries. A system with a
    ``line_charge`` matrix (a steady form's transmission lines) adds
    ``line_charge @ x`` to ``q`` there.
    """

    def __init__(self, system: DaeSystem, groups: list[ChargeGroup]):
        self.inner = system
        self.n, self.names, self.kinds, self.linear = system.n, system.names, system.kinds, system.linear
        old = system.pattern
        self.first = np.array([int(g.rows[0]) for g in groups], dtype=np.int64)
        self.charge = np.array([float(g.charge) for g in groups])
        members, labels, weights = [], [], []
        src, dst_rows, src_w = [], [], []
        for k, g in enumerate(groups):
            rows = np.asarray(g.rows, dtype=np.int64)
            w = g.row_weights()
            members.append(rows)
            labels.append(np.full(rows.size, k, dtype=np.int64))
            weights.append(w)
            weight_of = np.zeros(system.n)
            weight_of[rows] = w
            e = np.flatnonzero(weight_of[old.rows] != 0.0)  # dq entries that add into the replaced row
            src.append(e)
            dst_rows.append(np.full(e.size, rows[0], dtype=np.int64))
            src_w.append(weight_of[old.rows[e]])
        cat = (lambda parts, dtype: np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype))
        self.member, self.label, self.weight = cat(members, np.int64), cat(labels, np.int64), cat(weights, float)
        self.src, self.src_w = cat(src, np.int64), cat(src_w, float)
        dst_rows = cat(dst_rows, np.int64)
        # the charge transmission lines hold at DC (a steady form's ``line_charge``): constant rows
        self.line = getattr(system, "line_charge", None)
        line_rows, line_cols, self.line_val = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        if self.line is not None and groups:
            W = sp.csr_matrix((self.weight, (self.label, self.member)), shape=(len(groups), system.n))
            G = (W @ self.line).tocoo()
            line_rows, line_cols, self.line_val = self.first[G.row], G.col.astype(np.int64), G.data
        self.pattern = SparsePattern.from_coo(system.n, [old.rows, dst_rows, line_rows],
                                              [old.cols, old.cols[self.src], line_cols])
        self.old_slots = self.pattern.slots(old.rows, old.cols)
        self.keep = ~np.isin(old.rows, self.first)  # dphi entries of replaced rows are dropped
        self.dst = self.pattern.slots(dst_rows, old.cols[self.src])
        self.line_dst = self.pattern.slots(line_rows, line_cols)

    def evaluate(self, x, t, *, jacobian=True, state=None, source_scale=1.0) -> Evaluation:
        ev = self.inner.evaluate(x, t, jacobian=jacobian, state=state, source_scale=source_scale)
        phi = ev.phi.copy()
        q = ev.q if self.line is None else ev.q + self.line @ np.asarray(x, dtype=float)
        totals = np.bincount(self.label, weights=self.weight * q[self.member], minlength=self.first.size)
        phi[self.first] = totals - source_scale * self.charge
        dq = dphi = None
        if ev.dphi is not None:
            # np.bincount returns integers when its input is empty (a circuit whose only entries
            # are in replaced rows, a current source into a node of capacitors): sum in floats
            nnz = self.pattern.nnz
            dq = np.bincount(self.old_slots, weights=ev.dq, minlength=nnz).astype(float, copy=False)
            dphi = np.bincount(self.old_slots[self.keep], weights=ev.dphi[self.keep],
                               minlength=nnz).astype(float, copy=False)
            dphi += np.bincount(self.dst, weights=self.src_w * ev.dq[self.src], minlength=nnz)
            if self.line_dst.size:
                dphi += np.bincount(self.line_dst, weights=self.line_val, minlength=nnz)
        return Evaluation(q=ev.q, phi=phi, dq=dq, dphi=dphi, limited=ev.limited, state=ev.state, ok=ev.ok)

    def initial_guess(self):
        return self.inner.initial_guess()

    def initial_state(self):
        return self.inner.initial_state() if hasattr(self.inner, "initial_state") else None


def _non_finite_rows(pattern: SparsePattern, ev: Evaluation) -> np.ndarray:
    """Rows of an evaluation whose residual or Jacobian entries are not finite."""
    bad = ~np.isfinite(ev.phi)
    for data in (ev.dphi, ev.dq):
        if data is not None:
            bad[pattern.rows[~np.isfinite(data)]] = True
    return np.flatnonzero(bad)


def _judge(newton: _Newton, x) -> tuple[float, MatrixRank | None, bool]:
    """Is the Jacobian of the solved equations singular at x? ``(min_pivot, rank, singular)``.

    The equilibrated LU of the last Newton iteration (at a point within the
    convergence tolerance of x), or else one at x, decides when its smallest
    pivot is clear; a pivot
    below ``PIVOT_SUSPECT`` is confirmed or refuted by the SVD rank decision
    (up to ``RANK_CHECK_LIMIT`` unknowns, else by ``PIVOT_SAFETY * n * eps``).
    """
    n = newton.system.n
    if n == 0:
        return 1.0, None, False
    if newton.last_pivot > PIVOT_SUSPECT:  # the last Newton matrix, within the tolerance of x: clear
        return newton.last_pivot, None, False
    out = newton._residual(x, 0.0, 1.0, None)
    if out is None:
        return float("nan"), None, False
    mat = newton.pattern.matrix(out[2])
    try:
        pivot = _FreshLU(newton.pattern, out[2]).min_pivot
    except _Singular:
        pivot = 0.0
    if pivot > PIVOT_SUSPECT:
        return pivot, None, False
    if n > RANK_CHECK_LIMIT:
        return pivot, None, pivot <= PIVOT_SAFETY * n * EPS
    rank = jacobian_rank(mat)
    return pivot, rank, rank.deficient


def solve_steady(system: DaeSystem, t: float = 0.0, x0: np.ndarray | None = None, *,
                 options: SteadyOptions | None = None, forcing: Forcing | None = None,
                 nodeset: Forcing | None = None, charges: list[ChargeGroup] | None = None) -> SteadyResult:
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
    charges : list of ChargeGroup, optional
        Groups of rows whose right-hand sides sum to zero: each group's first
        equation is replaced by the conservation of its charge. The caller
        checks that the dropped equation holds at the solution.

    Returns
    -------
    SteadyResult
        ``converged`` only when the Jacobian of the solved equations is
        nonsingular at the solution: a solution that LU rounding produced
        from a singular matrix is returned as ``singular`` with the rank
        decision and null spaces.

    Notes
    -----
    Each Newton iteration costs one evaluation and one sparse LU of the
    equilibrated Jacobian. A linear system converges in one iteration plus
    one refinement step. The final singularity judgement reuses the last
    LU; only when its smallest pivot is below ``PIVOT_SUSPECT`` does it cost
    one more evaluation and LU at the solution and a dense SVD.
    """
    opts = options or SteadyOptions()
    if charges:
        system = _ChargeRows(system, charges)
    x = np.asarray(system.initial_guess() if x0 is None else x0, dtype=float).copy()
    frc = [forcing] if forcing is not None else []
    newton = _Newton(system, t, opts, frc)
    solvers = [newton]  # every Newton problem of this solve, for the totals
    compiled_work = [0, 0]  # iterations and factorizations of the compiled plain Newton

    def totals():
        return (sum(s.iterations for s in solvers) + compiled_work[0],
                sum(s.factorizations for s in solvers) + compiled_work[1])

    def singular_result(x, message, rank=None):
        if rank is None and system.n <= RANK_CHECK_LIMIT:
            out = newton._residual(x, 0.0, 1.0, None)
            rank = jacobian_rank(newton.pattern.matrix(out[2])) if out is not None else None
        if rank is not None and not rank.deficient and not system.linear:
            # singular at an iterate only (a device law of zero slope there): Newton failed at x
            return result(x, False, "newton", f"no convergence ({message}; regular at the last iterate)")
        null = rank.right[:, -1] if rank is not None and rank.right.shape[1] else None
        return SteadyResult(x, False, *totals(), "newton", message, True, null, [], rank)

    def result(x, ok, strategy, message):
        order = list(np.argsort(-newton.last_dx)[:5])
        pivot = float("nan")
        if ok and opts.judge_singular:
            pivot, rank, singular = _judge(newton, x)
            if singular:
                dec = "" if rank is None else (f": rank {rank.rank} of {system.n}, smallest singular value "
                                               f"{(rank.decision.dropped or (0.0,))[0]:.3g} <= tolerance "
                                               f"{rank.decision.tol:.3g}")
                return singular_result(x, "singular Jacobian at the solution" + dec, rank)
        return SteadyResult(x, ok, *totals(), strategy, message, False, None, order, None, pivot)

    init = x0 is None
    singular = None
    x_new = x
    if not frc and nodeset is None and not charges and _compiled(system):
        # plain Newton in the compiled engine; where it would stop, the Python solver below starts over
        from .compiled import steady_driver as compiled

        x_c, status, its, facts, pivot = compiled.solve_dc(
            system, t, x, init=init, maxiter=opts.maxiter, reltol=opts.reltol, x_atol=newton.x_atol,
            r_atol=newton.r_atol, singular_pivot=PIVOT_SAFETY * system.n * EPS)
        compiled_work[:] = its, facts
        if status == compiled.CONVERGED:
            newton.last_pivot = pivot
            return result(x_c, True, "newton", "converged")
    try:
        if nodeset is not None:
            first = _Newton(system, t, opts, frc + [nodeset])
            solvers.append(first)
            x_ns, ok = first.solve(x, init=init)
            if ok:
                x, init = x_ns, False
        x_new, ok = newton.solve(x, init=init)
        if ok:
            return result(x_new, True, "newton", "converged")
    except _Singular as exc:
        if system.linear:
            return singular_result(x, f"singular Jacobian ({exc.args[0]})", exc.rank)
        singular = exc  # a nonlinear Jacobian may be singular at this point only: try the homotopies
    homotopies = [h for h, on in ((GminStepping(opts.gmin), opts.gmin_stepping),
                                  (SourceStepping(opts.gmin), opts.source_stepping),
                                  (PseudoTransient(opts.gmin, init), opts.pseudo_transient)) if on]
    try:
        for homotopy in homotopies:
            x_h, ok = homotopy(newton, x)
            if ok:
                return result(x_h, True, homotopy.name, f"converged with {homotopy.name}")
    except _Singular as exc:
        singular = singular or exc
    if singular is not None:
        return singular_result(x, f"singular Jacobian ({singular.args[0]})", singular.rank)
    if newton.ill_conditioned:  # the iterations met near-singular Jacobians: is the last iterate's singular?
        _, rank, is_singular = _judge(newton, x_new)
        if is_singular:
            return singular_result(x_new, "singular Jacobian (Newton, gmin stepping, source stepping and "
                                   "pseudo-transient continuation failed)", rank)
    if newton.not_finite is not None:  # the last solve could not evaluate its iterate: say so, with where
        x_bad, rows = newton.not_finite
        out = result(x_bad, False, "newton", "the equations are not finite at the iterate (Newton, gmin stepping, "
                     "source stepping and pseudo-transient continuation stopped there)")
        out.not_finite = rows
        return out
    return result(x_new, False, "newton", "no convergence (Newton, gmin stepping, source stepping and "
                  "pseudo-transient continuation failed)")


def _compiled(system: DaeSystem) -> bool:
    """Whether plain Newton runs in the compiled engine (an MNA system of its device families;
    not with ``NETDAE_ENGINE=python``, which keeps every solve in Python). Cheap after a
    system's first solve (a ``.dc`` sweep asks at every point)."""
    if not getattr(system, "families", None):
        return False
    from .bdf import _compiled_engine_enabled

    if not _compiled_engine_enabled():
        return False
    ok = _ELIGIBLE.get(system)
    if ok is None:
        from .compiled.steady_driver import eligible

        ok = _ELIGIBLE[system] = eligible(system)
    return ok


#: Systems asked about by :func:`_compiled`, and the answer.
_ELIGIBLE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class Homotopy(Protocol):
    """A continuation from an easy problem to ``phi(x, t) = 0``, each of its solutions starting the next solve.

    ``homotopy(newton, x) -> (x, converged)`` drives the Newton problem's
    parameters (its conductance to ground ``gdiag``, its source scale); it
    may raise ``_Singular``. ``name`` is reported as the solve's strategy.
    """

    name: str

    def __call__(self, newton: _Newton, x: np.ndarray) -> tuple[np.ndarray, bool]: ...


@dataclass(frozen=True)
class GminStepping:
    """Adaptive gmin homotopy (ngspice's dynamic gmin).

    Starts at ``GMIN_ANCHOR / factor``; after a success the conductance falls
    by a factor that grows while steps converge quickly; after a failure the
    factor shrinks to its fourth root and the conductance restarts from the
    last converged value (initially the anchor) divided by it, so a first
    failure *raises* the conductance towards the anchor. Ends with a solve
    without conductance from the solution at ``gmin``.

    Parameters
    ----------
    gmin : float
        The last conductance of the schedule [S].
    """

    gmin: float
    name: str = "gmin stepping"

    def __call__(self, newton: _Newton, x: np.ndarray) -> tuple[np.ndarray, bool]:
        factor = GMIN_FACTOR_START
        g_old = GMIN_ANCHOR
        gdiag = g_old / factor
        x_ok = np.asarray(x, dtype=float)
        fresh = True  # nothing converged yet: start the devices from scratch
        while True:
            x_new, ok = newton.solve(x_ok, gdiag=gdiag, maxiter=HOMOTOPY_MAXITER, init=fresh)
            if ok:
                x_ok, fresh = x_new, False
                if gdiag <= self.gmin:
                    break
                used = newton.last_used
                if used <= HOMOTOPY_MAXITER // 4:
                    factor = min(factor * np.sqrt(factor), GMIN_FACTOR_MAX)
                elif used > 3 * HOMOTOPY_MAXITER // 4:
                    factor = np.sqrt(factor)
                g_old = gdiag
                gdiag = max(gdiag / factor, self.gmin)
            else:
                factor = np.sqrt(np.sqrt(factor))
                if factor < GMIN_FACTOR_MIN:
                    return x_ok, False
                gdiag = g_old / factor
        return newton.solve(x_ok)


@dataclass(frozen=True)
class SourceStepping:
    """Adaptive ramp of every independent source from 0 to 1.

    The zero-source start is solved by plain Newton, or else by a gmin ramp
    from ``GMIN_START`` down to ``gmin`` at zero sources; then the source
    scale rises by ``SOURCE_RAISE_START``, growing by
    ``SOURCE_RAISE_GROWTH`` after a success and divided by ten after a
    failure (down to ``SOURCE_RAISE_MIN``).

    Parameters
    ----------
    gmin : float
        The last conductance of the zero-source gmin ramp [S].
    """

    gmin: float
    name: str = "source stepping"

    def __call__(self, newton: _Newton, x: np.ndarray) -> tuple[np.ndarray, bool]:
        x0, ok = newton.solve(np.zeros_like(x), scale=0.0, init=True)
        if not ok:
            x0, ok = self._gmin_at_zero(newton, x0)
            if not ok:
                return x0, False
        done, raise_ = 0.0, SOURCE_RAISE_START
        cur = x0
        while done < 1.0:
            s = min(1.0, done + raise_)
            x_new, ok = newton.solve(cur, scale=s, maxiter=HOMOTOPY_MAXITER)
            if ok:
                done, cur = s, x_new
                raise_ *= SOURCE_RAISE_GROWTH
            else:
                raise_ /= 10.0
                if raise_ < SOURCE_RAISE_MIN:
                    return cur, False
        return cur, True

    def _gmin_at_zero(self, newton: _Newton, x: np.ndarray) -> tuple[np.ndarray, bool]:
        gdiag = GMIN_START
        cur = x
        while gdiag > self.gmin:
            cur, ok = newton.solve(cur, gdiag=gdiag, scale=0.0, maxiter=HOMOTOPY_MAXITER)
            if not ok:
                return cur, False
            gdiag /= GMIN_FACTOR_START
        return newton.solve(cur, scale=0.0)


def _distance(a: np.ndarray, b: np.ndarray, rtol: float, x_atol: np.ndarray) -> np.ndarray:
    """``|a - b|`` in tolerances (``rtol`` of the larger magnitude plus ``x_atol``), entry by entry."""
    return np.abs(a - b) / (rtol * np.maximum(np.abs(a), np.abs(b)) + x_atol)


def _returned(visited: np.ndarray, count: int, x: np.ndarray, rtol: float, x_atol: np.ndarray) -> bool:
    """Whether pseudo-transient continuation came back to a point it left: a cycle, not a way to a steady state.

    ``visited`` holds the last accepted points (a ring of :data:`PTRAN_CYCLE_MEMORY`, ``count`` written);
    ``x`` returned when it is within tolerance (``rtol`` of the larger magnitude plus ``x_atol``, as
    the steps' "moved" test) of a point at least :data:`PTRAN_CYCLE_GAP` steps back, and a point in
    between was :data:`PTRAN_CYCLE_EXCURSION` tolerances away from it. A relaxation oscillator (a
    switch or comparator that contradicts every DC state) goes round in pseudo-time as in time, and
    without this test spent the whole budget (20,000 Newton iterations, 1.2-3.6 s of CPU on a switch
    with hysteresis discharging the capacitor it senses) before the operating point was given up;
    a path to a steady state (a chain whose stages switch one at a time) never returns.
    """
    m = min(count, PTRAN_CYCLE_MEMORY)
    if m <= PTRAN_CYCLE_GAP:
        return False
    order = (np.arange(count - m, count) % PTRAN_CYCLE_MEMORY)  # oldest first
    pts = visited[order]
    dist = np.max(_distance(pts, x, rtol, x_atol), axis=1)
    for j in range(m - PTRAN_CYCLE_GAP):
        if dist[j] <= 1.0 and np.max(dist[j + 1:]) > PTRAN_CYCLE_EXCURSION:
            return True
    return False


class _Swings:
    """Each unknown's swings along the pseudo-transient's accepted points: a sustained oscillation.

    A zigzag of every unknown: a turn is counted where it moved back from its extreme by more than
    :data:`PTRAN_CYCLE_EXCURSION` tolerances (``rtol`` of its magnitude plus ``x_atol``), its swing
    being the distance between the two last extremes. :meth:`cycling` says whether an unknown has
    turned :data:`PTRAN_SWING_REVERSALS` times with its last swing at least
    :data:`PTRAN_SWING_SUSTAINED` of its largest: an astable goes round in pseudo-time as in time
    (a 555's comparators and latch; the threshold node swings between 1/3 and 2/3 of the supply on
    every turn), without coming back within tolerance of a point it left, since the pseudo-time
    step grows from turn to turn (:func:`_returned` misses it). A way to a steady state turns each
    unknown a few times at most, and a ringing the implicit-Euler steps damp has decaying swings.

    Parameters
    ----------
    x : ndarray, shape (n,)
        The first accepted point.
    rtol : float
    x_atol : ndarray, shape (n,)
    """

    def __init__(self, x: np.ndarray, rtol: float, x_atol: np.ndarray):
        self.rtol, self.x_atol = rtol, x_atol
        self.pivot = np.array(x, dtype=float)  # the last extreme turned at
        self.extreme = self.pivot.copy()  # the running extreme in the current direction
        self.direction = np.zeros(self.pivot.size)  # +1 rising, -1 falling, 0 not moved yet
        self.turns = np.zeros(self.pivot.size, dtype=np.int64)
        self.last = np.zeros(self.pivot.size)
        self.largest = np.zeros(self.pivot.size)

    def add(self, x: np.ndarray) -> None:
        """Take the next accepted point. Cost: a few vector operations of length n."""
        thr = PTRAN_CYCLE_EXCURSION * (self.rtol * np.abs(x) + self.x_atol)
        d = self.direction
        start = d == 0
        up = start & (x - self.pivot > thr)
        down = start & (self.pivot - x > thr)
        d[up], d[down] = 1.0, -1.0
        self.extreme[up | down] = x[up | down]
        moving = ~start
        further = moving & ((x - self.extreme) * d > 0.0)
        self.extreme[further] = x[further]
        turned = moving & ~further & (np.abs(self.extreme - x) > thr)
        if turned.any():
            swing = np.abs(self.extreme[turned] - self.pivot[turned])
            self.last[turned] = swing
            self.largest[turned] = np.maximum(self.largest[turned], swing)
            self.turns[turned] += 1
            self.pivot[turned] = self.extreme[turned]
            self.extreme[turned] = x[turned]
            d[turned] = -d[turned]

    def cycling(self) -> bool:
        """An unknown turned often, its swings not decaying."""
        hit = (self.turns >= PTRAN_SWING_REVERSALS) & (self.last >= PTRAN_SWING_SUSTAINED * self.largest)
        return bool(hit.any())


@dataclass(frozen=True)
class PseudoTransient:
    """Pseudo-transient continuation: implicit-Euler steps in a pseudo-time towards the steady state.

    Every node gets a capacitance ``C`` to ground and each step solves
    ``phi(x) - (C / h) (x - x_prev) = 0`` by Newton from the last point
    ``x_prev`` (the start: the devices' initial junction voltages): the
    conductance ``g = C / h`` to the last point regularises the Jacobian as gmin
    does, and unlike gmin it does not pull the solution towards ground, so the
    circuit moves towards its equilibrium as it would in time, a stage at a time
    through a chain whose stages all switch (where Newton from a far start, gmin
    and source stepping jump between the chain's states and stall). ``g``
    starts at :data:`PTRAN_G_START` and falls by a factor (the step grows) that
    doubles after a quick step and halves after a slow one; a failed step
    raises ``g`` eightfold from the last point. Where a step moved the solution
    by less than its tolerance, plain Newton is tried from there; it also ends
    the schedule when ``g`` has fallen to ``gmin``. Gives up after
    :data:`PTRAN_MAX_STEPS` steps, :data:`PTRAN_MAX_ITERATIONS` Newton
    iterations or ``g`` above :data:`PTRAN_G_MAX`.

    Parameters
    ----------
    gmin : float
        The conductance [S] below which the schedule ends with plain Newton.
    from_scratch : bool
        Start the devices from their initial junction voltages (a solve from
        scratch); else from ``x`` (a ``.dc`` sweep's previous point: the
        circuit then moves from there, as after a step of its input).

    Notes
    -----
    ngspice has no such stage in its operating point (its ``optran`` is a
    separate option); Xyce and HSPICE end their DC strategies with it. Cost: a
    Newton solve per pseudo-time step, usually a few iterations each.

    References
    ----------
    .. [1] C. T. Kelley and D. E. Keyes, "Convergence analysis of
       pseudo-transient continuation", SIAM J. Numer. Anal. 35(2), 1998.
    """

    gmin: float
    from_scratch: bool = True
    name: str = "pseudo-transient continuation"

    def __call__(self, newton: _Newton, x: np.ndarray) -> tuple[np.ndarray, bool]:
        if newton.system.linear:
            return x, False
        g, factor = PTRAN_G_START, PTRAN_FACTOR_START
        cur = np.asarray(x, dtype=float)
        fresh = self.from_scratch  # the devices from their initial junction voltages, else from x
        start = newton.iterations
        visited = np.empty((PTRAN_CYCLE_MEMORY, cur.size))  # the last accepted points, a ring
        count = 0
        swings = None
        for _ in range(PTRAN_MAX_STEPS):
            if newton.iterations - start > PTRAN_MAX_ITERATIONS:
                break
            x_new, ok = newton.solve(cur, gdiag=g, anchor=cur, maxiter=PTRAN_STEP_MAXITER, init=fresh)
            if not ok:
                g *= 8.0
                factor = PTRAN_FACTOR_START
                if g > PTRAN_G_MAX:
                    break
                continue
            fresh = False
            moved = np.max(_distance(x_new, cur, newton.opts.reltol, newton.x_atol))
            if _returned(visited, count, x_new, newton.opts.reltol, newton.x_atol):
                return x_new, False  # a cycle in pseudo-time: no steady state along this path (an astable)
            if swings is None:
                swings = _Swings(x_new, newton.opts.reltol, newton.x_atol)
            else:
                swings.add(x_new)
                if swings.cycling():
                    return x_new, False  # an oscillation that does not decay: no steady state along this path
            visited[count % PTRAN_CYCLE_MEMORY] = x_new
            count += 1
            cur = x_new
            if moved <= 1.0 or g <= self.gmin:
                x_end, ok = newton.solve(cur, maxiter=HOMOTOPY_MAXITER)
                if ok:
                    return x_end, True
                if g <= self.gmin:
                    break
            used = newton.last_used
            if used <= PTRAN_STEP_MAXITER // 3:
                factor = min(2.0 * factor, PTRAN_FACTOR_MAX)
            elif used > 2 * PTRAN_STEP_MAXITER // 3:
                factor = max(factor / 2.0, PTRAN_FACTOR_MIN)
            g = max(g / factor, self.gmin)
        return cur, False
