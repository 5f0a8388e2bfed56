"""Junctions whose voltage the circuit's voltage sources alone hold.

A semiconductor junction (a diode, a transistor's base-emitter or bulk-source
pair) whose two nodes are joined by a path of voltage-fixing branches (ideal
voltage sources, controlled voltage outputs, ground) has its voltage set by
those sources, with nothing in series: forward-biased beyond a few tenths of a
volt its exponential current has no bound but the model's (``Is exp(V/Vt)``:
1e19 A and more), and a transient that meets it fails on the rounding of such
a current. The failure of such a run names the junction with this.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..circuit import GROUND, Circuit
from ..kinds import BRANCH_CURRENT_KINDS, KINDS, VOLTAGE
from .graph import RESISTIVE, build_graph
from .kernels import components

__all__ = ["HeldJunction", "source_held_junctions", "held_junction_cause"]


@dataclass(frozen=True, slots=True)
class HeldJunction:
    """A junction branch between two nodes that voltage sources alone join.

    Attributes
    ----------
    element : str
        The device (ngspice-style full name).
    nodes : tuple of str
        The branch's two nodes (an internal node reads ``<device>#internal``).
    """

    element: str
    nodes: tuple[str, str]


def source_held_junctions(circuit: Circuit, nodes: tuple[str, ...] | None = None) -> list[HeldJunction]:
    """The junction branches whose two nodes a path of voltage-fixing branches joins.

    Parameters
    ----------
    circuit : Circuit
    nodes : tuple of str, optional
        Keep only the junctions held by the sources joined to these nodes (a failed
        source current's terminals); all when None.

    Returns
    -------
    list of HeldJunction
        In netlist order, one per branch.

    Notes
    -----
    One classification of the branches (:func:`~netdae.topology.graph.build_graph`)
    and one connected-components pass over the voltage-fixing ones: O(elements).
    A diode with a series resistance has its junction behind an internal node,
    which no source reaches, so it is not listed.

    Examples
    --------
    >>> from netdae.netlist import load
    >>> c = load("t\\nV1 in 0 SIN(0 3 1k)\\nD1 in 0 dx\\nD2 in 0 dr\\nR1 in a 1k\\nD3 a 0 dx\\n"
    ...          "V2 d 0 5\\nM1 d in 0 0 mn\\n.model dx d\\n.model dr d(rs=10)\\n.model mn nmos\\n"
    ...          ".tran 1u 1m\\n.end\\n")
    >>> [(j.element, j.nodes) for j in source_held_junctions(c)]   # not m1's channel d-s, nor d2 behind rs
    [('d1', ('in', '0')), ('m1', ('d', '0'))]
    """
    g = build_graph(circuit)
    fixing = g.fixes_voltage & g.carrying
    labels = components(g.n_nodes, g.u[fixing], g.v[fixing])
    junction = np.array([bool(KINDS[g.element_kinds[e]].junctions) for e in g.element], dtype=bool)
    held = (g.cls == RESISTIVE) & junction & (g.u != g.v) & (labels[g.u] == labels[g.v])
    if nodes is not None:
        index = {name: i for i, name in enumerate(g.node_names)}
        wanted = {labels[index[n]] for n in nodes if n in index}
        held &= np.isin(labels[g.u], list(wanted))
    found = []
    for b in np.flatnonzero(held):
        el = circuit.elements[g.element[b]]
        pair = (g.node_names[g.u[b]], g.node_names[g.v[b]])
        pairs = KINDS[el.kind].junctions
        if any({el.nodes[i], el.nodes[j]} == set(pair) for i, j in pairs if max(i, j) < len(el.nodes)):
            found.append(HeldJunction(el.name, pair))
    return list(dict.fromkeys(found))  # a channel on the same two nodes as a junction (a source tied to bulk)


#: How many junctions a cause names.
_NAMED = 3


def held_junction_cause(circuit: Circuit, unknown: str, value: float, voltage=None) -> str | None:
    """The cause of a source current grown without bound through a junction its sources hold, or None.

    Parameters
    ----------
    circuit : Circuit
    unknown : str
        The unknown that grew most (``"i(vin)"``).
    value : float or None
        Its last value (A), when known.
    voltage : callable, optional
        ``voltage(node) -> float or None``: a node's voltage at the failure (ground 0), to give
        each junction's.

    Returns
    -------
    str or None
        A sentence for the failure's hint when ``unknown`` is the current of a voltage-fixing
        element whose sources hold a junction (:func:`source_held_junctions`); None otherwise.

    Examples
    --------
    >>> from netdae.netlist import load
    >>> c = load("t\\nVIN in 0 SIN(0 3 1k)\\nM1 d 0 in 0 mn\\nR1 d 0 1k\\n.model mn nmos\\n.tran 1u 1m\\n.end\\n")
    >>> held_junction_cause(c, "i(vin)", -4e19, {"in": -2.6}.get)[:104]
    'i(vin) = -4e+19 A flows through a junction that voltage sources alone hold: m1 between in and 0 (-2.6 V)'
    """
    m = re.fullmatch(r"i\((.+)\)", unknown)
    try:
        el = circuit.element(m.group(1)) if m else None
    except KeyError:  # a device's internal branch
        return None
    if el is None or el.kind not in BRANCH_CURRENT_KINDS or KINDS[el.kind].first_class != VOLTAGE:
        return None
    held = source_held_junctions(circuit, tuple(el.nodes[:2]))
    if not held:
        return None

    def across(j: HeldJunction) -> str:
        if voltage is None:
            return ""
        va, vb = (0.0 if n == GROUND else voltage(n) for n in j.nodes)
        return "" if va is None or vb is None else f" ({va - vb:.3g} V)"

    named = ", ".join(f"{j.element} between {j.nodes[0]} and {j.nodes[1]}{across(j)}" for j in held[:_NAMED])
    more = f" and {len(held) - _NAMED} more" if len(held) > _NAMED else ""
    amount = "" if value is None else f" = {value:.3g} A"
    return (f"{unknown}{amount} flows through a junction that voltage sources alone hold: {named}{more}, "
            "with nothing in series to bound its exponential current; the node voltages are the sources' and stay "
            "finite, the current is a model's Is exp(V/Vt) far past any real device (ngspice computes such currents "
            "too and goes on), and the run fails on the rounding of it: give the junction's model a series "
            "resistance (rs), put a resistor in series, or connect the device as intended (a transistor's bulk or "
            "base to the supply it should not forward-bias)")
