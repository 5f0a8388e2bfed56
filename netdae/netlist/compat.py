"""ngspice's compatibility modes (``set ngbehavior=...``) and the PSpice translations netdae does in them.

ngspice reads the variable ``ngbehavior`` from its start-up files (``spinit``, ``.spiceinit``)
before it reads a netlist, and in its PSpice mode translates PSpice idioms card by card
before parsing (ngspice 39: ``pspice_compat`` and its callers in ``src/frontend/inpcom.c``).
netdae never executes a ``.spiceinit`` (it is a control-language script): it reads only its
``set ngbehavior=VALUE`` commands and lists every other line as ignored
(:func:`read_spiceinit`); :func:`find_behavior` says where it looks. The value is read as
ngspice's ``set_compat_mode`` reads it: each two-letter code anywhere in it sets a flag
(``ps`` PSpice, ``lt`` LTspice, ``a`` the whole netlist; ``hs``, ``xs``, ``ki``, ``eg``,
``spe``, ``s3``, ``ll``, ``mc``: modes netdae knows by name and does not translate for; ``hs``
and ``spe`` choose BSIM bins by the finger's width, :attr:`Behavior.bins_by_finger`).
Of LTspice's mode netdae does the functions and cards of :func:`translate_ltspice`.

Scope (ngspice 39): in ``ps`` the translations apply to the cards of included files only
(``.include``, and ``.lib`` which this mode reads as ``.include``); with ``a`` (``psa``) to the
main netlist as well. :meth:`Behavior.translates` decides it per file; :func:`translate_cards`
rewrites one file's cards (located: every rewritten character keeps the file, line and column
of the character it replaces) and marks them (:attr:`Card.compat`) for the translations that
need the parsed netlist: PSpice's ``AKO:`` models (:func:`netdae.netlist.parser.build`) and
PSpice's ``vswitch``/``iswitch`` switches (:func:`realise_switch`).

Examples
--------
>>> b = parse_behavior("ltpsa")
>>> b.pspice, b.ltspice, b.all, b.translates(main=True)
(True, True, True, True)
>>> parse_behavior("ps").translates(main=True), parse_behavior("ps").translates(main=False)
(False, True)
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

from ..circuit import Diagnostic, Element
from ..errors import NetlistError, SourceLocation
from ..kinds import Kind
from . import expr as ex
from .lines import Card, fold_case

__all__ = ["Behavior", "parse_behavior", "read_spiceinit", "find_behavior", "translate_cards", "translate_ltspice",
           "realise_switch",
           "SPICEINIT", "MODE_HINT"]

#: The start-up file ngspice reads from the working directory (else from the home directory).
SPICEINIT = ".spiceinit"
#: How to select ngspice's PSpice compatibility mode for a netlist, for refusals outside it.
MODE_HINT = ("select ngspice's PSpice compatibility mode: a line 'set ngbehavior=psa' in a .spiceinit next to the "
             "netlist (or 'ps' for included files only), or netdae's --ngbehavior psa / load(..., behavior='psa')")

#: ngspice's mode codes (``set_compat_mode``): code -> meaning; netdae translates for ``ps`` only.
_CODES = {"hs": "HSPICE", "ps": "PSpice", "xs": "XSPICE", "lt": "LTspice", "ki": "KiCad", "a": "all",
          "ll": "all (unused)", "s3": "Spice3 only", "eg": "EAGLE", "spe": "Spectre", "mc": "make check"}


@dataclass(frozen=True)
class Behavior:
    """An ngspice compatibility mode, as ``set ngbehavior=VALUE`` selects it.

    Attributes
    ----------
    value : str
        The value as written (lower case).
    pspice, ltspice, all : bool
        ngspice's ``ps``, ``lt`` and ``a`` flags after its own rules (``spe`` clears ``ps`` and
        ``lt``; ``mc`` clears everything).
    others : tuple of str
        The other codes set (``hs``, ``xs``, ``ki``, ``eg``, ``spe``, ``s3``, ``ll``): named in a
        note, no translation.
    location : SourceLocation or None
        The ``.spiceinit`` line it comes from (None: given by the caller).
    """

    value: str
    pspice: bool = False
    ltspice: bool = False
    all: bool = False
    others: tuple = ()
    location: SourceLocation | None = None

    def translates(self, *, main: bool) -> bool:
        """True when ngspice translates PSpice idioms in the cards of this file (``main``: the netlist itself)."""
        return self.pspice and (self.all or not main)

    def translates_ltspice(self, *, main: bool) -> bool:
        """True when ngspice translates LTspice idioms in the cards of this file (the same scope rule)."""
        return self.ltspice and (self.all or not main)

    @property
    def bins_by_finger(self) -> bool:
        """ngspice chooses a BSIM bin by the width of one finger (``w/nf``) unless ``wnflag`` says otherwise.

        Its ``INPgetModBin`` defaults ``.options wnflag`` to 1 in the HSPICE and Spectre modes
        (``hs``, ``spe``), to 0 otherwise.
        """
        return "hs" in self.others or "spe" in self.others

    @property
    def reads_lib_as_include(self) -> bool:
        """ngspice 39 reads every ``.lib`` card as ``.include`` in its PSpice and LTspice modes."""
        return self.pspice or self.ltspice

    @property
    def ngspice_value(self) -> str:
        """The value netdae hands ngspice: ``a`` added to a PSpice mode without it.

        The deck netdae hands ngspice is one file, its includes expanded in place
        (:mod:`netdae.ngspice.deck`), so ngspice's ``ps`` would translate nothing; with ``psa``
        it translates the cards of the included files as ``ps`` does, and the main file's too
        (``lt`` alike).
        """
        return self.value + "a" if (self.pspice or self.ltspice) and not self.all else self.value

    def describe(self) -> str:
        """The mode in words, e.g. ``"ngbehavior=ltpsa (PSpice, LTspice, all)"``."""
        names = [_CODES[c] for c, on in (("ps", self.pspice), ("lt", self.ltspice), ("a", self.all)) if on]
        names += [_CODES[c] for c in self.others]
        return f"ngbehavior={self.value} ({', '.join(names) or 'no mode'})"


def parse_behavior(value: str, location: SourceLocation | None = None) -> Behavior | None:
    """The mode of ``set ngbehavior=value``, read as ngspice 39 reads it; None when it selects none.

    Parameters
    ----------
    value : str
        E.g. ``"ps"``, ``"psa"``, ``"ltpsa"``.
    location : SourceLocation, optional
        Where the value was written.

    Returns
    -------
    Behavior or None

    Raises
    ------
    NetlistError
        A value with other characters than letters and digits.
    """
    v = fold_case(value.strip().strip("\"'"))
    if not v:
        return None
    if not re.fullmatch(r"[a-z0-9]+", v):
        raise NetlistError(f"ngbehavior={value!r}: expected letters such as ps, psa, lt, ltpsa", location,
                           hint="write set ngbehavior=psa (PSpice's idioms in every file) or ps (in included files)")
    on = {code: code in v for code in _CODES}  # ngspice: strstr(behaviour, code)
    if on["spe"]:
        on["ps"] = on["lt"] = on["ki"] = on["eg"] = False
    if on["mc"]:
        return None
    if on["hs"] and on["ps"]:
        on["hs"] = False  # ngspice: 'hs and ps compatibility are mutually exclusive, switch to ps'
    others = tuple(c for c in ("hs", "xs", "ki", "eg", "spe", "s3", "ll") if on[c])
    if not (on["ps"] or on["lt"] or on["a"] or others):
        return None
    return Behavior(v, on["ps"], on["lt"], on["a"], others, location)


_SET = re.compile(r"^set\s+(.*)$", re.I)
_ASSIGN = re.compile(r"([a-z_][a-z0-9_]*)(?:\s*=\s*(\"[^\"]*\"|'[^']*'|\(.*?\)|\S+))?", re.I)


def read_spiceinit(path: str) -> tuple[Behavior | None, list[Diagnostic]]:
    """The ``set ngbehavior=VALUE`` of an ngspice start-up file, and a note for every other line.

    Nothing else in the file is executed or read: ``.spiceinit`` is a script of ngspice's
    control language (it may run commands); netdae takes the mode from it and lists every
    other command as ignored, at its line. The last ``set ngbehavior`` wins, an ``unset
    ngbehavior`` clears it (as running the script would).

    Parameters
    ----------
    path : str

    Returns
    -------
    behavior : Behavior or None
    notes : list of Diagnostic

    Raises
    ------
    NetlistError
        The file cannot be read.
    """
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
    except OSError as exc:
        raise NetlistError(f"cannot read ngspice's start-up file '{path}': {exc.strerror}",
                           SourceLocation(path, 1)) from None
    behavior = None
    notes: list[Diagnostic] = []
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if not text or text[0] in "*#":
            continue
        col = len(line) - len(line.lstrip()) + 1
        where = SourceLocation(path, number, col)
        m = _SET.match(text)
        if fold_case(text).split()[0] == "unset" and "ngbehavior" in fold_case(text).split()[1:]:
            behavior = None
            notes.append(Diagnostic("note", "unset ngbehavior: no compatibility mode from here on", where))
            continue
        ignored = text
        if m is not None:
            rest = []
            for a in _ASSIGN.finditer(m.group(1)):
                if fold_case(a.group(1)) == "ngbehavior" and a.group(2):
                    behavior = parse_behavior(a.group(2), SourceLocation(path, number, col + m.start(1) + a.start()))
                else:
                    rest.append(a.group(0))
            ignored = "set " + " ".join(rest) if rest else ""
        if ignored:
            notes.append(Diagnostic("note", f"'{ignored}' ignored: netdae reads only 'set ngbehavior=...' from "
                                    "ngspice's start-up file (it never executes it)", where))
    return behavior, notes


def find_behavior(netlist_dir: str | None) -> tuple[Behavior | None, list[Diagnostic]]:
    """The mode of the ``.spiceinit`` netdae reads for a netlist, and the notes about that file.

    netdae looks for ``.spiceinit`` in the netlist's directory, then in the working directory
    (ngspice reads it from its working directory, else from the home directory; netdae does
    not read the home directory's, nor ngspice's system-wide ``spinit``). The first file found
    is read (:func:`read_spiceinit`); none found: no mode.

    Parameters
    ----------
    netlist_dir : str or None
        The directory of the netlist (None or ``""`` for text without a path: the working
        directory only).
    """
    seen = set()
    for directory in (netlist_dir or os.curdir, os.curdir):
        candidate = os.path.join(directory, SPICEINIT)
        key = os.path.realpath(candidate)
        if key in seen:
            continue
        seen.add(key)
        if os.path.isfile(candidate):
            behavior, notes = read_spiceinit(candidate)
            if behavior is not None:
                notes.append(Diagnostic("note", f"ngspice's compatibility mode {behavior.describe()} from "
                                        f"{candidate}", behavior.location))
            return behavior, notes
    return None, []


# --- card translations ------------------------------------------------------------------------------------------

def _rewrite(card: Card, edits: list[tuple[int, int, str]]) -> Card:
    """A copy of ``card`` with ``raw[start:end]`` replaced by each edit's text, locations kept.

    Each replacement is located at the first character it replaces (an insertion at the
    character it precedes); the unchanged text keeps its own locations.
    """
    if not edits:
        return card
    raw = card.raw
    breaks = [s[0] for s in card.spans]
    pieces: list[str] = []
    spans: list[tuple[int, int, int]] = []
    length = 0

    def anchor(offset: int) -> None:
        loc = card.location(offset)
        if spans and spans[-1][0] == length:
            spans.pop()
        spans.append((length, loc.line, loc.column))

    def keep(a: int, b: int) -> None:
        nonlocal length
        cuts = [a] + [s for s in breaks if a < s < b] + [b]
        for c, d in zip(cuts, cuts[1:]):
            anchor(c)
            pieces.append(raw[c:d])
            length += d - c

    pos = 0
    for start, end, text in sorted(edits):
        if start > pos:
            keep(pos, start)
        if text:
            anchor(start)
            pieces.append(text)
            length += len(text)
        pos = max(pos, end)
    if pos < len(raw):
        keep(pos, len(raw))
    new = Card("".join(pieces), card.file, spans or [card.spans[0]])
    new.compat = card.compat
    return new


def _logic_edits(card: Card) -> list[tuple[int, int, str]]:
    """PSpice's ``&``, ``|``, ``~`` as ngspice's ``&&``, ``||``, ``!`` (pspice_compat: every card, raw text).

    As ngspice, a doubled ``&&``/``||`` is left alone, and ``~`` is kept on ``.include``,
    ``.lib`` and ``A`` cards (a path or an XSPICE port).
    """
    text = card.text
    edits = []
    for char, double in (("&", "&&"), ("|", "||")):
        i = text.find(char)
        while i >= 0:
            if text.startswith(double, i):
                i = text.find(char, i + 2)
                continue
            edits.append((i, i + 1, double))
            i = text.find(char, i + 1)
    if "~" in text and not (text.startswith((".inc", ".lib")) or text[0] == "a"):
        edits.extend((i, i + 1, "!") for i, c in enumerate(text) if c == "~")
    return edits


_WORD = r"(?<![a-z0-9_.])"
_VALUE_WORD = re.compile(r"(?<![a-z0-9_.])(value|cur)(?![a-z0-9_])")
_TABLE_CALL = re.compile(r"(?<![a-z0-9_.])table\(")


_PWR_CALL = re.compile(r"(?<![a-z0-9_.])pwr(?=\s*\()")


def _function_edits(card: Card) -> list[tuple[int, int, str]]:
    """``pwr(x, a)`` as ``pow(x, a)``: ngspice's PSpice mode defines ``.func pwr(x, a) {pow(x, a)}``."""
    return [(m.start(), m.end(), "pow") for m in _PWR_CALL.finditer(card.text)]


