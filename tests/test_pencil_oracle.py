"""Random pencils with prescribed Kronecker structure, against the exact data and SLICOT ag08bd.

Each pencil is ``P diag(I, N0) Q``, ``P diag(C0, I) Q`` with a known nilpotent
``N0`` (Jordan blocks of sizes up to 5), a finite part ``C0`` with known,
well-separated eigenvalues, and random well-conditioned P, Q (orthogonal
times a diagonal in [1/2, 2]). Both netdae and ag08bd must recover the block
sizes and the eigenvalues; the Drazin index, the rank sequence of the computed
N and the random-shift normal rank must agree.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import block_diag
from scipy.optimize import linear_sum_assignment
from test_pencil import ag08bd_structure, index_from_infe

from netdae.dae.pencil import (
    analyze_pencil,
    blocks_from_ranks,
    drazin_index,
    nilpotent_rank_sequence,
    shift_rank_check,
)

#: Eigenvalue errors are measured in units of this relative tolerance. The
#: transformations have condition numbers below 20 and the eigenvalues are
#: separated by >= 0.2 (condition numbers < 10), so errors are ~1e-14.
EIG_RTOL = 1e-10

CASES = [
    (3, (2,)),
    (4, (3, 1, 1)),
    (6, (5,)),
    (10, (4, 4, 2, 1, 1)),
    (0, (5, 5, 5, 3, 2, 1)),
    (20, (3, 3, 2, 2, 1, 1, 1)),
    (30, (5, 4, 3, 2, 1, 1, 1, 1, 1, 1)),
    (45, (5, 5, 3, 2)),
    (25, ()),
    (12, (1,) * 10),
]
SEEDS = [0, 1, 2]


def jordan_nilpotent(sizes) -> np.ndarray:
    n = sum(sizes)
    N = np.zeros((n, n))
    i = 0
    for s in sizes:
        N[np.arange(i, i + s - 1), np.arange(i + 1, i + s)] = 1.0
        i += s
    return N


def structured_pencil(seed: int, nf: int, sizes):
    """(E, H, eigenvalues) with Kronecker form diag(I, N0) / diag(C0, I)."""
    rng = np.random.default_rng(seed)
    npair = nf // 3
    nreal = nf - 2 * npair
    reals = -0.3 - 0.7 * np.arange(nreal)
    blocks = [np.array([[lam]]) for lam in reals]
    eigs = [complex(lam) for lam in reals]
    for j in range(npair):
        a, b = -0.2 - 0.5 * j, 1.0 + 0.8 * j
        blocks.append(np.array([[a, b], [-b, a]]))
        eigs += [complex(a, b), complex(a, -b)]
    if nf:
        S = np.linalg.qr(rng.standard_normal((nf, nf)))[0] * rng.uniform(0.5, 2.0, nf)
        C0 = S @ block_diag(*blocks) @ np.linalg.inv(S)
    else:
        C0 = np.zeros((0, 0))
    ni = sum(sizes)
    E0 = block_diag(np.eye(nf), jordan_nilpotent(sizes))
    H0 = block_diag(C0, np.eye(ni))
    n = nf + ni
    P = np.linalg.qr(rng.standard_normal((n, n)))[0] * rng.uniform(0.5, 2.0, n)
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    return P @ E0 @ Q, P @ H0 @ Q, np.array(eigs)


def eig_error(got, want) -> float:
    """Largest relative error after optimal matching of two eigenvalue lists."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.size == want.size
    if want.size == 0:
        return 0.0
    cost = np.abs(got[:, None] - want[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c] / np.maximum(np.abs(want[c]), 1.0)))


def ag08bd_eigenvalues(E, H):
    import scipy.linalg as sla
    import slycot

    n = E.shape[0]
    Af, Ef = slycot.ag08bd(
        n, n, 0, 0, np.asfortranarray(H), np.asfortranarray(E), np.zeros((n, 1)), np.zeros((1, n)), np.zeros((1, 1))
    )[:2]
    return sla.eigvals(Af, Ef) if Af.size else np.zeros(0, dtype=complex)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("nf, sizes", CASES)
