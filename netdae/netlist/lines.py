"""Physical lines to logical cards, as ngspice reads them.

Rules (ngspice 39, ``src/frontend/inpcom.c``):

- The first line of the main file is the title, whatever it contains
  (a first line ``.title text`` gives the title ``text``, as in ngspice).
  Included files have no title line.
- Lines starting with ``*`` (after leading blanks) and blank lines are comments.
- End-of-line comments start at ``;``, at ``//``, or at a ``$`` that opens
  the line or follows a blank, a tab or a comma.
- A line starting with ``+`` continues the previous card (comment lines may
  stand in between).
- ``.control`` ... ``.endc`` blocks (ngspice scripts) are never run: the
  commands that ask for an analysis, an output or an option become the
  equivalent dot cards, every other line a located note
  (:mod:`netdae.netlist.control`).
- In the main file ``.end`` ends the netlist: everything after it is
  ignored. ngspice ignores ``.end`` lines inside included files, and so does
  netdae (with a note).
- Everything is case-insensitive: :attr:`Card.text` is folded to lower case
  (ASCII letters only, so offsets stay valid); :attr:`Card.raw` keeps the
  original spelling for file names and titles.

Every card keeps the file, line and column of each of its characters
(:meth:`Card.location`), so a diagnostic can point at the offending token.

Examples
--------
>>> title, cards, notes = split_cards("my title\\nR1 a b\\n+ 1k ; load\\n.end\\nR2", "x.cir")
>>> title, [c.text for c in cards]
('my title', ['r1 a b 1k'])
>>> str(cards[0].location(cards[0].text.index("1k")))
'x.cir:3:3'
"""

from __future__ import annotations

import gc
import re
from bisect import bisect_right
from contextlib import contextmanager

from ..circuit import Diagnostic
from ..errors import NetlistError, SourceLocation

__all__ = ["Card", "Token", "split_cards", "fold_case", "no_gc"]

_LOWER = str.maketrans("ABCDEFGHIJKLMNOPQRSTUVWXYZ", "abcdefghijklmnopqrstuvwxyz")

# End-of-line comment starts: ';' anywhere, '//' anywhere, '$' at the start
# or after a blank, tab or comma (outside .control blocks, as ngspice).
_COMMENT = re.compile(r";|//|(?:^|(?<=[ \t,]))\$")
#: The same in ngspice's PSpice mode, where '$' starts no comment (ngspice 39's ``inp_stripcomments_line``).
_COMMENT_PSPICE = re.compile(r";|//")

# Characters that need the full tokenizer.
_SPECIAL = re.compile(r"""[=(),{}'"]""")

# Token starts: a word, one punctuation character, an expression in braces or
# single quotes, a double-quoted string, or any other single character.
_TOKEN = re.compile(r"""[^\s=(),{}'"]+|[=(),]|[{'"]|\S""")

#: Token kinds.
WORD, PUNCT, EXPR, STRING = "word", "punct", "expr", "string"


