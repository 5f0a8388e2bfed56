"""Transient analysis of circuits against closed forms, errors in tolerance units.

Each circuit is a netlist read by netdae.load; the exact solution is written
by hand. ``units(err, x, tol)`` expresses an error in units of the local
tolerance ``reltol*|x| + atol``, the scale the integrator controls.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import netdae
from netdae.analyses.tran import transient
from netdae.errors import NetdaeError, NetlistError

TWO_PI = 2 * np.pi


def run(text, **kw):
    return transient(netdae.load(text), **kw)


def units(err, x, rtol, atol):
    """Largest error in tolerance units."""
    return float(np.max(np.abs(err) / (rtol * np.abs(x) + atol)))


def peak_units(err, x, rtol):
    """Largest error relative to reltol times the signal's peak (for signals crossing zero)."""
    return float(np.max(np.abs(err)) / (rtol * np.max(np.abs(x))))


# --- RC, RL, RLC ---------------------------------------------------------------------------
RC = """RC low-pass
V1 in 0 {src}
R1 in out 1k
C1 out 0 1u
.tran 10u 5m 0 {tmax}
.options reltol={rtol}
.end
"""


def test_rc_sine_closed_form_and_tolerance_proportionality():
    tau, w, A = 1e-3, TWO_PI * 500, 1.0
    errs = []
    for rtol in (1e-3, 1e-5):
        r = run(RC.format(src="SIN(0 1 500)", rtol=rtol, tmax="1m"))
        t = r.t
        exact = A / (1 + (w * tau) ** 2) * (np.sin(w * t) - w * tau * np.cos(w * t) + w * tau * np.exp(-t / tau))
        err = r["v(out)"] - exact
        assert peak_units(err, exact, rtol) < 20
        errs.append(np.max(np.abs(err)))
    assert errs[1] < errs[0] / 20  # tighter tolerance, proportionally smaller error


def test_rc_pwl_ramp_closed_form_and_breakpoint():
    tau, tr = 1e-3, 0.5e-3
    r = run(RC.format(src="PWL(0 0 0.5m 1)", rtol=1e-4, tmax="10u"))
    t = r.t
    ramp = (t - tau * (1 - np.exp(-t / tau))) / tr
    after = 1 - (tau / tr) * (np.exp(tr / tau) - 1) * np.exp(-t / tau)
    exact = np.where(t <= tr, ramp, after)
    assert peak_units(r["v(out)"] - exact, exact, 1e-4) < 20
    assert np.any(np.isclose(t, tr, rtol=0, atol=1e-15))  # a step lands on the PWL corner


RL = """RL with a pulse
V1 in 0 PULSE(0 2 0.1m 1u 1u 1m 4m)
R1 in a 10
L1 a 0 10m
.tran 5u 1.5m
.options reltol=1e-4
.end
"""


def test_pulse_corners_are_breakpoints_and_rl_current():
    r = run(RL)
    t = r.t
    for corner in (0.1e-3, 0.1e-3 + 1e-6, 1.101e-3, 1.102e-3):
        assert np.min(np.abs(t - corner)) < 1e-15, corner
    tau = 10e-3 / 10
    # between the corners: the current after the 1 us ramp, i(L) = 0.2 (1 - exp(-(t-t1)/tau)) up to O(1us/tau)
    sel = (t > 0.2e-3) & (t < 1.1e-3)
    t1 = 0.1e-3 + 0.5e-6  # ramp mid-point: the ramp acts as a step delayed by half its width
    exact = 0.2 * (1 - np.exp(-(t[sel] - t1) / tau))
    assert np.max(np.abs(r["i(l1)"][sel] - exact)) < 2e-4 * 0.2 + 0.2 * (1e-6 / tau) ** 2


RLC = """series RLC, natural response from a charged capacitor
R1 a b {R}
L1 b c 1m
C1 c 0 1u ic=1
V0 a 0 0
.tran 1u 0.4m uic
.options reltol=1e-6 vntol=1e-9 abstol=1e-12
.end
"""


@pytest.mark.parametrize("R", [10.0, 2 * np.sqrt(1e-3 / 1e-6), 200.0])
def test_series_rlc_natural_response_all_dampings(R):
    L, C = 1e-3, 1e-6
    r = run(RLC.format(R=R))
    t = r.t
    alpha = R / (2 * L)
    w0 = 1 / np.sqrt(L * C)
    if np.isclose(alpha, w0):
        vc = (1 + alpha * t) * np.exp(-alpha * t)
    elif alpha < w0:
        wd = np.sqrt(w0**2 - alpha**2)
        vc = np.exp(-alpha * t) * (np.cos(wd * t) + alpha / wd * np.sin(wd * t))
    else:
        s1, s2 = -alpha + np.sqrt(alpha**2 - w0**2), -alpha - np.sqrt(alpha**2 - w0**2)
        vc = (s2 * np.exp(s1 * t) - s1 * np.exp(s2 * t)) / (s2 - s1)
    assert r["v(c)"][0] == pytest.approx(1.0, abs=1e-12)  # uic: the capacitor starts at its ic
    assert peak_units(r["v(c)"] - vc, vc, 1e-6) < 50


