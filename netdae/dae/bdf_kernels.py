"""Helpers of the FLC-BDF method that only the Python side needs.

The method's formulas (coefficients, norms, error estimates, the difference
update, breakpoint landing, error weights) exist once, as the compiled
kernels of :mod:`netdae.dae.compiled.control`, which both the compiled engine
and the :class:`~netdae.dae.bdf.BDF` driver call. What remains here has no
compiled twin: the predictor's weight rows (the compiled loop predicts in
place), backward differences of sampled values (a start from a given
history) and the merging of breakpoints (run once per integration, by both
engines).

The notation is that of DASSL and IDA [1]_ [2]_ (see :mod:`netdae.dae.bdf.history`).

References
----------
.. [1] K. E. Brenan, S. L. Campbell, L. R. Petzold, *Numerical Solution of
   Initial-Value Problems in Differential-Algebraic Equations*, SIAM 1996,
   Chapter 5.
.. [2] A. C. Hindmarsh et al., SUNDIALS IDA, ``src/ida/ida.c``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["predictor_weights", "differences_from_samples", "merge_breakpoints"]


def predictor_weights(gamma, k: int) -> np.ndarray:
    """Rows turning ``phi*[0..k]`` into the predicted value and derivative.

    Returns
    -------
    ndarray, shape (2, k + 1)
        ``W @ phi_star[:k+1]`` gives ``[x_pred, xp_pred]``.
    """
    w = np.empty((2, k + 1))
    w[0] = 1.0
    w[1, 0] = 0.0
    w[1, 1:] = gamma[1 : k + 1]
    return w


def differences_from_samples(samples: np.ndarray) -> np.ndarray:
    """Backward differences ``nabla^j y_n`` of equally spaced samples, newest last.

    At a constant step the modified divided differences are the backward
    differences, so this starts a multistep history from known values.

    Parameters
    ----------
    samples : ndarray, shape (k + 1, m)
        ``y_{n-k}, ..., y_n``.

    Returns
    -------
    ndarray, shape (k + 1, m)
        Row j is ``nabla^j y_n``.

    Examples
    --------
    >>> differences_from_samples(np.array([[0.0], [1.0], [4.0]])).ravel().tolist()
    [4.0, 3.0, 2.0]
    """
    s = np.array(samples, dtype=float)
    k = s.shape[0] - 1
    out = np.empty_like(s)
    for j in range(k + 1):
        out[j] = s[-1]
        s = s[1:] - s[:-1]
    return out


def merge_breakpoints(t0: float, t_bound: float, times, merge: float) -> np.ndarray:
    """Sorted breakpoints in ``(t0, t_bound]``, ``t_bound`` always last, no two closer than ``merge``.

    Parameters
    ----------
    t0, t_bound : float
    times : array_like
        Candidate breakpoints (any order, may fall outside the interval).
    merge : float
        Points closer than this to the next one (or to t0) are dropped (the
        last of a cluster stays), so no step is shorter than ``merge`` because
        of them.

    Examples
    --------
    >>> merge_breakpoints(0.0, 1.0, [0.5 - 1e-15, 0.5, 2.0, 0.0, 1.0 - 1e-15], 1e-9).tolist()
    [0.5, 1.0]
    """
    bp = np.asarray(times, dtype=float).ravel()
    bp = np.unique(np.append(bp[(bp > t0) & (bp < t_bound) & np.isfinite(bp)], t_bound))
    keep = np.ones(bp.size, dtype=bool)
    keep[:-1] = np.diff(bp) > merge
    bp = bp[keep]
    if bp.size > 1 and bp[0] - t0 <= merge:
        bp = bp[1:]
    return bp
