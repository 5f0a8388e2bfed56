"""The elements ``.options rseries``, ``rshunt`` and ``cshunt`` add to a circuit, as ngspice 39 does.

* ``rseries=R`` (``rseries`` alone: R = 1e-3 ohm, ngspice's default) puts a resistor
  in series with every inductor: ``Lname n1 n2`` becomes ``Lname n1 name_intern__``
  and ``Rname_intern__ name_intern__ n2 R`` (ngspice's names: its ``inpcom.c`` rewrites
  the cards so, inside subcircuits too).
* ``rshunt=R`` adds a conductance 1/R from every node to ground (ngspice adds it to
  the diagonal of the matrix), ``cshunt=C`` a capacitance C (ngspice adds a capacitor
  per node); the internal nodes ``rseries`` makes are nodes too.

The shunt elements are named ``rshunt(node)`` and ``cshunt(node)``: no card can name
an element so (a name ends at a parenthesis), so they never clash with the user's.
"""

from __future__ import annotations

from ..circuit import Element
from ..kinds import Kind

#: The series resistance of ``.options rseries`` given without a value (ngspice 39) [ohm].
DEFAULT_RSERIES = 1e-3


def _local(name: str) -> tuple[str, str]:
    """The instance prefix (``"x1."`` or ``""``) and the card name of a flat element name."""
    letter, _, rest = name.partition(".")
    if not rest:
        return "", name
    path, _, base = rest.rpartition(".")
    return path + ".", base


def series_resistors(elements: list[Element], r: float) -> tuple[list[Element], list[Element], list[str]]:
    """Every inductor split into itself and a resistor ``r`` towards its second node.

    Parameters
    ----------
    elements : list of Element
        The flat circuit.
    r : float
        The series resistance [ohm].

    Returns
    -------
    elements : list of Element
        The circuit with the inductors reconnected and the resistors after each.
    added : list of Element
        The resistors (to check their names against the circuit's).
    nodes : list of str
        The internal nodes, ngspice's ``<instance>.<lname>_intern__``.

    Examples
    --------
    >>> out, added, nodes = series_resistors([Element("l.x1.l1", Kind.INDUCTOR, ("a", "0"), 1e-6)], 2.0)
    >>> [(e.name, e.nodes, e.value) for e in out]
    [('l.x1.l1', ('a', 'x1.l1_intern__'), 1e-06), ('r.x1.rl1_intern__', ('x1.l1_intern__', '0'), 2.0)]
    """
    out: list[Element] = []
    added: list[Element] = []
    nodes: list[str] = []
    for el in elements:
        out.append(el)
        if el.kind != Kind.INDUCTOR:
            continue
        prefix, base = _local(el.name)
        inner = f"{prefix}{base}_intern__"
        name = f"r.{prefix}r{base}_intern__" if prefix else f"r{base}_intern__"
        resistor = Element(name, Kind.RESISTOR, (inner, el.nodes[1]), value=r, location=el.location,
                           instance_path=el.instance_path)
        el.nodes = (el.nodes[0], inner)
        out.append(resistor)
        added.append(resistor)
        nodes.append(inner)
    return out, added, nodes


def shunt_elements(nodes: list[str], rshunt: float | None, cshunt: float | None) -> list[Element]:
    """A resistor ``rshunt`` and a capacitor ``cshunt`` (each when given) from every node to ground.

    Examples
    --------
    >>> [(e.name, e.nodes, e.value) for e in shunt_elements(["a"], 1e3, 1e-12)]
    [('rshunt(a)', ('a', '0'), 1000.0), ('cshunt(a)', ('a', '0'), 1e-12)]
    """
    out: list[Element] = []
    for node in nodes:
        if rshunt is not None:
            out.append(Element(f"rshunt({node})", Kind.RESISTOR, (node, "0"), value=rshunt))
        if cshunt is not None:
            out.append(Element(f"cshunt({node})", Kind.CAPACITOR, (node, "0"), value=cshunt))
    return out
