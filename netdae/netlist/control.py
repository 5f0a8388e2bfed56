"""``.control`` ... ``.endc`` blocks: the commands netdae reads as cards, and a safe subset of the control language.

ngspice runs a control block as a script. netdae reads a block in one of two ways.

A block without the control language (:func:`needs_script` false: no ``$``
variable, loop, conditional, ``alter`` or ``altermod``) is read by
:func:`read_block`: the commands that ask for an analysis, an output or an
option become the equivalent dot cards, in block order, and every other line
is skipped (one located note each):

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
``meas(ure) ...``                      ``.meas ...``
``option(s) ...``                      ``.options ...``
``set name=value`` (a simulator        ``.options name=value``
option netdae reads)
=====================================  ======================================

``disto``, ``fourier`` ... are analyses netdae does not have: a located error
names them. Lines after ``quit``/``exit`` are skipped.

A block in the control language is a script: :func:`read_block` hands it on
as one ``.control`` card (``Card.script``), and after a first elaboration
(the script reads the ``.csparam`` values, made of top-level ``.param``
values, and checks ``alter`` against the circuit) :func:`run_scripts` runs it
with netdae's own interpreter: scalar ``let`` vectors and ``set`` variables,
``$name``/``$&name``/``{$name}`` substituted as ngspice's ``cp_variablesubst``
does, ``foreach``, ``repeat``, ``while``, ``dowhile``, ``if``/``else``,
``break``, ``continue`` (at most :data:`MAX_ITERATIONS` iterations in all),
and ``alter``/``altermod`` between analyses, carried on the analysis cards
(``Card.alter``, :class:`~netdae.circuit.Alteration`). Nothing outside this
subset runs: no shell, file, environment or plot; what the script cannot
know (a vector of simulation results, a function ``define`` makes, a random
draw) skips the analyses that depend on it, each with a located note naming
the command and the reason. The ngspice bridge hands ngspice the cards, or
for a script a control block of netdae's own with the analyses and ``alter``
commands netdae ran (:mod:`netdae.ngspice.deck`), never the user's block.

Examples
--------
>>> cards, notes = read_block([(3, 1, "op"), (4, 1, "let x = 1"), (5, 1, "tran 1u 1m")], "c.cir")
>>> [c.text for c in cards], [str(n.location) for n in notes]
(['.op', '.tran 1u 1m'], ['c.cir:4:1'])
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..circuit import Alteration, Diagnostic
from ..errors import NetlistError, SourceLocation
from ..kinds import KINDS, STEPPABLE_KINDS
from .expr import evaluate, parse_expression
from .lines import Card, fold_case
from .numbers import parse_number
from .syntax import ELEMENTS, UNSUPPORTED_DOT_CARDS
from .waveforms import WAVEFORMS, RandomSource

__all__ = ["read_block", "run_scripts", "with_scripts", "elaborate_scripted", "needs_script", "csparam_values", "waveform", "change_key",
           "ANALYSIS_COMMANDS", "OPTION_VARIABLES", "MAX_ITERATIONS", "MAX_COMMAND_LENGTH", "MAX_NESTING"]

#: Commands read as the dot card of the same name.
ANALYSIS_COMMANDS = frozenset({"op", "tran", "ac", "dc", "pz", "tf", "noise", "sens"})
#: Analyses netdae does not run as commands (refused by name), and what they are.
_UNSUPPORTED = {"disto": UNSUPPORTED_DOT_CARDS[".disto"], "fourier": "Fourier analysis", "four": "Fourier analysis",
                "sp": UNSUPPORTED_DOT_CARDS[".sp"], "pss": UNSUPPORTED_DOT_CARDS[".pss"],
                "hb": UNSUPPORTED_DOT_CARDS[".hb"]}
#: Extra hints for the commands that have a card of their own in netdae.
_UNSUPPORTED_HINT = {"fourier": " (a .four card outside the block analyses the first .tran)",
                     "four": " (a .four card outside the block analyses the first .tran)"}
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
        block order, located at the commands; for a block in the control language
        (:func:`needs_script`) one ``.control`` card holding its lines (``Card.script``),
        run later by :func:`run_scripts`.
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

    if needs_script(lines):
        card = _card("control", file, lines[0][0], lines[0][1])
        card.script = list(lines)
        return [card], []
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
            raise NetlistError(f".control: '{cmd}' ({_UNSUPPORTED[cmd]}) is not supported by netdae",
                               SourceLocation(file, line, col),
                               hint="netdae runs op, dc, ac, tran, pz, tf, noise and sens; remove the command or run the "
                                    f"netlist in ngspice{_UNSUPPORTED_HINT.get(cmd, '')}")
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
        elif cmd in _OUTPUT_COMMANDS:
            _output(cmd, rest, text, file, line, col, cards, skip)
        elif cmd in ("meas", "measure"):
            # ngspice measures the last run's plot; netdae's .meas measures its analysis of the kind named (one
            # it cannot read or measure is skipped: Card.from_control)
            card = _card(text, file, line, col)
            card.from_control = True
            cards.append(card)
        elif cmd == "set":
            assignment = re.fullmatch(r"([A-Za-z_]\w*)\s*=\s*(\S+)", rest.strip())
            name = fold_case(assignment.group(1)) if assignment else fold_case(rest.split("=")[0].strip())
            if assignment and name in OPTION_VARIABLES:
                cards.append(_card(f"options {name}={assignment.group(2)}", file, line, col))
            else:
                skip(line, col, text, f"'{name}' is an ngspice front-end variable, not an option netdae reads")
        else:
            skip(line, col, text, _NOT_READ)
    return cards, notes


#: Commands read as output requests and options.
_OUTPUT_COMMANDS = frozenset({"save", "print", "plot", "wrdata", "write", "pre_osdi", "option", "options", "opt"})
_NOT_READ = ("netdae does not run ngspice's control language (it reads op, tran, ac, dc, pz, tf, noise, sens, save, "
             "print, plot, wrdata, write, meas, option and set of options)")
#: A ``meas`` command of a script (a loop or a conditional): a script's analyses run in netdae's order, so a
#: measure there has no single analysis to read.
_MEAS_IN_SCRIPT = ("netdae reads meas commands outside loops and conditionals only (as .meas cards); for a "
                   "measure at each value of a loop, step the value with .step and measure with a .meas card "
                   "(netdae sweep)")


def _output(cmd: str, rest: str, text: str, file: str, line: int, col: int, cards: list[Card], skip) -> None:
    """An output request or options command (:data:`_OUTPUT_COMMANDS`) as its dot card, or a note."""
    if cmd in ("save", "print", "plot"):
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
    else:
        cards.append(_card("options " + rest, file, line, col + len(text) - len(rest) - 8))


# -- the control language's safe subset ----------------------------------------------------------------------------

#: Most loop iterations a script may make, all its loops together: a loop that has not ended by then is refused.
MAX_ITERATIONS = 10_000
#: Longest command a substitution may make (``set x = "$x $x"`` in a loop doubles a variable each time).
MAX_COMMAND_LENGTH = 100_000
#: Deepest nesting of loops and conditionals.
MAX_NESTING = 100
#: Commands that make a block a script (with any ``$`` variable).
_SCRIPT_COMMANDS = _BLOCK_OPEN | {"alter", "altermod"}
#: Characters of a variable's name after ``$`` (ngspice's ``span_var_expr``, ``src/frontend/variable.c``).
_NAME_CHARS = frozenset("$-_<#?@.()[]&")
#: ngspice's own variables that hold its plots' bookkeeping (``cp_enqvar``): names netdae has no value for.
_PLOT_VARIABLES = frozenset({"curplot", "curplotname", "curplottitle", "curplotdate", "plots"})
#: The control language's word operators as the expression parser spells them.
_WORD_OPERATORS = {"gt": ">", "lt": "<", "ge": ">=", "le": "<=", "eq": "==", "ne": "!=", "and": "&&", "or": "||",
                   "not": "!"}
#: ``$`` followed by a blank or the end of the line starts a comment in a control block.
_DOLLAR_COMMENT = re.compile(r"(?:^|(?<=\s))\$(?=\s|$)")


def needs_script(lines: list[tuple[int, int, str]]) -> bool:
    """True when a block uses the control language (a variable, a loop or conditional, ``alter``):
    :func:`run_scripts` runs it once the circuit's ``.csparam`` values are known."""
    for _, _, text in lines:
        text = _strip_comment(text)
        words = text.split(None, 1)
        if words and (fold_case(words[0]) in _SCRIPT_COMMANDS or "$" in text):
            return True
    return False


