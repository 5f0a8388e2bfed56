"""``.control`` ... ``.endc`` blocks: the commands netdae reads as cards, and the rest skipped.

ngspice runs a control block as a script. netdae never runs one; it reads
the commands that ask for an analysis, an output or an option as the
equivalent dot cards, in block order, and lists every other line as
skipped (one located note each):

=====================================  ======================================
command                                read as
=====================================  ======================================
``op``, ``tran``, ``ac``, ``dc``,      ``.op``, ``.tran``, ``.ac``, ``.dc``,
``pz``, ``tf``, ``noise``, ``sens``    ``.pz``, ``.tf``, ``.noise``, ``.sens``
``run``                                nothing (netdae runs every analysis)
``save``                               ``.save``
``print``, ``plot`` (signals only)     ``.print``, ``.plot``
``wrdata file sig...``,                ``.save sig...`` (the file is not
``write file sig...``                  written: netdae writes its own output)
``option(s) ...``                      ``.options ...``
``set name=value`` (a simulator        ``.options name=value``
option netdae reads)
=====================================  ======================================

``disto``, ``fourier`` ... are analyses
netdae does not have: a located error names them. Lines inside loops and
conditionals (``while``, ``repeat``, ``dowhile``, ``foreach``, ``if`` ...
``end``), after a command that changes the circuit (``alter``, ``altermod``,
``reset``, ``source`` ...) or after ``quit``/``exit`` are skipped whatever
they are, and so is a line using a variable (``$x``): netdae would not run
them as ngspice does. The ngspice bridge hands ngspice the cards, never the
block (:mod:`netdae.ngspice.deck`).

Examples
--------
>>> cards, notes = read_block([(3, 1, "op"), (4, 1, "let x = 1"), (5, 1, "tran 1u 1m")], "c.cir")
>>> [c.text for c in cards], [str(n.location) for n in notes]
(['.op', '.tran 1u 1m'], ['c.cir:4:1'])
"""

from __future__ import annotations

import re

from ..circuit import Diagnostic
from ..errors import NetlistError, SourceLocation
from .lines import Card, fold_case
from .syntax import UNSUPPORTED_DOT_CARDS

__all__ = ["read_block", "ANALYSIS_COMMANDS", "OPTION_VARIABLES"]

#: Commands read as the dot card of the same name.
ANALYSIS_COMMANDS = frozenset({"op", "tran", "ac", "dc", "pz", "tf", "noise", "sens"})
#: Analyses netdae does not have (refused by name).
_UNSUPPORTED = {"disto": ".disto",
                "fourier": ".fourier", "four": ".four", "sp": ".sp", "pss": ".pss", "hb": ".hb"}
#: ``set`` variables that are simulator options netdae reads.
OPTION_VARIABLES = frozenset({"reltol", "abstol", "vntol", "chgtol", "gmin", "temp", "tnom", "itl1", "itl4",
                              "maxord", "method"})
_BLOCK_OPEN = frozenset({"while", "repeat", "dowhile", "foreach", "if"})
_CHANGES_CIRCUIT = frozenset({"alter", "altermod", "alterparam", "reset", "source", "load", "remcirc", "setcirc",
                              "circbyline", "mc_source", "compose", "destroy"})
_STOP = frozenset({"quit", "exit"})
#: A signal as print/plot/save take it: v(...), i(...), a vector name, @device[param].
_SIGNAL = re.compile(r"(?:[vi]\s*\([^()]*\)|@[\w.#:]+\[\w+\]|[a-z_][\w.#:]*)")
_PLOT_WORDS = frozenset({"vs", "xlimit", "ylimit", "title", "xlabel", "ylabel", "loglog", "xlog", "ylog",
                         "linear", "combplot", "pointplot", "retraceplot", "nogrid", "nointerp", "xindices",
                         "xcompress", "xdelta", "ydelta", "samelogscale", "linplot", "noretraceplot"})


def _card(text: str, file: str, line: int, col: int) -> Card:
    """A dot card ``'.' + text`` whose characters point at the command as written."""
    return Card("." + text, file, [(0, line, col), (1, line, col)])


def _signals_only(rest: str) -> bool:
    words = fold_case(rest).replace(",", " ")
    pos = 0
    while True:
        while pos < len(words) and words[pos] == " ":
            pos += 1
        if pos >= len(words):
            return True
        m = _SIGNAL.match(words, pos)
        if m is None or m.group() in _PLOT_WORDS:
            return False
        pos = m.end()
        if pos < len(words) and words[pos] != " ":
            return False


