"""Operating points that stopped early: non-finite equations, regular Jacobians with tiny pivots.

* A behavioural expression ``v(a) / v(b)`` is ``0 / 0`` at the zero initial
  guess. ngspice's division adds ``gmin * 1e-20`` to the denominator (and to
  the ``b**2`` of its derivative), so the value and its derivatives are 0
  there and Newton starts; netdae does the same (the resistor whose value
  reads a node voltage becomes such a source).
* Equations that are not finite wherever the solver stands (the square root
  of a negative voltage) stop every strategy before an iteration: the error
  says so and names the equations, the elements and the values they read,
  never "did not converge after 0 Newton iterations".
* A node that reaches ground only through the 1e-12 S gmin of reverse-biased
  junctions, next to a 1 S resistor, gives a regular Jacobian whose smallest
  equilibrated pivot (about 1e-12) lies below ``PIVOT_SAFETY * n * eps``:
  the SVD rank decision confirms it regular and the iteration goes on (it
  used to stop there, and the ``.dc`` sweep of a reverse base current failed).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.dae.sparse import SparsePattern
from netdae.dae.steady import EPS, PIVOT_SAFETY, _check_pivot, _FreshLU, jacobian_rank
from netdae.errors import ConvergenceError

RELTOL, VNTOL = 1e-3, 1e-6

DIVISION = """resistor whose value reads a node voltage, 0/0 at the initial guess
v1 1 0 dc 2
v2 200 0 dc 1
r10 1 20 1k
r20 20 0 '1k*v(200)' tc1=0.001
.temp 127
.op
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_division_by_zero_at_the_initial_guess_starts_as_in_ngspice(engine, monkeypatch):
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    res = operating_point(netdae.load(DIVISION))
    # closed form: 1k in series with 1k * v(200) * (1 + tc1 (127 - 27)) = 1.1k from 2 V
    expected = 2.0 * 1100.0 / (1000.0 + 1100.0)
    got = float(res["v(20)"][0])
    assert abs(got - expected) <= RELTOL * abs(expected) + VNTOL, got


@pytest.mark.ngspice
def test_division_by_zero_at_the_initial_guess_agrees_with_ngspice():
    comparison = netdae.compare(DIVISION, backend="subprocess")
    assert comparison.passed, comparison


def test_zero_over_zero_is_zero_with_zero_derivatives():
    from netdae.devices.autodiff import DIVISION_FUDGE, _binary

    a = np.array([0.0, 1.0, -3.0])
    b = np.array([0.0, 2.0, 0.0])
    da = np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])  # d/d(leaf 0) of a, d/d(leaf 1) of a
    db = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    q, d = _binary("/", a, da, b, db)
    assert q[0] == 0.0 and np.all(d[:, 0] == 0.0)
    assert q[1] == pytest.approx(0.5, rel=1e-15) and d[:, 1] == pytest.approx([0.5, -0.25], rel=1e-15)
    assert q[2] == pytest.approx(-3.0 / DIVISION_FUDGE)  # ngspice's huge but finite quotient


def test_equations_not_finite_at_the_start_are_named():
    netlist = """square root of a negative voltage wherever the solver starts
v2 200 0 dc 1
r10 200 20 1k
b1 20 0 i=1m*sqrt(v(200)-0.5)
.op
.end
"""
    with pytest.raises(ConvergenceError) as info:
        operating_point(netdae.load(netlist))
    text = str(info.value)
    assert "0 Newton iterations" not in text
    assert "not finite at the initial guess" in text
    assert "b1" in text and "node '20'" in text and "v(200) = 0" in text


REVERSE_BASE = """reverse base current: the base reaches ground only through the junctions' gmin
q1 2 1 0 qn
ib 0 11 -0.1u
rb 11 1 1
vce 2 0 5
.model qn npn is=0.166f bf=324 vaf=84.57 ikf=24.6m br=37.2 var=1.696 ikr=39.6m rb=118 rbm=65.1 rc=26.45
.dc vce -0.1 0.5 0.1 ib -0.1u 0.1u 0.1u
.end
"""


def test_gmin_path_to_ground_is_a_regular_jacobian():
    # node 11 -(1 S)- node 1 -(1/118 S)- base -(two junctions' gmin of 1e-13 S)- ground: the base
    # row's equilibrated pivot is about 2e-13 * 118, below 1e3 * 3 * eps
    g, gx, gmin = 1.0, 1.0 / 118.0, 1e-13
    a = np.array([[g, -g, 0.0], [-g, g + gx, -gx], [0.0, -gx, gx + 2 * gmin]])
    pattern = SparsePattern.from_coo(3, [np.repeat(np.arange(3), 3)], [np.tile(np.arange(3), 3)])
    data = a[pattern.rows, pattern.cols]
    pivot = _FreshLU(pattern, data).min_pivot
    assert pivot <= PIVOT_SAFETY * 3 * EPS  # the pivot alone would call it singular
    assert not jacobian_rank(pattern.matrix(data)).deficient
    assert _check_pivot(pattern, data, pivot, False)


def test_reverse_base_current_sweep_converges():
    res = netdae.run(REVERSE_BASE)[0]
    v1 = np.asarray(res["v(1)"])
    assert v1.size == 21 and np.all(np.isfinite(v1))
    # at ib = -0.1 uA the base current flows through the two junctions' gmin (1e-12 S each):
    # about ib / (2 gmin) = -50 kV (less half of vce, plus the drop on the modulated base resistance)
    assert abs(np.min(v1) - (-0.1e-6 / 2e-12)) <= RELTOL * 5e4 + VNTOL


