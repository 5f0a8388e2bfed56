"""A transient that stays at an unstable operating point says so.

The exact solution from an equilibrium stays there, and a symmetric circuit (an astable multivibrator
built of two equal halves) stays on it in netdae's arithmetic too, where ngspice's rounding noise starts
it: the run gives flat lines. netdae then warns, with the growing mode's time constant from the pencil at
the operating point and the nodes it moves, and says how to start the circuit
(netdae.analyses.instability).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import netdae

#: A parallel LC with a negative conductance (a VCCS of -1 mS fed back onto its own node, and 1 uS to a
#: source at 0 V): G = -0.999 mS, C v'' + G v' + v / L = 0, lambda = (-G +- sqrt(G^2 - 4 C / L)) / (2 C)
#: = 4.995e5 +- 3.16224e7 j for C = 1 nF, L = 1 uH.
NEGATIVE_LC = """negative-resistance LC at rest
C1 a 0 1n
L1 a 0 1u
G1 a 0 a 0 -1m
R1 a b 1meg
V1 b 0 DC 0
.tran 1u 1m
.end
"""

#: Two equal halves: the operating point is symmetric and unstable (tau about 2.6 ns).
ASTABLE = """BJT astable multivibrator
VCC vcc 0 DC 5
RC1 vcc c1 1k
RC2 vcc c2 1k
RB1 vcc b1 47k
RB2 vcc b2 47k
C1 c1 b2 10n
C2 c2 b1 10n
Q1 c1 b1 0 qn
Q2 c2 b2 0 qn
.model qn npn(bf=100 is=1e-14 cje=5p cjc=2p tf=0.5n tr=10n rb=50)
{ic}
.tran 1u 1m
.end
"""


def _warning(res) -> str | None:
    found = [n for n in res.notes if "stayed at the DC operating point" in n]
    return found[0] if found else None


def test_a_flat_run_at_an_unstable_equilibrium_names_the_growing_mode():
    res = netdae.simulate(netdae.load(NEGATIVE_LC))
    assert res.ok, res.message
    assert np.max(np.abs(res["v(a)"])) == 0.0  # the exact solution: nothing moves
    note = _warning(res)
    assert note is not None and note.startswith("warning: ")
    # the closed form: Re(lambda) = -G / 2C, Im(lambda) = sqrt(4 C / L - G^2) / 2C
    g = -1e-3 + 1e-6
    lam = re.search(r"eigenvalue ([-+0-9.e]+) \+- ([0-9.e+]+)j 1/s", note)
    assert lam is not None, note
    assert float(lam.group(1)) == pytest.approx(-g / 2e-9, rel=1e-3)
    assert float(lam.group(2)) == pytest.approx(np.sqrt(4e-9 / 1e-6 - g * g) / 2e-9, rel=1e-3)
    tau = re.search(r"exp\(t / ([0-9.e+-]+) s\)", note)
    assert float(tau.group(1)) == pytest.approx(2e-9 / -g, rel=1e-2)
    assert "mostly v(a))" in note  # not v(b): the source holds it
    assert ".ic v(a)=" in note


def test_the_symmetric_astable_stays_and_is_told_how_to_start():
    res = netdae.simulate(netdae.load(ASTABLE.format(ic="")))
    assert res.ok, res.message
    assert np.ptp(res["v(c1)"]) < 1e-3  # flat: it never starts
    note = _warning(res)
    assert note is not None
    assert re.search(r"mostly v\((c|b)[12]\)", note), note
    # the hint works: one node held off the symmetric point in the operating point starts it
    started = netdae.simulate(netdae.load(ASTABLE.format(ic=".ic v(c2)=0")))
    assert started.ok, started.message
    assert _warning(started) is None
    assert np.ptp(started["v(c1)"]) > 4.0


def test_a_stable_circuit_at_rest_has_no_warning():
    res = netdae.simulate(netdae.load("rc at rest\nV1 a 0 DC 1\nR1 a b 1k\nC1 b 0 1u\n.tran 10u 1m\n.end\n"))
    assert res.ok, res.message
    assert _warning(res) is None


def test_no_warning_when_the_growing_mode_is_not_among_the_saved_signals():
    # an astable beside a divider, only the divider saved: the astable may have left its point unseen
    text = ASTABLE.format(ic="").replace(".tran", "RD1 vcc d 1k\nRD2 d 0 1k\n.save v(d)\n.tran")
    res = netdae.simulate(netdae.load(text))
    assert res.ok and list(res.signals) == ["v(d)"]
    assert _warning(res) is None
    res = netdae.simulate(netdae.load(text.replace(".save v(d)", ".save v(d) v(c1) v(c2) v(b1) v(b2)")))
    assert _warning(res) is not None


#: A Wien-bridge oscillator (loop gain 3.2 against the 3 it needs) at rest: ngspice's run stays at 0 V too.
WIEN = """wien bridge
B1 out 0 V=12*tanh(1e5*(v(p)-v(n))/12)
R1 out a 10k
C1 a p 16n
R2 p 0 10k
C2 p 0 16n
Rf out n 22k
Rg n 0 10k
.tran 10u 20m
.end
"""


def test_a_slowly_growing_oscillator_at_rest_is_warned_about_too():
    res = netdae.simulate(netdae.load(WIEN))
    assert res.ok and np.max(np.abs(res["v(out)"])) == 0.0
    note = _warning(res)
    assert note is not None
    # growth 1/(R C) (A - 3) / 2 ... about 625 1/s at 6.2 krad/s: e^12.5 over the 20 ms
    growth = float(re.search(r"by e\^([0-9.e+]+) over the run", note).group(1))
    assert 10.0 < growth < 15.0
