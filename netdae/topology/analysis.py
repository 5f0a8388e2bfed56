"""The topological analysis of a circuit: singular structures and the index.

Rules (MNA as netdae assembles it: unknowns are node potentials and the
currents of voltage-type branches and inductors, ``E = diag(A_C C A_C^T, L, 0)``)

- **Loop of voltage sources** (V-loop): the voltage rows of the loop add up
  to zero, so the DC matrix and the pencil ``lambda E - H`` are singular.
- **Cutset of current sources** (I-cutset), or a **floating** sub-network:
  the KCL rows of the cut-off nodes add up to a row without unknowns:
  singular. Found as the components, not containing ground, of the graph
  without current sources.
- **Index** (Estévez Schwarz & Tischendorf 2000 [1]_, Theorem 5.1 and its
  corollaries; Tischendorf 1999 [2]_): if the circuit has no V-loop and no
  I-cutset and its capacitance, inductance and conductance matrices are
  positive definite (passive elements, independent sources), the MNA DAE
  has index at most 2, and

  * index 0 iff there is no voltage source and every node has a path of
    capacitors to ground (then ``E`` is nonsingular);
  * index 2 iff there is a **CV-loop** (a loop of capacitors and voltage
    sources with at least one voltage source) or an **LI-cutset** (a cutset
    of inductors and current sources with at least one inductor; pure
    inductor cutsets count);
  * index 1 otherwise.

  The index-2 unknowns: the current of every voltage source on a CV-loop
  (it contains ``C dV/dt``), and the potentials of the nodes cut off by an
  LI-cutset (with a current source they contain ``L dI/dt``).
- **DC operating point**: capacitors open, inductors shorts. It is singular
  iff there is a loop of voltage sources and inductors or a node set
  without a conducting (resistive, inductive or voltage-source) path to
  ground. A node set attached only through capacitors (a *charge group*)
  still has an operating point: its conserved charge fixes it.

Controlled sources, ideal op-amps and transistors are outside the theorem's
hypotheses: the report says so and gives no index, and findings that rely on
a controlled element (counted as voltage-type or current-type by its output)
are marked ``controlled`` and worded as likely.

References
----------
.. [1] D. Estévez Schwarz, C. Tischendorf, "Structural analysis of electric
   circuits and consequences for MNA", Int. J. Circ. Theor. Appl. 28 (2000)
   131-162.
.. [2] C. Tischendorf, "Topological index calculation of differential-algebraic
   equations in circuit simulation", Surv. Math. Ind. 8 (1999) 187-199.
.. [3] M. Günther, U. Feldmann, "CAD-based electric-circuit modeling in
   industry I: mathematical structure and index of network equations",
   Surv. Math. Ind. 8 (1999) 97-129.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ..circuit import Circuit
from ..kinds import GROUPS, KINDS, Kind
from .context import EMPTY, Context, Partition, loops_through
from .dc import dc_loops, no_dc_path, unfixed_potentials
from .graph import CAPACITIVE, CURRENT, INDUCTIVE, NULLATOR, RESISTIVE, ROLES, VOLTAGE, build_graph, structure_key
from .kernels import blocks, components, on_cycle
from .report import Cutset, Finding, Loop, NodeGroup, TopologyReport
from .text import PATH_LIMIT, name_list, node_phrase, plural, with_inputs

__all__ = ["analyze_topology", "MAX_LISTED"]

#: Loops listed per kind, and findings per kind, before a "... more" note
#: (the counts stay exact; node sets and cutsets are always listed in full).
MAX_LISTED = 100

_SEVERITY_ORDER = {"error": 0, "warning": 1, "note": 2}
#: What the capacitors of a loop store (:attr:`netdae.kinds.ElementKind.stores`): a capacitor's charge, a junction's.
_CHARGED = ("charge", "junction charge")

# ---------------------------------------------------------------- singular structures


def _v_loops(ctx: Context) -> tuple[list[Loop], int]:
    """Loops of voltage-type branches, in two kinds that do not mix.

    Loops of branches whose current is free (voltage sources, E, H, B and
    op-amp outputs) leave the circulating current undetermined; loops of
    branches that fix their voltage (voltage sources, E, H, B and op-amp
    inputs) make the voltage constraints dependent. A loop through an
    op-amp's output *and* an op-amp's input (a voltage follower) is neither.
    """
    g = ctx.g
    free = np.flatnonzero(g.cls == VOLTAGE)
    loops, count = loops_through(ctx, free, np.where(g.controlled[free], 2, 1), np.ones(len(free), bool), None,
                                  exact_nullators=False)
    fixing = np.flatnonzero(g.fixes_voltage)
    is_input = g.cls[fixing] == NULLATOR
    weight = np.where(is_input, 3, np.where(g.controlled[fixing], 2, 1))
    more, more_count = loops_through(ctx, fixing, weight, is_input, None, exact_nullators=True)
    listed = (loops + more)[:MAX_LISTED]
    for lp, _ in listed:
        ctx.want("v_loop")
        sources, opamps = ctx.split(lp)
        if len(lp.elements) == 1 and opamps:
            text = (f"the inputs of op-amp {opamps[0]} are both on node '{lp.nodes[0]}': its equation "
                    "v(in+) = v(in-) says nothing, so its output current is undetermined")
        elif len(lp.elements) == 1:
            text = (f"{lp.elements[0]} is shorted (both terminals on node '{lp.nodes[0]}'): its current is "
                    "undetermined, and its voltage must be zero")
        elif opamps:
            text = (f"{with_inputs(sources, opamps, 'the voltage source', 'the voltage sources')} form a loop "
                    f"({lp.path(PATH_LIMIT)}): the op-amp holds its inputs at one potential, so one voltage "
                    "constraint of the loop is redundant, and the source voltages around it must add up to zero")
        else:
            sources = [f"the output of op-amp {e}" if ctx.kinds[e] == Kind.OPAMP else e for e in sources]
            text = (f"the voltage sources {name_list(sources)} form a loop ({lp.path(PATH_LIMIT)}): the current "
                    "circulating in it is undetermined, and the source voltages around it must add up to zero")
        if lp.controlled:
            ctl = [e for e in ctx.in_netlist_order(lp.elements) if e in ctx.controlled_names]
            text = f"likely singular ({name_list(ctl)} controlled): {text}"
        else:
            text = f"singular: {text}"
        ctx.add(Finding("v_loop", "warning" if lp.controlled else "error", text, lp.elements, lp.nodes,
                        controlled=lp.controlled,
                        hint="remove one source of the loop or put a resistance in series with it"))
    return [lp for lp, _ in listed], count + more_count


def _cut_groups(ctx: Context) -> tuple[list[NodeGroup], list[Cutset], np.ndarray]:
    """Floating groups and cutsets of current sources (independent, then with controlled sources)."""
    g = ctx.g
    indep_i = g.mask(CURRENT, controlled=False)
    part = Partition(ctx, g.carrying & ~indep_i)
    cut = part.cut(indep_i)
    sets = list(part.sets())
    touching = {}
    if any(label not in cut.names for label, _, _ in sets):  # floating groups: every element touching them
        touching = ctx.elements_by_label(
            np.concatenate([part.labels[g.u], part.labels[g.v], part.labels[g.attach_node]]),
            np.concatenate([g.element, g.element, g.attach_element]))
    # a floating group's branches lie inside it
    branch_count = np.bincount(part.labels[g.u[g.carrying]], minlength=ctx.n)
    att_by = part.attachments()
    floating, cutsets = [], []
    for label, _, names in sets:
        sources = cut.names.get(label)
        if sources is None:
            grp = NodeGroup(names, touching.get(label, ()))
            floating.append(grp)
            if ctx.want("floating"):
                ctx.add(_floating_finding(ctx, grp, branch_count[label] > 0, att_by.get(label, EMPTY)))
            continue
        cutsets.append(Cutset(names, sources))
        if ctx.want("i_cutset"):
            k = len(names)
            ctx.add(Finding(
                "i_cutset", "error",
                f"singular: {node_phrase(names)} {plural(k, 'is', 'are')} connected to the rest of the circuit "
                f"only through the current {plural(len(sources), 'source', 'sources')} {name_list(sources)}: "
                f"{plural(k, 'its', 'their')} potential is undetermined, and the source currents into "
                f"{plural(k, 'it', 'them')} must add up to zero",
                sources, names, hint="give these nodes a path to ground that is not only current sources "
                "(a large resistor will do)",
            ))
    # cutsets that need a controlled current-type source
    ilike = g.cls == CURRENT
    part_x = Partition(ctx, g.carrying & ~ilike)
    cut_x = part_x.cut(ilike)
    for label, idx, names in part_x.sets():
        if part.labels[idx[0]] != part.labels[0] or label not in cut_x.names:
            continue  # already singular through independent sources, or floating
        blind = _blind_to(ctx, part_x.labels, label, cut_x.names[label])
        cs = Cutset(names, cut_x.names[label], controlled=not blind)
        cutsets.append(cs)
        if ctx.want("i_cutset") and blind:
            k = len(names)
            ctx.add(Finding(
                "i_cutset", "error",
                f"singular: {node_phrase(names)} {plural(k, 'is', 'are')} connected to the rest of the circuit "
                f"only through the current-type sources {name_list(cs.elements)}, whose controlling voltages "
                f"do not change with {plural(k, 'its', 'their')} potential: that potential is undetermined, and "
                f"the source currents into {plural(k, 'it', 'them')} must add up to zero",
                cs.elements, names,
                hint="give these nodes a path to ground that is not only current sources (a large resistor will do)",
            ))
        elif ctx.want("i_cutset"):
            k = len(names)
            ctx.add(Finding(
                "i_cutset", "warning",
                f"likely singular (controlled sources): {node_phrase(names)} {plural(k, 'is', 'are')} connected to "
                f"the rest of the circuit only through the current-type sources {name_list(cs.elements)}: "
                f"{plural(k, 'its', 'their')} potential is undetermined unless the controlled currents depend on it",
                cs.elements, names, controlled=True,
                hint="give these nodes a path to ground that is not only current sources",
            ))
    return floating, cutsets, part.labels


def _blind_to(ctx: Context, labels: np.ndarray, label: int, sources: tuple[str, ...]) -> bool:
    """Whether nothing in the circuit changes with the common potential of the node set ``label``.

    The set is cut off by the current-type ``sources``. Shifting the potential of all its nodes
    together changes no branch voltage inside or outside it, hence no current, unless an element
    reads a voltage across its boundary. True (the potential is certainly undetermined, at DC and
    in the pencil) when every controlled source of the cut is a VCCS or a CCCS (a sensed current
    does not change either), every voltage read at a node of the set (attachments: controlling
    inputs, op-amp inputs, gates) is a VCCS's or VCVS's controlling pair that lies wholly inside
    the set, and the circuit has no behavioural source (whose expressions the graph does not
    read). False otherwise: a controlling voltage across the boundary may make the source a
    conductance that fixes the potential.
    """
    g = ctx.g
    kinds = g.element_kinds
    if any(kind in (Kind.BCURRENT, Kind.BVOLTAGE) for kind in kinds):
        return False
    for name in sources:
        kind = kinds[ctx.elem_index[name]]
        if KINDS[kind].controlled and kind not in (Kind.VCCS, Kind.CCCS):
            return False
    control = g.attach_role == ROLES.index("controlling input")
    for a in np.flatnonzero(labels[g.attach_node] == label):
        k = g.attach_element[a]
        if not control[a] or kinds[k] not in (Kind.VCCS, Kind.VCVS):
            return False
        if not np.all(labels[g.attach_node[(g.attach_element == k) & control]] == label):
            return False
    return True


def _floating_finding(ctx: Context, grp: NodeGroup, has_branches: bool, att: np.ndarray) -> Finding:
    g, k = ctx.g, len(grp.nodes)
    hint = "connect the sub-network to ground (a large resistor will do)"
    if k == ctx.n - 1 and g.terminal_count[0] == 0:
        text = "singular: no element is connected to ground (node '0'): every node potential is undetermined"
        return Finding("floating", "error", text, grp.elements, grp.nodes, hint="connect the circuit to node 0")
    nodes = node_phrase(grp.nodes)
    if not has_branches and len(att):
        text = (f"singular: {nodes} {plural(k, 'is', 'are')} attached only to "
                f"{name_list(ctx.attachment_phrases(att))}: no element carries current into "
                f"{plural(k, 'it', 'them')}, so {plural(k, 'its', 'their')} potential is undetermined")
    elif not has_branches:
        text = f"singular: {nodes} {plural(k, 'is', 'are')} not connected to any element"
    else:
        text = (f"singular: {nodes} {plural(k, 'has', 'have')} no connection to ground at all "
                f"(only {name_list(grp.elements)} touch {plural(k, 'it', 'them')}): "
                f"{plural(k, 'its', 'their')} potential is undetermined")
    return Finding("floating", "error", text, grp.elements, grp.nodes, hint=hint)


# ---------------------------------------------------------------- index-2 structures


def _cv_loops(ctx: Context) -> tuple[list[Loop], int, list[Loop], int, list[str]]:
    """Loops of capacitors, and CV-loops through a voltage source, plus the index-2 currents.

    The forest takes capacitors first, then op-amp inputs, then sources, so
    a loop closed by a capacitor or an op-amp input holds no source (a C-loop,
    possibly through a virtual ground), and one closed by a source is a
    CV-loop unless it holds sources and op-amp inputs only (a V-loop).
    """
    g = ctx.g
    sel = np.flatnonzero((g.cls == CAPACITIVE) | g.fixes_voltage)
    cls = g.cls[sel]
    is_input = cls == NULLATOR
    is_source = (cls == VOLTAGE) & g.fixes_voltage[sel]
    weight = np.select([cls == CAPACITIVE, is_input, is_source & ~g.controlled[sel]], [1, 2, 3], 4)
    c_loops, n_c = loops_through(ctx, sel, weight, ~is_source, is_input, exact_nullators=False)
    cv_loops, n_cv = loops_through(ctx, sel, weight, is_source, ~(cls == CAPACITIVE), exact_nullators=False)
    op_signals = []
    for lp, _ in cv_loops:
        ctx.want("cv_loop")
        plain, opamps = ctx.split(lp)
        vs = [e for e in plain if ctx.stores[e] not in _CHARGED]
        cs = [e if ctx.stores[e] == "charge" else f"{e} (junction capacitance)"
              for e in plain if ctx.stores[e] in _CHARGED]
        signals = tuple(f"i({e})" for e in vs + opamps)
        op_signals += [f"i({e})" for e in opamps]
        what = with_inputs(vs, opamps, "the voltage source", "the voltage sources",
                           f"{plural(len(cs), 'the capacitor', 'the capacitors')} {name_list(cs)}")
        text = (f"the loop {lp.path(PATH_LIMIT)} of {what} fixes the capacitor voltages, so {name_list(signals)} "
                f"{plural(len(signals), 'depends', 'depend')} on "
                f"{plural(len(vs), 'the derivative of the voltage', 'the derivatives of the voltages')} of "
                f"{name_list(vs)}")
        text = ("likely index 2 (controlled sources): " if lp.controlled else "index 2: ") + text
        ctx.add(Finding("cv_loop", "warning", text, lp.elements, lp.nodes, signals, lp.controlled,
                        hint="a resistance in series with a capacitor of the loop makes it index 1"))
    for lp, _ in c_loops:
        ctx.want("c_loop")
        plain, opamps = ctx.split(lp)
        if len(lp.elements) == 1:
            text = f"{lp.elements[0]} is shorted (both terminals on node '{lp.nodes[0]}'): it stores no charge"
        else:
            who = with_inputs(plain, opamps, "the capacitor", "the capacitors")
            text = (f"{who} form a loop ({lp.path(PATH_LIMIT)}): their voltages are not independent (one dynamic "
                    "state fewer; this does not raise the index)")
        ctx.add(Finding("c_loop", "note", text, lp.elements, lp.nodes, controlled=lp.controlled))
    probe = g.fixes_voltage & (g.cls == VOLTAGE)
    base = (g.cls == CAPACITIVE) | (g.cls == NULLATOR)
    hit = np.flatnonzero(probe)[on_cycle(ctx.n, g.u, g.v, base, probe)]
    hit = hit[_through_a_capacitor(ctx, base | probe, hit)]
    signals = [f"i({e})" for e in ctx.elem_arr[np.unique(g.element[hit])]] + op_signals
    return [lp for lp, _ in c_loops], n_c, [lp for lp, _ in cv_loops], n_cv, signals


def _through_a_capacitor(ctx: Context, within: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Which of the edges ``hit`` (voltage sources on a cycle of ``within``: capacitors, op-amp inputs and
    sources) lie on a cycle through a capacitor: a loop of sources (and op-amp inputs) alone fixes no
    capacitor voltage, and its currents depend on no derivative (a V-loop: singular, or regular through
    controlled sources). An edge and a capacitor lie on a common cycle iff they share a block
    (:func:`~netdae.topology.kernels.blocks`), computed on the components of ``within`` that hold a hit."""
    if not hit.size:
        return np.zeros(0, dtype=bool)
    g = ctx.g
    edges = np.flatnonzero(within & (g.u != g.v))
    labels = components(ctx.n, g.u[edges], g.v[edges])
    edges = edges[np.isin(labels[g.u[edges]], labels[g.u[hit]])]
    nodes, inv = np.unique(np.concatenate([g.u[edges], g.v[edges]]), return_inverse=True)
    label = blocks(len(nodes), inv[: edges.size], inv[edges.size:])
    charged = np.unique(label[g.cls[edges] == CAPACITIVE])
    out = np.zeros(hit.size, dtype=bool)
    looped = g.u[hit] != g.v[hit]  # a source from a node to itself closes a loop of its own
    out[looped] = np.isin(label[np.searchsorted(edges, hit[looped])], charged)
    return out


