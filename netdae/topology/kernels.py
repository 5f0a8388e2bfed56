"""Graph kernels on branch arrays: components, spanning forests, loops, cuts.

Pure functions over integer arrays (nodes ``0..n-1``, branches given by
their end nodes ``u, v``); parallel branches and self-loops are allowed.
The heavy lifting is done by :mod:`scipy.sparse.csgraph` (compiled), so
each kernel costs O(n + m) or O(m log m) with small constants; only the
explicit listing of a loop walks it in Python, O(length of the loop).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

__all__ = [
    "components",
    "Groups",
    "group_by",
    "Forest",
    "spanning_forest",
    "fundamental_cycle",
    "on_cycle",
    "bridges",
    "blocks",
]


def components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected-component label of every node of the graph with edges (u, v).

    Parameters
    ----------
    n : int
        Number of nodes.
    u, v : ndarray of int, shape (m,)

    Returns
    -------
    labels : ndarray of int, shape (n,)
        Equal labels for connected nodes; isolated nodes get their own.
    """
    adj = sp.coo_matrix((np.ones(len(u), dtype=np.int8), (u, v)), shape=(n, n)).tocsr()
    return csgraph.connected_components(adj, directed=False)[1]


class Groups(Mapping):
    """Values grouped by integer key: a read-only mapping ``key -> ndarray`` of views.

    Attributes
    ----------
    keys : ndarray, shape (g,)
        Distinct keys, ascending.
    starts, ends : ndarray, shape (g,)
        Slice of ``values`` holding each key's values.
    values : ndarray, shape (k,)
        All values, sorted by key (stable: original order within a key).
    """

    def __init__(self, keys: np.ndarray, starts: np.ndarray, ends: np.ndarray, values: np.ndarray):
        self.keys, self.starts, self.ends, self.values = keys, starts, ends, values
        self._position = dict(zip(keys.tolist(), range(len(keys))))

    def __getitem__(self, key) -> np.ndarray:
        i = self._position[int(key)]
        return self.values[self.starts[i]:self.ends[i]]

    def __iter__(self):
        return iter(self._position)

    def __len__(self) -> int:
        return len(self._position)


def group_by(keys: np.ndarray, values: np.ndarray) -> Groups:
    """Group ``values`` by ``keys`` in one stable sort, O(k log k).

    Parameters
    ----------
    keys, values : ndarray, shape (k,)

    Returns
    -------
    Groups
        ``{key: values with that key}``, values kept in their original order.
    """
    keys = np.asarray(keys, dtype=np.int64)
    order = np.argsort(keys, kind="stable")
    sk = keys[order]
    starts = np.flatnonzero(np.concatenate(([True], sk[1:] != sk[:-1]))) if len(sk) else np.zeros(0, np.int64)
    ends = np.append(starts[1:], len(sk)).astype(np.int64)
    return Groups(sk[starts], starts, ends, np.asarray(values)[order])


@dataclass(frozen=True)
class Forest:
    """A rooted spanning forest of a multigraph.

    Attributes
    ----------
    tree : ndarray of bool, shape (m,)
        The edge is in the forest.
    parent : ndarray of int64, shape (n,)
        Parent node, -1 at a root.
    parent_edge : ndarray of int64, shape (n,)
        Edge to the parent, -1 at a root.
    depth : ndarray of int64, shape (n,)
        Distance to the root.
    """

    tree: np.ndarray
    parent: np.ndarray
    parent_edge: np.ndarray
    depth: np.ndarray


def _depths(parent: np.ndarray) -> np.ndarray:
    """Depth of every node of a rooted forest by pointer jumping, O(n log n)."""
    n = len(parent)
    idx = np.arange(n)
    jump = np.where(parent < 0, idx, parent)
    dist = (parent >= 0).astype(np.int64)
    while np.any(jump[jump] != jump):
        dist = dist + dist[jump]
        jump = jump[jump]
    return dist


