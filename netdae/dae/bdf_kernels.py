"""Pure numerical kernels of the fixed-leading-coefficient BDF method.

Every function here takes all its inputs explicitly and returns new values;
:mod:`netdae.dae.bdf` strings them together into a step. The notation is
that of DASSL and IDA [1]_ [2]_: the history of a solution component is kept
as *modified divided differences* ``phi_j`` (row ``j`` of a
``(maxord + 1, m)`` array), the step is described by

- ``psi_i = t_{n+1} - t_{n-i}``, the distance from the new point back to the
  past points (``psi_0 = h``),
- ``alpha_i = h / psi_i``, ``beta_i`` (the factor turning ``phi_i`` into the
  predicted differences ``phi*_i = beta_i phi_i``), ``gamma_i`` (weights of
  the predicted derivative) and ``sigma_i`` (weights of the error estimates),

and the fixed leading coefficient of the corrector is
``cj = -alpha_s / h`` with ``alpha_s = -sum_{j=1}^{k} 1/j``: it depends on the
step size and the order only, never on the earlier step sizes, so the Newton
matrix ``cj dq/dx - dphi/dx`` stays the same for as long as ``h`` and ``k``
do.

All loops here run over the order (at most 5), never over unknowns.

References
----------
.. [1] K. E. Brenan, S. L. Campbell, L. R. Petzold, *Numerical Solution of
   Initial-Value Problems in Differential-Algebraic Equations*, SIAM 1996,
   Chapter 5 (DASSL: the fixed-leading-coefficient BDF, its predictor,
   corrector, error estimates and order selection).
.. [2] A. C. Hindmarsh et al., SUNDIALS IDA, ``src/ida/ida.c``
   (``IDASetCoeffs``, ``IDATestError``, ``IDACompleteStep``,
   ``IDAGetSolution``), and the IDA user guide, Section 2.1.
.. [3] K. R. Jackson, R. Sacks-Davis, An alternative implementation of
   variable step-size multistep formulas for stiff ODEs, *ACM TOMS* 6 (1980)
   295-318 (the fixed-leading-coefficient idea).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "Coefficients",
    "flc_coefficients",
    "leading_coefficient",
    "predictor_weights",
    "error_norms",
    "update_differences",
    "differences_from_samples",
    "wrms",
    "max_norm",
    "merge_breakpoints",
    "landing_step",
]


class Coefficients:
    """The coefficients of one FLC-BDF step (plain floats, order <= 5).

    Attributes
    ----------
    psi : list of float, length k + 1
        ``t_{n+1} - t_{n-i}`` for i = 0..k.
    alpha, beta, gamma, sigma : list of float, length k + 1
    cj : float
        Leading coefficient ``-alpha_s / h`` of the corrector.
    ck : float
        Variable-step error constant: the local error estimate is
        ``ck * |x_{n+1} - x_pred|``.
    """

    __slots__ = ("psi", "alpha", "beta", "gamma", "sigma", "cj", "ck")

    def __init__(self, psi, alpha, beta, gamma, sigma, cj, ck):
        self.psi = psi
        self.alpha = alpha
        self.beta = beta
        self.gamma = gamma
        self.sigma = sigma
        self.cj = cj
        self.ck = ck


def leading_coefficient(h: float, k: int) -> float:
    """``cj = (sum_{j=1}^k 1/j) / h``: the Newton-matrix coefficient of an order-k step.

    Examples
    --------
    >>> leading_coefficient(0.5, 1), leading_coefficient(1.0, 2)
    (2.0, 1.5)
    """
    return sum(1.0 / j for j in range(1, k + 1)) / h


def flc_coefficients(h: float, k: int, psi_old) -> Coefficients:
    """Coefficients of a step of size ``h`` and order ``k`` after steps described by ``psi_old``.

    Parameters
    ----------
    h : float
        Size of the step being taken.
    k : int
        Its order, 1 <= k <= 5.
    psi_old : sequence of float, length >= k
        ``psi`` of the previous step (``psi_old[i] = t_n - t_{n-1-i}``).

    Returns
    -------
    Coefficients

    Notes
    -----
    Cost O(k) scalar operations. With ``psi_old[i] = (i + 1) h`` (constant
    steps) every ``beta_i`` is 1 and ``sigma_k = ck = 1/(k+1)``, the error
    constant of the constant-step BDF of order k.

    Examples
    --------
    >>> c = flc_coefficients(1.0, 2, [1.0, 2.0])
    >>> c.beta, c.psi, round(c.cj, 12)
    ([1.0, 1.0, 1.0], [1.0, 2.0, 3.0], 1.5)
    """
    psi = [0.0] * (k + 1)
    alpha = [1.0] + [0.0] * k
    beta = [1.0] + [0.0] * k
    gamma = [0.0] * (k + 1)
    sigma = [1.0] + [0.0] * k
    temp1 = h
    for i in range(1, k + 1):
        temp2 = psi_old[i - 1]
        psi[i - 1] = temp1
        beta[i] = beta[i - 1] * temp1 / temp2
        temp1 = temp2 + h
        alpha[i] = h / temp1
        sigma[i] = i * sigma[i - 1] * alpha[i]
        gamma[i] = gamma[i - 1] + alpha[i - 1] / h
    psi[k] = temp1
    alpha_s = -sum(1.0 / j for j in range(1, k + 1))
    alpha_0 = -sum(alpha[:k])
    ck = max(abs(alpha[k] + alpha_s - alpha_0), alpha[k])
    return Coefficients(psi, alpha, beta, gamma, sigma, -alpha_s / h, ck)


def predictor_weights(gamma, k: int) -> np.ndarray:
    """Rows turning ``phi*[0..k]`` into the predicted value and derivative.

    Returns
    -------
    ndarray, shape (2, k + 1)
        ``W @ phi_star[:k+1]`` gives ``[x_pred, xp_pred]``.
    """
    w = np.empty((2, k + 1))
    w[0] = 1.0
    w[1, 0] = 0.0
    w[1, 1:] = gamma[1 : k + 1]
    return w


def wrms(v: np.ndarray, w: np.ndarray) -> float:
    """Weighted root-mean-square norm ``sqrt(mean((v w)^2))``."""
    return _wrms_scaled(v * w)


def max_norm(v: np.ndarray, w: np.ndarray | None = None) -> float:
    """Weighted maximum norm ``max |v_i w_i|`` (``w`` omitted: of ``v`` itself)."""
    if not v.size:
        return 0.0
    return float(np.max(np.abs(v if w is None else v * w)))


def error_norms(ee: np.ndarray, phi: np.ndarray, k: int, w: np.ndarray, kind: str = "rms") -> tuple:
    """Norms of the local error estimates at orders k, k-1, k-2.

    Parameters
    ----------
    ee : ndarray, shape (n,)
        ``x_{n+1} - x_pred``.
    phi : ndarray, shape (>= k + 1, n)
        The predicted differences ``phi*`` of the step (x part).
    k : int
    w : ndarray, shape (n,)
        Error weights (zero for unknowns left out of the test).
    kind : {"rms", "max"}

    Returns
    -------
    tuple of float, length min(k, 3)
        ``|ee|``, ``|ee + phi*_k|``, ``|ee + phi*_k + phi*_{k-1}|`` (as far as
        the order allows): the differences of order k+1, k and k-1 that
        estimate the local errors at orders k, k-1, k-2.

    Notes
    -----
    At most nine vector operations; no temporary (rows, n) stack.
    """
    norm = max_norm if kind == "max" else _wrms_scaled
    a0 = ee * w
    if k == 1:
        return (norm(a0),)
    a1 = phi[k] * w
    a1 += a0
    if k == 2:
        return (norm(a0), norm(a1))
    a2 = phi[k - 1] * w
    a2 += a1
    return (norm(a0), norm(a1), norm(a2))


def _wrms_scaled(a: np.ndarray) -> float:
    return math.sqrt(float(a @ a) / a.size) if a.size else 0.0


#: Below this row length the history update is one small matrix product (call overhead
#: dominates); above it, one contiguous vector addition per order (memory traffic dominates).
UPDATE_MATMUL_MAX = 4096

_SUFFIX_SUMS = [np.triu(np.ones((k + 1, k + 1))) for k in range(8)]


def update_differences(phi: np.ndarray, ee: np.ndarray, k: int, maxord: int) -> None:
    """Update the modified divided differences after an accepted step, in place.

    ``phi[k+1] = ee`` (kept for a later order increase) and
    ``phi[j] <- phi[j] + phi[j+1]`` for ``j = k .. 0`` with ``phi[k+1] = ee``,
    i.e. ``phi[j] <- ee + sum_{i=j}^{k} phi[i]``.

    Parameters
    ----------
    phi : ndarray, shape (maxord + 1, m)
        The predicted differences ``phi*`` of the step just accepted.
    ee : ndarray, shape (m,)
        Correction ``x_{n+1} - x_pred``.
    k : int
        Order of the accepted step.
    maxord : int

    Notes
    -----
    Short rows: one product with the (k+1, k+1) upper triangle of ones; long
    rows: k + 1 contiguous additions (O(k m) instead of O(k^2 m)).

    Examples
    --------
    >>> phi = np.array([[1.0], [0.5], [0.0]])
    >>> update_differences(phi, np.array([0.1]), 1, 2)
    >>> phi.ravel().tolist()
    [1.6, 0.6, 0.1]
    """
    if k < maxord:
        phi[k + 1] = ee
    if phi.shape[1] <= UPDATE_MATMUL_MAX:
        head = phi[: k + 1]
        np.matmul(_SUFFIX_SUMS[k], head, out=head)
        head += ee
        return
    np.add(phi[k], ee, out=phi[k])
    for j in range(k - 1, -1, -1):
        np.add(phi[j], phi[j + 1], out=phi[j])


def differences_from_samples(samples: np.ndarray) -> np.ndarray:
    """Backward differences ``nabla^j y_n`` of equally spaced samples, newest last.

    At a constant step the modified divided differences are the backward
    differences, so this starts a multistep history from known values.

    Parameters
    ----------
    samples : ndarray, shape (k + 1, m)
        ``y_{n-k}, ..., y_n``.

    Returns
    -------
    ndarray, shape (k + 1, m)
        Row j is ``nabla^j y_n``.

    Examples
    --------
    >>> differences_from_samples(np.array([[0.0], [1.0], [4.0]])).ravel().tolist()
    [4.0, 3.0, 2.0]
    """
    s = np.array(samples, dtype=float)
    k = s.shape[0] - 1
    out = np.empty_like(s)
    for j in range(k + 1):
        out[j] = s[-1]
        s = s[1:] - s[:-1]
    return out


def merge_breakpoints(t0: float, t_bound: float, times, merge: float) -> np.ndarray:
    """Sorted breakpoints in ``(t0, t_bound]``, ``t_bound`` always last, no two closer than ``merge``.

    Parameters
    ----------
    t0, t_bound : float
    times : array_like
        Candidate breakpoints (any order, may fall outside the interval).
    merge : float
        Points closer than this to the next one (or to t0) are dropped (the
        last of a cluster stays), so no step is shorter than ``merge`` because
        of them.

    Examples
    --------
    >>> merge_breakpoints(0.0, 1.0, [0.5 - 1e-15, 0.5, 2.0, 0.0, 1.0 - 1e-15], 1e-9).tolist()
    [0.5, 1.0]
    """
    bp = np.asarray(times, dtype=float).ravel()
    bp = np.unique(np.append(bp[(bp > t0) & (bp < t_bound) & np.isfinite(bp)], t_bound))
    keep = np.ones(bp.size, dtype=bool)
    keep[:-1] = np.diff(bp) > merge
    bp = bp[keep]
    if bp.size > 1 and bp[0] - t0 <= merge:
        bp = bp[1:]
    return bp


def landing_step(h: float, remaining: float, stretch: float, split: bool) -> tuple[float, bool]:
    """Step size that lands on a breakpoint ``remaining`` ahead without leaving a sliver.

    Parameters
    ----------
    h : float
        Wanted step size.
    remaining : float
        Distance to the next breakpoint (> 0).
    stretch : float
        Relative amount by which ``h`` may grow to land at once.
    split : bool
        When ``h < remaining < 2 h``, take half of ``remaining`` (two equal
        steps) instead of ``h`` and a sliver.

    Returns
    -------
    (float, bool)
        The step and whether it lands on the breakpoint.

    Examples
    --------
    >>> landing_step(1.0, 1.05, 0.1, True), landing_step(1.0, 1.5, 0.1, True), landing_step(1.0, 3.0, 0.1, True)
    ((1.05, True), (0.75, False), (1.0, False))
    """
    if h * (1.0 + stretch) >= remaining:
        return remaining, True
    if split and 2.0 * h > remaining:
        return 0.5 * remaining, False
    return h, False
