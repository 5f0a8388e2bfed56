"""Structure of a linear(ized) DAE ``E x' = H x + c``: regularity, forms (2.3)/(2.9), index.

The public entry points take a pencil ``(E, H)`` (dense or sparse, ``n x n``)
or a :class:`~netdae.dae.system.DaeSystem` and a point ``(x, t)`` (the pencil
of the linearization, ``system.jacobians(x, t)``), and answer with evidence:

- :func:`analyze_pencil` / :func:`analyze_dae` -> :class:`PencilReport`:
  regular or singular (with the minimal indices), nilpotency index, sizes of
  the infinite Jordan blocks, number of dynamic states and the finite
  eigenvalues, the SVD form (2.3), the Weierstrass form (2.9), a
  classification of every unknown, every rank decision with its tolerance and
  singular values;
- :func:`svd_form` -- the semi-explicit split (2.3)-(2.5);
- :func:`weierstrass_form` -- the decoupling (2.9)/(2.11) for the integrator;
- :func:`drazin_index`, :func:`shift_rank_check`, :func:`nilpotent_rank_sequence`
  -- independent cross-checks.

How the decisions are made
--------------------------
1. *Balancing* (:func:`~netdae.dae.kronecker.balance_pencil`): rows, columns and
   the relative scale of E and H are equilibrated by powers of two (exact)
   before any rank decision, so that MNA rows of capacitances (1e-12),
   conductances (1e-3) and voltage-source incidences (1) become comparable.
2. *Rank decisions*: a singular value counts as zero when it is at most
   ``tol * ||M||_F`` of the balanced matrix M (E or H), with the relative
   ``tol`` defaulting to ``n * eps`` (:func:`~netdae.dae.kronecker.default_rtol`).
   Each decision records its tolerance and the two singular values on each
   side of the cut.
3. *Structure*: the orthogonal staircase reduction (Van Dooren) of the balanced
   pencil decides regularity and the infinite Jordan structure; the pencil is
   regular iff it has no right singular blocks. The index is the number of
   staircase steps. QZ/Schur of the deflated finite part gives the finite
   eigenvalues.

Cost
----
Dense O(n^3): for index k, k+1 SVDs of size up to n, one QZ (finite part up to
:data:`~netdae.dae.decoupled.QZ_LIMIT`) or Schur form, and O(n^3) products.
:data:`DENSE_LIMIT` is the largest n analysed in about 30 s on the reference
machine (2 cores); the circuit-level analysis switches to topological methods
above it.

References
----------
.. [1] B. Simeon, *Differential-Algebraic Equations*, lecture notes, TU
   Kaiserslautern 2012, Section 2.2.
.. [2] P. Van Dooren, "The computation of Kronecker's canonical form of a
   singular pencil", Linear Algebra Appl. 27 (1979) 103-140.
.. [3] S. L. Campbell, C. D. Meyer, N. J. Rose, "Applications of the Drazin
   inverse to linear systems of differential equations with singular constant
   coefficients", SIAM J. Appl. Math. 31 (1976) 411-425.

Examples
--------
The semi-explicit index-2 system ``y' = z + u1``, ``0 = y + u2``:

>>> import numpy as np
>>> rep = analyze_pencil([[1.0, 0.0], [0.0, 0.0]], [[0.0, 1.0], [1.0, 0.0]])
>>> rep.regular, rep.index, rep.n_dynamic, rep.infinite_blocks
(True, 2, 0, (2,))
>>> rep.labels
('algebraic', 'index2')
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import SingularPencilError
from .decoupled import Classification, WeierstrassForm, weierstrass_from_staircase
from .exact import EXACT_LIMIT, ExactStructure, exact_structure
from .kronecker import (
    Balancing,
    KroneckerStructure,
    RankDecision,
    balance_pencil,
    blocks_from_counts,
    default_rtol,
    kronecker_structure,
    rank_decision,
)

__all__ = [
    "DENSE_LIMIT",
    "SHIFT_CHECK_LIMIT",
    "PencilReport",
    "SvdForm",
    "ShiftCheck",
    "DrazinResult",
    "analyze_pencil",
    "analyze_dae",
    "finite_eigenvalues",
    "svd_form",
    "weierstrass_form",
    "shift_rank_check",
    "drazin_index",
    "nilpotent_rank_sequence",
    "blocks_from_ranks",
]

#: Largest n for which the dense analysis is used by default. Measured on the
#: 2-core reference machine under load, one BLAS thread, index-2 dense test
#: pencils: 0.5 s at n=500, 2-4 s at 1000, 15 s at 2000 (with two OpenBLAS
#: threads on the oversubscribed machine 6 s, 27 s, 230 s; see
#: docs/index-theory.md for the command).
DENSE_LIMIT = 2000

#: :func:`analyze_pencil` cross-checks the normal rank by random shifts
#: (one complex SVD per shift) up to this size by default.
SHIFT_CHECK_LIMIT = 400

#: Number of random shifts of the regularity cross-check.
N_SHIFTS = 3

#: A structure whose closest rank decision has a margin below this factor
#: (the kept or dropped singular value within this factor of the tolerance) is
#: re-decided on the unbalanced pencil, and the clearer of the two is reported.
MARGIN_RETRY = 10.0

#: A structure whose closest rank decision has a margin below this factor is
#: decided again on the unbalanced pencil too, which is reported only when the two
#: differ and it is clearer: balancing that equalises a pencil dominated by
#: conductances (0.1 S) can bring a MOS overlap capacitance's (8e-16 F) singular
#: value of a staircase step within 16 times the tolerance of rounding (index 3),
#: where the unbalanced pencil keeps it with a margin of 5e9 (index 2, as with ten
#: times the capacitance on both; tests/test_pencil.py).
MARGIN_CHECK = 100.0

#: A structure decided in exact arithmetic is adopted through a staircase that drops singular values
#: up to this factor above their tolerance (rounding in H can leak more than the tolerance into a
#: block: ``Staircase.leaks``), never one that keeps a singular value at or below it.
EXACT_DROP = 1e3

#: A close call (not a dispute) is checked in exact arithmetic up to this many unknowns (about 0.05 s).
EXACT_ROUTINE_LIMIT = 150

#: A balanced pencil whose significant entries still span more than this many
#: decades is decided again on the unbalanced pencil too (the clearer of the two
#: is reported when the two differ): a rank tolerance of ``n eps`` of its norm cannot tell its
#: smallest entries from rounding. Balancing fitted to tiny entries that are not
#: rounding noise (a MOS model's capacitances of 1e-24 F next to 1e-13 F and
#: conductances of 1e-11 S next to 0.1 S, at zero bias) stretched a CMOS
#: oscillator's pencil over 16 decades and dropped a singular value of its CV
#: loop's chain (index 3) that the unbalanced pencil keeps with a margin of 600
#: (index 2; tests/test_pencil_oracle.py).
SPREAD_RETRY = 12.0

#: The Drazin cross-check forms (mu E - H)^-1 E, whose rounding grows with the
#: condition number of mu E - H: its rank tolerance is this factor times rtol.
DRAZIN_SAFETY = 1e3


def _dense(M, name: str) -> np.ndarray:
    a = M.toarray() if sp.issparse(M) else np.asarray(M)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {a.shape}")
    if np.iscomplexobj(a):
        if np.any(a.imag != 0):  # a cast to float would drop the imaginary parts without a word
            raise ValueError(f"{name} must be real: the pencil of a DAE E x' = H x + c has real matrices")
        a = a.real
    a = np.array(a, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has non-finite entries")
    return a


def _svd_full(M: np.ndarray):
    """SVD ``M = P diag(s) WH`` (full), tolerating empty matrices."""
    if M.size == 0:
        return np.eye(M.shape[0]), np.zeros(0), np.eye(M.shape[1], dtype=M.dtype)
    return sla.svd(M, full_matrices=True)


def _pair(E, H) -> tuple[np.ndarray, np.ndarray]:
    E = _dense(E, "E")
    H = _dense(H, "H")
    if E.shape != H.shape:
        raise ValueError(f"E and H must have the same shape, got {E.shape} and {H.shape}")
    return E, H


def _prepare(E, H, tol, balance):
    E, H = _pair(E, H)
    n = E.shape[0]
    bal = balance_pencil(E, H, enabled=balance)
    Eb, Hb = bal.apply(E, H)
    rtol = default_rtol(n) if tol is None else float(tol)
    if not 0.0 <= rtol < 1.0:
        raise ValueError(f"tol is a relative tolerance in [0, 1), got {tol}")
    return E, H, bal, Eb, Hb, rtol


@dataclass
class _Decided:
    """A structure decided on one scaling of the pencil."""

    bal: Balancing
    Eb: np.ndarray
    Hb: np.ndarray
    tol_e: float
    tol_h: float
    ks: KroneckerStructure
    notes: list
    #: The balanced and the unbalanced pencil gave different structures, each keeping a singular value within
    #: what rounding in H can leak into its block: double precision does not decide the structure.
    disputed: bool = False
    #: The structure of the stored matrices in exact arithmetic, where a close call asked for it and it was
    #: adopted or is noted (:mod:`netdae.dae.exact`); adopted unless ``disputed``.
    exact: ExactStructure | None = None
    #: The exact structure changed what double precision reported, or settled a dispute.
    exact_changed: bool = False


def _decide(E, H, bal: Balancing, rtol: float, null_dims=None) -> _Decided:
    Eb, Hb = bal.apply(E, H)
    tol_e = rtol * float(np.linalg.norm(Eb))
    tol_h = rtol * float(np.linalg.norm(Hb))
    ks = kronecker_structure(Eb, Hb, tol_e, tol_h, null_dims=null_dims)
    return _Decided(bal, Eb, Hb, tol_e, tol_h, ks, [])


def _follows(ks: KroneckerStructure) -> bool:
    """A staircase steered by exact null-space dimensions stays within double precision: it keeps no singular
    value at or below its tolerance and drops none above ``EXACT_DROP`` times it (the structure is then that of
    a pencil within rounding-sized perturbations of the stored one)."""
    for d in ks.decisions:
        if d.kept and d.kept[-1] <= d.tol:
            return False
        if d.dropped and d.dropped[0] > EXACT_DROP * d.tol:
            return False
    return True


def _arbitrate(E, H, rtol: float, chosen: _Decided, other: _Decided | None) -> _Decided:
    """A structure the rank decisions found close, settled in exact arithmetic where it can be.

    The exact structure (:func:`netdae.dae.exact.exact_structure`) of the stored matrices is adopted when
    ``chosen`` or ``other`` (the decision on the other scaling, when made) has it, or, for a regular pencil,
    through the staircase steered by its null-space dimensions on ``chosen``'s scaling when that stays
    within double precision (:func:`_follows`). Otherwise ``chosen`` stays: disputed, with the exact
    structure noted, when double precision does not decide it (the two scalings decided different
    structures, each within what rounding can leak into its blocks); as it is else, since the exact
    structure of the stored matrices may hold rounding residues (the sum of two capacitances at a node no
    longer cancels their off-diagonal entries exactly) that a decision within double precision rightly
    ignores. Up to ``EXACT_LIMIT`` unknowns for an undecided structure, ``EXACT_ROUTINE_LIMIT`` for a close
    one (the cost grows as n^3).
    """
    n = E.shape[0]
    undecided = other is not None and other.ks.summary() != chosen.ks.summary() and \
        max(chosen.ks.robust_margin, other.ks.robust_margin) < 1.0
    chosen.disputed = undecided
    if n > (EXACT_LIMIT if undecided else EXACT_ROUTINE_LIMIT):
        if undecided:
            chosen.notes.append(f"not decided in exact arithmetic either: it is limited to {EXACT_LIMIT} "
                                f"unknowns (O(n^3) integer operations), the pencil has {n}")
        return chosen
    ex = exact_structure(E, H)
    what = ("the ranks in exact arithmetic (over two prime fields) of the matrices as stored (every double is a "
            "binary fraction) give ")
    found = ex.describe()
    match = [d for d in (chosen, other) if d is not None and ex.agrees(d.ks)]
    if match:
        decided = match[0]
        if decided is chosen:
            decided.exact = ex
            decided.exact_changed = undecided
            decided.disputed = False
            decided.notes.append("confirmed in exact arithmetic: " + what + found)
            return decided
        how = "; reporting the " + ("balanced" if decided.bal.applied else "unbalanced") + " pencil's decision"
    elif ex.regular:
        decided = _decide(E, H, chosen.bal, rtol, null_dims=ex.null_dims)
        how = "; the staircase's rank decisions follow them"
        if not _follows(decided.ks):
            if undecided:
                chosen.exact = ex
                chosen.notes.append(what + found + ", which needs singular values below rounding in double "
                                    "precision (a finer structure than the element values can show): not adopted")
            return chosen
    else:
        if undecided:
            chosen.exact = ex
            chosen.notes.append(what + found + ", which neither floating-point decision has: not adopted")
        return chosen
    decided.notes[:0] = chosen.notes
    decided.notes.append("decided in exact arithmetic: " + what + found + how)
    decided.exact = ex
    decided.exact_changed = True
    decided.disputed = False
    return decided


def _structure(E, H, tol, balance, terms=None) -> tuple[_Decided, float]:
    """:func:`_decided_structure`, then, given the unsummed ``terms`` of E and H (a linear circuit's stamps), the
    structure checked against theirs in exact arithmetic (:func:`_check_terms`)."""
    best, rtol = _decided_structure(E, H, tol, balance)
    if terms is not None and best.Eb.shape[0] <= EXACT_ROUTINE_LIMIT:
        best = _check_terms(*_pair(E, H), rtol, best, terms)
    return best, rtol


def _check_terms(E, H, rtol: float, best: _Decided, terms) -> _Decided:
    """The reported structure against the exact structure of the stamps' unsummed entries (the elements'
    values as stored, their sums without rounding): adopted through either scaling's steered staircase
    when double precision can follow it, else the report is disputed, with the exact structure noted."""
    ex = exact_structure(E, H, terms=terms)
    if ex.agrees(best.ks):
        if best.exact is not None or best.disputed:  # a close call or a dispute: say what settled it
            best.exact, best.exact_changed = ex, best.exact_changed or best.disputed
            best.disputed = False
            best.notes.append("confirmed in exact arithmetic on the elements' values as stored (their sums "
                              "without rounding)")
        return best
    found = ex.describe()
    what = "the circuit's structure in exact arithmetic (the elements' values as stored, summed without rounding) is "
    if ex.regular:
        for bal in (best.bal, balance_pencil(E, H, enabled=not best.bal.applied)):
            steered = _decide(E, H, bal, rtol, null_dims=ex.null_dims)
            if _follows(steered.ks):
                steered.notes = best.notes + ["decided in exact arithmetic: " + what + found + "; the "
                                              + ("balanced" if bal.applied else "unbalanced")
                                              + " staircase's rank decisions follow it"]
                steered.exact, steered.exact_changed = ex, True
                return steered
    best.exact, best.disputed = ex, True
    best.notes.append(what + found + ", which double precision cannot resolve (it needs singular values "
                      "below rounding: element values whose ratios approach the limit of double precision); "
                      f"the floating-point structure is reported")
    return best


def _decided_structure(E, H, tol, balance) -> tuple[_Decided, float]:
    """Decide the structure on the balanced pencil, re-deciding unbalanced on a close call (margin below
    ``MARGIN_RETRY``: the clearer of the two is reported), a doubtful one (below ``MARGIN_CHECK``) or a
    balanced pencil still spread over more than ``SPREAD_RETRY`` decades, or a balanced structure keeping a
    singular value within what rounding in H can leak into its block (``KroneckerStructure.robust_margin``
    below ``MARGIN_RETRY``; in these three the unbalanced structure is reported only when it differs and is
    clearer: where the two agree the balanced one gives the better eigenvalues)."""
    E, H, bal, _, _, rtol = _prepare(E, H, tol, balance)
    best = _decide(E, H, bal, rtol)
    close = best.ks.margin < MARGIN_RETRY
    stretched = bal.spread_after > SPREAD_RETRY
    doubtful = best.ks.margin < MARGIN_CHECK
    # a kept singular value within what rounding in H can leak into its block is a close call that the
    # margin against the tolerance does not show (reported only when the unbalanced pencil disagrees)
    leaky = best.ks.robust_margin < MARGIN_RETRY
    if bal.applied and (close or stretched or doubtful or leaky):
        plain = _decide(E, H, balance_pencil(E, H, enabled=False), rtol)
        differ = plain.ks.summary() != best.ks.summary()
        if not (close or differ):
            return (_arbitrate(E, H, rtol, best, plain) if doubtful or leaky else best), rtol
        # where the two disagree, a kept singular value counts only by how far it exceeds what rounding in H
        # can leak into its E block: the unbalanced pencil's tolerance of n eps ||E|| does not see that
        # leak, which grows with the spread of H's entries (robust_margin)
        score = (lambda d: d.ks.robust_margin) if differ else (lambda d: d.ks.margin)
        chosen = plain if score(plain) > score(best) else best
        if close or doubtful or not (stretched or leaky):
            why = "the closest rank decision on the balanced pencil"
        elif stretched:
            why = f"the balanced pencil spans {bal.spread_after:.1f} decades; its closest rank decision"
        else:
            why = ("a singular value the balanced pencil keeps is within what rounding in H can leak into its "
                   f"block (margin {best.ks.robust_margin:.3g} against that); its closest rank decision")
        note = (
            f"{why} had margin {best.ks.margin:.3g}; decided again "
            f"on the unbalanced pencil (margin {plain.ks.margin:.3g}); reporting the "
            f"{'unbalanced' if chosen is plain else 'balanced'} one"
        )
        if differ:
            note += (
                f"; they disagree: balanced {best.ks.describe()}, unbalanced {plain.ks.describe()}; "
                "margins against what rounding "
                f"in H can leak into the blocks: balanced {best.ks.robust_margin:.3g}, unbalanced "
                f"{plain.ks.robust_margin:.3g}"
            )
        chosen.notes.append(note)
        best = _arbitrate(E, H, rtol, chosen, best if chosen is plain else plain)
    elif close or doubtful or leaky:
        best = _arbitrate(E, H, rtol, best, None)
    return best, rtol


# ---------------------------------------------------------------------------
# SVD form (2.3)-(2.5)
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class SvdForm:
    """The SVD form (2.3): ``U E V = diag(Sigma, 0)``, and the split (2.4)/(2.5).

    ``U = Ub Dl`` and ``V = Dr Vb`` with orthogonal ``Ub``, ``Vb`` from the SVD
    of the balanced E, so U and V are orthogonal when no balancing was applied
    (``orthogonal``) and orthogonal up to diagonal power-of-two scalings
    otherwise.

    Attributes
    ----------
    U, V : ndarray, shape (n, n)
    sigma : ndarray, shape (n_y,)
        Non-zero singular values (of E in the coordinates of U, V).
    n_y, n_z : int
        ``rank E`` and ``n - rank E``.
    UHV : ndarray, shape (n, n)
        ``U H V`` with blocks H11 (n_y x n_y), H12, H21, H22 (n_z x n_z).
    orthogonal : bool
    decision : RankDecision
        The rank decision on E.
    """

    U: np.ndarray
    V: np.ndarray
    sigma: np.ndarray
    n_y: int
    n_z: int
    UHV: np.ndarray
    orthogonal: bool
    decision: RankDecision

    @property
    def H11(self) -> np.ndarray:
        return self.UHV[: self.n_y, : self.n_y]

    @property
    def H12(self) -> np.ndarray:
        return self.UHV[: self.n_y, self.n_y :]

    @property
    def H21(self) -> np.ndarray:
        return self.UHV[self.n_y :, : self.n_y]

    @property
    def H22(self) -> np.ndarray:
        return self.UHV[self.n_y :, self.n_y :]

    def semi_explicit(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Blocks of the semi-explicit form (2.5) of the linear DAE.

        With ``x = V (y; z)`` and ``(c1; c2) = U c``:
        ``y' = A11 y + A12 z + Sigma^-1 c1``, ``0 = A21 y + A22 z + c2``.

        Returns
        -------
        A11, A12, A21, A22 : ndarray
            ``Sigma^-1 H11``, ``Sigma^-1 H12``, ``H21``, ``H22``.
        """
        inv = 1.0 / self.sigma[:, None]
        return inv * self.H11, inv * self.H12, self.H21, self.H22


