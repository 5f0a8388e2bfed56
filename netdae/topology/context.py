"""Shared machinery of the analyses: name lookups, partitions into components, cuts, loops."""

from __future__ import annotations

from collections import Counter
from functools import cached_property

import numpy as np

from ..kinds import KINDS
from .graph import NULLATOR, ROLES, CircuitGraph
from .kernels import components, fundamental_cycle, group_by, spanning_forest
from .report import Finding, Loop

__all__ = ["Context", "Cut", "Partition", "subforest", "loops_through", "EMPTY"]

#: How a message names an attachment of each role (see :data:`~netdae.topology.graph.ROLES`).
_ROLE = {"gate": "the gate of {}",
         "controlling input": "the controlling input of {}", "input": "the input of op-amp {}"}

#: An empty index array.
EMPTY = np.zeros(0, dtype=np.int64)


class Context:
    """The graph, name lookups and the findings collected for one circuit.

    Parameters
    ----------
    graph : CircuitGraph
    max_listed : int
        Findings per kind spelled out; :meth:`want` counts the rest.
    """

    def __init__(self, graph: CircuitGraph, max_listed: int):
        self.g = graph
        self.max_listed = max_listed
        self.n = graph.n_nodes
        self.nodes = graph.node_names
        self.elems = graph.element_names
        self.node_arr = np.array(graph.node_names, dtype=object)
        self.elem_arr = np.array(graph.element_names, dtype=object)
        self.findings: list[Finding] = []
        self.total: Counter[str] = Counter()

    def want(self, kind: str) -> bool:
        """Count a finding of ``kind``; true while it should still be spelled out."""
        self.total[kind] += 1
        return self.total[kind] <= self.max_listed

    def add(self, finding: Finding) -> None:
        self.findings.append(finding)

    @cached_property
    def elem_index(self) -> dict[str, int]:
        return {name: k for k, name in enumerate(self.elems)}

    @cached_property
    def kinds(self) -> dict[str, str]:
        return dict(zip(self.elems, self.g.element_kinds))

    @cached_property
    def stores(self) -> dict[str, str | None]:
        """What each element stores (:attr:`netdae.kinds.ElementKind.stores`), by name."""
        return {e: KINDS[k].stores for e, k in zip(self.elems, self.g.element_kinds)}

    @cached_property
    def controlled_names(self) -> frozenset[str]:
        return frozenset(self.elem_arr[np.unique(self.g.element[self.g.controlled])])

    def node_names(self, idx) -> tuple[str, ...]:
        """Names of node indices, in the given order."""
        return tuple(self.node_arr[np.asarray(idx, dtype=np.int64)])

    def in_netlist_order(self, names) -> list[str]:
        """Distinct element names sorted as in the netlist."""
        return sorted(set(names), key=self.elem_index.__getitem__)

    def elements_by_label(self, keys: np.ndarray, elements: np.ndarray) -> dict[int, tuple[str, ...]]:
        """``{key: distinct element names in netlist order}`` for (key, element) pairs, in one sort."""
        if len(keys) == 0:
            return {}
        m = len(self.elems)
        grp = group_by(*np.divmod(np.unique(keys.astype(np.int64) * m + elements), m))
        names = self.elem_arr[grp.values].tolist()
        return {k: tuple(names[a:b]) for k, a, b in zip(grp.keys.tolist(), grp.starts.tolist(), grp.ends.tolist())}

    def attachment_phrases(self, att) -> list[str]:
        g = self.g
        return [_ROLE[ROLES[g.attach_role[a]]].format(self.elems[g.attach_element[a]]) for a in att]

    def loop(self, forest, sel, local_u, local_v, local_edge, node_of, exact_nullators: bool = False):
        """The fundamental cycle of a non-tree edge as a :class:`Loop`, and its branches.

        The loop starts at its first node in circuit order (ground when it
        passes through ground) and runs in the direction in which the element
        first in netlist order comes first. It is ``controlled`` when a
        controlled element's equation takes part; with ``exact_nullators``
        the op-amp input equation ``v(in+) = v(in-)`` counts as exact.
        """
        g = self.g
        nodes, edges = fundamental_cycle(forest, int(local_u[local_edge]), int(local_v[local_edge]), int(local_edge))
        nodes = [int(node_of[i]) for i in nodes]
        k = nodes.index(min(nodes))
        nodes, edges = nodes[k:] + nodes[:k], edges[k:] + edges[:k]
        branches = sel[np.asarray(edges)]
        owners = g.element[branches]
        if owners[0] > owners[-1]:
            nodes, branches, owners = nodes[:1] + nodes[:0:-1], branches[::-1], owners[::-1]
        inputs = g.cls[branches] == NULLATOR
        relies = g.controlled[branches] & ~(inputs & exact_nullators)
        loop = Loop(
            elements=tuple(self.elem_arr[owners]),
            nodes=tuple(self.node_arr[np.asarray(nodes)]),
            controlled=bool(relies.any()),
            inputs=tuple(inputs.tolist()) if inputs.any() else (),
        )
        return loop, branches

    def split(self, loop: Loop) -> tuple[list[str], list[str]]:
        """(elements in the loop by their branch, op-amps in it by their input), each in netlist order."""
        inputs = loop.inputs or (False,) * len(loop.elements)
        plain = self.in_netlist_order(e for e, i in zip(loop.elements, inputs) if not i)
        return plain, self.in_netlist_order(e for e, i in zip(loop.elements, inputs) if i)