def _params_comma_edits(card: Card) -> list[tuple[int, int, str]]:
    """Commas between the ``params:`` of ``.subckt`` and X cards as blanks (outside braces), as ngspice's mode."""
    text = card.text
    if not (text.startswith(".subckt") or text[0] == "x"):
        return []
    at = text.find("params:")
    if at < 0:
        return []
    edits, depth = [], 0
    for i in range(at + 7, len(text)):
        c = text[i]
        depth += (c == "{") - (c == "}")
        if c == "," and depth == 0:
            edits.append((i, i + 1, " "))
    return edits


def _substrate_edits(card: Card) -> list[tuple[int, int, str]]:
    """PSpice's substrate node in brackets (``Q1 c b e [s] model``) without them, as ngspice's mode reads it."""
    text = card.text
    if text[0] != "q":
        return []
    words = list(re.finditer(r"\S+", text))
    if len(words) < 5 or not words[4].group().startswith("["):
        return []
    close = text.find("]", words[4].start())
    if close < 0:
        return []
    return [(words[4].start(), words[4].start() + 1, " "), (close, close + 1, " ")]


def _table_edits(card: Card) -> list[tuple[int, int, str]]:
    """PSpice's ``TABLE(x, x0, y0, ...)`` in an E/G ``VALUE`` expression as ngspice's ``pwl(...)`` (replace_table).

    ngspice moves each call to a B source of its own driving a new node and reads that node's
    voltage in its place: the same value; netdae calls ``pwl`` in place.
    """
    text = card.text
    m = _VALUE_WORD.search(text)
    if text[0] not in "eg" or m is None or (m.group(1) == "cur" and text[0] != "g"):
        return []
    return [(t.start(), t.end(), "pwl(") for t in _TABLE_CALL.finditer(text, m.end())]

