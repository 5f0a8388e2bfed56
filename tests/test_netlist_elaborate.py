"""Elaboration: every element kind's fields, parameters and scoping, subcircuits, models, control cards."""

from __future__ import annotations

import math

import pytest

import netdae

from netdae.circuit import AcAnalysis, DcAnalysis, OpAnalysis, TranAnalysis
from netdae.errors import NetlistError
from netdae.netlist import load
from netdae.netlist.expr import Binary, Const, Current, Time, Voltage, evaluate, transform
from netdae.netlist.waveforms import Am, Exp, Pulse, Pwl, Sffm, Sin


def net(body: str):
    return load("test netlist\n" + body + "\n.end\n")


def eval_at(expr, volts=None, amps=None):
    """Value of a behavioural tree for given node voltages and branch currents."""
    volts, amps = volts or {}, amps or {}

    def leaf(n):
        if type(n) is Voltage:
            return Const(volts.get(n.pos, 0.0) - (volts.get(n.neg, 0.0) if n.neg else 0.0))
        if type(n) is Current:
            return Const(amps[n.element])
        return None

    return evaluate(transform(expr, leaf), None)


# -- passive elements ------------------------------------------------------------------
def test_r_c_l_fields():
    c = net("R1 a b 2k tc1=1m tc2=2u m=2\nR2 b 0 r=3k\nC1 a 0 10u ic=1.5 m=3\nL1 a b 4.7m ic=-2m nt=10\n"
            "Rm a 0 1k rmod l=2u w=1u\n.model rmod r tc1=0.01")
    r1, r2, c1, l1, rm = c.elements
    assert (r1.kind, r1.nodes, r1.value, r1.params) == ("resistor", ("a", "b"), 2e3, {"tc1": 1e-3, "tc2": 2e-6, "m": 2.0})
    assert r2.value == 3e3 and r2.params == {}
    assert (c1.kind, c1.value, c1.params) == ("capacitor", pytest.approx(10e-6), {"ic": 1.5, "m": 3.0})
    assert (l1.kind, l1.value, l1.params) == ("inductor", pytest.approx(4.7e-3), {"ic": -2e-3, "nt": 10.0})
    assert rm.model == "rmod" and rm.params == {"l": 2e-6, "w": 1e-6, "tc1": 0.01}  # the model's tc1
    assert c.count_by_letter() == {"c": 1, "l": 1, "r": 3}


def test_tc_pair_and_locations():
    c = net("R1 a 0 1k tc=1m,2u")
    assert c.element("r1").params == {"tc1": 1e-3, "tc2": 2e-6}
    loc = c.element("r1").location
    assert (loc.file, loc.line, loc.column) == ("<string>", 2, 1)


def test_coupling_of_two_and_three_inductors():
    c = net("L1 a 0 1m\nL2 b 0 1m\nL3 c 0 2m\nK1 L1 L2 0.9\nKall l1 l2 l3 0.5")
    k1, kall = c.element("k1"), c.element("kall")
    assert (k1.kind, k1.nodes, k1.value, k1.controls) == ("coupling", (), 0.9, ("l1", "l2"))
    assert kall.controls == ("l1", "l2", "l3") and kall.value == 0.5


# -- sources -------------------------------------------------------------------------------
def test_source_values_and_functions():
    c = net("V1 a 0 5\nV2 b 0 dc 2 ac 1 45 sin(0 1 1k)\nV3 c 0 dc=3\nV4 d 0 ac\nV5 e 0 ac 2\n"
            "I1 0 f pulse(0 1m 1u 1n 1n 5u 10u)\nI2 0 g 1m ac 0.5 -90\nV6 h 0 pwl(0 0 1m 1 2m 0) r=1m td=0.5m\n"
            "V7 i 0 PWL 0 0 1 1\nV8 j 0 exp(0 1 1u 1u)\nV9 k 0 sffm(0 1 1k 5 100)\nV10 l 0 am(1 0.5 1k 10k)\n"
            "V11 m 0 SINE 0 1 1k\nV12 n 0 pulse(0, 1, 0, 1n, 1n, 1u, 2u)")
    v1, v2, v3, v4, v5, i1, i2, v6, v7, v8, v9, v10, v11, v12 = c.elements
    assert (v1.source.dc, v1.source.tran, v1.source.ac_mag) == (5.0, None, 0.0)
    assert (v2.source.dc, v2.source.ac_mag, v2.source.ac_phase) == (2.0, 1.0, 45.0)
    assert isinstance(v2.source.tran, Sin) and v2.source.tran.given[:3] == (0.0, 1.0, 1e3)
    assert v3.source.dc == 3.0
    assert (v4.source.dc, v4.source.ac_mag) == (None, 1.0)       # 'ac' alone is magnitude 1
    assert v5.source.ac_mag == 2.0 and v5.source.ac_phase == 0.0
    assert i1.kind == "isource" and isinstance(i1.source.tran, Pulse) and i1.nodes == ("0", "f")
    assert (i2.source.dc, i2.source.ac_mag, i2.source.ac_phase) == (1e-3, 0.5, -90.0)
    assert isinstance(v6.source.tran, Pwl) and (v6.source.tran.repeat, v6.source.tran.delay) == (1e-3, 0.5e-3)
    assert list(v7.source.tran.times) == [0.0, 1.0]
    assert isinstance(v8.source.tran, Exp) and isinstance(v9.source.tran, Sffm) and isinstance(v10.source.tran, Am)
    assert isinstance(v11.source.tran, Sin)
    assert v12.source.tran.given[:7] == (0.0, 1.0, 0.0, 1e-9, 1e-9, 1e-6, 2e-6)


