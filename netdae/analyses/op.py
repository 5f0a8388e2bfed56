"""The DC operating point (``.op``, and the start of every transient unless ``uic``).

Solves ``phi(x, t0) = 0`` of the MNA system (capacitors open, inductors
shorted) with :func:`netdae.dae.steady.solve_steady`, honouring ``.nodeset``
(initial guesses held for a first solve) and, for the operating point of a
transient, ``.ic`` (nodes held at their values through a 1e10 S conductance,
as ngspice does).

Nodes attached to the rest only through capacitors (a *charge group* of the
topological analysis) have no DC path to ground, so the DC matrix is
singular and ngspice stops ("singular matrix"); their operating point is
nevertheless well defined, because their total charge is conserved: netdae
replaces one current law of each group by "total charge = 0" (unless
``.ic`` holds a node of the group in a transient's operating point), checks
that the dropped current law holds (no net DC current into the group), and
says so in the result's notes.

A singular DC matrix is refused whatever the LU happened to produce: the
solver judges the equilibrated pivots and, when they are small, the rank by
an SVD (:func:`netdae.dae.steady.solve_steady`); the refusal names the
elements, by the topological analysis when the reason is topological, else
from the null spaces of the matrix.
"""

from __future__ import annotations

import contextlib
import contextvars
import time
from dataclasses import replace

import numpy as np

from ..circuit import Circuit
from ..devices.autodiff import leaves
from ..dae.kronecker import EPS
from ..dae.steady import ChargeGroup, Forcing, SteadyOptions, SteadyResult, solve_steady
from ..errors import CircuitError, ConvergenceError
from ..kinds import KINDS, Kind
from ..mna import MODE_DC, MnaSystem
from ..netlist.expr import Voltage
from ..results import Result, Statistics
from .prepared import Prepared, prepare

__all__ = ["steady_options", "solve_operating_point", "operating_point", "op_result", "charge_groups",
           "shared_operating_points", "circuit_operating_point"]

#: The kinds whose gains can make the DC equations dependent (named in the hint of a singular operating point).
_SOURCE_GROUPS = ("controlled sources", "charge-defined capacitors", "ideal op-amps")

#: Unknowns and elements named in a message about a singular DC matrix.
NAMED = 8


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


def _unheld_initial_conditions(circuit: Circuit, system: MnaSystem, forcing: Forcing, x,
                               unheld: np.ndarray) -> list[str]:
    """Warnings for ``.ic`` values the operating point could not hold (``unheld``: :func:`_unheld`'s mask).

    ngspice holds ``.ic`` nodes with a conductance, which a source's node overrides without a
    word; netdae says so rather than drop the value silently, at the ``.ic`` value, naming what
    fixes the node.
    """
    return [unheld_initial_condition(circuit, system.layout.target(int(i))[1], float(want), float(x[i]))
            for i, want in zip(forcing.index[unheld], forcing.value[unheld])]


def _unheld(forcing: Forcing, x, opts) -> np.ndarray:
    """Which forced values the solution ``x`` does not hold (a mask over ``forcing.index``)."""
    got = np.asarray(x)[forcing.index]
    return np.abs(got - forcing.value) > opts.reltol * np.maximum(np.abs(got), np.abs(forcing.value)) + opts.vntol


#: An ``.ic`` value the forcing conductance moved its node to within this fraction of where the circuit alone
#: puts it is held (the conductance carries the node's current); a source that fixes the node leaves it where
#: the circuit puts it (the fraction is 1).
HELD_FRACTION = 1e-3


def _overridden(forcing: Forcing, x_forced, x_free, unheld: np.ndarray) -> np.ndarray:
    """Which of the ``unheld`` forced values the circuit overrides (a mask over ``forcing.index``).

    ``x_forced`` is the solution with every value forced, ``x_free`` the one without the
    ``unheld`` ones: a value the forcing holds against a large current stays within
    :data:`HELD_FRACTION` of its distance from where the circuit alone puts the node.
    """
    want = forcing.value
    off_forced = np.abs(np.asarray(x_forced)[forcing.index] - want)
    off_free = np.abs(np.asarray(x_free)[forcing.index] - want)
    return unheld & ~(off_forced <= HELD_FRACTION * off_free)


def voltage_path(circuit: Circuit, node: str) -> list[str]:
    """The voltage-defining elements (V, E, H, B voltage sources, op-amp outputs) that tie ``node`` to ground.

    A shortest chain of such elements from the node to ground, in order from the
    node; empty when no chain reaches ground (the node's voltage is then not fixed by
    sources alone).

    Examples
    --------
    >>> from netdae.netlist import load
    >>> voltage_path(load("t\\nV1 a b 1\\nV2 b 0 2\\nR1 a c 1k\\nR2 c 0 1k\\n"), "a")
    ['v1', 'v2']
    >>> voltage_path(load("t\\nV1 a b 1\\nV2 b 0 2\\nR1 a c 1k\\nR2 c 0 1k\\n"), "c")
    []
    """
    from ..kinds import VOLTAGE

    return branch_path(circuit, node, "0", (VOLTAGE,))


