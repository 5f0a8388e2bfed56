"""pn-junction helpers against hand computations and closed forms."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import netdae
from netdae.devices.junction import (
    BOLTZMANN,
    CHARGE,
    REFTEMP,
    Depletion,
    energy_gap,
    fetlim,
    ideal_junction,
    limvds,
    pb_factor,
    pnjlim,
    saturation_exponent,
    scale_junction,
    thermal_voltage,
    vcrit,
)
from netdae.errors import NetlistError

VT = 0.025852  # thermal voltage near 300 K


# -- limiting ---------------------------------------------------------------

def test_pnjlim_forward_step_from_a_forward_old_value_is_logarithmic():
    # vold = 0.6, vnew = 1.0, vt = 0.025: arg = 16, v = 0.6 + 0.025 (2 + ln 14)
    v, changed = pnjlim(np.array([1.0]), np.array([0.6]), 0.025, 0.6)
    assert v[0] == pytest.approx(0.6 + 0.025 * (2.0 + math.log(14.0)), rel=1e-15)
    assert changed.tolist() == [True]


def test_pnjlim_from_reverse_bias_jumps_to_vt_log():
    # vold <= 0: v = vt ln(vnew / vt)
    v, changed = pnjlim(np.array([5.0]), np.array([-0.3]), 0.025, 0.7)
    assert v[0] == pytest.approx(0.025 * math.log(5.0 / 0.025), rel=1e-15)
    assert changed[0]


def test_pnjlim_large_downward_step_above_vcrit():
    # vold = 3, vnew = 1 (> vcrit): arg = -80, v = 3 - vt (2 + ln 82)
    v, _ = pnjlim(np.array([1.0]), np.array([3.0]), 0.025, 0.7)
    assert v[0] == pytest.approx(3.0 - 0.025 * (2.0 + math.log(82.0)), rel=1e-15)


def test_pnjlim_reverse_floors():
    # from vold = 0.5 > 0 the floor is -vold - 1; from vold = -2 it is 2 vold - 1
    v, changed = pnjlim(np.array([-10.0, -10.0, -1.2]), np.array([0.5, -2.0, 0.5]), 0.025, 0.7)
    assert v.tolist() == [-1.5, -5.0, -1.2]
    assert changed.tolist() == [True, True, False]


def test_pnjlim_leaves_small_steps_alone_and_says_so():
    vnew = np.array([0.65, 0.3, -0.5])
    v, changed = pnjlim(vnew, np.array([0.64, 0.2, -0.4]), 0.025, 0.7)
    assert v is vnew and changed is None


def test_fetlim_cases_from_devsup():
    vto = np.full(6, 1.0)
    vold = np.array([6.0, 6.0, 2.0, 2.0, 0.0, 0.0])
    vnew = np.array([20.0, 1.0, 10.0, -3.0, 5.0, -10.0])
    v = fetlim(vnew, vold, vto)
    # strongly on, up: vold + (|2 (vold - vto)| + 2) = 6 + 12; strongly on, down below vto+3.5: max(vnew, vto + 2)
    # middle region: min(vnew, vto + 4), max(vnew, vto - 0.5); off going on past vto+0.5: vto + 0.5;
    # off going down: vold - (|2 (vold - vto)| + 2) = -4
    assert v.tolist() == [18.0, 3.0, 5.0, 0.5, 1.5, -4.0]


def test_limvds_cases_from_devsup():
    v = limvds(np.array([20.0, 1.0, 10.0, -3.0, 3.0]), np.array([4.0, 4.0, 1.0, 1.0, 4.0]))
    # from >= 3.5: up to 3 vold + 2, down below 3.5 not under 2; from < 3.5: up to 4, down to -0.5
    assert v.tolist() == [14.0, 2.0, 4.0, -0.5, 3.0]


# -- junction current -------------------------------------------------------

def test_ideal_junction_forward_closed_form():
    isat, vte = 1e-14, 1.5 * VT
    v = np.array([-0.05, 0.0, 0.3, 0.7])
    i, g = ideal_junction(v, isat, vte, -3 * vte)
    np.testing.assert_allclose(i, isat * np.expm1(v / vte), rtol=1e-12, atol=1e-30)
    np.testing.assert_allclose(g, isat * np.exp(v / vte) / vte, rtol=1e-14)


def test_ideal_junction_reverse_cubic_and_continuity_at_the_knee():
    isat, vte = 2e-12, VT
    knee = -3 * vte
    v = np.array([-1.0, -10.0])
    i, g = ideal_junction(v, isat, vte, knee)
    a = (3 * vte / (v * math.e)) ** 3
    np.testing.assert_allclose(i, -isat * (1 + a), rtol=1e-14)
    np.testing.assert_allclose(g, isat * 3 * a / v, rtol=1e-14)
    # value and slope continuous at -3 vte (the cubic is ngspice's C1 continuation)
    eps = 1e-9
    ia, ga = ideal_junction(np.array([knee - eps]), isat, vte, knee)
    ib, gb = ideal_junction(np.array([knee + eps]), isat, vte, knee)
    assert ia[0] == pytest.approx(ib[0], rel=1e-7)
    assert ga[0] == pytest.approx(gb[0], rel=1e-6)


# -- depletion charge -------------------------------------------------------

def _ngspice_capacitance(v, cj0, vj, m, fc):
    """ngspice's depletion capacitance formula (dioload.c), written independently."""
    if v < fc * vj:
        return cj0 * (1 - v / vj) ** (-m)
    f2 = (1 - fc) ** (1 + m)
    f3 = 1 - fc * (1 + m)
    return cj0 / f2 * (f3 + m * v / vj)


