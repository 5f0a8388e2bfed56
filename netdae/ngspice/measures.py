"""ngspice's ``.meas`` output read back: values, failures and their reasons.

ngspice prints a measurement as a line on stdout after the analysis
(``Measurements for Transient Analysis``)::

    trise               =  2.197224e-03 targ=  2.302586e-03 trig=  1.053611e-04
    vmax                =  8.645360e-01 at=  1.999050e-03
    ratio               =   failed

and a measurement it cannot make as error lines ending with the card and
``failed!`` (stderr, or stdout for some reasons; ngspice 39 says ``Error:``
although the run itself is fine)::

    Error: measure  nev  when(WHEN) : out of interval
     .meas tran nev when v(out)=2 failed!

:func:`read_measures` takes these lines out of ngspice's output (so that they
are not taken for errors of the run) and returns one
:class:`~netdae.measures.Measure` per ``.meas`` card of the netlist ngspice
ran, in card order. Values carry ngspice's printed precision (7 significant
digits, 6 for some functions).

Examples
--------
>>> ms, out, err = read_measures(
...     ".meas tran a FIND v(x) AT=1\\n.meas tran b WHEN v(x)=2\\n",
...     ["a                   =  1.500000e+00", "done"],
...     ["Error: measure  b  when(WHEN) : out of interval", " .meas tran b when v(x)=2 failed!"])
>>> [(m.name, m.value, m.status, m.reason) for m in ms], out, err
([('a', 1.5, 'ok', ''), ('b', None, 'failed', 'out of interval')], ['done'], [])

A value ngspice prints as ``-inf`` (with ``Error: Bad value.`` on stderr; the run itself finished):

>>> ms, out, err = read_measures(".meas tran t1 WHEN v(x)=0.5 RISE=1\\n", ["t1                  =   -inf"],
...                              ["Error: Bad value."])
>>> [(m.name, m.value, m.status, m.reason) for m in ms], err
([('t1', None, 'failed', "ngspice printed -inf ('Error: Bad value.')")], [])
"""

from __future__ import annotations

import re

from ..measures import STATUS_FAILED, Measure

__all__ = ["read_measures", "measure_cards"]

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_VALUE = re.compile(rf"^\s*(\S+)\s*=\s*({_NUMBER}|failed|[-+]?inf|[-+]?nan)((?:\s+\w+=\s*{_NUMBER})*)\s*$", re.I)
#: What ngspice 39 prints on stderr where a measurement's value is not finite (``t1 = -inf``).
_BAD_VALUE = re.compile(r"^\s*error:\s*bad value\.?\s*$", re.I)
_EXTRA = re.compile(rf"(\w+)=\s*({_NUMBER})")
_FAILED_CARD = re.compile(r"^\s*\.meas(?:ure)?\s+\S+\s+(\S+).*\bfailed!\s*$", re.I)
_FAILED_NAME = re.compile(r"^\s*measure\s+'([^']+)'\s+failed", re.I)
_ERROR_NAME = re.compile(r"^\s*error:\s*measure\s+(\S+)", re.I)
_CARD = re.compile(r"^\s*\.meas(?:ure)?\s+(\S+)\s+(\S+)\s+(\S+)", re.I)
#: Error lines looked back for above a ``failed!`` line (the reason).
_REASON_LINES = 3
#: The head of a message of ngspice's parameter substitution (numparam): the deck's line it is about.
_NUMPARAM_AT = re.compile(r"^\s*(?:netlist line no\.\s*(\d+)|original line no\.:\s*(\d+)[^:]*):\s*$", re.I)


def measure_cards(netlist: str) -> list[tuple[str, str, str]]:
    """(analysis, name, function) of every ``.meas`` card of a one-card-per-line netlist, lower case."""
    out = []
    for line in netlist.splitlines():
        m = _CARD.match(line)
        if m is not None:
            out.append(tuple(g.lower() for g in m.groups()))
    return out


def _reason(lines: list[str]) -> str:
    parts = []
    for line in lines:
        text = re.sub(r"^\s*error:\s*", "", line.strip(), flags=re.I)
        text = re.sub(r"^measure\s+\S+\s+failed:?\s*", "", text, flags=re.I)
        text = re.sub(r"^measure\s+\S+\s+(?:\S+\s+)?(?:\(\S*\)\s*)?:\s*", "", text, flags=re.I)
        if text:
            parts.append(text.rstrip("."))
    return "; ".join(parts)


def _substitutions(lines: list[str], netlist: str) -> tuple[dict[str, str], list[str]]:
    """The messages of ngspice's parameter substitution about ``.meas`` cards, and the other lines.

    A ``PARAM`` measurement of a measurement that failed (or of one of another analysis) cannot
    be substituted after the run: ngspice prints ``Netlist line no. N:`` before each line of its
    complaint (``Undefined parameter [t1]``, ``Expression err: ...``, ``Cannot compute
    substitute``), then the measurement as ``failed``, and goes on. Returns the complaint by
    measurement name (the card on line N of ``netlist``, the title line 1) and the lines left.
    """
    card_at = {}
    for number, line in enumerate(netlist.splitlines(), start=1):
        m = _CARD.match(line)
        if m is not None:
            card_at[number] = m.group(2).lower()
    reasons: dict[str, list[str]] = {}
    rest = []
    i = 0
    while i < len(lines):
        m = _NUMPARAM_AT.match(lines[i])
        name = card_at.get(int(m.group(1) or m.group(2))) if m is not None else None
        if name is None or i + 1 >= len(lines):
            rest.append(lines[i])
            i += 1
            continue
        text = lines[i + 1].strip()
        if text and text.lower() != "cannot compute substitute":
            reasons.setdefault(name, []).append(text)
        i += 2
    return {name: "; ".join(texts) for name, texts in reasons.items()}, rest


