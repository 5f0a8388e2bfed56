"""Text-level translation between netdae's netlist dialect and ngspice.

Everything here works on the netlist *text* and on ngspice's printed output:

- :func:`translate_for_ngspice` -- make a netlist ngspice runs the way netdae
  needs it: the self-contained text of :func:`netdae.ngspice.deck.self_contained`
  (includes expanded by netdae's reader, no control-language card, one
  ``.end`` last), in which the ideal op-amp extension becomes a high-gain
  VCVS and ``.options interp`` and ``filetype`` are removed. Every change is
  returned as a note naming the line.
- :func:`override_options` -- a variant of a netlist with simulator options
  overridden (``reltol``, ``method``, ... and ``maxstep``, which ngspice takes
  from the ``.tran`` card only).
- :func:`dc_sweeps`, :func:`effective_tolerances` -- what the ``.dc`` and
  ``.options`` cards say, for naming dc axes and reporting tolerances.
- :func:`classify_output` -- ngspice's stdout/stderr lines sorted into errors,
  warnings and notes.

Numbers are read by netdae's one number parser
(:func:`netdae.netlist.numbers.parse_number`, ngspice's ``INPevaluate``).
Cards are found the way ngspice finds them: the first line is the title;
``*`` starts a comment line; ``;``, ``//`` and a ``$`` after a blank start an
inline comment; a line starting with ``+`` continues the previous card (blank
and comment lines may come in between); names are case-insensitive. A
rewritten card is written back on one line.

Examples
--------
>>> text, notes = translate_for_ngspice("diff\\nE1 out 0 0 minus OPAMP ; ideal\\n.end\\n")
>>> print(text, end="")
diff
E1 out 0 0 minus 1000000.0
.end
>>> notes[0].startswith("line 2: E1")
True
>>> translate_for_ngspice("t\\n.control\\nshell rm -rf ~\\n.endc\\n.op\\n")[0]
't\\n.op\\n.end\\n'

"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

from ..errors import NetlistError, NgspiceError
from ..netlist.numbers import parse_number
from .deck import Origin, self_contained

__all__ = [
    "OPAMP_GAIN",
    "NGSPICE_DEFAULT_TOLERANCES",
    "translate_for_ngspice",
    "override_options",
    "dc_sweeps",
    "DcSweepCard",
    "effective_tolerances",
    "classify_output",
]

#: Gain of the VCVS that stands for netdae's ideal op-amp in ngspice.
#: The finite-gain circuit differs from the ideal one by a relative error of
#: about (noise gain)/A, and adds a fast pole: the differentiator of
#: ``netlists/differentiator.cir`` becomes an index-1 circuit with time
#: constant L/(R (1 + A)) = 1e-10 s. 1e6 keeps the model error (1e-6 times
#: the noise gain) three decades below ngspice's default reltol while the
#: conditioning of the MNA matrix (which grows like A times the spread of the
#: conductances) leaves rounding errors below it; ngspice runs the
#: differentiator to completion for every gain from 1e3 to 1e15, so callers
#: that compare at reltol 1e-6 can pass ``opamp_gain=1e9``.
OPAMP_GAIN = 1e6

#: ngspice's defaults for the tolerances netdae reports (ngspice manual,
#: section "Options"): relative, current [A], voltage [V], charge [C], the
#: truncation-error overestimation factor, and the minimum conductance [S].
NGSPICE_DEFAULT_TOLERANCES = {
    "reltol": 1e-3,
    "abstol": 1e-12,
    "vntol": 1e-6,
    "chgtol": 1e-14,
    "trtol": 7.0,
    "gmin": 1e-12,
}

#: Options :func:`override_options` accepts (ngspice ignores unknown options
#: without a word, so netdae refuses them instead). ``maxstep`` is not an
#: ngspice option: it is written into the ``.tran`` cards.
_KNOWN_OPTIONS = frozenset(
    "reltol abstol vntol chgtol trtol gmin pivtol pivrel itl1 itl2 itl4 itl6 gminsteps srcsteps "
    "method maxord xmu temp tnom rshunt cshunt ramptime noopiter klu sparse keepopinfo "
    "savecurrents".split()
)
_METHODS = ("trap", "trapezoidal", "gear")
#: Options whose presence changes what ngspice reports, removed by the translation.
_STRIPPED_OPTIONS = {
    "interp": "ngspice 39 interpolates wrong values onto the tstep grid; netdae compares "
    "at ngspice's own accepted time points",
    "filetype": "netdae reads ngspice's binary raw file (full double precision)",
}

# ---------------------------------------------------------------------------
# cards
# ---------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Card:
    first: int  # index of its first physical line
    last: int  # index of its last physical line (continuations included)
    text: str  # logical text, comments removed, continuations joined

    @property
    def tokens(self) -> list[str]:
        return self.text.split()

    @property
    def keyword(self) -> str:
        tokens = self.tokens
        return tokens[0].lower() if tokens else ""


_INLINE_COMMENT = re.compile(r";|//|(?:^|(?<=[ \t]))\$")


def _strip_comment(line: str) -> str:
    match = _INLINE_COMMENT.search(line)
    return line[: match.start()] if match else line


def _cards(lines: list[str]) -> list[_Card]:
    """Logical cards of a netlist (the title line excluded)."""
    cards: list[_Card] = []
    for index in range(1, len(lines)):
        stripped = lines[index].strip()
        if not stripped or stripped.startswith("*"):
            continue
        if stripped.startswith("+") and cards:
            prev = cards[-1]
            more = _strip_comment(stripped[1:]).strip()
            cards[-1] = _Card(prev.first, index, f"{prev.text} {more}".strip())
            continue
        cards.append(_Card(index, index, _strip_comment(stripped).strip()))
    return cards


def _script_cards(lines: list[str]) -> list[_Card]:
    """The commands of netdae's own control block (:func:`netdae.ngspice.deck.script_block`), one line each."""
    from .deck import SCRIPT_MARK

    if SCRIPT_MARK not in lines:
        return []
    start = lines.index(SCRIPT_MARK)
    end = lines.index(".endc", start)
    return [_Card(index, index, lines[index].strip()) for index in range(start + 1, end)]


