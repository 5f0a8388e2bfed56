"""The structure of a circuit's DAE does not need its operating point.

A linear circuit's pencil ``(E, H)`` is the same at every point, so its index
is defined whether or not a DC operating point exists; a nonlinear circuit
whose operating point cannot be computed is linearised at another point,
and the report says which. The index is checked against SLICOT ag08bd on
the reference MNA (independent of netdae).
"""

from __future__ import annotations

import json

import netdae
from netdae.analyses.index import POINT_LINEAR, POINT_NETLIST, analyze_index
from netdae.cli import main as cli_main
from test_topology_helpers import pencil_structure, reference_mna

#: An index-2 RLC circuit: the CV-loop v1-c1-c2 and the LI-cutset {l1, i1} of node c; nodes b and c
#: have no DC path to ground and i1 charges them, so no DC operating point exists.
RLC = """rlc with a CV-loop and an LI-cutset
V1 a 0 SIN(0 1 1k)
C1 a b 1u
C2 b 0 2u
L1 b c 1m
I1 c 0 1m
R1 a 0 1k
.tran 1u 2m
.end
"""


def test_linear_index_without_operating_point(tmp_path, capsys):
    circuit = netdae.load(RLC)
    rep = analyze_index(circuit)
    E, H, _, _ = reference_mna(circuit)
    assert (rep.regular, rep.index) == pencil_structure(E, H) == (True, 2)
    assert rep.point == POINT_LINEAR
    assert rep.unknowns["v(c)"] == "index2" and rep.unknowns["i(v1)"] == "index2"
    assert any(m.startswith("the transient's initial point was not checked for consistency: no DC operating "
                            "point: i1 drives") for m in rep.messages)
    path = tmp_path / "rlc.cir"
    path.write_text(RLC)
    assert cli_main(["index", str(path)]) == 0
    out = capsys.readouterr().out
    assert "index: 2" in out and "no operating point: the circuit is linear" in out
    assert cli_main(["index", "--json", str(path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["index"] == 2 and doc["point"] == POINT_LINEAR


def test_nonlinear_circuit_without_operating_point_says_where_it_is_linearised():
    text = """diode and a charged group
V1 a 0 1
D1 a b dmod
C1 b c 1u
I1 0 c 1m
R1 c d 1k
C2 d 0 1u
.model dmod D(IS=1e-14)
.nodeset v(b)=0.4
.end
"""
    rep = analyze_index(netdae.load(text))
    assert rep.point == POINT_NETLIST and rep.regular
    assert rep.x[list(rep.system.names).index("v(b)")] == 0.4
    assert any(m.startswith(f"linearised at {POINT_NETLIST} because the DC operating point cannot be computed "
                            "(no DC operating point: i1 drives") for m in rep.messages)


def test_empty_circuit_has_no_index(tmp_path, capsys):
    """A netlist without elements has no unknowns: no DAE, so no index (it was reported as "index 0, an ODE")."""
    import pytest

    from netdae.errors import CircuitError
    from netdae.topology import analyze_topology

    for text in ("only a title\n", "only the end card\n.end\n"):
        circuit = netdae.load(text)
        with pytest.raises(CircuitError, match="the circuit has no elements: it has no unknowns"):
            analyze_index(circuit)
        topo = analyze_topology(circuit)
        assert topo.topological_index is None and topo.index_message.startswith("no index: the circuit has no "
                                                                               "elements")
    path = tmp_path / "empty.cir"
    path.write_text("only the end card\n.end\n")
    assert cli_main(["index", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: the circuit has no elements" in err and "Traceback" not in err


def test_json_floating_nodes_are_only_the_unconnected_ones(tmp_path, capsys):
    """A node attached only through capacitors has no DC path but is not floating: the pencil is regular.

    ``index --json`` listed it under ``floating_nodes`` (with the singular pencils' floating sub-networks);
    the reference MNA's pencil is regular of index 1, so it belongs under ``no_dc_path`` alone.
    """
    text = """capacitive divider off a resistive node
V1 in 0 SIN(0 1 1k)
R1 in a 1k
R2 a 0 1k
C1 a x 1u
C2 x 0 1u
R3 y z 1k
.end
"""
    E, H, _, _ = reference_mna(netdae.load(text.replace("R3 y z 1k\n", "")))
    assert pencil_structure(E, H) == (True, 1)
    path = tmp_path / "divider.cir"
    path.write_text(text.replace("R3 y z 1k\n", ""))
    assert cli_main(["index", "--json", str(path)]) == 0
    topo = json.loads(capsys.readouterr().out)["topology"]
    assert topo["floating_nodes"] == [] and topo["no_dc_path"] == [["x"]]
    path.write_text(text)  # y, z float: a singular pencil, listed under both
    assert cli_main(["index", "--json", str(path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["regular"] is False and doc["topology"]["floating_nodes"] == [["y", "z"]]


def test_controlled_suspicions_refuted_by_the_numerical_pencil_are_not_reported_as_singular():
    """A cutset of current-type sources through a VCCS that reads its own node (a conductance), and a
    gyrator (two VCCSs) turning C1 into an inductor fed by I1: the topology can only say *likely*
    singular; the reference MNA's pencil is regular (index 1 and 2) and its DC matrix has full rank, so
    the report must not say "likely singular" next to the regular index, but that the suspicion failed.
    """
    import numpy as np

    conductance = "vccs as a conductance\nI1 0 x DC 1m\nG1 x 0 x 0 1m\n.end\n"
    gyrator = "gyrator\nI1 0 a SIN(0 1m 1k)\nG1 a 0 b 0 1m\nG2 0 b a 0 1m\nC1 b 0 1u\n.end\n"
    for text, index in ((conductance, 1), (gyrator, 2)):
        circuit = netdae.load(text)
        E, H, _, _ = reference_mna(circuit)
        assert pencil_structure(E, H) == (True, index)
        assert np.linalg.matrix_rank(H) == H.shape[0]  # the DC matrix (-H) is regular
        rep = analyze_index(circuit)
        assert (rep.regular, rep.index) == (True, index)
        assert not any("likely singular" in m for m in rep.messages), rep.messages
        assert any(m.startswith("not confirmed: the loops or cutsets through controlled sources (i1, g1) suggested "
                                "a singular pencil: the pencil is regular") for m in rep.messages)
        assert any("suggested a singular DC matrix: the DC matrix has full rank" in m for m in rep.messages)
    # a cutset of a CCCS alone stays singular, and its DC suspicion stays
    rep = analyze_index(netdae.load("cccs\nV1 in 0 DC 1\nVs in c 0\nR1 c 0 1k\nF1 0 b Vs 2\n.end\n"))
    assert rep.regular is False and any("DC operating point likely singular" in m for m in rep.messages)


def test_singular_at_a_large_tolerance_does_not_call_a_full_rank_dc_matrix_singular():
    """A singular pencil has a singular DC matrix (det(sE - H) = 0 at s = 0), so the index report explains a
    singular pencil by the DC matrix's null space. At a user's large ``tol`` the pencil can be judged singular
    while the DC matrix keeps full rank; the DC rank was decided at the default tolerance, and the report said
    "the DC operating-point matrix is singular (the DC matrix has rank 5 of 5 ...)".
    """
    import numpy as np

    text = """finite-gain differentiator
V1 in 0 SIN(0 1 1k)
C1 in m 100n
R1 m out 1k
E1 out 0 0 m 1e4
.end
"""
    circuit = netdae.load(text)
    E, H, _, _ = reference_mna(circuit)
    assert pencil_structure(E, H) == (True, 1) and np.linalg.matrix_rank(H) == H.shape[0]
    rep = analyze_index(circuit, tol=1e-3)
    assert rep.regular is False  # at that tolerance
    assert not any("matrix is singular" in m or "rank 5 of 5" in m for m in rep.messages), rep.messages
    assert rep.messages[1].startswith("no structural reason: the DC matrix has full rank at this tolerance")
    assert analyze_index(circuit).index == 1


def test_certain_topological_singularity_overrules_a_close_regular_decision():
    """No element joins n1, n2, n3 to ground (E1 only reads v(n2) against it), so their current laws add
    up to zero for any element values: a singular pencil. The dense analysis kept an H singular value 1.2
    times its tolerance (the unbalanced pencil too) and reported regular, index 2, next to the topology's
    certain "no connection to ground at all"; the report contradicted itself.
    """
    import numpy as np

    text = "floating\nE1 n2 n3 0 n2 0.04173\nL2 n1 n3 0.000432\nC3 n3 n2 1.111e-06\n.end\n"
    circuit = netdae.load(text)
    E, H, _, names = reference_mna(circuit)
    nodes = [i for i, nm in enumerate(names) if nm.startswith("v(")]
    assert not E[nodes].sum(axis=0).any() and np.abs(H[nodes].sum(axis=0)).max() < 1e-15  # dependent rows
    rep = analyze_index(circuit)
    assert rep.regular is False and rep.index is None and rep.unknowns == {}
    assert "the circuit's structure makes it singular for any element values" in rep.messages[1]
    assert any("no connection to ground at all" in m for m in rep.messages)


def test_an_index_2_block_no_input_drives_is_not_said_to_carry_input_derivatives():
    """An ideal op-amp follower copies a capacitor node onto a second capacitor: v(out) = v(a) ties two
    capacitor voltages, an infinite block of size 2, but i(e1) = C2 v(a)' is a derivative of a state, not of
    the input (v(a)' = (v(in) - v(a)) / (R1 C1)). The report said 'some unknowns depend on derivatives of
    the inputs' and then named none."""
    text = """follower onto a capacitor
V1 in 0 DC 0 SIN(0 1 1k)
R1 in a 1k
C1 a 0 1u
E1 out 0 a out OPAMP
C2 out 0 1u
.tran 1u 1m
.end
"""
    circuit = netdae.load(text)
    rep = analyze_index(circuit)
    E, H, _, _ = reference_mna(circuit)
    assert (rep.regular, rep.index) == pencil_structure(E, H) == (True, 2)
    assert not any(lb.startswith("index") for lb in rep.unknowns.values())
    assert not any("depend on derivatives of the inputs" in m for m in rep.messages)
    assert any(m.startswith("index 2 (kronecker): the pencil has an infinite block of size 2, but no input drives it")
               for m in rep.messages)


def test_a_conserved_flux_is_a_natural_frequency_of_exactly_zero():
    """Two inductors in parallel fed by a current source: the flux around the loop they form is conserved, a
    natural frequency of 0; QZ gave 1.9e-15, a growing mode to the eye."""
    text = """parallel inductors
I1 0 1 DC 1m SIN(0 1m 1k)
L1 1 0 1m
L2 1 0 2m
.tran 1u 1m
.end
"""
    rep = analyze_index(netdae.load(text))
    assert rep.index == 2 and rep.finite_eigenvalues.tolist() == [0j]