def branch_path(circuit: Circuit, a: str, b: str, classes: tuple[int, ...], skip: str = "") -> list[str]:
    """A shortest chain from node ``a`` to node ``b`` of elements whose branches are of ``classes``.

    The elements in order from ``a``; ``skip`` is left out (the element whose own
    constraint is asked about); empty when no chain joins them. With ``VOLTAGE``
    alone: the sources that fix ``v(a) - v(b)``; with ``VOLTAGE`` and
    ``CAPACITIVE``: a loop of capacitors and sources that fixes a capacitor's
    voltage at a ``uic`` start.

    Examples
    --------
    >>> from netdae.kinds import CAPACITIVE, VOLTAGE
    >>> from netdae.netlist import load
    >>> c = load("t\\nV1 a 0 1\\nC1 a b 1u\\nC2 b 0 1u\\n")
    >>> branch_path(c, "a", "b", (VOLTAGE, CAPACITIVE), skip="c1")
    ['v1', 'c2']
    >>> branch_path(c, "a", "b", (VOLTAGE,))
    []
    """
    links: dict[str, list[tuple[str, str]]] = {}
    for el in circuit.elements:
        if el.name == skip:
            continue
        for cls, i, j in KINDS[el.kind].branches:
            if cls in classes and max(i, j) < len(el.nodes):
                ni, nj = el.nodes[i], el.nodes[j]
                links.setdefault(ni, []).append((el.name, nj))
                links.setdefault(nj, []).append((el.name, ni))
    came: dict[str, tuple[str, str] | None] = {a: None}
    queue = [a]
    for here in queue:
        if here == b:
            path = []
            while came[here] is not None:
                name, here = came[here]
                path.append(name)
            return path[::-1]
        for name, other in links.get(here, ()):
            if other not in came:
                came[other] = (name, here)
                queue.append(other)
    return []


def unheld_initial_condition(circuit: Circuit, node: str, want: float, got: float, when: str = "",
                             uic: bool = False) -> str:
    """The warning for an ``.ic v(node)=want`` the transient's start does not hold (it starts from ``got``).

    Located at the ``.ic`` value; names the sources that fix the node when there are,
    else the elements whose equations at the node decide its value.
    """
    where = circuit.ic_locations.get(node)
    text = f"{where}: " if where is not None else ""
    text += f".ic v({node})={want:g} is not held{when}: v({node}) = {got:.6g} at t = 0"
    path = voltage_path(circuit, node)
    if path:
        named = [f"{n} ({KINDS[circuit.element(n).kind].summary})" for n in path]
        text += (f", which {_names(named)} fix{'es' if len(path) == 1 else ''}"
                 f"{'' if len(path) == 1 else ' (in series from the node to ground)'}")
        sources = [n for n in path if KINDS[circuit.element(n).kind].independent]
        hint = f"drop the .ic of v({node})" + (f", or change {sources[0]}'s value" if sources else "")
    else:
        at = [el.name for el in circuit.elements if node in el.nodes]
        text += (f", which the circuit's equations fix there (no capacitor alone holds v({node}); elements at "
                 f"{node}: {_names(at)})")
        hint = "give .ic values only to nodes a capacitor holds" + (
            ", or leave out uic to start from the operating point" if uic else "")
    return f"warning: {text} (hint: {hint})"


def _describe_unknowns(system: MnaSystem, indices, x) -> str:
    return ", ".join(f"{system.names[i]} = {x[i]:.6g}" for i in indices)


def _names(items, limit: int = NAMED) -> str:
    items = list(items)
    return ", ".join(items[:limit]) + (f" and {len(items) - limit} more" if len(items) > limit else "")


def _support(v: np.ndarray) -> np.ndarray:
    """Indices carrying the weight of the null vectors (columns of v)."""
    if v.size == 0:
        return np.zeros(0, dtype=int)
    w = np.abs(v).max(axis=1) if v.ndim == 2 else np.abs(v)
    return np.flatnonzero(w > 1e-3 * w.max()) if w.size and w.max() > 0 else np.zeros(0, dtype=int)


def _row_names(system: MnaSystem, rows, parts: bool = False) -> list[str]:
    """Equations by name: the current law of a node, or the equation of an element's branch (with ``parts``, a
    realised element's internal node or branch by its bare name, for :func:`_collapse_parts`)."""
    out = []
    for i in rows:
        what, name = system.layout.target(int(i))
        if parts and "#" in name:
            out.append(name)
        else:
            out.append(f"the current law at node '{name}'" if what == "node" else f"the equation of {name}")
    return out


