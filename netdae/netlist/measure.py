"""``.meas``/``.measure`` cards (ngspice syntax) to :class:`~netdae.netlist.statements.MeasureCard`.

The forms, as ngspice's manual gives them (keywords in any case, values may
be numbers, ``{expressions}`` or parameter names)::

    .meas tran|ac|dc name TRIG sig VAL=v [TD=t] [FROM=] [TO=] RISE=n|FALL=n|CROSS=n|LAST  TARG sig VAL=v ...
    .meas tran|ac|dc name TRIG AT=t TARG sig VAL=v ...
    .meas tran|ac|dc name FIND sig AT=x
    .meas tran|ac|dc name FIND sig WHEN sig=v|sig [TD=] [FROM=] [TO=] [RISE=|FALL=|CROSS=n|LAST]
    .meas tran|ac|dc name WHEN sig=v|sig [TD=] [FROM=] [TO=] [RISE=|FALL=|CROSS=n|LAST]
    .meas tran|ac|dc name DERIV sig AT=x | DERIV sig WHEN ...
    .meas tran|ac|dc name MIN|MAX|PP|AVG|RMS|INTEG sig [TD=] [FROM=] [TO=]
    .meas tran|ac|dc name PARAM='expression of measurements and parameters'

Signals are ``v(node)``, ``v(a,b)``, ``i(vname)``, ``@device[param]``, for ``tran`` and
``dc`` ngspice's ``par('expression')`` (of ``v()``, ``i()``, ``time``, numbers and
parameters, evaluated at every point of the result), and, for ``ac``, ``vdb() vm()
vp() vr() vi()``. Nothing is evaluated here; errors are located at the token.
``TD=`` of MIN ... INTEG is kept and, at elaboration, ignored with a warning, as
ngspice 39 does not read it there.

Examples
--------
>>> from netdae.netlist.lines import split_cards
>>> _, (card,), _ = split_cards("t\\n.meas tran tr TRIG v(out) VAL=0.1 RISE=1 TARG v(out) VAL=0.9 RISE=1\\n", "x")
>>> m = parse_measure(card)
>>> m.name, m.function, m.trig["probe"][:3], m.targ["edge"], m.targ["count"]
('tr', 'trig', ('v', '', ('out',)), 'rise', 1)
"""

from __future__ import annotations

import math

from ..errors import NetlistError
from ..kinds import KINDS
from . import expr as ex
from .elements import IDENT, error, parse_expr, parse_value, unknown_node_hint
from .lines import EXPR, PUNCT, WORD, Card, Token
from .params import UnknownName, inline_calls
from .statements import MeasureCard

__all__ = ["parse_measure", "FORM"]

#: The expected form shown in errors.
FORM = (".meas tran|ac|dc name TRIG sig VAL=v RISE=n|FALL=n|CROSS=n|LAST TARG sig VAL=v ... | "
        "FIND sig AT=x | FIND sig WHEN sig=v ... | WHEN sig=v [TD=] [FROM=] [TO=] [RISE=|FALL=|CROSS=] | "
        "DERIV sig AT=x | MIN|MAX|MIN_AT|MAX_AT|PP|AVG|RMS|INTEG sig [TD=] [FROM=] [TO=] | PARAM='expr'")

_FUNCTIONS = {"trig": "trig", "delay": "trig", "find": "find", "when": "when", "deriv": "deriv",
              "derivative": "deriv", "min": "min", "max": "max", "pp": "pp", "avg": "avg", "rms": "rms",
              "integ": "integ", "integral": "integ", "param": "param", "min_at": "min_at", "max_at": "max_at"}
_NOT_SUPPORTED = {"err": "ERR", "err1": "ERR1", "err2": "ERR2", "err3": "ERR3"}
_PREFIXES = {"v": ("v", ""), "i": ("i", ""), "vdb": ("v", "db"), "vm": ("v", "m"), "vp": ("v", "p"),
             "vr": ("v", "r"), "vi": ("v", "i")}
