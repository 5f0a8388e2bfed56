"""Test problems for the BDF integrator, built by hand from Kirchhoff's laws.

Each builder returns a :class:`~netdae.dae.system.DaeSystem` together with
what a test needs to judge the answer (closed forms, index vectors). The
tests at the end check the builders themselves against hand computations,
so a wrong builder cannot make an integrator test pass.

Sign conventions as in ngspice: ``i(v1)`` flows from the + node through the
source to the - node; every KCL row reads "capacitor currents = sum of the
other currents entering the node".
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from netdae.dae.system import KIND_CURRENT, KIND_OTHER, KIND_VOLTAGE, FunctionDae, LinearDae


class Source:
    """A scalar input waveform with derivatives and breakpoints."""

    def __init__(self, value, derivative=None, breakpoints=()):
        self.value = value
        self.derivative = derivative
        self.points = np.asarray(breakpoints, dtype=float)

    def __call__(self, t):
        return self.value(t)


def sine(amplitude=1.0, freq=1e3, offset=0.0):
    w = 2 * np.pi * freq
    return Source(lambda t: offset + amplitude * np.sin(w * t), lambda t: amplitude * w * np.cos(w * t))


def pwl(times, values):
    """Piecewise-linear input through (times, values), constant outside."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    slopes = np.diff(values) / np.diff(times)

    def deriv(t):
        i = np.searchsorted(times, t, side="right") - 1
        return slopes[i] if 0 <= i < slopes.size else 0.0

    return Source(lambda t: float(np.interp(t, times, values)), deriv, times)


def rc_ladder(sections, r=1e3, c=1e-9, source=None):
    """V source -> R -> node 1 (C to ground) -> R -> node 2 (C) ... -> node N (C).

    Unknowns: v(0) .. v(N) (node 0 is the source node), i(v1): n = N + 2.
    """
    n_nodes = sections + 1
    n = n_nodes + 1
    iv = n_nodes
    g = 1.0 / r
    a = np.arange(sections)
    b = a + 1
    rows = np.concatenate([a, a, b, b, [0, iv]])
    cols = np.concatenate([a, b, b, a, [iv, 0]])
    vals = np.concatenate([np.full(sections, -g), np.full(sections, g), np.full(sections, -g),
                           np.full(sections, g), [-1.0, 1.0]])
    H = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    e = np.zeros(n)
    e[1:n_nodes] = c
    E = sp.diags(e).tocsc()
    src = source if source is not None else sine()
    unit = np.zeros(n)
    unit[iv] = -1.0

    def cfun(t, derivative=0):
        if derivative == 0:
            return unit * src(t)
        if derivative == 1:
            return unit * src.derivative(t)
        raise ValueError("only the first derivative is available")

    names = [f"v({k})" for k in range(n_nodes)] + ["i(v1)"]
    kinds = [KIND_VOLTAGE] * n_nodes + [KIND_CURRENT]
    bp = (lambda t0, t1: src.points[(src.points >= t0) & (src.points <= t1)]) if src.points.size else None
    return LinearDae(E, H, cfun, names=names, kinds=kinds, breakpoints=bp)


def rc_lowpass(r=1e3, c=1e-6, source=None):
    """V source at node in, R from in to out, C from out to ground: 3 unknowns (index 1)."""
    g = 1.0 / r
    E = np.zeros((3, 3))
    E[1, 1] = c
    # x = (v(in), v(out), i(v1))
    H = np.array([[-g, g, -1.0], [g, -g, 0.0], [1.0, 0.0, 0.0]])
    src = source if source is not None else sine()
    bp = (lambda t0, t1: src.points[(src.points >= t0) & (src.points <= t1)]) if src.points.size else None
    return LinearDae(E, H, lambda t, derivative=0: np.array([0.0, 0.0, -src(t)]),
                     names=["v(in)", "v(out)", "i(v1)"], kinds=[KIND_VOLTAGE, KIND_VOLTAGE, KIND_CURRENT],
                     breakpoints=bp)