def _apply(lines: list[str], edits: dict[int, tuple[int, str | None]]) -> str:
    """Replace line ranges ``first..last`` by one line (or nothing)."""
    out: list[str] = []
    index = 0
    while index < len(lines):
        if index in edits:
            last, replacement = edits[index]
            if replacement is not None:
                out.append(replacement)
            index = last + 1
        else:
            out.append(lines[index])
            index += 1
    return "\n".join(out) + "\n"


def _circuit_cards(cards: list[_Card]) -> list[_Card]:
    """The cards outside ``.control``/``.endc`` blocks.

    ngspice 39 reads the whole file: cards after ``.end`` still belong to the
    circuit, so nothing stops at ``.end``.
    """
    kept: list[_Card] = []
    in_control = False
    for card in cards:
        if in_control:
            in_control = card.keyword != ".endc"
        elif card.keyword == ".control":
            in_control = True
        else:
            kept.append(card)
    return kept


def _where(card: _Card) -> str:
    if card.last > card.first:
        return f"lines {card.first + 1}-{card.last + 1}"
    return f"line {card.first + 1}"


def _is_end(card: _Card) -> bool:
    return card.keyword == ".end"


def _option_tokens(text: str) -> list[str]:
    """``.options a=1 b = 2 c`` -> ['a=1', 'b=2', 'c'] (keyword dropped)."""
    body = re.sub(r"\s*=\s*", "=", text).split()
    return body[1:]


def _is_options(card: _Card) -> bool:
    return card.keyword in (".options", ".option", ".opt", ".opts")


_FUNC = re.compile(r"^\.func\s+([a-z_][\w.]*)\s*\(([^)]*)\)\s*=?(.*)$", re.IGNORECASE | re.DOTALL)
_CALL = re.compile(r"([a-z_][\w.]*)\s*\(", re.IGNORECASE)