_EDGES = ("rise", "fall", "cross")
#: Keywords each clause accepts (besides the edges and LAST where crossings are counted).
_WINDOW = ("td", "from", "to")
#: Reserved words of parameter expressions that a measurement's name hides in PARAM= (as in ngspice).
_SHADOWABLE = frozenset({"time", "pi", "hertz"})
_HINT_FUNCTIONS = "TRIG/TARG, FIND, WHEN, DERIV, MIN, MAX, MIN_AT, MAX_AT, PP, AVG, RMS, INTEG, PARAM"


class _Cursor:
    """The tokens of one card after the function word, read left to right."""

    def __init__(self, card: Card, toks: list[Token], i: int) -> None:
        self.card, self.toks, self.i = card, toks, i

    def peek(self, k: int = 0) -> Token | None:
        j = self.i + k
        return self.toks[j] if j < len(self.toks) else None

    def take(self) -> Token:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    @property
    def done(self) -> bool:
        return self.i >= len(self.toks)

    def end(self) -> int:
        return len(self.card.text)

    def fail(self, at: int, message: str, hint: str | None = None) -> NetlistError:
        return error(self.card, at, message, FORM, hint)

    def word_is(self, *words: str) -> bool:
        tok = self.peek()
        return tok is not None and tok.kind == WORD and tok.text in words



def _article(noun: str) -> str:
    """``noun`` with "a" or "an" (by its first letter).

    >>> _article("compiled Verilog-A device (OSDI)"), _article("MOSFET"), _article("ideal op-amp (nullor)")
    ('a compiled Verilog-A device (OSDI)', 'a MOSFET', 'an ideal op-amp (nullor)')
    """
    vowel = noun[:1].lower() in ("a", "e", "i", "o", "u")
    return f"{'an' if vowel else 'a'} {noun}"

def _starts_probe(cur: _Cursor) -> bool:
    """A signal (``v(``, ``vdb(`` ..., ``par(``) begins at the cursor."""
    tok, nxt = cur.peek(), cur.peek(1)
    return (tok is not None and tok.kind == WORD and (tok.text in _PREFIXES or tok.text == "par")
            and nxt is not None and nxt.text == "(")


def _expression_probe(cur: _Cursor, analysis: str) -> tuple:
    """``par('expression')`` (ngspice): ("par", "", (tree,), offset)."""
    tok = cur.take()
    if analysis == "ac":
        raise cur.fail(tok.start, "par() expressions are measured on tran and dc results",
                       hint="measure vdb(), vm(), vp(), vr() or vi() of an ac result, "
                            "and combine measurements with PARAM='...'")
    cur.i += 1  # '('
    body, close = cur.peek(), cur.peek(1)
    if body is None or body.kind not in (EXPR, WORD) or close is None or close.text != ")":
        at = body.start if body is not None else cur.end()
        raise cur.fail(at, "par() takes one quoted expression", hint="write par('v(out)*i(vdd)')")
    cur.i += 2
    tree = parse_expr(cur.card, body.text, body.start + (body.kind == EXPR), ex.BEHAVIOURAL, FORM)
    for node in ex.walk(tree):
        if isinstance(node, ex.Call) and node.func == "ddt":
            raise cur.fail(body.start, "ddt() in a par() expression",
                           hint="measure the slope with DERIV, or the signal itself")
    return "par", "", (tree,), tok.start


