"""The topological statements against an independent numerical oracle.

Random small circuits of R, C, L and independent V and I (the hypotheses of
the Estévez Schwarz-Tischendorf theorem) are assembled by the reference MNA
of ``test_topology_helpers`` and analysed numerically: regularity and
Kronecker index of the pencil by SLICOT ag08bd (cross-checked with the
Drazin index), singularity of the DC matrix by its rank, dependence on
source derivatives from the pencil's behaviour at large s. The topological
report must agree exactly. With controlled sources the report makes no index
claim, but its *certain* singularity findings must still be true.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from test_topology_helpers import (
    circuit,
    derivative_dependent,
    drazin_index,
    mk,
    pencil_structure,
    reference_mna,
)

from netdae.topology import analyze_topology

NODES = ["0", "n1", "n2", "n3", "n4"]
#: Kinds drawn for random circuits (R and C twice: fewer singular circuits, more CV-loops).
PASSIVE_KINDS = ["resistor", "resistor", "capacitor", "capacitor", "inductor", "vsource", "isource"]
SELF_LOOP_ODDS = 20  # about one element in 20 has both terminals on one node
RANK_RTOL = 1e-9  # element values are O(1): rank gaps are O(1) or exact zeros

_values = st.floats(0.5, 2.0)


@st.composite
def _terminals(draw, nodes):
    a = draw(st.sampled_from(nodes))
    if draw(st.integers(0, SELF_LOOP_ODDS - 1)) == 0:
        return a, a
    return a, draw(st.sampled_from([n for n in nodes if n != a]))


@st.composite
def passive_circuits(draw):
    nodes = NODES[: draw(st.integers(2, len(NODES)))]
    elements = []
    for k in range(draw(st.integers(1, 8))):
        kind = draw(st.sampled_from(PASSIVE_KINDS))
        elements.append(mk(f"{kind[0]}{k}", kind, draw(_terminals(nodes)), draw(_values)))
    return circuit(*elements)


@st.composite
def controlled_circuits(draw):
    c = draw(passive_circuits())
    for k in range(draw(st.integers(1, 2))):
        kind = draw(st.sampled_from(["vcvs", "vccs", "opamp"]))
        nodes = draw(_terminals(NODES)) + draw(_terminals(NODES))
        c.elements.append(mk(f"{kind[0]}x{k}", kind, nodes, draw(_values)))
        c.nodes.extend(n for n in nodes if n != "0" and n not in c.nodes)
    return c


def _dc_singular(H: np.ndarray) -> bool:
    return np.linalg.matrix_rank(H, tol=RANK_RTOL * max(1.0, np.linalg.norm(H, 2))) < H.shape[0]


@settings(max_examples=400, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(passive_circuits())
def test_singularity_and_index_match_the_pencil(c):
    E, H, B, names = reference_mna(c)
    assume(E.shape[0] > 0)
    report = analyze_topology(c)
    regular, index = pencil_structure(E, H)
    assert report.applicable
    assert report.singular == (not regular), report.findings
    assert report.dc_singular == _dc_singular(H), report.findings
    if regular:
        assert index == drazin_index(E, H, np.random.default_rng(0))  # the two oracles agree
        assert report.topological_index == index, (report.index_message, [str(f) for f in report.findings])
        assert derivative_dependent(E, H, B, names) <= set(report.index2_signals)
    else:
        assert report.topological_index is None


@settings(max_examples=200, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(passive_circuits())
def test_cv_loop_source_currents_depend_on_source_derivatives(c):
    """Every voltage source on a CV-loop has a current containing C dV/dt."""
    E, H, B, names = reference_mna(c)
    assume(E.shape[0] > 0)
    report = analyze_topology(c)
    assume(not report.singular)
    cv_currents = {s for s in report.index2_signals if s.startswith("i(")}
    assert cv_currents <= derivative_dependent(E, H, B, names)


@settings(max_examples=300, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(controlled_circuits())
def test_certain_findings_hold_with_controlled_sources(c):
    E, H, _, _ = reference_mna(c)
    report = analyze_topology(c)
    assert not report.applicable and report.topological_index is None
    assert "numerical index is authoritative" in report.not_applicable_reason
    if report.singular:
        assert not pencil_structure(E, H)[0], [str(f) for f in report.findings]
    if report.dc_singular:
        assert _dc_singular(H), [str(f) for f in report.findings]