def read_block(lines: list[tuple[int, int, str]], file: str) -> tuple[list[Card], list[Diagnostic]]:
    """The cards a control block stands for, and one note per skipped line.

    Parameters
    ----------
    lines : list of (line, column, text)
        The block's lines between ``.control`` and ``.endc`` (comment lines
        and blank lines left out), ``text`` stripped, in its original case.
    file : str
        The file, for locations.

    Returns
    -------
    cards : list of Card
        Dot cards (``.op``, ``.tran ...``, ``.save ...``, ``.options ...``) in
        block order, located at the commands.
    notes : list of Diagnostic
        One ``note`` per line not read, saying why.

    Raises
    ------
    NetlistError
        An analysis netdae does not have (``disto``, ``fourier`` ...), at the command.
    """
    cards: list[Card] = []
    notes: list[Diagnostic] = []
    depth = 0
    changed: str | None = None
    stopped: str | None = None

    def skip(line: int, col: int, text: str, why: str, done: str = "skipped") -> None:
        notes.append(Diagnostic("note", f".control: '{text}' {done}: {why}", SourceLocation(file, line, col)))

    for line, col, text in lines:
        words = text.split(None, 1)
        cmd = fold_case(words[0])
        rest = words[1] if len(words) > 1 else ""
        if stopped is not None:
            skip(line, col, text, f"it follows '{stopped}'")
            continue
        if cmd in _BLOCK_OPEN or depth > 0:
            depth += cmd in _BLOCK_OPEN
            depth -= cmd == "end"
            skip(line, col, text, "netdae does not run control-language loops and conditionals")
            continue
        if cmd in _UNSUPPORTED:
            what = UNSUPPORTED_DOT_CARDS[_UNSUPPORTED[cmd]]
            raise NetlistError(f".control: '{cmd}' ({what}) is not supported by netdae",
                               SourceLocation(file, line, col),
                               hint="netdae runs op, dc, ac, tran, pz, tf, noise and sens; remove the command or run the "
                                    "netlist in ngspice")
        if cmd in _STOP:
            stopped = cmd
            skip(line, col, text, "netdae reads the netlist to its end")
            continue
        if cmd in _CHANGES_CIRCUIT:
            changed = cmd
            skip(line, col, text, "netdae does not run commands that change the circuit")
            continue
        if "$" in text or "&" in text:
            skip(line, col, text, "it uses a control-language variable")
            continue
        if cmd == "run":
            continue
        if cmd in ANALYSIS_COMMANDS:
            if changed is not None:
                skip(line, col, text, f"it follows '{changed}', which netdae does not run")
            else:
                cards.append(_card(text, file, line, col))
        elif cmd in ("save", "print", "plot"):
            if cmd != "save" and not _signals_only(rest):
                skip(line, col, text, f"netdae reads {cmd} with signals only (v(node), i(source), names)")
            else:
                cards.append(_card(text, file, line, col))
        elif cmd in ("wrdata", "write"):
            parts = rest.split(None, 1)
            if len(parts) == 2 and _signals_only(parts[1]):
                cards.append(_card("save " + parts[1], file, line, col + len(text) - len(parts[1]) - 5))
                skip(line, col, text, f"netdae does not write the file '{parts[0]}'", f"read as '.save {parts[1]}'")
            else:
                skip(line, col, text, "netdae does not write ngspice's output files")
        elif cmd == "pre_osdi":
            cards.append(_card("osdi " + rest, file, line, col + len(text) - len(rest) - 5))
        elif cmd in ("option", "options", "opt"):
            cards.append(_card("options " + rest, file, line, col + len(text) - len(rest) - 8))
        elif cmd == "set":
            assignment = re.fullmatch(r"([A-Za-z_]\w*)\s*=\s*(\S+)", rest.strip())
            name = fold_case(assignment.group(1)) if assignment else fold_case(rest.split("=")[0].strip())
            if assignment and name in OPTION_VARIABLES:
                cards.append(_card(f"options {name}={assignment.group(2)}", file, line, col))
            else:
                skip(line, col, text, f"'{name}' is an ngspice front-end variable, not an option netdae reads")
        else:
            skip(line, col, text, "netdae does not run ngspice's control language (it reads op, tran, ac, dc, "
                 "pz, tf, noise, sens, save, print, plot, wrdata, write, option and set of options)")
    return cards, notes
