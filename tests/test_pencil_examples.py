"""Hand-built linear(ized) DAEs with known structure, shared by the pencil tests.

Each builder writes ``E x' = H x + B u`` from the equations (no netdae code
involved); the tests in this file check the builders against closed-form
solutions, so the other test files can rely on them.

- the differentiator circuit of the lecture notes, Section 1.3 (ideal op-amp:
  u3 = -L G V'), its finite-gain version and k cascaded stages;
- the planar pendulum (1.15) in its index-3 form and the index-1 (2.42),
  index-2 (2.47) and GGL (2.48) formulations, linearized by complex-step
  differentiation of the residual (exact to rounding);
- semi-explicit systems of index 1, 2 and 3.
"""

from __future__ import annotations

import numpy as np
import pytest

# ---------------------------------------------------------------------------
# circuits
# ---------------------------------------------------------------------------


def differentiator_cascade(k: int, G: float = 1e-3, L: float = 1e-3, gain: float | None = None):
    """k inverting R-L differentiators in cascade, driven by V(t) at node u1.

    Stage j: resistor G from its input node a_j (u1 or o_{j-1}) to the inverting
    node m_j, inductor L from m_j to the output o_j, op-amp output current ia_j
    into o_j. Ideal op-amp (gain None): m_j = 0. Finite gain A: o_j = -A m_j.

    Unknowns ``u1, (m_j, o_j, ia_j, il_j)_j, iv``; equations one per unknown:
    KCL at u1, m_j, o_j; op-amp; inductor ``L il_j' = m_j - o_j``; source
    ``0 = u1 - V``. Returns ``E, H, B, names`` with ``c = B V``.
    """
    names = ["u1"]
    for j in range(1, k + 1):
        names += [f"m{j}", f"o{j}", f"ia{j}", f"il{j}"]
    names.append("iv")
    ix = {nm: i for i, nm in enumerate(names)}
    n = len(names)
    E = np.zeros((n, n))
    H = np.zeros((n, n))
    B = np.zeros((n, 1))
    row = iter(range(n))

    def eq():
        return next(row)

    r = eq()  # KCL u1: 0 = -G (u1 - m1) - iv
    H[r, ix["u1"]] += -G
    H[r, ix["m1"]] += G
    H[r, ix["iv"]] += -1.0
    for j in range(1, k + 1):
        a = "u1" if j == 1 else f"o{j - 1}"
        m, o, ia, il = f"m{j}", f"o{j}", f"ia{j}", f"il{j}"
        r = eq()  # KCL m_j: 0 = G (a - m) - il
        H[r, ix[a]] += G
        H[r, ix[m]] += -G
        H[r, ix[il]] += -1.0
        r = eq()  # KCL o_j: 0 = il + ia - G (o - m_{j+1})
        H[r, ix[il]] += 1.0
        H[r, ix[ia]] += 1.0
        if j < k:
            H[r, ix[o]] += -G
            H[r, ix[f"m{j + 1}"]] += G
        r = eq()  # op-amp
        if gain is None:
            H[r, ix[m]] = 1.0  # 0 = m
        else:
            H[r, ix[m]] = -gain  # 0 = -A m - o
            H[r, ix[o]] = -1.0
        r = eq()  # inductor: L il' = m - o
        E[r, ix[il]] = L
        H[r, ix[m]] = 1.0
        H[r, ix[o]] = -1.0
    r = eq()  # source: 0 = u1 - V
    H[r, ix["u1"]] = 1.0
    B[r, 0] = -1.0
    return E, H, B, tuple(names)


def sine_derivative(omega: float, t, order: int):
    """d^order/dt^order sin(omega t)."""
    return omega**order * np.sin(omega * np.asarray(t, dtype=float) + order * np.pi / 2)


def cascade_solution(k: int, G: float, L: float, omega: float, t, derivative: int = 0) -> np.ndarray:
    """Closed-form solution (and its time derivatives) of the ideal cascade for V = sin(omega t).

    o_j = (-L G)^j V^(j), il_j = G o_{j-1} (o_0 = V), ia_j = -il_j + G o_j (j < k),
    ia_k = -il_k, m_j = 0, u1 = V, iv = -G V.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    _, _, _, names = differentiator_cascade(k, G, L)
    ix = {nm: i for i, nm in enumerate(names)}
    x = np.zeros((len(names), t.size))

    def out(j, d):  # d-th derivative of o_j (o_0 = V)
        return (-L * G) ** j * sine_derivative(omega, t, j + d)

    d = derivative
    x[ix["u1"]] = out(0, d)
    x[ix["iv"]] = -G * out(0, d)
    for j in range(1, k + 1):
        x[ix[f"o{j}"]] = out(j, d)
        x[ix[f"il{j}"]] = G * out(j - 1, d)
        x[ix[f"ia{j}"]] = -G * out(j - 1, d) + (G * out(j, d) if j < k else 0.0)
    return x


# ---------------------------------------------------------------------------
# pendulum (1.15) and its formulations
# ---------------------------------------------------------------------------
PEND = {"m": 2.0, "l": 1.5, "gamma": 9.81}


def _g(q, l):
    r1, r2, a = q
    return np.array([r1 - l / 2 * np.cos(a), r2 - l / 2 * np.sin(a)])


def _G(q, l):
    a = q[2]
    one, zero = np.ones_like(a), np.zeros_like(a)
    return np.array([[one, zero, l / 2 * np.sin(a)], [zero, one, -l / 2 * np.cos(a)]])


def _mass(m, l):
    return np.diag([m, m, m * l**2 / 12])


def _kappa(q, v, l):
    """d/dt (G(q)) v = derivative of G(q) v along q' = v (the acceleration-constraint term)."""
    a, va = q[2], v[2]
    return np.array([l / 2 * np.cos(a) * va * va, l / 2 * np.sin(a) * va * va])


