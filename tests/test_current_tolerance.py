"""A source current through a resistor is tested no tighter than the node voltages make it.

``V1 in 0 SIN(0 10 100k)`` through 10 ohm into 1 pF: the source current is the 63 uV lag of the
capacitor's node behind the 10 V input, over 10 ohm, 6.3 uA. Tested at its own tolerance
(``reltol |i| + abstol``, 6e-12 A at reltol 1e-6) it asked the node voltages for 6e-11 V, and the run
took 310,308 steps of the 10 ps mode where ngspice (which tests charges only) takes about 400. An
algebraic current that only resistive rows tie to the other unknowns now takes the tolerance those
rows give it, ``sum_j |J_rj| tol_j / |J_ri|`` (:func:`netdae.dae.compiled.control.current_error_weights`).
Oracles: the closed form of the RC section, and the step counts (the work).
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.dae.bdf.arguments import current_rows

AMP, FREQ, R, C = 10.0, 1e5, 10.0, 1e-12
RC = f"""RC behind 10 ohm
V1 in 0 SIN(0 {AMP:g} {FREQ:g})
R1 in a {R:g}
C1 a 0 {C:g}
.tran 100n 20u
.end
"""
#: The same with a 0 V source as an ammeter in series (its current law ties the two source currents).
AMMETER = RC.replace("R1 in a", "Vam in b 0\nR1 b a")
#: With a diode clamping the capacitor's node (nonlinear; it conducts on the negative half-waves).
CLAMP = RC.replace(".tran", "D1 0 a dr\n.model dr d(is=1e-14)\n.tran")


def exact(t):
    """v(a) and the source current of the RC section driven by AMP sin(w t) from rest."""
    w, tau = 2 * np.pi * FREQ, R * C
    wt = w * tau
    va = AMP / (1 + wt**2) * (np.sin(w * t) - wt * np.cos(w * t) + wt * np.exp(-t / tau))
    return va, -(AMP * np.sin(w * t) - va) / R


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("netlist", [RC, AMMETER], ids=["rc", "ammeter"])
@pytest.mark.parametrize("reltol", [1e-3, 1e-6])
def test_source_current_of_an_rc_section(engine, netlist, reltol, monkeypatch):
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    r = netdae.simulate(netdae.load(netlist.replace(".tran", f".options reltol={reltol:g}\n.tran")))
    assert r.ok, r.message
    assert r.stats["steps"] < 600  # 310,308 at reltol 1e-6 before (ngspice: about 400)
    t = np.linspace(1e-7, 2e-5, 2001)
    va, i1 = exact(t)
    got = r.dense(t)
    # the voltage within its tolerance; the current within what that tolerance makes of it over R
    tol_v = reltol * AMP + 1e-6
    assert np.max(np.abs(got["v(a)"] - va)) <= tol_v
    assert np.max(np.abs(got["i(v1)"] - i1)) <= 2 * tol_v / R


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_clamped_rc_takes_steps_of_its_input_not_of_its_mode(engine, monkeypatch):
    """The diode conducting on the negative half-waves: 1,184 steps at the default tolerance and 315,298 at
    reltol 1e-6 before (ngspice 208 and 427). Against the run at reltol 1e-9 in tolerance units."""
    monkeypatch.setenv("NETDAE_ENGINE", engine)
    ref = netdae.simulate(netdae.load(CLAMP.replace(".tran", ".options reltol=1e-9\n.tran")))
    t = np.linspace(1e-7, 2e-5, 4001)
    want = ref.dense(t)
    for reltol, most in ((1e-3, 600), (1e-6, 1500)):
        r = netdae.simulate(netdae.load(CLAMP.replace(".tran", f".options reltol={reltol:g}\n.tran")))
        assert r.ok, r.message
        assert r.stats["steps"] < most
        got = r.dense(t)
        assert np.max(np.abs(got["v(a)"] - want["v(a)"])) <= 5 * (reltol * AMP + 1e-6)


def test_which_currents_and_rows():
    """Candidates: currents without charge; rows: the charge-free rows where H ties them to another unknown."""
    from netdae.mna import assemble

    def rows_of(text):
        system = assemble(netdae.load(text), mode="tran", tstep=1e-7, tstop=2e-5)
        mask = np.ones(system.n)
        cand, rptr, eptr, ecol, ecand, gain, _ = current_rows(system, mask, np.empty(0, dtype=np.int64))
        names = system.names
        return {names[i]: sorted((names[int(j)], float(g)) for j, g in
                                 zip(ecol[eptr[rptr[c]]:eptr[rptr[c + 1]]], gain[eptr[rptr[c]]:eptr[rptr[c + 1]]]))
                for c, i in enumerate(cand)}

    # the source's current law (resistive) ties it to v(in) and v(a) through 1/R
    assert rows_of(RC) == {"i(v1)": [("v(a)", 1 / R), ("v(in)", 1 / R)]}
    # a capacitor on the source's node: its row has a charge, so the current keeps its own tolerance
    assert rows_of(RC.replace("C1 a 0", "C2 in 0 1p\nC1 a 0")) == {"i(v1)": []}
    # the ammeter: the source's row holds only the other current, the ammeter's its resistor too
    got = rows_of(AMMETER)
    assert got["i(vam)"] == [("i(v1)", 1.0), ("v(a)", 1 / R), ("v(b)", 1 / R)] and got["i(v1)"] == [("i(vam)", 1.0)]
