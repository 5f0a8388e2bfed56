"""The prepared circuit: what every step of one analysis reads, built once and passed down.

An analysis used to assemble its :class:`~netdae.mna.system.MnaSystem` and
then climb back from it to the circuit (its ``.ic``, its elements' names for
messages) and to the topology (recomputed, or looked up by structure, by every
step that needed it). A :class:`Prepared` holds the three together: the
elaborated :class:`~netdae.circuit.Circuit`, its MNA system in the analysis's
source mode, and its topological analysis (computed at the first need and
kept). The operating point, the index analysis, the transient's start and
structure steps and the noise generators take it; the MNA system knows
equations, not circuits.

Examples
--------
>>> import netdae
>>> p = prepare(netdae.load("rc\\nV1 a 0 1\\nR1 a b 1k\\nC1 b 0 1n\\n.end\\n"))
>>> p.system.names
('v(a)', 'v(b)', 'i(v1)')
>>> p.topology.topological_index  # the source's current is algebraic
1
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from ..circuit import Circuit
from ..mna import assemble
from ..mna.sources import MODE_DC
from ..mna.system import MnaSystem

__all__ = ["Prepared", "prepare"]


@dataclass(frozen=True, eq=False)
class Prepared:
    """One analysis's circuit, its MNA system and (at the first need) its topology.

    Attributes
    ----------
    circuit : Circuit
        The elaborated circuit.
    system : MnaSystem
        Its MNA system (in the source mode of the analysis).
    topology : TopologyReport
        :func:`netdae.topology.analyze_topology` of the circuit, computed once
        (memoised by structure there too, so a sweep's rows share it).
    """

    circuit: Circuit
    system: MnaSystem

    @cached_property
    def topology(self):
        from ..topology import analyze_topology

        return analyze_topology(self.circuit)

    @classmethod
    def known(cls, circuit: Circuit, system: MnaSystem, topology) -> "Prepared":
        """A prepared circuit whose topology is already at hand (the same connections as another's)."""
        out = cls(circuit, system)
        out.__dict__["topology"] = topology
        return out

    def with_system(self, system: MnaSystem) -> "Prepared":
        """Another system of the same circuit (its steady form, its transient form); the topology is shared."""
        if system is self.system:
            return self
        if "topology" in self.__dict__:
            return Prepared.known(self.circuit, system, self.__dict__["topology"])
        return Prepared(self.circuit, system)


def prepare(circuit: Circuit, *, mode: str = MODE_DC, tstep: float | None = None,
            tstop: float | None = None) -> Prepared:
    """Assemble ``circuit`` for one analysis (:func:`netdae.mna.assemble`, same arguments).

    Raises
    ------
    CircuitError
        What :func:`~netdae.mna.assemble` raises.
    """
    return Prepared(circuit, assemble(circuit, mode=mode, tstep=tstep, tstop=tstop))
