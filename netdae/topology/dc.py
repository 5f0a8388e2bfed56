"""The DC operating point: node sets without a DC path, inductor loops, potentials no op-amp output fixes.

At DC capacitors are open and inductors are shorts (0 V sources). The DC
matrix is singular iff there is a loop of voltage-type branches and
inductors, or a node set that nothing conducting joins to ground; with ideal
op-amps, also a node set whose potential only op-amp outputs (norators)
reach.

A node set attached to the rest only through capacitors (and independent
current sources) is singular at DC but has a well-defined operating point
all the same: its total charge is conserved (``d/dt`` of it is the sum of
the currents entering the set, zero at DC), so its value at t = 0 fixes the
set's potential. Such sets are listed as *charge groups*; the operating
point replaces one current law of each by the charge balance. The dual: a
loop of inductors alone conserves its total flux (``d/dt`` of it is the sum
of the voltages around the loop, zero), whose value at t = 0 fixes the
current circulating in it; such a loop is a note, and the operating point
finds the conserved combination from the DC matrix's left null space
(:func:`netdae.analyses.op.conservation_laws`).
"""

from __future__ import annotations

import numpy as np

from ..kinds import Kind
from .context import EMPTY, Context, Partition, loops_through
from .graph import CAPACITIVE, CURRENT, INDUCTIVE, NULLATOR, RESISTIVE, ROLES, VOLTAGE
from .report import Finding, Loop, NodeGroup
from .text import PATH_LIMIT, name_list, node_phrase, plural, with_inputs

__all__ = ["no_dc_path", "dc_loops", "unfixed_potentials"]

#: What fixes the DC potential of a charge group, in the findings ({} is "it" or "them").
CHARGE_PHRASE = "charge conservation (the total charge on {} at t = 0 is zero, or what .ic sets)"
#: What fixes the circulating current of a loop of inductors at DC, in the findings.
FLUX_PHRASE = "flux conservation (the total flux around it at t = 0 is zero)"


