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
  ground.

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

import numpy as np

from ..circuit import Circuit
from .graph import CAPACITIVE, CURRENT, INDUCTIVE, RESISTIVE, VOLTAGE, CircuitGraph, build_graph
from .kernels import components, fundamental_cycle, group_by, on_cycle, spanning_forest
from .report import Cutset, Finding, Loop, NodeGroup, TopologyReport
from .text import name_list, node_phrase, plural

__all__ = ["analyze_topology", "MAX_LISTED"]

#: Loops listed per kind, and findings per kind, before a "... more" summary
#: (the counts stay exact; node sets and cutsets are always listed in full).
MAX_LISTED = 100

_ROLE = {"gate": "the gate of {}", "substrate": "the substrate of {}",
         "controlling input": "the controlling input of {}", "input": "the input of op-amp {}"}

_SEVERITY_ORDER = {"error": 0, "warning": 1, "note": 2}


class _Ctx:
    """The graph and name lookups shared by the analyses of one circuit."""

    def __init__(self, graph: CircuitGraph):
        self.g = graph
        self.n = graph.n_nodes
        self.nodes = graph.node_names
        self.elems = graph.element_names
        self.elem_index = {name: k for k, name in enumerate(graph.element_names)}

    def node_names(self, idx) -> tuple[str, ...]:
        """Names of node indices, in circuit order, once each."""
        return tuple(self.nodes[i] for i in np.unique(np.asarray(idx, dtype=np.int64)))

    def element_names_of(self, branches) -> tuple[str, ...]:
        """Names of the elements of some branches, in netlist order, once each."""
        return tuple(self.elems[k] for k in np.unique(self.g.element[np.asarray(branches, dtype=np.int64)]))

    def attachment_phrases(self, att) -> list[str]:
        g = self.g
        return [_ROLE[g.attach_role[a]].format(self.elems[g.attach_element[a]]) for a in att]

    def loop(self, forest, sel, local_u, local_v, local_edge, node_of) -> Loop:
        """The fundamental cycle of a non-tree edge as a :class:`Loop`.

        The loop starts at its first node in circuit order (ground when it
        passes through ground) and runs in the direction in which the element
        first in netlist order comes first.
        """
        nodes, edges = fundamental_cycle(forest, int(local_u[local_edge]), int(local_v[local_edge]), int(local_edge))
        nodes = [int(node_of[i]) for i in nodes]
        k = nodes.index(min(nodes))
        nodes, edges = nodes[k:] + nodes[:k], edges[k:] + edges[:k]
        branches = sel[np.asarray(edges)]
        owners = self.g.element[branches]
        if owners[0] > owners[-1]:
            nodes, branches, owners = nodes[:1] + nodes[:0:-1], branches[::-1], owners[::-1]
        return Loop(
            elements=tuple(self.elems[k] for k in owners),
            nodes=tuple(self.nodes[i] for i in nodes),
            controlled=bool(self.g.controlled[branches].any()),
        )

    def in_netlist_order(self, names) -> list[str]:
        """Distinct element names sorted as in the netlist."""
        return sorted(set(names), key=self.elem_index.__getitem__)


def _subforest(ctx: _Ctx, sel: np.ndarray, weight: np.ndarray):
    """Spanning forest of the branches ``sel`` on the nodes they touch (compressed)."""
    u, v = ctx.g.u[sel], ctx.g.v[sel]
    node_of = np.unique(np.concatenate([u, v, [0]]))
    lu, lv = np.searchsorted(node_of, u), np.searchsorted(node_of, v)
    return spanning_forest(len(node_of), lu, lv, weight), lu, lv, node_of


def _component_sets(labels: np.ndarray) -> list[np.ndarray]:
    """Node sets of the components not containing ground, by smallest node."""
    sets = group_by(labels, np.arange(len(labels)))
    ground = int(labels[0])
    return [sets[k] for k in sorted(sets, key=lambda k: sets[k][0]) if k != ground]