@pytest.mark.parametrize("m,fc", [(0.5, 0.5), (0.33, 0.8), (0.45, 0.0)])
def test_depletion_capacitance_is_ngspice_formula_and_dq_dv(m, fc):
    cj0, vj = 3e-12, 0.75
    dep = Depletion(cj0, vj, m, fc)
    v = np.array([-20.0, -1.0, -0.1, 0.0, 0.2, 0.4, 0.6, 0.9, 1.5])
    q, c = dep(v)
    expected = np.array([_ngspice_capacitance(x, cj0, vj, m, fc) for x in v])
    np.testing.assert_allclose(c, expected, rtol=1e-13)
    # c is the derivative of q: central differences, error O(h^2 q''')
    h = 1e-6
    qp, _ = dep(v + h)
    qm, _ = dep(v - h)
    np.testing.assert_allclose((qp - qm) / (2 * h), c, rtol=1e-7)


def test_depletion_charge_is_the_integral_of_the_capacitance():
    cj0, vj, m, fc = 1e-12, 0.8, 0.4, 0.5
    dep = Depletion(cj0, vj, m, fc)
    v = np.linspace(-5.0, 1.2, 20001)
    q, c = dep(v)
    assert dep(np.array([0.0]))[0][0] == 0.0
    # trapezoidal integral of c from -5 to each point equals q - q(-5)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (c[1:] + c[:-1]) * np.diff(v))])
    np.testing.assert_allclose(integral, q - q[0], atol=1e-9 * cj0 * vj)


def test_depletion_closed_form_below_fc():
    cj0, vj, m = 2e-12, 0.9, 0.5
    q, _ = Depletion(cj0, vj, m, 0.5)(np.array([-3.0]))
    assert q[0] == pytest.approx(vj * cj0 * (1 - (1 + 3.0 / vj) ** (1 - m)) / (1 - m), rel=1e-14)


@pytest.mark.parametrize("v", [1e-15, -1e-12, 3e-9, -2e-6])
def test_depletion_charge_and_junction_current_keep_relative_accuracy_near_zero_bias(v):
    # near v = 0 the series q = cj0 v (1 + m v / (2 vj) + ...), i = Is (v/vte)(1 + v/(2 vte) + ...)
    # are exact to far below 1e-12 relative; a difference of two numbers near 1 would
    # leave an absolute error eps * vj cj0 / (1 - m) (relative 1e-4 at v = 1e-15)
    cj0, vj, m = 10e-12, 0.7, 0.5
    q, c = Depletion(cj0, vj, m, 0.5)(np.array([v]))
    x = v / vj
    series = cj0 * v * (1 + m * x / 2 + m * (m + 1) * x * x / 6)
    assert q[0] == pytest.approx(series, rel=1e-12)
    assert c[0] == pytest.approx(cj0 * (1 - x) ** -m, rel=1e-14)
    isat, vte = 7e-9, 1.8 * VT
    i, g = ideal_junction(np.array([v]), isat, vte, -3 * vte)
    y = v / vte
    assert i[0] == pytest.approx(isat * y * (1 + y / 2 + y * y / 6), rel=1e-12)
    assert g[0] == pytest.approx(isat * math.exp(y) / vte, rel=1e-14)


