""".ic, .nodeset, ic= and uic as ngspice honours them, against closed forms and ngspice."""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.analyses.tran import transient

RC = """RC with an initial condition
V1 in 0 1
R1 in out 1k
C1 out 0 1u {cic}
{cards}
.tran 10u 5m {uic}
.options reltol=1e-5
.end
"""
TAU = 1e-3


def rc(cic="", cards="", uic=""):
    return netdae.load(RC.format(cic=cic, cards=cards, uic=uic))


@pytest.mark.parametrize("variant", [
    {"cards": ".ic v(out)=2"},                      # held during the operating point
    {"cic": "ic=2", "uic": "uic"},                   # the capacitor's own initial voltage
    {"cards": ".ic v(out)=2", "uic": "uic"},        # uic with node values from .ic
])
def test_rc_relaxes_from_its_initial_condition(variant):
    r = transient(rc(**variant))
    t = r.t
    exact = 1.0 + (2.0 - 1.0) * np.exp(-t / TAU)
    # .ic holds the node through 1e10 S (ngspice's rule): the start is 2 V to about 1e-7
    assert r["v(out)"][0] == pytest.approx(2.0, abs=1e-6)
    assert np.max(np.abs(r["v(out)"] - exact)) < 1e-4


def test_ic_without_a_transient_does_not_change_the_operating_point():
    r = operating_point(rc(cards=".ic v(out)=2"))
    assert float(r["v(out)"][0]) == pytest.approx(1.0, rel=1e-12)


def test_nodeset_guides_newton_but_not_the_answer():
    with_ns = operating_point(rc(cards=".nodeset v(out)=0.3"))
    assert float(with_ns["v(out)"][0]) == pytest.approx(1.0, rel=1e-12)


def test_uic_without_ic_starts_every_capacitor_at_zero():
    r = transient(rc(uic="uic"))
    exact = 1.0 - np.exp(-r.t / TAU)
    assert r["v(out)"][0] == 0.0
    assert np.max(np.abs(r["v(out)"] - exact)) < 1e-4


def test_inductor_ic_with_uic():
    circuit = netdae.load("""RL with an initial current
R1 a 0 10
L1 a 0 10m ic=50m
.tran 10u 5m uic
.options reltol=1e-5
.end
""")
    r = transient(circuit)
    tau = 10e-3 / 10
    np.testing.assert_allclose(r["i(l1)"], 50e-3 * np.exp(-r.t / tau), atol=1e-6)
    # the resistor carries the inductor's current: v(a) = -R i(l1) from the first point on
    assert r["v(a)"][0] == pytest.approx(-10 * 50e-3, rel=1e-6)


@pytest.mark.ngspice
@pytest.mark.parametrize("variant", [
    {"cards": ".ic v(out)=2"},
    {"cic": "ic=2", "uic": "uic"},
])
def test_initial_conditions_agree_with_ngspice(variant):
    text = RC.format(cic=variant.get("cic", ""), cards=variant.get("cards", ""), uic=variant.get("uic", ""))
    comparison = netdae.compare(text, tol=1e-3, signals=["v(out)"])
    assert comparison.passed, comparison


ASTABLE = """relaxation oscillator: a switch with hysteresis discharges the capacitor it senses
V1 vcc 0 5
R1 vcc c 10k
C1 c 0 10n
S1 c d c 0 SHYST
RD d 0 100
.model SHYST SW(VT=2.5 VH=0.8 RON=1 ROFF=1G)
{tran}
.end
"""


