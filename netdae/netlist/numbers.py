"""SPICE numbers: scale suffixes, trailing units, and ngspice's two readers.

ngspice reads numbers in two places with slightly different rules, and
netdae follows each one where ngspice uses it:

:func:`parse_number` -- a whole token of an element card, a source function,
a ``.model`` or analysis card, and a number inside a behavioural expression
(``B1 ... V=...``, ``E ... value=...``). This is ngspice's ``INPevaluate``:

- an optional sign, digits with an optional decimal point, an optional
  exponent introduced by ``e`` or ``d`` (``1e-3``, ``1.5d2`` = 150);
- then one scale suffix, case-insensitive: ``t`` 1e12, ``g`` 1e9,
  ``meg`` 1e6, ``k`` 1e3, ``m`` 1e-3 (so ``1M`` is one milli!), ``mil``
  25.4e-6, ``u`` 1e-6, ``n`` 1e-9, ``p`` 1e-12, ``f`` 1e-15; the micro
  sign ``\u00b5`` (U+00B5) is ``u``, as in ngspice since 2021 (the Greek
  letter mu, U+03BC, is not a suffix there: ``2\u03bc`` is 2);
- everything after that is ignored, so units may follow: ``10kOhm`` = 1e4,
  ``1uF`` = 1e-6, ``2.2nH``; but beware ``1F`` = 1e-15 (femto) and
  ``1Farad`` = 1e-15, and ``4k7`` = 4000 (ngspice 39 reads no RKM codes).

:func:`scan_param_number` -- a number inside a parameter expression
(``.param``, ``{...}`` and ``'...'`` values). This is ngspice's numparam
reader: a C floating-point literal (exponent ``e`` only), one scale letter
(``t g meg k m u µ n p f``, no ``mil``: ``1mil`` is 1e-3 there), then the
letters that follow are swallowed (``10kOhm`` = 1e4). A digit right after
the letters (``4k7``) is a syntax error there.

Examples
--------
>>> parse_number("10kOhm"), parse_number("1M"), parse_number("1MEG")
(10000.0, 0.001, 1000000.0)
>>> parse_number("1e-3"), parse_number("1.5d2"), parse_number("4k7")
(0.001, 150.0, 4000.0)
>>> print(f"{parse_number('1mil'):g} {parse_number('2.2nF'):g} {parse_number('1Farad'):g}")
2.54e-05 2.2e-09 1e-15
>>> parse_number("abc") is None
True
>>> scan_param_number("1mil*2", 0)
(0.001, 4)

References
----------
ngspice 39, ``src/spicelib/parser/inpeval.c`` (``INPevaluate``) and
``src/frontend/numparam/xpressn.c`` (``fetchnumber``, ``parseunit``).
"""

from __future__ import annotations

import math
import re
from functools import lru_cache

__all__ = ["SCALE", "MICRO", "parse_number", "ignored_text", "underflows", "scan_param_number", "lookalike_hint"]

#: Scale factors of the one-letter suffixes (``m`` is milli; ``meg`` and
#: ``mil`` are recognised before ``m``).
SCALE = {
    "t": 1e12,
    "g": 1e9,
    "k": 1e3,
    "m": 1e-3,
    "u": 1e-6,
    "\u00b5": 1e-6,
    "n": 1e-9,
    "p": 1e-12,
    "f": 1e-15,
}

#: The micro sign (U+00B5), a scale suffix like ``u`` in both of ngspice's readers.
MICRO = "\u00b5"

#: One thousandth of an inch in metres (``mil``), applied as 25.4 * 1e-6.
_MIL_FACTOR = 25.4
#: Distinct number tokens remembered (netlists repeat their values a lot).
_CACHE_SIZE = 1 << 16
#: Number of mantissa digits a double holds exactly (2**53 > 10**15).
_EXACT_DIGITS = 15

# INPevaluate: sign, integer digits, optional fraction, optional exponent
# (e or d, digits optional), then whatever follows (suffix and ignored text).
_SPICE_NUMBER = re.compile(r"([+-]?)(\d*)(?:\.(\d*))?(?:[eEdD]([+-]?)(\d*))?(.*)", re.S | re.ASCII)

# numparam: a C floating literal as sscanf("%lG") reads it.
_PARAM_NUMBER = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
# numparam swallows letters after a number (its alfa(): letters, _ [ ] and 8-bit).
_PARAM_LETTERS = re.compile(r"[A-Za-z_\[\]\x80-\uffff]*")


def _mantissa(digits: str) -> float:
    """The digits as ngspice accumulates them (``10 * m + d`` in doubles)."""
    if len(digits) <= _EXACT_DIGITS:
        return float(int(digits)) if digits else 0.0
    value = 0.0
    for ch in digits:
        value = 10.0 * value + (ord(ch) - 48)
    return value


