"""The Python side of the compiled operating-point Newton (:mod:`netdae.dae.compiled.steady`).

Which systems it serves (:func:`eligible`), their packed arrays and pivot
order kept between solves, and :func:`solve_dc`, the call that
:func:`netdae.dae.steady.solve_steady` makes for its first phase.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from . import bdf_loop as L
from .lu import PIVOT_REL_THRESHOLD
from ..system import KIND_VOLTAGE
from .sources import pack_sources
from .steady import CONVERGED, ILL_CONDITIONED, N_S, NEED_PIVOTS, NOT_CONVERGED, S_FIRST, S_ITER, newton_dc, sweep_dc

__all__ = ["eligible", "solve_dc", "sweep_points", "CONVERGED", "NOT_CONVERGED", "ILL_CONDITIONED"]


def eligible(system) -> bool:
    """True when :func:`solve_dc` can run ``system``: an MNA system of the compiled engine's families.

    Linear systems (one Newton step), switches (held states) and systems
    without the compiled engine's data stay with the Python solver.
    """
    from .driver import _family_slot

    families = getattr(system, "families", None)
    if not families or not hasattr(system, "pattern") or getattr(system, "switching", None) is not None:
        return False
    if getattr(system, "sources", None) is None or getattr(system, "B", None) is None:
        return False
    if getattr(system, "delays", None) is not None:  # a transient's lines (the steady form has none)
        return False
    slots = [_family_slot(f) for f in families]
    return None not in slots and len(set(slots)) == len(slots) and system.n > 0


def solve_dc(system, t: float, x0: np.ndarray, *, init: bool, maxiter: int, reltol: float,
             x_atol: np.ndarray, r_atol: np.ndarray, singular_pivot: float):
    """Plain Newton on ``phi(x, t) = 0`` in compiled code.

    Parameters
    ----------
    system : MnaSystem
        With :func:`eligible` true.
    t : float
    x0 : ndarray, shape (n,)
    init : bool
        Start the devices from their initial junction voltages (SPICE's
        ``MODEINITJCT``, a solve from scratch), else evaluate them at ``x0``.
    maxiter : int
    reltol : float
    x_atol, r_atol : ndarray, shape (n,)
        Absolute tolerances of the unknowns and of the equations.
    singular_pivot : float
        An equilibrated pivot at or below it stops plain Newton (ill-conditioned).

    Returns
    -------
    (x, status, iterations, factorizations, pivot)
        ``status`` is :data:`CONVERGED`, :data:`NOT_CONVERGED` or
        :data:`ILL_CONDITIONED`; ``pivot`` the smallest equilibrated pivot of the
        last factorisation (nan: none).

    Notes
    -----
    Cost: at the first solve of a system, packing it and one fresh SuperLU
    pivot order (~1 ms of Python, kept with the system); at every solve,
    packing the sources and a few small arrays (~0.1 ms), then compiled
    iterations of a few microseconds each.
    """
    x = np.array(x0, dtype=float)
    pack, fresh = _pack(system, x, t)
    lu = pack.lu
    if lu.plan is None:
        return x, NOT_CONVERGED, 0, 0, math.nan
    w = _Work(system, pack)
    x_atol = np.ascontiguousarray(x_atol, dtype=float)
    r_atol = np.ascontiguousarray(r_atol, dtype=float)
    while True:
        try:
            status = newton_dc(w.F, w.I, w.S, float(t), x, bool(init), int(maxiter), float(reltol), x_atol,
                               r_atol, w.paired, float(singular_pivot), w.sysd, w.devd, w.lus(), w.u, w.evb, w.dx,
                               w.absjx, w.pivot)
        except ZeroDivisionError:  # a model's complex arithmetic (driver.MODEL_DIVISION): not converged, as non-finite
            status = NOT_CONVERGED
            break
        if status != NEED_PIVOTS:
            break
        if not lu.factor(pack.a_data):
            status = ILL_CONDITIONED
            break
        fresh += 1
    return x, status, int(w.S[S_ITER]), int(w.I[L.I_FACTORIZATIONS]) + fresh, float(w.pivot[0])


def sweep_points(system, values: np.ndarray, columns: np.ndarray, x0: np.ndarray, p0: int, *, maxiter: int,
                 reltol: float, x_atol: np.ndarray, r_atol: np.ndarray, singular_pivot: float,
                 clear_pivot: float):
    """Points ``p0, p0 + 1, ...`` of a ``.dc`` sweep by compiled plain Newton, each from the previous solution.

    Parameters
    ----------
    system : MnaSystem
        With :func:`eligible` true, in DC mode (its swept sources constant).
    values : ndarray, shape (P, S)
        The swept sources' DC values at every point.
    columns : ndarray of int64, shape (S,)
        The swept sources' columns in ``system.sources``.
    x0 : ndarray, shape (n,)
        The solution of the point before ``p0``.
    p0 : int
    maxiter, reltol, x_atol, r_atol, singular_pivot
        As :func:`solve_dc`.
    clear_pivot : float
        A converged point whose smallest equilibrated pivot is at or below it stops the
        sweep (the singularity judgement of :func:`netdae.dae.steady.solve_steady` takes
        a closer look there).

    Returns
    -------
    (X, iterations, p)
        ``X[p0:p]`` and ``iterations[p0:p]`` hold the points solved; ``p`` is the first
        point left to Python (``P`` when none). ``system.sources`` is not changed.

    Notes
    -----
    One compiled call for the whole sweep (a few microseconds per point on small
    circuits) where a Python solve per point costs about 0.1 ms of bookkeeping.
    """
    values = np.ascontiguousarray(values, dtype=float)
    x = np.array(x0, dtype=float)
    pack, _ = _pack(system, x, 0.0)
    X = np.zeros((values.shape[0], int(system.n)))
    its = np.zeros(values.shape[0], dtype=np.int64)
    if pack.lu.plan is None:
        return X, its, p0
    w = _Work(system, pack)
    cols = np.ascontiguousarray(columns, dtype=np.int64)
    x_atol = np.ascontiguousarray(x_atol, dtype=float)
    r_atol = np.ascontiguousarray(r_atol, dtype=float)
    p = p0
    while True:
        try:
            status, p = sweep_dc(w.F, w.I, w.S, x, X, its, values, cols, p, int(maxiter), float(reltol), x_atol,
                                 r_atol, w.paired, float(singular_pivot), float(clear_pivot), PIVOT_REL_THRESHOLD,
                                 w.sysd, w.devd, w.lus(), w.u, w.evb, w.dx, w.absjx, w.pivot)
        except ZeroDivisionError:  # a model's complex arithmetic (driver.MODEL_DIVISION): Python solves from point p on
            break
        if status != NEED_PIVOTS or not pack.lu.factor(pack.a_data):
            break
    return X, its, int(p)


def _pack(system, x, t) -> tuple["_Pack", int]:
    """The system's kept :class:`_Pack` (made at its first solve: then 1, the fresh pivot order)."""
    pack = _PACKS.get(system)
    if pack is not None:
        return pack, 0
    pack = _PACKS[system] = _Pack(system, x, t)
    return pack, 1