def test_a_circuit_without_a_dc_operating_point_starts_as_with_uic():
    """The switch turns on above VT + VH = 3.3 V and off below 1.7 V. Off, the capacitor would settle at
    5 V; on, at 5 RON' / (R + RON') = 0.05 V: no DC state is consistent, so .op refuses, and the transient
    starts as ngspice's uic would (C1 at 0 V), saying why (ngspice starts from its optran state). Its
    waveform is the closed form: the first charge from 0 V reaches 3.3 V at RC ln(5/1.7), and the period
    is RC ln(3.3/1.7) + (R || RON') C ln((3.3 - V') / (1.7 - V')), RON' = RON + RD, V' = 5 RON' / (R + RON')."""
    with pytest.raises(netdae.ConvergenceError, match="did not converge"):
        operating_point(netdae.load(ASTABLE.format(tran=".op")))
    r = transient(netdae.load(ASTABLE.format(tran=".tran 1u 1m")))
    assert r.ok, r.message
    assert any(n.startswith("no DC operating point") and "starts as with uic" in n for n in r.notes), r.notes
    R, C, ron = 10e3, 10e-9, 101.0
    assert abs(r["v(c)"][0]) < 1e-12  # the uic charge: 0 V (to the consistency solve's rounding)
    t, v = np.asarray(r.t), np.asarray(r["v(c)"])

    def crossings(level, rising=True):
        k = np.flatnonzero((v[:-1] < level) & (v[1:] >= level)) if rising else \
            np.flatnonzero((v[:-1] > level) & (v[1:] <= level))
        return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])

    first = R * C * np.log(5.0 / 1.7)
    assert crossings(3.3 - 1e-6)[0] == pytest.approx(first, rel=1e-3)
    v_on, r_on = 5.0 * ron / (R + ron), R * ron / (R + ron)
    period = R * C * np.log(3.3 / 1.7) + r_on * C * np.log((3.3 - v_on) / (1.7 - v_on))
    periods = np.diff(crossings(2.5))
    assert periods.size >= 10
    np.testing.assert_allclose(periods, period, rtol=1e-3)


def test_pseudo_transient_continuation_recognises_the_astable_cycle():
    """The astable goes round in pseudo-time as in time: the continuation recognises the return to a
    point it left and gives the operating point up at once (it spent its whole budget, 20,041 Newton
    iterations, before: about 1.2 s of the 1.6 s the failing operating point took; now 2,226 in all)."""
    import re

    with pytest.raises(netdae.ConvergenceError) as err:
        operating_point(netdae.load(ASTABLE.format(tran=".op")))
    iterations = int(re.search(r"after (\d+) Newton iterations", str(err.value)).group(1))
    assert iterations < 5_000


def test_a_return_is_a_cycle_only_after_an_excursion():
    from netdae.dae.steady import PTRAN_CYCLE_MEMORY, _returned

    atol = np.full(2, 1e-6)
    ring = np.empty((PTRAN_CYCLE_MEMORY, 2))
    path = [np.array([0.0, 1.0]), np.array([1.0, 0.5]), np.array([2.0, 0.0]), np.array([1.0, -0.5]),
            np.array([0.5, 0.2]), np.array([0.2, 0.6])]
    for k, p in enumerate(path):
        ring[k] = p
    assert _returned(ring, len(path), np.array([0.0, 1.0]), 1e-3, atol)  # back at the first point
    assert not _returned(ring, len(path), np.array([5.0, 5.0]), 1e-3, atol)  # somewhere new
    # a path converging to its steady state comes close to recent points only, never back after an excursion
    steady = np.empty((PTRAN_CYCLE_MEMORY, 2))
    for k in range(10):
        steady[k] = [1.0 + 0.5 ** k, 0.0]
    assert not _returned(steady, 10, np.array([1.0 + 0.5 ** 10, 0.0]), 1e-3, atol)


#: A 555-style astable: comparators at 1/3 and 2/3 of the supply set and reset a latch node held by a
#: capacitor and two clamps; the latch's output discharges the timing capacitor through a switch. No DC
#: state is consistent (the capacitor open: discharge on pulls th low and sets the latch, discharge off lets
#: th rise to the supply and resets it).
ASTABLE_555 = """555-style astable from behavioural sources
VCC vcc 0 DC 5
RA vcc dis 1k
RB dis th 10k
C1 th 0 10n
BQ q 0 V = V(qs) > 2.5 ? 5 : 0
RQS qs 0 1MEG
BSET 0 qs I = (V(th) < 1.6667 ? 1e-3 : 0) - (V(th) > 3.3333 ? 1e-3 : 0)
CQS qs 0 1n
DQ1 qs vcc DCLAMP
DQ2 0 qs DCLAMP
S1 dis 0 qn 0 SDIS
BQN qn 0 V = 5 - V(q)
.model SDIS SW(VT=2.5 VH=0.2 RON=10 ROFF=1G)
.model DCLAMP D(IS=1e-14)
{tran}
.end
"""


