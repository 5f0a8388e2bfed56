"""Packing helpers for the families' ``compiled()`` (numpy only, run once per analysis)."""

from __future__ import annotations

import numpy as np

__all__ = ["extended", "dependence_slots", "depletion_columns"]


def extended(nodes, n: int) -> np.ndarray:
    """Node indices with ground (-1) mapped to ``n``, the extended arrays' ground entry."""
    nodes = np.asarray(nodes, dtype=np.int64)
    return np.where(nodes < 0, n, nodes)


def dependence_slots(slots, a, b, p, m, where=None) -> np.ndarray:
    """Slots ``(a, p), (a, m), (b, p), (b, m)`` of a branch ``(a, b)`` on a control ``(p, m)``.

    Parameters
    ----------
    slots : SlotMap
    a, b, p, m : array_like of int, shape (N,)
        Node indices (ground -1).
    where : array_like of bool, shape (N,), optional
        Instances that have this dependence; the others get the dummy slot
        (their coordinates need not be in the pattern).

    Returns
    -------
    ndarray of int64, shape (N, 4)
    """
    a, b, p, m = (np.asarray(v, dtype=np.int64) for v in (a, b, p, m))
    if where is not None:
        off = ~np.asarray(where, dtype=bool)
        a, b, p, m = (np.where(off, -1, v) for v in (a, b, p, m))
    return slots(np.stack([a, a, b, b], axis=1), np.stack([p, m, p, m], axis=1))


def depletion_columns(dep, rows=slice(None)) -> np.ndarray:
    """A :class:`~netdae.devices.junction.Depletion`'s coefficients as columns, shape (N, 9).

    In the argument order of :func:`netdae.devices.kernels.junction.depletion`.
    """
    return np.stack([np.broadcast_to(getattr(dep, name), dep.cj0.shape)[rows]
                     for name in ("cj0", "vj", "m", "vfc", "q_scale", "q_fc", "czf2", "f3", "m_over_vj")], axis=1)