def _svd_form_from(first_svd, decision: RankDecision, bal: Balancing, Hb: np.ndarray) -> SvdForm:
    P, s, WT = first_svd
    n = Hb.shape[0]
    r = decision.rank
    Ub = P.T
    Vb = WT.T
    U = Ub * bal.row_scale[None, :]
    V = bal.col_scale[:, None] * Vb
    return SvdForm(
        U=U,
        V=V,
        sigma=s[:r] / bal.time_scale,
        n_y=r,
        n_z=n - r,
        UHV=Ub @ Hb @ Vb,
        orthogonal=not bal.applied
        or bool(np.all(bal.row_scale == 1.0) and np.all(bal.col_scale == 1.0) and bal.time_scale == 1.0),
        decision=decision,
    )


def svd_form(E, H, *, tol: float | None = None, balance: bool = True) -> SvdForm:
    """SVD form (2.3) of ``E x' = H x + c`` with the rank of E decided on the balanced pencil.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    tol : float, optional
        Relative tolerance of the rank decision (default ``n * eps``).
    balance : bool
        Equilibrate first (default). ``False`` gives orthogonal U, V.

    Returns
    -------
    SvdForm

    Notes
    -----
    One SVD of E: O(n^3).
    """
    E, H, bal, Eb, Hb, rtol = _prepare(E, H, tol, balance)
    n = E.shape[0]
    P, s, WT = sla.svd(Eb) if n else (np.eye(0), np.zeros(0), np.eye(0))
    dec = rank_decision(s, rtol * np.linalg.norm(Eb), "rank of E (SVD form)", Eb.shape)
    return _svd_form_from((P, s, WT), dec, bal, Hb)