def lowpass_sine_exact(t, r, c, amplitude, freq, v0=0.0):
    """v(out) of :func:`rc_lowpass` driven by ``amplitude sin(w t)`` from v(out)(0) = v0."""
    tau = r * c
    w = 2 * np.pi * freq
    a = amplitude / (1 + (w * tau) ** 2)
    steady = a * (np.sin(w * t) - w * tau * np.cos(w * t))
    return steady + (v0 + a * w * tau) * np.exp(-t / tau)


def v_parallel_c(c=1e-6, g=1e-3, source=None):
    """V source parallel to a capacitor C and a conductance G (a CV loop: index 2).

    Unknowns x = (v(1), i(v1)); exactly v(1) = V(t), i(v1) = -C V'(t) - G V(t).
    Index vector: v(1) is index-1 algebraic, i(v1) index 2.
    """
    E = np.array([[c, 0.0], [0.0, 0.0]])
    H = np.array([[-g, -1.0], [1.0, 0.0]])
    src = source if source is not None else sine()
    bp = (lambda t0, t1: src.points[(src.points >= t0) & (src.points <= t1)]) if src.points.size else None
    dae = LinearDae(E, H, lambda t, derivative=0: np.array([0.0, -src(t)]), names=["v(1)", "i(v1)"],
                    kinds=[KIND_VOLTAGE, KIND_CURRENT], breakpoints=bp)
    return dae, np.array([1, 2])


def differentiator(l_ind=1e-3, g=1e-3, source=None):
    """The differentiator circuit of the lecture notes, Section 1.3.

    V(t) at node 1; conductance G from node 1 to node 2; inductor L from node 2
    to node 3; ideal op-amp with + input grounded, - input at node 2, output
    at node 3. Unknowns x = (u1, u2, u3, I_A, I_L, I_V) with
    E = diag(0, 0, 0, 0, L, 0) and

        0 = -G u1 + G u2 - I_V          (KCL node 1)
        0 =  G u1 - G u2 - I_L          (KCL node 2, op-amp input draws no current)
        0 =  I_L + I_A                  (KCL node 3, I_A the op-amp output current)
        0 =  u2                         (ideal op-amp: virtual ground)
      L I_L' = u2 - u3                  (inductor)
        0 =  u1 - V(t)                  (source)

    Solution: u1 = V, u2 = 0, I_L = G V, I_A = -G V, I_V = -G V and the output
    u3 = -L G V'(t), which depends on the derivative of I_L: index 2.
    """
    E = np.zeros((6, 6))
    E[4, 4] = l_ind
    H = np.zeros((6, 6))
    H[0, [0, 1, 5]] = [-g, g, -1.0]
    H[1, [0, 1, 4]] = [g, -g, -1.0]
    H[2, [4, 3]] = [1.0, 1.0]
    H[3, 1] = 1.0
    H[4, [1, 2]] = [1.0, -1.0]
    H[5, 0] = 1.0
    src = source if source is not None else sine()
    bp = (lambda t0, t1: src.points[(src.points >= t0) & (src.points <= t1)]) if src.points.size else None
    names = ["v(1)", "v(2)", "v(3)", "i(xa)", "i(l1)", "i(v1)"]
    kinds = [KIND_VOLTAGE] * 3 + [KIND_CURRENT] * 3
    dae = LinearDae(E, H, lambda t, derivative=0: np.array([0, 0, 0, 0, 0, -src(t)], dtype=float),
                    names=names, kinds=kinds, breakpoints=bp)
    return dae, np.array([1, 1, 2, 1, 1, 1])


def differentiator_exact(t, l_ind, g, src):
    v = np.array([src(tt) for tt in np.atleast_1d(t)])
    dv = np.array([src.derivative(tt) for tt in np.atleast_1d(t)])
    return np.column_stack([v, 0 * v, -l_ind * g * dv, -g * v, g * v, -g * v])


