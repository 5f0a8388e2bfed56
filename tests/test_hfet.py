"""ngspice's HFET1 (``nhfet``/``phfet`` level 5) against ngspice 39, finite differences and the kernel.

ngspice's numbers come from ``ngspice -b`` on the same netlist (``@z1[...]`` after ``.op``: its drain
current ``cd``, ``gm``, ``gds``, the gate-drain current ``cgd`` and the gate capacitances it prints as
``qgs``, ``qgd`` after an operating point) or through :func:`netdae.compare` (``.dc`` sweeps, ``.ac``,
transients); tolerances are relative to each quantity's scale.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

import netdae
from netdae.devices.hfet import HfetFamily
from netdae.errors import CircuitError, NetlistError
from netdae.mna import assemble
from netdae.netlist import load

from test_devices_diode import assert_jacobians_match

#: A level-5 card that exercises most of HFET1: series, intrinsic and gate-charge resistances (RI, RF:
#: the charges' internal nodes), the gate leakage through RGS/RGD, the GGR term, CDS, the ETA2/D2 sheet
#: charge, P, GAMMA and the temperature coefficients.
MODEL = ("level=5 vto=0.13 rd=20 rs=15 rg=5 ri=10 rf=12 rdi=3 rsi=4 lambda=0.17 vs=1.5e5 mu=0.385 eta=1.32 "
         "sigma0=0.04 vsigma=0.1 vsigmat=0.3 js1s=1e-3 js1d=2e-3 js2s=1e5 m1s=1.4 nmax=6e15 cds=3f eta2=2.2 "
         "d2=0.15u p=0.8 ggr=30 del=0.05 klambda=1e-4 kmu=2e-4 kvto=5e-4 m=2.57")
#: The corpus card (tests/hfet/id_vgs.cir), with no gate leakage.
PLAIN = ("level=5 rdi=0 rsi=0 m=2.57 lambda=0.17 vs=1.5e5 mu=0.385 vt0=0.13 eta=1.32 sigma0=0.04 vsigma=0.1 "
         "vsigmat=0.3 js1s=0 js1d=0 nmax=6e15")
#: (vgs, vds) of an n device in its normal mode.
BIASES = [(0.3, 1.0), (0.6, 0.2), (0.05, 1.5), (-0.2, 0.8), (0.5, 0.3), (0.9, 2.0)]
TIGHT = {"reltol": 1e-10, "vntol": 1e-13, "abstol": 1e-16}
QUANTITIES = ("cd", "gm", "gds", "cgd", "qgs", "qgd")

ngspice = pytest.mark.skipif(shutil.which("ngspice") is None, reason="ngspice is not installed")


def held(vgs: float, vds: float, model: str = MODEL, kind: str = "nhfet", inst: str = "l=1u w=10u",
         extra: str = "") -> str:
    return (f"hfet held\nVD d 0 {vds}\nVG g 0 {vgs}\nZ1 d g 0 hm {inst}\n.model hm {kind} {model}\n{extra}"
            ".op\n.end\n")


def ngspice_op(text: str, names) -> dict[str, float]:
    """ngspice 39's values of ``@z1[name]`` at the operating point of ``text`` (solved tightly, as netdae's)."""
    deck = text.replace(".op\n", ".options reltol=1e-9 abstol=1e-15 vntol=1e-12\n.op\n.control\nrun\nprint "
                        + " ".join(f"@z1[{n}]" for n in names) + "\n.endc\n")
    out = subprocess.run(["ngspice", "-b"], input=deck, capture_output=True, text=True, timeout=60).stdout
    values = {}
    for n in names:
        m = re.search(rf"@z1\[{n}\] = (\S+)", out)
        assert m, out
        values[n] = float(m.group(1))
    return values


def netdae_op(text: str, names) -> dict[str, float]:
    spelled = {"qgs": "capgs", "qgd": "capgd"}  # ngspice prints the capacitances as qgs, qgd after .op
    r = netdae.run(text, save=[f"@z1[{spelled.get(n, n)}]" for n in names], **TIGHT)[0]
    return {n: float(r[f"@z1[{spelled.get(n, n)}]"][0]) for n in names}


def _agree(ours, theirs, rel=2e-6):
    for n in ours:
        assert ours[n] == pytest.approx(theirs[n], rel=rel, abs=1e-16 if n.startswith("q") else 1e-13), n


@ngspice
@pytest.mark.parametrize("vgs,vds", BIASES)
@pytest.mark.parametrize("temp", [27.0, 80.0])
def test_operating_point_quantities_agree_with_ngspice(vgs, vds, temp):
    text = held(vgs, vds, extra=f".options temp={temp}\n")
    _agree(netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES))


@ngspice
@pytest.mark.parametrize("vgs,vds", BIASES[:4])
def test_p_channel_agrees_with_ngspice(vgs, vds):
    # phfet: the card's VTO is multiplied by the type, every voltage and current too; P-channel defaults
    text = held(-vgs, -vds, model=MODEL.replace("vto=0.13", "vto=-0.13"), kind="phfet")
    _agree(netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES))
    defaults = held(-vgs - 0.2, -vds, model="level=5 js1s=0 js1d=0", kind="phfet")
    _agree(netdae_op(defaults, QUANTITIES), ngspice_op(defaults, QUANTITIES))


@ngspice
@pytest.mark.parametrize("inst", ["l=1u w=10u temp=60", "l=1u w=10u dtemp=30", "l=2u w=40u m=3",
                                  "l=0.5u w=8u"])
def test_instance_temperatures_and_sizes_agree_with_ngspice(inst):
    text = held(0.35, 0.9, inst=inst)
    _agree(netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES))


@ngspice
@pytest.mark.parametrize("card", ["gatemod=1", "gatemod=1 a1=0.02 a2=0.1", "vt1=0.9 eta1=1.7 d1=0.02u",
                                  "gamma=2 delta=2 mc=2.5 m=2 rsi=10 rdi=5"])
def test_model_options_agree_with_ngspice(card):
    text = held(0.4, 1.1, model=PLAIN + " " + card)
    _agree(netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES))


#: An HFET2 (level 6) card with its series resistances, gate diodes (JS, N, GGR), CF, the ETA2/D2 sheet
#: charge and the temperature coefficients, KNMAX included.
MODEL6 = ("level=6 vto=0.13 rd=20 rs=15 rdi=3 rsi=4 js=1e-2 n=1.5 ggr=30 cf=1f lambda=0.17 mu=0.385 eta=1.32 "
          "sigma0=0.04 nmax=6e15 eta2=2.2 d2=0.15u p=0.8 knmax=1e13 kvto=1e-3 kmu=2e-4 klambda=1e-4")


@ngspice
@pytest.mark.parametrize("vgs,vds", BIASES)
@pytest.mark.parametrize("temp", [27.0, 80.0])
def test_hfet2_operating_point_quantities_agree_with_ngspice(vgs, vds, temp):
    text = held(vgs, vds, model=MODEL6, extra=f".options temp={temp}\n")
    _agree(netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES))


@ngspice
@pytest.mark.parametrize("vgs,vds", BIASES[:3])
def test_hfet2_p_channel_agrees_with_ngspice(vgs, vds):
    # HFET2 sets the N channel's ETA, MU, VS defaults only: a phfet card gives them
    model = MODEL6.replace("vto=0.13", "vto=-0.13") + " vs=0.8e5"
    text = held(-vgs, -vds, model=model, kind="phfet", inst="l=1u w=10u dtemp=20")
    _agree(netdae_op(text, QUANTITIES), ngspice_op(text, QUANTITIES))


@ngspice
@pytest.mark.parametrize("kind,sign", [("nhfet", 1.0), ("phfet", -1.0)])
def test_hfet2_output_sweeps_agree_with_ngspice(kind, sign):
    from netdae.comparison import compare

    model = MODEL6.replace("vto=0.13", f"vto={0.13 * sign}") + " vs=1e5"
    text = (f"HFET2 output characteristics\nVD d 0 0\nVG g 0 0\nZ1 d g 0 hm l=1u w=10u\n.model hm {kind} {model}\n"
            f".dc VD {-0.6 * sign} {2 * sign} {0.05 * sign} VG {-0.1 * sign} {0.7 * sign} {0.2 * sign}\n.end\n")
    c = compare(text, tight=True, tol={"dc": 1e-5})
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("dc")
    assert a.error is None and a.points >= 3 * 50
    assert max(s.max_rel for s in a.signals if s.name.startswith("i(")) <= 1e-6


@ngspice
@pytest.mark.parametrize("kind,sign", [("nhfet", 1.0), ("phfet", -1.0)])
def test_output_and_transfer_sweeps_agree_with_ngspice(kind, sign):
    from netdae.comparison import compare

    vto = 0.13 * sign
    for sweep in (f".dc VD {-0.6 * sign} {2 * sign} {0.05 * sign} VG {-0.1 * sign} {0.7 * sign} {0.2 * sign}",
                  f".dc VG {-0.5 * sign} {1 * sign} {0.02 * sign} VD {0.2 * sign} {1.4 * sign} {0.6 * sign}"):
        text = (f"HFET characteristics\nVD d 0 0\nVG g 0 0\nZ1 d g 0 hm l=1u w=10u\n"
                f".model hm {kind} {MODEL.replace('vto=0.13', f'vto={vto}')}\n.options temp=45\n{sweep}\n.end\n")
        c = compare(text, tight=True, tol={"dc": 1e-5})
        assert c.ngspice_error is None, c.ngspice_error
        a = c.analysis("dc")
        assert a.error is None and a.signals and a.points >= 3 * 50
        # the terminal currents to 1e-6 of their range; the internal nodes to the Newton tolerance
        currents = max(s.max_rel for s in a.signals if s.name.startswith("i("))
        assert currents <= 1e-6, currents
        assert all(s.max_abs <= 2e-6 for s in a.signals if s.name.startswith("v(")), a.worst.name


@ngspice
def test_corpus_transfer_characteristic_agrees_with_ngspice():
    from netdae.comparison import compare

    text = (f"HFET Id versus Vds\nz1 1 2 0 hfet l=1u w=10u\nvgs 2 0 dc 0.3\nvds 1 0 dc 1.0\n"
            f".model hfet nhfet {PLAIN}\n.dc vds 0 1 0.01 vgs 0 0.6 0.1\n.end\n")
    c = compare(text, tight=True)
    a = c.analysis("dc")
    assert c.ngspice_error is None and a.error is None
    assert max(s.max_rel for s in a.signals if s.name.startswith("i(")) <= 1e-6


CS_STAGE = """HFET common-source stage
VDD vdd 0 2
VIN in 0 dc 0.35 ac 1
RG in g 1k
RL vdd d 1.5k
Z1 d g 0 hm l=1u w=10u
CL d 0 20f
.model hm nhfet {model}
.ac dec 10 1e6 1e11
.end
"""


@ngspice
def test_common_source_stage_ac_agrees_with_ngspice():
    from netdae.comparison import compare

    # the low-frequency gain (gm, gds and the load): ngspice's gm, gds are the derivatives netdae uses
    low = CS_STAGE.format(model=PLAIN).replace(".ac dec 10 1e6 1e11", ".ac dec 5 1e4 1e6")
    c = compare(low, tight=True, tol={"ac": 1e-4}, signals=["v(d)"])
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("ac")
    assert a.error is None and a.signals[0].max_rel <= 3e-5, a.signals[0].max_rel
    # up to 100 GHz: netdae's gate charges have transcapacitances (d qgs/d vds) that ngspice's small-signal
    # matrix, its capacitances alone, does not have: 1.4e-2 at most, near the stage's pole (3-10 GHz)
    c = compare(CS_STAGE.format(model=PLAIN), tight=True, tol={"ac": 2e-2}, signals=["v(d)", "v(g)"])
    a = c.analysis("ac")
    assert a.error is None and len(a.signals) >= 2
    worst = max(s.max_rel for s in a.signals)
    assert worst <= 2e-2, (a.worst.name, worst)


def _ngspice_tran(text: str, names, extra: str = "") -> tuple[np.ndarray, np.ndarray]:
    """ngspice 39's transient of ``text``: the time axis and the named signals (rows)."""
    deck = text.replace(".end\n", f"{extra}.control\nrun\nset width=300\nprint {' '.join(names)}\n.endc\n.end\n", 1)
    out = subprocess.run(["ngspice", "-b"], input=deck, capture_output=True, text=True, timeout=300).stdout
    rows = np.array([[float(v) for v in line.split()[1:]] for line in out.splitlines() if re.match(r"^\d+\s", line)])
    return rows[:, 0], rows[:, 1:].T