def test_substrate_form_with_fc_zero():
    cj0, vj, m = 1e-12, 0.75, 0.3
    q, c = Depletion(cj0, vj, m, 0.0)(np.array([0.5]))
    assert q[0] == pytest.approx(0.5 * cj0 * (1 + m * 0.5 / (2 * vj)), rel=1e-14)
    assert c[0] == pytest.approx(cj0 * (1 + m * 0.5 / vj), rel=1e-14)


# -- temperature -------------------------------------------------------------

def test_pb_factor_vanishes_at_the_reference_temperature():
    # -(1.1150877 - Eg(REFTEMP)): Eg(300.15 K) = 1.1150877 to 7 digits
    assert abs(float(pb_factor(REFTEMP))) < 1e-7
    assert float(energy_gap(REFTEMP)) == pytest.approx(1.1150877, abs=1e-7)


def test_scale_junction_identity_at_nominal_temperature():
    cj, vj = scale_junction(5e-12, 0.5, 0.8, 300.15, 300.15)
    assert float(cj) == pytest.approx(5e-12, rel=1e-14)
    assert float(vj) == pytest.approx(0.8, rel=1e-14)


def _pbfact(t):
    """ngspice's pbfact written independently (diotemp.c)."""
    vt = BOLTZMANN * t / CHARGE
    eg = 1.16 - 7.02e-4 * t * t / (t + 1108)
    return -2 * vt * (1.5 * math.log(t / REFTEMP) + CHARGE * (-eg / (2 * BOLTZMANN * t)
                                                            + 1.1150877 / (2 * BOLTZMANN * REFTEMP)))


@pytest.mark.parametrize("t,tnom", [(373.15, 300.15), (250.0, 320.0)])
def test_scale_junction_against_the_formula(t, tnom):
    vj0, m, c0 = 0.7, 0.5, 1e-12
    pbo = (vj0 - _pbfact(tnom)) / (tnom / REFTEMP)
    vj_t = _pbfact(t) + t / REFTEMP * pbo
    c_t = c0 / (1 + m * (400e-6 * (tnom - REFTEMP) - (vj0 - pbo) / pbo)) \
        * (1 + m * (400e-6 * (t - REFTEMP) - (vj_t - pbo) / pbo))
    cj, vj = scale_junction(c0, m, vj0, tnom, t)
    assert float(vj) == pytest.approx(vj_t, rel=1e-13)
    assert float(cj) == pytest.approx(c_t, rel=1e-13)


def test_saturation_current_scaling_at_two_temperatures():
    # Is(T) = Is exp((T/Tnom - 1) Eg / (N vt) + XTI/N ln(T/Tnom))
    eg, xti, n, tnom = 1.11, 3.0, 1.5, 300.15
    for t in (250.0, 400.0):
        vt = BOLTZMANN * t / CHARGE
        expected = math.exp((t / tnom - 1) * eg / (n * vt) + xti / n * math.log(t / tnom))
        assert math.exp(float(saturation_exponent(eg, xti, tnom, t)) / n) == pytest.approx(expected, rel=1e-13)


def test_vcrit_definition():
    vte = float(thermal_voltage(300.15))
    assert float(vcrit(vte, 1e-14)) == pytest.approx(vte * math.log(vte / (math.sqrt(2) * 1e-14)), rel=1e-15)