def pendulum_ggl(m=1.0, length=1.0, grav=9.81):
    """Planar pendulum (1.15) in the GGL formulation (2.48): index 2.

    x = (r1, r2, a, v1, v2, v3, l1, l2, s1, s2) with q-positions p = (r1, r2, a),
    velocities v, multipliers lambda = (l1, l2), tau = (s1, s2):

        p' = v - G(p)^T tau
        M v' = f - G(p)^T lambda,    f = (0, -m grav, 0),  M = diag(m, m, m l^2 / 12)
        0 = G(p) v
        0 = g(p) = (r1 - l/2 cos a, r2 - l/2 sin a)

    Charge form: q(x) = (p, M v, 0, 0, 0, 0); index vector 0 for p, v and 2
    for the multipliers.
    """
    half = 0.5 * length
    mass = np.array([m, m, m * length ** 2 / 12.0])

    def gmat(p):
        a = p[2]
        return np.array([[1.0, 0.0, half * np.sin(a)], [0.0, 1.0, -half * np.cos(a)]])

    def q(x):
        out = np.zeros(10)
        out[:3] = x[:3]
        out[3:6] = mass * x[3:6]
        return out

    def dq(x):
        d = np.zeros((10, 10))
        d[[0, 1, 2], [0, 1, 2]] = 1.0
        d[[3, 4, 5], [3, 4, 5]] = mass
        return d

    def phi(x, t):
        p, v, lam, tau = x[:3], x[3:6], x[6:8], x[8:10]
        gm = gmat(p)
        out = np.empty(10)
        out[:3] = v - gm.T @ tau
        out[3:6] = np.array([0.0, -m * grav, 0.0]) - gm.T @ lam
        out[6:8] = gm @ v
        a = p[2]
        out[8:10] = [p[0] - half * np.cos(a), p[1] - half * np.sin(a)]
        return out

    def dphi(x, t):
        p, v, lam, tau = x[:3], x[3:6], x[6:8], x[8:10]
        a = p[2]
        gm = gmat(p)
        dg_da = np.array([[0.0, 0.0, half * np.cos(a)], [0.0, 0.0, half * np.sin(a)]])
        d = np.zeros((10, 10))
        d[0:3, 3:6] = np.eye(3)
        d[0:3, 8:10] = -gm.T
        d[0:3, 2] += -dg_da.T @ tau
        d[3:6, 6:8] = -gm.T
        d[3:6, 2] += -dg_da.T @ lam
        d[6:8, 3:6] = gm
        d[6:8, 2] += dg_da @ v
        d[8:10, 0:3] = gm
        return d

    names = ["r1", "r2", "alpha", "v1", "v2", "v3", "lambda1", "lambda2", "tau1", "tau2"]
    kinds = [KIND_OTHER] * 10
    dae = FunctionDae(10, q, dq, phi, dphi, names=names, kinds=kinds)
    index = np.array([0, 0, 0, 0, 0, 0, 2, 2, 2, 2])

    def consistent(alpha0, omega0):
        """Consistent x0 for angle alpha0 and angular velocity omega0 (hand computation)."""
        p = np.array([half * np.cos(alpha0), half * np.sin(alpha0), alpha0])
        v = np.array([-half * np.sin(alpha0), half * np.cos(alpha0), 1.0]) * omega0
        gm = gmat(p)
        # acceleration-level constraint: G a + kappa = 0, kappa = dG/dt v = (half cos a w^2, half sin a w^2)
        kappa = np.array([half * np.cos(alpha0), half * np.sin(alpha0)]) * omega0 ** 2
        kkt = np.zeros((5, 5))
        kkt[:3, :3] = np.diag(mass)
        kkt[:3, 3:] = gm.T
        kkt[3:, :3] = gm
        rhs = np.concatenate([[0.0, -m * grav, 0.0], -kappa])
        sol = np.linalg.solve(kkt, rhs)
        return np.concatenate([p, v, sol[3:], [0.0, 0.0]])

    def energy(x):
        return 0.5 * np.sum(mass * x[..., 3:6] ** 2, axis=-1) + m * grav * x[..., 1]

    def constraints(x):
        a = x[..., 2]
        pos = np.stack([x[..., 0] - half * np.cos(a), x[..., 1] - half * np.sin(a)], axis=-1)
        vel = np.stack([x[..., 3] + half * np.sin(a) * x[..., 5], x[..., 4] - half * np.cos(a) * x[..., 5]],
                       axis=-1)
        return pos, vel

    return dae, index, consistent, energy, constraints


