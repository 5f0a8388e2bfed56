"""The interface of a nonlinear device family, and the accumulator it writes into.

A *family* holds every instance of one nonlinear element kind (all diodes, all
BJTs, ...) as arrays of parameters and node indices, and evaluates them all in
one vectorised pass: currents and charges, and their derivatives, scattered
into the MNA system's fixed sparsity pattern through precomputed slots. The
MNA system loops over families (a handful), never over instances.

Life cycle (driven by :func:`netdae.mna.assemble`)
----------------------------------------------------
1. ``Family(elements, circuit)`` reads parameters and models (raises
   :class:`~netdae.errors.CircuitError` for inconsistent data).
2. ``add_nodes(layout)`` creates internal nodes (e.g. behind a series
   resistance); ``add_branches(layout)`` creates branch-current unknowns.
3. ``coordinates(layout)`` returns every (row, column) the family may write
   (ground, index -1, allowed: it is dropped).
4. ``bind(slots)`` receives a :class:`SlotMap` to turn coordinates into
   positions in the Jacobian ``data`` arrays.
5. ``evaluate(x, t, acc, state, jacobian)`` adds contributions to ``acc``
   and returns the family's new limiting state (or ``None``).
6. ``noise(x, temp)`` (``.noise`` only, after ``bind``): the family's noise
   current generators at the operating point ``x``, as :class:`NoiseSources`.

Sign convention: as in :mod:`netdae.devices.linear`, node rows of ``phi`` are
the currents *entering* the node and node rows of ``q`` the charges stored on
the node side of each element, so a device current ``i`` flowing from node a
to node b through the device adds ``-i`` to ``phi[a]`` and ``+i`` to ``phi[b]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dae.sparse import SparsePattern

__all__ = ["Accumulator", "SlotMap", "DeviceFamily", "NoiseSources", "noise_sources", "thermal", "shot",
           "flicker"]


class SlotMap:
    """Maps (row, column) pairs, ground included, to Jacobian ``data`` positions.

    Ground rows/columns map to a dummy slot ``nnz`` (one past the end): the
    accumulator's Jacobian arrays have ``nnz + 1`` entries and the last is
    discarded, so device code scatters without masking.
    """

    def __init__(self, pattern: SparsePattern):
        self.pattern = pattern
        self.dummy = pattern.nnz

    def __call__(self, rows, cols) -> np.ndarray:
        rows = np.asarray(rows, dtype=np.int64)
        cols = np.asarray(cols, dtype=np.int64)
        out = np.full(rows.shape, self.dummy, dtype=np.int64)
        keep = (rows >= 0) & (cols >= 0)
        out[keep] = self.pattern.slots(rows[keep], cols[keep])
        return out


class Accumulator:
    """Extended arrays that device families add into.

    Attributes
    ----------
    q, phi : ndarray, shape (n + 1,)
        Last entry collects ground contributions (discarded).
    dq, dphi : ndarray, shape (nnz + 1,)
        Last entry is the dummy slot (discarded).
    limited : bool
        Set by a family that limited a junction voltage.
    ok : bool
        Cleared by a family whose evaluation produced non-finite values.
    """

    def __init__(self, n: int, nnz: int):
        self.n = n
        self.nnz = nnz
        self.q = np.zeros(n + 1)
        self.phi = np.zeros(n + 1)
        self.dq = np.zeros(nnz + 1)
        self.dphi = np.zeros(nnz + 1)
        self.limited = False
        self.ok = True

    def reset(self, q0: np.ndarray, phi0: np.ndarray, dq0: np.ndarray | None, dphi0: np.ndarray | None) -> None:
        """Start from the linear part (copies into the extended arrays)."""
        self.q[: self.n] = q0
        self.q[self.n] = 0.0
        self.phi[: self.n] = phi0
        self.phi[self.n] = 0.0
        if dq0 is not None:
            self.dq[: self.nnz] = dq0
            self.dq[self.nnz] = 0.0
            self.dphi[: self.nnz] = dphi0
            self.dphi[self.nnz] = 0.0
        self.limited = False
        self.ok = True

    @staticmethod
    def rows(idx: np.ndarray, n: int) -> np.ndarray:
        """Row indices with ground (-1) mapped to the discard slot ``n``."""
        idx = np.asarray(idx, dtype=np.int64)
        return np.where(idx < 0, n, idx)

    def add_q(self, rows_ext: np.ndarray, values: np.ndarray) -> None:
        self.q += np.bincount(rows_ext, weights=values, minlength=self.n + 1)

    def add_phi(self, rows_ext: np.ndarray, values: np.ndarray) -> None:
        self.phi += np.bincount(rows_ext, weights=values, minlength=self.n + 1)

    def add_dq(self, slots: np.ndarray, values: np.ndarray) -> None:
        self.dq += np.bincount(slots, weights=values, minlength=self.nnz + 1)

    def add_dphi(self, slots: np.ndarray, values: np.ndarray) -> None:
        self.dphi += np.bincount(slots, weights=values, minlength=self.nnz + 1)


def thermal(conductance, temp: float) -> np.ndarray:
    """Thermal noise of a conductance at ``temp`` [K]: ``4 k T G`` [A^2/Hz] (ngspice's ``THERMNOISE``)."""
    from .junction import BOLTZMANN

    return 4.0 * BOLTZMANN * temp * np.asarray(conductance, dtype=float)


def shot(current) -> np.ndarray:
    """Shot noise of a DC current: ``2 q |I|`` [A^2/Hz] (ngspice's ``SHOTNOISE``)."""
    from .junction import CHARGE

    return 2.0 * CHARGE * np.abs(np.asarray(current, dtype=float))


#: The smallest number ngspice takes the logarithm of (``N_MINLOG``): flicker noise of a zero current.
NOISE_MINLOG = 1e-38


def flicker(kf, current, af) -> np.ndarray:
    """``kf |I|^af`` [A^2/Hz at 1 Hz], as ngspice raises the current (``exp(af ln(max(|I|, 1e-38)))``)."""
    i = np.maximum(np.abs(np.asarray(current, dtype=float)), NOISE_MINLOG)
    return np.asarray(kf, dtype=float) * np.exp(np.asarray(af, dtype=float) * np.log(i))


@dataclass
class NoiseSources:
    """Noise current generators at an operating point, one entry per generator.

    A generator is a current noise source between two unknowns (node
    indices, -1 for ground) whose power spectral density at frequency f is
    ``white + coefficient / f**exponent`` [A^2/Hz]: thermal and shot noise are
    white, flicker noise the second term. Generators are in ngspice's order
    (instance by instance, each instance's generators as ngspice names them).

    Attributes
    ----------
    element : list of str
        The instance each generator belongs to.
    suffix : list of str
        ngspice's name of the generator within its instance (``"_rs"``,
        ``"_id"``, ``"_1overf"``, ``"_thermal"``; ``""`` for an instance
        with a single generator, a switch).
    pos, neg : ndarray of int
        The two unknowns the current flows between.
    white, coefficient, exponent : ndarray
        The spectral density's parts.
    """

    element: list[str] = field(default_factory=list)
    suffix: list[str] = field(default_factory=list)
    pos: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    neg: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    white: np.ndarray = field(default_factory=lambda: np.zeros(0))
    coefficient: np.ndarray = field(default_factory=lambda: np.zeros(0))
    exponent: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.element)

    def density(self, freqs) -> np.ndarray:
        """The generators' spectral densities [A^2/Hz], shape (len(freqs), len(self))."""
        f = np.asarray(freqs, dtype=float)[:, None]
        with np.errstate(divide="ignore"):
            return self.white[None, :] + self.coefficient[None, :] / f ** self.exponent[None, :]

    @staticmethod
    def concatenate(parts: list["NoiseSources"]) -> "NoiseSources":
        """The generators of several families, in order."""
        out = NoiseSources()
        for p in parts:
            out.element += p.element
            out.suffix += p.suffix
        for name in ("pos", "neg", "white", "coefficient", "exponent"):
            arrays = [getattr(p, name) for p in parts]
            setattr(out, name, np.concatenate(arrays) if arrays else getattr(out, name))
        return out


