"""An independent integrator as oracle: SUNDIALS IDA on the same MNA residual of a nonlinear circuit.

IDA (through scikit-sundae) integrates ``F(t, x, x') = E(x) x' - phi(x, t) = 0``
of netdae's own MnaSystem for a diode clipper with junction and diffusion
charges; netdae's transient must agree with a tight IDA reference within its
tolerance, and be about as accurate as IDA at the same tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest

import netdae
from netdae.analyses.op import solve_operating_point
from netdae.analyses.prepared import prepare
from netdae.analyses.tran import transient
from netdae.mna import MODE_TRAN

sun = pytest.importorskip("sksundae")

CLIPPER = """diode clipper with charge storage
V1 in 0 SIN(0 5 10k)
R1 in a 1k
D1 a 0 dmod
C1 a 0 1n
R2 a 0 10k
.model dmod d (is=1e-14 n=1.5 rs=5 cjo=20p vj=0.7 m=0.4 tt=20n)
.tran 1u 200u
.end
"""
TSTOP = 200e-6


@pytest.fixture(scope="module")
def problem():
    circuit = netdae.load(CLIPPER)
    prepared = prepare(circuit, mode=MODE_TRAN, tstep=1e-6, tstop=TSTOP)
    system = prepared.system
    x0 = solve_operating_point(prepared, transient=True).x
    pattern = system.pattern

    def resfn(t, y, yp, res):
        ev = system.evaluate(y, t, jacobian=True)
        res[:] = pattern.matrix(ev.dq) @ yp - ev.phi

    ev0 = system.evaluate(x0, 0.0, jacobian=True)
    E0 = pattern.matrix(ev0.dq).toarray()
    H0 = pattern.matrix(ev0.dphi).toarray()
    algebraic = np.flatnonzero(~np.any(E0 != 0.0, axis=0))
    # consistent x'(0) of this index-1 DAE, by hand: differential rows E x' = phi, algebraic rows
    # differentiated, H x' + c'(0) = 0
    alg_rows = ~np.any(E0 != 0.0, axis=1)
    M = np.where(alg_rows[:, None], H0, E0)
    rhs = np.where(alg_rows, -system.source(0.0, 1), ev0.phi)
    xp0 = np.linalg.solve(M, rhs)
    return circuit, system, x0, xp0, resfn, algebraic


def ida(problem, rtol, times):
    _, system, x0, xp0, resfn, algebraic = problem
    atol = np.where(system.kinds == 0, 1e-6, 1e-12) * (rtol / 1e-3)
    solver = sun.ida.IDA(resfn, algebraic_idx=algebraic, rtol=rtol, atol=atol, max_step=1e-6,
                         max_num_steps=500000)
    sol = solver.solve(times, x0.copy(), xp0.copy())
    assert sol.success, sol.message
    return sol.y


@pytest.fixture(scope="module")
def reference(problem):
    """IDA at reltol 1e-8 (about 20 s): the reference both tolerances are measured against."""
    times = np.linspace(0.0, TSTOP, 801)
    return times, ida(problem, 1e-8, times)


@pytest.mark.slow
@pytest.mark.parametrize("rtol", [1e-4, 1e-6])
def test_diode_clipper_agrees_with_ida(problem, reference, rtol):
    circuit, system = problem[:2]
    times, reference = reference
    same_tol = ida(problem, rtol, times)
    res = transient(circuit, reltol=rtol, vntol=1e-6 * rtol / 1e-3, abstol=1e-12 * rtol / 1e-3)
    assert res.ok, res.message
    ours = np.column_stack([res.dense(times)[nm] for nm in system.names])
    for k, name in enumerate(system.names):
        if not name.startswith("v("):
            continue
        scale = np.ptp(reference[:, k])
        err_ours = np.max(np.abs(ours[:, k] - reference[:, k])) / scale
        err_ida = np.max(np.abs(same_tol[:, k] - reference[:, k])) / scale
        assert err_ours < 30 * rtol, (name, err_ours)
        assert err_ours < 10 * max(err_ida, rtol), (name, err_ours, err_ida)