def _recursive_func(cards: list[_Card]) -> tuple[_Card, str] | None:
    """The first ``.func`` card whose body calls the function itself, and its name.

    ngspice 39 expands such a function without end, even one whose recursion a ternary ends
    (``.func fact(n) {n <= 1 ? 1 : n*fact(n-1)}``), called in a parameter or in a B source, and stops
    with a segmentation fault (measured, batch and shared library alike). Functions calling each other
    (``f`` calls ``g``, ``g`` calls ``f``) it refuses with an error ("Undefined parameter"), so they are
    left to it.

    Examples
    --------
    >>> card, name = _recursive_func(_cards(["t", ".func h(x) {x*x}", ".FUNC Fact(n) = {n <= 1 ? 1 : n*fact(n-1)}"]))
    >>> card.first, name
    (2, 'fact')
    >>> _recursive_func(_cards(["t", ".func f(x) {g(x)+1}", ".func g(x) {x > 1 ? f(x-1) : 1}"])) is None
    True
    """
    for card in cards:
        if card.keyword != ".func":
            continue
        match = _FUNC.match(card.text.strip())
        if match is None:
            continue
        name = match.group(1).lower()
        if any(m.group(1).lower() == name for m in _CALL.finditer(match.group(3))):
            return card, name
    return None


# ---------------------------------------------------------------------------
# translation
# ---------------------------------------------------------------------------


