"""A mode faster than the start's probe is resolved, not taken for a jump at t = 0.

A 10 V, 100 kHz SIN source rising from 0 at t = 0 charges 1 pF through 10 ohm (a 10 ps mode) with a reverse-biased
diode across the capacitor, so the system is nonlinear. The operating point at t = 0 is consistent
(v(a) = 0, nothing flows) and the input is continuous, so v(a) is continuous: it starts to lag the input
by tau v'(in) within a few tau. The start's probe takes implicit-Euler steps longer than tau; their
first step moved v(a) by the lag and the second little, which the jump test read as a jump at t = 0
(kept at the start, where after it a move was confirmed with short steps). Now every nonlinear move
at a restart that is not a switching event is confirmed with the short steps, within which a fast
mode does not move and the method resolves it with its own steps. Oracle: the closed form of the RC
section (the diode's reverse current, 1e-14 A, is far below the tolerance of the comparison).
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

AMP, FREQ, R, C = 10.0, 1e5, 10.0, 1e-12
NETLIST = f"""fast mode at the start
V1 in 0 SIN(0 {AMP} {FREQ:g})
R1 in a {R}
C1 a 0 {C}
D1 0 a dr
.model dr d(is=1e-14)
.tran 100n 20u
.end
"""


def exact(t):
    """v(a) of the RC section driven by AMP sin(w t) from rest."""
    w, tau = 2 * np.pi * FREQ, R * C
    wt = w * tau
    return AMP / (1 + wt**2) * (np.sin(w * t) - wt * np.cos(w * t) + wt * np.exp(-t / tau))


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("reltol", [1e-3, 1e-6])
def test_no_jump_at_the_start_of_a_continuous_input(engine, reltol, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(netdae.load(NETLIST.replace(".tran", f".options reltol={reltol:g}\n.tran")))
    assert r.ok, r.message
    jumped = [(t, names) for t, names in r.transient.jumps if "v(a)" in names]
    assert jumped == [], jumped  # (the source current i(v1) = C dv/dt may jump: an index-2 current)
    # the lag builds up over a few tau: against the closed form at the rounding of the tolerance
    lag = 2 * np.pi * FREQ * AMP * R * C  # v'(in) tau, 63 uV
    t = np.array([2e-12, 5e-12, 1e-11, 2e-11, 5e-11, 1e-10])
    got = r.dense(t)["v(a)"]
    assert np.max(np.abs(got - exact(t))) <= 0.05 * lag