def _involved_elements(circuit: Circuit, system: MnaSystem, unknowns) -> list[str]:
    """Elements owning a branch among the unknowns, or touching (or sensing) one of their nodes.

    A device's own unknowns (``d1#internal``, an OSDI instance's ``n1#c`` and its
    flows ``n1#br``) are on no element's card: the device that made them is named.
    """
    targets = [system.layout.target(int(i)) for i in unknowns]
    nodes = {name for what, name in targets if what == "node"}
    branches = {name for what, name in targets if what == "branch"}
    owners = {name.split("#", 1)[0] for name in nodes & system.layout.internal}
    owners |= {name.split("#", 1)[0] for name in branches if "#" in name}
    out = []
    for el in circuit.elements:
        if el.name in branches or el.name in owners or nodes.intersection(el.nodes) \
                or branches.intersection(el.controls) or nodes.intersection(el.controls):
            out.append(el.name)
    return out


def _undetermined(res: SteadyResult) -> np.ndarray:
    """The unknowns a singular solve leaves undetermined (the support of its right null vectors)."""
    if res.rank is not None:
        return _support(res.rank.right)
    return _support(res.null_vector) if res.null_vector is not None else np.zeros(0, dtype=int)


def _topological_reason(circuit: Circuit, system: MnaSystem, res: SteadyResult, topo):
    """The topological analysis's explanation of a singular solve (None when it has none)."""
    from ..topology import dc_singularity_explanation

    undetermined = _undetermined(res)
    signal = system.names[undetermined[0]] if undetermined.size else None
    return dc_singularity_explanation(circuit, signal, report=topo)


def _is_certain(found, topo) -> bool:
    """The topology's explanation ``found`` holds for any element values (it relies on no controlled source)."""
    return found is not None and not any(f.controlled and f.message == found.message for f in topo.findings)


def _is_flux_loop(found, topo) -> bool:
    """The topology's explanation ``found`` is a loop of inductors alone, whose flux is conserved (a note)."""
    return found is not None and any(f.kind == "dc_loop" and f.severity == "note" and f.message == found.message
                                     for f in topo.findings)


#: A right null vector ``v`` of a singular DC matrix ``J`` (unit largest entry) whose currents ``|J v|`` exceed this
#: many roundings of the matrix (``eps * max|J|``) is not a dependence but a weak hold: nodes that move together
#: against junction leakage and gmin, next to conductances that rounding cannot resolve them against.
WEAK_HOLD_ROUNDINGS = 10.0


def _weak_hold(system: MnaSystem, res: SteadyResult, t: float) -> tuple[float, float] | None:
    """``(A per volt, largest conductance)`` when the one undetermined direction of a singular solve is held by
    currents well above rounding (:data:`WEAK_HOLD_ROUNDINGS`), else None.

    An H-bridge with every switch off (nodes between reverse-biased body diodes with 0.01 ohm series resistances):
    the rank decision calls the DC matrix singular (smallest singular value 1.2e-14 against a tolerance of 2.6e-14),
    yet moving those nodes together changes their currents by 2e-12 A per volt, 100 times what rounding makes of a
    matrix with 100 S entries: the equations are not dependent, their solution is only lost to rounding.
    """
    rank = res.rank
    if rank is None or rank.right.ndim != 2 or rank.right.shape[1] != 1 or res.x is None:
        return None
    v = np.asarray(rank.right[:, 0], dtype=float)
    top = np.abs(v).max(initial=0.0)
    if not top > 0.0:
        return None
    v = v / top
    try:
        ev = system.evaluate(np.asarray(res.x, dtype=float), t, jacobian=True)
    except (ArithmeticError, ValueError):
        return None
    if not (ev.ok and np.all(np.isfinite(ev.dphi))):
        return None
    J = system.pattern.matrix(ev.dphi)
    largest = float(np.abs(ev.dphi).max(initial=0.0))
    held = float(np.abs(J @ v).max(initial=0.0))
    if not largest > 0.0 or held <= WEAK_HOLD_ROUNDINGS * EPS * largest:
        return None
    return held, largest


