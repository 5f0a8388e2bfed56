"""Newton iteration with sparse LU reuse: the kernel of netdae's implicit solvers.

Two pieces, usable by any solver that works on a :class:`SparsePattern`:

- :class:`LuCache` keeps one sparse LU factorisation of a matrix on the fixed
  pattern (:class:`netdae.dae.compiled.lu.SparseLU`: refactored in a kept
  pivot order, with fresh pivoting by SuperLU the first time and whenever a
  pivot degrades), counts factorisations and remembers what the
  factorisation was made for (its ``tag``, e.g. the BDF coefficient ``cj``),
  so the caller can reuse it while it is good enough.
- :func:`newton` runs the iteration ``x <- x - s J^{-1} F(x)`` on a residual
  callback with three Jacobian policies: ``"always"`` (full Newton, as the
  operating point uses it), ``"first"`` (factor at the starting point, then
  keep the matrix: modified Newton) and ``"never"`` (reuse the factorisation
  in the cache, as the BDF does while convergence is good). Optional Armijo
  backtracking on the residual norm damps the full Newton iteration.

It is netdae's one Newton iteration: the BDF corrector and the steady state
(:mod:`netdae.dae.steady`, whose gmin and source stepping are homotopies
over it) differ only in the *stopping rule* they pass:

- :class:`RateTest` (the default), the rate test of IDA [1]_: with the
  contraction rate ``rho`` estimated from successive corrections,
  ``rho / (1 - rho) * |dx| <= tol`` in a weighted norm; with a Jacobian
  evaluated in the same solve the estimate is trusted only for
  ``rho <= 0.25`` (near the root Newton converges quadratically);
- :class:`SpiceTest`, the test of SPICE [3]_: the last update is below
  ``reltol * max(|x_k|, |x_k+1|) + atol`` for every unknown, no device
  limited a junction voltage, and every equation's residual is below
  ``reltol`` times the magnitude of the terms that make it up plus its
  absolute tolerance.

A Jacobian reused from an earlier step (modified Newton, ``jacobian="never"``) can
be made at another operating point: a junction's conductance at a forward bias it
has since left, many orders of magnitude above its conductance now. Every
correction ``A^-1 r`` is then tiny, the rate test accepts at once, and the
iterate keeps the prediction's residual: a node that only capacitors hold
integrates that current into a permanent charge error. The correctors therefore
check an iterate accepted with such a Jacobian on a Jacobian evaluated there (not
factored) and solve again with a fresh one when an entry of ``dphi/dx`` the
factorisation holds off its diagonal fell by more than :data:`CONDUCTANCE_FALL`
(:func:`~netdae.dae.compiled.control.conductance_fell`: a junction that conducted
then and is off now, whose stale coupling can hide in the common mode of a node
group, where no row's residual shows it) or when the residual stalled
(:func:`~netdae.dae.compiled.control.residual_stalled`: not small in SPICE's sense
and not below :data:`RESIDUAL_RATE_MAX` of the residual the correction was
computed from).

A rule is asked twice per iteration: :meth:`StoppingRule.at_point` after an
evaluation, before the linear solve (SPICE decides there, with the residual
of the new iterate), and :meth:`StoppingRule.after_update` after the
correction (IDA decides there, from the correction's norm).

The residual callback
---------------------
``fun(x, jacobian) -> (residual, jac_data, ok, limited)`` with
``residual`` of shape (n,), ``jac_data`` the values of ``dF/dx`` on the cache's
pattern (shape (nnz,), or ``None`` when ``jacobian`` is false), ``ok`` false
when the evaluation produced non-finite values (a recoverable failure) and
``limited`` true when a device limited a junction voltage (the iteration is
then not converged, whatever the correction). A DC operating point passes
``F = -phi(x)`` and ``dF/dx = -dphi/dx``; the BDF passes its corrector
residual ``cj (q(x) - q_pred) + q'_pred - phi(x, t)``.

Examples
--------
Full Newton on ``x^2 = 2`` (one unknown, a 1x1 pattern):

>>> import numpy as np
>>> from netdae.dae.sparse import SparsePattern
>>> pat = SparsePattern.from_coo(1, [[0]], [[0]])
>>> def fun(x, jac):
...     return x ** 2 - 2.0, (2.0 * x if jac else None), True, False
>>> res = newton(fun, np.array([1.0]), LuCache(pat), np.array([1e6]), tol=0.33,
...              maxiter=10, jacobian="always")
>>> res.converged, round(float(res.x[0]), 10)
(True, 1.4142135624)

References
----------
.. [1] A. C. Hindmarsh et al., SUNDIALS IDA, ``src/ida/ida_nls.c``
   (``idaNlsConvTest``: the rate-based stopping test) and the IDA user guide,
   Section 2.1 (modified Newton, ``cj`` scaling of stale corrections).
.. [2] C. T. Kelley, *Solving Nonlinear Equations with Newton's Method*,
   SIAM 2003, Chapter 1.7 (Armijo line search).
.. [3] L. W. Nagel, *SPICE2: A computer program to simulate semiconductor
   circuits*, UCB/ERL M520, 1975 (the convergence test with limiting).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Callable, Protocol

import numpy as np
import scipy.sparse as sp

from .compiled.control import NORM_MAX, NORM_RMS, conductance_fell, residual_stalled, weighted_norm
from .compiled.lu import DEFAULT_PERMC_SPEC, PIVOT_REL_THRESHOLD, SparseLU
from .sparse import SparsePattern, residual_small

__all__ = [
    "DEFAULT_PERMC_SPEC",
    "LuCache",
    "NewtonResult",
    "NewtonInfo",
    "StoppingRule",
    "RateTest",
    "SpiceTest",
    "newton",
    "residual_stalled",
    "RESIDUAL_RATE_MAX",
    "RESIDUAL_NU_MAX",
    "conductance_fell",
    "CONDUCTANCE_FALL",
    "INFO_CONVERGED",
    "INFO_DIVERGED",
    "INFO_MAXITER",
    "INFO_EVALUATION",
    "INFO_SINGULAR",
    "INFO_NONFINITE",
]

#: Largest acceptable contraction rate; above it the iteration is diverging (IDA's RATEMAX).
RATE_MAX = 0.9
#: With a Jacobian evaluated in this solve Newton converges quadratically near the root;
#: a measured rate above this means the iterate is still far away (on the steep side of an
#: exponential the corrections shrink geometrically while the iterate stalls), so the rate
#: test is not trusted and the iteration goes on.
FRESH_RATE_MAX = 0.25
#: A first correction this small (relative to ``tol``) converges at once.
TINY_CORRECTION = 1e-4
#: A Newton step with a fit matrix removes the residual's linear part; an iterate accepted with a
#: Jacobian from an earlier step whose residual (SPICE's current test) is not small and fell by less
#: than this factor was corrected with a matrix made at another operating point (a junction's
#: conductance at a bias it has left): the correction understated the error, and the corrector
#: solves again with a fresh Jacobian (``residual_stalled``). A matrix off by the factor ``f`` in a
#: row leaves ``|1 - 1/f|`` of its residual: 0.5 is a matrix twice too stiff; the ``cj`` changes
#: that modified Newton accepts (``DCJ``, with IDA's scaling of the correction) leave at most 0.25.
RESIDUAL_RATE_MAX = 0.5
#: An iterate accepted with a Jacobian from an earlier step whose residual is more than this many
#: times its tolerance is not converged, however far the residual fell (``residual_stalled``): the
#: rate that accepted it was measured with the stale matrix (a behavioural ``sqrt(abs(v))`` at its
#: kink: a second correction's rate of 0.24 accepted an iterate 5 tolerances off its relation).
RESIDUAL_NU_MAX = 2.0
#: An iterate accepted with a Jacobian from an earlier step is not converged when an off-diagonal
#: entry of ``dphi/dx`` the factorisation holds is more than this factor above the same entry (with its
#: ``cj dq/dx``) at the iterate (``conductance_fell``): a junction that conducted when the matrix
#: was made and is off now. A stale coupling can hide in a direction no row's residual shows
#: (the common mode of a node group held only by junction capacitances, its rows' currents
#: cancelling); a conductance falling tenfold happens at a junction's turn-off, a few times a
#: cycle, where modified Newton would otherwise keep the matrix for hundreds of steps.
CONDUCTANCE_FALL = 10.0
#: Armijo sufficient-decrease constant of the damped iteration.
ARMIJO_C = 1e-4
#: Step-length reduction per backtracking trial.
BACKTRACK_FACTOR = 0.5



class NewtonInfo(StrEnum):
    """How a Newton iteration ended (compares equal to its lower-case name)."""

    #: The stopping rule accepted the iterate.
    CONVERGED = "converged"
    #: The contraction rate exceeded :data:`RATE_MAX`.
    DIVERGED = "diverged"
    #: The iteration limit was reached (or the rule refused the final iterate).
    MAXITER = "maxiter"
    #: The residual callback reported ``ok=False``.
    EVALUATION = "evaluation"
    #: The matrix could not be factored.
    SINGULAR = "singular"
    #: A non-finite correction.
    NONFINITE = "nonfinite"


INFO_CONVERGED = NewtonInfo.CONVERGED
INFO_DIVERGED = NewtonInfo.DIVERGED
INFO_MAXITER = NewtonInfo.MAXITER
INFO_EVALUATION = NewtonInfo.EVALUATION
INFO_SINGULAR = NewtonInfo.SINGULAR
INFO_NONFINITE = NewtonInfo.NONFINITE


class LuCache:
    """One sparse LU factorisation of matrices on a fixed pattern.

    Parameters
    ----------
    pattern : SparsePattern
    permc_spec : str
        SuperLU column ordering of the fresh factorisations
        (``"MMD_AT_PLUS_A"``, ``"COLAMD"``, ``"MMD_ATA"``, ``"NATURAL"``;
        :data:`DEFAULT_PERMC_SPEC`).
    diag_pivot_thresh : float, optional
        SuperLU's threshold for preferring a diagonal pivot (default 1:
        partial pivoting).
    pivot_threshold : float
        Relative pivot threshold of the refactorisations
        (:data:`netdae.dae.compiled.lu.PIVOT_REL_THRESHOLD`).

    Attributes
    ----------
    factorizations : int
        Number of successful factorisations so far (fresh and refactored).
    fresh_factorizations, refactorizations : int
        Of those, the ones that chose new pivots (SuperLU) and the ones that
        reused the pivot order.
    tag : object
        What the current factorisation was made for (set by :meth:`factor`);
        ``None`` when there is none.
    lu : SparseLU
        The factorisation itself.

    Notes
    -----
    The first factorisation chooses a pivot order (SuperLU); later ones redo
    only the arithmetic of the elimination in that order, in compiled code,
    until a pivot degrades (see :mod:`netdae.dae.compiled.lu`). No sparse
    constructor runs inside a solver loop.
    """

    def __init__(self, pattern: SparsePattern, *, permc_spec: str = DEFAULT_PERMC_SPEC,
                 diag_pivot_thresh: float | None = None,
                 pivot_threshold: float = PIVOT_REL_THRESHOLD) -> None:
        self.pattern = pattern
        self.permc_spec = permc_spec
        self.diag_pivot_thresh = diag_pivot_thresh
        self.lu = SparseLU(pattern, permc_spec=permc_spec, diag_pivot_thresh=diag_pivot_thresh,
                           threshold=pivot_threshold)
        self._data = None
        self.factorizations = 0
        self.tag = None

    @property
    def ready(self) -> bool:
        """True when a factorisation is available."""
        return self.lu.ready

    @property
    def fresh_factorizations(self) -> int:
        """Factorisations that chose a new pivot order."""
        return self.lu.fresh_factorizations

    @property
    def refactorizations(self) -> int:
        """Factorisations in the kept pivot order."""
        return self.lu.refactorizations

    @property
    def matrix(self) -> sp.csc_matrix | None:
        """The matrix last passed to :meth:`factor` (``None`` before the first)."""
        return None if self._data is None else self.pattern.matrix(self._data)

    def factor(self, data: np.ndarray, tag=None) -> bool:
        """Factor the matrix with values ``data`` on the pattern.

        Parameters
        ----------
        data : ndarray, shape (nnz,)
        tag : object, optional
            Stored in :attr:`tag` on success.

        Returns
        -------
        bool
            False when the matrix is singular, or has non-finite entries (the
            cache is then empty).
        """
        self._data = data
        if not self.lu.factor(data):
            self.tag = None
            return False
        self.factorizations += 1
        self.tag = tag
        return True

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``A y = b`` with the current factorisation (``b``: shape (n,) or (n, k))."""
        return self.lu.solve(b)

    def invalidate(self) -> None:
        """Forget the factorisation (the next use must factor again)."""
        self.lu.invalidate()
        self.tag = None


