"""Measurements (``.meas``/``.measure`` cards): what to measure, and what was measured.

Plain data, no numerics: the reader (:mod:`netdae.netlist.measure`,
:mod:`netdae.netlist.elaborate`) turns each card into a :class:`MeasureSpec`
with every number evaluated and every signal checked against the circuit;
:mod:`netdae.analyses.measure` evaluates the specs on the analyses' results
and returns one :class:`Measure` per card; :func:`format_measure` prints it as
ngspice does (``name = value`` and the ``at=``, ``from= to=`` or ``targ= trig=``
ngspice adds).

Examples
--------
>>> m = Measure("trise", "tran", "trig", 2.197e-3, extra={"targ": 2.3e-3, "trig": 1.05e-4})
>>> format_measure(m)
'trise               =  2.197000e-03 targ=  2.300000e-03 trig=  1.050000e-04'
>>> format_measure(Measure("t1", "tran", "when", None, status="failed", reason="v(out) never crosses 2"))
't1                  =  failed (v(out) never crosses 2)'
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from .signals import Signal

__all__ = ["Probe", "Condition", "MeasureSpec", "Measure", "format_measure", "FUNCTIONS", "AC_PREFIXES",
           "LAST", "MEASURE_ANALYSES", "MeasureStatus", "leaf_signal"]

#: Analyses a measurement can refer to.
MEASURE_ANALYSES = ("tran", "ac", "dc")
#: The measurement functions (``TRIG`` covers ``TRIG ... TARG ...``; ``INTEGRAL`` is ``INTEG``).
FUNCTIONS = ("trig", "find", "when", "deriv", "min", "max", "min_at", "max_at", "pp", "avg", "rms", "integ", "param")
#: ngspice's AC prefixes of ``v(...)``: ``vdb`` dB of the magnitude, ``vm`` magnitude, ``vp`` phase
#: in radians (as ngspice 39 prints it), ``vr`` real part, ``vi`` imaginary part.
AC_PREFIXES = {"db": "dB of the magnitude", "m": "magnitude", "p": "phase [rad]", "r": "real part",
               "i": "imaginary part"}
#: ``RISE=LAST``, ``FALL=LAST``, ``CROSS=LAST`` (or a bare ``LAST``).
LAST = -1


@dataclass(frozen=True)
class Probe:
    """A measured quantity: a signal, for AC maybe through a prefix (``vdb(out)``), or an
    expression of signals (ngspice's ``par('v(out)*i(vdd)')``).

    Attributes
    ----------
    signal : Signal or None
        ``v(node)``, ``v(a,b)`` or ``i(element)`` (:mod:`netdae.signals`); None for an expression.
    part : str
        ``""`` (AC: the real part, as ngspice), or a key of :data:`AC_PREFIXES`.
    expression : Expr or None
        ``par('...')``: the tree (:mod:`netdae.netlist.expr`) of ``V()``, ``I()``, ``time`` and
        numbers (parameters already replaced by their values), evaluated point by point on the
        signals it reads (:meth:`reads`).
    """

    signal: Signal | None
    part: str = ""
    expression: Any = None

    @property
    def name(self) -> str:
        """As written canonically: ``v(out)``, ``vdb(out)``, ``v(a,b)``, ``par('v(a)*2')``."""
        if self.expression is not None:
            from .netlist.expr import to_text

            return f"par('{to_text(self.expression)}')"
        base = self.signal.name
        return base[0] + self.part + base[1:] if self.part else base

    def reads(self) -> tuple[Signal, ...]:
        """The signals the quantity is made of: its signal, or those its expression reads, in order."""
        if self.expression is None:
            return (self.signal,)
        from .netlist import expr as ex

        out: dict[str, Signal] = {}
        for node in ex.walk(self.expression):
            if isinstance(node, (ex.Voltage, ex.Current)):
                sig = leaf_signal(node)
                out.setdefault(sig.name, sig)
        return tuple(out.values())


def leaf_signal(leaf) -> Signal:
    """The signal a ``V()``/``I()`` leaf of an expression (:mod:`netdae.netlist.expr`) reads."""
    from .netlist.expr import Current

    if isinstance(leaf, Current):
        return Signal("i", (leaf.element,))
    return Signal("v", (leaf.pos,) if leaf.neg in (None, "0") else (leaf.pos, leaf.neg))


@dataclass(frozen=True)
class Condition:
    """Where a quantity meets a value: ``TRIG``/``TARG``/``WHEN`` clauses.

    Attributes
    ----------
    probe : Probe or None
        The quantity (None for ``TRIG AT=t``).
    value : float or None
        ``VAL=`` or the number after ``=`` in ``WHEN``.
    other : Probe or None
        ``WHEN a=b``: the second quantity (then ``value`` is None).
    edge : str
        ``"rise"``, ``"fall"``, ``"cross"`` or ``""`` (the first crossing of any kind).
    count : int
        Which crossing, from 1; :data:`LAST` for the last.
    td : float
        Crossings of a transient before this time are not counted (``TD=``); without ``TD=`` minus
        infinity. A ``.meas ac`` or ``.meas dc`` does not read it (ngspice 39 does not).
    at : float or None
        ``TRIG AT=t``: the time itself.
    start, stop : float or None
        ``FROM=`` and ``TO=`` written in a ``TRIG`` or ``TARG`` clause: the stretch of the
        axis its crossings are looked for in (a ``WHEN``'s are the measurement's
        :attr:`MeasureSpec.start` and :attr:`MeasureSpec.stop`). As in ngspice 39, a ``TRIG``
        or ``TARG`` without ``FROM=`` takes the other clause's ``FROM=``; ``TO=`` is the
        clause's own.
    """

    probe: Probe | None
    value: float | None = None
    other: Probe | None = None
    edge: str = ""
    count: int = 1
    td: float = -math.inf
    at: float | None = None
    start: float | None = None
    stop: float | None = None


@dataclass(frozen=True)
class MeasureSpec:
    """One ``.meas`` card, elaborated.

    Attributes
    ----------
    name : str
        Lower case, as ngspice prints it.
    analysis : str
        ``"tran"``, ``"ac"`` or ``"dc"``.
    function : str
        One of :data:`FUNCTIONS`.
    probe : Probe or None
        The measured quantity (``FIND``, ``DERIV``, ``MIN`` ... ``INTEG``).
    trig, targ : Condition or None
        ``TRIG ... TARG ...``.
    when : Condition or None
        ``WHEN ...`` (alone, or after ``FIND``/``DERIV``).
    at : float or None
        ``FIND``/``DERIV ... AT=``.
    start, stop : float or None
        ``FROM=``, ``TO=`` (for ``MIN`` ... ``INTEG`` also ``TD=``, folded into ``start``).
    expression : object or None
        ``PARAM='...'``: the expression tree (:mod:`netdae.netlist.expr`) whose
        parameters are measurements (every non-``PARAM`` one, earlier ``PARAM`` ones) or top-level ``.param`` values.
    params : dict
        The top-level parameter values a ``PARAM`` expression may use.
    location : SourceLocation or None
    text : str
        The card as written (one line).
    """

    name: str
    analysis: str
    function: str
    probe: Probe | None = None
    trig: Condition | None = None
    targ: Condition | None = None
    when: Condition | None = None
    at: float | None = None
    start: float | None = None
    stop: float | None = None
    expression: Any = None
    params: dict = field(default_factory=dict, compare=False, repr=False)
    location: Any = None
    text: str = ""

    def probes(self) -> list[Probe]:
        """Every quantity the measurement reads."""
        out = [self.probe] if self.probe is not None else []
        for cond in (self.trig, self.targ, self.when):
            if cond is not None:
                out += [p for p in (cond.probe, cond.other) if p is not None]
        return out

    def signals(self) -> list[str]:
        """The names of the signals the measurement reads (an expression's each), without repeats."""
        return list(dict.fromkeys(sig.name for probe in self.probes() for sig in probe.reads()))


class MeasureStatus(StrEnum):
    """Whether a measurement gave a value (a ``str``: compares, prints and serialises as its value,
    ngspice's words)."""

    OK = "ok"
    FAILED = "failed"

    def __repr__(self) -> str:
        return repr(self.value)


STATUS_OK = MeasureStatus.OK
STATUS_FAILED = MeasureStatus.FAILED


@dataclass
class Measure:
    """The outcome of one measurement.

    Attributes
    ----------
    name : str
    analysis : str
        ``"tran"``, ``"ac"``, ``"dc"``.
    function : str
        One of :data:`FUNCTIONS`.
    value : float or None
        None when it failed.
    status : MeasureStatus
        ``"ok"`` or ``"failed"`` (a text given is checked against the vocabulary).
    reason : str
        Why it failed (empty when ok).
    at : float or None
        Where the value was found: the axis value of ``MIN``/``MAX``, the
        crossing of ``WHEN``/``FIND ... WHEN``, the ``AT=`` of ``FIND``.
    extra : dict
        What ngspice prints after the value: ``targ``/``trig`` (``TRIG``),
        ``from``/``to`` (``AVG``, ``RMS``, ``INTEG``, ``PP``).
    """

    name: str
    analysis: str
    function: str
    value: float | None
    status: MeasureStatus = STATUS_OK
    reason: str = ""
    at: float | None = None
    extra: dict[str, float] = field(default_factory=dict)

    def __post_init__(self):
        self.status = MeasureStatus(self.status)

    @property
    def ok(self) -> bool:
        """True when the measurement succeeded."""
        return self.status == STATUS_OK

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: name, analysis, function, value, status, reason, at, and the extras."""
        def clean(v):
            return None if v is None or not math.isfinite(v) else float(v)

        return {"name": self.name, "analysis": self.analysis, "function": self.function,
                "value": clean(self.value), "status": self.status, "reason": self.reason,
                "at": clean(self.at), **{k: clean(v) for k, v in self.extra.items()}}


#: The extras ngspice prints after a value, by function.
_PRINTED = {"trig": ("targ", "trig"), "min": ("at",), "max": ("at",), "min_at": ("with",), "max_at": ("with",),
            "avg": ("from", "to"),
            "rms": ("from", "to"), "integ": ("from", "to"), "pp": ("from", "to")}


def format_measure(m: Measure) -> str:
    """One line as ngspice prints it: ``name = value`` (``%e``) and its ``at=``/``from= to=``/``targ= trig=``."""
    head = f"{m.name:<20}="
    if not m.ok:
        return f"{head}  failed ({m.reason})" if m.reason else f"{head}  failed"
    parts = [f"{head} {m.value: e}"]
    for key in _PRINTED.get(m.function, ()):
        value = m.at if key == "at" else m.extra.get(key)
        if value is not None:
            parts.append(f"{key}= {value: e}")
    return " ".join(parts)
