"""Element cards (R C L K V I E F G H B D Q M J S W T O Y P N X) to :class:`ElementCard` / :class:`InstanceCard`.

One function per element family, all driven by :data:`netdae.netlist.syntax.ELEMENTS`:
the expected form of a card is the one the error messages show. Values are
parsed (numbers read, expressions turned into trees) but not evaluated.
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Mapping

from ..errors import NetlistError
from ..kinds import KINDS, MAX_CPL_CONDUCTORS, Kind
from . import expr as ex
from .lines import EXPR, PUNCT, STRING, WORD, Card, Token
from .numbers import ignored_text, lookalike_hint, parse_number, underflows
from .statements import ElementCard, InstanceCard, SourceCard, Val
from .syntax import ELEMENTS, SOURCE_FUNCTIONS, UNSUPPORTED_ELEMENTS, ElementSyntax, supported_letters
from .waveforms import WAVEFORMS

__all__ = ["parse_element", "parse_value", "parse_expr", "parse_node", "error", "split_args", "IDENT",
           "UNLABELLED_AREA"]

#: A bare word that can name a parameter.
IDENT = re.compile(r"[a-z_][a-z0-9_.]*\Z")

_GROUND_ALIASES = {"0": "0", "gnd": "0"}


def error(card: Card, offset: int, message: str, syntax: ElementSyntax | str | None = None,
          hint: str | None = None) -> NetlistError:
    """A :class:`NetlistError` at ``offset`` of ``card`` (``message`` prefixed by the card name)."""
    name = card.text.split(None, 1)[0] if card.text else ""
    expected = syntax.form if isinstance(syntax, ElementSyntax) else syntax
    return NetlistError(f"{name}: {message}", card.location(offset), expected=expected, hint=hint)


def parse_expr(card: Card, text: str, base: int, context: str, syntax=None,
               params: frozenset[str] = frozenset()) -> ex.Expr:
    """Parse expression ``text`` found at offset ``base`` of ``card``; errors name the card
    (``params``: names read as parameters even where reserved, :func:`~netdae.netlist.expr.parse_expression`)."""
    try:
        return ex.parse_expression(text, context=context, locate=lambda o: card.location(base + o),
                                   warn=lambda o, message: card.warn(base + o, message), params=params)
    except NetlistError as exc:
        name = card.text.split(None, 1)[0]
        expected = syntax.form if isinstance(syntax, ElementSyntax) else syntax
        raise NetlistError(f"{name}: {exc.message}", exc.location, expected=expected, hint=exc.hint) from None


def parse_value(card: Card, tok: Token, syntax=None, what: str = "value", *, numparam: bool = False) -> Val:
    """A number, ``{expr}``/``'expr'`` or parameter name as a :data:`Val`.

    Parameters
    ----------
    numparam : bool
        True where ngspice reads the value with its parameter code
        (``.param``, subcircuit defaults, instance parameters): a bare
        token is then an expression in the param context (``1mil`` = 1e-3,
        ``4k7`` an error); otherwise a bare number is read as an element
        value (``1mil`` = 25.4e-6, ``4k7`` = 4000).

    Raises
    ------
    NetlistError
        When the token is none of these.
    """
    if tok.kind == EXPR or (numparam and tok.kind == WORD):
        node = parse_expr(card, tok.text, tok.start + (tok.kind == EXPR), ex.PARAM, syntax)
        if type(node) is not ex.Const:
            return node, tok.start
        number = node.value
    elif tok.kind == WORD:
        number = parse_number(tok.text)
        if number is not None:
            ignored = ignored_text(tok.text)
            if ignored:
                odd = lookalike_hint(ignored)
                card.warn(tok.start, f"{what} '{tok.text}' read as {number:g}: '{ignored}' ignored, as ngspice "
                          "ignores what follows a number and its scale suffix" + (f" ({odd})" if odd else ""))
    else:
        number = None
    if number is not None:
        if not math.isfinite(number) or (tok.kind == WORD and number == 0.0 and underflows(tok.text)):
            raise error(card, tok.start, f"{what} '{tok.text}' is out of range", syntax)
        return number, tok.start
    if tok.kind == WORD:
        if IDENT.match(tok.text):
            if tok.text == "pi":
                return math.pi, tok.start
            if tok.text in ex.RESERVED:
                raise error(card, tok.start, f"'{tok.text}' cannot be used as a {what}", syntax)
            return ex.Param(tok.text), tok.start
    raise error(card, tok.start, f"bad {what} '{tok.text}': expected a number, {{expression}} or parameter name",
                syntax, hint=lookalike_hint(tok.text) or "numbers look like 10k, 4.7u, 1e-3, 1meg (1m is milli)")


def parse_node(card: Card, tok: Token, syntax) -> str:
    """A node name (``gnd`` becomes ``0``)."""
    if tok.kind != WORD:
        raise error(card, tok.start, f"expected a node name, found {tok.text!r}", syntax)
    return _GROUND_ALIASES.get(tok.text, tok.text)


def split_args(card: Card, toks: list[Token], start: int, syntax, *, allow_parens: bool = False):
    """Split tokens into positional tokens and ``name=value[,value...]`` keywords.

    Returns
    -------
    positional : list of Token
    keywords : list of (Token, list of Token)
    """
    positional: list[Token] = []
    keywords: list[tuple[Token, list[Token]]] = []
    i = start
    n = len(toks)
    while i < n:
        tok = toks[i]
        if tok.kind == WORD and i + 1 < n and toks[i + 1].kind == PUNCT and toks[i + 1].text == "=":
            values = []
            j = i + 2
            if j < n and toks[j].kind == STRING:  # a value is there, of a kind instance parameters do not take
                raise error(card, toks[j].start, f"'{tok.text}=' takes a number or an expression, not the string "
                            f"{toks[j].text!r}", syntax,
                            hint="write the value without quotes (strings are for a compiled model's string "
                                 "parameters, on its .model card)")
            if j >= n or toks[j].kind not in (WORD, EXPR):
                raise error(card, toks[i + 1].start, f"missing value after '{tok.text}='", syntax)
            values.append(toks[j])
            j += 1
            while j + 1 < n and toks[j].text == "," and toks[j].kind == PUNCT and toks[j + 1].kind in (WORD, EXPR):
                values.append(toks[j + 1])
                j += 2
            keywords.append((tok, values))
            i = j
            continue
        if tok.kind == PUNCT:
            if tok.text == ",":
                i += 1
                continue
            if not (allow_parens and tok.text in "()"):
                raise error(card, tok.start, f"unexpected '{tok.text}'", syntax)
        if tok.kind == STRING:
            raise error(card, tok.start, f"unexpected string \"{tok.text}\"", syntax)
        positional.append(tok)
        i += 1
    return positional, keywords


def _paren_group(card: Card, toks: list[Token], j: int) -> list[Token]:
    """``toks`` with the balanced group opening at ``toks[j]`` (a ``(``) replaced by one expression token."""
    depth = 0
    for k in range(j, len(toks)):
        if toks[k].kind == PUNCT:
            depth += {"(": 1, ")": -1}.get(toks[k].text, 0)
            if depth == 0:
                s, e = toks[j].start, toks[k].start
                return [*toks[:j], Token(card.text[s + 1 : e], EXPR, s, e + 1), *toks[k + 1:]]
    return toks


def _end(card: Card) -> int:
    return len(card.text)


#: How many nodes an element letter's cards start with, where a pair of them may be
#: parenthesised (``E1 (out 0) (in 0) -10``): the E and G linear forms have two pairs.
_PAIRED_NODES = {**dict.fromkeys("rclvibdfh", 2), **dict.fromkeys("eg", 4)}


def _unparenthesised_nodes(toks: list[Token], letter: str) -> list[Token]:
    """``toks`` with the parentheses (and a comma) around pairs of leading nodes removed.

    ngspice reads a node name skipping the ``(``, ``)`` and ``,`` around it
    (``INPgetNetTok``), so ``E1 (out 0) (in 0) -10`` is ``E1 out 0 in 0 -10``.
    Only a group of exactly two names that starts at an even node position
    (the pair n+ n-, or nc+ nc-), within the letter's leading nodes, is taken
    as nodes: ``POLY(1)``, ``SIN(0 1 1k)`` and TABLE points keep their
    parentheses.

    Examples
    --------
    >>> from netdae.netlist.lines import Card
    >>> toks = Card("e1 (o 0) (i, 0) -10", "<string>", [(0, 1, 1)]).tokens()
    >>> [t.text for t in _unparenthesised_nodes(toks, "e")]
    ['e1', 'o', '0', 'i', '0', '-10']
    >>> toks = Card("v1 a 0 sin(0 1)", "<string>", [(0, 1, 1)]).tokens()
    >>> len(_unparenthesised_nodes(toks, "v")) == len(toks)
    True
    """
    limit = _PAIRED_NODES.get(letter, 0)
    out, i, seen, changed = [toks[0]], 1, 0, False
    while i < len(toks) and seen < limit:
        tok = toks[i]
        if tok.kind == WORD:
            out.append(tok)
            seen += 1
            i += 1
            continue
        if not (tok.kind == PUNCT and tok.text == "(" and seen % 2 == 0):
            break
        names, j = [], i + 1
        while j < len(toks) and (toks[j].kind == WORD or (toks[j].kind == PUNCT and toks[j].text == ",")):
            if toks[j].kind == WORD:
                names.append(toks[j])
            j += 1
        if not (len(names) == 2 and j < len(toks) and toks[j].kind == PUNCT and toks[j].text == ")"
                and seen + 2 <= limit):
            break
        out.extend(names)
        seen, i, changed = seen + 2, j + 1, True
    return out + toks[i:] if changed else toks


def _nodes(card: Card, toks: list[Token], count: int, syntax) -> tuple[str, ...]:
    words = toks[1 : 1 + count]
    if len(words) == count and all([t.kind == WORD for t in words]):
        # one string object per node name however many cards name it (a 100,000-element netlist
        # keeps every node name twice otherwise: about 15 MiB)
        return tuple([_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words])
    found = 0
    for t in words:
        if t.kind != WORD:
            break
        found += 1
    at = toks[1 + found].start if 1 + found < len(toks) else _end(card)
    raise error(card, at, f"expected {count} nodes, found {found}", syntax)


#: ngspice 39's other names of R, C and L instance parameters (its res.c, cap.c, ind.c tables), read as netdae's.
_OTHER_NAMES = {Kind.RESISTOR: {"resistance": "r", "noise": "noisy"},
                Kind.CAPACITOR: {"capacitance": "c", "cap": "c"},
                Kind.INDUCTOR: {"inductance": "l"}}
#: R and C instance parameters of ngspice's safe-operating-area check, which only prints warnings.
_SOA_LIMITS = {Kind.RESISTOR: "bv_max", Kind.CAPACITOR: "bv_max"}


def _keyword_params(card: Card, keywords, syntax, kind: str) -> dict:
    params: dict = {}
    other_names = _OTHER_NAMES.get(kind, {})
    for key, values in keywords:
        name = other_names.get(key.text, key.text)
        if name == _SOA_LIMITS.get(kind) and len(values) == 1:
            parse_value(card, values[0], syntax)
            card.warn(key.start, f"{name}= (the voltage limit of ngspice's safe-operating-area check, which "
                      "only warns) is not used by netdae", severity="note")
            continue
        if syntax.keywords and name not in syntax.keywords:
            known = " ".join(sorted(syntax.keywords))
            raise error(card, key.start, f"unknown parameter '{name}' for a {syntax.description}", syntax,
                        hint=f"known parameters: {known}")
        labels = KINDS[kind].device_ic if kind in KINDS else ()
        if name == "ic" and len(labels) > 1:  # a transistor's ic= list names its terminal voltages
            if len(values) > len(labels):
                raise error(card, values[len(labels)].start, f"ic= takes at most {len(labels)} values "
                            f"({', '.join(labels)})", syntax)
            for label, tok in zip(labels, values):
                params[label] = parse_value(card, tok, syntax)
            continue
        if name == "tc":
            if len(values) > 2:
                raise error(card, values[2].start, "tc= takes at most 2 values (tc1, tc2)", syntax)
            for label, tok in zip(("tc1", "tc2"), values):
                if label in params:
                    raise error(card, key.start, f"{label} given twice (tc= sets tc1 and tc2)", syntax)
                params[label] = parse_value(card, tok, syntax)
            continue
        if len(values) != 1:
            raise error(card, values[1].start, f"{name}= takes one value", syntax)
        if name in params:
            why = " (tc= sets tc1 and tc2)" if name in ("tc1", "tc2") and "tc" in [k.text for k, _ in keywords] else ""
            raise error(card, key.start, f"parameter '{name}' given twice{why}", syntax)
        params[name] = parse_value(card, values[0], syntax)
    return params


#: The key of a Z card's unlabelled area (``Z1 d g s zm 2``), which ngspice 39's reader drops for a MES model.
UNLABELLED_AREA = "area#unlabelled"


# ---------------------------------------------------------------------------
#: A reference to a circuit quantity or time in an element value: the value is behavioural
#: (ngspice's b_transformation_wanted, without ``temper``, which netdae evaluates once).
_BEHAVIOURAL_VALUE = re.compile(r"(?<![a-z0-9_.])(?:[vi]\s*\(|time(?![a-z0-9_])|hertz(?![a-z0-9_]))")
_VALUE_KEY = {"resistor": "r", "capacitor": "c", "inductor": "l"}
_TEMPER = re.compile(r"(?<![a-z0-9_.])temper(?![a-z0-9_])")


def circuit_function_calls(cards) -> "re.Pattern | None":
    """A pattern matching calls of the ``.func`` functions among ``cards`` whose bodies read the circuit.

    ngspice expands ``.func`` calls in the text before it decides whether an R, C or L value is
    behavioural, so ``R1 a b {2*f(1)}`` with ``.func f(x) 'v(p)+x'`` is a behavioural resistor; a
    function that calls such a function reads the circuit too. None when no function does.
    """
    bodies = {}
    for card in cards:
        m = _FUNC_CARD.match(card.text)
        if m is not None:
            bodies[m.group(1).lower()] = m.group(2).lower()
    reading = {name for name, body in bodies.items() if _BEHAVIOURAL_VALUE.search(body)}
    while True:
        calls = _calls_of(reading)
        more = {name for name, body in bodies.items() if name not in reading and calls is not None
                and calls.search(body)}
        if not more:
            return calls
        reading |= more


_FUNC_CARD = re.compile(r"\.func\s+([a-z_][a-z0-9_]*)\s*\([^)]*\)(.*)$", re.IGNORECASE | re.DOTALL)


def _calls_of(names) -> "re.Pattern | None":
    if not names:
        return None
    return re.compile(r"(?<![a-z0-9_.])(?:" + "|".join(sorted(map(re.escape, names))) + r")\s*\(")


def _behavioural_value(toks: list[Token], kind: str, calls: "re.Pattern | None" = None) -> Token | None:
    """The ``{expr}``/``'expr'`` value token of an R, C or L card when it refers to V(), I() or time.

    ``calls`` matches calls of the ``.func`` functions that read the circuit (:func:`circuit_function_calls`).
    """
    key = _VALUE_KEY[kind]
    for k in range(3, len(toks)):
        tok = toks[k]
        if tok.kind != EXPR or (_BEHAVIOURAL_VALUE.search(tok.text) is None
                                and (calls is None or calls.search(tok.text) is None)):
            continue
        if k == 3 or (k >= 5 and toks[k - 1].text == "=" and toks[k - 2].kind == WORD and toks[k - 2].text == key):
            return tok
    return None


def _behavioural_two_terminal(card: Card, toks: list[Token], syntax: ElementSyntax, kind: str,
                              value: Token) -> list[ElementCard]:
    """``R|C|L n+ n- [R=|C=|L=]{expr} [m=mult]`` whose value depends on V(), I() or time, as behavioural elements.

    As ngspice 39 reads them (``inp_compat``): a resistor carries the current
    ``m V(n+, n-) / expr``; a capacitor written ``C={expr}`` the current
    ``m expr d/dt V(n+, n-)`` and one written ``{expr}`` alone the charge
    ``m expr`` (as ``Q={expr}``); an inductor has the voltage ``expr / m d/dt I``.
    The time derivative of the capacitor's voltage (the inductor's current) is an
    internal node ``<name>#ddt`` (``v(<name>#ddt)``, in V/s or A/s): the charge
    ``-V(n+, n-)`` (``-I(<name>)``) sits on it and 1 ohm to ground carries it away,
    so ``v(<name>#ddt)`` is that derivative; the element itself is a behavioural
    current (R, C) or voltage (L: its branch current is ``i(<name>)``) source.
    """
    name = toks[0].text
    nodes = _nodes(card, toks, 2, syntax)
    key = _VALUE_KEY[kind]
    form = f"{name[0].upper()}name n+ n- {key.upper()}={{expr}} [m=mult]" + (
        " | Cname n+ n- {charge expr} [m=mult]" if kind == Kind.CAPACITOR else "")
    mult = None
    coefficients: dict = {}
    k = 3
    while k < len(toks):
        tok = toks[k]
        if tok is value:
            k += 1
            continue
        if tok.kind == WORD and tok.text == key and k + 2 < len(toks) and toks[k + 1].text == "=" \
                and toks[k + 2] is value:
            k += 1
            continue
        if tok.kind == PUNCT and tok.text == "=" and k + 1 < len(toks) and toks[k + 1] is value:
            k += 1
            continue
        if tok.kind == WORD and tok.text == "m" and k + 2 < len(toks) and toks[k + 1].text == "=" and mult is None:
            mult = parse_value(card, toks[k + 2], form, "multiplier m")
            k += 3
            continue
        if (kind == Kind.RESISTOR and tok.kind == WORD and tok.text in ("tc1", "tc2") and k + 2 < len(toks)
                and toks[k + 1].text == "=" and tok.text not in coefficients):
            # ngspice 39 hands them to the B source it makes of the resistor, which scales the resistance
            coefficients[tok.text] = parse_value(card, toks[k + 2], form, tok.text)
            k += 3
            continue
        what = f"parameter '{tok.text}'" if k + 1 < len(toks) and toks[k + 1].text == "=" else repr(tok.text)
        raise error(card, tok.start, f"unexpected {what}: a {syntax.description} whose value depends on V(), "
                    "I() or time takes only m=", form,
                    hint="ngspice 39 turns such an element into behavioural sources, which drop ic, temp, "
                    "scale and model names (and tc1, tc2 but on a resistor)")
    expr = parse_expr(card, value.text, value.start + 1, ex.BEHAVIOURAL, form)
    m = None if mult is None else (ex.Const(mult[0]) if isinstance(mult[0], float) else mult[0])

    def scaled(node):
        return node if m is None else ex.Binary("*", m, node)

    at = value.start
    if kind == Kind.RESISTOR:
        current = ex.Binary("/", ex.Voltage(nodes[0], nodes[1]), expr)
        params = {**coefficients, "reciproctc": (1.0, at)} if coefficients else {}
        return [ElementCard(name, "bcurrent", card, nodes, params=params, expr=(scaled(current), at))]
    k = next(j for j, t in enumerate(toks) if t is value)
    written_key = k >= 5 and toks[k - 1].text == "=" and toks[k - 2].text == key
    if kind == Kind.CAPACITOR and not written_key:
        # ngspice 39 reads 'C n+ n- {expr}' (no c=) as a charge
        return [ElementCard(name, "bcharge", card, nodes, expr=(scaled(expr), at))]
    aux = f"{name}#ddt"
    if kind == Kind.CAPACITOR:
        measured = ex.Voltage(nodes[0], nodes[1])
        main = ElementCard(name, "bcurrent", card, nodes, expr=(scaled(ex.Binary("*", expr, ex.Voltage(aux))), at))
    else:
        measured = ex.Current(name)
        inductance = expr if m is None else ex.Binary("/", expr, m)
        main = ElementCard(name, "bvoltage", card, nodes, expr=(ex.Binary("*", inductance, ex.Voltage(aux)), at))
    charge = ElementCard(f"{name}#q", "bcharge", card, (aux, "0"), expr=(ex.Unary("-", measured), at))
    sink = ElementCard(f"{name}#r", "resistor", card, (aux, "0"), value=(1.0, at))
    return [main, charge, sink]


def _two_terminal(card: Card, toks: list[Token], syntax: ElementSyntax, kind: str, calls=None):
    if len(toks) > 5 and toks[4].text == "=" and toks[5].kind == PUNCT and toks[5].text == "(":
        toks = _paren_group(card, toks, 5)  # R = (expression): ngspice's parenthesised value
    value = _behavioural_value(toks, kind, calls)
    if value is not None:
        return _behavioural_two_terminal(card, toks, syntax, kind, value)
    nodes = _nodes(card, toks, 2, syntax)
    positional, keywords = split_args(card, toks, 3, syntax)
    params = _keyword_params(card, keywords, syntax, kind)
    el = ElementCard(toks[0].text, kind, card, nodes, params=params)
    key = _VALUE_KEY[kind]
    if key in params:
        if positional and key != "r":
            raise error(card, positional[0].start, f"{kind} value given twice (as {key}= and {positional[0].text!r})",
                        syntax)
        el.value = params.pop(key)
    if (len(positional) == 2 and positional[0].kind == WORD and IDENT.match(positional[0].text)
            and positional[0].text != "pi"
            and (positional[1].kind == EXPR or parse_number(positional[1].text) is not None)):
        positional.reverse()  # 'R1 a b RMOD 2k': the model name, then the value (ngspice accepts both orders)
    if positional:
        el.value = parse_value(card, positional[0], syntax)
        if kind == Kind.CAPACITOR and positional[0].kind == EXPR and _TEMPER.search(positional[0].text):
            card.warn(positional[0].start, "ngspice 39 makes a capacitor whose value {expr} reads temper, written "
                      "without c=, the charge expr, a constant: it carries no current there; netdae keeps the "
                      "capacitance (write c={expr} for both to agree)")
        if len(positional) > 1:
            tok = positional[1]
            if tok.kind != WORD or parse_number(tok.text) is not None:
                raise error(card, tok.start, f"expected a model name after the value, found {tok.text!r}", syntax)
            el.model = (tok.text, tok.start)
        if len(positional) > 2:
            raise error(card, positional[2].start, f"unexpected {positional[2].text!r}", syntax)
    if el.value is None:
        what = {"resistor": "resistance", "capacitor": "capacitance", "inductor": "inductance"}[kind]
        raise error(card, _end(card), f"missing {what}", syntax,
                    hint=f"give the {what} after the two nodes, e.g. {'1k' if kind == Kind.RESISTOR else '1u'}")
    return el


def _coupling(card: Card, toks: list[Token], syntax: ElementSyntax) -> ElementCard:
    positional, keywords = split_args(card, toks, 1, syntax)
    for key, values in keywords:
        # ngspice 39 reads the factor written k= or coefficient= too (its mutual inductor's parameter names)
        if key.text not in ("k", "coefficient") or len(keywords) > 1 or len(values) != 1:
            raise error(card, key.start, f"unexpected parameter '{key.text}'", syntax)
        positional = [*positional, values[0]]
    if len(positional) < 3:
        raise error(card, _end(card), f"expected at least two inductor names and a coupling factor, found {len(positional)} "
                    "item(s)", syntax)
    names = positional[:-1]
    for tok in names:
        if tok.kind != WORD or not tok.text.startswith("l"):
            raise error(card, tok.start, f"'{tok.text}' is not an inductor name (inductor names start with L)",
                        syntax)
    seen = set()
    for tok in names:
        if tok.text in seen:
            raise error(card, tok.start, f"inductor '{tok.text}' is named twice", syntax)
        seen.add(tok.text)
    return ElementCard(toks[0].text, "coupling", card, (), value=parse_value(card, positional[-1], syntax),
                       controls=tuple((t.text, t.start) for t in names))


_SOURCE_WORDS = set(WAVEFORMS) | {"sine", "dc", "ac"}
_UNSUPPORTED_SOURCE = {"external": "external source", "portnum": "RF port"}
#: Inputs of ngspice's distortion analysis: ``DISTOF1 [mag [phase]]``, read and skipped (no .disto in netdae).
_DISTORTION_INPUTS = ("distof1", "distof2")


def _source(card: Card, toks: list[Token], syntax: ElementSyntax, kind: str) -> ElementCard:
    nodes = _nodes(card, toks, 2, syntax)
    spec = SourceCard()
    i, n = 3, len(toks)
    first = True

    def is_value(t: Token) -> bool:
        return t.kind == EXPR or (t.kind == WORD and t.text not in _SOURCE_WORDS
                                  and t.text not in _UNSUPPORTED_SOURCE and t.text not in ("r", "td")
                                  and t.text not in _DISTORTION_INPUTS)

    def skip_eq(j: int) -> int:
        return j + 1 if j < n and toks[j].kind == PUNCT and toks[j].text == "=" else j

    while i < n:
        tok = toks[i]
        word = tok.text if tok.kind == WORD else None
        if word == "dc":
            j = skip_eq(i + 1)
            if j < n and toks[j].kind == WORD and (toks[j].text in WAVEFORMS or toks[j].text == "sine"):
                # 'DC PWL(...)': ngspice reads a DC value of 0 and the function
                if spec.dc is not None:
                    raise error(card, tok.start, "DC value given twice", syntax)
                spec.dc = (0.0, tok.start)
                i = j
                first = False
                continue
            if j >= n or not is_value(toks[j]):
                raise error(card, toks[j].start if j < n else _end(card), "missing value after 'dc'", syntax)
            if spec.dc is not None:
                raise error(card, tok.start, "DC value given twice", syntax)
            spec.dc = parse_value(card, toks[j], syntax)
            i = j + 1
        elif word == "ac":
            if spec.ac_mag is not None:
                raise error(card, tok.start, "'ac' given twice", syntax)
            j = skip_eq(i + 1)
            vals = []
            while j < n and len(vals) < 2 and is_value(toks[j]):
                vals.append(parse_value(card, toks[j], syntax))
                j += 1
                if j < n and toks[j].kind == PUNCT and toks[j].text == ",":
                    j += 1
            spec.ac_mag = vals[0] if vals else (1.0, tok.start)
            spec.ac_phase = vals[1] if len(vals) > 1 else None
            i = j
        elif word in WAVEFORMS or word == "sine":
            if spec.tran is not None:
                raise error(card, tok.start, "more than one transient function", syntax)
            i = _waveform(card, toks, i, spec, syntax)
            _check_pwl_extras(card, spec, syntax, kind)
        elif (tok.kind == PUNCT and tok.text == "(" and i + 1 < n and toks[i + 1].kind == WORD
              and (toks[i + 1].text in WAVEFORMS or toks[i + 1].text == "sine")):
            # '0v (PULSE 0 1 ...)': a function in parentheses (ngspice accepts it)
            if spec.tran is not None:
                raise error(card, toks[i + 1].start, "more than one transient function", syntax)
            j = _waveform(card, toks, i + 1, spec, syntax)
            if j >= n or toks[j].text != ")" or toks[j].kind != PUNCT:
                raise error(card, toks[j].start if j < n else _end(card),
                            f"expected ')' closing '(' of {toks[i + 1].text.upper()}", syntax)
            i = j + 1
            _check_pwl_extras(card, spec, syntax, kind)
        elif word in _DISTORTION_INPUTS:
            j = skip_eq(i + 1)
            count = 0
            while j < n and count < 2 and is_value(toks[j]):
                parse_value(card, toks[j], syntax, f"{word} value")
                j += 1
                count += 1
            card.warn(tok.start, f"'{word}' skipped: an input of ngspice's distortion analysis (.disto), which "
                                 "netdae does not have")
            i = j
        elif word in _UNSUPPORTED_SOURCE:
            raise error(card, tok.start, f"'{word}' ({_UNSUPPORTED_SOURCE[word]}) is not supported by netdae",
                        syntax, hint=f"supported functions: {SOURCE_FUNCTIONS}")
        elif first and is_value(tok):
            spec.dc = parse_value(card, tok, syntax)
            i += 1
        elif word == "m" and kind == Kind.ISOURCE and skip_eq(i + 1) > i + 1:
            raise error(card, tok.start, "m= (ngspice's multiplier of a current source's current) is not read by "
                        "netdae", syntax, hint="multiply the source's values instead (its DC value, AC magnitude "
                        "and the levels of its function)")
        else:
            raise error(card, tok.start, f"unexpected {tok.text!r}", syntax,
                        hint=f"after the nodes: [dc] value, ac mag [phase], {SOURCE_FUNCTIONS}")
        first = False
    if spec.dc is None and spec.tran is None and spec.ac_mag is None:  # ngspice 39 notes it (not for 'ac 1')
        card.warn(_end(card), "has no value, DC 0 assumed (as ngspice 39 notes)", severity="note")
    return ElementCard(toks[0].text, kind, card, nodes, source=spec)


def _check_pwl_extras(card: Card, spec: SourceCard, syntax, kind: str) -> None:
    if kind == Kind.ISOURCE and spec.tran[2]:
        key = next(iter(spec.tran[2]))
        raise error(card, spec.tran[2][key][1], f"PWL {key}= is not available on current sources "
                    "(ngspice 39 rejects it)", syntax, hint="write the repeated or delayed points out")


def _waveform(card: Card, toks: list[Token], i: int, spec: SourceCard, syntax) -> int:
    name_tok = toks[i]
    kind = "sin" if name_tok.text == "sine" else name_tok.text
    n = len(toks)
    j = i + 1
    vals: list[Val] = []
    extras: dict = {}
    if j < n and toks[j].kind == PUNCT and toks[j].text == "(":
        j += 1
        while True:
            if j >= n:
                raise error(card, name_tok.start, f"{kind.upper()}( without a closing ')'", syntax)
            t = toks[j]
            if t.kind == PUNCT and t.text == ")":
                j += 1
                break
            if t.kind == PUNCT and t.text == ",":
                j += 1
                continue
            if kind == "pwl" and _pwl_extra(card, toks, j, extras, syntax):
                j += 3  # 'PWL(t1 v1 ... r=0 td=1u)': ngspice 39 reads them inside the parentheses too
                continue
            vals.append(parse_value(card, t, syntax, f"{kind.upper()} parameter"))
            j += 1
    else:
        while j < n and (toks[j].kind == EXPR or (toks[j].kind == WORD and toks[j].text not in _SOURCE_WORDS
                                                   and toks[j].text not in ("r", "td")
                                                   and toks[j].text not in _UNSUPPORTED_SOURCE
                                                   and toks[j].text not in _DISTORTION_INPUTS
                                                   and not (j + 1 < n and toks[j + 1].text == "="))):
            vals.append(parse_value(card, toks[j], syntax, f"{kind.upper()} parameter"))
            j += 1
            if j < n and toks[j].kind == PUNCT and toks[j].text == ",":
                j += 1
    if kind == "pwl":
        while _pwl_extra(card, toks, j, extras, syntax):
            j += 3
    spec.tran = (kind, vals, extras, name_tok.start)
    return j


def _pwl_extra(card: Card, toks: list[Token], j: int, extras: dict, syntax: ElementSyntax) -> bool:
    """Read a PWL's ``r=value`` or ``td=value`` at token ``j`` into ``extras``; False when there is none."""
    if not (j + 2 < len(toks) and toks[j].kind == WORD and toks[j].text in ("r", "td") and toks[j + 1].text == "="):
        return False
    if toks[j].text in extras:
        raise error(card, toks[j].start, f"PWL {toks[j].text}= given twice", syntax)
    extras[toks[j].text] = parse_value(card, toks[j + 2], syntax)
    return True


#: HSPICE's keyword after the output nodes of a linear controlled source, and the card's length with it:
#: ngspice 39 drops the keyword when the card has exactly that many words (``inp_compat``'s ``replace_token``).
_HSPICE_KEYWORDS = {"e": ("vcvs", 7), "g": ("vccs", 7), "f": ("cccs", 6), "h": ("ccvs", 6)}


def _controlled(card: Card, toks: list[Token], syntax: ElementSyntax, letter: str) -> ElementCard:
    name = toks[0].text
    keyword, length = _HSPICE_KEYWORDS[letter]
    if len(toks) == length and toks[3].kind == WORD and toks[3].text == keyword:
        toks = toks[:3] + toks[4:]  # 'E1 out 0 VCVS in 0 2' is 'E1 out 0 in 0 2'
    # behavioural form: value= (vol= for E, cur= for G)
    keys = {"e": ("value", "vol"), "g": ("value", "cur")}.get(letter, ())
    for k, tok in enumerate(toks):
        # value={expr}, and value {expr} without '=' (ngspice 39 reads both)
        if tok.kind == WORD and tok.text in keys and k + 1 < len(toks) and (
                toks[k + 1].text == "=" or (k == 3 and toks[k + 1].kind == EXPR)):
            if k != 3:
                raise error(card, tok.start, f"expected 2 nodes before '{tok.text}='", syntax)
            nodes = _nodes(card, toks, 2, syntax)
            kind = "bvoltage" if letter == "e" else "bcurrent"
            start = k + 2 if toks[k + 1].text == "=" else k + 1
            end, params = _b_instance_parameters(card, toks, start + 1, syntax)
            expr = _multiplied(_behavioural(card, toks, start, syntax, end), params.pop("m", None))
            return ElementCard(name, kind, card, nodes, params=params, expr=expr)
    if letter in "eg":
        table = next((k for k, t in enumerate(toks[:6]) if t.kind == WORD and t.text == "table"), None)
        if table is not None:
            return _table(card, toks, table, syntax, letter)
        if len(toks) > 3 and toks[3].kind == WORD and toks[3].text == "laplace":
            return _laplace(card, toks, syntax, letter)
    for tok in toks[3:]:
        if tok.kind == WORD and tok.text in ("laplace", "table", "freq", "and", "or", "nand", "nor", "chebyshev"):
            raise error(card, tok.start, f"the '{tok.text.upper()}' form of {letter.upper()} is not supported "
                        "by netdae", syntax, hint="write it as value={expression}")
    poly = next((k for k, t in enumerate(toks) if t.kind == WORD and t.text == "poly"), None)
    if poly is not None:
        return _poly(card, toks, poly, syntax, letter)
    if letter in "eg":
        nodes = _nodes(card, toks, 4, syntax)
        positional, keywords = split_args(card, toks, 5, syntax)
        mult, keywords = _parallel_multiplier(card, keywords, syntax, letter)
        if keywords:
            raise error(card, keywords[0][0].start, f"unexpected parameter '{keywords[0][0].text}'", syntax)
        if letter == "e" and positional and positional[0].kind == WORD and positional[0].text == "opamp":
            if len(positional) > 1:
                raise error(card, positional[1].start, f"unexpected {positional[1].text!r} after OPAMP", syntax)
            return ElementCard(name, "opamp", card, nodes)
        if not positional:
            what = "gain" if letter == "e" else "transconductance"
            raise error(card, _end(card), f"missing {what}", syntax)
        if len(positional) > 1:
            raise error(card, positional[1].start, f"unexpected {positional[1].text!r}", syntax)
        kind = "vcvs" if letter == "e" else "vccs"
        return ElementCard(name, kind, card, nodes, value=parse_value(card, positional[0], syntax),
                           params={} if mult is None else {"m": mult})
    nodes = _nodes(card, toks, 2, syntax)
    positional, keywords = split_args(card, toks, 3, syntax)
    mult, keywords = _parallel_multiplier(card, keywords, syntax, letter)
    if keywords:
        raise error(card, keywords[0][0].start, f"unexpected parameter '{keywords[0][0].text}'", syntax)
    if not positional or positional[0].kind != WORD or parse_number(positional[0].text) is not None:
        at = positional[0].start if positional else _end(card)
        raise error(card, at, "expected the name of the controlling voltage source", syntax)
    if len(positional) < 2:
        what = "gain" if letter == "f" else "transresistance"
        raise error(card, _end(card), f"missing {what}", syntax)
    if len(positional) > 2:
        raise error(card, positional[2].start, f"unexpected {positional[2].text!r}", syntax)
    kind = "cccs" if letter == "f" else "ccvs"
    return ElementCard(name, kind, card, nodes, value=parse_value(card, positional[1], syntax),
                       params={} if mult is None else {"m": mult}, controls=((positional[0].text, positional[0].start),))


def _parallel_multiplier(card: Card, keywords, syntax, letter: str):
    """``(m, other keywords)``: the ``m=`` of a linear G or F (ngspice 39's VCCS and CCCS ``m``, the parallel
    multiplier of their current; E and H have none), else ``(None, keywords)``."""
    if letter not in "gf":
        return None, keywords
    found = [kv for kv in keywords if kv[0].text == "m"]
    if not found:
        return None, keywords
    if len(found) > 1:
        raise error(card, found[1][0].start, "multiplier m given twice", syntax)
    values = found[0][1]
    if len(values) > 1:
        raise error(card, values[1].start, f"unexpected {values[1].text!r} after m=", syntax)
    return parse_value(card, values[0], syntax, "multiplier m"), [kv for kv in keywords if kv[0].text != "m"]


def _behavioural(card: Card, toks: list[Token], k: int, syntax, end: int | None = None) -> tuple:
    """The behavioural expression from token ``k`` to the end of the card (or up to token ``end``)."""
    end = len(toks) if end is None else end
    if k >= end:
        raise error(card, _end(card) if end == len(toks) else toks[end].start, "missing expression", syntax)
    tok = toks[k]
    if tok.kind == EXPR and k == end - 1:
        text, base = tok.text, tok.start + 1
    else:
        text, base = card.text[tok.start:toks[end].start if end < len(toks) else None], tok.start
    return parse_expr(card, text, base, ex.BEHAVIOURAL, syntax), tok.start


def _table(card: Card, toks: list[Token], k: int, syntax, letter: str) -> ElementCard:
    """``E|G n+ n- TABLE {expr} = (x0, y0) (x1, y1) ... [m=mult (G)]`` as a behavioural source.

    The pairs may be written with or without parentheses and commas, the ``=``
    after the expression may be left out, and ``TABLE = {expr}`` is accepted, as
    ngspice 39 reads them. The source's value is ``table(expr, x0, y0, ...)``
    (:func:`netdae.netlist.expr.table_point`); a single pair is the constant y0.
    """
    name = toks[0].text
    form = f"{letter.upper()}name n+ n- TABLE {{expr}} = (x0, y0) (x1, y1) ...{' [m=mult]' if letter == 'g' else ''}"
    if k != 3:
        hint = ("ngspice 39 reads TABLE after the two output nodes only (the 4-node form "
                f"{letter.upper()}name n+ n- nc+ nc- TABLE=(...) is LTspice's)") if k == 5 else None
        raise error(card, toks[k].start, "expected 2 nodes before TABLE", form, hint=hint)
    nodes = _nodes(card, toks, 2, syntax)
    j = k + 1
    if j < len(toks) and toks[j].kind == PUNCT and toks[j].text == "=":
        j += 1
    if j >= len(toks) or toks[j].kind != EXPR:
        at = toks[j].start if j < len(toks) else _end(card)
        raise error(card, at, "expected the controlling expression in braces after TABLE", form,
                    hint="write TABLE {V(in)} = ... (ngspice 39 needs the braces or quotes)")
    ctrl = toks[j]
    control = parse_expr(card, ctrl.text, ctrl.start + 1, ex.BEHAVIOURAL, form)
    j += 1
    if j < len(toks) and toks[j].kind == PUNCT and toks[j].text == "=":
        j += 1
    values: list[Token] = []
    mult = None
    while j < len(toks):
        tok = toks[j]
        if tok.kind == PUNCT and tok.text in "(),":
            j += 1
            continue
        if tok.kind == WORD and j + 1 < len(toks) and toks[j + 1].text == "=":
            if letter == "g" and tok.text == "m" and mult is None and j + 2 < len(toks):
                mult = parse_value(card, toks[j + 2], form, "multiplier m")
                j += 3
                continue
            raise error(card, tok.start, f"unexpected parameter '{tok.text}=' in the table", form,
                        hint="G TABLE takes m=mult after the pairs; E TABLE takes none" if letter == "g" or
                        tok.text == "m" else None)
        if mult is not None or tok.kind not in (WORD, EXPR):
            raise error(card, tok.start, f"unexpected {tok.text!r} after the table", form)
        values.append(tok)
        j += 1
    if not values:
        raise error(card, _end(card), "TABLE without (x, y) pairs", form)
    if len(values) % 2:
        raise error(card, values[-1].start, f"the table needs (x, y) pairs: {values[-1].text!r} has no y value",
                    form)
    points = [parse_value(card, t, form, "table value") for t in values]
    xs = [(v, t) for (v, _), t in zip(points[0::2], values[0::2])]
    for (x0, _), (x1, t1) in zip(xs, xs[1:]):
        if isinstance(x0, float) and isinstance(x1, float) and not x1 > x0:
            raise error(card, t1.start, f"the table's x values must increase strictly: {t1.text} follows "
                        f"{x0:g}", form, hint="ngspice 39 reads a table whose x values do not increase "
                        "without a message and computes nonsense with it")

    def as_expr(v):
        return ex.Const(v) if isinstance(v, float) else v

    if len(points) == 2:  # ngspice 39: a single pair is the constant y0
        node = as_expr(points[1][0])
    else:
        node = ex.Call("table", (control,) + tuple(as_expr(v) for v, _ in points))
    if mult is not None:
        node = ex.Binary("*", as_expr(mult[0]), node)
    kind = "bvoltage" if letter == "e" else "bcurrent"
    return ElementCard(name, kind, card, nodes, expr=(node, toks[k].start))


def _laplace(card: Card, toks: list[Token], syntax, letter: str) -> ElementCard:
    """``E|G n+ n- LAPLACE {expr} = {H(s)}``: netdae's extension (PSpice's syntax; ngspice 39 has none).

    The card becomes kind ``laplace`` with the expression ``Call("laplace", (u, H))``, ``s``
    written as :class:`netdae.netlist.expr.Time`; elaboration realises it as a state-space
    block (:mod:`netdae.netlist.laplace`).
    """
    form = f"{letter.upper()}name n+ n- LAPLACE {{expr}} = {{H(s)}}"
    nodes = _nodes(card, toks, 2, syntax)
    exprs = [t for t in toks[4:] if not (t.kind == PUNCT and t.text == "=")]
    if len(exprs) != 2 or any(t.kind != EXPR for t in exprs):
        bad = next((t for t in exprs if t.kind != EXPR), exprs[2] if len(exprs) > 2 else None)
        raise error(card, bad.start if bad is not None else _end(card),
                    "expected the controlling expression and H(s), each in braces, after LAPLACE", form,
                    hint="e.g. LAPLACE {V(in)} = {1/(1 + s*1m)}")
    control = parse_expr(card, exprs[0].text, exprs[0].start + 1, ex.BEHAVIOURAL, form)
    h = parse_expr(card, exprs[1].text, exprs[1].start + 1, ex.BEHAVIOURAL, form)
    for m in ex.walk(h):
        if type(m) in (ex.Voltage, ex.Current, ex.Time):
            raise error(card, exprs[1].start, f"H(s) must be a function of s alone, not of {ex.to_text(m)}", form,
                        hint="the controlling expression goes in the first braces")
    h = ex.transform(h, lambda m: ex.Time() if m == ex.Param("s") else None)
    card.warn(toks[3].start, f"LAPLACE is netdae's extension: ngspice 39 reads no LAPLACE form of "
              f"{letter.upper()} (compare with an XSPICE s_xfer model)")
    return ElementCard(toks[0].text, "laplace", card, nodes, expr=(ex.Call("laplace", (control, h)), toks[3].start))


def _poly(card: Card, toks: list[Token], k: int, syntax, letter: str) -> ElementCard:
    """``POLY(n)`` controlled source as a behavioural polynomial (SPICE2 coefficient order)."""
    name = toks[0].text
    if k != 3:
        raise error(card, toks[k].start, "expected 2 nodes before POLY", syntax)
    nodes = _nodes(card, toks, 2, syntax)
    if not (k + 3 < len(toks) and toks[k + 1].text == "(" and toks[k + 3].text == ")"):
        raise error(card, toks[k].start, "expected POLY(n) with the number of controlling inputs n", syntax)
    dim_tok = toks[k + 2]
    dim = parse_number(dim_tok.text) if dim_tok.kind == WORD else None
    if dim is None or not math.isfinite(dim) or dim != int(dim) or dim < 1:
        raise error(card, dim_tok.start, f"POLY dimension must be a positive integer, found {dim_tok.text!r}",
                    syntax)
    dim = int(dim)
    rest, keywords = split_args(card, toks, k + 4, syntax, allow_parens=True)
    if keywords:
        raise error(card, keywords[0][0].start, f"unexpected parameter '{keywords[0][0].text}'", syntax)
    rest = [t for t in rest if t.kind != PUNCT]  # 'POLY(2) (3,0) (4,0) ...': the pairs may be parenthesised
    per_input = 2 if letter in "eg" else 1
    need = dim * per_input
    if len(rest) < need + 1:
        raise error(card, _end(card), f"POLY({dim}) needs {need} controlling "
                    f"{'nodes' if per_input == 2 else 'source names'} and at least one coefficient", syntax)
    controls = rest[:need]
    for t in controls:
        if t.kind != WORD:
            raise error(card, t.start, f"expected a {'node' if per_input == 2 else 'source'} name", syntax)
    coeffs = [parse_value(card, t, syntax, "coefficient") for t in rest[need:]]
    if per_input == 2:
        inputs = [ex.Voltage(_GROUND_ALIASES.get(controls[2 * m].text, controls[2 * m].text),
                             _GROUND_ALIASES.get(controls[2 * m + 1].text, controls[2 * m + 1].text))
                  for m in range(dim)]
    else:
        inputs = [ex.Current(t.text) for t in controls]
    node = poly_expression(inputs, [c for c, _ in coeffs])
    kind = "bvoltage" if letter in "eh" else "bcurrent"
    return ElementCard(name, kind, card, nodes, expr=(node, toks[k].start))


def poly_expression(inputs: list, coeffs: list) -> ex.Expr:
    """SPICE2 polynomial: c0 + sum c_i x_i + sum c_ij x_i x_j (i <= j) + ... as a tree.

    Terms are ordered by degree, and within a degree by non-decreasing index
    tuples in lexicographic order (x1^2, x1 x2, ..., x2^2, ...), as SPICE2 and
    ngspice define ``POLY``.

    An input that no written coefficient multiplies (``POLY(2) v1 vx 0 1``: only
    ``c1 x1``) stays in the tree as ``0 * x``: the element reads every control it
    names, as ngspice's does, so that a control source that does not exist is an
    error there too, and a control node nothing else connects is a floating node.

    Examples
    --------
    >>> ex.to_text(poly_expression([ex.Current("v1"), ex.Current("vx")], [0.0, 2.0]))
    '(2.0 * i(v1)) + (0.0 * i(vx))'
    """
    terms: list = []
    dim = len(inputs)
    index_tuples = [()]
    degree_tuples = [()]
    while len(index_tuples) < len(coeffs):
        degree_tuples = [t + (j,) for t in degree_tuples for j in range(t[-1] if t else 0, dim)]
        index_tuples.extend(degree_tuples)
    read: set[int] = set()
    for coeff, idx in zip(coeffs, index_tuples):
        if isinstance(coeff, float) and coeff == 0.0:
            continue
        term = coeff if not isinstance(coeff, float) else ex.Const(coeff)
        for j in idx:
            term = ex.Binary("*", term, inputs[j])
        read.update(idx)
        terms.append(term)
    terms.extend(ex.Binary("*", ex.Const(0.0), x) for j, x in enumerate(inputs) if j not in read)
    if not terms:
        return ex.Const(0.0)
    out = terms[0]
    for term in terms[1:]:
        out = ex.Binary("+", out, term)
    return out


#: Instance parameters ngspice 39's B source takes after its expression (netdae reads tc1 and tc2: the value times
#: ``1 + tc1 (T - 27) + tc2 (T - 27)^2``, ``_Elaborator._temperature_scaled``).
_B_INSTANCE = {"tc1": "temperature coefficient", "tc2": "temperature coefficient", "temp": "instance temperature",
               "dtemp": "instance temperature", "reciproctc": "temperature coefficient", "reciprocm": "multiplier",
               "m": "multiplier"}


def _multiplied(expr: tuple, mult) -> tuple:
    """A behavioural expression ``(node, offset)`` times the multiplier ``m=`` (a parsed value), as ngspice's
    B source applies it (``asrcload.c``: its voltage or current times m)."""
    if mult is None:
        return expr
    m = ex.Const(mult[0]) if isinstance(mult[0], float) else mult[0]
    return ex.Binary("*", m, expr[0]), expr[1]


def _b_instance_parameters(card: Card, toks: list[Token], first: int, syntax) -> tuple[int, dict]:
    """``(end, params)``: the instance parameters (``tc1= tc2= temp= dtemp= m=``) closing a B source's
    expression, searched from token ``first`` on, and the token where the expression ends.

    ngspice 39 hands the rest of an ``E ... value={expr} ...`` card to the B source it makes (and the
    ``m=`` of a G's to its G), so E and G ``value=``, ``vol=``, ``cur=`` cards read them too. ``temp=``
    and ``dtemp=`` enter only the tc1, tc2 factor (dropped without one); ``dtemp=`` beside ``temp=`` is
    ignored with a warning, as ngspice ignores it.
    """
    params: dict = {}
    end = len(toks)
    k = first
    while k < len(toks) - 1:
        if toks[k].kind == WORD and toks[k].text in _B_INSTANCE and toks[k + 1].kind == PUNCT \
                and toks[k + 1].text == "=" and (toks[k - 1].kind != PUNCT or toks[k - 1].text == ")"
                                                 or toks[k - 1].kind == EXPR or k > end):
            word = toks[k].text
            if word not in ("tc1", "tc2", "m", "temp", "dtemp"):
                raise error(card, toks[k].start, f"{word}= on a B source ({_B_INSTANCE[word]}) is not supported "
                            "by netdae", syntax,
                            hint="fold the factor into the expression, e.g. V={(1 + tc1*(temper - 27)) * (...)}")
            if k + 2 >= len(toks):
                raise error(card, toks[k + 1].start, f"missing value after '{word}='", syntax)
            end = min(end, k)
            params[word] = parse_value(card, toks[k + 2], syntax, word)
            k += 3
            continue
        k += 1
    if "temp" in params and "dtemp" in params:
        card.warn(params["dtemp"][1], "dtemp= ignored: the instance temperature temp= is given (as ngspice 39 "
                  "ignores it)")
        del params["dtemp"]
    if not ("tc1" in params or "tc2" in params):
        params.pop("temp", None), params.pop("dtemp", None)  # they enter only the tc1, tc2 factor
    return end, params


def _b_source(card: Card, toks: list[Token], syntax: ElementSyntax) -> ElementCard:
    nodes = _nodes(card, toks, 2, syntax)
    if len(toks) < 5 or toks[3].kind != WORD or toks[3].text not in ("v", "i") or toks[4].text != "=":
        at = toks[3].start if len(toks) > 3 else _end(card)
        raise error(card, at, "expected V={expr} or I={expr} after the nodes", syntax)
    kind = "bvoltage" if toks[3].text == "v" else "bcurrent"
    end, params = _b_instance_parameters(card, toks, 6, syntax)
    expr = _multiplied(_behavioural(card, toks, 5, syntax, end), params.pop("m", None))
    return ElementCard(toks[0].text, kind, card, nodes, params=params, expr=expr)


def _numeric(text: str) -> bool:
    """Whether a word starts as a number does (a digit, or a sign or point and a digit)."""
    head = text.lstrip("+-")
    return bool(head) and (head[0].isdigit() or (head[0] == "." and len(head) > 1 and head[1].isdigit()))


def _device(card: Card, toks: list[Token], syntax: ElementSyntax, kind: str, count: int) -> ElementCard:
    positional, keywords = split_args(card, toks, 1, syntax)
    params = _keyword_params(card, keywords, syntax, kind)
    flags = {}
    words = []
    for tok in positional:
        if tok.kind == WORD and tok.text in syntax.flags:
            flags[tok.text] = tok.start
        else:
            words.append(tok)
    el = ElementCard(toks[0].text, kind, card, params=params, flags=flags)
    thermal = next((t for t in words if t.kind == WORD and t.text == "thermal"), None)
    if thermal is not None and kind in (Kind.DIODE, Kind.MOSFET):
        what = "VDMOS (power MOSFET, .model ... vdmos)" if kind == Kind.MOSFET else "diode"
        raise error(card, thermal.start, f"a self-heating {what} with thermal nodes ('thermal') is not supported "
                    "by netdae", syntax, hint="remove the thermal nodes and 'thermal' to simulate it without "
                    "self-heating")
    if kind == Kind.BJT:
        el.positional = words
        return el
    if kind == Kind.MOSFET and len(words) in (count, count + 2) and all(t.kind == WORD for t in words):
        # three nodes and a model is ngspice 39's VDMOS, five nodes and a model its self-heating form;
        # judged when the models are known (parser._settle)
        el.positional = words
        return el
    if (kind == Kind.DIODE and len(words) in (count + 2, count + 3) and all(t.kind == WORD for t in words[:count + 2])
            and not _numeric(words[count + 1].text)):
        # 'D a k t mname [area]': ngspice 39's third node (its diode's thermal node) or 'D a k mname pname'
        # (an area given as a parameter's name): judged when the models are known (parser._settle)
        el.positional = words
        return el
    if len(words) < count + 1 or any(t.kind != WORD for t in words[: count + 1]):
        found = sum(1 for t in words[:count] if t.kind == WORD)
        raise error(card, _end(card) if len(words) <= count else words[count].start,
                    f"expected {count} nodes and a model name, found {min(found, count)} node(s)"
                    f"{' and no model' if len(words) <= count else ''}", syntax)
    el.nodes = tuple(_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words[:count])
    el.model = (words[count].text, words[count].start)
    extra = words[count + 1 :]
    if kind in (Kind.DIODE, Kind.JFET, Kind.MESFET) and extra:
        # ngspice's Z reader gives an unlabelled area to MESA/HFET models only (judged with the model)
        el.params[UNLABELLED_AREA if kind == Kind.MESFET else "area"] = parse_value(card, extra[0], syntax, "area")
        extra = extra[1:]
    if extra:
        raise error(card, extra[0].start, f"unexpected {extra[0].text!r}", syntax)
    return el


def _switch(card: Card, toks: list[Token], syntax: ElementSyntax, letter: str) -> ElementCard:
    """``Sname n+ n- nc+ nc- mname [on|off]`` or ``Wname n+ n- vname mname [on|off]``."""
    positional, keywords = split_args(card, toks, 1, syntax)
    if keywords:
        raise error(card, keywords[0][0].start, f"unexpected parameter '{keywords[0][0].text}'", syntax,
                    hint="a switch takes its parameters from its .model card (sw or csw)")
    nodes = 4 if letter == "s" else 2
    need = nodes + (1 if letter == "w" else 0) + 1
    words = positional[:need]
    found = 0
    for tok in words:
        if tok.kind != WORD:
            break
        found += 1
    if found < need:
        at = words[found].start if found < len(words) else _end(card)
        what = f"{nodes} nodes, the controlling source's name and a model name" if letter == "w" else \
            f"{nodes} nodes and a model name"
        raise error(card, at, f"expected {what}", syntax)
    el = ElementCard(toks[0].text, "vswitch" if letter == "s" else "cswitch", card,
                     tuple(_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words[:nodes]))
    if letter == "w":
        ctl = words[nodes]
        if parse_number(ctl.text) is not None:
            raise error(card, ctl.start, f"expected the name of the controlling source, found {ctl.text!r}", syntax)
        el.controls = ((ctl.text, ctl.start),)
    model = words[-1]
    if parse_number(model.text) is not None:
        raise error(card, model.start, f"expected a model name, found {model.text!r}", syntax)
    el.model = (model.text, model.start)
    for tok in positional[need:]:
        if tok.kind == WORD and tok.text in syntax.flags:
            if el.flags:
                raise error(card, tok.start, f"'{tok.text}' after '{next(iter(el.flags))}': give ON or OFF once",
                            syntax)
            el.flags[tok.text] = tok.start
        else:
            raise error(card, tok.start, f"unexpected {tok.text!r}", syntax,
                        hint="after the model name a switch takes only its initial state, ON or OFF")
    return el


#: The transmission line's ``ic=`` values, in ngspice's order.
TLINE_IC = ("v1", "i1", "v2", "i2")


def _tline(card: Card, toks: list[Token], syntax: ElementSyntax) -> ElementCard:
    """``Tname p1+ p1- p2+ p2- z0=.. td=..|f=.. [nl=..] [ic=v1,i1,v2,i2]`` (ngspice's TRA)."""
    for k in range(1, min(5, len(toks) - 1)):  # a keyword where a node should be
        if toks[k].kind == WORD and toks[k + 1].kind == PUNCT and toks[k + 1].text == "=":
            raise error(card, toks[k].start, f"expected 4 nodes, found {k - 1}", syntax)
    nodes = _nodes(card, toks, 4, syntax)
    positional, keywords = split_args(card, toks, 5, syntax)
    if positional:
        raise error(card, positional[0].start, f"unexpected {positional[0].text!r}", syntax,
                    hint="a transmission line takes z0=, td= (or f= [nl=]) and ic= as name=value")
    ics = [(key, values) for key, values in keywords if key.text == "ic"]
    for key, values in ics:
        if len(values) > len(TLINE_IC):
            raise error(card, values[len(TLINE_IC)].start, "ic= takes at most 4 values (v1, i1, v2, i2)", syntax)
    params = _keyword_params(card, [(k, v) for k, v in keywords if k.text != "ic"], syntax, "tline")
    if "zo" in params:
        if "z0" in params:
            raise error(card, params["zo"][1], "z0 given twice (zo= is z0=)", syntax)
        params["z0"] = params.pop("zo")
    for key, values in ics:
        if any(label in params for label in TLINE_IC):
            raise error(card, key.start, "ic= given twice", syntax)
        for label, tok in zip(TLINE_IC, values):
            params[label] = parse_value(card, tok, syntax)
    if "z0" not in params:
        raise error(card, _end(card), "the characteristic impedance z0= is missing", syntax)
    if "td" not in params and "f" not in params:
        raise error(card, _end(card), "the delay is missing: give td= (or f= with nl=, the length in "
                    "wavelengths at f, 0.25 when omitted)", syntax)
    return ElementCard(toks[0].text, "tline", card, nodes, params=params)


#: The element kind of each lossy line's card letter (a Y card with a CPL model becomes a ``cpl``
#: when the model is known, as ngspice 39 reads it).
_LOSSY_KINDS = {letter: spec.name for spec in reversed(KINDS.values()) if spec.realised_by == "netdae.netlist.lossy"
                for letter in spec.letters}


def _leading_words(card: Card, toks: list[Token], syntax: ElementSyntax, message, hint: str | None = None
                   ) -> tuple[list[Token], int]:
    """The words after the element name up to the first ``name=`` (nodes and a model name), and where they end.

    Raises
    ------
    NetlistError
        At a token that is not a word, with ``message(token)``.
    """
    words: list[Token] = []
    i = 1
    while i < len(toks):
        tok = toks[i]
        if tok.kind == WORD and i + 1 < len(toks) and toks[i + 1].kind == PUNCT and toks[i + 1].text == "=":
            break
        if tok.kind != WORD:
            raise error(card, tok.start, message(tok), syntax, hint=hint)
        words.append(tok)
        i += 1
    return words, i


def _lossy_line(card: Card, toks: list[Token], syntax: ElementSyntax, letter: str) -> ElementCard:
    """``O``, ``Y`` and ``P`` cards: ngspice's lossy lines (LTRA, TXL, CPL), nodes and model name.

    An O card has four nodes; a Y card four (the references are read and, as in ngspice
    39, not used: the line is referenced to ground); a P card ``2 N + 2`` for N
    conductors, N counted as ngspice counts it (the words before ``len=``, less the
    two references and the model, halved). Y and P take ``len=`` (P also
    ``length=``), which overrides the model's length; the line itself is made by
    :mod:`netdae.netlist.lossy` when the model is known.
    """
    words, i = _leading_words(card, toks, syntax, lambda tok: f"unexpected {tok.text!r}: expected node names and "
                              "a model name")
    _, keywords = split_args(card, toks, i, syntax)
    if letter == "p":
        if len(words) < 5 or len(words) % 2 == 0:
            at = words[-1].start if words else _end(card)
            raise error(card, at, f"expected N input nodes, a reference, N output nodes, a reference and a model "
                        f"name (an odd number of words, at least 5), found {len(words)} word(s)", syntax,
                        hint="P1 in1 in2 0 out1 out2 0 mymodel: two conductors")
        count = len(words) - 1
        if count // 2 - 1 > MAX_CPL_CONDUCTORS:
            raise error(card, words[0].start, f"{count // 2 - 1} conductors: ngspice 39's CPL holds at most "
                        f"{MAX_CPL_CONDUCTORS}", syntax)
    else:
        count = 4
        if len(words) != 5:
            at = words[5].start if len(words) > 5 else _end(card)
            found = min(len(words), 4)
            raise error(card, at, f"expected 4 nodes and a model name, found {found} node(s)"
                        f"{' and no model' if len(words) < 5 else ' and more words'}", syntax)
    model = words[count]
    if parse_number(model.text) is not None:
        raise error(card, model.start, f"expected a model name, found {model.text!r}", syntax)
    params = {}
    for key, values in keywords:
        if key.text not in syntax.keywords:
            what = ("an LTRA line takes no instance parameters here: its initial conditions (ic=, v1= ...) "
                    "are not supported by netdae" if letter == "o" else f"'{key.text}=' is not a parameter of "
                    f"{'a Y' if letter == 'y' else 'a P'} card")
            raise error(card, key.start, f"unexpected parameter '{key.text}'", syntax,
                        hint=what if letter == "o" else "give the line's length as len=")
        if len(values) != 1:
            raise error(card, (values[1] if len(values) > 1 else key).start, f"{key.text}= takes one value", syntax)
        if "len" in params:
            raise error(card, key.start, "the length is given twice", syntax)
        params["len"] = parse_value(card, values[0], syntax, "length")
    nodes = tuple(_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words[:count])
    return ElementCard(toks[0].text, _LOSSY_KINDS[letter], card, nodes, model=(model.text, model.start),
                       params=params)


def _urc(card: Card, toks: list[Token], syntax: ElementSyntax) -> ElementCard:
    """``Uname n1 n2 ref mname l=length [n=lumps]``: ngspice's uniform RC line (made by :mod:`netdae.netlist.urc`).

    A U card of another form (PSpice's digital primitives, ``U1 NAND(2) ...``, which
    ngspice reads only in its PSpice compatibility mode, as XSPICE code models) is
    refused by name.
    """
    words, i = _leading_words(card, toks, syntax, lambda tok: (
        f"a U element with {tok.text!r} here is a PSpice digital primitive, which netdae does not "
        "support (nor does ngspice 39 outside its PSpice compatibility mode)"),
        hint="netdae's U element is the uniform RC line")
    if len(words) != 4:
        at = words[4].start if len(words) > 4 else _end(card)
        raise error(card, at, f"expected 3 nodes and a model name, found {len(words)} word(s)", syntax)
    model = words[3]
    if parse_number(model.text) is not None:
        raise error(card, model.start, f"expected a model name, found {model.text!r}", syntax)
    _, keywords = split_args(card, toks, i, syntax)
    params = {}
    for key, values in keywords:
        if key.text not in syntax.keywords:
            raise error(card, key.start, f"unexpected parameter '{key.text}'", syntax,
                        hint="a URC line takes its length l= and its number of lumps n=")
        if len(values) != 1:
            raise error(card, (values[1] if len(values) > 1 else key).start, f"{key.text}= takes one value", syntax)
        if key.text in params:
            raise error(card, key.start, f"{key.text}= is given twice", syntax)
        params[key.text] = parse_value(card, values[0], syntax, "length" if key.text == "l" else "number of lumps")
    if "l" not in params:
        raise error(card, _end(card), "the line's length l= is missing", syntax)
    nodes = tuple(_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words[:3])
    return ElementCard(toks[0].text, Kind.URC.value, card, nodes, model=(model.text, model.start), params=params)


def _instance(card: Card, toks: list[Token], syntax: ElementSyntax) -> InstanceCard:
    words: list[Token] = []
    i = 1
    while i < len(toks):
        tok = toks[i]
        if tok.kind == WORD and tok.text == "params:":
            i += 1
            break
        if tok.kind == WORD and i + 1 < len(toks) and toks[i + 1].text == "=":
            break
        if tok.kind != WORD:
            raise error(card, tok.start, f"unexpected {tok.text!r}: expected node names and a subcircuit name",
                        syntax)
        words.append(tok)
        i += 1
    if not words:
        raise error(card, _end(card), "missing subcircuit name", syntax)
    positional, keywords = split_args(card, toks, i, syntax)
    if positional:
        raise error(card, positional[0].start, f"unexpected {positional[0].text!r} among the parameters",
                    syntax, hint="instance parameters are written name=value")
    params = {}
    for key, values in keywords:
        if len(values) != 1:
            raise error(card, values[1].start, f"{key.text}= takes one value", syntax)
        if key.text in params:
            raise error(card, key.start, f"parameter '{key.text}' given twice", syntax)
        params[key.text] = parse_value(card, values[0], syntax, numparam=True)
    sub = words[-1]
    nodes = tuple(_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words[:-1])
    return InstanceCard(toks[0].text, card, nodes, sub.text, sub.start, params)


def _osdi_device(card: Card, toks: list[Token], syntax: ElementSyntax) -> ElementCard:
    """``Nname n1 n2 ... mname [name=value ...]``: the node count is the OSDI module's (checked later)."""
    words: list[Token] = []
    i = 1
    while i < len(toks):
        tok = toks[i]
        if tok.kind == WORD and i + 1 < len(toks) and toks[i + 1].text == "=":
            break
        if tok.kind != WORD:
            raise error(card, tok.start, f"unexpected {tok.text!r}: expected node names and a model name", syntax)
        words.append(tok)
        i += 1
    if len(words) < 2:
        raise error(card, _end(card), "expected at least one node and a model name", syntax)
    positional, keywords = split_args(card, toks, i, syntax)
    if positional:
        raise error(card, positional[0].start, f"unexpected {positional[0].text!r} among the parameters", syntax,
                    hint="instance parameters are written name=value")
    params = _keyword_params(card, keywords, syntax, "osdi")
    model = words[-1]
    if parse_number(model.text) is not None:
        raise error(card, model.start, f"expected a model name, found {model.text!r}", syntax)
    nodes = tuple(_GROUND_ALIASES.get(t.text) or sys.intern(t.text) for t in words[:-1])
    return ElementCard(toks[0].text, "osdi", card, nodes, model=(model.text, model.start), params=params)


def parse_element(card: Card, calls: "re.Pattern | None" = None) -> ElementCard | InstanceCard | list[ElementCard]:
    """Parse one element card (:func:`_parse_element`), its ``ddt()`` calls realised (:func:`realise_ddt`).

    ``calls`` matches calls of the netlist's ``.func`` functions that read the circuit
    (:func:`circuit_function_calls`): an R, C or L value calling one is behavioural.
    """
    parsed = _parse_element(card, calls)
    if isinstance(parsed, InstanceCard):
        return parsed
    items = parsed if isinstance(parsed, list) else [parsed]
    if not any(item.expr is not None and any(isinstance(n, ex.Call) and n.func == "ddt" for n in ex.walk(item.expr[0]))
               for item in items):
        return parsed
    out: list[ElementCard] = []
    for item in items:
        out.extend(realise_ddt(item))
    return out


def realise_ddt(item: ElementCard) -> list[ElementCard]:
    """An element whose expression calls ``ddt(x)``, with each call replaced by the voltage of a node holding dx/dt.

    Each call gets an internal node ``<name>#ddt<k>`` carrying the charge ``-x``
    (a ``bcharge`` to ground) and 1 ohm to ground: its current law says
    ``v = dx/dt``, and at an operating point ``v = 0`` (ngspice's ``ddt`` is 0
    there too). The same construction as the behavioural capacitor's.
    """
    if item.expr is None:
        return [item]
    at = item.expr[1]
    extra: list[ElementCard] = []

    def visit(node):
        if isinstance(node, ex.Call) and node.func == "ddt":
            inner = ex.transform(node.args[0], visit)
            aux = f"{item.name}#ddt{len(extra) // 2 + 1}"
            extra.append(ElementCard(f"{aux}#q", "bcharge", item.card, (aux, "0"), expr=(ex.Unary("-", inner), at)))
            extra.append(ElementCard(f"{aux}#r", "resistor", item.card, (aux, "0"), value=(1.0, at)))
            return ex.Voltage(aux)
        return None

    item.expr = (ex.transform(item.expr[0], visit), at)
    return [item, *extra]


def _parse_element(card: Card, calls=None) -> ElementCard | InstanceCard | list[ElementCard]:
    """Parse one element card.

    Returns
    -------
    ElementCard, InstanceCard or list of ElementCard
        A list for an R, C or L whose value depends on V(), I() or time: the
        behavioural elements that realise it (see ``_behavioural_two_terminal``).

    Raises
    ------
    NetlistError
        Unsupported element letters, wrong node counts, missing or bad
        values, unknown parameters ... located at the offending token, with
        the card's expected form.
    """
    toks = card.tokens()
    head = toks[0]
    letter = head.text[0] if head.kind == WORD else ""
    syntax = ELEMENTS.get(letter)
    if syntax is None:
        if letter in UNSUPPORTED_ELEMENTS:
            raise NetlistError(
                f"{head.text}: element type '{letter.upper()}' ({UNSUPPORTED_ELEMENTS[letter]}) is not "
                f"supported by netdae", card.location(0),
                hint=f"netdae reads {supported_letters()}; replace it by an equivalent circuit of these")
        raise NetlistError(f"unknown card '{card.text.split(None, 1)[0]}'", card.location(0),
                           hint=f"element names start with one of {supported_letters()}; dot cards with '.'")
    toks = _unparenthesised_nodes(toks, letter)
    if letter == "c" and len(toks) > 4 and toks[3].kind == WORD and toks[3].text == "q" and toks[4].text == "=":
        # ngspice's charge-defined capacitor: Cname n+ n- Q={expr}
        return ElementCard(toks[0].text, "bcharge", card, _nodes(card, toks, 2, syntax),
                           expr=_behavioural(card, toks, 5, syntax))
    if letter in "rcl":
        return _two_terminal(card, toks, syntax, {"r": "resistor", "c": "capacitor", "l": "inductor"}[letter],
                             calls)
    if letter == "k":
        return _coupling(card, toks, syntax)
    if letter in "vi":
        return _source(card, toks, syntax, "vsource" if letter == "v" else "isource")
    if letter in "efgh":
        return _controlled(card, toks, syntax, letter)
    if letter == "b":
        return _b_source(card, toks, syntax)
    if letter == "d":
        return _device(card, toks, syntax, "diode", 2)
    if letter == "q":
        return _device(card, toks, syntax, "bjt", 3)
    if letter == "m":
        return _device(card, toks, syntax, "mosfet", 4)
    if letter == "j":
        return _device(card, toks, syntax, "jfet", 3)
    if letter == "z":
        return _device(card, toks, syntax, "mesfet", 3)
    if letter in "sw":
        return _switch(card, toks, syntax, letter)
    if letter == "n":
        return _osdi_device(card, toks, syntax)
    if letter == "t":
        return _tline(card, toks, syntax)
    if letter in _LOSSY_KINDS:
        return _lossy_line(card, toks, syntax, letter)
    if letter == "u":
        return _urc(card, toks, syntax)
    return _instance(card, toks, syntax)


def unknown_node_hint(node: str, port_nodes: Mapping[str, str], example: str, ngspice: str = "") -> str:
    """The hint at a card naming a node the circuit lacks: where ``node`` is the hierarchical name of a
    subcircuit port (``x1.out``), which names no node (the port *is* the node the instance connects to
    it), the node to write instead, then ``ngspice`` (what ngspice does with the name); else how
    subcircuit nodes are named (``example``, e.g. ``x1.mid``)."""
    connected = port_nodes.get(node)
    if connected is None:
        return f"subcircuit nodes are named hierarchically, e.g. {example}"
    instance, _, port = node.rpartition(".")
    if connected == "0":
        what = (f"'{port}' is a port of subcircuit instance {instance}, which connects ground to it: "
                "the name is ground's, 0 V, so leave it out")
    else:
        what = (f"'{port}' is a port of subcircuit instance {instance}, which connects node '{connected}' to it, "
                f"and a port has no name of its own inside the instance: write v({connected})")
    return what + (f"; {ngspice}" if ngspice else "")
