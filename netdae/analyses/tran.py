"""Transient analysis (``.tran tstep tstop [tstart [tmax]] [uic]``) that respects the index.

The steps, each visible in the result's notes and ``transient`` (:class:`netdae.metadata.TransientInfo`):

1. **Start**: the DC operating point at t = 0 with the sources' values at
   t = 0 and ``.ic`` nodes held (ngspice's rule); with ``uic``, no operating
   point: node voltages from ``.ic`` (else 0), capacitor voltages and
   inductor currents from their ``ic=`` (else from the node voltages), as
   ngspice does. A circuit without a DC operating point (an astable
   multivibrator: Newton, gmin stepping, source stepping and pseudo-transient
   continuation do not converge) starts as with ``uic``, and a note says so;
   ngspice starts such a circuit from the end of its own pseudo-transient
   (``optran``), so the first cycle of the two can differ.
2. **Structure**: the pencil of the linearisation at the start
   (:func:`netdae.analyses.index.analyze_index`; dense up to
   :data:`TRAN_PENCIL_LIMIT` unknowns, sparse above, and topological
   too where the topological statement is exact and gives index 0 or 1: a
   circuit of R, L, C, diodes and independent sources with positive values,
   no CV-loop and no LI-cutset, whose index no value can change) gives the
   index and which unknowns depend on input derivatives (index 2).
3. **Consistent initial values**: an index-2 circuit whose inputs change at
   t0 (the differentiator driven by a sine) has hidden constraints the DC
   operating point violates (a steady state of the inputs' values at t0, it
   violates only what their derivatives there impose: nothing when they do
   not change); netdae replaces the nilpotent part of the start
   by the one the decoupled solution (2.12) prescribes and reports what
   changed (``initial="ngspice"`` keeps the inconsistent start as ngspice
   does). A ``uic`` start keeps the given charges and fluxes and solves for
   the rest (the decoupled form for linear circuits, a vanishing implicit
   Euler step otherwise).
4. **Integration**: index <= 2 by the variable-order BDF
   (:mod:`netdae.dae.bdf`) with the index-2 unknowns left out of the error
   test; a *linear* circuit of index >= 3 through its Weierstrass form: the
   finite part by BDF, the nilpotent part by (2.12) with the sources'
   analytic derivatives, warning where an input is not smooth enough (the
   true solution then contains impulses). A nonlinear circuit of index >= 3
   is refused with the explanation.

ngspice's defaults: the largest step is ``min(tstep, (tstop - tstart)/50)``
unless ``tmax`` is given; output before ``tstart`` is dropped; with
``.options interp`` results are reported on the tstep grid (through the
dense output). Integration method: netdae integrates with BDF (ngspice's
``method=gear``) of orders up to ``.options maxord`` (default 5);
``method=trap`` is refused with a message.
"""

from __future__ import annotations

import math
import re
import sys
import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..circuit import Circuit, TranAnalysis
from ..dae.bdf import MAX_ORDER, ImplicitEulerStep, integrate
from ..dae.bdf.failures import RUNAWAY_FACTOR
from ..dae.steady import SteadyOptions, solve_steady
from ..dae.system import KIND_VOLTAGE, LinearDae
from ..devices.linear import add_initial_charges, initial_currents
from ..errors import (CircuitError, ConvergenceError, NetdaeError, NetlistError, SingularPencilError, count_text,
                      size_text)
from ..kinds import KINDS, NO_GAIN_KINDS, Kind
from ..mna import MODE_TRAN, MnaSystem
from ..metadata import TransientInfo
from ..results import STATUS_FAILED, STATUS_OK, Result, Statistics
from ..dae.algebraic import GROUP_LIMIT
from .index import IndexReport, analyze_index
from .instability import growing_eigenvalue, growth_note, held_equilibrium_note, stayed
from .prepared import Prepared, prepare
from ..topology.held import held_junction_cause


if TYPE_CHECKING:
    from ..dae.bdf.failures import IntegrationFailure

__all__ = ["transient", "output_size", "physical_memory", "memory_room", "TRAN_PENCIL_LIMIT", "UIC_PROBE_FRACTION"]

#: Circuits up to this many unknowns get the dense pencil analysis before a
#: transient (measured with one BLAS thread: 0.02 s at 100 unknowns, 0.11 s at
#: 200; 0.27 s at 478 and 1.0 s at 755 on 2026-11-28); larger ones the sparse one
#: (the topology where it gives the index, else the algebraic part,
#: :mod:`netdae.dae.algebraic`: 7 ms at 478 unknowns, 26 ms at 755).
TRAN_PENCIL_LIMIT = 300
#: A ``uic`` start without a decoupled form is made consistent by an implicit
#: Euler step of this fraction of the simulated interval (error O(step)).
UIC_PROBE_FRACTION = 1e-9
#: Relative size of the one-sided offsets used to detect jumps of input derivatives.
JUMP_PROBE = 1e-9
#: A derivative jump is reported when it exceeds this fraction of the input's scale.
JUMP_TOLERANCE = 1e-6
#: Jumps of the solution (inputs that jump, index-2 unknowns at corners) noted one by one
#: up to this many; the rest are counted (all are in ``transient.jumps``).
JUMP_NOTES = 3
#: Devices named when a transient stops on equations that are not finite.
NAMED_DEVICES = 4
#: A transient whose output needs more than this fraction of the machine's memory at its fewest
#: points is refused (it could not finish); above ADVISE_FRACTION it runs with a warning.
REFUSE_FRACTION = 1.0
ADVISE_FRACTION = 0.25
#: ngspice's default largest step is (tstop - tstart) / TMAX_DIVISOR (or tstep if smaller).
TMAX_DIVISOR = 50.0
#: The relative tolerance refers to an unknown's present magnitude, but to at
#: least a tenth of its largest magnitude so far (netdae.dae.bdf, "mixed"):
#: with IDA's purely local reference a current's tolerance collapses to abstol
#: (1e-12 A) at every zero crossing and forces thousands of order-1 steps
#: there (the half-wave rectifier and the voltage doubler then fail); relative
#: to the largest magnitude alone, the error after an input edge grows to the
#: tolerance of the signal's amplitude (measured 1.06e-3 of the range on
#: netlists/subckt_ladder.cir against 5.3e-4 with "mixed").
RELREF = "mixed"


@dataclass
class _Start:
    """The initial point and how it was obtained."""

    x: np.ndarray
    q0: np.ndarray | None = None  # uic: the charges/fluxes to keep
    op_iterations: int = 0
    notes: list[str] = field(default_factory=list)
    correction: dict | None = None
    uic: bool = False  # a uic start although the card has no uic (no DC operating point)
    no_op: ConvergenceError | None = None  # then: why the operating point failed


def _card(circuit: Circuit, card: TranAnalysis | None) -> TranAnalysis:
    if card is not None:
        return card
    for a in circuit.analyses:
        if isinstance(a, TranAnalysis):
            return a
    raise NetdaeError(f"{circuit.path}: no .tran card: give the analysis (tstep, tstop) or add a .tran line")


def _check_method(circuit: Circuit) -> None:
    """Refuse ``.options method=trap``, located at the option's value when the netlist gives it."""
    method = (circuit.options.method or "gear").lower()
    if method not in ("gear", "bdf"):
        where = circuit.options.locations.get("method")
        message = (f".options method={method}: netdae integrates with variable-order BDF (method=gear) only; "
                   "the trapezoidal rule is not implemented (it rings on stiff and index-2 circuits, which BDF "
                   "damps)")
        hint = "use method=gear or remove the option"
        if where is None:  # options set without a card (a Circuit built in Python)
            raise NetdaeError(f"{message} -- {hint}")
        raise NetlistError(message, where, expected=".options method=gear", hint=hint)


def _save_request(system: MnaSystem, names: list[str]) -> tuple[np.ndarray, list[str], dict[str, tuple[int, int]]]:
    """What to keep: unknown positions, the requested unknown names, and differences ``v(a,b)``.

    Returns the sorted positions of every unknown to store (requested ones and
    the nodes of requested differences), the names of the requested unknowns,
    and for each difference the positions of its two nodes in the stored set
    (-1 for ground).
    """
    if not names:
        return np.arange(system.n), list(system.names), {}
    index = {nm: i for i, nm in enumerate(system.names)}
    keep: set[int] = set()
    requested: list[str] = []
    diffs: dict[str, tuple[str, str]] = {}
    for raw in names:
        name = raw.strip().lower()
        if name in index or f"v({name})" in index:
            name = name if name in index else f"v({name})"
            keep.add(index[name])
            requested.append(name)
            continue
        m = re.fullmatch(r"v\(\s*([^,\s]+)\s*,\s*([^,\s]+)\s*\)", name)
        if m is not None:
            pair = ["0" if nd in ("0", "gnd") else f"v({nd})" for nd in m.group(1, 2)]
            if all(p == "0" or p in index for p in pair):
                keep.update(index[p] for p in pair if p != "0")
                diffs[f"v({m.group(1)},{m.group(2)})"] = tuple(pair)
                continue
        raise NetdaeError(
            f"cannot save '{raw}': netdae keeps node voltages v(node), differences v(a,b) and the branch "
            f"currents of voltage sources, inductors and voltage-type controlled sources (i(name))"
        )
    keep_arr = np.array(sorted(keep), dtype=np.int64)
    pos = {system.names[i]: k for k, i in enumerate(keep_arr)}
    return keep_arr, requested, {name: (pos.get(a, -1), pos.get(b, -1)) for name, (a, b) in diffs.items()}


