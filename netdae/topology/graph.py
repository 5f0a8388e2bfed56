"""The circuit as a graph of classified branches.

Every element of a :class:`~netdae.circuit.Circuit` becomes zero or more
*branches* (edges between two nodes) of one of five classes, the classes of
the structural theory of modified nodal analysis [1]_:

==============  =====================================================================
class           elements
==============  =====================================================================
capacitive      capacitors; the junction charge of a diode whose model has a nonzero
                CJO (CJ0, CJ) or TT, in parallel with its junction
inductive       inductors (of nonzero inductance)
resistive       resistors; diode junctions and series resistances; the conducting
                terminal pairs of transistors (collector-emitter, base-emitter,
                base-collector, substrate-collector; drain-source, drain-bulk,
                source-bulk; a JFET's drain-source, gate-source, gate-drain; a VDMOS's
                drain-source: channel, body diode, RDS); switches (S, W: a resistance RON or ROFF between
                n+ and n-, marked *controlled*); the terminals of an OSDI device
                (``N``: compiled Verilog-A), each joined to the first, marked
                *controlled* (what the module conducts or stores is not read here)
voltage         independent V; and, marked *controlled*: E, H, B with a voltage
                expression, the output of an ideal op-amp (a norator: its current
                is free, its voltage is not fixed); an inductor of zero
                inductance (its equation is then ``v = 0``: a 0 V source)
current         independent I; and, marked *controlled*: G, F, B with a current
                expression
==============  =====================================================================

The inputs of an ideal op-amp form a sixth kind of branch, a *nullator*
(class NULLATOR): zero voltage and zero current. It closes loops of voltage
constraints (a voltage source across the inputs is a singular loop; the
virtual ground of an inverting stage puts a capacitor across the source in a
differentiator) but never connects nodes for cutsets and DC paths.

Terminals that carry no branch current -- the controlling inputs of E, G and S,
the inputs of an ideal op-amp, a MOSFET gate -- are
*attachments*: they count as connections of a node (for dangling nodes and
for the messages) but not as edges. A capacitor of zero capacitance stores no
charge and stamps nothing, so it is left out (and reported as a note).

A diode with a series resistance (model RS > 0) has, as in netdae's device
model and in ngspice, an internal node ``<name>#internal`` between RS and
the junction: its junction charge then sits behind RS, so a voltage source
across the diode does not close a CV-loop through it.

Transistor charges are not modelled as capacitive branches: transistors are
outside the hypotheses of the index theorem anyway (the report says so), and
their conducting pairs are what the DC analysis needs.

References
----------
.. [1] D. Estévez Schwarz, C. Tischendorf, "Structural analysis of electric
   circuits and consequences for MNA", Int. J. Circ. Theor. Appl. 28 (2000)
   131-162.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..circuit import GROUND, Circuit
from ..errors import CircuitError
from ..kinds import (CAPACITIVE, CONTROLLED_KINDS, CURRENT, INDUCTIVE, KINDS, NULLATOR, RESISTIVE, ROLES, VOLTAGE,
                     resolve)

__all__ = [
    "CAPACITIVE",
    "INDUCTIVE",
    "RESISTIVE",
    "VOLTAGE",
    "CURRENT",
    "NULLATOR",
    "CONTROLLED_KINDS",
    "ROLES",
    "CircuitGraph",
    "build_graph",
]

#: The kinds in a fixed order: a kind's code in the graph is its position here.
_ORDER = tuple(KINDS)
_OPAMP = _ORDER.index("opamp")


@dataclass(frozen=True)
class CircuitGraph:
    """Branches of a circuit as arrays over integer node indices.

    Attributes
    ----------
    node_names : tuple of str, shape (n,)
        ``node_names[0]`` is ground ``"0"``; then the circuit's nodes.
    u, v : ndarray of int64, shape (m,)
        Terminal node indices of each branch.
    cls : ndarray of int8, shape (m,)
        Branch class (CAPACITIVE ... CURRENT).
    controlled : ndarray of bool, shape (m,)
        The branch belongs to a controlled element.
    fixes_voltage : ndarray of bool, shape (m,)
        The branch's equation fixes its voltage: voltage sources and the
        controlled voltage-type outputs, and op-amp inputs (nullators); not
        the output of an ideal op-amp (a norator: voltage and current free).
    carrying : ndarray of bool, shape (m,)
        The branch carries current (every class but NULLATOR).
    element : ndarray of int64, shape (m,)
        Index of the branch's element in ``element_names``.
    element_names, element_kinds : tuple of str
        Every element of the circuit, in netlist order.
    attach_node, attach_element : ndarray of int64, shape (a,)
        Terminals that carry no branch current.
    attach_role : ndarray of int64, shape (a,)
        What each attachment is: an index into :data:`ROLES`.
    terminal_count : ndarray of int64, shape (n,)
        Element terminals (branch ends and attachments) on each node.
    self_loops : tuple of (int, int)
        ``(element, node)``: elements whose branch has both ends on one node.
    notes : tuple of (str, str)
        ``(element, text)``: what the classification decided that the user
        should know (zero capacitance omitted, zero inductance as a short ...).
    hypothesis_violations : tuple of (str, str)
        ``(element, reason)``: elements that break the index theorem's
        hypotheses (controlled behaviour, non-positive values).
    """

    node_names: tuple[str, ...]
    u: np.ndarray
    v: np.ndarray
    cls: np.ndarray
    controlled: np.ndarray
    fixes_voltage: np.ndarray
    carrying: np.ndarray
    element: np.ndarray
    element_names: tuple[str, ...]
    element_kinds: tuple[str, ...]
    attach_node: np.ndarray
    attach_element: np.ndarray
    attach_role: np.ndarray
    terminal_count: np.ndarray
    self_loops: tuple[tuple[int, int], ...]
    notes: tuple[tuple[str, str], ...]
    hypothesis_violations: tuple[tuple[str, str], ...]

    @property
    def n_nodes(self) -> int:
        """Number of nodes including ground."""
        return len(self.node_names)

    def mask(self, *classes: int, controlled: bool | None = None) -> np.ndarray:
        """Branches of the given classes (and, if given, controlled or not), shape (m,)."""
        m = np.isin(self.cls, classes)
        if controlled is not None:
            m &= self.controlled == controlled
        return m


def _model_branches(circuit: Circuit, branches_of, members: np.ndarray, ids: np.ndarray, start: np.ndarray,
                    index: dict[str, int]) -> tuple[np.ndarray, ...]:
    """Branches (u, v, class, element) of ``members`` from their kind's topology hook; creates internal nodes."""
    rows = []
    for k in members.tolist():
        el = circuit.elements[k]

        def node(t):
            if isinstance(t, str):
                return index.setdefault(el.name + t, len(index))
            return int(ids[start[k] + t])

        rows += [(node(a), node(b), c, k) for c, a, b in branches_of(circuit, el)]
    if not rows:
        return tuple(np.zeros(0, dtype=np.int64) for _ in range(4))
    return tuple(np.array(col, dtype=np.int64) for col in zip(*rows))