def _probe(cur: _Cursor, analysis: str, what: str) -> tuple:
    """``v(a)``, ``v(a,b)``, ``i(v1)``, ``vdb(a)``, ``par('expr')`` ... as (letter, part, nodes, offset)."""
    tok = cur.peek()
    if tok is None:
        raise cur.fail(cur.end(), f"missing the signal {what}", hint="write v(node), v(a,b) or i(vname)")
    if tok.kind == WORD and tok.text == "par" and cur.peek(1) is not None and cur.peek(1).text == "(":
        return _expression_probe(cur, analysis)
    if tok.kind == WORD and tok.text.startswith("@"):  # a device quantity, @r1[p]
        from ..signals import parse_signal

        try:
            sig = parse_signal(tok.text)
        except ValueError as exc:
            raise cur.fail(tok.start, str(exc)) from None
        cur.i += 1
        return "@", "", sig.args, tok.start
    if tok.kind != WORD or tok.text not in _PREFIXES or not (cur.peek(1) and cur.peek(1).text == "("):
        raise cur.fail(tok.start, f"expected a signal {what}, found {tok.text!r}",
                       hint="write v(node), v(a,b), i(vname), @device[param] or par('expression')"
                       + ("; for ac also vdb() vm() vp() vr() vi()" if analysis == "ac" else ""))
    letter, part = _PREFIXES[tok.text]
    if part and analysis != "ac":
        raise cur.fail(tok.start, f"{tok.text}() is for ac measurements, this is a .meas {analysis}",
                       hint="use v(node) for tran and dc")
    cur.i += 2
    names: list[str] = []
    comma = None  # the ',' after the last name, which another name must follow
    what, form = ("an element name", "i(vname)") if letter == "i" else ("a node", "v(node) or v(a,b)")
    while True:
        t = cur.peek()
        if t is None:
            raise cur.fail(tok.start, f"{tok.text}(...): missing ')'")
        cur.i += 1
        if t.text == ")" and t.kind == PUNCT:
            if comma is not None:
                raise cur.fail(t.start, f"{tok.text}(...): {what} is missing after ','", hint=f"write {form}")
            break
        if t.kind == PUNCT and t.text == ",":
            if not names or comma is not None:
                raise cur.fail(t.start, f"{tok.text}(...): {what} is missing before ','", hint=f"write {form}")
            comma = t
            continue
        comma = None
        if t.kind != WORD:
            raise cur.fail(t.start, f"unexpected {t.text!r} in {tok.text}(...)")
        names.append("0" if t.text == "gnd" else t.text)
    limit = 1 if letter == "i" else 2
    if not names or len(names) > limit:
        raise cur.fail(tok.start, f"{tok.text}() takes {'one element name' if letter == 'i' else 'one or two nodes'}"
                       f", got {len(names)}", hint="write v(node), v(a,b) or i(vname)")
    return letter, part, tuple(names), tok.start


def _keyword(cur: _Cursor, allowed: tuple[str, ...], where: str) -> tuple[str, object, int]:
    """``name=value`` (value a Val, or LAST), or a bare ``LAST``: (name, value, offset)."""
    tok = cur.take()
    if tok.kind == WORD and tok.text == "last" and "last" in allowed:
        return "last", None, tok.start
    if tok.kind != WORD:
        raise cur.fail(tok.start, f"unexpected {tok.text!r} in {where}")
    nxt = cur.peek()
    if nxt is None or nxt.text != "=":
        if tok.text in allowed or tok.text in _EDGES + _WINDOW + ("val", "at"):
            raise cur.fail(nxt.start if nxt is not None else tok.end, f"missing '=' after {tok.text.upper()}",
                           hint=f"write {tok.text.upper()}=value")
        raise cur.fail(tok.start, f"unexpected {tok.text!r} in {where}",
                       hint="keywords here: " + " ".join(k.upper() + ("" if k == "last" else "=") for k in allowed))
    if tok.text not in allowed:
        raise cur.fail(tok.start, f"unknown keyword {tok.text.upper()}= in {where}",
                       hint="keywords here: " + " ".join(k.upper() + ("" if k == "last" else "=") for k in allowed))
    cur.i += 1
    val = cur.peek()
    if val is None or val.kind not in (WORD, EXPR):
        raise cur.fail(nxt.start, f"missing value after {tok.text.upper()}=")
    cur.i += 1
    if tok.text in _EDGES:
        if val.kind == WORD and val.text == "last":
            return tok.text, "last", tok.start
        parsed = parse_value(cur.card, val, FORM, f"{tok.text.upper()} count")
        if not isinstance(parsed[0], float) or parsed[0] != int(parsed[0]) or parsed[0] < 1:
            raise cur.fail(val.start, f"{tok.text.upper()}= takes a positive whole number or LAST, got {val.text!r}")
        return tok.text, int(parsed[0]), tok.start
    return tok.text, _meas_value(cur.card, val, f"{tok.text.upper()} value"), tok.start


