"""Exact solutions of the linear benchmark circuits (modal superposition).

A linear circuit with one input ``u(t)`` and zero initial state, written in
its eigenbasis, is a set of decoupled scalar equations

    a_k' = -mu_k a_k + g_k u(t),     y_s(t) = sum_k w_sk a_k(t),

and for a piecewise-linear ``u`` (PULSE) each mode has a closed form on every
linear piece. :func:`modal_pwl_response` evaluates it at arbitrary times; the
``*_modes`` functions give ``mu``, ``g`` and ``w`` of each benchmark circuit:

- the uniform RC ladder (Dirichlet at the source, open far end): the matrix
  ``T = tridiag(-1, 2, -1)`` with ``T[n, n] = 1`` has the eigenvectors
  ``sin(j theta_k)``, ``theta_k = (2k - 1) pi / (2n + 1)``, eigenvalues
  ``2 - 2 cos theta_k`` and ``|s_k|^2 = (2n + 1) / 4``;
- the RC mesh with uniform leaks: the 2-D Neumann Laplacian is the Kronecker
  sum of two path Laplacians with eigenvectors ``cos(pi k (i + 1/2) / n)``;
- the RLC line: a dense eigendecomposition of its state matrix (inductor
  currents and capacitor voltages, scaled by sqrt(L) and sqrt(C) so that the
  matrix is a skew-symmetric coupling plus a damping diagonal, well
  conditioned for eig).

The formulas are exact; the only errors are the rounding of the sums
(relative 1e-13 or so), far below every tolerance benchmarked.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Modes", "modal_pwl_response", "ladder_modes", "mesh_modes", "line_modes"]

#: Below this |mu tau| the phi functions use their Taylor series (no cancellation).
SERIES_LIMIT = 1e-3
#: Entries of the (times x modes) work array per chunk.
CHUNK_ENTRIES = 2_000_000


@dataclass
class Modes:
    """Decay rates ``mu`` (K,), input gains ``gain`` (K,), output weights ``weights`` (S, K)."""

    mu: np.ndarray
    gain: np.ndarray
    weights: np.ndarray


def _phi12(z):
    """``phi1 = (1 - e^-z)/z`` and ``phi2 = (z - 1 + e^-z)/z^2``, accurate for all z."""
    z = np.asarray(z)
    small = np.abs(z) < SERIES_LIMIT
    zs = np.where(small, 1.0, z)
    em1 = np.expm1(-zs)
    phi1 = np.where(small, 1 - z / 2 + z * z / 6 - z**3 / 24, -em1 / zs)
    phi2 = np.where(small, 0.5 - z / 6 + z * z / 24 - z**3 / 120, (zs + em1) / (zs * zs))
    return phi1, phi2


def modal_pwl_response(mu, gain, weights, t_knots, u_knots, times) -> np.ndarray:
    """Outputs of ``a_k' = -mu_k a_k + g_k u(t)``, ``a(t_knots[0]) = 0``, ``y = W a``.

    Parameters
    ----------
    mu, gain : ndarray, shape (K,)
        Decay rates (real part positive) and input gains; real or complex.
    weights : ndarray, shape (S, K)
    t_knots, u_knots : ndarray, shape (p,)
        Corners of the piecewise-linear input (increasing times); constant
        ``u_knots[-1]`` after the last one.
    times : ndarray, shape (M,)
        Output times, ``>= t_knots[0]``.

    Returns
    -------
    ndarray, shape (S, M)

    Notes
    -----
    Cost O(p K) for the states at the corners plus O(M K S) for the outputs,
    in chunks of :data:`CHUNK_ENTRIES`.
    """
    mu = np.asarray(mu)
    gain = np.asarray(gain)
    weights = np.atleast_2d(np.asarray(weights))
    tk = np.asarray(t_knots, dtype=float)
    uk = np.asarray(u_knots, dtype=float)
    times = np.asarray(times, dtype=float).reshape(-1)
    slopes = np.append(np.diff(uk) / np.diff(tk), 0.0)
    dtype = np.result_type(mu, gain, weights, float)
    states = np.zeros((tk.size, mu.size), dtype=dtype)
    for i in range(tk.size - 1):
        tau = tk[i + 1] - tk[i]
        p1, p2 = _phi12(mu * tau)
        states[i + 1] = states[i] * np.exp(-mu * tau) + gain * (uk[i] * tau * p1 + slopes[i] * tau * tau * p2)
    seg = np.clip(np.searchsorted(tk, times, side="right") - 1, 0, tk.size - 1)
    out = np.empty((weights.shape[0], times.size), dtype=np.result_type(dtype, weights))
    chunk = max(1, CHUNK_ENTRIES // max(mu.size, 1))
    for s in range(0, times.size, chunk):
        sl = slice(s, s + chunk)
        i = seg[sl]
        tau = (times[sl] - tk[i])[:, None]
        z = mu[None, :] * tau
        p1, p2 = _phi12(z)
        a = states[i] * np.exp(-z) + gain * (uk[i][:, None] * tau * p1 + slopes[i][:, None] * tau * tau * p2)
        out[:, sl] = weights @ a.T
    return out


def ladder_modes(n: int, r: float, c: float, probes) -> Modes:
    """Modes of the uniform RC ladder ``C v' = -(1/R) T v + (1/R) e_1 u`` (open far end).

    Parameters
    ----------
    n : int
        Sections; node ``j = 1..n``, the source drives node 0.
    r, c : float
        Section resistance and capacitance.
    probes : array_like of int
        Node numbers (1..n) observed.
    """
    k = np.arange(1, n + 1)
    theta = (2 * k - 1) * np.pi / (2 * n + 1)
    lam = 2.0 - 2.0 * np.cos(theta)
    scale = 1.0 / np.sqrt((2 * n + 1) / 4.0)
    q1 = np.sin(theta) * scale
    probes = np.asarray(probes)
    weights = np.sin(probes[:, None] * theta[None, :]) * scale
    return Modes(mu=lam / (r * c), gain=q1 / (r * c), weights=weights)


def _path_modes(n: int):
    k = np.arange(n)
    lam = 2.0 - 2.0 * np.cos(np.pi * k / n)
    norm = np.where(k == 0, np.sqrt(1.0 / n), np.sqrt(2.0 / n))
    return lam, lambda i: norm * np.cos(np.pi * k * (i + 0.5) / n)


def mesh_modes(n: int, r: float, c: float, r_leak: float, probes) -> Modes:
    """Modes of the ``n x n`` RC mesh with a leak at every node, fed at node (0, 0).

    ``C v' = -(1/R)(L (x) I + I (x) L) v - v / r_leak + e_00 i(t)`` with the
    path Laplacian ``L`` (Neumann ends).
    """
    lam, vec = _path_modes(n)
    mu = ((lam[:, None] + lam[None, :]) / r + 1.0 / r_leak) / c
    v0 = vec(0)
    gain = np.outer(v0, v0) / c
    weights = np.array([np.outer(vec(i), vec(j)).ravel() for i, j in probes])
    return Modes(mu=mu.ravel(), gain=gain.ravel(), weights=weights)


def line_modes(n: int, rk: float, lk: float, ck: float, r_source: float, r_load: float, probes) -> Modes:
    """Modes of the RLC line; outputs the voltages of nodes ``a<probe>``.

    State ``z = (sqrt(L) i_1..i_n, sqrt(C) v_1..v_n)``:
    ``L i_1' = u - (Rs + R) i_1 - v_1``, ``L i_k' = v_(k-1) - R i_k - v_k``,
    ``C v_k' = i_k - i_(k+1)``, ``C v_n' = i_n - v_n / RL``.
    """
    a = np.zeros((2 * n, 2 * n))
    idx = np.arange(n)
    coupling = 1.0 / np.sqrt(lk * ck)
    a[idx, idx] = -rk / lk
    a[0, 0] -= r_source / lk
    a[idx, n + idx] = -coupling  # -v_k in the equation of i_k
    a[idx[1:], n + idx[:-1]] = coupling  # +v_(k-1)
    a[n + idx, idx] = coupling  # +i_k in the equation of v_k
    a[n + idx[:-1], idx[1:]] = -coupling  # -i_(k+1)
    a[2 * n - 1, 2 * n - 1] = -1.0 / (r_load * ck)
    b = np.zeros(2 * n)
    b[0] = 1.0 / np.sqrt(lk)
    lam, vecs = np.linalg.eig(a)
    gain = np.linalg.solve(vecs, b)
    weights = np.array([vecs[n + p - 1] / np.sqrt(ck) for p in probes])
    return Modes(mu=-lam, gain=gain, weights=weights)
