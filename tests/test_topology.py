"""Topological analysis on circuits with known answers (worked out by hand)."""

from __future__ import annotations

import json

import pytest
from test_topology_helpers import circuit, mk

from netdae.circuit import Model
from netdae.errors import CircuitError
from netdae.topology import (
    MAX_LISTED,
    analyze_topology,
    dc_singularity_explanation,
    pencil_singularity_explanation,
)


def kinds(report, severity=None):
    return [f.kind for f in report.findings if severity is None or f.severity == severity]


def finding(report, kind):
    found = [f for f in report.findings if f.kind == kind]
    assert len(found) == 1, [str(f) for f in report.findings]
    return found[0]


# ---------------------------------------------------------------- index 0, 1, 2


def test_rc_lowpass_is_index_1():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("in", "0"), 1.0), mk("r1", "resistor", ("in", "out"), 1e3),
        mk("c1", "capacitor", ("out", "0"), 1e-6)))
    assert (rep.topological_index, rep.applicable, rep.singular, rep.dc_singular) == (1, True, False, False)
    assert rep.findings == [] and rep.index2_signals == []
    assert "not 0: v1 is a voltage source" in rep.index_message


def test_capacitive_path_to_ground_without_voltage_source_is_index_0():
    rep = analyze_topology(circuit(
        mk("i1", "isource", ("0", "a"), 1e-3), mk("c1", "capacitor", ("a", "0"), 1e-6),
        mk("r1", "resistor", ("a", "b"), 1e3), mk("c2", "capacitor", ("b", "a"), 1e-6),
        mk("l1", "inductor", ("b", "0"), 1e-3)))
    assert rep.topological_index == 0
    assert "every node has a path of capacitors to ground" in rep.index_message


def test_node_without_capacitive_path_is_not_index_0():
    rep = analyze_topology(circuit(
        mk("i1", "isource", ("0", "a"), 1e-3), mk("c1", "capacitor", ("a", "0"), 1e-6),
        mk("r1", "resistor", ("a", "b"), 1e3), mk("r2", "resistor", ("b", "0"), 1e3)))
    assert rep.topological_index == 1
    assert "node 'b' has no path of capacitors to ground" in rep.index_message


def test_voltage_source_parallel_to_capacitor_is_index_2():
    rep = analyze_topology(circuit(mk("v1", "vsource", ("a", "0"), 1.0), mk("c1", "capacitor", ("a", "0"), 1e-6)))
    assert rep.topological_index == 2
    assert [(lp.elements, lp.nodes) for lp in rep.cv_loops] == [(("v1", "c1"), ("0", "a"))]
    assert rep.index2_signals == ["i(v1)"]
    f = finding(rep, "cv_loop")
    assert f.signals == ("i(v1)",) and set(f.elements) == {"v1", "c1"}
    assert "i(v1) depends on the derivative of the voltage of v1" in f.message
    assert "0 -v1- a -c1- 0" in f.message


def test_source_and_two_capacitors_in_a_loop_is_index_2():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("c1", "capacitor", ("a", "b"), 1e-6),
        mk("c2", "capacitor", ("b", "0"), 1e-6), mk("r1", "resistor", ("b", "0"), 1e3)))
    assert rep.topological_index == 2
    (loop,) = rep.cv_loops
    assert loop.elements == ("v1", "c1", "c2") and loop.nodes == ("0", "a", "b")
    assert loop.path() == "0 -v1- a -c1- b -c2- 0"
    assert "the capacitors c1 and c2" in finding(rep, "cv_loop").message
    assert rep.counts["cv_loops"] == 1 and rep.counts["c_loops"] == 0


def test_current_source_feeding_an_inductor_is_index_2():
    rep = analyze_topology(circuit(mk("i1", "isource", ("0", "a"), 1e-3), mk("l1", "inductor", ("a", "0"), 1e-3)))
    assert rep.topological_index == 2
    assert [(c.nodes, c.elements) for c in rep.li_cutsets] == [(("a",), ("i1", "l1"))]
    assert rep.index2_signals == ["v(a)"]
    f = finding(rep, "li_cutset")
    assert "v(a) depends on the derivative of the current of i1" in f.message


