"""Nonlinear devices against ngspice 39 on the same netlists.

Every operating point is solved by both simulators with tight tolerances
(``reltol=1e-9, abstol=1e-15, vntol=1e-12``) and every node voltage and
branch current ngspice reports is compared: within 1e-6 relative or 1e-9
absolute (volts or amperes).
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import NETLISTS
from netdae.analyses.dc import dc_sweep
from netdae.analyses.op import operating_point
from netdae.circuit import DcAnalysis
from netdae.netlist import load

pytestmark = pytest.mark.ngspice

TIGHT = {"reltol": 1e-9, "abstol": 1e-15, "vntol": 1e-12}
REL, ABS = 1e-6, 1e-9

DEVICE_NETLISTS = [
    "halfwave_rectifier.cir", "bridge_rectifier.cir", "cw_doubler.cir", "ce_amplifier.cir", "diff_pair.cir",
    "cmos_inverter.cir", "ring_oscillator.cir", "ring_oscillator_notox.cir", "vanderpol_mu1.cir",
    "vanderpol_mu10.cir", "jfet_amplifier.cir",
]


def op_only(text: str) -> str:
    """The netlist with its analyses replaced by a single ``.op``."""
    out = []
    for line in text.splitlines():
        low = line.strip().lower()
        if low.split()[:1] in ([".tran"], [".dc"], [".ac"], [".op"]):
            continue
        if low == ".end":
            out.append(".op")
        out.append(line)
    return "\n".join(out) + "\n"


def ngspice_op(text: str):
    from netdae.ngspice import run_ngspice

    return run_ngspice(op_only(text), options=TIGHT).result("op")


def assert_op_agrees(text: str) -> float:
    """Compare every signal both simulators report; return the worst relative difference."""
    ours = operating_point(load(text), **TIGHT)
    ref = ngspice_op(text)
    common = [name for name in ref.names() if name in ours.signals]
    assert common, "no signal in common"
    worst = 0.0
    for name in common:
        v_ref, v_ours = float(ref[name][0]), float(ours[name][0])
        assert abs(v_ours - v_ref) <= max(REL * abs(v_ref), ABS), (name, v_ours, v_ref)
        if v_ref:
            worst = max(worst, abs(v_ours - v_ref) / abs(v_ref))
    # every external node and source current of netdae is in ngspice's results
    external = [n for n in ours.signals if "#" not in n]
    assert set(external) <= set(ref.names()), set(external) - set(ref.names())
    return worst


@pytest.mark.parametrize("name", DEVICE_NETLISTS)
def test_operating_point_of_the_example_netlists(name):
    assert_op_agrees((NETLISTS / name).read_text())


DIODES = """diodes: forward, area and m, series resistance, breakdown, temperature
V1 a 0 5
R1 a b 1k
D1 b 0 dmod 2 m=3
V2 c 0 -20
R2 c e 1k
D2 e 0 dz
V3 f 0 3
R3 f g 2.2k
D3 g 0 dmod temp=85
D4 g 0 dhot
I1 0 h 10u
D5 h 0 dz off
.model dmod d is=1e-14 n=1.1 rs=10 cjo=1p tt=1n
.model dz d is=1e-12 n=1.05 bv=5.6 ibv=1e-3 nbv=1.3 eg=1.2 xti=2.5
.model dhot d is=3e-15 n=1.9 rs=0.5 tnom=50 eg=1.05 xti=4
.options temp=45
.end
"""

BJTS = """bipolar transistors: NPN, PNP (lateral, IRB), substrate, temperature
vcc vcc 0 12
r1 vcc b 47k
r2 b 0 10k
rc vcc c 4.7k
re e 0 1k
q1 c b e qn
vee vee 0 -12
q2 c2 b2 e2 qp 2
rc2 c2 vee 3.3k
re2 vcc e2 1k
rb2 b2 mid 10k
r3 vcc mid 20k
r4 mid 0 30k
q3 c3 b3 0 sub qn2 areab=2 areac=3
rb3 vcc b3 100k
rc3 vcc c3 1k
rs sub vee 1k
.model qn npn is=1e-15 bf=150 vaf=80 ikf=0.05 ise=1e-13 ne=1.6 br=3 var=20 ikr=0.01 isc=1e-14 nc=1.8
+ rb=100 rbm=20 re=2 rc=10 cje=5p cjc=2p tf=0.3n
.model qp pnp is=2e-15 bf=80 vaf=50 rb=50 irb=1e-4 rbm=10 re=1 rc=5 xtb=1.5 c2=300
.model qn2 npn is=1e-16 bf=100 cjs=1p nkf=0.6 ikf=1m xti=2 eg=1.2 tnom=35
.options temp=45
.end
"""

MOSFETS = """MOSFETs: both types, reverse mode, body effect, series resistances, temperature, NSUB
vdd vdd 0 5
vin in 0 2.2
m1 out in 0 0 nm w=10u l=2u ad=20p as=20p pd=24u ps=24u
m2 out in vdd vdd pm w=20u l=2u
m3 d3 g3 s3 b3 nm2 w=5u l=1u
vg3 g3 0 3
rd3 vdd d3 10k
rs3 s3 0 2k
vb3 b3 0 -1
m4 d4 d4 vdd vdd pm w=5u l=1u m=2
r4 d4 0 50k
m5 x5 g5 y5 0 nm w=3u l=1u
vg5 g5 0 4
v5 x5 0 1
r5 y5 vdd 1k
m6 d6 d6 0 0 nsub w=4u l=1u
r6 vdd d6 20k
.model nm nmos vto=0.8 kp=50u gamma=0.5 phi=0.7 lambda=0.02 rd=10 rs=10 cbd=1f cj=1e-4 cjsw=1e-10 tox=20n
+ cgso=1e-10
.model pm pmos vto=-0.9 kp=20u gamma=0.4 lambda=0.03 is=1e-15 tox=20n ld=0.1u
.model nm2 nmos vto=1 kp=30u gamma=0.6 phi=0.65 rsh=20 js=1e-4 tnom=40
.model nsub nmos tox=25n nsub=2e16 u0=450 nss=1e10
.options temp=50
.end
"""

JFETS = """JFETs: both types, reverse mode, forward gate, B, area and m, off, series resistances, temperature
vdd vdd 0 12
j1 d1 g1 s1 jn
vg1 g1 0 -0.4
rd1 vdd d1 3.3k
rs1 s1 0 470
j2 d2 g2 s2 jp 2 m=3 temp=70
vg2 g2 0 0.3
rd2 d2 0 1.5k
rs2 vdd s2 820
j3 d3 g3 s3 jn2
v3 d3 0 0.6
vg3 g3 0 0.2
r3 s3 vdd 10k
j4 d4 g4 0 jn off
r4 vdd d4 10k
r4g d4 g4 1meg
j5 d5 d5 s5 jn2 area=0.5 dtemp=-40
r5 vdd d5 5k
r5s s5 0 100
.model jn njf vto=-1.8 beta=1.4m lambda=0.01 rd=15 rs=12 is=2e-14 b=0.75 pb=0.85 tcv=2.2m bex=-1.3
.model jp pjf vto=-2.2 beta=0.9m lambda=0.02 rd=5 is=1e-13 xti=2 eg=1.2 vtotc=1.5m betatce=-0.4 tnom=40
.model jn2 njf vto=-0.9 beta=3m b=1.3 pb=0.7 is=5e-12
.options temp=45
.end
"""

BEHAVIOURAL = """behavioural sources: B, E and G with value=, functions, I(), ternary
V1 a 0 2
R1 a b 1k
B1 b 0 I={1m*tanh(V(b)) + 0.1m*V(a,b)**2 - (V(a) > 1 ? 1m : 0)}
V2 c 0 1
Vs c d 0
R2 d 0 2k
B2 e 0 V={2*I(vs)*1k + exp(V(a)/2) + sqrt(V(a)+1+V(b)*V(b)) + min(V(a),V(b))}
R3 e 0 1k
B3 f 0 V={pwr(V(b)-1, 3) + ln(1+V(a))*sin(2) + atan(V(b)) + V(b)**2.5}
R4 f 0 1k
E1 g 0 value={V(e)*0.5 + I(b3)*100}
R5 g 0 1k
G1 h 0 value={V(g)*1m}
R6 h 0 1k
B4 k 0 I={1m*V(k)*V(k)*V(k) - 2m*V(k) + 0.1m}
R7 k 0 10k
.end
"""


KNEES = """diodes at high injection: IKF (alias IK) forward, IKR in breakdown, scaled by area and m
V1 a 0 0.9
R1 a b 100
D1 b 0 dk area=2 m=3
R2 a c 1k
D2 c 0 dk2
V2 n 0 12
R3 n r 100
D3 0 r dk
.model dk d is=21.91n n=2.233 rs=0.5 ikf=19.23m ikr=2m bv=6 ibv=1u tt=10n cjo=2p
.model dk2 d is=1e-12 n=1.5 ik=1m
.end
"""


@pytest.mark.parametrize("text", [DIODES, BJTS, MOSFETS, JFETS, BEHAVIOURAL, KNEES],
                         ids=["diodes", "bjts", "mosfets", "jfets", "behavioural", "diode knees"])
def test_operating_point_of_device_corner_cases(text):
    assert_op_agrees(text)


def test_dc_transfer_curve_of_the_cmos_inverter():
    from netdae.ngspice import run_ngspice

    text = (NETLISTS / "cmos_inverter.cir").read_text()
    circuit = load(text)
    card = next(a for a in circuit.analyses if isinstance(a, DcAnalysis))
    ours = dc_sweep(circuit, card, **TIGHT)
    only_dc = "\n".join(line for line in text.splitlines()
                         if line.strip().lower().split()[:1] not in ([".tran"], [".op"]))
    ref = run_ngspice(only_dc, options=TIGHT).result("dc")
    v_ref, v_ours = ref["v(out)"], ours["v(out)"]
    assert v_ref.shape == v_ours.shape == (101,)
    np.testing.assert_allclose(v_ours, v_ref, rtol=REL, atol=ABS)
    # the curve swings rail to rail through a high-gain region
    assert v_ref[0] > 4.99 and v_ref[-1] < 0.01 and np.min(np.diff(v_ref)) < -0.5


HARD = """exponential behavioural diodes without junction limiting
* Newton overshoots to exp(400); ngspice 39 needs dynamic gmin stepping here
V1 a 0 10
R1 a b 1k
B1 b 0 I={1e-14*(exp(V(b)/0.025)-1)}
R2 b c 2k
B2 c 0 I={1e-12*(exp(V(c)/0.05)-1)}
.end
"""


def test_homotopy_rescues_what_plain_newton_cannot():
    result = operating_point(load(HARD), **TIGHT)
    assert result.stats["strategy"] != "newton"
    assert_op_agrees(HARD)


def test_dc_sweep_and_transient_of_diodes_with_knee_currents():
    """IKF and IKR through forward conduction, the reverse region and breakdown (``.dc``), and a
    transient through breakdown and forward recovery whose diffusion charge ``TT id`` follows the current
    with the knee (ngspice 39; with the current without it, v(b) was 17 mV off on the plateaus)."""
    from netdae.analyses.tran import transient
    from netdae.ngspice import run_ngspice

    sweep = KNEES.replace(".end", ".dc V1 -9 1.5 0.05\n.end")
    ours = dc_sweep(load(sweep), next(a for a in load(sweep).analyses if isinstance(a, DcAnalysis)), **TIGHT)
    ref = run_ngspice(sweep, options=TIGHT).result("dc")
    for name in ("v(b)", "v(c)", "i(v1)"):
        np.testing.assert_allclose(ours[name], ref[name], rtol=REL, atol=ABS, err_msg=name)
    assert float(np.min(ref["v(b)"])) < -6.0  # D1 was driven into breakdown
    pulse = KNEES.replace("V1 a 0 0.9", "V1 a 0 PULSE(-8 1.2 10n 5n 5n 40n 100n)").replace(
        ".end", ".tran 0.1n 200n\n.end")
    tight = {"reltol": 1e-7, "abstol": 1e-14, "vntol": 1e-10}
    ours = transient(load(pulse), **tight)
    ref = run_ngspice(pulse, options=dict(tight, method="gear")).result("tran")
    t = np.asarray(ref.axes["time"])
    corners = np.array([10, 15, 55, 60, 110, 115, 155, 160]) * 1e-9
    keep = np.min(np.abs(t[:, None] - corners[None, :]), axis=1) > 8e-9  # the recovery's snap included
    for name in ("v(b)", "v(c)"):
        v_ref = np.asarray(ref[name])[keep]
        v_ours = ours.dense(t[keep])[name]
        assert np.max(np.abs(v_ours - v_ref)) < 1e-4 * np.ptp(v_ref), name