def test_lc_oscillator_energy_drift_is_within_tolerance():
    text = """LC tank
L1 a 0 1m
C1 a 0 1u ic=1
.tran 1u 2m 0 100u uic
.options reltol={rtol} vntol=1e-12 abstol=1e-15
.end
"""
    drifts = []
    for rtol in (1e-5, 1e-7):
        r = run(text.format(rtol=rtol))
        energy = 0.5 * 1e-6 * r["v(a)"] ** 2 + 0.5 * 1e-3 * r["i(l1)"] ** 2
        drifts.append(abs(energy[-1] - energy[0]) / energy[0])
    periods = 2e-3 * 1 / (TWO_PI * np.sqrt(1e-9))
    assert drifts[0] < 10 * 1e-5 * periods  # BDF damps: the loss stays at the tolerance level per period
    assert drifts[1] < drifts[0] / 10


# --- index 2 -------------------------------------------------------------------------------------
def test_v_parallel_c_index2_current():
    text = """V parallel to C with a resistor
V1 a 0 SIN(0 1 1k)
C1 a 0 1u
R1 a 0 1k
.tran 5u 3m
.end
"""
    r = run(text)
    t = r.t
    w = TWO_PI * 1e3
    exact = -(1e-6 * w * np.cos(w * t) + 1e-3 * np.sin(w * t))
    assert r.transient.index == 2 and "i(v1)" in r.transient.index2
    assert r.transient.initial_correction is not None  # the OP has i(v1) = 0, the true value is -C w
    assert r["i(v1)"][0] == pytest.approx(exact[0], rel=1e-9)
    assert peak_units(r["i(v1)"] - exact, exact, 1e-3) < 5
    assert r.stats["steps"] < 2000  # no step-size collapse


def test_vc1c2_loop_index2():
    text = """loop of V, C1, C2 with a resistor across C2
V1 a 0 SIN(0 1 1k)
C1 a b 1u
C2 b 0 2u
R1 b 0 500
.tran 5u 4m
.options reltol=1e-5
.end
"""
    r = run(text)
    t = r.t
    w, C1, C2, R = TWO_PI * 1e3, 1e-6, 2e-6, 500.0
    # (C1 + C2) vb' = C1 V' - vb/R, vb(0) = 0 (the consistent value: C1/(C1+C2) V(0) = 0)
    tau = R * (C1 + C2)
    k = C1 / (C1 + C2)
    amp = k * w * tau / (1 + (w * tau) ** 2)
    vb = amp * (np.cos(w * t) + w * tau * np.sin(w * t) - np.exp(-t / tau))
    dvb = amp * (-w * np.sin(w * t) + w * w * tau * np.cos(w * t) + np.exp(-t / tau) / tau)
    i_v1 = -C1 * (w * np.cos(w * t) - dvb)
    assert "i(v1)" in r.transient.index2
    assert peak_units(r["v(b)"] - vb, vb, 1e-5) < 20
    assert peak_units(r["i(v1)"] - i_v1, i_v1, 1e-5) < 50


def test_li_cutset_index2_voltage():
    text = """current source into an inductor cutset
I1 0 a SIN(0 1m 2k)
L1 a b 10m
R1 b 0 100
L2 a 0 5m
.tran 2u 1m
.end
"""
    # LI-cutset {I1, L1... }: node a joins the rest only through I1, L1 and L2 -> v(a) depends on I1'
    r = run(text)
    assert r.transient.index == 2
    assert "v(a)" in r.transient.index2
    t = r.t
    # currents: i1 + i2 = I(t) (KCL at a), L1 i1' + R i1 = L2 i2'  ->  (L1 + L2) i1' + R i1 = L2 I'
    L1, L2, R, w, A = 10e-3, 5e-3, 100.0, TWO_PI * 2e3, 1e-3
    tau = (L1 + L2) / R
    amp = L2 / (L1 + L2) * A * w * tau / (1 + (w * tau) ** 2)
    i1 = amp * (np.cos(w * t) + w * tau * np.sin(w * t) - np.exp(-t / tau))
    va = R * i1 + L1 * amp * (-w * np.sin(w * t) + w * w * tau * np.cos(w * t) + np.exp(-t / tau) / tau)
    assert r["v(a)"][0] == pytest.approx(va[0], rel=1e-6)  # consistent start: v(a) = L I'(0) share
    assert peak_units(r["v(a)"] - va, va, 1e-3) < 10


