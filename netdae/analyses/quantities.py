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

The nonlinear devices (diodes, bipolar transistors, MOSFETs, JFETs, and OSDI
devices with their modules' operating-point variables) give ngspice's
operating-point quantities (``@d1[id]``, ``@q1[gm]``, ``@m1[cgs]`` ...): their
family (:meth:`netdae.devices.base.DeviceFamily.quantities`)
evaluates its own equations at the result's solutions, every instance and
every point in one vectorised pass (in chunks of points), from the node
voltages of the device, internal nodes included (a transient keeps those it
needs). In a transient the terminal currents include the charges' currents,
``dQ/dv dv/dt`` with ``dv/dt`` the integrator's derivative at each point, as
for a capacitor; between the points the quantities are interpolated
linearly. They are not offered in ``.ac`` (they are the operating point's:
ask the ``.op``).

Powers are real quantities and are not offered in ``.ac``.
:data:`netdae.signals.DEVICE_QUANTITIES` lists the names.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..circuit import Circuit, Element, TranAnalysis
from ..devices.linear import capacitances, conductances
from ..errors import CircuitError
from ..kinds import BRANCH_CURRENT_KINDS, KINDS, Kind
from ..results import Result
from ..signals import NONLINEAR_QUANTITY_KINDS, device_quantity, parse_signal

__all__ = ["Quantity", "plan_quantities", "add_quantities", "saved_currents", "measured_quantities",
           "SAVECURRENTS"]

#: The quantities ``.options savecurrents`` adds to a result that keeps every unknown (as ngspice 39): a
#: view of the kinds' definitions (``ElementKind.saved_currents``, :mod:`netdae.kinds`).
SAVECURRENTS = {k.name: k.saved_currents for k in KINDS.values() if k.saved_currents}

#: Size of the one-sided differences on the dense output, relative to the step ending at each point.
_DIFF_FRACTION = 1e-4
#: Points per pass of a nonlinear family (bounds the temporaries: points x instances x controls).
_CHUNK_VALUES = 1 << 18


@dataclass(frozen=True)
class Quantity:
    """A device quantity to compute: the signal name, its element and the quantity."""

    name: str
    element: Element
    quantity: str
    #: The node voltages a nonlinear device's quantities are computed from (internal nodes included).
    voltages: tuple[str, ...] = ()

    def needs(self) -> list[str]:
        """The signals (node voltages, branch currents) it is computed from."""
        if self.element.kind in NONLINEAR_QUANTITY_KINDS:
            return list(self.voltages)
        a, b = self.element.nodes[:2]
        volts = [f"v({n})" for n in (a, b) if n != "0"]
        if self.element.kind in BRANCH_CURRENT_KINDS:  # its current is an unknown
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
    system = None
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
        if el.kind in NONLINEAR_QUANTITY_KINDS:
            system = _system(circuit) if system is None else system
            if el.kind == Kind.OSDI:
                _check_opvar(system, el, sig.name, q)
            item = replace(item, voltages=_device_voltages(system, el))
        quantities.append(item)
        out += [n for n in item.needs() if n not in out]
    return out, quantities


def _device_voltages(system, el: Element) -> tuple[str, ...]:
    """The node voltages one nonlinear device's quantities read: its equations' (``v(q1#base)`` ...) and its
    terminals' (the power)."""
    fam, k = _family_of(system, el)
    read = [system.names[int(i)] for i in fam.read_unknowns(k) if i >= 0]
    terminals = [f"v({nd})" for nd in el.nodes if system.node_index(nd) >= 0]
    return tuple(dict.fromkeys(read + terminals))


def _check_opvar(system, el: Element, name: str, q: str) -> None:
    """Refuse a name that is no operating-point variable of an OSDI device's module (listing those it has)."""
    fam, k = _family_of(system, el)
    have = fam.quantity_names(k)
    if q not in have:
        module = fam.instances[k].module.name
        offer = " ".join(f"@{el.name}[{v}]" for v in have)
        raise CircuitError(f"{name}: '{el.name}' is an instance of the OSDI module {module}, which has no "
                           f"operating-point variable '{q}'"
                           + (f"; it has {offer}" if offer else "; the module declares none"),
                           elements=(el.name,))


def _system(circuit: Circuit, temp: float | None = None):
    """The circuit's MNA system (its families and unknowns); at the temperature ``temp`` if given."""
    from ..mna.assemble import assemble

    if temp is not None:
        circuit = replace(circuit, options=replace(circuit.options, temp=temp))
    return assemble(circuit)


def _family_of(system, el: Element):
    """The family that evaluates ``el`` and its instance index."""
    for fam in system.families:
        for k, other in enumerate(fam.elements):
            if other.name == el.name:
                return fam, k
    raise CircuitError(f"{el.name}: not a nonlinear device of the circuit", elements=(el.name,))


def saved_currents(circuit: Circuit) -> list[Quantity]:
    """The currents ``.options savecurrents`` saves: ``@r1[i]``, ``@c1[i]``, ``@l1[i]``, ``@i1[current]``, ``@d1[id]``,
    ``@q1[ic]`` ... (:data:`SAVECURRENTS`)."""
    if not circuit.options.extra.get("savecurrents"):
        return []
    out = [Quantity(f"@{el.name}[{q}]", el, q)
           for el in circuit.elements if el.kind in SAVECURRENTS and "#" not in el.name
           for q in SAVECURRENTS[el.kind]]
    if any(el.kind == Kind.OSDI for el in circuit.elements):
        from ..devices.osdi.spice_models import spice_quantities  # an ngspice model's port: ngspice's currents

        for el in circuit.elements:
            rules = (spice_quantities(el.name, circuit.models[el.model].type)
                     if el.kind == Kind.OSDI and "#" not in el.name else None)
            out += [Quantity(f"@{el.name}[{q}]", el, q) for q in (rules.saved if rules else ())]
    return out


def measured_quantities(circuit: Circuit) -> list[Quantity]:
    """The device quantities the circuit's ``.meas`` cards read (``i(c1)``, ``@r1[p]``)."""
    names = list(dict.fromkeys(name for spec in circuit.measures for name in spec.signals()))
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
    ac = result.analysis == "ac"
    missing = []
    base = result.dense  # the integrator's own output (the derivatives are taken on it)
    devices: dict[str, dict[str, np.ndarray]] = {}  # element -> its quantities (a family's at once)
    systems: dict = {}  # the assembled circuit, once per call
    for item in quantities:
        el, q = item.element, item.quantity
        if el.kind in NONLINEAR_QUANTITY_KINDS:
            if ac:
                missing.append(item.name)
                result.notes.append(f"{item.name}: a device's operating-point quantity, not in .ac results "
                                    "(the .op gives it)")
                continue
            if el.name not in devices:
                devices.update(_device_values(circuit, result, base, el, systems))
            values = devices[el.name][q]
        elif ac and q == "p":
            missing.append(item.name)
            result.notes.append(f"{item.name}: powers are real quantities, not in .ac results")
            continue
        else:
            values = _linear_values(circuit, result, base, el, q, ac)
        result.signals[item.name] = np.asarray(values) + np.zeros(result.points, dtype=np.result_type(values))
        if result.dense is not None and result.analysis == "tran":
            result.dense = _dense_with(result.dense, circuit, item, result.t, result.signals[item.name])
    return missing


def _linear_values(circuit: Circuit, result: Result, base, el: Element, q: str, ac: bool):
    """Quantity ``q`` of the linear element ``el`` at the result's points."""
    o = circuit.options
    v = _voltage(result, el)
    if el.kind == Kind.RESISTOR:
        g = float(conductances([el], o.temp, o.tnom, ac=ac)[0])
        i = g * v
    elif el.kind == Kind.CAPACITOR:
        c = float(capacitances([el], o.temp, o.tnom)[0])
        i = c * _derivative(result, base, el, v)
    elif el.kind in BRANCH_CURRENT_KINDS:
        i = result.signals[f"i({el.name})"]
    else:  # isource: ngspice's voltage is v(n-) - v(n+), its power v(n+) - v(n-) times the current
        return -v if q == "v" else _source_current(circuit, result, el) if q == "current" \
            else v * _source_current(circuit, result, el)
    return i if q == "i" else v * i


def _device_values(circuit: Circuit, result: Result, dense, el: Element,
                   systems: dict) -> dict[str, dict[str, np.ndarray]]:
    """The quantities of every device of ``el``'s family at the result's points, by element name.

    One pass of the family per chunk of points; a ``.dc temp`` sweep assembles the circuit at each
    point's temperature. ``systems`` keeps the assembled circuit between the families.
    """
    temps = result.axes.get("temp") if result.analysis == "dc" else None
    if temps is None:
        system = systems.get(None)
        if system is None:
            system = systems[None] = _system(circuit)
        fam, _ = _family_of(system, el)
        values = _family_values(system, fam, result, dense, slice(None))
    else:
        parts = []
        for p, temp in enumerate(np.asarray(temps, dtype=float)):
            system = _system(circuit, temp=float(temp))
            fam, _ = _family_of(system, el)
            parts.append(_family_values(system, fam, result, None, slice(p, p + 1)))
        values = {q: np.concatenate([part[q] for part in parts]) for q in parts[0]}
    return {other.name: {q: v[:, k] for q, v in values.items()} for k, other in enumerate(fam.elements)}


def _family_values(system, fam, result: Result, dense, points: slice) -> dict[str, np.ndarray]:
    """``fam.quantities`` at the result's points (shape (T, N) each), from the node voltages it reads.

    The solutions are built a chunk of points at a time (at most :data:`_CHUNK_VALUES` values per
    chunk and per instance-unknown product), so that a long transient of a large circuit needs no
    (points x unknowns) matrix.
    """
    n = system.n
    columns = [int(c) for c in fam.read_unknowns() if c >= 0 and system.names[int(c)] in result.signals]
    names = [system.names[c] for c in columns]
    count = len(np.zeros(result.points)[points])
    values = np.zeros((count, len(columns)))
    for j, name in enumerate(names):
        values[:, j] = np.asarray(result.signals[name], dtype=float)[points]
    rates = None
    if result.analysis == "tran" and dense is not None and names:
        rates = _time_derivative(result, values, lambda t: np.stack([dense(t)[m] for m in names], axis=-1))
    chunk = max(1, _CHUNK_VALUES // max(len(fam.elements) * max(len(columns), 1), n + 1))
    position = {c: j for j, c in enumerate(columns)}

    def column(unknowns):
        out = np.zeros((count, len(unknowns)))
        for j, c in enumerate(np.asarray(unknowns).tolist()):
            if c >= 0:
                out[:, j] = values[:, position[c]]
        return out

    states = fam.point_states(column, _jump_rows(result, points)) if count else None
    pieces = []
    for i in range(0, count, chunk):
        part = slice(i, min(i + chunk, count))
        x = np.zeros((part.stop - part.start, n + 1))
        x[:, columns] = values[part]
        dxdt = None
        if rates is not None:
            dxdt = np.zeros_like(x)
            dxdt[:, columns] = rates[part]
        pieces.append(fam.quantities(x, dxdt) if states is None else fam.quantities(x, dxdt, states=states[part]))
    return {q: np.concatenate([piece[q] for piece in pieces]) for q in pieces[0]}


def _jump_rows(result: Result, points: slice) -> dict[int, tuple[str, ...]] | None:
    """A transient's rows (of ``points``) that are the left limit of a jump, to the elements switched there."""
    if result.analysis != "tran":
        return None
    t = np.asarray(result.t, dtype=float)[points]
    switched: dict[float, tuple[str, ...]] = {}
    for te, names in (result.transient.events if result.transient is not None else []):
        switched[te] = switched.get(te, ()) + tuple(names)
    return {k: switched.get(float(t[k]), ()) for k in np.flatnonzero(t[:-1] == t[1:]).tolist()}


def _source_current(circuit: Circuit, result: Result, el: Element) -> np.ndarray:
    """An independent current source's value at the result's points (DC value, swept value, waveform)."""
    if result.analysis == "tran" and el.source.tran is not None:
        wave = el.source.tran
        card = result.card if result.card is not None else next(
            (a for a in circuit.analyses if isinstance(a, TranAnalysis)), None)
        if not wave.is_resolved and card is not None:
            # the transient's own waveform: its step/stop defaults, a random source's realisation
            wave = wave.resolved(card.tstep, card.tstop)
        return np.asarray(wave.value(np.asarray(result.t, dtype=float)), dtype=float)
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
    return _time_derivative(result, v, lambda t: _dense_voltage(dense, el, t))


def _time_derivative(result: Result, f0: np.ndarray, probe) -> np.ndarray:
    """d/dt at a transient's points of values ``f0`` (shape (T,) or (T, K)), ``probe(t)`` on the dense output.

    The one-sided second-order difference on the step that ends at each point (the derivative the
    BDF formula gave that step), forward at the start.
    """
    t = result.t
    steps = np.diff(t)
    h = _DIFF_FRACTION * np.where(steps > 0, steps, np.inf)
    h_left = np.concatenate([[np.inf], h])  # the step that ends at each point
    h_right = np.concatenate([h, [np.inf]])
    back = np.isfinite(h_left)  # backward differences on the step ending there, forward at the start
    hh = np.where(back, h_left, h_right)
    hh = np.where(np.isfinite(hh), hh, 0.0)
    sign = np.where(back, -1.0, 1.0)
    f1 = probe(t + sign * hh)
    f2 = probe(t + 2 * sign * hh)
    shape = (-1,) + (1,) * (np.ndim(f0) - 1)
    hh, sign = hh.reshape(shape), sign.reshape(shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = -sign * (3.0 * f0 - 4.0 * f1 + f2) / (2.0 * hh)
    return np.where(hh > 0, d, 0.0)


def _dense_voltage(dense, el: Element, t: np.ndarray) -> np.ndarray:
    y = dense(t)
    a, b = el.nodes[:2]
    return (y[f"v({a})"] if a != "0" else 0.0) - (y[f"v({b})"] if b != "0" else 0.0)


def _dense_with(dense, circuit: Circuit, item: Quantity, times: np.ndarray, values: np.ndarray):
    """``dense`` extended by ``item`` (for ``.meas`` and comparisons between the time points).

    A capacitor's current (and power), and a nonlinear device's quantities, are interpolated
    linearly between their values at the points (the steps' BDF derivatives): the derivative of the interpolant inside
    a step is an order less accurate than the interpolant, and right after a breakpoint, where
    the step restarts at order 1, it is constant over the step.
    """

    def extended(t):
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        y = dense(tt)
        if item.element.kind == Kind.CAPACITOR or item.element.kind in NONLINEAR_QUANTITY_KINDS:
            y[item.name] = np.interp(tt, times, values)
            return y
        probe = Result("tran", axes={"time": tt}, signals=dict(y))
        add_quantities(circuit, probe, [item])
        y[item.name] = probe.signals[item.name]
        return y

    return extended