def test_source_spec_operating_point_rules():
    c = net("V1 a 0 0.5 sin(1 1 1k 0 0 90)\nV2 b 0 sin(0.25 1 1k 0 0 30)\nV3 c 0 ac 1")
    v1, v2, v3 = (e.source for e in c.elements)
    assert v1.dc_value() == 0.5 and v1.tran_value_at_zero() == pytest.approx(2.0)
    assert v2.dc_value() == pytest.approx(0.75) == v2.tran_value_at_zero()
    assert v3.dc_value() == 0.0 == v3.tran_value_at_zero()


# -- controlled and behavioural sources ----------------------------------------------------------
def test_linear_controlled_sources_and_the_opamp():
    c = net("V1 in 0 1\nE1 a 0 in 0 10\nG1 b 0 in a 2m\nF1 c 0 v1 3\nH1 d 0 V1 1k\nEop out 0 in n OPAMP\nR1 n 0 1")
    e1, g1, f1, h1, op = c.elements[1:6]
    assert (e1.kind, e1.nodes, e1.value) == ("vcvs", ("a", "0", "in", "0"), 10.0)
    assert (g1.kind, g1.nodes, g1.value) == ("vccs", ("b", "0", "in", "a"), 2e-3)
    assert (f1.kind, f1.nodes, f1.value, f1.controls) == ("cccs", ("c", "0"), 3.0, ("v1",))
    assert (h1.kind, h1.value, h1.controls) == ("ccvs", 1e3, ("v1",))
    assert (op.kind, op.nodes, op.value) == ("opamp", ("out", "0", "in", "n"), None)


def test_hspice_keyword_forms_of_linear_controlled_sources():
    """ngspice 39 drops VCVS, VCCS, CCCS, CCVS after the output nodes when the card has exactly 7 (E, G)
    or 6 (F, H) words (inp_compat's replace_token), and runs them as the plain forms (compared: equal);
    netdae refused them ("unexpected '2.5'")."""
    c = net("V1 in 0 1\nE1 a 0 VCVS in 0 2.5\nG1 b 0 vccs in a 2m\nF1 c 0 CCCS v1 3\nH1 d 0 ccvs V1 1k\n"
            "R1 a 0 1\nR2 b 0 1\nR3 c 0 1\nR4 d 0 1")
    e1, g1, f1, h1 = c.elements[1:5]
    assert (e1.kind, e1.nodes, e1.value) == ("vcvs", ("a", "0", "in", "0"), 2.5)
    assert (g1.kind, g1.nodes, g1.value) == ("vccs", ("b", "0", "in", "a"), 2e-3)
    assert (f1.kind, f1.nodes, f1.value, f1.controls) == ("cccs", ("c", "0"), 3.0, ("v1",))
    assert (h1.kind, h1.nodes, h1.value, h1.controls) == ("ccvs", ("d", "0"), 1e3, ("v1",))
    # another length: the word is a node, as in ngspice ('E2 a 0 vcvs 0 2' senses node vcvs)
    e2 = net("V1 vcvs 0 1\nE2 a 0 vcvs 0 2\nR1 a 0 1").elements[1]
    assert (e2.kind, e2.nodes, e2.value) == ("vcvs", ("a", "0", "vcvs", "0"), 2.0)


def test_behavioural_sources():
    c = net(".param k=3\nV1 in 0 1\nB1 a 0 V=V(in)*k + time\nB2 b 0 I = {2*v(in, a)}\n"
            "E1 c 0 value={V(in)**2}\nG1 d 0 cur='i(v1)*10'\nE2 e 0 vol={V(in, gnd)}")
    b1, b2, e1, g1, e2 = c.elements[1:]
    assert (b1.kind, b2.kind, e1.kind, g1.kind, e2.kind) == ("bvoltage", "bcurrent", "bvoltage", "bcurrent",
                                                              "bvoltage")
    assert b1.expr == Binary("+", Binary("*", Voltage("in"), Const(3.0)), Time())
    assert eval_at(b2.expr, {"in": 2.0, "a": 0.5}) == 3.0
    assert eval_at(e1.expr, {"in": -3.0}) == 9.0
    assert eval_at(g1.expr, amps={"v1": 0.25}) == 2.5
    assert e2.expr == Voltage("in")


