"""Topological analysis of a circuit, in circuit terms.

A :class:`~netdae.circuit.Circuit` in, plain data out: loops of voltage
sources and cutsets of current sources (singular), CV-loops and LI-cutsets
(index 2), loops of capacitors, nodes without a DC path to ground, floating
sub-networks, dangling nodes and shorted elements, each named by its
elements and nodes, with the index the structure implies (Estévez Schwarz &
Tischendorf 2000) when the circuit is within the theorem's hypotheses.

- :func:`analyze_topology` -- the full :class:`TopologyReport`.
- :func:`dc_singularity_explanation`, :func:`pencil_singularity_explanation`
  -- the best circuit-level reason for a singular matrix, for the solvers.
"""

from .analysis import MAX_LISTED, analyze_topology
from .explain import dc_singularity_explanation, pencil_singularity_explanation
from .report import Cutset, Finding, Loop, NodeGroup, TopologyReport

__all__ = [
    "analyze_topology",
    "dc_singularity_explanation",
    "pencil_singularity_explanation",
    "TopologyReport",
    "Finding",
    "Loop",
    "Cutset",
    "NodeGroup",
    "MAX_LISTED",
]
