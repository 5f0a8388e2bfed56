"""Packing helpers for the families' ``compiled()`` (numpy only, run once per analysis)."""

from __future__ import annotations

import numpy as np

__all__ = ["extended", "dependence_slots", "depletion_columns", "columns", "node_columns", "dependence_blocks"]


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


def columns(count: int, width: int, values) -> np.ndarray:
    """A family's parameter table: ``values`` (column -> value per instance or one value) in a zero table.

    Parameters
    ----------
    count, width : int
        Instances and columns (the kernel's ``N_PAR``).
    values : mapping of int to array_like, shape (count,) or scalar

    Returns
    -------
    ndarray, shape (count, width)
    """
    par = np.zeros((count, width))
    for col, value in values.items():
        par[:, col] = value
    return par


def node_columns(count: int, width: int, nodes, n: int) -> np.ndarray:
    """A family's index table with its node columns filled (:func:`extended`); the slot columns are zero.

    Parameters
    ----------
    count, width : int
        Instances and columns (the kernel's ``N_IDX``).
    nodes : mapping of int to array_like of int, shape (count,)
        Column -> node index per instance (ground -1).
    n : int
        Unknowns (the extended arrays' ground entry).

    Returns
    -------
    ndarray of int64, shape (count, width)
    """
    idx = np.zeros((count, width), dtype=np.int64)
    for col, node in nodes.items():
        idx[:, col] = extended(node, n)
    return idx


def dependence_blocks(idx: np.ndarray, start: int, slots, deps, branches, controls, where=None) -> None:
    """Fill the slot blocks of ``idx`` for a family's dependences, four columns each from ``start``.

    Parameters
    ----------
    idx : ndarray of int64, shape (N, N_IDX)
        Written in place: dependence ``j`` goes to columns ``start + 4 j`` to ``start + 4 j + 3``.
    start : int
    slots : SlotMap
    deps : sequence of (int, int)
        ``(output, control)`` pairs: the branch ``branches[output]`` depends on ``controls[control]``.
    branches, controls : sequence of (array_like, array_like)
        Node pairs per instance.
    where : array_like of bool, shape (N,), or sequence of them (one per dependence), optional
        Instances that have the dependence (:func:`dependence_slots`).
    """
    for j, (out, ctrl) in enumerate(deps):
        a, b = branches[out]
        p, m = controls[ctrl]
        mask = where[j] if isinstance(where, (list, tuple)) else where
        idx[:, start + 4 * j:start + 4 * j + 4] = dependence_slots(slots, a, b, p, m, where=mask)
