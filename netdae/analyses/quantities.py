"""Device quantities computed from a solution after the fact: ``i(r1)``, ``@r1[p]``, ``@c1[i]``.

The unknowns of the MNA system are node voltages and branch currents; the
currents of resistors and capacitors, powers and source voltages are not
among them. They are computed here from a result's signals, vectorised over
its points, once the analysis has run:

- a resistor's current ``G (v(n+) - v(n-))`` with the conductance netdae
  stamps (temperature, ``m``, ``scale``; the ``ac=`` resistance in ``.ac``);
- a capacitor's current ``C d(v(n+) - v(n-))/dt``: 0 in ``op`` and ``dc``,
  ``j w C v`` in ``.ac``, and in a transient the derivative of the
  integrator's dense output at each time point, taken on the step that ends
  there (the derivative the BDF formula gave that step), and linear between
  the points in the result's ``dense``;
- inductors' and voltage sources' currents are unknowns; their powers
  ``v i``, the power the element absorbs (as ngspice, sources included);
- an independent current source's voltage ``v(n-) - v(n+)`` (ngspice's
  sign: the voltage it drives its current against) and its absorbed power.

Powers are real quantities and are not offered in ``.ac``.
:data:`netdae.signals.DEVICE_QUANTITIES` lists the names.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..circuit import Circuit, Element
from ..devices.linear import capacitances, conductances
from ..errors import CircuitError
from ..results import Result
from ..signals import device_quantity, parse_signal

__all__ = ["Quantity", "plan_quantities", "add_quantities", "saved_currents", "measured_quantities",
           "SAVECURRENTS"]

#: The quantities ``.options savecurrents`` adds to a result that keeps every unknown (as ngspice 39).
SAVECURRENTS = {"resistor": "i", "capacitor": "i", "inductor": "i", "isource": "current"}

#: Size of the one-sided differences on the dense output, relative to the step ending at each point.
_DIFF_FRACTION = 1e-4


@dataclass(frozen=True)
class Quantity:
    """A device quantity to compute: the signal name, its element and the quantity."""

    name: str
    element: Element
    quantity: str

    def needs(self) -> list[str]:
        """The signals (node voltages, branch currents) it is computed from."""
        a, b = self.element.nodes[:2]
        volts = [f"v({n})" for n in (a, b) if n != "0"]
        if self.element.kind in ("inductor", "vsource"):
            return [f"i({self.element.name})"] + (volts if self.quantity == "p" else [])
        return volts


def plan_quantities(circuit: Circuit, names: list[str] | None) -> tuple[list[str] | None, list[Quantity]]:
    """Split signal names into what an analysis keeps and the device quantities computed afterwards.

    Parameters
    ----------
    circuit : Circuit
    names : list of str or None
        Signal names (``v(a)``, ``i(r1)``, ``@c1[i]`` ...); None: every unknown.

    Returns
    -------
    names : list of str or None
        ``names`` with each device quantity replaced by the signals it is
        computed from.
    quantities : list of Quantity

    Raises
    ------
    CircuitError
        For a device that is not in the circuit, or a quantity it does not
        have (the message lists the quantities it has).
    """
    if not names:
        return names, []
    out: list[str] = []
    quantities: list[Quantity] = []
    for raw in names:
        try:
            sig = parse_signal(raw)
        except ValueError:
            out.append(raw)  # the analysis judges names of no known form
            continue
        if sig.kind not in ("i", "@"):
            out.append(raw)
            continue
        try:
            el = circuit.element(sig.args[0])
        except KeyError:
            if sig.kind == "i":
                out.append(raw)
                continue
            raise CircuitError(f"{sig.name}: there is no device '{sig.args[0]}' in the circuit",
                               elements=(sig.args[0],)) from None
        try:
            q = device_quantity(sig, el.kind)
        except ValueError as exc:
            raise CircuitError(str(exc), elements=(el.name,)) from None
        if q is None:
            out.append(raw)
            continue
        item = Quantity(sig.name, el, q)
        quantities.append(item)
        out += [n for n in item.needs() if n not in out]
    return out, quantities


def saved_currents(circuit: Circuit) -> list[Quantity]:
    """The currents ``.options savecurrents`` saves: ``@r1[i]``, ``@c1[i]``, ``@l1[i]``, ``@i1[current]``."""
    if not circuit.options.extra.get("savecurrents"):
        return []
    return [Quantity(f"@{el.name}[{SAVECURRENTS[el.kind]}]", el, SAVECURRENTS[el.kind])
            for el in circuit.elements if el.kind in SAVECURRENTS and "#" not in el.name]


def measured_quantities(circuit: Circuit) -> list[Quantity]:
    """The device quantities the circuit's ``.meas`` cards read (``i(c1)``, ``@r1[p]``)."""
    names = list(dict.fromkeys(probe.signal.name for spec in circuit.measures for probe in spec.probes()))
    return plan_quantities(circuit, names)[1]