def test_pseudo_transient_continuation_recognises_a_sustained_oscillation():
    """The 555's pseudo-time trajectory never comes back within tolerance of a point it left (the
    pseudo-time step grows from turn to turn), so the continuation spent its budget: 17,897 Newton
    iterations, 3.7 s, before the transient started as with uic (ngspice gives its operating point up
    in 10 ms). The threshold node turns back after every swing between the comparators' levels: eight
    such turns end it (2,280 iterations in all, with a pseudo-time step cut after 15 iterations instead
    of 50). The transient then oscillates with the RC period."""
    import re

    with pytest.raises(netdae.ConvergenceError) as err:
        operating_point(netdae.load(ASTABLE_555.format(tran=".op")))
    iterations = int(re.search(r"after (\d+) Newton iterations", str(err.value)).group(1))
    assert iterations < 5_000
    r = transient(netdae.load(ASTABLE_555.format(tran=".tran 1u 1m")))
    assert r.ok, r.message
    t, v = np.asarray(r.t), np.asarray(r["v(th)"])
    up = t[np.flatnonzero((v[:-1] < 2.5) & (v[1:] >= 2.5))]
    # charging through RA + RB from 1/3 to 2/3 of the supply, discharging through RB (+ RON) to 1/3
    period = (11e3 * np.log(2.0) + 10.01e3 * np.log(2.0)) * 10e-9
    np.testing.assert_allclose(np.diff(up)[1:], period, rtol=2e-2)


def test_swings_that_do_not_decay_are_a_cycle_and_a_ringing_is_not():
    from netdae.dae.steady import PTRAN_SWING_REVERSALS, _Swings

    atol = np.full(2, 1e-6)
    # a triangle wave between 1.6 and 3.4 on the first unknown, a constant second
    wave = [np.array([1.6 + 1.8 * abs(((k / 6.0) % 2.0) - 1.0), 5.0]) for k in range(200)]
    sw = _Swings(wave[0], 1e-3, atol)
    turned_at = None
    for k, x in enumerate(wave[1:], 1):
        sw.add(x)
        if sw.cycling():
            turned_at = k
            break
    assert turned_at is not None and turned_at < 6 * (PTRAN_SWING_REVERSALS + 2)
    # a ringing that halves each half-period, and a monotone approach: not cycles
    for path in ([np.array([2.0 + 2.0 * (-0.5) ** k, 1.0]) for k in range(60)],
                 [np.array([3.0 - 2.0 * 0.8 ** k, 1.0 + k]) for k in range(60)]):
        sw = _Swings(path[0], 1e-3, atol)
        for x in path[1:]:
            sw.add(x)
            assert not sw.cycling()


def test_uic_starts_a_junction_behind_a_series_resistance_from_its_terminals_ic():
    """ngspice takes a device's initial junction voltages from its terminals' .ic under uic (BJTgetic, DIOgetic):
    a BJT with rb started its internal base at 0 V, reset .ic v(b)=0.8 V ('no capacitor alone holds v(b)') and its
    collector rose to 3.7 V in 2 ns; ngspice 39 (same netlist): v(c) = 1.840252e-02 V at 10 ps, 1.847977e-02 V at
    100 ps, v(b) = 8.004204e-01 V at 10 ps."""
    text = ("BJT junction states from node .ic under uic\nVcc vcc 0 5\nRc vcc c 1k\nRb vcc b 47k\nQ1 c b 0 qn\n"
            ".model qn npn is=1e-14 bf=100 cje=5p cjc=2p tf=0.3n rb=10\n.ic v(b)=0.8 v(c)=0.1\n.tran 1p 2n uic\n.end\n")
    r = netdae.simulate(text, save=["v(c)", "v(b)"])
    assert r.ok, r.message
    d = r.dense([10e-12, 100e-12])
    np.testing.assert_allclose(d["v(c)"], [1.840252e-02, 1.847977e-02], rtol=1e-4)
    assert d["v(b)"][0] == pytest.approx(8.004204e-01, rel=1e-5)


