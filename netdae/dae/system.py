"""The interface a DAE offers to netdae's solvers.

netdae's solvers (operating point, index analysis, BDF, AC) see only this
interface, never a netlist. A DAE is written in charge form

.. math::  \\frac{d}{dt} q(x) = \\varphi(x, t),

so for a constant ``E`` it is the linear-implicit form ``E x' = phi(x, t)`` of
the lecture notes (2.2), and for a linear circuit ``E x' = H x + c(t)`` (2.8).
Nonlinear capacitors and inductors keep their charge/flux in ``q``, so charge
is conserved by the discretisation, and ``E(x) = dq/dx``.

Contract
--------
A system has ``n`` unknowns with ``names`` and ``kinds`` (volts, amperes or
other, for per-kind absolute tolerances), a fixed :class:`SparsePattern`
(including the diagonal) that holds both Jacobians, and one method that does
all the work of a Newton iteration in a single pass over the devices:

``evaluate(x, t, jacobian=True, state=None, source_scale=1.0) -> Evaluation``

The Newton matrix of a BDF step, ``(alpha/h) dq/dx - dphi/dx``, is therefore
``alpha/h * ev.dq - ev.dphi`` on the shared pattern: no re-assembly, no
Python loop.

Linear systems (``system.linear``) also expose the constant matrices ``E``,
``H`` and the source vector ``c(t)`` with its analytic derivatives, which the
decoupled (Weierstrass) solution of higher-index problems needs.

Device limiting
---------------
Nonlinear device families may limit junction voltages between Newton
iterations as SPICE does (``pnjlim``). ``evaluate`` then linearises the
device currents around the limited voltages and returns ``limited=True`` and
an opaque ``state`` that the Newton solver passes back into the next
evaluation; a Newton iteration is not converged while ``limited`` is true.
Systems without limiting return ``state=None``, ``limited=False``.

References
----------
.. [1] B. Simeon, *Differential-Algebraic Equations*, lecture notes, TU
   Kaiserslautern 2012, Sections 2.1 and 2.2.
.. [2] K. E. Brenan, S. L. Campbell, L. R. Petzold, *Numerical Solution of
   Initial-Value Problems in Differential-Algebraic Equations*, SIAM 1996.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
import scipy.sparse as sp

from .sparse import SparsePattern

__all__ = [
    "KIND_VOLTAGE",
    "KIND_CURRENT",
    "KIND_OTHER",
    "Evaluation",
    "DaeSystem",
    "LinearDae",
    "FunctionDae",
]

#: Unknown is a node potential (absolute tolerance ``vntol``).
KIND_VOLTAGE = 0
#: Unknown is a branch current (absolute tolerance ``abstol``).
KIND_CURRENT = 1
#: Any other quantity (generic DAEs; absolute tolerance ``atol`` of the solver).
KIND_OTHER = 2


@dataclass(slots=True)
class Evaluation:
    """Everything a Newton iteration needs at one point (x, t).

    Attributes
    ----------
    q : ndarray, shape (n,)
        Charges/fluxes q(x).
    phi : ndarray, shape (n,)
        Right-hand side phi(x, t).
    dq : ndarray, shape (nnz,) or None
        Values of dq/dx on the system's pattern (``None`` unless ``jacobian``).
    dphi : ndarray, shape (nnz,) or None
        Values of dphi/dx on the system's pattern.
    limited : bool
        True when a device limited a junction voltage (Newton not converged).
    state : object
        Device limiting state to pass to the next evaluation.
    ok : bool
        False when a device evaluation produced a non-finite value (overflow,
        NaN): a recoverable failure, the caller cuts the step or moves on.
    """

    q: np.ndarray
    phi: np.ndarray
    dq: np.ndarray | None = None
    dphi: np.ndarray | None = None
    limited: bool = False
    state: Any = None
    ok: bool = True


class DaeSystem:
    """Base class of a DAE ``d/dt q(x) = phi(x, t)``.

    Subclasses set the attributes below in ``__init__`` and implement
    :meth:`evaluate`.

    Attributes
    ----------
    n : int
        Number of unknowns.
    names : tuple of str, length n
        Name of each unknown (``"v(out)"``, ``"i(v1)"`` for circuits).
    kinds : ndarray of int8, shape (n,)
        ``KIND_VOLTAGE``, ``KIND_CURRENT`` or ``KIND_OTHER`` per unknown.
    pattern : SparsePattern
        Holds dq/dx and dphi/dx (and the diagonal).
    linear : bool
        True when q and phi are affine in x (constant Jacobians). Then
        :attr:`E`, :attr:`H` and :meth:`source` are available and
        ``phi(x, t) = H x + c(t)``, ``q(x) = E x``.
    """

    n: int
    names: tuple[str, ...]
    kinds: np.ndarray
    pattern: SparsePattern
    linear: bool = False

    # -- the one method every system implements ---------------------------------
    def evaluate(
        self,
        x: np.ndarray,
        t: float,
        *,
        jacobian: bool = True,
        state: Any = None,
        source_scale: float = 1.0,
    ) -> Evaluation:
        """Evaluate q, phi and (optionally) their Jacobians at (x, t).

        Parameters
        ----------
        x : ndarray, shape (n,)
        t : float
        jacobian : bool
            Also return dq/dx and dphi/dx values on :attr:`pattern`.
        state : object, optional
            Limiting state from the previous evaluation of this Newton solve.
        source_scale : float
            Factor on every independent source (source stepping; 1 normally).

        Returns
        -------
        Evaluation
        """
        raise NotImplementedError

    # -- optional capabilities with defaults ---------------------------------
    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Sorted instants in [t0, t1] where the inputs are not smooth.

        The integrator lands exactly on each and restarts at low order.
        """
        return np.empty(0)

    def step_bound(self) -> float:
        """The longest next step the system's devices allow after the last evaluation (inf: no bound).

        Read by the integrator after each accepted step (a Verilog-A module's
        ``$bound_step``); the evaluation it reads is the accepted point's.
        """
        return math.inf

    def ended(self) -> str | None:
        """Why a device ended the analysis at the last evaluation (None: none did).

        Read by the integrator after each accepted step (a Verilog-A module's
        ``$finish`` or ``$stop``): the run stops there, its result kept.
        """
        return None

    def initial_guess(self) -> np.ndarray:
        """Starting point for the operating-point Newton iteration."""
        return np.zeros(self.n)

    def index_of(self, name: str) -> int:
        """Position of the unknown called ``name`` (case-insensitive).

        Raises
        ------
        KeyError
        """
        try:
            return self._name_index[name.lower()]
        except AttributeError:
            self._name_index = {nm.lower(): i for i, nm in enumerate(self.names)}
            return self._name_index[name.lower()]

    # -- linear systems -------------------------------------------------------
    @property
    def E(self) -> sp.csc_matrix:
        """Constant ``dq/dx`` of a linear system, shape (n, n)."""
        raise NotImplementedError("E is only constant for a linear system; use jacobians(x, t)")

    @property
    def H(self) -> sp.csc_matrix:
        """Constant ``dphi/dx`` of a linear system, shape (n, n)."""
        raise NotImplementedError("H is only constant for a linear system; use jacobians(x, t)")

    def source(self, t: float, derivative: int = 0) -> np.ndarray:
        """``c(t)`` (or its ``derivative``-th time derivative) of ``phi = H x + c(t)``."""
        raise NotImplementedError

    # -- nonlinear systems with a constant part of dq/dx -------------------------
    def nonlinear_charge_rows(self) -> np.ndarray | None:
        """Rows whose charge may be a nonlinear function of x; ``None``: every row (the default).

        A system that knows them returns the sorted row indices; every other
        row ``r`` then has the charge ``q_r(x) = (E x)_r`` with the constant
        :attr:`E`, and ``dq/dx`` equals ``E`` in that row. The BDF integrator
        keeps a charge history for the listed rows only and writes the
        corrector of the others in correction form, ``cj E (x - x_pred) +
        E x'_pred``, whose rounding error does not grow like ``1/h``
        (docs/integrator.md, "Charge form"). Not used for a linear system.

        Returns
        -------
        ndarray of int64, shape (m,), or None
        """
        return None

    # -- conveniences built on evaluate --------------------------------------
    def jacobians(self, x: np.ndarray, t: float) -> tuple[sp.csc_matrix, sp.csc_matrix]:
        """``(dq/dx, dphi/dx)`` at (x, t) as CSC matrices: the pencil (E, H)."""
        ev = self.evaluate(np.asarray(x, dtype=float), t, jacobian=True)
        return self.pattern.matrix(ev.dq.copy()), self.pattern.matrix(ev.dphi.copy())


