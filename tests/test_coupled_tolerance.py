"""The windings of a transformer share one current scale in the error test.

A winding that does not conduct (the off half of a centre-tapped secondary) carries
microamperes that ring with the leakage inductance and the junction's charge at MHz. Its
relative tolerance, ``reltol`` of its own largest current so far, made the steps resolve
that ringing through a 60 Hz simulation: 361,485 steps for 40 ms of the rectifier below.
A coupled inductor's current is now referred to its group's largest ampere-turns, read in
its own turns (``netdae.dae.bdf.coupled_current_groups``, ``set_weights``; docs/integrator.md,
"Tolerances").

Reference: ngspice 39 at ``reltol=1e-7`` on the same netlist (``.meas`` in a ``.control`` block).
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.dae.bdf import coupled_current_groups
from netdae.mna import assemble

#: A centre-tapped full-wave rectifier, diodes with transit time (no junction capacitance).
RECTIFIER = """Full-wave rectifier, centre-tapped transformer, diodes with tt
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
.model dr d is=1e-9 n=1.5 rs=0.02 tt=5u bv=100
.tran 10u 40m
.meas tran vavg avg v(out) from=30m to=40m
.meas tran vpp pp v(out) from=30m to=40m
.meas tran ipk min i(ls1) from=30m to=40m
.end
"""


def test_groups_are_the_coupled_inductors_with_their_turns():
    text = """two transformers and a lone inductor
V1 a 0 1
Lp a 0 4
Ls b 0 1
K1 Lp Ls 0.9
L3 c 0 2
L4 d 0 8
L5 e 0 0.5
K2 L4 L5 0.5
R1 b 0 1
R2 c 0 1
R3 d 0 1
R4 e 0 1
.tran 1m 1
.end
"""
    system = assemble(netdae.load(text))
    group, scale, gmax = coupled_current_groups(system)
    names = list(system.names)
    at = {nm: (int(group[names.index(nm)]), float(scale[names.index(nm)]))
          for nm in ("i(lp)", "i(ls)", "i(l3)", "i(l4)", "i(l5)", "i(v1)", "v(a)")}
    assert at["i(lp)"][0] == at["i(ls)"][0] >= 0
    assert at["i(l4)"][0] == at["i(l5)"][0] >= 0
    assert at["i(lp)"][0] != at["i(l4)"][0]
    assert at["i(l3)"][0] == at["i(v1)"][0] == at["v(a)"][0] == -1
    assert [at[nm][1] for nm in ("i(lp)", "i(ls)", "i(l4)", "i(l5)")] == pytest.approx([2.0, 1.0, np.sqrt(8), np.sqrt(0.5)])
    assert gmax.shape == (2,)


def test_no_coupling_no_groups():
    system = assemble(netdae.load("rl\nV1 a 0 1\nL1 a b 1m\nR1 b 0 1\n.tran 1u 1m\n.end\n"))
    group, _, gmax = coupled_current_groups(system)
    assert np.all(group == -1) and gmax.size == 0


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_an_off_winding_does_not_set_the_steps(engine, monkeypatch):
    """361,485 steps before (1.4 s compiled); now about 5,200, and the measures within 2e-4 (average),
    2e-3 (ripple) and 3e-3 (peak current) of ngspice's at reltol 1e-7: 15.20506 V, 2.376759 V, -9.069362 A."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    tran = next(r for r in netdae.run(netdae.load(RECTIFIER)) if r.analysis == "tran")
    assert tran.ok, tran.message
    m = {x.name: x.value for x in tran.measures}
    assert m["vavg"] == pytest.approx(15.20506, rel=2e-4)
    assert m["vpp"] == pytest.approx(2.376759, rel=2e-3)
    assert m["ipk"] == pytest.approx(-9.069362, rel=3e-3)
    assert tran.stats.steps < 20_000


#: The rectifier with junction capacitance: a diode's reverse recovery snaps off at 20.69 ms and rings with the
#: leakage inductance at about 16 MHz for milliseconds (docs/integrator.md, "Known limitations").
RINGING = RECTIFIER.replace("tt=5u bv=100", "cjo=200p tt=5u").replace("n=1.5 ", "").replace(
    ".meas tran ipk min i(ls1) from=30m to=40m\n", "")


def test_a_ringing_rectifier_at_the_a_stable_orders_gives_the_converged_ripple():
    """At orders up to 5 the ringing grows in the integration and the run fails at 22.4 ms (the runaway
    message names the orders); at maxord=2 the average and ripple are ngspice's at reltol 1e-7 (15.45278 V,
    2.444196 V) within 4e-5 and 6e-5."""
    text = RINGING.replace(".tran", ".options maxord=2\n.tran")
    tran = next(r for r in netdae.run(netdae.load(text)) if r.analysis == "tran")
    assert tran.ok, tran.message
    m = {x.name: x.value for x in tran.measures}
    assert m["vavg"] == pytest.approx(15.45278, rel=3e-4)
    assert m["vpp"] == pytest.approx(2.444196, rel=2e-3)


def test_the_runaway_message_names_the_high_orders():
    from netdae.dae.bdf.failures import runaway

    names, kinds = ["v(a)", "i(l1)"], np.array([0, 1])
    start, end = np.array([1.0, 1e-3]), np.array([3e18, 2e12])
    assert "maxord=2" in runaway(names, kinds, start, end, max_order=5)
    assert "maxord=2" not in runaway(names, kinds, start, end, max_order=2)
