"""DC sweep (``.dc SRC start stop step [SRC2 start2 stop2 step2]``).

Sweeps the DC value of one or two independent sources (or the circuit
temperature, ``temp``, or a resistor's resistance), solving the operating point
at every point with the previous solution as the initial guess (continuation).
As in ngspice the first sweep is the inner loop.

A swept resistor takes each value as its resistance at ``tnom``: its
temperature coefficients (``tc1``, ``tc2``, ``tce``), ``scale`` and ``m`` apply
at every point, as in ngspice 39 (measured: ``tc1=0.01`` at 50 degC, 1 kohm
conducts as 1.23 kohm in both).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..circuit import Circuit, DcAnalysis, DcSweep
from ..errors import CircuitError, ConvergenceError, NetdaeError
from ..kinds import KINDS, Kind
from ..mna import MODE_DC, assemble
from ..netlist.steps import check_grid_size
from .prepared import Prepared, prepare
from ..results import Result, Statistics
from .op import solve_operating_point, steady_options

__all__ = ["sweep_values", "dc_sweep"]

#: Slack, in units of the step, that keeps the stop value in the sweep despite rounding.
STEP_SLACK = 1e-9
#: The compiled sweep takes a point whose smallest equilibrated pivot is at least this fraction of the
#: last one the full solver judged regular (its SVD rank decision confirmed a suspect pivot), and leaves
#: a smaller one to the full solver's judgement: along a sweep the pivots move with the bias, and a
#: matrix that becomes singular shows it as a pivot falling away from the last one proven regular.
PROVEN_PIVOT_FRACTION = 0.1

#: Points of a ``.dc`` sweep per compiled call (about 0.1 s on a small circuit): Ctrl-C is seen between
#: calls, and the points solved before are kept.
SWEEP_CHUNK = 20_000


def sweep_values(sw: DcSweep) -> np.ndarray:
    """Values of one sweep: start, start + step, ... up to stop inclusive.

    Raises
    ------
    NetdaeError
        For a zero step (unless start == stop) or a step pointing away from stop.

    Examples
    --------
    >>> sweep_values(DcSweep("v1", 0.0, 1.0, 0.25)).tolist()
    [0.0, 0.25, 0.5, 0.75, 1.0]
    >>> sweep_values(DcSweep("v1", 1.0, 0.0, -0.5)).tolist()
    [1.0, 0.5, 0.0]
    """
    if sw.step == 0.0:
        if sw.start == sw.stop:
            return np.array([sw.start])
        raise NetdaeError(f".dc {sw.source}: the step is zero")
    count = (sw.stop - sw.start) / sw.step
    if count < -STEP_SLACK:
        raise NetdaeError(
            f".dc {sw.source}: the step {sw.step:g} points away from stop {sw.stop:g} (start {sw.start:g})"
        )
    try:
        check_grid_size(np.floor(count + STEP_SLACK) + 1)
    except ValueError as exc:
        raise NetdaeError(f".dc {sw.source}: {exc}") from None
    k = np.arange(int(np.floor(count + STEP_SLACK)) + 1)
    return sw.start + k * sw.step


def _check_source(circuit: Circuit, sw: DcSweep) -> None:
    name = sw.source
    if name == "temp":
        return
    try:
        el = circuit.element(name)
    except KeyError:
        raise CircuitError(f".dc: there is no source named '{name}'", elements=(name,)) from None
    if not KINDS[el.kind].independent and el.kind != Kind.RESISTOR:
        raise CircuitError(
            f".dc: '{name}' is {KINDS[el.kind].noun}; netdae sweeps independent V and I sources, resistors and temp",
            elements=(name,),
        )
    if el.kind == Kind.RESISTOR and sw.start * sw.stop <= 0:
        raise CircuitError(f".dc: the resistance sweep of {name} from {sw.start:g} to {sw.stop:g} reaches 0 ohm",
                           elements=(name,), hint="sweep a resistance of one sign; a short circuit is a 0 V source")



def _at_point(circuit: Circuit, names: list[str], values: tuple, resistors: set[str]) -> Circuit:
    """The circuit at a point of a sweep that changes more than source values (temperature, resistances)."""
    at = circuit
    if "temp" in names:
        temp = values[names.index("temp")]
        if circuit.uses_temper:  # its values follow the temperature (ngspice re-evaluates 'temper' too)
            from ..netlist.elaborate import TEMPER

            at = circuit.variant({TEMPER: temp})
        else:
            at = replace(circuit, options=replace(circuit.options, temp=temp))
    if resistors:
        swept = {name: v for name, v in zip(names, values) if name in resistors}
        elements = []
        for el in at.elements:
            if el.name in swept:
                el = replace(el, value=float(swept[el.name]))
            elements.append(el)
        at = replace(at, elements=elements)
    return at


def _compiled_sweep(system, circuit: Circuit, names: list[str], points: list[tuple], opts, topo):
    """``fast(x, p) -> (X, iterations, stop)``: points ``p .. stop - 1`` by the compiled sweep, or None.

    It applies where every point's solve would be plain Newton in the compiled engine
    (:func:`netdae.dae.steady.solve_steady`'s first phase): an eligible nonlinear system,
    no group of nodes attached only through capacitors (``.nodeset`` values act at the first
    point only, as in ngspice's sweep). The first point
    and any point plain Newton does not clearly solve (no convergence, a small pivot)
    go through :func:`~netdae.analyses.op.solve_operating_point` as before, so the
    results, failures and messages are those of the point-by-point sweep. ``fast(x, p,
    proven)`` takes the smallest pivot of the last point the full solver judged: a point
    whose pivot is at least ``PROVEN_PIVOT_FRACTION`` of it is clear (a BJT's output
    curves at zero base current: every point's pivot 6e-11 to 1e-8, each confirmed
    regular by an SVD when every point went through the full solver).
    """
    from ..dae.steady import EPS, PIVOT_SAFETY, PIVOT_SUSPECT, _compiled, _tolerances
    from .op import charge_groups

    system = system.steady_form()
    if not _compiled(system):
        return None
    if charge_groups(system, topo, None)[0]:
        return None
    from ..dae.compiled.steady_driver import sweep_points

    cols = np.array([system.sources.names.index(nm) for nm in names], dtype=np.int64)
    values = np.array(points, dtype=float)
    x_atol, r_atol = _tolerances(system.kinds, opts)

    singular = PIVOT_SAFETY * system.n * EPS

    def fast(x, p, proven=float("nan")):
        # a pivot the full solver proved regular lowers the threshold of a closer look (never below the
        # singular one, never above PIVOT_SUSPECT)
        clear = PIVOT_SUSPECT
        if proven < PIVOT_SUSPECT:  # False for nan: no judgement made
            clear = max(singular, PROVEN_PIVOT_FRACTION * proven)
        # a chunk at a time: Ctrl-C reaches Python between chunks (and loses at most the one running)
        X, its, stop = sweep_points(system, values[p:p + SWEEP_CHUNK], cols, x, 0, maxiter=opts.maxiter,
                                    reltol=opts.reltol, x_atol=x_atol, r_atol=r_atol, singular_pivot=singular,
                                    clear_pivot=clear)
        return X[:stop], its[:stop], p + stop

    return fast


def _solve_point(prepared: Prepared, opts, x, names, values):
    """One point of the sweep: from the previous point's solution, and where that fails from scratch
    (ngspice's sweep does the same: ``CKTop`` from the junctions' initial voltages once its itl2
    iterations from the previous point fail). A point where the solution jumps far from the
    previous one (a chain of stages that all switch: every stage is limited on its way) is
    often reached from scratch only. The attempt from scratch runs Newton, gmin and source
    stepping only: pseudo-transient continuation, the slowest strategy, has had its budget in
    the first attempt (a point that no strategy reaches costs one budget, not two); the error
    is the first attempt's. ``.nodeset`` values act at the first point and in the attempts from
    scratch only (ngspice applies them in its junction-initialisation modes, not from the
    previous point's solution).

    Raises
    ------
    ConvergenceError
        Neither converged; the message names the point.
    CircuitError
        The point's matrix is singular (the message names the point).
    """
    where = _point_text(names, values)
    try:
        try:  # from the previous point's solution without the .nodeset values (ngspice's MODEINITPRED)
            return solve_operating_point(prepared, options=opts, x0=x, nodesets=x is None)
        except ConvergenceError as exc:
            failure = exc
        if x is not None:
            try:  # without pseudo-transient continuation, which the first attempt ran to its budget
                return solve_operating_point(prepared, options=replace(opts, pseudo_transient=False), x0=None)
            except ConvergenceError:
                pass
    except CircuitError as exc:
        raise type(exc)(f".dc at {where}: {exc.located_message}", elements=exc.elements, nodes=exc.nodes,
                        hint=exc.hint) from None
    raise ConvergenceError(f".dc at {where}: {failure.message}" + (" (from the previous point's solution and from "
                           "scratch)" if x is not None else ""), t=failure.t, h=failure.h, worst=failure.worst,
                           hint=failure.hint) from None


def dc_sweep(circuit: Circuit, card: DcAnalysis, **overrides) -> Result:
    """Run a ``.dc`` sweep.

    Parameters
    ----------
    circuit : Circuit
    card : DcAnalysis
        One or two sweeps (first is the inner loop).
    **overrides
        Operating-point tolerances.

    Returns
    -------
    Result
        ``analysis == "dc"``; axes: the swept values per point, named after the
        sources (``"v1"``, then ``"v2"``); signals per unknown.

        A point that fails (no convergence, a singular matrix, a circuit
        refused at that temperature) ends the sweep there, as in ngspice:
        the result holds the points before it, ``status`` failed and its
        ``message`` the error, naming the sweep value where it failed.

    Raises
    ------
    CircuitError, ConvergenceError, NetdaeError
        A sweep that cannot start: its card refused, or its first point
        failed (nothing was computed).

    Notes
    -----
    One Newton solve per point, warm-started from the previous point (switches
    start from the previous point's states, so a sweep shows their hysteresis,
    as in ngspice). A temperature sweep re-assembles the circuit at each
    temperature; a circuit whose values use ``temper`` is elaborated again there
    (:meth:`~netdae.circuit.Circuit.variant`), as ngspice re-evaluates them. A
    resistance sweep re-assembles the circuit with the resistor at each value
    (the module docstring says how ngspice sets it).
    """
    t_start = time.perf_counter()
    sweeps = list(card.sweeps)
    for sw in sweeps:
        _check_source(circuit, sw)
    where = f"{card.location}: " if card.location is not None else ""
    try:
        grids = [sweep_values(sw) for sw in sweeps]
    except NetdaeError as exc:  # a sweep of too many points, located at its card
        raise NetdaeError(f"{where}{exc}") from None
    try:
        check_grid_size(float(np.prod([g.size for g in grids], dtype=float)))
    except ValueError as exc:
        raise NetdaeError(f"{where}.dc {' '.join(sw.source for sw in sweeps)}: {exc}") from None
    if len(sweeps) == 1:
        points = [(v,) for v in grids[0]]
    else:
        points = [(v1, v2) for v2 in grids[1] for v1 in grids[0]]
    names = [sw.source for sw in sweeps]
    opts = steady_options(circuit, **overrides)

    resistors = {name for name in names if name != "temp" and circuit.element(name).kind == Kind.RESISTOR}
    sweeps_temp = "temp" in names or bool(resistors)  # the circuit assembled again at every point
    if sweeps_temp:  # the topology is the same at every point
        from ..topology import analyze_topology

        prepared, system, topo = None, None, analyze_topology(circuit)
    else:
        prepared = prepare(circuit, mode=MODE_DC)
        system, topo = prepared.system, prepared.topology
    fast = None if sweeps_temp else _compiled_sweep(system, circuit, names, points, opts, topo)
    try:
        rows, iterations, system, failure = _sweep_points(points, names, resistors, sweeps_temp, circuit, prepared,
                                                          system, topo, opts, fast)
    except KeyboardInterrupt as exc:  # Ctrl-C: the points solved so far, as a failed result
        done, iterations, system = exc.done
        m = len(done)
        if m == 0 or system is None:
            raise
        at = ", ".join(f"{name} = {v:.9g}" for name, v in zip(names, points[m - 1]))
        exc.partial = _result(points[:m], names, done, system, iterations, opts, t_start, status=-1,
                              message=f"interrupted at {at}, point {m} of {len(points)} (the results up to there "
                                      "are kept)")
        raise
    if failure is not None:  # the points before it are the result (none: the sweep could not start)
        error, text = failure
        m = len(rows)
        if m == 0 or system is None:
            raise error
        return _result(points[:m], names, rows, system, iterations, opts, t_start, status=-1,
                       message=f"{text} (the sweep stopped at point {m + 1} of {len(points)}; the {m} points "
                               "before it are kept)")
    return _result(points, names, rows, system, iterations, opts, t_start)


def _sweep_points(points, names, resistors, sweeps_temp, circuit, prepared, system, topo, opts, fast):
    """Solve the sweep's points in order: ``(rows, Newton iterations, the last point's system, failure)``.

    ``failure`` is None, or ``(error, text)``: the error of the point that failed and its text naming
    the point; the rows are the points solved before it (ngspice's sweep stops at a point that fails
    too).

    Raises
    ------
    KeyboardInterrupt
        With ``done``: the rows solved, the iterations and the last system.
    """
    x = None
    rows = []
    iterations = 0
    proven = float("nan")  # the smallest pivot of the last point the full solver judged
    p = 0
    try:
        while p < len(points):
            values = points[p]
            if fast is not None and x is not None:
                # the following points in one compiled call, until one needs the full solver
                X, its, stop = fast(x, p, proven)
                rows.extend(X)
                iterations += int(its.sum())
                if stop > p:
                    x = X[-1].copy()
                    p = stop
                    continue
            if sweeps_temp:
                try:
                    at_point = _at_point(circuit, names, values, resistors)
                    at_system = assemble(at_point, mode=MODE_DC)
                except NetdaeError as exc:  # the circuit refused at this point (a device at this temperature)
                    return rows, iterations, system, (exc, f".dc at {_point_text(names, values)}: {exc}")
                system = at_system
                prepared = Prepared.known(at_point, system, topo)
                x = None if x is None or x.size != system.n else x
            for name, v in zip(names, values):
                if name != "temp" and name not in resistors:
                    system.sources.set_value(name, v)
            try:
                res = _solve_point(prepared, opts, x, names, values)
            except NetdaeError as exc:  # a ConvergenceError's or CircuitError's message names the point
                named = isinstance(exc, (ConvergenceError, CircuitError))
                return rows, iterations, system, (exc, str(exc) if named else f".dc at {_point_text(names, values)}: "
                                                                               f"{exc}")
            iterations += res.iterations
            proven = res.min_pivot
            x = res.x
            system.remember_switches(x)
            rows.append(x.copy())
            p += 1
    except KeyboardInterrupt as exc:
        exc.done = (rows, iterations, system)
        raise
    return rows, iterations, system, None


def _point_text(names, values) -> str:
    """``v1 = 0.5, temp = 27``: a point of the sweep as its errors name it."""
    return ", ".join(f"{name} = {value:g}" for name, value in zip(names, values))


def _result(points, names, rows, system, iterations, opts, t_start, *, status=0, message="ok"):
    """The sweep's ``Result`` from its solved ``rows`` (one per point)."""
    X = np.array(rows).reshape(len(rows), system.n)
    axes = {name: np.array([p[i] for p in points]) for i, name in enumerate(names)}
    return Result(
        "dc",
        axes=axes,
        signals={name: X[:, i] for i, name in enumerate(system.names)},
        stats=Statistics(points=len(points), newton_iterations=iterations,
                         wall_time=time.perf_counter() - t_start, **system.describe()),
        status=status,
        message=message,
        tolerances={"reltol": opts.reltol, "vntol": opts.vntol, "abstol": opts.abstol},
        notes=list(system.notes),
    )