def physical_memory() -> int | None:
    """The machine's physical memory in bytes (None where the system does not say)."""
    import os

    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def address_space_room() -> int | None:
    """Bytes this process may still map under its address-space limit, or None without one.

    ``ulimit -v`` (``RLIMIT_AS``) bounds all the process maps, the numerical
    libraries' code and arenas included: the room is the limit less what the
    process maps already (``/proc/self/statm``; on a system without it the
    whole limit). None where there is no limit or the system does not say.
    """
    import os

    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, AttributeError, ValueError, OSError):
        return None
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    try:
        with open("/proc/self/statm") as f:
            mapped = int(f.read().split()[0]) * int(os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, IndexError, AttributeError):
        mapped = 0
    return max(0, int(soft) - mapped)


def memory_room() -> tuple[int | None, str]:
    """The memory a transient's output can have [bytes] and the words that say where the bound comes from.

    The smaller of the machine's memory (:func:`physical_memory`) and the
    room left under the process's address-space limit
    (:func:`address_space_room`, ``ulimit -v``): a run refused by the first
    only would otherwise fail later with an allocation error. None (and no
    words) where neither is known.
    """
    machine = physical_memory()
    limit = address_space_room()
    if limit is not None and (machine is None or limit < machine):
        return limit, f"this process may map {size_text(limit)} more (ulimit -v)"
    if machine is None:
        return None, ""
    return machine, f"this machine has {size_text(machine)}"


#: Past this many points :func:`output_size` counts in floating point.
MOST_POINTS = 2**62


def output_size(saved: int, tstop: float, tmax: float) -> tuple[int | float, int | float]:
    """The fewest points a transient records and the bytes its output then needs at least.

    The integrator never steps further than ``tmax``, so it records at least
    ``ceil(tstop / tmax) + 1`` points (usually many more: steps shrink at
    every corner of the inputs), each a time, an order byte and the
    ``saved`` unknowns as doubles; a lower bound, not a forecast.

    Integers up to :data:`MOST_POINTS` points, floats past it: infinity where ``tstop / tmax``
    overflows (``tstop = 1e300``), which no integer can hold.

    >>> output_size(100_000, 1e-3, 1e-9)  # every node of 100,000 at 1e6 points at least
    (1000001, 800009800009)
    >>> output_size(1, 1e300, 1e-12)
    (inf, inf)
    """
    ratio = tstop / tmax
    if not ratio < MOST_POINTS:
        return ratio + 1.0, (ratio + 1.0) * (8 * (saved + 1) + 1)
    points = int(math.ceil(ratio)) + 1
    return points, points * (8 * (saved + 1) + 1)


def _check_size(saved: int, total: int, card: TranAnalysis, tmax: float, room: int | None = None) -> str | None:
    """Refuse a transient whose output cannot fit; a warning when it fills much of the room it has.

    The room is the machine's memory or, when smaller, what the process's
    address-space limit leaves (:func:`memory_room`), or with ``room`` (a run
    that keeps only its last points in memory and writes all to a file) the
    free space where the file goes.

    Raises
    ------
    NetdaeError
        When the fewest points the run records need more than that room.
    """
    capacity, source = memory_room() if room is None else (room, "")
    if not capacity:
        return None
    points, size = output_size(saved, card.tstop, tmax)
    if size <= ADVISE_FRACTION * capacity:
        return None
    has = (f"of memory, {source}" if room is None
           else f"of disk space for its file, {size_text(capacity)} are free there")
    if math.isfinite(size):
        what = (f"keeping {saved:,} of {total:,} unknowns at {count_text(points)} points or more (tstop/tmax = "
                f"{card.tstop:g}/{tmax:g}) needs at least {size_text(size)} {has}")
    else:  # tstop/tmax overflows: more points than a double counts
        what = (f"keeping {saved:,} of {total:,} unknowns at tstop/tmax = {card.tstop:g}/{tmax:g} points or more "
                f"(beyond {count_text(sys.float_info.max)}) needs more than any memory or disk holds")
    hint = "save only the signals you need (--save v(out),i(v1) or a .save card), or a larger tstep or tmax"
    if size > REFUSE_FRACTION * capacity:
        where = f"{card.location}: " if card.location is not None else ""
        raise NetdaeError(f"{where}.tran: {what}: the run cannot finish (hint: {hint})")
    return f"warning: {what} (hint: {hint})"


def _streamable(system: MnaSystem, options, integrate_options: dict) -> bool:
    """True when the result's points are the compiled engine's accepted points, as they come."""
    from ..dae.bdf.run import _compiled_engine_enabled
    from ..dae.compiled.driver import supports

    return (not options.interp and _compiled_engine_enabled()
            and supports(system, {**integrate_options, "output": None}))


def _blocks(output: Callable[[int, Result], str | None], tstart: float, kept_names, requested,
            diffs, streamed: list[int]) -> Callable:
    """The integrator's ``output(start, t, x)`` that hands ``output`` the result's next points as a Result
    (the points before ``tstart`` left out, as the result leaves them out); ``streamed[0]`` counts them."""
    first = []  # the integrator's position of the result's first point, once known

    def accepted(start: int, t: np.ndarray, x: np.ndarray) -> str | None:
        sel = t >= tstart
        if not sel.any():
            return None
        head = int(np.argmax(sel))  # the times grow: the points kept are the block's tail
        if not first:
            first.append(start + head)
        block = Result("tran", axes={"time": t[head:].copy()},
                       signals=_signals(kept_names, requested, x[head:].copy(), diffs))
        position = start + head - first[0]
        streamed[0] = max(streamed[0], position + block.points)
        return output(position, block)

    return accepted


def _signals(kept_names, requested, values: np.ndarray, diffs) -> dict[str, np.ndarray]:
    pos = {nm: k for k, nm in enumerate(kept_names)}
    out = {nm: values[:, pos[nm]] for nm in requested}
    for name, (a, b) in diffs.items():
        va = values[:, a] if a >= 0 else 0.0
        vb = values[:, b] if b >= 0 else 0.0
        out[name] = va - vb
    return out


# -- the start --------------------------------------------------------------------
def _uic_start(prepared: Prepared) -> _Start:
    """ngspice's ``uic`` state: .ic node voltages (else .nodeset's, else 0), element ic= for C and L, device ic=
    where the family supports it (:meth:`netdae.devices.base.DeviceFamily.uic_start`)."""
    circuit, system = prepared.circuit, prepared.system
    x = np.zeros(system.n)
    notes = []
    # ngspice (CKTic) writes the .nodeset values, then the .ic values, into the solution the uic state
    # starts from: a node's .nodeset is its initial voltage unless an .ic gives one
    initial = {**circuit.nodeset, **circuit.ic}
    for node, v in initial.items():
        try:
            i = system.node_index(node)
        except KeyError:
            card = ".ic" if node in circuit.ic else ".nodeset"
            raise CircuitError(f"{card} names node '{node}', which is not in the circuit", nodes=(node,)) from None
        if i >= 0:
            x[i] = v
    # ngspice takes a device's initial junction voltages from its terminals' .ic (BJTgetic, DIOgetic,
    # MOS1getic): a node behind a series resistance (a BJT's rb, a diode's rs) starts at its terminal's value
    given = set(initial)
    for inner, outer in system.layout.beside.items():  # in the order made: a node behind an internal one follows
        if outer in given and inner not in given:
            x[system.node_index(inner)] = x[system.node_index(outer)]
            given.add(inner)
    # and a device's own ic= (a BJT's icvbe, icvce) sets its junctions, as in ngspice
    fixed = {system.node_index(node) for node in circuit.ic if system.node_index(node) >= 0}
    started = {name for family in system.families for name in family.uic_start(x, fixed)}
    initial_currents(circuit, system.layout, x)
    q0 = system.evaluate(x, 0.0, jacobian=False).q.copy()
    add_initial_charges(circuit, system.layout, x, q0)
    ignored = [el.name for el in circuit.elements
               if el.name not in started and any(p in el.params for p in KINDS[el.kind].device_ic)]
    if ignored:
        notes.append(f"uic: device initial conditions of {', '.join(ignored[:5])} are not used; the devices start "
                     "from their node voltages")
    return _Start(x=x, q0=q0, notes=notes)


