"""The step and order controller of the FLC-BDF method: pure decisions on numbers.

Every function takes the error norms, orders and counters it decides on and
returns the decision; none holds state or touches an array. They follow
IDA's ``IDATestError``, ``IDAHandleNFlag`` and ``IDACompleteStep`` [1]_, with
two rules beyond IDA (:func:`hold_growth`). The norms they judge come from the
compiled kernels of :mod:`netdae.dae.compiled.control`.

References
----------
.. [1] A. C. Hindmarsh et al., SUNDIALS IDA, ``src/ida/ida.c``.
"""

from __future__ import annotations

import math

from .constants import (
    ERROR_FLOOR,
    ETA_ERROR_FAIL_MIN,
    ETA_GROW_MAX,
    ETA_GROW_MIN,
    ETA_SAFETY,
    ETA_SHRINK_MAX,
    ETA_SHRINK_MIN,
    H0_DERIVATIVE_BOUND,
    H0_ERROR_TARGET,
    ROUNDOFF_ULPS,
)

__all__ = ["ErrorTest", "error_test", "raise_test_due", "choose_order", "step_factor", "hold_growth",
           "error_failure", "reduced_step", "first_step_from_curvature", "first_step_from_derivative"]


class ErrorTest:
    """Outcome of the local error test of one step attempt.

    Attributes
    ----------
    passed : bool
        ``ck |x_new - x_pred|_w <= 1``.
    finite : bool
        Whether the error norm is finite (a non-finite one is a corrector failure).
    knew : int
        Order proposed for the next step (``k`` or ``k - 1``).
    err_k, err_km1 : float
        Error estimates at orders k and k - 1 (0 for k = 1).
    """

    __slots__ = ("passed", "finite", "knew", "err_k", "err_km1")

    def __init__(self, passed, finite, knew, err_k, err_km1):
        self.passed, self.finite, self.knew, self.err_k, self.err_km1 = passed, finite, knew, err_k, err_km1


def error_test(norms, sigma, ck: float, k: int) -> ErrorTest:
    """The local error test and the order-lowering proposal (IDA's IDATestError).

    Parameters
    ----------
    norms : sequence of float, length 3
        Weighted norms of the differences of order k + 1, k and k - 1
        (``error_norms``: |ee|, |ee + phi*_k|, |ee + phi*_k + phi*_{k-1}|; entries
        beyond the order are ignored).
    sigma : sequence of float, length >= k + 1
        The step's error weights.
    ck : float
        The step's error constant.
    k : int
        The step's order.

    Returns
    -------
    ErrorTest

    Examples
    --------
    >>> r = error_test((0.5, 0.1, 0.0), [1.0, 0.5, 1.0 / 3.0], 1.0 / 3.0, 2)
    >>> r.passed, r.knew
    (True, 1)
    """
    enorm_k = norms[0]
    err_k = sigma[k] * enorm_k
    terr_k = (k + 1) * err_k
    knew = k
    err_km1 = 0.0
    if k > 1:
        err_km1 = sigma[k - 1] * norms[1]
        terr_km1 = k * err_km1
        if k > 2:
            terr_km2 = (k - 1) * sigma[k - 2] * norms[2]
            if max(terr_km1, terr_km2) <= terr_k:
                knew = k - 1
        elif terr_km1 <= 0.5 * terr_k:
            knew = k - 1
    return ErrorTest(ck * enorm_k <= 1.0, math.isfinite(enorm_k), knew, err_k, err_km1)


def raise_test_due(k: int, knew: int, maxord: int, ns: int, kdiff: int) -> bool:
    """Whether the order-raise test runs after this step: ``k + 2`` steps at constant size and order,
    the order not just raised, not proposed lower, below ``maxord``."""
    return knew != k - 1 and k < maxord and ns >= k + 2 and kdiff != 1


def choose_order(k: int, err_km1: float, err_k: float, err_kp1: float) -> tuple[int, float]:
    """Order k - 1, k or k + 1 for the next step, from the error estimates at those orders (IDACompleteStep).

    Returns
    -------
    (int, float)
        The order and the error estimate the step size is chosen for.

    Examples
    --------
    >>> choose_order(1, 0.0, 0.4, 0.1), choose_order(3, 0.1, 0.2, 0.3), choose_order(3, 0.5, 0.3, 0.1)
    ((2, 0.1), (2, 0.1), (4, 0.1))
    """
    terr_k = (k + 1) * err_k
    terr_kp1 = (k + 2) * err_kp1
    if k == 1:
        if terr_kp1 < 0.5 * terr_k:
            return 2, err_kp1
    elif k * err_km1 <= min(terr_k, terr_kp1):
        return k - 1, err_km1
    elif terr_kp1 < terr_k:
        return k + 1, err_kp1
    return k, err_k