def _singular_error(circuit: Circuit, system: MnaSystem, res: SteadyResult, topo, t: float = 0.0) -> CircuitError:
    """The best explanation of a singular DC matrix, in circuit terms, naming the elements.

    ``system`` is the circuit's steady form, ``topo`` its topological analysis, ``t`` the time of its sources.
    """
    rank = res.rank
    evidence = ""
    if rank is not None:
        dropped = rank.decision.dropped[0] if rank.decision.dropped else 0.0
        evidence = (f" (the DC matrix has rank {rank.rank} of {system.n}: smallest singular value {dropped:.3g} "
                    f"<= tolerance {rank.decision.tol:.3g} of the balanced matrix)")
    undetermined = _undetermined(res)
    found = _topological_reason(circuit, system, res, topo)
    if _is_certain(found, topo):
        return found
    if found is not None:  # a structural reason that relies on controlled sources, confirmed numerically
        text = found.message
        for prefix in ("DC operating point likely singular (controlled sources): ", "likely singular "):
            if text.startswith(prefix):
                text = text[len(prefix):]
                text = text.split("): ", 1)[1] if prefix == "likely singular " and "): " in text else text
        return CircuitError(f"DC operating point singular{evidence}: {text}", elements=found.elements,
                            nodes=found.nodes, hint=found.hint)
    if not undetermined.size:
        return CircuitError(
            "the DC operating-point matrix is singular" + evidence,
            hint="look for a node without DC path to ground, a loop of voltage sources/inductors, "
            "or a cutset of current sources/capacitors",
        )
    dependent = _support(rank.left) if rank is not None else np.zeros(0, dtype=int)
    elements = _involved_elements(circuit, system, np.union1d(undetermined, dependent))
    controlled = [e for e in elements if KINDS[circuit.element(e).kind].group in _SOURCE_GROUPS]
    weak = _weak_hold(system, res, t)
    if weak is not None:
        held, largest = weak
        k = undetermined.size
        text = (f"no DC operating point netdae can trust{evidence}: {_names(system.names[i] for i in undetermined)} "
                f"{'moves' if k == 1 else 'move together'} against only about {held:.2g} A per volt (junctions in "
                f"reverse, gmin), while conductances up to {largest:.3g} S act among {'it' if k == 1 else 'them'}: "
                "a matrix too close to singular for its rank decision to trust the solution; elements involved: "
                f"{_names(elements)}")
        targets = [system.layout.target(int(i)) for i in undetermined]
        return CircuitError(text, elements=tuple(elements),
                            nodes=tuple(name for what, name in targets if what == "node"),
                            hint="give these nodes a DC path to ground (a resistor, e.g. 1G), raise .options gmin "
                            "(e.g. 1e-10), or start the transient with uic")
    text = f"no unique DC operating point{evidence}: {_names(system.names[i] for i in undetermined)} " \
        f"{'is' if undetermined.size == 1 else 'are'} undetermined"
    if dependent.size:
        text += f", because {_names(_row_names(system, dependent))} " \
            f"{'depends on the other equations' if dependent.size == 1 else 'are dependent'}"
    text += f"; elements involved: {_names(elements)}"
    hint = ("the controlled sources " + _names(controlled) + " close a loop or cutset whose gains make the "
            "equations dependent: change a gain, or add a resistance that breaks the loop or a path to ground"
            if controlled else "look for a node without DC path to ground, a loop of voltage sources/inductors, "
            "or a cutset of current sources among these elements")
    targets = [system.layout.target(int(i)) for i in undetermined]
    return CircuitError(text, elements=tuple(elements), nodes=tuple(name for what, name in targets if what == "node"),
                        hint=hint)


def fatal_messages(circuit: Circuit, levels: tuple[str, ...] = ("fatal", "error")) -> str:
    """``"; n1 (OSDI) said: ..."``: the errors an OSDI module logged (``$fatal``, ``$error``), else ``""``.

    A module's ``$fatal`` stops its evaluation as a non-finite value does;
    what it said is the reason, so the failure's message quotes it (the last
    of each instance). The messages stay for the result's notes.
    """
    if not any(el.kind == Kind.OSDI for el in circuit.elements):
        return ""
    from ..devices.osdi.library import peek_messages

    last: dict[str, str] = {}
    for who, level, text in peek_messages():
        if level in levels and text.strip():
            last[who] = f"{level}: {text.strip()}"
    return "".join(f"; {who} (OSDI) said {text}" for who, text in list(last.items())[:NAMED])


def _not_finite_error(circuit: Circuit, system: MnaSystem, res: SteadyResult) -> ConvergenceError:
    """The solve stopped where the circuit's equations are not finite: which equations, which elements, where."""
    rows = res.not_finite
    where = ("at the initial guess, before any Newton iteration" if res.iterations == 0 else
             f"at the iterate reached after {res.iterations} Newton iterations")
    text = f"operating point: the circuit equations are not finite {where}"
    shown = list(rows)
    if rows.size:
        elements = _involved_elements(circuit, system, rows)
        text += f" ({_names(_row_names(system, rows))}; elements there: {_names(elements)})"
        for name in elements:  # the voltages these elements read
            el = circuit.element(name)
            read = [*el.nodes, *el.controls]
            if el.expr is not None:
                read += [n for leaf in leaves(el.expr) if isinstance(leaf, Voltage) for n in (leaf.pos, leaf.neg)]
            for node in read:
                try:
                    i = system.node_index(node) if node else -1
                except KeyError:  # an element name among the controls
                    continue
                if i >= 0 and i not in shown:
                    shown.append(i)
    text += (", so Newton, gmin stepping, source stepping and pseudo-transient continuation stopped"
             + (f"; values there: {_describe_unknowns(system, shown[:2 * NAMED], res.x)}" if shown else "")
             + fatal_messages(circuit))
    return ConvergenceError(
        text, worst=system.names[rows[0]] if rows.size else None,
        hint="an expression of these elements divides by zero, or takes the square root or logarithm of a "
        "negative number, at these values (or a model overflows); a .nodeset that avoids such values helps",
    )


