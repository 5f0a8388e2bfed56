"""A switch's event whose right limit needs implicit-Euler steps longer than the event's first ones.

A switch closing onto L - diode (rs, cjo) - L: the three nodes between the inductors are reached only
through them (an inductor cutset, index 2), so their voltages jump at the event and are fixed only
through the inductors' derivatives. The right limit's implicit-Euler steps after an event are 1e-6 of
the probe's (1e-19 s here): ``L / eps`` and ``C / eps`` then swamp every conductance, the matrix is
singular in floating point, and the run stopped at t = 25 ns with "no values consistent with them right
of it were found (singular Jacobian ...)". The steps are now tried again 1000 times longer
(``RIGHT_LIMIT_RETRIES``, ``RIGHT_LIMIT_STRETCH``).

Reference: ngspice 39 at reltol 1e-6 with a 0.1 ns step bound: max i(l2) = 0.2577013 A, and the
cathode's spike when the switch opens onto the inductors' current, min v(c) = -1.280142e5 V.
"""

from __future__ import annotations

import pytest

import netdae

NETLIST = """switch closing onto an inductor-diode(rs,cjo)-inductor chain
V1 vin 0 12
Vg g 0 PULSE(0 10 0 50n 50n 4.5u 10u)
S1 vin a g 0 ssw
L1 a b 100u
D1 b c dr
L2 c 0 100u
.model ssw sw vt=5 ron=0.1 roff=1meg
.model dr d is=1e-12 rs=0.05 cjo=50p
.tran 0.05u 20u
.meas tran icmax max i(l2)
.meas tran vcmin min v(c)
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_switch_closing_onto_an_inductor_cutset_goes_on(engine, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    tran = next(r for r in netdae.run(netdae.load(NETLIST)) if r.analysis == "tran")
    assert tran.ok, tran.message
    m = {x.name: x.value for x in tran.measures}
    assert m["icmax"] == pytest.approx(0.2577013, rel=1e-4)
    assert m["vcmin"] == pytest.approx(-1.280142e5, rel=2e-2)
