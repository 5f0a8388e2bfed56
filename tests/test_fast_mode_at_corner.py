"""A mode faster than the restart's probe at an input's corner is not taken for a jump.

A PULSE (1.5 us edges) through 7.5 pF into the base of a pnp transistor: at the end of each
edge the capacitor's current stops, and the collector answers within about 0.1 ns, as fast as
the restart's probe steps (a thousandth of the step bound). The probe's implicit-Euler steps
moved the collector by 0.32 mV in their first step and little in the second, which the jump test
took for a jump: the run recorded v(n3) jumping from 0 to -0.32 mV at the corner, where every
node has capacitance and the input's value is continuous, and stayed 8.5 % of the collector's
swing off ngspice's waveform from there (a random circuit of a nonlinear fuzz pass). A nonlinear
system's move at a restart that is not a switching event is now confirmed with implicit-Euler
steps a million times shorter, within which such a mode does not move and a real jump (an input
that jumps, an inconsistent start) does. Oracles: the continuity of capacitive nodes under a
continuous input, and ngspice at tight settings.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.comparison import compare

NETLIST = """fast mode at a corner
VDD vdd 0 5.0
VIN in 0 PULSE(0 3.59 7.51e-06 1.5e-06 1.5e-06 2.5e-05 7.51e-05)
RT0 n1 0 793
RT1 n2 n1 1130
RT2 n3 0 2811
R1 n2 0 34.4
C1 n1 in 7.499e-12
C2 vdd n2 1.512e-12
Q1 n3 n1 n2 qp
R2 n1 n2 1101
.model qp pnp(is=1e-16 bf=50 br=1 rb=80 rc=10 re=2 cje=1p cjc=1p tf=0.5n tr=15n vaf=60)
.save v(n1) v(n2) v(n3)
.tran 7.51e-07 0.0002253
.end
"""
#: The PULSE's corners within the run (delay, end of rise, start and end of fall, per period).
CORNERS = [7.51e-6 + k * 75.1e-6 + d for k in range(3) for d in (0.0, 1.5e-6, 26.5e-6, 28e-6)]


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("reltol", [1e-3, 1e-6])
def test_no_jump_at_the_corners_of_a_continuous_input(engine, reltol, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(netdae.load(NETLIST.replace(".tran", f".options reltol={reltol:g}\n.tran")))
    assert r.ok, r.message
    jumped = [(t, names) for t, names in r.transient.jumps
              if any(n in ("v(n1)", "v(n2)", "v(n3)") for n in names)]
    assert jumped == [], jumped  # (the source current i(vin) = C1 dv/dt may jump at a corner)
    # and the collector moves continuously after each corner: within a nanosecond of it, by far less
    # than the 0.32 mV the probe's steps took for a jump
    d = r.dense(np.array(CORNERS[1:4]) + 1e-12)
    before = r.dense(np.array(CORNERS[1:4]) - 1e-12)
    assert np.max(np.abs(d["v(n3)"] - before["v(n3)"])) < 1e-6


@pytest.mark.ngspice
def test_the_waveforms_after_the_corners_agree_with_ngspice():
    c = compare(NETLIST, tight=True)
    assert c.ngspice_error is None, c.ngspice_error
    a = c.analysis("tran")
    assert a.error is None
    for s in a.signals:
        assert s.max_rel <= 1e-3, (s.name, s.max_rel, s.at)
