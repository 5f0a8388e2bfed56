"""Scatter of nonlinear branch currents and charges into the MNA system.

A nonlinear device family is described, for all its instances at once, by

- *controls*: node pairs ``(p_k, m_k)`` whose voltage differences
  ``v_k = x[p_k] - x[m_k]`` the device equations depend on (``vbe``, ``vds`` ...);
- *current branches*: node pairs ``(a_j, b_j)`` carrying a current ``i_j(v)``
  from ``a_j`` through the device to ``b_j``;
- *charge branches*: node pairs carrying a charge ``Q_j(v)`` stored on the
  ``a_j`` side (``-Q_j`` on the ``b_j`` side), as a capacitor does;
- the sparse dependence of each output on the controls: a list of
  ``(output, control)`` pairs whose derivatives the family provides.

:class:`BranchStamps` precomputes, once, every row and every Jacobian slot
these imply, and then adds one evaluation into an
:class:`~netdae.devices.base.Accumulator` with one ``bincount`` per array:
``phi[a] -= i``, ``phi[b] += i``, ``q[a] += Q``, ``q[b] -= Q`` and the
matching derivative entries.

SPICE's companion model
-----------------------
When a family limits its control voltages (``pnjlim``), the outputs are
evaluated at the limited voltages ``v_lim`` and continued linearly to the
iterate's voltages ``v(x)``:

    i(x) = i(v_lim) + di/dv (v_lim) (v(x) - v_lim),

the same for the charges. The Newton step then solves exactly the linear
circuit SPICE builds from its companion models (conductance ``g`` and
current source ``i - g v_lim``), and at convergence ``v(x) = v_lim``.

Sign conventions are those of :mod:`netdae.devices.base`.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .base import Accumulator, SlotMap

__all__ = ["BranchStamps", "LimitState", "GateJunctionLimits", "starting_voltages"]

# row/column order of the four Jacobian entries of one (output, control) pair:
# (a, p), (a, m), (b, p), (b, m)
_CURRENT_SIGNS = np.array([-1.0, 1.0, 1.0, -1.0])[:, None, None]
_CHARGE_SIGNS = -_CURRENT_SIGNS


def _pairs(nodes, n: int) -> tuple[np.ndarray, np.ndarray]:
    arr = np.asarray(nodes, dtype=np.int64).reshape(-1, 2, n)
    return arr[:, 0, :], arr[:, 1, :]


class BranchStamps:
    """Rows and slots of a family's nonlinear branches, and their scatter.

    Parameters
    ----------
    n : int
        Number of instances N.
    controls : array_like of int, shape (nc, 2, N)
        ``controls[k] = (p_k, m_k)``: node indices (ground ``-1``) per instance.
    currents : array_like of int, shape (ni, 2, N)
        Current branches ``(a_j, b_j)``.
    charges : array_like of int, shape (nq, 2, N)
        Charge branches.
    current_deps, charge_deps : sequence of (int, int)
        ``(output j, control k)`` pairs with a non-zero derivative, in the
        order the family returns the derivative rows.

    Notes
    -----
    Memory: ``4 N`` slots per dependence pair. Each :meth:`add` costs a few
    numpy calls over arrays of ``N`` times the number of pairs.
    """

    def __init__(self, n: int, controls, currents, charges, current_deps: Sequence[tuple[int, int]],
                 charge_deps: Sequence[tuple[int, int]]):
        self.n_instances = int(n)
        self.ctrl_p, self.ctrl_m = _pairs(controls, n)
        self.cur_a, self.cur_b = _pairs(currents, n)
        self.chg_a, self.chg_b = _pairs(charges, n)
        self.current_deps = np.asarray(current_deps, dtype=np.int64).reshape(-1, 2)
        self.charge_deps = np.asarray(charge_deps, dtype=np.int64).reshape(-1, 2)
        # 0/1 matrices summing per-dependence terms into their outputs (linearisation)
        self._cur_sum = self._summation(self.current_deps, self.cur_a.shape[0])
        self._chg_sum = self._summation(self.charge_deps, self.chg_a.shape[0])

    @staticmethod
    def _summation(deps: np.ndarray, n_out: int) -> np.ndarray:
        mat = np.zeros((n_out, deps.shape[0]))
        if deps.size:
            mat[deps[:, 0], np.arange(deps.shape[0])] = 1.0
        return mat

    def _entries(self, a, b, deps) -> tuple[np.ndarray, np.ndarray]:
        if deps.size == 0:
            return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        j, k = deps[:, 0], deps[:, 1]
        rows = np.stack([a[j], a[j], b[j], b[j]])
        cols = np.stack([self.ctrl_p[k], self.ctrl_m[k], self.ctrl_p[k], self.ctrl_m[k]])
        return rows, cols

    def coordinates(self) -> tuple[np.ndarray, np.ndarray]:
        """Every (row, column) the branches write, ground included (index -1)."""
        r1, c1 = self._entries(self.cur_a, self.cur_b, self.current_deps)
        r2, c2 = self._entries(self.chg_a, self.chg_b, self.charge_deps)
        return np.concatenate([r1.ravel(), r2.ravel()]), np.concatenate([c1.ravel(), c2.ravel()])

    def charge_rows(self) -> np.ndarray:
        """The rows the charge branches write (their charges and derivatives), ground (-1) included, sorted."""
        return np.unique(np.concatenate([self.chg_a.ravel(), self.chg_b.ravel()]))

    def bind(self, slots: SlotMap, n: int) -> None:
        """Precompute extended rows and Jacobian slots (once, after the pattern is fixed)."""
        self._cur_rows = Accumulator.rows(np.concatenate([self.cur_a, self.cur_b]).ravel(), n)
        self._chg_rows = Accumulator.rows(np.concatenate([self.chg_a, self.chg_b]).ravel(), n)
        r, c = self._entries(self.cur_a, self.cur_b, self.current_deps)
        self._cur_slots = slots(r, c).ravel()
        r, c = self._entries(self.chg_a, self.chg_b, self.charge_deps)
        self._chg_slots = slots(r, c).ravel()
        n_inst = self.n_instances
        self._cur_buf = np.empty((2, self.cur_a.shape[0], n_inst))
        self._chg_buf = np.empty((2, self.chg_a.shape[0], n_inst))
        self._dcur_buf = np.empty((4, self.current_deps.shape[0], n_inst))
        self._dchg_buf = np.empty((4, self.charge_deps.shape[0], n_inst))

    def voltages(self, x_ext: np.ndarray) -> np.ndarray:
        """Control voltages ``x[p_k] - x[m_k]``, shape (nc, N).

        ``x_ext`` is the extended iterate (``x_ext[-1] == 0`` is ground, so
        index -1 reads ground).
        """
        return x_ext[self.ctrl_p] - x_ext[self.ctrl_m]

    def voltages_at(self, x_ext: np.ndarray) -> np.ndarray:
        """Control voltages at many solutions: ``x_ext`` of shape (T, n + 1) gives (nc, T, N).

        For a family's device quantities (:meth:`~netdae.devices.base.DeviceFamily.quantities`),
        not the Newton iteration; ``x_ext[:, -1] == 0`` is ground.
        """
        x = np.atleast_2d(x_ext)
        return np.moveaxis(x[:, self.ctrl_p] - x[:, self.ctrl_m], 1, 0)

    def charge_rates(self, dcharges: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """``dQ_j/dt = sum_k dQ_j/dv_k dv_k/dt`` of every charge branch, shape (nq, T, N).

        Parameters
        ----------
        dcharges : ndarray, shape (len(charge_deps), T, N)
            The charges' derivatives, in the order of ``charge_deps``.
        rates : ndarray, shape (nc, T, N)
            The controls' time derivatives (:meth:`voltages_at` of ``dx/dt``).
        """
        out = np.zeros((self.chg_a.shape[0],) + rates.shape[1:])
        for d, (j, k) in enumerate(self.charge_deps):
            out[j] += dcharges[d] * rates[k]
        return out

    def linearise(self, values: np.ndarray, derivs: np.ndarray, deps: np.ndarray, summation: np.ndarray,
                  delta: np.ndarray) -> np.ndarray:
        """``values + sum_k d(values)/dv_k * delta_k`` (the companion-model continuation)."""
        if deps.size == 0:
            return values
        return values + summation @ (derivs * delta[deps[:, 1]])

    def add(self, acc: Accumulator, currents: np.ndarray, dcurrents: np.ndarray | None,
            charges: np.ndarray, dcharges: np.ndarray | None, *, delta: np.ndarray | None = None,
            jacobian: bool = True) -> None:
        """Add one evaluation to the accumulator.

        Parameters
        ----------
        acc : Accumulator
        currents : ndarray, shape (ni, N)
            Branch currents at the (limited) control voltages.
        dcurrents : ndarray, shape (len(current_deps), N) or None
            Their derivatives, in the order of ``current_deps``.
        charges : ndarray, shape (nq, N)
        dcharges : ndarray, shape (len(charge_deps), N) or None
        delta : ndarray, shape (nc, N), optional
            ``v(x) - v_lim`` where the family limited its voltages; the
            outputs are then continued linearly (SPICE's companion model).
        jacobian : bool
            Also add the derivatives.
        """
        if delta is not None:
            currents = self.linearise(currents, dcurrents, self.current_deps, self._cur_sum, delta)
            charges = self.linearise(charges, dcharges, self.charge_deps, self._chg_sum, delta)
        if currents.size:
            buf = self._cur_buf
            np.negative(currents, out=buf[0])
            buf[1] = currents
            acc.add_phi(self._cur_rows, buf.ravel())
        if charges.size:
            buf = self._chg_buf
            buf[0] = charges
            np.negative(charges, out=buf[1])
            acc.add_q(self._chg_rows, buf.ravel())
        if not jacobian:
            return
        if self.current_deps.size:
            acc.add_dphi(self._cur_slots, np.multiply(_CURRENT_SIGNS, dcurrents, out=self._dcur_buf).ravel())
        if self.charge_deps.size:
            acc.add_dq(self._chg_slots, np.multiply(_CHARGE_SIGNS, dcharges, out=self._dchg_buf).ravel())


class LimitState:
    """Limited control voltages of one family from the previous Newton iteration.

    Attributes
    ----------
    v : ndarray, shape (k, N)
        The voltages the device equations were last evaluated at.
    initial : bool
        True for the state before the first iteration of a solve (SPICE's
        ``MODEINITJCT``): the family then starts from ``v`` when the iterate
        is the zero vector, and from the iterate's own voltages otherwise
        (a continuation from a previous solution).
    extra : ndarray or None
        Further per-instance data a family carries between iterations
        (the MOSFET's threshold voltage).
    """

    __slots__ = ("v", "initial", "extra")

    def __init__(self, v: np.ndarray, initial: bool = False, extra: np.ndarray | None = None):
        self.v = v
        self.initial = initial
        self.extra = extra


class GateJunctionLimits:
    """Newton support of the FETs whose limiting state is their two gate junctions' voltages (JFET, MESA).

    A family using it sets ``elements`` (nodes ``(d, g, s, ...)``), ``off`` (shape (N,)),
    and, for the gate-source junctions then the gate-drain ones (shape (2N,)), ``lim_vt``
    (``N vt``), ``lim_vcrit`` (the critical voltages) and ``lim_vto`` (VTO at the device
    temperature). The state is ``(vgs, vgd)``, shape (2, N).
    """

    #: SPICE's ``MODEINITJCT`` voltage of both gate junctions [V] (0 for ``off`` devices).
    INITIAL_GATE_VOLTAGE = -1.0

    def junction_nodes(self) -> list[tuple[str, str]]:
        pairs = []
        for el in self.elements:
            d, g, s = el.nodes[:3]
            pairs += [(d, s), (g, s), (g, d)]
        return pairs

    def initial_state(self) -> LimitState:
        """SPICE's ``MODEINITJCT``: vgs = vgd = -1 (0 for ``off``)."""
        start = np.where(self.off, 0.0, self.INITIAL_GATE_VOLTAGE)
        return LimitState(np.stack([start, start]), initial=True)

    def limit(self, vn: np.ndarray, vold: np.ndarray) -> tuple[np.ndarray, bool]:
        """ngspice's limiting of (vgs, vgd): pnjlim (``N vt``, each junction's vcrit), then fetlim against VTO(T)."""
        from .junction import fetlim, pnjlim

        flat_old = vold.ravel()
        v, _ = pnjlim(vn.ravel(), flat_old, self.lim_vt, self.lim_vcrit)
        v = fetlim(v, flat_old, self.lim_vto).reshape(vn.shape)
        return v, bool(np.any(v != vn))


def starting_voltages(state: LimitState | None, x_ext: np.ndarray,
                      v_x: np.ndarray) -> tuple[np.ndarray, bool] | None:
    """Control voltages of an evaluation without limiting history, or None.

    Parameters
    ----------
    state : LimitState or None
        The state passed to the family's ``evaluate``.
    x_ext : ndarray
        The extended iterate.
    v_x : ndarray, shape (k, N)
        The iterate's own (type-normalised) control voltages.

    Returns
    -------
    (v, changed) or None
        ``None`` when ``state`` holds the previous iteration's voltages: the
        family limits against them. Otherwise the voltages to evaluate at
        and whether they differ from the iterate's:

        - ``state is None`` (no history, e.g. the first step of an
          integration from a consistent point): the iterate's voltages;
        - an initial state (SPICE's ``MODEINITJCT``): its voltages when the
          iterate is the zero vector (a solve from scratch), else the
          iterate's (a continuation from a previous solution).
    """
    if state is None:
        return v_x, False
    if not state.initial:
        return None
    if x_ext.any():
        return v_x, False
    return state.v, True
