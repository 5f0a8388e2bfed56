"""Source waveforms: values, exact derivatives, breakpoints and the vectorised bank, by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netdae.netlist.waveforms import CORNER_RTOL, Am, Exp, Pulse, Pwl, Sffm, Sin, SourceBank

TSTEP, TSTOP = 1e-3, 1.0


def _central(f, t, h):
    """Fourth-order central difference of f at t (independent check of derivatives)."""
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


# -- defaults ------------------------------------------------------------------------
def test_pulse_defaults_follow_tstep_and_tstop():
    p = Pulse(0, 1).resolved(TSTEP, TSTOP)
    v1, v2, td, tr, tf, pw, per, npulse = p._P[:, 0]
    assert (td, tr, tf, pw, per, npulse) == (0.0, TSTEP, TSTEP, TSTOP, TSTOP, 0.0)
    # zero rise/fall/width/period mean "not given" in ngspice
    q = Pulse(0, 1, 0, 0, 0, 0, 0).resolved(TSTEP, TSTOP)
    assert np.array_equal(q._P, p._P)


def test_sin_exp_sffm_am_defaults():
    assert Sin(0, 1).resolved(TSTEP, TSTOP)._P[2, 0] == 1 / TSTOP
    e = Exp(0, 1).resolved(TSTEP, TSTOP)._P[:, 0]
    assert list(e[2:]) == [TSTEP, TSTEP, 2 * TSTEP, TSTEP]  # td1, tau1, td2 = td1 + tstep, tau2
    e = Exp(0, 1, 0.5).resolved(TSTEP, TSTOP)._P[:, 0]
    assert e[4] == 0.5 + TSTEP
    s = Sffm(0, 1).resolved(TSTEP, TSTOP)._P[:, 0]
    assert (s[2], s[3], s[4]) == (1 / TSTOP, 0.0, 1 / TSTOP)
    a = Am(1, 0.5).resolved(TSTEP, TSTOP)._P[:, 0]
    assert (a[2], a[3], a[4]) == (1 / TSTOP, 0.0, 0.0)


def test_unresolved_value_works_where_defaults_do_not_matter():
    assert Pulse(0, 1, 1e-3).value(0.0) == 0.0
    assert Sin(0.5, 1).value(0.0) == 0.5
    assert Exp(2, 3).value(0.0) == 2.0
    assert Sffm(1, 2, 0, 0.5, 0, 90, 90).value(0.0) == pytest.approx(1 + 2 * math.sin(math.pi / 2 + 0.5))
    assert Am(1, 0.5).value(0.0) == 0.0
    with pytest.raises(ValueError, match="resolved"):
        Pulse(0, 1).value(1e-3)
    with pytest.raises(ValueError, match="resolved"):
        Sin(0, 1).derivative(0.0)


def test_wrong_arity_and_negative_times_are_rejected():
    with pytest.raises(ValueError, match="at least 2"):
        Pulse(1)
    with pytest.raises(ValueError, match="at most 8"):
        Pulse(*range(9))
    with pytest.raises(ValueError, match="tr must be >= 0"):
        Pulse(0, 1, 0, -1)
    with pytest.raises(ValueError, match="tau1 must be >= 0"):
        Exp(0, 1, 0, -1)
    with pytest.raises(ValueError, match="must not decrease"):
        Pwl([0, 2, 1], [0, 1, 2])
    with pytest.raises(ValueError, match="does not match"):
        Pwl([0, 1, 2], [0, 1, 0], repeat=0.5)
    with pytest.raises(ValueError, match="smaller than the last"):
        Pwl([0, 1, 2], [0, 1, 0], repeat=2)


# -- PULSE -----------------------------------------------------------------------------
P = Pulse(-1, 3, 1.0, 0.5, 0.25, 2.0, 5.0).resolved(TSTEP, 100.0)  # corners at 1, 1.5, 3.5, 3.75 (+5k)


@pytest.mark.parametrize("t, expected", [
    (0.0, -1), (1.0, -1), (1.25, 1.0), (1.5, 3), (3.0, 3), (3.5, 3), (3.625, 1.0), (3.75, -1), (5.0, -1),
    (6.25, 1.0), (11.0, -1), (13.625, 1.0),
])
def test_pulse_values_by_hand(t, expected):
    assert P.value(t) == pytest.approx(expected, abs=1e-12)


def test_pulse_derivative_is_one_sided_after_the_corner():
    slope_up, slope_down = 4 / 0.5, -4 / 0.25
    t = np.array([0.5, 1.0, 1.2, 1.5, 2.0, 3.5, 3.6, 3.75, 6.0, 6.5, 8.5, 8.75])
    want = [0, slope_up, slope_up, 0, 0, slope_down, slope_down, 0, slope_up, 0, slope_down, 0]
    np.testing.assert_allclose(P.derivative(t), want, rtol=0, atol=1e-12)
    assert np.all(P.derivative(t, order=2) == 0)


def test_pulse_corner_found_despite_rounding_of_the_breakpoint():
    # a breakpoint computed as td + k*per + tr is a few ulps off the corner
    p = Pulse(0, 1, 1e-7, 1e-9, 1e-9, 3e-9, 1e-8).resolved(1e-10, 1e-5)
    for corner in p.breakpoints(0, 1e-6)[::4]:  # the starts of the rising edges
        assert p.derivative(corner) == pytest.approx(1e9)
        assert p.derivative(corner * (1 - 2 * CORNER_RTOL)) == 0.0


def test_pulse_number_of_pulses_stops_the_train():
    p = Pulse(0, 1, 0, 1, 1, 1, 4, 2).resolved(TSTEP, 100.0)
    assert p.value(5.5) == pytest.approx(1.0) and p.value(9.5) == 0.0
    assert p.derivative(4.0) == 1.0 and p.derivative(8.0) == 0.0
    assert p.breakpoints(0, 20).tolist() == [0, 1, 2, 3, 4, 5, 6, 7]


def test_pulse_breakpoints_in_a_window():
    assert P.breakpoints(4.0, 14.0).tolist() == pytest.approx([6, 6.5, 8.5, 8.75, 11, 11.5, 13.5, 13.75])
    assert P.breakpoints(0, 0.5).size == 0


# -- SIN, EXP, SFFM, AM --------------------------------------------------------------------
S = Sin(0.5, 2.0, 3.0, 0.25, 0.4, 30.0).resolved(TSTEP, TSTOP)


def test_sin_value_and_derivatives():
    w, ph = 2 * math.pi * 3.0, math.radians(30.0)
    assert S.value(0.1) == pytest.approx(0.5 + 2 * math.sin(ph))
    t = 0.7
    tau = t - 0.25
    assert S.value(t) == pytest.approx(0.5 + 2 * math.sin(w * tau + ph) * math.exp(-0.4 * tau))
    assert S.derivative(0.1) == 0.0
    for order in (1, 2, 3):
        f = (lambda x, o=order - 1: S.value(x) if o == 0 else S.derivative(x, o))
        assert S.derivative(t, order) == pytest.approx(_central(f, t, 1e-4), rel=1e-6)
    # just after the delay: the slope of the started sinusoid
    assert S.derivative(0.25) == pytest.approx(2 * (w * math.cos(ph) - 0.4 * math.sin(ph)))
    assert S.breakpoints(0, 1).tolist() == [0.25]


def test_exp_value_derivatives_and_breakpoints():
    e = Exp(1.0, -1.0, 0.2, 0.1, 0.5, 0.3).resolved(TSTEP, TSTOP)
    assert e.value(0.2) == 1.0
    rise = lambda t: -2 * (1 - math.exp(-(t - 0.2) / 0.1))
    assert e.value(0.4) == pytest.approx(1 + rise(0.4))
    assert e.value(0.9) == pytest.approx(1 + rise(0.9) + 2 * (1 - math.exp(-(0.9 - 0.5) / 0.3)))
    assert e.derivative(0.2) == pytest.approx(-2 / 0.1)
    assert e.derivative(0.1) == 0.0
    assert e.derivative(0.9, 2) == pytest.approx(
        -2 * -(1 / 0.1**2) * math.exp(-0.7 / 0.1) + 2 * -(1 / 0.3**2) * math.exp(-0.4 / 0.3))
    for t in (0.3, 0.7):
        assert e.derivative(t, 2) == pytest.approx(_central(e.derivative, t, 1e-5), rel=1e-6)
    assert e.breakpoints(0, 1).tolist() == [0.2, 0.5]


def test_sffm_derivatives_of_any_order_match_differences():
    s = Sffm(0.1, 1.0, 5.0, 2.0, 1.5, 20.0, 40.0).resolved(TSTEP, TSTOP)
    t = 0.31
    assert s.value(t) == pytest.approx(0.1 + math.sin(2 * math.pi * 5 * t + math.radians(20)
                                                      + 2 * math.sin(2 * math.pi * 1.5 * t + math.radians(40))))
    for order in (1, 2, 3, 4):
        f = (lambda x, o=order - 1: s.value(x) if o == 0 else s.derivative(x, o))
        assert s.derivative(t, order) == pytest.approx(_central(f, t, 2e-5), rel=1e-5)
    assert s.breakpoints(0, 1).size == 0


def test_am_uses_the_phase_of_the_modulation_for_both_sines():
    a = Am(2.0, 0.5, 3.0, 20.0, 0.1, 10.0, 30.0).resolved(TSTEP, TSTOP)
    tau, ph = 0.33 - 0.1, math.radians(30.0)
    assert a.value(0.33) == pytest.approx(2 * (0.5 + math.sin(2 * math.pi * 3 * tau + ph))
                                         * math.sin(2 * math.pi * 20 * tau + ph))
    assert a.value(0.1) == 0.0
    for order in (1, 2, 3):
        f = (lambda x, o=order - 1: a.value(x) if o == 0 else a.derivative(x, o))
        assert a.derivative(0.33, order) == pytest.approx(_central(f, 0.33, 1e-5), rel=1e-5)
    assert a.breakpoints(0, 1).tolist() == [0.1]


# -- PWL ----------------------------------------------------------------------------------
def test_pwl_interpolates_holds_and_steps():
    w = Pwl([1, 2, 2, 4], [0, 1, 3, 5])
    np.testing.assert_allclose(w.value([0, 1, 1.5, 2, 3, 4, 10]), [0, 0, 0.5, 1, 4, 5, 5])
    assert w.value(2 * (1 + 1e-12)) == pytest.approx(3.0, abs=1e-9)
    np.testing.assert_allclose(w.derivative([0.5, 1, 1.5, 2, 3, 4, 5]), [0, 1, 1, 1, 1, 0, 0])
    assert w.has_steps and w.breakpoints(0, 10).tolist() == [1, 2, 4]


def test_pwl_repeat_and_delay():
    w = Pwl([0, 1, 2, 3], [0, 2, 1, 2], repeat=1.0, delay=0.5)   # repeats [1, 3] with period 2
    assert w.value(0.5 + 2.5) == pytest.approx(1.5)
    assert w.value(0.5 + 4.5) == pytest.approx(1.5)              # 4.5 -> 2.5
    assert w.value(0.5 + 3.0) == 2.0                             # the end: value at the repeat point
    assert w.value(0.5 + 103.25) == pytest.approx(2 - 0.25)      # 103.25 -> 1.25
    assert w.derivative(0.5 + 5.0) == pytest.approx(-1.0)        # just after a wrap: segment 1 -> 2
    assert w.breakpoints(0, 8).tolist() == pytest.approx([0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5])


def test_pwl_single_point_is_constant():
    w = Pwl([1e-3], [4.0])
    assert w.value(0.0) == 4.0 and w.value(1.0) == 4.0 and w.derivative(1.0) == 0.0


# -- the bank -------------------------------------------------------------------------------
def _zoo():
    return [
        P,
        Pulse(0, 2, 0.3, 0.1, 0.1, 0.2, 1.0, 3).resolved(TSTEP, TSTOP),
        S,
        Sin(0, 1, 2).resolved(TSTEP, TSTOP),
        Exp(0, 1, 0.1, 0.2).resolved(TSTEP, TSTOP),
        Sffm(0, 1, 4, 1, 2).resolved(TSTEP, TSTOP),
        Am(1, 0.2, 2, 9, 0.05).resolved(TSTEP, TSTOP),
        Pwl([0, 1, 2], [0, 1, 0]),
        Pwl([0, 0.5, 0.5, 0.7, 1.0, 2.0], [1, 2, 3, 4, 5, 1], repeat=0.5, delay=0.1),
        Pwl([0.2], [7.0]),
    ]


@pytest.mark.parametrize("t", [0.0, 0.1, 0.5, 0.6, 1.0, 1.2345, 3.75, 17.3])
def test_bank_equals_the_single_waveforms(t):
    waves = _zoo()
    bank = SourceBank(waves)
    np.testing.assert_allclose(bank.values(t), [float(w.value(t)) for w in waves], rtol=1e-14, atol=1e-14)
    for order in (1, 2):
        np.testing.assert_allclose(bank.values(t, derivative=order),
                                   [float(w.derivative(t, order)) for w in waves], rtol=1e-12, atol=1e-12)


def test_bank_breakpoints_are_the_union():
    waves = _zoo()
    bank = SourceBank(waves)
    union = np.unique(np.concatenate([w.breakpoints(0, 5) for w in waves]))
    np.testing.assert_array_equal(bank.breakpoints(0, 5), union)
    assert np.all(np.diff(bank.breakpoints(0, 5)) > 0)


def test_bank_needs_resolved_waveforms():
    with pytest.raises(ValueError, match="not resolved"):
        SourceBank([Sin(0, 1)])
    assert SourceBank([]).values(1.0).shape == (0,)


@pytest.mark.parametrize("inside, outside", [
    ("PWL(0 0 1u 1 50u 1 51u 0 r=0)", "PWL(0 0 1u 1 50u 1 51u 0) r=0"),
    ("PWL(0 0 1u 1 2u 0 td=5u r=1u)", "PWL(0 0 1u 1 2u 0) td=5u r=1u"),
])
def test_pwl_repeat_and_delay_inside_the_parentheses(inside, outside):
    # ngspice 39 reads r= and td= inside PWL's parentheses too; netdae refused them ("bad PWL parameter '='")
    from netdae.netlist import load

    def wave(card):
        c = load(f"t\nV1 a 0 {card}\nR1 a 0 1k\n.tran 1u 200u\n.end\n")
        return c.elements[0].source.tran

    assert wave(inside) == wave(outside)
