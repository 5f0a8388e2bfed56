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
  in the cache, as the BDF does while convergence is good). Convergence is
  decided by the rate test of IDA [1]_: with the contraction rate
  ``rho`` estimated from successive corrections,
  ``rho / (1 - rho) * |dx| <= tol`` in a weighted norm; with a Jacobian
  evaluated in the same solve the estimate is trusted only for
  ``rho <= 0.25`` (near the root Newton converges quadratically). Optional
  Armijo backtracking on the residual norm damps the full Newton iteration.

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp

from .compiled.control import NORM_MAX, NORM_RMS, weighted_norm
from .compiled.lu import DEFAULT_PERMC_SPEC, PIVOT_REL_THRESHOLD, SparseLU
from .sparse import SparsePattern

__all__ = [
    "DEFAULT_PERMC_SPEC",
    "LuCache",
    "NewtonResult",
    "newton",
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
#: Armijo sufficient-decrease constant of the damped iteration.
ARMIJO_C = 1e-4
#: Step-length reduction per backtracking trial.
BACKTRACK_FACTOR = 0.5

INFO_CONVERGED = "converged"
INFO_DIVERGED = "diverged"
INFO_MAXITER = "maxiter"
INFO_EVALUATION = "evaluation"
INFO_SINGULAR = "singular"
INFO_NONFINITE = "nonfinite"


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
        Contraction-rate estimate after the iteration: measured from the
        corrections when two or more were taken, otherwise the ``rate`` the
        caller assumed. Pass it back for the next solve (IDA carries it from
        step to step).
    info : str
        ``"converged"``, ``"diverged"`` (rate above 0.9), ``"maxiter"``,
        ``"evaluation"`` (the callback reported ``ok=False``), ``"singular"``
        (the matrix could not be factored) or ``"nonfinite"`` (a non-finite
        correction).
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
    info: str
    correction_norm: float
    worst: int
    evaluations: int


def _worst(d, w) -> int:
    if d is None or d.size == 0:
        return -1
    s = np.abs(d * w)
    s[~np.isfinite(s)] = np.inf
    return int(np.argmax(s))


def newton(
    fun: Callable,
    x0: np.ndarray,
    lu: LuCache,
    weights: np.ndarray,
    *,
    tol: float,
    maxiter: int = 4,
    jacobian: str = "first",
    rate: float = 20.0 / 21.0,
    linear: bool = False,
    scale: float = 1.0,
    norm: str = "rms",
    max_backtracks: int = 0,
    residual_weights: np.ndarray | None = None,
    tag=None,
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
        Factorisation to use or refresh.
    weights : ndarray, shape (n,)
        Weights of the convergence norm, ``1 / (rtol |x| + atol)``; zero
        leaves an unknown out of the test.
    tol : float
        Convergence when ``rate / (1 - rate) * |dx| <= tol`` (weighted norm;
        the BDF uses 0.33 of its error-test bound, as IDA).
    maxiter : int
        Largest number of linear solves.
    jacobian : {"first", "always", "never"}
        Evaluate and factor the Jacobian at the first iterate only (modified
        Newton), at every iterate (full Newton), or never (use ``lu`` as it is).
    rate : float
        Contraction rate assumed for the test after the first correction
        (before a rate can be measured): IDA uses 20/21 after a new
        factorisation and carries the measured rate from step to step.
    linear : bool
        ``F`` is affine and ``lu`` holds its exact Jacobian: one solve gives
        the solution, which is accepted without a second evaluation.
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

    Returns
    -------
    NewtonResult

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
    kind = NORM_MAX if norm == "max" else NORM_RMS

    def normf(v, w):
        return weighted_norm(v, w, kind)

    rw = residual_weights
    x = np.array(x0, dtype=float)
    ss = rate / (1.0 - rate)
    rate_out = rate
    old = 0.0
    dn = math.inf
    d = None
    nev = 0

    def evaluate(xv, it):
        need = jacobian == "always" or (jacobian == "first" and it == 0)
        return fun(xv, need), need

    (r, jac, ok, limited), need = evaluate(x, 0)
    nev += 1
    for m in range(maxiter):
        if not ok:
            return NewtonResult(x, False, m, rate_out, INFO_EVALUATION, dn, _worst(d, weights), nev)
        if need and not lu.factor(jac, tag):
            return NewtonResult(x, False, m, rate_out, INFO_SINGULAR, dn, -1, nev)
        d = lu.solve(r)
        if scale != 1.0:
            d *= scale
        dn = normf(d, weights)
        if not math.isfinite(dn) or not np.all(np.isfinite(d)):
            return NewtonResult(x, False, m + 1, rate_out, INFO_NONFINITE, dn, _worst(d, weights), nev)
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
        # convergence test on the full correction (IDA's idaNlsConvTest)
        trusted = True
        # a correction at the roundoff level converges at once (its rate means nothing)
        done = dn <= TINY_CORRECTION * tol
        if m == 0:
            old = dn
        elif not done:
            rho = (dn / old) ** (1.0 / m) if old > 0.0 else 0.0
            if rho > RATE_MAX:
                return NewtonResult(x_new, False, m + 1, rho, INFO_DIVERGED, dn, _worst(d, weights), nev)
            rate_out = rho
            ss = rho / (1.0 - rho)
            trusted = jacobian == "never" or rho <= FRESH_RATE_MAX
        if linear and not limited:
            return NewtonResult(x_new, True, m + 1, rate_out, INFO_CONVERGED, dn, _worst(d, weights), nev)
        if not limited and (done or (trusted and ss * dn <= tol)):
            return NewtonResult(x_new, True, m + 1, rate_out, INFO_CONVERGED, dn, _worst(d, weights), nev)
        x = x_new
        if m + 1 < maxiter:
            if max_backtracks:
                r, jac, ok, limited = rt, jt, okt, limt
            else:
                (r, jac, ok, limited), need = evaluate(x, m + 1)
                nev += 1
    return NewtonResult(x, False, maxiter, rate_out, INFO_MAXITER, dn, _worst(d, weights), nev)
