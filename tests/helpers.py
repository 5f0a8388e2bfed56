"""Small builders for circuits written by hand in tests."""

from __future__ import annotations

from netdae.circuit import Circuit, Element, SourceSpec


def mk(name, kind, nodes, value=None, **kw):
    """An element; for sources ``value`` is the DC value."""
    if kind in ("vsource", "isource"):
        return Element(name, kind, tuple(nodes), source=SourceSpec(dc=value, **kw.pop("src", {})), **kw)
    return Element(name, kind, tuple(nodes), value, **kw)


def circuit(*elements, title="t", **kw):
    """A flat circuit with nodes in order of first appearance."""
    nodes = []
    for el in elements:
        for nd in el.nodes:
            if nd != "0" and nd not in nodes:
                nodes.append(nd)
    return Circuit(title, elements=list(elements), nodes=nodes, **kw)