def step_factor(err: float, k: int) -> float:
    """Step-size factor after an accepted step whose next order is ``k`` and error estimate ``err``.

    The step doubles when it can at least double, shrinks to 0.5-0.9 when the
    estimate asks for any reduction, else stays (IDACompleteStep).

    Examples
    --------
    >>> step_factor(0.0, 1), step_factor(10.0, 1), step_factor(0.2, 1)
    (2.0, 0.5, 1.0)
    """
    tmp = (2.0 * err + ERROR_FLOOR) ** (-1.0 / (k + 1))
    if tmp >= ETA_GROW_MIN:
        return min(tmp, ETA_GROW_MAX)
    if tmp <= 1.0:
        return max(ETA_SHRINK_MIN, min(tmp, ETA_SHRINK_MAX))
    return 1.0


def hold_growth(eta: float, retried: bool, growth_failed: bool, ns: int, k: int) -> tuple[float, bool]:
    """The two rules beyond IDA that keep the step from oscillating.

    A step that needed a retry is not followed by a larger one (CVODE's rule),
    and after a larger step failed the error test the step grows again only
    after ``k + 2`` steps at constant size and order. Without them a tight
    absolute tolerance on an unknown crossing zero traps the method at order
    1 in a cycle "grow, fail, shrink, grow".

    Returns
    -------
    (float, bool)
        The factor and the new "a larger step failed" flag.

    Examples
    --------
    >>> hold_growth(2.0, True, False, 5, 1), hold_growth(2.0, False, True, 2, 1), hold_growth(2.0, False, True, 3, 1)
    ((1.0, False), (1.0, True), (2.0, False))
    """
    if eta > 1.0:
        if retried or (growth_failed and ns < k + 2):
            return 1.0, growth_failed
        return eta, False
    return eta, growth_failed


def error_failure(nef: int, k: int, knew: int, err_k: float, err_km1: float) -> tuple[int, float]:
    """Order and step-size factor after the ``nef``-th error-test failure of a step (IDAHandleNFlag).

    The first failure shrinks by ``0.9 (2 err)^(-1/(knew+1))`` within
    [0.25, 0.9] at the proposed order; later ones by 0.25, at order 1 from the third.

    Examples
    --------
    >>> error_failure(1, 2, 2, 10.0, 0.0)[0], error_failure(2, 3, 2, 1.0, 1.0), error_failure(3, 3, 2, 1.0, 1.0)
    (2, (2, 0.25), (1, 0.25))
    """
    if nef == 1:
        err_knew = err_k if knew == k else err_km1
        eta = ETA_SAFETY * (2.0 * err_knew + ERROR_FLOOR) ** (-1.0 / (knew + 1))
        return knew, max(ETA_ERROR_FAIL_MIN, min(ETA_SHRINK_MAX, eta))
    return (knew if nef == 2 else 1), ETA_ERROR_FAIL_MIN


def reduced_step(t: float, h: float, eta: float, min_step: float) -> tuple[float | None, str | None]:
    """The step ``h * eta`` after a failed attempt at ``t``, bounded below.

    Returns
    -------
    (float or None, str or None)
        ``(h_new, None)``; ``(min_step, None)`` when ``h * eta`` falls below a
        ``min_step`` that ``h`` was above; ``(None, "min_step")`` when ``h`` was
        at ``min_step`` already; ``(None, "roundoff")`` when the step would be
        below ``ROUNDOFF_ULPS`` ulps of ``t`` (it cannot advance time).

    Examples
    --------
    >>> reduced_step(1.0, 0.1, 0.25, 0.0), reduced_step(1.0, 0.1, 0.25, 0.05), reduced_step(1.0, 0.05, 0.25, 0.05)
    ((0.025, None), (0.05, None), (None, 'min_step'))
    >>> reduced_step(1.0, 1e-15, 0.25, 0.0)
    (None, 'roundoff')
    """
    h_new = h * eta
    if h_new < min_step:
        if h > min_step * (1.0 + 1e-12):
            return min_step, None
        return None, "min_step"
    if h_new <= ROUNDOFF_ULPS * math.ulp(abs(t)) or t + h_new == t:
        return None, "roundoff"
    return h_new, None


def first_step_from_curvature(curvature: float, cap: float, min_step: float) -> float:
    """First order-1 step ``sqrt(2 * 0.25 / |x''|_w)`` (a quarter of the error bound), at most ``cap``.

    Examples
    --------
    >>> first_step_from_curvature(0.0, 1e-3, 0.0), first_step_from_curvature(0.5e6, 1e-3, 0.0)
    (0.001, 0.001)
    """
    h = cap if curvature * cap * cap <= 2.0 * H0_ERROR_TARGET else math.sqrt(2.0 * H0_ERROR_TARGET / curvature)
    return max(h, min_step)


def first_step_from_derivative(ypnorm: float, cap: float) -> float:
    """First step with a given x'(t0): IDA's ``h |x'(t0)|_w <= 1/2``, at most ``cap``.

    Examples
    --------
    >>> first_step_from_derivative(1.0, 1.0), first_step_from_derivative(1.0, 0.1)
    (0.5, 0.1)
    """
    return cap if ypnorm * cap <= H0_DERIVATIVE_BOUND else H0_DERIVATIVE_BOUND / ypnorm
