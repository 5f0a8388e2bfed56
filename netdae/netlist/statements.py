"""The parsed netlist: cards understood, nothing evaluated yet.

:func:`netdae.netlist.parse` returns a :class:`Netlist`: the tree of
subcircuit definitions (:class:`Definition`, the top level being one too),
each with its elements, instances, models, parameters and functions in
netlist order, and the analyses and control cards. Values are kept as
written: a float for a plain number, an expression tree
(:mod:`netdae.netlist.expr`) for ``{...}``, ``'...'`` or a parameter name.
:func:`netdae.netlist.elaborate` evaluates them.

A value always travels with the offset of its token in its card
(``Val = (value, offset)``) so that an error found later still points at it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

from ..circuit import Diagnostic
from .expr import Expr
from .lines import Card

__all__ = [
    "Val",
    "ElementCard",
    "SourceCard",
    "InstanceCard",
    "ModelCard",
    "InitialCard",
    "FuncDef",
    "ParamDef",
    "Definition",
    "AnalysisCard",
    "MeasureCard",
    "Netlist",
]

#: A value as written (float, or an expression tree) and its offset in the card.
Val = tuple[Union[float, Expr], int]


@dataclass(slots=True)
class SourceCard:
    """The value part of a V or I card.

    ``tran`` is ``(kind, [Val, ...], extras, offset)`` with ``extras`` the
    PWL ``r=``/``td=`` values, or None.
    """

    dc: Val | None = None
    ac_mag: Val | None = None
    ac_phase: Val | None = None
    tran: tuple | None = None


@dataclass(slots=True)
class ElementCard:
    """An element card (any letter but X), parsed.

    Attributes
    ----------
    name : str
        Lower-case name as written (``"r1"``).
    kind : str
        Element kind (see :mod:`netdae.circuit`); ``"bjt"`` cards get their
        node count settled when the models are known.
    card : Card
    nodes : tuple of str
    value : Val or None
    model : (str, int) or None
        Model name as written and its offset.
    params : dict of str to Val
    flags : dict of str to int
        Bare keywords (``off``) and their offsets.
    source : SourceCard or None
    controls : tuple of (str, int)
        Controlling elements as written (F/H source, K inductors, POLY).
    expr : (Expr, int) or None
        Behavioural expression (B, E/G value=, POLY).
    positional : list of Token
        Q cards: the words after the name until the first keyword, resolved
        into nodes, model and area once the models are known.
    """

    name: str
    kind: str
    card: Card
    nodes: tuple = ()
    value: Val | None = None
    model: tuple | None = None
    params: dict = field(default_factory=dict)
    flags: dict = field(default_factory=dict)
    source: SourceCard | None = None
    controls: tuple = ()
    expr: tuple | None = None
    positional: list | None = None


@dataclass(slots=True)
class InstanceCard:
    """An ``X`` card: an instance of a subcircuit."""

    name: str
    card: Card
    nodes: tuple
    subckt: str
    subckt_offset: int
    params: dict  # name -> Val


@dataclass(slots=True)
class ModelCard:
    """A ``.model`` card.

    ``strings`` holds string-valued parameters (``mfg="acme"``: name ->
    (text, offset)), ``flags`` bare names (name -> offset); both are judged
    when the circuit is elaborated (ngspice ignores the ones it does not know).
    ``vectors`` holds the parameters given several numbers (a CPL's ``r= l=
    g= c=`` matrices, ``VECTOR_PARAMETERS``): name -> list of Val.
    """

    name: str
    type: str
    card: Card
    params: dict  # name -> Val
    strings: dict = field(default_factory=dict)
    flags: dict = field(default_factory=dict)
    vectors: dict = field(default_factory=dict)  # name -> list of Val (a CPL's matrices)


@dataclass(slots=True)
class InitialCard:
    """An ``.ic`` or ``.nodeset`` card inside a subcircuit: applied to each instance's nodes.

    ``entries`` is a list of (node as written, Val, offset).
    """

    name: str  # ".ic" or ".nodeset"
    card: Card
    entries: list


@dataclass(slots=True)
class FuncDef:
    """A ``.func name(args) = {body}`` card.

    ``circuit`` is True when the body reads the circuit (``V(...)``, ``I(...)``, ``time``): ngspice
    expands such a function into the behavioural expression that calls it, where the body's node
    and element names are those of the calling card (``v(p)`` is node ``p`` even when ``p`` is also
    an argument's name); it has no value where only numbers are allowed (``.param``, an element's
    value).
    """

    name: str
    args: tuple
    body: Expr
    card: Card
    circuit: bool = False
    #: The body read by the behavioural rules (``pwr``, ``pow``, ``1mil`` as a B source reads them): ngspice
    #: expands a .func call textually, so in a behavioural expression its B-source parser reads the body.
    #: None when those rules cannot read it (the body then serves as it is).
    behavioural: "Expr | None" = None
    #: Why the body has no value in a parameter expression though a behavioural one reads it (a
    #: conditional ngspice's parameter evaluator reads otherwise), else None.
    param_refusal: str | None = None


@dataclass(slots=True)
class ParamDef:
    """One ``name=value`` of a ``.param`` card or a subcircuit default."""

    name: str
    value: Val
    card: Card
    offset: int


@dataclass
class Definition:
    """A subcircuit definition, or the top level (``name`` None).

    Attributes
    ----------
    name : str or None
    ports : tuple of str
    defaults : list of ParamDef
        ``params:`` of the ``.subckt`` card, in order.
    params : list of ParamDef
        ``.param`` cards of this body, in order.
    funcs : dict of str to FuncDef
    items : list of ElementCard, InstanceCard, ModelCard and InitialCard
        In netlist order.
    models : dict of str to ModelCard
        The models defined directly in this body.
    subckts : dict of str to Definition
        The subcircuits defined directly in this body.
    parent : Definition or None
    card : Card or None
        The ``.subckt`` card.
    errors : list of NetlistError
        Element cards of this body that cannot be read: raised when the
        subcircuit is instantiated; a subcircuit never instantiated keeps
        them as a warning (ngspice reads only the subcircuits it expands).
    first : Definition or None
        The earlier definition of the same name in the same scope that this
        one repeats (ngspice 39 keeps the first): compared at ``.ends``, an
        identical repetition is dropped with a warning, another is an error.
    span : tuple of int
        Indexes of the ``.subckt`` card and of its ``.ends`` card in the deck.
    """

    name: str | None
    ports: tuple = ()
    defaults: list = field(default_factory=list)
    params: list = field(default_factory=list)
    funcs: dict = field(default_factory=dict)
    items: list = field(default_factory=list)
    models: dict = field(default_factory=dict)
    subckts: dict = field(default_factory=dict)
    parent: "Definition | None" = None
    card: Card | None = None
    errors: list = field(default_factory=list)
    first: "Definition | None" = None
    span: tuple = ()

    def lookup_model(self, name: str) -> "tuple[ModelCard, Definition] | None":
        """The model a card in this body means by ``name`` (innermost first)."""
        scope: Definition | None = self
        while scope is not None:
            model = scope.models.get(name)
            if model is not None:
                return model, scope
            scope = scope.parent
        return None

    def _innermost(self, table: str, name: str):
        """``name`` in the ``table`` (``funcs``, ``subckts``) of this body or the nearest enclosing one."""
        scope: Definition | None = self
        while scope is not None:
            found = getattr(scope, table).get(name)
            if found is not None:
                return found
            scope = scope.parent
        return None

    def lookup_func(self, name: str) -> "FuncDef | None":
        """The ``.func`` a card in this body means by ``name`` (innermost first)."""
        return self._innermost("funcs", name)

    def lookup_subckt(self, name: str) -> "Definition | None":
        """The subcircuit an instance in this body means by ``name`` (innermost first)."""
        return self._innermost("subckts", name)

    @property
    def path(self) -> str:
        """``top`` or the nesting of definitions, e.g. ``outer/inner``."""
        names = []
        scope: Definition | None = self
        while scope is not None and scope.name is not None:
            names.append(scope.name)
            scope = scope.parent
        return "/".join(reversed(names)) or "top"


@dataclass(slots=True)
class AnalysisCard:
    """An analysis or control card with its values unevaluated.

    ``kind`` is ``"op"``, ``"dc"``, ``"ac"``, ``"tran"``; ``args`` holds the
    parsed fields (values as :data:`Val`).
    """

    kind: str
    card: Card
    args: dict


@dataclass(slots=True)
class MeasureCard:
    """A ``.meas``/``.measure`` card, parsed (:mod:`netdae.netlist.measure`), nothing evaluated.

    Signals are ``(letter, part, nodes, offset)``: ``("v", "db", ("out",), 17)``
    for ``vdb(out)``. ``trig``, ``targ`` and ``when`` are dicts with the keys
    ``probe``, ``value`` (Val), ``other`` (a signal), ``edge``
    (``"rise"``/``"fall"``/``"cross"``/``""``), ``count`` (-1: LAST), ``td``,
    ``at``, ``from``, ``to`` (Val or None) and ``offset``. ``window`` holds a
    window function's ``TD=``, ``FROM=``, ``TO=`` (Val), ``window_at`` where each
    keyword is on the card.
    """

    analysis: str
    name: str
    function: str
    card: Card
    offset: int
    probe: tuple | None = None
    trig: dict | None = None
    targ: dict | None = None
    when: dict | None = None
    at: Val | None = None
    window: dict = field(default_factory=dict)  # td, from, to -> Val
    window_at: dict = field(default_factory=dict)  # td, from, to -> offset of the keyword
    expression: tuple | None = None  # PARAM=: (Expr, offset, text, offset of the text)


@dataclass
class Netlist:
    """A parsed netlist.

    Attributes
    ----------
    title : str
    path : str
    top : Definition
    analyses : list of AnalysisCard
    options : list of (name, value, offset, Card)
        ``value`` is a Val, a word (str) or True for a bare flag.
    temps : list of (Val, Card)
    ic, nodeset : list of (node, Val, offset, Card)
    saves : list of (signal, offset, Card)
    measures : list of MeasureCard
    fouriers : list of (Val, list of (signal, offset), Card)
        The ``.four`` cards: the fundamental frequency and the signals.
    steps : list of StepCard
        The ``.step`` cards (:mod:`netdae.netlist.steps`).
    globals : dict of str to (Card, offset)
    diagnostics : list of Diagnostic
    files : list of str
    osdi : list of (str, SourceLocation)
        OSDI libraries to load (``.osdi`` cards, ``pre_osdi`` commands), paths resolved.
    behavior : Behavior or None
        ngspice's compatibility mode the netlist was read in (:mod:`netdae.netlist.compat`).
    scripts : list of Card
        The ``.control`` blocks that use ngspice's control language (variables, loops,
        ``alter``), run by :func:`netdae.netlist.control.run_scripts` after a first
        elaboration; empty once they ran.
    csparams : list of Card
        The ``.csparam`` cards: the values those scripts see.
    unscripted : Netlist or None
        For a netlist whose scripts ran: the netlist before (a variant with other
        parameter values runs them again).
    """

    title: str
    path: str
    top: Definition
    analyses: list = field(default_factory=list)
    options: list = field(default_factory=list)
    temps: list = field(default_factory=list)
    ic: list = field(default_factory=list)
    nodeset: list = field(default_factory=list)
    saves: list = field(default_factory=list)
    measures: list = field(default_factory=list)
    fouriers: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    globals: dict = field(default_factory=dict)
    diagnostics: list[Diagnostic] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    osdi: list = field(default_factory=list)
    behavior: object = None
    scripts: list = field(default_factory=list)
    csparams: list = field(default_factory=list)
    unscripted: object = None