def no_dc_path(ctx: Context, floating_labels: np.ndarray) -> tuple[list[NodeGroup], np.ndarray, list[NodeGroup]]:
    """Node sets without a conducting path to ground (capacitors and current sources open).

    Parameters
    ----------
    ctx : Context
    floating_labels : ndarray, shape (n,)
        Component labels of the graph of all current-carrying branches: a set
        inside a floating group is listed but not reported again.

    Returns
    -------
    groups : list of NodeGroup
        With the elements that attach each set without conducting.
    labels : ndarray, shape (n,)
        Component labels of the conducting graph.
    charge_groups : list of NodeGroup
        The sets (of ``groups``) attached to the rest only through capacitors
        and independent current sources, at least one capacitor, and no op-amp
        input: their operating point follows from charge conservation;
        ``elements`` are the crossing capacitors and current sources.
    """
    g = ctx.g
    conducting = (g.cls == RESISTIVE) | (g.cls == INDUCTIVE) | (g.cls == VOLTAGE)
    part = Partition(ctx, conducting)
    cut = part.cut(g.carrying & ~conducting)
    controlled = cut.count(g.controlled)
    capacitors = cut.count(g.cls == CAPACITIVE)
    plain = capacitors + cut.count((g.cls == CURRENT) & ~g.controlled)
    crossing = cut.count(np.ones(len(g.cls), dtype=bool))
    nullator = g.cls == NULLATOR
    sensed = np.bincount(np.concatenate([part.labels[g.u[nullator]], part.labels[g.v[nullator]]]), minlength=ctx.n)
    att_by = part.attachments()
    att_names = ctx.elements_by_label(part.labels[g.attach_node], g.attach_element)
    groups, charge_groups = [], []
    for label, idx, names in part.sets():
        through, attached = cut.names.get(label, ()), att_names.get(label, ())
        elements = tuple(ctx.in_netlist_order(through + attached)) if through and attached else through or attached
        grp = NodeGroup(names, elements, controlled=bool(controlled[label]))
        groups.append(grp)
        grounded = floating_labels[idx[0]] == floating_labels[0]
        by_charge = grounded and capacitors[label] > 0 and plain[label] == crossing[label] and not sensed[label]
        if by_charge:
            charge_groups.append(NodeGroup(names, through))
        if not grounded or not elements or not ctx.want("no_dc_path"):
            continue  # inside a floating group (reported there), or beyond the listing
        attaching = list(through) + ctx.attachment_phrases(att_by.get(label, EMPTY))
        how = name_list(attaching)
        if len(names) == 1:
            text = (f"{node_phrase(names)} has no DC path to ground: only {how} "
                    f"{plural(len(attaching), 'attaches', 'attach')} it")
        else:
            text = (f"{node_phrase(names)} have no DC path to ground: they are attached to the rest of the circuit "
                    f"only through {how}")
        if by_charge:
            sources = [e for e in through if ctx.stores[e] != "charge"]
            k = len(names)
            why = CHARGE_PHRASE.format(plural(k, "it", "them"))
            text = (f"{text}; {plural(k, 'its', 'their')} DC potential follows from {why}"
                    + (f", provided the DC currents of {name_list(sources)} into {plural(k, 'it', 'them')} add up "
                       "to zero" if sources else ""))
            ctx.add(Finding("no_dc_path", "note", f"DC operating point: {text}", elements, names,
                            hint=f"to fix the potential otherwise, add a large resistor (e.g. 1G) from "
                            f"{node_phrase(names[:1])} to ground, or set it with .ic"))
            continue
        prefix = ("DC operating point likely singular (controlled sources): " if grp.controlled
                  else "DC operating point singular: ")
        ctx.add(Finding(
            "no_dc_path", "warning", prefix + text, elements, names, controlled=grp.controlled,
            hint=f"add a large resistor (e.g. 1G) from {node_phrase(names[:1])} to ground, or start the transient "
            "with uic",
        ))
    return groups, part.labels, charge_groups


def dc_loops(ctx: Context) -> tuple[list[Loop], int]:
    """Loops through an inductor of inductors and voltage-type branches (inductors are shorts at DC).

    As for :func:`netdae.topology.analysis._v_loops`, loops through op-amp outputs (free currents) and
    loops through op-amp inputs (dependent voltage constraints) are found
    separately and never mixed.
    """
    g = ctx.g
    free = np.flatnonzero((g.cls == VOLTAGE) | (g.cls == INDUCTIVE))
    is_l = g.cls[free] == INDUCTIVE
    weight = np.where(is_l, 3, np.where(g.controlled[free], 2, 1))
    loops, count = loops_through(ctx, free, weight, is_l, None, exact_nullators=False)
    fixing = np.flatnonzero(g.fixes_voltage | (g.cls == INDUCTIVE))
    cls = g.cls[fixing]
    weight = np.select([cls == INDUCTIVE, cls == NULLATOR, g.controlled[fixing]], [4, 3, 2], 1)
    more, more_count = loops_through(ctx, fixing, weight, cls == INDUCTIVE, cls != NULLATOR, exact_nullators=True)
    listed = (loops + more)[:ctx.max_listed]
    for lp, _ in listed:
        ctx.want("dc_loop")
        plain, opamps = ctx.split(lp)
        flux = len(lp.elements) > 1 and not opamps and not lp.controlled and all(
            ctx.stores[e] == "flux" for e in plain)
        if flux:  # inductors only: the loop's total flux is conserved, and its value at t = 0 fixes the current
            what = (f"at DC the inductors are shorts, and {name_list(plain)} form a loop ({lp.path(PATH_LIMIT)}): "
                    f"the current circulating in it follows from {FLUX_PHRASE}")
            ctx.add(Finding("dc_loop", "note", f"DC operating point: {what}", lp.elements, lp.nodes,
                            hint="to set the current otherwise, add a small resistance in series with one of the "
                            "inductors"))
            continue
        if len(lp.elements) == 1:
            what = f"{lp.elements[0]} is shorted (both terminals on node '{lp.nodes[0]}'): at DC its current"
        else:
            ls = [e for e in plain if ctx.stores[e] == "flux"]
            vs = [e for e in plain if ctx.stores[e] != "flux"]
            with_v = f" with {with_inputs(vs, opamps, 'the source', 'the sources')}" if vs or opamps else ""
            what = (f"at DC the inductors are shorts, and {name_list(ls)} {plural(len(ls), 'forms', 'form')} a loop"
                    f"{with_v} "
                    f"({lp.path(PATH_LIMIT)}): " + ("one of its voltage constraints is redundant, so the current "
                                                     "through it" if opamps else "the current circulating in it"))
        prefix = ("DC operating point likely singular (controlled sources): " if lp.controlled
                  else "DC operating point singular: ")
        ctx.add(Finding("dc_loop", "warning", f"{prefix}{what} is undetermined", lp.elements, lp.nodes,
                        controlled=lp.controlled, hint="add a small resistance in series with one of the inductors"))
    return [lp for lp, _ in listed], count + more_count


