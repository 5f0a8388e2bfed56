"""Numbering of MNA unknowns: node potentials first, then branch currents.

The layout turns names into indices once, so that every stamp afterwards is
array arithmetic. Ground has index ``GND = -1``; stamps map it to an extra
slot that is dropped (see :mod:`netdae.devices.stamps`), so no branch on ground is
needed in vectorised code.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..circuit import GROUND
from ..dae.system import KIND_CURRENT, KIND_VOLTAGE

__all__ = ["GND", "Layout"]

#: Index of the ground node in stamp arrays.
GND = -1


@dataclass
class Layout:
    """Unknowns of an MNA system.

    Attributes
    ----------
    nodes : list of str
        Non-ground node names; node ``nodes[i]`` has unknown ``i``.
    branches : list of str
        Element names whose current is an unknown, in order after the nodes.
    internal : set of str
        Nodes created by device models (e.g. the node behind a series resistance).
    beside : dict of str to str
        An internal node behind a series resistance, and the terminal's node in front of it
        (ngspice takes a device's initial junction voltages from its terminals' ``.ic``).
    """

    nodes: list[str] = field(default_factory=list)
    branches: list[str] = field(default_factory=list)
    internal: set[str] = field(default_factory=set)
    beside: dict[str, str] = field(default_factory=dict)
    _node_index: dict[str, int] = field(default_factory=dict)
    _branch_index: dict[str, int] = field(default_factory=dict)

    @classmethod
    def from_nodes(cls, nodes) -> "Layout":
        """A layout with the given non-ground nodes and no branches yet."""
        lay = cls()
        for name in nodes:
            lay.add_node(name)
        return lay

    def add_node(self, name: str, *, internal: bool = False, beside: int | None = None) -> int:
        """Index of node ``name``, creating it if new (``beside``: the index of the terminal's node in front of
        an internal node behind a series resistance)."""
        if name == GROUND:
            return GND
        idx = self._node_index.get(name)
        if idx is None:
            if self.branches:
                raise RuntimeError("nodes must be added before branches")
            idx = len(self.nodes)
            self.nodes.append(name)
            self._node_index[name] = idx
            if internal:
                self.internal.add(name)
                if beside is not None and beside != GND:
                    self.beside[name] = self.nodes[beside]
        return idx

    def add_branch(self, element: str) -> int:
        """Index of the branch-current unknown of ``element`` (created once)."""
        idx = self._branch_index.get(element)
        if idx is None:
            idx = len(self.nodes) + len(self.branches)
            self.branches.append(element)
            self._branch_index[element] = idx
        return idx

    def node(self, name: str) -> int:
        """Index of an existing node (``GND`` for ground).

        Raises
        ------
        KeyError
        """
        return GND if name == GROUND else self._node_index[name]

    def nodes_of(self, names) -> np.ndarray:
        """Indices of several node names as an int array."""
        return np.array([self.node(nm) for nm in names], dtype=np.int64)

    def branch(self, element: str) -> int:
        """Index of the branch current of ``element``.

        Raises
        ------
        KeyError
        """
        return self._branch_index[element]

    def has_branch(self, element: str) -> bool:
        return element in self._branch_index

    def target(self, i: int) -> tuple[str, str]:
        """What unknown ``i`` is: ``("node", name)`` (its potential) or ``("branch", element)`` (its current).

        Examples
        --------
        >>> lay = Layout.from_nodes(["a", "b"]); _ = lay.add_branch("v1")
        >>> lay.target(1), lay.target(2)
        (('node', 'b'), ('branch', 'v1'))
        """
        k = len(self.nodes)
        return ("node", self.nodes[i]) if i < k else ("branch", self.branches[i - k])

    @property
    def n(self) -> int:
        """Number of unknowns."""
        return len(self.nodes) + len(self.branches)

    @property
    def names(self) -> tuple[str, ...]:
        """Signal names: ``v(node)`` then ``i(element)``."""
        return tuple(f"v({nm})" for nm in self.nodes) + tuple(f"i({nm})" for nm in self.branches)

    @property
    def kinds(self) -> np.ndarray:
        """Kind of each unknown (volts for nodes, amperes for branches)."""
        k = np.full(self.n, KIND_CURRENT, dtype=np.int8)
        k[: len(self.nodes)] = KIND_VOLTAGE
        return k
