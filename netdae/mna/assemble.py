"""Assembly: an elaborated :class:`~netdae.circuit.Circuit` -> :class:`MnaSystem`.

Done once per circuit and analysis: number the unknowns, stamp the linear
elements into constant matrices, let every nonlinear family allocate its
nodes/branches and declare its Jacobian entries, then fix the sparsity
pattern (union of all entries plus the diagonal) for the whole run.
"""

from __future__ import annotations

from collections import defaultdict

from ..circuit import Circuit, Element
from ..dae.sparse import SparsePattern
from ..devices.base import SlotMap
from ..devices.linear import branch_names, stamp_linear
from ..devices.registry import family_for
from ..errors import CircuitError
from ..kinds import KINDS
from .layout import Layout
from .sources import MODE_DC, MODE_TRAN, SourceVector
from .system import Delays, MnaSystem

__all__ = ["assemble", "group_by_kind"]


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
    n = layout.n
    rows = [stamps.E.coordinates()[0], stamps.H.coordinates()[0], stamps.D.coordinates()[0]]
    cols = [stamps.E.coordinates()[1], stamps.H.coordinates()[1], stamps.D.coordinates()[1]]
    for fam in families:
        r, c = fam.coordinates(layout)
        keep = (r >= 0) & (c >= 0)
        rows.append(r[keep])
        cols.append(c[keep])
    pattern = SparsePattern.from_coo(n, rows, cols)
    slots = SlotMap(pattern)
    for fam in families:
        fam.bind(slots, n)
    sources = SourceVector(stamps.sources, mode, tstep, tstop)
    return MnaSystem(
        layout,
        stamps.E.matrix(n),
        stamps.H.matrix(n),
        stamps.B.matrix(n, len(stamps.sources)),
        sources,
        families,
        pattern,
        stamps.notes,
        stamps.H_ac.matrix(n),
        delays=Delays.of(stamps, n) if stamps.delay_rows else None,
    )
