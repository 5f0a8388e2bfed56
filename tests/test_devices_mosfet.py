"""The level-1 MOSFET against closed forms, symmetries and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netdae.analyses.op import operating_point
from netdae.devices.mosfet import drain_current, gate_charges
from netdae.mna import assemble
from netdae.netlist import load

from test_devices_diode import assert_jacobians_match

GMIN = 1e-12
TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}


def op(text: str) -> dict[str, float]:
    r = operating_point(load(text), **TIGHT)
    return {k: float(v[0]) for k, v in r.signals.items()}


def held(model: str, vgs: float, vds: float, vbs: float = 0.0, kind: str = "nmos", geometry: str = "w=10u l=2u"):
    """A transistor with all four terminals held by sources."""
    return op(f"t\nVG g 0 {vgs}\nVD d 0 {vds}\nVB b 0 {vbs}\nM1 d g 0 b mm {geometry}\n"
              f".model mm {kind} {model}\n.end\n")


@pytest.mark.parametrize("vgs,vds,vbs", [(0.5, 1.0, 0.0), (2.0, 3.0, 0.0), (2.0, 0.4, 0.0), (3.0, 2.0, -1.5)])
def test_shichman_hodges_closed_form(vgs, vds, vbs):
    KP, VTO, GAMMA, PHI, LAMBDA = 50e-6, 0.8, 0.5, 0.7, 0.02
    x = held(f"kp={KP} vto={VTO} gamma={GAMMA} phi={PHI} lambda={LAMBDA}", vgs, vds, vbs)
    beta = KP * 10 / 2
    vth = VTO + GAMMA * (math.sqrt(PHI - vbs) - math.sqrt(PHI))
    vgst = vgs - vth
    if vgst <= 0:
        ids = 0.0
    elif vgst <= vds:
        ids = beta / 2 * vgst ** 2 * (1 + LAMBDA * vds)
    else:
        ids = beta * vds * (vgst - vds / 2) * (1 + LAMBDA * vds)
    # the drain source also feeds the reverse-biased bulk-drain diode: GMIN vbd - IS (ngspice, vbd < -3 vt)
    vbd = vbs - vds
    assert vbd < -0.1
    ibd = GMIN * vbd - 1e-14
    assert x["i(vd)"] == pytest.approx(-(ids - ibd), rel=1e-10)


def test_body_effect_clamp_for_forward_bulk_bias():
    # vbs > 0: sarg = sqrt(PHI) - vbs / (2 sqrt(PHI)) (ngspice's linear continuation)
    KP, VTO, GAMMA, PHI = 50e-6, 0.8, 0.5, 0.64
    cd, gm, gds, gmbs, von, dvon = drain_current(np.array([2.0]), np.array([3.0]), np.array([0.2]),
                                                 np.array([KP]), np.array([0.0]),
                                                 np.array([VTO - GAMMA * math.sqrt(PHI)]), np.array([GAMMA]),
                                                 np.array([PHI]))
    sarg = math.sqrt(PHI) - 0.2 / (2 * math.sqrt(PHI))
    assert von[0] == pytest.approx(VTO - GAMMA * math.sqrt(PHI) + GAMMA * sarg, rel=1e-14)
    assert dvon[0] == pytest.approx(-GAMMA / (2 * math.sqrt(PHI)), rel=1e-14)
    assert gmbs[0] == pytest.approx(gm[0] * GAMMA / (2 * math.sqrt(PHI)), rel=1e-14)


def test_drain_current_derivatives_by_finite_differences():
    rng = np.random.default_rng(3)
    vgs = rng.uniform(-1.0, 4.0, 200)
    vds = rng.uniform(0.0, 4.0, 200)
    vbs = rng.uniform(-3.0, 0.5, 200)
    args = (np.full(200, 1e-4), np.full(200, 0.03), np.full(200, 0.4), np.full(200, 0.6), np.full(200, 0.7))
    cd, gm, gds, gmbs, _, _ = drain_current(vgs, vds, vbs, *args)
    h = 1e-7
    for k, g in ((0, gm), (1, gds), (2, gmbs)):
        up = [vgs, vds, vbs]
        dn = [vgs, vds, vbs]
        up[k] = up[k] + h
        dn[k] = dn[k] - h
        fd = (drain_current(*up, *args)[0] - drain_current(*dn, *args)[0]) / (2 * h)
        np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-10)


PAIR = """mos pair
VDD vdd 0 {vdd}
VIN in 0 {vin}
RD vdd d {rd}
M1 d in s b mm w=4u l=1u ad=8p as=8p pd=8u ps=8u
RS s 0 500
VB b 0 {vb}
.model mm {kind} vto={vto} kp=80u gamma=0.45 phi=0.65 lambda=0.05 rd=20 rs=15 cbd=2f cbs=3f cj=0.5m
+ mj=0.45 cjsw=0.3n mjsw=0.25 pb=0.85 cgso=0.2n cgdo=0.25n cgbo=0.1n tox=10n ld=0.05u fc=0.55 is=1e-15
.end
"""


def test_pmos_is_a_mirrored_nmos():
    n = op(PAIR.format(vdd=5, vin=2.0, rd="10k", vb=-1, kind="nmos", vto=0.7))
    p = op(PAIR.format(vdd=-5, vin=-2.0, rd="10k", vb=1, kind="pmos", vto=-0.7))
    for key, value in n.items():
        assert p[key] == pytest.approx(-value, rel=1e-9, abs=1e-15), key


def test_source_and_drain_are_interchangeable():
    # the same transistor with its drain and source cards swapped carries the same current
    base = "t\nVA a 0 {va}\nVG g 0 3\nVC c 0 1\nM1 {n1} g {n2} 0 mm w=10u l=2u\n.model mm nmos vto=0.7 kp=60u gamma=0.3\n.end\n"
    for va in (0.2, 2.5):
        x1 = op(base.format(va=va, n1="a", n2="c"))
        x2 = op(base.format(va=va, n1="c", n2="a"))
        assert x1["i(va)"] == pytest.approx(x2["i(va)"], rel=1e-12)
        assert x1["i(vc)"] == pytest.approx(x2["i(vc)"], rel=1e-12)


@pytest.mark.parametrize("vin,vdd,vb", [(2.0, 5.0, -1.0), (0.3, 5.0, 0.0), (3.0, 0.5, -0.5), (2.0, -1.5, 0.2)])
@pytest.mark.parametrize("kind,vto", [("nmos", 0.7), ("pmos", -0.7)])
def test_jacobians_are_derivatives_of_q_and_phi(vin, vdd, vb, kind, vto):
    s = 1.0 if kind == "nmos" else -1.0
    system = assemble(circuit := load(PAIR.format(vdd=s * vdd, vin=s * vin, rd="10k", vb=s * vb, kind=kind, vto=vto)))
    sol = operating_point(circuit)
    x = np.array([float(sol[name][0]) for name in system.names])
    x += 1e-3 * np.cos(np.arange(system.n))
    assert_jacobians_match(system, x, rtol=2e-6)


# -- intrinsic gate charge -----------------------------------------------------

def test_gate_charges_conserve_charge_and_partition_ward_dutton():
    a = np.array([1.0, 1.0, 0.8, -0.2, -0.5, -1.0])
    b = np.array([-1.0, 1.0, 0.3, -0.2, -0.9, -1.5])
    phi = np.full(6, 0.6)
    qg, qs, qd, qb, *_ = gate_charges(a, b, phi)
    np.testing.assert_allclose(qg + qs + qd + qb, 0.0, atol=1e-15)
    # saturation: channel charge -(2/3) Cox A split 60/40; vds = 0: halves
    assert qs[0] / (qs[0] + qd[0]) == pytest.approx(0.6, rel=1e-14)
    assert qs[1] == pytest.approx(qd[1], rel=1e-14)
    assert qs[0] + qd[0] == pytest.approx(-2 / 3 * 1.0, rel=1e-14)


def test_gate_charge_derivatives_are_meyer_capacitances():
    # strong inversion: d qg / d a, d qg / d b are Meyer's Cgs, Cgd per Cox
    a, b = np.array([1.2, 1.2]), np.array([0.5, -0.3])
    phi = np.full(2, 0.7)
    _, _, _, _, (dga, dgb), _, _ = gate_charges(a, b, phi)
    vdsat, vds = a, a - np.maximum(b, 0.0)
    cgs = np.where(vds < vdsat, 2 / 3 * (1 - (vdsat - vds) ** 2 / (2 * vdsat - vds) ** 2), 2 / 3)
    cgd = np.where(vds < vdsat, 2 / 3 * (1 - vdsat ** 2 / (2 * vdsat - vds) ** 2), 0.0)
    np.testing.assert_allclose(dga, cgs, rtol=1e-14)
    np.testing.assert_allclose(dgb, cgd, rtol=1e-14, atol=1e-16)
    # below threshold (saturated side): the gate capacitance is Meyer's Cgs + Cgb
    a = np.array([-0.1, -0.3, -0.5, -1.0])
    phi = np.full(4, 0.7)
    _, _, _, _, (dga, dgb), _, _ = gate_charges(a, a - 5.0, phi)
    meyer_total = np.where(a <= -0.7, 1.0, np.where(a <= -0.35, -a / 0.7,
                                                    2 / 3 * (1 + 2 * a / 0.7) - a / 0.7))
    np.testing.assert_allclose(dga, meyer_total, rtol=1e-14)
    np.testing.assert_allclose(dgb, 0.0)


def test_gate_charges_are_continuous_and_their_derivatives_exact():
    phi = 0.6
    a = np.linspace(-1.5, 1.5, 3001)
    for offset in (0.0, 0.2, 1.0, 3.0):
        b = a - offset
        qg, qs, qd, qb, dg, ds, dd = gate_charges(a, b, np.full(a.size, phi))
        for q in (qg, qs, qd, qb):
            assert np.max(np.abs(np.diff(q))) < 2.5e-3  # no jumps on a 1 mV grid
        h = 1e-7
        for q_index, (da, db) in ((0, dg), (1, ds), (2, dd)):
            up_a = gate_charges(a + h, b, np.full(a.size, phi))[q_index]
            dn_a = gate_charges(a - h, b, np.full(a.size, phi))[q_index]
            up_b = gate_charges(a, b + h, np.full(a.size, phi))[q_index]
            dn_b = gate_charges(a, b - h, np.full(a.size, phi))[q_index]
            # away from the region boundaries (kinks of the piecewise definition)
            smooth = (np.abs(a) > 2e-6) & (np.abs(b) > 2e-6) & (np.abs(a + phi / 2) > 2e-6) & (np.abs(a + phi) > 2e-6)
            np.testing.assert_allclose(((up_a - dn_a) / (2 * h))[smooth], da[smooth], atol=2e-7)
            np.testing.assert_allclose(((up_b - dn_b) / (2 * h))[smooth], db[smooth], atol=2e-7)


def test_device_charges_sum_to_zero():
    # no terminal grounded, no other capacitor: the charges on the four nodes of the MOSFET cancel
    text = ("t\nVD d 9 {vd}\nVG g 9 {vg}\nVB b 9 {vb}\nR9 9 0 1k\nM1 d g s b mm w=4u l=1u ad=8p as=8p pd=8u ps=8u\n"
            "RS s 9 1k\n.model mm nmos vto=0.7 kp=80u gamma=0.45 tox=10n cgso=0.2n cgdo=0.2n cgbo=0.1n cj=0.5m "
            "cjsw=0.3n\n.end\n")
    for vd, vg, vb in ((2.0, 3.0, -1.0), (-1.0, 1.5, -2.0), (0.5, -1.0, -0.5)):
        system = assemble(circuit := load(text.format(vd=vd, vg=vg, vb=vb)))
        sol = operating_point(circuit)
        x = np.array([float(sol[name][0]) for name in system.names])
        q = system.evaluate(x, 0.0).q
        nodes = [system.names.index(f"v({n})") for n in ("d", "g", "s", "b")]
        assert abs(q[nodes].sum()) < 1e-28


@pytest.mark.parametrize("card, shown", [("l=0", "l = 0 m, model mm's ld = 0 m"),
                                         ("l=1u", "l = 1e-06 m, model mm's ld = 6e-07 m")])
def test_a_channel_without_length_is_refused_at_the_card(card, shown):
    """L - 2 LD <= 0 was an error without file and line (ngspice 39 warns and then does not converge)."""
    from netdae.errors import CircuitError

    ld = " ld=0.6u" if card == "l=1u" else ""
    text = f"t\nV1 a 0 1\nR1 a b 1k\nM1 b a 0 0 mm {card} w=1u\n.model mm nmos{ld}\n.op\n.end\n"
    with pytest.raises(CircuitError) as err:
        assemble(load(text, path="m.cir"))
    assert str(err.value).startswith(f"m.cir:4:1: m1: effective channel length L - 2 LD = ")
    assert f"is not positive ({shown})" in str(err.value) and "give l more than twice ld" in str(err.value)


@pytest.mark.parametrize("phi", ["0", "-1"])
def test_a_surface_potential_that_is_not_positive_is_refused_at_the_value(phi):
    """phi <= 0 was 'm1: model mm: PHI must be positive' without file, line or value."""
    from netdae.errors import NetlistError

    text = f"t\nV1 a 0 1\nR1 a b 1k\nM1 b a 0 0 mm l=1u w=1u\n.model mm nmos phi={phi}\n.op\n.end\n"
    with pytest.raises(NetlistError) as err:
        assemble(load(text, path="m.cir"))
    assert str(err.value).startswith(f"m.cir:5:20: model mm: phi={phi} is impossible for a MOSFET (level 1): "
                                     "phi must be > 0")


def test_a_temperature_beyond_the_surface_potentials_law_is_refused_at_the_element():
    """At 280 degC PHI (0.6 V at 27 degC, ngspice's temperature law) is negative: the run said only 'the circuit
    equations are not finite' (ngspice 39: NaN voltages); it now names the element, PHI and the temperature."""
    import netdae
    from netdae.errors import CircuitError

    text = "t\nV1 a 0 1\nR1 a b 1k\nM1 b a 0 0 mm\n.model mm nmos\n.temp {}\n.op\n.end\n"
    assert netdae.run(netdae.load(text.format(250)))[0].ok  # PHI still positive there
    with pytest.raises(CircuitError) as exc:
        netdae.run(netdae.load(text.format(280)))
    assert str(exc.value).startswith("<string>:4:1: m1: the surface potential PHI at 280 degC is -0.00598")
    assert "PHI = 0.6 V at tnom = 27 degC" in str(exc.value) and "check .temp" in exc.value.hint
