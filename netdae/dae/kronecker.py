"""Kronecker structure of a matrix pencil ``lambda E - H`` by orthogonal staircase reduction.

This module holds the numerical kernels behind :mod:`netdae.dae.pencil`:

- :func:`balance_pencil` -- diagonal equilibration of the pencil (rows,
  columns and the relative scale of E and H) by exact powers of two, before
  any rank decision;
- :func:`rank_decision` -- one numerical rank decision with its evidence
  (tolerance and the singular values on each side of the cut);
- :func:`staircase` -- the staircase reduction of Van Dooren [1]_ that deflates
  the null space of E step by step with orthogonal transformations only;
- :func:`kronecker_structure` -- regularity, the sizes of the infinite
  (nilpotent) Jordan blocks, the right and left minimal indices of a singular
  pencil and the finite eigenvalues, from one or two staircases.

Staircase
---------
For the pencil ``lambda E - H`` (``m x k``) step ``i`` takes the active block
``(E_i, H_i)`` (rows ``r0:``, columns ``c0:``), computes the null space of
``E_i`` (dimension ``s_i``) by an SVD, rotates it to the leading active
columns (where ``E`` is then exactly zero), and compresses the rows of ``H``
on those columns by a second SVD (rank ``rho_i``). The ``rho_i`` rows and
``s_i`` columns are deflated and the next step works on the rest. The
reduction stops when the active ``E`` block has full column rank. Then

- the pencil has ``s_i - rho_i`` right singular blocks ``L_{i-1}``,
- ``rho_i - s_{i+1}`` infinite Jordan blocks of size ``i``,

and the deflated leading part is block upper triangular with zero diagonal
blocks in ``E`` and diagonal, positive diagonal blocks in ``H``: in the
regular case ``E_inf`` is strictly upper triangular and ``H_inf`` upper
triangular, so ``N = H_inf^{-1} E_inf`` is an exactly nilpotent, strictly
upper triangular matrix of index ``len(steps)``. The trailing part
``(E_f, H_f)`` has ``E_f`` of full column rank and carries the finite
eigenvalues (and, for a singular pencil, the left singular blocks, which the
same reduction applied to the transposed remainder extracts).

Every transformation is orthogonal, and the only approximations are the
neglected singular values below the tolerance (recorded), so the computed
structure is exact for a pencil within that distance of the input: the
reduction is backward stable [1]_, [2]_.

References
----------
.. [1] P. Van Dooren, "The computation of Kronecker's canonical form of a
   singular pencil", Linear Algebra Appl. 27 (1979) 103-140.
.. [2] J. Demmel, B. Kagstrom, "The generalized Schur decomposition of an
   arbitrary pencil A - lambda B: robust software with error bounds and
   applications", ACM TOMS 19 (1993) 160-174 and 175-201.
.. [3] R. C. Ward, "Balancing the generalized eigenvalue problem", SIAM J.
   Sci. Stat. Comput. 2 (1981) 141-152.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.sparse.linalg import LinearOperator, cg

__all__ = [
    "EPS",
    "RankDecision",
    "Balancing",
    "Staircase",
    "KroneckerStructure",
    "default_rtol",
    "rank_decision",
    "balance_pencil",
    "MatrixRank",
    "matrix_rank",
    "staircase",
    "kronecker_structure",
    "quasi_triangular_eigvals",
]

#: Machine epsilon of float64.
EPS = float(np.finfo(float).eps)

#: Default relative tolerance of a rank decision is ``RTOL_FACTOR * n * EPS``
#: times the Frobenius norm of the (balanced) matrix: the numpy/LAPACK
#: convention ``max(m, n) * eps * ||M||``. After balancing, rounding errors of
#: the orthogonal staircase stay a small multiple of ``EPS * ||M||``, far
#: below this.
RTOL_FACTOR = 1.0

#: An entry below ``BALANCE_NEGLIGIBLE`` times *both* the largest entry of its
#: row and the largest entry of its column (of the pencil ``[alpha0 E, H]``,
#: ``alpha0 = ||H|| / ||E||``) is rounding noise (``cos(pi/2) = 6e-17`` next to
#: O(1) entries, or noise in an algebraic row of E) and does not steer the
#: balancing (it stays in the pencil): fitted, it would drag a row and a column
#: by 50 binary orders and ruin the rank decisions. A genuine small value of a
#: badly scaled matrix is large relative to its own row or its own column, and
#: is kept.
BALANCE_NEGLIGIBLE = EPS

#: Iteration limit and relative tolerance of the conjugate-gradient solve for
#: the balancing exponents, which are rounded to integers: a loose solve suffices.
BALANCE_MAXITER = 200
BALANCE_LSQ_TOL = 1e-6


def default_rtol(n: int) -> float:
    """Default relative tolerance of rank decisions for an ``n x n`` pencil."""
    return RTOL_FACTOR * max(int(n), 1) * EPS


# ---------------------------------------------------------------------------
# rank decisions with evidence
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class RankDecision:
    """One numerical rank decision and its evidence.

    Attributes
    ----------
    what : str
        What was decided (e.g. ``"rank E (staircase step 1)"``).
    shape : tuple of int
        Shape of the matrix whose rank was decided.
    tol : float
        Absolute tolerance: singular values ``<= tol`` count as zero.
    rank : int
        The numerical rank.
    kept : tuple of float
        The (up to) two smallest singular values counted as non-zero.
    dropped : tuple of float
        The (up to) two largest singular values counted as zero; exact zeros
        implied by the shape (a wide matrix) are not listed.
    gap : float
        ``kept[-1] / dropped[0]`` (``inf`` when nothing was dropped or kept):
        a large gap means a clear decision.
    """

    what: str
    shape: tuple
    tol: float
    rank: int
    kept: tuple
    dropped: tuple
    gap: float

    @property
    def margin(self) -> float:
        """How clear the decision is: ``min(kept[-1] / tol, tol / dropped[0])`` (``inf`` if exact)."""
        up = self.kept[-1] / self.tol if self.kept and self.tol > 0 else float("inf")
        down = self.tol / self.dropped[0] if self.dropped and self.dropped[0] > 0 else float("inf")
        return float(min(up, down))

    def to_dict(self) -> dict:
        """JSON-serialisable form."""
        return {
            "what": self.what,
            "shape": list(self.shape),
            "tol": self.tol,
            "rank": self.rank,
            "kept": list(self.kept),
            "dropped": list(self.dropped),
            "gap": None if not np.isfinite(self.gap) else self.gap,
            "margin": None if not np.isfinite(self.margin) else self.margin,
        }


def rank_decision(sigma: np.ndarray, tol: float, what: str, shape, rank: int | None = None) -> RankDecision:
    """Decide the numerical rank from singular values.

    Parameters
    ----------
    sigma : ndarray, shape (min(shape),)
        Singular values in descending order.
    tol : float
        Absolute tolerance; singular values ``<= tol`` count as zero.
    what : str
        Description kept in the evidence.
    shape : tuple of int
    rank : int, optional
        The rank, when it was decided otherwise (in exact arithmetic: :mod:`netdae.dae.exact`); the
        evidence then shows how far the singular values are from the tolerance, and
        :attr:`RankDecision.margin` may fall below 1.

    Returns
    -------
    RankDecision
    """
    sigma = np.asarray(sigma, dtype=float)
    r = int(np.count_nonzero(sigma > tol)) if rank is None else int(rank)
    kept = tuple(float(v) for v in sigma[max(r - 2, 0) : r])
    dropped = tuple(float(v) for v in sigma[r : r + 2])
    if kept and dropped:
        gap = kept[-1] / dropped[0] if dropped[0] > 0 else float("inf")
    else:
        gap = float("inf")
    return RankDecision(what, tuple(int(s) for s in shape), float(tol), r, kept, dropped, float(gap))


def _svd(m: np.ndarray):
    """Full SVD ``m = P diag(s) WT`` with a fallback LAPACK driver; handles empty matrices."""
    rows, cols = m.shape
    if rows == 0 or cols == 0:
        return np.eye(rows), np.zeros(0), np.eye(cols)
    try:
        return sla.svd(m, full_matrices=True, lapack_driver="gesdd", check_finite=False)
    except np.linalg.LinAlgError:  # gesdd can fail to converge where gesvd succeeds
        return sla.svd(m, full_matrices=True, lapack_driver="gesvd", check_finite=False)


def _svdvals(m: np.ndarray) -> np.ndarray:
    """Singular values only (about a third of the cost of a full SVD)."""
    if m.size == 0:
        return np.zeros(0)
    return sla.svd(m, compute_uv=False, check_finite=False)


# ---------------------------------------------------------------------------
# balancing
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Balancing:
    """Diagonal equilibration of a pencil by powers of two.

    The balanced pencil is ``Eb = alpha * Dl E Dr``, ``Hb = Dl H Dr`` with
    ``Dl = diag(row_scale)``, ``Dr = diag(col_scale)`` and ``alpha =
    time_scale``. It has the same Kronecker structure, and its eigenvalues
    ``mu`` are those of the original pencil divided by ``alpha`` (``lambda =
    alpha * mu``): ``alpha`` rescales time. All factors are powers of two, so
    the scaling itself is exact in floating point.

    Attributes
    ----------
    applied : bool
        False when balancing was switched off (all scales one).
    row_scale, col_scale : ndarray, shape (n,)
    time_scale : float
    spread_before, spread_after : float
        Decades between the largest and smallest entry that steered the
        balancing (``log10(max/min)`` over the significant entries of E and
        H), before and after balancing.
    """

    applied: bool
    row_scale: np.ndarray
    col_scale: np.ndarray
    time_scale: float
    spread_before: float
    spread_after: float

    def apply(self, E: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The balanced dense pair ``(Eb, Hb)``."""
        dl = self.row_scale[:, None]
        dr = self.col_scale[None, :]
        return (self.time_scale * dl) * E * dr, dl * H * dr

    def to_dict(self) -> dict:
        """JSON-serialisable summary (the scales as base-2 exponents)."""
        return {
            "applied": self.applied,
            "row_exponents": np.log2(self.row_scale).astype(int).tolist(),
            "col_exponents": np.log2(self.col_scale).astype(int).tolist(),
            "time_exponent": int(np.log2(self.time_scale)),
            "spread_before_decades": self.spread_before,
            "spread_after_decades": self.spread_after,
        }


