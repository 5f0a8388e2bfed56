"""Assembly: an elaborated :class:`~netdae.circuit.Circuit` -> :class:`MnaSystem`.

Done once per circuit and analysis: number the unknowns, stamp the linear
elements into constant matrices, let every nonlinear family allocate its
nodes/branches and declare its Jacobian entries, then fix the sparsity
pattern (union of all entries plus the diagonal) for the whole run.

A circuit that differs from an assembled one only in the values of its linear
elements (a sweep's or a Monte Carlo run's rows) is assembled on that one's
unknowns, pattern and device families (:func:`reassemble`): only its linear
stamps are made again.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from ..circuit import Circuit, Element
from ..dae.exact import EXACT_LIMIT
from ..dae.sparse import SparsePattern
from ..devices.base import SlotMap
from ..devices.linear import branch_names, stamp_linear
from ..devices.registry import family_for
from ..errors import CircuitError
from ..kinds import KINDS
from .layout import Layout
from .sources import MODE_DC, MODE_TRAN, SourceVector
from .system import Delays, MnaSystem

__all__ = ["assemble", "group_by_kind", "Template", "reassemble"]


def group_by_kind(circuit: Circuit) -> dict[str, list[Element]]:
    """The circuit's elements by kind, in netlist order."""
    by_kind: dict[str, list[Element]] = defaultdict(list)
    for el in circuit.elements:
        by_kind[el.kind].append(el)
    return by_kind


def assemble(circuit: Circuit, *, mode: str = MODE_DC, tstep: float | None = None,
             tstop: float | None = None) -> MnaSystem:
    """Build the MNA system of a circuit.

    Parameters
    ----------
    circuit : Circuit
        The elaborated flat circuit (:func:`netdae.load`).
    mode : {"dc", "tran"}
        Which source values apply (see :mod:`netdae.mna.sources`): ``"dc"`` for
        ``.op``/``.dc``/``.ac``, ``"tran"`` for a transient and its operating point.
    tstep, tstop : float, optional
        The transient's step and stop time (waveform defaults depend on them).

    Returns
    -------
    MnaSystem

    Raises
    ------
    CircuitError
        An element kind netdae cannot simulate, or inconsistent element data
        (e.g. a coupling matrix that is not positive definite).

    Notes
    -----
    Cost O(elements + nnz log nnz). Unknowns: the circuit's nodes in order of
    first appearance, internal device nodes, then branch currents in element
    order.

    Examples
    --------
    >>> from netdae.circuit import Circuit, Element, SourceSpec
    >>> ckt = Circuit("divider", nodes=["a", "b"], elements=[
    ...     Element("v1", "vsource", ("a", "0"), source=SourceSpec(dc=1.0)),
    ...     Element("r1", "resistor", ("a", "b"), 1e3),
    ...     Element("r2", "resistor", ("b", "0"), 1e3)])
    >>> sys = assemble(ckt)
    >>> sys.names
    ('v(a)', 'v(b)', 'i(v1)')
    >>> (0.0 - sys.H.toarray()).tolist()
    [[0.001, -0.001, 1.0], [-0.001, 0.002, 0.0], [-1.0, 0.0, 0.0]]
    """
    if mode not in (MODE_DC, MODE_TRAN):
        raise ValueError(f"mode must be 'dc' or 'tran', not {mode!r}")
    by_kind = group_by_kind(circuit)
    families = []
    for kind, els in by_kind.items():
        spec = KINDS.get(kind)
        if spec is not None and spec.stamped:
            continue
        fam_cls = family_for(kind)
        if fam_cls is None:
            names = ", ".join(el.name for el in els[:5])
            raise CircuitError(
                f"netdae cannot simulate elements of kind '{kind}' ({names})",
                elements=[el.name for el in els],
            )
        if not any(isinstance(f, fam_cls) for f in families):
            families.append(fam_cls([e for e in circuit.elements if family_for(e.kind) is fam_cls], circuit))

    layout = Layout.from_nodes(circuit.nodes)
    for el in circuit.elements:  # nodes appearing only in elements (defensive)
        for nd in el.nodes:
            layout.add_node(nd)
    for fam in families:
        fam.add_nodes(layout)
    for el in circuit.elements:
        if family_for(el.kind) is None:
            for name in branch_names(el):
                layout.add_branch(name)
    for fam in families:
        fam.add_branches(layout)

    stamps = stamp_linear(circuit, layout, by_kind)
    rows = [stamps.E.coordinates()[0], stamps.H.coordinates()[0], stamps.D.coordinates()[0]]
    cols = [stamps.E.coordinates()[1], stamps.H.coordinates()[1], stamps.D.coordinates()[1]]
    for fam in families:
        r, c = fam.coordinates(layout)
        keep = (r >= 0) & (c >= 0)
        rows.append(r[keep])
        cols.append(c[keep])
    pattern = SparsePattern.from_coo(layout.n, rows, cols)
    slots = SlotMap(pattern)
    for fam in families:
        fam.bind(slots, layout.n)
    return _system(layout, stamps, families, pattern, mode, tstep, tstop)