def test_two_series_inductors_form_an_inductor_cutset_index_2():
    """The middle node of two series inductors is cut off by {l1, l2}: an L-cutset.

    KCL there gives i(l1) = i(l2); differentiating, v(a) = v(b) L1/(L1+L2) is
    found only after one differentiation: index 2 (no source derivative).
    """
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("in", "0"), 1.0), mk("r1", "resistor", ("in", "b"), 1.0),
        mk("l2", "inductor", ("b", "a"), 1e-3), mk("l1", "inductor", ("a", "0"), 1e-3)))
    assert rep.topological_index == 2
    assert [(c.nodes, c.elements) for c in rep.li_cutsets] == [(("a",), ("l2", "l1"))]
    assert "only through the inductors l2 and l1" in finding(rep, "li_cutset").message


def test_pure_capacitor_loop_is_a_note_and_index_1():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("in", "0"), 1.0), mk("r1", "resistor", ("in", "a"), 1.0),
        mk("c1", "capacitor", ("a", "b"), 1.0), mk("c2", "capacitor", ("b", "0"), 1.0),
        mk("c3", "capacitor", ("a", "0"), 1.0)))
    assert rep.topological_index == 1
    (loop,) = rep.c_loops
    assert set(loop.elements) == {"c1", "c2", "c3"}
    f = finding(rep, "c_loop")
    assert f.severity == "note" and "c1, c2 and c3 form a loop" in f.message


# ---------------------------------------------------------------- not applicable


def test_differentiator_with_ideal_opamp_is_not_applicable():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("in", "0"), 1.0), mk("c1", "capacitor", ("in", "m"), 1e-6),
        mk("r1", "resistor", ("m", "out"), 1e3), mk("e1", "opamp", ("out", "0", "0", "m"))))
    assert not rep.applicable and rep.topological_index is None and rep.index2_signals == ["i(v1)", "i(e1)"]
    assert rep.not_applicable_reason.startswith("ideal op-amps e1:")
    assert "numerical index is authoritative" in rep.not_applicable_reason
    assert rep.index_message.startswith("no topological index")
    assert not rep.singular


def test_differentiator_virtual_ground_closes_a_likely_cv_loop():
    """v(m) = 0 (the op-amp's inputs) puts c1 across v1: i(v1) = -C1 V1', i(e1) = C1 V1'."""
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("in", "0"), 1.0), mk("c1", "capacitor", ("in", "m"), 1e-6),
        mk("r1", "resistor", ("m", "out"), 1e3), mk("e1", "opamp", ("out", "0", "0", "m"))))
    (loop,) = rep.cv_loops
    assert loop.path() == "0 -v1- in -c1- m -e1(in)- 0" and loop.controlled
    f = finding(rep, "cv_loop")
    assert f.message.startswith("likely index 2 (controlled sources): the loop 0 -v1- in -c1- m -e1(in)- 0 of the "
                                "voltage source v1, the capacitor c1 and the input of op-amp e1")
    assert f.signals == ("i(v1)", "i(e1)")


def test_voltage_follower_is_not_a_loop_of_sources():
    """v1, the op-amp input and the op-amp output form a loop, but a regular one."""
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r0", "resistor", ("a", "0"), 1.0),
        mk("e1", "opamp", ("out", "0", "a", "out")), mk("rl", "resistor", ("out", "0"), 1.0)))
    assert rep.findings == [finding(rep, "not_applicable")] and not rep.dc_singular


def test_source_across_opamp_inputs_is_singular():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "out"), 1.0),
        mk("r2", "resistor", ("out", "0"), 1.0), mk("e1", "opamp", ("out", "0", "a", "0"))))
    assert rep.singular
    f = finding(rep, "v_loop")
    assert f.severity == "error" and "the voltage source v1 and the input of op-amp e1 form a loop" in f.message