@contextmanager
def no_gc():
    """Pause Python's cyclic garbage collector while building a netlist.

    Reading a large netlist creates hundreds of thousands of long-lived
    objects, which trigger many useless collections (measured: a 100k-element
    netlist reads 2-3 times faster). The collector's previous state is
    restored on exit, also on errors.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def fold_case(text: str) -> str:
    """Lower-case ASCII letters only (offsets stay valid for any text)."""
    return text.lower() if text.isascii() else text.translate(_LOWER)


class Token:
    """One token of a card.

    Attributes
    ----------
    text : str
        The token (lower case); for ``{expr}`` and ``'expr'`` the expression
        inside the delimiters (it starts at offset ``start + 1``), for
        ``"string"`` the string without quotes (original case).
    kind : str
        ``"word"``, ``"punct"`` (``= ( ) ,``), ``"expr"`` or ``"string"``.
    start, end : int
        Offsets of the token in :attr:`Card.text` (delimiters included).
    """

    __slots__ = ("text", "kind", "start", "end")

    def __init__(self, text: str, kind: str, start: int, end: int) -> None:
        self.text = text
        self.kind = kind
        self.start = start
        self.end = end

    def __repr__(self) -> str:
        return f"Token({self.text!r}, {self.kind}, {self.start})"


class Card:
    """One logical line of a netlist (continuations joined).

    Attributes
    ----------
    text : str
        Lower-case text, continuation lines joined by one blank.
    raw : str
        The same text in its original case.
    file : str
        The file as given (or ``"<string>"``).
    spans : list of (offset, line, column)
        Where each physical line starts in :attr:`text`.
    notes : list of Diagnostic or None
        Warnings found while parsing the card (a number read only in part),
        collected by the parser with :meth:`take_notes`.
    compat : bool
        True when the card is in the scope of ngspice's PSpice compatibility
        mode (:mod:`netdae.netlist.compat`).
    alter : tuple of Alteration
        On an analysis card a ``.control`` block's script made: the ``alter``/``altermod``
        changes in force when it runs (:mod:`netdae.netlist.control`); empty otherwise.
    script : list of (line, column, text) or None
        On the ``.control`` card standing for a block that uses the control language
        (variables, loops, ``alter``): the block's lines, run by
        :func:`netdae.netlist.control.run_scripts` once the circuit's ``.csparam`` values are known.
    """

    __slots__ = ("text", "raw", "file", "spans", "_tokens", "notes", "compat", "alter", "script", "from_control",
                 "_located")

    def __init__(self, raw: str, file: str, spans: list[tuple[int, int, int]]) -> None:
        self.raw = raw
        text = fold_case(raw)
        self.text = raw if text == raw else text  # one string object for a card already in lower case
        self.file = file
        self.spans = spans
        self._tokens: list[Token] | None = None
        self.notes: list[Diagnostic] | None = None
        #: True when ngspice's PSpice compatibility mode translates this card (:mod:`netdae.netlist.compat`).
        self.compat = False
        self.alter: tuple = ()
        self.script: list[tuple[int, int, str]] | None = None
        #: A ``.meas`` card made of a ``.control`` block's ``meas`` command: one netdae cannot read (the parser:
        #: a located note) or measure (elaboration: an analysis the netlist does not run, a node it does not
        #: have; a located warning) is skipped, as ngspice goes on past a failed command, not refused.
        self.from_control = False
        #: The locations made so far (:meth:`location`), with the file and spans they were made from.
        self._located: tuple | None = None

    def warn(self, offset: int, message: str, severity: str = "warning") -> None:
        """Record a located warning (or note) about this card (its name prefixes ``message``)."""
        name = self.text.split(None, 1)[0] if self.text else ""
        if self.notes is None:
            self.notes = []
        self.notes.append(Diagnostic(severity, f"{name}: {message}", self.location(offset)))

    def take_notes(self) -> list[Diagnostic]:
        """The recorded warnings, removed from the card."""
        notes, self.notes = self.notes or [], None
        return notes

    @property
    def line(self) -> int:
        """Line number of the card's first physical line."""
        return self.spans[0][1]

    def location(self, offset: int = 0) -> SourceLocation:
        """The file position of character ``offset`` of :attr:`text`.

        Kept per offset (a location is immutable): every elaboration of the card (a sweep's rows) asks
        for the same ones.
        """
        spans = self.spans
        located = getattr(self, "_located", None)
        if located is None or located[0] is not spans or located[1] is not self.file:
            located = self._located = (spans, self.file, {})
        found = located[2].get(offset)
        if found is not None:
            return found
        if len(spans) == 1:
            start, line, col = spans[0]
        else:
            start, line, col = spans[bisect_right(spans, (offset, 1 << 62, 0)) - 1]
        found = located[2][offset] = SourceLocation(self.file, line, col + max(offset - start, 0))
        return found

    def tokens(self) -> list[Token]:
        """The card split into tokens (computed once).

        Raises
        ------
        NetlistError
            On an unterminated ``{``, ``'`` or ``"``, or a stray ``}``.
        """
        if self._tokens is None:
            self._tokens = _tokenize(self)
        return self._tokens

    def forget_tokens(self) -> None:
        """Drop the cached tokens (a later :meth:`tokens` splits the card again).

        The parser calls this once an element card is parsed: its tokens are
        no longer needed, and on a 100,000-element netlist they would hold
        about 100 MiB for the rest of the run.
        """
        self._tokens = None

    def __repr__(self) -> str:
        return f"Card({self.text!r} @ {self.file}:{self.line})"


def _closing_brace(text: str, start: int) -> int:
    """Index of the ``}`` matching the ``{`` at ``start``, or -1."""
    depth = 0
    i = start
    n = len(text)
    while i < n:
        j = min((k for k in (text.find("{", i), text.find("}", i)) if k >= 0), default=-1)
        if j < 0:
            return -1
        depth += 1 if text[j] == "{" else -1
        if depth == 0:
            return j
        i = j + 1
    return -1


