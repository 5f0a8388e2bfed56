"""The FLC-BDF integrator against closed forms, in units of the tolerance.

Errors are measured as ``|x - x_exact| / (rtol max|x_exact| + atol)``: the
tolerance of the error test at the scale of the waveform (near a zero
crossing the pointwise relative tolerance shrinks to ``atol`` while the
global error carried there does not). A local error test does not bound the
global error by the tolerance, so each test states the multiple it allows
and the tolerance proportionality it expects when rtol and atol shrink
together.
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.dae.bdf import BDF, integrate
from netdae.dae.system import KIND_CURRENT, KIND_VOLTAGE, LinearDae
from netdae.errors import ConvergenceError

from test_bdf_problems import (
    Source,
    Source,
    differentiator,
    differentiator_exact,
    lowpass_sine_exact,
    pwl,
    rc_ladder,
    rc_lowpass,
    sine,
    v_parallel_c,
)

R, C = 1e3, 1e-6  # tau = 1 ms


def tol_units(err, ref, rtol, atol):
    return np.abs(err) / (rtol * np.max(np.abs(ref)) + atol)


def lowpass_state(t, v_in, v_out):
    return np.array([v_in, v_out, -(v_in - v_out) / R])


# --------------------------------------------------------------------------- RC with closed forms
@pytest.mark.parametrize("rtol", [1e-4, 1e-6])
def test_rc_lowpass_sine_within_a_few_tolerances(rtol):
    src = sine(1.0, 500.0)
    dae = rc_lowpass(R, C, src)
    atol = rtol * 1e-2
    res = integrate(dae, (0.0, 6e-3), np.zeros(3), rtol=rtol, vntol=atol, abstol=atol / R)
    assert res.ok, res.message
    exact = lowpass_sine_exact(res.t, R, C, 1.0, 500.0)
    units = tol_units(res["v(out)"] - exact, exact, rtol, atol)
    assert units.max() < 2.0
    # the source node is algebraic and exact up to the corrector's roundoff
    v_in = np.sin(2 * np.pi * 500.0 * res.t)
    assert np.max(np.abs(res["v(in)"] - v_in)) < 1e-12
    # Kirchhoff's current law holds at every step for the algebraic current
    np.testing.assert_allclose(res["i(v1)"], -(res["v(in)"] - res["v(out)"]) / R, rtol=0, atol=1e-15)


def test_rc_lowpass_errors_are_proportional_to_the_tolerance():
    src = sine(1.0, 500.0)
    dae = rc_lowpass(R, C, src)
    errs = []
    for rtol in (1e-3, 1e-5, 1e-7):
        atol = rtol * 1e-2
        res = integrate(dae, (0.0, 6e-3), np.zeros(3), rtol=rtol, vntol=atol, abstol=atol / R)
        exact = lowpass_sine_exact(res.t, R, C, 1.0, 500.0)
        errs.append(np.max(np.abs(res["v(out)"] - exact)))
    # 100x smaller tolerances: errors fall by well over 10x each time, and the error stays
    # within a few tolerances (tolerance proportionality of a BDF code: error ~ tol^(k/(k+1)))
    assert errs[1] < errs[0] / 15 and errs[2] < errs[1] / 15
    assert errs[2] < 1e-6


def test_rc_lowpass_step_response():
    dae = rc_lowpass(R, C, Source(lambda t: 1.0, lambda t: 0.0))
    x0 = lowpass_state(0.0, 1.0, 0.0)
    rtol, atol = 1e-6, 1e-9
    res = integrate(dae, (0.0, 8e-3), x0, rtol=rtol, vntol=atol, abstol=atol / R)
    exact = 1.0 - np.exp(-res.t / (R * C))
    assert tol_units(res["v(out)"] - exact, exact, rtol, atol).max() < 1.0
    # no breakpoints, no failures: a smooth decay needs few steps
    assert res.stats["steps"] < 200 and res.stats["rejected"] <= 3


def _ramp_response(t, slope, tau):
    tt = np.maximum(t, 0.0)
    return slope * (tt - tau * (1.0 - np.exp(-tt / tau)))


def test_breakpoints_land_exactly_and_restart_at_order_one():
    corners = np.array([0.0, 1e-3, 1.7e-3, 3.1e-3, 4e-3])
    values = np.array([0.0, 1.0, 1.0, -0.5, 0.0])
    src = pwl(corners, values)
    dae = rc_lowpass(R, C, src)
    rtol, atol = 1e-6, 1e-9
    x0 = lowpass_state(0.0, 0.0, 0.0)
    res = integrate(dae, (0.0, 6e-3), x0, rtol=rtol, vntol=atol, abstol=atol / R)
    assert res.ok, res.message
    for tc in corners[1:]:
        hits = np.flatnonzero(res.t == tc)
        assert hits.size == 1, f"no step ends exactly on the corner {tc}"
        # the step after a corner is an order-1 restart
        assert res.order[hits[0] + 1] == 1
    np.testing.assert_array_equal(res.restarts, corners[1:])
    assert res.t[-1] == 6e-3
    # closed form: superposition of ramp responses
    slopes = np.diff(values) / np.diff(corners)
    ds = np.diff(np.concatenate([[0.0], slopes, [0.0]]))
    exact = sum(d * np.array(_ramp_response(res.t - tc, 1.0, R * C)) for d, tc in zip(ds, corners))
    assert tol_units(res["v(out)"] - exact, exact, rtol, atol).max() < 3.0
    # the dense output between steps is the method's interpolant: close to the exact solution too
    tq = np.linspace(0.0, 6e-3, 2001)
    dense = res.dense(tq, ["v(out)"])[:, 0]
    exact_q = sum(d * _ramp_response(tq - tc, 1.0, R * C) for d, tc in zip(ds, corners))
    assert tol_units(dense - exact_q, exact_q, rtol, atol).max() < 3.0


def test_breakpoints_closer_than_a_sliver_are_merged():
    dae = rc_lowpass(R, C, Source(lambda t: 1.0, lambda t: 0.0))
    x0 = lowpass_state(0.0, 1.0, 0.0)
    bp = [1e-3, 1e-3 + 1e-17, 2e-3 - 1e-18]
    res = integrate(dae, (0.0, 2e-3), x0, rtol=1e-4, breakpoints=bp)
    assert res.ok
    assert np.diff(res.t).min() > 1e-12
    assert res.t[-1] == 2e-3


def test_steps_never_exceed_max_step():
    dae = rc_lowpass(R, C, Source(lambda t: 1.0, lambda t: 0.0))
    res = integrate(dae, (0.0, 8e-3), lowpass_state(0.0, 1.0, 0.0), rtol=1e-3, max_step=2e-4)
    assert np.diff(res.t).max() <= 2e-4 * (1 + 1e-12)


# --------------------------------------------------------------------------- fixed-step order study
def _lowpass_history(t_points, freq):
    out = []
    for t in t_points:
        v_out = lowpass_sine_exact(t, R, C, 1.0, freq)
        out.append(lowpass_state(t, np.sin(2 * np.pi * freq * t), v_out))
    return np.array(out)


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5])
def test_observed_order_of_fixed_step_bdf(order):
    freq, T = 200.0, 2e-3
    dae = rc_lowpass(R, C, sine(1.0, freq))
    errors = []
    for n_steps in (32, 64, 128):
        h = T / n_steps
        t_hist = -h * np.arange(order, -1, -1)
        x_hist = _lowpass_history(t_hist, freq)
        res = integrate(dae, (0.0, T), x_hist[-1], fixed_step=h, fixed_order=order,
                        history=(t_hist, x_hist), rtol=1e-3)
        assert res.ok and res.stats["steps"] == n_steps
        errors.append(abs(res["v(out)"][-1] - lowpass_sine_exact(T, R, C, 1.0, freq)))
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.25), observed


# --------------------------------------------------------------------------- index 2
def test_index2_v_parallel_c_sine_is_exact_to_tolerance_and_converges():
    c, g, freq = 1e-6, 1e-3, 1e3
    src = sine(1.0, freq)
    dae, index = v_parallel_c(c, g, src)
    x0 = np.array([0.0, -c * src.derivative(0.0)])
    errs = []
    for rtol in (1e-3, 1e-5, 1e-7):
        res = integrate(dae, (0.0, 3e-3), x0, rtol=rtol, vntol=rtol * 1e-3, abstol=rtol * 1e-6, index=index)
        assert res.ok, res.message
        w = 2 * np.pi * freq
        exact_i = -c * w * np.cos(w * res.t) - g * np.sin(w * res.t)
        errs.append(np.max(np.abs(res["i(v1)"] - exact_i)) / (c * w))
        assert res.stats["rejected"] <= 10
    assert errs[0] < 1e-2 and errs[1] < errs[0] / 5 and errs[2] < errs[1] / 5


def test_index2_jump_at_a_corner_is_reported_on_both_sides():
    c, g = 1e-6, 1e-3
    corners = [0.0, 1e-3, 2e-3, 3e-3]
    src = pwl(corners, [0.0, 1.0, 1.0, 0.0])
    dae, index = v_parallel_c(c, g, src)
    x0 = np.array([0.0, -c * 1e3])
    aware = integrate(dae, (0.0, 3e-3), x0, rtol=1e-3, index=index)
    # without the index information the restart's right limit still catches the jump of
    # i(v1) (it used to collapse the step at the first corner)
    blind = integrate(dae, (0.0, 3e-3), x0, rtol=1e-3)
    for res in (aware, blind):
        assert res.ok, res.message
        assert res.stats["rejected"] == 0 and res.stats["h_min"] > 1e-7
        assert [t for t, _ in res.jumps] == [1e-3, 2e-3]
        assert all(who == ("i(v1)",) for _, who in res.jumps)
        # i(v1) = -C V' - G V exactly, piece by piece (V is piecewise linear, BDF differentiates it
        # exactly); at a corner the left value, then the right limit at the same time
        t = res.t
        slope = np.select([t <= 1e-3, t <= 2e-3], [1e3, 0.0], -1e3)
        v = np.interp(t, corners, [0.0, 1.0, 1.0, 0.0])
        inside = ~np.isin(t, corners)
        np.testing.assert_allclose(res["i(v1)"][inside], (-c * slope - g * v)[inside], rtol=0, atol=1e-12)
        at = np.flatnonzero(t == 1e-3)
        assert at.size == 2
        np.testing.assert_allclose(res["i(v1)"][at], [-c * 1e3 - g, -g], rtol=1e-9)
        # the dense output does not interpolate across the jump
        tq = np.array([1e-3, 1e-3 + 1e-9, 1.5e-3, 2e-3 + 1e-9])
        np.testing.assert_allclose(res.dense(tq, ["i(v1)"])[:, 0],
                                   [-c * 1e3 - g, -g, -g, c * 1e3 - g * (1 - 1e-6)],
                                   rtol=1e-9, atol=1e-15)


def test_index2_sine_without_index_needs_far_more_work():
    c, g = 1e-6, 1e-3
    src = sine(1.0, 1e3)
    dae, index = v_parallel_c(c, g, src)
    x0 = np.array([0.0, -c * src.derivative(0.0)])
    blind = integrate(dae, (0.0, 2e-3), x0, rtol=1e-5, vntol=1e-8, abstol=1e-11, max_steps=20000)
    aware = integrate(dae, (0.0, 2e-3), x0, rtol=1e-5, vntol=1e-8, abstol=1e-11, index=index)
    assert aware.ok
    assert (not blind.ok) or blind.stats["rejected"] > 20 * max(aware.stats["rejected"], 1)


def test_differentiator_of_the_lecture_notes():
    l_ind, g, freq = 1e-3, 1e-3, 1e3
    src = sine(1.0, freq)
    dae, index = differentiator(l_ind, g, src)
    # consistent initial values by hand: u1 = V(0) = 0, u2 = 0, I_L = G V = 0, I_A = 0,
    # I_V = 0 and the hidden constraint u3 = -L G V'(0)
    x0 = differentiator_exact(0.0, l_ind, g, src)[0]
    assert x0[2] == pytest.approx(-l_ind * g * 2 * np.pi * freq)
    errs = []
    for rtol in (1e-4, 1e-6):
        res = integrate(dae, (0.0, 2e-3), x0, rtol=rtol, vntol=rtol * 1e-3, abstol=rtol * 1e-6, index=index)
        assert res.ok, res.message
        exact = differentiator_exact(res.t, l_ind, g, src)
        scale = l_ind * g * 2 * np.pi * freq
        errs.append(np.max(np.abs(res["v(3)"] - exact[:, 2])) / scale)
        # the index-1 unknowns are algebraic functions of V: exact up to roundoff
        np.testing.assert_allclose(res.x[:, [0, 1, 3, 4, 5]], exact[:, [0, 1, 3, 4, 5]], rtol=0, atol=1e-12)
    assert errs[0] < 1e-2 and errs[1] < errs[0] / 10


# --------------------------------------------------------------------------- linear work bounds
def test_linear_factorizations_bounded_by_newton_matrix_changes():
    dae = rc_ladder(1000, r=1e3, c=1e-9, source=sine(1.0, 1e4))
    res = integrate(dae, (0.0, 3e-4), np.zeros(dae.n), rtol=1e-4, save=np.array([0, 500, 1000]))
    st = res.stats
    assert res.ok
    # one factorisation per change of cj, plus one per derivative probe (start, restarts)
    assert st["factorizations"] <= st["cj_changes"] + st["probes"]
    # a linear corrector is one solve
    assert st["newton_iterations"] == st["steps"] + st["rejected"]
    assert res.x.shape == (res.t.size, 3)


# --------------------------------------------------------------------------- dense output, save
def test_dense_output_reproduces_steps_and_selects_components():
    dae = rc_lowpass(R, C, sine(1.0, 500.0))
    res = integrate(dae, (0.0, 4e-3), np.zeros(3), rtol=1e-6, vntol=1e-8, abstol=1e-11, save=np.array([1, 2]))
    assert res.names == ("v(out)", "i(v1)")
    np.testing.assert_allclose(res.dense(res.t), res.x, rtol=0, atol=1e-14)
    tq = np.sort(np.random.default_rng(1).uniform(0.0, 4e-3, 5000))
    vout = res.dense(tq, [0])[:, 0]
    exact = lowpass_sine_exact(tq, R, C, 1.0, 500.0)
    assert tol_units(vout - exact, exact, 1e-6, 1e-8).max() < 2.0
    assert res.dense(2e-3).shape == (2,)
    with pytest.raises(ValueError):
        res.dense([5e-3])


def test_progress_is_reported():
    calls = []
    dae = rc_lowpass(R, C, sine(1.0, 500.0))
    integrate(dae, (0.0, 2e-3), np.zeros(3), rtol=1e-4, progress=lambda t, tf, n: calls.append((t, tf, n)))
    assert calls and calls[-1][0] == 2e-3 and calls[-1][1] == 2e-3 and calls[-1][2] > 0


def test_tolerances_by_kind_are_reported_and_used():
    dae = rc_lowpass(R, C, sine(1.0, 500.0))
    solver = BDF(dae, 0.0, np.zeros(3), 1e-3, rtol=1e-4, vntol=1e-7, abstol=1e-10)
    np.testing.assert_array_equal(solver._atol, [1e-7, 1e-7, 1e-10])
    res = integrate(dae, (0.0, 1e-3), np.zeros(3), rtol=1e-4, atol=np.array([1e-6, 1e-6, 1e-9]))
    assert res.tolerances["atol"] == "per-unknown" and res.tolerances["rtol"] == 1e-4


# --------------------------------------------------------------------------- failures
def test_arguments_are_checked():
    dae = rc_lowpass(R, C)
    x0 = np.zeros(3)
    with pytest.raises(ValueError, match="index >= 3"):
        BDF(dae, 0.0, x0, 1.0, index=np.array([0, 3, 0]))
    with pytest.raises(ValueError, match="x0"):
        BDF(dae, 0.0, np.zeros(2), 1.0)
    with pytest.raises(ValueError, match="t_bound"):
        BDF(dae, 1.0, x0, 1.0)
    with pytest.raises(ValueError, match="rtol"):
        BDF(dae, 0.0, x0, 1.0, rtol=0.0)
    with pytest.raises(ValueError, match="fixed_order"):
        BDF(dae, 0.0, x0, 1.0, fixed_order=2)
    # 1/atol squared overflows the RMS norm: the first step came out 0 and the probe divided by it (a
    # ZeroDivisionError in the Python engine, a 'singular' matrix in the compiled one)
    with pytest.raises(ValueError, match="absolute tolerances must be at least 1e-100, got 1e-200"):
        BDF(dae, 0.0, x0, 1.0, atol=1e-200, vntol=1e-200)


def test_singular_system_fails_with_a_message():
    # a floating node: v(2) appears nowhere
    E = np.zeros((2, 2))
    H = np.array([[-1.0, 0.0], [0.0, 0.0]])
    dae = LinearDae(E, H, names=["v(1)", "v(2)"], kinds=[KIND_VOLTAGE, KIND_VOLTAGE])
    res = integrate(dae, (0.0, 1.0), np.zeros(2))
    assert not res.ok and "singular" in res.message
    with pytest.raises(ConvergenceError) as err:
        integrate(dae, (0.0, 1.0), np.zeros(2), raise_on_failure=True)
    assert err.value.t == 0.0 and "singular" in str(err.value)


def test_min_step_failure_names_time_step_and_unknown():
    c, g = 1e-6, 1e-3
    ramp = pwl([0.0, 1e-3, 2e-3], [0.0, 1.0, 1.0])
    hidden = Source(ramp.value, ramp.derivative)  # the corner at 1 ms is not declared a breakpoint
    dae, _ = v_parallel_c(c, g, hidden)
    res = integrate(dae, (0.0, 2e-3), np.array([0.0, -c * 1e3]), rtol=1e-3, min_step=1e-9)
    assert not res.ok
    f = res.failure
    assert f.worst == "i(v1)" and abs(f.t - 1e-3) < 1e-5 and f.h <= 4e-9
    assert "min_step" in res.message and f"t={f.t:.9g}" in res.message and "i(v1)" in res.message
    assert res.message == f.message
    # the solution up to the failure is kept
    assert res.t[-1] == pytest.approx(f.t) and res.dense(5e-4).shape == (2,)


def test_kinds_decide_default_absolute_tolerances_for_a_ladder():
    dae = rc_ladder(2)
    assert list(dae.kinds) == [KIND_VOLTAGE] * 3 + [KIND_CURRENT]
    solver = BDF(dae, 0.0, np.zeros(dae.n), 1e-6)
    np.testing.assert_array_equal(solver._atol, [1e-6, 1e-6, 1e-6, 1e-12])