def structure_key(circuit: Circuit) -> tuple:
    """Everything :func:`build_graph` reads, as a hashable key.

    Two circuits with equal keys have the same graph and the same topological
    findings: per element its name, kind, nodes, controls and model, the sign
    class of an R, C or L value (the value itself when negative, as the
    findings quote it), and the branches of a kind whose branches depend on
    its model (a diode's series resistance and junction charge). Other values
    do not enter.

    Notes
    -----
    One pass over the elements, O(m); about 1 us per element.
    """
    parts = []
    models = circuit.models
    for el in circuit.elements:
        v = el.value
        spec = KINDS.get(el.kind)
        if spec is not None and spec.passive:
            v = "nan" if v is None or v != v else (v if v < 0 else ("zero" if v == 0 else "pos"))
        else:
            v = None
        extra = resolve(spec.topology)(circuit, el) if spec is not None and spec.topology else None
        parts.append((el.name, el.kind, el.nodes, el.controls, el.model if el.model in models else None, v, extra))
    return tuple(circuit.nodes), tuple(parts)


def _passive_values(circuit: Circuit, members: np.ndarray) -> np.ndarray:
    """Values of R, C, L elements, NaN where none is given (model-only cards)."""
    els = circuit.elements
    return np.array([np.nan if els[k].value is None else els[k].value for k in members], dtype=float)


def _check(circuit: Circuit, kinds: list[str], counts: np.ndarray) -> np.ndarray:
    """Kind codes (positions in :data:`netdae.kinds.KINDS`); raise for an unknown kind or a wrong node count."""
    unknown = set(kinds).difference(KINDS)
    if unknown:
        el = next(el for el in circuit.elements if el.kind in unknown)
        raise CircuitError(
            f"{el.name}: element kind '{el.kind}' is unknown to the topological analysis",
            elements=(el.name,),
            hint=f"known kinds: {', '.join(sorted(KINDS))}",
        )
    kind_code = {k: i for i, k in enumerate(_ORDER)}
    code = np.fromiter((kind_code[k] for k in kinds), dtype=np.int64, count=len(kinds))
    for kind, spec in KINDS.items():
        bad = np.flatnonzero((code == kind_code[kind]) & ~np.isin(counts, spec.node_counts))
        if len(bad):
            el = circuit.elements[bad[0]]
            raise CircuitError(
                f"{el.name}: a {kind} has {' or '.join(map(str, spec.node_counts))} nodes, not {len(el.nodes)}",
                elements=(el.name,),
            )
    return code


