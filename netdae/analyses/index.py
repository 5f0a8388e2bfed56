"""Index analysis of a circuit: the pencil, its Kronecker structure, and why, in circuit terms.

:func:`analyze_index` combines two independent views of the DAE
``E x' = H x + c(t)`` (linearised at the operating point for nonlinear
circuits, ``H = dphi/dx``):

- the *numerical* structure of the pencil (:mod:`netdae.dae.pencil`):
  regularity, nilpotency index, infinite Jordan blocks, dynamic states and
  finite eigenvalues (the circuit's poles), the per-unknown classification
  (differential, algebraic, index-2, ...), every rank decision with its
  tolerance; dense O(n^3), used up to :data:`~netdae.dae.pencil.DENSE_LIMIT`
  unknowns;
- the *topological* analysis (:mod:`netdae.topology`): V-loops, I-cutsets,
  CV-loops, LI-cutsets, nodes without DC path, named by element; the index
  it implies when the theorem of Estévez Schwarz and Tischendorf applies
  (independent sources and passive elements only).

Above the dense limit the report rests on the topology alone, says so in
``method``, and gives an index only when the theorem applies.

Where the pencil is taken: a linear circuit's pencil is the same at every
point, so no operating point is computed (the index of a linear circuit
never depends on one). A nonlinear circuit is linearised at its DC
operating point (``at="op"``) or at the transient's initial point
(``at="t0"``); when that point cannot be computed (a singular DC matrix, no
convergence) the analysis falls back to the transient's initial point and
then to the point the netlist gives (``.ic``/``.nodeset`` node voltages,
zero elsewhere), and ``IndexReport.point`` and the messages say which.

Consistency: the transient's initial point (the DC operating point at t0,
or the ``uic`` values) is checked against the explicit and hidden
constraints ``z(t0) = -sum N^l theta^(l)(t0)`` of the decoupled form (2.12).
When that point does not exist the check is skipped and a message says why.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..circuit import STAMP_MAGNITUDES, Circuit, TranAnalysis
from ..dae.algebraic import GROUP_LIMIT, AlgebraicPart, algebraic_part
from ..dae.pencil import DENSE_LIMIT, PencilReport, analyze_pencil
from ..errors import CircuitError, ConvergenceError, NetdaeError
from ..mna import MODE_DC, MODE_TRAN, MnaSystem, assemble
from .prepared import Prepared, prepare

__all__ = ["IndexReport", "analyze_index", "index_of_unknowns", "LABEL_DIFFERENTIAL", "LABEL_ALGEBRAIC"]

LABEL_DIFFERENTIAL = "differential"
LABEL_ALGEBRAIC = "algebraic"


@dataclass
class IndexReport:
    """What kind of DAE a circuit is, with evidence.

    Attributes
    ----------
    regular : bool or None
        The pencil is regular (None when the topology could not decide).
    index : int or None
        Nilpotency index of the linearisation (None: singular, or unknown
        above the dense limit when the topological theorem does not apply).
    method : str
        ``"kronecker"`` (numerical, exact at the tolerance), ``"topological"`` or ``"sparse"`` (the
        algebraic part at the point, :func:`netdae.dae.algebraic.algebraic_part`: index and index-2 unknowns
        only).
    n_unknowns : int
    n_dynamic : int or None
        Number of finite eigenvalues (dynamic states).
    rank_E : int or None
    infinite_blocks : list of int
        Sizes of the nilpotent Jordan blocks (descending).
    finite_eigenvalues : ndarray of complex
        The circuit's natural frequencies [1/s] (poles).
    tolerance : dict
        Rank-decision tolerances (relative and absolute).
    unknowns : dict of str to str
        Signal name to ``"differential"``, ``"algebraic"``, ``"index2"``, ...
    derivative_order : dict of str to int
        Highest input derivative each unknown depends on.
    topology : TopologyReport
    consistency : ConsistencyReport or None
        Check of the transient's initial point (when the netlist has ``.tran``).
    at : str
        ``"op"`` (linearised at the DC operating point) or ``"t0"`` (at the
        initial point of the transient): what was asked.
    point : str
        Where the pencil was actually taken, in words (a linear circuit needs
        no point; a fallback when the requested point does not exist).
    messages : list of str
        The diagnosis, most important first.
    pencil : PencilReport or None
    system : MnaSystem
    x : ndarray
        The linearisation point.
    wall_time : float
    algebraic : AlgebraicPart or None
        The sparse analysis of the algebraic part, where it was made.
    """

    regular: bool | None
    index: int | None
    method: str
    n_unknowns: int
    n_dynamic: int | None
    rank_E: int | None
    infinite_blocks: list[int]
    finite_eigenvalues: np.ndarray
    tolerance: dict
    unknowns: dict[str, str]
    derivative_order: dict[str, int]
    topology: Any
    consistency: Any
    at: str
    messages: list[str] = field(default_factory=list)
    point: str = ""
    pencil: PencilReport | None = None
    system: MnaSystem | None = None
    x: np.ndarray | None = None
    wall_time: float = 0.0
    algebraic: AlgebraicPart | None = None

    @property
    def consistent_initial_values(self) -> bool | None:
        """Whether the transient's initial point satisfies every constraint (None: not checked)."""
        return None if self.consistency is None else bool(self.consistency.consistent)

    def to_dict(self) -> dict:
        """The JSON document of ``netdae index --json``."""
        topo = self.topology.to_dict() if self.topology is not None else {}
        return {
            "regular": self.regular,
            "index": self.index,
            "method": self.method,
            "at": self.at,
            "point": self.point,
            "n_unknowns": self.n_unknowns,
            "n_dynamic": self.n_dynamic,
            "rank_E": self.rank_E,
            "infinite_blocks": list(self.infinite_blocks),
            "finite_eigenvalues": [[float(z.real), float(z.imag)] for z in self.finite_eigenvalues],
            "tolerance": self.tolerance,
            "unknowns": dict(self.unknowns),
            "derivative_order": dict(self.derivative_order),
            "topology": {
                "v_loops": [lp["elements"] for lp in topo.get("v_loops", [])],
                "i_cutsets": [cs["elements"] for cs in topo.get("i_cutsets", [])],
                "cv_loops": [lp["elements"] for lp in topo.get("cv_loops", [])],
                "li_cutsets": [cs["elements"] for cs in topo.get("li_cutsets", [])],
                # floating: no connection to ground at all (a singular pencil); a node set without a DC
                # path (a capacitive divider's middle node, an integrator's output) is no reason for a
                # singular pencil and is listed apart
                "floating_nodes": [g["nodes"] for g in topo.get("floating_groups", [])],
                "no_dc_path": [g["nodes"] for g in topo.get("no_dc_path", [])],
                "applicable": topo.get("applicable"),
                "topological_index": topo.get("topological_index"),
                "findings": topo.get("findings", []),
            },
            "consistent_initial_values": self.consistent_initial_values,
            "consistency": None
            if self.consistency is None
            else self.consistency.to_dict(list(self.system.names) if self.system is not None else None),
            "evidence": [] if self.pencil is None else [d.to_dict() for d in self.pencil.evidence],
            "warnings": [] if self.pencil is None else list(self.pencil.warnings),
            # the structure undecided in double precision, and what exact arithmetic said (docs/index-theory.md)
            "disputed": self.pencil is not None and self.pencil.disputed,
            "exact": None if self.pencil is None else self.pencil.exact_dict(),
            "messages": list(self.messages),
            "wall_time": self.wall_time,
        }