def test_opamp_inputs_on_one_node_are_singular():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "out"), 1.0),
        mk("e1", "opamp", ("out", "0", "b", "b")), mk("r2", "resistor", ("b", "0"), 1.0)))
    assert rep.singular
    assert "the inputs of op-amp e1 are both on node 'b'" in finding(rep, "v_loop").message


def test_opamp_output_driving_nothing_has_no_fixed_potential():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("e1", "opamp", ("out", "0", "a", "b")), mk("r2", "resistor", ("b", "0"), 1.0)))
    assert rep.singular and rep.index2_signals == []
    assert [(g.nodes, g.elements, g.controlled) for g in rep.floating_groups] == [(("out",), ("e1",), False)]
    assert finding(rep, "floating").message.startswith(
        "singular: the potential of node 'out' is not fixed: only the output of op-amp e1 attaches it")


def test_integrator_output_is_not_fixed_at_dc():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("in", "0"), 1.0), mk("r1", "resistor", ("in", "m"), 1e3),
        mk("c1", "capacitor", ("m", "out"), 1e-6), mk("e1", "opamp", ("out", "0", "0", "m"))))
    assert rep.dc_singular and not rep.singular
    assert [(g.nodes, g.elements) for g in rep.no_dc_path] == [(("out",), ("c1", "e1"))]
    assert ("the potential of node 'out' is not fixed at DC: only c1 and the output of op-amp e1 attach it"
            in finding(rep, "no_dc_path").message)


def test_controlled_sources_and_transistors_are_named():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("e1", "vcvs", ("b", "0", "a", "0"), 2.0), mk("r2", "resistor", ("b", "0"), 1.0),
        mk("g2", "vccs", ("c", "0", "a", "0"), 1e-3), mk("r3", "resistor", ("c", "0"), 1.0),
        mk("q1", "bjt", ("c", "b", "0"), model="qn")))
    assert rep.not_applicable_reason.startswith("controlled sources e1 and g2; transistors q1:")


def test_negative_resistance_breaks_the_hypotheses():
    rep = analyze_topology(circuit(mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), -5.0)))
    assert not rep.applicable and "negative element values (r1)" in rep.not_applicable_reason


def test_controlled_voltage_loop_is_labelled_likely():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("e1", "vcvs", ("a", "0", "b", "0"), 2.0),
        mk("r1", "resistor", ("b", "0"), 1.0), mk("r2", "resistor", ("a", "b"), 1.0)))
    f = finding(rep, "v_loop")
    assert f.controlled and f.severity == "warning"
    assert f.message.startswith("likely singular (e1 controlled)")
    assert not rep.singular  # only certain findings set the flag


def test_controlled_current_cutset_is_labelled_likely():
    # g1's controlling voltage v(a) crosses the set's boundary: g1 may be a conductance that fixes v(a)
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("b", "0"), 1.0), mk("r1", "resistor", ("b", "0"), 1.0),
        mk("g1", "vccs", ("a", "0", "a", "b"), 1e-3), mk("i1", "isource", ("0", "a"), 1e-3)))
    assert [(c.nodes, c.elements, c.controlled) for c in rep.i_cutsets] == [(("a",), ("g1", "i1"), True)]
    f = finding(rep, "i_cutset")
    assert f.severity == "warning" and f.message.startswith("likely singular (controlled sources)")
    assert not rep.singular


@pytest.mark.parametrize("controls", [("b", "0"), ("a", "c")], ids=["outside", "inside"])
def test_controlled_current_cutset_blind_to_the_set_is_singular(controls):
    # g1 reads a voltage outside the set {a, c}, or one across two of its nodes: a common shift of the
    # set's potential changes no current into it, so the potential is undetermined whatever the gain
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("b", "0"), 1.0), mk("r1", "resistor", ("b", "0"), 1.0),
        mk("r2", "resistor", ("a", "c"), 1.0),
        mk("g1", "vccs", ("a", "0", *controls), 1e-3), mk("i1", "isource", ("0", "c"), 1e-3)))
    assert [(c.nodes, c.elements, c.controlled) for c in rep.i_cutsets] == [(("a", "c"), ("g1", "i1"), False)]
    f = finding(rep, "i_cutset")
    assert f.severity == "error" and f.message.startswith("singular: nodes 'a' and 'c'")
    assert "whose controlling voltages do not change with their potential" in f.message
    assert rep.singular