def noise_sources(names, generators) -> NoiseSources:
    """Generators of N instances, instance by instance.

    Parameters
    ----------
    names : sequence of str
        The N instance names.
    generators : list of tuple
        ``(suffix, pos, neg, white, coefficient, exponent)`` per kind of
        generator, in ngspice's order; the arrays (or scalars) have one entry
        per instance.

    Returns
    -------
    NoiseSources

    Examples
    --------
    >>> ns = noise_sources(["d1", "d2"], [("_rs", [1, 2], [0, 0], [1.0, 2.0], 0.0, 1.0),
    ...                                   ("_id", [1, 2], [-1, -1], [3.0, 4.0], 0.0, 1.0)])
    >>> [e + s for e, s in zip(ns.element, ns.suffix)], ns.white.tolist()
    (['d1_rs', 'd1_id', 'd2_rs', 'd2_id'], [1.0, 3.0, 2.0, 4.0])
    """
    count, kinds = len(names), len(generators)
    if count == 0 or kinds == 0:
        return NoiseSources()

    def column(k: int, dtype) -> np.ndarray:
        return np.stack([np.broadcast_to(np.asarray(g[k], dtype=dtype), (count,)) for g in generators],
                        axis=1).ravel()

    return NoiseSources(
        element=[name for name in names for _ in range(kinds)],
        suffix=[g[0] for _ in range(count) for g in generators],
        pos=column(1, np.int64), neg=column(2, np.int64), white=column(3, float),
        coefficient=column(4, float), exponent=column(5, float))


