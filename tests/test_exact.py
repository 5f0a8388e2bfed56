"""The exact structure of a pencil (netdae.dae.exact) against constructed Weierstrass forms and rational
arithmetic (fractions), and the staircase steered by it."""

from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg as sla

from netdae.dae.exact import EXACT_LIMIT, PRIMES, exact_structure, rank_mod, to_field
from netdae.dae.kronecker import default_rtol, kronecker_structure


def _unimodular(n, rng):
    """An integer matrix of determinant +-1 (a product of integer triangular factors with unit diagonals, rows
    permuted): exactly invertible over the integers, entries small enough for exact float products."""
    L = np.tril(rng.integers(-2, 3, (n, n)), -1) + np.eye(n, dtype=int)
    U = np.triu(rng.integers(-2, 3, (n, n)), 1) + np.eye(n, dtype=int)
    return (L @ U)[rng.permutation(n)]


def _weierstrass(n_finite, blocks, rng, transform=True):
    """E = P diag(I, N) Q, H = P diag(J, I) Q with integer P, Q, triangular J and N of nilpotent Jordan blocks of
    the given sizes: the structure is known exactly, and every entry is an exact integer. Returns E, H and the
    finite eigenvalues (J's diagonal)."""
    n = n_finite + sum(blocks)
    Eb = np.zeros((n, n), dtype=int)
    Hb = np.zeros((n, n), dtype=int)
    Eb[:n_finite, :n_finite] = np.eye(n_finite, dtype=int)
    Hb[:n_finite, :n_finite] = np.triu(rng.integers(-3, 4, (n_finite, n_finite)))
    k = n_finite
    for b in blocks:
        for i in range(b - 1):
            Eb[k + i, k + i + 1] = 1
        Hb[k : k + b, k : k + b] = np.eye(b, dtype=int)
        k += b
    if transform:
        P, Q = _unimodular(n, rng), _unimodular(n, rng)
    else:  # signed permutations: orthogonal, the structure stays well-conditioned
        P = np.eye(n, dtype=int)[rng.permutation(n)] * rng.choice([-1, 1], n)
        Q = np.eye(n, dtype=int)[rng.permutation(n)]
    E, H = P @ Eb @ Q, P @ Hb @ Q
    assert np.abs(E).max() < 2**50 and np.abs(H).max() < 2**50
    return E.astype(float), H.astype(float), np.diag(Hb[:n_finite, :n_finite]).astype(float)


@pytest.mark.parametrize("seed", range(6))
def test_constructed_weierstrass_forms_are_recovered(seed):
    rng = np.random.default_rng(seed)
    n_finite = int(rng.integers(0, 5))
    blocks = sorted((int(b) for b in rng.integers(1, 5, int(rng.integers(1, 6)))), reverse=True)
    E, H, _ = _weierstrass(n_finite, blocks, rng)
    ex = exact_structure(E, H, seed=seed)
    assert ex.regular and ex.normal_rank == E.shape[0]
    assert ex.infinite_blocks == tuple(blocks)
    assert ex.index == blocks[0]
    assert ex.n_finite == n_finite


def test_an_ode_and_a_purely_algebraic_system():
    rng = np.random.default_rng(3)
    E, H, _ = _weierstrass(6, [], rng)
    assert exact_structure(E, H).index == 0 and exact_structure(E, H).n_finite == 6
    E, H, _ = _weierstrass(0, [1, 1, 1], rng)
    assert exact_structure(E, H).infinite_blocks == (1, 1, 1)


def test_a_singular_pencil_and_its_normal_rank():
    rng = np.random.default_rng(4)
    E, H, _ = _weierstrass(3, [2, 1], rng)
    # a common right null vector (zero columns after Q's inverse) and a common left one: normal rank n - 2
    Q = _unimodular(6, rng).astype(float)
    D = np.diag([1.0, 1, 1, 1, 0, 0])
    E, H = E @ D @ Q, H @ D @ Q
    ex = exact_structure(E, H)
    assert not ex.regular and ex.normal_rank == 4 and ex.index is None and ex.infinite_blocks == ()


