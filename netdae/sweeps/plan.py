"""What a sweep runs: its axes (``.step`` cards and ``params=``), Monte Carlo samples, and rows.

A *row* is one simulation: a value on every axis and, for a Monte Carlo
sweep, a sample index. Rows are ordered as nested loops, the first axis
outermost, the samples innermost. The sample index of a row is its Monte
Carlo index within its point (0 to N-1), so every point of a stepped Monte
Carlo sweep sees the same N realisations of the random values (common random
numbers: differences between points are not blurred by different draws).
"""

from __future__ import annotations

import difflib

import itertools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from ..circuit import Circuit
from ..errors import NetdaeError
from ..kinds import STEPPABLE_KINDS
from ..netlist.steps import StepSpec, model_parameter

__all__ = ["Axis", "Row", "Plan", "make_plan", "MAX_ROWS"]

#: The most rows a sweep may have (each is a simulation).
MAX_ROWS = 10_000_000


@dataclass(frozen=True, slots=True)
class Axis:
    """One swept quantity.

    Parameters
    ----------
    target : {"param", "element", "model", "temp"}
    name : str
        Top-level parameter, element full name, ``"model(param)"``, or ``"temp"``.
    values : tuple of float
    """

    target: str
    name: str
    values: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class Row:
    """One simulation of a sweep.

    Parameters
    ----------
    index : int
        Position in the sweep (0-based).
    point : tuple of float
        The value of every axis, in axis order.
    sample : int or None
        The Monte Carlo sample index (None: no Monte Carlo).
    """

    index: int
    point: tuple[float, ...]
    sample: int | None


@dataclass(frozen=True, slots=True)
class Plan:
    """The axes, the Monte Carlo sample count and the rows of a sweep."""

    axes: tuple[Axis, ...]
    samples: int | None
    rows: tuple[Row, ...]

    def overrides(self, row: Row) -> tuple[dict[str, float], dict[str, float]]:
        """``(params, values)`` for :func:`netdae.netlist.elaborate`: parameters (``temper`` for
        temp) and element values of ``row``."""
        params: dict[str, float] = {}
        values: dict[str, float] = {}
        for axis, v in zip(self.axes, row.point):
            if axis.target in ("element", "model"):
                values[axis.name] = v
            else:
                params["temper" if axis.target == "temp" else axis.name] = v
        return params, values


def _target(circuit: Circuit, name: str) -> str:
    """What ``name`` sets: a top-level parameter, ``temp``, an element, or a model parameter (``model(param)``)."""
    if name in circuit.params:
        return "param"
    mp = model_parameter(name)
    if mp is not None:
        if mp[0] not in circuit.models:
            known = ", ".join(sorted(circuit.models)) or "none"
            raise NetdaeError(f"sweep: no model '{mp[0]}' for '{name}' (models: {known})")
        return "model"
    if name == "temp":
        return "temp"
    try:
        el = circuit.element(name)
    except KeyError:
        known = ", ".join(sorted(circuit.params)) or "none"
        names = dict.fromkeys([*circuit.params, *(e.name for e in circuit.elements), "temp"])
        near = difflib.get_close_matches(name, list(names), n=3)
        hint = (f"did you mean {' or '.join(near)}? " if near else "") + \
            "name a .param, an element (r1), a model parameter as model(param) (dmod(is)) or temp"
        raise NetdaeError(f"sweep: '{name}' is neither a top-level .param ({known}), an element, nor temp "
                          f"(hint: {hint})") from None
    if el.kind not in STEPPABLE_KINDS:
        raise NetdaeError(f"sweep: cannot step '{name}', a {el.kind}: step a .param used in its value or model")
    return "element"


def _values(name: str, values) -> tuple[float, ...]:
    if isinstance(values, (int, float)) and not isinstance(values, bool):
        values = (values,)
    try:
        out = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise NetdaeError(f"sweep: the values of '{name}' must be numbers, got {values!r}") from None
    if not out:
        raise NetdaeError(f"sweep: '{name}' has no values to step through")
    bad = next((v for v in out if not math.isfinite(v)), None)
    if bad is not None:
        raise NetdaeError(f"sweep: '{name}' has a value that is not finite ({bad})")
    return out


def make_plan(circuit: Circuit, params: Mapping[str, Iterable[float] | float] | None = None,
              samples: int | None = None) -> Plan:
    """The rows of a sweep of ``circuit``.

    Parameters
    ----------
    circuit : Circuit
        Its ``.step`` cards are the axes.
    params : mapping, optional
        More axes: name (a top-level ``.param``, an element, or ``temp``) to
        values. A name that a ``.step`` card also steps replaces that card's
        values in place; the others are added after the cards.
    samples : int, optional
        Monte Carlo samples per point.

    Returns
    -------
    Plan

    Raises
    ------
    NetdaeError
        An unknown name, an empty or non-numeric list of values, a sample
        count that is not a positive integer, more than :data:`MAX_ROWS` rows.
    """
    axes: list[Axis] = [Axis(s.target, s.name, s.values) for s in circuit.steps if isinstance(s, StepSpec)]
    for raw, values in (params or {}).items():
        name = str(raw).lower()
        axis = Axis(_target(circuit, name), name, _values(name, values))
        slot = next((k for k, a in enumerate(axes) if a.name == name), None)
        if slot is None:
            axes.append(axis)
        else:
            axes[slot] = axis
    if samples is not None:
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
            raise NetdaeError(f"sweep: samples must be a positive integer, got {samples!r}")
    total = math.prod(len(a.values) for a in axes) * (samples or 1)
    if total > MAX_ROWS:
        raise NetdaeError(f"sweep: {total:,} simulations is more than netdae runs in one sweep ({MAX_ROWS:,})")
    sample_range: Iterable[int | None] = range(samples) if samples is not None else (None,)
    rows = []
    for point in itertools.product(*(a.values for a in axes)):
        for s in sample_range:
            rows.append(Row(len(rows), tuple(point), s))
    return Plan(tuple(axes), samples, tuple(rows))