def _crossings(t, v, level):
    k = np.nonzero((v[:-1] - level) * (v[1:] - level) < 0.0)[0]
    return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


@ngspice
def test_inverter_transient_agrees_with_ngspice():
    # the public DCFL inverter pair (tests/hfet/inverter.cir): ngspice 39's operating point is a spurious
    # one (v(3) = v(4) = -0.275 V with the drivers off and depletion loads), which its HFETAload's inverse
    # flag, kept from a reverse-biased device to the devices after it, makes a solution; the physical one
    # (v(3) = 1.956 V) is a solution of ngspice's equations too (every device forward), and a .nodeset
    # near it makes ngspice find it. Against that run: the levels to 1e-5, the edges' 1 V crossings within
    # 2 ps (first stage) and 8 ps (second stage, whose node has no capacitor: ngspice's Meyer currents
    # against netdae's charges) of ngspice's at tight tolerances.
    text = open_corpus("inverter.cir").replace(".print tran all\n", "")
    text = text.replace("pwl(0,0V   1ns,0V 1.005ns,1V 2ns,1V)", "pwl(0,0V 1ns,0V 1.1ns,1V 2ns,1V 2.1ns,0)")
    r = netdae.run(text, save=["v(3)", "v(4)"])[0]
    ours = r.axis, np.asarray(r["v(3)"]), np.asarray(r["v(4)"])
    spurious_t, spurious = _ngspice_tran(text, ["v(3)", "v(4)"])
    assert abs(spurious[0][0] + 0.275) < 1e-3 and abs(ours[1][0] - 1.9557) < 1e-3
    t, (v3, v4) = _ngspice_tran(text.replace(".tran 0.01n 3n", ".tran 0.01n 3n 0 0.2p"), ["v(3)", "v(4)"],
                                ".nodeset v(3)=2 v(4)=0.05\n.options reltol=1e-5\n")
    for when in (0.5e-9, 0.99e-9, 1.8e-9, 2.99e-9):
        for mine, theirs in ((ours[1], v3), (ours[2], v4)):
            assert np.interp(when, ours[0], mine) == pytest.approx(np.interp(when, t, theirs), rel=3e-5)
    for mine, theirs, within in ((ours[1], v3, 2e-12), (ours[2], v4, 8e-12)):
        a, b = _crossings(ours[0], mine, 1.0), _crossings(t, theirs, 1.0)
        assert len(a) == len(b) == 2
        assert np.max(np.abs(a - b)) <= within, (a, b)