def _failures(lines: list[str], names: set[str]) -> tuple[dict[str, str], list[str]]:
    """Failed measurements and their reasons, and the lines that are not about them."""
    failed: dict[str, str] = {}
    drop = set()
    for i, line in enumerate(lines):
        m = _FAILED_CARD.match(line)
        if m is not None and m.group(1).lower() in names:
            drop.add(i)
            above = []
            j = i - 1
            while j >= 0 and len(above) < _REASON_LINES and j not in drop and lines[j].strip() \
                    and not _FAILED_CARD.match(lines[j]) and not _VALUE.match(lines[j]) \
                    and not lines[j].strip().lower().startswith(("warning", "note")):
                above.insert(0, lines[j])
                drop.add(j)
                j -= 1
            failed[m.group(1).lower()] = "; ".join(filter(None, (failed.get(m.group(1).lower()), _reason(above))))
            continue
        m = _FAILED_NAME.match(line) or _ERROR_NAME.match(line)
        if m is not None and m.group(1).lower() in names:
            name = m.group(1).lower()
            drop.add(i)
            reason = [line] if _ERROR_NAME.match(line) else []
            j = i + 1
            while j < len(lines) and lines[j].strip() and lines[j][:1] in " \t" and not _VALUE.match(lines[j]) \
                    and not _FAILED_CARD.match(lines[j]):
                reason.append(lines[j])
                drop.add(j)
                j += 1
            if _reason(reason):
                failed[name] = "; ".join(filter(None, (failed.get(name), _reason(reason))))
            else:
                failed.setdefault(name, "")
    return failed, [line for i, line in enumerate(lines) if i not in drop]


def read_measures(netlist: str, stdout: list[str], stderr: list[str]) -> tuple[list[Measure], list[str], list[str]]:
    """ngspice's measurements of ``netlist``, and its output without the measurement lines.

    Parameters
    ----------
    netlist : str
        The text ngspice ran (one card per line).
    stdout, stderr : list of str
        ngspice's lines.

    Returns
    -------
    measures : list of Measure
        One per ``.meas`` card, in card order: the printed value (``at``,
        ``from``/``to``, ``trig``/``targ`` as printed), or ``failed`` with
        ngspice's reason ("ngspice printed no value" when it said nothing).
    stdout, stderr : list of str
        The other lines, for :func:`netdae.ngspice.translate.classify_output`.
    """
    cards = measure_cards(netlist)
    if not cards:
        return [], stdout, stderr
    names = {name for _, name, _ in cards}
    # the printed lines of each name in order (ngspice prints one per card, a name's cards in card order)
    printed: dict[str, list[tuple[float | None, dict]]] = {}
    rest_out = []
    infinite: dict[str, str] = {}  # a value printed as -inf, inf or nan: the measurement failed
    for line in stdout:
        m = _VALUE.match(line)
        if m is not None and m.group(1).lower() in names:
            word = m.group(2).lower()
            number = None if word == "failed" or word.lstrip("+-") in ("inf", "nan") else float(m.group(2))
            if word.lstrip("+-") in ("inf", "nan"):
                infinite[m.group(1).lower()] = f"ngspice printed {m.group(2)}"
            extra = {k.lower(): float(v) for k, v in _EXTRA.findall(m.group(3) or "")}
            printed.setdefault(m.group(1).lower(), []).append((number, extra))
        else:
            rest_out.append(line)
    failed_out, rest_out = _failures(rest_out, names)
    failed_err, rest_err = _failures(list(stderr), names)
    substituted, rest_err = _substitutions(rest_err, netlist)
    if infinite and any(_BAD_VALUE.match(line) for line in rest_err):
        # ngspice's 'Error: Bad value.' is about such a value, not the run (its analysis finished)
        rest_err = [line for line in rest_err if not _BAD_VALUE.match(line)]
        infinite = {name: f"{why} ('Error: Bad value.')" for name, why in infinite.items()}
    failed = {name: "; ".join(filter(None, (failed_out.get(name), failed_err.get(name), substituted.get(name),
                                            infinite.get(name))))
              for name in {*failed_out, *failed_err, *substituted, *infinite}}
    out = []
    seen: dict[str, int] = {}
    for analysis, name, function in cards:
        k = seen[name] = seen.get(name, -1) + 1
        lines = printed.get(name, [])
        if k < len(lines) and lines[k][0] is not None:
            number, extra = lines[k][0], dict(lines[k][1])
            at = extra.pop("at", None)
            out.append(Measure(name, analysis, function, number, at=at, extra=extra))
            continue
        reason = failed.get(name) or ("ngspice printed 'failed'" if k < len(lines) else
                                      "ngspice could not make it" if name in failed else "ngspice printed no value")
        out.append(Measure(name, analysis, function, None, status=STATUS_FAILED, reason=reason))
    return out, rest_out, rest_err