def test_differentiator_closed_form_and_convergence():
    c = netdae.load("netlists/differentiator.cir")
    errs = []
    for rtol in (1e-3, 1e-5):
        r = transient(c, reltol=rtol)
        t = r.t
        exact = -(10e-3 / 100) * TWO_PI * 1e3 * np.cos(TWO_PI * 1e3 * t)
        assert r.transient.index == 2 and r.transient.index2 == ["v(out)"]
        errs.append(np.max(np.abs(r["v(out)"] - exact)))
        assert r.stats["steps"] < 1500
    assert errs[0] / 0.628 < 2e-3
    assert errs[1] < errs[0] / 10


def test_differentiator_ngspice_start_keeps_the_jump():
    r = transient(netdae.load("netlists/differentiator.cir"), initial="ngspice")
    assert r["v(out)"][0] == 0.0
    assert r["v(out)"][1] == pytest.approx(-0.6283185, rel=1e-3)
    assert r.transient.initial_correction is None


# --- index 3 and 4: cascaded ideal differentiators ---------------------------------------------
def cascade(k: int, source: str) -> str:
    lines = [f"{k} cascaded ideal differentiators", f"V1 n0 0 {source}"]
    for s in range(1, k + 1):
        lines += [f"R{s} n{s - 1} m{s} 1k", f"L{s} m{s} n{s} 100m", f"E{s} n{s} 0 0 m{s} opamp"]
    lines += [".tran 1u 2m", ".options reltol=1e-6", ".end"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("k", [2, 3])
def test_cascaded_differentiators_index_k_plus_1(k):
    r = run(cascade(k, "SIN(0 1 1k)"))
    assert r.transient.index == k + 1
    t = r.t
    w, g = TWO_PI * 1e3, 100e-3 / 1e3  # each stage multiplies by -(L/R) d/dt
    # (-g d/dt)^k sin(w t)
    phase = np.array([np.sin, np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x)])[k % 4]
    exact = (-g * w) ** k * phase(w * t)
    out = r[f"v(n{k})"]
    assert np.max(np.abs(out - exact)) <= 1e-6 * np.max(np.abs(exact))
    assert not r.transient.impulses


def test_cascade_with_pulse_warns_about_impulses():
    """The PULSE's slope jumps at its corners: the second and third derivatives contain deltas there."""
    r = run(cascade(2, "PULSE(0 1 0.5m 0.1m 0.1m 0.5m 2m)"))
    assert r.transient.index == 3
    corners = ["t=0.0005:", "t=0.0006:", "t=0.0011:", "t=0.0012:"]
    assert [w.split()[0] for w in r.transient.impulses] == corners
    assert all("derivative of order 1" in w and "v(n2)" in w for w in r.transient.impulses)
    r3 = run(cascade(3, "PULSE(0 1 0.5m 0.1m 0.1m 0.5m 2m)"))
    assert "v(n2)" in r3.transient.impulses[0] and "v(n3)" in r3.transient.impulses[0]


def test_single_differentiator_of_a_pulse_has_steps_not_impulses():
    """Index 2: the continuous PULSE's slope jumps, so v(out) = -(L/R) dV/dt steps; no impulse."""
    with open("netlists/differentiator.cir") as fh:
        text = fh.read().replace("SIN(0 1 1k)", "PULSE(0 1 0.5m 0.1m 0.1m 0.5m 2m)")
    r = run(text)
    assert r.transient.index == 2 and r.transient.impulses == []
    mid_rise = r.dense(np.array([0.55e-3, 0.85e-3]))["v(out)"]
    np.testing.assert_allclose(mid_rise, [-1e-4 * 1e4, 0.0], atol=1e-6)


# --- options and interface -----------------------------------------------------------------------
def test_save_tstart_interp_and_difference_signal():
    text = """save test
V1 in 0 SIN(0 1 1k)
R1 in out 1k
C1 out 0 1u
.save v(out) v(in,out)
.tran 10u 2m 1m
.options interp
.end
"""
    r = run(text)
    assert set(r.signals) == {"v(out)", "v(in,out)"}
    np.testing.assert_allclose(r.t, 1e-3 + 1e-5 * np.arange(101), rtol=0, atol=1e-15)
    d = r.dense(np.array([1.5e-3]))
    assert d["v(in,out)"][0] == pytest.approx(np.sin(TWO_PI * 1.5) - d["v(out)"][0], abs=1e-3)