@ngspice
def test_hfet2_inverter_transient_agrees_with_ngspice():
    # the public inverter pair with HFET2 cards (level 6; HFET2 clears its inverse flag per device, and
    # ngspice finds the physical operating point): levels to 1e-5, crossings as for HFET1
    text = open_corpus("inverter.cir").replace(".print tran all\n", "").replace("level=5", "level=6")
    text = text.replace("js1s=1e-12 js1d=1e-12", "js=1e-12")
    text = text.replace("pwl(0,0V   1ns,0V 1.005ns,1V 2ns,1V)", "pwl(0,0V 1ns,0V 1.1ns,1V 2ns,1V 2.1ns,0)")
    r = netdae.run(text, save=["v(3)", "v(4)"])[0]
    ours = r.axis, np.asarray(r["v(3)"]), np.asarray(r["v(4)"])
    t, (v3, v4) = _ngspice_tran(text.replace(".tran 0.01n 3n", ".tran 0.01n 3n 0 0.2p"), ["v(3)", "v(4)"],
                                ".options reltol=1e-5\n")
    for when in (0.5e-9, 0.99e-9, 1.8e-9, 2.99e-9):
        for mine, theirs in ((ours[1], v3), (ours[2], v4)):
            assert np.interp(when, ours[0], mine) == pytest.approx(np.interp(when, t, theirs), rel=3e-5)
    for mine, theirs, within in ((ours[1], v3, 2e-12), (ours[2], v4, 8e-12)):
        a, b = _crossings(ours[0], mine, 1.0), _crossings(t, theirs, 1.0)
        assert len(a) == len(b) == 2
        assert np.max(np.abs(a - b)) <= within, (a, b)