_TEMP_NAMES = re.compile(_WORD + r"(t_abs|t_rel_global|t_measured)(?=\s*=)")
_TEMP_RENAMES = {"t_abs": "temp", "t_rel_global": "dtemp", "t_measured": "tnom"}
_LEVEL = re.compile(_WORD + r"level\s*=\s*(\d+)(?![0-9.e])")
_MC_TOLERANCE = re.compile(_WORD + r"(dev|lot)\s*=\s*[^\s()]*")
#: PSpice's model levels ngspice's PSpice mode maps to its own (``pspice_compat``): (types, level) -> text.
_LEVEL_MAPS = {("mos", "5"): "level=44", ("mos", "6"): "level=8 version=3.2.4", ("mos", "7"): "level=8 version=3.2.4",
               ("mos", "8"): "level=14 version=4.5.0", ("bjt", "2"): "level=6"}
_MODEL_HEAD = re.compile(r"\.model\s+\S+\s+([a-z_][a-z0-9_]*)")


def _model_edits(card: Card) -> list[tuple[int, int, str]]:
    """``.model`` rewrites of ngspice's PSpice mode: temperature names, levels, Monte-Carlo tolerances."""
    text = card.text
    edits = []
    m = _TEMP_NAMES.search(text)  # ngspice renames the first of the three only
    if m is not None:
        edits.append((m.start(1), m.end(1), _TEMP_RENAMES[m.group(1)]))
    head = _MODEL_HEAD.match(text)
    if head is not None:
        mtype = head.group(1)
        family = "mos" if mtype in ("nmos", "pmos") else "bjt" if mtype in ("npn", "pnp") else None
        if mtype == "lpnp":
            edits.append((head.start(1), head.end(1), "pnp level=1 subs=-1"))
        lv = _LEVEL.search(text, head.end())
        if family is not None and lv is not None and (family, lv.group(1)) in _LEVEL_MAPS:
            edits.append((lv.start(), lv.end(), _LEVEL_MAPS[family, lv.group(1)]))
        edits.extend((t.start(), t.end(), "") for t in _MC_TOLERANCE.finditer(text, head.end()))
    return edits


