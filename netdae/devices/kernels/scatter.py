"""Scatter of one instance's branch currents and charges, compiled (see :mod:`netdae.devices.companion`).

A current ``i`` from node ``a`` to node ``b`` adds ``-i`` to ``phi[a]`` and
``+i`` to ``phi[b]``; a charge ``Q`` on the ``a`` side adds ``+Q`` to
``q[a]`` and ``-Q`` to ``q[b]``. A derivative ``g`` of an output on the
control ``v = x[p] - x[m]`` lands in the four slots ``(a, p), (a, m), (b, p),
(b, m)``, stored as ``idx[k, s:s + 4]``.
"""

from __future__ import annotations

from ...dae.compiled import kernel

__all__ = ["is_zero", "add_current", "add_charge", "add_current_slope", "add_charge_slope"]


@kernel
def is_zero(x):
    """True when every entry of ``x`` is zero (a solve from scratch)."""
    for v in x:
        if v != 0.0:
            return False
    return True


@kernel
def add_current(phi, a, b, i):
    """Current ``i`` from node ``a`` to node ``b`` (extended indices)."""
    phi[a] -= i
    phi[b] += i


@kernel
def add_charge(q, a, b, charge):
    """Charge on the ``a`` side of the branch ``(a, b)``."""
    q[a] += charge
    q[b] -= charge


@kernel
def add_current_slope(dphi, idx, k, s, g):
    """Derivative ``g`` of a branch current on one control, into slots ``idx[k, s:s + 4]``."""
    dphi[idx[k, s]] -= g
    dphi[idx[k, s + 1]] += g
    dphi[idx[k, s + 2]] += g
    dphi[idx[k, s + 3]] -= g


@kernel
def add_charge_slope(dq, idx, k, s, c):
    """Derivative ``c`` of a branch charge on one control, into slots ``idx[k, s:s + 4]``."""
    dq[idx[k, s]] += c
    dq[idx[k, s + 1]] -= c
    dq[idx[k, s + 2]] -= c
    dq[idx[k, s + 3]] += c
