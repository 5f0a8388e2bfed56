"""The FLC-BDF history alone: divided differences, psi, coefficients, restore."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netdae.dae.bdf.history import History

MAXORD = 5


def _divided_difference(t, y):
    """[y_0, ..., y_j] by the recursive definition (newest first)."""
    if len(t) == 1:
        return y[0]
    return (_divided_difference(t[:-1], y[:-1]) - _divided_difference(t[1:], y[1:])) / (t[0] - t[-1])


@pytest.mark.parametrize("k", [1, 2, 3, 5])
def test_update_keeps_modified_divided_differences(k):
    """After every accepted step P[j] = psi_0 ... psi_{j-1} [x_{n+1}, ..., x_{n+1-j}] for j <= k."""
    rng = np.random.default_rng(k)
    h0 = 0.1
    times = list(h0 * np.arange(-k, 1))
    values = list(rng.normal(size=(k + 1, 3)))
    hist = History(3, 3, MAXORD)
    hist.from_samples(h0, np.array(values))
    t = 0.0
    for h in rng.uniform(0.03, 0.2, 12):
        hist.set_coefficients(h)
        x_pred = hist.predict()[0]
        x_new = rng.normal(size=3)  # any accepted value: the update is exact algebra
        hist.accept(h)
        hist.update(x_new - x_pred, k)
        t += h
        times.append(t)
        values.append(x_new)
        newest_t = times[::-1]
        newest_y = values[::-1]
        for j in range(k + 1):
            scale = math.prod(hist.psi[:j])
            direct = scale * _divided_difference(newest_t[: j + 1], newest_y[: j + 1])
            np.testing.assert_allclose(hist.P[j], direct, rtol=1e-9, atol=1e-11 * max(1.0, scale))


def test_psi_are_the_distances_to_past_points():
    hist = History(1, 1, MAXORD)
    hist.from_samples(0.1, np.array([[0.0], [1.0], [2.0]]))  # order 2 at t = -0.2, -0.1, 0
    hist.set_coefficients(0.05)
    np.testing.assert_allclose(hist.psi[:3], [0.05, 0.15, 0.25])


def test_restore_undoes_the_coefficients_and_prediction():
    rng = np.random.default_rng(1)
    hist = History(2, 4, MAXORD)
    hist.from_samples(0.1, rng.normal(size=(4, 2)), rng.normal(size=(4, 2)))
    hist.set_coefficients(0.1)
    hist.accept(0.1)
    hist.update(rng.normal(size=4), 3)
    P, psi = hist.P.copy(), hist.psi.copy()
    hist.set_coefficients(0.037)  # a new step size: the predicted differences are scaled
    assert not np.array_equal(hist.P, P)
    hist.restore()
    np.testing.assert_allclose(hist.P, P, rtol=1e-15)
    np.testing.assert_array_equal(hist.psi, psi)


def test_leading_coefficient_changes_only_with_step_and_order():
    hist = History(1, 1, MAXORD)
    hist.P[0, 0] = 1.0
    hist.initialise(0.1, np.array([1.0]))
    assert hist.cj == pytest.approx(10.0)
    hist.set_coefficients(0.1)
    assert hist.cj == pytest.approx(10.0) and hist.k == 1
    hist.accept(0.1)
    hist.update(np.zeros(1), 1)
    hist.k = 2
    hist.set_coefficients(0.1)
    assert hist.cj == pytest.approx(1.5 / 0.1)
    assert hist.cjlast == pytest.approx(10.0)


def test_initialise_and_rescale_the_first_step():
    hist = History(2, 4, MAXORD)
    hist.P[0] = [1.0, 2.0, 3.0, 4.0]
    hist.initialise(0.01, np.array([1.0, -1.0]), np.array([2.0, 0.5]))
    np.testing.assert_allclose(hist.P[1], [0.01, -0.01, 0.02, 0.005])
    assert not hist.P[2:].any() and hist.k == 1 and hist.ns == 0
    hist.rescale_first_step(0.0025, 0.01)
    np.testing.assert_allclose(hist.P[1], [0.0025, -0.0025, 0.005, 0.00125])
    assert hist.psi[0] == 0.0025


def test_sampled_history_is_checked():
    from netdae.dae.bdf.history import sampled_history

    x0 = np.array([2.0])
    t, x, h = sampled_history(([0.0, 0.5, 1.0], [[0.0], [1.0], [2.0]]), 1.0, x0, MAXORD)
    assert h == 0.5 and x.shape == (3, 1)
    with pytest.raises(ValueError, match="equally spaced"):
        sampled_history(([0.0, 0.4, 1.0], [[0.0], [1.0], [2.0]]), 1.0, x0, MAXORD)
    with pytest.raises(ValueError, match="equal x0"):
        sampled_history(([0.0, 0.5, 1.0], [[0.0], [1.0], [3.0]]), 1.0, x0, MAXORD)
    with pytest.raises(ValueError, match="times and values"):
        sampled_history(([1.0], [[2.0]]), 1.0, x0, MAXORD)