def van_der_pol(eps):
    """(1.2) in Lienard coordinates: y' = z, eps z' = -y + z - z^3/3 (x = (y, z))."""

    def q(x):
        return np.array([x[0], eps * x[1]])

    def dq(x):
        return np.diag([1.0, eps])

    def phi(x, t):
        y, z = x
        return np.array([z, -y + z - z ** 3 / 3.0])

    def dphi(x, t):
        return np.array([[0.0, 1.0], [-1.0, 1.0 - x[1] ** 2]])

    return FunctionDae(2, q, dq, phi, dphi, names=["y", "z"])


def van_der_pol_reduced_time(z):
    """Time at which the reduced DAE (2.6) started at z = 2 reaches z (1 < z <= 2).

    From y' = z, y = z - z^3/3: (1 - z^2) z' = z, so t(z) = ln z - z^2/2 - (ln 2 - 2).
    """
    return np.log(z) - z ** 2 / 2.0 - (np.log(2.0) - 2.0)


# --------------------------------------------------------------------------- checks of the builders
def test_rc_ladder_dc_solution_is_the_source_voltage():
    dae = rc_ladder(5, source=Source(lambda t: 2.0, lambda t: 0.0))
    # steady state: all nodes at 2 V, no current: H x + c = 0
    x = np.concatenate([np.full(6, 2.0), [0.0]])
    ev = dae.evaluate(x, 0.0)
    np.testing.assert_allclose(ev.phi, 0.0, atol=1e-15)


def test_v_parallel_c_exact_solution_satisfies_the_equations():
    c, g = 2e-6, 1e-3
    src = sine(1.5, 200.0)
    dae, _ = v_parallel_c(c, g, src)
    for t in (0.0, 1.3e-3, 4e-3):
        x = np.array([src(t), -c * src.derivative(t) - g * src(t)])
        ev = dae.evaluate(x, t)
        # E x' = phi with x' = (V', anything)
        np.testing.assert_allclose(ev.phi, [c * src.derivative(t), 0.0], atol=1e-14)


def test_differentiator_exact_solution_satisfies_the_equations():
    l_ind, g = 2e-3, 5e-4
    src = sine(1.0, 100.0)
    dae, _ = differentiator(l_ind, g, src)
    w = 2 * np.pi * 100.0
    for t in (0.0, 2.1e-3):
        x = differentiator_exact(t, l_ind, g, src)[0]
        ev = dae.evaluate(x, t)
        # only the inductor row is dynamic: L I_L' = L G V'
        expected = np.zeros(6)
        expected[4] = l_ind * g * w * np.cos(w * t)
        np.testing.assert_allclose(ev.phi, expected, atol=1e-13)


def test_pendulum_consistent_values_satisfy_all_constraints():
    dae, _, consistent, _, constraints = pendulum_ggl()
    x0 = consistent(-1.0, 0.7)
    pos, vel = constraints(x0)
    np.testing.assert_allclose(pos, 0.0, atol=1e-15)
    np.testing.assert_allclose(vel, 0.0, atol=1e-15)
    # the Jacobian of the hand-written phi agrees with finite differences
    eps = 1e-7
    jac = dae._dphi(x0, 0.0)
    fd = np.column_stack([(dae._phi(x0 + eps * e, 0.0) - dae._phi(x0 - eps * e, 0.0)) / (2 * eps)
                          for e in np.eye(10)])
    np.testing.assert_allclose(jac, fd, atol=1e-6)


def test_van_der_pol_reduced_time_matches_quadrature():
    from scipy.integrate import quad

    z = 1.3
    t_quad, _ = quad(lambda s: (s ** 2 - 1.0) / s, z, 2.0)
    assert abs(van_der_pol_reduced_time(z) - t_quad) < 1e-12