def _strip_comment(text: str) -> str:
    m = _DOLLAR_COMMENT.search(text)
    return text[: m.start()].rstrip() if m else text


class _Refused(Exception):
    """A value netdae cannot know (a vector of simulation results, a random draw ...): the reason."""


@dataclass
class _Step:
    """One command, or a loop/conditional with its body (and ``else`` part)."""

    line: int
    col: int
    text: str
    word: str
    body: list[_Step] | None = None
    other: list[_Step] | None = None


def _structure(lines: list[tuple[int, int, str]], file: str) -> list[_Step]:
    """The block's commands with each loop's and conditional's body nested (``end`` closes, ``else`` splits).

    Raises
    ------
    NetlistError
        An ``end`` or ``else`` without its opening command, a loop or ``if`` without ``end``.
    """
    top: list[_Step] = []
    stack: list[tuple[_Step, list[_Step]]] = []
    for line, col, raw in lines:
        text = _strip_comment(raw)
        if not text:
            continue
        word = fold_case(text.split(None, 1)[0])
        target = stack[-1][1] if stack else top
        if word in _BLOCK_OPEN:
            step = _Step(line, col, text, word, body=[])
            if len(stack) >= MAX_NESTING:
                raise NetlistError(f".control: '{word}' nested deeper than {MAX_NESTING} loops and conditionals",
                                   SourceLocation(file, line, col))
            target.append(step)
            stack.append((step, step.body))
        elif word == "else":
            if not stack or stack[-1][0].word != "if" or stack[-1][0].other is not None:
                raise NetlistError(".control: 'else' without 'if'", SourceLocation(file, line, col))
            stack[-1][0].other = []
            stack[-1] = (stack[-1][0], stack[-1][0].other)
        elif word == "end":
            if not stack:
                raise NetlistError(".control: 'end' without a loop or 'if' to close", SourceLocation(file, line, col))
            stack.pop()
        else:
            target.append(_Step(line, col, text, word))
    if stack:
        step = stack[-1][0]
        raise NetlistError(f".control: '{step.word}' without 'end'", SourceLocation(file, step.line, step.col),
                           hint="close the loop or conditional with a line 'end'")
    return top


