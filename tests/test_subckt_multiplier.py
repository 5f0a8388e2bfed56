"""``m=`` on a subcircuit instance: ngspice 39 multiplies the elements inside.

ngspice adds ``m={m}`` to the cards of the body (not to B, V, E, H) of a subcircuit one of
whose instances gives ``m=`` (``inp_fix_subckt_multiplier``). netdae multiplies the elements
whose own ``m`` it applies, and refuses what would differ (an inner ``m`` that ngspice
replaces, a kind netdae does not multiply). Checked against closed forms of the DC currents,
and against ngspice.
"""

import math

import pytest

import netdae
from netdae.errors import NetlistError

BODY = """\
.subckt cr a
R1 a 0 1k
.ends
.subckt cg a
G1 a 0 a 0 1m
.ends
.subckt cf a
VS a b 0
R1 b 0 1k
F1 a 0 VS 1
.ends
.subckt ce a
E1 b 0 a 0 1
R1 b 0 1k
RA a 0 1k
.ends
.subckt cd a
D1 a 0 DD
.ends
.subckt nest a
X1 a cr
.ends
.model DD D(IS=1e-14)
V1 in 0 DC 0.5
VR in nr 0
XR nr cr m=3
VG in ng 0
XG ng cg m=3
VF in nf 0
XF nf cf m=3
VE in ne 0
XE ne ce m=3
VD in nd 0
XD nd cd m=3
VN in nn 0
XN nn nest m={2+1}
VP in np 0
XP np cr
.op
"""

V = 0.5
VT = 1.38064852e-23 * 300.15 / 1.6021766208e-19  # ngspice 39 constants (CONSTboltz, CHARGE): kT/q at 27 C


def _op(text):
    (res,) = netdae.run(netdae.load("m on subcircuit instances\n" + text + ".end\n"))
    return {name: float(res[name][0]) for name in res.names()}


def test_instance_multiplier_closed_form():
    op = _op(BODY)
    rtol = 1e-9
    # i(vx): the current from node in through the source into the instance
    assert op["i(vr)"] == pytest.approx(3 * V / 1e3, rel=rtol)          # R: conductance times m
    assert op["i(vg)"] == pytest.approx(3 * 1e-3 * V, rel=rtol)         # G: transconductance times m
    # F: its controlling current is R1's (times m), and F itself is times m
    assert op["i(vf)"] == pytest.approx(3 * V / 1e3 + 3 * (3 * V / 1e3), rel=rtol)
    assert op["i(ve)"] == pytest.approx(3 * V / 1e3, rel=rtol)          # E not multiplied, RA is
    assert op["i(vn)"] == pytest.approx(3 * V / 1e3, rel=rtol)          # through a nested instance
    assert op["i(vp)"] == pytest.approx(V / 1e3, rel=rtol)              # an instance without m
    diode = 1e-14 * math.expm1(V / VT) + 1e-12 * V                       # IS (e^(v/vt) - 1) + gmin v
    assert op["i(vd)"] == pytest.approx(3 * diode, rel=1e-6)


def test_subckt_parameter_named_m_stays_a_parameter():
    text = """\
.subckt cr a params: m=1
R1 a 0 {1k*m}
.ends
V1 in 0 DC 0.5
VR in nr 0
XR nr cr m=4
.op
"""
    op = _op(text)
    assert op["i(vr)"] == pytest.approx(V / 4e3, rel=1e-9)


@pytest.mark.parametrize("body, words", [
    (".subckt cr a\nR1 a 0 1k m=2\n.ends\nV1 in 0 0.5\nXR in cr m=3\n.op\n", "replaces the inner m"),
    (".subckt cr a\nR1 a 0 1k\n.ends\n.subckt n2 a\nX1 a cr m=5\n.ends\nV1 in 0 0.5\nXR in n2 m=3\n.op\n",
     "replaces the inner m"),
    (".subckt ci a\nI1 a 0 1m\nR1 a 0 1k\n.ends\nXI in ci m=2\nR9 in 0 1\n.op\n", "isource"),
])
def test_refused_where_netdae_would_differ(body, words):
    with pytest.raises(NetlistError, match=words):
        netdae.load("m refused\n" + body + ".end\n")


def test_unknown_parameter_still_refused():
    with pytest.raises(NetlistError, match="has no parameter 'q'"):
        netdae.load("t\n.subckt cr a\nR1 a 0 1k\n.ends\nV1 in 0 1\nXR in cr q=3\n.op\n.end\n")


@pytest.mark.ngspice
def test_instance_multiplier_against_ngspice():
    from netdae.ngspice import run_ngspice

    text = "m on subcircuit instances\n" + BODY + ".end\n"
    ours = _op(BODY)
    ng = run_ngspice(text).result("op")
    for name in ("i(vr)", "i(vg)", "i(vf)", "i(ve)", "i(vd)", "i(vn)", "i(vp)"):
        assert ours[name] == pytest.approx(float(ng[name][0]), rel=1e-9, abs=1e-15)
