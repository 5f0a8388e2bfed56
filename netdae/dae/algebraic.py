"""Which unknowns of a large sparse DAE depend on the inputs' derivatives: the index-2 directions without a dense pencil.

For ``E x' = H x + c`` the dense analysis (:mod:`netdae.dae.pencil`) reduces the whole pencil; its cost
grows as ``n^3``. The unknowns a transient must keep out of its error test, those that carry the
derivatives of the inputs (index 2), are found more cheaply from the algebraic part alone. With
``K0`` a basis of ``ker E`` and ``L0`` one of ``ker E^T``,

    W = ker E  ∩  {w : H w ∈ im E}  =  K0 ker(L0^T H K0),

and

- ``W = {0}`` exactly when the pencil has index <= 1 (``L0^T H K0`` is the Jacobian of the algebraic
  equations with respect to the algebraic unknowns; in MNA, the rows and columns where ``E`` is zero),
- otherwise ``W`` is the span of the impulsive directions: a step of the inputs puts a Dirac impulse into
  ``x`` only along ``W``, and the unknowns on ``W``'s support are those that depend on the inputs' first
  derivatives (the currents of voltage sources in loops with capacitors, the voltages of nodes cut from
  ground by inductors and current sources, and what controlled sources copy of them).

Both kernels are taken block by block: ``E``'s rows and columns fall into independent groups (the
connected components of its sparsity graph; in a circuit, the capacitively coupled node groups and the
coupled inductors), and so do those of ``L0^T H K0``; each group's kernel is one dense SVD of the
group, balanced and decided as the dense pencil analysis decides ranks. A circuit's groups are small,
so the cost is about linear in ``n``.

Notes
-----
Without the input matrix the support is all of ``W``'s, also directions no input excites (the dense
analysis's classification leaves those out). An index of 3 or more is told from 2, not counted.

References
----------
.. [1] R. März, "Numerical methods for differential algebraic equations", Acta Numerica 1 (1992)
   141-198 (the subspaces ``N0 ∩ S0`` of the tractability index).
.. [2] D. Estévez Schwarz, C. Tischendorf, "Structural analysis of electric circuits and consequences
   for MNA", Int. J. Circ. Theor. Appl. 28 (2000) 131-162.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from .kronecker import RankDecision, matrix_rank
from .sparse import bipartite_components

__all__ = ["AlgebraicPart", "algebraic_part", "GROUP_LIMIT"]

#: Largest group (rows or columns) whose kernel is taken by a dense SVD; a larger one leaves the answer
#: undetermined (``AlgebraicPart.determined`` False). 1,500 columns cost about 1 s.
GROUP_LIMIT = 1500
#: Entries of a kernel vector below this fraction of its largest (equilibrated) entry are rounding.
SUPPORT_FRACTION = 1e-10


@dataclass(frozen=True)
class AlgebraicPart:
    """The algebraic part of ``E x' = H x + c`` and its impulsive directions.

    Attributes
    ----------
    determined : bool
        False when a group exceeded :data:`GROUP_LIMIT` (then the other fields are empty).
    n : int
        Number of unknowns.
    kernel_dim : int
        ``dim ker E`` (the algebraic unknowns' count).
    impulsive_dim : int
        ``dim W``: 0 means index <= 1 (0 when ``kernel_dim`` is 0 too).
    index2 : bool
        ``W`` is not trivial and the index is exactly 2 (the matrix ``S`` of :func:`algebraic_part` is
        nonsingular).
    support : ndarray of int
        Unknowns on ``W``'s support (depend on the inputs' derivatives), ascending.
    decisions : tuple of RankDecision
        The rank decisions of the groups whose rank was not full, for evidence.
    largest_group : int
        The size of the largest group decided densely.
    """

    determined: bool
    n: int
    kernel_dim: int = 0
    impulsive_dim: int = 0
    index2: bool = False
    support: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    decisions: tuple = ()
    largest_group: int = 0

    @property
    def index(self) -> int | None:
        """0 (no algebraic unknown), 1 (``W = {0}``), 2, or None (undetermined, 3 or more, or singular)."""
        if not self.determined:
            return None
        if self.kernel_dim == 0:
            return 0
        if self.impulsive_dim == 0:
            return 1
        return 2 if self.index2 else None


class _Blocks:
    """A sparse matrix taken apart into its independent groups of rows and columns.

    Parameters
    ----------
    a : sparse matrix, shape (m, k)
    what : str
        Its name in the rank decisions.

    Attributes
    ----------
    determined : bool
        False when a group has more than :data:`GROUP_LIMIT` rows or columns (nothing else is computed).
    right, left : csr_matrix, shapes (k, dim) and (m, dim')
        Bases of ``ker a`` and ``ker a^T``, block by block: an empty column or row is a unit vector; a
        group's rank is decided as the pencil analysis decides ranks
        (:func:`netdae.dae.kronecker.matrix_rank`: balanced by powers of two, singular values below
        ``max(p, q) eps`` of the Frobenius norm count as zero).
    decisions : list of RankDecision
        Those of the rank-deficient groups.
    largest : int
        The largest group decided by an SVD.
    """

    def __init__(self, a: sp.spmatrix, what: str):
        a = sp.csr_matrix(a)
        m, k = a.shape
        coo = a.tocoo()
        count, rlab, clab = bipartite_components(coo.row, coo.col, m, k)
        self._coo = coo
        self._csr = a
        self._rlab, self._clab = rlab, clab
        rows_of = np.argsort(rlab, kind="stable")
        cols_of = np.argsort(clab, kind="stable")
        rstart = np.searchsorted(rlab[rows_of], np.arange(count + 1))
        cstart = np.searchsorted(clab[cols_of], np.arange(count + 1))
        self._groups: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (rows, cols, block) of the larger groups
        right: list[tuple[np.ndarray, np.ndarray]] = []  # (indices, values) of each kernel vector
        left: list[tuple[np.ndarray, np.ndarray]] = []
        self.decisions: list[RankDecision] = []
        self.largest = 0
        self.determined = True
        for g in range(count):
            rows = rows_of[rstart[g]:rstart[g + 1]]
            cols = cols_of[cstart[g]:cstart[g + 1]]
            p, q = rows.size, cols.size
            if p == 0 or q == 0:  # an empty column (row): a unit vector of the kernel (left kernel)
                right += [(np.array([j]), np.ones(1)) for j in cols]
                left += [(np.array([i]), np.ones(1)) for i in rows]
                continue
            if p == 1 and q == 1:  # a single nonzero entry
                continue
            if max(p, q) > GROUP_LIMIT:
                self.determined = False
                return
            self.largest = max(self.largest, p, q)
            block = a[rows][:, cols].toarray()
            self._groups.append((rows, cols, block))
            rank = matrix_rank(block, what=f"rank of {what} on a group of {p} x {q}")
            if rank.deficient:
                self.decisions.append(rank.decision)
            right += [(cols, v) for v in rank.right.T]
            left += [(rows, v) for v in rank.left.T]
        self.right = _columns(right, k)
        self.left = _columns(left, m)

    def independent_beside(self, z: np.ndarray, what: str):
        """Whether the columns of ``z`` are independent modulo the range of ``a``: ``rank [a | z] = rank a +
        z.shape[1]``, decided as every other rank here on the groups ``z``'s rows reach (their rows and
        columns; no other group shares a row with ``z``), or None when those groups together exceed
        :data:`GROUP_LIMIT`.

        ``Y^T z`` with ``Y`` a basis of ``ker a^T`` is nonsingular exactly then; deciding that small product's
        rank against its own norm cannot tell a zero left by rounding from a value (a 1 x 1 product is
        always 'full rank'), while ``[a | z]`` keeps the scale of the entries rounding acts on.

        Parameters
        ----------
        z : ndarray, shape (m, d)
        what : str
            The decision's name in the evidence.

        Returns
        -------
        tuple (bool or None, RankDecision or None)
        """
        d = z.shape[1]
        mag = np.abs(z).max(axis=1) if d else np.zeros(z.shape[0])
        top = mag.max() if mag.size else 0.0
        if not top > 0.0:
            return d == 0, None
        # entries below SUPPORT_FRACTION of their column's largest are rounding (as in the kernel vectors); kept,
        # balancing scales their column up against the rows they sit in and can hide a rank
        colmax = np.abs(z).max(axis=0)
        z = np.where(np.abs(z) > SUPPORT_FRACTION * colmax[None, :], z, 0.0)
        mag = np.abs(z).max(axis=1)
        reached = np.unique(self._rlab[mag > 0.0])
        rows = np.flatnonzero(np.isin(self._rlab, reached))
        cols = np.flatnonzero(np.isin(self._clab, reached))
        if max(rows.size, cols.size + d) > GROUP_LIMIT:
            return None, None
        block = self._csr[rows][:, cols].toarray()
        base = matrix_rank(block, vectors=False).rank if block.size else 0
        aug = matrix_rank(np.hstack([block, z[rows]]), what=what, vectors=False)
        return aug.rank - base == d, aug.decision

    def solve(self, z: np.ndarray) -> np.ndarray:
        """A solution ``y`` of ``a y = z`` for ``z`` in the range of ``a`` (least squares group by group).

        Parameters
        ----------
        z : ndarray, shape (m, d)

        Returns
        -------
        ndarray, shape (k, d)
        """
        coo = self._coo
        y = np.zeros((coo.shape[1], z.shape[1]))
        single = np.ones(coo.shape[0], dtype=bool)
        for rows, _, _ in self._groups:
            single[rows] = False
        one = single[coo.row]
        y[coo.col[one]] = z[coo.row[one]] / coo.data[one][:, None]
        for rows, cols, block in self._groups:
            y[cols] = np.linalg.lstsq(block, z[rows], rcond=None)[0]
        return y


def _columns(vectors: list[tuple[np.ndarray, np.ndarray]], n: int) -> sp.csr_matrix:
    """The sparse ``n x len(vectors)`` matrix of the given ``(indices, values)`` columns, each scaled to a
    largest entry of 1 (a balanced group's kernel vector mapped back can be of any size: a common mode of
    millions, which would leave the next matrix built on it to balance what this scaling removes)."""
    if not vectors:
        return sp.csr_matrix((n, 0))
    rows = np.concatenate([ix for ix, _ in vectors])
    vals = np.concatenate([v / np.abs(v).max() for _, v in vectors])
    cols = np.concatenate([np.full(ix.size, j) for j, (ix, _) in enumerate(vectors)])
    keep = vals != 0.0
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, len(vectors)))


def _support(w: np.ndarray) -> np.ndarray:
    """Rows where some column of ``w`` has an entry above :data:`SUPPORT_FRACTION` of the column's largest."""
    big = np.abs(w).max(axis=0, initial=0.0)
    return np.flatnonzero((np.abs(w) > SUPPORT_FRACTION * big[None, :]).any(axis=1))


