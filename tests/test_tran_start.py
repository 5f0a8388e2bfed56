"""The transient's first step and its restarts: jumps of the inputs, inconsistent starts, empty circuits.

Closed forms where there are some (errors in tolerance units), ngspice
otherwise (``netdae.compare``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.analyses.tran import transient
from netdae.comparison.report import format_analysis
from netdae.dae.bdf import integrate
from netdae.dae.system import KIND_CURRENT, KIND_VOLTAGE, LinearDae
from netdae.errors import NetlistError


def run(text, **kw):
    return transient(netdae.load(text), **kw)


def test_a_tran_without_elements_is_a_located_error():
    # ngspice fails on it too; netdae says where and why (not an internal error)
    with pytest.raises(NetlistError, match=r":2:1: \.tran: the circuit has no elements: nothing to simulate"):
        run("empty\n.tran 1m 10m\n.end\n")


def test_a_tran_of_ideal_sources_only_runs():
    # v(a) = V1 exactly; i(v1) = 0: every unknown is fixed by the sources
    r = run("sources only\nV1 a 0 SIN(0 1 1k)\n.tran 10u 1m\n.end\n")
    assert r.ok, r.message
    t = r.axes["time"]
    np.testing.assert_allclose(r.signals["v(a)"], np.sin(2 * np.pi * 1e3 * t), atol=1e-12)
    np.testing.assert_allclose(r.signals["i(v1)"], 0.0, atol=1e-15)


def test_every_unknown_index2_integrates():
    # i1 = -C1 V', i2 = -C2 V' (two capacitors across an ideal ramp, currents only):
    # nothing to error-test, the steps follow max_step and the breakpoints
    c1, c2 = 1e-6, 2e-6
    E = np.zeros((2, 2))
    H = np.eye(2)
    dae = LinearDae(E, H, lambda t, derivative=0: np.array([c1, c2]) * (1e3 if derivative == 0 else 0.0),
                    names=["i(a)", "i(b)"], kinds=[KIND_CURRENT, KIND_CURRENT])
    res = integrate(dae, (0.0, 1e-3), np.array([-1e-3, -2e-3]), index=np.array([2, 2]), max_step=1e-4)
    assert res.ok, res.message
    np.testing.assert_allclose(res.x, np.tile([-1e-3, -2e-3], (res.t.size, 1)), rtol=1e-12)
    assert res.stats["steps"] <= 20  # ramp-up from 1e-3 of the interval, then max_step


PWL_STEP = """PWL step into an RC
V1 a 0 PWL(0 0 1m 0 1m 1 2m 1)
R1 a b 1k
C1 b 0 1u
.tran 10u 3m
.options reltol={rtol}
.end
"""


@pytest.mark.parametrize("rtol", [1e-3, 1e-6])
def test_pwl_step_jumps_and_is_reported_on_both_sides(rtol):
    r = run(PWL_STEP.format(rtol=rtol))
    assert r.ok, r.message
    t = r.axes["time"]
    at = np.flatnonzero(t == 1e-3)
    assert at.size == 2
    np.testing.assert_allclose(r["v(a)"][at], [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(r["i(v1)"][at], [0.0, -1e-3], rtol=1e-9, atol=1e-15)
    assert [tj for tj, _ in r.transient.jumps] == [1e-3]
    assert any("t=0.001: the solution jumps" in n for n in r.notes)
    # v(b) = 1 - exp(-(t - 1m)/RC) after the step, in tolerance units
    after = t > 1e-3
    exact = 1.0 - np.exp(-(t[after] - 1e-3) / 1e-3)
    err = np.abs(r["v(b)"][after] - exact) / (rtol * np.abs(exact) + 1e-6)
    assert err.max() < 20
    # the dense output does not smear the step: left value at 1 ms, right limit just after
    d = r.dense(np.array([1e-3, 1e-3 * (1 + 1e-9)]))
    np.testing.assert_allclose(d["v(a)"], [0.0, 1.0], atol=1e-9)


def test_pwl_step_at_t0_into_a_diode():
    # the operating point sees the first value (0), the transient starts from the second one
    r = run("""PWL step at t = 0