def index_of_unknowns(report: IndexReport) -> np.ndarray:
    """Per-unknown index for the integrator's error control: 1 + highest input derivative.

    Differential and algebraic unknowns get 1, index-2 unknowns 2, and so on.
    """
    names = report.system.names
    return np.array([1 + report.derivative_order.get(nm, 0) for nm in names], dtype=np.int64)


#: How IndexReport.point names each place the pencil can be taken.
POINT_LINEAR = "linear circuit: the pencil is the same at every point, no operating point needed"
POINT_OP = "the DC operating point"
POINT_T0 = "the transient's initial point"
POINT_GIVEN = "the given point"
POINT_NETLIST = "the netlist's .ic/.nodeset node voltages (zero elsewhere)"


def _netlist_point(circuit: Circuit, system: MnaSystem) -> np.ndarray:
    """Node voltages from ``.nodeset`` then ``.ic`` (zero elsewhere)."""
    x = np.zeros(system.n)
    for values in (circuit.nodeset, circuit.ic):
        for node, v in values.items():
            try:
                i = system.node_index(node)
            except KeyError:
                continue
            if i >= 0:
                x[i] = v
    return x


def _linearization_point(prepared: Prepared, at: str, x: np.ndarray | None):
    """The point where the pencil is taken, its description, and why a fallback was needed."""
    from .op import solve_operating_point

    circuit, system = prepared.circuit, prepared.system
    if x is not None:
        x = np.asarray(x, dtype=float)
        if x.shape != (system.n,):
            raise ValueError(f"x must hold one value per unknown, shape ({system.n},) in the order of the "
                             f"system's names, not shape {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("x must be finite")
        return x, POINT_GIVEN, None
    if system.linear:
        return np.zeros(system.n), POINT_LINEAR, None
    try:
        return solve_operating_point(prepared, transient=(at == "t0")).x, \
            (POINT_T0 if at == "t0" else POINT_OP), None
    except (CircuitError, ConvergenceError) as exc:
        why = f"{POINT_T0 if at == 't0' else POINT_OP} cannot be computed ({exc})"
    card = _transient_card(circuit)
    if at == "op" and card is not None and not card.uic and circuit.ic:
        try:
            tran = prepared.with_system(assemble(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop))
            return solve_operating_point(tran, transient=True).x, POINT_T0, why
        except (CircuitError, ConvergenceError):
            pass
    return _netlist_point(circuit, system), POINT_NETLIST, why


def _transient_card(circuit: Circuit) -> TranAnalysis | None:
    return next((a for a in circuit.analyses if isinstance(a, TranAnalysis)), None)


def _consistency(prepared: Prepared, pencil: PencilReport, x0: np.ndarray | None):
    """Check the transient's starting point against the constraints of the decoupled form.

    The transient's system is ``prepared``'s when it is in transient mode, else assembled.
    """
    circuit = prepared.circuit
    card = _transient_card(circuit)
    if card is None or pencil is None or pencil.weierstrass is None:
        return None
    from .op import solve_operating_point

    tran = prepared if prepared.system.sources.mode == MODE_TRAN else \
        prepared.with_system(assemble(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop))
    tsys = tran.system
    steady = x0 is None and not circuit.ic  # the operating point without .ic: a steady state of the inputs at t0
    if x0 is None:
        if card.uic:
            return None  # the uic start is judged by the transient itself
        x0 = solve_operating_point(tran, transient=True).x  # raises when the start does not exist
    tsys.start_delays(x0)  # transmission lines hold the start's waves
    H = pencil.weierstrass
    ev = tsys.evaluate(x0, 0.0, jacobian=False)
    c0 = ev.phi - tsys.jacobians(x0, 0.0)[1] @ x0

    def c_derivs(k: int) -> np.ndarray:
        return c0 if k == 0 else tsys.source(0.0, k)

    return H.check_consistency(x0, c_derivs, steady=steady)


def _singular_reason(prepared: Prepared, x: np.ndarray, tol: float | None = None) -> str | None:
    """A singular pencil has a singular DC matrix: its null spaces name the unknowns, equations and elements.

    The DC matrix's rank is decided at the pencil's relative tolerance ``tol``. Exactly, a singular
    pencil's DC matrix is singular (``det(s E - H) = 0`` for every ``s``, so at ``s = 0``); a DC
    matrix of full rank at that tolerance means the pencil was judged singular only by rank
    decisions at the edge of the tolerance (a large ``--tol``), and the message says so instead.
    """
    from ..dae.kronecker import matrix_rank
    from ..dae.steady import SteadyResult
    from .op import _singular_error

    system, topo = prepared.system, prepared.topology
    if any(f.severity != "note" and f.kind in ("v_loop", "floating", "i_cutset", "dc_loop", "no_dc_path")
           for f in topo.findings):
        return None  # the topological reason is among the messages already
    H = system.jacobians(x, 0.0)[1]
    rank = matrix_rank(H, rtol=tol, what="rank of the DC matrix")
    if rank.rank == system.n:
        return ("no structural reason: the DC matrix has full rank at this tolerance, so the pencil was judged "
                "singular by a rank decision near the tolerance (see the rank decisions and their margins; a "
                "smaller --tol decides them again)")
    err = _singular_error(prepared.circuit, system, SteadyResult(x, False, singular=True, rank=rank), topo)
    return str(err)


#: Findings that claim a singular pencil, and those that claim a singular DC matrix.
_PENCIL_SINGULAR = ("v_loop", "floating", "i_cutset")
_DC_SINGULAR = ("dc_loop", "no_dc_path")


def _refuted(rep: IndexReport, f, dc_regular: bool | None) -> bool:
    """Whether the numerical analysis refutes a topological suspicion that rests on controlled sources.

    A loop of voltage-type branches or a cutset of current-type branches through a controlled
    source is reported as *likely* singular: the controlled source's law may fix what the
    topology leaves free (a CCVS reading the current of the loop's other source, a VCCS reading
    its own node: a conductance, a gyrator). Where the dense pencil is regular, a likely singular
    pencil is refuted; where the DC matrix has full rank, a likely singular DC point is; where
    the index is below 2, a likely index-2 loop or cutset is.
    """
    if not f.controlled or f.severity == "note" or rep.method != "kronecker":
        return False
    if f.kind in _PENCIL_SINGULAR:
        return rep.regular is True
    if f.kind in _DC_SINGULAR:
        return dc_regular is True
    if f.kind in ("cv_loop", "li_cutset"):
        return rep.index is not None and rep.index < 2
    return False


def _dc_regular(system: MnaSystem, topo, x: np.ndarray) -> bool | None:
    """Whether the DC matrix at ``x`` has full rank, decided only where a controlled finding doubts it."""
    if not any(f.controlled and f.kind in _DC_SINGULAR and f.severity != "note" for f in topo.findings):
        return None
    from ..dae.kronecker import matrix_rank

    H = system.jacobians(x, 0.0)[1]
    return matrix_rank(H, what="rank of the DC matrix").decision.rank == system.n


def _messages(rep: IndexReport, dc_regular: bool | None = None) -> list[str]:
    out = []
    topo = rep.topology
    refuted = []
    if rep.pencil is not None and rep.pencil.singular_by_rounding:
        out.append("singular pencil in double precision, regular in exact arithmetic (see 'uncertain' below)")
    elif rep.regular is False:
        out.append("singular pencil: the circuit equations have no or infinitely many solutions")
    elif rep.index is not None:
        kind = {0: "an ODE (E is invertible)", 1: "every algebraic unknown follows from the states and the inputs"}
        excited = rep.pencil is None or any(lb.startswith("index") for lb in rep.unknowns.values())
        out.append(f"index {rep.index} ({rep.method}): " + kind.get(rep.index, (
            f"some unknowns depend on derivatives of the inputs up to order {rep.index - 1}" if excited else
            f"the pencil has an infinite block of size {rep.index}, but no input drives it: no unknown depends on "
            "the inputs' derivatives")))
    else:
        out.append("index unknown: " + (topo.index_message if topo is not None else "no analysis"))
    pen = rep.pencil
    if pen is not None and pen.disputed and rep.regular is not None:
        ex = pen.exact
        if ex is not None and ex.regular and rep.regular and ex.index == rep.index:
            out.append(f"uncertain in its details: double precision does not decide this structure; exact "
                       f"arithmetic confirms a regular pencil of index {ex.index}, with {ex.n_finite} dynamic states "
                       f"where the report has {pen.n_dynamic}, a difference only singular values below rounding can "
                       f"show (see the warnings under the rank decisions), or element values that satisfy a relation "
                       f"exactly (inductors coupled with K = 1) which the stored, rounded values do not")
        else:
            out.append("uncertain: double precision does not decide this structure (see the warnings under the "
                       "rank decisions)" + (f"; in exact arithmetic it is {'regular, of index ' + str(ex.index) if ex.regular else 'singular'}"
                                            if ex is not None else "")
                       + "; element values whose ratios approach the limit of double precision (gains of 1e9 and "
                       "more, resistances of milli-ohms beside tera-ohms) make a finite value indistinguishable "
                       "from an ideal one, and element values that satisfy a relation exactly (a loop gain of exactly "
                       "1, inductors coupled with K = 1) no longer satisfy it once stored rounded (a resistor's "
                       "conductance 1/R, a coupling's k sqrt(L1 L2)), which the exact arithmetic sees")
    if pen is not None and pen.decided_exactly:
        out.append("decided exactly: double precision decided this structure otherwise, or only closely; ranks in "
                   "exact arithmetic decide it (see the warnings under the rank decisions for what they were "
                   "computed on)")
    hi = [nm for nm, lb in rep.unknowns.items() if lb.startswith("index")]
    if hi:
        shown = ", ".join(f"{nm} ({rep.unknowns[nm]})" for nm in hi[:8])
        out.append(f"unknowns depending on input derivatives: {shown}" + (" ..." if len(hi) > 8 else ""))
    if topo is not None:
        for f in topo.findings:
            if f.kind in ("not_applicable", "truncated", "element_note") or (
                    f.severity == "note" and f.kind != "no_dc_path"):
                continue
            if _refuted(rep, f, dc_regular):
                refuted.append(f)
                continue
            singular = f.kind in ("v_loop", "floating", "i_cutset", "dc_loop", "no_dc_path") and f.severity != "note"
            out.append(f"{f.message} (hint: {f.hint})" if singular and f.hint else f.message)
        for kinds, what in ((_PENCIL_SINGULAR, "a singular pencil: the pencil is regular"),
                            (_DC_SINGULAR, "a singular DC matrix: the DC matrix has full rank"),
                            (("cv_loop", "li_cutset"), f"index 2: the index is {rep.index}")):
            hit = [f for f in refuted if f.kind in kinds]
            if hit:
                names = list(dict.fromkeys(e for f in hit for e in f.elements))
                out.append(f"not confirmed: the loops or cutsets through controlled sources ("
                           f"{', '.join(names[:8])}{' ...' if len(names) > 8 else ''}) suggested {what}, so the "
                           "controlled sources' laws determine what the topology leaves free")
        if not topo.applicable and topo.not_applicable_reason:
            reason = topo.not_applicable_reason
            if rep.pencil is not None and rep.pencil.disputed:  # nothing is authoritative then
                reason = reason.replace("; the numerical index is authoritative", "")
            out.append(reason)
        elif topo.topological_index is not None and rep.index is not None and rep.method == "kronecker" \
                and topo.topological_index != rep.index:
            out.append(f"note: the topological index {topo.topological_index} differs from the numerical "
                       f"index {rep.index}; the numerical one is authoritative (element values may cancel)")
    if rep.consistency is not None and not rep.consistency.consistent:
        names = rep.system.names
        cons = rep.consistency
        changed = ", ".join(
            f"{names[i]}: {cons.x_consistent[i] - cons.dx[i]:.6g} -> {cons.x_consistent[i]:.6g}"
            for i in cons.affected[:6]
        )
        out.append("the transient's initial point (DC operating point) violates hidden constraints "
                   f"because inputs change at t0; consistent values: {changed}")
    return out


def check_magnitudes(E, H, names, what: str) -> None:
    """Refuse a linearised circuit whose matrices the dense analyses cannot hold.

    Parameters
    ----------
    E, H : sparse or ndarray, shape (n, n)
        The charge and right-hand-side Jacobians at the linearisation point.
    names : sequence of str
        The unknowns' names (rows).
    what : str
        The analysis, for the message (``".pz"``, ``"the index analysis"``).

    Raises
    ------
    CircuitError
        When an entry is not finite or larger than ``STAMP_MAGNITUDES[1]``
        (the dense analyses square entries: norms, balancing, SVDs), naming
        the unknowns whose rows hold them. Element values are checked when
        the netlist is read; such entries come from device models (a model
        parameter out of range, e.g. a junction capacitance of 1e300) or an
        operating point far outside any device's range.
    """
    limit = STAMP_MAGNITUDES[1]
    rows: set[int] = set()
    largest = 0.0
    for M in (E, H):
        coo = M.tocoo() if hasattr(M, "tocoo") else None
        r, v = (coo.row, coo.data) if coo is not None else (np.nonzero(np.asarray(M))[0], np.asarray(M)[np.nonzero(
            np.asarray(M))])
        bad = ~np.isfinite(v) | (np.abs(v) > limit)
        if bad.any():
            rows.update(int(i) for i in r[bad])
            found = np.abs(v[bad])
            # (a NaN is not larger than anything: max() would keep the magnitude found before it)
            largest = math.inf if not np.all(np.isfinite(found)) else max(largest, float(np.max(found)))
    if rows:
        unknowns = [names[i] for i in sorted(rows)]
        size = ("non-finite entries" if not np.isfinite(largest)
                else f"entries of magnitude {largest:.3g} (above {limit:g}, which the dense analysis cannot square)")
        raise CircuitError(
            f"{what}: the circuit linearised at its operating point has {size} "
            f"in the equations of {', '.join(unknowns[:6])}"
            + (" ..." if len(unknowns) > 6 else ""),
            nodes=tuple(unknowns),
            hint="a device model parameter out of range (a junction capacitance or current of 1e300, say) "
                 "or an operating point far outside the devices' range; check the models of the devices "
                 "at these nodes")


def _index2_from_topology(labels: dict[str, str], orders: dict[str, int], index: int | None,
                          topo) -> tuple[dict[str, str], dict[str, int]]:
    """The pencil's per-unknown labels, with the topology's index-2 unknowns added where the pencil has index 2.

    The pencil's index is a rank count and holds; its per-unknown labels
    (:meth:`netdae.dae.decoupled.WeierstrassForm.classify`) compare each row
    of ``V2 N U2 B`` with a threshold made of the factors' Frobenius norms,
    which grow with the number of infinite directions and inputs. In a
    macromodel circuit the current of a source on a capacitor loop falls
    below it: ngspice's transimpedance amplifier (245 infinite directions)
    has index 2 and no unknown labelled so, i(v3) weighing 4.8e-4 of the
    threshold, and one OP177A with a capacitor loop at its input labels seven
    of its input stage's unknowns and not the loop's source current. The
    transient then tests the error of that current, a derivative of the
    inputs, and its steps collapse at every input corner (to a probe whose
    Newton matrix is singular in rounding). The topology's capacitor-source
    loops and inductor-source cutsets name those unknowns structurally; where
    the pencil finds index 2 they are of index 2, and are added.

    Parameters
    ----------
    labels : dict of str to str
        The pencil's labels by unknown name.
    orders : dict of str to int
        The pencil's derivative orders by unknown name.
    index : int or None
        The pencil's index.
    topo : TopologyReport
        The circuit's topology (``index2_signals``).

    Returns
    -------
    labels, orders : dict
        New dicts when an unknown was added, else the arguments.
    """
    if index != 2:
        return labels, orders
    sig2 = [nm for nm in topo.index2_signals if nm in orders and orders[nm] < 1]
    if not sig2:
        return labels, orders
    labels, orders = dict(labels), dict(orders)
    for nm in sig2:
        labels[nm], orders[nm] = "index2", 1
    return labels, orders


def analyze_index(circuit: Circuit | Prepared | str | os.PathLike, *, at: str = "op", tol: float | None = None,
                  x: np.ndarray | None = None, method: str = "auto", check_consistency: bool = True) -> IndexReport:
    """The structure of a circuit's DAE and the reasons for it.

    Parameters
    ----------
    circuit : Circuit, Prepared, str or os.PathLike
        An elaborated circuit (or one already assembled:
        :func:`~netdae.analyses.prepared.prepare`; its topology is reused), or
        what :func:`netdae.load` takes (a file name or the netlist text).
    at : {"op", "t0"}
        Linearise at the DC operating point (``.op`` source values) or at the
        initial point of the transient (source values at t0, ``.ic`` applied).
    tol : float, optional
        Relative tolerance of every rank decision (default ``n * eps``).
    x : ndarray, optional
        Linearisation point (default: the operating point; zeros for linear circuits).
    method : {"auto", "kronecker", "topological", "sparse"}
        ``auto`` uses the dense Kronecker analysis up to DENSE_LIMIT unknowns, and ``sparse`` above.
        ``sparse`` takes the index from the circuit's structure where the topological statement gives it,
        else from the algebraic part at the linearisation point
        (:func:`netdae.dae.algebraic.algebraic_part`: index 0, 1 or 2 and the unknowns carrying the
        inputs' derivatives, in about linear time; 3 or more is left undetermined). ``topological``
        takes the structure only.
    check_consistency : bool
        Check the transient's initial point against the hidden constraints.

    Returns
    -------
    IndexReport

    Raises
    ------
    NetdaeError
        For an unknown ``at`` or ``method``, or ``method="kronecker"`` above the dense limit.
    CircuitError, ConvergenceError
        When the operating point cannot be computed, or the circuit has no
        unknowns (no elements, or none off ground): an empty system has no
        index to report.
    """
    t_start = time.perf_counter()
    if at not in ("op", "t0"):
        raise NetdaeError(f"at must be 'op' or 't0', not {at!r}")
    if method not in ("auto", "kronecker", "topological", "sparse"):
        raise NetdaeError(f"method must be auto, kronecker, topological or sparse, not {method!r}")
    if isinstance(circuit, Prepared):
        prepared = circuit
    else:
        if not isinstance(circuit, Circuit):  # a file name or the netlist text, as netdae.load takes them
            from ..netlist import load

            circuit = load(circuit)
        card = _transient_card(circuit)
        if at == "t0" and card is None:
            raise NetdaeError("--at t0 needs a .tran card (the initial point of a transient)")
        prepared = (prepare(circuit, mode=MODE_TRAN, tstep=card.tstep, tstop=card.tstop) if at == "t0"
                    else prepare(circuit, mode=MODE_DC))
    circuit, system, topo = prepared.circuit, prepared.system, prepared.topology
    if system.n == 0:
        raise CircuitError(
            f"{circuit.path}: the circuit has {'no elements' if not circuit.elements else 'no node other than ground'}"
            ": it has no unknowns, so there is no DAE to analyse",
            elements=tuple(el.name for el in circuit.elements),
            hint="connect elements between nodes and ground (0); an empty netlist may come from a wrong file "
                 "or a .include or .lib that brought nothing")
    use_dense = method == "kronecker" or (method == "auto" and system.n <= DENSE_LIMIT)
    xlin, point, fallback = None, "", None
    if method == "kronecker" and system.n > DENSE_LIMIT:
        raise NetdaeError(
            f"the dense Kronecker analysis is limited to {DENSE_LIMIT} unknowns (this circuit has {system.n}); "
            "use the topological method"
        )
    pencil = None
    if use_dense and not (topo.singular and system.n == 0):
        xlin, point, fallback = _linearization_point(prepared, at, x)
        E, H = system.jacobians(xlin, 0.0)
        check_magnitudes(E, H, system.names, "the index analysis")
        terms = getattr(system, "linear_terms", None) if system.linear else None
        pencil = analyze_pencil(E, H, B=system.B.toarray(), names=system.names, tol=tol, terms=terms)
    names = system.names
    if pencil is not None:
        labels = dict(zip(names, pencil.labels)) if pencil.labels is not None else {}
        orders = ({nm: int(d) for nm, d in zip(names, pencil.derivative_order)}
                  if pencil.derivative_order is not None else {})
        # A certain topological singularity (a loop of independent voltage sources, a cutset of current
        # sources, a floating sub-network) holds for any element values: where the dense analysis finds
        # the pencil regular anyway, one of its rank decisions kept rounding, and the structure wins.
        overruled = topo.singular and pencil.regular
        if overruled:
            labels, orders = {}, {}
        else:
            labels, orders = _index2_from_topology(labels, orders, pencil.index, topo)
        rep = IndexReport(
            regular=False if overruled else pencil.regular, index=None if overruled else pencil.index,
            method="kronecker", n_unknowns=system.n,
            n_dynamic=pencil.n_dynamic, rank_E=pencil.rank_E, infinite_blocks=list(pencil.infinite_blocks),
            finite_eigenvalues=pencil.finite_eigenvalues,
            tolerance={"rtol": pencil.rtol, "tol_E": pencil.tol_E, "tol_H": pencil.tol_H},
            unknowns=labels, derivative_order=orders, topology=topo, consistency=None, at=at,
            pencil=pencil, system=system, x=xlin,
        )
        start_missing = None
        if check_consistency and rep.regular:
            try:
                rep.consistency = _consistency(prepared, pencil, None)
            except ConvergenceError as exc:  # no DC operating point: the transient starts as with uic
                start_missing = f"no DC operating point ({exc.message}): the transient starts as with uic"
            except CircuitError as exc:
                start_missing = str(exc)
    else:
        idx = topo.topological_index if topo.applicable and not topo.singular else None
        sig2 = set(topo.index2_signals) if idx == 2 else set()
        how, part = "topological", None
        if idx is None and not topo.singular and method in ("auto", "sparse"):
            xlin, point, fallback = _linearization_point(prepared, at, x)
            E, H = system.jacobians(xlin, 0.0)
            part = algebraic_part(E, H, system.B)
            if part.determined and part.index is not None:
                idx, how = part.index, "sparse"
                sig2 = {names[i] for i in part.support}
                if idx == 2:  # as the dense path does (_index2_from_topology): the structure's index-2 unknowns,
                    # which the input matrix misses where a device's law holds the input (a B source of time)
                    sig2 |= set(topo.index2_signals) & set(names)
        labels = {nm: ("index2" if nm in sig2 else "unclassified") for nm in names}
        rep = IndexReport(
            regular=False if topo.singular else (True if idx is not None else None), index=idx,
            method=how, n_unknowns=system.n, n_dynamic=None, rank_E=None, infinite_blocks=[],
            finite_eigenvalues=np.zeros(0, dtype=complex), tolerance={}, unknowns=labels,
            derivative_order={nm: (1 if nm in sig2 else 0) for nm in names}, topology=topo, consistency=None,
            at=at, system=system, x=xlin,
        )
        rep.algebraic = part
    rep.point = point
    rep.messages = _messages(rep, _dc_regular(system, topo, xlin) if pencil is not None else None)
    if pencil is not None and pencil.regular and rep.regular is False:
        rep.messages.insert(1, (
            "the dense analysis found the pencil regular (index "
            f"{pencil.index}), by rank decisions as close as a margin of "
            f"{min((d.margin for d in pencil.evidence if 'staircase' in d.what), default=float('inf')):.3g} "
            "to its tolerance, "
            "but the circuit's structure makes it singular for any element values: the structure is reported"))
    reason = _singular_reason(prepared, xlin, tol) if rep.regular is False and pencil is not None else None
    if reason is not None:
        rep.messages.insert(1, reason)
    if fallback is not None:
        rep.messages.insert(1, f"linearised at {point} because {fallback}")
    if pencil is not None and start_missing is not None:
        rep.messages.append(f"the transient's initial point was not checked for consistency: {start_missing}")
    if rep.method in ("topological", "sparse"):
        why = (f"{system.n} unknowns is above the dense limit of {DENSE_LIMIT}" if system.n > DENSE_LIMIT
               else "requested" if method == rep.method else f"{method} requested")
        part = rep.algebraic
        if rep.method == "sparse":
            where = "a linear circuit" if point == POINT_LINEAR else f"linearised at {point}"
            how = (f"the circuit's structure does not give it, the algebraic part does ({where}: "
                   f"{part.kernel_dim} algebraic directions, {part.impulsive_dim} impulsive, decided group by "
                   f"group, the largest {part.largest_group} wide)")
        elif part is not None and not part.determined:
            how = (f"no exact index can be given (the algebraic part has a group wider than {GROUP_LIMIT}, too "
                   "large for its dense decisions)")
        elif part is not None:
            how = ("no exact index can be given (the algebraic part has impulsive directions but is not of "
                   "index 2: index 3 or more, or a singular pencil)")
        else:
            how = ("the index follows from the circuit's structure" if rep.index is not None
                   else "no exact index can be given")
        rep.messages.append(f"method: {rep.method} ({why}); {how}")
    rep.wall_time = time.perf_counter() - t_start
    return rep