@pytest.mark.parametrize("engine", ["python"])
def test_compiled_engine_equals_the_python_integrator(engine, monkeypatch):
    text = open_corpus("inverter.cir").replace(".print tran all\n", "").replace(".tran 0.01n 3n", ".tran 0.01n 1.5n")
    compiled = netdae.run(text, save=["v(3)", "v(4)"])[0]
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    python = netdae.run(text, save=["v(3)", "v(4)"])[0]
    # the engines take their own steps (355 and 352); each is within 1.6e-2 V of a reltol 1e-7 run on
    # v(4) (measured: 1.3e-2 and 1.5e-2), and they agree to 2.6e-3 V
    for name in ("v(3)", "v(4)"):
        np.testing.assert_allclose(np.interp(python.axis, compiled.axis, compiled[name]), python[name], atol=4e-3)


def open_corpus(name: str) -> str:
    from pathlib import Path

    path = Path("/work/corpus/tests/hfet") / name
    if not path.exists():
        pytest.skip("the public corpus is not on this machine")
    return path.read_text()


@pytest.mark.parametrize("vgs,vds", BIASES + [(0.4, -0.6)])
def test_jacobians_are_the_derivatives_of_q_and_phi(vgs, vds):
    circuit = load(held(vgs, vds))
    system = assemble(circuit)
    from netdae.analyses.op import operating_point

    r = operating_point(circuit, **TIGHT)
    x = np.array([float(r[name][0]) if name in r.signals else 0.0 for name in system.names])
    x = x + 1e-3 * np.sin(np.arange(x.size) + 1.0)
    # the charges' entries are differences of quadratures of 1e-14 C: 5e-6 of the largest entry
    assert_jacobians_match(system, x, rtol=5e-6)