@lru_cache(maxsize=_CACHE_SIZE)
def parse_number(token: str) -> float | None:
    """Read a SPICE number the way ngspice's ``INPevaluate`` does.

    Parameters
    ----------
    token : str
        One token, e.g. ``"10k"``, ``"-1.5e-3"``, ``"2.2nF"``.

    Returns
    -------
    float or None
        The value, or None when the token does not start like a number
        (after an optional sign it needs a digit, or a point and a digit).

    Notes
    -----
    Text after the scale suffix is ignored, as in ngspice. The value is
    computed as ``sign * mantissa * 10.0**exponent`` like ngspice, so it is
    bit-identical to ngspice's for mantissas up to 15 digits.
    """
    m = _SPICE_NUMBER.match(token)
    sign, whole, frac, esign, edigits, rest = m.groups()
    frac = frac or ""
    if not whole and not frac:
        return None
    mantissa = _mantissa(whole + frac)
    exponent = -len(frac)
    if edigits:
        exponent += -int(edigits) if esign == "-" else int(edigits)
    if rest:
        c = rest[0].lower()
        if c == "m":
            low = rest[:3].lower()
            if low == "meg":
                exponent += 6
            elif low == "mil":
                exponent -= 6
                mantissa *= _MIL_FACTOR
            else:
                exponent -= 3
        elif c in SCALE:
            exponent += _SCALE_EXPONENT[c]
    try:
        value = mantissa * 10.0**exponent
    except OverflowError:  # C's pow() gives inf
        value = math.inf
    return -value if sign == "-" else value


_SCALE_EXPONENT = {"t": 12, "g": 9, "k": 3, "u": -6, MICRO: -6, "n": -9, "p": -12, "f": -15}
_DIGIT_OR_POINT = re.compile(r"[0-9.]")


def ignored_text(token: str) -> str:
    """The part of a number token that :func:`parse_number` ignores, when it looks numeric.

    ngspice ignores whatever follows a number and its scale suffix, so
    ``1.2.3k`` is 1.2 and ``4k7`` is 4000. A unit (``10kOhm``) is the
    intended use; ignored text with a digit or a point in it is almost
    always a typing error, worth a warning.

    Returns
    -------
    str
        The ignored text when it contains a digit, a point or a typographic look-alike of an
        ASCII character (``4.7\u03bc``: a Greek mu, not ``u``), else ``""``
        (also for a token that is not a number).

    Examples
    --------
    >>> ignored_text("1.2.3k"), ignored_text("4k7"), ignored_text("10kOhm"), ignored_text("1meg")
    ('.3k', '7', '', '')

    An exponent without digits (``1e``, ``1E+``) is ignored text too:

    >>> ignored_text("1e"), ignored_text("1E+"), ignored_text("1e3")
    ('e', 'E+', '')
    """
    m = _SPICE_NUMBER.match(token)
    rest = m.group(6)
    if not (m.group(2) or m.group(3)):
        return ""
    if m.group(4) is not None and not m.group(5):  # a dangling exponent: '1e', '1E+'
        return token[m.start(4) - 1:]
    if not rest:
        return ""
    c = rest[0].lower()
    if c == "m":
        low = rest[:3].lower()
        rest = rest[3:] if low in ("meg", "mil") else rest[1:]
    elif c in SCALE:
        rest = rest[1:]
    return rest if _DIGIT_OR_POINT.search(rest) or lookalike_hint(rest) else ""


#: Characters a word processor or a PDF puts where a netlist needs ASCII, and what was meant.
_LOOKALIKES = {"\u2013": ("an en dash", "-"), "\u2014": ("an em dash", "-"), "\u2212": ("a minus sign", "-"),
               "\u2010": ("a hyphen", "-"), "\u2011": ("a non-breaking hyphen", "-"), "\u2012": ("a figure dash", "-"),
               "\u03bc": ("a Greek mu", "u")}  # (the micro sign, MICRO, is a scale suffix)


def lookalike_hint(text: str) -> str | None:
    """The hint for the first typographic look-alike of an ASCII character in ``text`` (None: none).

    >>> lookalike_hint("\u20131k")
    "'\u2013' (U+2013) is an en dash, not ASCII '-': a word processor or a PDF put it there; type '-'"
    """
    for ch in text:
        if ch in _LOOKALIKES:
            what, meant = _LOOKALIKES[ch]
            return (f"'{ch}' (U+{ord(ch):04X}) is {what}, not ASCII '{meant}': a word processor or a PDF put it "
                    f"there; type '{meant}'")
    return None


def underflows(token: str) -> bool:
    """Whether a number token with a nonzero mantissa reads as 0 (``1e-400``: below the smallest double).

    Examples
    --------
    >>> underflows("1e-400"), underflows("0e-400"), underflows("1e-300")
    (True, False, False)
    """
    m = _SPICE_NUMBER.match(token)
    digits = (m.group(2) or "") + (m.group(3) or "")
    return parse_number(token) == 0.0 and any(d != "0" for d in digits)


def scan_param_number(text: str, pos: int) -> tuple[float, int] | None:
    """Read a number at ``text[pos:]`` the way ngspice's numparam does.

    Parameters
    ----------
    text : str
        The expression text.
    pos : int
        Index of the first character (a digit or a point).

    Returns
    -------
    (value, end) or None
        The value and the index just after the number and its swallowed
        letters; None when no number starts at ``pos``.
    """
    m = _PARAM_NUMBER.match(text, pos)
    if m is None:
        return None
    value = float(m.group())
    end = m.end()
    if end < len(text):
        c = text[end].lower()
        if c == "m":
            value *= 1e6 if text[end : end + 3].lower() == "meg" else 1e-3
        elif c in SCALE:
            value *= SCALE[c]
    end = _PARAM_LETTERS.match(text, end).end()
    return value, end
