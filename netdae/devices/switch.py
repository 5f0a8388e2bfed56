"""Voltage- and current-controlled switches (S and W), as ngspice 39 computes them.

Syntax: ``Sname n+ n- nc+ nc- model [ON|OFF]`` with ``.model name SW (VT= VH= RON= ROFF=)``;
``Wname n+ n- vname model [ON|OFF]`` with ``.model name CSW (IT= IH= RON= ROFF=)``.

A switch is a resistor between n+ and n-: ``RON`` (default 1 ohm) when it is
on, ``ROFF`` (default ``1/GMIN``, 1e12 ohm) when it is off. Its *state* follows
the control ``c`` -- the voltage ``v(nc+) - v(nc-)`` (S) or the current of the
element ``vname`` (W: a V source, inductor, E/H or B voltage source) -- with
the threshold ``VT`` (``IT``) and the hysteresis ``VH`` (``IH``), in ngspice's
four states (``swload.c``, ``cswload.c``; :mod:`netdae.devices.kernels.switch`):

* ``VH > 0``: the switch turns on when ``c > VT + VH``, off when
  ``c < VT - VH``, and keeps its state in between;
* ``VH <= 0`` (ngspice's "negative hysteresis", ``VH = 0`` included): on
  above ``VT - VH``, off below ``VT + VH``; a control that enters the band
  ``[VT + VH, VT - VH]`` reverses the state it had outside (from above: off,
  from below: on), which then holds while the control stays inside.

Operating point (ngspice's ``MODEINITJCT`` then ``MODEINITFLOAT``): the first
Newton iteration uses the ON/OFF flag (no flag: off), the following ones
decide from the iterate's control; inside the band the state is the previous
iterate's for S with ``VH > 0``, and otherwise the one ngspice's
``CKTstate1`` implies, ``REALLY_OFF`` (so inside the band an S with
``VH <= 0`` is on and a W is off, whatever the flag; ngspice 39 does the
same). A change of conductance asks for another iteration (the "limited"
flag, ngspice's ``CKTnoncon++``). In a DC sweep each point starts from the
states of the previous one (``memory``, :meth:`SwitchFamily.remember`), which
also replace ``REALLY_OFF`` as the reference: a sweep down shows the
hysteresis as ngspice's does.

Transient: the state is held through each step (the conductance is constant
while Newton iterates) and decided between steps at the accepted points, with
the hysteresis of the previous accepted state. A step at whose end a switch
would change conductance is cut where the control crossed the threshold,
located on the step's interpolant (:class:`SwitchEvents`,
:mod:`netdae.dae.compiled.events`); the switch changes there and the method
restarts at order 1 from the right limit.

``held`` (set by the integrators through :class:`SwitchEvents`): the states a
transient holds; every evaluation then uses them, whatever the ``state``
argument. ``memory`` (set by a DC sweep): the previous point's states. The
compiled kernel knows ``held`` (its hold flag) but not ``memory``: it serves
transients only.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import CircuitError
from ..kinds import Kind
from .base import Accumulator, DeviceFamily, NoiseSources, SlotMap, noise_sources, thermal
from .companion import BranchStamps, LimitState
from .kernels.switch_states import HYST_OFF, HYST_ON, REALLY_OFF, REALLY_ON
from .modelcard import ParameterTable, instance_values, resolve_model

__all__ = ["SwitchFamily", "SwitchEvents", "SW_PARAMETERS", "CSW_PARAMETERS"]

SW_PARAMETERS = ParameterTable(
    "voltage-controlled switch",
    defaults={"vt": 0.0, "vh": 0.0, "ron": 1.0, "roff": None},
    family="vswitch",
)
CSW_PARAMETERS = ParameterTable(
    "current-controlled switch",
    defaults={"it": 0.0, "ih": 0.0, "ron": 1.0, "roff": None},
    family="cswitch",
)
#: Instance flags (``ON``/``OFF``, stored as 1.0 when given).
_INSTANCE = {"on": None, "off": None}
#: Ground in stamp arrays (netdae.mna.layout.GND).
GND = -1



def _kernels():
    """The compiled switch kernels and their layout (imported on first use: they load numba)."""
    from .kernels import switch as ks

    return ks


def conducting(s: np.ndarray) -> np.ndarray:
    """True where the state conducts with GON."""
    return (s == REALLY_ON) | (s == HYST_ON)


def junction_state(c, on, vt, vh) -> np.ndarray:
    """ngspice's ``MODEINITJCT`` states (vectorised :func:`netdae.devices.kernels.switch.junction_state`)."""
    up = np.where(vh >= 0.0, c > vt + vh, c > vt - vh)
    down = np.where(vh >= 0.0, c < vt - vh, c < vt + vh)
    return np.where(on, np.where(up, REALLY_ON, HYST_ON), np.where(down, REALLY_OFF, HYST_OFF))


