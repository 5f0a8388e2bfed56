"""What a validation netlist says about itself in its header comments.

Every netlist in ``netlists/`` starts with a title line and ``*`` comments that
describe the circuit and state, as ``key: value`` lines:

``* expected index: N``
    The Kronecker index of the circuit's DAE (``singular`` for a singular
    pencil), optionally followed by an explanation.
``* compare tolerance: X``
    The largest error against ngspice, relative to the signal's scale
    (:mod:`netdae.comparison.metrics`), for every analysis; or per analysis,
    separated by ``;``: ``.op 1e-6 relative (or 1e-9 absolute) against ngspice;
    transient 1e-3 of the signal range``. An analysis named without a number
    (``transient: period and waveform, see ...``) has no numeric tolerance.
``* compare options: tight``
    Compare with tight tolerances on both sides (``netdae compare --tight``).

A value continues on the following comment lines that are indented (``*``
followed by at least two blanks).

Examples
--------
>>> h = parse_header('''amp
... * A test amplifier.
... * expected index: 1
... * compare tolerance: .op 1e-6 relative (or 1e-9 absolute) against ngspice;
... *   transient 1e-3 of the signal range.
... V1 in 0 1
... ''')
>>> h.expected_index, h.tolerance("op"), h.tolerance("tran"), h.tolerance("ac")
(1, Tolerance(rel=1e-06, abs=1e-09), Tolerance(rel=0.001, abs=None), None)
>>> h.states("ac")
False
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

from ..errors import NetdaeError

__all__ = ["Tolerance", "NetlistHeader", "parse_header", "read_header", "ANALYSES"]

ANALYSES = ("op", "dc", "ac", "tran", "pz", "tf", "noise", "sens")
#: Words naming an analysis in a tolerance statement.
_ANALYSIS_WORDS = {
    ".op": "op", "op": "op", ".dc": "dc", "dc": "dc", ".ac": "ac", "ac": "ac",
    ".tran": "tran", "tran": "tran", "transient": "tran", "transients": "tran",
    ".pz": "pz", "pz": "pz", ".tf": "tf", "tf": "tf", ".noise": "noise", "noise": "noise",
    ".sens": "sens", "sens": "sens",
}
_KEY = re.compile(r"^\*\s?([a-z][a-z ]*[a-z]):\s*(.*)$", re.I)
_CONTINUATION = re.compile(r"^\*\s{2,}(\S.*)$")
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_LEADING_NUMBER = re.compile(rf"^({_NUMBER})(?![\w.])")
_ABSOLUTE = re.compile(rf"\bor\s+({_NUMBER})\s+absolute\b", re.I)


@dataclass(frozen=True)
class Tolerance:
    """A pass criterion: ``|error| <= rel * scale`` or ``|error| <= abs``."""

    rel: float
    abs: float | None = None


@dataclass
class NetlistHeader:
    """The header of a validation netlist.

    Attributes
    ----------
    title : str
        The first line.
    description : list of str
        The comment lines before the first ``key:`` line, without ``*``.
    expected_index : int, str or None
        ``2``, ``"singular"``, or None when not stated.
    tolerances : dict
        Analysis (``"op"``, ``"dc"``, ``"ac"``, ``"tran"``) to
        :class:`Tolerance`, or to None when the header names the analysis
        without a number.
    tolerance_text : str
        The ``compare tolerance`` statement as written.
    tight : bool
        ``* compare options: tight``.
    fields : dict of str to str
        Every ``key: value`` statement, continuation lines joined.
    """

    title: str
    description: list[str] = field(default_factory=list)
    expected_index: int | str | None = None
    tolerances: dict[str, Tolerance | None] = field(default_factory=dict)
    tolerance_text: str = ""
    tight: bool = False
    fields: dict[str, str] = field(default_factory=dict)

    def tolerance(self, analysis: str) -> Tolerance | None:
        """The tolerance for an analysis, None when the header gives none."""
        return self.tolerances.get(analysis)

    def states(self, analysis: str) -> bool:
        """True when the header says something about this analysis's tolerance."""
        return analysis in self.tolerances


def _statements(lines: list[str]) -> tuple[list[str], dict[str, str]]:
    description: list[str] = []
    fields: dict[str, str] = {}
    key = None
    seen_key = False
    for raw in lines[1:]:
        line = raw.rstrip()
        if not line.startswith("*"):
            if line.strip():
                break
            continue
        match = _KEY.match(line)
        if match and not _CONTINUATION.match(line):
            key = match.group(1).lower().strip()
            fields[key] = match.group(2).strip()
            seen_key = True
            continue
        cont = _CONTINUATION.match(line)
        if key is not None and cont:
            fields[key] = f"{fields[key]} {cont.group(1).strip()}".strip()
        else:
            key = None
            text = line[1:].strip()
            if text and not seen_key:
                description.append(text)
    return description, fields


def _index(text: str) -> int | str | None:
    word = text.split()[0].lower() if text.split() else ""
    if word.isdigit():
        return int(word)
    if word == "singular":
        return "singular"
    return None


def _segments(text: str) -> list[str]:
    """``text`` split at the semicolons outside parentheses."""
    parts, depth, current = [], 0, []
    for char in text:
        depth += {"(": 1, ")": -1}.get(char, 0)
        if char == ";" and depth <= 0:
            parts.append("".join(current))
            current = []
        else:
            current.append(char)
    parts.append("".join(current))
    return parts


def _tolerances(text: str, source: str) -> dict[str, Tolerance | None]:
    found: dict[str, Tolerance | None] = {}
    for segment in _segments(text):
        words = segment.replace(",", " ").split()
        named: list[str] = []
        while words and (words[0].lower().rstrip(":") in _ANALYSIS_WORDS or words[0].lower() == "and"):
            word = words.pop(0).lower().rstrip(":")
            if word != "and":
                named.append(_ANALYSIS_WORDS[word])
        rest = " ".join(words)
        number = _LEADING_NUMBER.match(rest)
        if number is None:
            if not named and rest.strip():
                raise NetdaeError(
                    f"{source}: 'compare tolerance: {text}' does not start with a number or an analysis "
                    "(.op, .dc, .ac, transient)"
                )
            value = None
        else:
            extra = _ABSOLUTE.search(rest)
            value = Tolerance(float(number.group(1)), float(extra.group(1)) if extra else None)
        for analysis in named or list(ANALYSES):
            found.setdefault(analysis, value)
    return found


def parse_header(text: str, *, source: str = "<string>") -> NetlistHeader:
    """Parse the header of a netlist's text.

    Raises
    ------
    NetdaeError
        When a ``compare tolerance`` statement cannot be read.
    """
    lines = text.splitlines()
    title = lines[0].strip() if lines else ""
    description, fields = _statements(lines)
    tolerance_text = fields.get("compare tolerance", "")
    options = fields.get("compare options", "").lower().replace(",", " ").split()
    return NetlistHeader(
        title=title,
        description=description,
        expected_index=_index(fields.get("expected index", "")),
        tolerances=_tolerances(tolerance_text, source) if tolerance_text else {},
        tolerance_text=tolerance_text,
        tight="tight" in options,
        fields=fields,
    )


def read_header(path: str | os.PathLike) -> NetlistHeader:
    """Parse the header of a netlist file.

    Raises
    ------
    NetdaeError
        When the file cannot be read or its tolerance statement is malformed.
    """
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            text = handle.read()
    except OSError as exc:
        raise NetdaeError(f"{path}: cannot read netlist: {exc.strerror}") from None
    return parse_header(text, source=os.fspath(path))
