"""The MNA system of a circuit as a :class:`~netdae.dae.system.DaeSystem`.

``d/dt q(x) = phi(x, t)`` with

    q(x)      = E x + q_dev(x)
    phi(x, t) = H x + B u(t) + f_dev(x, t)

where E, H, B are the constant linear stamps (assembled once) and the device
families add their charges and currents vectorised. For a circuit without
nonlinear devices, ``linear`` is true and E, H, c(t) = B u(t) are available
directly (``E x' = H x + c(t)``, the form of the lecture notes (2.8)).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import scipy.sparse as sp

from ..dae.sparse import SparsePattern
from ..dae.system import DaeSystem, Evaluation
from ..devices.base import Accumulator, DeviceFamily
from .layout import Layout
from .sources import SourceVector

__all__ = ["MnaSystem", "Delays", "MAX_DELAYED_BREAKPOINTS", "DELAY_DEPTH"]

#: Most breakpoints the transmission lines' delays add to a transient (the sources' corners
#: carried along the lines and their reflections); past it the error control finds the rest.
MAX_DELAYED_BREAKPOINTS = 50_000
#: Passes along the lines a source's corner is followed as a breakpoint (the direct wave, its
#: reflection back and the second arrival, and one more): later reflections are weaker by the
#: product of the ports' reflection coefficients, and the error control sees their corners.
DELAY_DEPTH = 4

#: ``B`` (or, for a large circuit, ``B`` restricted to its non-zero rows) is
#: kept dense when it has at most this many entries: ``c = B u`` then costs one
#: small dense product (and a scatter), about 1-2 us, instead of a scipy sparse
#: product (about 7 us of call overhead).
DENSE_SOURCE_ENTRIES = 4096
#: Circuits up to this many unknowns form ``E x`` and ``H x`` with dense
#: matrices: at this size a dense product (about 1 us) beats scipy's sparse
#: one (about 4 us of call overhead each).
DENSE_MATVEC_MAX = 64


@dataclass
class Delays:
    """The transmission lines of a circuit: ``phi[rows] += (D x)(t - tau)`` in a transient.

    Each row is a line's port equation; ``(D x)[row]`` is minus the wave that
    leaves the line's other port (``-(v + z0 i)``), which arrives ``tau``
    later. At DC the delayed solution is the solution itself, so the steady
    state solves ``phi = (H + D) x + B u`` (:meth:`MnaSystem.steady_form`);
    in ``.ac`` the coupling is ``exp(-j w tau) D``.

    Attributes
    ----------
    D : scipy.sparse.csr_matrix, shape (n, n)
        Non-zero only in ``rows``.
    rows : ndarray of int64, shape (R,)
    tau : ndarray, shape (R,)
        Each row's delay [s], positive.
    ic : ndarray, shape (R,)
        Each row's wave before a ``uic`` transient starts (the lines' ``ic=``).
    W : scipy.sparse.csr_matrix, shape (R, n)
        ``D``'s delayed rows (sorted indices): ``W x`` are the waves (what the compiled loop records).
    C : scipy.sparse.csr_matrix, shape (n, n), optional
        The lines' capacitance at DC (``td / z0`` each, half at each port): ``C x`` is the charge they
        hold at a steady state, where a line's voltage is uniform.
    """

    D: sp.csr_matrix
    rows: np.ndarray
    tau: np.ndarray
    ic: np.ndarray
    W: sp.csr_matrix = None
    C: sp.csr_matrix = None

    def __post_init__(self) -> None:
        if self.W is None:
            self.W = self.D[self.rows].tocsr()
            self.W.sort_indices()

    @classmethod
    def of(cls, stamps, n: int) -> "Delays":
        """From :class:`~netdae.devices.linear.LinearStamps` with lines."""
        return cls(stamps.D.matrix(n).tocsr(), np.asarray(stamps.delay_rows, dtype=np.int64),
                   np.asarray(stamps.delay_tau, dtype=float), np.asarray(stamps.delay_ic, dtype=float),
                   C=stamps.C_line.matrix(n).tocsr())

    def waves(self, x: np.ndarray) -> np.ndarray:
        """``(D x)[rows]``: the waves the rows receive when ``x`` is their delayed solution, shape (R,)."""
        return self.W @ np.asarray(x, dtype=float)

    def by_delay(self) -> list[tuple[float, sp.csr_matrix]]:
        """``[(tau, D_tau)]``: the coupling split by distinct delay (for ``.ac``)."""
        out = []
        for tau in np.unique(self.tau):
            keep = np.zeros(self.D.shape[0])
            keep[self.rows[self.tau == tau]] = 1.0
            out.append((float(tau), sp.diags(keep) @ self.D))
        return out

    def breakpoints(self, corners: np.ndarray, t0: float, t1: float) -> tuple[np.ndarray, bool]:
        """The corners (and the start) carried along the lines: ``c + a sum of up to`` :data:`DELAY_DEPTH`
        ``delays`` in [t0, t1].

        Lines that share one delay are followed further, as many passes more as there are of
        them (a lossy line's sections, :mod:`netdae.netlist.lossy`, are a cascade of equal lines a
        corner crosses one after another): ``c + k tau`` for ``k`` up to :data:`DELAY_DEPTH`
        times their number.

        Returns the sorted points and whether :data:`MAX_DELAYED_BREAKPOINTS` cut the set short.
        """
        taus, counts = np.unique(self.tau, return_counts=True)
        points = np.unique(np.concatenate([[t0], np.asarray(corners, dtype=float)]))
        start = points
        frontier = points
        for _ in range(DELAY_DEPTH):
            if not frontier.size:
                break
            new = (frontier[:, None] + taus[None, :]).ravel()
            new = np.setdiff1d(new[new <= t1], points)
            points = np.union1d(points, new)
            frontier = new
            if points.size > MAX_DELAYED_BREAKPOINTS:
                return points[:MAX_DELAYED_BREAKPOINTS], True
        for tau, count in zip(taus, counts):
            passes = DELAY_DEPTH * (int(count) // 2)  # two rows per line
            if passes <= DELAY_DEPTH:
                continue
            k = np.arange(DELAY_DEPTH + 1, passes + 1)
            chain = (start[:, None] + tau * k[None, :]).ravel()
            points = np.union1d(points, chain[chain <= t1])
            if points.size > MAX_DELAYED_BREAKPOINTS:
                return points[:MAX_DELAYED_BREAKPOINTS], True
        return points, False


class MnaSystem(DaeSystem):
    """MNA equations of a circuit.

    Build with :func:`netdae.mna.assemble`; see that function for parameters.
    The system knows its equations and unknowns, not the circuit they came
    from: an analysis that needs both holds a
    :class:`~netdae.analyses.prepared.Prepared`.

    Attributes
    ----------
    layout : Layout
        Unknown numbering (``layout.nodes``, ``layout.branches``).
    sources : SourceVector
        u(t), with the independent sources' names in column order of ``B``.
    B : scipy.sparse.csc_matrix, shape (n, m)
        Source incidence.
    families : list of DeviceFamily
    notes : list of str
        Things the user should know about the assembly.
    H_ac : scipy.sparse.csc_matrix, shape (n, n)
        Added to dphi/dx by ``.ac`` only (resistors with an ``ac=``
        resistance); all zeros when there is none.
    switching : SwitchEvents or None
        The switches' states and events for a transient
        (:class:`~netdae.devices.switch.SwitchEvents`); None without switches.
    delays : Delays or None
        The transmission lines (None without T elements; the transient form:
        :meth:`steady_form` is the DC one).
    delay_start : ndarray or None
        The lines' waves before the transient's start (:meth:`start_delays`).
    delay_history : callable or None
        ``history(tq) -> waves`` of the rows at times ``tq`` (shape (R,)) after the
        start, set by the integrator while it runs; None: the start's waves.
    """

    def __init__(self, layout: Layout, E: sp.csc_matrix, H: sp.csc_matrix,
                 B: sp.csc_matrix, sources: SourceVector, families: list[DeviceFamily],
                 pattern: SparsePattern, notes: list[str], H_ac: sp.csc_matrix | None = None,
                 delays: Delays | None = None, like: "MnaSystem | None" = None):
        self.layout = layout
        self.n = layout.n
        self.names = layout.names
        self.kinds = layout.kinds
        self.pattern = pattern
        self._E = E
        self._H = H
        self.B = B
        self.sources = sources
        self.families = families
        self.linear = not families
        self.notes = notes
        self.H_ac = H_ac if H_ac is not None else sp.csc_matrix((self.n, self.n))
        self.delays = delays
        self.delay_start: np.ndarray | None = None
        self.delay_history: Callable[[np.ndarray], np.ndarray] | None = None
        self._delay_t0 = 0.0
        self._steady = None
        #: The steady form's transmission lines' capacitance at DC (``Delays.C``), None elsewhere.
        self.line_charge = None
        #: A small linear system's E and H as their elements' unsummed entries, ``((rows, cols, values),
        #: (rows, cols, values))``: the index analysis decides their structure in exact arithmetic without
        #: the rounding of the sums (:func:`netdae.dae.exact.exact_structure`); None elsewhere.
        self.linear_terms = None
        self._acc = Accumulator(self.n, pattern.nnz) if families else None
        self._switching = None
        self._behavioural_events = False  # not looked for yet (None: there are none)
        self._charge_rows: np.ndarray | None = None
        self._time_rows: np.ndarray | None = None
        if like is not None and like.families is families:  # the same device families: the same rows
            self._charge_rows, self._time_rows = like._charge_rows, like._time_rows
        self._xext = np.zeros(self.n + 1)
        self._placement: _Placement | None = None
        placed = like.placement() if like is not None and like.pattern is pattern else None
        if placed is not None and placed.fits(E, H, B):
            placed.fill(self, E, H, B)
            self._placement = placed
            return
        self._dq_lin = pattern.data_of(E)
        self._dphi_lin = pattern.data_of(H)
        dense = self.n <= DENSE_MATVEC_MAX
        self._E_mv = E.toarray() if dense else E
        self._H_mv = H.toarray() if dense else H
        rows = np.unique(B.tocoo().row)
        self._b_full = B.toarray() if B.shape[0] * B.shape[1] <= DENSE_SOURCE_ENTRIES else None
        if self._b_full is None and rows.size * B.shape[1] <= DENSE_SOURCE_ENTRIES:
            self._b_rows, self._b_dense = rows, B.tocsr()[rows].toarray()
        else:
            self._b_rows, self._b_dense = None, None

    def placement(self) -> "_Placement | None":
        """Where this system's constant matrices lie in its pattern and dense copies, for systems of the
        same structure built ``like`` it (made at the first call; None when there is no shortcut)."""
        if self._placement is None:
            self._placement = _Placement.of(self)
        return self._placement or None

    def _add_sources(self, out: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``out += B u`` (in place); returns ``out``."""
        if self._b_full is not None:
            out += self._b_full @ u
        elif self._b_dense is not None:
            out[self._b_rows] += self._b_dense @ u
        else:
            out += self.B @ u
        return out

    @property
    def switching(self):
        """The switches' event handling for a transient, or None (no S or W element)."""
        if self._switching is None:
            from ..devices.switch import SwitchEvents, SwitchFamily

            family = next((f for f in self.families if isinstance(f, SwitchFamily)), None)
            if family is None:
                return None
            self._switching = SwitchEvents(family, self.pattern, self.n)
        return self._switching

    @property
    def behavioural_events(self):
        """The held comparisons of behavioural sources for a transient
        (:class:`~netdae.devices.behavioral.BehaviouralEvents`), or None (no source compares the state)."""
        if self._behavioural_events is False:
            from ..devices.behavioral import BehaviouralEvents, BehaviouralFamily

            family = next((f for f in self.families if isinstance(f, BehaviouralFamily)), None)
            self._behavioural_events = None if family is None else BehaviouralEvents.of(family, self.n)
        return self._behavioural_events

    def remember_switches(self, x) -> None:
        """After a point of a DC sweep: the switches start the next point in the states at ``x``."""
        from ..devices.switch import SwitchFamily

        xe = np.append(np.asarray(x, dtype=float), 0.0)
        for family in self.families:
            if isinstance(family, SwitchFamily):
                family.remember(xe)

    # -- linear parts ------------------------------------------------------
    @property
    def E(self) -> sp.csc_matrix:
        """Constant part of dq/dx (all of it for a linear circuit)."""
        return self._E

    @property
    def H(self) -> sp.csc_matrix:
        """Constant part of dphi/dx (all of it for a linear circuit)."""
        return self._H

    def source(self, t: float, derivative: int = 0, *, waves: bool = True) -> np.ndarray:
        """``c(t) = B u(t)`` or its time derivative, shape (n,).

        With transmission lines the delayed waves are part of ``c`` (``waves=False``: the
        independent sources' part alone).
        """
        u = self.sources.values(t, derivative)
        c = self._b_full @ u if self._b_full is not None else self._add_sources(np.zeros(self.n), u)
        if self.delays is not None and waves:
            if derivative == 0:
                c[self.delays.rows] += self.delayed_waves(t)
            elif np.any(t - self.delays.tau > self._delay_t0):
                from ..errors import CircuitError

                raise CircuitError("the derivatives of a transmission line's delayed waves are not available "
                                   "here (a linear circuit of index 3 or more solved by decoupling)",
                                   hint="transmission lines run with the BDF integrator")
        return c

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        corners = self.sources.breakpoints(t0, t1)
        extra = [f.breakpoints(t0, t1) for f in self.families]
        if any(e.size for e in extra):
            corners = np.union1d(corners, np.concatenate(extra))
        if self.delays is None:
            return corners
        return self.delays.breakpoints(corners, t0, t1)[0]

    def step_bound(self) -> float:
        """The shortest ``$bound_step`` of the OSDI devices at their last evaluation (inf: none)."""
        return min((f.step_bound for f in self.families if hasattr(f, "step_bound")), default=math.inf)

    def ended(self) -> str | None:
        """The ``$finish`` / ``$stop`` an OSDI device raised at its last evaluation (None: none)."""
        return next((f.ended for f in self.families if getattr(f, "ended", None)), None)

    def time_charge_rows(self) -> np.ndarray:
        """The rows whose charge reads time itself, not only through the unknowns (a ``Q`` source whose
        expression reads ``time``; sorted, computed once). The integrators take ``dq/dt`` at fixed x
        into account there: the start-up's derivative probe (:func:`netdae.dae.bdf.startup.probe`) and
        the error test of those rows' charges (:func:`netdae.dae.compiled.control.time_charge_residual`)."""
        if self._time_rows is None:
            parts = [np.asarray(f.time_charge_rows(), dtype=np.int64) for f in self.families
                     if hasattr(f, "time_charge_rows")]
            rows = np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.int64)
            self._time_rows = rows[rows >= 0]
        return self._time_rows

    def nonlinear_charge_rows(self) -> np.ndarray:
        """The rows to which a device family adds charges (sorted); every other row's charge is ``E x``.

        Structural: the rows of the families' charge branches (a junction's
        depletion charge, a MOS gate charge, a ``Q`` source), whatever their
        values. Linear capacitors and inductors stamp ``E`` only. Computed once.
        """
        if self._charge_rows is None:
            parts = [np.asarray(f.charge_rows(), dtype=np.int64) for f in self.families]
            rows = np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.int64)
            self._charge_rows = rows[rows >= 0]
        return self._charge_rows

    # -- transmission lines ----------------------------------------------------
    def steady_form(self) -> "MnaSystem":
        """The system whose steady states are the circuit's DC ones (itself without lines).

        A line at DC joins its ports (its delayed solution is the solution):
        the copy solves ``phi = (H + D) x + B u`` on the same pattern and
        unknowns, and has no delays. Made once and kept.
        """
        if self.delays is None:
            return self
        if self._steady is None:
            s = copy.copy(self)
            s._H = (self._H + self.delays.D).tocsc()
            s._dphi_lin = self.pattern.data_of(s._H)
            s._H_mv = s._H.toarray() if self.n <= DENSE_MATVEC_MAX else s._H
            s._acc = Accumulator(self.n, self.pattern.nnz) if self.families else None
            s._xext = np.zeros(self.n + 1)
            s.delays = None
            s.line_charge = self.delays.C  # the lines' charge, conserved with the capacitors' (op.py)
            s._steady = s
            self._steady = s
        return self._steady

    def start_delays(self, x0: np.ndarray, t0: float = 0.0, *, uic: bool = False) -> None:
        """Fix the lines' waves before ``t0``: those of the solution ``x0`` (the operating point),
        or with ``uic`` the lines' ``ic=`` values (zero when not given), as ngspice starts them."""
        if self.delays is None:
            return
        self.delay_start = self.delays.ic.copy() if uic else self.delays.waves(x0)
        self._delay_t0 = float(t0)
        self.delay_history = None

    def delayed_waves(self, t: float) -> np.ndarray:
        """The waves the lines' rows receive at time ``t``, shape (R,)."""
        d = self.delays
        out = self.delay_start.copy() if self.delay_start is not None else np.zeros(d.rows.size)
        tq = t - d.tau
        after = tq > self._delay_t0
        if self.delay_history is not None and after.any():
            out[after] = self.delay_history(tq)[after]
        return out

    def initial_state(self) -> Any:
        """Limiting state of every family for a solve from scratch (SPICE's MODEINITJCT).

        ``evaluate`` with ``state=None`` evaluates every device at x instead
        (no limiting history), which is right when x is already a solution
        nearby (continuation, the first step of a transient).
        """
        if not self.families:
            return None
        return tuple(f.initial_state() for f in self.families)

    # -- the DAE -------------------------------------------------------------
    def evaluate(self, x, t, *, jacobian=True, state=None, source_scale=1.0) -> Evaluation:
        x = np.asarray(x, dtype=float)
        q = self._E_mv @ x
        phi = self._H_mv @ x
        if self.sources.m:
            u = self.sources.values(t)
            self._add_sources(phi, u if source_scale == 1.0 else source_scale * u)
        if self.delays is not None:
            phi[self.delays.rows] += self.delayed_waves(t)
        if not self.families:
            return Evaluation(
                q=q, phi=phi,
                dq=self._dq_lin if jacobian else None,
                dphi=self._dphi_lin if jacobian else None,
            )
        acc = self._acc
        acc.reset(q, phi, self._dq_lin if jacobian else None, self._dphi_lin if jacobian else None)
        xe = self._xext
        xe[: self.n] = x
        states = state if state is not None else (None,) * len(self.families)
        new_states = tuple(
            fam.evaluate(xe, t, acc, st, jacobian) for fam, st in zip(self.families, states)
        )
        return Evaluation(
            q=acc.q[: self.n].copy(),
            phi=acc.phi[: self.n].copy(),
            dq=acc.dq[: self.pattern.nnz].copy() if jacobian else None,
            dphi=acc.dphi[: self.pattern.nnz].copy() if jacobian else None,
            limited=acc.limited,
            state=new_states,
            ok=acc.ok,
        )

    # -- names -----------------------------------------------------------------
    def node_index(self, node: str) -> int:
        """Unknown index of a node name (``-1`` for ground).

        Raises
        ------
        KeyError
        """
        return self.layout.node(node.lower())

    def describe(self) -> dict:
        """Sizes for reports: unknowns, nodes, branches, non-zeros, linear."""
        return {
            "n_unknowns": self.n,
            "n_nodes": len(self.layout.nodes),
            "n_branches": len(self.layout.branches),
            "nnz": self.pattern.nnz,
            "linear": self.linear,
        }