def test_poly_sources_are_spice2_polynomials():
    c = net("V1 x 0 1\nV2 y 0 1\nR1 x 0 1\nR2 y 0 1\n"
            "E1 a 0 POLY(2) x 0 y 0 1 2 3 4 5 6\n"      # 1 + 2x + 3y + 4x^2 + 5xy + 6y^2
            "G1 b 0 poly(1) x 0 0 1 0.5\n"               # x + 0.5 x^2
            "F1 c 0 POLY(2) V1 V2 0 1 -1\n"              # i1 - i2
            "H1 d 0 poly(1) v2 2 0 0 1")                 # 2 + i2^3
    e1, g1, f1, h1 = c.elements[4:]
    assert (e1.kind, g1.kind, f1.kind, h1.kind) == ("bvoltage", "bcurrent", "bcurrent", "bvoltage")
    x, y = 0.7, -1.3
    assert eval_at(e1.expr, {"x": x, "y": y}) == pytest.approx(1 + 2 * x + 3 * y + 4 * x * x + 5 * x * y + 6 * y * y)
    assert eval_at(g1.expr, {"x": x}) == pytest.approx(x + 0.5 * x * x)
    assert eval_at(f1.expr, amps={"v1": 2.0, "v2": 0.5}) == 1.5
    assert eval_at(h1.expr, amps={"v2": 1.5}) == pytest.approx(2 + 1.5**3)


# -- semiconductor devices --------------------------------------------------------------------
def test_devices_models_and_the_q_node_count():
    c = net(".model dm d (is=1e-14 n=1.5 cjo=2p)\n.model qn npn is=1e-16 bf=100\n.model qp PNP(bf=50)\n"
            ".model nm nmos level=1 vto=0.7 kp=50u\n"
            "D1 a k dm 2 off ic=0.6 temp=50\nQ1 c b e qn\nQ2 c b e sub qn 1.5 ic=0.7,5\nQ3 c b e qp off\n"
            "M1 d g s b nm w=10u l=1u ad=1p as=1p pd=4u ps=4u ic=1,2,3 off")
    d1, q1, q2, q3, m1 = c.elements
    assert (d1.kind, d1.nodes, d1.model) == ("diode", ("a", "k"), "dm")
    assert d1.params == pytest.approx({"ic": 0.6, "temp": 50.0, "area": 2.0, "off": 1.0})
    assert (q1.kind, q1.nodes, q1.model) == ("bjt", ("c", "b", "e"), "qn")
    assert (q2.nodes, q2.model) == (("c", "b", "e", "sub"), "qn")
    assert q2.params == pytest.approx({"icvbe": 0.7, "icvce": 5.0, "area": 1.5})
    assert q3.params == {"off": 1.0}
    assert (m1.kind, m1.nodes, m1.model) == ("mosfet", ("d", "g", "s", "b"), "nm")
    assert m1.params == pytest.approx({"w": 1e-5, "l": 1e-6, "ad": 1e-12, "as": 1e-12, "pd": 4e-6, "ps": 4e-6,
                         "icvds": 1.0, "icvgs": 2.0, "icvbs": 3.0, "off": 1.0})
    assert c.models["dm"].params == {"is": 1e-14, "n": 1.5, "cjo": 2e-12}
    assert (c.models["qp"].type, c.models["qp"].params) == ("pnp", {"bf": 50.0})
    assert c.models["nm"].params["level"] == 1.0


# -- parameters and functions ----------------------------------------------------------------------
def test_params_several_per_line_forward_references_and_all_spellings():
    c = net(".param a=2 b={a*3} c='b+1', d = 4\n.param e={f*2}\n.param f=5\nR1 x 0 {a+b}\nR2 x 0 'c*d'\nR3 x 0 e")
    assert c.params == {"a": 2.0, "b": 6.0, "c": 7.0, "d": 4.0, "e": 10.0, "f": 5.0}
    assert [e.value for e in c.elements] == [8.0, 28.0, 10.0]


def test_redefined_param_takes_the_last_value_with_a_warning():
    c = net(".param a=1\nR1 x 0 {a}\n.param a=2")
    assert c.element("r1").value == 2.0
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert "parameter 'a' redefined" in w.message and w.location.line == 4