def _meas_value(card: Card, tok: Token, what: str):
    """A value of a ``.meas`` card: a number, ``{expr}``/``'expr'``, a parameter name, or, as ngspice
    reads it, an expression without braces or blanks (``VAL=vdd*0.5``)."""
    try:
        return parse_value(card, tok, FORM, what)
    except NetlistError as first:
        if tok.kind != WORD:
            raise
        try:
            return parse_value(card, tok, FORM, what, numparam=True)
        except NetlistError:
            raise first from None


def _condition(cur: _Cursor, analysis: str, clause: str, stop: str | None) -> dict:
    """A TRIG/TARG/WHEN clause up to the word ``stop`` (or the end)."""
    start = cur.peek(-1).start
    cond: dict = {"probe": None, "value": None, "other": None, "edge": "", "count": 1, "td": None, "at": None,
                  "from": None, "to": None, "offset": start}
    when = clause == "WHEN"
    if clause == "TRIG" and cur.word_is("at"):
        _, value, _ = _keyword(cur, ("at",), clause)
        cond["at"] = value
    else:
        cond["probe"] = _probe(cur, analysis, f"after {clause}")
        if when:
            eq = cur.peek()
            if eq is None or eq.text != "=":
                raise cur.fail(eq.start if eq is not None else cur.end(), "missing '=' after the WHEN signal",
                               hint="write WHEN v(out)=0.5 or WHEN v(a)=v(b)")
            cur.i += 1
            nxt = cur.peek()
            if nxt is None:
                raise cur.fail(eq.start, "missing the value after WHEN ...=")
            if _starts_probe(cur):
                cond["other"] = _probe(cur, analysis, "after '='")
            else:
                cond["value"] = _meas_value(cur.card, cur.take(), "WHEN value")
    allowed = ("val", "td", "last", "from", "to") + _EDGES
    edge_at = None
    while not cur.done and not cur.word_is(stop or "\0"):
        key, value, offset = _keyword(cur, allowed, clause)
        if key in _EDGES or key == "last":
            if edge_at is not None:
                raise cur.fail(offset, f"{clause}: more than one of RISE=, FALL=, CROSS=, LAST",
                               hint="give one of them")
            edge_at = offset
            cond["edge"] = "cross" if key == "last" else key
            cond["count"] = -1 if value in (None, "last") else value
        else:
            if key == "val" and when:
                raise cur.fail(offset, "VAL= does not belong to WHEN", hint="write WHEN v(out)=0.5")
            slot = "value" if key == "val" else key
            if cond[slot] is not None:
                raise cur.fail(offset, f"{key.upper()}= given twice")
            cond[slot] = value
            cond[f"{slot}_at"] = offset
    if cond["at"] is None and not when:
        if cond["value"] is None:
            raise cur.fail(start, f"{clause} needs VAL=", hint=f"e.g. {clause} v(out) VAL=0.5 RISE=1")
        if edge_at is None:
            raise cur.fail(start, f"{clause} needs RISE=, FALL=, CROSS= or LAST (as ngspice)",
                           hint=f"e.g. {clause} v(out) VAL=0.5 RISE=1")
    return cond