class _Break(Exception):
    """``break``: leave the innermost loop."""


class _Continue(Exception):
    """``continue``: the innermost loop's next iteration."""


class _Script:
    """One run of a ``.control`` block's script: netdae's interpreter of the control language's safe subset."""

    def __init__(self, file: str, vectors: dict[str, float], circuit) -> None:
        self.file = file
        #: ``let`` vectors (and ``.csparam`` values): a number, or a _Refused reason.
        self.vectors: dict[str, float | _Refused] = dict(vectors)
        #: ``set`` variables as ngspice prints them, or a _Refused reason.
        self.variables: dict[str, str | _Refused] = {}
        #: ``define``d functions: name -> why netdae does not evaluate them.
        self.functions: dict[str, str] = {}
        self.alter: dict[tuple, Alteration] = {}
        self.cards: list[Card] = []
        self.notes: dict[tuple[int, int], Diagnostic] = {}
        self.iterations = 0
        self.refused: str | None = None
        self.stopped = False
        self.elements = {el.name: el for el in circuit.elements}
        self.models = circuit.models

    # -- messages ----------------------------------------------------------------------------------------------------
    def where(self, step: _Step) -> SourceLocation:
        return SourceLocation(self.file, step.line, step.col)

    def note(self, step: _Step, why: str, done: str = "skipped") -> None:
        key = (step.line, step.col)
        if key not in self.notes:
            self.notes[key] = Diagnostic("note", f".control: '{step.text}' {done}: {why}", self.where(step))

    def refuse(self, step: _Step, why: str) -> None:
        """From here on no analysis runs: the circuit's or the script's state is unknown to netdae."""
        if self.refused is None:
            self.refused = f"'{step.text}' ({self.where(step)}), which netdae does not run: {why}"
        self.note(step, f"{why}; the analyses after it are skipped")

    # -- values ------------------------------------------------------------------------------------------------------
    def substitute(self, step: _Step, text: str) -> str:
        """``text`` with ``$name``, ``$&name``, ``$?name``, ``$#name`` and ``{$name}`` replaced as ngspice does.

        Raises
        ------
        _Refused
            A variable or vector whose value netdae cannot know.
        NetlistError
            A variable or vector never defined.
        """
        out = []
        pos = 0
        while True:
            at = text.find("$", pos)
            if at < 0:
                out.append(text[pos:])
                break
            end = _span_name(text, at + 1)
            name = text[at + 1: end]
            start = at
            if at > 0 and text[at - 1] == "{" and end < len(text) and text[end] == "}":
                start, end = at - 1, end + 1  # ngspice's braces around a substitution leave its value alone
            out.append(text[pos:start])
            out.append(self.value_of(step, name))
            pos = end
        made = "".join(out)
        if len(made) > MAX_COMMAND_LENGTH:
            raise NetlistError(f".control: '{step.text}' becomes {len(made):,} characters long after substitution, "
                               f"more than netdae's limit of {MAX_COMMAND_LENGTH:,}", self.where(step))
        return made

    def value_of(self, step: _Step, name: str) -> str:
        folded = fold_case(name)
        if not folded:
            return "$"
        if "[" in folded:
            raise _Refused(f"'${name}' takes a range of a variable, which netdae does not substitute")
        if folded[0] == "&":
            value = self.vectors.get(folded[1:])
            if value is None:
                raise NetlistError(f".control: '${name}': no vector '{folded[1:]}' (no 'let {folded[1:]} = ...' "
                                   "before it; .param values reach the control language through .csparam)",
                                   self.where(step))
            if isinstance(value, _Refused):
                raise value
            return _vector_text(value)
        if folded[0] == "?":
            return "1" if folded[1:] in self.variables else "0"
        if folded[0] == "#":
            value = self.variables.get(folded[1:])
            if value is None:
                raise NetlistError(f".control: '${name}': no variable '{folded[1:]}'", self.where(step))
            return str(len(value.split())) if isinstance(value, str) else "1"
        value = self.variables.get(folded)
        if value is None:
            if folded in _PLOT_VARIABLES:
                raise _Refused(f"'${name}' is ngspice's plot bookkeeping, which netdae does not keep")
            raise NetlistError(f".control: '${name}': no variable '{folded}' (no 'set {folded} = ...' or "
                               "'foreach' before it; netdae reads no environment variable)", self.where(step),
                               hint="'$x' is a variable 'set' made; '$&x' the value of a vector 'let' made")
        if isinstance(value, _Refused):
            raise value
        return value

    def evaluate(self, step: _Step, text: str) -> float:
        """A control-language expression of numbers and vectors, as a number.

        Raises
        ------
        _Refused
            It reads simulation results, a ``define``d function, a random draw ...
        """
        text = re.sub(r"\b(gt|lt|ge|le|eq|ne|and|or|not)\b", lambda m: f" {_WORD_OPERATORS[m.group(1).lower()]} ",
                      text, flags=re.I)
        text = re.sub(r"(?<![<>=!])=(?!=)", "==", text)
        text = re.sub(r"(?<!&)&(?!&)", "&&", text)
        text = re.sub(r"(?<!\|)\|(?!\|)", "||", text)
        try:
            tree = parse_expression(text)
        except NetlistError as exc:
            if "circuit reference" in exc.message:
                raise _Refused(f"'{text.strip()}' reads simulation results, which netdae's script does not "
                               "have") from None
            raise _Refused(f"'{text.strip()}' is not an expression netdae's script evaluates ({exc.message})") from None

        def lookup(name: str) -> float:
            value = self.vectors.get(name)
            if value is None:
                raise _Refused(f"'{name}' is no vector 'let' made: a vector of simulation results, which netdae's "
                               "script does not have")
            if isinstance(value, _Refused):
                raise value
            return value

        def call(name: str, args: list[float]) -> float:
            if name in self.functions:
                raise _Refused(self.functions[name])
            raise _Refused(f"'{name}()' is one of ngspice's vector functions or random draws, which netdae's script "
                           "does not evaluate")

        try:
            return evaluate(tree, lookup, call)
        except ValueError as exc:
            raise _Refused(f"'{text.strip()}': {exc}") from None

    # -- running -----------------------------------------------------------------------------------------------------
    def run(self, steps: list[_Step]) -> None:
        for step in steps:
            if self.stopped:
                self.note(step, "it follows 'quit'")
                continue
            if step.body is not None:
                self.block(step)
            else:
                self.command(step)

    def count(self, step: _Step) -> None:
        self.iterations += 1
        if self.iterations > MAX_ITERATIONS:
            raise NetlistError(f".control: '{step.text}' makes more than {MAX_ITERATIONS:,} loop iterations; "
                               "netdae runs a script's loops only when they end within that many",
                               self.where(step), hint="bound the loop (a condition on a 'let' vector that changes)")

    def loop_body(self, step: _Step) -> bool:
        """Run the body once; False after ``break``."""
        self.count(step)
        try:
            self.run(step.body)
        except _Break:
            return False
        except _Continue:
            pass
        return True

    def condition(self, step: _Step, text: str) -> bool | None:
        """The truth of a loop's or ``if``'s condition, or None (refused: the rest of the block is skipped)."""
        try:
            return self.evaluate(step, self.substitute(step, text)) != 0.0
        except _Refused as why:
            self.refuse(step, f"netdae cannot evaluate its condition: {why}")
            self.skip(step.body + (step.other or []))
            return None

    def skip(self, steps: list[_Step]) -> None:
        """A note for each analysis in a block not run."""
        for step in steps:
            if step.body is not None:
                self.skip(step.body + (step.other or []))
            elif step.word in ANALYSIS_COMMANDS:
                self.note(step, f"it follows {self.refused}")

    def block(self, step: _Step) -> None:
        rest = step.text.split(None, 1)[1] if len(step.text.split(None, 1)) > 1 else ""
        if step.word == "foreach":
            try:
                words = self.substitute(step, rest).split()
            except _Refused as why:
                self.refuse(step, str(why))
                self.skip(step.body)
                return
            if not words:
                raise NetlistError(".control: 'foreach' needs a variable and its values", self.where(step),
                                   expected="foreach var value1 value2 ...")
            var = fold_case(words[0])
            for word in words[1:]:
                self.variables[var] = word
                if not self.loop_body(step):
                    break
        elif step.word == "repeat":
            try:
                count = self.evaluate(step, self.substitute(step, rest)) if rest.strip() else None
            except _Refused as why:
                self.refuse(step, str(why))
                self.skip(step.body)
                return
            if count is None:  # until 'break' (the iteration limit stops one that never comes)
                while self.loop_body(step):
                    pass
                return
            for _ in range(max(int(count), 0)):
                if not self.loop_body(step):
                    break
        elif step.word == "while":
            while True:
                truth = self.condition(step, rest)
                if not truth or not self.loop_body(step):
                    break
        elif step.word == "dowhile":
            while self.loop_body(step):
                truth = self.condition(step, rest)
                if not truth:
                    break
        else:  # if
            truth = self.condition(step, rest)
            if truth is not None:
                self.run(step.body if truth else (step.other or []))

    def command(self, step: _Step) -> None:
        word, text = step.word, step.text
        if word in ("break", "continue"):
            raise _Break() if word == "break" else _Continue()
        if word in _STOP:
            self.stopped = True
            self.note(step, "netdae reads the netlist to its end")
            return
        if word in _UNSUPPORTED:
            raise NetlistError(f".control: '{word}' ({_UNSUPPORTED[word]}) is not supported by netdae", self.where(step),
                               hint="netdae runs op, dc, ac, tran, pz, tf, noise and sens; remove the command or run "
                                    f"the netlist in ngspice{_UNSUPPORTED_HINT.get(word, '')}")
        if word == "define":
            m = re.match(r"define\s+([A-Za-z_]\w*)", text, re.I)
            if m:
                random = [f for f in ("sunif", "sgauss", "rnd", "gauss", "unif", "aunif", "agauss")
                          if re.search(rf"\b{f}\s*\(", text[m.end():], re.I)]
                self.functions[fold_case(m.group(1))] = (
                    f"'{m.group(1)}' is a function 'define' made at {self.where(step)}"
                    + (f", drawing ngspice's random numbers ({', '.join(random)})" if random else "")
                    + ", which netdae's script does not evaluate")
            self.note(step, "netdae does not evaluate functions 'define' makes")
            return
        try:
            if word == "let":
                self.let(step)
            elif word == "set":
                self.set(step)
            elif word in ("unset",):
                for name in text.split()[1:]:
                    self.variables.pop(fold_case(name), None)
            elif word in ("alter", "altermod"):
                self.change(step)
            elif word == "reset":
                self.alter.clear()
            elif word in _CHANGES_CIRCUIT:
                self.refuse(step, "netdae does not run commands that change the circuit but alter and altermod")
            elif word in ("goto", "label"):
                self.refuse(step, "netdae does not run 'goto' and 'label'")
            elif word == "run":
                pass
            elif word in ANALYSIS_COMMANDS:
                self.analysis(step)
            elif word in _OUTPUT_COMMANDS:
                sub = self.substitute(step, text)
                words = sub.split(None, 1)
                _output(word, words[1] if len(words) > 1 else "", sub, self.file, step.line, step.col,
                        self.cards, lambda line, col, _text, why, done="skipped": self.note(step, why, done))
            elif word == "meas":
                self.note(step, _MEAS_IN_SCRIPT)
            else:
                self.note(step, _NOT_READ)
        except _Refused as why:
            if word in ANALYSIS_COMMANDS:
                self.note(step, str(why))
            elif word in ("alter", "altermod"):
                self.refuse(step, str(why))
            else:
                self.note(step, str(why))

    def let(self, step: _Step) -> None:
        m = re.fullmatch(r"let\s+([^\s=]+)\s*=\s*(.+)", step.text, re.I | re.S)
        if m is None:
            self.note(step, "netdae reads 'let name = expression'")
            return
        name = fold_case(m.group(1))
        if not re.fullmatch(r"[a-z_][\w]*", name):
            self.note(step, f"'{m.group(1)}' is an element of a vector or a vector of another plot: netdae's script "
                            "keeps scalar vectors only")
            return
        try:
            self.vectors[name] = self.evaluate(step, self.substitute(step, m.group(2)))
        except _Refused as why:
            self.vectors[name] = _Refused(f"vector '{name}' ('{step.text}' at {self.where(step)}) is not a number "
                                          f"netdae's script has: {why}")
            self.note(step, f"netdae's script keeps numbers only: {why}")

    def set(self, step: _Step) -> None:
        rest = step.text.split(None, 1)[1] if len(step.text.split(None, 1)) > 1 else ""
        listed = re.match(r"\s*([^\s=]+)\s*=\s*\(", rest)
        if listed:  # set name = ( w1 w2 ... ): a list variable
            name = fold_case(listed.group(1))
            self.variables[name] = _Refused(f"variable '{name}' ('{step.text}' at {self.where(step)}) is a list, "
                                            "which netdae's script does not keep")
            self.note(step, "netdae's script keeps no list variables")
            return
        for m in re.finditer(r"([^\s=]+)\s*(?:=\s*(\"[^\"]*\"|'[^']*'|\S+))?", rest):
            name = fold_case(m.group(1))
            written = m.group(2)
            if name in _PLOT_VARIABLES:
                self.variables[name] = _Refused(f"'{name}' is ngspice's plot bookkeeping, which netdae does not keep")
                self.note(step, f"netdae does not keep ngspice's plots ('{name}')")
                continue
            try:
                value = "" if written is None else self.substitute(step, written)
            except _Refused as why:
                self.variables[name] = _Refused(f"variable '{name}' ('{step.text}' at {self.where(step)}) has no "
                                                f"value netdae knows: {why}")
                self.note(step, str(why))
                continue
            self.variables[name] = _variable_text(value)
            if name in OPTION_VARIABLES and written is not None:
                self.cards.append(_card(f"options {name}={self.variables[name]}", self.file, step.line, step.col))

    def change(self, step: _Step) -> None:
        """``alter``/``altermod``: the change, in force for the analyses after it."""
        sub = self.substitute(step, step.text)
        word, _, rest = sub.partition(" ")
        rest = rest.strip()
        m = re.fullmatch(r"@([^\s\[]+)\[([^\]]+)\]\s*(?:=\s*)?(.+)", rest, re.S)
        if m:
            name, param, value = fold_case(m.group(1)), fold_case(m.group(2).strip()), m.group(3)
        else:
            m = re.fullmatch(r"([^\s=]+)\s*(?:([A-Za-z_]\w*)\s*)?(?:=\s*)?(.+)", rest, re.S)
            if m is None:
                raise NetlistError(f".control: '{step.text}': expected '{word} name [param] = value'", self.where(step))
            name, param, value = fold_case(m.group(1)), fold_case(m.group(2)) if m.group(2) else None, m.group(3)
        value = value.strip()
        if word.lower() == "altermod":
            change = self.model_change(step, name, param, value)
        else:
            change = self.element_change(step, name, param, value)
        key = change_key(change)
        self.alter.pop(key, None)
        self.alter[key] = change

    def numbers(self, step: _Step, text: str) -> float | tuple[float, ...]:
        if text.startswith("["):
            if not text.endswith("]"):
                raise NetlistError(f".control: '{step.text}': a vector value is '[ v1 v2 ... ]'", self.where(step))
            return tuple(self.evaluate(step, w) for w in text[1:-1].replace(",", " ").split())
        return self.evaluate(step, text)

    def element_change(self, step: _Step, name: str, param: str | None, text: str) -> Alteration:
        el = self.elements.get(name)
        if el is None:
            what = f" ('{name}' is a model: altermod changes a model's parameters)" if name in self.models else ""
            raise NetlistError(f".control: '{step.text}': no element '{name}' in the circuit{what}", self.where(step),
                               hint="name elements in full as ngspice does: r1, or r.x1.r2 inside subcircuit x1")
        value = self.numbers(step, text)
        if param in WAVEFORMS and el.source is not None:
            if not isinstance(value, tuple):
                raise NetlistError(f".control: '{step.text}': a source function's parameters are a vector "
                                   f"'[ v1 v2 ... ]'", self.where(step))
            if issubclass(WAVEFORMS[param], RandomSource):
                raise _Refused(f"netdae does not alter the random source function {param.upper()}")
            try:
                waveform(param, value)
            except ValueError as exc:
                raise NetlistError(f".control: '{step.text}': {exc}", self.where(step)) from None
            command = f"alter @{name}[{param}] [ {' '.join(repr(v) for v in value)} ]"
            return Alteration("element", name, param, value, self.where(step), command)
        if param in ("ac", "acmag") and el.source is not None and not isinstance(value, tuple):
            return Alteration("element", name, "acmag", value, self.where(step), f"alter @{name}[acmag] = {value!r}")
        names = KINDS[el.kind].value_names  # an element's own value as alter names it (@r1[resistance])
        if param is not None and param not in names:
            if el.instance_path or el.source is not None or isinstance(value, tuple):
                raise NetlistError(f".control: '{step.text}': netdae alters an element's value ("
                                   f"{', '.join(names) or 'none for ' + el.kind}), a "
                                   "source's function, an instance parameter of a top-level element and model "
                                   f"parameters (altermod), not the parameter '{param}' of {name}", self.where(step))
            syntax = ELEMENTS.get(name[0])
            if syntax is not None and syntax.keywords and param not in syntax.keywords:
                raise NetlistError(f".control: '{step.text}': no such parameter '{param}' of {name} (a "
                                   f"{syntax.description})", self.where(step),
                                   hint=f"known parameters: {' '.join(sorted(syntax.keywords))}")
            return Alteration("instance", name, param, value, self.where(step), f"alter @{name}[{param}] = {value!r}")
        if isinstance(value, tuple) or el.kind not in STEPPABLE_KINDS:
            raise NetlistError(f".control: '{step.text}': {name} ({el.kind}) takes no "
                               + ("vector" if isinstance(value, tuple) else "value") + " there", self.where(step),
                               hint="alter the value of R, C, L, E, F, G, H, a source's DC value or function")
        return Alteration("element", name, None, value, self.where(step), f"alter {name} = {value!r}")

    def model_change(self, step: _Step, name: str, param: str | None, text: str) -> Alteration:
        if name not in self.models:
            raise NetlistError(f".control: '{step.text}': no model '{name}' in the circuit", self.where(step),
                               hint="altermod names a .model card (models inside subcircuits as netdae names them: "
                                    "x1:dmod)")
        if param is None:
            raise NetlistError(f".control: '{step.text}': expected 'altermod {name} param = value'", self.where(step))
        value = self.numbers(step, text)
        if isinstance(value, tuple):
            raise NetlistError(f".control: '{step.text}': a model parameter takes a number", self.where(step))
        return Alteration("model", name, param, value, self.where(step), f"altermod {name} {param} = {value!r}")

    def analysis(self, step: _Step) -> None:
        if self.refused is not None:
            self.note(step, f"it follows {self.refused}")
            return
        card = _card(self.substitute(step, step.text), self.file, step.line, step.col)
        card.alter = tuple(self.alter.values())
        self.cards.append(card)