def test_a_param_given_twice_on_one_card_is_warned_about_and_once_per_card_in_subcircuits():
    """'.param r=1k r=2k' took 2k without a word (two cards warned); a redefinition inside a subcircuit was warned
    about once per instance, the same warning at the same place each time."""
    c = net(".param r=1k r=2k\nR1 x 0 {r}")
    assert c.element("r1").value == 2e3
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert "parameter 'r' redefined" in w.message and (w.location.line, w.location.column) == (2, 13)
    c = net(".subckt s p q\n.param r=1k\n.param r=2k\nR1 p q {r}\n.ends\nX1 a 0 s\nX2 a 0 s\nX3 a 0 s")
    assert [(d.location.line, d.message.split(" (")[0]) for d in c.diagnostics if d.severity == "warning"] == [
        (4, "parameter 'r' redefined")]


def test_an_option_given_again_with_another_value_is_warned_about():
    """.options reltol=1e-3 reltol=1e-4 (one card or two) took 1e-4 without a word (ngspice 39 says nothing)."""
    for text in (".options reltol=1e-3 reltol=1e-4", ".options reltol=1e-3\n.options reltol=1e-4"):
        c = net(text)
        assert c.options.reltol == 1e-4
        (w,) = [d for d in c.diagnostics if d.severity == "warning"]
        assert w.message.startswith("option reltol=0.0001 replaces reltol=0.001 given at <string>:2:17 (the last "
                                    "value holds, as in ngspice)")
    assert not [d for d in net(".options method=gear method=gear").diagnostics if d.severity == "warning"]


def test_functions_with_and_without_equals_and_nesting():
    c = net(".param k=2\n.func f(x, y) = {x*y + k}\n.func g(x) {f(x, x) + 1}\nR1 a 0 {g(3)}\nB1 b 0 V=g(v(a))")
    assert c.element("r1").value == 12.0
    assert eval_at(c.element("b1").expr, {"a": 2.0}) == 7.0


# -- subcircuits ---------------------------------------------------------------------------------
SUBCKTS = """
.param g=10
.global vdd
.subckt leaf a b params: r=1k k=2
R1 a mid {r*k}
R2 mid b {r}
Rv vdd mid 1meg
.ends leaf
.subckt outer p n rr=100 kk={g}
X1 p n leaf r={rr*2}
X2 p n leaf k={kk}
.subckt local a b
Rl a b 7
.ends
X3 p n local
.model dm d is=1e-15
D1 p n dm
.ends outer
Xa in gnd outer
Xb in 0 outer rr=1 kk=3
V1 in 0 1
Vdd vdd 0 5
.model dm d is=2e-14
D2 in 0 dm
"""


def test_subcircuit_expansion_values_and_ngspice_names():
    c = net(SUBCKTS)
    values = {e.name: e.value for e in c.elements if e.kind == "resistor"}
    assert values == {
        "r.xa.x1.r1": 400.0, "r.xa.x1.r2": 200.0, "r.xa.x1.rv": 1e6, "r.xa.x2.r1": 10e3, "r.xa.x2.r2": 1e3,
        "r.xa.x2.rv": 1e6, "r.xa.r.x3.rl": 7.0, "r.xb.x1.r1": 4.0, "r.xb.x1.r2": 2.0, "r.xb.x1.rv": 1e6,
        "r.xb.x2.r1": 3e3, "r.xb.x2.r2": 1e3, "r.xb.x2.rv": 1e6, "r.xb.r.x3.rl": 7.0}
    assert c.nodes == ["in", "xa.x1.mid", "vdd", "xa.x2.mid", "xb.x1.mid", "xb.x2.mid"]
    assert c.element("d.xa.d1").model == "xa:dm" and c.element("d2").model == "dm"
    assert {n: m.params["is"] for n, m in c.models.items()} == {"xa:dm": 1e-15, "xb:dm": 1e-15, "dm": 2e-14}
    assert c.element("r.xa.x1.r1").instance_path == ("xa", "x1")
    assert c.element("r.xb.r.x3.rl").instance_path == ("xb", "x3")
    assert c.element("r.xa.x1.r1").location.line == 6   # the definition's card


def test_parameters_are_scoped_dynamically_like_numparam():
    c = net(".subckt s2 a b\nR1 a b {rr}\n.ends\n.subckt s1 a b params: rr=5\nX1 a b s2\n.ends\n"
            "X1 1 0 s1\nX2 1 0 s1 rr=6")
    assert c.element("r.x1.x1.r1").value == 5.0 and c.element("r.x2.x1.r1").value == 6.0


def test_defaults_see_overrides_and_local_params():
    c = net(".subckt s a b params: rr=5 r2={rr*2}\n.param loc={rr+1}\nR1 a b {r2}\nR2 a b {loc}\n.ends\n"
            "X1 1 0 s\nX2 1 0 s rr=7\nX3 1 0 s params: r2=1")
    assert [e.value for e in c.elements] == [10.0, 6.0, 14.0, 8.0, 1.0, 6.0]


