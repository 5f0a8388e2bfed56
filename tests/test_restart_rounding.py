"""A restart's first step is not set by the curvature of an unknown known only to rounding.

A push-pull converter's secondary floats on a 1 Mohm resistor to ground (no capacitance there): its
common mode is an algebraic unknown the probe's implicit-Euler steps know only to rounding, and its
``x''`` grows like ``1/eps^2`` as the probe step shrinks. Weighed at its own tolerance it chased each
shorter probe down at the gate's 50 ns corner (first steps of 3e-11, 5e-13, then 9e-18 s); Newton then
failed on the numerically singular matrices of such steps and the common mode ran away to 1e25-1e44 V.
The curvature norm now takes the error-test weights raised to the probe's rounding level
(``netdae.dae.bdf.startup.Probe.w_err_floor``, the compiled ``_restart_at``).

Reference: ngspice 39 at ``reltol=1e-6`` on the same netlist (``meas ... find ... at=60n``).
"""

from __future__ import annotations

import pytest

import netdae

PUSH_PULL = """Push-pull converter, centre-tapped transformer, secondary floating on 1 Mohm
V1 vin 0 12
Vg1 g1 0 PULSE(0 10 0 50n 50n 4.5u 10u)
Vg2 g2 0 PULSE(0 10 5u 50n 50n 4.5u 10u)
M1 d1 g1 0 0 nsw W=20m L=1u
M2 d2 g2 0 0 nsw W=20m L=1u
Lp1 vin d1 100u
Lp2 d2 vin 100u
Ls1 s1 ct 400u
Ls2 ct s2 400u
K1 Lp1 Lp2 0.99
K2 Lp1 Ls1 0.99
K3 Lp1 Ls2 0.99
K4 Lp2 Ls1 0.99
K5 Lp2 Ls2 0.99
K6 Ls1 Ls2 0.99
Da s1 out dr
Db s2 out dr
Lo out o2 100u
Co o2 ct 10u
Rl o2 ct 50
Rgnd ct 0 1meg
.model nsw nmos level=1 vto=2 kp=50u cbd=200p cbs=200p
.model dr d is=1e-12 rs=0.05 cjo=50p tt=20n
.tran 0.05u 60n 0 50n
.meas tran vd1 find v(d1) at=60n
.meas tran ilp find i(lp1) at=60n
.meas tran vs1 find v(s1) at=60n
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_the_gate_corner_restart_of_a_floating_secondary_goes_on(engine, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    tran = next(r for r in netdae.run(netdae.load(PUSH_PULL)) if r.analysis == "tran")
    assert tran.ok, tran.message
    m = {x.name: x.value for x in tran.measures}
    assert m["vd1"] == pytest.approx(4.276108e-3, rel=1e-2)
    assert m["ilp"] == pytest.approx(3.388457e-2, rel=1e-3)
    assert m["vs1"] == pytest.approx(57.35158, rel=1e-3)
    assert abs(float(tran["v(ct)"][-1])) < 1e-3