def charge_groups(system: MnaSystem, topo, held: np.ndarray | None = None) -> tuple[list[ChargeGroup], list]:
    """The charge groups of the circuit as rows of the system, skipping groups with a held node.

    Parameters
    ----------
    system : MnaSystem
    topo : TopologyReport
    held : ndarray of int, optional
        Unknowns held by ``.ic`` (their group is fixed by the forcing).

    Returns
    -------
    groups : list of ChargeGroup
        Rows (the nodes' current laws) and zero total charge.
    node_groups : list of NodeGroup
        The topological groups used, in the same order.
    """
    held_set = set(() if held is None else held.tolist())
    out, used = [], []
    for grp in topo.charge_groups:
        rows = np.array([system.node_index(nd) for nd in grp.nodes], dtype=np.int64)
        rows = rows[rows >= 0]
        if rows.size and not held_set.intersection(rows.tolist()):
            out.append(ChargeGroup(rows, 0.0))
            used.append(grp)
    return out, used


def _charge_note(grp) -> str:
    k = len(grp.nodes)
    nodes = ", ".join(f"'{nd}'" for nd in grp.nodes)
    caps = [e for e in grp.elements]
    return (f"{'node' if k == 1 else 'nodes'} {nodes} {'has' if k == 1 else 'have'} no DC path to ground "
            f"(attached only through {_names(caps)}): {'its' if k == 1 else 'their'} operating point follows from "
            "charge conservation, total charge zero at t = 0")


def _imbalances(system: MnaSystem, res: SteadyResult, groups: list[ChargeGroup], t: float,
                opts: SteadyOptions) -> list[float | None]:
    """Per group, the net DC current into its (weighted) rows at the solution where it exceeds their
    tolerance (``reltol`` of the rows' terms plus ``abstol`` a row, weighted), else None: the dropped
    equation of a charge group or conservation law must hold."""
    ev = system.evaluate(res.x, t, jacobian=True)
    scale = system.pattern.matrix(np.abs(ev.dphi)) @ np.abs(res.x) + np.abs(ev.phi)
    out = []
    for g in groups:
        w = g.row_weights()
        net = float(w @ ev.phi[g.rows])
        aw = np.abs(w)
        out.append(net if abs(net) > opts.reltol * float(aw @ scale[g.rows]) + opts.abstol * float(aw.sum()) else None)
    return out


def _check_charge_balance(circuit: Circuit, system: MnaSystem, res: SteadyResult, groups, used, t: float,
                          opts: SteadyOptions) -> None:
    """The dropped current law of each charge group must hold: no net DC current into the group."""
    for net, ng in zip(_imbalances(system, res, groups, t, opts), used):
        if net is not None:
            sources = [e for e in ng.elements if KINDS[circuit.element(e).kind].stores != "charge"]
            k = len(ng.nodes)
            raise CircuitError(
                f"no DC operating point: {_names(sources) or 'the sources'} "
                f"{'drives' if len(sources) == 1 else 'drive'} a net DC current of {net:.6g} A "
                f"into {'node' if k == 1 else 'nodes'} {', '.join(repr(n) for n in ng.nodes)}, which "
                f"{'is' if k == 1 else 'are'} attached to the rest only through {_names(ng.elements)}: "
                "the charge there grows without bound",
                elements=ng.elements, nodes=ng.nodes,
                hint=f"add a resistor from node '{ng.nodes[0]}' to ground, or start the transient with uic",
            )


#: A weight of a conservation law below this fraction of its largest is rounding (left out).
LAW_WEIGHT_FLOOR = 1e-12
#: The conservation laws carry charge independently when the smallest singular value of their charge
#: rows ``Y^T E`` is above this fraction of the largest.
LAW_CHARGE_RTOL = 1e-8