# ---------------------------------------------------------------------------
# cross-checks
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ShiftCheck:
    """Normal rank of the pencil from ``rank(mu E - H)`` at random complex shifts.

    Attributes
    ----------
    shifts : tuple of complex
        The shifts, in balanced units (``lambda = time_scale * mu``).
    ranks : tuple of int
    normal_rank : int
        Maximum of ``ranks`` (a shift that hits an eigenvalue lowers one rank only).
    decisions : tuple of RankDecision
    """

    shifts: tuple
    ranks: tuple
    normal_rank: int
    decisions: tuple

    def to_dict(self) -> dict:
        return {
            "shifts": [[float(np.real(m)), float(np.imag(m))] for m in self.shifts],
            "ranks": list(self.ranks),
            "normal_rank": self.normal_rank,
            "decisions": [d.to_dict() for d in self.decisions],
        }


def _shift_radius(Eb: np.ndarray, Hb: np.ndarray) -> float:
    ne, nh = np.linalg.norm(Eb), np.linalg.norm(Hb)
    return nh / ne if ne > 0 and nh > 0 else 1.0


def _shift_check(Eb, Hb, rtol, n_shifts, seed) -> ShiftCheck:
    rng = np.random.default_rng(seed)
    rho = _shift_radius(Eb, Hb)
    shifts, ranks, decisions = [], [], []
    for j in range(n_shifts):
        mu = rho * np.exp(2j * np.pi * rng.random())
        M = mu * Eb - Hb
        s = sla.svd(M, compute_uv=False) if M.size else np.zeros(0)
        dec = rank_decision(s, rtol * np.linalg.norm(M), f"rank of mu E - H at random shift {j + 1}", M.shape)
        shifts.append(complex(mu))
        ranks.append(dec.rank)
        decisions.append(dec)
    return ShiftCheck(tuple(shifts), tuple(ranks), max(ranks, default=0), tuple(decisions))