def test_uic_starts_a_bjts_junctions_at_its_own_initial_conditions():
    """Q1 ... ic=0.8,0.1 (icvbe, icvce) under uic, no .ic: ngspice 39 starts the junctions there (BJTicVBE,
    BJTicVCE), v(c) = 1.840252e-02 V at 10 ps and v(b) = 8.004204e-01 V; netdae noted 'not used' and started from
    0 V. A diode's ic changes no waveform of ngspice 39 (v(k) stays 0): it stays noted as not used."""
    text = ("BJT junction states from its ic= under uic\nVcc vcc 0 5\nRc vcc c 1k\nRb vcc b 47k\nQ1 c b 0 qn ic=0.8,0.1\n"
            ".model qn npn is=1e-14 bf=100 cje=5p cjc=2p tf=0.3n rb=10\n.tran 1p 2n uic\n.end\n")
    r = netdae.simulate(text, save=["v(c)", "v(b)"])
    d = r.dense([10e-12, 100e-12])
    np.testing.assert_allclose(d["v(c)"], [1.840252e-02, 1.847977e-02], rtol=1e-4)
    assert d["v(b)"][0] == pytest.approx(8.004204e-01, rel=1e-5)
    assert not [n for n in r.notes if "are not used" in n]
    diode = ("diode ic under uic\nV1 a 0 0\nR1 a k 1k\nD1 k 0 dm ic=0.7\nC1 k 0 1n\n"
             ".model dm d is=1e-14 cjo=10p tt=10n\n.tran 0.1n 50n uic\n.end\n")
    r = netdae.simulate(diode, save=["v(k)"])
    assert np.max(np.abs(r["v(k)"])) < 1e-9
    assert any("device initial conditions of d1 are not used" in n for n in r.notes)


def test_uic_starts_a_level_1_mosfet_at_its_own_initial_conditions():
    """M1 ... ic=3,1 (icvds, icvgs) under uic: ngspice 39 starts the drain and gate there (without ic=: v(d) =
    0.5152 V at 1 ns); ngspice (same netlist): v(d) = 3.359612 V and v(g) = 1.199295 V at 1 ns, v(d) = 4.329421 V
    at 50 ns (its trapezoidal rule's error at the default tolerance is a few 1e-4 of these)."""
    text = ("mos ic under uic\nVd vdd 0 5\nR2 vdd d 10k\nRg vdd g 1meg\nM1 d g 0 0 mm ic=3,1\n"
            ".model mm nmos level=1 vto=0.7 kp=50u cgso=1n cgdo=1n cbd=1p cbs=1p\n.tran 1n 100n uic\n.end\n")
    r = netdae.simulate(text, save=["v(d)", "v(g)"])
    d = r.dense([1e-9, 50e-9])
    np.testing.assert_allclose(d["v(d)"], [3.359612, 4.329421], rtol=1e-3)
    assert d["v(g)"][0] == pytest.approx(1.199295, rel=1e-3)
    assert not [n for n in r.notes if "are not used" in n]


def test_an_initial_value_of_ground_is_ignored_with_a_warning_as_ngspice_ignores_it():
    """.ic v(0)=2 was refused as an 'unknown node '0'' with the hint about hierarchical names; a subcircuit's .ic
    of a port its instance grounds was dropped without a word. ngspice 39 ignores both (v(b) starts at 0.5 there
    too)."""
    import netdae

    text = ("t\n.subckt s p q\nR1 p q 1k\nC1 p q 1n\n.ic v(q)=1 v(p)=0.5\n.ends\nV1 a 0 1\nR9 a b 1k\nX1 b 0 s\n"
            ".ic v(gnd)=2\n.tran 1u 10u\n.end\n")
    c = netdae.load(text)
    warnings = [(d.location.line, d.location.column, d.message) for d in c.diagnostics if d.severity == "warning"]
    assert warnings == [
        (10, 7, ".ic v(0): the ground node is always 0 V: the entry is ignored, as ngspice 39 ignores it"),
        (5, 7, ".ic v(q): the instance connects this node to ground, always 0 V: the entry is ignored, as ngspice "
               "39 ignores it")]
    assert c.ic == {"b": 0.5}
    assert netdae.run(c)[0]["v(b)"][0] == 0.5