def _rational_null_dims(E, H, s0):
    """s_i = rank F^{i-1} - rank F^i for F = (s0 E - H)^{-1} E, in rational arithmetic (fractions)."""
    n = E.shape[0]
    M = [[Fraction(s0) * Fraction(E[i, j]) - Fraction(H[i, j]) for j in range(n)] for i in range(n)]
    A = [M[i] + [Fraction(E[i, j]) for j in range(n)] for i in range(n)]
    for c in range(n):  # Gauss-Jordan, M invertible for the shifts used
        piv = next(i for i in range(c, n) if A[i][c] != 0)
        A[c], A[piv] = A[piv], A[c]
        inv = 1 / A[c][c]
        A[c] = [v * inv for v in A[c]]
        for i in range(n):
            if i != c and A[i][c] != 0:
                f = A[i][c]
                A[i] = [a - f * b for a, b in zip(A[i], A[c])]
    F = [row[n:] for row in A]

    def rank(X):
        X = [row[:] for row in X]
        r = 0
        for c in range(n):
            piv = next((i for i in range(r, n) if X[i][c] != 0), None)
            if piv is None:
                continue
            X[r], X[piv] = X[piv], X[r]
            for i in range(r + 1, n):
                if X[i][c] != 0:
                    f = X[i][c] / X[r][c]
                    X[i] = [a - f * b for a, b in zip(X[i], X[r])]
            r += 1
        return r

    dims, prev, power = [], n, F
    while True:
        r = rank(power)
        if r == prev:
            return tuple(dims)
        dims.append(prev - r)
        prev = r
        power = [[sum(power[i][k] * F[k][j] for k in range(n)) for j in range(n)] for i in range(n)]


@pytest.mark.parametrize("seed", range(8))
def test_random_circuit_like_pencils_against_rational_arithmetic(seed):
    # sparse pencils of circuit-like values (picofarads, kilo-ohm conductances, unit incidences, gains of 1e6 to
    # 1e9): binary fractions spanning 40 decades, decided in rational arithmetic as the oracle
    rng = np.random.default_rng(100 + seed)
    n = 7
    vals = np.array([1e-12, 2.2e-12, 1e-3, 1.0 / 3.3e3, 1.0, -1.0, 1e6, 1e9, 0.5])
    E = np.zeros((n, n))
    H = np.zeros((n, n))
    for _ in range(3):
        i, j = rng.integers(0, n, 2)
        E[i, j] += rng.choice(vals[:2])
    for _ in range(12):
        i, j = rng.integers(0, n, 2)
        H[i, j] += rng.choice(vals)
    ex = exact_structure(E, H, seed=seed)
    if not ex.regular:  # no invertible shift: the rational determinant vanishes at the shifts tried too
        for s0 in (3, 17, 1234567):
            M = [[Fraction(s0) * Fraction(E[i, j]) - Fraction(H[i, j]) for j in range(n)] for i in range(n)]
            assert _rational_det_is_zero(M)
        return
    s0 = next(s for s in (3, 17, 1234567, 7654321) if not _rational_det_is_zero(
        [[Fraction(s) * Fraction(E[i, j]) - Fraction(H[i, j]) for j in range(n)] for i in range(n)]))
    assert ex.null_dims == _rational_null_dims(E, H, s0)


def _rational_det_is_zero(M):
    n = len(M)
    X = [row[:] for row in M]
    for c in range(n):
        piv = next((i for i in range(c, n) if X[i][c] != 0), None)
        if piv is None:
            return True
        X[c], X[piv] = X[piv], X[c]
        for i in range(c + 1, n):
            f = X[i][c] / X[c][c]
            X[i] = [a - f * b for a, b in zip(X[i], X[c])]
    return False


def test_residues_are_exact_binary_fractions():
    x = np.array([[0.5, 1e-12, -3.0], [1e9, 2.0**-1074, 1.0 / 3.0]])
    for p in PRIMES:
        got = to_field(x, p)
        for v, r in zip(x.ravel(), got.ravel()):
            q = Fraction(v)
            assert r == q.numerator * pow(q.denominator, -1, p) % p
    assert rank_mod(to_field(np.array([[1.0, 2.0], [0.5, 1.0]]), PRIMES[0]), PRIMES[0]) == 1


def test_the_staircase_follows_the_exact_null_dimensions():
    rng = np.random.default_rng(9)
    rtol = default_rtol(9)

    def decide(E, H, null_dims=None):
        return kronecker_structure(E, H, rtol * np.linalg.norm(E), rtol * np.linalg.norm(H), null_dims=null_dims)

    # well-conditioned (signed permutations for P and Q): steering changes nothing
    E, H, _ = _weierstrass(3, [3, 2, 1], rng, transform=False)
    free = decide(E, H)
    steered = decide(E, H, exact_structure(E, H).null_dims)
    assert free.summary() == steered.summary() == (True, (3, 2, 1), (), ())
    # integer transformations make the pencil ill-conditioned: the free staircase decides (2, 1, 1) here; steered
    # by the exact dimensions it keeps the structure and still separates the three finite eigenvalues
    E, H, lam = _weierstrass(3, [3, 2, 1], np.random.default_rng(11))
    assert decide(E, H).summary() != (True, (3, 2, 1), (), ())
    steered = decide(E, H, exact_structure(E, H).null_dims)
    assert steered.summary() == (True, (3, 2, 1), (), ())
    fe, fh = steered.finite_pencil
    got = np.sort(sla.eigvals(fh, fe).real)
    np.testing.assert_allclose(got, np.sort(lam), rtol=1e-6, atol=1e-6)