class _Placement:
    """How a system's constant matrices ``E``, ``H`` and ``B`` lie in its pattern and dense copies.

    A system assembled with matrices of the same structure (the same stored entries: matrices summed
    from the same stamp coordinates, :class:`~netdae.devices.stamps.CscSum`) fills its derived arrays
    from it: the pattern's data by one ``bincount``, the dense copies by one scatter, instead of
    searching the pattern and converting the matrices again. The arrays come out as
    :class:`MnaSystem`'s own construction makes them, value for value.
    """

    def __init__(self, system: "MnaSystem") -> None:
        pattern = system.pattern
        self.nnz = pattern.nnz
        self.dense = system.n <= DENSE_MATVEC_MAX
        self.structure = tuple((m.indptr.copy(), m.indices.copy(), m.shape) for m in (system.E, system.H, system.B))
        self.slots = []
        self.flat = []
        for m in (system.E, system.H):
            rows, cols = _entries(m)
            self.slots.append(pattern.slots(rows, cols))
            self.flat.append(rows * m.shape[1] + cols)
        rows, cols = _entries(system.B)
        self.b_flat = rows * system.B.shape[1] + cols

    @classmethod
    def of(cls, system: "MnaSystem") -> "_Placement | bool":
        """The placement of ``system``, or False when its sources' incidence is kept sparse or by rows
        (large circuits) or a matrix has an entry outside the pattern."""
        if system._b_full is None or system.delays is not None:
            return False
        try:
            return cls(system)
        except ValueError:  # an entry outside the pattern (a zero that data_of left out)
            return False

    def fits(self, E: sp.csc_matrix, H: sp.csc_matrix, B: sp.csc_matrix) -> bool:
        """True when the three matrices have the stored entries of the system placed."""
        for m, (indptr, indices, shape) in zip((E, H, B), self.structure):
            if not (sp.isspmatrix_csc(m) and m.shape == shape and np.array_equal(m.indptr, indptr)
                    and np.array_equal(m.indices, indices)):
                return False
        return True

    def fill(self, system: "MnaSystem", E: sp.csc_matrix, H: sp.csc_matrix, B: sp.csc_matrix) -> None:
        """Set ``system``'s pattern data, dense copies and source incidence from the matrices' values."""
        system._dq_lin = np.bincount(self.slots[0], weights=E.data, minlength=self.nnz)
        system._dphi_lin = np.bincount(self.slots[1], weights=H.data, minlength=self.nnz)
        system._E_mv = _scatter(self.flat[0], E) if self.dense else E
        system._H_mv = _scatter(self.flat[1], H) if self.dense else H
        system._b_full = _scatter(self.b_flat, B)
        system._b_rows, system._b_dense = None, None


def _entries(m: sp.csc_matrix) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of a CSC matrix's stored entries, in storage order."""
    cols = np.repeat(np.arange(m.shape[1], dtype=np.int64), np.diff(m.indptr))
    return np.asarray(m.indices, dtype=np.int64), cols


def _scatter(flat: np.ndarray, m: sp.csc_matrix) -> np.ndarray:
    """The dense array of ``m`` from its stored entries' flat positions (as ``m.toarray()``)."""
    out = np.zeros(m.shape)
    out.flat[flat] = m.data
    return out
