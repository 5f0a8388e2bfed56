"""Large circuits: exact counts on structures with closed-form answers.

(No timing assertions; the analysis of the 100,000-section ladder takes
well under a second on a 2-core machine, see docs/topology.md.)
"""

from __future__ import annotations

from netdae.circuit import Circuit, Element
from netdae.topology import MAX_LISTED, analyze_topology

SECTIONS = 100_000


def rc_ladder(sections: int, tail: str | None = None) -> Circuit:
    """v1 -> r1 -> c1 to ground -> r2 -> c2 ... (2 sections + 1 elements)."""
    els = [Element("v1", "vsource", ("n0", "0"), 1.0)]
    for k in range(1, sections + 1):
        els.append(Element(f"r{k}", "resistor", (f"n{k - 1}", f"n{k}"), 1.0))
        els.append(Element(f"c{k}", "capacitor", (f"n{k}", "0"), 1e-9))
    if tail == "inductor":
        els.append(Element("lt", "inductor", (f"n{sections}", "end"), 1e-6))
    return Circuit("ladder", els, [f"n{k}" for k in range(sections + 1)] + (["end"] if tail else []))


def capacitor_grid(side: int) -> Circuit:
    """A side x side grid of capacitors, driven at one corner through r0, with an inductor to ground per node."""
    els = [Element("v1", "vsource", ("in", "0"), 1.0), Element("r0", "resistor", ("in", "g0_0"), 1.0)]
    nodes = ["in"]
    for i in range(side):
        for j in range(side):
            nodes.append(f"g{i}_{j}")
            if i + 1 < side:
                els.append(Element(f"cv{i}_{j}", "capacitor", (f"g{i}_{j}", f"g{i + 1}_{j}"), 1e-9))
            if j + 1 < side:
                els.append(Element(f"ch{i}_{j}", "capacitor", (f"g{i}_{j}", f"g{i}_{j + 1}"), 1e-9))
            els.append(Element(f"l{i}_{j}", "inductor", (f"g{i}_{j}", "0"), 1e-6))
    return Circuit("grid", els, nodes)


def test_long_rc_ladder_is_index_1_without_findings():
    rep = analyze_topology(rc_ladder(SECTIONS))
    assert rep.topological_index == 1 and rep.findings == []
    assert all(v == 0 for v in rep.counts.values())


def test_inductor_at_the_end_of_a_long_ladder_is_found():
    rep = analyze_topology(rc_ladder(SECTIONS, tail="inductor"))
    assert rep.topological_index == 2
    assert [(c.nodes, c.elements) for c in rep.li_cutsets] == [(("end",), ("lt",))]
    assert rep.dangling_nodes == ["end"] and rep.index2_signals == ["v(end)"]


def test_capacitor_grid_loop_count_is_the_cyclomatic_number():
    side = 180  # 64,440 capacitors, 32,400 inductors
    rep = analyze_topology(capacitor_grid(side))
    assert rep.counts["c_loops"] == (side - 1) ** 2  # 2 s (s-1) edges - s^2 nodes + 1 component
    assert len(rep.c_loops) == MAX_LISTED
    assert rep.topological_index == 1  # every grid node reaches ground through an inductor: no LI-cutset
    assert rep.counts["dc_loops"] == 0 and not rep.dc_singular