def _crossing(ctx: _Ctx, labels: np.ndarray, mask: np.ndarray) -> dict[int, np.ndarray]:
    """Branches of ``mask`` crossing between components, grouped by each side's label."""
    b = np.flatnonzero(mask)
    lu, lv = labels[ctx.g.u[b]], labels[ctx.g.v[b]]
    cross = lu != lv
    return group_by(np.concatenate([lu[cross], lv[cross]]), np.concatenate([b[cross], b[cross]]))


# ---------------------------------------------------------------- singular structures


def _v_loops(ctx: _Ctx):
    g = ctx.g
    sel = np.flatnonzero(g.cls == VOLTAGE)
    forest, lu, lv, node_of = _subforest(ctx, sel, np.where(g.controlled[sel], 2, 1))
    nontree = np.flatnonzero(~forest.tree)
    nontree = nontree[np.argsort(g.controlled[sel[nontree]], kind="stable")]  # certain loops first
    loops = [ctx.loop(forest, sel, lu, lv, e, node_of) for e in nontree[:MAX_LISTED]]
    controlled = _controlled_names(ctx)
    findings = []
    for lp in loops:
        if len(lp.elements) == 1:
            text = (f"{lp.elements[0]} is shorted (both terminals on node '{lp.nodes[0]}'): its current is "
                    "undetermined")
            consistency = "and its voltage must be zero"
        else:
            text = (f"the voltage sources {name_list(ctx.in_netlist_order(lp.elements))} form a loop ({lp.path()}): "
                    "the current circulating in it is undetermined")
            consistency = "and the source voltages around it must add up to zero"
        if lp.controlled:
            ctl = [e for e in ctx.in_netlist_order(lp.elements) if e in controlled]
            text = f"likely singular ({name_list(ctl)} controlled): {text}"
        else:
            text = f"singular: {text}, {consistency}"
        findings.append(Finding(
            "v_loop", "warning" if lp.controlled else "error", text, lp.elements, lp.nodes,
            controlled=lp.controlled, hint="remove one source of the loop or put a resistance in series with it",
        ))
    return loops, len(nontree), findings


def _controlled_names(ctx: _Ctx) -> frozenset[str]:
    g = ctx.g
    return frozenset(ctx.elems[k] for k in np.unique(g.element[g.controlled]))


def _cut_groups(ctx: _Ctx):
    """Floating groups, I-cutsets (independent, then with controlled sources)."""
    g, n = ctx.g, ctx.n
    indep_i = g.mask(CURRENT, controlled=False)
    lab_i = components(n, g.u[~indep_i], g.v[~indep_i])
    cross_i = _crossing(ctx, lab_i, indep_i)
    touching = group_by(np.concatenate([lab_i[g.u], lab_i[g.v]]), np.concatenate([np.arange(len(g.u))] * 2))
    att_by = group_by(lab_i[g.attach_node], np.arange(len(g.attach_node)))
    floating, cutsets, findings = [], [], []
    for nodes in _component_sets(lab_i):
        label = int(lab_i[nodes[0]])
        names = ctx.node_names(nodes)
        cut = cross_i.get(label)
        if cut is None:
            att = att_by.get(label, np.array([], dtype=np.int64))
            grp = NodeGroup(names, tuple(dict.fromkeys(
                ctx.element_names_of(touching.get(label, [])) + tuple(ctx.elems[g.attach_element[a]] for a in att))))
            floating.append(grp)
            findings.append(_floating_finding(ctx, grp, touching.get(label, []), att))
            continue
        cs = Cutset(names, ctx.element_names_of(cut))
        cutsets.append(cs)
        findings.append(Finding(
            "i_cutset", "error",
            f"singular: {node_phrase(names)} {plural(len(names), 'is', 'are')} connected to the rest of the circuit "
            f"only through the current {plural(len(cs.elements), 'source', 'sources')} {name_list(cs.elements)}: "
            f"{plural(len(names), 'its', 'their')} potential is undetermined, and the source currents into "
            f"{plural(len(names), 'it', 'them')} must add up to zero",
            cs.elements, names,
            hint="give these nodes a path to ground that is not only current sources (a large resistor will do)",
        ))
    # cutsets that need a controlled current-type source
    ilike = g.cls == CURRENT
    lab_x = components(n, g.u[~ilike], g.v[~ilike])
    cross_x = _crossing(ctx, lab_x, ilike)
    for nodes in _component_sets(lab_x):
        if lab_i[nodes[0]] != lab_i[0] or int(lab_x[nodes[0]]) not in cross_x:
            continue  # already singular through independent sources, or floating
        names = ctx.node_names(nodes)
        cs = Cutset(names, ctx.element_names_of(cross_x[int(lab_x[nodes[0]])]), controlled=True)
        cutsets.append(cs)
        findings.append(Finding(
            "i_cutset", "warning",
            f"likely singular (controlled sources): {node_phrase(names)} {plural(len(names), 'is', 'are')} "
            f"connected to the rest of the circuit only through the current-type sources {name_list(cs.elements)}: "
            f"{plural(len(names), 'its', 'their')} potential is undetermined unless the controlled currents depend on it",
            cs.elements, names, controlled=True,
            hint="give these nodes a path to ground that is not only current sources",
        ))
    return floating, cutsets, findings, lab_i