def shift_rank_check(
    E, H, *, n_shifts: int = N_SHIFTS, tol: float | None = None, balance: bool = True, seed: int = 0
) -> ShiftCheck:
    """Normal rank of ``lambda E - H`` by SVDs of ``mu E - H`` at random complex ``mu``.

    A regular pencil has ``rank(mu E - H) = n`` for all but finitely many mu.
    The shifts lie on the circle of radius ``||Hb|| / ||Eb||`` (balanced).

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    n_shifts : int
    tol : float, optional
        Relative tolerance (default ``n * eps``).
    balance : bool
    seed : int
        Seed of the random phases (reproducible).

    Returns
    -------
    ShiftCheck

    Notes
    -----
    ``n_shifts`` complex SVDs: O(n^3) each.
    """
    E, H, bal, Eb, Hb, rtol = _prepare(E, H, tol, balance)
    return _shift_check(Eb, Hb, rtol, n_shifts, seed)


@dataclass(frozen=True)
class DrazinResult:
    """Index from the Drazin (shift) characterisation.

    ``index`` is the smallest k with ``rank Ehat^k = rank Ehat^(k+1)`` for
    ``Ehat = (mu E - H)^-1 E``; ``ranks[j] = rank Ehat^j``.
    """

    index: int
    ranks: tuple
    mu: complex
    decisions: tuple


