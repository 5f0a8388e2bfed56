"""The compiled transient engine against the Python integrator and the reader's waveforms.

The compiled loop (netdae.dae.compiled) is the same FLC-BDF method as
netdae.dae.bdf.BDF: on linear circuits it must take the same number of steps and
give the same waveforms to the level of rounding (only the LU's rounding differs,
which can move the probed first step slightly), and its source waveforms must be
the reader's (the reference formulas of ngspice's vsrcload.c).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.dae import bdf as bdf_module
from netdae.dae.compiled.driver import integrate_compiled, supports
from netdae.dae.compiled.sources import pack_sources, source_values
from netdae.mna import assemble
from netdae.mna.sources import MODE_TRAN
from netdae.netlist.waveforms import Am, Exp, Pulse, Pwl, Sffm, Sin, SourceBank

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"


class _Sources:
    """A minimal SourceVector stand-in: every source has a transient function."""

    mode = MODE_TRAN

    def __init__(self, waves):
        self.m = len(waves)
        self.u0 = np.zeros(self.m)
        self.timed = np.arange(self.m)
        self.bank = SourceBank(waves)


WAVES = [
    Pulse(0, 1, 1e-6, 1e-7, 2e-7, 1e-6, 3e-6).resolved(1e-8, 1e-5),
    Pulse(-1, 2, 0, 0, 0, 0, 0, 3).resolved(1e-8, 1e-5),
    Sin(0.5, 2, 1e5, 1e-6, 1e4, 30).resolved(1e-8, 1e-5),
    Exp(0, 1, 1e-6, 1e-6, 4e-6, 2e-6).resolved(1e-8, 1e-5),
    Pwl([0, 1e-6, 1e-6, 3e-6, 5e-6], [0, 1, 2, -1, 0.5]).resolved(1e-8, 1e-5),
    Pwl([0, 1e-6, 2e-6, 3e-6], [0, 1, 0, 2], repeat=1e-6, delay=5e-7).resolved(1e-8, 1e-5),
    Sffm(0, 1, 1e6, 2, 1e5, 10, 20).resolved(1e-8, 1e-5),
    Am(1, 0.5, 1e5, 1e6, 1e-6, 0, 45).resolved(1e-8, 1e-5),
]


def test_compiled_waveforms_equal_the_readers():
    src = _Sources(WAVES)
    packed = pack_sources(src)
    rng = np.random.default_rng(3)
    times = np.concatenate([rng.uniform(0, 1e-5, 400), src.bank.breakpoints(0, 1e-5), [0.0, 1e-5]])
    out = np.empty(len(WAVES))
    for t in times:
        source_values(*packed, float(t), out)
        ref = src.bank.values(float(t))
        scale = np.maximum(np.abs(ref), 1.0)
        # the same formulas, evaluated in the same order: equal up to a few ulps
        assert np.max(np.abs(out - ref) / scale) <= 8 * np.finfo(float).eps, t


def _tran_system(path: Path):
    circuit = netdae.load(path)
    card = next(a for a in circuit.analyses if type(a).__name__ == "TranAnalysis")
    system = assemble(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop)
    return system, card


LINEAR = [p for p in sorted(NETLISTS.glob("*.cir")) if p.stem in {
    "rc_lowpass", "rc_lowpass_pulse", "rlc_series_underdamped", "lc_ladder_butterworth5", "sallen_key_lowpass",
    "opamp_integrator", "pwl_rc", "transformer", "li_cutset", "cv_loop_sin", "rl_highpass_pulse",
}]


def _tran(path: Path, engine: str, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    return next(r for r in netdae.run(netdae.load(path)) if r.analysis == "tran")


@pytest.mark.parametrize("path", LINEAR, ids=lambda p: p.stem)
def test_compiled_linear_engine_matches_the_python_integrator(path, monkeypatch):
    comp = _tran(path, "compiled", monkeypatch)
    ref = _tran(path, "python", monkeypatch)
    assert comp.ok and ref.ok
    assert comp.stats["integrator"]["engine"] == "compiled" and "engine" not in ref.stats["integrator"]
    # the same method: step counts equal within 1 % (the probed first step depends on the LU's rounding)
    assert abs(comp.stats["steps"] - ref.stats["steps"]) <= max(1, 0.01 * ref.stats["steps"])
    # waveforms agree far within the requested tolerance (reltol 1e-3 of the signal range)
    t_end = float(ref.axes["time"][-1])
    tt = np.linspace(0.0, t_end, 501)
    a, b = comp.dense(tt), ref.dense(tt)
    for name in b:
        scale = max(float(np.ptp(b[name])), 1e-6 if name.startswith("v") else 1e-12)
        assert np.max(np.abs(a[name] - b[name])) / scale < 1e-5, name


def test_engine_choice_and_failure_messages(monkeypatch):
    system, card = _tran_system(NETLISTS / "rc_lowpass.cir")
    x0 = np.zeros(system.n)
    assert not supports(system, {"xp0": x0})  # an option the compiled engine does not implement
    res = integrate_compiled(system, (0.0, card.tstop), x0, max_steps=10)
    assert not res.ok and res.failure.what == "reached max_steps=10"
    assert res.t.size == 11 and res.stats["steps"] == 10
    with pytest.raises(ValueError, match="rtol"):
        integrate_compiled(system, (0.0, card.tstop), x0, rtol=2.0)


def test_compiled_engine_closed_form_rc():
    """v(out) of an RC low-pass after a step: 1 - exp(-t/RC), to the requested tolerance."""
    text = "rc\nV1 in 0 PWL(0 0 1n 1)\nR1 in out 1k\nC1 out 0 1n\n.tran 10n 5u\n.end\n"
    circuit = netdae.load(text)
    system = assemble(circuit, mode=MODE_TRAN, tstep=1e-8, tstop=5e-6)
    res = integrate_compiled(system, (0.0, 5e-6), np.zeros(system.n), rtol=1e-7, vntol=1e-10, abstol=1e-15)
    assert res.ok
    t = np.linspace(2e-9, 5e-6, 200)
    # exact response to the 1 ns ramp: v = (t - tau (1 - e^{-t/tau}))/T up to T, then the ramp's tail
    tau, T = 1e-6, 1e-9
    exact = 1.0 - tau / T * (math.exp(T / tau) - 1.0) * np.exp(-t / tau)
    v = res.dense(t)[:, system.names.index("v(out)")]
    assert np.max(np.abs(v - exact)) < 2e-6


NONLINEAR = [p for p in sorted(NETLISTS.glob("*.cir")) if p.stem in {
    "halfwave_rectifier", "bridge_rectifier", "cw_doubler", "voltage_multiplier", "ring_oscillator_notox",
    "cmos_inverter", "ce_amplifier", "diff_pair", "jfet_amplifier",
}]


@pytest.mark.parametrize("path", NONLINEAR, ids=lambda p: p.stem)
def test_compiled_nonlinear_engine_matches_the_python_integrator(path, monkeypatch):
    """Diodes, BJTs, MOSFETs and JFETs in the compiled loop: the Python integrator's method, step for step.

    The device kernels equal the numpy families to rounding; on a switching circuit
    rounding can change a Newton iteration's count, so the step counts may drift apart
    by a few per cent, and the waveforms agree to the requested tolerance.
    """
    comp = _tran(path, "compiled", monkeypatch)
    ref = _tran(path, "python", monkeypatch)
    assert comp.ok and ref.ok
    assert comp.stats["integrator"]["engine"] == "compiled"
    assert abs(comp.stats["steps"] - ref.stats["steps"]) <= max(2, 0.1 * ref.stats["steps"])
    t_end = float(ref.axes["time"][-1])
    tt = np.linspace(0.0, t_end, 501)
    a, b = comp.dense(tt), ref.dense(tt)
    for name in b:
        if not name.startswith("v("):
            continue
        scale = max(float(np.ptp(b[name])), 1e-3)
        assert np.max(np.abs(a[name] - b[name])) / scale < 1e-2, name


def test_compiled_nonlinear_right_limit_after_an_input_step(monkeypatch):
    """A step of the input switches a diode on: the loop asks Python for the right limit
    (converged implicit-Euler steps) and continues from it, as the Python integrator does."""
    text = ("step into a diode\nV1 in 0 PWL(0 0 1u 0 1u 5 3u 5)\nR1 in a 1k\nD1 a 0 dmod\nC1 in b 1n\n"
            "R2 b 0 1k\n.model dmod d is=1e-14 cjo=1p\n.tran 10n 3u\n.end\n")
    circuit = netdae.load(text)
    system = assemble(circuit, mode=MODE_TRAN, tstep=1e-8, tstop=3e-6)
    assert supports(system, {})
    x0 = np.zeros(system.n)
    monkeypatch.setenv("NETDAE_ENGINE", "python")
    ref = bdf_module.integrate(system, (0.0, 3e-6), x0)
    comp = integrate_compiled(system, (0.0, 3e-6), x0)
    assert comp.ok and ref.ok
    assert [t for t, _ in comp.jumps] == [t for t, _ in ref.jumps] == [1e-6]
    assert set(comp.jumps[0][1]) == set(ref.jumps[0][1])
    # both sides of the jump are recorded at t = 1 us
    at = np.flatnonzero(comp.t == 1e-6)
    assert at.size == 2
    ib = system.names.index("v(b)")
    # v(b) jumps by the full step (the capacitor's charge is continuous), then decays with tau = 1 us
    assert comp.x[at[1], ib] - comp.x[at[0], ib] == pytest.approx(5.0, rel=1e-3)
    assert abs(comp.stats["steps"] - ref.stats["steps"]) <= max(2, 0.05 * ref.stats["steps"])


def test_compiled_nonlinear_failure_reports_as_the_python_integrator(monkeypatch):
    system, card = _tran_system(NETLISTS / "halfwave_rectifier.cir")
    x0 = np.zeros(system.n)
    comp = integrate_compiled(system, (0.0, card.tstop), x0, max_steps=25)
    monkeypatch.setenv("NETDAE_ENGINE", "python")
    ref = bdf_module.integrate(system, (0.0, card.tstop), x0, max_steps=25)
    assert not comp.ok and comp.failure.what == ref.failure.what == "reached max_steps=25"
    assert comp.t.size == ref.t.size
    np.testing.assert_allclose(comp.x, ref.x, rtol=1e-6, atol=1e-9)