def test_bad_input():
    with pytest.raises(ValueError, match="square"):
        exact_structure(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="finite"):
        exact_structure(np.array([[np.nan]]), np.array([[1.0]]))
    n = EXACT_LIMIT + 1
    with pytest.raises(ValueError, match="limited"):
        exact_structure(np.zeros((n, n)), np.eye(n))


def test_long_lists_of_block_sizes_are_printed_with_counts():
    from netdae.dae.kronecker import format_sizes

    assert format_sizes([]) == "none"
    assert format_sizes([2, 1, 1]) == "[2, 1, 1]"
    assert format_sizes([3] + [2] * 4 + [1] * 722) == "[3, 2 x4, 1 x722]"
    # the CLI's report of a pencil with hundreds of blocks stays one short line
    import netdae
    from netdae.cli.index import format_report

    lines = ["many algebraic unknowns", "V1 n0 0 DC 1", "C1 n0 0 1p"]
    lines += [f"R{k} n{k} n{k + 1} 1k" for k in range(40)] + ["R40 n40 0 1k", ".tran 1n 10n", ".end"]
    text = format_report(netdae.analyze_index(netdae.load("\n".join(lines) + "\n")))
    line = next(ln for ln in text.splitlines() if "infinite blocks" in ln)
    # the capacitor on the source: one block of size 2; the 40 other nodes and one more current: size 1
    assert line.endswith("dynamic states = 0; infinite blocks = [2, 1 x40]"), line


_PARALLEL_CAPS = """parallel capacitors beside a milliohm, a femtofarad and a VCVS of gain 1000
V1 n0 0 PULSE(0 1 1n 1n 1n 5n 20n)
C1 n2 n3 1e-12
R2 n2 n4 0.001
L3 n4 n1 0.001
E4 n0 n2 n1 n2 1000.0
C5 n3 n2 1e-06
C6 n1 0 1e-15
R7 n2 n1 0.001
Rgn0 n0 0 1e12
Rgn1 n1 0 1e12
Rgn2 n2 0 1e12
Rgn3 n3 0 1e12
Rgn4 n4 0 1e12
.tran 1n 20n
.end
"""


def test_two_scalings_that_disagree_are_settled_by_the_exact_structure():
    # The balanced pencil decides index 2 (blocks [2, 1, 1, 1], two dynamic states) with margin 137 against the
    # leak, the unbalanced one index 1 with margin 45: both "decided", so the clearer (balanced) was reported.
    # The exact structure of the circuit (rational MNA of the element values, below) is index 1 with three
    # dynamic states (C1 + C5, C6, L3): the unbalanced decision, which exact arithmetic now picks.
    import netdae

    rep = netdae.analyze_index(netdae.load(_PARALLEL_CAPS))
    assert rep.pencil.decided_exactly and not rep.pencil.disputed
    assert rep.index == 1 and rep.pencil.infinite_blocks == (1,) * 5 and rep.pencil.n_dynamic == 3
    # the structure of the circuit itself: its MNA in rational arithmetic from the values as written
    true = _fuzz_index().true_structure(_PARALLEL_CAPS)
    assert true.regular and true.index == 1 and true.infinite_blocks == (1,) * 5


def _fuzz_index():
    """scripts/fuzz_index.py as a module (its rational MNA of R, C, L, V, E and G cards)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "scripts" / "fuzz_index.py"
    spec = importlib.util.spec_from_file_location("fuzz_index", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_UNRESOLVABLE = """a gain of 1e9 beside tera-ohm leaks
