"""``.step`` cards (netdae's extension, as LTspice and Xyce write them) and sweep grids.

Forms (case-insensitive; the variation word may come before or after the name)::

    .step param NAME start stop incr          linear (also: lin)
    .step dec param NAME start stop points    points per decade (oct: per octave)
    .step param NAME list v1 v2 ...           the values as listed
    .step R1 1k 10k 1k                        an element's value (R, C, L; a V/I source's DC
                                              value; an E/F/G/H gain)
    .step temp -40 125 15                     the circuit temperature
    .step NPN 2N2222(VAF) 50 100 25           a model parameter (LTspice's form; the model
                                              type word is optional; Xyce's 2N2222:VAF too)

Several ``.step`` cards nest: the points are all combinations, the last card
varying fastest. ngspice has no ``.step``; ``netdae compare`` runs each point
in ngspice as a separate netlist.

:func:`grid` is the one place where linear and logarithmic sweep points are
made (``.ac`` frequencies, ``.step``, ``netdae sweep --step``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SourceLocation, count_text
from .elements import error, parse_value
from .lines import PUNCT, WORD, Card, Token
from .numbers import parse_number
from .syntax import DOT_CARDS

__all__ = ["StepCard", "StepSpec", "parse_step", "model_parameter", "unseen_step", "grid", "GRID_SLACK",
           "VARIATIONS"]

#: Relative slack that keeps the stop value in a grid despite rounding.
GRID_SLACK = 1e-9
#: The most points a sweep grid may have (`.step`, `.dc`, `.ac`, `.noise`, `--step`): ten million points
#: are 80 MB per saved signal, and a card that asks for more is almost always a typo (a step of 1e-9
#: where 1e-3 was meant); building its grid alone would take the machine's memory.
MAX_GRID_POINTS = 10_000_000
VARIATIONS = ("lin", "dec", "oct", "list")
#: Model type words that may stand before a stepped model parameter (LTspice: ``.step NPN Q(BF) ...``).
MODEL_TYPE_WORDS = frozenset({"npn", "pnp", "d", "nmos", "pmos", "njf", "pjf", "nmf", "pmf", "sw", "csw", "r", "c",
                              "l"})


@dataclass
class StepCard:
    """A parsed ``.step`` card (values unevaluated)."""

    card: Card
    keyword_param: bool
    name: str
    name_offset: int
    variation: str
    values: list  # Val
    model_type: str | None = None  # the type word before a model parameter (LTspice: NPN)


@dataclass(frozen=True, slots=True)
class StepSpec:
    """One elaborated ``.step``: what it sets and its points.

    Parameters
    ----------
    target : {"param", "element", "model", "temp"}
    name : str
        The top-level parameter, the element's full name, ``"model(param)"``
        (see :func:`model_parameter`), or ``"temp"``.
    values : tuple of float
    location : SourceLocation or None
    """

    target: str
    name: str
    values: tuple[float, ...]
    location: SourceLocation | None = None

    @property
    def label(self) -> str:
        """The column name of this step in sweep tables (``r``, ``r1``, ``temp``)."""
        return self.name


def parse_step(card: Card, toks: list[Token]) -> StepCard:
    """Read a ``.step`` card.

    Raises
    ------
    NetlistError
        A missing name, an unknown variation, a wrong number of values.
    """
    form = DOT_CARDS[".step"]
    words = [t for t in toks[1:] if not (t.kind == PUNCT and t.text == ",")]
    variation = None
    keyword_param = False
    name_tok = None
    i = 0
    while i < len(words) and name_tok is None:
        tok = words[i]
        text = tok.text if tok.kind == WORD else None
        if text in VARIATIONS and variation is None and parse_number(text) is None:
            variation = text
        elif text == "param" and not keyword_param:
            keyword_param = True
        elif text is not None and parse_number(text) is None:
            name_tok = tok
        else:
            raise error(card, tok.start, f"expected a parameter, element or temp to step, found {tok.text!r}", form)
        i += 1
    if name_tok is None:
        raise error(card, len(card.text), "missing the name of what to step", form)
    name, model_type = name_tok.text, None
    # a model parameter: [type] MODEL ( PARAM ) as LTspice writes it, or MODEL:PARAM as Xyce does
    if (i < len(words) and words[i].kind == WORD and parse_number(words[i].text) is None and i + 1 < len(words)
            and words[i + 1].kind == PUNCT and words[i + 1].text == "("):
        model_type, name_tok = name_tok.text, words[i]
        i += 1
    if i < len(words) and words[i].kind == PUNCT and words[i].text == "(":
        if not (i + 2 < len(words) and words[i + 1].kind == WORD and words[i + 2].text == ")"):
            raise error(card, words[i].start, "expected MODEL(PARAM): a model's name and one of its parameters "
                        "in parentheses", form)
        name = f"{name_tok.text}({words[i + 1].text})"
        i += 3
    elif ":" in name and not keyword_param:
        model, _, param = name.partition(":")
        if not model or not param:
            raise error(card, name_tok.start, f"expected MODEL:PARAM, found {name!r}", form)
        name = f"{model}({param})"
    elif model_type is not None:
        raise error(card, name_tok.start, "expected MODEL(PARAM) after the model type", form)
    elif (name in MODEL_TYPE_WORDS and not keyword_param and i < len(words) and words[i].kind == WORD
          and parse_number(words[i].text) is None and words[i].text not in VARIATIONS):
        raise error(card, words[i].start, "expected MODEL(PARAM) after the model type", form)
    if i < len(words) and words[i].kind == WORD and words[i].text in VARIATIONS:
        if variation is not None:
            raise error(card, words[i].start, f"a second variation word '{words[i].text}'", form)
        variation = words[i].text
        i += 1
    variation = variation or "lin"
    values = [parse_value(card, t, form, "step value") for t in words[i:]]
    if variation == "list":
        if not values:
            raise error(card, len(card.text), "a list step needs at least one value", form)
    elif len(values) != 3:
        at = words[i + 3].start if len(values) > 3 else len(card.text)
        what = "start stop points" if variation in ("dec", "oct") else "start stop increment"
        raise error(card, at, f"expected {what} ({len(values)} value{'s' if len(values) != 1 else ''} given)", form)
    return StepCard(card, keyword_param, name, name_tok.start, variation, values, model_type)


def model_parameter(name: str) -> tuple[str, str] | None:
    """``("2n2222", "vaf")`` for a stepped model parameter's name ``"2n2222(vaf)"``, else None."""
    if name.endswith(")") and "(" in name:
        model, _, param = name[:-1].partition("(")
        return model, param
    return None