@dataclass(slots=True)
class NewtonResult:
    """Outcome of :func:`newton`.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Last iterate (the solution when ``converged``).
    converged : bool
    iterations : int
        Linear solves performed.
    rate : float
        Contraction-rate estimate of a :class:`RateTest` after the iteration:
        measured from the corrections when two or more were taken, otherwise
        the ``rate`` the caller assumed. Pass it back for the next solve (IDA
        carries it from step to step). NaN under other rules.
    info : NewtonInfo
        How the iteration ended.
    correction_norm : float
        Weighted norm of the last correction.
    worst : int
        Unknown with the largest weighted last correction (-1 if none).
    evaluations : int
        Residual evaluations.
    """

    x: np.ndarray
    converged: bool
    iterations: int
    rate: float
    info: NewtonInfo
    correction_norm: float
    worst: int
    evaluations: int


def _worst(d, w) -> int:
    if d is None or d.size == 0:
        return -1
    with np.errstate(over="ignore", invalid="ignore"):  # a diverging correction: non-finite is the answer
        s = np.abs(d * w)
    s[~np.isfinite(s)] = np.inf
    return int(np.argmax(s))


class StoppingRule(Protocol):
    """When a Newton iteration has converged: the part of :func:`newton` that differs between its users.

    A rule keeps the state of one solve; :func:`newton` calls :meth:`begin`
    first.
    """

    #: Contraction-rate estimate reported in :attr:`NewtonResult.rate`.
    rate: float

    def begin(self) -> None:
        """Forget the previous solve."""

    def at_point(self, m: int, x: np.ndarray, r: np.ndarray, jac, limited: bool) -> bool | None:
        """After the evaluation at iterate ``m``, before its solve (``jac``: None when not evaluated).

        Returns True (``x`` is the solution), False (stop: not converged) or
        None (go on).
        """

    def after_update(self, m: int, x: np.ndarray, x_new: np.ndarray, d: np.ndarray, dn: float,
                     limited: bool) -> NewtonInfo | None:
        """After correction ``m`` (``x_new = x - d``, ``dn`` its weighted norm).

        Returns :attr:`NewtonInfo.CONVERGED` (accept ``x_new``),
        :attr:`NewtonInfo.DIVERGED` (stop) or None (go on).
        """


