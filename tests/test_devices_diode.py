"""The level-1 diode against closed forms, finite differences and ngspice's formulas."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

from netdae.analyses.op import operating_point
from netdae.circuit import Model
from netdae.devices.companion import LimitState
from netdae.devices.diode import breakdown_voltage
from netdae.devices.junction import BOLTZMANN, CHARGE, KELVIN
from netdae.errors import CircuitError, NetlistError
from netdae.mna import assemble
from netdae.netlist import load

GMIN = 1e-12
TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}


def vt_at(celsius: float) -> float:
    return BOLTZMANN * (celsius + KELVIN) / CHARGE


def op(text: str) -> dict[str, float]:
    r = operating_point(load(text), **TIGHT)
    return {k: float(v[0]) for k, v in r.signals.items()}


def fd_jacobians(system, x, t=0.0, h=1e-7):
    """Central-difference dq/dx and dphi/dx (state None: continuation, no limiting)."""
    n = system.n
    dq = np.zeros((n, n))
    dphi = np.zeros((n, n))
    for j in range(n):
        step = h * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += step
        xm[j] -= step
        ep, em = system.evaluate(xp, t), system.evaluate(xm, t)
        dq[:, j] = (ep.q - em.q) / (2 * step)
        dphi[:, j] = (ep.phi - em.phi) / (2 * step)
    return dq, dphi


def assert_jacobians_match(system, x, rtol=1e-6):
    ev = system.evaluate(x, 0.0)
    assert ev.ok and not ev.limited
    dq, dphi = fd_jacobians(system, x)
    E = system.pattern.matrix(ev.dq).toarray()
    H = system.pattern.matrix(ev.dphi).toarray()
    np.testing.assert_allclose(H, dphi, rtol=rtol, atol=rtol * np.abs(H).max())
    np.testing.assert_allclose(E, dq, rtol=rtol, atol=rtol * max(np.abs(E).max(), 1e-30))


def test_forward_biased_diode_with_resistor_closed_form():
    # (V - vd)/R = Is (exp(vd/(N vt)) - 1) + GMIN vd
    V, R, Is, N = 5.0, 1e3, 1e-14, 1.2
    x = op(f"t\nV1 a 0 {V}\nR1 a d {R}\nD1 d 0 dm\n.model dm d is={Is} n={N}\n.end\n")
    vte = N * vt_at(27.0)
    vd = brentq(lambda v: (V - v) / R - Is * math.expm1(v / vte) - GMIN * v, 0.0, 1.5, xtol=1e-15)
    assert x["v(d)"] == pytest.approx(vd, rel=1e-11)
    assert x["i(v1)"] == pytest.approx(-(V - vd) / R, rel=1e-10)


def test_series_resistance_and_area_multiplier():
    # area 2 and m 3 = six unit diodes in parallel; RS/(area m) in series
    Is, RS, I = 1e-14, 6.0, 10e-3
    x = op(f"t\nI1 0 a {I}\nD1 a 0 dm 2 m=3\n.model dm d is={Is} rs={RS}\n.end\n")
    vt = vt_at(27.0)
    vj = brentq(lambda v: 6 * Is * math.expm1(v / vt) + GMIN * v - I, 0.0, 1.5, xtol=1e-15)
    assert x["v(d1#internal)"] == pytest.approx(vj, rel=1e-10)
    assert x["v(a)"] == pytest.approx(vj + I * RS / 6, rel=1e-10)


@pytest.mark.parametrize("celsius", [-20.0, 27.0, 100.0])
def test_saturation_current_temperature_scaling(celsius):
    # forward voltage at a fixed current with IS(T) = IS (T/Tnom)^(XTI/N) exp((T/Tnom - 1) EG/(N vt))
    Is, N, EG, XTI, I = 1e-14, 1.5, 1.2, 2.5, 1e-3
    x = op(f"t\nI1 0 a {I}\nD1 a 0 dm temp={celsius}\n.model dm d is={Is} n={N} eg={EG} xti={XTI}\n.end\n")
    t, tnom = celsius + KELVIN, 27.0 + KELVIN
    vt = vt_at(celsius)
    is_t = Is * math.exp(((t / tnom) - 1) * EG / (N * vt) + XTI / N * math.log(t / tnom))
    vd = brentq(lambda v: is_t * math.expm1(v / (N * vt)) + GMIN * v - I, 0.0, 2.0, xtol=1e-15)
    assert x["v(a)"] == pytest.approx(vd, rel=1e-10)


def test_reverse_cubic_region():
    # a reverse-biased diode at -2 V carries -Is (1 + (3 vt / (e v))^3) - GMIN... + GMIN v
    Is = 1e-9
    x = op(f"t\nV1 a 0 -2\nD1 a 0 dm\n.model dm d is={Is}\n.end\n")
    vt = vt_at(27.0)
    a = (3 * vt / (-2.0 * math.e)) ** 3
    assert x["i(v1)"] == pytest.approx(-(-Is * (1 + a) + GMIN * -2.0), rel=1e-12)


def test_breakdown_current_at_the_adjusted_voltage():
    # deep in breakdown: -id = Is exp(-(BV' + vd)/(NBV vt)) - GMIN vd
    Is, BV, IBV, NBV = 1e-12, 5.6, 1e-3, 1.3
    x = op(f"t\nV1 a 0 -6\nD1 a 0 dz\n.model dz d is={Is} bv={BV} ibv={IBV} nbv={NBV}\n.end\n")
    vt = vt_at(27.0)
    bvp = float(breakdown_voltage(np.array([BV]), np.array([IBV]), np.array([Is]), np.array([NBV * vt]),
                                  np.array([vt]), 1e-3)[0])
    assert x["i(v1)"] == pytest.approx(Is * math.exp(-(bvp - 6.0) / (NBV * vt)) - GMIN * 6.0, rel=1e-12)


def test_breakdown_adjustment_matches_ibv_within_reltol():
    # Is (exp((BV - BV')/(NBV vt)) - 1 + BV'/vt) = IBV within reltol * IBV (ngspice's stopping rule)
    vt = vt_at(27.0)
    bv = np.array([5.6, 20.0, 100.0])
    ibv = np.array([1e-3, 1e-5, 1e-1])
    isat = np.array([1e-12, 1e-14, 1e-9])
    nbv_vt = np.array([1.0, 1.5, 2.0]) * vt
    bvp = breakdown_voltage(bv, ibv, isat, nbv_vt, vt, 1e-6)
    current = isat * (np.exp((bv - bvp) / nbv_vt) - 1 + bvp / vt)
    np.testing.assert_allclose(current, ibv, rtol=1e-6)
    # a breakdown current below Is BV / vt keeps BV (ngspice's rule)
    assert float(breakdown_voltage(np.array([5.0]), np.array([1e-12]), np.array([1e-12]), np.array([vt]),
                                   vt, 1e-3)[0]) == 5.0


CHARGED = """diode charges
V1 a 0 0
R1 a b 10
D1 b c dm 1.5
R2 c 0 100
.model dm d is=1e-13 n=1.3 rs=2 tt=5n cjo=3p vj=0.8 m=0.4 fc=0.6 bv=30 ibv=1e-4
.end
"""


@pytest.mark.parametrize("vd,knees", [(-35.0, ""), (-3.0, ""), (0.3, ""), (0.55, ""), (0.75, ""),
                                       (-7.0, "ikf=2m ikr=1m"), (-3.0, "ikf=2m ikr=1m"), (0.3, "ikf=2m ikr=1m"),
                                       (0.62, "ikf=2m ikr=1m"), (0.8, "ikf=2m ikr=1m")])
def test_jacobians_are_derivatives_of_q_and_phi(vd, knees):
    # with the knee currents the breakdown is at 5 V, so that -7 V meets IKR there
    system = assemble(load(CHARGED.replace("bv=30 ibv=1e-4", "bv=5 ibv=1e-4 " + knees) if knees else CHARGED))
    x = np.zeros(system.n)
    names = system.names
    x[names.index("v(b)")] = vd + 0.1
    x[names.index("v(d1#internal)")] = vd + 0.05
    x[names.index("v(c)")] = 0.05
    assert_jacobians_match(system, x)


def test_charge_is_tt_times_current_plus_depletion():
    # q on the junction at vd: TT id(vd) + qdep(vd), area 1.5 scales Is and CJO
    system = assemble(load(CHARGED))
    vd = 0.45
    x = np.zeros(system.n)
    x[system.names.index("v(d1#internal)")] = vd
    ev = system.evaluate(x, 0.0)
    vt = vt_at(27.0)
    i = 1.5e-13 * math.expm1(vd / (1.3 * vt)) + GMIN * vd
    cj0, vj, m = 1.5 * 3e-12, 0.8, 0.4
    qdep = vj * cj0 * (1 - (1 - vd / vj) ** (1 - m)) / (1 - m)
    assert ev.q[system.names.index("v(d1#internal)")] == pytest.approx(5e-9 * i + qdep, rel=1e-13)


def test_first_iteration_starts_at_vcrit_and_is_linearised():
    # MODEINITJCT: from the zero vector the diode is evaluated at vcrit and continued linearly to v = 0
    Is = 1e-14
    system = assemble(load(f"t\nV1 a 0 1\nR1 a b 1k\nD1 b 0 dm\n.model dm d is={Is}\n.end\n"))
    ev = system.evaluate(np.zeros(system.n), 0.0, state=system.initial_state())
    assert ev.limited
    vt = vt_at(27.0)
    vc = vt * math.log(vt / (math.sqrt(2) * Is))
    i, g = Is * math.expm1(vc / vt) + GMIN * vc, Is * math.exp(vc / vt) / vt + GMIN
    assert ev.phi[system.names.index("v(b)")] == pytest.approx(-(i + g * (0.0 - vc)), rel=1e-12)
    assert ev.state[0].v[0, 0] == pytest.approx(vc, rel=1e-15)


def test_limited_step_is_flagged_and_continued_linearly():
    Is = 1e-14
    system = assemble(load(f"t\nV1 a 0 1\nR1 a b 1k\nD1 b 0 dm\n.model dm d is={Is}\n.end\n"))
    fam = system.families[0]
    x = np.zeros(system.n)
    x[system.names.index("v(b)")] = 1.0
    ev = system.evaluate(x, 0.0, state=(LimitState(np.array([[0.6]])),))
    assert ev.limited
    vt = vt_at(27.0)
    vl = 0.6 + vt * (2 + math.log((1.0 - 0.6) / vt - 2))
    assert ev.state[0].v[0, 0] == pytest.approx(vl, rel=1e-14)
    i, g = fam.current(np.array([vl]))
    assert ev.phi[system.names.index("v(b)")] == pytest.approx(-(i[0] + g[0] * (1.0 - vl)) + 1e-3 * (0.0 - 1.0),
                                                                 rel=1e-12)


def test_without_history_the_diode_is_evaluated_at_the_iterate():
    # state None (continuation, first step of a transient): no MODEINITJCT, no limiting
    system = assemble(load("t\nV1 a 0 1\nR1 a b 1k\nD1 b 0 dm\n.model dm d is=1e-14\n.end\n"))
    fam = system.families[0]
    x = np.zeros(system.n)
    ev = system.evaluate(x, 0.0, state=(None,))
    assert not ev.limited and ev.state[0].v[0, 0] == 0.0
    i, _ = fam.current(np.array([0.0]))
    assert ev.phi[system.names.index("v(b)")] == -i[0]


def test_off_diode_starts_at_zero():
    system = assemble(load("t\nV1 a 0 1\nR1 a b 1k\nD1 b 0 dm off\n.model dm d\n.end\n"))
    assert system.families[0].initial_state().v[0, 0] == 0.0


def test_overflow_is_a_failed_evaluation_without_warnings():
    system = assemble(load("t\nV1 a 0 1\nR1 a b 1k\nD1 b 0 dm\n.model dm d\n.end\n"))
    x = np.zeros(system.n)
    x[system.names.index("v(b)")] = 100.0  # exp(100/vt) overflows; no limiting in continuation mode
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ev = system.evaluate(x, 0.0)
    assert not ev.ok


@pytest.mark.parametrize("card,message", [
    (".model dm d is=1e-14 jsw=1e-15", "'jsw' of the diode .* used by ngspice but not implemented"),
    (".model dm d level=3", "diode level 3 .* is not implemented by netdae"),
])
def test_unsupported_or_wrong_models_are_errors(card, message):
    with pytest.raises((CircuitError, NetlistError), match=message):
        assemble(load(f"t\nV1 a 0 1\nD1 a 0 dm\n{card}\n.end\n"))


def test_an_unknown_instance_parameter_names_the_ones_read():
    """A misspelt 'are=2' (ngspice 39: 'unknown parameter (are)') lists the parameters netdae reads."""
    with pytest.raises(CircuitError) as info:
        assemble(load("t\nV1 a 0 1\nD1 a 0 dm are=2\n.model dm d\n.end\n"))
    assert "instance parameter 'are' of the diode" in str(info.value)
    assert info.value.hint == "the diode's instance parameters netdae reads: area, m, off, temp, dtemp, ic"


def test_missing_or_mistyped_model_is_an_error():
    # the netlist reader checks models; a circuit built otherwise is checked by the family
    circuit = load("t\nV1 a 0 1\nD1 a 0 dm\n.model dm d\n.end\n")
    circuit.models["dm"] = Model("dm", "npn")
    with pytest.raises(CircuitError, match="type 'npn'"):
        assemble(circuit)
    circuit.element("d1").model = "dmissing"
    with pytest.raises(CircuitError, match="dmissing"):
        assemble(circuit)


@pytest.mark.parametrize("area,mult", [(1, 1), (2, 1), (1, 3)])
def test_forward_knee_current_closed_form(area, mult):
    """ngspice's high injection: c / (1 + sqrt(c / IKF)) with IKF times area and m; ngspice 39 gives
    v(out) = 0.56424, 0.528155 and 0.507021 V on this card (the closed form's 0.564240, 0.528155,
    0.507021)."""
    text = (f"t\nV1 in 0 0.9\nR1 in out 1k\nD1 out 0 dd area={area} m={mult}\n"
            ".model dd d is=21.91n n=2.233 ikf=19.23m\n.end\n")
    vte = 2.233 * vt_at(27.0)

    def current(v):
        c = 21.91e-9 * area * mult * math.expm1(v / vte)
        return c / (1.0 + math.sqrt(c / (19.23e-3 * area * mult))) + GMIN * v

    v = brentq(lambda v: (0.9 - v) / 1e3 - current(v), 0.0, 0.9, xtol=1e-15)
    assert op(text)["v(out)"] == pytest.approx(v, abs=1e-10)


def test_reverse_knee_current_in_breakdown_closed_form():
    """12 V through 100 ohm into a 6 V zener with IKR = 2 mA: the breakdown current c = -Is exp(-(BV' + vd)
    / vt) becomes c / (1 + sqrt(-c / IKR)); the resistor's current equals it at the solution."""
    text = "t\nV1 n 0 12\nR1 n r 100\nD1 0 r dz\n.model dz d is=1e-14 bv=6 ibv=1u ikr=2m\n.end\n"
    x = op(text)
    vd = -x["v(r)"]  # anode at ground, cathode at r
    i_d = -(12.0 - x["v(r)"]) / 100.0
    assert i_d < -5e-3  # deep in breakdown, beyond IKR
    vt = vt_at(27.0)
    bvp = float(breakdown_voltage(np.array([6.0]), np.array([1e-6]), np.array([1e-14]), np.array([vt]),
                                  np.array([vt]), 1e-3)[0])
    c = -1e-14 * math.exp(-(bvp + vd) / vt)
    assert c / (1.0 + math.sqrt(-c / 2e-3)) + GMIN * vd == pytest.approx(i_d, rel=1e-7)


def test_the_diffusion_charge_follows_the_current_with_the_knee():
    # TT id with id after the knee, as ngspice 39 (tests/test_devices_ngspice.py checks a transient)
    system = assemble(load(CHARGED.replace("bv=30 ibv=1e-4", "bv=30 ibv=1e-4 ikf=1u")))
    vd = 0.6
    x = np.zeros(system.n)
    x[system.names.index("v(d1#internal)")] = vd
    ev = system.evaluate(x, 0.0)
    vt = vt_at(27.0)
    c = 1.5e-13 * math.expm1(vd / (1.3 * vt))
    i = c / (1.0 + math.sqrt(c / 1.5e-6)) + GMIN * vd
    cj0, vj, m = 1.5 * 3e-12, 0.8, 0.4
    qdep = vj * cj0 * (1 - (1 - vd / vj) ** (1 - m)) / (1 - m)
    assert ev.q[system.names.index("v(d1#internal)")] == pytest.approx(5e-9 * i + qdep, rel=1e-12)