def change_key(change: Alteration) -> tuple:
    """What a change sets: a later change with the same key replaces it (a source's function, whichever)."""
    return change.target, change.name, "function" if change.param in WAVEFORMS else change.param


def _span_name(text: str, pos: int) -> int:
    """Where a variable's name that starts at ``pos`` ends (ngspice's ``span_var_expr``)."""
    parens = brackets = 0
    while pos < len(text) and (text[pos].isalnum() or text[pos] in _NAME_CHARS):
        c = text[pos]
        pos += 1
        if c == "[":
            brackets += 1
        elif c == "(":
            parens += 1
        elif c == "]":
            if brackets <= 0:
                return pos - 1
            brackets -= 1
            if brackets <= 0:
                return pos
        elif c == ")":
            if parens <= 0:
                return pos - 1
            parens -= 1
            if parens <= 0:
                return pos
    return pos


def _vector_text(value: float) -> str:
    """A vector's value as ``$&name`` substitutes it (ngspice prints a real with ``%G``).

    >>> _vector_text(1.1 / 7e-9), _vector_text(1e-10), _vector_text(5.0)
    ('1.57143E+08', '1E-10', '5')
    """
    return "%G" % value


def _variable_text(written: str) -> str:
    """A ``set`` value as ``$name`` substitutes it: a quoted string as written, a number as ngspice
    stores it (an integer ``%d``, else ``%G``), any other word as written.

    >>> _variable_text("10n"), _variable_text("1k"), _variable_text('"0"'), _variable_text("abc")
    ('1E-08', '1000', '0', 'abc')
    """
    if len(written) >= 2 and written[0] == written[-1] and written[0] in "\"'":
        return written[1:-1]
    number = parse_number(written)
    if number is None or not math.isfinite(number):
        return written
    if number == int(number) and abs(number) < 2 ** 31:
        return str(int(number))
    return "%G" % number