def test_random_structure_against_exact_data_and_ag08bd(nf, sizes, seed):
    E, H, eigs = structured_pencil(seed, nf, sizes)
    blocks = tuple(sorted(sizes, reverse=True))
    index = max(sizes, default=0)
    rep = analyze_pencil(E, H)
    assert rep.regular
    # the only admissible warning is the documented fall-back: a close rank decision on the
    # balanced pencil decided again on the unbalanced one (which balancing wins a close call
    # depends on the BLAS's rounding)
    assert all("decided again on the unbalanced pencil" in w for w in rep.warnings), rep.warnings
    assert rep.infinite_blocks == blocks
    assert rep.index == index
    assert rep.n_dynamic == nf and rep.rank_E == nf + sum(sizes) - len(sizes)
    assert eig_error(rep.finite_eigenvalues, eigs) / EIG_RTOL < 1
    # the independent oracle sees the same structure
    oracle = ag08bd_structure(E, H)
    assert oracle["infe"] == blocks and oracle["nfz"] == nf
    assert index_from_infe(oracle["infe"]) == index
    assert eig_error(ag08bd_eigenvalues(E, H), eigs) / EIG_RTOL < 1
    # cross-checks: rank sequence of the computed N, Drazin index, shifts
    wf = rep.weierstrass
    ranks, _ = nilpotent_rank_sequence(wf.N)
    assert blocks_from_ranks(ranks) == blocks
    assert drazin_index(E, H, seed=seed).index == index
    assert rep.shift_check.normal_rank == E.shape[0]


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("nf, sizes", CASES[:8])
def test_badly_scaled_rows_and_columns(nf, sizes, seed):
    """Rows and columns scaled by 10^[-12, 12] and E by 1e-9: balancing undoes it."""
    E, H, eigs = structured_pencil(seed, nf, sizes)
    rng = np.random.default_rng(100 + seed)
    n = E.shape[0]
    dl = 10.0 ** rng.uniform(-12, 12, n)
    dr = 10.0 ** rng.uniform(-12, 12, n)
    time = 1e-9
    Es = time * dl[:, None] * E * dr[None, :]
    Hs = dl[:, None] * H * dr[None, :]
    rep = analyze_pencil(Es, Hs)
    assert rep.regular and rep.infinite_blocks == tuple(sorted(sizes, reverse=True))
    assert rep.index == max(sizes, default=0) and rep.n_dynamic == nf
    # E scaled by 1e-9 multiplies the eigenvalues by 1e9
    assert eig_error(rep.finite_eigenvalues / 1e9, eigs) / EIG_RTOL < 1
    assert rep.balancing.spread_before > 30 and rep.balancing.spread_after < 8
    assert drazin_index(Es, Hs, seed=seed).index == rep.index


def test_rounding_noise_does_not_steer_the_balancing():
    """Noise entries (1e-17 next to O(1)) must not drag rows and columns by 50 binary orders."""
    sizes = (3, 2)
    nf = 4
    rng = np.random.default_rng(9)
    E0 = block_diag(np.eye(nf), jordan_nilpotent(sizes))
    H0 = block_diag(np.diag(-1.0 - np.arange(nf)), np.eye(sum(sizes)))
    noise = 1e-17 * rng.standard_normal(E0.shape) * (E0 == 0) * (rng.random(E0.shape) < 0.2)
    rep = analyze_pencil(E0 + noise, H0 + noise.T)
    assert rep.infinite_blocks == sizes and rep.n_dynamic == nf
    assert np.max(np.abs(np.log2(rep.balancing.row_scale))) <= 4
    assert eig_error(rep.finite_eigenvalues, -1.0 - np.arange(nf)) / EIG_RTOL < 1