def _synthetic(text: str, near: Card) -> Card:
    """A card ngspice's PSpice mode adds, located at the card it stands before."""
    card = Card(text, near.file, [(0, near.line, near.spans[0][2])])
    card.compat = True
    return card


#: The parameters ngspice's PSpice mode defines at the start of the translated cards and of every subcircuit
#: (the first two), and the functions it defines that netdae has no built-in for (``limit``, ``if``, ``int`` are
#: netdae's own, with the same meaning; ``pwr`` is read as ``pow``, :func:`_function_edits`).
PREDEFINED = (".param temp = 'temper'", ".param vt = '(temper + 273.15) * 8.6173303e-5'", ".param gmin = 1e-12",
              ".func pwrs(x, a) {sgn(x) * pow(x, a)}", ".func stp(x) {u(x)}")


def translate_cards(cards: list[Card], behavior: Behavior, *, predefine: bool = True
                    ) -> tuple[list[Card], list[Diagnostic]]:
    """The PSpice translations of ngspice 39's ``pspice_compat`` on one file's cards.

    Text translations (each located at the characters it replaces): ``&`` ``|`` ``~`` as
    ``&&`` ``||`` ``!``; ``TABLE(...)`` in the ``VALUE`` of E and G cards as ``pwl(...)``;
    ``pwr(`` as ``pow(``; commas between ``params:`` as blanks; a Q card's ``[substrate]``
    node without its brackets;
    in ``.model`` cards ``T_ABS``/``T_REL_GLOBAL``/``T_MEASURED`` as
    ``temp``/``dtemp``/``tnom``, the PSpice levels of MOSFET and BJT models as ngspice's,
    ``LPNP`` as a lateral PNP and ``DEV=``/``LOT=`` tolerances removed; ``.distribution``
    cards dropped; the parameters ``temp``, ``vt`` and ``gmin`` and the functions ``pwrs``
    and ``stp`` defined before the cards (and ``temp``, ``vt`` at the start of each subcircuit). Every card is marked
    (``Card.compat``) for the translations that need the parsed netlist.

    Parameters
    ----------
    cards : list of Card
        One file's cards, before its includes are expanded.
    behavior : Behavior
    predefine : bool
        Define ``temp``, ``vt``, ``gmin``, ``pwrs`` and ``stp`` before the cards. ngspice does it once per
        translated text (the whole deck in ``psa``, each included file in ``ps``); netdae
        once per netlist, in the first file translated (the values are the same).

    Returns
    -------
    cards : list of Card
    notes : list of Diagnostic
    """
    out: list[Card] = []
    notes: list[Diagnostic] = []
    if not cards:
        return out, notes
    if predefine:
        out.extend(_synthetic(text, cards[0]) for text in PREDEFINED)
    for card in cards:
        card.compat = True
        text = card.text
        if text.startswith(".distribution"):
            notes.append(Diagnostic("note", ".distribution dropped: PSpice's Monte-Carlo distribution (as ngspice's "
                                    "PSpice mode does)", card.location(0)))
            continue
        edits = (_logic_edits(card) + _table_edits(card) + _function_edits(card) + _params_comma_edits(card)
                 + _substrate_edits(card))
        if text.startswith(".model"):
            edits += _model_edits(card)
        out.append(_rewrite(card, edits) if edits else card)
        if text.startswith(".subckt"):
            out.extend(_synthetic(t, card) for t in PREDEFINED[:2])
    return out, notes