def conservation_laws(system, res: SteadyResult, t: float, groups: list[ChargeGroup],
                      forcing: Forcing | None, *, fluxes: bool = False) -> list[ChargeGroup]:
    """Conservation laws that fix an operating point the DC equations leave undetermined.

    When the DC Jacobian is singular with left null vectors ``Y`` (``Y^T dphi/dx = 0``: a
    combination of the equations adds up to zero, as controlled sources make the current laws of
    a network attached to the rest only through capacitors and those sources dependent) and the
    same combinations of the charges are independent (``Y^T dq/dx`` of full rank), then
    ``d/dt (Y^T q) = Y^T phi = 0``: the combinations of the charges are conserved, and, as for a
    group of nodes attached only through capacitors (:func:`charge_groups`), their values at
    t = 0 (zero) pick the operating point. The null vectors are made unit at pivot rows chosen
    by a column-pivoted QR among the rows of no charge group and no ``.ic`` (a law weighing a
    row that a group or ``.ic`` replaced, or that the free rows cannot carry, is not made).

    Parameters
    ----------
    system : MnaSystem
        The steady form solved.
    res : SteadyResult
        A singular solve, with its rank decision (``res.rank``: up to the dense SVD's limit).
    t : float
    groups : list of ChargeGroup
        The topological charge groups already in the solve.
    forcing : Forcing or None
    fluxes : bool
        Count the inductors' fluxes among the conserved quantities (a loop of inductors alone,
        whose branch equations add up to zero at DC: the topology found one); else a
        combination that weighs a flux is refused, as ngspice's singular matrix.

    Returns
    -------
    list of ChargeGroup
        One per null vector, weighted; empty when the rank is unknown or some combination
        carries no charge (the equations are then undetermined for good).

    Notes
    -----
    Cost: one evaluation, a product with the sparse ``dq`` and a QR and an SVD of ``d x n``
    matrices (``d`` the rank deficiency).
    """
    import scipy.linalg

    rank = res.rank
    if rank is None or rank.left.ndim != 2 or rank.left.shape[1] == 0:
        return []
    Y = np.asarray(rank.left, dtype=float)
    d = Y.shape[1]
    replaced = np.zeros(system.n, dtype=bool)  # rows that are charge balances in the solve, not equations
    taken = np.zeros(system.n, dtype=bool)  # rows a law may not replace
    for g in groups:
        replaced[int(g.rows[0])] = True
        taken[np.asarray(g.rows, dtype=np.int64)] = True
    if forcing is not None:
        replaced[forcing.index] = True
        taken[forcing.index] = True
    if np.any(np.abs(Y[replaced]) > LAW_WEIGHT_FLOOR * np.abs(Y).max()):
        return []
    ev = system.evaluate(res.x, t, jacobian=True)
    E = system.pattern.matrix(ev.dq)
    if getattr(system, "line_charge", None) is not None:  # what transmission lines hold at DC
        E = E + system.line_charge
    nodes = np.asarray(system.kinds) == 0
    YE = np.asarray((E.T @ np.where(nodes[:, None], Y, 0.0)).T)  # the node charges of the combinations
    flux = np.asarray((E.T @ np.where(nodes[:, None], 0.0, Y)).T)  # the inductor fluxes
    if fluxes:
        YE = YE + flux  # the conserved quantities: charges and fluxes together
    sv = np.linalg.svd(YE, compute_uv=False)
    if not sv.size or not np.isfinite(sv).all() or sv[0] == 0.0 or sv[-1] <= LAW_CHARGE_RTOL * sv[0]:
        return []
    if not fluxes and np.abs(flux).max(initial=0.0) > LAW_CHARGE_RTOL * np.abs(YE).max():
        return []  # a loop of inductors: a conserved flux, not charge (refused, as ngspice's singular matrix)
    _, R, order = scipy.linalg.qr(np.where(taken[None, :], 0.0, Y.T), mode="economic", pivoting=True)
    pivots = order[:d]
    if np.abs(R[d - 1, d - 1]) <= LAW_CHARGE_RTOL * np.abs(R[0, 0]):
        return []  # the free rows cannot carry every law
    W = Y @ np.linalg.inv(Y[pivots])
    laws = []
    for k in range(d):
        col = W[:, k]
        rows = np.flatnonzero(np.abs(col) > LAW_WEIGHT_FLOOR * np.abs(col).max())
        rows = np.concatenate([[pivots[k]], rows[rows != pivots[k]]]).astype(np.int64)
        laws.append(ChargeGroup(rows, 0.0, col[rows]))
    return laws


def _check_law_balance(circuit: Circuit, system: MnaSystem, res: SteadyResult, laws: list[ChargeGroup], t: float,
                       opts: SteadyOptions, singular: SteadyResult, topo) -> None:
    """The dropped equation of each conservation law must hold: no net DC "current" into its combination.

    Raises
    ------
    CircuitError
        Where one does not: with the topology's explanation of the ``singular`` solve when it
        has one (a node attached only through capacitors and controlled sources), else naming
        the equations and the net current.
    """
    for net, law in zip(_imbalances(system, res, laws, t, opts), laws):
        if net is not None:
            if _topological_reason(circuit, system, singular, topo) is not None:
                raise _singular_error(circuit, system, singular, topo, t)
            elements = _involved_elements(circuit, system, law.rows)
            raise CircuitError(
                f"no DC operating point: {_names(_row_names(system, law.rows))} are dependent at DC, and the "
                f"sources drive a net DC current of {net:.6g} A into their combination, whose charge "
                f"(attached only through capacitors and controlled sources) then grows without bound; "
                f"elements involved: {_names(elements)}",
                elements=tuple(elements),
                hint="add a resistance to ground from the nodes of these elements, or start the transient with uic",
            )