def _family(text: str) -> HfetFamily:
    system = assemble(load(text))
    return next(f for f in system.families if isinstance(f, HfetFamily))


@pytest.mark.parametrize("vgs,vds", BIASES)
def test_gate_charges_have_ngspice_capacitances_along_the_gate(vgs, vds):
    # the charge form: moving the gate alone, d qgs/d vgs'' is ngspice's capgs, d qgd/d vgd'' its capgd
    fam = _family(held(vgs, vds))
    vgs_a, vgd_a = np.array([vgs]), np.array([vgs - vds])
    r = fam.dc(vgs_a, vgd_a)
    _, _, dqs, dqd = fam.charges(vgs_a, vgd_a, vgs_a, vgd_a)
    assert (dqs[0] + dqs[1] + dqs[2])[0] == pytest.approx(r["capgs"][0], rel=1e-6)
    assert (dqd[0] + dqd[1] + dqd[2])[0] == pytest.approx(r["capgd"][0], rel=1e-6)


def test_inverse_mode_is_ngspice_s():
    # ngspice evaluates the inverse mode at vgs (not vgd) and |vds|: the current is odd in vds at fixed vgs
    fam = _family(held(0.3, 1.0, model=PLAIN))
    vgs, vds = np.array([0.45, 0.1, 0.3]), np.array([0.7, 0.05, 1.2])
    fwd = fam.dc(vgs, vgs - vds)["ich"]
    rev = fam.dc(vgs, vgs + vds)["ich"]
    np.testing.assert_allclose(rev, -fwd, rtol=1e-14)


