"""The method's history: modified divided differences, the ``psi`` of past steps, the step's coefficients.

The notation is that of DASSL and IDA [1]_ [2]_. A solution component's
history is kept as *modified divided differences* ``phi_j`` (row ``j`` of the
``(maxord + 1, width)`` array ``P``; ``width`` is ``n + m``: the ``n`` unknowns,
then the charges of the ``m`` rows whose charge is nonlinear, which have a
history of their own; ``m = 0`` for a linear system). A step of
size ``h`` and order ``k`` is described by

- ``psi_i = t_{n+1} - t_{n-i}`` (``psi_0 = h``),
- ``alpha_i = h / psi_i``, ``beta_i`` (turning ``phi_i`` into the predicted
  differences ``phi*_i = beta_i phi_i``), ``gamma_i`` (weights of the
  predicted derivative), ``sigma_i`` (weights of the error estimates),
- the fixed leading coefficient ``cj = (sum_{j<=k} 1/j) / h`` and the error
  constant ``ck``.

The formulas are the compiled kernels of :mod:`netdae.dae.compiled.control`
(``flc_coefficients``, ``update_differences``), the same the compiled engine
runs; this class owns the arrays they work on.

References
----------
.. [1] K. E. Brenan, S. L. Campbell, L. R. Petzold, *Numerical Solution of
   Initial-Value Problems in Differential-Algebraic Equations*, SIAM 1996,
   Chapter 5.
.. [2] A. C. Hindmarsh et al., SUNDIALS IDA, ``src/ida/ida.c``
   (``IDASetCoeffs``, ``IDARestore``, ``IDACompleteStep``).
"""

from __future__ import annotations

import numpy as np

from ..bdf_kernels import differences_from_samples, predictor_weights
from ..compiled.control import flc_coefficients, update_differences

__all__ = ["History", "sampled_history"]