# --- LTspice's mode ----------------------------------------------------------------------------------------------

#: The functions ngspice's LTspice mode defines (``ltspice_compat``): soft limits.
LTSPICE_FUNCTIONS = (
    ".func uplim(x, pos, z) {min(x, pos - z) + (1 - (min(max(0, x - pos + z), 2 * z) / 2 / z - 1)**2) * z}",
    ".func dnlim(x, neg, z) {max(x, neg + z) - (1 - (min(max(0, -x + neg + z), 2 * z) / 2 / z - 1)**2) * z}",
    ".func uplim_tanh(x, pos, z) {min(x, pos - z) + tanh(max(0, x - pos + z) / z) * z}",
    ".func dnlim_tanh(x, neg, z) {max(x, neg + z) - tanh(max(0, neg + z - x) / z) * z}")
#: Diode model parameters of LTspice's ideal diode, which ngspice's LTspice mode runs as its XSPICE ``sidiode``.
SIDIODE_PARAMETERS = ("roff", "ron", "rrev", "vfwd", "vrev", "revepsilon", "epsilon", "revilimit", "ilimit")
_NOISELESS = re.compile(r"(?<=\s)noiseless(?=\s|$)")
_DIODE_MODEL = re.compile(r"\.model\s+\S+\s+d(?![a-z0-9_])")