def series_nodes(layout, elements, outer: np.ndarray, conductance, suffix: str) -> np.ndarray:
    """The node behind each instance's series resistance: ``<name>#<suffix>`` where the
    conductance is positive (a new internal node of ``layout``), else the terminal itself.

    Parameters
    ----------
    layout : Layout
    elements : list of Element
    outer : ndarray of int, shape (N,)
        The terminals' node indices.
    conductance : array_like, shape (N,)
        The series conductances (0: no resistance, the terminal is used directly).
    suffix : str
        The internal node's name after ``#`` (ngspice's: ``drain``, ``source``, ``base`` ...).

    Returns
    -------
    ndarray of int64, shape (N,)
    """
    return np.array([layout.add_node(f"{el.name}#{suffix}", internal=True, beside=int(node)) if g > 0.0 else node
                     for el, g, node in zip(elements, conductance, outer)], dtype=np.int64)


def start_from_device_ic(elements, x: np.ndarray, given: set[int], reference: np.ndarray,
                         targets: list[tuple[str, np.ndarray]]) -> list[str]:
    """A ``uic`` start from the instances' own initial conditions: each target node at its ``ic`` above the reference.

    Parameters
    ----------
    elements : list of Element
    x : ndarray, shape (n,)
        The start (node potentials first), set in place.
    given : set of int
        Nodes with an ``.ic`` of their own, left alone.
    reference : ndarray of int, shape (N,)
        Each instance's node the voltages are measured from (a BJT's emitter, a MOSFET's source).
    targets : list of (str, ndarray of int, shape (N,))
        The instance parameter (``icvbe`` ...) and the node it sets.

    Returns
    -------
    list of str
        The instances with at least one value applied (:meth:`DeviceFamily.uic_start`).
    """
    done = []
    for k, el in enumerate(elements):
        ref = int(reference[k])
        base = x[ref] if ref >= 0 else 0.0
        used = False
        for key, nodes in targets:
            node = int(nodes[k])
            if key in el.params and node >= 0 and node not in given:
                x[node] = base + float(el.params[key])
                used = True
        if used:
            done.append(el.name)
    return done


class _KindsOf:
    """``Family.kinds``: the element kinds whose definition (:mod:`netdae.kinds`) names this family."""

    def __get__(self, obj, cls) -> frozenset[str]:
        from ..kinds import KINDS

        ref = f"{cls.__module__}:{cls.__qualname__}"
        return frozenset(k.name for k in KINDS.values() if k.family == ref)


