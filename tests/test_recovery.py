"""Recovery of the compiled transient where bipolar gates switch and where a restart's probes need new pivots.

Two failures of ngspice's public examples, each on a small circuit of the same kind:

- A one-bit full adder of nine bipolar NAND gates (the gate of ngspice's 4-bit adder,
  ``examples/digital/compare/adder_bip.cir``). In each gate's output stage Q4's internal base,
  its emitter and its collector are joined only by the junction capacitances: their common
  mode has no capacitance and is fixed by the balance of the currents into the group. An
  iterate accepted after one Newton correction on a contraction rate carried from earlier
  steps left that balance 2 mA off (the stale Jacobian's correction, diluted by the RMS over
  the other unknowns, passed); on the 4-bit adder the error grows until Newton fails on every
  step size. The corrector's check of an iterate accepted with a Jacobian from an earlier step
  (docs/integrator.md, "Newton and the sparse LU") takes it to 1.6 mA, not below 1 mA: a known
  limitation (docs/integrator.md, "Known limitations"), its test here an expected failure.
- CMOS inverters into two coupled lossy lines (as ``examples/TransmissionLines/cpl2_2_line.sp``):
  at a restart two probes of very different steps needed different pivot orders and took
  turns asking for them ("no step after 51 restarts"). A restart now resumes with the probe
  that asked (docs/integrator.md, "Impasse points").
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import netdae
from netdae.mna import assemble
from netdae.netlist import load

ngspice = pytest.mark.skipif(shutil.which("ngspice") is None, reason="ngspice is not installed")

NAND_ADDER = """one-bit full adder of bipolar NAND gates
.SUBCKT NAND 1 2 3 4
Q1 9 5 1 QMOD
D1CLAMP 0 1 DMOD
Q2 9 5 2 QMOD
D2CLAMP 0 2 DMOD
RB 4 5 4K
R1 4 6 1.6K
Q3 6 9 8 QMOD
R2 8 0 1K
RC 4 7 130
Q4 7 6 10 QMOD
DVBEDROP 10 3 DMOD
Q5 3 8 0 QMOD
.ENDS NAND
.SUBCKT ONEBIT 1 2 3 4 5 6
X1 1 2 7 6 NAND
X2 1 7 8 6 NAND
X3 2 7 9 6 NAND
X4 8 9 10 6 NAND
X5 3 10 11 6 NAND
X6 3 11 12 6 NAND
X7 10 11 13 6 NAND
X8 12 13 4 6 NAND
X9 11 7 5 6 NAND
.ENDS ONEBIT
.MODEL DMOD D
.MODEL QMOD NPN(BF=75 RB=100 CJE=1PF CJC=3PF)
VCC 99 0 DC 5V
VA 1 0 PULSE(0 3 0 10NS 10NS 10NS 50NS)
VB 2 0 PULSE(0 3 0 10NS 10NS 20NS 100NS)
VC 3 0 PULSE(0 3 0 10NS 10NS 40NS 200NS)
X1 1 2 3 4 5 99 ONEBIT
RS 4 0 1K
RCO 5 0 1K
.TRAN 1NS 400NS
.END
"""

LINES = """CMOS inverters into two coupled lossy lines, capacitive loads
M1 out1 in 0 0 nm W=18u L=1u
M2 out1 in vdd vdd pm W=36u L=1u
M3 out2 inb 0 0 nm W=18u L=1u
M4 out2 inb vdd vdd pm W=36u L=1u
C1 out1 0 0.02p
C2 out2 0 0.02p
P1 out1 out2 0 far1 far2 0 LINE
C3 far1 0 0.01p
C4 far2 0 0.01p
VDD vdd 0 DC 5
VIN in 0 PULSE(0 5 10N 0.2N 0.2N 10N 40N)
VINB inb 0 DC 0
.MODEL LINE CPL R=0.2 0 0.2 L=9.13e-9 3.3e-9 9.13e-9 G=0 0 0 C=3.65e-13 -9e-14 3.65e-13 length=12
.MODEL nm NMOS VTO=0.8 KP=48U GAMMA=0.30 PHI=0.55 LAMBDA=0 CGSO=0 CGDO=0 CJ=0 CJSW=0 TOX=18000N
.MODEL pm PMOS VTO=-0.8 KP=21U GAMMA=0.45 PHI=0.61 LAMBDA=0 CGSO=0 CGDO=0 CJ=0 CJSW=0 TOX=18000N
.TRAN 0.2N 30N
.save v(out1) v(out2) v(far1) v(far2)
.END
"""


def test_the_gates_output_stages_balance_their_currents_at_every_accepted_point():
    r = netdae.simulate(NAND_ADDER)
    assert r.ok, r.message
    system = assemble(load(NAND_ADDER))
    names = list(system.names)
    groups = []
    for name in names:
        if name.endswith(".q4#base)"):
            gate = name[len("v(q."):-len(".q4#base)")]
            groups.append([names.index(name), names.index(f"v({gate}.10)"), names.index(f"v({gate}.7)")])
    assert len(groups) == 9
    x = np.column_stack([np.asarray(r[name], dtype=float) for name in names])
    worst = 0.0
    for t, xi in zip(r.t, x):
        phi = system.evaluate(xi, float(t), jacobian=False).phi
        worst = max(worst, max(abs(phi[g].sum()) for g in groups))
    # the currents into a group without capacitance sum to zero at a solution; the stages carry
    # up to about 30 mA (RC = 130 ohm from 5 V). Measured 2.05e-3 A before the check of iterates
    # accepted with a Jacobian from an earlier step, 1.6e-3 A with it (9.3e-4 A with a residual test
    # measured on the linear part's magnitudes, confirmed on the Jacobian's: docs/integrator.md);
    # 1.23e-3 A at one of 3,432 points (the next 8.6e-4 A) once the loop took its starting charges from
    # its own evaluation: the last bits of the start move the points, and with them this tail
    assert worst < 1.5e-3, worst


@ngspice
def test_the_gate_adder_agrees_with_ngspice():
    from netdae.comparison import compare

    c = compare(NAND_ADDER, tol={"tran": 2e-2})
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("tran")
    assert a.error is None and a.points > 100
    outputs = [s for s in a.signals if s.name in ("v(4)", "v(5)")]
    assert len(outputs) == 2
    # logic levels 0.2-3.6 V switching in a few ns: the outputs' worst error is at an edge, where a
    # small shift in time is a large difference in value; their RMS error is a few mV
    for s in outputs:
        assert s.max_rel < 5e-2 and s.rms < 2e-2, (s.name, s.max_rel, s.rms)


@pytest.mark.xfail(strict=False, reason="fragile: the coupled lossy lines' run stops with step-size failures at "
                   "some tolerances and not at others (measured on the compiled engine: it finishes at every "
                   "reltol of 0.5e-3, 0.7e-3, 0.9e-3, 1e-3, 1.1e-3, 1.5e-3, 2e-3 but 1.5e-3); docs/integrator.md, "
                   "Known limitations")
def test_a_restart_whose_probes_need_different_pivots_goes_on():
    r = netdae.simulate(LINES)
    assert r.ok, r.message
    t = np.asarray(r.t)
    far1 = np.asarray(r["v(far1)"])
    far2 = np.asarray(r["v(far2)"])
    # closed forms: the lines' DC path carries no current into the capacitive loads, so 9 ns after
    # an edge the far ends sit near the driver's rail (v(far2) is never driven; measured: v(far1)
    # within 14 mV of 0 V before the falling edge)
    high = (t > 19.0e-9) & (t < 20.0e-9)
    low_after = t > 29.0e-9
    assert np.abs(far1[high]).max() < 3e-2
    assert np.abs(far1[low_after] - 5.0).max() < 3e-2
    assert np.abs(far2[t > 5e-9] - 5.0).max() < 1.0  # crosstalk from line 1 only (measured 0.63 V)
    assert np.abs(far2[low_after] - 5.0).max() < 3e-2


_LOGIC = """logic b source
vin in 0 pulse(0 1 1u 1u 1u 2u 6u)
b1 out 0 v={OUT}
r1 out 0 1k
b2 o2 0 v={O2}
r2 o2 x 1k
c2 x 0 1n
.tran 10n 12u
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_behavioural_source_jumping_with_the_state_is_named_with_a_way_around(engine, monkeypatch):
    """A B source whose law is unbounded approaching the change it jumps at (the log of the compared
    voltage): the transient stops, and the message names the source, why, and what runs instead (a
    branch merely undefined past its change runs: tests/test_behavioural_events.py)."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    text = ("log jump\nV1 in 0 SIN(0 1 1k)\nB1 out 0 V={v(in) > 0 ? 1 + 0.1*ln(v(in)) : -1}\nR1 out 0 1k\n"
            ".tran 1u 2m\n.end\n")
    res = [r for r in netdae.run(netdae.load(text)) if r.analysis == "tran"][0]
    assert not res.ok
    assert "b1's value jumps where a comparison" in res.message and "unbounded approaching the change" in res.message
    assert "tanh" in res.message and "S/W switch" in res.message


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_both_engines_step_across_sources_jumping_with_the_state_at_the_located_crossings(engine, monkeypatch):
    """Logic written as B sources: their comparisons held through each step, their changes located on
    the interpolant of the input's edges (linear in time, so exactly), the gate's pulse between v(in)
    crossing 0.3 and the output changing, its RC load the exponentials of that pulse."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    text = _LOGIC.replace("{OUT}", "{v(in) > 0.5 ? 1 : 0}").replace("{O2}",
                                                                      "{(v(in) > 0.3) && (v(out) < 0.5) ? 2 : 0}")
    res = [r for r in netdae.run(netdae.load(text)) if r.analysis == "tran"][0]
    assert res.ok, res.message
    events = [(t, tuple(names)) for t, names in res.transient.events]
    # rising edges at 1.3 us (b2 on) and 1.5 us (b1; b2 off once out has jumped), falling edges at
    # 4.5 us (b1 off: b2 on, v(in) still above 0.3) and 4.7 us (b2 off), then again 6 us later
    # (b2's change at 1.5 us follows b1's as a second event just after it, once out has jumped; the
    # instants carry the Newton tolerance of v(in), 1e-8 V on a 1e6 V/s edge)
    times = np.array([t for t, _ in events])
    edges = np.array([1.3e-6, 1.5e-6, 4.5e-6, 4.7e-6, 7.3e-6, 7.5e-6, 10.5e-6, 10.7e-6])
    assert np.abs(times[:, None] - edges[None, :]).min(axis=0).max() < 1e-13
    assert np.abs(times[:, None] - edges[None, :]).min(axis=1).max() < 1e-13
    assert {names for _, names in events} <= {("b1",), ("b2",), ("b1", "b2")}
    # v(x): the 2 V pulse of 0.2 us through 1k into 1n (tau = 1 us), then the decay
    vx = lambda t: float(res.dense(t)["v(x)"][0])  # noqa: E731
    top = 2.0 * (1.0 - np.exp(-0.2))
    assert vx(1.5e-6) == pytest.approx(top, rel=2e-3)
    assert vx(2.5e-6) == pytest.approx(top * np.exp(-1.0), rel=2e-3)