def test_trap_is_refused_with_a_message():
    text = RC.format(src="SIN(0 1 500)", rtol=1e-3, tmax="10u").replace(".end", ".options method=trap\n.end")
    with pytest.raises(NetdaeError, match="method=trap"):
        run(text)


def test_rc_ladder_factorizations_bounded():
    n = 1000
    lines = ["RC ladder", "V1 n0 0 PULSE(0 1 0 10u 10u 1 2)"]
    for k in range(1, n + 1):
        lines += [f"R{k} n{k - 1} n{k} 100", f"C{k} n{k} 0 1n"]
    lines += [".tran 1u 200u", ".end"]
    r = run("\n".join(lines) + "\n", save=["v(n1)", "v(n1000)"])
    st = r.stats["integrator"]
    assert r.ok
    # a linear circuit refactors only when cj changes (plus one probe per restart)
    assert r.stats["factorizations"] <= st["cj_changes"] + st["probes"] + 1
    assert r.stats["factorizations"] < 60
    assert set(r.signals) == {"v(n1)", "v(n1000)"}


def test_floating_bridge_output_keeps_its_charge():
    """The output of a diode bridge floats between reverse-biased diodes.

    Between conduction intervals its common-mode voltage is fixed by charge
    alone; after three mains periods (t = 60 ms, v(ac) = 0) a tight reference
    run gives |v(pos) + v(neg)|/2 < 1e-6 V. A linearised charge update in the
    integrator once injected charge at every step: 0.44 V of drift.
    """
    r = transient(netdae.load("netlists/bridge_rectifier.cir"), reltol=1e-6, save=["v(pos)", "v(neg)"])
    common = 0.5 * (r["v(pos)"][-1] + r["v(neg)"][-1])
    assert r.t[-1] == pytest.approx(60e-3)
    assert abs(common) < 5e-3



def test_tiny_abstol_still_integrates_the_rectifier():
    """abstol = 1e-15 A on the half-wave rectifier: rounding must not kill the run.

    The junction charge near zero bias once carried an absolute rounding error
    eps * cj0 vj / (1 - m), noise far above abstol in the source current at the
    first steps (h = 1e-17 s): the run died at t = 5e-17 s. The run must reach
    tstop and agree with a reference at reltol 1e-6 (measured, in units of
    reltol 1e-4 times the range: 0.002 for v(in), 0.025 for v(out), 3.5 for
    the source current). The multiplier of netlists/, whose source
    current carries the rounding error of a 10 uF charge, is compared with
    ngspice at reltol 1e-6 in tests/test_validation.py.
    """
    path = "netlists/halfwave_rectifier.cir"
    r = transient(netdae.load(path), reltol=1e-4, abstol=1e-15)
    assert r.ok, r.message
    ref = transient(netdae.load(path), reltol=1e-6)
    assert ref.ok, ref.message
    assert r.t[-1] == pytest.approx(ref.t[-1])
    dense = r.dense(ref.t)
    for name in ("v(in)", "v(out)", "i(v1)"):
        err = np.abs(dense[name] - ref[name]).max() / np.ptp(ref[name]) / 1e-4
        assert err < 20, (name, err)


def test_an_unstable_linear_circuit_fails_naming_its_growing_eigenvalue():
    # a negative conductance (g1) beats r1: v grows as exp(900 t) from the pulse's kick and overflows
    text = ("negative resistance\nV1 in 0 PULSE(0 1 1m 1u 1u 1m 1)\nR0 in n1 1meg\nC1 n1 0 1u\nR1 n1 0 10k\n"
            "G1 n1 0 n1 0 -1m\n.tran 1m 2\n.end\n")
    res = netdae.simulate(netdae.load(text))
    assert res.status < 0
    lam = float(re.search(r"the eigenvalue (\S+) 1/s in the right half-plane", res.message).group(1))
    assert lam == pytest.approx((1e-3 - 1e-4 - 1e-6) / 1e-6, rel=1e-3)


@pytest.mark.parametrize("written", ["trap", "trapezoidal", "TRAP"])
def test_trap_is_refused_at_the_option(written):
    """The refusal of ``method=trap`` (ngspice's default rule, which ngspice 39 takes) was a bare message
    without the file, line and column of the option; it is located at the option's value."""
    text = RC.format(src="SIN(0 1 500)", rtol=1e-3, tmax="10u").replace(
        ".end", f".options reltol=1e-3 method={written}\n.end")
    with pytest.raises(NetlistError) as exc:
        run(text)
    err = exc.value
    line = text.split("\n").index(f".options reltol=1e-3 method={written}") + 1
    assert (err.location.line, err.location.column) == (line, len(".options reltol=1e-3 method=") + 1)
    assert "method=trap" in err.message and err.hint == "use method=gear or remove the option"