V1 n0 0 PULSE(0 1 1n 1n 1n 5n 20n)
C1 n2 n1 1e-09
V2 n0 n2 DC 0
G3 0 n0 0 n2 1000000000.0
Rgn0 n0 0 1e12
Rgn1 n1 0 1e12
Rgn2 n2 0 1e12
.tran 1n 20n
.end
"""


def test_a_structure_double_precision_cannot_resolve_is_reported_uncertain_and_run_as_the_exact_one():
    # The 1e-12 S leaks sit at 1e-21 of the 1e9 S entries in their rows: double precision decides a singular pencil
    # (clearly, by its margins), the circuit is regular of index 1 (its rational MNA). The exact structure of the
    # stamps' unsummed entries says so, no staircase in double precision can follow it, and the report is
    # disputed instead of silently wrong.
    import netdae

    rep = netdae.analyze_index(netdae.load(_UNRESOLVABLE))
    true = _fuzz_index().true_structure(_UNRESOLVABLE)
    assert true.regular and true.index == 1
    assert rep.pencil.disputed and rep.regular is False
    assert rep.pencil.exact.regular and rep.pencil.exact.index == 1
    assert any(m.startswith("uncertain: double precision does not decide this structure") and
               "in exact arithmetic it is regular, of index 1" in m for m in rep.messages)
    assert rep.to_dict()["disputed"] and rep.to_dict()["exact"]["index"] == 1
    assert rep.messages[0].startswith("singular pencil in double precision, regular in exact arithmetic")
    # the transient runs as the exact structure says (index 1), with a warning; at the pulse's corner its
    # Newton matrices lose the leaks' direction to rounding, the run stops there and its message says why
    res = netdae.simulate(netdae.load(_UNRESOLVABLE))
    assert any(n.startswith("warning: the circuit's pencil (E, H) is singular in double precision, though regular "
                            "of index 1 in exact arithmetic") for n in res.notes)
    if not res.ok:
        assert "singular in double precision" in res.message and "closer together" in res.message
    # with a smooth input it reaches the end, on the closed form: v(n1) = v(n2) = v(n0) = sin (C1 holds no
    # charge through its 1e12-ohm leak on this time scale)
    smooth = netdae.simulate(netdae.load(_UNRESOLVABLE.replace("PULSE(0 1 1n 1n 1n 5n 20n)", "SIN(0 1 50meg)")))
    assert smooth.ok, smooth.message
    t = np.asarray(smooth.t)
    for name in ("v(n1)", "v(n2)"):
        assert np.max(np.abs(np.asarray(smooth[name]) - np.sin(2 * np.pi * 50e6 * t))) < 1e-9, name


def test_the_stamps_unsummed_entries_have_no_rounding_residue():
    # Two capacitances at a node, 1e-6 and 1e-9: their rounded sum on the diagonal no longer cancels the two
    # off-diagonal entries, and the stored C matrix gains a rank (a capacitor of about 1e-22 F to ground); the
    # unsummed stamps, summed exactly, keep the circuit's rank.
    import netdae
    from netdae.analyses.prepared import prepare

    text = "caps\nV1 a 0 1\nR1 a b 1k\nC1 b c 1e-6\nC2 c d 1e-9\nR2 d 0 1k\nR3 c 0 1k\n.tran 1n 1u\n.end\n"
    system = prepare(netdae.load(text)).system
    E, H = system._E.toarray(), system._H.toarray()
    stored = exact_structure(E, H)
    circuit = exact_structure(E, H, terms=system.linear_terms)
    assert circuit.n_finite == 2  # C1 and C2
    assert stored.n_finite == 3  # the residue's spurious state


def test_a_resistor_is_the_exact_reciprocal_of_its_resistance():
    """A CCVS of 1k sensing a 0 V source in series with a 1k resistor, its output across both: v(2) = 1k
    i(v2) = v(2), a loop gain of exactly 1, so the circuit is singular (no unique DC solution). The stored
    conductance is 1/1000 rounded, and 1000 times it is not 1: the exact structure of the stored values was
    regular, and `netdae index` called the singular pencil 'uncertain: regular in exact arithmetic'. The
    stamps carry the resistance a conductance is the reciprocal of, and the exact structure reads 1/R."""
    import netdae
    from netdae.analyses.index import analyze_index
    from netdae.analyses.prepared import prepare

    text = ("ccvs loop of gain 1\nV1 in 0 1\nR1 in 2 3k\nH1 2 0 V2 1k\nV2 2 3 0\nR3 3 0 1k\n.op\n.end\n")
    system = prepare(netdae.load(text)).system
    E, H = system._E.toarray(), system._H.toarray()
    assert exact_structure(E, H, terms=system.linear_terms).regular is False
    # the value rounded, read as stored, is regular: the reciprocal is what decides it
    assert exact_structure(E, H, terms=tuple(t[:3] for t in system.linear_terms)).regular is True
    rep = analyze_index(netdae.load(text))
    assert rep.regular is False and not rep.pencil.disputed
    assert not any("uncertain" in m or "regular in exact arithmetic" in m for m in rep.messages)
    # a gain of 999 is regular, in both arithmetics
    other = prepare(netdae.load(text.replace("V2 1k", "V2 999"))).system
    assert exact_structure(other._E.toarray(), other._H.toarray(), terms=other.linear_terms).regular is True