def test_the_smooth_form_of_that_source_runs_and_keeps_its_law():
    text = _LOGIC.replace("{OUT}", "{0.5+0.5*tanh((v(in)-0.5)/0.01)}").replace(
        "{O2}", "{2*(0.5+0.5*tanh((v(in)-0.3)/0.01))*(0.5+0.5*tanh((0.5-v(out))/0.01))}")
    res = [r for r in netdae.run(netdae.load(text)) if r.analysis == "tran"][0]
    assert res.ok, res.message
    vin, out = res["v(in)"], res["v(out)"]
    # algebraic, so it holds at every step to the integrator's tolerance: reltol (1e-3) of its 1 V swing
    np.testing.assert_allclose(out, 0.5 + 0.5 * np.tanh((vin - 0.5) / 0.01), rtol=0, atol=1e-3)


BOOST = """boost converter, PWM comparator of B sources, S switch, feedback loop
VIN in 0 5
L1 in sw 22u
S1 sw 0 gate 0 SWM
D1 sw out DS
Cout out 0 22u
Rload out 0 50
Vramp ramp 0 PULSE(0 1 0 9.9u 0.05u 0 10u)
Rs1 out fbk 30k
Rs2 fbk 0 10k
Berr e 0 V=min(max(4*(2.5-v(fbk)),0),0.9)
Rerr e ctl 10k
Cerr ctl 0 10n
Bcmp gate 0 V=v(ctl)>v(ramp) ? 1 : 0
.model SWM SW(VT=0.5 VH=0.1 RON=0.05 ROFF=1MEG)
.model DS D(IS=1e-12 RS=0.02 CJO=50p)
.tran 0.1u 140u
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_boost_converter_steps_on_after_its_diode_was_accepted_forward_after_one_correction(engine, monkeypatch):
    """The switch node of a boost converter rings (22 uH with the diode's junction capacitance, ROFF
    = 1 MOhm) and its peaks turn the diode on. At t = 133.02 us the compiled engine accepted a step
    after one Newton correction (the contraction rate carried from earlier steps) that moved the
    junction from 0.29 V, the prediction's, to 0.69 V; the devices' limiting state kept 0.29 V, the
    voltage of the last evaluation, and every later attempt limited the junction from there (0.41,
    0.52, 0.62, 0.66 V in four iterations, each limited, so never converged): Newton failed on every
    step size down to 5e-17 s and through four impasse restarts. After a Newton failure the state is
    now re-based on the accepted point (both engines: ``corrector.point_state``, the compiled loop's
    ``_point_state``).
    v(out) at 140 us against ngspice 39 with method=gear, reltol=1e-5 (97.269766 V; 1e-6 gives
    97.269502 V), in units of its tolerance reltol |v(out)| (measured 0.46 in both engines;
    ngspice's default trapezoidal run is 97.27 V here, but its undamped ringing later discharges
    the output: 34.2 V at 0.5 ms where gear, reltol 1e-4 and netdae give 70.1-70.4 V)."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    res = [r for r in netdae.run(netdae.load(BOOST)) if r.analysis == "tran"][0]
    assert res.ok, res.message
    out = float(res.dense(140e-6)["v(out)"][0])
    assert abs(out - 97.269766) < 1e-3 * 97.27, out


def test_a_junctions_limiting_state_re_based_on_a_point_is_its_voltage_there():
    """point_state: the junction families take their state from the evaluation without limiting at
    the accepted point, the others (the switch's held state) keep theirs."""
    from netdae.dae.bdf.corrector import point_state

    system = assemble(load(BOOST))
    names = list(system.names)
    x = np.zeros(system.n)
    x[names.index("v(in)")] = 5.0
    x[names.index("v(sw)")] = 98.536
    x[names.index("v(d1#internal)")] = 98.536
    x[names.index("v(out)")] = 97.844
    # a trial state limited from a junction voltage of 0.29 V
    y = x.copy()
    y[names.index("v(d1#internal)")] = 98.137
    y[names.index("v(sw)")] = 98.137
    trial = system.evaluate(y, 0.0, jacobian=False, state=None).state
    point = system.evaluate(x, 0.0, jacobian=False, state=None).state
    state = point_state(system, trial, point)
    for family, s, p, tr in zip(system.families, state, point, trial):
        if type(family).__name__ == "DiodeFamily":
            assert s is p and float(np.asarray(s.v)[0, 0]) == pytest.approx(0.692, abs=1e-9)
        else:
            assert s is tr