def _li_cutsets(ctx: Context) -> tuple[list[Cutset], list[str]]:
    """Cutsets of inductors and current sources with at least one inductor, and the index-2 potentials."""
    g = ctx.g
    li = (g.cls == INDUCTIVE) | (g.cls == CURRENT)
    part = Partition(ctx, g.carrying & ~li)
    cut = part.cut(li)
    inductors = cut.count(g.cls == INDUCTIVE)
    controlled = cut.count(g.controlled)
    cutsets, signals = [], []
    for label, _, names in part.sets():
        if inductors[label] == 0:
            continue  # floating or a cutset of current sources alone (singular, reported)
        cs = Cutset(names, cut.names[label], controlled=bool(controlled[label]))
        cutsets.append(cs)
        sig = tuple(f"v({x})" for x in names)
        signals += sig
        if not ctx.want("li_cutset"):
            continue
        ls = [e for e in cs.elements if ctx.stores[e] == "flux"]
        srcs = [e for e in cs.elements if ctx.stores[e] != "flux"]
        many = len(names) > 1
        head = (f"{node_phrase(names)} {'are' if many else 'is'} connected to the rest of the circuit only through "
                f"{plural(len(ls), 'the inductor', 'the inductors')} {name_list(ls)}")
        if srcs:
            text = (f"{head} and the current {plural(len(srcs), 'source', 'sources')} {name_list(srcs)}: KCL fixes "
                    f"the inductor currents, so {name_list(sig)} {'depend' if many else 'depends'} on "
                    f"{plural(len(srcs), 'the derivative of the current', 'the derivatives of the currents')} "
                    f"of {name_list(srcs)}")
        else:
            text = (f"{head}: KCL ties the inductor currents together, so {name_list(sig)} "
                    f"{'are' if many else 'is'} determined only through the derivatives of the inductor currents")
        text = ("likely index 2 (controlled sources): " if cs.controlled else "index 2: ") + text
        ctx.add(Finding("li_cutset", "warning", text, cs.elements, names, sig, cs.controlled,
                        hint=f"a resistance from {node_phrase(names[:1])} to ground (or across an inductor) "
                        "makes it index 1"))
    return cutsets, signals


