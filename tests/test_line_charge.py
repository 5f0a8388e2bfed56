"""Operating points of nets that float at DC behind transmission lines: the charge a line holds at DC is
conserved with the capacitors' (netdae.analyses.op.conservation_laws, Delays.C), against closed forms and the
transient's own charge conservation; and the DC rank decision that finds such nets (steady.jacobian_rank)."""

import numpy as np
import pytest

import netdae

_T_NET = """a floating net through a lossless line
V1 in 0 {source}
C1 in a 1p
T1 a 0 b 0 z0=50 td=1n
C2 b 0 2p
{analysis}
.end
"""

_CPL = """three coupled conductors, the middle one floating
V1 a 0 {source}
R1 a 1 50
R3 3 0 50
RL1 4 0 50
RL3 6 0 50
p1 1 2 3 0 4 5 6 0 pline
.model pline cpl
+C = 1.2P -0.4P -0.05P
+          1.3P -0.4P
+                1.2P
+L = 0.8E-7 0.3E-7 0.1E-7
+           0.8E-7 0.3E-7
+                  0.8E-7
+R = 0.2 0 0
+      0.2 0
+        0.2
+G = 0 0 0 0 0 0
+length = 2
{analysis}
.end
"""


def _op(text):
    r = netdae.run(netdae.load(text))[0]
    assert r.analysis == "op" and r.ok, r.message
    return {k: float(v[0]) for k, v in r.signals.items()}, r


def test_a_net_behind_a_lossless_line_shares_its_charge_with_the_line():
    # nodes a and b are joined by T1 at DC and attached to the rest only through C1 and C2: zero total charge,
    # the line's td/z0 = 20 pF included, gives v = C1 V / (C1 + C2 + td/z0) = 1/23 (1/3 without the line)
    op, r = _op(_T_NET.format(source="DC 1", analysis=".op"))
    assert op["v(a)"] == pytest.approx(1.0 / 23.0, rel=1e-12)
    assert op["v(b)"] == pytest.approx(1.0 / 23.0, rel=1e-12)
    assert any("charge the transmission lines hold" in m for m in r.notes)


def test_the_transient_conserves_the_same_charge():
    # an independent oracle: ramp the source slowly from 0 (a consistent zero-charge start) and let the
    # transient's line carry the charge in its waves; the floating net settles (ringing without loss about) 1/23
    res = netdae.run(netdae.load(_T_NET.format(source="PWL(0 0 200n 1)", analysis=".tran 1n 400n")))[0]
    assert res.ok, res.message
    t = res.axes["time"]
    va = res.signals["v(a)"]
    tail = t > 300e-9
    assert np.mean(va[tail]) == pytest.approx(1.0 / 23.0, rel=1e-2)


def test_a_floating_conductor_of_coupled_lines_takes_the_charge_neutral_potential():
    # conductor 1 carries the DC current from a (1 V) through 50 ohm, its 0.4 ohm and 50 ohm to ground, conductor 3
    # is grounded through its terminations, conductor 2 floats: its charge len * (C21 avg(v1) + C22 v2) = 0, with
    # avg(v1) the mean of conductor 1's end voltages (its voltage is linear along the line)
    op, r = _op(_CPL.format(source="DC 1", analysis=".op"))
    i = 1.0 / (50 + 0.4 + 50)
    v_near, v_far = 1.0 - 50 * i, 50 * i
    assert op["v(1)"] == pytest.approx(v_near, rel=1e-9) and op["v(4)"] == pytest.approx(v_far, rel=1e-9)
    expected = 0.4 / 1.3 * (v_near + v_far) / 2
    assert op["v(2)"] == pytest.approx(expected, rel=1e-9)
    assert op["v(5)"] == pytest.approx(expected, rel=1e-9)
    note = next(m for m in r.notes if m.startswith("the DC equations"))
    assert "of p1's realisation" in note and "p1#" not in note


def test_the_rank_decision_of_the_floating_conductor_is_clear():
    # Ward's balancing of this DC matrix (the line's modal sources beside 50 ohm terminations) dropped three
    # singular values, one within 1 % of its tolerance; the max-equilibrated matrix shows the one null direction
    from netdae.analyses.op import solve_operating_point
    from netdae.dae import steady
    from netdae.analyses.prepared import prepare

    seen = []
    original = steady.jacobian_rank

    def spy(mat, what="rank", **options):
        rank = original(mat, what, **options)
        seen.append(rank)
        return rank

    steady.jacobian_rank = spy
    try:
        prepared = prepare(netdae.load(_CPL.format(source="DC 1", analysis=".op")))
        solve_operating_point(prepared)
    finally:
        steady.jacobian_rank = original
    assert seen, "the singular DC matrix was judged"
    rank = seen[0]
    n = rank.decision.shape[0]
    assert rank.rank == n - 1 and rank.right.shape == (n, 1) and rank.left.shape == (n, 1)
    assert rank.decision.margin > 100


def test_the_verdict_alone_is_the_same_decision():
    # jacobian_rank(vectors=False), used inside nonlinear solves, decides as the full SVD does
    from netdae.dae.steady import jacobian_rank

    rng = np.random.default_rng(5)
    for deficiency in (0, 1, 3):
        A = rng.standard_normal((30, 30)) * np.logspace(-6, 3, 30)[None, :]
        if deficiency:
            A[:, :deficiency] = A[:, deficiency:2 * deficiency] * 2.0 ** np.arange(1, deficiency + 1)
        full, fast = jacobian_rank(A), jacobian_rank(A, vectors=False)
        assert full.rank == fast.rank == 30 - deficiency
        assert full.decision.tol == fast.decision.tol
        assert full.right.shape == (30, deficiency) and fast.right.shape == (30, 0)
