"""A capacitor left between open switches: the right limit keeps its charge, the common mode jumps.

When the switches around a capacitor open, its two nodes are held only by the
switches' off-conductances: the capacitor's charge is continuous, the pair's
common mode is algebraic and jumps to what those conductances set. The
right limit's implicit-Euler steps (C / eps ~ 2e5 S against 1e-12 S) lose that
equation to rounding unless the pair's current balance is solved without the
cancelling charge terms (``netdae.dae.bdf.startup``).

Closed form of ``SW_CAP`` (g = 1 / roff, g_on = 1 / ron, C = C1): before the
event ``a = g_on / (g_on + g)``, ``b = 0``; after it (S1, S2 and S3 off)
``2 a + b = 1`` (the pair's current balance) and ``C d' = g b`` for
``d = a - b``, so ``a = (1 + d) / 3``, ``b = (1 - 2 d) / 3`` and
``d = 1/2 + (d0 - 1/2) exp(-2 g (t - t_off) / (3 C))``.
"""

from __future__ import annotations

import numpy as np
import pytest

from netdae.analyses.tran import transient
from netdae.netlist import load

SW_CAP = """capacitor between two switched nodes: both switches open at 1us, the pair's common mode jumps
V1 in 0 1
VC c 0 PULSE(5 0 1u 10n 10n 1 2)
S1 in a c 0 sw
S2 b 0 c 0 sw
S3 a 0 0 0 sw
C1 a b 1p
R1 in 0 1k
.model sw sw vt=2.5 vh=0.2 ron=1k roff={roff}
.tran 10n 3u
.end
"""

RELTOL, VNTOL = 1e-3, 1e-6


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("roff", [1e12, 1e11, 1e10])
def test_a_capacitor_between_open_switches_keeps_its_charge(engine, roff, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = transient(load(SW_CAP.format(roff=roff)))
    assert r.ok
    g, g_on, cap = 1.0 / roff, 1e-3, 1e-12
    t_off = 1e-6 + 10e-9 * (5.0 - 2.3) / 5.0  # VC falls through vt - vh = 2.3 V
    assert [t for t, _ in r.transient.events] == [pytest.approx(t_off, rel=1e-9)]
    d0 = g_on / (g_on + g)  # a - b before the event (b = 0)

    def exact(t):
        d = 0.5 + (d0 - 0.5) * np.exp(-2.0 * g * (t - t_off) / (3.0 * cap))
        return (1.0 + d) / 3.0, (1.0 - 2.0 * d) / 3.0

    # the right limit recorded at the event: the charge held, the common mode from the off-conductances
    at = np.flatnonzero(np.abs(r.axes["time"] - t_off) <= 1e-9 * t_off)
    assert at.size == 2
    a_right, b_right = exact(t_off)
    for name, value in (("v(a)", a_right), ("v(b)", b_right)):
        err = abs(r.signals[name][at[1]] - value) / (RELTOL * abs(value) + VNTOL)
        assert err < 1e-3, (name, r.signals[name][at[1]], value)
    assert r.signals["v(a)"][at[0]] == pytest.approx(d0, rel=1e-9)  # the left value
    # after it: the slow discharge through the off-conductances, in tolerance units
    t = np.linspace(t_off * (1 + 1e-9), 3e-6, 200)
    a, b = exact(t)
    got = r.dense(t)
    for name, value in (("v(a)", a), ("v(b)", b)):
        err = np.max(np.abs(got[name] - value) / (RELTOL * np.abs(value) + VNTOL))
        assert err < 0.1, (name, err)


SC_INTEGRATOR = """Switched-capacitor integrator, non-overlapping two-phase clock, ideal-ish E op-amp
VIN vin 0 DC 0.5 SIN(0.5 0.3 2k)
VP1 p1 0 PULSE(0 5 0 10n 10n 4.5u 10u)
VP2 p2 0 PULSE(0 5 5u 10n 10n 4.5u 10u)
S1 vin a p1 0 sw
S2 a 0 p2 0 sw
CS a b 1p
S3 b 0 p1 0 sw
S4 b vm p2 0 sw
CI vm out 10p
EOP out 0 0 vm 1e4
RLEAK vm out 100meg
.model sw sw (vt=2.5 vh=0.2 ron=1k roff=1e12)
.tran 50n 100u
.end
"""


@pytest.mark.ngspice
def test_switched_capacitor_integrator_agrees_with_ngspice():
    """Every phase change leaves CS between open switches (a and b held by 1e-12 S): the first at 4.5 us.

    Compared where each phase has settled (its last 0.1 us), in tolerance units: at the edges
    ngspice decides the switches at its time points, netdae at the located crossings
    (``netdae compare`` says so), which shifts the 2 ns transients of CS by a fraction of a step.
    """
    import netdae
    from netdae.ngspice import run_ngspice

    (ours,) = netdae.run(SC_INTEGRATOR)
    assert len(ours.transient.events) == 40  # each clock edge
    ref = run_ngspice(SC_INTEGRATOR).result("tran")
    t_ng = np.asarray(ref.t)
    settled = np.array([k * 1e-5 + dt for k in range(10) for dt in (4.4e-6, 9.9e-6)])
    for name in ("v(out)", "v(a)", "v(b)"):
        ng = np.interp(settled, t_ng, np.asarray(ref[name]))
        err = np.abs(ours.dense(settled)[name] - ng) / (RELTOL * np.abs(ng) + VNTOL)
        assert np.max(err) < 0.05, (name, settled[np.argmax(err)], np.max(err))