# ---------------------------------------------------------------- small things


def _dangling(ctx: Context) -> list[str]:
    g = ctx.g
    dangling = np.flatnonzero(g.terminal_count == 1)
    dangling = dangling[dangling != 0]
    owner = np.full(ctx.n, -1, dtype=np.int64)
    owner[g.u[g.carrying]] = g.element[g.carrying]
    owner[g.v[g.carrying]] = g.element[g.carrying]
    attached = np.full(ctx.n, -1, dtype=np.int64)
    attached[g.attach_node] = np.arange(len(g.attach_node))
    for i in dangling:
        if not ctx.want("dangling"):
            continue
        if owner[i] >= 0:
            el = what = ctx.elems[owner[i]]
        else:
            el = ctx.elems[g.attach_element[attached[i]]]
            what = ctx.attachment_phrases([attached[i]])[0]
        ctx.add(Finding("dangling", "warning", f"node '{ctx.nodes[i]}' is dangling: only {what} attaches it", (el,),
                        (ctx.nodes[i],), hint=f"connect the other terminals of {el} or remove it"))
    return list(ctx.node_arr[dangling])


def _self_loops(ctx: Context) -> list[str]:
    g = ctx.g
    for k, i in g.self_loops:
        spec, name, node = KINDS[g.element_kinds[k]], ctx.elems[k], ctx.nodes[i]
        # shorted sources, capacitors and inductors are reported as loops (V-loop, C-loop, DC loop), not here
        if spec.loop_reported or not ctx.want("self_loop"):
            continue
        effect = "its current has no effect" if spec.drives_current else "it carries no current"
        ctx.add(Finding("self_loop", "note", f"{name} is shorted: both of its terminals are on node '{node}', so "
                        f"{effect}", (name,), (node,)))
    return [ctx.elems[k] for k, _ in g.self_loops]