#: The linearisation of a CMOS oscillator at its transient start (supply at 0 V, every BSIM
#: transistor off; ngspice's examples/soa/nic_soa.cir): unknowns v(bias), v(ra), v(net99), v(net95),
#: v(net93), v(vdd), v(lc), v(p001), v(p002), i(v39), i(l1), i(l2). The gate capacitances chain the
#: supply node to ground (a CV loop with V39: index 2); the transistors add capacitances of 1e-24 to
#: 1e-21 F and conductances of 1e-11 S next to 1e-13 F and 0.1 S.
_OSCILLATOR_START_E = [
    (0, 0, 2.589e-13), (0, 1, -1.483e-14), (1, 0, -1.57e-14), (1, 1, 6.994e-14), (1, 2, -6.933e-22),
    (1, 3, -5.512e-14), (2, 1, -1.198e-21), (2, 2, 3.589e-13), (2, 3, -4.344e-14), (2, 5, -3.155e-13),
    (3, 1, -5.512e-14), (3, 2, -4.344e-14), (3, 3, 1.537e-13), (3, 4, -5.512e-14), (3, 5, 2.864e-21),
    (4, 3, -5.512e-14), (4, 4, 5.512e-14), (5, 2, -3.155e-13), (5, 3, -3.983e-24), (5, 5, 3.155e-13),
    (6, 6, 1.8e-09), (10, 10, 1.49e-05), (11, 11, 0.0014)]
_OSCILLATOR_START_H = [
    (0, 0, -2.347e-05), (1, 0, 5.041e-18), (1, 1, -0.0002609), (1, 2, 1.486e-11), (1, 3, 7.647e-24),
    (2, 1, 1.486e-11), (2, 2, -2.632e-05), (2, 3, -7.647e-24), (2, 5, 1.529e-11), (3, 3, -9.706e-12),
    (3, 4, 2.773e-12), (3, 5, 6.933e-12), (4, 3, 2.773e-12), (4, 4, -0.1), (4, 6, 0.1), (5, 2, 1.529e-11),
    (5, 3, 6.933e-12), (5, 5, -2.222e-11), (5, 9, -1.0), (6, 4, 0.1), (6, 6, -0.1), (6, 7, 2.5e-05),
    (6, 10, -1.0), (7, 6, 2.5e-05), (7, 7, -2.5e-05), (7, 11, -1.0), (8, 8, -1.818), (8, 10, 1.0),
    (9, 5, 1.0), (10, 6, 1.0), (10, 8, -1.0), (11, 7, 1.0)]


def test_balancing_stretched_by_tiny_device_entries_is_decided_unbalanced_too():
    """Balanced, the oscillator's pencil spans 16 decades and a singular value of its CV loop's chain
    was dropped (index 3 was reported); the unbalanced decision is clear (margin ~600) and agrees
    with SLICOT: index 2, the supply current the only index-2 unknown."""
    E, H = np.zeros((12, 12)), np.zeros((12, 12))
    for M, entries in ((E, _OSCILLATOR_START_E), (H, _OSCILLATOR_START_H)):
        for i, j, v in entries:
            M[i, j] = v
    oracle = ag08bd_structure(E, H)
    rep = analyze_pencil(E, H)
    assert rep.infinite_blocks == oracle["infe"] == (2, 1, 1)
    assert rep.index == index_from_infe(oracle["infe"]) == 2
    assert rep.n_dynamic == oracle["nfz"]
    assert [int(d) for d in rep.derivative_order] == [0] * 9 + [1, 0, 0]
    assert any("reporting the unbalanced one" in w for w in rep.warnings), rep.warnings


def test_shift_check_on_a_singular_pencil():
    E, H, _ = structured_pencil(0, 4, (2, 1))
    n = E.shape[0]
    v = np.ones(n) / np.sqrt(n)
    proj = np.eye(n) - np.outer(v, v)  # remove a common direction: singular pencil
    check = shift_rank_check(E @ proj, H @ proj)
    assert check.normal_rank == n - 1
    rep = analyze_pencil(E @ proj, H @ proj)
    assert not rep.regular and rep.normal_rank == n - 1
    assert rep.right_indices == (0,)
