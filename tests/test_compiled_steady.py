"""The compiled operating-point Newton is the Python solver's first phase, step for step.

For MNA systems of the compiled engine's device families, plain Newton runs in
``netdae/dae/compiled/steady.py`` (called by ``steady_driver.py``); ``NETDAE_ENGINE=python`` keeps it in
``netdae/dae/steady.py``. Both must give the same operating points (within the
convergence tolerance: the same iterates up to rounding), the same iteration
counts and strategies, and hand the same circuits to the homotopies.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import NETLISTS
from test_devices_ngspice import HARD  # plain Newton overshoots; the homotopies rescue it
from netdae.analyses.dc import dc_sweep
from netdae.analyses.op import operating_point
from netdae.circuit import DcAnalysis
from netdae.dae.compiled import steady_driver as compiled
from netdae.netlist import load

CIRCUITS = ["bridge_rectifier.cir", "ce_amplifier.cir", "cmos_inverter.cir", "diff_pair.cir",
            "voltage_multiplier.cir", "ring_oscillator.cir", "halfwave_rectifier.cir", "diode_iv.cir",
            "testset_transamp.cir", "cw_doubler.cir", "vanderpol_mu1.cir", "jfet_amplifier.cir"]



@pytest.fixture
def calls(monkeypatch):
    """Counts the compiled solves (and checks that the compiled path is the one taken)."""
    seen = []
    original = compiled.solve_dc

    def counting(*args, **kw):
        out = original(*args, **kw)
        seen.append(out[1])
        return out

    monkeypatch.setattr(compiled, "solve_dc", counting)
    return seen


def _both(monkeypatch, run):
    fast = run()
    monkeypatch.setenv("NETDAE_ENGINE", "python")
    slow = run()
    monkeypatch.delenv("NETDAE_ENGINE")
    return fast, slow


def _within_tolerance(a, b, names, reltol=1e-3, vntol=1e-6, abstol=1e-12):
    for name in names:
        x, y = float(a[name][0]), float(b[name][0])
        atol = abstol if name.startswith("i(") else vntol
        assert abs(x - y) <= reltol * max(abs(x), abs(y)) + atol, (name, x, y)


@pytest.mark.parametrize("name", CIRCUITS)
def test_operating_points_equal_the_python_solver(name, monkeypatch, calls):
    circuit = load(NETLISTS / name)
    fast, slow = _both(monkeypatch, lambda: operating_point(circuit))
    assert calls and calls[0] in (compiled.CONVERGED, compiled.NOT_CONVERGED, compiled.ILL_CONDITIONED)
    assert fast.stats["strategy"] == slow.stats["strategy"]
    if calls[0] == compiled.CONVERGED:
        assert fast.stats["strategy"] == "newton"
        assert abs(fast.stats["newton_iterations"] - slow.stats["newton_iterations"]) <= 1  # the same iterates, up to rounding
    _within_tolerance(fast, slow, slow.signals)


def test_where_plain_newton_fails_the_homotopies_take_over(monkeypatch, calls):
    fast, slow = _both(monkeypatch, lambda: operating_point(load(HARD)))
    assert calls == [compiled.NOT_CONVERGED] or calls == [compiled.ILL_CONDITIONED]
    assert fast.stats["strategy"] == slow.stats["strategy"] != "newton"
    np.testing.assert_array_equal(fast["v(c)"], slow["v(c)"])  # the Python solver ran both from the start


def test_a_dc_sweep_equals_the_python_solver(monkeypatch, calls):
    circuit = load(NETLISTS / "cmos_inverter.cir")
    card = next(a for a in circuit.analyses if isinstance(a, DcAnalysis))
    fast, slow = _both(monkeypatch, lambda: dc_sweep(circuit, card))
    assert calls and all(c == compiled.CONVERGED for c in calls)
    a, b = fast["v(out)"], slow["v(out)"]
    np.testing.assert_array_less(np.abs(a - b), 1e-3 * np.maximum(np.abs(a), np.abs(b)) + 1e-6)


def _point_by_point(monkeypatch, run):
    """``run()`` with the compiled sweep, then with one compiled solve per point."""
    import netdae.analyses.dc as dc

    swept = run()
    monkeypatch.setattr(dc, "_compiled_sweep", lambda *a, **k: None)
    single = run()
    monkeypatch.undo()
    return swept, single


@pytest.mark.parametrize("name", ["cmos_inverter.cir", "diode_iv.cir", "bridge_dc.cir"])
def test_the_compiled_sweep_is_the_point_by_point_sweep(name, monkeypatch):
    circuit = load(NETLISTS / name)
    card = next((a for a in circuit.analyses if isinstance(a, DcAnalysis)), None)
    if card is None:
        pytest.skip(f"{name} has no .dc")
    swept, single = _point_by_point(monkeypatch, lambda: dc_sweep(circuit, card))
    assert swept.stats["newton_iterations"] == single.stats["newton_iterations"]
    for nm in single.signals:
        np.testing.assert_array_equal(swept[nm], single[nm])


def test_a_point_plain_newton_cannot_solve_goes_to_the_homotopies_and_the_sweep_resumes(monkeypatch):
    # from 10 V to 400 V in one step plain Newton overshoots (HARD's exponentials without limiting)
    text = HARD.replace(".end", ".dc V1 0 400 10\n.end")
    circuit = load(text)
    card = circuit.analyses[0]
    seen = []
    original = compiled.sweep_points

    def counting(*args, **kw):
        out = original(*args, **kw)
        seen.append((args[4], out[2]))
        return out

    monkeypatch.setattr(compiled, "sweep_points", counting)
    swept = dc_sweep(circuit, card)
    monkeypatch.undo()
    assert len(seen) >= 2 and any(stop < 41 for _, stop in seen)  # stopped, then resumed after the hard point
    _, single = _point_by_point(monkeypatch, lambda: dc_sweep(circuit, card))
    for nm in single.signals:
        np.testing.assert_array_equal(swept[nm], single[nm])


BJT_CURVES = """BJT output characteristics: the base current steps from zero
VCE c 0 0
IB 0 b 0
Q1 c b 0 QN
.model QN NPN(IS=1e-15 BF=150 VAF=60 BR=3 RB=50 RC=2 IKF=50m)
.dc VCE 0 10 0.05 IB 0 50u 10u
.end
"""


def test_a_pivot_proven_regular_lets_the_compiled_sweep_take_its_neighbours(monkeypatch):
    # at IB = 0 the base hangs on the junctions' leakage and gmin: every point's smallest equilibrated pivot
    # (6e-11 at VCE = 0 to 1e-8 at 10 V) is below PIVOT_SUSPECT, so each went to the full solver and its SVD,
    # which judged it regular; now the first judgement clears the points whose pivots stay within
    # PROVEN_PIVOT_FRACTION of it, and the values are the point-by-point solver's within its tolerance
    import netdae.analyses.dc as dc

    circuit = load(BJT_CURVES)
    card = circuit.analyses[0]
    full = []
    original = dc._solve_point

    def counting(prepared, opts, x, names, values):
        res = original(prepared, opts, x, names, values)
        full.append((values, res.min_pivot))
        return res

    monkeypatch.setattr(dc, "_solve_point", counting)
    swept = dc_sweep(circuit, card)
    assert len(full) == 1 and full[0][1] < 1e-9  # the first point only, judged by the SVD
    monkeypatch.setattr(dc, "PROVEN_PIVOT_FRACTION", np.inf)  # every suspect pivot to the full solver, as before
    full.clear()
    judged = dc_sweep(circuit, card)
    at_zero = [p for values, p in full if values[1] == 0.0]
    assert len(at_zero) == 201 and all(p < 1e-6 for p in at_zero)  # the whole IB = 0 curve
    for nm in ("v(b)", "i(vce)"):
        a, b = swept[nm], judged[nm]
        np.testing.assert_array_less(np.abs(a - b), 1e-3 * np.maximum(np.abs(a), np.abs(b)) + 1e-9)


def test_a_sweep_point_whose_matrix_becomes_singular_is_still_refused():
    # G1's transconductance is the only path of node a, and it is proportional to the swept v(c): at
    # v(c) = 0 node a floats, whatever the pivots of the points before
    text = """floating at one point of the sweep