class RateTest:
    """IDA's rate-based stopping test (``idaNlsConvTest``) for the BDF corrector.

    Parameters
    ----------
    tol : float
        Convergence when ``rate / (1 - rate) * |dx| <= tol`` (weighted norm;
        the BDF uses 0.33 of its error-test bound, as IDA).
    rate : float
        Contraction rate assumed after the first correction (before one can
        be measured): IDA uses 20/21 after a new factorisation and carries
        the measured rate from step to step.
    fresh : bool
        The Jacobian is evaluated in this solve: a measured rate is trusted
        only below :data:`FRESH_RATE_MAX`.
    linear : bool
        ``F`` is affine and the factorisation its exact Jacobian: the first
        correction is the solution (unless a device limited).
    """

    def __init__(self, tol: float, *, rate: float = 20.0 / 21.0, fresh: bool = False, linear: bool = False) -> None:
        self.tol, self.assumed, self.fresh, self.linear = float(tol), float(rate), fresh, linear
        self.begin()

    def begin(self) -> None:
        self.rate = self.assumed
        self._ss = self.assumed / (1.0 - self.assumed)
        self._first = 0.0

    def at_point(self, m, x, r, jac, limited):
        return None

    def after_update(self, m, x, x_new, d, dn, limited):
        trusted = True
        # a correction at the roundoff level converges at once (its rate means nothing)
        done = dn <= TINY_CORRECTION * self.tol
        if m == 0:
            self._first = dn
        elif not done:
            rho = (dn / self._first) ** (1.0 / m) if self._first > 0.0 else 0.0
            if rho > RATE_MAX:
                self.rate = rho
                return NewtonInfo.DIVERGED
            self.rate = rho
            self._ss = rho / (1.0 - rho)
            trusted = not self.fresh or rho <= FRESH_RATE_MAX
        if limited:
            return None
        if self.linear or done or (trusted and self._ss * dn <= self.tol):
            return NewtonInfo.CONVERGED
        return None