def _tokenize(card: Card) -> list[Token]:
    text = card.text
    if _SPECIAL.search(text) is None:  # only blank-separated words: the common case
        out = []
        pos = 0
        find = text.find
        for word in text.split():
            start = find(word, pos)
            pos = start + len(word)
            out.append(Token(word, WORD, start, pos))
        return out
    name = text.split(None, 1)[0]
    out: list[Token] = []
    pos = 0
    n = len(text)
    finder = _TOKEN.search
    while True:
        m = finder(text, pos)
        if m is None:
            return out
        s = m.start()
        tok = m.group()
        c = tok[0]
        if c == "{":
            e = _closing_brace(text, s)
            if e < 0:
                raise NetlistError(f"{name}: unterminated '{{': no matching '}}'", card.location(s),
                                   hint="close the expression with '}'")
            out.append(Token(text[s + 1 : e], EXPR, s, e + 1))
            pos = e + 1
        elif c == "'":
            e = text.find("'", s + 1)
            if e < 0:
                raise NetlistError(f"{name}: unterminated quote: no closing \"'\"", card.location(s),
                                   hint="close the expression with a single quote")
            out.append(Token(text[s + 1 : e], EXPR, s, e + 1))
            pos = e + 1
        elif c == '"':
            e = text.find('"', s + 1)
            if e < 0:
                raise NetlistError(f"{name}: unterminated string: no closing '\"'", card.location(s),
                                   hint='close the string with a double quote')
            out.append(Token(card.raw[s + 1 : e], STRING, s, e + 1))
            pos = e + 1
        elif c == "}":
            raise NetlistError(f"{name}: unexpected '}}' without an opening '{{'", card.location(s))
        else:
            kind = PUNCT if tok in "=()," and len(tok) == 1 else WORD
            out.append(Token(tok, kind, s, m.end()))
            pos = m.end()
        if pos >= n:
            return out


def _is_dot(stripped_lower: str, word: str) -> bool:
    """True when the line's first word is ``word`` (e.g. ``.end``), ended by anything but a name character.

    ngspice reads ``.end=`` or ``.end;`` as ``.end`` (and ``.ends``, ``.endc`` as other cards).
    """
    if not stripped_lower.startswith(word):
        return False
    if len(stripped_lower) == len(word):
        return True
    nxt = stripped_lower[len(word)]
    return not (nxt.isalnum() or nxt in "_.")


#: The words of the warning at a top-level ``.end`` that cards follow (the ngspice bridge,
#: which says what it passes to ngspice, replaces it with its own note).
AFTER_END = "after .end are not read by netdae"


def _note_after_end(rest: list[str], where: SourceLocation, notes: list) -> None:
    """A warning at ``.end`` when cards follow it: netdae reads none of them, ngspice 39 reads them all.

    ngspice's reader turns the top-level ``.end`` into a comment and goes on
    (``inpcom.c``): an element, an analysis or a ``.control`` block after it is
    part of ngspice's circuit. A file that relies on it is then not the same
    circuit in netdae; the warning names the first such line.
    """
    after = [k for k, line in enumerate(rest) if line.strip() and line.strip()[0] != "*"]
    if after:
        first = shown(rest[after[0]].strip())
        notes.append(Diagnostic(
            "warning", f"{len(after)} line(s) {AFTER_END} (the first: {first[:40]!r}); "
            "ngspice 39 reads on past .end: move them before .end to keep them", where))


#: Characters that look like a blank (or like nothing) but are not one to ngspice, whose reader
#: separates words at ASCII blanks only: a no-break space between two names makes one name.
#: ASCII control characters that are no blank in ngspice 39 (tab, form feed and vertical tab are; CR and LF end
#: lines; NUL refuses the file): in a card they make names and values ngspice reads otherwise.
_CONTROL = re.compile("[\x01-\x08\x0e-\x1f\x7f]")
_ODD_SPACE = re.compile("[\u0085\u00a0\u1680\u2000-\u200b\u2028\u2029\u202f\u205f\u2060\u3000\ufeff]")


#: A byte that is not UTF-8, as :func:`netdae.netlist.reader.decode` leaves it (``surrogateescape``).
_NOT_UTF8 = re.compile("[\udc80-\udcff]")


def shown(text: str) -> str:
    """``text`` with each byte that is not UTF-8 shown as U+FFFD (a title, a line quoted in a message)."""
    return _NOT_UTF8.sub("\ufffd", text) if not text.isascii() else text