def decide(c, ref, vt, vh) -> np.ndarray:
    """ngspice's ``MODEINITFLOAT`` states (vectorised :func:`netdae.devices.kernels.switch.decide`)."""
    positive = vh > 0.0
    hi = np.where(positive, vt + vh, vt - vh)
    lo = np.where(positive, vt - vh, vt + vh)
    band = np.where(positive | (ref == HYST_OFF) | (ref == HYST_ON), ref,
                    np.where(ref == REALLY_ON, HYST_OFF, HYST_ON))
    return np.where(c > hi, REALLY_ON, np.where(c < lo, REALLY_OFF, band))


def switched(s, vh) -> np.ndarray:
    """The states just past the threshold after states ``s`` (vectorised :func:`netdae.devices.kernels.switch.switched`)."""
    flipped = np.where(s == REALLY_OFF, HYST_ON, np.where(s == HYST_OFF, REALLY_ON,
                                                          np.where(s == REALLY_ON, HYST_OFF, REALLY_OFF)))
    return np.where(vh > 0.0, np.where(conducting(s), REALLY_OFF, REALLY_ON), flipped)


class SwitchFamily(DeviceFamily):
    """All S and W switches of a circuit, evaluated in one vectorised pass.

    Parameters
    ----------
    elements : list of Element
        The ``vswitch`` and ``cswitch`` elements.
    circuit : Circuit

    Raises
    ------
    CircuitError
        A missing or mistyped model, an instance parameter other than ON/OFF.
    NetlistError
        A non-positive RON or ROFF (at the value).

    Attributes
    ----------
    held : ndarray or None
        The states a transient holds (see the module docstring).
    memory : ndarray or None
        The states of the previous point of a DC sweep (None: an operating point of its own).
    """


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        gmin = float(circuit.options.gmin)
        count = len(self.elements)
        self.gon, self.goff, self.vt, self.vh = (np.zeros(count) for _ in range(4))
        self.on = np.zeros(count, dtype=bool)
        self.dc_hold = np.zeros(count, dtype=bool)
        for k, el in enumerate(self.elements):
            voltage = el.kind == Kind.VSWITCH
            model = resolve_model(el, circuit, ("sw",) if voltage else ("csw",))
            mv = (SW_PARAMETERS if voltage else CSW_PARAMETERS).read(model)
            inst = instance_values(el, _INSTANCE, "switch")
            if inst.get("on") and inst.get("off"):
                raise CircuitError(f"{el.name}: both ON and OFF given", elements=(el.name,))
            self.gon[k] = 1.0 / mv["ron"]
            self.goff[k] = 1.0 / mv["roff"] if mv.given("roff") else gmin
            self.vt[k] = mv["vt" if voltage else "it"]
            self.vh[k] = mv["vh" if voltage else "ih"]
            self.on[k] = bool(inst.get("on"))
            self.dc_hold[k] = voltage and self.vh[k] > 0.0
        self.held: np.ndarray | None = None
        self.memory: np.ndarray | None = None

    # -- topology ----------------------------------------------------------
    def coordinates(self, layout):
        els = self.elements
        self.plus = layout.nodes_of([el.nodes[0] for el in els])
        self.minus = layout.nodes_of([el.nodes[1] for el in els])
        cp, cm = [], []
        for el in els:
            if el.kind == Kind.VSWITCH:
                cp.append(layout.node(el.nodes[2]))
                cm.append(layout.node(el.nodes[3]))
                continue
            name = el.controls[0] if el.controls else None
            if name is None or not layout.has_branch(name):
                raise CircuitError(f"{el.name}: the controlling element '{name}' has no branch current",
                                   elements=(el.name,) + ((name,) if name else ()),
                                   hint="W senses the current of a V source, inductor, E/H source or B voltage "
                                        "source; put a 0 V source in series with the branch and name it",
                                        location=el.location)
            cp.append(layout.branch(name))
            cm.append(GND)
        self.cp = np.array(cp, dtype=np.int64)
        self.cm = np.array(cm, dtype=np.int64)
        branch = (self.plus, self.minus)
        self.stamps = BranchStamps(len(els), [branch], [branch], [], [(0, 0)], [])
        return self.stamps.coordinates()

    def bind(self, slots: SlotMap, n: int) -> None:
        self.stamps.bind(slots, n)
        self._q = np.zeros((0, len(self.elements)))

    def junction_nodes(self) -> list[tuple[str, str]]:
        return [(el.nodes[0], el.nodes[1]) for el in self.elements]

    # -- states --------------------------------------------------------------
    def control(self, x_ext: np.ndarray) -> np.ndarray:
        """The control values (``v(nc+) - v(nc-)``, or the controlling current) at the extended ``x``."""
        return x_ext[self.cp] - x_ext[self.cm]

    def dc_state(self, c: np.ndarray, old: np.ndarray | None) -> np.ndarray:
        """The operating point's states at control ``c`` after the previous iterate's ``old`` (None: none).

        See :func:`netdae.devices.kernels.switch.dc_state`; in a DC sweep (``memory``)
        the previous point's states stand for the ON/OFF flags and for ``REALLY_OFF``.
        """
        memory = self.memory
        if old is None:
            old = junction_state(c, self.on, self.vt, self.vh) if memory is None else memory
        ref = np.where(self.dc_hold, old, REALLY_OFF if memory is None else memory)
        return decide(c, ref, self.vt, self.vh)

    def remember(self, x_ext: np.ndarray) -> None:
        """Keep the states at the solution ``x_ext`` of a DC sweep's point for the next point."""
        self.memory = self.dc_state(self.control(x_ext), None)

    def initial_state(self) -> LimitState:
        """SPICE's ``MODEINITJCT``: the ON/OFF flags decide the first iteration."""
        count = len(self.elements)
        return LimitState(np.vstack([np.where(self.on, HYST_ON, HYST_OFF), np.zeros(count)]), initial=True)

    def compiled(self, slots: SlotMap, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pack the family for :func:`netdae.devices.kernels.switch.eval_switch` (after ``bind``).

        Returns
        -------
        par : ndarray, shape (N, kernels.switch.N_PAR)
        idx : ndarray of int64, shape (N, kernels.switch.N_IDX)
        vold0 : ndarray, shape (N, kernels.switch.N_STATE)
            The initial state (:meth:`initial_state`), not held.
        """
        from .kernels.packing import columns, dependence_slots, node_columns

        ks = _kernels()

        count = len(self.elements)
        par = columns(count, ks.N_PAR, {
            ks.P_GON: self.gon, ks.P_GOFF: self.goff, ks.P_VT: self.vt, ks.P_VH: self.vh, ks.P_ON: self.on,
            ks.P_DC_HOLD: self.dc_hold})
        idx = node_columns(count, ks.N_IDX, {ks.I_P: self.plus, ks.I_M: self.minus, ks.I_CP: self.cp,
                                             ks.I_CM: self.cm}, n)
        idx[:, ks.S_G:ks.S_G + 4] = dependence_slots(slots, self.plus, self.minus, self.plus, self.minus)
        return par, idx, self.initial_state().v.T.copy()

    def read_unknowns(self, k: int | None = None) -> np.ndarray:
        """The switched branch's nodes and the control's unknowns (nodes, or the sensed branch current)."""
        cols = slice(None) if k is None else k
        return np.unique(np.concatenate([np.ravel(a[cols]) for a in (self.plus, self.minus, self.cp, self.cm)]))

    def point_states(self, column, jumps):
        """The switches' states along a sequence of solutions (a ``.dc`` sweep's points, a transient's).

        The first point's are the operating point's (:meth:`dc_state`); each
        later point's follow from the previous point's by the hysteresis
        (:func:`decide`), as the integrator decides them at its accepted
        points. At a switching event the transient records the left and the
        right limit at one time: the left keeps the states of the step before,
        the right takes the switched states of the switches named by the event
        (the integrator's rule: past the threshold, whatever rounding left the
        control at), the others' unchanged conductance.
        """
        c = column(self.cp) - column(self.cm)
        names = np.array([el.name for el in self.elements], dtype=object)
        jumps = jumps or {}
        states = np.empty(c.shape)
        s = self.dc_state(c[0], None)
        for k in range(c.shape[0]):
            if k == 0 or k in jumps:
                pass
            elif k - 1 in jumps:
                new = decide(c[k], s, self.vt, self.vh)
                named = np.isin(names, list(jumps[k - 1]))
                same = conducting(new) == conducting(s)
                s = np.where(named & same, switched(s, self.vh), np.where(~named & ~same, s, new))
            else:
                s = decide(c[k], s, self.vt, self.vh)
            states[k] = s
        return states

    def quantities(self, x, dxdt=None, states=None):
        """ngspice's switch quantities ``@s1[i]`` and ``@s1[p]`` at solutions ``x``, shape (T, N) each.

        ``i`` is the current from n+ through the switch to n- (RON's or ROFF's
        conductance, by ``states`` (:meth:`point_states`; None: each point's
        operating-point state), times the voltage), ``p`` the power it absorbs.
        """
        xx = np.atleast_2d(x)
        if states is None:
            states = self.dc_state((xx[:, self.cp] - xx[:, self.cm]), None)
        v = xx[:, self.plus] - xx[:, self.minus]
        i = np.where(conducting(states), self.gon, self.goff) * v
        return {"i": i, "p": v * i}

    def noise(self, x: np.ndarray, temp: float) -> NoiseSources:
        """Thermal noise of each switch's conductance at the operating point ``x`` (extended).

        One generator per switch (``swnoise.c``, ``cswnoise.c``), named by the
        switch alone: ``4 k T`` times RON's or ROFF's conductance, the one of
        the state the operating point's evaluation decides, which the
        small-signal matrix has too (ngspice 39 takes RON's for every state
        number but 0, an OFF switch inside its hysteresis band included, while
        its AC matrix has ROFF's whatever the state).
        """
        g = np.where(conducting(self.dc_state(self.control(x), None)), self.gon, self.goff)
        names = [el.name for el in self.elements]
        return noise_sources(names, [("", self.plus, self.minus, thermal(g, temp), 0.0, 1.0)])

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        count = len(self.elements)
        if self.held is not None:
            s = np.asarray(self.held, dtype=float).copy()
            hold = np.ones(count)
        else:
            c = self.control(x)
            hold = np.zeros(count) if state is None else np.asarray(state.v[1], dtype=float)
            if state is None:
                s = self.dc_state(c, None)
            elif state.initial:
                s = junction_state(c, self.on, self.vt, self.vh)
            else:
                s = self.dc_state(c, state.v[0])
                if np.any((conducting(s) != conducting(state.v[0])) & (hold == 0.0)):
                    acc.limited = True
            if state is not None:
                s = np.where(hold != 0.0, state.v[0], s)
        g = np.where(conducting(s), self.gon, self.goff)
        with np.errstate(all="ignore"):
            current = g * self.stamps.voltages(x)[0]
        self.stamps.add(acc, current[None, :], g[None, :], self._q, self._q, jacobian=jacobian)
        if not math.isfinite(float(current.sum())):
            acc.ok = False
        return LimitState(np.vstack([s, hold]))


class SwitchEvents:
    """A transient's switches: their held states, decided between steps, and the events that change them.

    Parameters
    ----------
    family : SwitchFamily
    pattern : SparsePattern
        The system's pattern (for the kernels' packing).
    n : int
        Number of unknowns.

    Attributes
    ----------
    states : ndarray, shape (N, 2)
        The held states (column 0) and the hold flags (column 1, all 1), as the
        compiled loop keeps them (``kernels.switch.V_*``).
    events : int
        Steps cut at a switching event so far.

    Notes
    -----
    The Python ``BDF`` driver calls :meth:`start` and, after every accepted
    step, :meth:`step`; the compiled loop runs the same kernel
    (:func:`netdae.devices.kernels.switch.switch_step`) on its own copy of
    the states, and hands them to :meth:`hold` when it asks Python for a
    right limit.
    """

    def __init__(self, family: SwitchFamily, pattern, n: int) -> None:
        ks = _kernels()
        self.family = family
        self.n = n
        self.par, self.idx, _ = family.compiled(SlotMap(pattern), n)
        count = len(family.elements)
        self.states = np.zeros((count, ks.N_STATE))
        self._new = np.zeros((count, ks.N_STATE))
        self._tcross = np.zeros(count)
        self._xe = np.zeros(n + 1)
        self._xw = np.zeros(n)
        self.events = 0

    def start(self, x: np.ndarray) -> np.ndarray:
        """Hold the operating point's states at ``x`` (the integration's start); returns ``states``."""
        ks = _kernels()
        xe = np.append(np.asarray(x, dtype=float), 0.0)
        self.states[:, ks.V_STATE] = self.family.dc_state(self.family.control(xe), None)
        self.states[:, ks.V_HOLD] = 1.0
        self.family.held = self.states[:, ks.V_STATE].copy()
        return self.states

    def hold(self, states: np.ndarray) -> None:
        """Hold ``states`` (shape (N, 2), e.g. the compiled loop's) in every evaluation."""
        ks = _kernels()
        self.states[:] = states
        self.family.held = self.states[:, ks.V_STATE].copy()

    def release(self) -> None:
        """Stop holding: evaluations decide the states again (as an operating point does)."""
        self.family.held = None

    def at(self, x: np.ndarray, t: float) -> tuple[str, ...]:
        """The states at the point ``x`` at ``t``, where an event without a step happens (a behavioural
        source's comparison changing at ``t``, its held branch undefined past it); the switches that change
        conductance there, in that event (:func:`netdae.devices.kernels.switch.switch_at`)."""
        ks = _kernels()
        xe = np.append(np.asarray(x, dtype=float), 0.0)
        changes = ks.switch_at(xe, float(t), self.par, self.idx, self.states, self._new, self._tcross)
        self.hold(self.states)
        if not changes:
            return ()
        self.events += 1
        return tuple(el.name for el, tc in zip(self.family.elements, self._tcross) if tc <= t)

    def step(self, P: np.ndarray, k: int, psi: np.ndarray, t: float,
             t_new: float) -> tuple[float, tuple[str, ...], np.ndarray | None]:
        """After an accepted step (``P`` updated): where it ends and the switches' states there.

        Returns
        -------
        (t_end, switched, x_event)
            ``t_end`` is ``t_new`` or the first crossing of a threshold;
            ``switched`` the switches that change conductance at ``t_end``
            (the method must restart there when there is any); ``x_event``
            the interpolated unknowns when the step was cut (else None). The
            held states are updated.
        """
        ks = _kernels()
        t_end, changes = ks.switch_step(P, int(k), psi, float(t), float(t_new), self.n, self.par, self.idx,
                                        self.states, self._new, self._tcross, self._xe, self._xw)
        self.hold(self._new)
        switched = ()
        if changes:
            self.events += 1
            from ..dae.compiled.events import EVENT_TOGETHER

            limit = t_end + EVENT_TOGETHER * (t_new - t)
            switched = tuple(el.name for el, tc in zip(self.family.elements, self._tcross) if tc <= limit)
        return t_end, switched, (self._xw.copy() if t_end < t_new else None)