def _floating_finding(ctx: _Ctx, grp: NodeGroup, branches, att) -> Finding:
    g = ctx.g
    hint = "connect the sub-network to ground (a large resistor will do)"
    if len(grp.nodes) == ctx.n - 1 and g.terminal_count[0] == 0:
        text = "singular: no element is connected to ground (node '0'): every node potential is undetermined"
        return Finding("floating", "error", text, grp.elements, grp.nodes, hint="connect the circuit to node 0")
    nodes = node_phrase(grp.nodes)
    if len(branches) == 0 and len(att):
        text = (f"singular: {nodes} {plural(len(grp.nodes), 'is', 'are')} attached only to "
                f"{name_list(ctx.attachment_phrases(att))}: no element carries current into "
                f"{plural(len(grp.nodes), 'it', 'them')}, so {plural(len(grp.nodes), 'its', 'their')} "
                "potential is undetermined")
    elif len(branches) == 0:
        text = f"singular: {nodes} {plural(len(grp.nodes), 'is', 'are')} not connected to any element"
    else:
        text = (f"singular: {nodes} {plural(len(grp.nodes), 'has', 'have')} no connection to ground at all "
                f"(only {name_list(grp.elements)} touch {plural(len(grp.nodes), 'it', 'them')}): "
                f"{plural(len(grp.nodes), 'its', 'their')} potential is undetermined")
    return Finding("floating", "error", text, grp.elements, grp.nodes, hint=hint)


# ---------------------------------------------------------------- index-2 structures