def pendulum_residual(form: str, x, m=PEND["m"], l=PEND["l"], gamma=PEND["gamma"]):
    """Right-hand side phi(x) of E x' = phi(x) for the formulations of the notes.

    form: "index3" (1.15), "index1" (2.42), "index2" (2.47), "ggl" (2.48).
    x = (q (3), v (3), lambda (2)[, tau (2)]).
    """
    q, v, lam = x[0:3], x[3:6], x[6:8]
    f = np.array([0.0, -m * gamma, 0.0])
    Gq = _G(q, l)
    if form == "ggl":
        tau = x[8:10]
        kin = v - Gq.T @ tau
    else:
        kin = v
    dyn = f - Gq.T @ lam
    if form == "index3":
        con = _g(q, l)
        return np.concatenate([kin, dyn, con])
    if form == "index1":  # 0 = G v' + kappa  ->  E row G, phi row = -kappa
        return np.concatenate([kin, dyn, -_kappa(q, v, l)])
    if form == "index2":
        return np.concatenate([kin, dyn, Gq @ v])
    if form == "ggl":
        return np.concatenate([kin, dyn, Gq @ v, _g(q, l)])
    raise ValueError(form)


def pendulum_E(form: str, x, m=PEND["m"], l=PEND["l"]):
    n = 10 if form == "ggl" else 8
    E = np.zeros((n, n))
    E[0:3, 0:3] = np.eye(3)
    E[3:6, 3:6] = _mass(m, l)
    if form == "index1":
        E[6:8, 3:6] = _G(x[0:3], l)
    return E


def complex_step_jacobian(f, x, h=1e-30):
    """Jacobian of f at x by complex-step differentiation (no cancellation)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.size):
        xc = x.astype(complex)
        xc[j] += 1j * h
        cols.append(np.imag(f(xc)) / h)
    return np.array(cols).T


def pendulum_hanging_state(form: str, m=PEND["m"], l=PEND["l"], gamma=PEND["gamma"]):
    """Equilibrium hanging straight down: alpha = -pi/2, v = 0, lambda = (0, -m gamma)."""
    x = np.zeros(10 if form == "ggl" else 8)
    x[0:3] = [0.0, -l / 2, -np.pi / 2]
    x[6:8] = [0.0, -m * gamma]
    return x


def pendulum_pencil(form: str, x):
    """(E, H) of the linearization of a pendulum formulation at x (x' = 0 there)."""
    E = pendulum_E(form, x)
    H = complex_step_jacobian(lambda z: pendulum_residual(form, z), x)
    return E, H


#: Angular frequency of small oscillations about the hanging equilibrium:
#: J alpha'' = -m gamma (l/2) cos(alpha) (1.16) with J = m l^2 / 3.
PEND_OMEGA = np.sqrt(3 * PEND["gamma"] / (2 * PEND["l"]))


# ---------------------------------------------------------------------------
# semi-explicit examples
# ---------------------------------------------------------------------------
def semi_explicit(index: int):
    """Small semi-explicit DAEs ``E x' = H x + B u`` of the given index.

    index 1: y' = -y + z, 0 = -y - 2 z + u         (lambda = -3/2)
    index 2: y' = -y + z, 0 = y - u                 (y = u, z = u' + u)
    index 3: y1' = y2, y2' = z, 0 = y1 - u          (y1 = u, y2 = u', z = u'')
    """
    if index == 1:
        E = np.diag([1.0, 0.0])
        H = np.array([[-1.0, 1.0], [-1.0, -2.0]])
        B = np.array([[0.0], [1.0]])
    elif index == 2:
        E = np.diag([1.0, 0.0])
        H = np.array([[-1.0, 1.0], [1.0, 0.0]])
        B = np.array([[0.0], [-1.0]])
    elif index == 3:
        E = np.diag([1.0, 1.0, 0.0])
        H = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
        B = np.array([[0.0], [0.0], [-1.0]])
    else:
        raise ValueError(index)
    return E, H, B


# ---------------------------------------------------------------------------
# the builders against their closed forms
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_cascade_closed_form_solves_the_dae(k):
    G, L, omega = 2e-3, 5e-4, 7.0
    E, H, B, _ = differentiator_cascade(k, G, L)
    t = np.linspace(0.0, 1.0, 9)
    x = cascade_solution(k, G, L, omega, t)
    xd = cascade_solution(k, G, L, omega, t, derivative=1)
    res = E @ xd - H @ x - B @ np.sin(omega * t)[None, :]
    scale = np.abs(E) @ np.abs(xd) + np.abs(H) @ np.abs(x) + 1.0
    assert np.max(np.abs(res) / scale) < 1e-13


def test_pendulum_hanging_state_is_an_equilibrium():
    for form in ("index3", "index1", "index2", "ggl"):
        x = pendulum_hanging_state(form)
        assert np.max(np.abs(pendulum_residual(form, x))) < 1e-13


def test_complex_step_matches_hand_jacobian_of_the_constraint():
    q = np.array([0.3, -0.2, 0.7])
    l = PEND["l"]
    J = complex_step_jacobian(lambda z: _g(z, l), q)
    assert np.max(np.abs(J - _G(q, l))) < 1e-15
