"""A junction's diffusion charge converged to its own accuracy, not its voltage's.

A charge-form row integrates ``q(x)``; a diode's diffusion charge ``tt Is exp(v/Vt)`` moves
by ``1/Vt`` of itself per volt, so a Newton correction within the junction voltage's
tolerance (``reltol |v|``, 0.9 mV at 0.9 V) left the charge 3.5 % unconverged, and the
accepted iterates let the integrated charge drift: the junction carried thousands of
amperes balanced by its own displacement current, and the run went away
(``netdae.dae.compiled.control.charge_newton_weights``; docs/integrator.md).

References: ngspice 39 at ``reltol=1e-6`` with a step bound of 0.1-0.5 ns (0.5 us for the
rectifier), which netdae at ``reltol=1e-6`` reproduces to the digits given.
"""

from __future__ import annotations

import pytest

import netdae

#: A switched inductor dumped through a diode with rs and tt into a second inductor and a load.
DUMP = """switched inductor dumped through a diode (tt only) into a second inductor
V1 vin 0 12
Vg g 0 PULSE(0 10 0 50n 50n 4.5u 10u)
S1 d 0 g 0 ssw
Cd d 0 200p
Lp vin d 100u
D1 d out dr
Lo out o 100u
Rl o 0 50
.model ssw sw vt=5 ron=0.1 roff=1meg
.model dr d is=1e-12 rs=0.05 tt=20n
.tran 0.05u 20u
.meas tran vdmax max v(d)
.meas tran vdmin min v(d)
.meas tran ilo19 find i(lo) at=19u
.end
"""

#: A 60 Hz centre-tapped full-wave rectifier (three coupled windings, diodes with tt and cjo).
RECTIFIER = """Full-wave rectifier, centre-tapped transformer, diodes with tt and cjo
Vac ac 0 SIN(0 170 60)
Rpri ac p 1
Lp p 0 1
Ls1 s1 0 0.01
Ls2 0 s2 0.01
K1 Lp Ls1 0.999
K2 Lp Ls2 0.999
K3 Ls1 Ls2 0.999
D1 s1 out dr
D2 s2 out dr
C1 out 0 2200u
Rl out 0 20
.model dr d is=1e-9 n=1.5 rs=0.02 cjo=200p tt=5u bv=100
.tran 10u 100m
.meas tran vavg avg v(out) from=80m to=100m
.meas tran vpp pp v(out) from=80m to=100m
.end
"""


def _measures(text: str) -> dict:
    tran = next(r for r in netdae.run(netdae.load(text)) if r.analysis == "tran")
    assert tran.ok, tran.message
    return {m.name: m.value for m in tran.measures}


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_diode_between_two_inductors_keeps_its_charge(engine, monkeypatch):
    """It failed at 8.1 us (compiled) and 7.6 us (python) with the junction at 1.8 V and 'the solution ran
    away: v(out) = 1e18 V'; now the default tolerance's swing and current are within 0.2 % of the reference's
    swing and 0.3 % of the current's range (0.75 A)."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    m = _measures(DUMP)
    assert m["vdmax"] == pytest.approx(387.387, rel=2e-3)
    assert m["vdmin"] == pytest.approx(-341.108, rel=2e-3)
    assert m["ilo19"] == pytest.approx(0.084055, abs=2.5e-3)


def test_a_rectifier_with_charge_storage_diodes_gives_the_right_ripple():
    """The default tolerance gave 15.807 V and 1.750 V of ripple in 11.4 million steps (115 s)."""
    m = _measures(RECTIFIER)
    assert m["vavg"] == pytest.approx(15.1561, rel=1e-3)
    assert m["vpp"] == pytest.approx(2.4807, rel=1e-2)


#: A flyback's primary switched off into a clamp diode with tt (K = 0.98, a 1 ohm secondary load).
FLYBACK = """flyback with a clamp diode
Vin in 0 12
Vg g 0 PULSE(0 10 0 20n 20n 4u 10u)
Lp in d 100u
Ls 0 s 100u
K1 Lp Ls 0.98
S1 d 0 g 0 sw
Rsec s 0 1
Dcl d cl dcl
Rcl cl in 10k
Ccl cl in 10n
.model sw sw vt=5 vh=0.5 ron=0.05 roff=1meg
.model dcl d is=1e-12 rs=0.05 cjo=50p tt=10n
.tran 50n 12u
.meas tran vdmin min v(d)
.meas tran vdmax max v(d)
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_flybacks_clamp_diode_rings_as_the_converged_run(engine, monkeypatch):
    """After turn-off the drain rings down to -570 V in spikes (netdae at reltol 1e-7: -570.7 V; ngspice at
    reltol 1e-5: -569.0 V) and is clamped at 158.6 V. The default tolerance gave -9,343 V (ngspice's default
    -7,418 V): the clamp diode's diffusion charge drifted between the spikes.

    Near the default tolerance the deepest spike is not converged: the diode's reverse recovery at 4.35 us
    ends in a snap whose depth the steps there decide, and the ringing after it keeps that error (both
    engines, reltol 7e-4 to 2e-3: -566 to -585 V at most settings, -1,328 V at 1.2e-3, the compiled one
    -872 V at 2e-3; not the orders: maxord=2 gives -969 V at 1e-3; docs/integrator.md, "Known
    limitations"). So the default run is held to the drift's absence (within twice the converged depth),
    and reltol 1e-4 to the converged depth.
    """
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    m = _measures(FLYBACK)
    assert -2 * 570.7 < m["vdmin"] < -0.97 * 570.7
    assert m["vdmax"] == pytest.approx(158.6, rel=2e-3)
    m = _measures(FLYBACK.replace(".tran", ".options reltol=1e-4\n.tran"))
    assert m["vdmin"] == pytest.approx(-570.7, rel=0.03)
    assert m["vdmax"] == pytest.approx(158.6, rel=2e-3)