def unseen_step(element, analyses) -> str | None:
    """Why stepping ``element`` changes nothing in the transient, or None.

    Stepping a V or I source sets its DC value. A source with a transient
    function (PULSE, SIN, EXP, PWL, SFFM, AM) follows that function in the
    transient and in the operating point it starts from (ngspice's rule,
    :class:`~netdae.circuit.SourceSpec`); the DC value enters the ``.op``,
    ``.dc``, ``.ac`` and ``.noise`` analyses only. (TRNOISE and TRRANDOM add
    the DC value to their random value: their steps do reach the transient.)

    Parameters
    ----------
    element : Element
    analyses : list
        The circuit's analysis cards (a netlist without ``.tran`` gives None).

    Returns
    -------
    str or None
        The warning's text.
    """
    from ..circuit import TranAnalysis
    from .waveforms import RandomSource

    source = element.source
    if (source is None or source.tran is None or isinstance(source.tran, RandomSource)
            or not any(isinstance(a, TranAnalysis) for a in analyses)):
        return None
    function = source.tran.kind.upper()
    return (f"'{element.name}' has a {function} transient function: the step sets its DC value, which the operating "
            f"point and the .dc, .ac and .noise analyses use, but the transient (and the operating point it starts "
            f"from) follows the {function} function, so this step changes nothing in the .tran result (to step the "
            f"{function}, step a .param used in its values)")


