"""The DC operating point (``.op``, and the start of every transient unless ``uic``).

Solves ``phi(x, t0) = 0`` of the MNA system (capacitors open, inductors
shorted) with :func:`netdae.dae.steady.solve_steady`, honouring ``.nodeset``
(initial guesses held for a first solve) and, for the operating point of a
transient, ``.ic`` (nodes held at their values through a 1e10 S conductance,
as ngspice does). A singular DC matrix is explained in circuit terms by the
topological analysis when the reason is topological.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..circuit import Circuit
from ..dae.steady import Forcing, SteadyOptions, SteadyResult, solve_steady
from ..errors import CircuitError, ConvergenceError
from ..mna import MODE_DC, MnaSystem, assemble
from ..results import Result

__all__ = ["steady_options", "solve_operating_point", "operating_point", "op_result"]


def steady_options(circuit: Circuit, **overrides) -> SteadyOptions:
    """Solver options from the circuit's ``.options`` with keyword overrides."""
    o = circuit.options
    opts = SteadyOptions(reltol=o.reltol, vntol=o.vntol, abstol=o.abstol, gmin=o.gmin, maxiter=o.itl1)
    return replace(opts, **overrides) if overrides else opts


def _node_forcing(system: MnaSystem, values: dict[str, float], what: str) -> Forcing | None:
    if not values:
        return None
    idx, val = [], []
    for node, v in values.items():
        try:
            i = system.node_index(node)
        except KeyError:
            raise CircuitError(f"{what} names node '{node}', which is not in the circuit", nodes=(node,)) from None
        if i >= 0:
            idx.append(i)
            val.append(v)
    if not idx:
        return None
    return Forcing(np.array(idx, dtype=np.int64), np.array(val, dtype=float))


def _describe_unknowns(system: MnaSystem, indices, x) -> str:
    return ", ".join(f"{system.names[i]} = {x[i]:.6g}" for i in indices)


def _singular_error(system: MnaSystem, res: SteadyResult) -> CircuitError:
    """The best explanation of a singular DC matrix, in circuit terms."""
    from ..topology import dc_singularity_explanation

    found = dc_singularity_explanation(system.circuit)
    if found is not None:
        return found
    if res.null_vector is not None:
        v = np.abs(res.null_vector)
        involved = [system.names[i] for i in np.flatnonzero(v > 1e-3 * v.max())]
        return CircuitError(
            "the DC operating-point matrix is singular: " + ", ".join(involved[:10])
            + (" ..." if len(involved) > 10 else "") + " are not determined",
            hint="look for a node without DC path to ground, a loop of voltage sources/inductors, "
            "or a cutset of current sources/capacitors among these unknowns",
        )
    return CircuitError(
        "the DC operating-point matrix is singular",
        hint="look for a node without DC path to ground, a loop of voltage sources/inductors, "
        "or a cutset of current sources/capacitors",
    )


def solve_operating_point(system: MnaSystem, *, t: float = 0.0, transient: bool = False,
                          options: SteadyOptions | None = None, x0: np.ndarray | None = None) -> SteadyResult:
    """Operating point of an assembled circuit.

    Parameters
    ----------
    system : MnaSystem
    t : float
        Time at which sources are evaluated (0 for the start of a transient).
    transient : bool
        This operating point starts a transient: ``.ic`` values are forced.
    options : SteadyOptions, optional
        Defaults from the circuit's ``.options``.
    x0 : ndarray, optional
        Initial guess (continuation in sweeps).

    Returns
    -------
    SteadyResult
        Converged.

    Raises
    ------
    CircuitError
        When the DC matrix is singular, with the topological reason.
    ConvergenceError
        When Newton, gmin stepping and source stepping all fail; names the
        unknowns that did not settle and their last values.
    """
    circuit = system.circuit
    opts = options or steady_options(circuit)
    forcing = _node_forcing(system, circuit.ic, ".ic") if transient else None
    nodeset = _node_forcing(system, circuit.nodeset, ".nodeset")
    res = solve_steady(system, t, x0, options=opts, forcing=forcing, nodeset=nodeset)
    if res.converged:
        return res
    if res.singular:
        raise _singular_error(system, res)
    worst = _describe_unknowns(system, res.worst, res.x)
    raise ConvergenceError(
        f"operating point did not converge after {res.iterations} Newton iterations "
        f"(plain Newton, gmin stepping, source stepping); last values: {worst}",
        worst=system.names[res.worst[0]] if res.worst else None,
        hint="check device models and connections near these unknowns; .nodeset values close to "
        "the expected solution help; so does a larger itl1 in .options",
    )


def op_result(system: MnaSystem, res: SteadyResult, wall: float, opts: SteadyOptions) -> Result:
    """Package an operating point as a :class:`~netdae.results.Result`."""
    signals = {name: np.array([res.x[i]]) for i, name in enumerate(system.names)}
    return Result(
        "op",
        signals=signals,
        stats={
            "newton": res.iterations,
            "factorizations": res.factorizations,
            "strategy": res.strategy,
            "wall_time": wall,
            **system.describe(),
        },
        message=res.message,
        tolerances={"reltol": opts.reltol, "vntol": opts.vntol, "abstol": opts.abstol, "gmin": opts.gmin},
        notes=list(system.notes),
    )


def operating_point(circuit: Circuit, **overrides) -> Result:
    """Run ``.op`` on a circuit.

    Parameters
    ----------
    circuit : Circuit
    **overrides
        :class:`~netdae.dae.steady.SteadyOptions` fields (``reltol=...``).

    Returns
    -------
    Result
        ``analysis == "op"``, one value per unknown (``v(node)``, ``i(vsrc)``).

    Raises
    ------
    CircuitError, ConvergenceError

    Examples
    --------
    >>> from netdae.circuit import Circuit, Element, SourceSpec
    >>> ckt = Circuit("divider", nodes=["a", "b"], elements=[
    ...     Element("v1", "vsource", ("a", "0"), source=SourceSpec(dc=10.0)),
    ...     Element("r1", "resistor", ("a", "b"), 3e3),
    ...     Element("r2", "resistor", ("b", "0"), 1e3)])
    >>> r = operating_point(ckt)
    >>> round(float(r["v(b)"][0]), 12), round(float(r["i(v1)"][0]), 12)
    (2.5, -0.0025)
    """
    t0 = time.perf_counter()
    system = assemble(circuit, mode=MODE_DC)
    opts = steady_options(circuit, **overrides)
    res = solve_operating_point(system, options=opts)
    return op_result(system, res, time.perf_counter() - t0, opts)