class History:
    """Divided differences and step coefficients of the FLC-BDF method (orders 1..maxord).

    Parameters
    ----------
    n : int
        Number of unknowns.
    width : int
        Columns of the history: ``n + m``, the unknowns, then the charges of ``m`` rows
        (:func:`~netdae.dae.bdf.arguments.charge_columns`; ``m = 0``: unknowns only).
    maxord : int
        Highest order.

    Attributes
    ----------
    P : ndarray, shape (maxord + 1, width)
        The differences; row 0 is the current point. Between ``set_coefficients``
        and ``accept``/``restore`` rows ``ns..k`` hold the predicted differences ``phi*``.
    psi, psi_saved : ndarray, shape (maxord + 1,)
        ``psi`` of the current step and as it was before it (for ``restore``).
    alpha, beta, gamma, sigma : ndarray, shape (maxord + 1,)
        Coefficients of the step (entries ``0..k`` valid).
    cj, cjlast : float
        Leading coefficient of this attempt and of the previous one.
    ck : float
        Error constant of the step.
    k, kused : int
        Order of the step being taken and of the last accepted step.
    hused : float
        Size of the last accepted step.
    ns : int
        Steps taken at constant size and order (IDA's ``ns``).
    """

    def __init__(self, n: int, width: int, maxord: int) -> None:
        self.n, self.width, self.maxord = int(n), int(width), int(maxord)
        self.P = np.zeros((self.maxord + 1, self.width))
        self.psi = np.zeros(self.maxord + 1)
        self.psi_saved = np.zeros(self.maxord + 1)
        self.alpha = np.zeros(self.maxord + 1)
        self.beta = np.zeros(self.maxord + 1)
        self.gamma = np.zeros(self.maxord + 1)
        self.sigma = np.zeros(self.maxord + 1)
        self.W = None
        self._valid = False  # the coefficient arrays describe the current (h, k)
        self._cj_coef = 0.0
        self.cj = 0.0
        self.cjlast = 0.0
        self.ck = 0.0
        self.k = 1
        self.kused = 0
        self.hused = 0.0
        self.ns = 0

    # ---------------------------------------------------------------- starts
    def initialise(self, h: float, xp, qp=None) -> None:
        """Order-1 start at the current point ``P[0]`` with derivatives ``xp`` (and ``qp`` of the charges).

        Parameters
        ----------
        h : float
            First step.
        xp : ndarray, shape (n,)
        qp : ndarray, shape (m,), optional
            The charges' derivatives (a history that holds charges).
        """
        n = self.n
        self.P[1:] = 0.0
        self.P[1, :n] = h * xp
        if qp is not None:
            self.P[1, n:] = h * qp
        self.psi[0] = h
        self.k = 1
        self.kused = 0
        self.hused = 0.0
        self.ns = 0
        self.cj = 1.0 / h
        self._valid = False

    def from_samples(self, h: float, x_hist, q_hist=None) -> None:
        """Start at order ``k`` from ``k + 1`` equally spaced past values (newest last).

        Parameters
        ----------
        h : float
            Their spacing.
        x_hist : ndarray, shape (k + 1, n)
        q_hist : ndarray, shape (k + 1, m), optional
            The charges there (a history with charges).
        """
        k = x_hist.shape[0] - 1
        n = self.n
        self.P[: k + 1, :n] = differences_from_samples(x_hist)
        if q_hist is not None:
            self.P[: k + 1, n:] = differences_from_samples(q_hist)
        self.psi[:] = [(i + 1) * h for i in range(self.maxord + 1)]
        self.k = self.kused = k
        self.hused = h
        self.ns = 0

    def rescale_first_step(self, h_new: float, h: float) -> None:
        """Change the first step after a (re)start from ``h`` to ``h_new`` (IDA's IDAReset)."""
        self.psi[0] = h_new
        self.P[1] *= h_new / h

    # ------------------------------------------------------------------ step
    def set_coefficients(self, h: float) -> None:
        """Coefficients of a step of size ``h`` at order ``k``, and the predicted differences (IDASetCoeffs).

        The coefficients are recomputed only while the last ``k + 1`` steps
        were not all of size ``h`` and order ``k``; afterwards they are constant.
        """
        k = self.k
        if h != self.hused or k != self.kused:
            self.ns = 0
        self.ns = min(self.ns + 1, self.kused + 2)
        np.copyto(self.psi_saved, self.psi)
        if k + 1 >= self.ns or not self._valid:
            self._cj_coef, self.ck = flc_coefficients(h, k, self.psi, self.psi, self.alpha, self.beta, self.gamma,
                                                      self.sigma)
            self.W = predictor_weights(self.gamma, k)
            self._valid = True
        self.cjlast = self.cj
        self.cj = self._cj_coef
        if self.ns <= k:
            self.P[self.ns : k + 1] *= self.beta[self.ns : k + 1, None]

    def predict(self) -> np.ndarray:
        """The predicted point and derivative, shape (2, width): ``[x_pred, x'_pred]`` (and charges)."""
        return self.W @ self.P[: self.k + 1]

    def restore(self) -> None:
        """Undo :meth:`set_coefficients` after a failed attempt (IDARestore)."""
        k = self.k
        np.copyto(self.psi, self.psi_saved)
        if self.ns <= k:
            self.P[self.ns : k + 1] /= self.beta[self.ns : k + 1, None]
        self._valid = False

    def accept(self, h: float) -> int:
        """Note an accepted step of size ``h`` at order ``k``; returns ``k`` minus the previous step's order."""
        kdiff = self.k - self.kused
        self.kused = self.k
        self.hused = h
        return kdiff

    def update(self, ee: np.ndarray, k: int) -> None:
        """The differences after an accepted step of order ``k`` with correction ``ee`` (shape (width,))."""
        update_differences(self.P, ee, k, self.maxord)


def sampled_history(history, t0: float, x0, maxord: int):
    """Check a caller's history ``(t_hist, x_hist)`` for a start at order ``k`` (:meth:`History.from_samples`).

    Parameters
    ----------
    history : (array_like, array_like)
        ``k + 1`` equally spaced increasing times ending at ``t0`` and the
        solution there, shape (k + 1, n).
    t0 : float
    x0 : ndarray, shape (n,)
        Must equal the last value.
    maxord : int

    Returns
    -------
    (t_hist, x_hist, h)
        As float arrays, and the spacing.

    Raises
    ------
    ValueError
        For a malformed history.

    Examples
    --------
    >>> t, x, h = sampled_history(([0.0, 0.5, 1.0], [[0.0], [1.0], [2.0]]), 1.0, np.array([2.0]), 5)
    >>> h, x.shape
    (0.5, (3, 1))
    """
    t_hist, x_hist = history
    t_hist = np.asarray(t_hist, dtype=float)
    x_hist = np.asarray(x_hist, dtype=float)
    k = t_hist.size - 1
    n = np.asarray(x0).size
    if not (1 <= k <= maxord) or x_hist.shape != (k + 1, n):
        raise ValueError(f"history needs 2..{maxord + 1} times and values of shape (times, {n})")
    steps = np.diff(t_hist)
    h = float(steps[0])
    if h <= 0.0 or not np.allclose(steps, h, rtol=1e-10, atol=0.0) or t_hist[-1] != t0:
        raise ValueError("history times must be equally spaced, increasing and end at t0")
    if not np.array_equal(x_hist[-1], x0):
        raise ValueError("the last history value must equal x0")
    return t_hist, x_hist, h