class _Work:
    """The arrays of one solve (or one sweep): the sources packed now (a ``.dc`` sweep sets their values),
    the families' limiting states copied from the initial ones, the loop's scalars and work arrays."""

    def __init__(self, system, pack: "_Pack"):
        from .driver import no_delays

        n = int(system.n)
        skind, spar, spwl_t, spwl_v, spwl_n = pack_sources(system.sources)
        devd = list(pack.devd)
        for k in pack.states:
            devd[k] = devd[k].copy()
        self.devd = tuple(devd)
        nnz = pack.nnz
        self.evb = (np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1), np.zeros(nnz + 1), np.zeros(nnz + 1),
                    np.zeros(nnz))
        self.F = np.zeros(L.N_F)
        self.I = np.zeros(L.N_I, dtype=np.int64)
        self.sysd = (*pack.sysd, skind, spar, spwl_t, spwl_v, spwl_n, no_delays(self.I))
        self.F[L.F_LU_TAG] = math.nan
        self.F[L.F_PIVOT_THRESHOLD] = PIVOT_REL_THRESHOLD
        self.S = np.zeros(N_S, dtype=np.int64)
        self.S[S_FIRST] = 1
        self.u = np.zeros(skind.size)
        self.dx = np.zeros(n)
        self.absjx = np.zeros(n)
        # a node's potential and its current law (the residual test's measure of a row)
        self.paired = np.ascontiguousarray(np.asarray(system.kinds) == KIND_VOLTAGE, dtype=np.int8)
        self.swork = np.zeros(n)
        self.pivot = np.full(1, math.nan)
        self._lu = pack.lu

    def lus(self) -> tuple:
        """The LU's arrays in its current pivot order (new after a ``NEED_PIVOTS``)."""
        lu, plan = self._lu, self._lu.plan
        return (*plan.refactor_args(), plan.perm_r, plan.perm_c, lu._l, lu._u, lu._x, self.swork)


class _Pack:
    """A system's arrays for :func:`newton_dc` that do not change between its solves, and its LU.

    The sources are packed at every solve (a ``.dc`` sweep sets their values);
    the families' limiting states are copied from the initial ones.
    """

    def __init__(self, system, x, t):
        from .driver import _pack_families, limiting_states, pack_matrices
        from .lu import SparseLU

        pattern = system.pattern
        indptr, indices, e_data, h_data, b_rows, b_cols, b_vals = pack_matrices(system)
        self.nnz = e_data.size
        self.a_data = np.zeros(self.nnz)
        self.sysd = (indptr, indices, e_data, h_data, self.a_data, b_rows, b_cols, b_vals)
        self.devd = _pack_families(system, x, None)
        self.states = limiting_states(self.devd)
        self.lu = SparseLU(pattern, threshold=PIVOT_REL_THRESHOLD)
        # a first pivot order: of the matrix at x evaluated without limiting (a degraded pivot
        # later comes back to Python for a new one)
        ev = system.evaluate(x, t, jacobian=True, state=None)
        if not (ev.ok and np.all(np.isfinite(ev.dphi)) and self.lu.factor(-ev.dphi)):
            self.lu.factor(np.where(pattern.rows == pattern.cols, 1.0, 0.0))


#: The packed arrays and the LU (its pivot order) of each system solved, for its next solves.
_PACKS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