def _applicability(ctx: Context) -> tuple[bool, str | None]:
    violations = ctx.g.hypothesis_violations
    parts = []
    for group in GROUPS:
        names = [e for e, why in violations if why == group]
        if names:
            parts.append(f"{group} {name_list(names)}")
    negative = [e for e, why in violations if why.startswith("negative")]
    if negative:
        parts.append(f"negative element values ({name_list(negative)})")
    if not parts:
        return True, None
    return False, (f"{'; '.join(parts)}: the topological index statement (Estévez Schwarz & Tischendorf 2000) "
                   "does not apply; the numerical index is authoritative")


def _index(ctx: Context, report: TopologyReport) -> None:
    """Set ``topological_index`` and ``index_message``."""
    if report.singular:
        first = next(f for f in report.findings if f.severity == "error")
        report.index_message = f"no index, the DAE is singular: {first.message.removeprefix('singular: ')}"
        return
    g = ctx.g
    if ctx.n <= 1 and not np.any((g.cls == VOLTAGE) | (g.cls == INDUCTIVE)):
        # no node off ground and no branch current: no unknowns, no equations (an empty netlist)
        what = "no elements" if not len(ctx.elems) else "no node other than ground"
        report.index_message = f"no index: the circuit has {what}, so it has no unknowns and no DAE"
        return
    if not report.applicable:
        report.index_message = f"no topological index: {report.not_applicable_reason}"
        return
    cv_count, li_count = report.counts["cv_loops"], report.counts["li_cutsets"]
    if cv_count or li_count:
        report.topological_index = 2
        parts = []
        if cv_count:
            parts.append(f"{cv_count} {plural(cv_count, 'loop', 'loops')} of capacitors and voltage sources "
                         "through a voltage source")
        if li_count:
            parts.append(f"{li_count} {plural(li_count, 'cutset', 'cutsets')} of inductors and current sources")
        report.index_message = f"index 2 (topological): {' and '.join(parts)}"
        return
    c = g.cls == CAPACITIVE
    c_labels = components(ctx.n, g.u[c], g.v[c])
    no_c_path = np.flatnonzero(c_labels != c_labels[0])
    sources = ctx.elem_arr[np.unique(g.element[g.cls == VOLTAGE])]
    if len(sources) == 0 and len(no_c_path) == 0:
        report.topological_index = 0
        report.index_message = ("index 0 (topological): every node has a path of capacitors to ground and there is "
                                "no voltage source, so E is nonsingular (an ODE)")
        return
    report.topological_index = 1
    why = (f"{name_list(sources)} {plural(len(sources), 'is a voltage source', 'are voltage sources')}"
           if len(sources) else f"{node_phrase(ctx.node_names(no_c_path[:1]))} has no path of capacitors to ground")
    report.index_message = ("index 1 (topological): no loop of capacitors and voltage sources through a voltage "
                            f"source and no cutset of inductors and current sources (not 0: {why})")