def _significant(E: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the entries of E and of H that steer the balancing.

    Significance is judged in the combined pencil ``[alpha0 E, H]`` with the
    provisional time scale ``alpha0 = ||H||_F / ||E||_F``: an entry is noise
    when it is below ``BALANCE_NEGLIGIBLE`` times both the largest entry of
    its row and of its column (over E and H together).
    """
    aE, aH = np.abs(E), np.abs(H)
    ne, nh = np.linalg.norm(aE), np.linalg.norm(aH)
    alpha0 = nh / ne if ne > 0 and nh > 0 else 1.0
    rmax = np.maximum(alpha0 * aE.max(axis=1, initial=0.0), aH.max(axis=1, initial=0.0))
    cmax = np.maximum(alpha0 * aE.max(axis=0, initial=0.0), aH.max(axis=0, initial=0.0))
    floor = BALANCE_NEGLIGIBLE * np.minimum(rmax[:, None], cmax[None, :])
    return (aE > 0) & (alpha0 * aE >= floor), (aH > 0) & (aH >= floor)


def _masked_log2(M: np.ndarray, mask: np.ndarray) -> np.ndarray:
    out = np.zeros(M.shape)
    np.log2(np.abs(M), out=out, where=mask)
    return out


def _spread(logs: np.ndarray, mask: np.ndarray) -> float:
    """Decades between the largest and smallest masked entry, from their log2."""
    if not mask.any():
        return 0.0
    v = logs[mask]
    return float((v.max() - v.min()) * np.log10(2.0))


def _ward_exponents(ME: np.ndarray, MH: np.ndarray, LE: np.ndarray, LH: np.ndarray) -> np.ndarray:
    """Integer exponents ``(r, c, a)`` of the least-squares balancing.

    Solves the normal equations of the fit by conjugate gradients; the
    operator is applied with the dense 0/1 masks (O(n^2) per iteration).
    The system is singular (``r + t, c - t`` fit equally well) but consistent,
    and CG from zero returns the minimum-norm solution.
    """
    n_r, n_c = ME.shape
    me, mh = ME.astype(float), MH.astype(float)
    M = me + mh
    ne_r, ne_c = me.sum(axis=1), me.sum(axis=0)
    d_r, d_c = M.sum(axis=1), M.sum(axis=0)
    n_e = me.sum()

    def normal(w):
        r, c, a = w[:n_r], w[n_r : n_r + n_c], w[-1]
        return np.concatenate(
            [d_r * r + M @ c + ne_r * a, M.T @ r + d_c * c + ne_c * a, [ne_r @ r + ne_c @ c + n_e * a]]
        )

    rhs = -np.concatenate([LE.sum(axis=1) + LH.sum(axis=1), LE.sum(axis=0) + LH.sum(axis=0), [LE.sum()]])
    op = LinearOperator((n_r + n_c + 1,) * 2, matvec=normal, dtype=float)
    sol = cg(op, rhs, rtol=BALANCE_LSQ_TOL, maxiter=BALANCE_MAXITER)[0]
    return np.rint(sol).astype(int)


def balance_pencil(E: np.ndarray, H: np.ndarray, *, enabled: bool = True) -> Balancing:
    """Equilibrate the pencil ``lambda E - H`` by diagonal scaling (Ward's method).

    Finds integer exponents ``r`` (rows), ``c`` (columns) and ``a`` (time)
    that minimise, over the significant non-zero entries,

    .. math:: \\sum_E (\\log_2|e_{ij}| + r_i + c_j + a)^2
              + \\sum_H (\\log_2|h_{ij}| + r_i + c_j)^2,

    i.e. bring every entry of ``2^a Dl E Dr`` and ``Dl H Dr`` as close to one
    as diagonal scaling allows [3]_. The extra time exponent ``a`` balances E
    against H (capacitances of picofarads against conductances of
    millisiemens), which LAPACK's ``ggbal`` does not do. Entries below
    ``BALANCE_NEGLIGIBLE`` times both the largest entry of their row and of
    their column (of ``[alpha0 E, H]``, ``alpha0 = ||H|| / ||E||``) are
    rounding noise and do not steer the fit.

    Parameters
    ----------
    E, H : ndarray, shape (n, n)
    enabled : bool
        False returns the identity scaling (``applied=False``).

    Returns
    -------
    Balancing

    Notes
    -----
    Conjugate gradients on the normal equations (``2n + 1`` unknowns), each
    iteration O(n^2) with dense masks, at most ``BALANCE_MAXITER`` iterations.
    """
    n_r, n_c = E.shape
    ME, MH = _significant(E, H)
    LE, LH = _masked_log2(E, ME), _masked_log2(H, MH)
    mask = np.concatenate([ME, MH], axis=1)
    before = _spread(np.concatenate([LE, LH], axis=1), mask)
    if not enabled or not mask.any():
        return Balancing(False, np.ones(n_r), np.ones(n_c), 1.0, before, before)
    expo = _ward_exponents(ME, MH, LE, LH)
    r, c, a = expo[:n_r], expo[n_r : n_r + n_c], expo[-1]
    shift = r[:, None] + c[None, :]
    after = _spread(np.concatenate([LE + shift + a, LH + shift], axis=1), mask)
    return Balancing(True, np.ldexp(1.0, r), np.ldexp(1.0, c), float(np.ldexp(1.0, a)), before, after)


# ---------------------------------------------------------------------------
# the rank of one square matrix (the DC matrix of a circuit)
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class MatrixRank:
    """Numerical rank of a matrix, with its null spaces.

    Attributes
    ----------
    decision : RankDecision
        On the balanced matrix ``Dl M Dr`` (exact powers of two).
    right : ndarray, shape (k, k - rank)
        Orthonormal-before-scaling basis of the right null space of the ``m x k`` matrix ``M``
        (columns, in the original unknowns: ``M @ right ~ 0``).
    left : ndarray, shape (m, m - rank)
        Basis of the left null space (``left.T @ M ~ 0``): which equations
        depend on each other.
    """

    decision: RankDecision
    right: np.ndarray
    left: np.ndarray

    @property
    def rank(self) -> int:
        return self.decision.rank

    @property
    def deficient(self) -> bool:
        """Rank below the smaller dimension."""
        return self.decision.rank < min(self.decision.shape)


def matrix_rank(M, rtol: float | None = None, what: str = "rank of the matrix", *, vectors: bool = True) -> MatrixRank:
    """Numerical rank of a matrix, decided as the pencil analysis decides ranks.

    The matrix is balanced by :func:`balance_pencil` (rows and columns by
    powers of two, as the pencil ``(0, M)``), and a singular value of the
    balanced matrix ``Mb`` counts as zero when it is at most
    ``rtol * ||Mb||_F`` (``rtol`` defaults to :func:`default_rtol`), so that a
    DC matrix judged singular here is judged singular by the index analysis.

    Parameters
    ----------
    M : ndarray or sparse matrix, shape (m, k)
    rtol : float, optional
        Default ``default_rtol(max(m, k))``.
    what : str
        Description kept in the decision.
    vectors : bool
        Compute the null spaces (default); without them (the verdict only) the SVD
        costs about a third, and ``right`` and ``left`` are empty.

    Returns
    -------
    MatrixRank

    Notes
    -----
    One dense SVD, O(n^3), after an O(n^2) balancing.

    Examples
    --------
    >>> r = matrix_rank(np.array([[1e-3, -2e-3], [1.0, -2.0]]))
    >>> r.rank, r.decision.tol > 0, bool(np.allclose(r.right[:, 0] / r.right[0, 0], [1.0, 0.5]))
    (1, True, True)
    """
    A = M.toarray() if hasattr(M, "toarray") else np.array(M, dtype=float)
    rt = default_rtol(max(A.shape)) if rtol is None else float(rtol)
    bal = balance_pencil(np.zeros_like(A), A)
    dl, dr = bal.row_scale, bal.col_scale
    Ab = dl[:, None] * A * dr[None, :]
    if not vectors:
        dec = rank_decision(_svdvals(Ab), rt * np.linalg.norm(Ab), what, A.shape)
        return MatrixRank(dec, np.zeros((A.shape[1], 0)), np.zeros((A.shape[0], 0)))
    P, s, WT = _svd(Ab)
    dec = rank_decision(s, rt * np.linalg.norm(Ab), what, A.shape)
    right = dr[:, None] * WT[dec.rank:].T
    left = dl[:, None] * P[:, dec.rank:]
    return MatrixRank(dec, right, left)


# ---------------------------------------------------------------------------
# staircase
# ---------------------------------------------------------------------------
@dataclass
class Staircase:
    """Result of :func:`staircase` on an ``m x k`` pencil ``(E, H)``.

    ``QT @ E @ Z == A`` and ``QT @ H @ Z == B`` up to the neglected parts.

    Attributes
    ----------
    A, B : ndarray, shape (m, k)
        The reduced pencil: columns ``:c0`` and rows ``:r0`` form the deflated
        staircase; ``A[r0:, c0:]`` has full column rank.
    QT : ndarray, shape (m, m)
        Orthogonal left transformation (already transposed).
    Z : ndarray, shape (k, k)
        Orthogonal right transformation.
    cols : list of int
        ``s_i``: null-space dimension of the active E block at step i.
    rows : list of int
        ``rho_i``: rank of H on that null space.
    r0, c0 : int
        Start of the remainder.
    decisions : list of RankDecision
    neglected : float
        Frobenius norm of everything set to zero (the backward error of the
        structure, apart from rounding).
    first_svd : tuple
        ``(P, s, WT)``, the SVD of the whole E at step 1 (reused for the SVD
        form (2.3)).
    leaks : tuple of float
        Per decision (in the order of ``decisions``), how large a singular value
        of that block rounding in H alone can make: 0 at step 1; at step
        ``i > 1`` the rows of E (for an E block) or of H's remaining columns
        (for an H block) that the compression of H at step ``i - 1`` mixes in
        when a perturbation of H of its rounding (``tol_h``) turns that
        compression's null space (Wedin: towards the j-th kept left singular
        vector by up to ``tol_h / s_j``). A kept singular value below its leak
        may be rounding that the tolerances alone do not see
        (:attr:`KroneckerStructure.robust_margin`).
    """

    A: np.ndarray
    B: np.ndarray
    QT: np.ndarray
    Z: np.ndarray
    cols: list
    rows: list
    r0: int
    c0: int
    decisions: list
    neglected: float
    first_svd: tuple = field(repr=False, default=None)
    leaks: tuple = ()

    @property
    def right_indices(self) -> list[int]:
        """Right minimal (column) indices: ``s_i - rho_i`` blocks ``L_{i-1}``."""
        out: list[int] = []
        for i, (s, r) in enumerate(zip(self.cols, self.rows)):
            out += [i] * (s - r)
        return out

    @property
    def infinite_blocks(self) -> list[int]:
        """Sizes of the infinite Jordan blocks: ``rho_i - s_{i+1}`` blocks of size ``i``."""
        out: list[int] = []
        nxt = self.cols[1:] + [0]
        for i, (r, s_next) in enumerate(zip(self.rows, nxt)):
            out += [i + 1] * (r - s_next)
        return sorted(out, reverse=True)


def staircase(
    E: np.ndarray, H: np.ndarray, tol_e: float, tol_h: float, *, label: str = "", null_dims=None
) -> Staircase:
    """Staircase reduction of ``lambda E - H`` deflating the null space of E.

    Parameters
    ----------
    E, H : ndarray, shape (m, k)
        Dense matrices (not modified).
    tol_e, tol_h : float
        Absolute tolerances of the rank decisions on E blocks and H blocks.
    label : str
        Prefix of the evidence strings (e.g. ``"transposed remainder: "``).
    null_dims : sequence of int, optional
        For a pencil known to be regular: the null-space dimension of the active E block at every
        step (``s_i``, the number of infinite Jordan blocks of size at least ``i``; from
        :func:`netdae.dae.exact.exact_structure`). The rank decisions then take these ranks instead
        of comparing with the tolerances, which only measure them.

    Returns
    -------
    Staircase

    Notes
    -----
    Step i costs one SVD of the active E block and one of the H columns on
    its null space, plus O(n^2 (s_i + rho_i) + n k_i^2) for applying the
    transformations; for a pencil of index k the total is O((k+1) n^3). The
    last step, which only confirms full column rank, computes singular values
    without vectors.
    """
    A = np.array(E, dtype=float, copy=True)
    B = np.array(H, dtype=float, copy=True)
    m, k = A.shape
    QT = np.eye(m)
    Z = np.eye(k)
    r0 = c0 = 0
    cols: list[int] = []
    rows: list[int] = []
    decisions: list[RankDecision] = []
    neglected_sq = 0.0
    first_svd = None
    step = 0
    leaks: list[float] = []
    leak_e = leak_h = 0.0  # what rounding in H can leak into the next E block and H block
    while c0 < k:
        step += 1
        mi, ki = m - r0, k - c0
        if first_svd is None:
            P, s, WT = first_svd = _svd(A[r0:, c0:])
        else:  # singular values first: the last step (full column rank) needs no vectors
            s = _svdvals(A[r0:, c0:])
        forced = None
        if null_dims is not None:
            forced = ki - (int(null_dims[step - 1]) if step <= len(null_dims) else 0)
        dec = rank_decision(s, tol_e, f"{label}rank of E block (staircase step {step})", (mi, ki), forced)
        decisions.append(dec)
        leaks.append(leak_e)
        ns = ki - dec.rank
        if ns == 0:
            break
        if step > 1:
            P, s, WT = _svd(A[r0:, c0:])
        neglected_sq += float(np.sum(s[dec.rank :] ** 2))
        W = np.concatenate([WT[dec.rank :], WT[: dec.rank]]).T  # null space first
        A[:, c0:] = A[:, c0:] @ W
        B[:, c0:] = B[:, c0:] @ W
        Z[:, c0:] = Z[:, c0:] @ W
        A[r0:, c0 : c0 + ns] = 0.0
        P2, s2, W2T = _svd(B[r0:, c0 : c0 + ns])
        dec2 = rank_decision(s2, tol_h, f"{label}rank of H on null space of E (staircase step {step})", (mi, ns),
                             None if null_dims is None else ns)
        decisions.append(dec2)
        leaks.append(leak_h)
        rho = dec2.rank
        neglected_sq += float(np.sum(s2[rho:] ** 2))
        if rho:  # the rows paired with H's kept singular values, weighted by how far rounding turns them
            kept = P2[:, :rho].T
            leak_e = float(tol_h * np.linalg.norm(np.linalg.norm(kept @ A[r0:, c0:], axis=1) / s2[:rho]))
            leak_h = float(tol_h * np.linalg.norm(np.linalg.norm(kept @ B[r0:, c0 + ns:], axis=1) / s2[:rho]))
        # rows r0: are zero in columns :c0, so only the active columns change
        A[r0:, c0:] = P2.T @ A[r0:, c0:]
        B[r0:, c0:] = P2.T @ B[r0:, c0:]
        QT[r0:, :] = P2.T @ QT[r0:, :]
        V2 = W2T.T
        A[:r0, c0 : c0 + ns] = A[:r0, c0 : c0 + ns] @ V2
        B[:r0, c0 : c0 + ns] = B[:r0, c0 : c0 + ns] @ V2
        Z[:, c0 : c0 + ns] = Z[:, c0 : c0 + ns] @ V2
        block = np.zeros((mi, ns))
        block[np.arange(rho), np.arange(rho)] = s2[:rho]
        B[r0:, c0 : c0 + ns] = block
        cols.append(ns)
        rows.append(rho)
        r0 += rho
        c0 += ns
    return Staircase(A, B, QT, Z, cols, rows, r0, c0, decisions, float(np.sqrt(neglected_sq)), first_svd,
                     tuple(leaks))


# ---------------------------------------------------------------------------
# eigenvalues of a (quasi-)triangular pair
# ---------------------------------------------------------------------------
def quasi_triangular_eigvals(T: np.ndarray, S: np.ndarray | None = None) -> np.ndarray:
    """Eigenvalues of ``T - lambda S`` with T real quasi-upper-triangular, S upper triangular.

    Parameters
    ----------
    T : ndarray, shape (n, n)
        Real Schur form (1x1 and 2x2 diagonal blocks).
    S : ndarray, shape (n, n), optional
        Upper triangular with non-zero diagonal; the identity when omitted.

    Returns
    -------
    ndarray of complex, shape (n,)
        In diagonal order (conjugate pairs adjacent, positive imaginary part first).

    Notes
    -----
    Vectorised over the diagonal blocks, O(n).
    """
    n = T.shape[0]
    if n == 0:
        return np.zeros(0, dtype=complex)
    S = np.eye(n) if S is None else S
    sub = np.zeros(n, dtype=bool)
    sub[:-1] = np.diag(T, -1) != 0
    start = np.flatnonzero(sub)  # first index of each 2x2 block
    lam = (np.diag(T) / np.diag(S)).astype(complex)
    if start.size:
        i, j = start, start + 1
        a11, a12, a21, a22 = T[i, i], T[i, j], T[j, i], T[j, j]
        b11, b12, b22 = S[i, i], S[i, j], S[j, j]
        # det(A - lam B) = qa lam^2 - qb lam + qc
        qa = b11 * b22
        qb = a11 * b22 + a22 * b11 - a21 * b12
        qc = a11 * a22 - a12 * a21
        root = np.sqrt((qb * qb - 4.0 * qa * qc).astype(complex))
        l1 = (qb + root) / (2.0 * qa)
        l2 = (qb - root) / (2.0 * qa)
        first = np.where(l1.imag >= 0, l1, l2)
        lam[i] = first
        lam[j] = np.conj(first)
    return lam


# ---------------------------------------------------------------------------
# the whole Kronecker structure
# ---------------------------------------------------------------------------
@dataclass
class KroneckerStructure:
    """Kronecker structure of a square pencil, from orthogonal reductions.

    Attributes
    ----------
    regular : bool
    infinite_blocks : list of int
        Sizes of the infinite Jordan blocks (descending); their maximum is the
        nilpotency index of a regular pencil.
    right_indices, left_indices : list of int
        Minimal indices ``epsilon`` of the blocks ``L_epsilon`` and ``eta`` of
        ``L_eta^T`` (empty for a regular pencil).
    normal_rank : int
    n_finite : int
        Number of finite eigenvalues (``deg det(lambda E - H)`` when regular).
    first : Staircase
        Staircase of ``(Eb, Hb)``.
    second : Staircase or None
        Staircase of the transposed remainder (singular pencils only).
    finite_pencil : tuple of ndarray
        ``(E_f, H_f)``: square part carrying the finite eigenvalues, E_f invertible.
    decisions : list of RankDecision
    warnings : list of str
    """

    regular: bool
    infinite_blocks: list
    right_indices: list
    left_indices: list
    normal_rank: int
    n_finite: int
    first: Staircase
    second: Staircase | None
    finite_pencil: tuple
    decisions: list
    warnings: list

    @property
    def margin(self) -> float:
        """Worst :attr:`RankDecision.margin` of the structure's decisions."""
        return min((d.margin for d in self.decisions), default=float("inf"))

    @property
    def robust_margin(self) -> float:
        """:attr:`margin` with each kept singular value measured against its leak too.

        A kept singular value of a block of staircase step ``i > 1`` counts only by how far it
        exceeds both its tolerance and what rounding in H can put there (:attr:`Staircase.leaks`):
        the worst-case distance from a structure of rounding, for choosing between two scalings of
        one pencil that disagree.
        """
        worst = self.margin
        for st in (self.first, self.second):
            if st is None:
                continue
            for d, leak in zip(st.decisions, st.leaks):
                if d.kept and leak > d.tol:
                    worst = min(worst, d.kept[-1] / leak)
        return float(worst)

    def summary(self) -> tuple:
        """The structure as comparable data."""
        return (self.regular, tuple(self.infinite_blocks), tuple(self.right_indices), tuple(self.left_indices))

    def describe(self) -> str:
        """The structure in words, lists of sizes compressed (:func:`format_sizes`)."""
        if self.regular:
            return f"regular, infinite blocks {format_sizes(self.infinite_blocks)}"
        return (f"singular, infinite blocks {format_sizes(self.infinite_blocks)}, right minimal indices "
                f"{format_sizes(self.right_indices)}, left {format_sizes(self.left_indices)}")


def blocks_from_counts(at_least) -> tuple[int, ...]:
    """Jordan block sizes (descending) from ``at_least[i - 1]``, the number of blocks of size at least ``i``
    (non-increasing): ``at_least[i - 1] - at_least[i]`` blocks of size exactly ``i``.

    Examples
    --------
    >>> blocks_from_counts([3, 1, 1])
    (3, 1, 1)
    """
    counts = [int(c) for c in at_least] + [0]
    out: list[int] = []
    for i in range(1, len(counts)):
        out += [i] * (counts[i - 1] - counts[i])
    return tuple(sorted(out, reverse=True))


def format_sizes(sizes) -> str:
    """A list of block sizes or minimal indices for people: short lists as they are, long ones with repeats
    counted (``[3, 2 x4, 1 x722]``, in the given order); ``none`` when empty."""
    sizes = [int(v) for v in sizes]
    if not sizes:
        return "none"
    if len(sizes) <= 8:
        return str(sizes)
    runs: list[list[int]] = []
    for v in sizes:
        if runs and runs[-1][0] == v:
            runs[-1][1] += 1
        else:
            runs.append([v, 1])
    return "[" + ", ".join(str(v) if c == 1 else f"{v} x{c}" for v, c in runs) + "]"


def kronecker_structure(
    Eb: np.ndarray, Hb: np.ndarray, tol_e: float, tol_h: float, *, null_dims=None
) -> KroneckerStructure:
    """Regularity and Kronecker structure of the square pencil ``lambda Eb - Hb``.

    Parameters
    ----------
    Eb, Hb : ndarray, shape (n, n)
        The (balanced) pencil.
    tol_e, tol_h : float
        Absolute tolerances of the rank decisions on E and on H.
    null_dims : sequence of int, optional
        The staircase's null-space dimensions of a pencil known to be regular (see
        :func:`staircase`).

    Returns
    -------
    KroneckerStructure

    Notes
    -----
    One staircase of ``(Eb, Hb)`` extracts the right singular blocks and the
    infinite Jordan blocks; the pencil is regular iff there are no right
    singular blocks (for square pencils their number equals that of the left
    ones, ``n - normal_rank``). For a singular pencil a second staircase on the
    transposed remainder extracts the left minimal indices and leaves the
    square regular part with the finite eigenvalues.
    """
    n = Eb.shape[0]
    first = staircase(Eb, Hb, tol_e, tol_h, null_dims=null_dims)
    right = first.right_indices
    decisions = list(first.decisions)
    warnings: list[str] = []
    infinite = first.infinite_blocks
    second = None
    rem_e = first.A[first.r0 :, first.c0 :]
    rem_h = first.B[first.r0 :, first.c0 :]
    left: list[int] = []
    if right or rem_e.shape[0] != rem_e.shape[1]:
        second = staircase(rem_e.T, rem_h.T, tol_e, tol_h, label="transposed remainder: ")
        decisions += second.decisions
        left = second.right_indices
        extra = second.infinite_blocks
        if extra:
            warnings.append(
                f"the transposed remainder showed infinite blocks {extra} after the first "
                "staircase: inconsistent rank decisions near the tolerance; counted as infinite blocks"
            )
            infinite = sorted(infinite + extra, reverse=True)
        fe = second.A[second.r0 :, second.c0 :].T
        fh = second.B[second.r0 :, second.c0 :].T
    else:
        fe, fh = rem_e, rem_h
    if len(left) != len(right):
        warnings.append(
            f"{len(right)} right but {len(left)} left singular blocks in a square pencil: "
            "rank decisions near the tolerance; inspect the evidence"
        )
    regular = not right and not left
    normal_rank = n - len(right)
    return KroneckerStructure(
        regular=regular,
        infinite_blocks=infinite,
        right_indices=right,
        left_indices=left,
        normal_rank=normal_rank,
        n_finite=int(fe.shape[0]),
        first=first,
        second=second,
        finite_pencil=(fe, fh),
        decisions=decisions,
        warnings=warnings,
    )
