"""The one netlist ngspice is given: self-contained and written by netdae.

ngspice is a command interpreter as much as a simulator: besides
``.control`` blocks (any card that *begins* with ``.control``), it runs a file
whose title starts with ``*ng_script`` (also when a ``.title`` card sets it)
as a script, runs ``*#`` comment lines as commands, reads files named by any
card beginning with ``.inc`` or ``.lib`` (the title line included), stops
reading at a line beginning with ``@``, and reads the cards after ``.end``.
A netlist -- or a vendor model file it includes -- could therefore make
ngspice run commands (``shell``) or read and write files.

netdae never hands ngspice the user's files. :func:`self_contained` reads
the netlist with netdae's own reader (:func:`netdae.netlist.reader.read_deck`:
``.include`` files and ``.lib`` sections expanded in place, ``.control``
blocks replaced by the dot cards of the commands netdae reads in them
(:mod:`netdae.netlist.control`: ``op``, ``tran``, ``save``, ``option`` ...;
never a command that runs anything), the main file ended at ``.end``) and
writes it back as

- one title line that cannot be taken for a command or a card (a title that
  does not begin with a letter or digit is prefixed with ``netdae:``; the
  last ``.title`` card, which would replace the title in ngspice, becomes
  the title line);
- one line per card, continuation lines joined and comments removed: only
  element cards of the kinds netdae reads (R C L K V I E F G H B D Q M J S W N X;
  S and W cards must parse as switches, so that a stray ``shell ...`` or
  ``write ...`` command is refused too) and the dot cards of
  :data:`DOT_CARDS`; anything else, e.g.
  ``.controlfoo``, ``.includex`` or an XSPICE ``A`` device (code models read
  and write files), is a :class:`~netdae.errors.NetlistError` at its
  location;
- a final ``.end``.

A block in ngspice's control language (variables, loops, ``alter``), which
netdae runs with its own interpreter, is not handed over either: in its place
:func:`script_block` writes a control block of netdae's own, every analysis
of the circuit in netdae's order, each preceded by the ``alter``/``altermod``
commands netdae ran before it, with numbers only (the dot analysis cards move
into it).

Every skipped block and dropped card is a note. The backends run this text
in a private temporary directory with the user's ``.spiceinit`` disabled
(:mod:`netdae.ngspice.batch`, :mod:`netdae.ngspice.shared`).

Examples
--------
>>> lines, origins, notes = self_contained("*ng_script\\nR1 1 0 1k ; load\\n+ \\n.control\\nshell ls\\n.endc\\n.op\\n")
>>> lines
['netdae: *ng_script', 'R1 1 0 1k', '.op', '.end']
>>> str(origins[1]), notes[0].startswith("line 1: title")
('lines 2-3', True)
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

from ..errors import NetlistError
from ..netlist.elements import parse_element
from ..netlist.lines import AFTER_END, split_cards
from ..netlist.reader import STRING_SOURCE, read_deck
from ..netlist.syntax import ELEMENTS, IGNORED_DOT_CARDS

__all__ = ["DOT_CARDS", "Origin", "self_contained", "script_block", "SCRIPT_MARK", "SCRIPT_RAW"]

#: The dot cards handed to ngspice: those netdae's reader knows, none of which
#: makes ngspice read a file or run a command (``.title`` becomes the title
#: line; ``.include``, ``.lib`` and ``.control`` never reach ngspice).
DOT_CARDS = frozenset(
    ".param .func .subckt .ends .model .global .op .dc .ac .tran .pz .tf .noise .sens .ic .nodeset .options .option .opt "
    ".temp .save .print .plot .probe .meas .measure .four .fourier".split()
)
#: Title prefix when the title could be read by ngspice as a command or a card.
TITLE_PREFIX = "netdae: "
_WORD_END = re.compile(r"[\s(=]")
#: ngspice's prefixes for cards that read files or open a control block.
_DANGEROUS = {
    ".control": "ngspice takes any card beginning with .control for a control block and runs its commands",
    ".endc": "ngspice takes it for the end of a control block",
    ".inc": "ngspice takes any card beginning with .inc for an include and reads the file it names",
    ".lib": "ngspice takes any card beginning with .lib for a library reference and reads the file it names",
}


def _first_word(text: str) -> str:
    match = _WORD_END.search(text)
    return text[: match.start()] if match else text


@dataclass(frozen=True)
class Origin:
    """Where a written line comes from.

    Attributes
    ----------
    file : str
        The file (or ``"<string>"``).
    first, last : int
        Its physical lines (continuations joined into one card).
    main : bool
        True for the main netlist, False for an included file.
    card : Card or None
        netdae's card (None for the title and the final ``.end``).
    """

    file: str
    first: int
    last: int
    main: bool = True
    card: object = None

    def __str__(self) -> str:
        lines = f"line {self.first}" if self.first == self.last else f"lines {self.first}-{self.last}"
        return lines if self.main else f"{self.file} {lines}"

    def location(self, word: str = ""):
        """The :class:`~netdae.errors.SourceLocation` of ``word`` in the card (its start if absent)."""
        if self.card is None:
            from ..errors import SourceLocation

            return SourceLocation(self.file, self.first)
        return self.card.location(max(self.card.text.find(word), 0) if word else 0)


def _safe_title(title: str) -> str:
    """A title ngspice reads as nothing but a title."""
    title = " ".join(title.split())
    if title[:1].isalnum():
        return title
    return (TITLE_PREFIX + title).rstrip()


def _refuse(card, word: str, dot: bool) -> NetlistError:
    if dot:
        reason = next((why for prefix, why in _DANGEROUS.items() if word.startswith(prefix)), None)
        return NetlistError(
            f"{word}: card not handed to ngspice" + (f" ({reason})" if reason else ""),
            card.location(0),
            hint="netdae hands ngspice only the cards it reads itself: " + " ".join(sorted(DOT_CARDS))
            + " and element cards",
        )
    letters = " ".join(k.upper() for k in ELEMENTS)
    hint = ("an XSPICE code model can read and write files; replace it by an equivalent circuit"
            if word[:1] == "a" else None)
    return NetlistError(
        f"{word}: card not handed to ngspice (netdae reads the element letters {letters} and dot cards)",
        card.location(0),
        hint=hint,
    )


def _after_end(text: str, last_line: int, source: str) -> tuple[int, int] | None:
    """(line of the main file's ``.end``, cards after it), None when nothing follows it."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    in_control = False
    for index in range(max(last_line, 1), len(lines)):
        head = lines[index].strip().lower()
        if in_control:
            in_control = not head.startswith(".endc")
        elif head.startswith(".control"):
            in_control = True
        elif _first_word(head) == ".end":
            try:
                _, cards, notes = split_cards("\n".join(lines[index + 1 :]), source, title=False)
                count = len(cards) + len(notes)
            except NetlistError:
                count = 1
            return (index + 1, count) if count else None
    return None


def self_contained(
    text: str, *, base_dir: str | os.PathLike | None = None, source: str = STRING_SOURCE, behavior=None
) -> tuple[list[str], list[Origin], list[str]]:
    """The netlist as the self-contained text netdae hands to ngspice.

    Parameters
    ----------
    text : str
        The netlist (first line is the title).
    base_dir : path-like, optional
        Directory that relative ``.include``/``.lib`` names refer to (the
        netlist's directory); the current directory by default.
    source : str
        Name of the netlist in locations and notes.
    behavior : str or Behavior, optional
        ngspice's compatibility mode (:func:`netdae.netlist.reader.read_deck`): the cards are
        read in it (``.lib`` as ``.include``, ``$``) but not translated (ngspice, run in the same
        mode, translates them itself).

    Returns
    -------
    lines : list of str
        The title, one line per card, ``.end``.
    origins : list of Origin
        For each line, where it comes from; as text ``"line 4"``,
        ``"lines 4-6"`` (continuations joined), ``"models/d.lib line 3"`` (an
        included file).
    notes : list of str
        Every block skipped and every card dropped, and a changed title.

    Raises
    ------
    NetlistError
        A card ngspice would take for a control block or a file reference
        (``.controlfoo``, ``.includex``), another dot card netdae does not
        read, an element letter netdae does not read, and what the reader
        raises (a missing include file, an unclosed ``.control`` block ...).

    Notes
    -----
    Cost: one pass of netdae's reader over the netlist and its includes.
    """
    path = source if source != STRING_SOURCE else None
    if base_dir is not None and (path is None or not os.path.isabs(path)):
        path = os.path.join(os.fspath(base_dir), os.path.basename(source))
    deck = read_deck(text, path=path, behavior=behavior, translate=False)
    main = deck.path
    lines: list[str] = [""]
    origins: list[Origin] = [Origin(main, 1, 1)]
    notes = [f"{d.location}: {d.message}" if d.location else d.message for d in deck.notes]
    title = deck.title
    title_origin = origins[0]
    script = None
    for card in deck.cards:
        word = _first_word(card.text)
        where = Origin(card.file, card.line, card.spans[-1][1], card.file == main, card)
        if card.script is not None:  # a control-language block: its analyses and alter commands as netdae ran them
            script = where
            continue
        if word == ".title":
            title = card.raw[len(".title"):].strip()
            title_origin = where
            notes.append(f"{where}: .title card written as the title line (ngspice replaces the title with it)")
            continue
        if word == ".step":  # netdae's extension: compare hands ngspice one point at a time
            notes.append(f"{where}: .step (netdae's extension) not passed to ngspice; each point is a netlist "
                         "of its own")
            continue
        if word == ".backanno" and deck.behavior is not None and deck.behavior.ltspice:
            notes.append(f"{where}: .backanno not passed to ngspice (LTspice's annotation, which ngspice's LTspice "
                         "mode comments out)")
            continue
        if word in IGNORED_DOT_CARDS:  # netdae's reader skips them; the control block they serve is not handed over
            notes.append(f"{where}: {word} not passed to ngspice (it sets {IGNORED_DOT_CARDS[word]})")
            continue
        if word.startswith("."):
            if word not in DOT_CARDS:
                raise _refuse(card, word, True)
        elif word[:1] not in ELEMENTS:
            raise _refuse(card, word, False)
        elif word[:1] in "sw":
            # a switch card must read as one: ngspice's commands 'shell ...', 'write ...' begin with
            # these letters (harmless outside a control block, but never handed over)
            parse_element(card)
        lines.append(card.raw.rstrip())
        origins.append(where)
    lines[0] = _safe_title(title)
    origins[0] = title_origin
    if lines[0] != " ".join(title.split()):
        notes.insert(0, f"{title_origin}: title {title!r} written as {lines[0]!r} (ngspice would read a title "
                        "beginning with '*', '.' or '@' as a script marker, a card or the end of the input)")
    main_lines = [c.spans[-1][1] for c in deck.cards if c.file == main]
    after = _after_end(text, max(main_lines, default=1), main)
    if after is not None:
        line, count = after
        # the reader's warning at .end says the same for netdae alone: this note replaces it
        notes = [n for n in notes if AFTER_END not in n]
        notes.append(f"line {line}: the {count} card(s) or block(s) after .end are not passed to ngspice "
                     "(netdae's reader ends the netlist at .end; ngspice 39 would read them)")
    if script is not None:
        kept = [(line, origin) for line, origin in zip(lines, origins)
                if origin.card is None or _first_word(origin.card.text) not in ANALYSIS_CARDS]
        lines, origins = [k[0] for k in kept], [k[1] for k in kept]
        block = script_block(text, path, behavior)
        lines += block
        origins += [script] * len(block)
        notes.append(f"{script}: the .control block's script is not passed to ngspice: netdae hands it every "
                     "analysis in netdae's order, with the alter and altermod commands netdae ran before each, as a "
                     "control block of its own")
    lines.append(".end")
    origins.append(Origin(main, len(text.splitlines()) + 1, len(text.splitlines()) + 1))
    return lines, origins, notes


#: The analysis cards (written as commands in the control block of a netlist with a script).
ANALYSIS_CARDS = frozenset(".op .dc .ac .tran .pz .tf .noise .sens".split())
#: The first line of the control block netdae writes (:func:`script_block`), by which the backends know it.
SCRIPT_MARK = "* netdae: analyses and alter commands"
#: The raw file the batch backend's script appends each analysis to.
SCRIPT_RAW = "out.raw"


def script_block(text: str, path: str | None, behavior=None) -> list[str]:
    """The control block netdae hands ngspice for a netlist with a control-language script.

    netdae runs the script itself (:func:`netdae.netlist.control.run_scripts`); ngspice is
    given its outcome, commands with numbers only: every analysis of the circuit in
    netdae's order, each preceded by the ``alter``/``altermod`` commands that change the
    circuit from the previous analysis's (``reset`` first when a change is undone), and
    followed by ``write`` to :data:`SCRIPT_RAW` (``set appendwrite``: one file, every plot),
    which the batch backend reads, and ``quit`` at the end (``ngspice -b`` would go on to run
    the dot analyses, here none, and exit with status 1); the shared library's backend sends
    the analyses and changes one by one instead (:mod:`netdae.ngspice.shared`).

    Returns
    -------
    list of str
        The output and option cards the script made (``.save``, ``.print``, ``.options``),
        ``.control``, the commands, ``.endc``.
    """
    from ..netlist import parse
    from ..netlist.control import change_key, elaborate_scripted, run_scripts

    net = parse(text, path=path, behavior=behavior)
    first, circuit = elaborate_scripted(net)
    made, _ = run_scripts(net, first)
    cards = [" ".join(c.raw.split()) for c in made if _first_word(c.text) not in ANALYSIS_CARDS]
    block = [*cards, ".control", SCRIPT_MARK, "set appendwrite"]
    before: dict = {}
    for card, written in zip(circuit.analyses, circuit.netlist.analyses):
        now = {change_key(c): c for c in card.alter}
        if any(key not in now for key in before):
            block.append("reset")
            before = {}
        block += [c.command for key, c in now.items() if before.get(key) != c]
        before = now
        block += [" ".join(written.card.raw.split())[1:], f"write {SCRIPT_RAW}"]
    block += ["quit", ".endc"]  # (ngspice -b would run the netlist's, here no, dot analyses next and fail)
    return block