def check_grid_size(count: float) -> None:
    """Refuse a sweep of more than :data:`MAX_GRID_POINTS` points (``ValueError``, before anything is allocated)."""
    if not count <= MAX_GRID_POINTS:
        shown = count_text(count)
        raise ValueError(f"the sweep would have {shown} points, more than netdae's limit of {MAX_GRID_POINTS:,} "
                         "(check the increment or the number of points)")


def grid(variation: str, start: float, stop: float, step: float) -> np.ndarray:
    """The points of a linear or logarithmic sweep, as SPICE makes them.

    Parameters
    ----------
    variation : {"lin", "dec", "oct"}
        ``lin``: ``start, start + step, ...`` up to ``stop`` (``step`` is the
        increment; its sign must lead from start to stop); ``dec``/``oct``:
        ``start * base**(k/step)`` up to ``stop``, ``step`` points per decade
        or octave.
    start, stop, step : float

    Returns
    -------
    ndarray, shape (k,)

    Raises
    ------
    ValueError
        A zero increment or one of the wrong sign; a logarithmic sweep with a
        non-positive start or stop, stop below start, or a point count that is
        not a positive integer; more than :data:`MAX_GRID_POINTS` points.

    Examples
    --------
    >>> grid("lin", 1.0, 2.0, 0.25).tolist()
    [1.0, 1.25, 1.5, 1.75, 2.0]
    >>> grid("dec", 1.0, 100.0, 2).round(6).tolist()
    [1.0, 3.162278, 10.0, 31.622777, 100.0]
    """
    if variation == "lin":
        if start == stop:
            return np.array([start])
        if step == 0 or (stop - start) * step < 0:
            raise ValueError(f"the increment {step:g} does not lead from {start:g} to {stop:g}")
        span = (stop - start) / step * (1 + GRID_SLACK) + GRID_SLACK
        count = math.floor(span) + 1 if math.isfinite(span) else span  # inf: refused before it meets an integer
        check_grid_size(count)
        return start + step * np.arange(count)
    if variation not in ("dec", "oct"):
        raise ValueError(f"unknown variation {variation!r} (lin, dec or oct)")
    if step < 1 or step != int(step):
        raise ValueError(f"the number of points per {'decade' if variation == 'dec' else 'octave'} must be a "
                         f"positive integer, not {step:g}")
    if start <= 0 or stop <= 0:
        raise ValueError(f"a logarithmic sweep needs positive start and stop (got {start:g}, {stop:g})")
    if stop < start:
        raise ValueError(f"stop ({stop:g}) is below start ({start:g})")
    base = 10.0 if variation == "dec" else 2.0
    ratio = stop / start
    wide = not math.isfinite(ratio)  # 1e-300 to 1e300: the ratio overflows, its logarithm does not
    steps = ((math.log(stop) - math.log(start)) if wide else math.log(ratio)) / math.log(base) * step
    span = steps * (1 + GRID_SLACK) + GRID_SLACK
    count = math.floor(span) + 1 if math.isfinite(span) else span
    check_grid_size(count)
    k = np.arange(count)
    if wide:
        return np.exp(math.log(start) + (k / step) * math.log(base))
    return start * base ** (k / step)


def step_values(card: StepCard, numbers: list[float]) -> tuple[float, ...]:
    """The points of an elaborated ``.step`` card.

    Raises
    ------
    NetlistError
        At the card: what :func:`grid` refuses.
    """
    if card.variation == "list":
        return tuple(numbers)
    try:
        return tuple(grid(card.variation, *numbers).tolist())
    except ValueError as exc:
        raise error(card.card, card.values[0][1], str(exc), DOT_CARDS[".step"]) from None
