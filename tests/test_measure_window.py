"""``.meas`` on the window a transient measures: from its ``tstart`` on, not from its first kept point.

An RC low-pass (tau = 0.1 ms) driven by ``0.2 + sin(2 pi 1k t)`` from rest has the closed form
``v(out) = 0.2 (1 - e^(-t/tau)) + A sin(w t - phi) + A sin(phi) e^(-t/tau)`` with
``A = 1/sqrt(1 + (w tau)^2)`` and ``phi = atan(w tau)``. ngspice's values converge to these
integrals over ``[tstart, tstop]`` as its steps shrink (``.tran 1u 3m 1m 5n``, reltol 1e-7:
``INTEG`` 4.00003e-04, ``AVG`` 2.000017e-01, ``RMS`` 6.31252e-01).
"""

from __future__ import annotations

import math

import pytest

from netdae.analyses.runner import run

TAU, W = 1e-4, 2 * math.pi * 1e3
A, PHI = 1 / math.sqrt(1 + (W * TAU) ** 2), math.atan(W * TAU)
K = A * math.sin(PHI)


def _integral(t0: float, t1: float) -> float:
    """The closed-form integral of v(out) over [t0, t1]."""
    def prim(t):
        e = math.exp(-t / TAU)
        return 0.2 * (t + TAU * e) - A / W * math.cos(W * t - PHI) - K * TAU * e
    return prim(t1) - prim(t0)


NETLIST = """rc from tstart
V1 in 0 SIN(0.2 1 1k)
R1 in out 1k
C1 out 0 100n
.tran 1u 3m 1m
.meas tran area INTEG v(out)
.meas tran mean AVG v(out)
.meas tran area2 INTEG v(out) FROM=0.5m TO=2m
.meas tran start FIND v(out) AT=1m
.end
"""


def test_window_starts_at_tstart():
    (res,) = run(NETLIST)
    m = {x.name: x for x in res.measures}
    assert all(x.ok for x in m.values()), [x.reason for x in m.values()]
    # the first kept point lies a part of a step after tstart; the window is from tstart itself
    assert res.axis[0] > 1e-3
    assert m["area"].value == pytest.approx(_integral(1e-3, 3e-3), rel=2e-5)
    assert m["mean"].value == pytest.approx(_integral(1e-3, 3e-3) / 2e-3, rel=2e-5)
    assert m["area2"].value == pytest.approx(_integral(1e-3, 2e-3), rel=2e-5)
    assert m["area"].extra["from"] == 1e-3
    t = 1e-3
    exact = 0.2 * (1 - math.exp(-t / TAU)) + A * math.sin(W * t - PHI) + K * math.exp(-t / TAU)
    assert m["start"].value == pytest.approx(exact, abs=1e-4)
