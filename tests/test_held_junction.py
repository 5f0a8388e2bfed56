"""A source current that runs away through a junction the sources alone hold is named as such.

A level-1 MOSFET whose source sits on the input source and whose bulk is grounded has its source-bulk
junction across the input: at the input's negative peak, -2.59 V, the junction's current is
``Is exp(2.59/Vt)`` with nothing in series, about 1e19 A (ngspice computes the same and goes on). The node
voltages are the sources' and stay finite; the run fails on the rounding of that current at an input
corner. The failure used to say that a mode of the circuit grows without bound (a pole in the right
half-plane), which this circuit does not have; it now names the junction and the sources that hold it.
Found by the nonlinear fuzzer (scripts/fuzz_nonlinear.py, seed 21, circuit 23).
"""

from __future__ import annotations

import pytest

import netdae
from netdae.netlist import load
from netdae.topology.held import source_held_junctions

FUZZ_21_23 = """random nonlinear 23
VDD vdd 0 5.0
VIN in 0 SIN(0 2.59 3.263e+04)
RT0 n1 in 1210
RT1 n2 0 6.798e+04
RT2 n3 n2 3.971e+04
RT3 n4 0 499.5
D1 n2 n4 dn
M1 n3 n4 in 0 mn w=4.06e-06 l=1u
L1 0 n4 4.514e-07
R1 0 n4 1719
M2 n3 in n1 0 mn w=3.18e-06 l=1u
C1 n4 n1 3.155e-12
I1 vdd 0 PWL(0 0 6.872e-06 1.94e-05 8.066e-06 -3.27e-06 5.706e-05 5.54e-06 6.056e-05 7.58e-06)
I2 n1 0 PWL(0 0 1.481e-05 -1.38e-08 8.928e-05 1.04e-06)
B1 n3 n1 I=0.000109*(v(n1) > 1.41 ? 5 : 0)
B2 0 n4 I=0.000673*(abs(v(vdd)-v(n4)))
.model dn d(is=1e-14 rs=1 cjo=2p tt=5n bv=50)
.model mn nmos(level=1 vto=0.7 kp=100u lambda=0.02 cgso=0.2n cgdo=0.2n cbd=5f cbs=5f)
.save v(n1) v(n2) v(n3) v(n4) i(vin)
.tran 3.065e-07 9.195e-05
.end
"""


def test_the_held_junctions_are_the_junction_pairs_on_a_source_path():
    # m1's source-bulk pair (in, 0) is across VIN; m2's gate is on `in` (no junction), its source n1 behind RT0;
    # d1 sits behind its series resistance
    held = source_held_junctions(load(FUZZ_21_23))
    assert [(j.element, j.nodes) for j in held] == [("m1", ("in", "0"))]


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_current_through_a_junction_the_sources_hold_is_not_called_a_growing_mode(engine, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(load(FUZZ_21_23))
    assert not r.ok
    failure = r.transient.failure
    assert failure.runaway == "i(vin)" and abs(failure.runaway_value) > 1e15
    assert "flows through a junction that voltage sources alone hold: m1 between in and 0" in r.message
    assert "grows without bound" not in r.message  # the sentence of a right-half-plane mode is replaced
    assert failure.hint.startswith(failure.cause)