def waveform(kind: str, values: tuple[float, ...]):
    """The source function ``kind`` (not a random one) with parameters ``values``.

    Raises
    ------
    ValueError
        Parameters that do not fit it.
    """
    if kind == "pwl":
        if len(values) < 2 or len(values) % 2:
            raise ValueError(f"PWL needs time-value pairs, got {len(values)} number(s)")
        return WAVEFORMS[kind](values[0::2], values[1::2])
    return WAVEFORMS[kind](*values)


def csparam_values(cards: list[Card], params) -> dict[str, float]:
    """The ``.csparam`` values: each ``name=expression`` evaluated over the circuit's top-level parameters.

    Raises
    ------
    NetlistError
        An expression that is not a number there, at the card.
    """
    values: dict[str, float] = {}
    for card in cards:
        body = card.text[len(".csparam"):]
        for m in re.finditer(r"([a-z_][\w]*)\s*=\s*(\{[^}]*\}|'[^']*'|[^\s{}']+)", body):
            text = m.group(2)
            if text[0] in "{'":
                text = text[1:-1]
            where = card.location(len(".csparam") + m.start(2))
            try:
                values[m.group(1)] = evaluate(parse_expression(text), lambda name: {**params, **values}[name])
            except (KeyError, ValueError) as exc:
                raise NetlistError(f".csparam {m.group(1)}: '{text}' is not a number ({exc})", where,
                                   hint="a .csparam value is an expression of top-level .param values") from None
    return values


