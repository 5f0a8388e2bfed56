"""Voltage- and current-controlled switches (S, W): syntax, errors, ngspice's states, events.

The closed forms: a switch between a divider and an RC load gives the on and
off divider values at the operating point and, in a transient, exponentials
whose time constants follow the switch's resistance; a triangle or sine
control switches at the instants where it crosses VT + VH (on) and VT - VH
(off), which the integrator locates on its interpolant (the solution jumps
there: its two values are recorded at the instant).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.analyses.tran import transient
from netdae.errors import NetlistError
from netdae.mna import MODE_TRAN, assemble
from netdae.netlist import load

# --- syntax ------------------------------------------------------------------------------------


def test_s_and_w_cards_are_read():
    c = load("t\nV1 c 0 1\nVs x 0 0\nR1 a x 1k\nS1 a 0 c 0 smod ON\nW1 a 0 vs wmod\nW2 a 0 vs wmod off\n"
             ".model smod sw vt=0.5 vh=0.1 ron=2 roff=1meg\n.model wmod csw(it=1m ih=0.1m)\n")
    s1, w1, w2 = c.element("s1"), c.element("w1"), c.element("w2")
    assert (s1.kind, s1.nodes, s1.model, s1.params) == ("vswitch", ("a", "0", "c", "0"), "smod", {"on": 1.0})
    assert (w1.kind, w1.nodes, w1.controls, w1.model, w1.params) == ("cswitch", ("a", "0"), ("vs",), "wmod", {})
    assert w2.params == {"off": 1.0}
    assert c.models["smod"].params == {"vt": 0.5, "vh": 0.1, "ron": 2.0, "roff": 1e6}


def test_switches_inside_subcircuits_name_their_controls_hierarchically():
    c = load("t\n.subckt cell a\nVs a m 0\nR1 m 0 1k\nW1 a 0 vs wm\n.model wm csw it=1m\n.ends\nX1 n cell\n"
             "V1 n 0 1\n")
    w = c.element("w.x1.w1")
    assert (w.nodes, w.controls, w.model) == (("n", "0"), ("v.x1.vs",), "x1:wm")


def _column(text: str, line: int, token: str, occurrence: int = 1) -> int:
    row = text.split("\n")[line - 1]
    at = -1
    for _ in range(occurrence):
        at = row.index(token, at + 1)
    return at + 1


# (netlist, message regex, line, the text the column must point at [, occurrence])
ERRORS = [
    ("t\nS1 a b c\n", r"s1: expected 4 nodes and a model name", 2, None),
    ("t\nS1 a b c d\n", r"s1: expected 4 nodes and a model name", 2, None),
    ("t\nW1 a b\n", r"w1: expected 2 nodes, the controlling source's name and a model name", 2, None),
    ("t\nW1 a b 0 wm\n.model wm csw\n", r"w1: expected the name of the controlling source, found '0'", 2, "0 wm"),
    ("t\nS1 a b c d 1k\n", r"s1: expected a model name, found '1k'", 2, "1k"),
    ("t\nS1 a b c d sm on off\n.model sm sw\n", r"'off' after 'on': give ON or OFF once", 2, "off"),
    ("t\nS1 a b c d sm big\n.model sm sw\n", r"s1: unexpected 'big'", 2, "big"),
    ("t\nS1 a b c d sm ron=1\n.model sm sw\n", r"s1: unexpected parameter 'ron'", 2, "ron"),
    ("t\nV1 c 0 1\nS1 a 0 c 0 nosuch\n", r"s1: undefined model 'nosuch'", 3, "nosuch"),
    ("t\nV1 c 0 1\nS1 a 0 c 0 dm\n.model dm d\n",
     r"model 'dm' is of type 'd', a voltage-controlled switch needs sw", 3, "dm"),
    ("t\nVs c 0 1\nW1 a 0 vs sm\n.model sm sw\n",
     r"model 'sm' is of type 'sw', a current-controlled switch needs csw", 3, "sm"),
    ("t\nR9 c 0 1\nW1 a 0 r9 wm\n.model wm csw\n", r"'r9' is a resistor, which has no branch current", 3, "r9"),
    ("t\nW1 a 0 vx wm\n.model wm csw\n", r"'vx' names no element", 2, "vx"),
    ("t\nV1 c 0 1\nS1 a 0 c 0 sm\n.model sm sw gon=1\n", r"'gon' is an output of ngspice's vswitch model", 4, "1"),
]


@pytest.mark.parametrize("case", ERRORS, ids=lambda c: c[1][:40])
def test_bad_switch_cards_are_located_errors(case):
    text, pattern, line, token, *occ = case
    with pytest.raises(NetlistError) as exc:
        load(text)
    err = exc.value
    assert __import__("re").search(pattern, err.message), err.message
    assert (err.location.file, err.location.line) == ("<string>", line), str(err)
    if token is not None:
        assert err.location.column == _column(text, line, token, *occ), str(err)
    assert err.expected


@pytest.mark.parametrize("card, name", [("ron=0", "ron"), ("roff=-1", "roff"), ("ron={1-1}", "ron")])
def test_impossible_resistances_are_located_errors(card, name):
    text = f"t\nV1 c 0 1\nR1 c a 1k\nS1 a 0 c 0 sm\n.model sm sw vt=0.5 {card}\n.op\n"
    with pytest.raises(NetlistError) as exc:
        netdae.run(text)
    err = exc.value
    assert f"{name}=" in err.message and "must be > 0" in err.message
    assert err.location.line == 5 and err.location.column == text.split("\n")[4].index(card) + len(name) + 2
    assert err.hint


def test_unknown_model_parameters_are_ignored_with_a_warning_as_ngspice_does():
    c = load("t\nV1 c 0 1\nR1 c a 1k\nS1 a 0 c 0 sm\n.model sm sw vt=0.5 level=2 vceo=3\n")
    warned = [d.message for d in c.diagnostics if d.severity == "warning"]
    assert any("'level'" in w and "vswitch" in w for w in warned)
    assert any("'vceo'" in w for w in warned)


def test_check_reads_switches(tmp_path, capsys):
    from netdae.cli import main as cli_main

    path = tmp_path / "sw.cir"
    path.write_text("t\nV1 c 0 1\nR1 c a 1k\nS1 a 0 c 0 sm\n.model sm sw vt=0.5\n.op\n.end\n")
    assert cli_main(["check", str(path)]) == 0


# --- operating point: the divider in each state ---------------------------------------------------

DIVIDER = """switch divider
V1 c 0 {vc}
V2 a 0 1
R1 a b 1k
S1 b 0 c 0 smod {flag}
.model smod sw vt=0.5 vh={vh} ron=1 roff=1meg
.op
.end
"""
ON, OFF = 1.0 / 1001.0, 1e6 / (1e6 + 1e3)


@pytest.mark.parametrize("vh, flag, vc, expected", [
    (0.2, "", 0.0, OFF), (0.2, "", 1.0, ON),
    # inside the band [0.3, 0.7] the flag decides (no flag: off)
    (0.2, "ON", 0.5, ON), (0.2, "OFF", 0.5, OFF), (0.2, "", 0.5, OFF),
    # VH <= 0: inside the band ngspice's reference state is REALLY_OFF, which the band reverses: on
    (-0.2, "OFF", 0.5, ON), (-0.2, "ON", 0.5, ON), (0.0, "OFF", 0.5, ON), (-0.2, "", 0.2, OFF),
    (-0.2, "ON", 0.8, ON),
])
def test_operating_point_states_are_ngspices(vh, flag, vc, expected):
    r = operating_point(load(DIVIDER.format(vh=vh, flag=flag, vc=vc)))
    assert r["v(b)"][0] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("ih, flag, ic, expected", [
    (0.2e-3, "", 2e-3, ON), (0.2e-3, "", 0.0, OFF),
    # W: inside the band the reference is REALLY_OFF whatever the flag (ngspice 39's cswload.c)
    (0.2e-3, "ON", 1e-3, OFF), (-0.2e-3, "OFF", 1e-3, ON), (0.0, "", 1e-3, ON),
])
def test_w_operating_point_states_are_ngspices(ih, flag, ic, expected):
    text = (f"w divider\nI1 0 c {ic}\nVs c 0 0\nV2 a 0 1\nR1 a b 1k\nW1 b 0 Vs wmod {flag}\n"
            f".model wmod csw it=1m ih={ih} ron=1 roff=1meg\n.op\n")
    r = operating_point(load(text))
    assert r["v(b)"][0] == pytest.approx(expected, rel=1e-9)


def test_default_resistances_are_one_ohm_and_one_over_gmin():
    text = "t\nV1 c 0 {vc}\nV2 a 0 1\nR1 a b 1k\nS1 b 0 c 0 smod\n.model smod sw\n.op\n"
    on = operating_point(load(text.replace("{vc}", "1")))["v(b)"][0]
    off = operating_point(load(text.replace("{vc}", "-1")))["v(b)"][0]
    assert on == pytest.approx(1.0 / 1001.0, rel=1e-12)
    assert off == pytest.approx(1e12 / (1e12 + 1e3), rel=1e-12)
    off2 = operating_point(load(text.replace("{vc}", "-1") + ".options gmin=1e-9\n"))["v(b)"][0]
    assert off2 == pytest.approx(1e9 / (1e9 + 1e3), rel=1e-12)


def test_a_switch_is_a_controlled_resistive_branch_of_the_topology():
    from netdae.topology.graph import RESISTIVE, build_graph

    c = load("t\nV1 c 0 1\nVs x 0 0\nR1 a x 1k\nS1 a 0 c 0 sm\nW1 a x vs wm\n.model sm sw\n.model wm csw\n")
    g = build_graph(c)
    for name in ("s1", "w1"):
        k = g.element_names.index(name)
        branches = np.flatnonzero(g.element == k)
        assert branches.size == 1 and g.cls[branches[0]] == RESISTIVE and g.controlled[branches[0]]
    # S's control terminals are attachments (they carry no current), W has none
    s1 = g.element_names.index("s1")
    assert sorted(g.node_names[i] for i in g.attach_node[g.attach_element == s1]) == ["0", "c"]


# --- transient: closed forms --------------------------------------------------------------------

RC = """switch into an RC load
V1 c 0 PULSE(0 1 1m 1u 1u 2m 4m)
V2 a 0 1
R1 a b 1k
S1 b out c 0 smod
C1 out 0 1u
R2 out 0 1k
.model smod sw vt=0.5 ron=1 roff=1e12
.tran 10u 5m
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_rc_load_follows_the_switch_time_constants(engine, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = transient(load(RC))
    assert r.ok
    # the control ramps 0 -> 1 in 1 us from 1 ms and back from 3.001 ms: it crosses vt = 0.5 at
    t_on, t_off = 1e-3 + 0.5e-6, 3.001e-3 + 0.5e-6
    assert r.transient.events == [(pytest.approx(t_on, rel=1e-12), ["s1"]), (pytest.approx(t_off, rel=1e-12), ["s1"])]
    assert [t for t, _ in r.transient.jumps] == [t for t, _ in r.transient.events]  # v(b) jumps at each
    assert r.stats["integrator"]["events"] == 2
    v_inf = 1000.0 / 2001.0
    tau_on = 1e-6 * (1001.0 * 1000.0 / 2001.0)
    tau_off = 1e-6 * 1000.0
    t = np.linspace(0.0, 5e-3, 2001)
    v_on = v_inf * (1.0 - np.exp(-(np.minimum(t, t_off) - t_on) / tau_on))
    exact = np.where(t <= t_on, 0.0, np.where(t <= t_off, v_on, v_on * np.exp(-(t - t_off) / tau_off)))
    got = r.dense(t)["v(out)"]
    assert np.max(np.abs(got - exact)) < 2e-4 * v_inf
    # before the switch closes the load sees the off resistance only
    assert abs(float(r.dense(0.9e-3)["v(out)"][0]) - 1000.0 / (1e12 + 2000.0)) < 1e-12
    # v(b) jumps from the open circuit's 1 V to the closed switch's divider, both values recorded at t_on
    at = np.flatnonzero(np.abs(r.axes["time"] - t_on) <= 1e-12 * t_on)  # located on the interpolant
    assert at.size == 2 and r.axes["time"][at[0]] == r.axes["time"][at[1]]
    vb = r.signals["v(b)"][at]
    assert vb[0] == pytest.approx(1.0, rel=1e-6) and vb[1] < 0.01


def _instants(r) -> list[float]:
    """The switching instants of a transient."""
    return [t for t, _ in r.transient.events]


TRIANGLE = """hysteresis on a triangle
V1 c 0 PWL(0 0 2m 1 4m 0 6m 1 8m 0)
V2 a 0 1
R1 a b 1k
S1 b 0 c 0 smod
R2 b 0 1meg
.model smod sw vt=0.5 vh={vh} ron=1 roff=1e9
.tran 10u 8m
.end
"""


def test_hysteresis_switches_at_vt_plus_and_minus_vh_on_a_triangle():
    r = transient(load(TRIANGLE.format(vh=0.2)))
    assert r.ok
    # the control rises 0.5 V/ms: on at 0.7 V (1.4 ms, 5.4 ms), off at 0.3 V on the way down (3.4 ms, 7.4 ms);
    # a step that ends on the threshold puts the event EVENT_MIN_GAP of the next step later (1e-11 s)
    assert _instants(r) == pytest.approx([1.4e-3, 3.4e-3, 5.4e-3, 7.4e-3], rel=0, abs=2e-11)
    vb = lambda t: float(r.dense(t)["v(b)"][0])  # noqa: E731
    assert vb(1.3e-3) > 0.99 and vb(1.5e-3) < 2e-3 and vb(3.3e-3) < 2e-3 and vb(3.5e-3) > 0.99
    # between the thresholds the state holds: at 0.5 V it is off rising and on falling
    assert vb(1.0e-3) > 0.99 and vb(3.0e-3) < 2e-3


def test_negative_hysteresis_reverses_the_state_entering_the_band():
    # VH = -0.2: on entering the band [0.3, 0.7] from below (0.3 V rising: 0.6 ms), off entering it from
    # above (0.7 V falling: 2.6 ms); leaving it changes nothing
    r = transient(load(TRIANGLE.format(vh=-0.2)))
    assert r.ok
    assert _instants(r) == pytest.approx([0.6e-3, 2.6e-3, 4.6e-3, 6.6e-3], rel=0, abs=2e-11)
    vb = lambda t: float(r.dense(t)["v(b)"][0])  # noqa: E731
    assert vb(0.5e-3) > 0.99 and vb(0.7e-3) < 2e-3 and vb(1.9e-3) < 2e-3 and vb(2.7e-3) > 0.99


def test_hysteresis_on_a_sine_switches_at_its_analytic_crossings():
    text = ("sine control\nV1 c 0 SIN(0 1 1k)\nV2 a 0 1\nR1 a b 1k\nS1 b 0 c 0 smod\nC1 b 0 10n\n"
            ".model smod sw vt=0.2 vh=0.3 ron=10 roff=1e9\n.tran 1u 2m\n.end\n")
    r = transient(load(text))
    assert r.ok
    w = 2 * math.pi * 1e3
    on = math.asin(0.5) / w                 # sin rises through 0.5
    off = (math.pi - math.asin(-0.1)) / w   # sin falls through -0.1
    expected = [on, off, on + 1e-3, off + 1e-3]
    assert _instants(r) == pytest.approx(expected, rel=1e-6)


def test_w_switch_follows_a_source_current():
    text = ("current control\nI1 0 c PWL(0 0 2m 2m 4m 0)\nVs c 0 0\nV2 a 0 1\nR1 a b 1k\nW1 b 0 Vs wmod\n"
            "C1 b 0 100n\n.model wmod csw it=1m ih=0.2m ron=1 roff=1e9\n.tran 10u 4m\n.end\n")
    r = transient(load(text))
    assert r.ok
    # i(vs) = the source's 1 mA/ms ramps: on above 1.2 mA (1.2 ms), off below 0.8 mA (3.2 ms)
    assert _instants(r) == pytest.approx([1.2e-3, 3.2e-3], rel=0, abs=2e-11)
    vb = lambda t: float(r.dense(t)["v(b)"][0])  # noqa: E731
    # the 100 nF capacitor discharges through RON and recharges through R1 (tau = 100 us)
    assert vb(1.19e-3) > 0.99 and vb(1.3e-3) < 2e-3
    assert vb(3.2e-3 + 300e-6) == pytest.approx(1.0 - math.exp(-3.0), abs=2e-3)


RELAXATION = """relaxation oscillator
V1 vdd 0 5
R1 vdd a 1k
C1 a 0 1u
S1 a d a 0 smod
R2 d 0 100
.model smod sw vt=2 vh=1 ron=1 roff=1e9
.ic v(a)=0
.tran 10u 10m
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_switch_controlled_by_its_own_node_oscillates_with_the_analytic_period(engine, monkeypatch):
    # C1 charges through R1 towards 5 V until v(a) = 3 V (VT + VH), then S1 discharges it through
    # RON + R2 until v(a) = 1 V (VT - VH): the events are where the solution itself crosses the thresholds
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = transient(load(RELAXATION))
    assert r.ok
    events = np.array(_instants(r))
    assert [w for _, w in r.transient.events] == [["s1"]] * events.size
    tau, r_th = 1e-3, 1000.0 * 101.0 / 1101.0
    v_low = 5.0 * 101.0 / 1101.0
    first = tau * math.log(5.0 / 2.0)
    charge = tau * math.log(4.0 / 2.0)
    discharge = 1e-6 * r_th * math.log((3.0 - v_low) / (1.0 - v_low))
    assert events[0] == pytest.approx(first, rel=1e-6)
    assert np.diff(events)[0::2] == pytest.approx(np.full((events.size) // 2, discharge), rel=1e-3)
    assert np.diff(events)[1::2] == pytest.approx(np.full((events.size - 1) // 2, charge), rel=1e-3)
    # at each event the control is on its threshold
    va = np.asarray(r.dense(events)["v(a)"])
    assert va[0::2] == pytest.approx(3.0, abs=1e-6) and va[1::2] == pytest.approx(1.0, abs=1e-6)


def test_engines_agree_on_switching_and_step_counts(monkeypatch):
    text = TRIANGLE.format(vh=0.2).replace("R2 b 0 1meg", "R2 b 0 1meg\nC1 b 0 10n")
    runs = {}
    for engine in ("compiled", "python"):
        monkeypatch.setenv("NETDAE_ENGINE", engine)
        runs[engine] = transient(load(text))
    comp, ref = runs["compiled"], runs["python"]
    assert comp.stats["integrator"]["engine"] == "compiled"
    assert _instants(comp) == _instants(ref)
    assert comp.stats["steps"] == ref.stats["steps"]
    t = np.linspace(0.0, 8e-3, 801)
    np.testing.assert_allclose(comp.dense(t)["v(b)"], ref.dense(t)["v(b)"], atol=1e-9)


def test_the_integration_releases_the_switch_states():
    system = assemble(load(RC), mode=MODE_TRAN, tstep=1e-5, tstop=5e-3)
    from netdae.dae.bdf import integrate

    integrate(system, (0.0, 5e-3), np.zeros(system.n), max_step=1e-5)
    assert system.switching.family.held is None


def test_dc_sweeps_carry_the_states_from_point_to_point():
    # as ngspice: each point starts from the previous point's states, so sweeping the control down
    # keeps the switch on inside the band [0.3, 0.7] (S with VH > 0, and W), and a negative hysteresis
    # turns it off where the control enters the band from above
    base = ("dc hysteresis\nV1 c 0 0\nI1 0 d 0\nVs d 0 0\nV2 a 0 1\nR1 a b 1k\nS1 b 0 c 0 smod\n"
            "R3 a e 1k\nW1 e 0 vs wmod\n.model smod sw vt=0.5 vh={vh} ron=1 roff=1meg\n"
            ".model wmod csw it=0.5m ih=0.2m ron=1 roff=1meg\n{cards}\n.end\n")
    on = lambda v: v < 0.01  # noqa: E731
    # (the sweeps' points 0.01, 0.05, ... 0.97 miss the thresholds 0.3 and 0.7)
    (up, down) = netdae.run(base.format(vh=0.2, cards=".dc V1 0.01 0.97 0.04\n.dc V1 0.97 0.01 -0.04"))
    assert [on(v) for v in up["v(b)"]] == [c > 0.7 for c in up.axes["v1"]]
    assert [on(v) for v in down["v(b)"]] == [c > 0.3 for c in down.axes["v1"]]
    (neg,) = netdae.run(base.format(vh=-0.2, cards=".dc V1 0.97 0.01 -0.04"))
    assert [on(v) for v in neg["v(b)"]] == [c > 0.7 for c in neg.axes["v1"]]
    (w_down,) = netdae.run(base.format(vh=0.2, cards=".dc I1 0.97m 0.01m -0.04m"))
    assert [on(v) for v in w_down["v(e)"]] == [i > 0.3e-3 for i in w_down.axes["i1"]]


# --- against ngspice -------------------------------------------------------------------------------


@pytest.mark.ngspice
@pytest.mark.parametrize("vh, flag, vc", [(0.2, "", 0.5), (0.2, "ON", 0.5), (-0.2, "OFF", 0.5), (0.0, "", 0.5),
                                          (0.2, "", 1.0), (-0.2, "ON", 0.1)])
def test_operating_points_agree_with_ngspice(vh, flag, vc):
    from netdae.ngspice import run_ngspice

    text = DIVIDER.format(vh=vh, flag=flag, vc=vc)
    ref = run_ngspice(text).result("op")
    ours = operating_point(load(text))
    assert ours["v(b)"][0] == pytest.approx(float(ref["v(b)"][0]), rel=1e-6)


@pytest.mark.ngspice
def test_dc_sweep_hysteresis_agrees_with_ngspice():
    from netdae.ngspice import run_ngspice

    text = DIVIDER.format(vh=0.2, flag="", vc=0).replace(".op", ".dc V1 1 0 -0.04")
    ref = run_ngspice(text).result("dc")
    (ours,) = netdae.run(text)
    np.testing.assert_allclose(ours["v(b)"], np.asarray(ref["v(b)"]), rtol=1e-6)


@pytest.mark.ngspice
def test_rc_switch_agrees_with_ngspice():
    from netdae.comparison import compare

    result = compare(RC)
    assert result.ngspice_error is None
    item = result.analysis("tran", 0)
    assert item.passed, [(s.name, s.max_rel) for s in item.signals]
    assert max(s.max_rel for s in item.signals) < 1e-3


@pytest.mark.ngspice
def test_boost_converter_edges_agree_with_ngspice_to_its_step(netlists_dir):
    """The switch node's edges: netdae's at the located crossings, ngspice's within the step that crosses.

    ngspice decides a switch at the end of each step and applies the new state over the whole
    step, so its edge lies anywhere in the step whose end first finds the control past the
    threshold; netdae's starts at the crossing itself (the gate's analytic threshold time).
    """
    from netdae.ngspice import run_ngspice

    text = (netlists_dir / "boost_converter.cir").read_text().replace(".save v(out) i(l1) v(gate)", ".save v(sw)")
    (ours,) = netdae.run(text)
    ref = run_ngspice(text).result("tran")
    t_ng, v_ng = np.asarray(ref.t), np.asarray(ref["v(sw)"])
    # the gate crosses 3 V rising 6 ns after each period starts, 2 V falling 5.016 us after it
    on = [k * 1e-5 + 6e-9 for k in range(40)]
    off = [k * 1e-5 + 5.016e-6 for k in range(40)]
    events = [t for t, _ in ours.transient.events]
    assert events == pytest.approx(sorted(on + off), rel=0, abs=1e-15)
    for t_sw in off[1:]:
        k = int(np.searchsorted(t_ng, t_sw))  # ngspice's first point at or after the crossing
        low, high = v_ng[k - 1], v_ng[k + 3]
        assert low < 0.5 and high > 4.0
        assert v_ng[k] > 0.5 * (low + high)  # switched over the whole step [t_ng[k-1], t_ng[k]]
        assert t_ng[k] - t_ng[k - 1] < 0.5e-9  # its switching instant is uncertain by that step
        # netdae: still on the switch's side at the crossing, then the 0.2 ns edge
        at = ours.dense([t_sw - 1e-12, t_sw + 0.5e-9])["v(sw)"]
        assert at[0] < 0.5 and abs(at[1] - high) < 0.05 * high


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_chattering_switch_stops_the_run_with_a_message(engine, monkeypatch):
    # without hysteresis the switch's own closing pulls its control back below VT: a sliding mode
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = transient(load(RELAXATION.replace("vt=2 vh=1", "vt=2 vh=0")))
    assert not r.ok
    assert "switch s1 chatters" in r.message and "VH > 0" in r.message
    assert r.transient.failure.t == pytest.approx(transient_first_crossing(), rel=1e-3)
    assert r.stats["integrator"]["events"] < 200


def transient_first_crossing() -> float:
    """When the relaxation oscillator's capacitor first reaches 2 V (VT), charging from 0 towards 5 V."""
    return 1e-3 * math.log(5.0 / 3.0)