def parse_measure(card: Card) -> MeasureCard:
    """Parse one ``.meas``/``.measure`` card.

    Raises
    ------
    NetlistError
        At the offending token: a missing or unknown analysis, name or
        function, a signal of the wrong form (``vdb()`` outside ``ac``), a
        missing ``=``, an unknown keyword, a clause without ``VAL=`` or
        without ``RISE=``/``FALL=``/``CROSS=``, a ``TRIG`` without ``TARG``.
    """
    toks = card.tokens()
    cur = _Cursor(card, toks, 1)
    if cur.done or toks[1].kind != WORD or toks[1].text not in ("tran", "ac", "dc"):
        at = toks[1].start if len(toks) > 1 else cur.end()
        found = repr(toks[1].text) if len(toks) > 1 else "nothing"
        raise cur.fail(at, f"expected the analysis tran, ac or dc, found {found}",
                       hint="netdae measures transient, ac and dc results (as ngspice's .meas tran|ac|dc)")
    analysis = toks[1].text
    if len(toks) < 3 or toks[2].kind != WORD or not IDENT.match(toks[2].text):
        at = toks[2].start if len(toks) > 2 else cur.end()
        raise cur.fail(at, "expected the measurement's name after the analysis",
                       hint="names start with a letter and contain letters, digits and '_'")
    name = toks[2].text
    if len(toks) < 4:
        raise cur.fail(cur.end(), "missing the measurement function", hint=f"one of {_HINT_FUNCTIONS}")
    head = toks[3]
    if head.kind != WORD or head.text not in _FUNCTIONS:
        if head.text in _NOT_SUPPORTED:
            raise cur.fail(head.start, f"{_NOT_SUPPORTED[head.text]} is not supported by netdae",
                           hint=f"netdae measures with {_HINT_FUNCTIONS}")
        raise cur.fail(head.start, f"unknown measurement function {head.text!r}", hint=f"one of {_HINT_FUNCTIONS}")
    function = _FUNCTIONS[head.text]
    m = MeasureCard(analysis=analysis, name=name, function=function, card=card, offset=toks[2].start)
    cur.i = 4
    if function == "param":
        eq, val = cur.peek(), cur.peek(1)
        if eq is None or eq.text != "=":
            raise cur.fail(eq.start if eq is not None else cur.end(), "missing '=' after PARAM",
                           hint="write PARAM='expression'")
        if val is None or val.kind not in (WORD, EXPR):
            raise cur.fail(eq.start, "missing the expression after PARAM=")
        # a reserved word (time, pi) may be a measurement's name, which ngspice reads here: read as a
        # name now, settled when the measurements are known (elaborate_measures)
        base = val.start + (val.kind == EXPR)
        body = parse_expr(card, val.text, base, ex.PARAM, FORM, params=_SHADOWABLE)
        m.expression = (body, val.start, val.text, base)
        cur.i += 2
    elif function == "trig":
        m.trig = _condition(cur, analysis, "TRIG", "targ")
        if not cur.word_is("targ"):
            raise cur.fail(cur.end(), "TRIG without TARG", hint="add TARG sig VAL=v RISE=n")
        cur.i += 1
        m.targ = _condition(cur, analysis, "TARG", None)
    elif function == "when":
        m.when = _condition(cur, analysis, "WHEN", None)
    else:
        m.probe = _probe(cur, analysis, f"after {head.text.upper()}")
        if function in ("find", "deriv"):
            if cur.word_is("when"):
                cur.i += 1
                m.when = _condition(cur, analysis, "WHEN", None)
            elif cur.word_is("at"):
                _, m.at, _ = _keyword(cur, ("at",), head.text.upper())
                _window_beside_at(cur, head.text.upper())
            else:
                tok = cur.peek()
                raise cur.fail(tok.start if tok is not None else cur.end(),
                               f"{head.text.upper()} needs AT=x or WHEN ...",
                               hint=f"e.g. {head.text.upper()} v(out) AT=1m")
        else:
            while not cur.done:
                key, value, offset = _keyword(cur, _WINDOW, head.text.upper())
                if m.window.get(key) is not None:
                    raise cur.fail(offset, f"{key.upper()}= given twice")
                m.window[key] = value
                m.window_at[key] = offset
    if not cur.done:
        tok = cur.peek()
        raise cur.fail(tok.start, f"unexpected {tok.text!r} after the measurement")
    return m