def _cv_loops(ctx: _Ctx):
    """Pure C-loops and CV-loops through a voltage source, plus the index-2 source currents."""
    g = ctx.g
    sel = np.flatnonzero((g.cls == CAPACITIVE) | (g.cls == VOLTAGE))
    is_v = g.cls[sel] == VOLTAGE
    weight = np.where(is_v, np.where(g.controlled[sel], 3, 2), 1)
    forest, lu, lv, node_of = _subforest(ctx, sel, weight)
    nontree = np.flatnonzero(~forest.tree)
    c_edges = nontree[~is_v[nontree]]
    v_edges = nontree[is_v[nontree]]
    tv = forest.tree & is_v
    lab_tv = components(len(node_of), lu[tv], lv[tv])
    v_edges = v_edges[lab_tv[lu[v_edges]] != lab_tv[lv[v_edges]]]  # not a loop of sources alone
    v_edges = v_edges[np.argsort(g.controlled[sel[v_edges]], kind="stable")]
    c_loops = [ctx.loop(forest, sel, lu, lv, e, node_of) for e in c_edges[:MAX_LISTED]]
    cv_loops = [ctx.loop(forest, sel, lu, lv, e, node_of) for e in v_edges[:MAX_LISTED]]
    kinds = dict(zip(ctx.elems, g.element_kinds))
    findings = []
    for lp in cv_loops:
        vs = [e for e in ctx.in_netlist_order(lp.elements) if kinds[e] not in ("capacitor", "diode")]
        cs = [e if kinds[e] == "capacitor" else f"{e} (junction capacitance)"
              for e in ctx.in_netlist_order(lp.elements) if kinds[e] in ("capacitor", "diode")]
        signals = tuple(f"i({e})" for e in vs)
        verb = plural(len(signals), "depends", "depend")
        text = (f"the loop {lp.path()} of {plural(len(vs), 'the voltage source', 'the voltage sources')} "
                f"{name_list(vs)} and {plural(len(cs), 'the capacitor', 'the capacitors')} {name_list(cs)} "
                f"fixes the capacitor voltages, so {name_list(signals)} {verb} on "
                f"{plural(len(vs), 'the derivative of the voltage', 'the derivatives of the voltages')} "
                f"of {name_list(vs)}")
        text = ("likely index 2 (controlled sources): " if lp.controlled else "index 2: ") + text
        findings.append(Finding("cv_loop", "warning", text, lp.elements, lp.nodes, signals, lp.controlled,
                                hint="a resistance in series with a capacitor of the loop makes it index 1"))
    for lp in c_loops:
        if len(lp.elements) == 1:
            text = f"{lp.elements[0]} is shorted (both terminals on node '{lp.nodes[0]}'): it stores no charge"
        else:
            text = (f"the capacitors {name_list(ctx.in_netlist_order(lp.elements))} form a loop ({lp.path()}): their voltages are not "
                    "independent (one dynamic state fewer; this does not raise the index)")
        findings.append(Finding("c_loop", "note", text, lp.elements, lp.nodes))
    probe = g.cls == VOLTAGE
    hit = on_cycle(ctx.n, g.u, g.v, g.cls == CAPACITIVE, probe)
    signals = [f"i({e})" for e in ctx.element_names_of(np.flatnonzero(probe)[hit])]
    return c_loops, len(c_edges), cv_loops, len(v_edges), findings, signals


def _li_cutsets(ctx: _Ctx):
    g = ctx.g
    li = (g.cls == INDUCTIVE) | (g.cls == CURRENT)
    labels = components(ctx.n, g.u[~li], g.v[~li])
    cross = _crossing(ctx, labels, li)
    kinds = dict(zip(ctx.elems, g.element_kinds))
    cutsets, findings = [], []
    for nodes in _component_sets(labels):
        cut = cross.get(int(labels[nodes[0]]))
        if cut is None or not np.any(g.cls[cut] == INDUCTIVE):
            continue  # floating or a cutset of current sources alone (singular, reported)
        names = ctx.node_names(nodes)
        cs = Cutset(names, ctx.element_names_of(cut), controlled=bool(g.controlled[cut].any()))
        cutsets.append(cs)
        ls = [e for e in cs.elements if kinds[e] == "inductor"]
        srcs = [e for e in cs.elements if kinds[e] != "inductor"]
        signals = tuple(f"v({x})" for x in names)
        many = len(names) > 1
        head = (f"{node_phrase(names)} {'are' if many else 'is'} connected to the rest of the circuit only through "
                f"{plural(len(ls), 'the inductor', 'the inductors')} {name_list(ls)}")
        if srcs:
            text = (f"{head} and the current {plural(len(srcs), 'source', 'sources')} {name_list(srcs)}: KCL fixes "
                    f"the inductor currents, so {name_list(signals)} {'depend' if many else 'depends'} on "
                    f"{plural(len(srcs), 'the derivative of the current', 'the derivatives of the currents')} "
                    f"of {name_list(srcs)}")
        else:
            text = (f"{head}: KCL ties the inductor currents together, so {name_list(signals)} "
                    f"{'are' if many else 'is'} determined only through the derivatives of the inductor currents")
        text = ("likely index 2 (controlled sources): " if cs.controlled else "index 2: ") + text
        findings.append(Finding(
            "li_cutset", "warning", text, cs.elements, names, signals, cs.controlled,
            hint=f"a resistance from {node_phrase(names[:1])} to ground (or across an inductor) makes it index 1",
        ))
    return cutsets, findings


