"""One operating point for the small-signal analyses of a netlist (analyses.op.shared_operating_points).

A two-stage CMOS op-amp in unity-gain feedback whose operating point needs gmin
stepping (in ngspice too) was solved four times by ``.op .ac .noise .tf``: 1.0 s
of 1.02 s in netdae against 0.021 s in ngspice. ``run`` now solves it once; the
later analyses must get exactly what they computed alone.
"""

import numpy as np
import pytest

import netdae
import netdae.analyses.op as op_module
from netdae.analyses.ac import ac_analysis
from netdae.analyses.noise import noise_analysis
from netdae.analyses.op import operating_point
from netdae.analyses.tf import tf_analysis

MILLER = """CMOS two-stage Miller op-amp, unity-gain DC feedback, loop open for AC
VDD vdd 0 2.5
VSS vss 0 -2.5
VIN inp 0 DC 0 AC 1
LB out inn 1k
CB inn 0 1k
M1 n1 inn tail vss nch w=10u l=1u
M2 n2 inp tail vss nch w=10u l=1u
M3 n1 n1 vdd vdd pch w=20u l=1u
M4 n2 n1 vdd vdd pch w=20u l=1u
M5 tail bias vss vss nch w=20u l=1u
M6 out n2 vdd vdd pch w=80u l=1u
M7 out bias vss vss nch w=40u l=1u
M8 bias bias vss vss nch w=20u l=1u
IB vdd bias 20u
CC n2 nc 2p
RZ nc out 3k
CL out 0 5p
.model nch nmos (level=1 vto=0.6 kp=100u gamma=0.5 phi=0.7 lambda=0.05 tox=10n cgso=0.2n cgdo=0.2n)
.model pch pmos (level=1 vto=-0.7 kp=40u gamma=0.5 phi=0.7 lambda=0.06 tox=10n cgso=0.2n cgdo=0.2n)
.op
.ac dec 5 10 1g
.noise v(out) vin dec 5 10 100meg
.tf v(out) vin
.end
"""

SWITCHED = """a switch in the operating point is solved by every analysis
V1 in 0 DC 1 AC 1
VC c 0 2
S1 in out c 0 sw
R1 out 0 1k
.model sw sw vt=1 ron=10 roff=1meg
.op
.ac lin 3 1 10
.end
"""


def _counting(monkeypatch):
    calls = []
    real = op_module.solve_steady

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(op_module, "solve_steady", counted)
    return calls


def test_small_signal_analyses_share_one_operating_point(monkeypatch):
    circuit = netdae.load(MILLER)
    cards = {type(c).__name__: c for c in circuit.analyses}
    alone = [operating_point(circuit),
             ac_analysis(circuit, cards["AcAnalysis"]),
             noise_analysis(circuit, cards["NoiseAnalysis"]),
             tf_analysis(circuit, cards["TfAnalysis"])]
    calls = _counting(monkeypatch)
    shared = netdae.run(circuit)
    assert len(calls) == 1
    assert [r.analysis for r in shared] == [r.analysis for r in alone]
    for a, b in zip(alone, shared):
        assert a.names() == b.names()
        for name in a.names():  # value for value what each analysis computes alone
            np.testing.assert_array_equal(np.asarray(a[name]), np.asarray(b[name]), err_msg=f"{a.analysis} {name}")


def test_the_operating_point_is_the_callers_copy():
    circuit = netdae.load(MILLER)
    with op_module.shared_operating_points():
        first = operating_point(circuit)
        first.signals["v(out)"][0] = 1e3
        second = operating_point(circuit)
    assert second["v(out)"][0] != pytest.approx(1e3)


def test_circuits_with_switches_are_solved_by_every_analysis(monkeypatch):
    calls = _counting(monkeypatch)
    op, ac = netdae.run(netdae.load(SWITCHED))
    assert len(calls) == 2
    # closed form: ron = 10 ohm into 1 kohm
    assert op["v(out)"][0] == pytest.approx(1000 / 1010, rel=1e-9)
    np.testing.assert_allclose(np.abs(ac["v(out)"]), 1000 / 1010, rtol=1e-9)


def test_outside_run_every_call_solves(monkeypatch):
    circuit = netdae.load(MILLER)
    calls = _counting(monkeypatch)
    operating_point(circuit)
    operating_point(circuit)
    assert len(calls) == 2