def run_scripts(net, circuit) -> tuple[list[Card], list[Diagnostic]]:
    """Run the control-language scripts of a netlist (its ``.control`` blocks that use variables,
    loops, conditionals or ``alter``): the cards they make and a note per line not run.

    Parameters
    ----------
    net : Netlist
        With ``scripts`` (the blocks) and ``csparams``.
    circuit : Circuit
        Its elaboration without the scripts: its top-level parameters (what ``.csparam``
        values are made of), its elements and models (what ``alter`` and ``altermod`` may change).

    Returns
    -------
    cards : list of Card
        Analysis cards, each with the ``alter``/``altermod`` changes in force when it runs
        (``Card.alter``), output requests and options, in the order the scripts made them.
    notes : list of Diagnostic
        One located note per command not run (the first time), with the reason.

    Raises
    ------
    NetlistError
        An unknown variable or vector, an ``alter`` of an element the circuit does not have,
        a loop that does not end within :data:`MAX_ITERATIONS` iterations, an unbalanced
        ``end``, ... at the command.
    """
    vectors = csparam_values(net.csparams, circuit.params)
    cards: list[Card] = []
    notes: list[Diagnostic] = []
    for block in net.scripts:
        script = _Script(block.file, vectors, circuit)
        try:
            script.run(_structure(block.script, block.file))
        except (_Break, _Continue):
            pass  # ngspice: a 'break' outside a loop ends the block
        cards += script.cards
        notes += list(script.notes.values())
    return cards, notes