@pytest.mark.parametrize("text, pattern, column_text", [
    (held(0.2, 1.0, model="level=7"), r"level 7 is not one ngspice 39 has", "7"),
    (held(0.2, 1.0, model="level=3"), r"an nhfet model of level 3 is ngspice's MESA", "3"),
    (held(0.2, 1.0, model="vto=0.1"), r"an nhfet model of level 1 is ngspice's Statz MESFET", ".model"),
    (held(0.2, 1.0, inst="2 l=1u"), r"an area \(2\) on the card of an HFET model", "Z1"),
    (held(0.2, 1.0, inst="ts=50"), r"'ts' is not an instance parameter of ngspice's HFET", "Z1"),
    (held(0.2, 1.0, model="level=5 type=1"), r"'type' is an output", "1"),
])
def test_bad_cards_are_located_errors(text, pattern, column_text):
    with pytest.raises(NetlistError, match=pattern) as err:
        assemble(load(text))
    line = text.splitlines()[err.value.location.line - 1]
    assert line[err.value.location.column - 1:].startswith(column_text)


def test_unknown_parameters_are_warned_as_ngspice_does():
    circuit = load(held(0.2, 1.0, model=PLAIN + " foo=3"))
    text = " | ".join(d.message for d in circuit.diagnostics if d.severity == "warning")
    assert "'foo'" in text
    a = netdae_op(held(0.3, 1.0, model=PLAIN + " foo=3"), ("cd",))
    b = netdae_op(held(0.3, 1.0, model=PLAIN), ("cd",))
    assert a["cd"] == b["cd"] > 0.0


def test_instance_errors_and_unsupported_parameters():
    with pytest.raises(CircuitError, match="KAPPA with DELF=1e\\+09 .*not implemented"):
        assemble(load(held(0.2, 1.0, model=PLAIN + " kappa=0.1 delf=1e9")))
    with pytest.raises(CircuitError, match="w = 0 must be positive"):
        assemble(load(held(0.2, 1.0, inst="w=0")))


# --- the compiled kernel ----------------------------------------------------------------------

def hfet_case(text):
    from test_device_kernels import Case, diode_state

    from netdae.devices.kernels.hfet import eval_hfet
    return Case(text, HfetFamily, eval_hfet, diode_state)


KERNEL_DECK = f"""three HFET devices, with and without the series and gate resistances, both types
Z1 1 2 3 hm l=1u w=10u
Z2 3 2 0 hp l=1.2u w=10u m=2
Z3 4 1 2 hm l=0.8u w=15u off
.model hm nhfet {MODEL}
.model hp phfet level=5 vto=-0.3 lambda=0.05 cds=2f
Z4 1 4 0 h6 l=1u w=10u
.model h6 nhfet {MODEL6}
.end
"""


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_the_family(seed, monkeypatch):
    import test_device_kernels
    from test_device_kernels import exercise, scales

    monkeypatch.setattr(test_device_kernels, "SPREAD", 1e-12)
    case = hfet_case(KERNEL_DECK)
    rng = np.random.default_rng(seed)
    exercise(case, rng, scales(0.3, 1.0, 2.0), scales(0.2, 0.8), draws=4)


def test_kernel_jacobians_match_differences():
    case = hfet_case(KERNEL_DECK)
    rng = np.random.default_rng(5)
    case.jacobians_match_differences(rng.uniform(-0.3, 0.3, case.n), rtol=5e-6)