class DeviceFamily:
    """Base class of a vectorised nonlinear device family.

    Subclasses implement the hooks; the element kinds they evaluate name them
    in their definitions (``ElementKind.family``, :mod:`netdae.kinds`). ``x`` passed to
    :meth:`evaluate` is *extended*: ``x[n] == 0`` is the ground potential, so
    node index -1 reads ground directly.
    """

    #: Element kinds this family evaluates (read from their definitions).
    kinds = _KindsOf()
    #: True when the family keeps nothing of a run between calls (only its parameters, slots and
    #: scratch arrays), so that the systems of circuits with equal instances may share the object
    #: (:func:`netdae.mna.assemble.reassemble`). Families with held states (switches, behavioural
    #: comparisons) or foreign instance memory (OSDI) keep the default.
    shareable = False
    #: True when the family's limiting state (:class:`~netdae.devices.companion.LimitState`) is its
    #: controlling voltages: a transient step takes the state of its evaluation without limiting at
    #: the accepted point, and the next step limits from there (as ngspice from the converged point)
    #: rather than from the iterate the last correction was computed at. Switches (held states),
    #: behavioural comparisons and OSDI devices keep the default.
    limits_from_point = False

    def __init__(self, elements, circuit) -> None:
        self.elements = list(elements)
        self.circuit = circuit

    def add_nodes(self, layout) -> None:
        """Create internal nodes (default: none)."""

    def add_branches(self, layout) -> None:
        """Create branch-current unknowns (default: none)."""

    def coordinates(self, layout) -> tuple[np.ndarray, np.ndarray]:
        """Every (row, column) of dq/dx or dphi/dx this family may write."""
        raise NotImplementedError

    def bind(self, slots: SlotMap, n: int) -> None:
        """Precompute the slots and extended row indices (called once)."""
        raise NotImplementedError

    def charge_rows(self) -> np.ndarray:
        """The rows (unknowns; ground -1 may appear) to which the family adds charges and their derivatives.

        Called after :meth:`coordinates`. Every other row of ``q`` and ``dq/dx`` is left to the
        linear stamps (``E``), which the integrator relies on
        (:meth:`netdae.dae.system.DaeSystem.nonlinear_charge_rows`). By default the rows of the
        family's charge branches (``self.stamps``, a
        :class:`~netdae.devices.companion.BranchStamps`).
        """
        return self.stamps.charge_rows()

    def initial_state(self) -> Any:
        """Limiting state before the first Newton iteration (``None`` if unused)."""
        return None

    def uic_start(self, x: np.ndarray, given: set[int]) -> list[str]:
        """Set ``x`` (the ``uic`` start, node potentials first) from the instances' initial conditions.

        ngspice starts a BJT's junctions at its ``icvbe``/``icvce`` under ``uic``, a level-1 MOSFET's at
        ``icvds``/``icvgs``/``icvbs``. A family that
        supports its instances' initial conditions sets the nodes behind its junctions so that the
        junction voltages are those values, leaving the nodes in ``given`` (an ``.ic`` of their own)
        alone, and returns the names of the instances it started so. The default supports none (a
        diode's ``ic`` changes no waveform of ngspice 39: it serves its first Newton iteration only).
        """
        return []

    def evaluate(self, x: np.ndarray, t: float, acc: Accumulator, state: Any, jacobian: bool) -> Any:
        """Add the family's q, phi (and Jacobians) at extended ``x`` into ``acc``.

        Returns the new limiting state; sets ``acc.limited``/``acc.ok`` as needed.
        """
        raise NotImplementedError

    def junction_nodes(self) -> list[tuple[str, str]]:
        """Pairs of nodes joined by a conducting path at DC (for topology)."""
        return []

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Instants in [t0, t1] where the family's equations are not smooth in time (default: none)."""
        return np.empty(0)

    def read_unknowns(self, k: int | None = None) -> np.ndarray:
        """The unknowns (indices, ground -1 included) the equations of instance ``k`` read (None: of every one).

        By default the nodes of the family's control voltages (``self.stamps``).
        """
        st = self.stamps
        cols = slice(None) if k is None else k
        return np.unique(np.concatenate([np.ravel(st.ctrl_p[:, cols]), np.ravel(st.ctrl_m[:, cols])]))

    def point_states(self, column, jumps) -> np.ndarray | None:
        """The states the family's quantities depend on along a sequence of solutions (None: none).

        A family whose equations depend on more than the solution (a switch's
        hysteresis) gives them here, walking the points in order; the result
        is passed to :meth:`quantities` as ``states``.

        Parameters
        ----------
        column : callable
            ``column(unknowns)``: the values of the unknowns (indices, -1 for
            ground) at every point, shape (T, len(unknowns)).
        jumps : dict of int to tuple of str, or None
            A transient's rows that are the left limit of a jump (the next row
            is its right limit, at the same time), to the elements that
            switched there.
        """
        return None

    def quantities(self, x: np.ndarray, dxdt: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """ngspice's named device quantities of every instance at solutions ``x`` (``@q1[gm]`` ...).

        Parameters
        ----------
        x : ndarray, shape (T, n + 1)
            Extended solutions (``x[:, n] == 0`` is ground), one row per point.
        dxdt : ndarray, shape (T, n + 1), optional
            Their time derivatives (a transient): the charges' currents are
            added to the terminal currents. None: a DC solution.

        Returns
        -------
        dict of str to ndarray, shape (T, N)
            :data:`netdae.signals.DEVICE_QUANTITIES` of the family's kind.
        """
        raise NotImplementedError(f"{type(self).__name__} computes no device quantities")

    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """The noise generators of every instance at the operating point (``.noise``).

        Parameters
        ----------
        x : ndarray, shape (n + 1,)
            The extended operating point (``x[n] == 0`` is ground).
        temp : float
            The circuit temperature [K] (ngspice's thermal and shot noise use
            it, not an instance's own temperature).

        Raises
        ------
        CircuitError
            For a family without a noise model (the default): naming the
            first instance and where it is written.
        """
        from ..errors import CircuitError

        el = self.elements[0]
        raise CircuitError(f"{el.name}: netdae has no noise model for a {el.kind} element, so .noise "
                           "cannot run", elements=(el.name,),
                           hint="remove the .noise card, or simulate this circuit's noise in ngspice",
                           location=getattr(el, "location", None))
