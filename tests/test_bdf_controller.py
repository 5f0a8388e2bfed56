"""The FLC-BDF step and order controller alone: pure decisions on crafted error norms.

At constant steps ``sigma_i = 1/(i + 1)``, so the scaled estimates
``terr_j = (j + 1) sigma_j |.|`` are the norms of the differences themselves.
"""

from __future__ import annotations

import math

import pytest

from netdae.dae.bdf import controller as ctl
from netdae.dae.bdf.constants import (
    ERROR_FLOOR,
    ETA_ERROR_FAIL_MIN,
    ETA_GROW_MAX,
    ETA_SAFETY,
    ETA_SHRINK_MAX,
    ETA_SHRINK_MIN,
    H0_ERROR_TARGET,
)


def _sigma(k):
    return [1.0] + [1.0 / (i + 1) for i in range(1, k + 1)]


def test_error_test_passes_up_to_the_bound_and_flags_non_finite_norms():
    ck = 1.0 / 3.0
    assert ctl.error_test((3.0, 0.0, 0.0), _sigma(2), ck, 2).passed
    assert not ctl.error_test((3.0 * (1 + 1e-15), 0.0, 0.0), _sigma(2), ck, 2).passed
    r = ctl.error_test((math.nan, 0.0, 0.0), _sigma(2), ck, 2)
    assert not r.passed and not r.finite
    assert ctl.error_test((math.inf, 0.0, 0.0), _sigma(2), ck, 2).finite is False


def test_error_test_order_one_has_no_lower_order():
    r = ctl.error_test((0.1, 5.0, 5.0), _sigma(1), 0.5, 1)
    assert r.knew == 1 and r.err_km1 == 0.0 and r.err_k == pytest.approx(0.05)


def test_error_test_lowers_order_two_when_the_lower_estimate_is_half():
    assert ctl.error_test((1.0, 0.5, 0.0), _sigma(2), 0.3, 2).knew == 1
    assert ctl.error_test((1.0, 0.51, 0.0), _sigma(2), 0.3, 2).knew == 2


def test_error_test_lowers_higher_orders_when_both_lower_estimates_are_smaller():
    assert ctl.error_test((1.0, 0.9, 1.0), _sigma(3), 0.25, 3).knew == 2
    assert ctl.error_test((1.0, 0.9, 1.1), _sigma(3), 0.25, 3).knew == 3
    r = ctl.error_test((1.0, 0.6, 0.2), _sigma(5), 1.0 / 6.0, 5)
    assert r.knew == 4 and r.err_k == pytest.approx(1.0 / 6.0) and r.err_km1 == pytest.approx(0.6 / 5.0)


def test_raise_test_needs_k_plus_2_constant_steps_and_no_recent_raise():
    assert ctl.raise_test_due(2, 2, 5, 4, 0)
    assert not ctl.raise_test_due(2, 2, 5, 3, 0)  # too few constant steps
    assert not ctl.raise_test_due(2, 2, 5, 4, 1)  # the order was just raised
    assert not ctl.raise_test_due(2, 1, 5, 4, 0)  # a lower order is proposed
    assert not ctl.raise_test_due(5, 5, 5, 9, 0)  # at maxord


def test_choose_order():
    assert ctl.choose_order(1, 0.0, 0.4, 0.1) == (2, 0.1)  # 3 * 0.1 < 0.5 * 2 * 0.4
    assert ctl.choose_order(1, 0.0, 0.4, 0.2) == (1, 0.4)
    assert ctl.choose_order(3, 0.1, 0.2, 0.3) == (2, 0.1)  # 3 * 0.1 <= min(4 * 0.2, 5 * 0.3)
    assert ctl.choose_order(3, 0.5, 0.3, 0.1) == (4, 0.1)
    assert ctl.choose_order(3, 0.5, 0.3, 0.3) == (3, 0.3)


def test_step_factor_doubles_holds_or_shrinks():
    assert ctl.step_factor(0.0, 3) == ETA_GROW_MAX
    # exactly at the doubling threshold: (2 err + floor)^(-1/2) = 2
    err = (0.25 - ERROR_FLOOR) / 2.0
    assert ctl.step_factor(err * (1 - 1e-9), 1) == 2.0
    assert ctl.step_factor(err * 1.01, 1) == 1.0
    assert ctl.step_factor(0.5, 2) == ETA_SHRINK_MAX  # asks for 0.99..: at most 0.9
    assert ctl.step_factor(1e6, 1) == ETA_SHRINK_MIN
    tmp = (2.0 * 1.5 + ERROR_FLOOR) ** (-1.0 / 3.0)
    assert ctl.step_factor(1.5, 2) == pytest.approx(tmp) and ETA_SHRINK_MIN < tmp < ETA_SHRINK_MAX


def test_hold_growth_rules():
    assert ctl.hold_growth(2.0, True, False, 9, 1) == (1.0, False)  # after a retry: no growth
    assert ctl.hold_growth(2.0, False, True, 2, 1) == (1.0, True)  # a larger step failed: wait k + 2 steps
    assert ctl.hold_growth(2.0, False, True, 3, 1) == (2.0, False)  # then grow and forget
    assert ctl.hold_growth(0.5, True, True, 0, 1) == (0.5, True)  # shrinking is never held


def test_error_failure_factors_and_orders():
    k, eta = ctl.error_failure(1, 3, 3, 2.0, 0.0)
    assert k == 3 and eta == pytest.approx(max(ETA_ERROR_FAIL_MIN, ETA_SAFETY * (4.0 + ERROR_FLOOR) ** -0.25))
    k, eta = ctl.error_failure(1, 3, 2, 100.0, 0.6)  # at the proposed lower order, its estimate
    assert k == 2 and eta == pytest.approx(ETA_SAFETY * (1.2 + ERROR_FLOOR) ** (-1.0 / 3.0))
    assert ctl.error_failure(1, 2, 2, 1e-9, 0.0)[1] == ETA_SHRINK_MAX
    assert ctl.error_failure(1, 1, 1, 1e9, 0.0)[1] == ETA_ERROR_FAIL_MIN
    assert ctl.error_failure(2, 4, 3, 1.0, 1.0) == (3, ETA_ERROR_FAIL_MIN)
    assert ctl.error_failure(3, 4, 3, 1.0, 1.0) == (1, ETA_ERROR_FAIL_MIN)


def test_first_steps():
    # h^2/2 |x''| = H0_ERROR_TARGET
    h = ctl.first_step_from_curvature(8.0, 10.0, 0.0)
    assert h * h / 2.0 * 8.0 == pytest.approx(H0_ERROR_TARGET)
    assert ctl.first_step_from_curvature(8.0, 0.01, 0.0) == 0.01
    assert ctl.first_step_from_curvature(8.0, 10.0, 1.0) == 1.0
    assert ctl.first_step_from_derivative(4.0, 1.0) == 0.125
    assert ctl.first_step_from_derivative(4.0, 0.1) == 0.1


def test_reduced_step_is_bounded_by_min_step_and_the_roundoff_of_t():
    assert ctl.reduced_step(1.0, 0.1, 0.25, 0.0) == (0.1 * 0.25, None)
    assert ctl.reduced_step(1.0, 0.1, 0.25, 0.05) == (0.05, None)  # clamped once ...
    assert ctl.reduced_step(1.0, 0.05, 0.25, 0.05) == (None, "min_step")  # ... then a failure
    assert ctl.reduced_step(1e3, 1e-12, 0.25, 0.0) == (None, "roundoff")  # below 16 ulps of t
    assert ctl.reduced_step(0.0, 1e-300, 0.25, 0.0)[1] is None  # at t = 0 any positive step advances