def _system(layout: Layout, stamps, families: list, pattern: SparsePattern, mode: str, tstep: float | None,
            tstop: float | None, sums: tuple | None = None, like: MnaSystem | None = None) -> MnaSystem:
    """The system of a circuit's linear stamps and bound families on its pattern.

    ``sums``: the :class:`~netdae.devices.stamps.CscSum` of ``E``, ``H``, ``B`` and ``H_ac`` when the
    stamps' coordinates are known (a template's); ``like``: a system of the same structure
    (:class:`MnaSystem`'s shortcut).
    """
    n = layout.n
    sources = SourceVector(stamps.sources, mode, tstep, tstop, like=like.sources if like is not None else None)
    if sums is None:
        sums = _sums(stamps, n)
    E, H, B, H_ac = (s.matrix(t.values()) for s, t in zip(sums, (stamps.E, stamps.H, stamps.B, stamps.H_ac)))
    system = MnaSystem(layout, E, H, B, sources, families, pattern, stamps.notes, H_ac,
                       delays=Delays.of(stamps, n) if stamps.delay_rows else None, like=like)
    if not families and not stamps.delay_rows and n <= EXACT_LIMIT:
        system.linear_terms = tuple((*t.coordinates(), t.values(), t.reciprocals()) for t in (stamps.E, stamps.H))
    return system


def _sums(stamps, n: int) -> tuple:
    """How the stamps' entries sum into ``E``, ``H``, ``B`` and ``H_ac``."""
    return (stamps.E.summation(n), stamps.H.summation(n), stamps.B.summation(n, len(stamps.sources)),
            stamps.H_ac.summation(n))


# -- circuits that differ only in linear values ---------------------------------------------------
def _coordinates(stamps) -> tuple[np.ndarray, ...]:
    """Where the linear stamps write (E, H, B, H_ac, D): what two assemblies must share to share a pattern."""
    return tuple(c for t in (stamps.E, stamps.H, stamps.B, stamps.H_ac, stamps.D) for c in t.coordinates())


@dataclass(frozen=True, eq=False)
class Template:
    """An assembled circuit that circuits of the same structure are assembled from (:func:`reassemble`).

    Attributes
    ----------
    circuit : Circuit
    system : MnaSystem
        Its system (families bound, pattern fixed).
    mode : str
    tstep, tstop : float or None
        The arguments of its :func:`assemble`.
    coordinates : tuple of ndarray
        Where its linear stamps write.
    sums : tuple of CscSum
        How they sum into ``E``, ``H``, ``B`` and ``H_ac``.
    """

    circuit: Circuit
    system: MnaSystem
    mode: str
    tstep: float | None
    tstop: float | None
    coordinates: tuple
    sums: tuple

    @classmethod
    def of(cls, circuit: Circuit, system: MnaSystem, *, mode: str = MODE_DC, tstep: float | None = None,
           tstop: float | None = None) -> "Template | None":
        """The template of ``circuit`` and its ``system`` (made by :func:`assemble` with these arguments),
        or None when no other circuit may share its system's parts (a family with held states,
        transmission lines)."""
        if system.delays is not None or not all(f.shareable for f in system.families):
            return None
        stamps = stamp_linear(circuit, system.layout, group_by_kind(circuit))
        return cls(circuit, system, mode, tstep, tstop, _coordinates(stamps), _sums(stamps, system.n))


def _same_but_linear_values(base: Circuit, circuit: Circuit) -> bool:
    """True when ``circuit`` has ``base``'s nodes, elements (names, kinds, nodes, controls, models),
    models and options, and differs at most in values of elements that no device family evaluates."""
    if (circuit.nodes != base.nodes or len(circuit.elements) != len(base.elements)
            or circuit.options != base.options or circuit.models != base.models):
        return False
    for a, b in zip(circuit.elements, base.elements):
        if a is b:
            continue
        if a.name != b.name or a.kind != b.kind or a.nodes != b.nodes or a.controls != b.controls \
                or a.model != b.model:
            return False
        if family_for(a.kind) is not None and a != b:
            return False
    return True


def reassemble(template: Template, circuit: Circuit) -> MnaSystem | None:
    """The system of ``circuit`` assembled on ``template``'s, when they differ only in linear values.

    The linear elements are stamped again (the same stamps :func:`assemble` makes, on the template's
    unknowns); the layout, the pattern and the device families (whose instances are equal) are the
    template's, shared. The result is the system :func:`assemble` would build for ``circuit``, value
    for value, without building the families again.

    Returns
    -------
    MnaSystem or None
        None when the circuits differ in more than the values of linear elements (another node or
        element, another device instance, model or option) or the stamps write elsewhere (a value
        that became zero): assemble ``circuit`` on its own.

    Raises
    ------
    CircuitError
        What stamping ``circuit``'s linear elements raises in :func:`assemble`.

    Notes
    -----
    Cost: the linear stamps, O(elements), and the matrices summed on the template's structure,
    O(nnz); a sweep's rows pay this instead of a whole assembly (the families' parameters, their
    node and slot bookkeeping, the sorts of the coordinates and the search of the pattern).
    """
    if not _same_but_linear_values(template.circuit, circuit):
        return None
    base = template.system
    stamps = stamp_linear(circuit, base.layout, group_by_kind(circuit))
    got = _coordinates(stamps)
    if len(got) != len(template.coordinates) or not all(
            np.array_equal(a, b) for a, b in zip(got, template.coordinates)):
        return None
    return _system(base.layout, stamps, base.families, base.pattern, template.mode, template.tstep, template.tstop,
                   template.sums, base)