# ---------------------------------------------------------------- DC operating point


def _dc(ctx: _Ctx, lab_all: np.ndarray):
    g = ctx.g
    conducting = (g.cls == RESISTIVE) | (g.cls == INDUCTIVE) | (g.cls == VOLTAGE)
    labels = components(ctx.n, g.u[conducting], g.v[conducting])
    cross = _crossing(ctx, labels, ~conducting)
    att_by = group_by(labels[g.attach_node], np.arange(len(g.attach_node)))
    groups, findings = [], []
    for nodes in _component_sets(labels):
        label = int(labels[nodes[0]])
        cut = cross.get(label, np.array([], dtype=np.int64))
        att = att_by.get(label, np.array([], dtype=np.int64))
        names = ctx.node_names(nodes)
        elements = tuple(dict.fromkeys(ctx.element_names_of(cut) + tuple(ctx.elems[g.attach_element[a]] for a in att)))
        grp = NodeGroup(names, elements, controlled=bool(g.controlled[cut].any()))
        groups.append(grp)
        if lab_all[nodes[0]] != lab_all[0] or not elements:
            continue  # inside a floating group: reported there
        attaching = list(ctx.element_names_of(cut)) + ctx.attachment_phrases(att)
        how = name_list(attaching)
        if len(names) == 1:
            verb = plural(len(attaching), "attaches", "attach")
            text = f"{node_phrase(names)} has no DC path to ground: only {how} {verb} it"
        else:
            text = (f"{node_phrase(names)} have no DC path to ground: they are attached to the rest of the circuit "
                    f"only through {how}")
        prefix = "DC operating point likely singular (controlled sources): " if grp.controlled \
            else "DC operating point singular: "
        findings.append(Finding(
            "no_dc_path", "warning", prefix + text, elements, names, controlled=grp.controlled,
            hint=f"add a large resistor (e.g. 1G) from {node_phrase(names[:1])} to ground, or start the transient "
            "with uic",
        ))
    # loops of voltage sources and inductors (shorts at DC) through an inductor
    sel = np.flatnonzero((g.cls == VOLTAGE) | (g.cls == INDUCTIVE))
    is_l = g.cls[sel] == INDUCTIVE
    weight = np.where(is_l, 3, np.where(g.controlled[sel], 2, 1))
    forest, lu, lv, node_of = _subforest(ctx, sel, weight)
    l_edges = np.flatnonzero(~forest.tree & is_l)
    loops = [ctx.loop(forest, sel, lu, lv, e, node_of) for e in l_edges[:MAX_LISTED]]
    kinds = dict(zip(ctx.elems, g.element_kinds))
    for lp in loops:
        if len(lp.elements) == 1:
            what = f"{lp.elements[0]} is shorted (both terminals on node '{lp.nodes[0]}'): at DC its current"
        else:
            ls = [e for e in ctx.in_netlist_order(lp.elements) if kinds[e] == "inductor"]
            vs = [e for e in ctx.in_netlist_order(lp.elements) if kinds[e] != "inductor"]
            with_v = f" with {plural(len(vs), 'the source', 'the sources')} {name_list(vs)}" if vs else ""
            what = (f"at DC the inductors are shorts, and {name_list(ls)} form a loop{with_v} ({lp.path()}): "
                    "the current circulating in it")
        prefix = "DC operating point likely singular (controlled sources): " if lp.controlled \
            else "DC operating point singular: "
        findings.append(Finding(
            "dc_loop", "warning", f"{prefix}{what} is undetermined", lp.elements, lp.nodes, controlled=lp.controlled,
            hint="add a small resistance in series with one of the inductors",
        ))
    return groups, loops, len(l_edges), findings


