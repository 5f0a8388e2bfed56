"""Impasse points: where a circuit's algebraic solution ends and it snaps to another state.

A current ramp into a node whose current-voltage law is N-shaped, ``i = v^3 - 3 v``
(a resistor and a cubic B source), with no capacitance: ``v`` follows the root of
``v^3 - 3 v = I(t)`` on its branch until ``I = 2``, where the branch ``v < -1`` ends
(the fold at ``v = -1``); no solution is near there any more, and the circuit jumps to
the other branch, ``v = 2``. A BDF method sees Newton fail on every step size at the
fold. netdae then solves two implicit-Euler steps right of it with its steady-state
solver (damped Newton, limiting, gmin and source stepping), records the jump and
restarts there: ngspice's behaviour on such circuits (it steps over the fold), with the
jump stated. Checked against the roots of the cubic, in both integrators.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae

FOLD = """N-shaped conductance driven by a current ramp
I1 0 n PWL(0 -3 1 3)
R1 n 0 1
B1 n 0 I = v(n)*v(n)*v(n) - 4*v(n)
.nodeset v(n)=-2
.tran 1m 1
.end
"""
T_FOLD = 5.0 / 6.0  # I(t) = -3 + 6 t reaches the fold's current 2


def branch_root(current: float, lower: bool) -> float:
    """The real root of v^3 - 3 v = current on the lower (v < -1) or upper (v > 1) branch."""
    roots = np.roots([1.0, 0.0, -3.0, -current])
    real = roots[np.abs(roots.imag) < 1e-9].real
    return float(real.min() if lower else real.max())


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_the_solution_jumps_at_the_fold_and_follows_the_other_branch(engine, monkeypatch):
    if engine == "python":
        monkeypatch.setenv("NETDAE_ENGINE", "python")
    res = netdae.simulate(netdae.load(FOLD), reltol=1e-6)
    assert res.ok, res.message
    assert res.stats["integrator"]["impasses"] >= 1
    assert any("impasse" in note for note in res.notes)
    jumps = [t for t, names in res.transient.jumps if "v(n)" in names and t > 0.5]
    assert jumps and abs(jumps[0] - T_FOLD) < 1e-3  # where Newton can no longer follow the branch
    t = np.array([0.1, 0.4, 0.8, 0.9, 0.95, 1.0])
    v = res.dense(t)["v(n)"]
    expect = [branch_root(-3.0 + 6.0 * tk, lower=tk < jumps[0]) for tk in t]
    np.testing.assert_allclose(v, expect, rtol=1e-4)


def test_an_operating_point_newton_cannot_reach_is_a_convergence_error_not_a_singular_matrix():
    # -1 A into (v - 1)^2 >= 0 has no solution; Newton's iterates meet the zero slope at v = 1, where
    # the Jacobian is singular, but it is regular where they start: no singular circuit, no convergence
    with pytest.raises(netdae.ConvergenceError, match="did not converge .* .nodeset values close to"):
        netdae.run(netdae.load("no solution\nI1 0 n -1\nB1 n 0 I = (v(n)-1)*(v(n)-1)\n.op\n.end\n"))


def test_a_smooth_circuit_has_no_impasse():
    res = netdae.simulate(netdae.load(FOLD.replace("PWL(0 -3 1 3)", "PWL(0 -3 1 1.9)")), reltol=1e-6)
    assert res.ok and res.stats["integrator"]["impasses"] == 0


def test_the_right_limit_at_a_fold_leaves_it_by_pseudo_transient_continuation():
    # left value on the fold's branch end, a hair past the fold's time: no root near it (v^3 - 3 v = I > 2 has
    # only v > 2), and Newton, gmin and source stepping (which follows the lower branch to the same fold) stall
    # there; only at an impasse is the pseudo-time's continuation tried, and it carries v to the upper branch
    from netdae.dae.bdf import right_limit
    from netdae.mna import MODE_TRAN, assemble

    system = assemble(netdae.load(FOLD), mode=MODE_TRAN, tstep=1e-3, tstop=1.0)
    t = T_FOLD + 2e-12
    x = np.array([-1.00000024])
    high = np.zeros(1, dtype=bool)
    plain = right_limit(system, t, x, 3.47e-12, high, 1e-6, 1e-6, 1e-12)
    at_impasse = right_limit(system, t, x, 3.47e-12, high, 1e-6, 1e-6, 1e-12, impasse=True)
    assert at_impasse[0] is not None, at_impasse[3]
    want = branch_root(-3.0 + 6.0 * (t + 3.47e-12), lower=False)
    assert at_impasse[0][0] == pytest.approx(want, rel=1e-6)
    assert plain[0] is None  # what the impasse met before (the homotopies alone)


def _crawling_dae(bad: dict):
    """``y' = -y``, ``0 = cos t - z``, to which ``z^2 + 1`` is added past ``bad["t"]``.

    No real root is left there (``z^2 - z + 1 + cos t > 0``): Newton fails on every
    step that ends past that time, however short, the failure an impasse meets. The
    fake right limit below moves that time a few steps further each time, as a model
    whose state is stale after the jump would (a crawl).
    """
    from netdae.dae.system import FunctionDae

    def phi(x, t):
        extra = x[1] ** 2 + 1.0 if t > bad["t"] else 0.0
        return np.array([-x[0], np.cos(t) - x[1] + extra])

    def dphi(x, t):
        return np.array([[-1.0, 0.0], [0.0, -1.0 + (2.0 * x[1] if t > bad["t"] else 0.0)]])

    return FunctionDae(2, lambda x: np.array([x[0], 0.0]), lambda x: np.diag([1.0, 0.0]), phi, dphi,
                       names=["y", "z"])


def test_impasses_that_make_no_progress_end_in_a_failure_not_a_crawl(monkeypatch):
    # each impasse got its tries counted from 1 again when its t differed from the last one by a few
    # ulps: 23,000 impasses a few ulps apart ran for ten minutes on a Schmitt trigger. A failure within
    # IMPASSE_NEAR of the last impasse's steps is now one more try at it
    from netdae.dae.bdf import IMPASSE_TRIES, integrate, stepper

    bad = {"t": 0.5}
    calls = []

    def fake_right_limit(system, t, x, eps, *args, **kwargs):
        calls.append(eps)
        assert len(calls) <= 3 * IMPASSE_TRIES, "impasses crawl on without end"
        bad["t"] = t + 3.0 * eps  # steps succeed a little further, then fail again
        return np.array([np.exp(-(t + eps)), np.cos(t + eps)]), 1, 1, ""

    monkeypatch.setattr(stepper, "right_limit", fake_right_limit)
    res = integrate(_crawling_dae(bad), (0.0, 1.0), np.array([1.0, 1.0]), rtol=1e-6)
    assert not res.ok and "Newton" in res.message
    assert len(calls) == IMPASSE_TRIES


def test_the_compiled_loop_counts_a_crawl_of_impasses_as_one_place():
    # the compiled loop's rule (bdf_loop._impasse), called as the loop calls it: the first impasse at t,
    # then failures a few of its steps later escalate the tries (ten times the step each); after
    # IMPASSE_TRIES the failure stands. A failure far from the last impasse starts a new count
    from netdae.dae.bdf import IMPASSE_NEAR, IMPASSE_TRIES
    from netdae.dae.compiled import bdf_loop as L

    F, I = np.zeros(L.N_F), np.zeros(L.N_I, dtype=np.int64)
    F[L.F_IMPASSE_T], F[L.F_H] = np.nan, 1e-12
    t, steps = 0.5, []
    for _ in range(IMPASSE_TRIES):
        assert L._impasse(F, I, t)
        steps.append(F[L.F_RL_EPS])
        t += 3.0 * F[L.F_RL_EPS]  # a little progress, then the next failure
    assert not L._impasse(F, I, t)  # was a fresh impasse each time: tries back at 1, without end
    np.testing.assert_allclose(steps[1:], 10.0 * np.array(steps[:-1]), rtol=1e-12)
    assert steps[0] == 1e-12 and int(I[L.I_IMPASSE_TRIES]) == IMPASSE_TRIES
    far = float(F[L.F_IMPASSE_T]) + 2.0 * IMPASSE_NEAR * F[L.F_IMPASSE_EPS]
    assert L._impasse(F, I, far) and int(I[L.I_IMPASSE_TRIES]) == 1 and F[L.F_RL_EPS] == 1e-12