def elaborate_scripted(net, **options):
    """Elaborate a netlist that has scripts: once without them (what they read: ``.csparam`` values,
    elements, models), then with the cards they make (:func:`with_scripts`).

    The first elaboration leaves the ``.meas`` cards out: a ``.meas tran`` may measure a
    transient only the script asks for.

    Parameters
    ----------
    net : Netlist
    **options
        For :func:`netdae.netlist.elaborate.elaborate` (``params``, ``max_elements``).

    Returns
    -------
    first : Circuit
        The elaboration without the scripts.
    circuit : Circuit
        The netlist's circuit.
    """
    import dataclasses

    from .elaborate import elaborate

    first = elaborate(dataclasses.replace(net, measures=[]), **options)
    return first, elaborate(with_scripts(net, first), **options)


def with_scripts(net, circuit):
    """A copy of ``net`` with its scripts run: their cards parsed in (after the netlist's own), their notes added.

    Raises
    ------
    NetlistError
        As :func:`run_scripts`, and a card a script made that does not parse (at its command).
    """
    import dataclasses

    from .parser import add_cards

    cards, notes = run_scripts(net, circuit)
    copies = {f.name: list(getattr(net, f.name)) for f in dataclasses.fields(net)
              if isinstance(getattr(net, f.name), list)}
    out = dataclasses.replace(net, **copies)
    out.scripts = []
    out.unscripted = net
    out.diagnostics.extend(notes)
    add_cards(out, cards)
    return out