def _window_beside_at(cur: _Cursor, where: str) -> None:
    """Read the ``FROM=``, ``TO=`` or ``TD=`` after ``FIND|DERIV sig AT=x``, which ngspice 39 accepts and does not
    read (measured: the value at x whatever the window), with a warning; ``FROM=`` and ``TO=`` together make
    ngspice print no value at all, and are refused."""
    seen: dict[str, int] = {}
    while not cur.done:
        tok = cur.peek()
        if tok.kind != WORD or tok.text not in _WINDOW:
            return
        key, _, offset = _keyword(cur, _WINDOW, where)
        if key in seen:
            raise cur.fail(offset, f"{key.upper()}= given twice")
        seen[key] = offset
        if "from" in seen and "to" in seen:
            raise cur.fail(offset, f"{where} ... AT= with both FROM= and TO=: ngspice 39 prints no value for such a "
                           "card, and AT= alone says where", hint="remove FROM= and TO= (AT= gives the point)")
        cur.card.warn(offset, f"{key.upper()}= has no effect on {where} ... AT= (as in ngspice 39): the value is "
                      "the one at AT=")


# ---------------------------------------------------------------------------
# elaboration: MeasureCard -> MeasureSpec
# ---------------------------------------------------------------------------
def elaborate_measures(cards: list[MeasureCard], circuit, nodes, elements, value, branch_kinds,
                       functions=None, port_nodes=None) -> list:
    """Evaluate and check the measurement cards against the flat circuit.

    Parameters
    ----------
    cards : list of MeasureCard
    circuit : Circuit
        With its analyses and top-level ``params`` set.
    nodes, elements : mapping
        The circuit's node names and elements by name.
    value : callable
        ``value(val, card, what) -> float``: a Val evaluated with the top-level parameters.
    branch_kinds : set of str
        Element kinds whose current ``i(name)`` is an unknown.
    functions : Env, optional
        The top-level scope whose ``.func`` definitions ``PARAM=`` expressions
        may call (expanded here, as in ``.param``).
    port_nodes : mapping, optional
        ``x1.out`` -> the node instance x1 connects its port ``out`` to, for the
        hint at a signal that names a port hierarchically (which names no node).

    Returns
    -------
    list of MeasureSpec

    Raises
    ------
    NetlistError
        A measurement of an analysis the netlist does not run, a node or
        element that does not exist, a ``PARAM`` naming
        something that is neither a measurement nor a top-level
        ``.param``, a value that cannot be evaluated; each at its token.
    """
    from ..analyses.runner import analysis_name
    from ..measures import Condition, MeasureSpec, Probe
    from ..signals import Signal, device_quantity

    kinds = {analysis_name(a) for a in circuit.analyses}
    seen: dict[str, MeasureCard] = {}
    measured = {c.name for c in cards}  # the names a PARAM card may read (a later PARAM card's fails when measured)
    out = []

    def inlined(tree, offset, card, what: str):
        """``tree`` with the top-level ``.func`` calls expanded (as ``.param`` does)."""
        if functions is None:
            return tree
        try:
            return inline_calls(tree, functions)
        except UnknownName as exc:
            raise error(card, offset, f"{what}: unknown function '{exc.name}'", FORM,
                        hint="define it with .func") from None
        except ValueError as exc:
            raise error(card, offset, f"{what}: {exc}", FORM) from None

    def expression_probe(tree, offset, card, analysis) -> Probe:
        """``par('...')``: parameters and .func calls replaced, every signal checked."""
        tree = inlined(tree, offset, card, "par()")

        def leaf(node):
            if isinstance(node, ex.Param):
                if node.name not in circuit.params:
                    raise error(card, offset, f"par(): '{node.name}' is not a top-level .param", FORM,
                                hint="par() reads v(node), v(a,b), i(vname), time, numbers and parameters; "
                                     "combine measurements with PARAM='...'")
                return ex.Const(float(circuit.params[node.name]))
            if isinstance(node, ex.Time) and analysis != "tran":
                raise error(card, offset, f"par(): 'time' in a .meas {analysis}", FORM,
                            hint="time is the axis of a transient only")
            if isinstance(node, ex.Voltage):
                names = tuple("0" if n == "gnd" else n for n in (node.pos, node.neg) if n is not None)
                sig = probe(("v", "", names, offset), card).signal
                return ex.Voltage(*sig.args) if len(sig.args) == 2 else ex.Voltage(sig.args[0])
            if isinstance(node, ex.Current):
                probe(("i", "", (node.element,), offset), card)
            if isinstance(node, ex.Call) and node.func not in ex.FUNCTIONS:
                raise error(card, offset, f"par(): unknown function '{node.func}'", FORM)
            return None

        tree = ex.fold_constants(ex.transform(tree, leaf))
        return Probe(None, "", tree)

    def probe(sig, card, analysis="tran") -> Probe:
        letter, part, names, offset = sig
        if letter == "par":
            return expression_probe(names[0], offset, card, analysis)
        if letter == "@":
            target = elements.get(names[0])
            if target is None:
                raise error(card, offset, f"@{names[0]}[{names[1]}]: there is no device '{names[0]}'", FORM)
            try:
                device_quantity(Signal("@", names), target.kind)
            except ValueError as exc:
                raise error(card, offset, str(exc), FORM) from None
            return Probe(Signal("@", names), part)
        if letter == "i":
            target = elements.get(names[0])
            if target is None or (target.kind not in branch_kinds
                                  and device_quantity(Signal("i", names), target.kind) is None):
                what = ("no element" if target is None else
                        f"{_article(KINDS[target.kind].summary)}, whose current netdae does not compute")
                raise error(card, offset, f"i({names[0]}): '{names[0]}' is {what}", FORM,
                            hint="i() names an R, C, V source, inductor, E/H source or B voltage source "
                                 "(elements in subcircuits by their full name, e.g. v.x1.v1)")
            return Probe(Signal("i", names), part)
        for nd in names:
            if nd != "0" and nd not in nodes:
                raise error(card, offset, f"unknown node '{nd}' in a measured signal", FORM,
                            hint=unknown_node_hint(nd, port_nodes or {}, "v(x1.mid)"))
        if len(names) == 2 and names[1] == "0":
            names = names[:1]
        return Probe(Signal("v", tuple(names)), part)

    def number(val, card, what):
        return None if val is None else value(val, card, what)

    def condition(c: dict, card, analysis, when: bool = False) -> Condition:
        return Condition(probe=probe(c["probe"], card, analysis) if c["probe"] else None,
                         value=number(c["value"], card, "VAL"),
                         other=probe(c["other"], card, analysis) if c["other"] else None,
                         edge=c["edge"], count=c["count"],
                         td=-math.inf if c["td"] is None else number(c["td"], card, "TD"),
                         at=number(c["at"], card, "AT"),
                         start=number(c["from"], card, "FROM") if not when else None,
                         stop=number(c["to"], card, "TO") if not when else None)

    def one(m):
        card = m.card
        if m.name in seen:
            # ngspice 39 measures and prints each card of a name; later PARAM= read the last before them
            first = seen[m.name].card
            card.warn(m.offset, f"measurement '{m.name}' is defined again (before at {first.file}:{first.line}): each "
                      "card is measured and printed, as in ngspice; PARAM= expressions and a sweep's "
                      "table read the last")
        if m.analysis not in kinds:
            raise error(card, card.text.index(m.analysis, len(card.text.split()[0])),
                        f"no .{m.analysis} card: a .meas {m.analysis} has nothing to measure", FORM,
                        hint=f"add a .{m.analysis} analysis or change the measurement's analysis")
        if m.name in circuit.params:
            card.warn(m.offset, f"measurement '{m.name}' hides the parameter of that name in later PARAM= expressions")
        start = stop = None
        expression = None
        params = {}
        if m.function == "param":
            tree, offset, text, base = m.expression
            if any(isinstance(node, ex.Param) and node.name in _SHADOWABLE for node in ex.walk(tree)):
                # reserved words are what they are unless a measurement has the name (.meas tran pi ...)
                tree = parse_expr(card, text, base, ex.PARAM, FORM, params=_SHADOWABLE & measured)
            tree = inlined(tree, offset, card, "PARAM")
            for node in ex.walk(tree):
                # as ngspice: every other measurement first, then the PARAM cards in order; one naming a
                # later PARAM card fails when measured (ngspice prints it failed)
                if isinstance(node, ex.Param) and node.name not in measured and node.name not in circuit.params:
                    raise error(card, offset, f"PARAM: '{node.name}' is neither a measurement nor a "
                                "top-level .param", FORM,
                                hint="PARAM= combines measurements and parameters, e.g. PARAM='tr/2'")
                if isinstance(node, ex.Call) and node.func not in ex.FUNCTIONS:
                    raise error(card, offset, f"PARAM: unknown function '{node.func}'", FORM)
            expression = tree
            params = dict(circuit.params)
        for clause in (m.trig, m.targ, m.when):
            if m.analysis != "tran" and clause is not None and clause["td"] is not None:
                # ngspice 39 reads TD= in a transient's measurements only (measured: .dc and .ac ignore it)
                card.warn(clause.get("td_at", m.offset), f"TD= has no effect on a .meas {m.analysis} in ngspice 39 "
                          "(netdae ignores it too): crossings are counted over the whole sweep; write FROM= to "
                          "start the search later")
        window = dict(m.window)
        if m.when is not None:
            window.setdefault("from", m.when.get("from"))
            window.setdefault("to", m.when.get("to"))
        start = number(window.get("from"), card, "FROM")
        if "td" in m.window:  # ngspice 39's measure_minMaxAvg and measure_rms_integral do not read it
            card.warn(m.window_at["td"], f"TD= has no effect on {m.function.upper()} in ngspice 39 (netdae "
                      "ignores it too): the window starts at FROM= or the analysis's start; write FROM= "
                      "to start it later")
        stop = number(window.get("to"), card, "TO")
        if start is not None and stop is not None and stop < start:
            if m.analysis == "dc":
                start, stop = stop, start  # as ngspice: a dc window is ordered
            else:
                raise error(card, m.offset, f"TO={stop:g} is before FROM={start:g}", FORM)
        spec = MeasureSpec(
            name=m.name, analysis=m.analysis, function=m.function,
            probe=probe(m.probe, card, m.analysis) if m.probe else None,
            trig=condition(m.trig, card, m.analysis) if m.trig else None,
            targ=condition(m.targ, card, m.analysis) if m.targ else None,
            when=condition(m.when, card, m.analysis, when=True) if m.when else None,
            at=number(m.at, card, "AT"), start=start, stop=stop, expression=expression, params=params,
            location=card.location(0), text=card.raw,
        )
        return spec

    for m in cards:
        try:
            spec = one(m)
        except NetlistError as err:
            if not m.card.from_control:
                raise
            # a .control block's meas command: ngspice reports it failed and goes on
            m.card.warn(0, f"skipped (a .control block's meas command): {err.message.removeprefix('.meas: ')}")
            continue
        seen[m.name] = m
        out.append(spec)
    return out