def drazin_index(
    E, H, *, mu: complex | None = None, tol: float | None = None, balance: bool = True, seed: int = 0
) -> DrazinResult:
    """Nilpotency index by the shift trick of the notes (Drazin index of ``(mu E - H)^-1 E``).

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    mu : complex, optional
        Shift in balanced units; random on the circle ``||Hb|| / ||Eb||`` when omitted.
    tol : float, optional
        Relative tolerance; default ``DRAZIN_SAFETY * n * eps``, relative to
        ``||Ehat||_F``.
    balance : bool
    seed : int

    Returns
    -------
    DrazinResult

    Raises
    ------
    SingularPencilError
        When ``mu E - H`` is numerically singular (at tolerance ``n * eps``) at
        every tried shift: a singular pencil, or one too ill-conditioned for
        this cross-check.

    Notes
    -----
    ``rank Ehat^j = n - dim ker Ehat^j`` is computed from the kernel chain
    ``ker Ehat^(j+1) = {x : Ehat x in ker Ehat^j}`` (each step one SVD of
    ``Q_j^H Ehat`` with orthonormal ``Q_j``), never from explicit powers, whose
    rounding grows like ``||Ehat||^j``. A cross-check, not the primary method:
    ``Ehat`` is formed with a solve whose error grows with the condition number
    of ``mu E - H``. Cost O(k n^3).
    """
    E, H, bal, Eb, Hb, rtol = _prepare(E, H, tol, balance)
    n = E.shape[0]
    rt = DRAZIN_SAFETY * default_rtol(n) if tol is None else rtol
    rng = np.random.default_rng(seed)
    rho = _shift_radius(Eb, Hb)
    tries = [mu] if mu is not None else [rho * np.exp(2j * np.pi * rng.random()) for _ in range(N_SHIFTS)]
    for m in tries:
        A = m * Eb - Hb
        s = sla.svd(A, compute_uv=False) if n else np.zeros(0)
        if rank_decision(s, default_rtol(n) * np.linalg.norm(A), "", A.shape).rank == n:
            break
    else:
        raise SingularPencilError(
            "mu E - H is numerically singular at every tried shift: the pencil is singular, "
            "or too ill-conditioned for the Drazin cross-check",
            hint="use analyze_pencil for the structure and its evidence",
        )
    Ehat = sla.solve(A, Eb.astype(complex)) if n else np.zeros((0, 0), dtype=complex)
    tol_abs = rt * np.linalg.norm(Ehat)
    ranks = [n]
    decisions = []
    Q = np.eye(n, dtype=complex)  # orthonormal basis of ker(Ehat^j)^perp, as rows of Q^H
    for j in range(1, n + 2):
        _, s, WH = _svd_full(Q.conj().T @ Ehat)
        dec = rank_decision(s, tol_abs, f"rank of Ehat^{j} (kernel chain)", (n, n))
        decisions.append(dec)
        ranks.append(dec.rank)
        if ranks[-1] == ranks[-2]:
            break
        Q = WH[: dec.rank].conj().T
    return DrazinResult(len(ranks) - 2, tuple(ranks), complex(m), tuple(decisions))


def nilpotent_rank_sequence(N: np.ndarray, tol: float | None = None) -> tuple[tuple, tuple]:
    """Ranks of ``N^j``, j = 0, 1, ... until zero, by SVD with an explicit tolerance.

    Parameters
    ----------
    N : ndarray, shape (p, p)
        A (numerically) nilpotent matrix.
    tol : float, optional
        Relative tolerance; ``N^j`` has singular values below
        ``tol * ||N||_F^j`` counted as zero (the rounding bound of the j-th
        power). Default ``p * eps``.

    Returns
    -------
    ranks : tuple of int
        ``ranks[j] = rank N^j``, ending with 0 (or at a repeated non-zero rank
        when N is not nilpotent).
    decisions : tuple of RankDecision
    """
    N = np.asarray(N, dtype=float)
    p = N.shape[0]
    rt = default_rtol(p) if tol is None else float(tol)
    norm = np.linalg.norm(N)
    ranks = [p]
    decisions = []
    P = np.eye(p)
    for j in range(1, p + 2):
        if ranks[-1] == 0:
            break
        P = N @ P
        s = sla.svd(P, compute_uv=False)
        dec = rank_decision(s, rt * norm**j, f"rank of N^{j}", P.shape)
        decisions.append(dec)
        ranks.append(dec.rank)
        if ranks[-1] == ranks[-2]:
            break
    return tuple(ranks), tuple(decisions)