#: A transient through each family's junction capacitances, with ``{}`` on the model card.
_JUNCTIONS = {
    "mosfet": ("V1 d 0 PULSE(0 5 1n 1n 1n 5n 10n)\nV2 g 0 2\nM1 d g 0 0 nm l=1u w=10u ad=1p as=1p pd=4u ps=4u\n"
               ".model nm nmos level=1 vto=0.7 kp=1e-4 cj=1e-4 cjsw=1e-10 {}"),
    "bjt": "V1 c 0 PULSE(0 5 1n 1n 1n 5n 10n)\nV2 b 0 0.7\nQ1 c b 0 qn\n.model qn npn cje=1p cjc=1p cjs=1p {}",
    "diode": "V1 a 0 PULSE(-1 1 1n 1n 1n 5n 10n)\nR1 a b 1k\nD1 b 0 dm\n.model dm d cjo=1p {}",
    "jfet": "V1 d 0 PULSE(0 5 1n 1n 1n 5n 10n)\nV2 g 0 0\nJ1 d g 0 jm\n.model jm njf vto=-2 cgs=1p cgd=1p {}",
    "vdmos": "V1 d 0 PULSE(0 5 1n 1n 1n 5n 10n)\nV2 g 0 3\nM1 d g 0 vm\n.model vm vdmos cjo=1p {}",
}


def _junction_card(family: str, values: str) -> str:
    return f"t\n{_JUNCTIONS[family].format(values)}\n.tran 0.1n 10n\n.end\n"


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("family, values, need", [
    ("mosfet", "mjsw=1e300", "mjsw must be between 0 and 10, and not 1"),
    ("mosfet", "mj=1e300", "mj must be between 0 and 10, and not 1"),
    ("mosfet", "mj=-1e300", "mj must be between 0 and 10, and not 1"),
    ("mosfet", "mjsw=1", "mjsw must be between 0 and 10, and not 1"),  # (1 - m) divides the charge
    ("mosfet", "fc=1e300", "fc must be between 0 and 1 (1 excluded)"),
    ("mosfet", "fc=1", "fc must be between 0 and 1 (1 excluded)"),
    ("mosfet", "pb=1e-300", "pb must be >= 0.01 V"),
    ("bjt", "mje=-1e300", "mje must be >= 0"),
    ("bjt", "mjc=-1e300", "mjc must be >= 0"),
    ("bjt", "vje=1e-300", "vje must be >= 0.01 V"),
    ("bjt", "vjs=1e-300", "vjs must be >= 0.01 V"),
    ("diode", "mj=-1e300", "mj must be >= 0"),
    ("diode", "vj=1e-300", "vj must be >= 0.01 V"),
    ("jfet", "pb=1e-300", "pb must be >= 0.01 V"),
    ("vdmos", "m=-1e300", "m must be >= 0"),
])
def test_absurd_junction_parameters_are_refused_at_the_value(family, values, need):
    """They overflowed numpy's power and exponential in the depletion charge (RuntimeWarnings, then non-finite
    equations or a failed run); ngspice 39 stops on them too (mjsw=1e300: NaN currents; mj=1, mj=-1e300 and
    pb=1e-300: "Timestep too small"). Located at the value, naming the parameter and its valid range."""
    text = _junction_card(family, values)
    with pytest.raises(NetlistError, match=re.escape(need)) as err:
        netdae.simulate(text)
    raw = values.split("=")[0]
    assert err.value.location is not None and "model " in str(err.value)
    line = text.splitlines()[err.value.location.line - 1]
    assert line[err.value.location.column - 1:].startswith(values.split("=")[1])  # at the value
    assert raw in str(err.value)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("family, values", [
    ("mosfet", "mj=10 mjsw=10 fc=0.9999999999"),  # the limits themselves: finite, no warning
    ("mosfet", "pb=0.01"),
    ("bjt", "mje=1e300 fc=1e300 vjc=0.01"),  # clamped (grading 0.999, fc 0.9999)
    ("diode", "m=1e300 vj=0.01"),  # clamped at 0.9, as ngspice
    ("jfet", "pb=0.01 fc=1e300"),
])
def test_junction_parameters_at_their_limits_run_without_warnings(family, values):
    assert netdae.simulate(_junction_card(family, values)).ok


@pytest.mark.filterwarnings("error")
def test_the_diode_clamps_fc_at_095_as_ngspice():
    """ngspice's diotemp.c limits FC to 0.95 ("coefficient Fc too large"); netdae took ln(1 - fc) of fc=1e300
    (NaN, a RuntimeWarning and a failed run)."""
    clamped = netdae.simulate(_junction_card("diode", "fc=1e300"))
    at_limit = netdae.simulate(_junction_card("diode", "fc=0.95"))
    assert clamped.ok
    np.testing.assert_array_equal(clamped["v(b)"], at_limit["v(b)"])