# ---------------------------------------------------------------- small things


def _dangling_and_self_loops(ctx: _Ctx):
    g = ctx.g
    dangling = np.flatnonzero(g.terminal_count == 1)
    dangling = dangling[dangling != 0]
    owner = np.full(ctx.n, -1, dtype=np.int64)
    owner[g.u] = g.element
    owner[g.v] = g.element
    attached = np.full(ctx.n, -1, dtype=np.int64)
    attached[g.attach_node] = np.arange(len(g.attach_node))
    findings = []
    for i in dangling:
        if owner[i] >= 0:
            el = ctx.elems[owner[i]]
            what = el
        else:
            el = ctx.elems[g.attach_element[attached[i]]]
            what = ctx.attachment_phrases([attached[i]])[0]
        findings.append(Finding(
            "dangling", "warning", f"node '{ctx.nodes[i]}' is dangling: only {what} attaches it", (el,),
            (ctx.nodes[i],), hint=f"connect the other terminals of {el} or remove it",
        ))
    loops_reported = ("vsource", "vcvs", "ccvs", "bvoltage", "opamp", "inductor", "capacitor")
    for k, i in g.self_loops:
        kind, name, node = g.element_kinds[k], ctx.elems[k], ctx.nodes[i]
        if kind in loops_reported:
            continue
        effect = "its current has no effect" if kind in ("isource", "vccs", "cccs", "bcurrent") \
            else "it carries no current"
        findings.append(Finding("self_loop", "note", f"{name} is shorted: both of its terminals are on node "
                                f"'{node}', so {effect}", (name,), (node,)))
    return [ctx.nodes[i] for i in dangling], [ctx.elems[k] for k, _ in g.self_loops], findings


_KIND_GROUPS = (
    ({"vcvs", "vccs", "cccs", "ccvs", "bvoltage", "bcurrent"}, "controlled sources"),
    ({"opamp"}, "ideal op-amps"),
    ({"bjt", "mosfet"}, "transistors"),
)


def _applicability(ctx: _Ctx) -> tuple[bool, str | None]:
    violations = ctx.g.hypothesis_violations
    parts = []
    for group, label in _KIND_GROUPS:
        names = [e for e, why in violations if why in group]
        if names:
            parts.append(f"{label} {name_list(names)}")
    negative = [e for e, why in violations if why.startswith("negative")]
    if negative:
        parts.append(f"negative element values ({name_list(negative)})")
    if not parts:
        return True, None
    return False, (f"{'; '.join(parts)}: the topological index statement (Estévez Schwarz & Tischendorf 2000) "
                   "does not apply; the numerical index is authoritative")


def _index(ctx: _Ctx, report: TopologyReport, cv_count: int) -> None:
    if report.singular:
        first = next(f for f in report.findings if f.severity == "error")
        report.index_message = f"no index, the DAE is singular: {first.message.removeprefix('singular: ')}"
        return
    if not report.applicable:
        report.index_message = f"no topological index: {report.not_applicable_reason}"
        return
    g = ctx.g
    if cv_count or report.li_cutsets:
        report.topological_index = 2
        parts = []
        if cv_count:
            parts.append(f"{cv_count} {plural(cv_count, 'loop', 'loops')} of capacitors and voltage sources "
                         "through a voltage source")
        if report.li_cutsets:
            k = len(report.li_cutsets)
            parts.append(f"{k} {plural(k, 'cutset', 'cutsets')} of inductors and current sources")
        report.index_message = f"index 2 (topological): {' and '.join(parts)}"
        return
    c = g.cls == CAPACITIVE
    c_labels = components(ctx.n, g.u[c], g.v[c])
    no_c_path = np.flatnonzero(c_labels != c_labels[0])
    sources = ctx.element_names_of(np.flatnonzero(g.cls == VOLTAGE))
    if not sources and len(no_c_path) == 0:
        report.topological_index = 0
        report.index_message = ("index 0 (topological): every node has a path of capacitors to ground and there is "
                                "no voltage source, so E is nonsingular (an ODE)")
        return
    report.topological_index = 1
    why = (f"{name_list(sources)} {plural(len(sources), 'is a voltage source', 'are voltage sources')}" if sources
           else f"{node_phrase(ctx.node_names(no_c_path[:1]))} has no path of capacitors to ground")
    report.index_message = ("index 1 (topological): no loop of capacitors and voltage sources through a voltage "
                            f"source and no cutset of inductors and current sources (not 0: {why})")