# ---------------------------------------------------------------- singular structures


def test_parallel_voltage_sources_are_a_singular_loop():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("v2", "vsource", ("a", "0"), 1.0),
        mk("r1", "resistor", ("a", "0"), 1.0)))
    assert rep.singular and rep.dc_singular and rep.topological_index is None
    assert [lp.elements for lp in rep.v_loops] == [("v1", "v2")]
    f = finding(rep, "v_loop")
    assert f.severity == "error" and "the voltage sources v1 and v2 form a loop (0 -v1- a -v2- 0)" in f.message
    assert rep.index_message.startswith("no index, the DAE is singular: the voltage sources v1 and v2")


def test_zero_valued_voltage_loop_is_singular_too():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 0.0), mk("v2", "vsource", ("a", "b"), 0.0),
        mk("v3", "vsource", ("b", "0"), 0.0), mk("r1", "resistor", ("a", "b"), 1.0)))
    assert rep.singular and rep.counts["v_loops"] == 1
    assert set(rep.v_loops[0].elements) == {"v1", "v2", "v3"}


def test_current_sources_in_series_cut_off_a_node():
    rep = analyze_topology(circuit(
        mk("i1", "isource", ("0", "a"), 1e-3), mk("i2", "isource", ("a", "b"), 1e-3),
        mk("r1", "resistor", ("b", "0"), 1e3)))
    assert rep.singular
    assert [(c.nodes, c.elements) for c in rep.i_cutsets] == [(("a",), ("i1", "i2"))]
    f = finding(rep, "i_cutset")
    assert f.severity == "error" and "only through the current sources i1 and i2" in f.message


def test_node_attached_only_by_a_capacitor_has_no_dc_path():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("c1", "capacitor", ("a", "x"), 1e-6)))
    assert rep.dc_singular and not rep.singular and rep.topological_index == 1
    assert [(g.nodes, g.elements) for g in rep.no_dc_path] == [(("x",), ("c1",))]
    assert "node 'x' has no DC path to ground: only c1 attaches it" in finding(rep, "no_dc_path").message


def test_group_without_dc_path_names_capacitors_and_current_sources():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("c3", "capacitor", ("a", "x"), 1e-6),
        mk("r1", "resistor", ("x", "y"), 1.0), mk("i1", "isource", ("y", "0"), 1e-3),
        mk("r2", "resistor", ("a", "0"), 1.0)))
    (grp,) = rep.no_dc_path
    assert grp.nodes == ("x", "y") and grp.elements == ("c3", "i1")
    assert "only through c3 and i1" in finding(rep, "no_dc_path").message


def test_parallel_inductors_make_the_dc_point_singular_only():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("1", "0"), 1.0), mk("r1", "resistor", ("1", "2"), 1e3),
        mk("l1", "inductor", ("2", "0"), 1e-3), mk("l2", "inductor", ("2", "0"), 1e-3)))
    assert rep.dc_singular and not rep.singular and rep.topological_index == 1
    assert [lp.elements for lp in rep.dc_loops] == [("l1", "l2")]
    assert "at DC the inductors are shorts, and l1 and l2 form a loop" in finding(rep, "dc_loop").message


def test_floating_subnetwork_and_sense_only_node():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("r2", "resistor", ("x", "y"), 1.0), mk("c2", "capacitor", ("x", "y"), 1e-6),
        mk("e1", "vcvs", ("b", "0", "z", "0"), 2.0), mk("r3", "resistor", ("b", "0"), 1.0)))
    assert rep.singular
    assert [(g.nodes, g.elements) for g in rep.floating_groups] == [(("x", "y"), ("r2", "c2")), (("z",), ("e1",))]
    messages = [f.message for f in rep.findings if f.kind == "floating"]
    assert "nodes 'x' and 'y' have no connection to ground at all (only r2 and c2 touch them)" in messages[0]
    assert "node 'z' is attached only to the controlling input of e1" in messages[1]
    assert rep.to_dict()["floating_nodes"] == [["x", "y"], ["z"]]


