"""Cards to a :class:`~netdae.netlist.statements.Netlist`: structure and dot cards.

:func:`parse` reads the files (:mod:`netdae.netlist.reader`), sorts every
card into the subcircuit definition it belongs to, parses element cards
(:mod:`netdae.netlist.elements`) and dot cards, and settles what needs the
whole netlist (which word of a Q card is the model, whether a word after a
resistor's nodes is a model or a parameter). Nothing is evaluated here.
"""

from __future__ import annotations

from ..circuit import Diagnostic
from ..devices.model_names import VECTOR_PARAMETERS
from ..errors import NetlistError
from ..kinds import KINDS, MODEL_TYPES, Kind
from . import expr as ex
from .elements import (IDENT, circuit_function_calls, error, parse_element, parse_expr, parse_node, parse_value,
                       split_args)
from .lines import EXPR, PUNCT, STRING, WORD, Card, Token, no_gc
from .measure import parse_measure
from .steps import parse_step
from .numbers import ignored_text, parse_number
from .compat import SWITCH_DEFAULTS, SWITCH_FORMS, switch_form
from .reader import Deck, read_deck
from .size import MAX_SUBCKT_DEPTH
from .statements import (AnalysisCard, Definition, ElementCard, FuncDef, InitialCard, ModelCard, Netlist,
                         ParamDef)
from .syntax import DOT_ALIASES, DOT_CARDS, ELEMENTS, IGNORED_DOT_CARDS, UNSUPPORTED_DOT_CARDS

__all__ = ["parse", "build", "add_cards"]

_IN_SUBCKT = {".param", ".func", ".model", ".subckt", ".ends", ".global", ".ic", ".nodeset"}
_PRINT_TYPES = {"tran", "ac", "dc", "op", "noise", "disto", "tf", "pz", "sens"}


def parse(source, *, path: str | None = None, behavior=None) -> Netlist:
    """Read and parse a netlist (no evaluation, no subcircuit expansion).

    Parameters
    ----------
    source : str or os.PathLike
        A file name or the netlist text (see :func:`netdae.netlist.load`).
    path : str, optional
        Name of the text for locations and relative includes.
    behavior : str, optional
        ngspice's compatibility mode (``set ngbehavior=`` value; ``""``: none); default: the
        ``.spiceinit`` next to the netlist or in the working directory
        (:func:`netdae.netlist.reader.read_deck`).

    Returns
    -------
    Netlist

    Raises
    ------
    NetlistError
        Any syntax error, located at its token.
    """
    with no_gc():
        return build(read_deck(source, path=path, behavior=behavior))


def build(deck: Deck) -> Netlist:
    """Parse the cards of a :class:`~netdae.netlist.reader.Deck`."""
    top = Definition(None)
    net = Netlist(title=deck.title, path=deck.path, top=top, diagnostics=list(deck.notes),
                  files=list(deck.files), osdi=list(deck.osdi), behavior=deck.behavior)
    stack = [top]
    calls = circuit_function_calls(card for card in deck.cards if card.text[0] == ".")
    net.diagnostics.extend(_title_like_a_card(deck, calls))
    for index, card in enumerate(deck.cards):
        if card.text[0] == ".":
            depth = len(stack)
            closed = stack[-1]
            _dot_card(card, stack, net)
            if len(stack) > depth:  # a .subckt
                stack[-1].span = (index,)
            elif len(stack) < depth:  # an .ends
                closed.span = (*closed.span, index)
                if closed.first is not None:
                    _repeated(closed, deck)
                    net.diagnostics.extend(closed.card.take_notes())
        else:
            try:
                item = parse_element(card, calls)
            except NetlistError as exc:
                if stack[-1].name is None:
                    raise
                stack[-1].errors.append(exc)  # raised if the subcircuit is used (ngspice reads only those)
                card.forget_tokens()
                continue
            if type(item) is list:
                stack[-1].items.extend(item)
            else:
                stack[-1].items.append(item)
            card.forget_tokens()
        if card.notes:
            net.diagnostics.extend(card.take_notes())
    if len(stack) > 1:
        raise NetlistError(f".subckt {stack[-1].name}: no matching .ends", stack[-1].card.location(0),
                           expected=DOT_CARDS[".ends"], hint="close the definition with '.ends'")
    _resolve_ako(top, top)
    _settle(top)
    return net


def _connects(item, deck: Deck) -> bool:
    """Whether every node of a parsed element card (ground aside) is a word of the deck's other element cards."""
    nodes = getattr(item, "nodes", None) or ()
    if not nodes:  # forms judged with the models (a transistor's words): its first two words
        nodes = tuple(t.text for t in (getattr(item, "positional", None) or ())[:2])
    nodes = [n for n in nodes if n not in ("0", "gnd")]
    if not nodes:
        return False
    words = {w.lower() for c in deck.cards if c.text[0] != "." for w in c.text.split()[1:]}
    return all(n in words for n in nodes)


def _title_like_a_card(deck: Deck, calls) -> list[Diagnostic]:
    """A warning when the title line (the first line, as in ngspice) reads as a dot card or an element card.

    A netlist without its title line loses its first card so, silently in ngspice.
    """
    title = deck.title
    if not title or not deck.path or title[0] == "*":
        return []
    card = Card(title, deck.path, [(0, 1, 1)])
    word = title.split()[0].lower()
    if word[0] == ".":
        what = f"a {word} card" if DOT_ALIASES.get(word, word) in DOT_CARDS else None
    elif word[0] in ELEMENTS:
        try:
            item = parse_element(card, calls)
        except NetlistError:
            item = None
        # an element only when it would connect to the circuit ('V1 in 0 1' above 'R1 in a 1k'); a title
        # such as 'Ring oscillator 5 stages' reads as a resistor too, between nodes nothing else names
        what = f"an element card ({word})" if item is not None and _connects(item, deck) else None
    else:
        what = None
    if what is None:
        return []
    return [Diagnostic("warning", f"the first line is the title (as in ngspice), but '{title}' reads as {what}: it is "
                       "not part of the circuit; if it is meant as a card, add a title line above it",
                       card.location(0))]


def add_cards(net: Netlist, cards: list[Card]) -> None:
    """Parse top-level dot cards into ``net`` (the cards a ``.control`` block's script made).

    Raises
    ------
    NetlistError
        As :func:`build`, located at the command that made the card.
    """
    stack = [net.top]
    for card in cards:
        _dot_card(card, stack, net)
        if card.notes:
            net.diagnostics.extend(card.take_notes())


#: Every model type name netdae knows (an AKO card may restate its base's).
MODEL_TYPE_NAMES = frozenset(t for types in MODEL_TYPES.values() for t in types)