def _truncation(kind: str, count: int, shown: int, what: str) -> list[Finding]:
    if count <= shown:
        return []
    return [Finding("truncated", "note", f"{count - shown:,} more {what} not listed ({count:,} in all)")]


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
    Cost: one Python pass over the elements to build the branch arrays, then
    about ten connected-component, spanning-forest and sort operations of
    :mod:`scipy.sparse.csgraph` over the arrays, O(m log m); a listed loop is
    walked in O(its length). At most :data:`MAX_LISTED` loops and findings
    per kind are spelled out; counts stay exact.

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
    ctx = _Ctx(build_graph(circuit))
    rep = TopologyReport()
    rep.v_loops, n_v, f_v = _v_loops(ctx)
    rep.floating_groups, rep.i_cutsets, f_cut, lab_i = _cut_groups(ctx)
    rep.c_loops, n_c, rep.cv_loops, n_cv, f_cv, cv_signals = _cv_loops(ctx)
    rep.li_cutsets, f_li = _li_cutsets(ctx)
    g = ctx.g
    lab_all = components(ctx.n, g.u, g.v)
    rep.no_dc_path, rep.dc_loops, n_dc, f_dc = _dc(ctx, lab_all)
    rep.dangling_nodes, rep.self_loops, f_small = _dangling_and_self_loops(ctx)
    rep.applicable, rep.not_applicable_reason = _applicability(ctx)

    notes = [Finding("element_note", "note", f"{el}: {text}", (el,)) for el, text in g.notes]
    if not rep.applicable:
        notes.append(Finding("not_applicable", "note", rep.not_applicable_reason,
                             tuple(e for e, _ in g.hypothesis_violations)))
    by_kind: dict[str, list[Finding]] = {}
    for f in f_v + f_cut + f_cv + f_li + f_dc + f_small + notes:
        by_kind.setdefault(f.kind, []).append(f)
    findings = []
    for kind, items in by_kind.items():
        findings += items[:MAX_LISTED] + _truncation(kind, len(items), MAX_LISTED, f"{kind} findings")
    findings += _truncation("v_loop", n_v, len(rep.v_loops), "independent loops of voltage sources")
    findings += _truncation("cv_loop", n_cv, len(rep.cv_loops), "independent CV-loops")
    findings += _truncation("c_loop", n_c, len(rep.c_loops), "independent loops of capacitors")
    findings += _truncation("dc_loop", n_dc, len(rep.dc_loops), "independent inductor loops")
    rep.findings = sorted(findings, key=lambda f: _SEVERITY_ORDER[f.severity])

    rep.singular = any(f.severity == "error" for f in rep.findings)
    rep.dc_singular = rep.singular or any(f.kind in ("dc_loop", "no_dc_path") and not f.controlled for f in rep.findings)
    index2 = list(dict.fromkeys(cv_signals + [s for f in f_li for s in f.signals]))
    rep.index2_signals = index2
    rep.counts = {
        "v_loops": n_v, "i_cutsets": len(rep.i_cutsets), "floating_groups": len(rep.floating_groups),
        "cv_loops": n_cv, "c_loops": n_c, "li_cutsets": len(rep.li_cutsets), "dc_loops": n_dc,
        "no_dc_path": len(rep.no_dc_path), "dangling_nodes": len(rep.dangling_nodes),
        "self_loops": len(rep.self_loops),
    }
    _index(ctx, rep, n_cv)
    return rep
