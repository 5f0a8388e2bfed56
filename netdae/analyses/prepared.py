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

from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from functools import cached_property

from ..circuit import Circuit
from ..mna import assemble
from ..mna.sources import MODE_DC
from ..mna.system import MnaSystem

__all__ = ["Prepared", "prepare", "reusing"]


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


#: The templates the analyses of this context assemble from (:func:`reusing`); None: assemble each circuit.
_TEMPLATES: ContextVar[dict | None] = ContextVar("netdae_templates", default=None)


@contextmanager
def reusing(templates: dict):
    """Within the block, :func:`prepare` assembles a circuit on the first one prepared with the same
    arguments when the two differ only in linear values (:func:`netdae.mna.assemble.reassemble`).

    ``templates`` is the caller's store (empty at first; kept to reuse across blocks, e.g. the rows
    of one sweep in a process). A circuit so assembled gets the same system, value for value, as on
    its own: results do not depend on which circuit came first.
    """
    token = _TEMPLATES.set(templates)
    try:
        yield templates
    finally:
        _TEMPLATES.reset(token)


def prepare(circuit: Circuit, *, mode: str = MODE_DC, tstep: float | None = None,
            tstop: float | None = None) -> Prepared:
    """Assemble ``circuit`` for one analysis (:func:`netdae.mna.assemble`, same arguments).

    Within :func:`reusing`, on the template of the block's first circuit prepared with the same
    arguments when only linear values differ (its topology shared too).

    Raises
    ------
    CircuitError
        What :func:`~netdae.mna.assemble` raises.
    """
    templates = _TEMPLATES.get()
    if templates is None:
        return Prepared(circuit, assemble(circuit, mode=mode, tstep=tstep, tstop=tstop))
    from ..mna.assemble import Template, reassemble

    key = (mode, tstep, tstop)
    if key in templates:
        found = templates[key]
        if found is not None:
            template, first = found
            system = reassemble(template, circuit)
            if system is not None:
                if "topology" in first.__dict__:  # the same structure: the same topology
                    return Prepared.known(circuit, system, first.__dict__["topology"])
                return Prepared(circuit, system)
        return Prepared(circuit, assemble(circuit, mode=mode, tstep=tstep, tstop=tstop))
    prepared = Prepared(circuit, assemble(circuit, mode=mode, tstep=tstep, tstop=tstop))
    template = Template.of(circuit, prepared.system, mode=mode, tstep=tstep, tstop=tstop)
    templates[key] = None if template is None else (template, prepared)
    return prepared