V1 c 0 1
B1 a 0 I=v(a)*v(c)
R1 c 0 1k
.dc V1 1 -1 -0.25
.end
"""
    circuit = load(text)
    res = dc_sweep(circuit, circuit.analyses[0])  # the sweep stops there, keeping the points before
    assert not res.ok and res.axis.tolist() == [1.0, 0.75, 0.5, 0.25]
    assert res.message.lower().startswith(".dc at v1 = 0: dc operating point singular")


HYSTERESIS = """positive feedback: the sweep leaves the .nodeset state on its branch
V1 in 0 0
R1 in p 10k
R2 p out 100k
B1 out 0 V = 5*tanh(100*v(p))
.nodeset v(out)=5
.dc V1 -1 1 0.05
.end
"""


def test_nodesets_act_at_the_first_point_and_the_compiled_sweep_takes_the_rest(monkeypatch):
    # ngspice applies .nodeset in its junction-initialisation modes only (the first point, a point solved
    # from scratch); from the previous point's solution it does not: netdae's sweep went point by point
    # through the full solver with the nodeset pulling each one. At in = -1 only the lower state exists
    # (out = -5), and the sweep follows it up to the branch's end at in = 0.5 (v(p) = (10 in + out) / 11
    # reaches 0), whatever the nodeset says, as ngspice's sweep does
    import netdae.analyses.dc as dc

    circuit = load(HYSTERESIS)
    full = []
    original = dc._solve_point

    def counting(prepared, opts, x, names, values):
        full.append(values)
        return original(prepared, opts, x, names, values)

    monkeypatch.setattr(dc, "_solve_point", counting)
    res = dc_sweep(circuit, circuit.analyses[0])
    assert len(full) == 1  # the first point
    vin, out = np.asarray(res.axes["v1"]), np.asarray(res["v(out)"])
    for x, y in zip(vin, out):
        # the stable state on the branch: out = 5 tanh(100 v(p)) iterated from the rail (a contraction there)
        root = -5.0 if x < 0.5 - 1e-9 else 5.0
        for _ in range(200):
            root = 5.0 * np.tanh(100.0 * (10.0 * x + root) / 11.0)
        assert y == pytest.approx(root, abs=1e-6), (x, y, root)