def _consistent_from_charges(system: MnaSystem, start: _Start, rep: IndexReport | None, tstop: float,
                             opts: SteadyOptions) -> np.ndarray:
    """Consistent x0 that keeps the uic charges/fluxes."""
    wf = rep.pencil.weierstrass if rep is not None and rep.pencil is not None else None
    if wf is not None and system.linear:
        y0 = wf.U1 @ start.q0
        z0 = wf.nilpotent_from_inputs(np.array([system.source(0.0, k) for k in range(max(wf.index, 1))])) \
            if wf.index else np.zeros(0)
        return wf.combine(y0, z0)
    # The algebraic equations hold at t = 0 itself: with the inputs taken at h, a source
    # rising from 0 at t = 0 would start from its value at h, inconsistent with x(0).
    # One Euler step moves the charges by h q'(0); two steps (h and 2h) extrapolated to
    # h = 0 keep them to O(h^2) (one step moved v(8) of netlists/testset_transamp.cir
    # 2.2e-9 V off its given start).
    h = UIC_PROBE_FRACTION * tstop
    xs = []
    for step in (h, 2.0 * h):
        res = solve_steady(ImplicitEulerStep(system, start.q0, step, 0.0), 0.0, start.x,
                           options=replace(opts, judge_singular=False))
        if not res.converged:
            raise NetdaeError(
                "uic: could not find values consistent with the initial capacitor voltages and inductor "
                f"currents ({res.message})"
            )
        xs.append(res.x)
    return 2.0 * xs[0] - xs[1]


def _change(old: float, new: float) -> str:
    """``old -> new`` with the digits that show the change (six at least: -0.0004128 -> -0.0004128 said nothing).

    >>> _change(-4.1280001e-4, -4.1280003e-4), _change(0.0, 1.7)
    ('-0.00041280001 -> -0.00041280003', '0 -> 1.7')
    """
    digits = 6
    scale = max(abs(old), abs(new))
    if old != new and scale > 0.0:
        digits = min(17, max(6, int(math.ceil(math.log10(scale / abs(new - old)))) + 1))
    return f"{old:.{digits}g} -> {new:.{digits}g}"


def _correction_note(system: MnaSystem, x_old: np.ndarray, x_new: np.ndarray, why: str) -> tuple[str, dict]:
    names = system.names
    scale = np.maximum(np.abs(x_old), np.abs(x_new))
    tol = np.where(system.kinds == 0, 1e-9, 1e-15) + 1e-9 * scale
    changed = np.flatnonzero(np.abs(x_new - x_old) > tol)
    detail = {names[i]: [float(x_old[i]), float(x_new[i])] for i in changed}
    shown = ", ".join(f"{names[i]}: {_change(x_old[i], x_new[i])}" for i in changed[:6])
    more = f" and {len(changed) - 6} more" if len(changed) > 6 else ""
    return f"{why}: {shown}{more}", detail


# -- structure ----------------------------------------------------------------------
def _structure(prepared: Prepared, x0: np.ndarray, uic: bool) -> IndexReport | None:
    """Index report at the start: topological when the topological statement is exact for the circuit and
    gives index 0 or 1 (the dense analysis could only confirm it), or above the dense limit; else dense.

    A linear ``uic`` start keeps the dense analysis: its consistent values come from the Weierstrass form.
    """
    system, topo = prepared.system, prepared.topology
    idx = topo.topological_index
    exact = topo.applicable and not topo.singular and idx is not None and idx <= 1 and not (uic and system.linear)
    method = "topological" if exact else ("sparse" if system.n > TRAN_PENCIL_LIMIT else "auto")
    rep = analyze_index(prepared, x=x0, method=method, check_consistency=False)
    if rep.regular is False:
        from ..topology import pencil_singularity_explanation

        why = pencil_singularity_explanation(prepared.circuit)
        if why is not None:
            raise SingularPencilError(why.message, elements=why.elements, nodes=why.nodes, hint=why.hint)
        if rep.pencil is not None and rep.pencil.singular_by_rounding:
            if rep.pencil.exact.index <= 2:
                return _rounding_regular(prepared, rep)
            raise SingularPencilError(
                "the circuit's pencil (E, H) is singular in double precision, though regular of index "
                f"{rep.pencil.exact.index} in exact arithmetic: element values whose ratios approach the limit of double "
                "precision make the transient unsolvable as written (netdae index shows the rank decisions)",
                hint=ROUNDING_HINT,
            )
        raise SingularPencilError(
            "the circuit's pencil (E, H) is singular: the transient has no or infinitely many solutions",
            hint="look for loops of voltage sources or cutsets of current sources",
        )
    return rep


def _rounding_regular(prepared: Prepared, rep: IndexReport) -> IndexReport:
    """The report of a pencil singular only in double precision, of index <= 2 in exact arithmetic, made runnable.

    The exact structure (:func:`netdae.dae.exact.exact_structure`) says the solution is unique; double
    precision cannot tell which directions carry the index, so the index is the exact one, the index-2
    unknowns are the topological statement's where it names them (else none: every unknown is
    error-tested), and a warning says that unknowns in the unresolved directions may carry rounding noise.
    ngspice simulates such circuits (vendor op-amp macromodels with 1e12-ohm leaks beside 1e-12 F) without
    a word; a run whose Newton matrices lose the directions to rounding fails, and its message says why
    (:data:`ROUNDING_NOTE`).
    """
    topo = prepared.topology
    index = rep.pencil.exact.index
    index2 = set(topo.index2_signals) if index == 2 and topo.topological_index == 2 else set()
    orders = {name: (1 if name in index2 else 0) for name in prepared.system.names}
    labels = {name: ("index2" if name in index2 else "differential") for name in prepared.system.names}
    return replace(rep, regular=True, index=index, derivative_order=orders, unknowns=labels)


#: Why a pencil singular only by rounding is suspect (a note of its run, and of its failure).
ROUNDING_NOTE = ("the circuit's pencil (E, H) is singular in double precision, though regular of index {index} in "
                 "exact arithmetic: element values whose ratios approach the limit of double precision")
#: What to do about it.
ROUNDING_HINT = ("bring the extreme values closer together (a gain of 1e9 beside tera-ohm leaks, milli-ohms beside "
                 "giga-ohms), so that their ratios stay well within double precision (about 1e-16)")


def _c_derivatives(system: MnaSystem, x0: np.ndarray, t: float) -> Callable[[int], np.ndarray]:
    """Derivatives of the linearisation's source term ``c(t) = phi(x0, t) - H x0``."""
    if system.linear:
        return lambda k: system.source(t, k)
    ev = system.evaluate(x0, t, jacobian=True)
    c0 = ev.phi - system.pattern.matrix(ev.dphi) @ x0
    return lambda k: c0 if k == 0 else system.source(t, k)


