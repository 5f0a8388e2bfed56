"""A mode faster than the restart's probe, at an input's corner: the first step's derivatives probed again.

A PULSE through 1 ohm into 1 pF and 1 ohm (a 0.5 ps time constant) at the corner where
the input starts to rise (5 V/ns): the restart's probe, two implicit-Euler steps of a
thousandth of the 1 ns step bound (1 ps), sees the derivatives after the fast mode has
settled, and the first step's error estimate of the source current shrank only in
proportion to the step (a slope the predictor did not have); ten error-test failures
later the run stopped at t = 1 us ("error test failed 10 times"), where ngspice runs
through. The first step from a (re)start that fails the error test now probes again on
the shorter step (``BDF._reprobe``, the compiled loop's ``_reprobe``). Oracle: the
closed form of the RC's ramp response.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

SLOPE = 5e9  # V/s: 5 V in 1 ns
T0, RISE = 1e-6, 1e-9


def _ramp_response(t, r1, r9, c):
    """v(a) of ``V1 in 0 PULSE(0 5 1u 1n ..)``, ``R1 in a r1``, ``R9 a 0 r9``, ``C1 a 0 c``, up to the top."""
    g = 1.0 / r1 + (1.0 / r9 if r9 else 0.0)
    tau = c / g
    s = np.clip(t - T0, 0.0, None)
    ramp = SLOPE / (r1 * g) * (np.minimum(s, RISE) - tau * (1.0 - np.exp(-np.minimum(s, RISE) / tau)))
    top = 5.0 / (r1 * g)
    at_top = SLOPE / (r1 * g) * (RISE - tau * (1.0 - np.exp(-RISE / tau)))
    return np.where(s <= RISE, ramp, top + (at_top - top) * np.exp(-np.maximum(s - RISE, 0.0) / tau))


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("r1, r9", [(1.0, 1.0), (10.0, 10.0), (1.0, None)])
def test_the_first_step_after_a_stiff_corner_is_probed_again(engine, r1, r9, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    shunt = f"R9 a 0 {r9:g}\n" if r9 else ""
    r = netdae.simulate(netdae.load(f"stiff corner\nV1 in 0 PULSE(0 5 1u 1n 1n 1u 2u)\nR1 in a {r1:g}\n{shunt}"
                                    "C1 a 0 1p\n.tran 1n 1.5u\n.end\n"))
    assert r.ok, r.message
    t = T0 + np.array([1e-13, 5e-13, 2e-12, 1e-11, 1e-10, 5e-10, 1e-9, 1.001e-9, 1.01e-9, 2e-9, 1e-7])
    d = r.dense(t)
    want = _ramp_response(t, r1, r9, 1e-12)
    scale = 5.0 / (r1 * (1.0 / r1 + (1.0 / r9 if r9 else 0.0)))
    np.testing.assert_allclose(d["v(a)"], want, atol=2e-3 * scale)
    v_in = np.clip((t - T0) * SLOPE, 0.0, 5.0)
    np.testing.assert_allclose(d["i(v1)"], -(v_in - want) / r1, atol=2e-3 * scale / r1)
