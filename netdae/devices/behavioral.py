"""Behavioural sources: ``B`` (and ``E``/``G`` with ``value=``) voltage and current sources, and
charge-defined capacitors.

Syntax: ``Bname n+ n- V={expr}`` (kind ``bvoltage``), ``Bname n+ n- I={expr}``
(kind ``bcurrent``) or ``Cname n+ n- Q={expr}`` (kind ``bcharge``), the
expression over ``V(node)``, ``V(a, b)``, ``I(vname)`` and ``time``
(:mod:`netdae.netlist.expr`).

Equations (signs as ngspice's)
------------------------------
- ``bcurrent``: the current ``expr(x, t)`` flows from n+ through the source
  to n-: ``phi[n+] -= expr``, ``phi[n-] += expr``.
- ``bcharge``: the charge ``expr(x, t)`` sits on n+ (``-expr`` on n-), as a
  capacitor's: ``q[n+] += expr``, ``q[n-] -= expr`` (charge form: the current
  into n+ is its time derivative, so a nonlinear capacitance conserves charge).
- ``bvoltage``: a branch-current unknown ``i`` (``i(bname)``, from n+
  through the source to n-, as for a V source) with
  ``phi[n+] -= i``, ``phi[n-] += i`` and the branch equation
  ``v(n+) - v(n-) - expr(x, t) = 0``.

The Jacobian is exact: forward-mode differentiation of the expression tree
(:mod:`netdae.devices.autodiff`). Sources whose expressions have the same
structure (same tree shape, any constants, any nodes) are evaluated
together in one vectorised pass: the cost of an evaluation grows with the
number of *distinct* expression shapes, not with the number of sources (a
subcircuit with B sources instantiated a hundred times costs one pass per
source of the subcircuit).

A non-finite value marks the evaluation as failed (recoverable: the solver
cuts the step or moves on). A non-finite derivative of a finite value (the
slope of ``sqrt(V(a))`` or ``ln`` at 0, where Newton iterations often start)
enters the Jacobian as 0 for that iteration: the residual, not the
Jacobian, decides convergence.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError
from ..netlist.expr import Current, Time, time_corners, walk
from .autodiff import ExpressionGroup, group_by_structure
from .base import Accumulator, DeviceFamily, NoiseSources, SlotMap
from .companion import BranchStamps

__all__ = ["BehaviouralFamily", "BehaviouralEvents"]

_VOLTAGE, _CURRENT, _CHARGE = "bvoltage", "bcurrent", "bcharge"
#: Index of the ground node in stamp arrays (netdae.mna.layout.GND).
GND = -1


class _Group:
    """Sources of one kind and one expression structure."""

    def __init__(self, kind: str, elements: list, exprs: ExpressionGroup):
        self.kind = kind
        self.elements = elements
        self.exprs = exprs
        self.stamps: BranchStamps | None = None


class BehaviouralFamily(DeviceFamily):
    """All behavioural voltage and current sources of a circuit.

    Raises
    ------
    CircuitError
        A source without an expression, with instance parameters, or whose
        expression references the current of an element that has no branch
        current (``I(r1)``).
    """


    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """No generator: a behavioural source is noiseless, as ngspice's B source (it has no noise routine)."""
        return NoiseSources()

    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        for el in self.elements:
            if el.expr is None:
                raise CircuitError(f"{el.name}: behavioural source without an expression",
                                   elements=(el.name,), location=el.location)
            if el.params:
                names = ", ".join(sorted(el.params))
                raise CircuitError(f"{el.name}: instance parameters ({names}) of behavioural sources "
                                   "are not supported by netdae", elements=(el.name,), location=el.location)
        self.groups: list[_Group] = []
        #: The locked outcomes a transient holds (``kernels.behavioural``'s ``lock``), or None: every
        #: evaluation then runs the compiled kernel with them (set by :class:`BehaviouralEvents`).
        self.held = None
        self._packed = None
        for kind in (_VOLTAGE, _CURRENT, _CHARGE):
            els = [el for el in self.elements if el.kind == kind]
            for idx in group_by_structure([el.expr for el in els]):
                members = [els[i] for i in idx]
                self.groups.append(_Group(kind, members, ExpressionGroup([el.expr for el in members])))

    # -- topology ----------------------------------------------------------
    def add_branches(self, layout) -> None:
        for el in self.elements:
            if el.kind == _VOLTAGE:
                layout.add_branch(el.name)

    def _leaf_pair(self, layout, leaf, owner) -> tuple[int, int]:
        if isinstance(leaf, Current):
            if not layout.has_branch(leaf.element):
                raise CircuitError(
                    f"{owner.name}: I({leaf.element}) refers to an element without a branch current",
                    elements=(owner.name, leaf.element),
                    hint="only voltage sources, inductors, E/H sources and behavioural voltage sources "
                    "have a current unknown; measure a current with a 0 V source in series",
                    location=owner.location,
                )
            return layout.branch(leaf.element), GND
        return layout.node(leaf.pos), (GND if leaf.neg is None else layout.node(leaf.neg))

    def coordinates(self, layout):
        self._layout = layout  # the compiled kernel's packing resolves its leaves in it
        rows, cols = [], []
        for grp in self.groups:
            n = len(grp.elements)
            controls = []
            for column in grp.exprs.leaves:
                pairs = [self._leaf_pair(layout, leaf, el) for leaf, el in zip(column, grp.elements)]
                controls.append((np.array([p for p, _ in pairs]), np.array([m for _, m in pairs])))
            plus = layout.nodes_of([el.nodes[0] for el in grp.elements])
            minus = layout.nodes_of([el.nodes[1] for el in grp.elements])
            n_leaves = len(controls)
            on_leaves = [(0, k) for k in range(n_leaves)]
            currents, current_deps, charges, charge_deps = [], [], [], []
            if grp.kind == _CHARGE:
                charges, charge_deps = [(plus, minus)], on_leaves
            elif grp.kind == _CURRENT:
                currents, current_deps = [(plus, minus)], on_leaves
            else:
                branch = np.array([layout.branch(el.name) for el in grp.elements], dtype=np.int64)
                ground = np.full(n, GND, dtype=np.int64)
                controls += [(plus, minus), (branch, ground)]
                currents = [(branch, ground), (plus, minus)]
                current_deps = on_leaves + [(0, n_leaves), (1, n_leaves + 1)]
            grp.stamps = BranchStamps(n, controls, currents, charges, current_deps, charge_deps)
            r, c = grp.stamps.coordinates()
            rows.append(r)
            cols.append(c)
        if not rows:
            return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        return np.concatenate(rows), np.concatenate(cols)

    def bind(self, slots: SlotMap, n: int) -> None:
        for grp in self.groups:
            grp.stamps.bind(slots, n)
        self._slots, self._n = slots, n
        self._packed = None
        self.held = None

    def packed(self) -> tuple:
        """The arrays of :meth:`compiled` for the slots of the last :meth:`bind` (packed once)."""
        if self._packed is None:
            self._packed = self.compiled(self._slots, self._n)
        return self._packed

    def charge_rows(self) -> np.ndarray:
        """The rows of the charge sources' terminals (``Q`` groups; the other groups store no charge)."""
        rows = [grp.stamps.charge_rows() for grp in self.groups]
        return np.unique(np.concatenate(rows)) if rows else np.empty(0, dtype=np.int64)

    def compiled(self, slots: SlotMap, n: int) -> tuple:
        """Pack the family for :func:`netdae.devices.kernels.behavioural.eval_behavioural` (after ``bind``).

        Every expression becomes a tape (:func:`netdae.devices.kernels.tape.compile_tape`).

        Returns
        -------
        tuple
            ``(prog, const, inst, leaf, val, der, lock)`` as described in
            :mod:`netdae.devices.kernels.behavioural` (``lock`` a template
            with the hold flag 0: copy it per analysis).

        Raises
        ------
        ValueError
            For an expression the kernel cannot evaluate (the numpy family
            refuses it too).
        """
        from .kernels import behavioural as kb
        from .kernels.packing import dependence_slots, extended
        from .kernels.tape import compile_tape, count_locked

        layout = self._layout
        count = len(self.elements)
        inst = np.zeros((count, kb.N_INST), dtype=np.int64)
        prog: list = []
        consts: list = []
        leaf_rows: list = []
        widest = 1
        longest = 1
        slots_used = 0
        for k, el in enumerate(self.elements):
            ops, args, cvals, leaves = compile_tape(el.expr)
            inst[k, kb.B_LOCK] = slots_used
            # a charge is continuous: its comparisons select between regions that meet (not held)
            inst[k, kb.B_NLOCK] = count_locked(ops, args) if el.kind != _CHARGE else 0
            slots_used += inst[k, kb.B_NLOCK]
            plus = layout.node(el.nodes[0])
            minus = layout.node(el.nodes[1])
            voltage = el.kind == _VOLTAGE
            branch = layout.branch(el.name) if voltage else GND
            out_a, out_b = (branch, GND) if voltage else (plus, minus)
            kind = kb.KIND_VOLTAGE if voltage else kb.KIND_CHARGE if el.kind == _CHARGE else kb.KIND_CURRENT
            inst[k, kb.B_PROG] = len(prog)
            inst[k, kb.B_LEN] = len(ops)
            inst[k, kb.B_LEAF] = len(leaf_rows)
            inst[k, kb.B_NLEAF] = len(leaves)
            inst[k, kb.B_CONST] = len(consts)
            inst[k, kb.B_KIND] = kind
            inst[k, kb.B_P], inst[k, kb.B_M], inst[k, kb.B_BR] = extended([plus, minus, branch], n)
            if voltage:
                inst[k, kb.B_S_VPM:kb.B_S_VPM + 4] = dependence_slots(slots, [branch], [GND], [plus], [minus])[0]
                inst[k, kb.B_S_IB:kb.B_S_IB + 4] = dependence_slots(slots, [plus], [minus], [branch], [GND])[0]
            else:
                inst[k, kb.B_S_VPM:kb.B_S_IB + 4] = slots.dummy
            for leaf in leaves:
                p, m = self._leaf_pair(layout, leaf, el)
                row = np.zeros(kb.N_LEAF, dtype=np.int64)
                row[kb.L_P], row[kb.L_M] = extended([p, m], n)
                row[kb.L_S:kb.L_S + 4] = dependence_slots(slots, [out_a], [out_b], [p], [m])[0]
                leaf_rows.append(row)
            prog += [(op, *a) for op, a in zip(ops, args)]
            consts += cvals
            widest = max(widest, len(leaves))
            longest = max(longest, len(ops))
        return (np.array(prog, dtype=np.int64).reshape(-1, 4), np.array(consts, dtype=float),
                inst, np.array(leaf_rows, dtype=np.int64).reshape(-1, kb.N_LEAF), np.zeros(2 * longest),
                np.zeros((longest, widest)), np.zeros((kb.N_LOCK_ROWS, slots_used + 1)))

    def time_charge_rows(self) -> np.ndarray:
        """The rows of the terminals of the charge sources whose expression reads ``time``
        (``Q={1n*sin(2*pi*1k*time) + 1p*v(a)}``: a charge that moves at fixed unknowns; ground -1 dropped)."""
        layout = self._layout
        rows = [layout.node(node) for el in self.elements
                if el.kind == _CHARGE and any(type(n) is Time for n in walk(el.expr)) for node in el.nodes[:2]]
        rows = np.unique(np.asarray(rows, dtype=np.int64))
        return rows[rows >= 0]

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Where an expression jumps or kinks in ``time`` (``time < 1m ? a : b``, ``u(time - td)``):
        :func:`netdae.netlist.expr.time_corners` of every expression that reads ``time``."""
        out: list[float] = []
        for el in self.elements:
            if any(type(n) is Time for n in walk(el.expr)):
                out.extend(time_corners(el.expr, t0, t1))
        return np.unique(np.asarray(out, dtype=float))

    def junction_nodes(self) -> list[tuple[str, str]]:
        return [(el.nodes[0], el.nodes[1]) for el in self.elements if el.kind == _VOLTAGE]

    # -- evaluation --------------------------------------------------------
    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        if self.held is not None:
            return self._evaluate_held(x, t, acc, jacobian)
        ok = True
        with np.errstate(all="ignore"):
            for grp in self.groups:
                v = grp.stamps.voltages(x)
                n_leaves = grp.exprs.n_leaves
                value, deriv = grp.exprs.evaluate(v[:n_leaves], t)
                if not math.isfinite(float(deriv.sum())):
                    deriv = np.where(np.isfinite(deriv), deriv, 0.0)
                none = np.empty((0, value.size))
                if grp.kind == _CHARGE:
                    currents, dcur, charges, dchg = none, None, value[None, :], deriv
                elif grp.kind == _CURRENT:
                    currents, dcur, charges, dchg = value[None, :], deriv, none, None
                else:
                    n = value.size
                    currents = np.stack([value - v[n_leaves], v[n_leaves + 1]])
                    dcur = np.concatenate([deriv, -np.ones((1, n)), np.ones((1, n))])
                    charges, dchg = none, None
                grp.stamps.add(acc, currents, dcur, charges, dchg, jacobian=jacobian)
                ok = ok and math.isfinite(float(value.sum()))
        if not ok:
            acc.ok = False
        return None

    def _evaluate_held(self, x, t, acc: Accumulator, jacobian) -> None:
        """Every source through the compiled kernel with the held outcomes (a transient's step)."""
        from .kernels.behavioural import eval_behavioural

        prog, const, inst, leaf, val, der, _ = self.packed()
        xe = np.asarray(x, dtype=float)  # extended (ground last), as every family receives it
        if xe.size != acc.n + 1:
            raise ValueError(f"expected the extended unknowns ({acc.n + 1} values), got {xe.size}")
        flags, bad = eval_behavioural(xe, float(t), prog, const, inst, leaf, val, der, self.held, acc.q, acc.phi,
                                      acc.dq, acc.dphi, bool(jacobian))
        if bad >= 0:
            acc.ok = False


class BehaviouralEvents:
    """A transient's held comparisons of behavioural sources: their outcomes and the events that change them.

    The twin of :class:`netdae.devices.switch.SwitchEvents` for the comparisons of the circuit's state in
    behavioural expressions (:mod:`netdae.devices.kernels.behavioural`, "Locked outcomes"): the Python
    ``BDF`` driver calls :meth:`start`, after every accepted step :meth:`step`, and :meth:`flip` once the
    step's end is recorded; while held, the family evaluates through the compiled kernel.

    Parameters
    ----------
    family : BehaviouralFamily
        Bound (its slots known).
    n : int
        Number of unknowns.
    """

    def __init__(self, family: BehaviouralFamily, n: int) -> None:
        self.family = family
        self.n = n
        prog, const, inst, leaf, val, der, lock = family.packed()
        self.lock = lock.copy()
        self._xw = np.zeros(n + 1)
        self.events = 0

    @staticmethod
    def of(family: BehaviouralFamily, n: int) -> "BehaviouralEvents | None":
        """The events of ``family``, or None when none of its sources compares the circuit's state."""
        return BehaviouralEvents(family, n) if family.packed()[6].shape[1] > 1 else None

    def start(self, x: np.ndarray, t: float) -> None:
        """Hold the outcomes at ``x`` at ``t`` (the integration's start)."""
        from .kernels.behavioural import lock_record

        prog, const, inst, leaf, val, der, _ = self.family.packed()
        lock_record(np.append(np.asarray(x, dtype=float), 0.0), float(t), prog, const, inst, leaf, val, der,
                    self.lock)
        self.family.held = self.lock

    def hold(self, lock: np.ndarray) -> None:
        """Hold ``lock`` (e.g. the compiled loop's) in every evaluation."""
        self.lock[:] = lock
        self.family.held = self.lock

    def release(self) -> None:
        """Stop holding: evaluations decide the outcomes again (as an operating point does)."""
        self.family.held = None

    def step(self, P: np.ndarray, k: int, psi: np.ndarray, t: float, t_new: float,
             t_cap: float) -> tuple[float, tuple[str, ...]]:
        """After an accepted step: the first change of an outcome in ``(t, t_cap]`` (see ``lock_step``).

        Returns
        -------
        (t_end, changed)
            ``t_end``: the change's time, or ``t_cap``; ``changed``: the sources whose outcomes change
            there (empty: none). Call :meth:`flip` after the point at ``t_end`` is evaluated.
        """
        from ..dae.compiled.events import EVENT_TOGETHER
        from .kernels.behavioural import lock_step

        prog, const, inst, leaf, val, der, _ = self.family.packed()
        t_end, count = lock_step(P, int(k), psi, float(t), float(t_new), float(t_cap), self.n, prog, const, inst,
                                 leaf, val, der, self.lock, self._xw)
        if not count:
            return t_cap, ()
        self._limit = t_end + EVENT_TOGETHER * (t_new - t)
        return t_end, self._changing(inst)

    def undefined(self) -> str | None:
        """The source whose held branch was undefined at the last evaluation's point (None: none)."""
        from .kernels.behavioural import lock_undefined

        k = lock_undefined(self.lock)
        return self.family.elements[k].name if k >= 0 else None

    def ahead(self, P: np.ndarray, k: int, psi: np.ndarray, t: float, h: float,
              together: float) -> tuple[float | None, tuple[str, ...]]:
        """Before a step from ``t``: the first change of an outcome in ``(t, t + h]`` on the last step's
        polynomial continued (``P`` and ``psi`` the history at ``t``; the compiled engine's twin is in
        ``bdf_loop.run``).

        Returns
        -------
        (t_change, changed)
            The change's time (``t`` itself when the continued polynomial is past it at ``t``) and the
            sources changing within ``together`` of it, or ``(None, ())``. :meth:`flip` makes them change.
        """
        from .kernels.behavioural import LOCK_TIME, lock_step

        prog, const, inst, leaf, val, der, _ = self.family.packed()
        _, count = lock_step(P, int(k), psi, float(t), float(t), float(t + h), self.n, prog, const, inst, leaf,
                             val, der, self.lock, self._xw)
        if not count:
            return None, ()
        first = float(min(t + h, self.lock[LOCK_TIME, :-1].min()))
        self._limit = first + together
        return first, self._changing(inst)

    def at(self, x: np.ndarray, t: float) -> tuple[str, ...]:
        """The outcomes at ``x`` that differ from the held ones change at ``t`` (``lock_at``); the sources
        changing. :meth:`flip` makes them change."""
        from .kernels.behavioural import lock_at

        prog, const, inst, leaf, val, der, _ = self.family.packed()
        lock_at(np.append(np.asarray(x, dtype=float), 0.0), float(t), prog, const, inst, leaf, val, der, self.lock)
        self._limit = float(t)
        return self._changing(inst)

    def _changing(self, inst) -> tuple[str, ...]:
        """The sources with an outcome changing by the pending limit (what :meth:`flip` changes)."""
        from .kernels.behavioural import lock_changed

        return tuple(el.name for i, el in enumerate(self.family.elements)
                     if lock_changed(inst, self.lock, i, self._limit))

    def flip(self) -> None:
        """The outcomes :meth:`step` found changing take their new values."""
        from .kernels.behavioural import lock_flip

        lock_flip(self.lock, self._limit)
        self.events += 1