def spanning_forest(n: int, u: np.ndarray, v: np.ndarray, weight: np.ndarray) -> Forest:
    """A minimum spanning forest, rooted at the smallest node of each component.

    Parameters
    ----------
    n : int
        Number of nodes.
    u, v : ndarray of int, shape (m,)
        Edges; parallel edges and self-loops allowed.
    weight : ndarray of int, shape (m,)
        Positive edge weights (priority classes: lighter edges first).

    Returns
    -------
    Forest

    Notes
    -----
    Minimality gives the property the loop analysis relies on: for every
    threshold w, the forest's edges of weight <= w span the components of
    the subgraph of edges of weight <= w, so the fundamental cycle of a
    non-tree edge of weight w uses only edges of weight <= w. Cost: one
    sort of the edges, :func:`scipy.sparse.csgraph.minimum_spanning_tree`,
    one breadth-first search, O(m log m + n log n).
    """
    m = len(u)
    tree = np.zeros(m, dtype=bool)
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    proper = np.flatnonzero(lo != hi)
    key = lo[proper] * n + hi[proper]
    # one representative per node pair: the lightest edge, then the first
    order = np.lexsort((proper, weight[proper], key))
    first = np.ones(len(order), dtype=bool)
    first[1:] = key[order][1:] != key[order][:-1]
    rep = proper[order[first]]
    rep_key = key[order[first]]  # sorted
    graph = sp.coo_matrix((weight[rep].astype(float), (lo[rep], hi[rep])), shape=(n, n)).tocsr()
    mst = csgraph.minimum_spanning_tree(graph).tocoo()
    tkey = np.minimum(mst.row, mst.col).astype(np.int64) * n + np.maximum(mst.row, mst.col)
    tree[rep[np.searchsorted(rep_key, tkey)]] = True

    # root every component at its smallest node through a virtual node n
    tu, tv = u[tree], v[tree]
    labels = components(n, tu, tv)
    _, roots = np.unique(labels, return_index=True)
    vu = np.concatenate([tu, np.full(len(roots), n)])
    vv = np.concatenate([tv, roots])
    adj = sp.coo_matrix((np.ones(len(vu), dtype=np.int8), (vu, vv)), shape=(n + 1, n + 1)).tocsr()
    _, pred = csgraph.breadth_first_order(adj, n, directed=False, return_predecessors=True)
    parent = pred[:n].astype(np.int64)
    parent[parent == n] = -1
    parent_edge = np.full(n, -1, dtype=np.int64)
    child = np.flatnonzero(parent >= 0)
    ckey = np.minimum(child, parent[child]) * n + np.maximum(child, parent[child])
    parent_edge[child] = rep[np.searchsorted(rep_key, ckey)]
    return Forest(tree, parent, parent_edge, _depths(parent))


def fundamental_cycle(forest: Forest, u: int, v: int, edge: int) -> tuple[list[int], list[int]]:
    """The cycle closed by a non-tree edge ``edge = (u, v)``.

    Parameters
    ----------
    forest : Forest
    u, v : int
        End nodes of the edge.
    edge : int
        Its index.

    Returns
    -------
    nodes : list of int
        The nodes around the cycle, starting at ``u``.
    edges : list of int
        ``edges[i]`` joins ``nodes[i]`` and ``nodes[i+1]`` (cyclically); the
        last is ``edge`` itself, from ``v`` back to ``u``.

    Notes
    -----
    Walks the forest from both ends to their common ancestor: O(length).
    """
    parent, pedge, depth = forest.parent, forest.parent_edge, forest.depth
    left_n, left_e, right_n, right_e = [u], [], [v], []
    a, b = u, v
    while depth[a] > depth[b]:
        left_e.append(int(pedge[a]))
        a = int(parent[a])
        left_n.append(a)
    while depth[b] > depth[a]:
        right_e.append(int(pedge[b]))
        b = int(parent[b])
        right_n.append(b)
    while a != b:
        left_e.append(int(pedge[a]))
        a = int(parent[a])
        left_n.append(a)
        right_e.append(int(pedge[b]))
        b = int(parent[b])
        right_n.append(b)
    nodes = left_n + right_n[-2::-1]
    edges = left_e + right_e[::-1] + [edge]
    return nodes, edges


