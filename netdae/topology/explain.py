"""Explanations of a singular matrix in circuit terms, for the solvers.

When a solver finds its matrix singular it asks here for the topological
reason. The answer is a :class:`~netdae.errors.CircuitError` (not raised
unless asked) that names the elements and nodes and carries a hint, or
``None`` when the structure shows no reason (then the singularity is
numerical or comes from element values).
"""

from __future__ import annotations

from ..circuit import Circuit
from ..errors import CircuitError
from ..signals import parse_signal
from .analysis import analyze_topology
from .report import Finding, TopologyReport

__all__ = ["dc_singularity_explanation", "pencil_singularity_explanation"]

#: Findings that make the DC operating-point matrix singular, best first.
DC_KINDS = ("v_loop", "floating", "i_cutset", "dc_loop", "no_dc_path")
#: Findings that make the pencil (E, H) singular, best first.
PENCIL_KINDS = ("v_loop", "floating", "i_cutset")


def _mentions(f: Finding, signal: str | None) -> bool:
    """The finding involves the unknown ``signal`` (``"v(a)"``, ``"i(v1)"`` or a bare name)."""
    if not signal:
        return False
    s = signal.strip().lower()
    if not s.startswith(("v(", "i(")):  # a bare name: a node or an element
        return s in f.nodes or s in f.elements
    try:
        sig = parse_signal(s)
    except ValueError:
        return False
    if sig.kind == "v":
        return len(sig.nodes) == 1 and sig.nodes[0] in f.nodes
    return sig.args[0] in f.elements


def _explain(circuit: Circuit, kinds: tuple[str, ...], signal: str | None, report: TopologyReport | None,
             raise_error: bool) -> CircuitError | None:
    report = report if report is not None else analyze_topology(circuit)
    candidates = [f for f in report.findings if f.kind in kinds]
    if not candidates:
        return None
    # a group that charge conservation fixes (a note) explains the raw DC matrix, but comes last
    best = min(candidates, key=lambda f: (f.severity == "note", f.controlled, not _mentions(f, signal),
                                          kinds.index(f.kind)))
    err = CircuitError(best.message, elements=best.elements, nodes=best.nodes, hint=best.hint)
    if raise_error:
        raise err
    return err


def dc_singularity_explanation(circuit: Circuit, signal: str | None = None, *, report: TopologyReport | None = None,
                               raise_error: bool = False) -> CircuitError | None:
    """Why the DC operating-point matrix of ``circuit`` is singular.

    Parameters
    ----------
    circuit : Circuit
    signal : str, optional
        An unknown the solver found undetermined (``"v(a)"``, ``"i(l2)"``);
        findings that involve it are preferred.
    report : TopologyReport, optional
        A report already computed for ``circuit``.
    raise_error : bool
        Raise the explanation instead of returning it.

    Returns
    -------
    CircuitError or None
        The best explanation (``.message``, ``.elements``, ``.nodes``,
        ``.hint``), or None when the topology shows no reason. Certain
        findings come before those that rely on controlled sources; then
        loops of voltage sources, floating sub-networks, cutsets of current
        sources, inductor loops, nodes without DC path.

    Raises
    ------
    CircuitError
        The explanation, when ``raise_error`` is true and there is one.

    Examples
    --------
    >>> from netdae.circuit import Circuit, Element
    >>> c = Circuit("", [Element("v1", "vsource", ("a", "0")), Element("r1", "resistor", ("a", "b"), 1e3),
    ...                  Element("c1", "capacitor", ("b", "0"), 1e-6)], ["a", "b"])
    >>> dc_singularity_explanation(c) is None
    True
    >>> c.elements.append(Element("c2", "capacitor", ("x", "b"), 1e-6))
    >>> print(dc_singularity_explanation(c).message)  # a note: the operating point exists all the same
    DC operating point: node 'x' has no DC path to ground: only c2 attaches it; its DC potential follows from charge conservation (the total charge on it at t = 0 is zero, or what .ic sets)
    """
    return _explain(circuit, DC_KINDS, signal, report, raise_error)


def pencil_singularity_explanation(circuit: Circuit, signal: str | None = None, *,
                                   report: TopologyReport | None = None,
                                   raise_error: bool = False) -> CircuitError | None:
    """Why the pencil ``(E, H)`` of ``circuit`` is singular (loops of voltage
    sources, cutsets of current sources, floating sub-networks).

    Parameters and result as :func:`dc_singularity_explanation`.
    """
    return _explain(circuit, PENCIL_KINDS, signal, report, raise_error)