def blocks_from_ranks(ranks) -> tuple[int, ...]:
    """Jordan block sizes of a nilpotent matrix from ``rank N^j`` (descending sizes).

    There are ``r_{j-1} - r_j`` blocks of size >= j (:func:`~netdae.dae.kronecker.blocks_from_counts`).
    """
    r = list(ranks) + [0]
    return blocks_from_counts([r[j - 1] - r[j] for j in range(1, len(ranks))])


# ---------------------------------------------------------------------------
# the report
# ---------------------------------------------------------------------------
def _complex_list(v) -> list:
    return [[float(np.real(z)), float(np.imag(z))] for z in v]


@dataclass(frozen=True)
class PencilReport:
    """Everything :func:`analyze_pencil` found, with the evidence.

    Attributes
    ----------
    regular : bool
        ``det(lambda E - H)`` is not identically zero (numerically: no
        singular Kronecker blocks at the tolerance).
    index : int or None
        Nilpotency index (size of the largest infinite Jordan block; 0 when E
        is invertible); None for a singular pencil.
    n : int
    rank_E : int
    n_dynamic : int
        Number of finite eigenvalues, ``deg det(lambda E - H)`` (of the
        regular part when singular).
    infinite_blocks : tuple of int
        Sizes of the infinite (nilpotent) Jordan blocks, descending,
        including blocks of size 1.
    finite_eigenvalues : ndarray of complex
        The natural frequencies (sorted by real, then imaginary part).
    normal_rank : int
    right_indices, left_indices : tuple of int
        Minimal indices of the singular blocks (empty when regular):
        ``len(right_indices) = n - normal_rank`` is the dimension of the right
        null structure.
    rtol : float
        Relative tolerance of the rank decisions.
    tol_E, tol_H : float
        Absolute tolerances on the balanced E and H.
    neglected : float
        Frobenius norm of what the staircase set to zero (balanced units).
    balancing : Balancing
    evidence : tuple of RankDecision
        Every rank decision in order.
    names : tuple of str
    classification : Classification or None
        Per-unknown labels (regular pencils only).
    method : str
        ``"kronecker"`` (staircase + QZ/Schur of the finite part).
    finite_method : str
        ``"qz"``, ``"schur"`` or ``"none"`` (no finite part or singular).
    weierstrass : WeierstrassForm or None
    svd : SvdForm
    shift_check : ShiftCheck or None
    warnings : tuple of str
    disputed : bool
        The structure is not decided in double precision: the balanced and the unbalanced pencil
        disagree, and each keeps a singular value within what rounding in H can leak into its
        block (``warnings`` says how), and the structure in exact arithmetic was not adopted either
        (``exact``); the reported one is the clearer of the two.
    exact : ExactStructure or None
        Where a rank decision was close: the structure in exact arithmetic on the stored matrices
        (:func:`netdae.dae.exact.exact_structure`) when it was adopted (it is then the reported
        structure) or when a dispute could not be settled by it (``disputed``: it needs singular
        values below rounding, or no floating-point decision matches a singular one); ``warnings``
        says which.
    exact_changed : bool
        The exact structure changed the structure double precision would have reported, or settled
        a dispute (:attr:`decided_exactly`).
    """

    regular: bool
    index: int | None
    n: int
    rank_E: int
    n_dynamic: int
    infinite_blocks: tuple
    finite_eigenvalues: np.ndarray
    normal_rank: int
    right_indices: tuple
    left_indices: tuple
    rtol: float
    tol_E: float
    tol_H: float
    neglected: float
    balancing: Balancing
    evidence: tuple
    names: tuple
    classification: Classification | None
    method: str
    finite_method: str
    weierstrass: WeierstrassForm | None
    svd: SvdForm
    shift_check: ShiftCheck | None
    warnings: tuple
    disputed: bool = False
    exact: ExactStructure | None = None
    exact_changed: bool = False

    @property
    def decided_exactly(self) -> bool:
        """Exact arithmetic changed the reported structure, or settled one double precision left undecided."""
        return self.exact is not None and not self.disputed and self.exact_changed

    @property
    def singular_by_rounding(self) -> bool:
        """Singular as reported, in double precision, but regular in exact arithmetic (a dispute it could not
        settle)."""
        return not self.regular and self.disputed and self.exact is not None and self.exact.regular

    def exact_dict(self) -> dict | None:
        """``exact`` in JSON form (with whether it was ``adopted`` and ``changed`` the report), or None."""
        if self.exact is None:
            return None
        ex = self.exact
        return {"regular": ex.regular, "index": ex.index, "normal_rank": ex.normal_rank,
                "infinite_blocks": list(ex.infinite_blocks), "adopted": not self.disputed,
                "changed": self.exact_changed}

    @property
    def labels(self) -> tuple | None:
        """Per-unknown labels (``"differential"``, ``"algebraic"``, ``"index2"``, ...)."""
        return None if self.classification is None else self.classification.labels

    @property
    def derivative_order(self) -> np.ndarray | None:
        """Per-unknown highest input derivative (0, 1, 2, ...)."""
        return None if self.classification is None else self.classification.derivative_order

    def to_dict(self) -> dict:
        """JSON-serialisable summary (no matrices)."""
        return {
            "regular": self.regular,
            "index": self.index,
            "n": self.n,
            "rank_E": self.rank_E,
            "n_dynamic": self.n_dynamic,
            "infinite_blocks": list(self.infinite_blocks),
            "finite_eigenvalues": _complex_list(self.finite_eigenvalues),
            "normal_rank": self.normal_rank,
            "right_indices": list(self.right_indices),
            "left_indices": list(self.left_indices),
            "tolerance": {"rtol": self.rtol, "tol_E": self.tol_E, "tol_H": self.tol_H, "neglected": self.neglected},
            "balancing": self.balancing.to_dict(),
            "evidence": [d.to_dict() for d in self.evidence],
            "classification": None if self.classification is None else self.classification.to_dict(self.names),
            "method": self.method,
            "finite_method": self.finite_method,
            "decoupling": None
            if self.weierstrass is None
            else {"coupling_norms": list(self.weierstrass.coupling_norms), "blocks": list(self.weierstrass.blocks)},
            "svd_form": {"n_y": self.svd.n_y, "n_z": self.svd.n_z, "orthogonal": self.svd.orthogonal},
            "shift_check": None if self.shift_check is None else self.shift_check.to_dict(),
            "warnings": list(self.warnings),
            "disputed": self.disputed,
            "exact": self.exact_dict(),
        }