def translate_for_ngspice(
    text: str,
    *,
    opamp_gain: float = OPAMP_GAIN,
    base_dir: str | os.PathLike | None = None,
    source: str = "<string>",
    behavior=None,
) -> tuple[str, list[str]]:
    """Make a netdae netlist runnable by ngspice, saying what was changed.

    Parameters
    ----------
    text : str
        The netlist (first line is the title).
    opamp_gain : float
        Gain of the VCVS that replaces each ideal op-amp (see :data:`OPAMP_GAIN`).
    base_dir : path-like, optional
        Directory relative ``.include``/``.lib`` names refer to (the
        netlist's directory); the current directory by default.
    source : str
        Name of the netlist for error messages.
    behavior : str or Behavior, optional
        ngspice's compatibility mode the netlist is read in
        (:func:`netdae.ngspice.deck.self_contained`).

    Returns
    -------
    text : str
        The netlist ngspice should run: self-contained, one card per line.
    notes : list of str
        One entry per change, ``"line N: <card>: <what and why>"`` (lines of
        the netlist as written; ``"file line N"`` for an included file).

    Raises
    ------
    NetlistError
        When an op-amp card is malformed, and for every card netdae does not
        hand to ngspice (:func:`netdae.ngspice.deck.self_contained`).
    NgspiceError
        For a ``.func`` that calls itself, on which ngspice 39 crashes (its
        segmentation fault would take the process down with the shared library).

    Notes
    -----
    First the netlist is written out by netdae
    (:func:`~netdae.ngspice.deck.self_contained`): ``.include`` files and
    ``.lib`` sections expanded, ``.control`` blocks and comments left out,
    continuation lines joined, nothing after ``.end``, one ``.end`` last --
    ngspice never reads a file of the user's and never runs a command of the
    netlist. Then: ``Ename out+ out- in+ in- OPAMP`` (any case) becomes
    ``Ename out+ out- in+ in- <opamp_gain>``; a ``K`` card coupling more than
    two inductors becomes one card per pair; ``interp`` and ``filetype`` are
    removed from ``.options`` cards. Everything else, including ngspice's
    default options, is left as written. Cost: one pass of netdae's reader,
    one pass over the cards.
    """
    if not opamp_gain > 0:
        raise NgspiceError(f"opamp_gain must be positive, got {opamp_gain!r}")
    lines, origins, notes = self_contained(text, base_dir=base_dir, source=source, behavior=behavior)
    edits: dict[int, tuple[int, str | None]] = {}
    subckt: list[str] = []
    cards = _cards(lines)
    keywords = {card.keyword for card in cards}
    if keywords & {".meas", ".measure"} and not keywords & {".save", ".print", ".probe", ".plot"}:
        end = next(card for card in reversed(cards) if _is_end(card))
        edits[end.first] = (end.last, ".save all\n" + lines[end.first])
        first = next(card for card in cards if card.keyword in (".meas", ".measure"))
        notes.append(f"{origins[first.first]}: '.save all' added: with .meas cards and no .save card, ngspice 39 "
                     "saves only the vectors the .meas cards name")
    saves = [card for card in cards if card.keyword == ".save"]
    analyses = [card for card in cards if card.keyword in (".pz", ".tf", ".noise", ".sens")]
    if saves and analyses and not any(t.lower() == "all" for card in saves for t in card.tokens[1:]):
        end = next(card for card in reversed(cards) if _is_end(card))
        old = edits.get(end.first, (end.last, lines[end.first]))
        edits[end.first] = (old[0], ".save all\n" + old[1])
        notes.append(f"{origins[analyses[0].first]}: '.save all' added: with .save cards, ngspice 39 saves no "
                     f"{analyses[0].keyword} result ('no data saved for ... analysis; analysis not run')")
    recursive = _recursive_func(cards)
    if recursive is not None:
        card, name = recursive
        raise NgspiceError(
            f"{origins[card.first]}: .func {name} calls itself: ngspice 39 expands it without end and stops "
            "with a segmentation fault (measured), so netdae does not hand it this netlist"
        )
    bjt = any(card.keyword[:1] == "q" for card in cards)
    sens_seen = False
    for card in cards:
        keyword = card.keyword
        where = origins[card.first]
        if keyword == ".sens" and (bjt or sens_seen):
            edits[card.first] = (card.last, None)
            why = ("stops with a segmentation fault computing the sensitivity of a circuit with a bipolar "
                   "transistor" if bjt else "corrupts its memory and aborts running a second sensitivity analysis")
            notes.append(f"{where}: .sens removed: ngspice 39 {why} (measured); netdae computes it alone")
            continue
        sens_seen = sens_seen or keyword == ".sens"
        if keyword == ".subckt" and len(card.tokens) > 1:
            subckt.append(card.tokens[1].lower())
        elif keyword == ".ends" and subckt:
            subckt.pop()
        elif keyword[:1] == "e" and _is_opamp(card.tokens):
            new = _translate_opamp(card, opamp_gain, where)
            edits[card.first] = (card.last, new)
            inside = f" (in subcircuit {subckt[-1]})" if subckt else ""
            notes.append(
                f"{where}: {card.tokens[0]}{inside}: ideal op-amp written as a VCVS of gain "
                f"{opamp_gain:.3g} (ngspice has no ideal op-amp; the finite gain adds a relative error "
                f"of about noise-gain/{opamp_gain:.3g} and turns an index-2 op-amp circuit into an "
                "index-1 one with a fast time constant)"
            )
        elif keyword[:1] == "k" and len(card.tokens) > 4:
            edits[card.first] = (card.last, _split_coupling(card.tokens))
            pairs = len(card.tokens) - 2
            notes.append(
                f"{where}: {card.tokens[0]} couples {pairs} inductors (a netdae extension): written as "
                f"{pairs * (pairs - 1) // 2} K cards, one per pair, with the same coupling factor"
            )
        elif keyword in (".save", ".print", ".probe", ".plot") and card.first not in edits:
            text = "\n".join(lines[card.first:card.last + 1])
            new = _DEVICE_CURRENT.sub(lambda m: f"@{m.group(1)}[i]", text)
            if new != text:
                edits[card.first] = (card.last, new)
                notes.append(f"{where}: {keyword} i(R or C) written as @name[i] (ngspice names the currents of "
                             "resistors and capacitors so; netdae compares them as i(name))")
        elif _is_options(card):
            new, removed = _strip_options(card)
            if removed:
                edits[card.first] = (card.last, new)
                for name, token in removed:
                    notes.append(f"{where}: .options {token} removed: {_STRIPPED_OPTIONS[name]}")
    return _apply(lines, edits), notes