V1 a 0 PWL(0 0 0 2 1m 2)
R1 a b 1k
D1 b 0 dm
.model dm D
.tran 10u 1m
.end
""")
    assert r.ok, r.message
    t = r.axes["time"]
    assert t[0] == t[1] == 0.0
    assert r["v(a)"][0] == 0.0 and r["v(a)"][1] == pytest.approx(2.0)
    # the diode's forward voltage at 1.3 mA (Is = 1e-14, n = 1): i = (2 - v)/R = Is (exp(v/vt) - 1)
    v = r["v(b)"][-1]
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    assert abs((2.0 - v) / 1e3 - 1e-14 * np.expm1(v / vt)) < 1e-3 * (2.0 - v) / 1e3


DIODE_PULSE_UIC = """diode and PULSE from 0 with uic
V1 a 0 PULSE(0 5 0 1n 1n 1u 2u)
R1 a b 1k
D1 b 0 dmod
C1 b 0 1n
.model dmod D
.tran 10n 6u uic
.end
"""


def test_diode_pulse_from_zero_with_uic_matches_ngspice():
    r = run(DIODE_PULSE_UIC)
    assert r.ok, r.message
    # the uic start is consistent at t = 0 itself: no jump at t = 0
    assert r.axes["time"][1] > 0.0 and r.transient.jumps == []
    cmp = netdae.compare(DIODE_PULSE_UIC, tol=2e-3, signals=["v(b)"], analyses=["tran"])
    assert cmp.passed, "\n".join(format_analysis(a) for a in cmp.analyses)


def test_an_inconsistent_start_is_corrected_and_reported():
    # v(1) = V(t) is algebraic; a start with v(1) != V(0) is inconsistent: the method continues
    # from the right limit and says so, instead of failing its first step
    E = np.array([[0.0, 0.0], [0.0, 1e-6]])
    H = np.array([[-1.0, 0.0], [1e-3, -1e-3]])
    dae = LinearDae(E, H, lambda t, derivative=0: np.array([1.0 if derivative == 0 else 0.0, 0.0]),
                    names=["v(1)", "v(2)"], kinds=[KIND_VOLTAGE, KIND_VOLTAGE])
    res = integrate(dae, (0.0, 5e-3), np.array([0.0, 0.0]), rtol=1e-6, vntol=1e-9)
    assert res.ok, res.message
    assert res.jumps == [(0.0, ("v(1)",))]
    assert res.t[0] == res.t[1] == 0.0 and res.x[1, 0] == pytest.approx(1.0)
    exact = 1.0 - np.exp(-res.t[-1] / 1e-3)
    assert abs(res.x[-1, 1] - exact) < 1e-4


# -- an operating point is consistent when no input changes at t0 -----------------------------------------------
TIA = Path("/work/corpus/examples/TransImpedanceAmp/output.net")  # ngspice's example: op-amp macromodels


def _op177a() -> str:
    """The OP177A macromodel of ngspice's transimpedance-amplifier example (Analog Devices'), as a library text."""
    if not TIA.exists():
        pytest.skip("the ngspice corpus is not here")
    found = re.search(r"^\.SUBCKT OP177A.*?^\.ENDS", TIA.read_text(), flags=re.M | re.S | re.I)
    assert found is not None
    return found.group(0)


#: An OP177A inverting amplifier with a capacitor loop (Cp, V3, Cb) at its input; I1 flat until 1 ns.
OP177A_LOOP = """OP177A inverting amplifier with a capacitor loop at its input
.options gmin=1e-9 method=gear abstol=1e-11
.include op177a.lib
V1 vp 0 DC 5
V2 vn 0 DC -5
XU 0 inm vp vn out OP177A
Rf out inm 10k
Rin b inm 1k
Cp 0 a 1p
V3 b a DC 0
Cb b 0 1p
I1 0 a PWL(0 0 1n 0 1.01n 1u)
.tran 0.05n 5n
.end
"""


def op177a_loop(tmp_path: Path) -> Path:
    """:data:`OP177A_LOOP` written with its library in ``tmp_path`` (skips without the ngspice corpus)."""
    (tmp_path / "op177a.lib").write_text(_op177a() + "\n")
    netlist = tmp_path / "loop.cir"
    netlist.write_text(OP177A_LOOP)
    return netlist


@pytest.mark.ngspice
def test_an_operating_point_is_kept_when_no_input_changes_at_t0(tmp_path):
    # A capacitor loop through V3 makes i(v3) index 2; I1 is flat until 1 ns, so the DC operating point is
    # a steady state of the transient and consistent. The OP177A's Weierstrass transformation has a
    # condition of 1e19: its Newton residual (1e-9 A) read through it as violated constraints moved 48
    # unknowns (the supply node v(vn) from -5 to -5.00002, i(e.xu.e3) by 12 A) and the transient failed at t = 0.
    netlist = op177a_loop(tmp_path)
    ckt = netdae.load(str(netlist))
    report = netdae.analyze_index(ckt)
    assert report.index == 2 and report.consistent_initial_values
    r = transient(ckt)
    assert r.ok, r.message
    assert r.transient.initial_correction is None and all(tj > 0.0 for tj, _ in r.transient.jumps)
    start = r.transient.start
    for name in ("v(vn)", "v(out)", "i(v3)", "i(e.xu.e3)"):
        assert r[name][0] == start[name], name  # the transient starts from the operating point
    cmp = netdae.compare(str(netlist), signals=["v(out)", "v(inm)", "i(v3)"], analyses=["tran"])
    assert cmp.passed, "\n".join(format_analysis(a) for a in cmp.analyses)


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_nonlinear_start_with_an_infinite_slope_is_no_jump(engine, monkeypatch):
    """v(d) = sqrt(|v(in)|) of a sine from 0 grows like sqrt(t): the start probe's extrapolation to eps = 0 missed
    0 by 0.59 sqrt(eps), which a nonlinear system took for a jump at t0; restarted from that value the error test
    failed 10 times down to h = 1.3e-27 (ngspice runs it). Against the closed form at every point."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    res = netdae.simulate("t\nV1 in 0 SIN(0 2 500)\nB4 d 0 V = sqrt(abs(V(in)))\nR4 d 0 1k\n.tran 10u 4m\n.end\n",
                          save=["v(d)"])
    assert res.ok and res.t[-1] == pytest.approx(4e-3)
    assert not res.transient.jumps
    exact = np.sqrt(np.abs(2.0 * np.sin(2.0 * np.pi * 500.0 * res.t)))
    # algebraic: off by Newton's stopping only (3.3 tolerances at worst, next to the kinks at the zero crossings)
    assert np.max(np.abs(res["v(d)"] - exact) / (1e-3 * exact + 1e-6)) < 5.0


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_nonlinear_start_with_a_large_second_derivative_is_no_jump(engine, monkeypatch):
    """An RC behind a gain of 1e7 on a sine, with a diode: at t0 v(n2)'' = 4e15 V/s^2 made the probe's O(eps^2 x'')
    error (-3.95e-5 V) a jump at t = 0 in a nonlinear system. The start is the operating point and the input is
    continuous: v(n2) starts from 0 and follows the closed form while the diode is off."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    text = ("t\nV1 in 0 SIN(0 1 1k)\nE1 n1 0 in 0 1e7\nR1 n1 n2 1k\nC1 n2 0 15.9n\nD1 n2 0 DX\n"
            ".model DX D(IS=1e-14)\n.tran 5u 100u\n.end\n")
    res = netdae.simulate(text, save=["v(n2)"])
    assert res.ok and not res.transient.jumps
    w, tau = 2.0 * np.pi * 1e3, 1e3 * 15.9e-9
    t = res.t
    exact = 1e7 / (1.0 + (w * tau) ** 2) * (w * tau * np.exp(-t / tau) + np.sin(w * t) - w * tau * np.cos(w * t))
    early = exact < 0.2  # the diode's current below 1e-11 A
    assert np.count_nonzero(early) >= 5
    v, exact = res["v(n2)"][early], exact[early]
    assert v[0] == 0.0
    assert np.max(np.abs(v - exact) / (1e-3 * np.abs(exact) + 1e-6)) < 5.0