def _as_kinds(kinds, n: int) -> np.ndarray:
    if kinds is None:
        return np.full(n, KIND_OTHER, dtype=np.int8)
    k = np.asarray(kinds, dtype=np.int8)
    if k.shape != (n,):
        raise ValueError(f"kinds must have shape ({n},)")
    return k


def _as_names(names, n: int) -> tuple[str, ...]:
    if names is None:
        return tuple(f"x{i}" for i in range(n))
    names = tuple(names)
    if len(names) != n:
        raise ValueError(f"names must have {n} entries")
    return names


class LinearDae(DaeSystem):
    """The linear constant-coefficient DAE ``E x' = H x + c(t)``.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    c : callable, optional
        ``c(t, derivative=0) -> ndarray (n,)``; zero when omitted. Must accept
        the keyword ``derivative`` (the k-th time derivative) when the system
        is solved through its decoupled form (index >= 3).
    names : sequence of str, optional
    kinds : array_like of int, optional
    breakpoints : callable, optional
        ``breakpoints(t0, t1) -> ndarray``.

    Examples
    --------
    The RC circuit ``C v' = -v/R`` as a one-unknown DAE:

    >>> import numpy as np
    >>> dae = LinearDae([[1e-6]], [[-1e-3]])
    >>> ev = dae.evaluate(np.array([2.0]), 0.0)
    >>> float(ev.q[0]), float(ev.phi[0])
    (2e-06, -0.002)
    """

    linear = True

    def __init__(self, E, H, c: Callable | None = None, *, names=None, kinds=None, breakpoints=None):
        self._E = sp.csc_matrix(E, dtype=float)
        self._H = sp.csc_matrix(H, dtype=float)
        n = self._E.shape[0]
        if self._E.shape != (n, n) or self._H.shape != (n, n):
            raise ValueError("E and H must be square and of the same size")
        if not (np.all(np.isfinite(self._E.data)) and np.all(np.isfinite(self._H.data))):
            raise ValueError("E and H must be finite (an entry is nan or inf)")
        self.n = n
        self.names = _as_names(names, n)
        self.kinds = _as_kinds(kinds, n)
        self.pattern = SparsePattern.from_matrices(self._E, self._H)
        self._dq = self.pattern.data_of(self._E)
        self._dphi = self.pattern.data_of(self._H)
        self._c = c
        self._bp = breakpoints

    @property
    def E(self) -> sp.csc_matrix:
        return self._E

    @property
    def H(self) -> sp.csc_matrix:
        return self._H

    def source(self, t: float, derivative: int = 0) -> np.ndarray:
        if self._c is None:
            return np.zeros(self.n)
        c = self._c(t) if derivative == 0 else self._c(t, derivative=derivative)
        return _vector(c, self.n, "c(t)" if derivative == 0 else f"c(t, derivative={derivative})")

    def evaluate(self, x, t, *, jacobian=True, state=None, source_scale=1.0) -> Evaluation:
        x = np.asarray(x, dtype=float)
        phi = self._H @ x
        if self._c is not None:
            phi = phi + source_scale * self.source(t)
        return Evaluation(
            q=self._E @ x,
            phi=phi,
            dq=self._dq if jacobian else None,
            dphi=self._dphi if jacobian else None,
        )

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        if self._bp is None:
            return np.empty(0)
        return np.asarray(self._bp(t0, t1), dtype=float)