def unfixed_potentials(ctx: Context, reported: np.ndarray, fixing: np.ndarray, dc: bool) -> list[NodeGroup]:
    """Node sets whose potential nothing fixes once op-amp outputs are discounted.

    The output of an ideal op-amp (a norator) carries current but fixes no
    voltage: a node set joined to ground only through op-amp outputs (and,
    at DC, capacitors; and current sources) has an undetermined potential
    (for instance the output of an integrator at DC). Without op-amps this
    is the analysis of floating nodes and cutsets already done.

    Parameters
    ----------
    reported : ndarray, shape (n,)
        Component labels of the analysis already reported: sets starting in
        one of its non-ground components are skipped.
    fixing : ndarray of bool, shape (m,)
        Branches that fix potentials (conductors, voltage constraints, op-amp inputs).
    dc : bool
        Wording for the DC operating point or for the DAE.
    """
    g = ctx.g
    part = Partition(ctx, fixing)
    cut = part.cut(g.carrying & ~fixing)
    norator = (g.cls == VOLTAGE) & ~g.fixes_voltage
    controlled = cut.count(g.controlled & ~norator)
    sensing = np.bincount(part.labels[g.attach_node[g.attach_role == ROLES.index("controlling input")]],
                          minlength=ctx.n)
    groups = []
    for label, idx, names in part.sets():
        if reported[idx[0]] != reported[0] or label not in cut.names:
            continue  # reported already, or a floating group
        grp = NodeGroup(names, cut.names[label], controlled=bool(controlled[label] or sensing[label]))
        groups.append(grp)
        kind = "no_dc_path" if dc else "floating"
        if not ctx.want(kind):
            continue
        how = [f"the output of op-amp {e}" if ctx.kinds[e] == Kind.OPAMP else e for e in grp.elements]
        k = len(names)
        text = (f"the potential of {node_phrase(names)} is not fixed{' at DC' if dc else ''}: only {name_list(how)} "
                f"{plural(len(how), 'attaches', 'attach')} {plural(k, 'it', 'them')}, and the output of an ideal "
                "op-amp fixes no voltage by itself")
        if dc:
            text += " (the op-amp has no DC feedback)"
            prefix = "DC operating point likely singular (controlled sources): " if grp.controlled \
                else "DC operating point singular: "
            ctx.add(Finding(kind, "warning", prefix + text, grp.elements, names, controlled=grp.controlled,
                            hint="give the op-amp a DC feedback path (a large resistor across the capacitor)"))
        else:
            ctx.add(Finding(kind, "warning" if grp.controlled else "error",
                            ("likely singular (controlled sources): " if grp.controlled else "singular: ") + text,
                            grp.elements, names, controlled=grp.controlled,
                            hint="connect the op-amp output to the circuit it is meant to drive"))
    return groups
