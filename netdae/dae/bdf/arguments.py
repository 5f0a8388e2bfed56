"""The integrator's argument checks, shared by the :class:`~netdae.dae.bdf.BDF` driver and the compiled engine."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..system import KIND_CURRENT, KIND_VOLTAGE
from .constants import MAX_ORDER

__all__ = ["check_arguments", "absolute_tolerances", "row_tolerances", "index_mask", "save_indices", "rounding_signs",
           "breakpoint_times", "current_rows"]


def breakpoint_times(system, t0: float, t_bound: float, breakpoints) -> np.ndarray:
    """The times to land on: the system's breakpoints in ``[t0, t_bound]`` and the caller's ``breakpoints``.

    Returns
    -------
    ndarray, shape (m,)
        Unsorted, unmerged (:func:`netdae.dae.bdf_kernels.merge_breakpoints` does that).

    Raises
    ------
    ValueError
        When a given breakpoint is not a finite number (a nan was dropped without a word).
    """
    times = np.asarray(system.breakpoints(t0, t_bound), dtype=float).ravel()
    if breakpoints is None:
        return times
    given = np.asarray(breakpoints, dtype=float).ravel()
    if not np.all(np.isfinite(given)):
        raise ValueError(f"breakpoints must be finite times, got {float(given[~np.isfinite(given)][0])!r}")
    return np.concatenate([times, given])


def check_arguments(t0: float, t_bound: float, x0, n: int, *, rtol: float, maxord: int, norm: str, relref: str,
                    max_step: float, min_step: float, first_step) -> np.ndarray:
    """Validate the integrator's arguments; returns ``x0`` as a float array.

    Raises
    ------
    ValueError
        Naming the argument that is out of range.
    """
    if not (math.isfinite(t0) and math.isfinite(t_bound)) or t_bound <= t0:
        raise ValueError(f"need finite t0 < t_bound, got t0={t0!r}, t_bound={t_bound!r}")
    x0 = np.array(x0, dtype=float)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite array of shape ({n},)")
    if not (0.0 < rtol < 1.0):
        raise ValueError(f"rtol must lie in (0, 1), got {rtol!r}")
    if not (1 <= int(maxord) <= MAX_ORDER):
        raise ValueError(f"maxord must be 1..{MAX_ORDER}, got {maxord!r}")
    if norm not in ("rms", "max"):
        raise ValueError("norm must be 'rms' or 'max'")
    if relref not in ("local", "signal", "mixed"):
        raise ValueError("relref must be 'local', 'signal' or 'mixed'")
    if not (max_step > 0.0) or min_step < 0.0 or min_step > max_step:
        raise ValueError("need 0 <= min_step <= max_step and max_step > 0")
    if first_step is not None and not (first_step > 0.0):
        raise ValueError("first_step must be positive")
    return x0


#: The smallest absolute tolerance of any unknown (generic DAEs; circuits refuse below
#: :data:`netdae.circuit.TOLERANCE_MIN` first): squared weights of smaller ones overflow the RMS norm.
ATOL_MIN = 1e-100


def absolute_tolerances(kinds, n: int, atol, vntol: float, abstol: float) -> tuple[np.ndarray, Any]:
    """Per-unknown absolute tolerances and their label for reports.

    ``atol`` is one value per unknown, or a scalar for ``KIND_OTHER`` unknowns
    (voltages then take ``vntol``, currents ``abstol``).

    Raises
    ------
    ValueError
    """
    a = np.asarray(atol, dtype=float)
    if a.ndim == 1:
        if a.shape != (n,):
            raise ValueError(f"atol must be a scalar or have shape ({n},)")
        vec, label = a.copy(), "per-unknown"
    elif a.ndim == 0:
        kinds = np.asarray(kinds)
        vec = np.where(kinds == KIND_VOLTAGE, float(vntol), np.where(kinds == KIND_CURRENT, float(abstol), float(a)))
        label = float(a)
    else:
        raise ValueError("atol must be a scalar or a 1-D array")
    if np.any(~np.isfinite(vec)) or np.any(vec <= 0.0):
        raise ValueError("absolute tolerances must be positive and finite")
    if np.any(vec < ATOL_MIN):
        raise ValueError(f"absolute tolerances must be at least {ATOL_MIN:g}, got {float(vec.min()):g}: the error "
                         "weights 1/atol of smaller ones overflow the norms (inf), and no first step is found")
    return vec, label


def row_tolerances(kinds, atol: np.ndarray, vntol: float, abstol: float) -> np.ndarray:
    """Absolute tolerance of each equation row of the corrector's residual.

    Row ``i`` of a circuit's system is the equation of unknown ``i``'s element: a node's
    current law (amperes: ``abstol``) or a branch's voltage equation (volts: ``vntol``), so
    the row tolerances swap the unknowns' kinds; a row of another kind keeps its unknown's
    ``atol``.

    Parameters
    ----------
    kinds : ndarray, shape (n,)
    atol : ndarray, shape (n,)
        The unknowns' absolute tolerances (:func:`absolute_tolerances`).
    vntol, abstol : float

    Returns
    -------
    ndarray, shape (n,)
    """
    kinds = np.asarray(kinds)
    return np.where(kinds == KIND_VOLTAGE, float(abstol), np.where(kinds == KIND_CURRENT, float(vntol), atol))


def index_mask(names, n: int, index, norm: str) -> tuple[np.ndarray, np.ndarray | None, int]:
    """Which unknowns are index 2, and the factor that leaves them out of the error test.

    Returns
    -------
    (high, factor, excluded)
        ``high`` bool (n,); ``factor`` (n,) multiplying the error weights, or
        None when every unknown is tested (with "rms" the RMS is over the
        tested unknowns only); the number of unknowns left out.

    Raises
    ------
    ValueError
        For a malformed ``index`` or an index of 3 or more.
    """
    high = np.zeros(n, dtype=bool)
    if index is None:
        return high, None, 0
    idx = np.asarray(index)
    if idx.shape != (n,) or idx.dtype.kind not in "iu" or np.any(idx < 0):
        raise ValueError(f"index must be a non-negative integer array of shape ({n},)")
    if np.any(idx > 2):
        worst = names[int(np.argmax(idx))]
        raise ValueError(
            f"unknown {worst} has index {int(idx.max())}: the BDF method does not converge for "
            "index >= 3; solve such (linear) problems through their decoupled (Weierstrass) form"
        )
    high = idx >= 2
    tested = int(np.count_nonzero(~high))
    if tested == n:
        return high, None, 0
    factor = (~high).astype(float)
    if tested == 0:
        # every unknown is a derivative of the inputs (a source driving only
        # capacitors): nothing to error-test, the steps follow max_step and
        # the breakpoints
        return high, factor, n
    if norm == "rms":
        # the RMS over the tested unknowns only: sqrt(sum_tested (e w)^2 / tested)
        factor *= math.sqrt(n / tested)
    return high, factor, n - tested


def save_indices(n: int, save) -> np.ndarray:
    """Positions of the unknowns to record (all when ``save`` is None).

    Raises
    ------
    ValueError
    """
    if save is None:
        return np.arange(n, dtype=np.int64)
    s = np.asarray(save)
    if s.ndim != 1 or s.dtype.kind not in "iu" or (s.size and (s.min() < 0 or s.max() >= n)):
        raise ValueError(f"save must be a 1-D integer array of unknown positions in [0, {n})")
    return s.astype(np.int64)



def charge_columns(system, linear: bool) -> tuple[np.ndarray, np.ndarray]:
    """The rows whose charges have a history of their own, and each row's column in it.

    A nonlinear system keeps the charges of the rows
    :meth:`~netdae.dae.system.DaeSystem.nonlinear_charge_rows` names (every row
    when it names none) in columns ``n, n + 1, ...`` of the history, in that
    order; the corrector of the other rows is written with the constant ``E``
    in correction form. A linear system keeps no charges.

    Returns
    -------
    (rows, column)
        ``rows``: int64, shape (m,), sorted; ``column``: int64, shape (n,),
        the position of row ``r`` among ``rows`` (-1 for a row without charge history).

    Raises
    ------
    ValueError
        When the system names rows outside ``0..n-1``.
    """
    n = int(system.n)
    if linear:
        rows = np.empty(0, dtype=np.int64)
    else:
        given = system.nonlinear_charge_rows() if hasattr(system, "nonlinear_charge_rows") else None
        rows = np.arange(n, dtype=np.int64) if given is None else np.unique(np.asarray(given, dtype=np.int64))
        if rows.size and (rows[0] < 0 or rows[-1] >= n):
            raise ValueError(f"nonlinear_charge_rows must be row indices in [0, {n})")
    column = np.full(n, -1, dtype=np.int64)
    column[rows] = np.arange(rows.size, dtype=np.int64)
    return rows, column


def charge_rows(indptr, indices, high: np.ndarray, column: np.ndarray) -> np.ndarray:
    """Rows whose charge error is tested: those with a charge history in which an index-2 unknown appears.

    An index-2 unknown (the current of a source in a loop of capacitors) is the time
    derivative of the charge of the rows it enters, ``i = -dq_r/dt + ...``: it is
    accurate when that charge is, and the unknowns of the row do not say so when the
    charge is a nonlinear function of a voltage the source fixes (a MOS gate charge of
    a driven gate: the voltage is exact, its charge's derivative is what the current
    carries). These rows' charge errors join the error test (:func:`netdae.dae.compiled.
    control.charge_weights`). Index-2 rows themselves and rows without a charge history
    (``column`` -1: a linear system, or a row whose charge is ``E x``, tested through x)
    have none.

    Parameters
    ----------
    indptr, indices : ndarray
        The CSC pattern.
    high : ndarray of bool, shape (n,)
        Index-2 unknowns.
    column : ndarray of int64, shape (n,)
        Each row's column in the charge history (:func:`charge_columns`).

    Returns
    -------
    ndarray of int64, shape (n,)
        The tested row's column in the charge history, -1 for the other rows.
    """
    n = high.size
    rows = np.zeros(n, dtype=np.bool_)
    if high.any():
        for j in np.flatnonzero(high):
            rows[np.asarray(indices[indptr[j]:indptr[j + 1]])] = True
        rows[high] = False
    return np.where(rows & (column >= 0), column, -1).astype(np.int64)


def time_charge_rows(system, column: np.ndarray) -> np.ndarray:
    """Rows whose charge reads time itself, each with its column in the charge history (-1: other rows).

    ``system.time_charge_rows()`` names them (a ``Q`` source whose expression reads ``time``;
    none when the system does not say). Their charge errors join the error test
    (:func:`netdae.dae.compiled.control.time_charge_residual`): the current ``dq/dt`` at fixed x
    is the BDF's derivative of the charge history, which no unknown's error estimate measures.
    A row without a charge history (a linear system's) has none.
    """
    n = column.size
    out = np.full(n, -1, dtype=np.int64)
    given = system.time_charge_rows() if hasattr(system, "time_charge_rows") else None
    if given is not None and len(given):
        rows = np.asarray(given, dtype=np.int64)
        rows = rows[(rows >= 0) & (rows < n)]
        out[rows] = column[rows]
    return out


#: :func:`rounding_signs` of each size asked for (read by the integrators, never written).
_SIGNS: dict[int, np.ndarray] = {}


def rounding_signs(n: int) -> np.ndarray:
    """Fixed pseudo-random signs +-1, shape (n,), of the rounding floor's second right-hand side.

    Rounding errors have no fixed sign: the floor takes the larger response to its
    non-negative right-hand side and to the same with these signs (a single non-negative one
    can cancel, e.g. across a capacitor between two nodes). The same signs for every run of a
    size (seeded), so that a run does not depend on what ran before it; a new array each call.
    """
    signs = _SIGNS.get(n)
    if signs is None:
        signs = _SIGNS[n] = np.where(np.random.default_rng(1).random(n) < 0.5, -1.0, 1.0)
    return signs.copy()


def current_rows(system, mask: np.ndarray, crows: np.ndarray) -> tuple:
    """The algebraic currents whose error tolerance their resistive rows may raise, and those rows.

    A candidate is a circuit current (``KIND_CURRENT``) in the error test (``mask > 0``) with no
    charge of its own (no entry of ``E`` in its column: not an inductor's). Its rows are those where
    the linear conductances ``H`` hold it and another unknown, without charge (no ``E`` entry, not in
    ``crows``) and without delayed terms (a transmission line's port): the current laws of nodes
    without capacitance, a controlled source's branch law. Each row's other entries are listed with
    their gains ``|H_rj / H_ri|``, for :func:`netdae.dae.compiled.control.current_error_weights`.

    Returns
    -------
    (cand, rptr, eptr, ecol, ecand, gain, tolc)
        The candidates (int64); per candidate its rows ``rptr[c]:rptr[c+1]``, each with its other
        entries ``eptr[r]:eptr[r+1]`` in columns ``ecol`` (``ecand``: the column's candidate number,
        -1 for none) with ``gain`` (float64); ``tolc``: float64 work, one per candidate. All empty
        when nothing qualifies (a system without constant ``E`` and ``H``).

    Notes
    -----
    Cost: O(nnz) once per transient (a row view of ``H``).
    """
    n = int(system.n)
    empty = np.empty(0, dtype=np.int64)
    nothing = (empty, np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), empty, empty, np.empty(0),
               np.empty(0))
    kinds = np.asarray(system.kinds)
    currents = (kinds == KIND_CURRENT) & (np.asarray(mask) > 0)
    if not currents.any():
        return nothing
    try:
        E, H = sp.csr_matrix(system.E, copy=True), sp.csr_matrix(system.H, copy=True)  # (zeros eliminated below)
    except (AttributeError, NotImplementedError):  # a system without constant E and H (no MNA)
        return nothing
    E.eliminate_zeros()
    H.eliminate_zeros()
    blocked = np.diff(E.indptr) > 0  # rows with a charge or a delayed term
    blocked[np.asarray(crows, dtype=np.int64)] = True
    delays = getattr(system, "delays", None)
    if delays is not None:
        D = sp.csr_matrix(delays.D)
        D.eliminate_zeros()
        blocked |= np.diff(D.indptr) > 0
    charged = np.diff(sp.csc_matrix(E).indptr) > 0  # a current with a charge (flux) of its own: an inductor's
    cand = np.flatnonzero(currents & ~charged).astype(np.int64)
    if cand.size == 0:
        return nothing
    Hc = sp.csc_matrix(H)
    number = np.full(n, -1, dtype=np.int64)
    number[cand] = np.arange(cand.size)
    rptr, eptr, ecol, gain = [0], [0], [], []
    for i in cand:
        for r, h_ri in zip(Hc.indices[Hc.indptr[i]:Hc.indptr[i + 1]], Hc.data[Hc.indptr[i]:Hc.indptr[i + 1]]):
            if blocked[r]:
                continue
            lo, hi = H.indptr[r], H.indptr[r + 1]
            cols, vals = H.indices[lo:hi], H.data[lo:hi]
            others = cols != i
            if not others.any():
                continue
            ecol.extend(cols[others].tolist())
            gain.extend(np.abs(vals[others] / h_ri).tolist())
            eptr.append(len(ecol))
        rptr.append(len(eptr) - 1)
    ecol_a = np.asarray(ecol, dtype=np.int64)
    return (cand, np.asarray(rptr, dtype=np.int64), np.asarray(eptr, dtype=np.int64), ecol_a,
            number[ecol_a] if ecol_a.size else empty, np.asarray(gain, dtype=float), np.zeros(cand.size))