@pytest.mark.ngspice
def test_reverse_base_current_sweep_agrees_with_ngspice():
    comparison = netdae.compare(REVERSE_BASE, backend="subprocess")
    assert comparison.passed, comparison


def _chain(stages: int, analysis: str) -> str:
    """A chain of saturating BJT inverters (each collector drives the next base through 10 kOhm): at an
    input above the first stage's threshold every stage switches, each the opposite of the one before."""
    lines = ["bjt inverter chain", ".model qn npn bf=100 is=1e-15 vaf=50", "VCC vcc 0 5", "VIN in 0 1.5"]
    prev = "in"
    for k in range(stages):
        lines += [f"RB{k} {prev} b{k} 10k", f"Q{k} c{k} b{k} 0 qn", f"RC{k} vcc c{k} 1k"]
        prev = f"c{k}"
    return "\n".join(lines + [analysis, ".end"]) + "\n"


def _alternates(x_c: np.ndarray) -> None:
    """Stage k saturated (its collector low) for even k, off for odd k: then its collector sits where
    the next base's current through 10 kOhm pulls it from 5 V through 1 kOhm, or at 5 V for the last."""
    low, high = x_c[0::2], x_c[1::2]
    assert np.all(low < 0.2), low.max()
    assert np.all(high[:-1] > 4.5) and np.all(high[:-1] < 4.7), (high.min(), high.max())
    assert high[-1] == pytest.approx(5.0, abs=1e-6)
    # an off stage's collector feeds the next base: 5 V - 1k (v_c - v_be)/10k; v_be of a saturated stage
    # is where is exp(v/vt) bf carries that current: the high collectors are equal to 1e-9 of each other
    assert np.ptp(high[:-1]) < 1e-6


def test_a_chain_whose_stages_all_switch_is_solved_by_pseudo_transient_continuation(monkeypatch):
    """60 stages: Newton from the initial junction voltages, gmin stepping and source stepping all
    stall (each moves many stages at once between the chain's states); implicit-Euler steps in a
    pseudo-time switch it a stage at a time. Without that stage the operating point is refused."""
    import netdae.dae.steady as steady

    op = netdae.run(netdae.load(_chain(60, ".op")))[0]
    assert op.message == "converged with pseudo-transient continuation"
    _alternates(np.array([float(op[f"v(c{k})"][0]) for k in range(60)]))
    monkeypatch.setattr(steady.PseudoTransient, "__call__", lambda self, newton, x: (x, False))
    with pytest.raises(ConvergenceError, match="did not converge"):
        netdae.run(netdae.load(_chain(60, ".op")))


def test_a_dc_sweep_point_that_fails_from_the_previous_one_is_solved_again_and_else_named(monkeypatch):
    """The sweep's point past the chain's switching: from the previous point's solution, then from
    scratch (ngspice's CKTop after its itl2 iterations); where both fail the error names the point."""
    import netdae.dae.steady as steady

    text = _chain(60, ".dc VIN 0 2 0.5")
    res = netdae.run(netdae.load(text))[0]
    _alternates(np.array([float(res[f"v(c{k})"][-1]) for k in range(60)]))
    monkeypatch.setattr(steady.PseudoTransient, "__call__", lambda self, newton, x: (x, False))
    failed = netdae.run(netdae.load(text))[0]  # the sweep stops there, keeping the points before
    assert not failed.ok and 0 < failed.points < res.points
    assert re.match(r"^\.dc at vin = [0-9.]+: .*from the previous point's solution and from scratch", failed.message)
    np.testing.assert_array_equal(failed["v(c0)"], res["v(c0)"][:failed.points])


def test_a_point_no_strategy_reaches_runs_pseudo_transient_continuation_once(monkeypatch):
    """The attempt from scratch leaves out pseudo-transient continuation, whose budget the attempt from the
    previous point has spent: a hopeless point costs one budget (it cost two)."""
    import netdae.dae.steady as steady

    calls = []

    def fails(self, newton, x):
        calls.append(1)
        return x, False

    monkeypatch.setattr(steady.PseudoTransient, "__call__", fails)
    failed = netdae.run(netdae.load(_chain(60, ".dc VIN 0 2 0.5")))[0]
    assert not failed.ok and failed.message.startswith(".dc at vin = ")
    assert len(calls) == 1


REVERSE_AT = """a diode reverse-biased from a source at {v} V through a large resistor
vout out 0 {v}
d1 sw out ds
roff sw 0 1e6
.model ds d(is=1e-12)
.op
.end
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
@pytest.mark.parametrize("volts", [5.0, 50.0, 500.0])
def test_a_junction_on_a_high_node_is_not_accepted_off_its_current_law(engine, volts, monkeypatch):
    # SPICE's update test allows reltol |v| + vntol on a node (50 mV at 50 V, two thermal
    # voltages), and the residual test measured against |J| |x| counted the junction's
    # conductance times both node potentials: v(sw) = 50.559 V, the diode forward at 0.56 V with
    # 2.45 mA, was accepted where Roff carries 51 uA (ngspice 39 stops there too). Closed form:
    # the diode is reverse biased, i = is + gmin (v - v(sw)), so v(sw) = roff (is + gmin v) / (1 + roff gmin).
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    res = operating_point(netdae.load(REVERSE_AT.format(v=volts)))
    roff, i_s, gmin = 1e6, 1e-12, 1e-12
    expected = roff * (i_s + gmin * volts) / (1.0 + roff * gmin)
    got = float(res["v(sw)"][0])
    assert abs(got - expected) <= RELTOL * abs(expected) + VNTOL, (got, expected)