def _one_sided(system: MnaSystem, tb: float, m: int, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Left and right limits of ``c^(m)`` at ``tb``.

    Both are extrapolated linearly with the next derivative, from ``tb - eps``
    and ``tb + eps``, so a smooth input shows no jump (error O(eps^2)) and a
    corner that the waveform's own arithmetic puts a few roundoffs away from
    its breakpoint (a repeated PWL's ``k * period + t``, a pulse train's
    ``td + k * per``) is seen on its side (the value at ``tb`` itself missed
    such jumps). The independent sources only: the transmission lines'
    delayed waves are known once the run has computed them (their corners are
    the sources' carried along the lines, among the breakpoints already).
    """
    left = system.source(tb - eps, m, waves=False) + eps * system.source(tb - eps, m + 1, waves=False)
    right = system.source(tb + eps, m, waves=False) - eps * system.source(tb + eps, m + 1, waves=False)
    return left, right


def _impulses(system: MnaSystem, rep: IndexReport, t0: float, tstop: float) -> list[str]:
    """Breakpoints where an input derivative the solution needs jumps: impulses there.

    With ``z = -sum_l N^l theta^(l)`` (2.12), a jump of the m-th input
    derivative at ``tb`` puts a Dirac delta (or its derivatives) into every
    higher derivative l > m, which reaches the unknowns through
    ``V2 N^l U2``. A jump counts when it exceeds ``JUMP_TOLERANCE`` times the
    largest magnitude of that derivative at the breakpoints.
    """
    wf = rep.pencil.weierstrass if rep.pencil is not None else None
    if wf is None or wf.index < 2:
        return []
    bps = system.breakpoints(t0, tstop)
    bps = bps[(bps > t0) & (bps < tstop)]
    if bps.size == 0:
        return []
    eps = JUMP_PROBE * (tstop - t0)
    bps = bps[np.concatenate([[True], np.diff(bps) > 2.0 * eps])]  # one corner computed twice, a roundoff apart
    powers = []  # V2 N^l U2 for l = 1 .. index-1
    Nl = np.eye(wf.n_infinite)
    for _ in range(wf.index - 1):
        Nl = wf.N @ Nl
        powers.append(wf.V2 @ Nl @ wf.U2)
    # a jump of the m-th derivative acts through every N^l with l > m
    gains = [np.abs(np.stack(powers[m:])) for m in range(len(powers))]
    limits = [[_one_sided(system, tb, m, eps) for m in range(len(gains))] for tb in bps]
    # (an input that overflows, a SIN growing with a negative damping factor, is not finite at some
    # breakpoints: no jump is measured there, and the largest magnitude is the finite ones')
    finite = [[bool(np.all(np.isfinite(left)) and np.all(np.isfinite(right))) for left, right in lim]
              for lim in limits]
    amplitude = [max((max(np.max(np.abs(lim[m][0])), np.max(np.abs(lim[m][1]))) for lim, ok in zip(limits, finite)
                      if ok[m]), default=0.0) for m in range(len(gains))]
    out = []
    for tb, lim, ok in zip(bps, limits, finite):
        for m, G in enumerate(gains):
            if not ok[m]:
                continue
            jump = lim[m][1] - lim[m][0]
            if amplitude[m] == 0.0 or np.max(np.abs(jump)) <= JUMP_TOLERANCE * amplitude[m]:
                continue
            hit = (G @ np.abs(jump)).max(axis=0)
            if np.max(hit) <= JUMP_TOLERANCE * np.max(G) * np.max(np.abs(jump)):
                continue
            who = [system.names[i] for i in np.flatnonzero(hit > JUMP_TOLERANCE * hit.max())][:5]
            order = "value" if m == 0 else f"derivative of order {m}"
            out.append(f"t={tb:.6g}: the inputs' {order} jumps, so the true solution contains an impulse "
                       f"(Dirac delta) in {', '.join(who)}; the values shown there are its regular part")
    return out


# -- the decoupled solution for index >= 3 ------------------------------------------------
def _decoupled(system: MnaSystem, rep: IndexReport, x_start: np.ndarray, y0: np.ndarray, tstop: float,
               keep: np.ndarray, bdf_opts: dict, progress) -> tuple[np.ndarray, np.ndarray, Callable, dict, str, int]:
    """Integrate ``y' = C y + delta`` by BDF and add ``z = -sum N^l theta^(l)`` analytically."""
    wf = rep.pencil.weierstrass
    k = wf.index
    nf = wf.n_finite

    def z_at(times: np.ndarray) -> np.ndarray:
        stack = np.array([[system.source(float(t), l) for t in times] for l in range(k)])  # (k, m, n)
        return wf.nilpotent_from_inputs(np.moveaxis(stack, 2, 1))  # (n_inf, m)

    atol_x = np.where(system.kinds == 0, bdf_opts["vntol"], bdf_opts["abstol"])
    stats: Statistics = Statistics()
    if nf:
        V1 = np.abs(wf.V1)
        atol_y = np.min(np.where(V1 > 0, atol_x[:, None] / np.maximum(V1, 1e-300), np.inf), axis=0)
        atol_y = np.where(np.isfinite(atol_y), atol_y, 1.0)
        finite = LinearDae(np.eye(nf), wf.C, c=lambda t, derivative=0: wf.U1 @ system.source(t, derivative),
                           breakpoints=system.breakpoints)
        res = integrate(finite, (0.0, tstop), y0, rtol=bdf_opts["rtol"], atol=atol_y,
                        maxord=bdf_opts["maxord"], max_step=bdf_opts["max_step"], progress=progress)
        times = res.t
        ys = res.x.T
        y_dense = res.dense
        stats = Statistics.from_counts(res.stats)
        status, message = res.status, res.message
    else:
        grid = np.arange(0.0, tstop, bdf_opts["max_step"])
        times = np.union1d(np.append(grid, tstop), system.breakpoints(0.0, tstop))
        ys = np.zeros((0, times.size))
        y_dense = None
        stats = Statistics(steps=0, rejected=0, newton_iterations=0, factorizations=0)
        status, message = STATUS_OK, f"no dynamic states: the solution is algebraic in the inputs ({times.size} points)"
    x = (wf.combine(ys, z_at(times)) if nf else wf.V2 @ z_at(times)).T  # (m, n)

    def dense(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        y = y_dense(t).T if nf else np.zeros((0, t.size))
        return (wf.combine(y, z_at(t)) if nf else wf.V2 @ z_at(t)).T[:, keep]

    return times, x[:, keep], dense, stats, message, status


# -- the analysis ---------------------------------------------------------------------
def _check_delays(prepared: Prepared) -> None:
    """Transmission lines need the compiled engine (it keeps the delayed solution at hand).

    Raises
    ------
    CircuitError
        With ``NETDAE_ENGINE=python``.
    """
    from ..dae.bdf.run import _compiled_engine_enabled

    if not _compiled_engine_enabled():
        lines = sorted({el.name for el in prepared.circuit.elements if el.kind == Kind.TLINE})
        raise CircuitError(f"transmission lines ({', '.join(lines[:5])}) run in the compiled engine only, and "
                           "NETDAE_ENGINE=python asks for the Python integrator", elements=tuple(lines),
                           hint="unset NETDAE_ENGINE (or set it to 'compiled')")


def transient(circuit: Circuit, card: TranAnalysis | None = None, *, save: list[str] | None = None,
              reltol: float | None = None, abstol: float | None = None, vntol: float | None = None,
              maxord: int | None = None, initial: str = "consistent", max_step: float | None = None,
              raise_on_failure: bool = False, progress: Callable | None = None,
              output: Callable[[int, Result], str | None] | None = None, bounded: bool = False,
              room: int | None = None) -> Result:
    """Run a transient analysis.

    Parameters
    ----------
    circuit : Circuit
    card : TranAnalysis, optional
        Default: the circuit's first ``.tran`` card.
    save : list of str, optional
        Signals to keep (``v(out)``, ``v(a,b)``, ``i(v1)``); default the
        netlist's ``.save``/``.print``/``.probe`` signals, else every unknown.
    reltol, abstol, vntol : float, optional
        Tolerances (default: the netlist's ``.options``, else SPICE's).
    maxord : int, optional
        Highest BDF order (default ``.options maxord``, else 5).
    initial : {"consistent", "ngspice"}
        ``consistent`` replaces an inconsistent start (hidden constraints of
        index-2 circuits) by consistent values and says what changed;
        ``ngspice`` keeps the operating point as ngspice does.
    max_step : float, optional
        Overrides the card's tmax.
    raise_on_failure : bool
        Raise :class:`~netdae.errors.ConvergenceError` instead of returning a
        failed result.
    progress : callable, optional
        ``progress(t, tstop, steps)``, called a few times per second.
    output : callable, optional
        ``output(start, block) -> str | None``: the result's points as they
        are computed, each ``block`` a ``tran`` Result holding the points from
        position ``start`` on (axis ``time`` and the same signals as the
        returned Result, equal to its rows; a block may repeat points of the
        one before when a Ctrl-C interrupted that call), called about ten
        times per second of computation and once at the end, also when the run
        fails or is interrupted; a text returned stops the run with that
        reason (the result then ends there, failed). Only where the result's
        points are the integrator's accepted points (the compiled engine,
        without ``.options interp``, index <= 2); otherwise never called.
    bounded : bool
        With ``output`` called: keep only the last points in memory (tens of
        MiB; :data:`netdae.dae.compiled.driver.WINDOW_BYTES`), for a caller
        that needs every point only in what ``output`` wrote. The result then
        holds the last points, its dense output covers those, ``stats.points``
        counts all of them and a note says so. No effect on a circuit with
        transmission lines (the integrator reads their past waves).
    room : int, optional
        With ``bounded``: the bytes free where ``output`` writes (its disk).
        Before the run, the output's size at its fewest points (one per
        largest step) is checked against the machine's memory, or for a
        bounded run against ``room`` (no check without it): a run that cannot
        fit is refused, one that fills more than a quarter of it warned about.

    Returns
    -------
    Result
        ``analysis == "tran"``, axis ``time``, ``dense(t) -> dict``;
        ``transient`` (:class:`netdae.metadata.TransientInfo`): ``index``,
        ``index_method``, ``index2`` (unknowns), ``initial_correction``
        (``{"reason", "changed": {name: [old, new]}}`` or None), ``impulses``
        (warnings), ``start`` (the values at t0 before correction),
        ``failure``, ``jumps``, ``events``.

    Raises
    ------
    NetdaeError
        No ``.tran`` card, ``method=trap``, an unknown save name, an output
        that cannot fit in memory (or, bounded, in ``room``) at its fewest points.
    CircuitError, SingularPencilError, ConvergenceError
        A circuit that cannot be simulated (singular pencil, a nonlinear
        circuit of index >= 3, an operating point that does not converge).
    """
    t_wall = time.perf_counter()
    settings = _settings(circuit, card, reltol=reltol, abstol=abstol, vntol=vntol, maxord=maxord,
                         max_step=max_step, initial=initial)
    card = settings.card
    prepared = prepare(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop)
    system = prepared.system
    saved = _saved(prepared, save)
    notes = list(system.notes)
    fits_memory = bounded and output is not None and system.delays is None and _streamable(system, circuit.options, {})
    size_warning = None if fits_memory and room is None else \
        _check_size(saved.keep.size, system.n, card, settings.tmax, room if fits_memory else None)
    if size_warning is not None:
        notes.append(size_warning)
    settings = _line_delays(prepared, settings)
    start = _start(prepared, settings)
    if start.uic:  # no operating point: the rest of the run is a uic run
        settings = replace(settings, card=replace(settings.card, uic=True))
        card = settings.card
    notes += start.notes
    system.start_delays(start.x, uic=card.uic)
    rep = _structure(prepared, start.x, card.uic)
    notes += _index_notes(prepared, rep)
    try:
        x0, correction, more = _consistent_start(prepared, start, rep, settings)
    except NetdaeError as exc:
        if start.no_op is None:
            raise
        # the card has no uic: say first why the operating point failed, then why its replacement did
        raise ConvergenceError(f"no DC operating point ({start.no_op.message}), and the start without one (as "
                               f"with uic: capacitor voltages and inductor currents from their ic= or 0) failed "
                               f"too: {str(exc).removeprefix('uic: ')}", hint=start.no_op.hint) from None
    notes += more
    impulses = _impulses(system, rep, 0.0, card.tstop) if rep.pencil is not None else []
    notes += [f"warning: {w}" for w in impulses[:JUMP_NOTES]]  # all of them in transient.impulses
    if len(impulses) > JUMP_NOTES:
        notes.append(f"warning: {len(impulses) - JUMP_NOTES:,} more breakpoints where the inputs jump put impulses "
                     f"into the solution (the last at {impulses[-1].split(':', 1)[0]}; all in transient.impulses)")
    if rep.index is not None and rep.index >= 3:
        run = _decoupled_run(prepared, rep, start, x0, saved, settings, progress)
    else:
        run = _integrated_run(prepared, rep, x0, saved, settings, progress, output, bounded, raise_on_failure)
    notes += run.notes
    result = _result(prepared, settings, saved, start, rep, run, correction, impulses, notes, t_wall)
    if run.interrupted is not None:
        run.interrupted.partial = result
        raise run.interrupted
    return result


# -- the pipeline's steps and records -----------------------------------------------
@dataclass(frozen=True)
class _Settings:
    """What the card, the options and the caller ask of the run (checked)."""

    card: TranAnalysis
    rtol: float
    vntol: float
    abstol: float
    order: int
    tmax: float
    steady: SteadyOptions
    initial: str
    order_given: bool = False


def _settings(circuit: Circuit, card: TranAnalysis | None, *, reltol, abstol, vntol, maxord, max_step,
              initial: str) -> _Settings:
    """The run's settings from the card, ``.options`` and the caller's overrides.

    Raises
    ------
    NetdaeError
        No ``.tran`` card, ``method=trap``, a bad ``initial``, ``tstep``/``tstop``/``tstart`` or ``maxord``.
    """
    card = _card(circuit, card)
    _check_method(circuit)
    if initial not in ("consistent", "ngspice"):
        raise NetdaeError(f"initial must be 'consistent' or 'ngspice', not {initial!r}")
    if not (card.tstop > 0.0 and card.tstep > 0.0):
        raise NetdaeError(f".tran: tstep and tstop must be positive (got {card.tstep:g}, {card.tstop:g})")
    if not (0.0 <= card.tstart < card.tstop):
        raise NetdaeError(f".tran: tstart {card.tstart:g} must lie in [0, tstop)")
    o = circuit.options
    rtol = reltol if reltol is not None else o.reltol
    vntol_ = vntol if vntol is not None else o.vntol
    abstol_ = abstol if abstol is not None else o.abstol
    order = maxord if maxord is not None else (o.maxord or MAX_ORDER)
    if not 1 <= order <= MAX_ORDER:
        raise NetdaeError(f"maxord={order}: netdae's BDF has orders 1 to {MAX_ORDER} (BDF7 and beyond are not "
                          "zero-stable, and BDF6's stability region is too narrow for stiff circuits); set .options "
                          "maxord between 1 and 5")
    tmax = max_step if max_step is not None else card.tmax
    if tmax is None or tmax <= 0.0:
        tmax = min(card.tstep, (card.tstop - card.tstart) / TMAX_DIVISOR)
    steady = SteadyOptions(reltol=rtol, vntol=vntol_, abstol=abstol_, gmin=o.gmin, maxiter=o.itl1)
    return _Settings(card, rtol, vntol_, abstol_, order, tmax, steady, initial,
                     order_given=maxord is not None or o.maxord is not None)


@dataclass(frozen=True)
class _Saved:
    """The signals the result keeps: unknowns kept, names asked for, and differences ``v(a,b)``."""

    keep: np.ndarray
    requested: list
    diffs: dict
    kept_names: list
    asked: list | None


def _saved(prepared: Prepared, save: list[str] | None) -> _Saved:
    """The caller's ``save`` (else the netlist's ``.save``/``.print``/``.probe``, else every unknown)."""
    asked = save if save is not None else prepared.circuit.saves
    keep, requested, diffs = _save_request(prepared.system, asked)
    return _Saved(keep, requested, diffs, [prepared.system.names[i] for i in keep], asked)


def _line_delays(prepared: Prepared, settings: _Settings) -> _Settings:
    """With transmission lines: checked for the engine, and no step past the shortest delay (the wave a
    step needs has left the other port before the step began: an accepted point, interpolated)."""
    system = prepared.system
    if system.delays is None:
        return settings
    _check_delays(prepared)
    return replace(settings, tmax=min(settings.tmax, float(system.delays.tau.min())))


def _start(prepared: Prepared, settings: _Settings) -> _Start:
    """The values at t = 0: ngspice's ``uic`` state, else the operating point with ``.ic`` held.

    An operating point that does not converge (every strategy of
    :func:`~netdae.analyses.op.solve_operating_point` failed: a circuit with no
    DC steady state, such as an astable multivibrator, or one netdae cannot
    find) gives way to the ``uic`` state, with a note naming the failure
    (``_Start.uic``). A singular or otherwise ill-posed circuit is still
    refused: those errors are not :class:`~netdae.errors.ConvergenceError`.
    """
    if settings.card.uic:
        return _uic_start(prepared)
    from .op import solve_operating_point

    try:
        op = solve_operating_point(prepared, transient=True, options=settings.steady)
    except ConvergenceError as exc:
        start = _uic_start(prepared)
        start.uic, start.no_op = True, exc
        start.notes.insert(0, (
            f"no DC operating point: {exc.message}; the transient starts as with uic (node voltages from .ic, "
            "capacitor voltages and inductor currents from their ic= or the node voltages, else 0; the other "
            "unknowns made consistent), as a circuit without a steady state (an astable) needs. ngspice starts "
            "from the end of its transient operating point (optran) instead, so the first cycle can differ; "
            ".nodeset values lead the operating point to a solution where one exists, .tran ... uic with .ic "
            "chooses the start"))
        return start
    return _Start(x=op.x, op_iterations=op.iterations, notes=list(op.notes))


def _index_notes(prepared: Prepared, rep: IndexReport) -> list[str]:
    """What the structure means for the run; a nonlinear circuit of index >= 3 is refused.

    Raises
    ------
    CircuitError
        Index >= 3 in a nonlinear circuit.
    """
    system, index = prepared.system, rep.index
    if index is not None and index >= 3 and not system.linear:
        index2 = [nm for nm, d in rep.derivative_order.items() if d >= 1]
        raise CircuitError(
            f"the circuit has index {index} (unknowns {', '.join(index2[:6])} depend on derivatives of the "
            f"inputs up to order {index - 1}); BDF does not converge beyond index 2 and netdae solves index >= 3 "
            "only for linear circuits, through their decoupled form",
            hint="replace an ideal element in the chain (e.g. give an op-amp a finite gain) to lower the index",
        )
    if rep.pencil is not None and rep.pencil.singular_by_rounding:  # made runnable by _rounding_regular
        return [f"warning: {ROUNDING_NOTE.format(index=index)}; the transient runs as the exact structure says, and "
                "unknowns in the directions double precision cannot resolve may carry rounding noise (netdae index "
                "shows the rank decisions)"]
    part = rep.algebraic
    if index is None and rep.method in ("topological", "sparse"):
        why = ("" if part is None else
               f"; the algebraic part has a group wider than {GROUP_LIMIT}" if not part.determined else
               "; the algebraic part has impulsive directions but not index 2")
        return [f"index not determined ({system.n} unknowns, above the dense limit of {TRAN_PENCIL_LIMIT} "
                f"for a transient, and the topological statement does not apply{why}): every unknown is "
                "error-tested"]
    if rep.method == "sparse" and index == 2:
        index2 = [nm for nm, d in rep.derivative_order.items() if d >= 1]
        return [f"index 2 from the algebraic part ({system.n} unknowns, above the dense limit of {TRAN_PENCIL_LIMIT} "
                f"for a transient): {', '.join(index2[:6])}{' and more' if len(index2) > 6 else ''} carry the "
                "inputs' derivatives and are left out of the error test"]
    return []


def _consistent_start(prepared: Prepared, start: _Start, rep: IndexReport,
                      settings: _Settings) -> tuple[np.ndarray, dict | None, list[str]]:
    """``(x0, correction, notes)``: the start made consistent with the ``uic`` charges, or with the hidden
    constraints of an index-2 circuit whose inputs change at t0 (unless ``initial="ngspice"``)."""
    system, card = prepared.system, settings.card
    x0 = start.x.copy()
    if card.uic:
        x0 = _consistent_from_charges(system, start, rep, card.tstop, settings.steady)
        text, detail = _correction_note(system, start.x, x0, "uic: algebraic unknowns made consistent with the "
                                        "initial capacitor voltages and inductor currents")
        warnings = _moved_initial_conditions(prepared.circuit, system, x0, settings, " by the uic start")
        warnings += _unheld_element_ics(prepared.circuit, system, x0, settings)
        if detail:
            return x0, {"reason": "uic", "changed": detail}, warnings + [text]
        return x0, None, warnings
    if not (rep.pencil is not None and rep.pencil.weierstrass is not None and (rep.index or 0) >= 2):
        return x0, None, []
    # Without .ic the start is the DC operating point, a steady state of the inputs' values at t0: it
    # violates only the hidden constraints of the inputs' derivatives there, nothing when they do not change
    # (its Newton residual, mapped through the Weierstrass form, would read as violations of 1e-1 V on op-amp
    # macromodels, whose transformation has a condition of 1e18). .ic nodes are held off their equilibrium.
    check = rep.pencil.weierstrass.check_consistency(start.x, _c_derivatives(system, start.x, 0.0),
                                                     steady=not prepared.circuit.ic)
    if check.consistent:
        return x0, None, []
    if settings.initial != "consistent":
        return x0, None, ["initial values kept as ngspice does although they violate hidden constraints: "
                          "expect a jump in the first step"]
    changed = list(check.affected)
    x0[changed] = check.x_consistent[changed]  # the rest moved by rounding only
    why = ("the .ic values hold nodes off the DC equilibrium" if prepared.circuit.ic else
           "the inputs change at t0")
    text, detail = _correction_note(
        system, start.x, x0,
        f"initial values made consistent (the DC operating point violates hidden constraints because {why})")
    if not detail:  # moved by rounding only (below 1e-9 of each value): nothing to report
        return x0, None, []
    text += "" if system.linear else " (from the linearisation at the operating point)"
    warnings = _moved_initial_conditions(prepared.circuit, system, x0, settings,
                                         " by the hidden constraints of the start", held=start.x)
    return x0, {"reason": "hidden constraints", "changed": detail}, warnings + [text]


def _unheld_element_ics(circuit: Circuit, system: MnaSystem, x0: np.ndarray, settings: _Settings) -> list[str]:
    """Located warnings for the capacitors' and inductors' ``ic=`` a ``uic`` start cannot keep.

    A capacitor in a loop with voltage sources and other capacitors (across a
    source, say) has its voltage fixed by the loop, an inductor in a cutset with
    current sources by the cutset; the consistent start takes those values, and
    the warning at the element names the loop (or the current sources and
    inductors at its nodes) and the value used.
    """
    from ..kinds import CAPACITIVE, CURRENT, INDUCTIVE, VOLTAGE
    from .op import branch_path

    def voltage(node: str) -> float:
        i = system.node_index(node) if node != "0" else -1
        return float(x0[i]) if i >= 0 else 0.0

    out = []
    for el in circuit.elements:
        if "ic" not in el.params or el.kind not in (Kind.CAPACITOR, Kind.INDUCTOR):
            continue
        want = float(el.params["ic"])
        where = f"{el.location}: " if el.location else ""
        if el.kind == Kind.CAPACITOR:
            a, b = el.nodes[0], el.nodes[1]
            got = voltage(a) - voltage(b)
            if abs(got - want) <= settings.rtol * max(abs(got), abs(want)) + settings.vntol:
                continue
            what = f"v({a})" if b == "0" else f"v({a},{b})" if a != "0" else f"-v({b})"
            loop = branch_path(circuit, a, b, (VOLTAGE, CAPACITIVE), skip=el.name)
            why = (f"which the loop of {', '.join(loop)} with {el.name} fixes" if loop else
                   "which the circuit's equations fix there")
        else:
            got = float(x0[system.layout.branch(el.name)])
            if abs(got - want) <= settings.rtol * max(abs(got), abs(want)) + settings.abstol:
                continue
            what = f"i({el.name})"
            cut = [o.name for o in circuit.elements if o.name != el.name and set(o.nodes) & set(el.nodes)
                   and any(cls in (CURRENT, INDUCTIVE) for cls, _, _ in KINDS[o.kind].branches)]
            why = (f"which the current sources and inductors at its nodes ({', '.join(cut[:NAMED_DEVICES])}) fix"
                   if cut else "which the circuit's equations fix there")
        out.append(f"warning: {where}{el.name}: ic={want:g} is not held by the uic start: {what} = {got:.6g} at "
                   f"t = 0, {why} (hint: drop ic= on {el.name}, or give values that agree)")
    return out


def _moved_initial_conditions(circuit: Circuit, system: MnaSystem, x0: np.ndarray, settings: _Settings,
                              when: str, held: np.ndarray | None = None) -> list[str]:
    """Located warnings for the ``.ic`` values a consistent start ``x0`` does not keep.

    A ``uic`` start keeps the capacitor voltages and inductor currents; a node a
    voltage source fixes, or one no capacitor holds, takes the value the circuit's
    equations give it at t = 0 (ngspice starts from the ``.ic`` value there and
    jumps in its first step). Each such value is named at its ``.ic`` card with
    what fixes it and the value used. ``held``: the operating point the start
    corrects; a value it did not hold has had its warning there, repeated here
    only when the correction moves it again (the value the transient starts from).
    """
    from .op import unheld_initial_condition

    def differs(got: float, want: float) -> bool:
        return abs(got - want) > settings.rtol * max(abs(got), abs(want)) + settings.vntol

    out = []
    for node, want in circuit.ic.items():
        try:
            i = system.node_index(node)
        except KeyError:
            continue
        if i < 0 or (held is not None and differs(float(held[i]), want)
                     and not differs(float(x0[i]), float(held[i]))):
            continue  # the operating point's warning said it, and the start keeps that value
        if differs(float(x0[i]), want):
            out.append(unheld_initial_condition(circuit, node, want, float(x0[i]), when, uic=settings.card.uic))
    return out


@dataclass
class _Run:
    """What the integration gave: the points, the dense output of the kept unknowns, how it went."""

    times: np.ndarray
    X: np.ndarray
    dense: Callable
    stats: Statistics
    message: str
    status: int
    failure: IntegrationFailure | None
    tolerances: dict
    jumps: list = field(default_factory=list)
    events: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    streamed: int = 0
    interrupted: BaseException | None = None


def _decoupled_run(prepared: Prepared, rep: IndexReport, start: _Start, x0: np.ndarray, saved: _Saved,
                   settings: _Settings, progress) -> _Run:
    """A linear circuit of index >= 3 through its Weierstrass form (:func:`_decoupled`)."""
    card = settings.card
    wf = rep.pencil.weierstrass
    y0 = (wf.U1 @ start.q0) if card.uic else wf.split(x0)[0]
    bdf_opts = {"rtol": settings.rtol, "vntol": settings.vntol, "abstol": settings.abstol,
                "maxord": settings.order, "max_step": settings.tmax}
    times, X, dense, stats, message, status = _decoupled(prepared.system, rep, start.x, y0, card.tstop,
                                                         saved.keep, bdf_opts, progress)
    note = (f"index {rep.index}: solved through the Weierstrass form (finite part by BDF, nilpotent part by "
            "(2.12) with the inputs' analytic derivatives)")
    tolerances = {"reltol": settings.rtol, "vntol": settings.vntol, "abstol": settings.abstol,
                  "maxord": settings.order, "max_step": settings.tmax}
    return _Run(times, X, dense, stats, message, status, None, tolerances, notes=[note])


def _integrated_run(prepared: Prepared, rep: IndexReport, x0: np.ndarray, saved: _Saved, settings: _Settings,
                    progress, output, bounded: bool, raise_on_failure: bool) -> _Run:
    """Index <= 2 by the variable-order BDF, the index-2 unknowns out of the error test; a Ctrl-C keeps
    what was integrated (the run's ``interrupted``)."""
    system, card = prepared.system, settings.card
    unknown_index = np.array([1 + rep.derivative_order.get(nm, 0) for nm in system.names], dtype=np.int64)
    opts = dict(rtol=settings.rtol, vntol=settings.vntol, abstol=settings.abstol, index=unknown_index,
                maxord=settings.order, max_step=settings.tmax, save=saved.keep, relref=RELREF)
    streamed = [0]  # points handed to output
    if output is not None and _streamable(system, prepared.circuit.options, opts):
        opts["output"] = _blocks(output, card.tstart, saved.kept_names, saved.requested, saved.diffs, streamed)
        opts["window"] = bounded
    interrupted = None
    notes = []
    try:
        res = integrate(system, (0.0, card.tstop), x0, progress=progress, **opts)
        if _high_order_runaway(prepared, x0, settings, res):
            notes.append(f"warning: at BDF orders up to {settings.order} the solution ran away at "
                         f"t={res.failure.t:.6g} in a circuit without gain (resistances, capacitances, inductances, "
                         "junctions, switches, lines and independent sources only), which has no growing mode: "
                         "orders 3-5, not A-stable, grew a lightly damped resonance the steps followed; the "
                         "transient was run again from the start at orders 1-2 (.options maxord=2), which damp "
                         "it as the circuit does")
            # a streamed file is written again whole from this run's result, which keeps every point (a run
            # too long for memory then ends with what fitted, and says so)
            opts.pop("output", None)
            opts.pop("window", None)
            opts["maxord"] = 2
            streamed[0] = 0
            res = integrate(system, (0.0, card.tstop), x0, progress=progress, **opts)
    except KeyboardInterrupt as exc:
        # Ctrl-C: keep what was integrated (the compiled engine attaches it), raise after the Result
        res = getattr(exc, "partial", None)
        if res is None or res.t.size == 0:
            raise
        interrupted = exc
    if res.failure is not None and res.failure.runaway:
        res = _held_junction_failure(prepared.circuit, res)
    if raise_on_failure and interrupted is None and not res.ok:
        raise res.failure.error() if res.failure is not None else ConvergenceError(res.message)
    message, status = res.message, res.status
    if interrupted is not None:
        message = f"interrupted at t={res.t[-1]:.9g} of {card.tstop:.9g} (the results up to there are kept)"
        status = -1
    stats = Statistics.from_counts(res.stats)
    jumps = [(t, list(w)) for t, w in res.jumps]
    events = [(t, list(w)) for t, w in res.events]
    for tj, who in jumps[:JUMP_NOTES]:
        if not who:  # an event whose right limit moved no unknown beyond its tolerance
            notes.append(f"t={tj:.6g}: both the value from the left and the right limit are reported at this "
                         "time (no unknown jumps there beyond its tolerance)")
            continue
        notes.append(f"t={tj:.6g}: the solution jumps ({', '.join(who[:5])}"
                     f"{' and more' if len(who) > 5 else ''}); both the value from the left and "
                     "the right limit are reported at this time")
    if len(jumps) > JUMP_NOTES:
        notes.append(f"the solution jumps at {len(jumps) - JUMP_NOTES} more times (transient.jumps)")
    if stats.get("impasses"):
        notes.append(f"Newton failed on every step size at {stats['impasses']} instant(s): the solution continued "
                     "from implicit-Euler steps right of each solved by the steady-state solver (damped Newton, "
                     "limiting, gmin and source stepping), recorded as a jump (an impasse: the circuit snaps "
                     "to another state, as a latch or a trigger with feedback does, or as an inductor's current "
                     "does when a switch cuts its path)")
    if events:
        first_t, first_w = events[0]
        notes.append(f"switches or behavioural sources' comparisons changed at {len(events)} instant(s), located "
                     f"where their controls cross the thresholds (the first: t={first_t:.6g}, "
                     f"{', '.join(first_w[:5])}; all in transient.events)")
    tolerances = {"reltol": settings.rtol, "vntol": settings.vntol, "abstol": settings.abstol,
                  "maxord": opts["maxord"], "max_step": settings.tmax,
                  "index_excluded": res.tolerances.get("index_excluded", 0)}
    if res.failure is not None and rep.pencil is not None and rep.pencil.singular_by_rounding:
        message += (f" ({ROUNDING_NOTE.format(index=rep.index)}, whose Newton matrices lose some directions to "
                    f"rounding; {ROUNDING_HINT})")
    elif res.failure is not None and rep.topology is not None:
        reasons = [f.message for f in rep.topology.findings if f.severity in ("error", "warning")]
        if reasons:
            message += f" (circuit structure: {reasons[0]})"
    if res.failure is not None and system.linear:
        message += growth_note(rep.finite_eigenvalues, res.t[-1] - card.tstart)
    if res.failure is not None and res.failure.worst:
        message += _jumping_source(prepared.circuit, res.failure.worst)
    if res.failure is not None:  # a module's $fatal names no unknown
        message += _undefined_devices(prepared.circuit, system, res.failure)
    if status == STATUS_OK and interrupted is None:
        note = _held_equilibrium(prepared, x0, saved, settings, res)
        if note is not None:
            notes.append(note)
    return _Run(res.t, res.x, res.dense, stats, message, status, res.failure, tolerances, jumps, events, notes,
                streamed[0], interrupted)


def _held_junction_failure(circuit: Circuit, res):
    """A failed run whose source current ran away through a junction the sources hold, its hint saying so
    (:func:`netdae.topology.held.held_junction_cause` in place of the growing mode's sentence); else ``res``."""
    failure = res.failure
    index = {name.lower(): i for i, name in enumerate(res.names)}
    last = res.x[-1] if res.x.shape[0] else None

    def value(name: str) -> float | None:
        i = index.get(name)
        return None if i is None or last is None else float(last[i])

    cause = held_junction_cause(circuit, failure.runaway, failure.runaway_value, lambda n: value(f"v({n})"))
    if cause is None:
        return res
    # a run that ran away has its hint begin with the runaway's sentence (its cause: with_runaway)
    failure = replace(failure, hint=cause + failure.hint[len(failure.cause):], cause=cause)
    return replace(res, failure=failure, message=failure.message)


def _high_order_runaway(prepared: Prepared, x0: np.ndarray, settings: _Settings, res) -> bool:
    """Whether a failed run is to be run again at BDF orders 1-2: its solution ran away at orders 3-5 in a
    circuit that has no gain.

    Orders 3-5 are not A-stable: where the steps follow a lightly damped resonance (a transformer's leakage
    inductance ringing with a diode's junction capacitance after its reverse recovery), their error per step
    can outweigh the mode's damping and the integration grows it while the circuit damps it. A circuit with
    gain can have a mode in the right half-plane (a transimpedance amplifier's op-amp models, past its input
    corner; an oscillator's start), and orders 1-2 at long steps would damp its growth into a bounded
    waveform the circuit does not have: such a circuit keeps its failure. So only a circuit whose elements
    all have no gain (:data:`netdae.kinds.NO_GAIN_KINDS`), with positive resistances, capacitances and
    inductances, whose inputs stayed within :data:`~netdae.dae.bdf.failures.RUNAWAY_FACTOR` of their start
    (a source whose waveform grows without bound is no resonance), whose pencil at the start has no growing
    mode (within :data:`TRAN_PENCIL_LIMIT` unknowns, a dense eigenvalue analysis), and whose maximum order
    the user did not choose.
    """
    failure = res.failure
    if failure is None or failure.runaway_order < 3 or settings.order_given or settings.order < 3:
        return False
    for el in prepared.circuit.elements:
        if el.kind not in NO_GAIN_KINDS:
            return False
        if el.kind in (Kind.RESISTOR, Kind.CAPACITOR, Kind.INDUCTOR) and el.value is not None and not el.value > 0:
            return False
    system = prepared.system
    try:  # an input that grows without bound itself (SIN with a negative damping factor) is no resonance
        u0 = float(np.max(np.abs(system.source(0.0, waves=False)), initial=0.0))
        uf = float(np.max(np.abs(system.source(failure.t, waves=False)), initial=0.0))
    except (OverflowError, FloatingPointError, ValueError):
        return False
    if not uf <= RUNAWAY_FACTOR * max(1.0, u0):
        return False
    if system.n > TRAN_PENCIL_LIMIT:
        return True
    E, H = system.jacobians(x0, 0.0)
    try:
        return growing_eigenvalue(E, H, float(res.t[-1] - res.t[0]) if res.t.size else 0.0) is None
    except np.linalg.LinAlgError:  # QZ or the SVD did not converge: the failure stands
        return False


def _held_equilibrium(prepared: Prepared, x0: np.ndarray, saved: _Saved, settings: _Settings, res) -> str | None:
    """A warning when the run stayed at its operating point and that point is unstable (an astable built
    symmetric stays on it in exact arithmetic; :func:`~netdae.analyses.instability.held_equilibrium_note`).

    Only for a start at the DC operating point (no ``uic``, no ``.ic``: otherwise the start is not an
    equilibrium) of a circuit within the dense limit, and only when every saved unknown stayed within its
    tolerances of its starting value at every kept point (the check costs an eigenvalue analysis, done
    only then) and the growing mode's largest component is one of them.
    """
    system, card = prepared.system, settings.card
    if card.uic or prepared.circuit.ic or system.n > TRAN_PENCIL_LIMIT or not saved.keep.size or res.t.size < 2:
        return None
    atol = np.where(system.kinds[saved.keep] == KIND_VOLTAGE, settings.vntol, settings.abstol)
    if not stayed(res.x, x0[saved.keep], settings.rtol, atol):
        return None
    E, H = system.jacobians(x0, 0.0)
    try:
        return held_equilibrium_note(E, H, system.names, x0, float(res.t[-1] - res.t[0]), watched=saved.keep)
    except np.linalg.LinAlgError:  # QZ or the SVD did not converge: a note less, the run stands
        return None


def _undefined_devices(circuit: Circuit, system: MnaSystem, failure) -> str:
    """Which devices' equations a failure on a non-finite evaluation comes from, else ``""``.

    The integrators stop when the equations are not finite at every step size
    (a model's square root or logarithm of a negative number, a division by
    zero, an overflow) and name the first unknown whose row is not finite.
    Here that row becomes the devices writing into it: the elements touching
    its node or owning its branch, the nonlinear ones (those evaluated by a
    device family: diodes, transistors, OSDI modules, behavioural sources)
    first, since constant stamps are always finite.

    Parameters
    ----------
    circuit : Circuit
    system : MnaSystem
    failure : IntegrationFailure
        The run's failure; its ``worst`` names the non-finite row.

    Returns
    -------
    str
        ``" (not finite in the equations of ...: n1 (model nm, module nanres) ...)"`` or ``""``.
    """
    from .op import _involved_elements, fatal_messages

    if "not finite" not in f"{failure.what} {failure.hint}":
        return ""
    said = fatal_messages(circuit, ("fatal",))
    if said:  # a module's $fatal: its words are the reason
        return f" (an OSDI module stopped its evaluation{said})"
    if failure.worst not in system.names:
        return ""
    names = _involved_elements(circuit, system, [system.names.index(failure.worst)])
    devices = [n for n in names if not KINDS[circuit.element(n).kind].stamped] or names
    if not devices:
        return ""
    shown = []
    for name in devices[:NAMED_DEVICES]:
        el = circuit.element(name)
        model = circuit.models.get(el.model) if el.model else None
        shown.append(f"{name} (model {el.model}, {model.type})" if model is not None else name)
    more = f" and {len(devices) - NAMED_DEVICES} more" if len(devices) > NAMED_DEVICES else ""
    return (f" (the equations of {failure.worst} are not finite there; devices writing into them: "
            f"{', '.join(shown)}{more}: one of them is undefined at these values, e.g. the square root or logarithm "
            "of a negative number, a division by zero or an overflow in its model or expression)")


def _jumping_source(circuit, worst: str) -> str:
    """What to say when the failure's worst unknown belongs to a behavioural source whose value jumps with
    the circuit's state (a comparison of voltages in its expression), else ``""``: both integrators hold
    such comparisons and locate their changes as events, so a failure there has a reason of its own."""
    from ..netlist.expr import jumps_with_state

    for el in circuit.elements:
        if el.kind not in (Kind.BVOLTAGE, Kind.BCURRENT) or el.expr is None:
            continue
        own = {f"i({el.name})"} | {f"v({node})" for node in el.nodes if node != "0"}
        if worst in own and jumps_with_state(el.expr):
            return (f" ({el.name}'s value jumps where a comparison of the circuit's voltages or currents in its "
                    "expression changes; netdae holds such comparisons through each step and locates their changes "
                    "(also where the held branch is undefined past the change), but not where the law is unbounded "
                    "approaching the change (a log of the compared quantity) or where the comparison flips on "
                    "rounding noise (a difference of large, nearly equal terms): write it as a smooth function (e.g. "
                    "tanh of the difference over a small scale) or as an S/W switch)")
    return ""


def _result(prepared: Prepared, settings: _Settings, saved: _Saved, start: _Start, rep: IndexReport, run: _Run,
            correction: dict | None, impulses: list[str], notes: list[str], t_wall: float) -> Result:
    """The ``tran`` Result: the points from ``tstart`` on (or the ``interp`` grid), the dense output of the
    saved signals, the statistics and what the structure and the start said."""
    system, card, o = prepared.system, settings.card, prepared.circuit.options
    notes = [d.message for d in prepared.circuit.diagnostics if d.in_results] + list(notes)
    if o.interp:
        grid = np.arange(card.tstart, card.tstop + 0.5 * card.tstep, card.tstep)
        grid = grid[grid <= card.tstop * (1 + 1e-12)]
        grid[-1] = min(grid[-1], run.times[-1])
        if run.status < 0:
            grid = grid[grid <= run.times[-1]]  # a run that stopped early: no extrapolation past its end
        out_t, out_x = grid, np.asarray(run.dense(grid))
        notes.append(f".options interp: results on the tstep grid ({grid.size} points) from the dense output")
    else:
        sel = run.times >= card.tstart
        out_t, out_x = run.times[sel], run.X[sel]
    kept_names, requested, diffs = saved.kept_names, saved.requested, saved.diffs
    dense_kept = run.dense

    def dense(t):
        return _signals(kept_names, requested, np.atleast_2d(np.asarray(dense_kept(np.atleast_1d(t)))), diffs)

    points = int(out_t.size)
    if run.streamed > points:  # a bounded run: the points before these went to output only
        notes.append(f"memory: the result holds the last {points:,} of the {run.streamed:,} points (all of them "
                     "went to the output file as they were computed)")
        points = run.streamed
    integrator = Statistics.from_counts(run.stats)
    stats_out = Statistics(
        steps=integrator.steps or 0, rejected=integrator.rejected or 0,
        newton_iterations=integrator.newton_iterations or 0, factorizations=integrator.factorizations or 0,
        points=points, op_newton_iterations=start.op_iterations, integrator=integrator,
        wall_time=time.perf_counter() - t_wall, **system.describe())
    kept_note = ("all unknowns" if saved.asked in (None, []) else ", ".join(requested + list(diffs)))
    index2 = [nm for nm, d in rep.derivative_order.items() if d >= 1]
    return Result(
        "tran",
        axes={"time": out_t},
        signals=_signals(kept_names, requested, out_x, diffs),
        stats=stats_out,
        status=STATUS_OK if run.status >= 0 else STATUS_FAILED,
        message=run.message,
        tolerances=run.tolerances,
        dense=dense,
        notes=notes + [f"saved: {kept_note}"],
        card=card,
        transient=TransientInfo(
            index=rep.index, index_method=rep.method, index2=index2, initial_correction=correction,
            impulses=impulses, start={nm: float(v) for nm, v in zip(system.names, start.x)},
            failure=run.failure, jumps=run.jumps, events=run.events, index_report=rep),
    )