#: ``i(r1)``/``i(c1)`` in an output card: ngspice names these currents ``@r1[i]``.
_DEVICE_CURRENT = re.compile(r"\b[iI]\(\s*([rRcC][^\s(),]*)\s*\)")


def _split_coupling(tokens: list[str]) -> str:
    """``K1 L1 L2 L3 k`` as one K card per pair (ngspice 39 couples two inductors per card)."""
    name, inductors, value = tokens[0], tokens[1:-1], tokens[-1]
    cards = []
    for i in range(len(inductors)):
        for j in range(i + 1, len(inductors)):
            cards.append(f"{name}_{inductors[i]}_{inductors[j]} {inductors[i]} {inductors[j]} {value}")
    return "\n".join(cards)


def _is_opamp(tokens: list[str]) -> bool:
    """An E card meant as an ideal op-amp: OPAMP as its gain or its last word."""
    words = [t.lower() for t in tokens]
    return len(words) > 3 and (words[-1] == "opamp" or (len(words) > 5 and words[5] == "opamp"))


def _translate_opamp(card: _Card, gain: float, where: Origin) -> str:
    tokens = card.tokens
    if len(tokens) != 6:
        raise NetlistError(
            f"{tokens[0]}: an ideal op-amp takes two output and two input nodes and nothing after OPAMP",
            where.location("opamp"),
            expected="Ename out+ out- in+ in- OPAMP",
        )
    return " ".join(tokens[:5]) + f" {_format_value(float(gain))}"


def _strip_options(card: _Card) -> tuple[str | None, list[tuple[str, str]]]:
    kept: list[str] = []
    removed: list[tuple[str, str]] = []
    for token in _option_tokens(card.text):
        name = token.split("=", 1)[0].lower()
        if name in _STRIPPED_OPTIONS:
            removed.append((name, token))
        else:
            kept.append(token)
    if not kept:
        return None, removed
    return " ".join([card.tokens[0], *kept]), removed


# ---------------------------------------------------------------------------
# options override
# ---------------------------------------------------------------------------


def override_options(text: str, **options: float | str | bool) -> tuple[str, list[str]]:
    """A variant of a netlist with simulator options overridden.

    Parameters
    ----------
    text : str
        The netlist.
    **options
        ngspice option names and values, e.g. ``reltol=1e-6, abstol=1e-15,
        vntol=1e-9, method="gear"``; ``True`` for flag options. ``maxstep``
        sets the maximum step of every ``.tran`` card (its fourth argument,
        ``tmax``; ngspice has no ``maxstep`` option and would ignore it).

    Returns
    -------
    text : str
        The netlist with one ``.options`` card inserted before ``.end`` (at
        the end when there is no ``.end``), and ``.tran`` cards rewritten for
        ``maxstep``. A later ``.options`` card overrides an earlier one in
        ngspice, and ngspice 39 reads cards after ``.end`` too: when
        ``.options`` cards follow ``.end``, the new card goes after the last
        of them.
    notes : list of str
        What was changed.

    Raises
    ------
    NgspiceError
        For an option ngspice does not know (it would ignore it silently), a
        bad ``method``, a non-positive ``maxstep``, or ``maxstep`` without a
        ``.tran`` card.

    Examples
    --------
    >>> text, notes = override_options("rc\\nR1 1 0 1k\\n.tran 1u 1m\\n.end\\n", reltol=1e-6, maxstep=1e-6)
    >>> print(text, end="")
    rc
    R1 1 0 1k
    .tran 1u 1m 0 1e-06
    .options reltol=1e-06
    .end
    """
    maxstep = options.pop("maxstep", None)
    for name, value in options.items():
        if name.lower() not in _KNOWN_OPTIONS:
            raise NgspiceError(
                f"unknown ngspice option {name!r} (ngspice would ignore it silently); "
                f"known: {', '.join(sorted(_KNOWN_OPTIONS))}, and maxstep"
            )
        if name.lower() == "method" and str(value).lower() not in _METHODS:
            raise NgspiceError(f"method must be one of {', '.join(_METHODS)}, got {value!r}")
    lines = text.splitlines()
    cards = _circuit_cards(_cards(lines))
    edits: dict[int, tuple[int, str | None]] = {}
    notes: list[str] = []
    if maxstep is not None:
        for card in cards + _script_cards(lines):
            if card.keyword in (".tran", "tran"):
                edits[card.first] = (card.last, _with_maxstep(card, maxstep))
                notes.append(f"{_where(card)}: .tran maximum step set to {maxstep!r}: {edits[card.first][1]}")
        if not edits:
            raise NgspiceError("maxstep given but the netlist has no .tran card to apply it to")
    if options:
        words = []
        for name, value in options.items():
            if value is True:
                words.append(name.lower())
            else:
                words.append(f"{name.lower()}={_format_value(value)}")
        card_text = ".options " + " ".join(words)
        ends = [card for card in cards if _is_end(card)]
        later_options = [c for c in cards if _is_options(c) and ends and c.first > ends[0].first]
        if ends and not later_options:
            first = ends[0].first
            notes.append(f"line {first + 1}: inserted before .end: {card_text}")
        elif later_options:
            # ngspice 39 reads cards after .end; the last .options card wins
            first = later_options[-1].last + 1
            notes.append(f"line {first + 1}: inserted after the last .options card: {card_text}")
        else:
            first = len(lines)
            notes.append(f"line {first + 1}: appended (no .end): {card_text}")
        if first < len(lines):
            last, replacement = edits.get(first, (first, lines[first]))
            edits[first] = (last, f"{card_text}\n{replacement}")
        else:
            lines.append(card_text)
    return _apply(lines, edits), notes