def translate_ltspice(cards: list[Card], *, predefine: bool = True) -> tuple[list[Card], list[Diagnostic]]:
    """The translations of ngspice 39's ``ltspice_compat`` netdae does, on one file's cards.

    The functions ``uplim``, ``dnlim``, ``uplim_tanh``, ``dnlim_tanh`` defined before the cards
    (once per netlist, ``predefine``); ``.backanno`` dropped; ``noiseless`` on an R card read as
    ``noisy=0``. A diode model with LTspice's ideal-diode parameters (ngspice runs it as its
    XSPICE ``sidiode``) is refused by name.

    Raises
    ------
    NetlistError
        A diode model with ``ron``, ``roff``, ``vfwd`` ... (:data:`SIDIODE_PARAMETERS`).
    """
    out: list[Card] = []
    notes: list[Diagnostic] = []
    if not cards:
        return out, notes
    if predefine:
        out.extend(_synthetic(text, cards[0]) for text in LTSPICE_FUNCTIONS)
    for card in cards:
        text = card.text
        if text.startswith(".backanno"):
            notes.append(Diagnostic("note", ".backanno dropped (LTspice's annotation, as ngspice's LTspice mode "
                                    "does)", card.location(0)))
            continue
        if text[0] == "r":
            m = _NOISELESS.search(text)
            if m is not None:
                card = _rewrite(card, [(m.start(), m.end(), "noisy=0")])
        elif _DIODE_MODEL.match(text):
            found = next((m for name in SIDIODE_PARAMETERS
                          if (m := re.search(rf"(?<![a-z0-9_]){name}\s*=", text)) is not None), None)
            if found is not None:
                raise NetlistError(f"{text.split()[1]}: a diode model with LTspice's ideal-diode parameters "
                                   f"('{found.group().rstrip('= ')}'), which ngspice's LTspice mode runs as its XSPICE "
                                   "sidiode code model: not supported by netdae", card.location(found.start()),
                                   hint="model the diode with ngspice's diode parameters (is, n, rs ...)")
        out.append(card)
    return out, notes