def _refuse_not_utf8(stripped: str, line: str, file: str, lineno: int) -> None:
    """Refuse a card (or a command) holding a byte that is not UTF-8, located at the byte.

    It has no reading: ngspice 39 refuses the file ("UTF-8 syntax error"), and
    replacing it (U+FFFD) would make two different names one (Latin-1 ``é``
    and ``è``). Comments and the title may hold such bytes, as in ngspice.
    """
    bad = _NOT_UTF8.search(stripped)
    if bad is not None:
        column = line.find(bad.group()) + 1
        raise NetlistError(
            f"byte 0x{ord(bad.group()) - 0xDC00:02X} is not UTF-8 (text saved in another "
            "encoding, such as Latin-1 or Windows-1252): ngspice 39 refuses the file too (\"UTF-8 syntax error\")",
            SourceLocation(file, lineno, column),
            hint="save the file as UTF-8 (most editors offer the encoding when saving; iconv -f latin1 -t utf-8 "
                 "converts it)")


def _refuse_odd_space(stripped: str, line: str, file: str, lineno: int) -> None:
    """Refuse a card holding a byte that is not UTF-8 (:func:`_refuse_not_utf8`) or a Unicode space.

    A Unicode space (a no-break space copied from a web page or a document):
    netdae would split words at it and ngspice would not (it reads
    ``in\u00a0a`` as one node name): the two would simulate different
    circuits, so neither reading is guessed.
    """
    _refuse_not_utf8(stripped, line, file, lineno)
    m = _ODD_SPACE.search(stripped)
    if m is None:
        return
    import unicodedata

    ch = m.group()
    what = unicodedata.name(ch, "a space character").lower()
    raise NetlistError(
        f"a {what} (U+{ord(ch):04X}) in the card: ngspice does not read it as a blank (the words on both "
        "sides would make one name), netdae refuses to guess",
        SourceLocation(file, lineno, line.find(ch) + 1),
        hint="replace it with a plain space (text copied from a web page or a document often holds such "
             "characters)")


def _refuse_control(stripped: str, line: str, file: str, lineno: int) -> None:
    """Refuse a card holding an ASCII control character (:data:`_CONTROL`), located at it.

    ngspice 39 reads none of them as a blank: ``a<Ctrl-A>0`` is one node name there (which it prints as
    ``a_0``), where Python's ``split`` cuts at some of them (0x1C to 0x1F); neither reading is guessed.
    """
    if stripped.isprintable():
        return
    m = _CONTROL.search(stripped)
    if m is None:
        return
    code = ord(m.group())
    what = "DEL" if code == 0x7F else f"Ctrl-{chr(code + 64)}"
    raise NetlistError(
        f"a control character (0x{code:02X}, {what}) in the card: ngspice 39 does not read it as a blank (the "
        "words on both sides would make one name), netdae refuses to guess",
        SourceLocation(file, lineno, line.find(m.group()) + 1),
        hint="remove it (a stray key press, or a file that went through a binary transfer)")


def _line_feeds(text: str, file: str) -> str:
    """``text`` with its CRLF line ends as LF; a carriage return inside a line is refused.

    ngspice 39 ends lines at LF only (a CR before it is a blank): a file whose
    lines end in CR alone (classic Mac OS) is one title line there, and
    ``a\rb`` one line. Splitting at the CR would simulate another circuit.

    Raises
    ------
    NetlistError
        At line 1 for a file with CR line ends only; else at the first CR
        followed by more text on its line.
    """
    text = re.sub("\r+(?=\n|$)", "", text)
    at = text.find("\r")
    if at < 0:
        return text
    if "\n" not in text:
        raise NetlistError(
            f"the lines end in a carriage return (CR) alone, the line ends of classic Mac OS: ngspice 39 reads "
            f"the whole file as one title line ({text.count(chr(13)) + 1} lines here) and simulates nothing",
            SourceLocation(file, 1, at + 1), hint="convert the line endings to LF or CRLF (e.g. with "
                                                "'tr \"\\r\" \"\\n\"' or an editor's line-ending setting)")
    start = text.rfind("\n", 0, at) + 1
    raise NetlistError(
        "a carriage return (CR) inside the line: ngspice 39 reads the text after it as part of the same line",
        SourceLocation(file, text.count("\n", 0, at) + 1, at - start + 1),
        hint="end the line with LF or CRLF, or remove the stray CR")