def _resolve_ako(scope: Definition, top: Definition) -> None:
    """PSpice's AKO models (``.model new ako:base [type] (changes)``) as copies of their base.

    ngspice's PSpice mode (``ako_model``) looks the base up in the same subcircuit, then at
    the top level, and appends the changes to a copy of its parameters (the last value of a
    parameter wins); the type, when given, must be the base's. Only cards in the mode's scope
    are resolved; the others stay AKO models, which elaboration refuses by name. A base
    parameter's location becomes the ``ako:`` word of the new card.
    """
    for model in list(scope.models.values()):
        if model.type.startswith("ako:") and model.card.compat and scope.models.get(model.name) is model:
            _ako_model(model, scope, top, ())
    for sub in scope.subckts.values():
        _resolve_ako(sub, top)


def _ako_model(model: ModelCard, scope: Definition, top: Definition, chain: tuple) -> ModelCard:
    card = model.card
    at = max(card.text.find("ako:"), 0)
    base_name = model.type[4:]
    form = ".model mname ako:base type (name=value ...)"
    if model.name in chain:
        raise error(card, at, "AKO models refer to each other in a cycle: " + " -> ".join(chain + (model.name,)), form)
    base = scope.models.get(base_name) or top.models.get(base_name)
    if base is None:
        raise error(card, at + 4, f"no model '{base_name}' for this AKO model in {'.subckt ' + scope.name if scope.name else 'the netlist'} "
                    "or at the top level (ngspice: 'no model found')", form,
                    hint=f"define .model {base_name} in the same subcircuit or at the top level")
    if base.type.startswith("ako:"):
        base = _ako_model(base, scope if base_name in scope.models else top, top, chain + (model.name,))
    stated = [f for f in model.flags if f in MODEL_TYPE_NAMES]
    if stated and stated[0] != base.type:
        raise error(card, model.flags[stated[0]], f"type '{stated[0]}' differs from the type '{base.type}' of its base "
                    f"model '{base_name}' (ngspice: 'Original and new type for AKO model disagree')", form,
                    hint=f"write {base.type}")
    params = {k: (v[0], at) for k, v in base.params.items()}
    params.update(model.params)
    strings = {k: (v[0], at) for k, v in base.strings.items()} | model.strings
    flags = {k: at for k in base.flags} | {k: v for k, v in model.flags.items() if k not in MODEL_TYPE_NAMES}
    vectors = {k: [(v[0], at) for v in vals] for k, vals in base.vectors.items()} | model.vectors
    new = ModelCard(model.name, base.type, card, params, strings, flags, vectors)
    owner = scope if scope.models.get(model.name) is model else top
    owner.models[model.name] = new
    owner.items[owner.items.index(model)] = new
    return new


# ---------------------------------------------------------------------------
def _dot_card(card: Card, stack: list[Definition], net: Netlist) -> None:
    toks = card.tokens()
    word = DOT_ALIASES.get(toks[0].text, toks[0].text)
    scope = stack[-1]
    if word in UNSUPPORTED_DOT_CARDS:
        raise NetlistError(f"{word}: {UNSUPPORTED_DOT_CARDS[word]} is not supported by netdae",
                           card.location(0),
                           hint="netdae runs .op, .dc, .ac, .tran, .pz, .tf, .noise and .sens; remove the card or run it "
                                "in ngspice")
    if card.script is not None:  # a .control block that uses the control language: run after elaboration
        net.scripts.append(card)
        return
    if word == ".csparam":
        net.csparams.append(card)
    if word in IGNORED_DOT_CARDS:
        net.diagnostics.append(Diagnostic("note", f"{word} skipped: it sets {IGNORED_DOT_CARDS[word]}",
                                          card.location(0)))
        return
    if word not in DOT_CARDS:
        raise NetlistError(f"unknown dot card '{toks[0].text}'", card.location(0),
                           hint="netdae reads " + " ".join(sorted(DOT_CARDS)))
    if scope.name is not None and word not in _IN_SUBCKT:
        where = f" (line {scope.card.line})" if scope.card is not None else ""
        raise NetlistError(f"{word} is not allowed inside .subckt {scope.name}{where}: it acts on the whole circuit",
                           card.location(0),
                           hint=f"move the card to the top level, after .subckt {scope.name}'s '.ends' (or close the "
                                ".subckt before this card if its '.ends' is missing); name subcircuit nodes "
                                "hierarchically there, e.g. v(x1.mid)")
    _HANDLERS[word](card, toks, stack, net)