class FunctionDae(DaeSystem):
    """A DAE ``d/dt q(x) = phi(x, t)`` given by Python callables.

    Meant for small systems written by hand (the planar pendulum, Van der Pol):
    the callables may return dense arrays; each evaluation converts them to
    the fixed pattern, which costs O(n^2) for dense Jacobians.

    Parameters
    ----------
    n : int
    q : callable ``q(x) -> (n,)``
    dq : callable ``dq(x) -> (n, n)``
    phi : callable ``phi(x, t) -> (n,)``
    dphi : callable ``dphi(x, t) -> (n, n)``
    pattern : SparsePattern, optional
        Defaults to a dense pattern.
    names, kinds : optional
    """

    def __init__(self, n, q, dq, phi, dphi, *, pattern=None, names=None, kinds=None):
        self.n = int(n)
        self._q, self._dq, self._phi, self._dphi = q, dq, phi, dphi
        if pattern is None:
            full = np.ones((self.n, self.n))
            pattern = SparsePattern.from_matrices(full)
        self.pattern = pattern
        self.names = _as_names(names, self.n)
        self.kinds = _as_kinds(kinds, self.n)

    def _values(self, m, what: str) -> np.ndarray:
        m = np.asarray(m.toarray() if sp.issparse(m) else m, dtype=float)
        if m.shape != (self.n, self.n):
            raise ValueError(f"{what} must return an array of shape ({self.n}, {self.n}), not shape {m.shape}")
        return m[self.pattern.rows, self.pattern.cols]

    def evaluate(self, x, t, *, jacobian=True, state=None, source_scale=1.0) -> Evaluation:
        x = np.asarray(x, dtype=float)
        q = _vector(self._q(x), self.n, "q(x)")
        phi = _vector(self._phi(x, t), self.n, "phi(x, t)")
        ok = bool(np.all(np.isfinite(q)) and np.all(np.isfinite(phi)))
        if not jacobian:
            return Evaluation(q=q, phi=phi, ok=ok)
        return Evaluation(q=q, phi=phi, dq=self._values(self._dq(x), "dq(x)"),
                          dphi=self._values(self._dphi(x, t), "dphi(x, t)"), ok=ok)


def _vector(value, n: int, what: str) -> np.ndarray:
    """``value`` as a float array of shape (n,); a user's callable that returns another shape is a ValueError
    (a wrong length reached the compiled LU's solve, which does not check sizes)."""
    v = np.asarray(value, dtype=float)
    if v.shape != (n,):
        raise ValueError(f"{what} must return an array of shape ({n},), not shape {v.shape}")
    return v


def names_index(names: Sequence[str]) -> dict[str, int]:
    """Lower-case name to position."""
    return {nm.lower(): i for i, nm in enumerate(names)}