def _structure_warnings(ks: KroneckerStructure, shift: ShiftCheck | None) -> list[str]:
    out = list(ks.warnings)
    if shift is not None and shift.normal_rank != ks.normal_rank:
        out.append(
            f"random-shift cross-check gives normal rank {shift.normal_rank}, the staircase {ks.normal_rank} "
            f"(reported): mu E - H is ill-conditioned at the shifts (closest shift decision margin "
            f"{min(d.margin for d in shift.decisions):.3g}); inspect the evidence or change tol"
        )
    return out


def analyze_pencil(
    E,
    H,
    *,
    B=None,
    names=None,
    tol: float | None = None,
    balance: bool = True,
    finite_method: str = "auto",
    shift_check: bool | None = None,
    seed: int = 0,
    terms=None,
) -> PencilReport:
    """Regularity, index and Kronecker structure of ``E x' = H x + c``.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    B : array_like, shape (n, p), optional
        Input matrix (``c = B u``): the classification then counts only the
        directions the inputs excite.
    names : sequence of str, optional
        Names of the unknowns (for the report).
    tol : float, optional
        Relative tolerance of every rank decision (default ``n * eps``),
        applied to the Frobenius norm of the balanced E or H.
    balance : bool
        Equilibrate the pencil before deciding ranks (default, recommended).
    finite_method : {"auto", "qz", "schur"}
        Reduction of the finite part (see ``netdae.dae.decoupled.QZ_LIMIT``).
    shift_check : bool, optional
        Cross-check the normal rank by random shifts (default: when
        ``n <= SHIFT_CHECK_LIMIT``); a disagreement becomes a warning.
    seed : int
        Seed of the random shifts.
    terms : tuple, optional
        E and H as the unsummed entries they are sums of (``((rows, cols, values), (rows, cols,
        values))``: a linear circuit's element stamps, ``MnaSystem.linear_terms``). Up to
        ``EXACT_ROUTINE_LIMIT`` unknowns every structure is then checked in exact arithmetic on
        them (:func:`netdae.dae.exact.exact_structure`): one that double precision can follow
        is adopted, one it cannot resolve makes the report ``disputed``.

    Returns
    -------
    PencilReport
        A singular pencil is reported (``regular=False``), not raised.

    Raises
    ------
    ValueError
        For matrices of the wrong shape or with non-finite entries.

    Notes
    -----
    O(n^3) time and O(n^2) memory; see :data:`DENSE_LIMIT`.
    """
    dec, rtol = _structure(E, H, tol, balance, terms)
    bal, Eb, Hb, tol_e, tol_h, ks = dec.bal, dec.Eb, dec.Hb, dec.tol_e, dec.tol_h, dec.ks
    n = Eb.shape[0]
    names = tuple(names) if names is not None else tuple(f"x{i}" for i in range(n))
    if len(names) != n:
        raise ValueError(f"names must have {n} entries")
    do_shift = n <= SHIFT_CHECK_LIMIT if shift_check is None else bool(shift_check)
    shift = _shift_check(Eb, Hb, rtol, N_SHIFTS, seed) if do_shift else None
    if n:
        svd = _svd_form_from(ks.first.first_svd, ks.first.decisions[0], bal, Hb)
    else:
        empty = (np.eye(0), np.zeros(0), np.eye(0))
        svd = _svd_form_from(empty, rank_decision(np.zeros(0), tol_e, "rank of E", (0, 0)), bal, Hb)
    evidence = list(ks.decisions) + (list(shift.decisions) if shift else [])
    neglected = ks.first.neglected + (ks.second.neglected if ks.second is not None else 0.0)
    if ks.regular:
        wf = weierstrass_from_staircase(ks.first, bal, rtol, finite_method=finite_method)
        cls = wf.classify(B)
        lam = exact_zeros(wf.eigenvalues, *ks.finite_pencil, tol_e, tol_h)
        index = wf.index
        fmethod = wf.finite_method
    else:
        wf = None
        cls = None
        fe, fh = ks.finite_pencil
        lam = bal.time_scale * sla.eigvals(fh, fe) if fe.size else np.zeros(0, dtype=complex)
        index = None
        fmethod = "none"
    return PencilReport(
        regular=ks.regular,
        index=index,
        n=n,
        rank_E=svd.n_y,
        n_dynamic=ks.n_finite,
        infinite_blocks=tuple(ks.infinite_blocks),
        finite_eigenvalues=np.sort_complex(np.asarray(lam, dtype=complex)),
        normal_rank=ks.normal_rank,
        right_indices=tuple(ks.right_indices),
        left_indices=tuple(ks.left_indices),
        rtol=rtol,
        tol_E=tol_e,
        tol_H=tol_h,
        neglected=neglected,
        balancing=bal,
        evidence=tuple(evidence),
        names=names,
        classification=cls,
        method="kronecker",
        finite_method=fmethod,
        weierstrass=wf,
        svd=svd,
        shift_check=shift,
        warnings=tuple(dec.notes + _structure_warnings(ks, shift)),
        disputed=dec.disputed,
        exact=dec.exact,
        exact_changed=dec.exact_changed,
    )


@dataclass(frozen=True)
class FiniteSpectrum:
    """The finite eigenvalues of ``lambda E - H`` and how they were separated from the infinite ones.

    Attributes
    ----------
    regular : bool
        The pencil is regular (otherwise ``eigenvalues`` are those of the
        regular part and mean little: ``det(lambda E - H)`` vanishes for every
        lambda).
    eigenvalues : ndarray of complex
        The finite eigenvalues, in LAPACK's order.
    n_infinite : int
        How many eigenvalues at infinity the staircase deflated.
    rtol : float
        The relative tolerance of its rank decisions.
    margin : float
        The closest rank decision's margin (ratio of the singular values on
        either side of the cut; large is clear).
    notes : tuple of str
        Close calls re-decided on the unbalanced pencil.
    """

    regular: bool
    eigenvalues: np.ndarray
    n_infinite: int
    rtol: float
    margin: float
    notes: tuple


