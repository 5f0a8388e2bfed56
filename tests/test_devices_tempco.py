"""Temperature coefficients of diode and BJT model parameters (``1 + c1 dT + c2 dT^2``), against ngspice 39.

The numbers were measured with ngspice 39 (``netdae.ngspice.run_ngspice``, shared library) on the
netlists below, with ``.options reltol=1e-9 abstol=1e-16 vntol=1e-12``; netdae agreed with them to
3e-13 relative when these tests were written. Before, every one of these parameters was refused
("used by ngspice but not implemented by netdae").
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.analyses.ac import ac_analysis
from netdae.analyses.op import operating_point
from netdae.circuit import Circuit
from netdae.errors import CircuitError
from netdae.netlist import load

TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}

OP_NETLIST = """diode and bjt temperature coefficients
.options tnom=20
.temp 100
I1 0 a 100m
D1 a 0 dr
V3 c 0 -8
R3 c k 1k
D3 k 0 dz0
R4 c k4 1k
D4 k4 0 dz1
VCC vcc 0 5
IB1 0 b1 20u
Q1 vcc b1 e1 q1
RE1 e1 0 100
VB2 b2 0 0.8
RB2 b2 bb2 1k
Q2 c2 bb2 0 q2
RC2 vcc c2 1k
.model dr d is=1e-14 rs=2 trs1=4e-3 trs2=2e-5
.model dz0 d is=1e-14 bv=5 ibv=1m tcv=2e-3 nbv=1.2
.model dz1 d is=1e-14 bv=5 ibv=1m tcv=2e-3 tlev=1
.model q1 npn is=1e-15 bf=120 br=3 vaf=60 var=20 ikf=20m ikr=5m rb=200 rbm=20 irb=100u re=2 rc=10
+ trb1=3e-3 trb2=1e-5 trm1=1e-3 tirb1=2e-3 tre1=1e-3 tre2=1e-6 trc1=4e-3 tikf1=-2e-3 tikr1=1e-3
+ tvaf1=1e-3 tvar2=1e-6 tbf1=5e-3 tbf2=-1e-5 tbr1=1e-3 xtb=1.5
.model q2 npn is=1e-16 bf=80 ise=1e-14 ne=1.6 isc=1e-13 nc=1.8 nf=1.01 nr=1.02 rb=50 trb=2e-3 trc=1e-3 rc=5
+ tre=1e-3 re=1 tnf1=1e-4 tnf2=1e-7 tne1=5e-4 tnc1=3e-4 tnr1=1e-4 xtb=2 tlev=1
.end
"""

#: ngspice 39's operating point of OP_NETLIST.
NGSPICE_OP = {
    "v(a)": 0.9259384832844194,  # trs1, trs2: the series resistance at 100 C
    "v(k)": -4.88385873644069,  # tcv, tlev=0: BV - TCV dT
    "v(k4)": -4.242566424668971,  # tcv, tlev=1: BV (1 - TCV dT)
    "v(b1)": 0.8966980237272205,  # the resistances', beta's, IKF's, VAF's ... coefficients
    "v(e1)": 0.28656410580783737,
    "v(bb2)": 0.7433095738600026,  # the emission coefficients', tlev=1's beta
    "v(c2)": 0.040119832579782785,
    "i(vcc)": -0.007805521230461132,
}

AC_NETLIST = """charge temperature coefficients
.temp 100
VCC vcc 0 5
V1 in 0 DC 0.75 AC 1
RB in b 2k
Q1 c b 0 s qs
RC vcc c 1k
V5 in5 0 DC -3 AC 1
R5 in5 e 10k
D5 e 0 dc1
I6 0 f 1m AC 1m
D6 f 0 dt1
.model qs npn is=1e-16 bf=100 tf=0.5n tr=20n cje=2p cjc=1p mje=0.35 mjc=0.4 xtf=2 vtf=3 itf=10m cjs=1p mjs=0.3
+ ttf1=2e-3 ttf2=1e-5 ttr1=-1e-3 titf1=2e-3 tmje1=1e-3 tmjc1=2e-3 tmjs1=1e-3 tmje2=1e-6
.model dc1 d is=1e-14 cjo=20p vj=0.8 m=0.4 tm1=2e-3 tm2=1e-5
.model dt1 d is=1e-14 tt=50n ttt1=5e-3 ttt2=1e-5
.ac dec 1 1e6 1e9
.end
"""

#: ngspice 39's AC solution of AC_NETLIST at 1 MHz, 10 MHz, 100 MHz, 1 GHz.
NGSPICE_AC = {
    "v(c)": [-24.103441812225295 + 12.232043805971468j, -1.0253678542831475 + 5.791340475163951j,
             0.1055814670195952 + 0.5785914454039692j, 0.02468526754623496 + 0.011081071949208226j],
    "v(e)": [0.7307044534100852 - 0.4435937870041468j, 0.026417123193008752 - 0.16037224987823087j,
             0.00027126562896402965 - 0.01646790943652333j, 2.713384977249235e-06 - 0.0016472333130596677j],
    "v(f)": [0.026829132559023822 - 0.011954228275262286j, 0.0015419990274242084 - 0.006870668790169828j,
             1.6188537871641213e-05 - 0.0007213109731914827j, 1.6196610422794016e-07 - 7.216706610011127e-05j],
}


def test_operating_point_matches_ngspice():
    r = operating_point(load(OP_NETLIST), **TIGHT)
    for name, expected in NGSPICE_OP.items():
        assert float(r.signals[name][0]) == pytest.approx(expected, rel=1e-9), name


def test_series_resistance_closed_form():
    """The drop across RS is I RS (1 + TRS1 dT + TRS2 dT^2), dT = 80 K (TRS is ngspice's name of TRS1)."""
    for card in ("trs1=4e-3 trs2=2e-5", "trs=4e-3 trs2=2e-5"):
        text = OP_NETLIST.replace("trs1=4e-3 trs2=2e-5", card)
        r = operating_point(load(text), **TIGHT)
        drop = float(r.signals["v(a)"][0] - r.signals["v(d1#internal)"][0])
        assert drop == pytest.approx(0.1 * 2 * (1 + 4e-3 * 80 + 2e-5 * 80**2), rel=1e-9)


def test_charge_coefficients_match_ngspice_ac():
    """TTF, TTR, TITF, TMJE, TMJC, TMJS of the BJT, TM1/TM2 and TTT1/TTT2 of the diode."""
    circuit: Circuit = load(AC_NETLIST)
    r = ac_analysis(circuit, circuit.analyses[0], **TIGHT)
    for name, expected in NGSPICE_AC.items():
        np.testing.assert_allclose(np.asarray(r.signals[name]), expected, rtol=1e-9, err_msg=name)


@pytest.mark.parametrize("model, message", [
    (".model dm d is=1e-14 tlev=2", "tlev=2; netdae implements tlev=0 and tlev=1"),
    (".model dm npn is=1e-16 tlev=3", "tlev=3; netdae implements tlev=0 and tlev=1"),
])
def test_other_equation_selectors_are_refused(model, message):
    element = "D1 a 0 dm" if " d " in model else "Q1 a a 0 dm"
    text = f"t\nV1 a 0 0.7\n{element}\n{model}\n.end\n"
    with pytest.raises(CircuitError, match=message) as err:
        operating_point(load(text, path="t.cir"))
    assert str(err.value).startswith("t.cir:4:")  # at the model's tlev=, not without a place


@pytest.mark.parametrize("model, element, message", [
    (".model qm npn ptf=10", "Q1 b a 0 qm", r"t\.cir:4:19: q1: model qm: excess phase \(PTF\) is not supported"),
    (".model mm nmos nsub=1e5 tox=1e-8", "M1 b a 0 0 mm",
     r"t\.cir:4:21: m1: model mm: nsub=100000 cm\^-3 is below the intrinsic density of silicon"),
])
def test_model_values_netdae_refuses_are_located_at_the_value(model, element, message):
    """Refusals made where the device family reads its model were without file and line."""
    text = f"t\nV1 a 0 1\n{element}\n{model}\nR1 a b 1k\n.op\n.end\n"
    with pytest.raises(CircuitError, match=message):
        operating_point(load(text, path="t.cir"))