def test_controls_and_expressions_inside_subcircuits_are_renamed():
    c = net(".subckt amp in out\nVs in mid 0\nRs mid 0 1k\nF1 out 0 vs 2\nB1 x 0 V=V(in, mid)*I(Vs)\nRx x 0 1\n"
            "L1 out 0 1m\nL2 x 0 1m\nK1 L1 L2 0.5\n.ends\nX1 a b amp\nV1 a 0 1\nRb b 0 1")
    assert c.element("f.x1.f1").controls == ("v.x1.vs",)
    assert c.element("b.x1.b1").expr == Binary("*", Voltage("a", "x1.mid"), Current("v.x1.vs"))
    assert c.element("k.x1.k1").controls == ("l.x1.l1", "l.x1.l2")


def test_global_nodes_and_ground_aliases():
    c = net(".global vcc\n.subckt s a\nR1 a vcc 1\nR2 a gnd 1\nR3 a 0 1\n.ends\nX1 n s\nV1 vcc GND 5")
    assert c.element("r.x1.r1").nodes == ("n", "vcc")
    assert c.element("r.x1.r2").nodes == ("n", "0") == c.element("r.x1.r3").nodes
    assert c.element("v1").nodes == ("vcc", "0")


def test_continuation_lines_and_comments_inside_subcircuits():
    c = net(".subckt s a b\n+ params: r=1k ; the default\nR1 a\n* a comment inside\n+ b {r} $ value\n.ends\n"
            "X1 p q s r=2k")
    assert c.element("r.x1.r1").nodes == ("p", "q") and c.element("r.x1.r1").value == 2e3


# -- control cards -------------------------------------------------------------------------------
def test_analyses():
    c = net(".param ts=1u\nV1 a 0 1\nI1 0 a 1m\nR1 a 0 1k\n.op\n.tran {ts} 1m\n.tran 1u 2m 0.5m 5u uic\n"
            ".ac dec 10 1 1meg\n.ac lin 11 0 10\n.dc V1 0 5 0.5\n.dc v1 0 1 0.1 I1 0 1m 0.5m\n.dc temp -50 50 25")
    op, t1, t2, ac1, ac2, dc1, dc2, dc3 = c.analyses
    assert isinstance(op, OpAnalysis) and op.location.line == 6
    assert isinstance(t1, TranAnalysis) and (t1.tstep, t1.tstop, t1.tstart, t1.tmax, t1.uic) == (1e-6, 1e-3, 0, None, False)
    assert (t2.tstart, t2.tmax, t2.uic) == (0.5e-3, pytest.approx(5e-6), True)
    assert isinstance(ac1, AcAnalysis) and (ac1.variation, ac1.points, ac1.fstart, ac1.fstop) == ("dec", 10, 1.0, 1e6)
    assert (ac2.variation, ac2.fstart) == ("lin", 0.0)
    assert isinstance(dc1, DcAnalysis) and [(s.source, s.start, s.stop, s.step) for s in dc1.sweeps] == [("v1", 0, 5, 0.5)]
    assert [s.source for s in dc2.sweeps] == ["v1", "i1"]
    assert dc3.sweeps[0].source == "temp" and dc3.sweeps[0].start == -50


def test_options_and_temperature():
    c = net("R1 a 0 1\n.options reltol=1e-4 abstol=1p method=gear maxord=3 itl1=200 interp\n.option vntol=1u "
            "filetype=ascii\n.opt tnom=25 noacct gmin=1e-15 rshunt=1e12\n.temp 85")
    o = c.options
    assert (o.reltol, o.abstol, o.vntol, o.gmin, o.method, o.maxord, o.itl1, o.interp) == (
        1e-4, 1e-12, 1e-6, 1e-15, "gear", 3, 200, True)
    assert (o.temp, o.tnom, o.chgtol, o.itl4) == (85.0, 25.0, 1e-14, 10)
    assert o.extra == {"filetype": "ascii", "noacct": True}
    assert o.rshunt == 1e12
    assert load("t\nR1 a 0 1\n.options method=trapezoidal\n").options.method == "trap"


def test_initial_conditions_saves_and_title():
    c = net(".title The Real Title\n.subckt s a\nR1 a m 1\nC1 m 0 1u\n.ends\nX1 n s\nV1 n 0 1\n"
            ".ic v(n)=1 v(x1.m)=0.5\n.nodeset V(N)=0.9\n.save v(n) V(x1.m, 0) i(V1) n v(n,x1.m) all\n"
            ".print tran v(n) vdb(x1.m)\n.probe @r.x1.r1[i]\n.plot ac v(nope) i(r.x1.r1)")
    assert c.title == "The Real Title"
    assert c.ic == {"n": 1.0, "x1.m": 0.5} and c.nodeset == {"n": 0.9}
    # vdb(x1.m) is SPICE2's decibel form of v(x1.m); what netdae cannot keep is left out with a warning
    assert c.saves == ["v(n)", "v(x1.m)", "i(v1)", "v(n,x1.m)", "@r.x1.r1[i]", "i(r.x1.r1)"]
    warnings = [d.message for d in c.diagnostics if d.severity == "warning"]
    assert warnings == [".plot v(nope): no node 'nope' (not kept)"]  # i(r.x1.r1) is computed after the analysis