def test_circuit_without_ground():
    rep = analyze_topology(circuit(mk("r1", "resistor", ("a", "b"), 1.0), mk("v1", "vsource", ("a", "b"), 1.0)))
    assert rep.singular
    assert "no element is connected to ground" in finding(rep, "floating").message


# ---------------------------------------------------------------- small things


def test_dangling_resistor_end():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("r2", "resistor", ("a", "x"), 1.0)))
    assert rep.dangling_nodes == ["x"] and not rep.dc_singular
    f = finding(rep, "dangling")
    assert f.message == "node 'x' is dangling: only r2 attaches it" and f.elements == ("r2",)


def test_shorted_resistor_and_shorted_voltage_source():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("r2", "resistor", ("a", "a"), 1.0), mk("v2", "vsource", ("a", "a"), 0.0)))
    assert rep.self_loops == ["r2", "v2"]
    assert finding(rep, "self_loop").message == "r2 is shorted: both of its terminals are on node 'a', so it carries no current"
    f = finding(rep, "v_loop")
    assert f.severity == "error" and f.elements == ("v2",)
    assert "v2 is shorted (both terminals on node 'a'): its current is undetermined" in f.message


def test_diode_counts_as_capacitive_only_with_junction_charge():
    with_charge = {"dm": Model("dm", "d", {"is": 1e-14, "cjo": 1e-12})}
    without = {"dm": Model("dm", "d", {"is": 1e-14})}
    parts = (mk("v1", "vsource", ("a", "0"), 1.0), mk("d1", "diode", ("a", "0"), model="dm"))
    assert analyze_topology(circuit(*parts, models=with_charge)).topological_index == 2
    rep = analyze_topology(circuit(*parts, models=without))
    assert rep.applicable and rep.topological_index == 1


def test_mosfet_gate_has_no_dc_path():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("d", "0"), 1.0), mk("m1", "mosfet", ("d", "g", "0", "0"), model="nm"),
        mk("c1", "capacitor", ("g", "0"), 1e-12)))
    assert [g.nodes for g in rep.no_dc_path] == [("g",)]
    assert "only c1 and the gate of m1 attach it" in finding(rep, "no_dc_path").message


def test_zero_capacitance_is_left_out_and_zero_inductance_is_a_short():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("c1", "capacitor", ("a", "0"), 0.0),
        mk("l1", "inductor", ("a", "0"), 0.0)))
    assert rep.cv_loops == [] and [lp.elements for lp in rep.v_loops] == [("v1", "l1")]
    notes = [f.message for f in rep.findings if f.kind == "element_note"]
    assert any(m.startswith("c1: zero capacitance") for m in notes)
    assert any(m.startswith("l1: zero inductance") for m in notes)


def test_loop_lists_are_capped_but_counts_are_exact():
    count = MAX_LISTED + 30
    rep = analyze_topology(circuit(*[mk(f"v{k}", "vsource", ("a", "0"), 1.0) for k in range(count)]))
    assert rep.counts["v_loops"] == count - 1 and len(rep.v_loops) == MAX_LISTED
    assert any(f.kind == "truncated" and "29 more independent loops of voltage sources" in f.message
               for f in rep.findings)


def test_unknown_kind_and_wrong_node_count_are_circuit_errors():
    with pytest.raises(CircuitError, match="kind 'thing' is unknown"):
        analyze_topology(circuit(mk("x1", "thing", ("a", "0"))))
    with pytest.raises(CircuitError, match="r1: a resistor has 2 nodes, not 3"):
        analyze_topology(circuit(mk("r1", "resistor", ("a", "b", "0"), 1.0)))