def add_quantities(circuit: Circuit, result: Result, quantities: list[Quantity]) -> list[str]:
    """Compute ``quantities`` from ``result``'s signals and add them to it (in place).

    Returns
    -------
    list of str
        The quantities this result cannot have (powers in ``.ac``), noted in
        ``result.notes``.
    """
    if not quantities or result.analysis in ("pz", "tf", "noise"):
        return []
    o = circuit.options
    ac = result.analysis == "ac"
    missing = []
    base = result.dense  # the integrator's own output (the derivatives are taken on it)
    for item in quantities:
        el, q = item.element, item.quantity
        if ac and q == "p":
            missing.append(item.name)
            result.notes.append(f"{item.name}: powers are real quantities, not in .ac results")
            continue
        v = _voltage(result, el)
        if el.kind == "resistor":
            g = float(conductances([el], o.temp, o.tnom, ac=ac)[0])
            i = g * v
            values = i if q == "i" else v * i
        elif el.kind == "capacitor":
            c = float(capacitances([el], o.temp, o.tnom)[0])
            i = c * _derivative(result, base, el, v)
            values = i if q == "i" else v * i
        elif el.kind == "inductor":
            i = result.signals[f"i({el.name})"]
            values = i if q == "i" else v * i
        elif el.kind == "vsource":
            i = result.signals[f"i({el.name})"]
            values = i if q == "i" else v * i
        else:  # isource: ngspice's voltage is v(n-) - v(n+), its power v(n+) - v(n-) times the current
            values = -v if q == "v" else _source_current(result, el) if q == "current" \
                else v * _source_current(result, el)
        result.signals[item.name] = np.asarray(values) + np.zeros(result.points, dtype=np.result_type(values))
        if result.dense is not None and result.analysis == "tran":
            result.dense = _dense_with(result.dense, circuit, item, result.t, result.signals[item.name])
    return missing


def _source_current(result: Result, el: Element) -> np.ndarray:
    """An independent current source's value at the result's points (DC value, swept value, waveform)."""
    if result.analysis == "tran" and el.source.tran is not None:
        wave = el.source.tran
        return np.array([float(wave.value(float(t))) for t in result.t])
    if result.analysis == "dc" and el.name in result.axes:
        return np.asarray(result.axes[el.name], dtype=float)
    if result.analysis == "tran":
        return np.full(result.points, el.source.dc if el.source.dc is not None else 0.0)
    return np.full(max(result.points, 1), el.source.dc_value())


def _voltage(result: Result, el: Element):
    a, b = el.nodes[:2]
    va = result.signals[f"v({a})"] if a != "0" else 0.0
    vb = result.signals[f"v({b})"] if b != "0" else 0.0
    return np.asarray(va - vb)


def _derivative(result: Result, dense, el: Element, v: np.ndarray) -> np.ndarray:
    """d/dt of ``v(n+) - v(n-)`` at the result's points: 0 at DC, j w in .ac, the dense output's in .tran."""
    if result.analysis == "ac":
        return 2j * np.pi * result.axes["frequency"] * v
    if result.analysis != "tran" or dense is None:
        return np.zeros_like(v, dtype=float)
    t = result.t
    steps = np.diff(t)
    h = _DIFF_FRACTION * np.where(steps > 0, steps, np.inf)
    h_left = np.concatenate([[np.inf], h])  # the step that ends at each point
    h_right = np.concatenate([h, [np.inf]])
    back = np.isfinite(h_left)  # backward differences on the step ending there, forward at the start
    hh = np.where(back, h_left, h_right)
    hh = np.where(np.isfinite(hh), hh, 0.0)
    sign = np.where(back, -1.0, 1.0)
    f1 = _dense_voltage(dense, el, t + sign * hh)
    f2 = _dense_voltage(dense, el, t + 2 * sign * hh)
    f0 = v
    with np.errstate(divide="ignore", invalid="ignore"):
        d = -sign * (3.0 * f0 - 4.0 * f1 + f2) / (2.0 * hh)
    return np.where(hh > 0, d, 0.0)


def _dense_voltage(dense, el: Element, t: np.ndarray) -> np.ndarray:
    y = dense(t)
    a, b = el.nodes[:2]
    return (y[f"v({a})"] if a != "0" else 0.0) - (y[f"v({b})"] if b != "0" else 0.0)


def _dense_with(dense, circuit: Circuit, item: Quantity, times: np.ndarray, values: np.ndarray):
    """``dense`` extended by ``item`` (for ``.meas`` and comparisons between the time points).

    A capacitor's current (and power) between the points is interpolated linearly between its
    values at the points (the steps' BDF derivatives): the derivative of the interpolant inside
    a step is an order less accurate than the interpolant, and right after a breakpoint, where
    the step restarts at order 1, it is constant over the step.
    """

    def extended(t):
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        y = dense(tt)
        if item.element.kind == "capacitor":
            y[item.name] = np.interp(tt, times, values)
            return y
        probe = Result("tran", axes={"time": tt}, signals=dict(y))
        add_quantities(circuit, probe, [item])
        y[item.name] = probe.signals[item.name]
        return y

    return extended
