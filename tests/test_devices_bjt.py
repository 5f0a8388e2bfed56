"""The Gummel-Poon BJT against Ebers-Moll closed forms, symmetry and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netdae.analyses.op import operating_point
from netdae.devices.junction import BOLTZMANN, CHARGE, KELVIN
from netdae.mna import assemble
from netdae.netlist import load

from test_devices_diode import assert_jacobians_match

GMIN = 1e-12
TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}
VT27 = BOLTZMANN * (27.0 + KELVIN) / CHARGE


def op(text: str) -> dict[str, float]:
    r = operating_point(load(text), **TIGHT)
    return {k: float(v[0]) for k, v in r.signals.items()}


def biased(model: str, vbe: float, vce: float, kind: str = "npn") -> dict[str, float]:
    """Terminal currents of one transistor with its terminals held by sources."""
    return op(f"t\nVB b 0 {vbe}\nVC c 0 {vce}\nQ1 c b 0 qm\n.model qm {kind} {model}\n.end\n")


@pytest.mark.parametrize("vbe,vce", [(0.65, 5.0), (0.7, 0.1), (0.1, -0.5), (-1.0, 3.0)])
def test_ebers_moll_closed_form(vbe, vce):
    # no Early effect, no high injection, no leakage: the transport form of Ebers-Moll plus GMIN
    IS, BF, BR = 1e-15, 120.0, 3.0
    x = biased(f"is={IS} bf={BF} br={BR}", vbe, vce)
    vbc = vbe - vce

    def junction(v):
        if v >= -3 * VT27:
            return IS * math.expm1(v / VT27)
        return -IS * (1 + (3 * VT27 / (v * math.e)) ** 3)

    cbe, cbc = junction(vbe), junction(vbc)
    ic = cbe - cbc - cbc / BR - GMIN * vbc
    ib = cbe / BF + cbc / BR + GMIN * (vbe + vbc)
    # the source currents flow from + through the source: i(vc) = -ic
    # the substrate (ground) junction carries GMIN (v(s) - v(c)) from substrate to collector
    assert x["i(vc)"] == pytest.approx(-(ic + GMIN * vce), rel=1e-10)
    assert x["i(vb)"] == pytest.approx(-ib, rel=1e-10)


def test_early_effect_and_high_injection_base_charge():
    IS, BF, VAF, VAR, IKF = 1e-15, 100.0, 50.0, 10.0, 5e-3
    vbe, vce = 0.75, 4.0
    x = biased(f"is={IS} bf={BF} vaf={VAF} var={VAR} ikf={IKF}", vbe, vce)
    vbc = vbe - vce
    cbe = IS * math.expm1(vbe / VT27)
    cbc = -IS * (1 + (3 * VT27 / (vbc * math.e)) ** 3)
    q1 = 1 / (1 - vbc / VAF - vbe / VAR)
    qb = q1 * (1 + math.sqrt(1 + 4 * cbe / IKF)) / 2
    ic = (cbe - cbc) / qb - cbc - GMIN * vbc
    # the substrate (ground) junction carries GMIN (v(s) - v(c)) from substrate to collector
    assert x["i(vc)"] == pytest.approx(-(ic + GMIN * vce), rel=1e-10)


def test_beta_temperature_exponent():
    # low injection, vbc = 0, no leakage: ic / ib = BF (T/Tnom)^XTB (GMIN vbe removed from ib)
    IS, BF, XTB, vbe = 1e-15, 100.0, 1.7, 0.65
    x = op(f"t\nVB b 0 {vbe}\nVC c 0 {vbe}\nQ1 c b 0 qm temp=120\n.model qm npn is={IS} bf={BF} xtb={XTB}\n.end\n")
    ic, ib = -x["i(vc)"], -x["i(vb)"] - GMIN * vbe
    assert ic / ib == pytest.approx(BF * ((120 + KELVIN) / (27 + KELVIN)) ** XTB, rel=1e-10)


KITCHEN = """bjt kitchen sink
VCC vcc 0 {vcc}
VB bb 0 {vb}
RB bb b 20k
RC vcc c 2k
RE e 0 200
RS s {vs} 1k
Q1 c b e s qm 1.5 m=2
.model qm {kind} is=2e-15 bf=150 nf=1.02 vaf=60 ikf=20m ise=5e-14 ne=1.6 br=4 nr=1.01 var=15
+ ikr=5m isc=1e-14 nc=1.9 rb=150 rbm=30 irb=1m re=1.5 rc=12 cje=8p vje=0.72 mje=0.35 tf=0.4n
+ xtf=2 vtf=3 itf=50m cjc=3p vjc=0.6 mjc=0.4 xcjc=0.7 tr=20n cjs=2p vjs=0.7 mjs=0.3 fc=0.6 xtb=1.2
.end
"""


def test_pnp_is_a_mirrored_npn():
    n = op(KITCHEN.format(vcc=9, vb=1.5, vs="0", kind="npn"))
    p = op(KITCHEN.format(vcc=-9, vb=-1.5, vs="0", kind="pnp subs=1"))
    for key, value in n.items():
        assert p[key] == pytest.approx(-value, rel=1e-9, abs=1e-15), key


@pytest.mark.parametrize("vb,vcc", [(1.2, 9.0), (3.0, 0.4), (-2.0, 5.0)])
@pytest.mark.parametrize("kind", ["npn", "pnp"])
def test_jacobians_are_derivatives_of_q_and_phi(vb, vcc, kind):
    sign = 1.0 if kind == "npn" else -1.0
    system = assemble(circuit := load(KITCHEN.format(vcc=sign * vcc, vb=sign * vb, vs="0", kind=kind)))
    ckt_op = operating_point(circuit)
    x = np.array([float(ckt_op[name][0]) for name in system.names])
    x += 1e-3 * np.sin(np.arange(system.n))  # off the solution, so every term contributes
    assert_jacobians_match(system, x, rtol=2e-6)


def test_area_scales_currents_and_the_base_collector_saturation_current_twice():
    # ngspice 39: IS(bc) = IS * area * areab. With vbe = vbc = v the collector current is
    # cbe - cbc - cbc/BR = area IS e - area^2 IS e - area^2 IS e / BR (e = exp(v/vt) - 1)
    IS, BR, area, v = 1e-15, 2.0, 3.0, 0.6
    x = op(f"t\nVB b 0 {v}\nQ1 0 b 0 qm {area}\n.model qm npn is={IS} br={BR}\n.end\n")
    e = math.expm1(v / VT27)
    ib = area * IS * e / 100.0 + area * area * IS * e / BR + 2 * GMIN * v
    assert x["i(vb)"] == pytest.approx(-ib, rel=1e-10)


def test_substrate_junction_is_gmin_to_collector():
    x = op("t\nVC c 0 2\nVS s 0 -3\nQ1 c 0 0 s qm\n.model qm npn\n.end\n")
    # vsub = v(s) - v(c) = -5: the substrate carries GMIN vsub from s to c
    assert x["i(vs)"] == pytest.approx(-(GMIN * -5.0), rel=1e-9)


def test_initial_state_and_off():
    system = assemble(load("t\nVC c 0 5\nQ1 c b 0 qm\nQ2 c b 0 qm off\nRB c b 100k\n.model qm npn is=1e-15\n.end\n"))
    state = system.families[0].initial_state()
    vc = VT27 * math.log(VT27 / (math.sqrt(2) * 1e-15))
    assert state.v[:, 0].tolist() == pytest.approx([vc, 0.0, 0.0], rel=1e-14)
    assert state.v[:, 1].tolist() == [0.0, 0.0, 0.0]