def test_an_element_named_by_its_instance_path_first_gets_its_ngspice_name():
    """'.save i(x1.v9)' (and PSpice's x1:v9) was 'no element' without a word of the name that exists, v.x1.v9."""
    c = net(".subckt s p q\nR1 p q 1k\nV9 p q 0\n.ends\nX1 a 0 s\nV1 a 0 1\nR2 a 0 1k\n"
            ".save i(x1.v9) @x1:r1[i] i(x1.v8)\n.op")
    warnings = [d.message for d in c.diagnostics if d.severity == "warning"]
    assert warnings == [".save i(x1.v9): no element 'x1.v9': inside subcircuits it is named 'v.x1.v9' (ngspice's "
                        "names) (not kept)",
                        ".save @x1:r1[i]: no device 'x1:r1': inside subcircuits it is named 'r.x1.r1' (ngspice's "
                        "names) (not kept)",
                        ".save i(x1.v8): no element 'x1.v8' (not kept)"]
    with pytest.raises(netdae.NetdaeError, match=r"cannot save 'i\(x1\.v9\)': no element 'x1\.v9' in the circuit: "
                                                 r"inside subcircuits it is named 'v\.x1\.v9'"):
        netdae.run(c, save=["i(x1.v9)"])


def test_control_block_commands_become_cards_the_rest_located_notes():
    c = net("R1 a 0 1\n.control\nrun\nplot v(a)\nshell ls\n.endc")
    (note,) = c.diagnostics
    assert note.severity == "note" and "'shell ls' skipped" in note.message and note.location.line == 6
    assert c.saves == ["v(a)"]


def test_circuit_is_independent_of_spelling_case():
    a = load("t\nR1 IN Out 1K\nV1 in 0 DC 1\n.TRAN 1U 1M\n")
    b = load("t\nr1 in out 1k\nv1 IN 0 dc 1\n.tran 1u 1m\n")
    assert [(e.name, e.nodes, e.value) for e in a.elements] == [(e.name, e.nodes, e.value) for e in b.elements]
    assert [(t.tstep, t.tstop) for t in a.analyses] == [(t.tstep, t.tstop) for t in b.analyses]


def test_pi_and_math_in_values():
    c = net("C1 a 0 {1/(2*pi*1k*1k)}")
    assert c.element("c1").value == pytest.approx(1 / (2 * math.pi * 1e6))


def test_models_take_the_parameters_of_their_instance():
    c = net(".subckt cell a params: isx=1e-15\n.model dm d is={isx} n={1+isx*1e15}\nD1 a 0 dm\n.ends\n"
            "X1 p cell\nX2 q cell isx=2e-15")
    assert c.models["x1:dm"].params == pytest.approx({"is": 1e-15, "n": 2.0})
    assert c.models["x2:dm"].params == pytest.approx({"is": 2e-15, "n": 3.0})
    assert c.element("d.x2.d1").model == "x2:dm"


def test_local_subcircuits_are_invisible_outside():
    with pytest.raises(Exception, match="unknown subcircuit 'inner'"):
        net(".subckt outer a\n.subckt inner b\nR1 b 0 1\n.ends\nX1 a inner\n.ends\nX1 n outer\nX2 n inner")
    c = net(".subckt inner b\nR1 b 0 2\n.ends\n.subckt outer a\n.subckt inner b\nR1 b 0 1\n.ends\nX1 a inner\n"
            ".ends\nX1 n outer\nX2 n inner")
    assert c.element("r.x1.r.x1.r1").value == 1.0 and c.element("r.x2.r1").value == 2.0


def test_unused_parameters_of_an_instance_are_still_checked():
    with pytest.raises(Exception, match="division by zero"):
        net(".subckt s a\n.param bad={1/0}\nR1 a 0 1\n.ends\nX1 n s")


def test_models_no_element_uses_are_not_screened():
    c = load("t\nV1 a 0 1\nR1 a 0 1\n.model q npn vceo=40 mfg=\"x\"\n.model m nmos level=49\n.end\n")
    assert c.diagnostics == []


def test_control_lines_drop_inline_comments_and_hash_lines():
    c = load("t\nV1 a 0 1\nR1 a 0 1k\n.control\n# a comment\nop ; the op\nprint v(a) // out\n.endc\n")
    assert [type(a).__name__ for a in c.analyses] == ["OpAnalysis"] and c.saves == ["v(a)"]
    assert c.diagnostics == []