def algebraic_part(E, H, B=None) -> AlgebraicPart:
    """The algebraic part of ``E x' = H x + c`` and the unknowns its impulsive directions ``W`` reach.

    Parameters
    ----------
    E, H : sparse matrix or ndarray, shape (n, n)
        The pencil (in a circuit: ``dq/dx`` and ``dphi/dx`` at the linearisation point).
    B : sparse matrix or ndarray, shape (n, p), optional
        Input matrix (``c = B u``): the support is then that of the impulses the inputs' steps excite,
        not of all of ``W``.

    Returns
    -------
    AlgebraicPart
        ``support`` names the unknowns depending on the inputs' derivatives; ``index`` is 0, 1 or 2, or
        None (3 or more, or a singular pencil).

    Raises
    ------
    ValueError
        For matrices of different or non-square shapes, or with non-finite entries.

    Notes
    -----
    With ``M = L0^T H K0`` and ``Y`` a basis of ``ker M^T``, the index is 2 exactly when
    ``S = Y^T L0^T H E^+ H K0 N`` (``N`` a basis of ``ker M``) is nonsingular (decided as
    ``rank [M | L0^T H E^+ H K0 N] = rank M + dim N`` on the groups it reaches, which keeps the scale
    that a rank of the small ``S`` against its own norm loses), and a step ``b`` of the
    inputs then puts the impulse ``-K0 N S^-1 Y^T L0^T b`` into ``x``: its coefficient in ``E x'`` must
    vanish (``m`` in ``ker E``), its coefficient in ``x`` must be a jump of the charges (``H m`` in
    ``im E``), and the jump must carry the algebraic equations to their new right-hand side.

    Cost: two passes of connected components over the sparsity graphs and one dense SVD per group
    (``O(p q min(p, q))`` for a group of ``p x q``), so about linear in ``n`` for a circuit's small
    groups; a group beyond :data:`GROUP_LIMIT` returns an undetermined result rather than an ``n^3`` one.
    Exact zeros of ``E`` are structure; an entry that is not exactly zero counts as a charge however
    small, unless its group's SVD decides otherwise.
    """
    E = sp.csr_matrix(E, dtype=float)
    H = sp.csr_matrix(H, dtype=float)
    n = E.shape[0]
    if E.shape != (n, n) or H.shape != (n, n):
        raise ValueError(f"E and H must be square and of one shape, not {E.shape} and {H.shape}")
    if not (np.all(np.isfinite(E.data)) and np.all(np.isfinite(H.data))):
        raise ValueError("E and H must be finite")
    E.eliminate_zeros()
    eb = _Blocks(E, "E")
    if not eb.determined:
        return AlgebraicPart(determined=False, n=n)
    k0, l0 = eb.right, eb.left
    if k0.shape[1] == 0:
        return AlgebraicPart(determined=True, n=n, decisions=tuple(eb.decisions), largest_group=eb.largest)
    lh = sp.csr_matrix(l0.T @ H)
    m = sp.csr_matrix(lh @ k0)
    m.eliminate_zeros()
    mb = _Blocks(m, "the algebraic Jacobian L0^T H K0")
    if not mb.determined:
        return AlgebraicPart(determined=False, n=n)
    decisions = tuple(eb.decisions + mb.decisions)
    largest = max(eb.largest, mb.largest)
    nm, y = mb.right, mb.left
    d = nm.shape[1]
    if d == 0:
        return AlgebraicPart(determined=True, n=n, kernel_dim=k0.shape[1], decisions=decisions,
                             largest_group=largest)
    # one step of refinement: remove from each kernel vector the part its group's rounding left in M's row space
    nm = np.asarray(nm.todense())
    nm = nm - mb.solve(np.asarray(m @ nm))
    w = np.asarray(k0 @ nm)
    hw = np.asarray(H @ w)
    z = np.asarray(lh @ eb.solve(hw))
    s_mat = np.asarray(y.T @ z)
    # S = Y^T z is nonsingular exactly when z's columns are independent modulo im M: decided on [M | z], whose
    # entries carry the scale rounding acts on (S alone is decided against its own norm: a rounding residue
    # of 1e-13 in a 1 x 1 S counted as full rank, and an index-3 circuit was reported as index 2)
    two, decision = mb.independent_beside(z, "rank of [L0^T H K0 | L0^T H E^+ H W] (index 2: full)")
    if two is None:  # the reached groups are too large to decide together: S's own rank
        two = s_mat.shape[0] == d and not matrix_rank(s_mat, what="rank of the index-2 matrix S").deficient
    elif not two and decision is not None:
        decisions = decisions + (decision,)
    if B is not None and two:
        b = np.asarray(B.todense() if sp.issparse(B) else B, dtype=float).reshape(n, -1)
        w = w @ np.linalg.solve(s_mat, np.asarray(y.T @ (l0.T @ b)))
    return AlgebraicPart(determined=True, n=n, kernel_dim=k0.shape[1], impulsive_dim=d, index2=two,
                         support=_support(w).astype(np.int64), decisions=decisions, largest_group=largest)