def _collapse_parts(names: list[str], what: str) -> list[str]:
    """Names of the parts of realised elements (``p1#va_1``: a coupled line's sections, docs/netlist.md) counted
    under their element; other names as they are."""
    out, parts = [], {}
    for nm in names:
        owner, sep, _ = nm.partition("#")
        if sep:
            if owner not in parts:
                parts[owner] = 0
                out.append(owner)
            parts[owner] += 1
        else:
            out.append(nm)
    return [f"{parts[nm]} {what} of {nm}'s realisation" if nm in parts else nm for nm in out]


def _law_note(circuit: Circuit, system: MnaSystem, laws: list[ChargeGroup]) -> str:
    rows = np.unique(np.concatenate([law.rows for law in laws]))
    elements = _involved_elements(circuit, system, rows)
    equations = _row_names(system, rows, parts=True)
    k = len(laws)
    lines = " (with the charge the transmission lines hold)" if getattr(system, "line_charge", None) is not None \
        else ""
    branches = np.asarray(system.kinds)[rows] != 0
    if branches.all():  # inductors' branch equations: a loop of inductors
        inductors = [name for what, name in (system.layout.target(int(i)) for i in rows) if what == "branch"]
        return (f"the DC equations ({_names(_collapse_parts(equations, 'equations'))}) are dependent (at DC the "
                f"inductors are shorts, and {_names(_collapse_parts(inductors, 'parts'))} form "
                f"{'a loop' if k == 1 else f'{k} loops'}), and the total flux around "
                f"{'it' if k == 1 else 'each'} is conserved: the operating point follows from flux conservation, "
                "total flux zero at t = 0")
    what = "the charges and fluxes" if branches.any() else "the charges"
    return (f"the DC equations ({_names(_collapse_parts(equations, 'equations'))}) are dependent (elements "
            f"involved: {_names(_collapse_parts(elements, 'parts'))}), and "
            f"{'a combination' if k == 1 else f'{k} combinations'} of {what} there "
            f"{'is' if k == 1 else 'are'} conserved{lines}: the operating point follows from charge conservation, "
            "total charge zero at t = 0")