def test_report_is_json_serialisable():
    rep = analyze_topology(circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("c1", "capacitor", ("a", "0"), 1e-6),
        mk("i1", "isource", ("0", "b"), 1e-3), mk("l1", "inductor", ("b", "0"), 1e-3)))
    data = json.loads(json.dumps(rep.to_dict()))
    assert data["topological_index"] == 2
    assert data["cv_loops"][0]["elements"] == ["v1", "c1"]
    assert data["li_cutsets"][0] == {"nodes": ["b"], "elements": ["i1", "l1"], "controlled": False}
    assert data["index2_signals"] == ["i(v1)", "v(b)"]


# ---------------------------------------------------------------- explanations for the solvers


def test_dc_explanation_prefers_the_signal_the_solver_names():
    c = circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0),
        mk("c1", "capacitor", ("a", "x"), 1e-6), mk("c2", "capacitor", ("a", "y"), 1e-6))
    err = dc_singularity_explanation(c, "v(y)")
    assert isinstance(err, CircuitError) and err.nodes == ("y",) and err.elements == ("c2",)
    assert dc_singularity_explanation(c).nodes == ("x",)
    with pytest.raises(CircuitError, match="node 'y' has no DC path to ground") as info:
        dc_singularity_explanation(c, "v(y)", raise_error=True)
    assert "1G" in info.value.hint


def test_dc_explanation_puts_loops_of_sources_first_and_none_when_regular():
    c = circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("v2", "vsource", ("a", "0"), 2.0),
        mk("c1", "capacitor", ("a", "x"), 1e-6))
    err = dc_singularity_explanation(c)
    assert err.elements == ("v1", "v2") and "form a loop" in err.message
    assert pencil_singularity_explanation(c).elements == ("v1", "v2")
    fine = circuit(mk("v1", "vsource", ("a", "0"), 1.0), mk("r1", "resistor", ("a", "0"), 1.0))
    assert dc_singularity_explanation(fine) is None and pencil_singularity_explanation(fine) is None


def test_pencil_explanation_ignores_dc_only_causes():
    c = circuit(
        mk("v1", "vsource", ("a", "0"), 1.0), mk("l1", "inductor", ("a", "0"), 1e-3),
        mk("c1", "capacitor", ("a", "x"), 1e-6))
    assert pencil_singularity_explanation(c) is None
    assert dc_singularity_explanation(c).elements == ("v1", "l1")


@pytest.mark.parametrize("text, expected", [
    # a loop of V1 and the CCVS reading i(v1): regular, index 1, every unknown algebraic; no capacitor in it
    ("V1 a 0 DC 1\nH1 a 0 V1 1k\nR1 a 0 1k\n", []),
    # C1 across V1: a CV-loop, i(v1) depends on dV1/dt
    ("V1 a 0 SIN(0 1 1k)\nC1 a 0 1n\nR1 a b 1k\nC2 b 0 1n\n", ["i(v1)"]),
    # both: only the loop through a capacitor labels its source
    ("V1 a 0 DC 1\nH1 a 0 V1 1k\nR1 a 0 1k\nV2 c 0 SIN(0 1 1k)\nC3 c 0 1n\nR3 c 0 1k\n", ["i(v2)"]),
    # a capacitor reached through another source: V2 + C4 close a loop with V1 (i(v1), i(v2) both index 2)
    ("V1 a 0 SIN(0 1 1k)\nV2 a d DC 1\nC4 d 0 1n\nR4 d 0 1k\n", ["i(v1)", "i(v2)"]),
])
def test_index2_currents_are_those_of_sources_on_a_loop_through_a_capacitor(text, expected):
    """A source's current depends on a derivative only when a loop through it holds a capacitor
    (the capacitor's voltage is then fixed by the sources of the loop); a loop of sources alone (a
    V-loop, regular through controlled sources) labels none. Checked against the pencil's labels."""
    from netdae import load
    from netdae.analyses.index import analyze_index

    circuit = load("t\n" + text + ".tran 1u 10u\n.end\n")
    rep = analyze_topology(circuit)
    assert sorted(rep.index2_signals) == sorted(expected)
    dense = analyze_index(circuit)  # the pencil's: the currents that depend on an input's derivative
    labelled = [n for n, d in dense.derivative_order.items() if d >= 1 and n.startswith("i(")]
    assert sorted(labelled) == sorted(expected)
