"""The result of the topological analysis: plain data, JSON-ready."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

__all__ = ["Loop", "Cutset", "NodeGroup", "Finding", "FindingKind", "Severity", "TopologyReport", "SEVERITIES"]


class _Vocabulary(StrEnum):
    """A closed vocabulary of strings: compares, serialises and prints (also in lists) as its value."""

    def __repr__(self) -> str:
        return repr(self.value)


class Severity(_Vocabulary):
    """How serious a finding is (a ``str``: compares and serialises as its value)."""

    #: The DAE is singular.
    ERROR = "error"
    #: Index 2, a singular DC operating point, a dangling node.
    WARNING = "warning"
    NOTE = "note"


#: Severities, most serious first.
SEVERITIES = tuple(Severity)


class FindingKind(_Vocabulary):
    """What a finding is about (a ``str``: compares and serialises as its value)."""

    V_LOOP = "v_loop"
    I_CUTSET = "i_cutset"
    FLOATING = "floating"
    CV_LOOP = "cv_loop"
    LI_CUTSET = "li_cutset"
    C_LOOP = "c_loop"
    DC_LOOP = "dc_loop"
    NO_DC_PATH = "no_dc_path"
    DANGLING = "dangling"
    SELF_LOOP = "self_loop"
    NOT_APPLICABLE = "not_applicable"
    ELEMENT_NOTE = "element_note"
    TRUNCATED = "truncated"


@dataclass(frozen=True, slots=True)
class Loop:
    """A loop of branches.

    Attributes
    ----------
    elements : tuple of str
        The elements around the loop, in order.
    nodes : tuple of str
        ``nodes[i]`` is the node between ``elements[i-1]`` and ``elements[i]``:
        the loop runs ``nodes[0] -elements[0]- nodes[1] ... -elements[-1]- nodes[0]``
        (it starts at ground when it passes through ground).
    controlled : bool
        The statement made about the loop relies on the equation of a
        controlled element, so it is structural (likely), not certain.
    inputs : tuple of bool
        ``inputs[i]`` is true when the loop passes through the *input* of the
        ideal op-amp ``elements[i]`` (shown as ``e1(in)``); empty: none does.
    """

    elements: tuple[str, ...]
    nodes: tuple[str, ...]
    controlled: bool = False
    inputs: tuple[bool, ...] = ()

    def path(self, limit: int | None = None) -> str:
        """The loop as text: ``"0 -v1- a -v2- 0"``.

        With ``limit``, a loop of more elements shows its first and last
        ``limit // 2`` steps around an ellipsis.

        >>> Loop(("v1", "c1", "c2"), ("0", "a", "b")).path()
        '0 -v1- a -c1- b -c2- 0'
        >>> Loop(tuple(f"c{k}" for k in range(6)), tuple(f"n{k}" for k in range(6))).path(limit=2)
        'n0 -c0- ... (4 more elements) ... n5 -c5- n0'
        """
        inputs = self.inputs or (False,) * len(self.elements)
        steps = [f"{node} -{el}{'(in)' if i else ''}-" for node, el, i in zip(self.nodes, self.elements, inputs)]
        if limit is not None and len(steps) > limit:
            half = max(1, limit // 2)
            steps = steps[:half] + [f"... ({len(steps) - 2 * half:,} more elements) ..."] + steps[-half:]
        return " ".join(steps + [self.nodes[0]])

    def to_dict(self) -> dict:
        return {"elements": list(self.elements), "nodes": list(self.nodes), "controlled": self.controlled,
                "inputs": list(self.inputs or (False,) * len(self.elements))}


@dataclass(frozen=True, slots=True)
class Cutset:
    """A set of nodes joined to the rest of the circuit only by certain branches.

    Attributes
    ----------
    nodes : tuple of str
        The nodes on the side away from ground.
    elements : tuple of str
        The elements whose branches cross from ``nodes`` to the rest.
    controlled : bool
        Some crossing element is a controlled source.
    """

    nodes: tuple[str, ...]
    elements: tuple[str, ...]
    controlled: bool = False

    def to_dict(self) -> dict:
        return {"nodes": list(self.nodes), "elements": list(self.elements), "controlled": self.controlled}


@dataclass(frozen=True, slots=True)
class NodeGroup:
    """Nodes together with the elements that attach them to the rest.

    Attributes
    ----------
    nodes : tuple of str
    elements : tuple of str
        For a group without DC path: the elements that attach it without
        conducting at DC (capacitors, current sources, gates, controlling
        inputs). For a floating group: every element touching it.
    controlled : bool
        Some attaching element is a controlled source.
    """

    nodes: tuple[str, ...]
    elements: tuple[str, ...]
    controlled: bool = False

    def to_dict(self) -> dict:
        return {"nodes": list(self.nodes), "elements": list(self.elements), "controlled": self.controlled}


@dataclass(frozen=True, slots=True)
class Finding:
    """One fact about the circuit's structure, in circuit terms.

    Attributes
    ----------
    kind : FindingKind
        Given as the enum or its value (``"v_loop"``); another value raises
        ``ValueError``.
    severity : Severity
        Given as the enum or its value (``"error"``).
    message : str
        What a circuit engineer would say.
    elements, nodes : tuple of str
        Everything involved.
    signals : tuple of str
        Unknowns this finding makes (likely) index 2: ``i(v1)``, ``v(a)``.
    controlled : bool
        Involves controlled sources: a structural (likely) statement.
    hint : str or None
        What the user might do.
    """

    kind: FindingKind
    severity: Severity
    message: str
    elements: tuple[str, ...] = ()
    nodes: tuple[str, ...] = ()
    signals: tuple[str, ...] = ()
    controlled: bool = False
    hint: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", FindingKind(self.kind))
        object.__setattr__(self, "severity", Severity(self.severity))

    def __str__(self) -> str:
        return f"{self.severity}: {self.message}"

    def to_dict(self) -> dict:
        return {
            "kind": self.kind.value,
            "severity": self.severity.value,
            "message": self.message,
            "elements": list(self.elements),
            "nodes": list(self.nodes),
            "signals": list(self.signals),
            "controlled": self.controlled,
            "hint": self.hint,
        }


@dataclass
class TopologyReport:
    """Everything the topological analysis found.

    Attributes
    ----------
    v_loops : list of Loop
        Loops of voltage sources only (singular); a basis of them.
    i_cutsets : list of Cutset
        Node sets cut from ground by current sources only (singular).
    cv_loops : list of Loop
        Loops of capacitors and voltage sources with at least one of each
        (index 2).
    c_loops : list of Loop
        Loops of capacitors only (dependent capacitor voltages).
    li_cutsets : list of Cutset
        Node sets cut from ground by inductors and current sources only, with
        at least one inductor (index 2).
    dc_loops : list of Loop
        Loops of inductors and voltage sources with at least one inductor:
        singular at DC, where inductors are shorts.
    no_dc_path : list of NodeGroup
        Node sets without a DC path to ground (singular DC matrix).
    charge_groups : list of NodeGroup
        Those of ``no_dc_path`` attached only through capacitors (and
        independent current sources; ``elements``: these crossing elements):
        the operating point fixes their potential by charge conservation.
    dangling_nodes : list of str
        Nodes with a single element terminal.
    floating_groups : list of NodeGroup
        Sub-networks with no connection to ground at all (singular).
    self_loops : list of str
        Elements with both terminals on one node.
    applicable : bool
        The hypotheses of the index theorem hold.
    not_applicable_reason : str or None
    topological_index : int or None
        0, 1 or 2 when applicable and not singular, else None.
    index_message : str
        The index statement or why there is none.
    singular : bool
        A certain singularity of the DAE (V-loop, I-cutset, floating group).
    dc_singular : bool
        A certain singularity of the DC operating point.
    index2_signals : list of str
        Unknowns likely of index 2 (empty when the DAE is singular).
    counts : dict of str to int
        Exact numbers of independent loops and of cutsets per kind; the
        lists above may be truncated (see :data:`MAX_LISTED`).
    findings : list of Finding
        Most serious first.
    """

    v_loops: list[Loop] = field(default_factory=list)
    i_cutsets: list[Cutset] = field(default_factory=list)
    cv_loops: list[Loop] = field(default_factory=list)
    c_loops: list[Loop] = field(default_factory=list)
    li_cutsets: list[Cutset] = field(default_factory=list)
    dc_loops: list[Loop] = field(default_factory=list)
    no_dc_path: list[NodeGroup] = field(default_factory=list)
    charge_groups: list[NodeGroup] = field(default_factory=list)
    dangling_nodes: list[str] = field(default_factory=list)
    floating_groups: list[NodeGroup] = field(default_factory=list)
    self_loops: list[str] = field(default_factory=list)
    applicable: bool = True
    not_applicable_reason: str | None = None
    topological_index: int | None = None
    index_message: str = ""
    singular: bool = False
    dc_singular: bool = False
    index2_signals: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-serialisable dictionary (lists, strings, numbers, booleans)."""
        return {
            "v_loops": [x.to_dict() for x in self.v_loops],
            "i_cutsets": [x.to_dict() for x in self.i_cutsets],
            "cv_loops": [x.to_dict() for x in self.cv_loops],
            "c_loops": [x.to_dict() for x in self.c_loops],
            "li_cutsets": [x.to_dict() for x in self.li_cutsets],
            "dc_loops": [x.to_dict() for x in self.dc_loops],
            "no_dc_path": [x.to_dict() for x in self.no_dc_path],
            "charge_groups": [x.to_dict() for x in self.charge_groups],
            "floating_nodes": [list(x.nodes) for x in self.floating_groups],
            "floating_groups": [x.to_dict() for x in self.floating_groups],
            "dangling_nodes": list(self.dangling_nodes),
            "self_loops": list(self.self_loops),
            "applicable": self.applicable,
            "not_applicable_reason": self.not_applicable_reason,
            "topological_index": self.topological_index,
            "index_message": self.index_message,
            "singular": self.singular,
            "dc_singular": self.dc_singular,
            "index2_signals": list(self.index2_signals),
            "counts": dict(self.counts),
            "findings": [f.to_dict() for f in self.findings],
        }