def bridges(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Which edges of an undirected multigraph are bridges (on no cycle).

    Parameters
    ----------
    n : int
        Number of vertices.
    a, b : ndarray of int, shape (m,)
        Edge end points, no self-loops; parallel edges are allowed (and are
        never bridges).

    Returns
    -------
    ndarray of bool, shape (m,)

    Notes
    -----
    A bridge is a block of one edge (:func:`blocks`: Tarjan's low-link
    depth-first search, where a parallel edge counts as a way back; R. E.
    Tarjan, A note on finding the bridges of a graph, *Inf. Process. Lett.* 2
    (1974) 160-161). O(n + m) Python steps: it runs once per topological
    analysis, never in a solver loop.
    """
    label = blocks(n, a, b)
    if not label.size:
        return np.zeros(0, dtype=bool)
    return np.bincount(label)[label] == 1


def blocks(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The biconnected component (block) of every edge of an undirected multigraph.

    Two edges lie on a common simple cycle iff they are in the same block; a
    bridge is a block of its own, and parallel edges share one.

    Parameters
    ----------
    n : int
        Number of vertices.
    a, b : ndarray of int, shape (m,)
        Edge end points, no self-loops; parallel edges are allowed.

    Returns
    -------
    ndarray of int, shape (m,)
        Block labels ``0..k-1``.

    Notes
    -----
    Tarjan's low-link depth-first search with a stack of edges (Hopcroft and
    Tarjan, *Commun. ACM* 16 (1973) 372-378), iterative, with edge identities
    so that a parallel edge counts as a way back: when a child's low link does
    not reach above its parent, the edges stacked since the tree edge to it
    form a block.
    O(n + m) Python steps, once per topological analysis.

    Examples
    --------
    >>> blocks(4, np.array([0, 1, 2, 2]), np.array([1, 2, 0, 3])).tolist()  # a triangle and a pendant edge
    [1, 1, 1, 0]
    """
    m = len(a)
    ends = np.concatenate([a, b])
    order = np.argsort(ends, kind="stable")
    nbr = np.concatenate([b, a])[order].tolist()
    eid = np.concatenate([np.arange(m), np.arange(m)])[order].tolist()
    start = np.searchsorted(ends[order], np.arange(n + 1)).tolist()
    disc = [-1] * n
    low = [0] * n
    label = np.full(m, -1, dtype=np.int64)
    edges: list[int] = []
    count = 0
    timer = 0
    for root in range(n):
        if disc[root] >= 0:
            continue
        disc[root] = low[root] = timer
        timer += 1
        stack = [[root, -1, start[root]]]  # vertex, edge it was reached by, next adjacency slot
        while stack:
            top = stack[-1]
            node, pos = top[0], top[2]
            if pos < start[node + 1]:
                top[2] = pos + 1
                e = eid[pos]
                if e == top[1]:
                    continue
                w = nbr[pos]
                if disc[w] < 0:
                    edges.append(e)
                    disc[w] = low[w] = timer
                    timer += 1
                    stack.append([w, e, start[w]])
                elif disc[w] < disc[node]:  # a way back to an ancestor (each back edge stacked once)
                    edges.append(e)
                    if disc[w] < low[node]:
                        low[node] = disc[w]
            else:
                stack.pop()
                if stack:
                    parent = stack[-1][0]
                    if low[node] < low[parent]:
                        low[parent] = low[node]
                    if low[node] >= disc[parent]:  # the edges since the tree edge to node: one block
                        while True:
                            f = edges.pop()
                            label[f] = count
                            if f == top[1]:
                                break
                        count += 1
    return label


def on_cycle(n: int, u: np.ndarray, v: np.ndarray, base: np.ndarray, probe: np.ndarray) -> np.ndarray:
    """Which probe edges lie on some cycle of the graph of base and probe edges.

    Parameters
    ----------
    n : int
    u, v : ndarray of int, shape (m,)
    base, probe : ndarray of bool, shape (m,)
        Disjoint edge masks.

    Returns
    -------
    ndarray of bool, shape (number of probe edges,)
        In the order of ``np.flatnonzero(probe)``.

    Notes
    -----
    Contracting the connected components of the base edges keeps the
    bridges among the probe edges: a probe edge inside one component lies on
    a cycle; the others lie on a cycle iff they are not bridges of the small
    contracted multigraph (:func:`bridges`, O(probe edges)).
    """
    labels = components(n, u[base], v[base])
    idx = np.flatnonzero(probe)
    cu, cv = labels[u[idx]], labels[v[idx]]
    result = cu == cv
    rest = np.flatnonzero(~result)
    if len(rest):
        # relabel the contracted vertices 0..k-1 so the search is O(probe edges)
        verts, inv = np.unique(np.concatenate([cu[rest], cv[rest]]), return_inverse=True)
        a, b = inv[: len(rest)], inv[len(rest):]
        result[rest] = ~bridges(len(verts), a, b)
    return result
