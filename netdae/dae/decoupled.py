"""Weierstrass (Kronecker) form (2.9) of a regular pencil and the decoupled system (2.11)/(2.12).

For a regular pencil ``lambda E - H`` this module builds invertible ``U``, ``V``
with

.. math::  U E V = \\begin{pmatrix} I & 0 \\\\ 0 & N \\end{pmatrix}, \\qquad
           U H V = \\begin{pmatrix} C & 0 \\\\ 0 & I \\end{pmatrix}

(finite part first, ``N`` strictly upper triangular, hence nilpotent), so that
``E x' = H x + c`` splits with ``x = V (y; z)``, ``U c = (delta; theta)`` into

.. math::  y' = C y + \\delta, \\qquad N z' = z + \\theta, \\qquad
           z = -\\sum_{l<k} N^l \\theta^{(l)}   \\quad (2.11), (2.12).

Construction (never a Jordan form)
----------------------------------
1. The orthogonal staircase of :func:`netdae.dae.kronecker.staircase` on the
   balanced pencil gives ``Q^T (Eb, Hb) Z`` block upper triangular with the
   infinite part ``(E_inf, H_inf)`` leading (``E_inf`` strictly, ``H_inf``
   upper triangular) and the finite part ``(E_f, H_f)`` trailing, ``E_f``
   invertible.
2. ``N = H_inf^{-1} E_inf`` (a triangular solve; exactly strictly upper
   triangular). The finite part is brought to ``(I, C)`` either by QZ
   (``scipy.linalg.ordqz``: ``C = S^{-1} T`` from the generalized Schur
   pair) or, for large parts, by a real Schur form of ``E_f^{-1} H_f``.
3. The coupling blocks are removed by the generalized Sylvester equations
   ``N Y + X = -E_12``, ``Y + X C = -H_12``; eliminating ``Y`` gives
   ``X - N X C = N H_12 - E_12``, which :func:`solve_nilpotent_stein` solves by
   block back substitution over the staircase blocks of ``N`` (exact in a
   finite number of steps because ``N`` is nilpotent).
4. The balancing scalings are folded back into ``U`` and ``V``.

References
----------
.. [1] B. Simeon, *Differential-Algebraic Equations*, lecture notes, TU
   Kaiserslautern 2012, Section 2.2, (2.9)-(2.12).
.. [2] B. Kagstrom, P. Van Dooren, "A generalized state-space approach for the
   additive decomposition of a transfer matrix", J. Numer. Linear Algebra
   Appl. 1 (1992) 165-181 (block decoupling by generalized Sylvester equations).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.linalg as sla

from .kronecker import Balancing, Staircase, quasi_triangular_eigvals

__all__ = [
    "QZ_LIMIT",
    "CLASSIFY_SAFETY",
    "WeierstrassForm",
    "Classification",
    "ConsistencyReport",
    "solve_nilpotent_stein",
    "weierstrass_from_staircase",
]

#: Finite parts up to this size are reduced by QZ (backward stable for the
#: finite eigenvalues even when E_f is ill-conditioned); larger ones by a real
#: Schur form of ``E_f^{-1} H_f`` (measured on the 2-core reference machine:
#: QZ takes 0.8 s at n=500, 6.6 s at 1000 and 84 s at 2000, the Schur form
#: 0.6 s at 1000 and 3 s at 2000).
QZ_LIMIT = 600

#: Classification thresholds are ``CLASSIFY_SAFETY * rtol`` times the product
#: of the norms of the factors (V, N^m, U, B): these products of
#: non-orthogonal factors carry more rounding than a single orthogonal rank
#: decision.
CLASSIFY_SAFETY = 100.0

#: Default tolerances of :meth:`WeierstrassForm.check_consistency` (relative
#: to |x0_i|, and absolute in the units of each unknown).
CONSISTENCY_RTOL = 1e-8
CONSISTENCY_ATOL = 1e-12


def _keep_order(alpha, beta) -> np.ndarray:
    """``ordqz`` selection that moves no eigenvalue (all are finite here)."""
    return np.zeros(np.shape(alpha), dtype=bool)


def solve_nilpotent_stein(N: np.ndarray, C: np.ndarray, F: np.ndarray, blocks) -> np.ndarray:
    """Solve ``X - N X C = F`` for a strictly block upper triangular (nilpotent) ``N``.

    Parameters
    ----------
    N : ndarray, shape (p, p)
        Strictly block upper triangular with diagonal blocks of the sizes in
        ``blocks`` (so ``N^len(blocks) = 0``).
    C : ndarray, shape (q, q)
    F : ndarray, shape (p, q)
    blocks : sequence of int
        Sizes of the diagonal blocks of N, summing to p.

    Returns
    -------
    X : ndarray, shape (p, q)

    Notes
    -----
    Block back substitution from the last block row: ``X_b = F_b + sum_{c>b}
    N_bc (X_c C)``; the solution is ``X = sum_j N^j F C^j`` (a finite sum).
    Cost O(p q^2 + p^2 q) with one Python step per staircase block (the index).
    """
    X = np.array(F, dtype=float, copy=True)
    XC = np.zeros_like(X)
    bounds = np.concatenate([[0], np.cumsum(blocks)]).astype(int)
    for b in range(len(blocks) - 1, -1, -1):
        lo, hi = bounds[b], bounds[b + 1]
        if hi < X.shape[0]:
            X[lo:hi] += N[lo:hi, hi:] @ XC[hi:]
        XC[lo:hi] = X[lo:hi] @ C
    return X


@dataclass(frozen=True)
class Classification:
    """Per-unknown role in the decoupled solution.

    Attributes
    ----------
    labels : tuple of str
        ``"differential"``, ``"algebraic"``, ``"index2"``, ``"index3"``, ...
    derivative_order : ndarray of int, shape (n,)
        Highest derivative of the inputs the unknown depends on (0, 1, 2, ...).
    depends_on_state : ndarray of bool, shape (n,)
        Row i of ``V_1`` is non-negligible (x_i depends on the dynamic part y).
    weights : ndarray, shape (n, k + 1)
        Evidence: column 0 is ``|row_i(V_1)|`` relative to its threshold,
        column m+1 is ``|row_i(V_2 N^m G)|`` relative to its threshold
        (> 1 means non-negligible); computed in balanced coordinates.
    excited_only : bool
        True when an input matrix B restricted the inputs (``G = U_2 B``),
        False when every direction counted (``G = U_2``).
    """

    labels: tuple
    derivative_order: np.ndarray
    depends_on_state: np.ndarray
    weights: np.ndarray
    excited_only: bool

    def to_dict(self, names=None) -> dict:
        names = list(names) if names is not None else [f"x{i}" for i in range(len(self.labels))]
        return {
            "excited_only": self.excited_only,
            "unknowns": [
                {
                    "name": nm,
                    "label": lb,
                    "derivative_order": int(d),
                    "depends_on_state": bool(s),
                    "weights": [float(w) for w in row],
                }
                for nm, lb, d, s, row in zip(
                    names, self.labels, self.derivative_order, self.depends_on_state, self.weights
                )
            ],
        }


@dataclass(frozen=True)
class ConsistencyReport:
    """Check of an initial value against the explicit and hidden constraints.

    The constraints are ``z(t0) = -sum_{l<k} N^l theta^(l)(t0)`` in
    Weierstrass coordinates. Their violation ``r = z0 - z_cons`` is split
    by *order*: the order-m part is the component of ``r`` along the
    functionals ``w`` with ``w^T N^(m+1) = 0`` but ``w^T N^m != 0``, i.e. the
    constraints that involve input derivatives up to order m (order 0: the
    explicit algebraic equations; order >= 1: hidden constraints).

    Attributes
    ----------
    consistent : bool
        ``|dx_i| <= atol + rtol |x0_i|`` for every unknown.
    x_consistent : ndarray, shape (n,)
        ``V_1 y0 + V_2 z_cons`` with ``y0`` taken from ``x0``.
    dx : ndarray, shape (n,)
        ``x_consistent - x0``.
    violation_by_order : tuple of float
        ``max_i |dx_i|`` caused by the order-m constraints, m = 0..k-1.
    affected : tuple of int
        Unknowns whose value must change.
    affected_by_order : tuple of tuple of int
        The same per constraint order.
    rtol, atol : float
    """

    consistent: bool
    x_consistent: np.ndarray
    dx: np.ndarray
    violation_by_order: tuple
    affected: tuple
    affected_by_order: tuple
    rtol: float
    atol: float

    def to_dict(self, names=None) -> dict:
        nm = (lambda i: names[i]) if names is not None else (lambda i: i)
        return {
            "consistent": self.consistent,
            "violation_by_order": list(self.violation_by_order),
            "affected": [nm(i) for i in self.affected],
            "affected_by_order": [[nm(i) for i in a] for a in self.affected_by_order],
            "dx": self.dx.tolist(),
            "rtol": self.rtol,
            "atol": self.atol,
        }


def _norm(a: np.ndarray, axis: int | None = None):
    """Frobenius (or row, column) norm without overflow: of ``a / max|a|``, times ``max|a|``.

    ``np.linalg.norm`` squares the entries, and balanced coordinates of a badly scaled pencil hold
    entries above 1e154 (a 40-stage chain of gain stages): their squares overflow to inf and a
    threshold made of them decides nothing.
    """
    a = np.asarray(a, dtype=float)
    if a.size == 0:
        return np.linalg.norm(a, axis=axis)
    top = float(np.max(np.abs(a)))
    if top == 0.0 or not np.isfinite(top):
        return np.linalg.norm(a, axis=axis)
    return top * np.linalg.norm(a / top, axis=axis)


@dataclass(frozen=True)
class WeierstrassForm:
    """The decoupling ``U E V = diag(I, N)``, ``U H V = diag(C, I)`` of a regular pencil.

    Attributes
    ----------
    U, V, V_inv : ndarray, shape (n, n)
        Invertible transformations (finite part first).
    C : ndarray, shape (n_finite, n_finite)
        Real quasi-upper-triangular (real Schur form) matrix of the finite part.
    N : ndarray, shape (n_infinite, n_infinite)
        Strictly upper triangular nilpotent matrix, ``N^index = 0``.
    eigenvalues : ndarray of complex, shape (n_finite,)
        Finite eigenvalues (those of C).
    blocks : tuple of int
        Staircase block sizes of N (``blocks[i]`` = number of Jordan blocks of
        size > i); ``len(blocks)`` is the index.
    finite_method : str
        ``"qz"`` or ``"schur"`` (see :data:`QZ_LIMIT`).
    balancing : Balancing
        The scaling folded into U and V (used for classification thresholds).
    coupling_norms : tuple of float
        Frobenius norms of the Sylvester solutions (X, Y) in balanced
        coordinates: large values mean the finite and infinite parts are close
        to each other (an ill-conditioned decoupling).
    rtol : float
        Relative tolerance the structure was decided with.
    """

    U: np.ndarray
    V: np.ndarray
    V_inv: np.ndarray
    C: np.ndarray
    N: np.ndarray
    eigenvalues: np.ndarray
    blocks: tuple
    finite_method: str
    balancing: Balancing
    coupling_norms: tuple
    rtol: float

    # -- sizes --------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.U.shape[0]

    @property
    def n_finite(self) -> int:
        return self.C.shape[0]

    @property
    def n_infinite(self) -> int:
        return self.N.shape[0]

    @property
    def index(self) -> int:
        """Nilpotency index k (0 when E is invertible)."""
        return len(self.blocks)

    # -- the transformation split by parts ---------------------------------
    @property
    def U1(self) -> np.ndarray:
        """Rows of U for the finite part: ``delta = U1 c``."""
        return self.U[: self.n_finite]

    @property
    def U2(self) -> np.ndarray:
        """Rows of U for the nilpotent part: ``theta = U2 c``."""
        return self.U[self.n_finite :]

    @property
    def V1(self) -> np.ndarray:
        return self.V[:, : self.n_finite]

    @property
    def V2(self) -> np.ndarray:
        return self.V[:, self.n_finite :]

    # -- coordinates ---------------------------------------------------------
    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(y, z) = V^{-1} x``; x of shape (n,) or (n, m)."""
        w = self.V_inv @ np.asarray(x, dtype=float)
        return w[: self.n_finite], w[self.n_finite :]

    def combine(self, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """``x = V1 y + V2 z``; y of shape (n_finite[, m]), z of shape (n_infinite[, m])."""
        return self.V1 @ np.asarray(y, dtype=float) + self.V2 @ np.asarray(z, dtype=float)

    # -- the nilpotent part (2.12) --------------------------------------------
    def nilpotent_solution(self, theta_derivs) -> np.ndarray:
        """``z = -sum_{l<k} N^l theta^(l)`` (2.12).

        Parameters
        ----------
        theta_derivs : array_like, shape (k, n_infinite[, m])
            ``theta_derivs[l]`` is the l-th time derivative of ``theta``
            (possibly at m instants); at least ``index`` derivatives (more are
            ignored: ``N^l = 0`` for ``l >= index``).

        Returns
        -------
        z : ndarray, shape (n_infinite[, m])

        Raises
        ------
        ValueError
            When fewer than ``index`` derivatives are given.

        Notes
        -----
        Horner's scheme, ``index`` products with N.
        """
        th = np.asarray(theta_derivs, dtype=float)
        k = self.index
        if k == 0:
            return np.zeros((0,) + th.shape[2:])
        if th.shape[0] < k:
            raise ValueError(f"the nilpotent part needs theta and its first {k - 1} derivatives, got {th.shape[0]}")
        acc = th[k - 1].copy()
        for l in range(k - 2, -1, -1):
            acc = th[l] + self.N @ acc
        return -acc

    def nilpotent_from_inputs(self, c_derivs) -> np.ndarray:
        """``z`` from the derivatives of the source vector ``c`` of ``E x' = H x + c``.

        Parameters
        ----------
        c_derivs : array_like, shape (k, n[, m])
            ``c_derivs[l]`` is ``c^(l)`` (possibly at m instants).

        Returns
        -------
        z : ndarray, shape (n_infinite[, m])
        """
        c = np.asarray(c_derivs, dtype=float)
        k = self.index
        if k == 0:
            return np.zeros((0,) + c.shape[2:])
        if c.shape[0] < k:
            raise ValueError(f"the nilpotent part needs c and its first {k - 1} derivatives, got {c.shape[0]}")
        theta = np.tensordot(self.U2, c[:k], axes=([1], [1]))  # (n_inf, k[, m])
        return self.nilpotent_solution(np.moveaxis(theta, 1, 0))

    def _c_stack(self, c_derivs: Callable[[int], np.ndarray]) -> np.ndarray:
        k = self.index
        return np.array([np.asarray(c_derivs(l), dtype=float) for l in range(k)]).reshape(k, self.n)

    # -- consistent initial values --------------------------------------------
    def consistent_initial_value(self, x0: np.ndarray, c_derivs: Callable[[int], np.ndarray]) -> np.ndarray:
        """``x0`` with its nilpotent part replaced by the one (2.12) prescribes.

        Keeps ``y0 = (V^{-1} x0)_y`` and sets ``z0 = -sum N^l theta^(l)(t0)``.

        Parameters
        ----------
        x0 : ndarray, shape (n,)
        c_derivs : callable
            ``c_derivs(l) -> ndarray (n,)``: the l-th derivative of ``c`` at t0,
            called for ``l = 0 .. index-1``.

        Returns
        -------
        ndarray, shape (n,)
        """
        y0, _ = self.split(x0)
        z = self.nilpotent_from_inputs(self._c_stack(c_derivs)) if self.index else np.zeros(0)
        return self.combine(y0, z)

    def check_consistency(
        self,
        x0: np.ndarray,
        c_derivs: Callable[[int], np.ndarray],
        *,
        rtol: float = CONSISTENCY_RTOL,
        atol: float = CONSISTENCY_ATOL,
        steady: bool = False,
    ) -> ConsistencyReport:
        """Check ``x0`` against the explicit and hidden constraints.

        Parameters
        ----------
        x0 : ndarray, shape (n,)
        c_derivs : callable
            ``c_derivs(l) -> c^(l)(t0)``, shape (n,), for ``l < index``
            (with ``steady``, only ``l >= 1`` is asked for).
        rtol, atol : float
            An unknown is affected when ``|dx_i| > atol + rtol |x0_i|``.
        steady : bool
            ``x0`` is a steady state of the inputs' values at t0 (``H x0 +
            c(t0) = 0``, as a converged DC operating point): it satisfies
            ``N z' = z + theta`` with ``z' = 0``, so ``z0 = -theta(t0)`` and the
            violation is exactly the part the inputs' derivatives make,
            ``r = sum_{l>=1} N^l theta^(l)(t0)`` (zero when the inputs do not
            change at t0). ``z0 + theta(t0)`` is then the solver's residual
            mapped by ``U2``, not measured: ``V2 U2`` amplifies it by up to the
            condition of the transformation (1e18 for op-amp macromodels with
            gains of 1e6 and resistances from 1e-6 to 1e11 ohm).

        Returns
        -------
        ConsistencyReport

        Notes
        -----
        Cost O(n^2 + k n_inf^3) (one SVD of each power of N for the split by order).
        """
        x0 = np.asarray(x0, dtype=float)
        k = self.index
        if steady:
            r = np.zeros(self.n_infinite)
            if k > 1:  # Horner's scheme over l = 1 .. k-1: r = N (theta' + N (theta'' + ...))
                acc = np.zeros(self.n_infinite)
                for l in range(k - 1, 0, -1):
                    acc = self.U2 @ np.asarray(c_derivs(l), dtype=float).reshape(self.n) + self.N @ acc
                r = self.N @ acc
        else:
            _, z0 = self.split(x0)
            zc = self.nilpotent_from_inputs(self._c_stack(c_derivs)) if k else np.zeros(0)
            r = z0 - zc
        ranges = self._power_ranges()
        parts = []
        for m in range(k):
            hi, lo = ranges[m], ranges[m + 1]
            parts.append(hi @ (hi.T @ r) - lo @ (lo.T @ r))
        dx_parts = [-(self.V2 @ p) for p in parts]
        dx = -(self.V2 @ r)
        bound = atol + rtol * np.abs(x0)
        affected = tuple(int(i) for i in np.flatnonzero(np.abs(dx) > bound))
        by_order = tuple(tuple(int(i) for i in np.flatnonzero(np.abs(d) > bound)) for d in dx_parts)
        viol = tuple(float(np.max(np.abs(d))) if d.size else 0.0 for d in dx_parts)
        return ConsistencyReport(
            consistent=not affected,
            x_consistent=x0 + dx,
            dx=dx,
            violation_by_order=viol,
            affected=affected,
            affected_by_order=by_order,
            rtol=float(rtol),
            atol=float(atol),
        )

    def _power_ranges(self) -> list[np.ndarray]:
        """Orthonormal bases of range(N^j), j = 0..index (ranks from the staircase)."""
        p = self.n_infinite
        ranks = [p - sum(self.blocks[:j]) for j in range(self.index + 1)]
        out = [np.eye(p)]
        Nj = np.eye(p)
        for j in range(1, self.index + 1):
            Nj = self.N @ Nj
            if ranks[j] == 0:
                out.append(np.zeros((p, 0)))
                continue
            P, _, _ = sla.svd(Nj, full_matrices=False)
            out.append(P[:, : ranks[j]])
        return out

    # -- classification of unknowns -------------------------------------------
    def classify(self, B: np.ndarray | None = None) -> Classification:
        """Classify each unknown by what its value depends on.

        With ``x = V1 y + V2 z`` and ``z = -sum_l N^l theta^(l)``, ``theta = U2 c``
        (``c = B u`` when B is given): unknown i has *derivative order* m when
        row i of ``V2 N^m G`` (``G = U2 B`` or ``U2``) is non-negligible for the
        largest such m; it is labelled ``"index{m+1}"`` when m >= 1, else
        ``"differential"`` when row i of ``V1`` is non-negligible, else
        ``"algebraic"`` (determined by the inputs' values, or identically zero).

        Parameters
        ----------
        B : ndarray, shape (n, p) or (n,), optional
            Input matrix of ``c(t) = B u(t)``: only directions the inputs
            excite count.

        Returns
        -------
        Classification

        Raises
        ------
        ValueError
            When B does not have n rows.

        Notes
        -----
        Decided in balanced coordinates (rows and columns of comparable scale),
        with threshold ``CLASSIFY_SAFETY * rtol * ||V2|| ||N^m|| ||U2|| ||B||``
        (Frobenius norms; B's columns normalised first). Cost O(k n^2 p).
        """
        bal = self.balancing
        nf = self.n_finite
        dr = bal.col_scale
        dl = bal.row_scale
        Vb = self.V / dr[:, None]
        V1b, V2b = Vb[:, :nf], Vb[:, nf:]
        U2b = self.U2 / dl[None, :]
        Nb = self.N * bal.time_scale
        Bb = None
        if B is None:
            G = U2b
        else:
            B = np.asarray(B, dtype=float)
            B = B[:, None] if B.ndim == 1 else B
            if B.ndim != 2 or B.shape[0] != self.n:
                raise ValueError(f"B must have shape ({self.n}, p), got {B.shape}")
            Bb = dl[:, None] * B
            norms = _norm(Bb, axis=0)
            Bb = Bb[:, norms > 0] / norms[norms > 0]
            G = U2b @ Bb
        tol = CLASSIFY_SAFETY * self.rtol
        k = self.index
        weights = np.zeros((self.n, k + 1))
        thr_y = tol * _norm(V1b)
        weights[:, 0] = _norm(V1b, axis=1) / thr_y if thr_y > 0 else 0.0
        W = G
        Nm_norm = 1.0
        norm_v2 = _norm(V2b)
        # the product of the factors' norms, ||U2|| ||B||, not ||U2 B||: where the inputs do not excite the
        # nilpotent part, U2 B is rounding, and a threshold scaled by it turns rounding into dependence
        norm_g = (_norm(U2b) * (1.0 if Bb is None else _norm(Bb))) if G.size else 0.0
        Nm = np.eye(self.n_infinite)
        for m in range(k):
            thr = tol * norm_v2 * Nm_norm * norm_g
            rows = _norm(V2b @ W, axis=1) if W.size else np.zeros(self.n)
            weights[:, m + 1] = rows / thr if thr > 0 else 0.0
            W = Nb @ W
            Nm = Nb @ Nm
            Nm_norm = _norm(Nm)
        dep = weights[:, 1:] > 1.0
        if k:
            order = np.where(dep.any(axis=1), k - 1 - np.argmax(dep[:, ::-1], axis=1), 0)
        else:
            order = np.zeros(self.n, dtype=int)
        state = weights[:, 0] > 1.0
        labels = tuple(
            f"index{o + 1}" if o >= 1 else ("differential" if s else "algebraic") for o, s in zip(order, state)
        )
        return Classification(labels, order.astype(int), state, weights, B is not None)


def weierstrass_from_staircase(
    st: Staircase,
    balancing: Balancing,
    rtol: float,
    *,
    finite_method: str = "auto",
) -> WeierstrassForm:
    """Weierstrass form of a regular pencil from its staircase (see module docstring).

    Parameters
    ----------
    st : Staircase
        Staircase of the balanced pencil; must describe a regular pencil
        (``st.r0 == st.c0`` and no right singular blocks).
    balancing : Balancing
        The balancing that produced the staircase's input.
    rtol : float
        Relative tolerance used for the structure (kept for classification).
    finite_method : {"auto", "qz", "schur"}
        Reduction of the finite part; "auto" uses QZ up to :data:`QZ_LIMIT`.

    Returns
    -------
    WeierstrassForm

    Raises
    ------
    ValueError
        For an unknown ``finite_method`` or a staircase of a singular pencil.

    Notes
    -----
    Cost: QZ O(30 n_f^3) or Schur O(10 n_f^3), plus O(n^3) matrix products.
    """
    if st.r0 != st.c0 or st.right_indices:
        raise ValueError("the staircase describes a singular pencil: no Weierstrass form")
    if finite_method not in ("auto", "qz", "schur"):
        raise ValueError(f"finite_method must be 'auto', 'qz' or 'schur', not {finite_method!r}")
    A, B, QT, Z = st.A, st.B, st.QT, st.Z
    n = A.shape[0]
    ni = st.r0
    nf = n - ni
    Hinf = B[:ni, :ni]
    Nb = np.triu(sla.solve_triangular(Hinf, A[:ni, :ni], check_finite=False), 1)
    E12 = sla.solve_triangular(Hinf, A[:ni, ni:], check_finite=False)
    H12 = sla.solve_triangular(Hinf, B[:ni, ni:], check_finite=False)
    Uinf0 = sla.solve_triangular(Hinf, QT[:ni], check_finite=False)
    Ef, Hf = A[ni:, ni:], B[ni:, ni:]
    method = finite_method if finite_method != "auto" else ("qz" if nf <= QZ_LIMIT else "schur")
    if nf == 0:
        Cb = np.zeros((0, 0))
        Zf = np.zeros((0, 0))
        Uf0 = np.zeros((0, n))
        lam = np.zeros(0, dtype=complex)
    elif method == "qz":
        # (Hf, Ef) -> (TT, SS): Qf^T Hf Zf = TT quasi-triangular, Qf^T Ef Zf = SS triangular
        TT, SS, _, _, Qf, Zf = sla.ordqz(Hf, Ef, sort=_keep_order)
        Cb = sla.solve_triangular(SS, TT, check_finite=False)
        Uf0 = sla.solve_triangular(SS, Qf.T @ QT[ni:], check_finite=False)
        lam = quasi_triangular_eigvals(TT, SS)
    else:
        lu = sla.lu_factor(Ef, check_finite=False)
        Cb, Zf = sla.schur(sla.lu_solve(lu, Hf, check_finite=False), output="real")
        Uf0 = Zf.T @ sla.lu_solve(lu, QT[ni:], check_finite=False)
        lam = quasi_triangular_eigvals(Cb)
    E12 = E12 @ Zf if nf else E12
    H12 = H12 @ Zf if nf else H12
    X = solve_nilpotent_stein(Nb, Cb, Nb @ H12 - E12, st.cols)
    Y = -H12 - X @ Cb
    # balanced transformations, infinite part rows/columns
    Uinf = Uinf0 + X @ Uf0
    Vinf = Z[:, :ni]
    Vf = Z[:, ni:] @ Zf + Vinf @ Y if nf else Z[:, ni:]
    Vinv_f = Zf.T @ Z[:, ni:].T if nf else np.zeros((0, n))
    Vinv_inf = Z[:, :ni].T - Y @ Vinv_f
    # fold the balancing back in: Eb = a Dl E Dr, Hb = Dl H Dr
    a = balancing.time_scale
    dl, dr = balancing.row_scale, balancing.col_scale
    U = np.vstack([a * Uf0, Uinf]) * dl[None, :]
    V = dr[:, None] * np.hstack([Vf, Vinf])
    V_inv = np.vstack([Vinv_f, Vinv_inf]) / dr[None, :]
    return WeierstrassForm(
        U=U,
        V=V,
        V_inv=V_inv,
        C=a * Cb,
        N=Nb / a,
        eigenvalues=a * lam,
        blocks=tuple(st.cols),
        finite_method=method if nf else "none",
        balancing=balancing,
        coupling_norms=(float(np.linalg.norm(X)), float(np.linalg.norm(Y))),
        rtol=float(rtol),
    )