_TRUNCATION_WHAT = {
    "v_loop": "independent loops of voltage sources", "cv_loop": "independent CV-loops",
    "c_loop": "independent loops of capacitors", "dc_loop": "independent inductor loops",
}


def analyze_topology(circuit: Circuit) -> TopologyReport:
    """Loops, cutsets, floating nodes and the topological index of a circuit.

    Parameters
    ----------
    circuit : Circuit
        The elaborated circuit.

    Returns
    -------
    TopologyReport
        Findings named by elements and nodes, most serious first.

    Raises
    ------
    CircuitError
        When an element has a kind the analysis does not know or the wrong
        number of nodes.

    Notes
    -----
    The report is memoised by :func:`~netdae.topology.graph.structure_key`
    (the last :data:`MEMO_SIZE` structures of up to :data:`MEMO_MAX_ELEMENTS`
    elements): a circuit that differs from an earlier one only in values gets
    the same report object, which callers must not modify.

    Cost: a few list comprehensions over the elements to build the branch
    arrays, then about ten connected-component, spanning-forest and sort
    operations of :mod:`scipy.sparse.csgraph` and numpy over the arrays,
    O(m log m); a listed loop is walked in O(its length); one Python step per
    node set found. At most :data:`MAX_LISTED` loops and findings per kind
    are spelled out; counts and node sets stay complete.

    Examples
    --------
    >>> from netdae.circuit import Circuit, Element
    >>> c = Circuit("v parallel to c", [Element("v1", "vsource", ("a", "0")),
    ...                                 Element("c1", "capacitor", ("a", "0"), 1e-6)], ["a"])
    >>> rep = analyze_topology(c)
    >>> rep.topological_index, rep.index2_signals
    (2, ['i(v1)'])
    >>> print(rep.cv_loops[0].path())
    0 -v1- a -c1- 0
    """
    if len(circuit.elements) > MEMO_MAX_ELEMENTS:
        return _analyze(circuit)
    key = structure_key(circuit)
    cached = _MEMO.get(key)
    if cached is not None:
        _MEMO.move_to_end(key)
        return cached
    rep = _analyze(circuit)
    _MEMO[key] = rep
    if len(_MEMO) > MEMO_SIZE:
        _MEMO.popitem(last=False)
    return rep