class Cut:
    """Branches crossing between the components of a partition, per component label.

    Attributes
    ----------
    keys, branches : ndarray, shape (2 k,)
        Each crossing branch twice, once under the label of each side.
    names : dict of int to tuple of str
        Distinct crossing elements per label, in netlist order.
    """

    def __init__(self, ctx: Context, labels: np.ndarray, mask: np.ndarray):
        g = ctx.g
        b = np.flatnonzero(mask)
        lu, lv = labels[g.u[b]], labels[g.v[b]]
        cross = lu != lv
        self.n = ctx.n
        self.keys = np.concatenate([lu[cross], lv[cross]])
        self.branches = np.concatenate([b[cross], b[cross]])
        self.names = ctx.elements_by_label(self.keys, g.element[self.branches])

    def count(self, flag: np.ndarray) -> np.ndarray:
        """Per label, the number of crossing branches with ``flag`` (a mask over all branches), shape (n,)."""
        return np.bincount(self.keys[flag[self.branches]], minlength=self.n)


class Partition:
    """Components of a subgraph; those without ground in order of their first node.

    Attributes
    ----------
    labels : ndarray, shape (n,)
        Component label of every node.
    """

    def __init__(self, ctx: Context, mask: np.ndarray):
        self.ctx = ctx
        self.labels = components(ctx.n, ctx.g.u[mask], ctx.g.v[mask])
        grp = group_by(self.labels, np.arange(ctx.n))  # nodes ascending within each component
        keep = np.flatnonzero(grp.keys != self.labels[0])
        keep = keep[np.argsort(grp.values[grp.starts[keep]])]
        self._labels, self._starts, self._ends = grp.keys[keep], grp.starts[keep], grp.ends[keep]
        self._nodes = grp.values
        self._names = ctx.node_arr[grp.values].tolist()

    def sets(self):
        """``(label, node indices, node names)`` of each component without ground."""
        for label, a, b in zip(self._labels.tolist(), self._starts.tolist(), self._ends.tolist()):
            yield label, self._nodes[a:b], tuple(self._names[a:b])

    def cut(self, mask: np.ndarray) -> Cut:
        """The branches of ``mask`` that cross between components."""
        return Cut(self.ctx, self.labels, mask)

    def attachments(self):
        """Attachment indices per label."""
        g = self.ctx.g
        return group_by(self.labels[g.attach_node], np.arange(len(g.attach_node)))


def subforest(ctx: Context, sel: np.ndarray, weight: np.ndarray):
    """Spanning forest of the branches ``sel`` on the nodes they touch (compressed)."""
    u, v = ctx.g.u[sel], ctx.g.v[sel]
    node_of = np.unique(np.concatenate([u, v, [0]]))
    lu, lv = np.searchsorted(node_of, u), np.searchsorted(node_of, v)
    return spanning_forest(len(node_of), lu, lv, weight), lu, lv, node_of


def loops_through(ctx: Context, sel: np.ndarray, weight: np.ndarray, probe: np.ndarray, skip: np.ndarray | None,
                   exact_nullators: bool):
    """Fundamental loops of the branches ``sel`` closed by non-tree branches of ``probe`` (a mask over ``sel``).

    ``skip`` (a mask over ``sel``): drop the loops of ``skip`` branches
    alone, i.e. closing branches of ``skip`` whose ends are joined by tree
    branches of ``skip`` (another analysis reports those). Returns (listed
    loops with their branches, number of loops), certain loops first.
    """
    g = ctx.g
    forest, lu, lv, node_of = subforest(ctx, sel, weight)
    closing = np.flatnonzero(~forest.tree & probe)
    if skip is not None:
        inside = forest.tree & skip
        labels = components(len(node_of), lu[inside], lv[inside])
        closing = closing[~skip[closing] | (labels[lu[closing]] != labels[lv[closing]])]
    closing = closing[np.argsort(g.controlled[sel[closing]] & (g.cls[sel[closing]] != NULLATOR), kind="stable")]
    return [ctx.loop(forest, sel, lu, lv, e, node_of, exact_nullators) for e in closing[:ctx.max_listed]], len(closing)