def _format_value(value: float | str | int) -> str:
    """Shortest text that reads back as the same value (``1e-06``, ``gear``)."""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, (int, float)):
        return repr(value)
    return str(value)


def _with_maxstep(card: _Card, maxstep: float) -> str:
    if not maxstep > 0:
        raise NgspiceError(f"maxstep must be positive, got {maxstep!r}")
    tokens = card.tokens
    flags = [t for t in tokens[1:] if t.lower() == "uic"]
    numbers = [t for t in tokens[1:] if t.lower() != "uic"]
    if len(numbers) < 2:
        raise NgspiceError(f"line {card.first + 1}: cannot set a maximum step on {card.text!r}")
    tstart = numbers[2] if len(numbers) > 2 else "0"
    return " ".join([tokens[0], numbers[0], numbers[1], tstart, _format_value(float(maxstep)), *flags])


# ---------------------------------------------------------------------------
# what the netlist asks for
# ---------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class DcSweepCard:
    """The sweeps of one ``.dc`` card, innermost first (as ngspice nests them).

    Attributes
    ----------
    sources : tuple of str
        Lower-case swept names (``"v1"``, ``"i2"``, ``"r1"``, ``"temp"``).
    ranges : tuple of (float, float, float) or None
        ``(start, stop, step)`` per source; None when a value is not a plain
        number (an expression).
    """

    sources: tuple[str, ...]
    ranges: tuple[tuple[float, float, float] | None, ...]


def dc_sweeps(text: str) -> list[DcSweepCard]:
    """The ``.dc`` cards of a netlist, in order (with the ``dc`` commands of netdae's control block after them).

    Examples
    --------
    >>> dc_sweeps("t\\nV1 1 0 1\\n.DC V1 0 1 0.5 I2 0 2m 1m\\n.end")[0].sources
    ('v1', 'i2')
    """
    found = []
    lines = text.splitlines()
    for card in _circuit_cards(_cards(lines)) + _script_cards(lines):
        if card.keyword not in (".dc", "dc"):
            continue
        tokens = card.tokens[1:]
        if tokens and tokens[0].lower() in ("lin", "dec", "oct"):
            tokens = tokens[1:]
        sources, ranges = [], []
        for k in range(0, len(tokens) - 3, 4):
            sources.append(tokens[k].lower())
            values = [parse_number(t) for t in tokens[k + 1 : k + 4]]
            ranges.append(None if None in values else tuple(values))
        if sources and len(tokens) % 4 == 0:
            found.append(DcSweepCard(tuple(sources), tuple(ranges)))
    return found