def split_cards(
    text: str, file: str, *, title: bool = True, pspice: bool = False
) -> tuple[str | None, list[Card], list[Diagnostic]]:
    """Split netlist text into its title and logical cards.

    Parameters
    ----------
    text : str
        The whole file.
    file : str
        Name used in locations.
    title : bool
        True for the main file (first line is the title, ``.end`` ends the
        netlist); False for included files.
    pspice : bool
        ngspice's PSpice compatibility mode: ``$`` starts no comment.

    Returns
    -------
    title : str or None
        The title line (stripped), None for included files.
    cards : list of Card
    notes : list of Diagnostic
        The lines of ``.control`` blocks not read and ignored ``.end`` lines.

    Raises
    ------
    NetlistError
        On a continuation line with nothing to continue, an unterminated
        ``.control`` block, an ``.endc`` without ``.control``, or an analysis
        netdae does not have in a ``.control`` block (``pz``, ``tf`` ...).

    Notes
    -----
    The cards a ``.control`` block stands for (:func:`netdae.netlist.control.read_block`)
    take its place. One pass over the lines; the comment search is one regular-expression
    call per line that contains a comment character.
    """
    from .control import read_block  # control.py builds Cards: imported here, not at the top (a cycle)

    if "\r" in text:
        text = _line_feeds(text, file)
    if text.rstrip().endswith("\x1a"):  # a DOS end-of-file mark (Ctrl-Z) after the last card
        text = text.rstrip().rstrip("\x1a")
    lines = text.split("\n")
    if lines and lines[0].startswith("\ufeff"):
        lines[0] = lines[0][1:]
    notes: list[Diagnostic] = []
    cards: list[Card] = []
    title_text = None
    start = 0
    if title:
        title_text = shown(lines[0].strip()) if lines else ""
        if _is_dot(fold_case(title_text[:7]), ".title"):  # ngspice: '.title text' as the first line
            title_text = title_text[len(".title"):].strip()
        start = 1
    cur_raw: list[str] | None = None
    cur_spans: list[tuple[int, int, int]] = []
    cur_len = 0
    control_at = None
    comment = (_COMMENT_PSPICE if pspice else _COMMENT).search

    for index in range(start, len(lines)):
        line = lines[index]
        lineno = index + 1
        stripped = line.strip()
        if not stripped or stripped[0] == "*" or not stripped.strip("\x1a"):  # Ctrl-Z alone: DOS's end of file,
            continue  # which ngspice 39 skips as a blank line
        if control_at is not None:
            if _is_dot(fold_case(stripped[:5]), ".endc"):
                block_cards, block_notes = read_block(control_lines, file)
                cards.extend(block_cards)
                notes.extend(block_notes)
                control_at = None
            else:
                command = re.split(r";|//", stripped, maxsplit=1)[0].rstrip()  # '$' is a variable there
                if command and command[0] != "#":
                    if not command.isascii():
                        _refuse_not_utf8(command, line, file, lineno)
                    control_lines.append((lineno, len(line) - len(line.lstrip()) + 1, command))
            continue
        if ";" in stripped or ("$" in stripped and not pspice) or "//" in stripped:
            m = comment(stripped)
            if m is not None:
                stripped = stripped[: m.start()].rstrip()
                if not stripped:
                    continue
        if stripped[0] == ".":
            head = fold_case(stripped[:9])
            if _is_dot(head, ".control"):
                if cur_raw is not None:
                    cards.append(Card("".join(cur_raw), file, cur_spans))
                cur_raw = None
                control_at = SourceLocation(file, lineno, line.index(".") + 1)
                control_lines: list[tuple[int, int, str]] = []
                continue
            if _is_dot(head, ".endc"):
                raise NetlistError(".endc without a preceding .control",
                                   SourceLocation(file, lineno, line.index(".") + 1))
            if _is_dot(head, ".end"):
                if title:
                    _note_after_end(lines[index + 1:], SourceLocation(file, lineno, line.index(".") + 1), notes)
                    break
                notes.append(Diagnostic("note", ".end inside an included file ignored (as ngspice does)",
                                        SourceLocation(file, lineno, line.index(".") + 1)))
                continue
        col = len(line) - len(line.lstrip()) + 1
        if not stripped.isascii():
            _refuse_odd_space(stripped, line, file, lineno)
        _refuse_control(stripped, line, file, lineno)
        if stripped[0] == "+":
            if cur_raw is None:
                raise NetlistError("continuation line '+' with no card to continue",
                                   SourceLocation(file, lineno, col),
                                   hint="a '+' line continues the card on the line above")
            body = stripped[1:].lstrip()
            cur_raw.append(" ")
            cur_len += 1
            cur_spans.append((cur_len, lineno, col + len(stripped) - len(body)))
            cur_raw.append(body)
            cur_len += len(body)
            continue
        if cur_raw is not None:
            cards.append(Card("".join(cur_raw), file, cur_spans))
        cur_raw = [stripped]
        cur_spans = [(0, lineno, col)]
        cur_len = len(stripped)
    if control_at is not None:
        raise NetlistError(".control block without .endc", control_at,
                           hint="close the block with a line '.endc'")
    if cur_raw is not None:
        cards.append(Card("".join(cur_raw), file, cur_spans))
    return title_text, cards, notes
