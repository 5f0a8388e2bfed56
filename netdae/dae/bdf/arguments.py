"""The integrator's argument checks, shared by the :class:`~netdae.dae.bdf.BDF` driver and the compiled engine."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..system import KIND_CURRENT, KIND_VOLTAGE
from .constants import MAX_ORDER

__all__ = ["check_arguments", "absolute_tolerances", "index_mask", "save_indices"]


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
    return vec, label


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



def charge_rows(indptr, indices, high: np.ndarray, linear: bool) -> np.ndarray:
    """Rows whose charge error is tested: those in which an index-2 unknown appears.

    An index-2 unknown (the current of a source in a loop of capacitors) is the time
    derivative of the charge of the rows it enters, ``i = -dq_r/dt + ...``: it is
    accurate when that charge is, and the unknowns of the row do not say so when the
    charge is a nonlinear function of a voltage the source fixes (a MOS gate charge of
    a driven gate: the voltage is exact, its charge's derivative is what the current
    carries). These rows' charge errors join the error test (:func:`netdae.dae.compiled.
    control.charge_weights`). Index-2 rows themselves and linear systems (whose charges
    ``E x`` are tested through x) have none.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    n = high.size
    rows = np.zeros(n, dtype=np.bool_)
    if linear or not high.any():
        return rows
    for j in np.flatnonzero(high):
        rows[np.asarray(indices[indptr[j]:indptr[j + 1]])] = True
    rows[high] = False
    return rows