class SpiceTest:
    """SPICE's stopping test for the operating point [3]_.

    Converged at an iterate ``x_k+1`` when the update that reached it was
    below ``reltol * max(|x_k|, |x_k+1|) + x_atol`` for every unknown, no
    device limited in the evaluation at ``x_k+1``, and every equation's
    residual is below ``reltol * m + r_atol``, ``m`` the magnitude of the
    terms that make the equation up (:meth:`SparsePattern.row_magnitudes`:
    ``|J| |x_k+1|``, or with ``paired`` a node row's branch currents measured
    from its own potential), plus the rounding of their sum
    (``RESIDUAL_ROUNDING |J| |x_k+1|``).

    SPICE measures the update against ``reltol |x| + vntol``, which on a node
    at 50 V is 50 mV, two thermal voltages: a junction's current may still be
    off by a factor of seven there. The residual test must then see the
    current law's error against the currents that flow, not against
    ``|J| |x|``, which counts a junction's conductance times both node
    potentials (``0.1 S x 100 V``, where the junction carries 2 mA): measured
    so, a reverse-biased diode at 50 V passed as forward-biased at 0.56 V with
    its current law 2.5 mA off (ngspice 39 stops at the same point).

    Parameters
    ----------
    pattern : SparsePattern
        Pattern of the Jacobian values passed with each residual.
    reltol : float
    x_atol, r_atol : ndarray, shape (n,)
        Absolute tolerances of the unknowns and of the equations.
    paired : ndarray of bool, shape (n,), optional
        Rows that are the current law of the node whose potential is the
        unknown of the same position (an MNA system's voltage unknowns).

    Attributes
    ----------
    last_dx : ndarray, shape (n,)
        ``|dx| / tolerance`` of the last update (for naming the unknowns that
        did not settle).
    """

    def __init__(self, pattern: SparsePattern, reltol: float, x_atol: np.ndarray, r_atol: np.ndarray,
                 paired: np.ndarray | None = None) -> None:
        self.pattern, self.reltol, self.x_atol, self.r_atol = pattern, float(reltol), x_atol, r_atol
        self.paired = None if paired is None else np.asarray(paired, dtype=bool)
        self.rate = math.nan
        self.last_dx = np.zeros(pattern.n)
        self.begin()

    def begin(self) -> None:
        self._small = False

    def residual_small(self, r: np.ndarray, jac: np.ndarray, x: np.ndarray) -> bool:
        """Every equation's residual within ``reltol`` of its terms' magnitude plus its tolerance."""
        return residual_small(self.pattern, r, jac, x, self.reltol, self.r_atol, self.paired)

    def at_point(self, m, x, r, jac, limited):
        if self._small and not limited and jac is not None and self.residual_small(r, jac, x):
            return True
        return None

    def after_update(self, m, x, x_new, d, dn, limited):
        tol = self.reltol * np.maximum(np.abs(x), np.abs(x_new)) + self.x_atol
        ad = np.abs(d)
        self._small = bool(np.all(ad <= tol))
        self.last_dx = ad / tol
        return None