#: Reports kept for circuits of the same structure (a sweep's rows, repeated runs).
MEMO_SIZE = 16
#: Larger circuits are analysed each time (their keys would hold megabytes).
MEMO_MAX_ELEMENTS = 20_000
_MEMO: "OrderedDict[tuple, TopologyReport]" = OrderedDict()


def _analyze(circuit: Circuit) -> TopologyReport:
    ctx = Context(build_graph(circuit), MAX_LISTED)
    g = ctx.g
    rep = TopologyReport()
    rep.v_loops, n_v = _v_loops(ctx)
    rep.floating_groups, rep.i_cutsets, pencil_labels = _cut_groups(ctx)
    rep.c_loops, n_c, rep.cv_loops, n_cv, cv_signals = _cv_loops(ctx)
    rep.li_cutsets, li_signals = _li_cutsets(ctx)
    rep.no_dc_path, dc_labels, rep.charge_groups = no_dc_path(ctx, components(ctx.n, g.u[g.carrying],
                                                                               g.v[g.carrying]))
    if np.any((g.cls == VOLTAGE) & ~g.fixes_voltage):  # ideal op-amps: their outputs fix no voltage
        fixing = g.fixes_voltage | (g.cls == RESISTIVE) | (g.cls == INDUCTIVE)
        rep.floating_groups += unfixed_potentials(ctx, pencil_labels, fixing | (g.cls == CAPACITIVE), dc=False)
        rep.no_dc_path += unfixed_potentials(ctx, dc_labels, fixing, dc=True)
    rep.dc_loops, n_dc = dc_loops(ctx)
    rep.dangling_nodes = _dangling(ctx)
    rep.self_loops = _self_loops(ctx)
    rep.applicable, rep.not_applicable_reason = _applicability(ctx)

    for el, text in g.notes:
        if ctx.want("element_note"):
            ctx.add(Finding("element_note", "note", f"{el}: {text}", (el,)))
    if not rep.applicable:
        ctx.add(Finding("not_applicable", "note", rep.not_applicable_reason,
                        tuple(dict.fromkeys(e for e, _ in g.hypothesis_violations))))
    exact = {"v_loop": n_v, "cv_loop": n_cv, "c_loop": n_c, "dc_loop": n_dc}
    for kind, total in {**ctx.total, **exact}.items():
        if total > MAX_LISTED:
            what = _TRUNCATION_WHAT.get(kind, f"{kind} findings")
            ctx.add(Finding("truncated", "note", f"{total - MAX_LISTED:,} more {what} not listed ({total:,} in all)"))
    rep.findings = sorted(ctx.findings, key=lambda f: _SEVERITY_ORDER[f.severity])
    rep.singular = any(f.severity == "error" for f in rep.findings)
    rep.dc_singular = rep.singular or any(
        f.kind in ("dc_loop", "no_dc_path") and not f.controlled for f in rep.findings)
    rep.index2_signals = [] if rep.singular else list(dict.fromkeys(cv_signals + li_signals))
    rep.counts = {
        "v_loops": n_v, "i_cutsets": len(rep.i_cutsets), "floating_groups": len(rep.floating_groups),
        "cv_loops": n_cv, "c_loops": n_c, "li_cutsets": len(rep.li_cutsets), "dc_loops": n_dc,
        "no_dc_path": len(rep.no_dc_path), "dangling_nodes": len(rep.dangling_nodes),
        "self_loops": len(rep.self_loops),
    }
    _index(ctx, rep)
    return rep