def effective_tolerances(text: str) -> tuple[dict[str, float], str | None]:
    """ngspice's tolerances for a netlist: defaults, then its ``.options`` in order.

    Returns
    -------
    tolerances : dict
        ``reltol``, ``abstol``, ``vntol``, ``chgtol``, ``trtol``, ``gmin``.
    method : str or None
        The integration method named by the netlist (``"trap"``/``"gear"``),
        None for ngspice's default (trapezoidal).
    """
    tolerances = dict(NGSPICE_DEFAULT_TOLERANCES)
    method = None
    for card in _circuit_cards(_cards(text.splitlines())):
        if not _is_options(card):
            continue
        for token in _option_tokens(card.text):
            name, _, value = token.partition("=")
            name = name.lower()
            if name in tolerances:
                number = parse_number(value)
                if number is not None:
                    tolerances[name] = number
            elif name == "method":
                method = value.lower()
    return tolerances, method


# ---------------------------------------------------------------------------
# ngspice's output
# ---------------------------------------------------------------------------

#: Lines that mean an analysis did not produce a valid result.
_ERROR_PATTERNS = re.compile(
    r"^error|simulation interrupted|simulation\(s\) aborted|doanalyses:|timestep too small|"
    r"^fatal|dc solution failed|cannot|no such|not found|unknown",
    re.I,
)
#: Failure only in strict mode: ngspice continued with gmin or source stepping.
_STRICT_PATTERNS = re.compile(r"singular matrix", re.I)
#: Progress chatter of gmin and source stepping (kept out of messages).
_PROGRESS = re.compile(r"^(trying gmin|supplies reduced)", re.I)
#: Harmless stderr notes that must not be taken for errors even though they
#: contain a trigger word.
_HARMLESS = re.compile(
    r"^note: no resource usage|^\s*or no active circuit available|can't find init file|"
    r"no compatibility mode selected",
    re.I,
)


def classify_output(stderr: list[str], stdout: list[str], *, strict: bool = True) -> tuple[list[str], list[str]]:
    """Sort ngspice's messages into errors and warnings.

    Parameters
    ----------
    stderr, stdout : list of str
        ngspice's lines (of stdout only ``DC solution failed`` and ``Error``
        lines are considered).
    strict : bool
        When True, ``singular matrix`` (ngspice continued with gmin or source
        stepping, so its answer depends on them) is an error too.

    Returns
    -------
    errors : list of str
        ngspice's error lines with the lines that explain them (the card and
        the reason after ``Error on line N``), each once, in order; empty when
        there is none.
    warnings : list of str
        ``Warning:`` and ``Note:`` lines and the lines that continue them,
        each once; gmin and source stepping progress is left out.

    Examples
    --------
    >>> errors, warnings = classify_output(
    ...     ["Note: v1: dc value used", "Error on line 4 or its substitute:", "  .tran 1u",
    ...      "TSTOP is invalid, must be greater than zero."], [])
    >>> errors
    ['Error on line 4 or its substitute:', '.tran 1u', 'TSTOP is invalid, must be greater than zero.']
    >>> warnings
    ['Note: v1: dc value used']
    """
    errors: list[str] = []
    warnings: list[str] = []
    context = warnings  # where a line that is neither error nor remark belongs
    for line in [*stderr, *(line for line in stdout if _is_stdout_error(line))]:
        text = line.strip()
        if not text or _PROGRESS.match(text) or _HARMLESS.search(text):
            continue
        is_remark = text.lower().startswith(("warning", "note"))
        is_error = (bool(_ERROR_PATTERNS.search(text)) and not is_remark) or (
            strict and bool(_STRICT_PATTERNS.search(text))
        )
        if is_error:
            target = context = errors
        elif is_remark:
            target = context = warnings
        else:
            target = context
        if text not in target:
            target.append(text)
    return errors, warnings


def _is_stdout_error(line: str) -> bool:
    return bool(re.search(r"dc solution failed|^error", line.strip(), re.I))
