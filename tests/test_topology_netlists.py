"""Topological analysis through the netlist reader.

Every netlist in ``netlists/`` states its expected index in its header
(``* expected index: N``), established by hand and by the numerical index
analysis. Where the Estévez Schwarz-Tischendorf hypotheses hold, the
topological index must equal it; elsewhere the report must decline to
give one.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from netdae.netlist import load
from netdae.topology import analyze_topology, dc_singularity_explanation

NETLISTS = sorted((Path(__file__).resolve().parent.parent / "netlists").glob("*.cir"))
EXPECTED = re.compile(r"^\*\s*expected index:\s*(\d+)", re.MULTILINE)


def _expected(path: Path) -> int | None:
    m = EXPECTED.search(path.read_text())
    return int(m.group(1)) if m else None


@pytest.mark.parametrize("path", [p for p in NETLISTS if _expected(p) is not None], ids=lambda p: p.stem)
def test_topological_index_matches_the_netlist_header(path):
    rep = analyze_topology(load(path))
    assert not rep.singular, [str(f) for f in rep.findings]
    if rep.applicable:
        assert rep.topological_index == _expected(path), rep.index_message
    else:
        assert rep.topological_index is None and "numerical index is authoritative" in rep.index_message


def test_netlist_li_cutset_names_the_elements():
    rep = analyze_topology(load("LI-cutset\nI1 0 a SIN(0 1m 1k)\nL1 a b 10m\nR1 b 0 100\n.tran 5u 3m\n.end\n"))
    assert rep.topological_index == 2 and rep.index2_signals == ["v(a)"]
    assert [(c.nodes, c.elements) for c in rep.li_cutsets] == [(("a",), ("i1", "l1"))]


def test_netlist_subcircuit_names_are_qualified():
    text = """V inside a subcircuit parallel to a capacitor
.subckt cell p n
C1 p n 1u
R1 p n 1k
.ends
V1 in 0 DC 1
X1 in 0 cell
.op
.end
"""
    rep = analyze_topology(load(text))
    assert rep.topological_index == 2
    assert rep.cv_loops[0].elements == ("v1", "c.x1.c1")


def test_netlist_singular_operating_point_is_explained():
    text = """Capacitor-coupled node
V1 in 0 DC 1
R1 in 0 1k
C1 in x 1u
C2 x 0 1u
.op
.end
"""
    c = load(text)
    err = dc_singularity_explanation(c)
    assert err.nodes == ("x",) and err.elements == ("c1", "c2")
    assert err.message.startswith("DC operating point: node 'x' has no DC path to ground: only c1 and c2 attach it; "
                                  "its DC potential follows from charge conservation")


def test_diode_junction_behind_series_resistance_closes_no_cv_loop():
    base = """V1 in 0 DC 1
D1 in out dmod
C1 out 0 1u
R1 out 0 1k
.model dmod d (is=1e-14 cjo=10p tt=1n {rs})
.op
.end
"""
    with_rs = analyze_topology(load("rs\n" + base.format(rs="rs=1")))
    assert with_rs.topological_index == 1 and with_rs.cv_loops == []
    no_rs = analyze_topology(load("no rs\n" + base.format(rs="")))
    assert no_rs.topological_index == 2
    assert no_rs.cv_loops[0].elements == ("v1", "d1", "c1")
    assert "d1 (junction capacitance)" in no_rs.findings[0].message


def test_charge_defined_capacitor_is_a_capacitor_in_loops_and_charge_groups():
    """A C card with Q={...} (kind bcharge) stores charge: a capacitor of a CV loop, no source of a charge group."""
    loop = analyze_topology(load("q loop\nV1 a 0 1\nC1 a 0 Q={1n*v(a)}\n.op\n.end\n"))
    cv = next(f for f in loop.findings if f.kind == "cv_loop")
    assert "of the voltage source v1 and the capacitor c1 fixes" in cv.message
    assert cv.signals == ("i(v1)",)  # c1 has no branch current
    group = analyze_topology(load("q group\nV1 a 0 1\nR1 a b 1k\nC1 b c Q={1n*v(b,c)}\nC2 c 0 1n\n.op\n.end\n"))
    dc = next(f for f in group.findings if f.kind == "no_dc_path")
    assert dc.nodes == ("c",) and "charge conservation" in dc.message and "DC currents" not in dc.message