def exact_zeros(lam: np.ndarray, fe: np.ndarray, fh: np.ndarray, tol_e: float, tol_h: float) -> np.ndarray:
    """The finite eigenvalues with those at the origin made exactly 0, decided structurally.

    The eigenvalues at 0 of the finite part ``lambda fe - fh`` (``fe`` invertible) are the infinite ones of
    the reversed pencil ``mu fh - fe``; QZ gives them as rounding of the size of the pencil's scale times
    eps, of either sign, and a multiple one (a Jordan block: two coupling capacitors, a double zero of a
    second-order high-pass) split by sqrt(eps) of the scale. The staircase of the reversed pencil, with the
    same tolerances (``n eps`` of the balanced matrices' norms: the mirror of the decisions that deflate the
    eigenvalues at infinity), counts them, and as many eigenvalues, the smallest in magnitude, are set to 0.

    >>> exact_zeros(np.array([-1000.0 + 0j, 3e-14 + 0j]), np.eye(2), np.array([[1.0, 0.0], [0.0, 1e-17]]),
    ...             1e-15, 1e-15).tolist()
    [(-1000+0j), 0j]
    """
    lam = np.asarray(lam, dtype=complex)
    if not lam.size or not fh.size:
        return lam
    zero = int(sum(kronecker_structure(fh, fe, tol_h, tol_e).infinite_blocks))
    if zero == 0:
        return lam
    out = lam.copy()
    out[np.argsort(np.abs(lam), kind="stable")[:zero]] = 0.0
    return out


def finite_eigenvalues(E, H, *, tol: float | None = None, balance: bool = True) -> FiniteSpectrum:
    """The finite eigenvalues of the pencil ``lambda E - H``, the infinite ones removed structurally.

    The staircase (the same rank decisions as :func:`analyze_pencil`: on the
    balanced pencil, singular values at most ``tol * ||M||_F`` count as zero)
    deflates every eigenvalue at infinity before QZ sees the pencil, so no
    threshold on ``|beta|`` decides which QZ eigenvalue is "large"; QZ of the
    remaining finite part (``E_f`` invertible) gives the eigenvalues.

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    tol : float, optional
        Relative rank tolerance (default ``n * eps``).
    balance : bool
        Equilibrate first (default).

    Returns
    -------
    FiniteSpectrum

    Examples
    --------
    The RC low-pass driven by a voltage source (unknowns ``v(in)``,
    ``v(out)``, ``i(v1)``; R = 1k, C = 1u): one pole at ``-1/RC``, two
    eigenvalues at infinity:

    >>> E = [[0, 0, 0], [0, 1e-6, 0], [0, 0, 0]]
    >>> H = [[-1e-3, 1e-3, -1], [1e-3, -1e-3, 0], [1, 0, 0]]
    >>> spec = finite_eigenvalues(E, H)
    >>> spec.regular, spec.eigenvalues.real.round(6).tolist(), spec.n_infinite
    (True, [-1000.0], 2)
    """
    dec, rtol = _structure(E, H, tol, balance)
    ks = dec.ks
    fe, fh = ks.finite_pencil
    lam = dec.bal.time_scale * sla.eigvals(fh, fe) if fe.size else np.zeros(0, dtype=complex)
    lam = exact_zeros(lam, fe, fh, dec.tol_e, dec.tol_h)
    return FiniteSpectrum(regular=ks.regular, eigenvalues=np.asarray(lam, dtype=complex),
                          n_infinite=int(sum(ks.infinite_blocks)), rtol=rtol, margin=float(ks.margin),
                          notes=tuple(dec.notes))


def analyze_dae(system, x, t: float, *, B=None, **options) -> PencilReport:
    """:func:`analyze_pencil` of the linearization of a DAE at ``(x, t)``.

    Parameters
    ----------
    system : DaeSystem
        The pencil is ``system.jacobians(x, t) = (dq/dx, dphi/dx)``.
    x : ndarray, shape (n,)
    t : float
    B : array_like, shape (n, p), optional
    **options
        Passed to :func:`analyze_pencil` (``tol``, ``balance``, ...).

    Returns
    -------
    PencilReport

    Raises
    ------
    ValueError
        When ``x`` is not of shape ``(system.n,)``, or as :func:`analyze_pencil`.
    """
    x = np.asarray(x, dtype=float)
    if x.shape != (system.n,):
        raise ValueError(f"x must hold one value per unknown, shape ({system.n},), not shape {x.shape}")
    E, H = system.jacobians(x, t)
    return analyze_pencil(E, H, B=B, names=system.names, **options)


def weierstrass_form(
    E, H, *, tol: float | None = None, balance: bool = True, finite_method: str = "auto"
) -> WeierstrassForm:
    """Weierstrass form (2.9) of a regular pencil, for the decoupled solution (2.11)/(2.12).

    Parameters
    ----------
    E, H : array_like or sparse, shape (n, n)
    tol : float, optional
    balance : bool
    finite_method : {"auto", "qz", "schur"}

    Returns
    -------
    WeierstrassForm

    Raises
    ------
    SingularPencilError
        When the pencil is singular (with its minimal indices in the message).
    """
    dec, rtol = _structure(E, H, tol, balance)
    ks, bal = dec.ks, dec.bal
    if not ks.regular:
        raise SingularPencilError(
            f"the pencil lambda E - H is singular (normal rank {ks.normal_rank} < {dec.Eb.shape[0]}; "
            f"right minimal indices {ks.right_indices}, left {ks.left_indices})",
            hint="the DAE has no or infinitely many solutions; analyze_pencil reports the structure",
        )
    return weierstrass_from_staircase(ks.first, bal, rtol, finite_method=finite_method)