# --- PSpice's switches ------------------------------------------------------------------------------------------

#: ngspice's defaults for a PSpice switch model's missing parameters (``pspice_compat``): PSpice's.
SWITCH_DEFAULTS = {"vswitch": {"von": 1.0, "voff": 0.0, "ron": 1.0, "roff": 1.0e6},
                   "iswitch": {"ion": 1.0, "ioff": 0.0, "ron": 1.0, "roff": 1.0e6}}
#: Per PSpice switch model: its PSpice parameters, ngspice's own switch parameters, and ngspice's model type.
SWITCH_FORMS = {"vswitch": (("von", "voff"), ("vt", "vh"), "sw"), "iswitch": (("ion", "ioff"), ("it", "ih"), "csw")}
#: The XSPICE code models' resistance limits: pswitch keeps r_on >= 1 mOhm and r_off <= 1 TOhm, aswitch r_on >= 1 mOhm.
R_ON_MIN, PSWITCH_R_OFF_MAX = 1.0e-3, 1.0e12
#: pswitch's control-port input resistance (``r_cntl_in``, its default).
PSWITCH_R_CONTROL = 1.0e12
#: pswitch widens a transition narrower than this by 1 mV each way.
PSWITCH_MIN_SPAN = 1.0e-12


def switch_form(mtype: str, params) -> str | None:
    """How ngspice's PSpice mode reads a ``vswitch``/``iswitch`` model with these parameter names.

    Returns ``"sw"``/``"csw"`` (ngspice's own switch: the model gives ``vt``/``vh``, ``it``/``ih``),
    ``"smooth"`` (PSpice's: ``von``/``voff``, ``ion``/``ioff``) or None (neither: ngspice's
    "Bad switch model").
    """
    smooth, native, ngspice_type = SWITCH_FORMS[mtype]
    if any(k in params for k in native):
        return ngspice_type
    if any(k in params for k in smooth):
        return "smooth"
    return None


