"""ngspice's MESA MESFET (levels 2, 3, 4) against ngspice 39, finite differences and its own equations.

ngspice's numbers come from ``ngspice -b`` on the same netlist (``@z1[...]`` after ``.op``: its drain
current ``cd``, ``gm``, ``gds``, and the gate capacitances it prints as ``qgs``, ``qgd`` after an
operating point) or through :func:`netdae.compare` (``.dc`` sweeps, transients); tolerances are relative
to each quantity's scale.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

import netdae
from netdae.devices.mesa import MesaFamily
from netdae.errors import CircuitError, NetlistError
from netdae.mna import assemble
from netdae.netlist import load

from test_devices_diode import assert_jacobians_match

#: A model that exercises most of level 2: series and intrinsic resistances, RI and RF (the gate
#: charges' internal nodes), ALPHA, THETA, TC, AG, the gate diodes' emission coefficient and the
#: temperature coefficients.
MODEL = ("nmf level=2 vto=0.1 rd=20 rs=15 rg=5 ri=10 rf=12 rdi=3 rsi=4 n=1.3 vs=1.7e5 mu=0.25 d=1e-7 m=2.2 "
         "mc=2.5 alpha=0.3 theta=0.02 tc=0.05 lambda=0.1 sigma0=0.03 vsigmat=0.5 ag=0.01 tvto=1e-3 xtm0=0.5 "
         "phib1=1e-3 xchi=0.02 rtc1=2e-3 teta0=500 tlambda=900")
#: Levels 3 and 4 (ngspice's ``mesa2``, ``mesa3``): the same resistances and temperature coefficients, and
#: each level's own parameters (level 3: the delta-doped layers, the card's BETA, TC; level 4: NMAX,
#: GAMMA, EPSI, CAS, CBS).
MODEL3 = ("nmf level=3 vto=-0.6 rd=20 rs=15 rg=5 ri=10 rf=12 rdi=3 rsi=4 n=1.3 mu=0.25 m=2.2 mc=2.5 tc=0.05 "
          "lambda=0.1 sigma0=0.03 vsigmat=0.5 ag=0.01 tvto=1e-3 xtm0=0.5 beta=0.01 du=0.03u th=0.012u ndelta=5e24 "
          "ndu=2e22 eta=1.5 phib1=1e-3 xchi=0.02 rtc1=2e-3 teta0=500 tlambda=900")
MODEL4 = ("nmf level=4 vto=-0.5 rd=20 rs=15 rg=5 ri=10 rf=12 rdi=3 rsi=4 n=1.3 mu=0.3 m=2.2 mc=2.5 lambda=0.1 "
          "sigma0=0.03 vsigmat=0.5 ag=0.01 nmax=3e16 gamma=2.5 eta=1.4 epsi=1.1e-10 cas=1.2 cbs=0.9 d=0.1u xtm0=0.5 "
          "tvto=1e-3 teta0=500 tlambda=900")
LEVEL_MODELS = {3: MODEL3, 4: MODEL4}
#: Normal-mode biases of levels 3 and 4: above threshold, near it, in saturation and in the linear region.
LEVEL_BIASES = [(0.3, 1.0), (0.6, 0.2), (0.05, 1.5), (-0.2, 0.8), (0.5, 0.3), (-0.45, 0.6)]
BIASES = [(0.3, 1.0), (0.6, 0.2), (0.05, 1.5), (0.4, -0.6), (-0.2, 0.8), (0.5, 0.3)]
TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}
QUANTITIES = ("cd", "gm", "gds", "qgs", "qgd")

ngspice = pytest.mark.skipif(shutil.which("ngspice") is None, reason="ngspice is not installed")


def held(vgs: float, vds: float, model: str = MODEL, inst: str = "l=0.8u w=15u", extra: str = "") -> str:
    return (f"mesa held\nVD d 0 {vds}\nVG g 0 {vgs}\nZ1 d g 0 zm {inst}\n.model zm {model}\n{extra}"
            ".op\n.end\n")


def ngspice_op(text: str, names, digits: int | None = None) -> dict[str, float]:
    """ngspice 39's values of ``@z1[name]`` at the operating point of ``text`` (solved tightly, as netdae's).

    ``digits``: print that many (ngspice's ``numdgt``; default its 7).
    """
    digits = f"set numdgt={digits}\n" if digits else ""
    deck = text.replace(".op\n", ".options reltol=1e-9 abstol=1e-15 vntol=1e-12\n.op\n.control\n" + digits
                        + "run\nprint " + " ".join(f"@z1[{n}]" for n in names) + "\n.endc\n")
    out = subprocess.run(["ngspice", "-b"], input=deck, capture_output=True, text=True, timeout=60).stdout
    values = {}
    for n in names:
        m = re.search(rf"@z1\[{n}\] = (\S+)", out)
        assert m, out
        values[n] = float(m.group(1))
    return values


def netdae_op(text: str, names) -> dict[str, float]:
    spelled = {"qgs": "cgs", "qgd": "cgdq"}  # ngspice prints the capacitances as qgs, qgd after .op
    r = netdae.run(text, save=[f"@z1[{spelled.get(n, n)}]" for n in names], **TIGHT)[0]
    return {n: float(r[f"@z1[{spelled.get(n, n)}]"][0]) for n in names}


@ngspice
@pytest.mark.parametrize("vgs,vds", [b for b in BIASES if b[1] >= 0.0])
@pytest.mark.parametrize("temp", [27.0, 80.0])
def test_operating_point_quantities_agree_with_ngspice(vgs, vds, temp):
    # the normal mode: ngspice's gm and gds are the derivatives of its current there
    text = held(vgs, vds, extra=f".options temp={temp}\n")
    ours, theirs = netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES)
    for n in QUANTITIES:
        assert ours[n] == pytest.approx(theirs[n], rel=2e-6, abs=1e-15 if n.startswith("q") else 1e-12), n


@ngspice
@pytest.mark.parametrize("inst", ["l=0.8u w=15u ts=60 td=75", "l=0.8u w=15u dtemp=30", "l=2u w=40u"])
def test_instance_temperatures_and_sizes_agree_with_ngspice(inst):
    text = held(0.35, 0.9, inst=inst)
    ours, theirs = netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES)
    for n in QUANTITIES:
        assert ours[n] == pytest.approx(theirs[n], rel=2e-6), n


@ngspice
def test_multiplier_scales_everything():
    text = held(0.4, 1.0, inst="l=0.8u w=15u m=3")
    ours, theirs = netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES)
    single = netdae_op(held(0.4, 1.0), QUANTITIES)
    for n in QUANTITIES:
        assert ours[n] == pytest.approx(theirs[n], rel=2e-6), n
    # three in parallel carry three times the current (the series resistances are m-scaled too, so
    # each sees the same internal bias)
    assert ours["cd"] == pytest.approx(3 * single["cd"], rel=1e-9)


@ngspice
def test_output_and_transfer_sweeps_agree_with_ngspice():
    from netdae.comparison import compare

    text = f"""MESA output characteristics, both modes
VD d 0 0
VG g 0 0
Z1 d g 0 zm l=0.8u w=15u
.model zm {MODEL}
.options temp=45
.dc VD -1 2 0.05 VG -0.3 0.7 0.25
.end
"""
    c = compare(text, tight=True, tol={"dc": 1e-5})
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("dc")
    assert a.error is None and a.signals and a.points >= 5 * 61
    # the terminal currents to 1e-6 of their range; the internal nodes to the Newton tolerance (vntol 1 uV)
    currents = max(s.max_rel for s in a.signals if s.name.startswith("i("))
    assert currents <= 1e-6, currents
    assert all(s.max_abs <= 2e-6 for s in a.signals if s.name.startswith("v(")), a.worst.name


@ngspice
@pytest.mark.parametrize("level", [3, 4])
@pytest.mark.parametrize("vgs,vds", LEVEL_BIASES)
@pytest.mark.parametrize("temp", [27.0, 80.0])
def test_levels_3_and_4_operating_points_agree_with_ngspice(level, vgs, vds, temp):
    # ngspice's gm and gds are the derivatives of its current in the normal mode at both levels (level 4:
    # while RSI has no temperature coefficient, below)
    text = held(vgs, vds, model=LEVEL_MODELS[level], extra=f".options temp={temp}\n")
    ours, theirs = netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES)
    for n in QUANTITIES:
        assert ours[n] == pytest.approx(theirs[n], rel=2e-6, abs=1e-15 if n.startswith("q") else 1e-12), n


@ngspice
@pytest.mark.parametrize("vgs", [0.1, 0.15, 0.16, 0.2])
def test_level_3_doped_layer_branches_agree_with_ngspice(vgs):
    # a thin delta layer (vpod 0.458 V, vpo 0.471 V, VTO -0.3, SIGMA0 0): vgt 0.40 below vpod; 0.45 below
    # vpod with vgte past it (ngspice's nsa = NDELTA (TH - DU) < 0: the channel is off); 0.46 past vpod with
    # vgte below vpo; 0.50 past both
    model = "nmf level=3 vto=-0.3 th=2e-9 du=3e-8 ndelta=5e24 ndu=2e22 sigma0=0"
    text = held(vgs, 1.0, model=model)
    ours, theirs = netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES)
    for n in QUANTITIES:
        assert ours[n] == pytest.approx(theirs[n], rel=2e-6, abs=1e-15 if n.startswith("q") else 1e-12), n


@ngspice
def test_level_4_reads_rsi_with_and_without_its_temperature_coefficients():
    # ngspice's mesa3 writes the card's RSI under the square root of the saturation current and the
    # temperature-scaled RSI beside it: the current follows both; its gm differentiates as if the two were
    # one, so at 120 degC (RTC1 5e-3) ngspice's gm is not the derivative of its own current, netdae's is
    model = "nmf level=4 vto=-0.5 rsi=40 rtc1=5e-3 mu=0.3 nmax=3e16 ggr=0"
    text = held(0.3, 1.0, model=model, extra=".options temp=120\n")
    ours, theirs = netdae_op(text, ("cd", "gds")), ngspice_op(text, ("cd", "gds"))
    assert ours["cd"] == pytest.approx(theirs["cd"], rel=2e-6)
    h = 1e-5
    up = ngspice_op(held(0.3 + h, 1.0, model=model, extra=".options temp=120\n"), ("cd",), digits=15)["cd"]
    down = ngspice_op(held(0.3 - h, 1.0, model=model, extra=".options temp=120\n"), ("cd",), digits=15)["cd"]
    slope = (up - down) / (2 * h)  # ngspice's own current's slope (GGR=0: the gate diode's share is 1e-12)
    gm = netdae_op(text, ("gm",))["gm"]
    assert gm == pytest.approx(slope, rel=1e-6)
    assert abs(ngspice_op(text, ("gm",), digits=15)["gm"] / slope - 1.0) > 1e-3  # measured: 6e-3 low


@ngspice
@pytest.mark.parametrize("level", [3, 4])
def test_levels_3_and_4_output_and_transfer_sweeps_agree_with_ngspice(level):
    from netdae.comparison import compare

    sweeps = ((".dc VD -1 2 0.05 VG -0.5 0.7 0.3", 5 * 61), (".dc VG -1.2 0.7 0.02 VD 0.1 1.6 0.5", 4 * 96))
    for sweep, points in sweeps:
        text = f"""MESA level {level} output and transfer characteristics
VD d 0 0
VG g 0 0
Z1 d g 0 zm l=0.8u w=15u
.model zm {LEVEL_MODELS[level]}
.options temp=45
{sweep}
.end
"""
        c = compare(text, tight=True, tol={"dc": 1e-5})
        assert c.ngspice_error is None, c.ngspice_error
        a = c.analysis("dc")
        assert a.error is None and a.signals and a.points >= points
        currents = max(s.max_rel for s in a.signals if s.name.startswith("i("))
        assert currents <= 1e-6, (sweep, currents)
        assert all(s.max_abs <= 2e-6 for s in a.signals if s.name.startswith("v(")), a.worst.name


def _without_series_resistances(model: str) -> str:
    """``model`` without RD, RS, RG, RI, RF and AG (which ngspice's small-signal matrix leaves out), GGR=0."""
    return re.sub(r" (rd|rs|rg|ri|rf|ag)=\S+", "", model) + " ggr=0"


ADMITTANCES = """MESA level {level}: the gate's admittances with drain and source held
VD d 0 1.2
VG g 0 dc 0.2 ac 1
Z1 d g 0 zm l=0.8u w=15u
.model zm {model}
.ac dec 4 1e6 1e12
.end
"""


@ngspice
def test_level_3_admittances_agree_with_ngspice():
    # drain and source held and no RD, RS, RI, RF: vds'' does not move, so netdae's charges have exactly
    # ngspice's capacitances (no transcapacitance enters); GGR=0 leaves ngspice's ggs its derivative
    from netdae.comparison import compare

    c = compare(ADMITTANCES.format(level=3, model=_without_series_resistances(MODEL3)), tight=True,
                tol={"ac": 1e-5})
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("ac")
    assert a.error is None and {s.name for s in a.signals} >= {"i(vd)", "i(vg)"}
    assert max(s.max_rel for s in a.signals) <= 1e-5, a.worst.name


@ngspice
def test_level_4_admittances_agree_with_ngspice_at_the_gate():
    # ngspice's level-4 .ac loads gm = gds = 0: mesaacl.c rebuilds them from fields that only mesa1 and
    # mesa2 (levels 2, 3) set; the gate's admittance, which has no gm, agrees, and netdae's drain
    # current is gm (ngspice's own @z1[gm]) at low frequency
    from netdae.comparison import compare

    text = ADMITTANCES.format(level=4, model=_without_series_resistances(MODEL4))
    c = compare(text, tight=True, tol={"ac": 1e-5}, signals=["i(vg)"])
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("ac")
    assert a.error is None and [s.name for s in a.signals] == ["i(vg)"]
    assert a.signals[0].max_rel <= 1e-5
    ours = netdae.run(text.replace(".ac dec 4 1e6 1e12", ".ac lin 1 1e3 1e3"), **TIGHT)[0]
    gm = ngspice_op(text.replace(".ac dec 4 1e6 1e12", ".op"), ("gm",))["gm"]
    assert -complex(ours["i(vd)"][0]) == pytest.approx(gm, rel=2e-6)


GATE_STEP = """MESA level {level}: the gate driven through a resistor, the drain held
VD d 0 1.2
VG g 0 pulse(-0.6 0.5 20p 30p 30p 100p 300p)
RG g gi 2k
Z1 d gi 0 zm l=0.8u w=15u
.model zm {model}
.tran 1p 300p
.end
"""


@ngspice
@pytest.mark.parametrize("level", [3, 4])
def test_levels_3_and_4_gate_transient_agrees_with_ngspice(level):
    # vds'' held (no RD, RS, RI, RF): netdae's charge and ngspice's C(v) dv/dt carry the same current
    from netdae.comparison import compare

    c = compare(GATE_STEP.format(level=level, model=_without_series_resistances(LEVEL_MODELS[level])), tight=True,
                tol={"tran": 1e-3})
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("tran")
    assert a.error is None and {s.name for s in a.signals} >= {"i(vd)", "i(vg)", "v(gi)"}
    assert max(s.max_rel for s in a.signals) <= 5e-4, a.worst.name


@ngspice
def test_pmf_levels_3_and_4_run_as_nmf_as_in_ngspice():
    for model in (MODEL3, MODEL4):
        pmf = model.replace("nmf", "pmf")
        circuit = load(held(0.3, 1.0, model=pmf))
        assert any("supports the nmf type only" in d.message for d in circuit.diagnostics)
        ours, theirs = netdae_op(held(0.3, 1.0, model=pmf), ("cd",)), ngspice_op(held(0.3, 1.0, model=pmf), ("cd",))
        assert ours["cd"] == pytest.approx(theirs["cd"], rel=2e-6)
        assert ours["cd"] == netdae_op(held(0.3, 1.0, model=model), ("cd",))["cd"] > 0.0


@pytest.mark.parametrize("model", [MODEL, MODEL3, MODEL4])
@pytest.mark.parametrize("vgs,vds", BIASES)
def test_jacobians_are_the_derivatives_of_q_and_phi(model, vgs, vds):
    circuit = load(held(vgs, vds, model=model))
    system = assemble(circuit)
    from netdae.analyses.op import operating_point

    r = operating_point(circuit, **TIGHT)
    x = np.array([float(r[name][0]) if name in r.signals else 0.0 for name in system.names])
    # every unknown is saved by .op; perturb off the solution so that every branch carries current
    x = x + 1e-3 * np.sin(np.arange(x.size) + 1.0)
    assert_jacobians_match(system, x, rtol=2e-6)


def _family(text: str) -> MesaFamily:
    system = assemble(load(text))
    return next(f for f in system.families if isinstance(f, MesaFamily))


@pytest.mark.parametrize("model", [MODEL, MODEL3, MODEL4])
@pytest.mark.parametrize("vgs,vds", BIASES)
def test_gate_charges_have_ngspice_capacitances_along_the_gate(model, vgs, vds):
    # the charge form: moving the gate alone, d qgs/d vgs'' is ngspice's cgs, d qgd/d vgd'' its cgd
    fam = _family(held(vgs, vds, model=model))
    vgs_a, vgd_a = np.array([vgs]), np.array([vgs - vds])
    r = fam.dc(vgs_a, vgd_a)
    h = 1e-6
    q_up = fam.charges(vgs_a + h, vgd_a + h, vgs_a + h, vgd_a + h)
    q_dn = fam.charges(vgs_a - h, vgd_a - h, vgs_a - h, vgd_a - h)
    total_up, total_dn = q_up[0] + q_up[1], q_dn[0] + q_dn[1]
    assert (total_up - total_dn)[0] / (2 * h) == pytest.approx((r["cgs"] + r["cgd"])[0], rel=1e-5)
    _, _, dqs, dqd = fam.charges(vgs_a, vgd_a, vgs_a, vgd_a)
    gate_s = dqs[0] + dqs[1] + dqs[2]  # the gate alone: vgs'', vgs and vgd move together
    gate_d = dqd[0] + dqd[1] + dqd[2]
    assert gate_s[0] == pytest.approx(r["cgs"][0], rel=1e-6)
    assert gate_d[0] == pytest.approx(r["cgd"][0], rel=1e-6)


@pytest.mark.parametrize("model", [MODEL, MODEL3, MODEL4])
def test_current_is_odd_under_exchanging_drain_and_source(model):
    fam = _family(held(0.3, 1.0, model=model.replace(" ag=0.01", "")))
    vgs, vds = np.array([0.45, 0.1, 0.3]), np.array([0.7, 0.05, 1.2])
    fwd = fam.dc(vgs, vgs - vds)["cdrain"]
    rev = fam.dc(vgs - vds, vgs)["cdrain"]  # source and drain exchanged: vgs' = vgd, vgd' = vgs
    np.testing.assert_allclose(rev, -fwd, rtol=1e-14)


CHAIN = """MESA inverters with ungated loads, a chain of three driven by a pulse
.subckt inv vdd in out
rdl vdd 1 20
bl 1 2 i=0.00025*tanh(v(1,2)/0.00025/2240)*(1+v(1,2)*0.027)
rsl 2 out 20
zd out in 0 driver l=0.7u w=20u
ci out 0 20f
.ends inv
.model driver nmf level=2 n=1.44 rd=20 rs=20 ri=5 rf=5 vs=1.9e5 mu=0.25 d=1e-7 vto=0.15 m=2 lambda=0.15
+ sigma0=0.02 vsigmat=0.5
vdd 1 0 1.6
vin 2 0 pulse(0.1 0.6 50p 40p 40p 300p 800p)
x1 1 2 3 inv
x2 1 3 4 inv
x3 1 4 5 inv
.tran 2p 800p
.end
"""


@ngspice
def test_inverter_chain_transient_agrees_with_ngspice():
    from netdae.comparison import compare

    c = compare(CHAIN, tight=True, tol={"tran": 1e-2}, signals=["v(3)", "v(4)", "v(5)"])
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("tran")
    assert a.error is None and len(a.signals) == 3
    worst = max(s.max_rel for s in a.signals)
    assert worst <= 1e-2, (a.worst.name, worst)
    # the stages switch: each output swings over most of its logic levels
    assert min(s.scale for s in a.signals) > 0.3


@ngspice
@pytest.mark.parametrize("level, tol", [(3, 5e-2), (4, 2.5e-2)])
def test_levels_3_and_4_inverter_chains_agree_with_ngspice(level, tol):
    # the chain's drains swing: netdae's charges then carry their transcapacitances, which ngspice's
    # C(v) dv/dt has not (measured: 3.0e-2 of the swing at level 3, 1.2e-2 at level 4, 0.8e-2 at level 2,
    # on the edges); the gate-driven transients above, where vds'' is held, agree to 5e-4
    from netdae.comparison import compare

    text = CHAIN.replace("level=2", f"level={level}").replace(" vs=1.9e5", "").replace(" d=1e-7", "")
    c = compare(text, tight=True, tol={"tran": tol}, signals=["v(3)", "v(4)", "v(5)"])
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("tran")
    assert a.error is None and len(a.signals) == 3
    worst = max(s.max_rel for s in a.signals)
    assert worst <= tol, (a.worst.name, worst)
    assert min(s.scale for s in a.signals) > 0.3


@pytest.mark.parametrize("text, pattern, column_text", [
    (held(0.2, 1.0, model="nmf level=9"), r"MESFET level 9 .*is not implemented by netdae \(expected: a MESFET "
     r"model of level 1, 2, 3, 4", "9"),
    (held(0.2, 1.0, model="nmf vto=0.1 level=7"), r"MESFET level 7 .*hint: .*level 2, 3, 4 \(MESA\)", "7"),
    (held(0.2, 1.0, model="nmf level=2 vcrit=0.5"), r"'vcrit' is an output", "0.5"),
    (held(0.2, 1.0, inst="2 l=1u"), r"an area \(2\) on the card of a MESA model", "Z1"),
    (held(0.2, 1.0, inst="temp=50"), r"'temp' is not an instance parameter of ngspice's MESA", "Z1"),
    (held(0.2, 1.0, model="nmf level=2 rd=-5"), r"rd=-5 is impossible", "-5"),
])
def test_bad_cards_are_located_errors(text, pattern, column_text):
    with pytest.raises(NetlistError, match=pattern) as err:
        assemble(load(text))
    line = text.splitlines()[err.value.location.line - 1]
    assert line[err.value.location.column - 1:].startswith(column_text)


def test_instance_errors_and_unsupported_parameters():
    with pytest.raises(CircuitError, match="KS=0.2 .*not implemented"):
        assemble(load(held(0.2, 1.0, model="nmf level=2 ks=0.2")))
    with pytest.raises(CircuitError, match="w = 0 must be positive"):
        assemble(load(held(0.2, 1.0, inst="w=0")))


def test_warnings_pmf_and_unknown_parameters():
    circuit = load(held(0.2, 1.0, model="pmf level=2 vto=0.1 cgs=1p"))
    text = " | ".join(d.message for d in circuit.diagnostics if d.severity == "warning")
    assert "supports the nmf type only" in text
    assert "parameter 'cgs' is not a parameter of ngspice's mesfet model" in text
    # pmf runs as nmf: the same currents as the nmf card
    a = netdae_op(held(0.3, 1.0, model="pmf level=2 vto=0.1"), ("cd",))
    b = netdae_op(held(0.3, 1.0, model="nmf level=2 vto=0.1"), ("cd",))
    assert a["cd"] == b["cd"] > 0.0


# --- the compiled kernel ----------------------------------------------------------------------

def mesa_case(text):
    from test_device_kernels import Case, diode_state

    from netdae.devices.kernels.mesa import eval_mesa
    return Case(text, MesaFamily, eval_mesa, diode_state)


KERNEL_DECK = f"""MESA devices of levels 2, 3 and 4, with and without the series and gate resistances
Z1 1 2 3 zm l=0.8u w=15u
Z2 3 2 0 zp l=1.2u w=10u m=2
Z3 4 1 2 zm l=0.8u w=15u off
Z4 1 4 3 z3 l=0.8u w=15u
Z5 4 3 0 z4 l=0.8u w=15u
Z6 2 1 4 z3b l=1u w=12u
.model zm {MODEL}
.model zp nmf level=2 vto=-0.3 lambda=0.05
.model z3 {MODEL3}
.model z4 {MODEL4}
.model z3b nmf level=3
.end
"""


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_the_family(seed, monkeypatch):
    import test_device_kernels
    from test_device_kernels import exercise, scales

    # the charges' quadrature sums 96 terms, pairwise in numpy and in order in the kernel: rounding of
    # the sum, not a few ulps of each entry
    monkeypatch.setattr(test_device_kernels, "SPREAD", 1e-12)
    case = mesa_case(KERNEL_DECK)
    rng = np.random.default_rng(seed)
    exercise(case, rng, scales(0.3, 1.0, 2.0), scales(0.2, 0.8), draws=4)


def test_kernel_jacobians_match_differences():
    case = mesa_case(KERNEL_DECK)
    rng = np.random.default_rng(5)
    # within +-0.3 V: away from the model's kinks (vgt at vpo, where ngspice's sheet charge stops)
    case.jacobians_match_differences(rng.uniform(-0.3, 0.3, case.n), rtol=5e-6)


#: A MESFET inverter whose DIBL parameter ``sigma0`` is far out of range: near vin = 1 V the level-2
#: kernel's gate capacitance meets ``tq + b = 0`` (``b = exp(-vgt / (eta vt))`` underflows), and numba's
#: complex division raises where real arithmetic would give a non-finite value.
FAR_SIGMA0 = """MESFET inverter, DIBL parameter sigma0 far out of range
z1 out in 0 mfet l=0.7u w=20u
rl vdd out 2k
vdd vdd 0 1.6
vin in 0 0
.model mfet nmf level=2 n=1.44 rd=20 rs=20 ri=10 rf=10 vs=1.9e5 mu=0.25 d=1e-7 vto=0.15 m=2 lambda=0.15
+ sigma0=99 vsigmat=0.5
.dc vin 0 1 0.01
.end
"""


@ngspice
def test_a_division_by_zero_in_the_compiled_kernel_leaves_the_point_to_the_python_solver():
    # the compiled Newton stops there as not converged (it raised ZeroDivisionError through `netdae run`,
    # "a bug in netdae", before); the point is then solved by the Python path, whose numpy arithmetic has
    # no such exception, and the sweep agrees with ngspice
    comparison = netdae.compare(FAR_SIGMA0, backend="subprocess")
    dc = comparison.analyses[0]
    assert dc.error is None and dc.passed, dc


def test_a_transient_whose_kernel_divides_by_zero_ends_with_its_points_and_a_message(monkeypatch):
    from netdae.dae.compiled import bdf_loop
    from netdae.dae.compiled.driver import MODEL_DIVISION

    calls = []
    run = bdf_loop.run

    def dividing(*args):  # the loop's first return, then the exception a complex division raises
        calls.append(1)
        if len(calls) > 2:
            raise ZeroDivisionError("complex division by zero")
        return run(*args)

    monkeypatch.setattr(bdf_loop, "run", dividing)
    text = FAR_SIGMA0.replace("sigma0=99", "sigma0=0.1").replace(".dc vin 0 1 0.01", ".tran 1n 100n")
    text = text.replace("vin in 0 0", "vin in 0 pulse(0 1 10n 10n 10n 20n 60n)")
    res = [r for r in netdae.run(netdae.load(text)) if r.analysis == "tran"][0]
    assert not res.ok and MODEL_DIVISION in res.message and "MESFETs" in res.message
    assert res.t.size >= 2 and np.all(np.isfinite(np.asarray(res["v(out)"])))
