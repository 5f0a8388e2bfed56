"""``netdae compare`` on disagreeing operating points: which point solves netdae's DC equations.

The reverse-biased diode on a 50 V node is a circuit where SPICE's update test
(reltol |v| + vntol, 50 mV there) lets Newton stop with the diode forward-biased:
ngspice 39 reports v(sw) = 50.559 V, netdae (whose residual test measures a node row
against its branch currents) 5.1e-5 V. The check puts both points into netdae's
equations and says which rows each leaves off, in amperes and tolerances.
"""

from __future__ import annotations

import math

import pytest

import netdae
from netdae.analyses.op import operating_point
from netdae.comparison.currentlaw import current_law_errors, current_law_note
from netdae.netlist import load

DIODE = """a diode reverse-biased from a source at 50 V through 1 MOhm
vout out 0 50
d1 sw out ds
roff sw 0 1e6
.model ds d(is=1e-12)
.op
.end
"""

#: The point ngspice 39 stops at (its .op output): the diode forward at 0.559 V.
NGSPICE_POINT = {"v(out)": 50.0, "v(sw)": 50.5591808, "i(vout)": -5.05591808e-05}


def _netdae_point(circuit):
    res = operating_point(circuit)
    return {name: float(res[name][0]) for name in res.names()}


def test_a_point_off_its_current_law_is_named_with_its_residual():
    circuit = load(DIODE)
    note = current_law_note(circuit, _netdae_point(circuit), NGSPICE_POINT, {})
    assert note is not None
    ngspice_part, netdae_part = note.split("; ")[:2]
    # the diode's current at 0.559 V minus Roff's: Is (exp(vd / vt) - 1) - v / Roff, at 27 C
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    leak = 1e-12 * math.expm1(0.5591808 / vt) + 1e-12 * 0.5591808 + 50.5591808 / 1e6
    assert "ngspice's point leaves the current law of node" in ngspice_part and "node sw off by" in ngspice_part
    got = float(ngspice_part.split("node sw off by ")[1].split(" A")[0])
    assert abs(got - leak) <= 0.01 * leak, (got, leak)
    assert netdae_part.startswith("netdae's point solves them")


def test_points_that_both_solve_the_equations_get_no_note():
    circuit = load(DIODE)
    point = _netdae_point(circuit)
    moved = {**point, "v(sw)": point["v(sw)"] * (1 + 1e-6)}
    assert current_law_note(circuit, point, moved, {}) is None


def test_a_point_without_its_internal_nodes_gets_them_from_their_own_rows():
    # rs = 10: the diode's internal node; ngspice's point (no internal node) is completed from its
    # current law and then still leaves node sw's off; netdae's own outer values need no note
    circuit = load(DIODE.replace("d(is=1e-12)", "d(is=1e-12 rs=10)"))
    point = _netdae_point(circuit)
    assert any("#" in name for name in point)
    outer = {name: value for name, value in point.items() if "#" not in name}
    assert current_law_note(circuit, point, outer, {}) is None
    note = current_law_note(circuit, point, NGSPICE_POINT, {})
    assert note is not None and "ngspice's point leaves the current law of node sw off by" in note


def test_a_point_without_an_outer_node_gets_no_note():
    circuit = load(DIODE)
    point = _netdae_point(circuit)
    assert current_law_note(circuit, point, {"v(out)": 50.0, "i(vout)": -5.06e-5}, {}) is None


def test_the_errors_are_in_units_of_each_row_s_tolerance():
    from netdae.analyses.prepared import prepare

    circuit = load(DIODE)
    system = prepare(circuit).system
    x = [NGSPICE_POINT[name] for name in system.names]
    residual, ratio = current_law_errors(system, x, 1e-3, 1e-12, 1e-6)
    k = list(system.names).index("v(sw)")
    # the row's branch currents: the diode's conductance times its voltage and Roff's current
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    gd = 1e-12 * math.exp(0.5591808 / vt) / vt + 1e-12
    magnitude = gd * 0.5591808 + 50.5591808 / 1e6
    assert ratio[k] == pytest.approx(abs(residual[k]) / (1e-3 * magnitude + 1e-12), rel=1e-3)


@pytest.mark.ngspice
def test_compare_says_which_point_solves_the_equations():
    comparison = netdae.compare(DIODE, backend="subprocess")
    (op,) = comparison.analyses
    assert op.passed is False  # ngspice 39 stops at the forward-biased point
    (note,) = [n for n in op.notes if n.startswith("current-law check")]
    assert "ngspice's point leaves the current law of node" in note and "netdae's point solves them" in note


def test_the_worst_sweep_point_is_where_the_two_differ_most_in_each_signal_s_scale():
    import numpy as np

    from netdae.comparison.currentlaw import worst_sweep_point

    curves = {"values": {"v(a)": (np.array([1.0, 2.0, 3.0]), np.array([1.0, 2.5, 3.0])),
                         "i(v1)": (np.array([0.0, 0.0, 1e-3]), np.array([0.0, 0.0, 3e-3]))}}
    # v(a): 0.5 V of 10 V at point 1; i(v1): 2 mA of 10 mA at point 2
    assert worst_sweep_point(curves, [("v(a)", 10.0), ("i(v1)", 0.01)]) == 2
    assert worst_sweep_point(curves, [("v(a)", 1.0), ("i(v1)", 0.01)]) == 1


@pytest.mark.ngspice
def test_compare_checks_a_source_sweep_at_its_worst_point():
    # from 50 V on, ngspice starts the sweep at the forward-biased point and keeps it
    comparison = netdae.compare(DIODE.replace(".op", ".dc vout 50 100 10"), backend="subprocess")
    (dc,) = comparison.analyses
    assert dc.passed is False
    (note,) = [n for n in dc.notes if "current-law check" in n]
    assert note.startswith("at vout = ") and "(the sweep's largest difference)" in note
    assert "ngspice's point leaves the current law of node" in note and "netdae's point solves them" in note