def realise_switch(el: Element, mtype: str, params: dict) -> list[Element]:
    """PSpice's smooth switch as ngspice's PSpice mode runs it, in netdae's element kinds.

    ngspice 39 replaces ``Sname d s c+ c- m`` with a ``vswitch`` model of ``VON``/``VOFF``
    by its XSPICE ``pswitch`` (``log=TRUE``), and ``Wname d s vctl m`` with an ``iswitch``
    model by ``aswitch`` (``log=TRUE limit=TRUE``) controlled by the current of ``vctl``.
    Their resistances between ``d`` and ``s`` are, with ``x`` the control:

    - ``pswitch``: ``s = (x - off)/(on - off)`` clamped to [0, 1], ``m = s - 1/2``,
      ``ln r = ln sqrt(ron roff) + ln(ron/roff) (3/2 m - 2 m^3)`` (a cubic in ``ln r``, flat
      at both ends; PSpice's law), ``ron >= 1 mOhm``, ``roff <= 1 TOhm``; a control port of
      1 TOhm (``r_cntl_in``);
    - ``aswitch``: ``r = ron exp(ln(roff/ron) (on - x)/(on - off))`` clamped to [ron, roff].

    netdae realises each as a behavioural current ``v(d,s)/r(x)`` named as the card (plus,
    for ``pswitch``, the resistor ``<name>#rc`` across the control port).

    Parameters
    ----------
    el : Element
        The S or W element (nodes, and the controlling source in ``controls`` for W).
    mtype : str
        ``"vswitch"`` or ``"iswitch"``.
    params : dict
        The model's evaluated parameters.

    Returns
    -------
    list of Element
        The behavioural current (named as the card) first.

    Raises
    ------
    ValueError
        ``RON`` or ``ROFF`` not positive, or ``ION`` equal to ``IOFF`` (the message says which).
    """
    defaults = SWITCH_DEFAULTS[mtype]
    p = {k: params.get(k, v) for k, v in defaults.items()}
    for key in ("ron", "roff"):
        if not (p[key] > 0.0 and math.isfinite(p[key])):
            raise ValueError(f"{key}={p[key]:g}: a resistance of PSpice's switch must be positive and finite")
    common = dict(location=el.location, instance_path=el.instance_path)
    d, s = el.nodes[0], el.nodes[1]
    v_out = ex.Voltage(d, s)
    const = ex.Const
    r_on = max(p["ron"], R_ON_MIN)
    if "von" in defaults:  # vswitch
        on, off = p["von"], p["voff"]
        if abs(on - off) < PSWITCH_MIN_SPAN:
            on, off = on + 0.001, off - 0.001
        r_off = min(p["roff"], PSWITCH_R_OFF_MAX)
        x = ex.Voltage(el.nodes[2], el.nodes[3])
        frac = ex.Binary("/", ex.Binary("-", x, const(off)), const(on - off))
        m = ex.Binary("-", ex.Call("min", (ex.Call("max", (frac, const(0.0))), const(1.0))), const(0.5))
        ratio = math.log(r_on / r_off)
        cubic = ex.Binary("-", ex.Binary("*", const(1.5 * ratio), m),
                          ex.Binary("*", const(2.0 * ratio), ex.Binary("*", m, ex.Binary("*", m, m))))
        log_r = ex.Binary("+", const(math.log(math.sqrt(r_on * r_off))), cubic)
        current = ex.Binary("*", v_out, ex.Call("exp", (ex.Unary("-", log_r),)))
        control = Element(f"{el.name}#rc", Kind.RESISTOR, (el.nodes[2], el.nodes[3]), value=PSWITCH_R_CONTROL,
                          **common)
        return [Element(el.name, Kind.BCURRENT, (d, s), expr=current, **common), control]
    on, off = p["ion"], p["ioff"]
    r_off = p["roff"]
    if on == off:
        raise ValueError("ion equals ioff: the switch has no transition (ngspice's aswitch: 'CONTROL voltage delta "
                         "less than 1.0e-12'); give them different values")
    x = ex.Current(el.controls[0])
    k = math.log(r_off / r_on) / (on - off)
    # ln r = ln ron + k (on - x), clamped to [ln ron, ln roff]: the conductance exp(-ln r)
    log_r = ex.Binary("+", const(math.log(r_on)), ex.Binary("*", const(k), ex.Binary("-", const(on), x)))
    lo, hi = sorted((math.log(r_on), math.log(r_off)))
    clamped = ex.Call("min", (ex.Call("max", (log_r, const(lo))), const(hi)))
    current = ex.Binary("*", v_out, ex.Call("exp", (ex.Unary("-", clamped),)))
    return [Element(el.name, Kind.BCURRENT, (d, s), expr=current, **common)]