def _subckt(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    form = DOT_CARDS[".subckt"]
    if len(toks) < 2 or toks[1].kind != WORD:
        raise error(card, len(card.text), "missing subcircuit name", form)
    name = toks[1].text
    if len(stack) > MAX_SUBCKT_DEPTH:
        raise error(card, toks[1].start, f"subcircuit definitions nested deeper than {MAX_SUBCKT_DEPTH} levels",
                    form, hint="close the enclosing definitions with .ends first")
    ports: list[str] = []
    i = 2
    while i < len(toks):
        tok = toks[i]
        if tok.kind == WORD and tok.text == "params:":
            i += 1
            break
        if tok.kind == WORD and i + 1 < len(toks) and toks[i + 1].text == "=":
            break
        if tok.kind == WORD and tok.text == "optional:":
            raise error(card, tok.start, "PSpice's 'optional:' ports are not read by ngspice 39, nor by netdae",
                        form, hint="list every port, and connect it on every instance")
        node = parse_node(card, tok, form)
        if node == "0":
            card.warn(tok.start, f"port '{tok.text}' is ground: inside the subcircuit it stays ground, and the node "
                      "an instance connects to it is not connected by the subcircuit (as ngspice does)")
        if node in ports:
            raise error(card, tok.start, f"port '{node}' listed twice", form)
        ports.append(node)
        i += 1
    positional, keywords = split_args(card, toks, i, form)
    if positional:
        raise error(card, positional[0].start, f"unexpected {positional[0].text!r} among the parameters",
                    form, hint="subcircuit parameters are written name=default")
    parent = stack[-1]
    sub = Definition(name, tuple(ports), parent=parent, card=card, first=parent.subckts.get(name))
    seen = set()
    for key, values in keywords:
        _check_param_name(card, key, form)
        if key.text in seen:
            raise error(card, key.start, f"parameter '{key.text}' listed twice", form)
        if len(values) != 1:
            raise error(card, values[1].start, f"{key.text}= takes one value", form)
        seen.add(key.text)
        sub.defaults.append(ParamDef(key.text, parse_value(card, values[0], form, numparam=True), card,
                                     key.start))
    if sub.first is None:
        parent.subckts[name] = sub
    stack.append(sub)


def _ends(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    if len(stack) == 1:
        raise error(card, 0, ".ends without a matching .subckt", DOT_CARDS[".ends"])
    scope = stack[-1]
    if len(toks) > 1:
        if toks[1].kind != WORD:
            raise error(card, toks[1].start, f"expected a subcircuit name, found {toks[1].text!r}", DOT_CARDS[".ends"])
        if toks[1].text != scope.name:
            card.warn(toks[1].start, f"'.ends {toks[1].text}' closes .subckt {scope.name} (opened at "
                      f"{scope.card.file}:{scope.card.line}); ngspice ignores the name after .ends, and so does netdae")
        if len(toks) > 2:
            raise error(card, toks[2].start, f"unexpected {toks[2].text!r}", DOT_CARDS[".ends"])
    stack.pop()


def _same_text(first, second) -> bool:
    """Whether two sequences of cards read alike (case and blanks aside)."""
    def words(cards):
        return [" ".join(c.text.lower().split()) for c in cards]
    return len(first) == len(second) and words(first) == words(second)


def _repeated(sub: Definition, deck: Deck) -> None:
    """Judge a subcircuit defined again in the same scope, at its ``.ends``: ngspice 39 keeps the first
    definition ("redefinition of .subckt ..., ignored"); a repetition card for card (a library section
    included twice) is dropped with a warning, another is an error."""
    first = sub.first
    a, b = first.span, sub.span
    # the .subckt cards read alike after their keyword, the bodies card for card; the .ends cards do not matter
    header = [" ".join(c.text.lower().split()[1:]) for c in (first.card, sub.card)]
    if header[0] == header[1] and _same_text(deck.cards[a[0] + 1:a[1]], deck.cards[b[0] + 1:b[1]]):
        sub.card.warn(0, f"subcircuit '{sub.name}' is defined again, identically (first at {first.card.file}:"
                      f"{first.card.line}): the first definition is used, as ngspice 39 does")
        return
    name_at = sub.card.text.lower().find(sub.name, len(".subckt"))
    raise error(sub.card, max(name_at, 0), f"subcircuit '{sub.name}' is defined twice (first at "
                f"{first.card.file}:{first.card.line})", DOT_CARDS[".subckt"],
                hint="ngspice 39 uses the first definition and ignores this one: remove or rename one")


def _check_param_name(card: Card, tok: Token, form: str) -> None:
    if tok.kind != WORD or not IDENT.match(tok.text):
        raise error(card, tok.start, f"bad parameter name {tok.text!r}", form,
                    hint="names start with a letter or '_' and contain letters, digits, '_' or '.'")
    if tok.text in ex.RESERVED:
        raise error(card, tok.start, f"'{tok.text}' is reserved and cannot be a parameter name", form)


def _param(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    form = DOT_CARDS[".param"]
    i = 1
    n = len(toks)
    if n == 1:
        raise error(card, len(card.text), "missing name=value", form)
    while i < n:
        tok = toks[i]
        if tok.kind == PUNCT and tok.text == ",":
            i += 1
            continue
        _check_param_name(card, tok, form)
        if i + 1 >= n or toks[i + 1].text != "=":
            raise error(card, toks[i + 1].start if i + 1 < n else len(card.text),
                        f"expected '=' after parameter name '{tok.text}'", form,
                        hint="write name=value; a value with blanks needs {braces} or 'quotes'")
        end = _value_end(toks, i + 2)
        if end == i + 3 and toks[i + 2].kind == STRING:  # "1k": ngspice 39 reads the text inside as the expression
            toks[i + 2] = Token(toks[i + 2].text, EXPR, toks[i + 2].start, toks[i + 2].end)
        if end == i + 2 or toks[i + 2].kind not in (WORD, EXPR, PUNCT) or toks[i + 2].text in ",)=":
            raise error(card, toks[i + 1].start, f"missing value for parameter '{tok.text}'", form)
        if end == i + 3:
            value = parse_value(card, toks[i + 2], form, f"value of '{tok.text}'", numparam=True)
        else:
            # a value written with blanks or parentheses ('.param a = 1 + 2'): the text up to the next name=
            start, stop = toks[i + 2].start, toks[end - 1].end
            text = card.text[start:stop]
            if end < n and any(c in " \t" for c in text):
                raise error(card, start, f"the value of '{tok.text}' contains blanks and another assignment "
                            "follows: ngspice would read only the text before the first blank", form,
                            hint="put the value in {braces} or 'quotes', or the assignment on its own .param card")
            if any(t.kind == EXPR for t in toks[i + 2 : end]):
                raise error(card, start, f"bad value of '{tok.text}': braces or quotes around part of it", form,
                            hint="put the whole value in {braces}")
            value = (parse_expr(card, text, start, ex.PARAM, form), start)
        stack[-1].params.append(ParamDef(tok.text, value, card, tok.start))
        i = end


def _value_end(toks: list[Token], i: int) -> int:
    """Index just after a ``.param`` value starting at token ``i``: before the next ``name =`` or the end."""
    n = len(toks)
    j = i
    while j < n:
        if j > i and toks[j].kind == WORD and j + 1 < n and toks[j + 1].kind == PUNCT and toks[j + 1].text == "=":
            break
        j += 1
    while j > i + 1 and toks[j - 1].kind == PUNCT and toks[j - 1].text == ",":
        j -= 1  # '.param a=1, b=2'
    return j


def _func(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    form = DOT_CARDS[".func"]
    if len(toks) < 4 or toks[1].kind != WORD or toks[2].text != "(":
        raise error(card, toks[1].start if len(toks) > 1 else len(card.text), "expected name(args)", form)
    name = toks[1].text
    if not IDENT.match(name):
        raise error(card, toks[1].start, f"bad function name {name!r}", form)
    if name in ex.FUNCTIONS or name in ("if", "ternary_fcn", "log", "arctan", "sqr"):
        raise error(card, toks[1].start, f"'{name}' is a built-in function and cannot be redefined", form)
    args: list[str] = []
    i = 3
    while i < len(toks) and toks[i].text != ")":
        tok = toks[i]
        if tok.kind == PUNCT and tok.text == ",":
            i += 1
            continue
        _check_param_name(card, tok, form)
        if tok.text in args:
            raise error(card, tok.start, f"argument '{tok.text}' listed twice", form)
        args.append(tok.text)
        i += 1
    if i >= len(toks):
        raise error(card, toks[2].start, "missing ')' after the arguments", form)
    i += 1
    if i < len(toks) and toks[i].kind == PUNCT and toks[i].text == "=":
        i += 1
    if i >= len(toks):
        raise error(card, len(card.text), "missing function body", form)
    body_tok = toks[i]
    if body_tok.kind == EXPR and i == len(toks) - 1:
        text, base = body_tok.text, body_tok.start + 1
    else:
        text, base = card.text[body_tok.start:], body_tok.start
    circuit = False
    refusal = None
    # the arguments are the body's names, whatever the rules: ngspice substitutes them as text before its
    # B-source parser would read an argument named e as the constant
    locals_ = frozenset(args)
    try:
        body = parse_expr(card, text, base, ex.PARAM, form, locals_)
    except NetlistError as exc:
        nested = "unparenthesised in the true branch" in exc.message
        if not nested and "is only allowed in behavioural" not in exc.message \
                and "'time' is only available" not in exc.message:
            raise
        # ngspice expands a .func like a macro, so its body may read the circuit where a behavioural
        # expression calls it: such a body is read by the behavioural rules it is expanded into
        body = parse_expr(card, text, base, ex.BEHAVIOURAL, form, locals_)
        circuit = any(type(node) in (ex.Voltage, ex.Current, ex.Time) for node in ex.walk(body))
        if nested:
            # ngspice's parameter evaluator reads such a body otherwise, its B-source parser as C does:
            # an error where a parameter expression calls the function, not where a behavioural one does
            refusal = f"{exc.message} (.func at {card.file}:{card.line}; hint: {exc.hint})"
        for node in ex.walk(body):
            if type(node) is ex.Call and node.func == "ddt":
                raise error(card, base, "ddt() in a .func body is not supported by netdae", form,
                            hint="write ddt(...) into the B source and pass it to the function as an argument")
    if refusal is None and not circuit:
        try:
            behavioural = parse_expr(card, text, base, ex.BEHAVIOURAL, form, locals_)
        except NetlistError:
            behavioural = None
    else:
        behavioural = body
    scope = stack[-1]
    if name in scope.funcs:
        first = scope.funcs[name].card
        raise error(card, toks[1].start, f"function '{name}' is defined twice (first at {first.file}:"
                    f"{first.line})", form)
    scope.funcs[name] = FuncDef(name, tuple(args), body, card, circuit, behavioural, refusal)


def _model(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    form = DOT_CARDS[".model"]
    if len(toks) < 3 or toks[1].kind != WORD or toks[2].kind != WORD:
        raise error(card, toks[-1].end if len(toks) > 1 else len(card.text), "expected a model name and type",
                    form)
    name, mtype = toks[1].text, toks[2].text
    params: dict = {}
    strings: dict = {}
    flags: dict = {}
    vectors: dict = {}
    i, n = 3, len(toks)
    while i < n:
        tok = toks[i]
        if tok.kind == PUNCT and tok.text in "(),":
            i += 1
            continue
        if tok.kind != WORD:
            raise error(card, tok.start, f"expected name=value, found {tok.text!r}", form)
        if i + 1 < n and toks[i + 1].kind == PUNCT and toks[i + 1].text == "=":
            if i + 2 >= n or toks[i + 2].kind not in (WORD, EXPR, STRING):
                raise error(card, toks[i + 1].start, f"missing value after '{tok.text}='", form)
            value = toks[i + 2]
            if i + 4 < n and toks[i + 3].text == "," and toks[i + 4].kind in (WORD, EXPR) and not (
                    i + 5 < n and toks[i + 5].text == "="):
                raise error(card, toks[i + 4].start, f"{tok.text}= takes one value", form)
            if tok.text in params or tok.text in strings:
                card.warn(tok.start, f"model parameter '{tok.text}' given twice: the last value is used "
                          "(as ngspice does)")
                params.pop(tok.text, None)
                strings.pop(tok.text, None)
            if value.kind == STRING or (tok.text == "version" and value.kind == WORD and ignored_text(value.text)):
                # version=4.8.1: ngspice's BSIM models read the version as text (a number with ignored text else)
                strings[tok.text] = (value.text, value.start)
            elif value.kind == WORD and parse_number(value.text) is None and not IDENT.match(value.text):
                params[tok.text] = (parse_expr(card, value.text, value.start, ex.PARAM, form), value.start)  # is=isv*2
            else:
                params[tok.text] = parse_value(card, value, form)
            i += 3
            if tok.text in VECTOR_PARAMETERS.get(mtype, ()):
                # ngspice's vector parameters (a CPL's matrices): the numbers up to the next name=
                more = [params[tok.text]]
                while i < n and toks[i].kind in (WORD, EXPR) and not (i + 1 < n and toks[i + 1].text == "="):
                    more.append(parse_value(card, toks[i], form))
                    i += 1
                while i < n and toks[i].kind == PUNCT and toks[i].text in "(),":
                    i += 1
                if len(more) > 1:
                    del params[tok.text]
                    vectors[tok.text] = more
                continue
            if i < n and toks[i].kind == WORD and not IDENT.match(toks[i].text) and not (
                    i + 1 < n and toks[i + 1].text == "="):
                raise error(card, toks[i].start, f"the value of '{tok.text}' goes on after a blank "
                            f"({toks[i].text!r}): ngspice would read only {value.text!r} and ignore the rest", form,
                            hint=f"write {tok.text}={{...}} with the whole expression in braces")
        else:
            flags[tok.text] = tok.start  # a bare name: ngspice sets a flag parameter (or ignores the name)
            i += 1
    if card.compat and mtype in SWITCH_DEFAULTS:
        form_kind = switch_form(mtype, params)
        if form_kind is None:
            smooth, native, _ = SWITCH_FORMS[mtype]
            raise error(card, toks[2].start, f"a PSpice {mtype} model needs {'/'.join(smooth)} (PSpice's switch) or "
                        f"{'/'.join(native)} (ngspice's), as ngspice's PSpice mode reads it ('Bad switch model')", form)
        if form_kind != "smooth":
            mtype = form_kind  # ngspice's own switch: .model name sw (vt= vh= ron= roff=)
    scope = stack[-1]
    if name in scope.models:
        first = scope.models[name].card
        if _same_text([first], [card]):
            card.warn(toks[1].start, f"model '{name}' is defined again, identically (first at {first.file}:"
                      f"{first.line}): the first definition is used, as ngspice 39 does")
            return
        raise error(card, toks[1].start, f"model '{name}' is defined twice (first at {first.file}:{first.line})",
                    form, hint="ngspice 39 silently uses the first definition: remove or rename one")
    model = ModelCard(name, mtype, card, params, strings, flags, vectors)
    scope.models[name] = model
    scope.items.append(model)


def _global(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    for tok in toks[1:]:
        node = parse_node(card, tok, DOT_CARDS[".global"])
        if node != "0":
            net.globals.setdefault(node, (card, tok.start))


def _title(card: Card, toks: list[Token], stack: list[Definition], net: Netlist) -> None:
    net.title = card.raw[len(".title"):].strip()


def _values(card: Card, toks: list[Token], start: int, form: str) -> list:
    out = []
    for tok in toks[start:]:
        if tok.kind == PUNCT and tok.text == ",":
            continue
        out.append(parse_value(card, tok, form))
    return out


def _op(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    if len(toks) > 1:
        raise error(card, toks[1].start, f"unexpected {toks[1].text!r}", DOT_CARDS[".op"])
    net.analyses.append(AnalysisCard("op", card, {}))


def _tran(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".tran"]
    uic = False
    rest = []
    for tok in toks[1:]:
        if tok.kind == WORD and tok.text == "uic":
            uic = True
        else:
            rest.append(tok)
    vals = _values(card, rest, 0, form)
    if len(vals) < 2:
        raise error(card, len(card.text), f"expected tstep and tstop, found {len(vals)} value(s)", form)
    if len(vals) > 4:
        raise error(card, vals[4][1], "too many values", form)
    args = dict(zip(("tstep", "tstop", "tstart", "tmax"), vals))
    args["uic"] = uic
    net.analyses.append(AnalysisCard("tran", card, args))


def _ac(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".ac"]
    if len(toks) < 2 or toks[1].text not in ("dec", "oct", "lin"):
        raise error(card, toks[1].start if len(toks) > 1 else len(card.text),
                    "expected the sweep type dec, oct or lin", form)
    vals = _values(card, toks, 2, form)
    if len(vals) != 3:
        raise error(card, vals[3][1] if len(vals) > 3 else len(card.text),
                    f"expected points, fstart and fstop, found {len(vals)} value(s)", form)
    net.analyses.append(AnalysisCard("ac", card, {"variation": toks[1].text, "points": vals[0],
                                                  "fstart": vals[1], "fstop": vals[2]}))


def _dc(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".dc"]
    items = [t for t in toks[1:] if not (t.kind == PUNCT and t.text == ",")]
    if len(items) not in (4, 8):
        raise error(card, items[8].start if len(items) > 8 else len(card.text),
                    f"expected one or two sweeps of 4 items (source start stop step), found {len(items)} item(s)",
                    form)
    sweeps = []
    for k in range(0, len(items), 4):
        src = items[k]
        if src.kind != WORD or parse_number(src.text) is not None:
            raise error(card, src.start, f"expected a source name or temp, found {src.text!r}", form)
        sweeps.append((src.text, src.start, *[parse_value(card, t, form) for t in items[k + 1 : k + 4]]))
    net.analyses.append(AnalysisCard("dc", card, {"sweeps": sweeps}))


def _pz(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".pz"]
    items = [t for t in toks[1:] if not (t.kind == PUNCT and t.text == ",")]
    nodes = []
    for k, what in enumerate(("input node in+", "input node in-", "output node out+", "output node out-")):
        if k >= len(items):
            raise error(card, len(card.text), f"missing the {what} (four nodes, then cur|vol and pol|zer|pz)",
                        form, hint="e.g. .pz in 0 out 0 vol pz")
        nodes.append((parse_node(card, items[k], form), items[k].start))
    words = []
    for k, (choices, what) in enumerate(((("cur", "vol"), "the input type"), (("pol", "zer", "pz"), "the analysis"))):
        if 4 + k >= len(items):
            raise error(card, len(card.text), f"missing {what} ({'|'.join(choices)})", form,
                        hint="cur: output voltage over input current; vol: voltage gain; pol: poles only, "
                             "zer: zeros only, pz: both")
        tok = items[4 + k]
        if tok.kind != WORD or tok.text not in choices:
            raise error(card, tok.start, f"expected {what} {' or '.join(choices)}, found {tok.text!r}", form)
        words.append(tok.text)
    if len(items) > 6:
        raise error(card, items[6].start, f"unexpected {items[6].text!r}", form)
    net.analyses.append(AnalysisCard("pz", card, {"nodes": nodes, "input_type": words[0], "what": words[1]}))


def _output(card: Card, toks: list[Token], form: str, hint: str, kinds: tuple, expected: str,
            what: str) -> tuple[Token, list, list[Token]]:
    """The output ``v(n[,m])`` (or ``i(source)`` when ``"i"`` is in ``kinds``) at ``toks[1]`` (``.tf``,
    ``.noise``, ``.sens``).

    Returns the output's head token, its arguments as ``(name, offset)`` (nodes read as nodes) and the
    tokens after it. Errors are located; ``expected`` and ``what`` name the output.
    """
    n = len(toks)
    tok = toks[1]
    if tok.kind != WORD or tok.text not in kinds or n < 3 or toks[2].text != "(":
        raise error(card, tok.start, f"expected {expected}, found {tok.text!r}", form, hint=hint)
    j, args = 3, []
    while j < n and toks[j].text != ")":
        if toks[j].kind == WORD:
            args.append((parse_node(card, toks[j], form) if tok.text == "v" else toks[j].text, toks[j].start))
        elif toks[j].text != ",":
            raise error(card, toks[j].start, f"unexpected {toks[j].text!r} in the {what}", form, hint=hint)
        j += 1
    if j >= n:
        raise error(card, tok.start, f"unterminated {what} {tok.text}(", form, hint=hint)
    limit = 2 if tok.text == "v" else 1
    if not args or len(args) > limit:
        raise error(card, tok.start, f"{tok.text}(...) takes {'one or two nodes' if limit == 2 else 'one source'}, "
                    f"found {len(args)}", form, hint=hint)
    return tok, args, toks[j + 1:]


def _output_and_source(card: Card, toks: list[Token], form: str, hint: str, kinds: tuple, expected: str,
                       what: str) -> tuple[Token, list, list[Token]]:
    """The output (:func:`_output`), then an input source's name (``.tf``, ``.noise``).

    Returns the output's head token, its arguments and the tokens from the source's name on.
    """
    tok, args, rest = _output(card, toks, form, hint, kinds, expected, what)
    if not rest:
        raise error(card, len(card.text), "missing the input source (an independent V or I source)", form, hint=hint)
    if rest[0].kind != WORD or parse_number(rest[0].text) is not None:
        raise error(card, rest[0].start, f"expected the input source's name, found {rest[0].text!r}", form, hint=hint)
    return tok, args, rest


def _tf(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".tf"]
    hint = "e.g. .tf v(out) vin, .tf v(out,ref) iin or .tf i(vload) vin"
    n = len(toks)
    if n < 2:
        raise error(card, len(card.text), "missing the output variable and the input source", form, hint=hint)
    tok, args, rest = _output_and_source(card, toks, form, hint, ("v", "i"),
                                         "the output v(node), v(node,node) or i(vsource)", "output variable")
    if len(rest) > 1:
        raise error(card, rest[1].start, f"unexpected {rest[1].text!r}", form)
    net.analyses.append(AnalysisCard("tf", card, {"output": (tok.text, tuple(args), tok.start),
                                                  "source": (rest[0].text, rest[0].start)}))


def _sens(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".sens"]
    hint = "e.g. .sens v(out), .sens v(out,ref) dc, .sens i(vsrc) or .sens v(out) ac dec 10 1k 1meg"
    if len(toks) < 2:
        raise error(card, len(card.text), "missing the output variable", form, hint=hint)
    tok, args, rest = _output(card, toks, form, hint, ("v", "i"), "the output v(node), v(node,node) or i(vsource)",
                              "output variable")
    found = {"output": (tok.text, tuple(args), tok.start)}
    if rest and rest[0].text == "dc":
        rest = rest[1:]
        if rest:
            raise error(card, rest[0].start, f"unexpected {rest[0].text!r} after dc", form, hint=hint)
    elif rest:
        if rest[0].text != "ac":
            raise error(card, rest[0].start, f"expected dc, ac or the end of the card, found {rest[0].text!r}", form,
                        hint=hint)
        if len(rest) < 2 or rest[1].text not in ("dec", "oct", "lin"):
            raise error(card, rest[1].start if len(rest) > 1 else len(card.text),
                        "expected the sweep type dec, oct or lin after ac", form, hint=hint)
        vals = _values(card, rest, 2, form)
        if len(vals) != 3:
            raise error(card, vals[3][1] if len(vals) > 3 else len(card.text),
                        f"expected points, fstart and fstop, found {len(vals)} value(s)", form, hint=hint)
        found.update(variation=rest[1].text, points=vals[0], fstart=vals[1], fstop=vals[2])
    net.analyses.append(AnalysisCard("sens", card, found))


def _noise(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".noise"]
    hint = "e.g. .noise v(out) vin dec 10 1 1meg, or .noise v(out,ref) iin lin 100 1k 100k 10"
    n = len(toks)
    if n < 2:
        raise error(card, len(card.text), "missing the output voltage v(out[,ref])", form, hint=hint)
    _, nodes, rest = _output_and_source(card, toks, form, hint, ("v",),
                                        "the output voltage v(node) or v(node,ref)", "output voltage")
    if len(rest) < 2 or rest[1].text not in ("dec", "oct", "lin"):
        raise error(card, rest[1].start if len(rest) > 1 else len(card.text),
                    "expected the sweep type dec, oct or lin", form, hint=hint)
    vals = _values(card, rest, 2, form)
    if len(vals) not in (3, 4):
        raise error(card, vals[4][1] if len(vals) > 4 else len(card.text),
                    f"expected points, fstart, fstop and optionally pts_per_summary, found {len(vals)} value(s)",
                    form, hint=hint)
    args = {"nodes": nodes, "source": (rest[0].text, rest[0].start), "variation": rest[1].text,
            "points": vals[0], "fstart": vals[1], "fstop": vals[2]}
    if len(vals) == 4:
        args["summary"] = vals[3]
    net.analyses.append(AnalysisCard("noise", card, args))


def _ic(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    word = DOT_ALIASES.get(toks[0].text, toks[0].text)
    form = DOT_CARDS[word]
    if stack[-1].name is None:
        target = net.ic if word == ".ic" else net.nodeset
    else:  # inside a subcircuit: the body's node names, applied to each instance
        local = InitialCard(word, card, [])
        stack[-1].items.append(local)
        target = local.entries
    i, n = 1, len(toks)
    if n == 1:
        raise error(card, len(card.text), "missing v(node)=value", form)
    while i < n:
        if toks[i].kind == PUNCT and toks[i].text == ",":
            i += 1
            continue
        ok = (i + 5 < n and toks[i].text == "v" and toks[i + 1].text == "(" and toks[i + 2].kind == WORD
              and toks[i + 3].text == ")" and toks[i + 4].text == "=")
        if not ok:
            raise error(card, toks[i].start, f"expected v(node)=value, found {toks[i].text!r}", form)
        node = parse_node(card, toks[i + 2], form)
        if stack[-1].name is None:
            target.append((node, parse_value(card, toks[i + 5], form), toks[i + 2].start, card))
        else:
            target.append((node, parse_value(card, toks[i + 5], form), toks[i + 2].start))
        i += 6


def _options(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".options"]
    i, n = 1, len(toks)
    while i < n:
        tok = toks[i]
        if tok.kind == PUNCT and tok.text == ",":
            i += 1
            continue
        if tok.kind != WORD:
            raise error(card, tok.start, f"expected an option name, found {tok.text!r}", form)
        if i + 1 < n and toks[i + 1].text == "=":
            if i + 2 >= n or toks[i + 2].kind not in (WORD, EXPR, STRING):
                raise error(card, toks[i + 1].start, f"missing value for option '{tok.text}'", form)
            net.options.append((tok.text, toks[i + 2], tok.start, card))
            i += 3
        else:
            net.options.append((tok.text, True, tok.start, card))
            i += 1


#: The temperature ngspice 39 runs at after a ``.temp`` card of several values (its default, 27 degC).
NGSPICE_DEFAULT_TEMP = 27.0


def _temp(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    vals = _values(card, toks, 1, DOT_CARDS[".temp"])
    if not vals:
        raise error(card, len(card.text), "expected a temperature", DOT_CARDS[".temp"])
    if len(vals) > 1:
        # ngspice 39: "Could not set temperature to 0 27 100 / Set to default 27 C instead", whatever
        # .options temp says (measured); SPICE2's list of temperatures is not ngspice's
        card.warn(vals[1][1], f"several temperatures: ngspice 39 runs one, and with several it runs at "
                  f"{NGSPICE_DEFAULT_TEMP:g} degC (whatever .options temp says), as netdae does here; for "
                  f"results at each temperature: '.dc temp ...', or '.step temp list ...' and 'netdae sweep'")
        net.temps.append(((NGSPICE_DEFAULT_TEMP, vals[0][1]), card))
        return
    net.temps.append((vals[0], card))


#: ngspice's functions of a vector that .print and .plot accept around a signal.
_OUTPUT_FUNCTIONS = frozenset({"db", "mag", "abs", "ph", "phase", "cph", "real", "re", "imag", "im", "norm",
                               "deriv", "group_delay"})
#: SPICE2's AC print forms: magnitude, phase, real and imaginary part, decibels of v() and i().
_AC_PRINT_FORMS = frozenset({"vm", "vp", "vr", "vi", "vdb", "im", "ip", "ir", "ii", "idb"})


def _entry_end(toks: list[Token], i: int) -> int:
    """The index after the output entry starting at ``toks[i]``: a word, ``word(...)`` or ``(...)``."""
    n = len(toks)
    j = i + 1 if toks[i].kind == WORD else i
    if j < n and toks[j].text == "(":
        depth = 0
        while j < n:
            depth += {"(": 1, ")": -1}.get(toks[j].text, 0)
            j += 1
            if depth == 0:
                break
        return j
    return max(j, i + 1)


def _saves(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    if toks[0].text != ".probe":
        _save_entries(card, toks, net)
        return
    # ngspice warns about a .probe entry it cannot read and ignores it: so does netdae, entry by entry
    i, n = 1, len(toks)
    while i < n:
        end = _entry_end(toks, i)
        try:
            _save_entries(card, [toks[0], *toks[i:end]], net)
        except NetlistError as exc:
            card.warn(toks[i].start, f"entry ignored, as ngspice ignores it: {exc.message.split(': ', 1)[-1]}")
        i = end


def _save_entries(card: Card, toks: list[Token], net: Netlist) -> None:
    word = toks[0].text
    i, n = 1, len(toks)
    if word in (".print", ".plot") and i < n and toks[i].kind == WORD and toks[i].text in _PRINT_TYPES:
        i += 1
    while i < n:
        tok = toks[i]
        if tok.kind == PUNCT and tok.text == ",":
            i += 1
            continue
        if tok.kind != WORD:
            raise error(card, tok.start, f"expected a signal, found {tok.text!r}", DOT_CARDS.get(word))
        head = tok.text
        if (head in _OUTPUT_FUNCTIONS and i + 3 < n and toks[i + 1].text == "(" and toks[i + 2].kind == WORD
                and toks[i + 3].text == "("):
            # db(v(out)), abs(i(vc)): the signal inside is what is kept (the function only shapes printing)
            end = i + 4
            while end < n and toks[end].text != ")":
                end += 1
            if end + 1 >= n or toks[end + 1].text != ")":
                raise error(card, tok.start, f"malformed signal {tok.text}(...)", DOT_CARDS.get(word))
            card.warn(tok.start, f"{head}(...): netdae keeps the signal inside; {head}() is ngspice's "
                                 "presentation of it")
            toks = toks[:i] + toks[i + 2:end + 1] + toks[end + 2:]
            n = len(toks)
            continue
        if head == "par" and i + 3 < n and toks[i + 1].text == "(" and toks[i + 2].kind == EXPR \
                and toks[i + 3].text == ")":
            # ngspice's par('expression') column (its pa_00 node): not a signal netdae keeps
            card.warn(tok.start, f"par('{toks[i + 2].text}') left out: netdae keeps no expressions of signals "
                                 "as outputs (ngspice adds a node pa_00 for it); measure it with .meas tran NAME "
                                 "FIND|AVG|MAX|... par('...'), or compute it from the saved signals")
            i += 4
            continue
        if head in _AC_PRINT_FORMS and i + 1 < n and toks[i + 1].text == "(":
            head = head[0]  # vdb(out), vm(out), ip(v1): SPICE2's AC print forms of v() and i()
        if i + 1 < n and toks[i + 1].text == "(":
            j = i + 2
            args = []
            while j < n and toks[j].text != ")":
                if toks[j].kind == WORD:
                    args.append("0" if toks[j].text == "gnd" else toks[j].text)
                elif toks[j].text != ",":
                    raise error(card, toks[j].start, f"unexpected {toks[j].text!r} in a signal", DOT_CARDS.get(word))
                j += 1
            if j >= n or not args:
                raise error(card, tok.start, f"malformed signal {tok.text}(...)", DOT_CARDS.get(word))
            net.saves.append((f"{head}({','.join(args)})", tok.start, card))
            i = j + 1
        else:
            net.saves.append((tok.text, tok.start, card))
            i += 1


def _meas(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    try:
        measure = parse_measure(card)
    except NetlistError as err:
        if not card.from_control:
            raise
        # a .control block's meas command netdae cannot read as a .meas card (a vector 'let' made, a form of the
        # control language's own) is skipped, as the rest of the control language is
        net.diagnostics.append(Diagnostic(
            "note", f".control: '{card.raw[1:]}' skipped: netdae reads meas as a .meas card, and this one is not "
            f"one: {err.message.removeprefix('.meas: ')}", card.location(0)))
        return
    net.measures.append(measure)


def _four(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    form = DOT_CARDS[".four"]
    if len(toks) < 2:
        raise error(card, len(card.text), "expected the fundamental frequency", form)
    if len(toks) < 3:
        raise error(card, len(card.text), "expected a signal after the frequency", form)
    freq = parse_value(card, toks[1], form)
    start = len(net.saves)  # ngspice saves what .four reads, as .print's signals
    _save_entries(card, [toks[0], *toks[2:]], net)
    net.fouriers.append((freq, [(signal, offset) for signal, offset, _ in net.saves[start:]], card))


def _step(card: Card, toks: list[Token], stack, net: Netlist) -> None:
    net.steps.append(parse_step(card, toks))


_HANDLERS = {
    ".subckt": _subckt, ".ends": _ends, ".param": _param, ".func": _func, ".model": _model,
    ".global": _global, ".title": _title, ".op": _op, ".tran": _tran, ".ac": _ac, ".dc": _dc, ".pz": _pz, ".tf": _tf,
    ".sens": _sens,
    ".noise": _noise,
    ".ic": _ic, ".nodeset": _ic, ".options": _options, ".temp": _temp, ".save": _saves,
    ".print": _saves, ".probe": _saves, ".plot": _saves, ".meas": _meas, ".four": _four,
    ".step": _step,
}


# ---------------------------------------------------------------------------
def _settle(scope: Definition) -> None:
    """Resolve what needs the models of the whole netlist (lexical lookup).

    A card of a subcircuit that cannot be resolved (a ``Q`` card whose model is defined nowhere
    in its scope) is kept as one of the subcircuit's errors, raised only if the subcircuit is
    instantiated: ngspice reads only the subcircuits it expands (a library file may hold a
    subcircuit whose model is defined only inside others, as ngspice's HICUM/L0 cards do).
    """
    broken = []
    for item in scope.items:
        if not isinstance(item, ElementCard):
            continue
        try:
            _settle_card(item, scope)
        except NetlistError as exc:
            if scope.name is None:
                raise
            scope.errors.append(exc)
            broken.append(item)
    if broken:
        scope.items = [item for item in scope.items if all(item is not b for b in broken)]
    for sub in scope.subckts.values():
        _settle(sub)


def _settle_card(item: ElementCard, scope: Definition) -> None:
    """Resolve one element card against the models its scope sees (:func:`_settle`)."""
    if item.kind == Kind.BJT:
        _settle_bjt(item, scope)
    elif item.kind == Kind.MOSFET and item.positional is not None:
        _settle_three_node_mosfet(item, scope)
    elif item.kind == Kind.DIODE and item.positional is not None:
        _settle_diode(item, scope)
    elif KINDS[item.kind].passive and item.model is None:
        value = item.value[0] if item.value is not None else None
        if (item.kind != Kind.INDUCTOR and isinstance(value, ex.Param)
                and scope.lookup_model(value.name) is not None):
            # 'R1 a b rmod [l= w=]', 'C1 a b cmod l= [w=]': the value comes from the model
            # (elaborate: _resistance_from_model, _capacitance_from_model)
            item.model, item.value = (value.name, item.value[1]), None
        elif isinstance(value, ex.Param) and scope.lookup_model(value.name) is not None:
            raise error(item.card, item.value[1], f"'{value.name}' is a model: an inductance computed "
                        "from a model (ngspice's ind, csect, length, nt, mu) is not supported by netdae",
                        ELEMENTS["l"], hint="give the value after the nodes, then the model name")


#: Instance parameters of a VDMOS M card (``ic=vds,vgs`` gives the first two; ``off`` is a flag).
VDMOS_INSTANCE_PARAMETERS = frozenset({"icvds", "icvgs", "m", "temp", "dtemp"})


def _settle_three_node_mosfet(el: ElementCard, scope: Definition) -> None:
    """An M card of three nodes and a model: ngspice 39's VDMOS when the model is one, else a missing node
    (five nodes and a VDMOS model: its self-heating form, refused).

    A VDMOS takes the instance parameters ``m``, ``off``, ``ic=vds,vgs`` (``icvds``, ``icvgs``),
    ``temp`` and ``dtemp``; the MOSFET's geometry and a third ``ic=`` value are refused at the word.
    """
    words, card, syntax = el.positional, el.card, ELEMENTS["m"]
    if len(words) == 6:
        found = scope.lookup_model(words[5].text)
        if found is not None and found[0].type in MODEL_TYPES[Kind.VDMOS]:
            raise error(card, words[3].start, f"five nodes (drain gate source and the thermal nodes tj tcase of "
                        f"ngspice's self-heating VDMOS, model {words[5].text}) are not supported by netdae", syntax,
                        hint="remove the thermal nodes to simulate it without self-heating")
        raise error(card, words[5].start, f"unexpected {words[5].text!r}", syntax)
    found = scope.lookup_model(words[3].text)
    if found is None or found[0].type not in MODEL_TYPES[Kind.VDMOS]:
        raise error(card, len(card.text), "expected 4 nodes and a model name, found 4 node(s) and no model", syntax)
    for name, value in el.params.items():
        if name not in VDMOS_INSTANCE_PARAMETERS:
            what = "a third ic= value (vbs)" if name == "icvbs" else f"'{name}'"
            raise error(card, value[1], f"{what} is not an instance parameter of a VDMOS (power MOSFET, "
                        f"model {words[3].text})", syntax,
                        hint="a VDMOS takes " + " ".join(f"{k}=" for k in ("m", "ic", "temp", "dtemp")) + " and off")
    el.kind = Kind.VDMOS.value
    el.nodes = tuple("0" if t.text == "gnd" else t.text for t in words[:3])
    el.model = (words[3].text, words[3].start)
    el.positional = None


def _settle_diode(el: ElementCard, scope: Definition) -> None:
    """A D card whose third word is not its model: ``D a k t mname [area]``, ngspice 39's diode with its
    thermal node ``t`` (used only with the instance flag ``thermal``, refused by netdae: without it ngspice
    leaves the node unconnected, and so does netdae), or ``D a k mname pname`` (an area by name)."""
    syntax, card = ELEMENTS["d"], el.card
    words = el.positional
    names = [t.text for t in words]
    if scope.lookup_model(names[2]) is not None:
        count = 2
    elif scope.lookup_model(names[3]) is not None:
        count = 3
    else:
        raise error(card, words[2].start, f"no model '{names[2]}' or '{names[3]}' defined", syntax,
                    hint="define it with .model mname d (...)")
    _settled(el, names[:2], count, syntax)


def _settled(el: ElementCard, nodes: list[str], count: int, syntax) -> None:
    """A device card's words judged: its ``nodes``, the model at word ``count`` and an optional area after it."""
    words, card = el.positional, el.card
    el.nodes = tuple("0" if n == "gnd" else n for n in nodes)
    el.model = (words[count].text, words[count].start)
    extra = words[count + 1:]
    if extra:
        el.params["area"] = parse_value(card, extra[0], syntax, "area")
    if len(extra) > 1:
        raise error(card, extra[1].start, f"unexpected {extra[1].text!r}", syntax)
    el.positional = None


def _settle_bjt(el: ElementCard, scope: Definition) -> None:
    syntax = ELEMENTS["q"]
    words = el.positional
    names = [t.text if t.kind == WORD else None for t in words]
    card = el.card
    if len(words) < 4 or any(name is None for name in names[:4]):
        raise error(card, len(card.text), "expected 3 or 4 nodes and a model name", syntax)
    if scope.lookup_model(names[3]) is not None:
        count = 3
    elif len(words) > 4 and names[4] is not None and scope.lookup_model(names[4]) is not None:
        count = 4
    elif len(words) > 5 and names[5] is not None and scope.lookup_model(names[5]) is not None:
        count = 5  # c b e s and the thermal node of ngspice's self-heating VBIC (judged with the model)
    else:
        tried = [f"'{name}'" for name in names[3:6] if name]
        tried = ", ".join(tried[:-1]) + " or " + tried[-1] if len(tried) > 1 else tried[0]
        raise error(card, words[3].start, f"no model {tried} defined", syntax,
                    hint="define it with .model mname npn|pnp (...)")
    _settled(el, names[:count], count, syntax)
