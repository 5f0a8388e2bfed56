"""Jumps at restarts: where the inputs are continuous, the solution is continuous.

At every breakpoint the integrator restarts and measures the right limit x(t+)
by two implicit-Euler steps of a small ``eps`` extrapolated to ``eps = 0``; its
error is O(eps^2 x''). At the corner of a PULSE driving an RC ladder, x'' of the
first node is the slope over the time constant (2e7 V/s over 10 ns: 2e15 V/s^2),
so with ``eps`` = 5e-11 s the extrapolation missed ``v(n1) = 0`` by 4.9e-6 V,
five times the absolute tolerance: both engines reported "the solution jumps
(v(n1), i(v1))" and recorded a right limit of -4.9e-6 V at the corner of a
capacitor voltage. A jump is now recognised by the first Euler step carrying it
(netdae.dae.bdf.constants.JUMP_FIRST_STEP): a continuous solution moves by
comparable amounts in both steps. Genuine jumps (a PWL step in an algebraic
current, an index-2 current at a corner) are still found.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

#: 10 sections of 100 ohm and 100 pF (time constant 10 ns per section), a 50 ns edge.
LADDER = "\n".join(
    ["rc ladder", "V1 n0 0 PULSE(0 1 100n 50n 50n 1.9u 4u)"]
    + [f"R{k} n{k - 1} n{k} 100\nC{k} n{k} 0 100p" for k in range(1, 11)]
    + [".tran 50n 10u", ".end", ""])

#: A PWL step into an RC: the source current (algebraic) jumps, the capacitor voltage does not.
STEP = """pwl step
V1 a 0 PWL(0 0 1m 0 1m 1 5m 1)
R1 a b 1k
C1 b 0 1u
.tran 10u 5m
.end
"""

#: The differentiator's index-2 current at a PULSE corner (a capacitor across a source).
CAP_ON_SOURCE = """cap on source
V1 a 0 PULSE(0 1 1m 1m 1m 1m 10m)
C1 a 0 1u
R1 a 0 1k
.tran 10u 5m
.end
"""


@pytest.fixture(params=["compiled", "python"])
def engine(request, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", request.param)
    return request.param


def _duplicates(t) -> np.ndarray:
    t = np.asarray(t)
    return t[np.flatnonzero(np.diff(t) == 0.0)]


def test_a_pulse_corner_into_an_rc_ladder_is_no_jump(engine):
    res = netdae.simulate(netdae.load(LADDER))
    assert res.ok, res.message
    assert res.transient.jumps == []
    assert _duplicates(res.t).size == 0
    assert not any("jumps" in note for note in res.notes)
    # before the first corner every node is at rest; right after it the first node has barely moved
    t = np.asarray(res.t)
    v1 = np.asarray(res["v(n1)"])
    at = np.flatnonzero(np.abs(t - 1e-7) <= 1e-20)
    assert at.size == 1 and v1[at[0]] == 0.0
    after = (t > t[at[0]]) & (t < 1.01e-7)
    # v1 ~ s t^2 / (2 RC) with s = 2e7 V/s, RC = 1 us over the whole ladder: far below 1e-6 V here
    assert np.all(v1[after] > -1e-9)


def test_a_pwl_step_still_makes_the_source_current_jump(engine):
    res = netdae.simulate(netdae.load(STEP))
    assert res.ok, res.message
    times = [t for t, _ in res.transient.jumps]
    assert times == [pytest.approx(1e-3)]
    names = res.transient.jumps[0][1]
    assert "i(v1)" in names and "v(a)" in names and "v(b)" not in names
    t = np.asarray(res.t)
    k = np.flatnonzero(np.abs(t - 1e-3) <= 1e-16)
    assert k.size == 2  # left and right value
    i = np.asarray(res["i(v1)"])
    assert i[k[0]] == pytest.approx(0.0, abs=1e-12) and i[k[1]] == pytest.approx(-1e-3, rel=1e-6)
    vb = np.asarray(res["v(b)"])  # the capacitor keeps its voltage (to the right limit's O(eps^2) error)
    assert vb[k[1]] == pytest.approx(vb[k[0]], abs=1e-9)


def test_an_index2_current_still_jumps_at_a_corner(engine):
    res = netdae.simulate(netdae.load(CAP_ON_SOURCE))
    assert res.ok, res.message
    jumped = {round(t, 9): names for t, names in res.transient.jumps}
    # i(v1) = -(C dv/dt + v/R): dv/dt steps from 0 to 1 V/ms at 1 ms and back to 0 at 2 ms
    assert 1e-3 in jumped and "i(v1)" in jumped[1e-3]
    assert 2e-3 in jumped and "i(v1)" in jumped[2e-3]
    assert all("v(a)" not in names for names in jumped.values())