def build_graph(circuit: Circuit) -> CircuitGraph:
    """Classify the branches of ``circuit``.

    Parameters
    ----------
    circuit : Circuit

    Returns
    -------
    CircuitGraph

    Raises
    ------
    CircuitError
        When an element has a kind the analysis does not know or the wrong
        number of nodes.

    Notes
    -----
    A few list comprehensions over the elements (names, kinds, nodes,
    values), then array operations per element kind: O(m) with a small
    constant. Diode models are looked up per diode; a diode with a series
    resistance adds its internal node after the circuit's nodes.
    """
    els = circuit.elements
    kinds = [el.kind for el in els]
    counts = np.fromiter((len(el.nodes) for el in els), dtype=np.int64, count=len(els))
    code = _check(circuit, kinds, counts)
    index: dict[str, int] = {GROUND: 0}
    for name in circuit.nodes:
        index.setdefault(name, len(index))
    flat = [nm for el in els for nm in el.nodes]
    ids = np.fromiter((index.setdefault(nm, len(index)) for nm in flat), dtype=np.int64, count=len(flat))
    start = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)

    bu, bv, bcls, bctl, bel = [], [], [], [], []
    an, ae, arole = [], [], []
    notes: list[tuple[int, str]] = []
    violations: list[tuple[int, str]] = []
    loops_k = []
    for kind_index, (kind, spec) in enumerate(KINDS.items()):
        members = np.flatnonzero(code == kind_index)
        if len(members) == 0:
            continue
        controlled = spec.controlled
        if controlled:
            violations += [(int(k), spec.group or kind) for k in members]
        keep, cls = members, None
        if spec.passive:
            value = _passive_values(circuit, members)
            violations += [(int(k), f"negative value {x:g}") for k, x in zip(members, value) if x < 0.0]
            zero = value == 0.0
            if spec.first_class == CAPACITIVE:
                notes += [(int(k), "zero capacitance: stores no charge, left out of the analysis")
                          for k in members[zero]]
                keep = members[~zero]
            elif spec.first_class == INDUCTIVE:
                notes += [(int(k), "zero inductance: its equation is v = 0, analysed as a 0 V source")
                          for k in members[zero]]
                cls = np.where(zero, VOLTAGE, INDUCTIVE)
        for c, a, b in spec.branches:
            with_terminals = counts[keep] > max(a, b)  # optional terminals (a BJT's substrate)
            have = keep[with_terminals]
            bu.append(ids[start[have] + a])
            bv.append(ids[start[have] + b])
            bcls.append(np.full(len(have), c) if cls is None else cls[with_terminals])
            bctl.append(np.full(len(have), controlled))
            bel.append(have)
        if spec.topology is not None:
            du, dv, dc, de = _model_branches(circuit, resolve(spec.topology), members, ids, start, index)
            bu.append(du)
            bv.append(dv)
            bcls.append(dc)
            bctl.append(np.full(len(de), controlled))
            bel.append(de)
        for pos, role in spec.attachments:
            present = members[counts[members] > pos]
            an.append(ids[start[present] + pos])
            ae.append(present)
            arole.append(np.full(len(present), ROLES.index(role)))
        if spec.self_loop:
            loops_k.append(members[ids[start[members]] == ids[start[members] + 1]])

    n = len(index)
    node_names = [""] * n
    for name, i in index.items():
        node_names[i] = name
    cat = lambda parts, dtype=np.int64: np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype)  # noqa: E731
    loops_k = np.sort(cat(loops_k))
    names = tuple(el.name for el in els)
    cls, element = cat(bcls, np.int8), cat(bel)
    norator = (cls == VOLTAGE) & (code[element] == _OPAMP)
    return CircuitGraph(
        node_names=tuple(node_names),
        u=cat(bu),
        v=cat(bv),
        cls=cls,
        controlled=cat(bctl, bool),
        fixes_voltage=((cls == VOLTAGE) & ~norator) | (cls == NULLATOR),
        carrying=cls != NULLATOR,
        element=element,
        element_names=names,
        element_kinds=tuple(kinds),
        attach_node=cat(an),
        attach_element=cat(ae),
        attach_role=cat(arole),
        terminal_count=np.bincount(ids, minlength=n).astype(np.int64),
        self_loops=tuple((int(k), int(ids[start[k]])) for k in loops_k),
        notes=tuple((names[k], text) for k, text in sorted(notes)),
        hypothesis_violations=tuple((names[k], why) for k, why in sorted(violations)),
    )