def solve_operating_point(prepared: Prepared, *, t: float = 0.0, transient: bool = False,
                          options: SteadyOptions | None = None, x0: np.ndarray | None = None,
                          nodesets: bool = True) -> SteadyResult:
    """Operating point of an assembled circuit.

    Parameters
    ----------
    prepared : Prepared
        The circuit, its system (:func:`~netdae.analyses.prepared.prepare`)
        and its topology (which fixes the groups of nodes attached only
        through capacitors, and explains a singular matrix).
    t : float
        Time at which sources are evaluated (0 for the start of a transient).
    transient : bool
        This operating point starts a transient: ``.ic`` values are forced.
    options : SteadyOptions, optional
        Defaults from the circuit's ``.options``.
    x0 : ndarray, optional
        Initial guess (continuation in sweeps).
    nodesets : bool
        Apply the circuit's ``.nodeset`` values (default). A ``.dc`` sweep's point solved from the
        previous point's solution does not, as ngspice's sweep does not (its nodesets act in the
        junction-initialisation modes only, ``MODEINITJCT``/``MODEINITFIX``: the first point and a
        point solved again from scratch).

    Returns
    -------
    SteadyResult
        Converged; ``notes`` says which node groups were fixed by charge
        conservation.

    Raises
    ------
    CircuitError
        When the DC matrix is singular (with the topological reason, or the
        undetermined unknowns and the elements involved), or when a group
        attached only through capacitors receives a net DC current.
    ConvergenceError
        When Newton, gmin stepping, source stepping and pseudo-transient continuation all fail; names the
        unknowns that did not settle and their last values.
    """
    circuit = prepared.circuit
    system = prepared.system.steady_form()  # transmission lines join their ports at DC
    topology = prepared.topology
    opts = options or steady_options(circuit)
    forcing = _node_forcing(system, circuit.ic, ".ic") if transient else None
    nodeset = _node_forcing(system, circuit.nodeset, ".nodeset") if nodesets else None
    groups, used = charge_groups(system, topology, None if forcing is None else forcing.index)
    res = solve_steady(system, t, x0, options=opts, forcing=forcing, nodeset=nodeset, charges=groups)
    laws: list[ChargeGroup] = []
    found = _topological_reason(circuit, system, res, topology) if res.singular else None
    loop = _is_flux_loop(found, topology)
    if res.singular and (loop or not _is_certain(found, topology)):
        laws = conservation_laws(system, res, t, groups, forcing, fluxes=loop)
        if laws:
            again = solve_steady(system, t, x0, options=opts, forcing=forcing, nodeset=nodeset,
                                 charges=groups + laws)
            if again.converged:
                _check_law_balance(circuit, system, again, laws, t, opts, res, topology)
                res = again
            else:
                laws = []
    if res.converged:
        if groups:
            _check_charge_balance(circuit, system, res, groups, used, t, opts)
        res.notes = [_charge_note(g) for g in used] + ([_law_note(circuit, system, laws)] if laws else [])
        if forcing is not None:
            unheld = _unheld(forcing, res.x, opts)
            forced = res
            if unheld.any():
                # The forcing conductance of a value the circuit overrides carries (value - v) * 1e10 A into
                # the source that fixes the node (5e10 A into an op-amp's output for .ic 5 V against 0 V):
                # the transient would start from that current. Solved again without those values.
                keep = ~unheld
                held = Forcing(forcing.index[keep], forcing.value[keep]) if keep.any() else None
                again = solve_steady(system, t, res.x, options=opts, forcing=held, nodeset=nodeset,
                                     charges=groups + laws)
                if again.converged:
                    # a value the forcing moved its node to, against a large current (a capacitor's node fed by
                    # 2e4 A stops 2 uV short of .ic 0 V), is held: the circuit alone puts the node elsewhere
                    # (2e16 V through 1e12 ohm), a source that fixes the node puts it where the forcing did
                    overridden = _overridden(forcing, forced.x, again.x, unheld)
                    if overridden.sum() < unheld.sum():
                        unheld = overridden
                        keep = ~unheld
                        held = Forcing(forcing.index[keep], forcing.value[keep]) if keep.any() else None
                        again = (solve_steady(system, t, res.x, options=opts, forcing=held, nodeset=nodeset,
                                              charges=groups + laws) if unheld.any() else forced)
                    if again.converged:
                        again.notes = res.notes
                        res = again
            res.notes = list(res.notes) + _unheld_initial_conditions(circuit, system, forcing, forced.x, unheld)
        return res
    if res.singular:
        raise _singular_error(circuit, system, res, topology, t)
    if res.not_finite is not None:
        raise _not_finite_error(circuit, system, res)
    worst = _describe_unknowns(system, res.worst, res.x)
    raise ConvergenceError(
        f"operating point did not converge after {res.iterations} Newton iterations "
        f"(plain Newton, gmin stepping, source stepping, pseudo-transient continuation); last values: {worst}",
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
        stats=Statistics(newton_iterations=res.iterations, factorizations=res.factorizations,
                         strategy=res.strategy, wall_time=wall, **system.describe()),
        message=res.message,
        tolerances={"reltol": opts.reltol, "vntol": opts.vntol, "abstol": opts.abstol, "gmin": opts.gmin},
        notes=list(system.notes) + list(res.notes),
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
    prepared = prepare(circuit, mode=MODE_DC)
    opts = steady_options(circuit, **overrides)
    res = circuit_operating_point(prepared, opts)
    return op_result(prepared.system, res, time.perf_counter() - t0, opts)


#: The operating points solved inside :func:`shared_operating_points` (None outside one).
_SHARED: contextvars.ContextVar[dict | None] = contextvars.ContextVar("netdae_shared_operating_points",
                                                                     default=None)


@contextlib.contextmanager
def shared_operating_points():
    """Within the block, a circuit's own DC operating point is solved once per tolerances.

    ``.op``, ``.ac``, ``.noise``, ``.tf``, ``.pz`` and ``.sens`` of one netlist
    each solve the same problem: the circuit assembled with its DC source
    values (``prepare(circuit, mode=MODE_DC)``), from the same initial guess,
    at the same tolerances. The solution is a function of those alone, so
    :func:`circuit_operating_point` hands the later analyses the first one's
    (its unknowns copied), value for value what they would compute. A
    circuit with switches is solved every time: a solve leaves the switch
    states in its system, which the linearisation reads.
    :func:`netdae.analyses.runner.run` runs a netlist's analyses inside one
    block; a circuit whose operating point needs gmin or source stepping
    (seconds in Python) pays it once instead of once per analysis.
    """
    token = _SHARED.set({})
    try:
        yield
    finally:
        _SHARED.reset(token)


def circuit_operating_point(prepared: Prepared, opts: SteadyOptions) -> SteadyResult:
    """The operating point of a circuit as elaborated (its DC source values), shared within a block.

    Parameters
    ----------
    prepared : Prepared
        ``prepare(circuit, mode=MODE_DC)``, its sources untouched.
    opts : SteadyOptions

    Returns
    -------
    SteadyResult
        :func:`solve_operating_point`'s, or inside :func:`shared_operating_points`
        the one solved there for the same circuit object and tolerances (a
        copy: its ``x`` is the caller's).
    """
    store = _SHARED.get()
    if store is None or prepared.system.switching is not None:
        return solve_operating_point(prepared, options=opts)
    key = (id(prepared.circuit), repr(opts))
    entry = store.get(key)
    if entry is None or entry[0] is not prepared.circuit:
        entry = store[key] = (prepared.circuit, solve_operating_point(prepared, options=opts))
    res = entry[1]
    return replace(res, x=res.x.copy(), notes=list(res.notes))

