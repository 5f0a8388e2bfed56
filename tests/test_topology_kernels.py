"""Graph kernels of the topological analysis against networkx (random multigraphs)."""

from __future__ import annotations

import networkx as nx
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from netdae.topology.kernels import bridges, components, fundamental_cycle, group_by, on_cycle, spanning_forest


@st.composite
def multigraphs(draw):
    n = draw(st.integers(1, 9))
    m = draw(st.integers(0, 16))
    u = np.array(draw(st.lists(st.integers(0, n - 1), min_size=m, max_size=m)), dtype=np.int64)
    v = np.array(draw(st.lists(st.integers(0, n - 1), min_size=m, max_size=m)), dtype=np.int64)
    w = np.array(draw(st.lists(st.integers(1, 3), min_size=m, max_size=m)), dtype=np.int64)
    return n, u, v, w


def _nx(n, u, v, edges=None):
    g = nx.MultiGraph()
    g.add_nodes_from(range(n))
    for e in range(len(u)) if edges is None else edges:
        g.add_edge(int(u[e]), int(v[e]), key=e)
    return g


@settings(max_examples=300, deadline=None, derandomize=True)
@given(multigraphs())
def test_components_match_networkx(graph):
    n, u, v, _ = graph
    labels = components(n, u, v)
    for comp in nx.connected_components(_nx(n, u, v)):
        comp = sorted(comp)
        assert len(set(labels[comp])) == 1
        assert np.count_nonzero(labels == labels[comp[0]]) == len(comp)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(multigraphs())
def test_spanning_forest_is_a_minimum_rooted_forest(graph):
    n, u, v, w = graph
    f = spanning_forest(n, u, v, w)
    g = _nx(n, u, v)
    for e in range(len(u)):
        g.edges[int(u[e]), int(v[e]), e]["weight"] = int(w[e])
    tree_edges = np.flatnonzero(f.tree)
    assert len(tree_edges) == n - nx.number_connected_components(g)
    assert nx.is_forest(nx.Graph(_nx(n, u, v, tree_edges)))
    best = sum(d["weight"] for *_, d in nx.minimum_spanning_edges(g, keys=True, data=True))
    assert int(w[tree_edges].sum()) == best
    for x in range(n):
        p, e = f.parent[x], f.parent_edge[x]
        if p < 0:
            assert f.depth[x] == 0 and e == -1
        else:
            assert f.tree[e] and {int(u[e]), int(v[e])} == {x, int(p)} and f.depth[x] == f.depth[p] + 1


@settings(max_examples=300, deadline=None, derandomize=True)
@given(multigraphs())
def test_fundamental_cycles_are_simple_closed_and_lighter(graph):
    n, u, v, w = graph
    f = spanning_forest(n, u, v, w)
    for e in np.flatnonzero(~f.tree):
        nodes, edges = fundamental_cycle(f, int(u[e]), int(v[e]), int(e))
        assert len(nodes) == len(edges) == len(set(nodes))
        assert edges[-1] == e and all(f.tree[x] for x in edges[:-1])
        for i, x in enumerate(edges):
            assert {int(u[x]), int(v[x])} == {nodes[i], nodes[(i + 1) % len(nodes)]}
        assert all(w[x] <= w[e] for x in edges)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(multigraphs(), st.data())
def test_on_cycle_matches_edge_removal(graph, data):
    n, u, v, _ = graph
    split = np.array(data.draw(st.lists(st.booleans(), min_size=len(u), max_size=len(u))), dtype=bool)
    base, probe = split, ~split
    got = on_cycle(n, u, v, base, probe)
    for k, e in enumerate(np.flatnonzero(probe)):
        g = _nx(n, u, v)
        g.remove_edge(int(u[e]), int(v[e]), key=int(e))
        assert got[k] == nx.has_path(g, int(u[e]), int(v[e]))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(multigraphs())
def test_bridges_match_networkx(graph):
    n, u, v, _ = graph
    keep = u != v  # bridges() takes no self-loops (a self-loop is never a bridge)
    u, v = u[keep], v[keep]
    got = bridges(n, u, v)
    g = _nx(n, u, v)
    expected = {frozenset(e) for e in nx.bridges(g)}
    for e in range(len(u)):
        parallel = np.count_nonzero(((u == u[e]) & (v == v[e])) | ((u == v[e]) & (v == u[e]))) > 1
        assert got[e] == (not parallel and frozenset((int(u[e]), int(v[e]))) in expected)


def test_bridges_of_a_path_a_cycle_and_a_parallel_pair():
    # 0-1-2 path (bridges), 2-3-4-2 triangle (not), 4=5 parallel pair (not), 5-6 bridge
    a = np.array([0, 1, 2, 3, 4, 4, 4, 5])
    b = np.array([1, 2, 3, 4, 2, 5, 5, 6])
    assert bridges(7, a, b).tolist() == [True, True, False, False, False, False, False, True]


def test_group_by_keeps_order_within_groups():
    groups = group_by(np.array([2, 0, 2, 1, 0]), np.array([10, 11, 12, 13, 14]))
    assert {k: g.tolist() for k, g in groups.items()} == {0: [11, 14], 1: [13], 2: [10, 12]}
    assert group_by(np.array([], dtype=int), np.array([], dtype=int)) == {}