def newton(
    fun: Callable,
    x0: np.ndarray,
    lu: LuCache,
    weights: np.ndarray,
    *,
    tol: float | None = None,
    maxiter: int = 4,
    jacobian: str = "first",
    rate: float = 20.0 / 21.0,
    linear: bool = False,
    scale: float = 1.0,
    norm: str = "rms",
    max_backtracks: int = 0,
    residual_weights: np.ndarray | None = None,
    tag=None,
    stop: StoppingRule | None = None,
) -> NewtonResult:
    """Solve ``F(x) = 0`` by (modified, optionally damped) Newton iteration.

    Parameters
    ----------
    fun : callable
        ``fun(x, jacobian) -> (residual, jac_data, ok, limited)``; see the
        module docstring.
    x0 : ndarray, shape (n,)
        Starting point (not modified).
    lu : LuCache
        Factorisation to use or refresh (any object with ``factor(data,
        tag) -> bool``, ``solve(b)`` and ``ready``).
    weights : ndarray, shape (n,)
        Weights of the correction norm, ``1 / (rtol |x| + atol)``; zero
        leaves an unknown out of the rate test.
    tol : float, optional
        The default stopping rule's tolerance (:class:`RateTest`): required
        without ``stop``, ignored with it.
    rate, linear
        The default stopping rule's (:class:`RateTest`); ignored with ``stop``.
    maxiter : int
        Largest number of linear solves.
    jacobian : {"first", "always", "never"}
        Evaluate and factor the Jacobian at the first iterate only (modified
        Newton), at every iterate (full Newton), or never (use ``lu`` as it is).
    scale : float
        Factor on every correction: ``2 / (1 + cj / cj_lu)`` makes a
        factorisation made for another ``cj`` a better approximation (IDA).
    norm : {"rms", "max"}
        Weighted root-mean-square or maximum norm.
    max_backtracks : int
        0 for the plain iteration; otherwise up to this many halvings of the
        step until ``|F|`` decreases by the Armijo condition (damped Newton).
    residual_weights : ndarray, shape (n,), optional
        Weights of the residual norm in the line search (default ones).
    tag : object, optional
        Tag stored with factorisations made here.
    stop : StoppingRule, optional
        When the iteration has converged (default: ``RateTest(tol, rate=rate,
        fresh=jacobian != "never", linear=linear)``).

    Returns
    -------
    NewtonResult

    Raises
    ------
    ValueError
        ``jacobian`` not one of the three, ``"never"`` without a
        factorisation, or neither ``tol`` nor ``stop`` given.

    Notes
    -----
    Cost per iteration: one callback, one triangular solve, a few vector
    operations; plus one factorisation per Jacobian evaluation. No Python
    loop over unknowns.
    """
    if jacobian not in ("first", "always", "never"):
        raise ValueError("jacobian must be 'first', 'always' or 'never'")
    if jacobian == "never" and not lu.ready:
        raise ValueError("jacobian='never' needs a factorisation in the cache")
    if stop is None:
        if tol is None:
            raise ValueError("newton() needs tol (the default RateTest's) or a stopping rule")
        stop = RateTest(tol, rate=rate, fresh=jacobian != "never", linear=linear)
    stop.begin()
    kind = NORM_MAX if norm == "max" else NORM_RMS

    def normf(v, w):
        return weighted_norm(v, w, kind)

    rw = residual_weights
    x = np.array(x0, dtype=float)
    dn = math.inf
    d = None
    nev = 0

    def evaluate(xv, it):
        need = jacobian == "always" or (jacobian == "first" and it == 0)
        return fun(xv, need), need

    def result(xv, converged, m, info):
        return NewtonResult(xv, converged, m, stop.rate, info, dn, _worst(d, weights), nev)

    (r, jac, ok, limited), need = evaluate(x, 0)
    nev += 1
    for m in range(maxiter):
        if not ok:
            return result(x, False, m, NewtonInfo.EVALUATION)
        verdict = stop.at_point(m, x, r, jac, limited)
        if verdict is not None:
            return result(x, verdict, m, NewtonInfo.CONVERGED if verdict else NewtonInfo.MAXITER)
        if need and not lu.factor(jac, tag):
            d = None
            return result(x, False, m, NewtonInfo.SINGULAR)
        d = lu.solve(r)
        if scale != 1.0:
            d *= scale
        dn = normf(d, weights)
        if not math.isfinite(dn) or not np.all(np.isfinite(d)):
            return result(x, False, m + 1, NewtonInfo.NONFINITE)
        if max_backtracks:
            f0 = normf(r, rw) if rw is not None else float(np.linalg.norm(r))
            lam = 1.0
            for _ in range(max_backtracks + 1):
                xt = x - lam * d
                (rt, jt, okt, limt), need = evaluate(xt, m + 1)
                nev += 1
                ft = normf(rt, rw) if rw is not None else float(np.linalg.norm(rt))
                if okt and (limt or ft <= (1.0 - ARMIJO_C * lam) * f0):
                    break
                lam *= BACKTRACK_FACTOR
            x_new = xt
        else:
            x_new = x - d
        verdict = stop.after_update(m, x, x_new, d, dn, limited)
        if verdict is not None:
            return result(x_new, verdict == NewtonInfo.CONVERGED, m + 1, verdict)
        x = x_new
        if m + 1 < maxiter:
            if max_backtracks:
                r, jac, ok, limited = rt, jt, okt, limt
            else:
                (r, jac, ok, limited), need = evaluate(x, m + 1)
                nev += 1
    return result(x, False, maxiter, NewtonInfo.MAXITER)