def test_poly_f_h_controls_must_be_voltage_sources():
    with pytest.raises(NetlistError, match=r"f1: POLY control 'r1' is a resistor, not a voltage source"):
        load("t\nV1 b 0 1\nR1 b 0 1\nF1 a 0 POLY(1) R1 1 2\nR2 a 0 1\n.end\n")


def test_tc_and_tc1_together_are_an_error():
    with pytest.raises(NetlistError, match=r"tc1 given twice \(tc= sets tc1 and tc2\)"):
        load("t\nV1 a 0 1\nR1 a 0 1k tc1=0.1 tc=0.2\n.end\n")


def test_a_source_without_a_value_gets_ngspices_note():
    c = load("t\nV1 in 0 ac 1\nR1 in a 1k\nI2 a 0\nV3 b 0 sin(0 1 1k)\nR3 b 0 1\n.op\n.end\n")
    notes = [(d.severity, d.message, d.location.line, d.location.column) for d in c.diagnostics
             if "has no value" in d.message]
    # ngspice 39 notes I2 only: a source with an AC value (V1) gets no note there, nor here
    assert notes == [("note", "i2: has no value, DC 0 assumed (as ngspice 39 notes)", 4, 7)]


def test_a_second_k_card_on_the_same_inductors_is_warned_about():
    c = load("k\nV1 in 0 1\nR1 in a 1\nL1 a 0 1m\nL2 b 0 1m\nR2 b 0 1k\nK1 L1 L2 0.3\nK2 L2 L1 0.3\n.op\n.end\n")
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert w.message.startswith("k2: couples l2 and l1 as k1 does: the coupling factors add")
    assert (w.location.line, w.location.column) == (8, 1)


def test_tran_with_tstep_above_tstop_warns_and_tmax_zero_is_not_given():
    c = load("t\nV1 in 0 1\nR1 in a 1k\nC1 a 0 1n\n.tran 1m 1u\n.tran 1u 1m 0 0\n.end\n")
    (w,) = [d for d in c.diagnostics if d.severity == "warning"]
    assert w.message.startswith(".tran: tstep 0.001 is larger than tstop 1e-06: swapped?")
    assert (w.location.line, w.location.column) == (5, 7)
    assert c.analyses[1].tmax is None  # ngspice 39 takes tmax = 0 as not given


def test_a_double_quoted_param_value_is_its_expression_as_in_ngspice():
    c = load('t\nV1 in 0 1\nR1 in a 1k\nR2 a 0 {rv}\n.param rv="1k" rw="rv*2"\n.op\n.end\n')
    assert c.element("r2").value == 1e3 and c.params["rw"] == 2e3
    with pytest.raises(NetlistError, match="unknown parameter 'abc'"):  # ngspice: 'unknown parameter (abc)'
        load('t\nV1 in 0 1\nR2 in 0 {rv}\n.param rv="abc"\n.op\n.end\n')


def test_multiplier_m_of_b_sources_behavioural_e_g_and_linear_g_f():
    """ngspice 39 multiplies a B source's voltage or current by its m= (asrcload.c), hands an E value='s m=
    to the B source it makes, makes a G value='s m= the gain of its G, and has m= on VCCS and CCCS (their
    parallel multiplier); it printed these nine voltages (netdae refused every m= here)."""
    from netdae.analyses.op import operating_point

    text = ("m\n.param k=1.5\nV1 in 0 2\n"
            "B1 o1 0 V=V(in) m=2\nB2 0 o2 I=1m*V(in)*V(in) m={k*2}\nG3 0 o3 in 0 1m m=3\n"
            "G4 0 o4 VALUE={1m*V(in)} m=2\nE5 o5 0 VALUE={V(in)*V(in)} m=2\nG6 0 o6 cur={1m*V(in)} m={k}\n"
            "E7 o7 0 vol={V(in)+1} m=0.5\nB8 o8 0 V=V(in) tc1=1e-2 m=3\nVs in s 0\nRs s 0 1k\nF9 0 o9 Vs 2 m=3\n"
            + "".join(f"R{i} o{i} 0 1k\n" for i in range(1, 10)) + ".end\n")
    r = operating_point(load(text))
    ngspice = {"o1": 4.0, "o2": 12.0, "o3": 6.0, "o4": 4.0, "o5": 8.0, "o6": 3.0, "o7": 1.5, "o8": 6.0, "o9": 12.0}
    for node, volts in ngspice.items():
        assert float(r.signals[f"v({node})"][0]) == pytest.approx(volts, rel=1e-12), node
    with pytest.raises(NetlistError, match="unexpected parameter 'm'"):
        net("V1 in 0 1\nE1 a 0 in 0 2 m=3\nR1 a 0 1")  # the VCVS has no m in ngspice 39


def test_own_m_of_a_g_inside_an_instance_with_m_is_refused_as_other_elements_own_m():
    """ngspice 39 replaces an element's m by its subcircuit instance's (it printed 2 V here, not 6 V)."""
    text = ".subckt gs in out\nG1 0 out in 0 1m m=3\nR1 out 0 1k\n.ends\nV1 in 0 2\nX1 in o1 gs m=2\n.op"
    with pytest.raises(NetlistError, match="has its own m= and sits in subcircuit instance x1"):
        net(text)


def test_b_source_temperature_coefficients_at_its_instance_temperature():
    """ngspice 39's B source scales by 1 + tc1 dT + tc2 dT^2 with dT = (temp=, else the circuit's plus dtemp=)
    - 27 C, and ignores dtemp= beside temp= (asrctemp.c); `temper` stays the circuit's. ngspice printed these
    four voltages at .temp 60 (netdae refused temp= and dtemp=)."""
    from netdae.analyses.op import operating_point

    text = ("t\n.temp 60\n.param tt=80\nV1 in 0 2\nB1 o1 0 V=V(in) tc1=1e-2 temp=100\n"
            "B2 o2 0 V=V(in) tc1=1e-2 tc2=1e-4 dtemp=-20\nB3 0 o3 I=1m*V(in) tc1=2e-3 temp={tt} dtemp=5\n"
            "B4 o4 0 V=V(in)*temper/100 temp=0\n" + "".join(f"R{i} o{i} 0 1k\n" for i in range(1, 5)) + ".end\n")
    circuit = load(text)
    r = operating_point(circuit)
    expected = {"o1": 2 * (1 + 1e-2 * 73), "o2": 2 * (1 + 1e-2 * 13 + 1e-4 * 13**2), "o3": 2 * (1 + 2e-3 * 53),
                "o4": 1.2}
    for node, volts in expected.items():
        assert float(r.signals[f"v({node})"][0]) == pytest.approx(volts, rel=1e-12), node
    assert any("dtemp= ignored" in d.message for d in circuit.diagnostics)


def test_e_and_g_value_cards_read_the_b_source_parameters_ngspice_hands_on():
    """ngspice 39 makes 'E1 o1 0 value={...} tc1=1e-2' a B source with the rest of the card (tc1, tc2, m ...)
    and a G value='s m= its G's gain; at .temp 77 it printed 1.5, 1.5, 3 and 4.5 V (netdae refused tc1 there:
    "unexpected 'tc1' in expression")."""
    from netdae.analyses.op import operating_point

    text = ("t\n.temp 77\nV1 in 0 1\nE1 o1 0 value={V(in)} tc1=1e-2\nG1 0 o2 cur={1m*V(in)} tc1=1e-2\n"
            "E3 o3 0 vol={V(in)} tc1=1e-2 m=2\nG4 0 o4 value={1m*V(in)} tc1=1e-2 m=3\n"
            + "".join(f"R{i} o{i} 0 1k\n" for i in range(1, 5)) + ".end\n")
    r = operating_point(load(text))
    for node, volts in {"o1": 1.5, "o2": 1.5, "o3": 3.0, "o4": 4.5}.items():
        assert float(r.signals[f"v({node})"][0]) == pytest.approx(volts, rel=1e-12), node


def test_a_capacitor_value_reading_temper_without_c_key_is_warned():
    """ngspice 39 turns 'C1 a 0 {1n*(1+2e-3*(temper-27))}' into a charge-defined capacitor of constant charge
    (inp_compat's b_transformation_wanted matches temper): in ngspice the capacitor carries no current (an RC
    with it followed its input at once at .temp 75, netdae's charges with tau = 1.1 us)."""
    warned = load("t\n.temp 75\nV1 in 0 1\nR1 in a 1k\nC1 a 0 {1n*(1+2e-3*(temper-27))}\n.end\n")
    assert warned.element("c1").value == pytest.approx(1.096e-9)
    assert any("carries no current there" in d.message for d in warned.diagnostics)
    keyed = load("t\n.temp 75\nV1 in 0 1\nR1 in a 1k\nC1 a 0 C={1n*(1+2e-3*(temper-27))}\n.end\n")
    assert not any("carries no current" in d.message for d in keyed.diagnostics)


def test_a_dotted_model_version_is_text_as_ngspice_reads_it():
    """ngspice's BSIM models read version=4.8.1 as text; netdae read the number 4.8 and warned on every such card
    that '.1' was ignored."""
    from netdae.netlist import parse

    text = "t\nM1 d g 0 0 nm l=1u w=1u\n.model nm nmos level=14 version=4.8.1\n"
    assert parse(text).top.models["nm"].strings["version"][0] == "4.8.1"
    assert not [d for d in load(text).diagnostics if "ignored" in d.message]
    assert parse(text.replace("4.8.1", "4.5")).top.models["nm"].params["version"][0] == 4.5  # a number stays one
