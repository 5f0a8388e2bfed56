"""The integrator's output: accepted points, their orders, restarts, jumps and the dense output's segments."""

from __future__ import annotations

import numpy as np

from ..dense import Interpolant
from .constants import BUFFER_START, BUFFER_START_BYTES
from .result import IntegrationResult

__all__ = ["Recorder"]


def start_capacity(saved: int) -> int:
    """Points the output buffers start with: :data:`BUFFER_START` within :data:`BUFFER_START_BYTES` of rows
    of ``saved`` doubles, but 16 at least.

    >>> start_capacity(3), start_capacity(200_001)
    (1024, 16)
    """
    return max(16, min(BUFFER_START, BUFFER_START_BYTES // (8 * (saved + 2))))


class Recorder:
    """Output buffers of an integration (they double when full).

    Parameters
    ----------
    names : sequence of str, length n
        Names of all unknowns.
    save : ndarray of int, shape (ns,)
        Positions of the unknowns to record.
    save_all : bool
        ``save`` is every unknown in order (then ``x`` is stored as given).

    Attributes
    ----------
    m : int
        Points recorded.
    segments : list of int
        Record positions where a segment of the dense output begins (a
        restart or a jump: the interpolant never uses points across one).
    restart_times : list of float
        Breakpoints where the method restarted at order 1.
    jumps : list of (float, tuple of str)
        Times where the solution jumped and the unknowns that moved.
    events : list of (float, tuple of str)
        Times where switches changed conductance, and which.

    Notes
    -----
    Memory: ``m (ns + 1)`` floats and ``m`` bytes.
    """

    def __init__(self, names, save: np.ndarray, save_all: bool) -> None:
        self.names = tuple(names)
        self.save = save
        self.save_all = save_all
        cap = start_capacity(save.size)
        self.t = np.empty(cap)
        self.k = np.zeros(cap, dtype=np.int8)
        self.x = np.empty((cap, save.size))
        self.m = 0
        self.segments: list[int] = [0]
        self.restart_times: list[float] = []
        self.jumps: list[tuple[float, tuple[str, ...]]] = []
        self.events: list[tuple[float, tuple[str, ...]]] = []

    def record(self, t: float, x: np.ndarray, k: int) -> None:
        """Append the point ``(t, x)`` (all n unknowns) reached by a step of order ``k`` (0: a start)."""
        m = self.m
        if m == self.t.size:
            cap = 2 * m
            self.t = np.resize(self.t, cap)
            self.k = np.resize(self.k, cap)
            self.x = np.resize(self.x, (cap, self.save.size))
        self.t[m] = t
        self.k[m] = k
        self.x[m] = x if self.save_all else x[self.save]
        self.m = m + 1

    def restart(self, t: float) -> None:
        """The method restarts at ``t`` (the last point): a new segment of the dense output."""
        self.restart_times.append(t)
        self.segments.append(self.m - 1)

    def jump(self, t: float, x_right: np.ndarray, moved) -> None:
        """The solution jumps at ``t``: record the right limit as a second point at ``t``, in a new segment.

        Parameters
        ----------
        t : float
        x_right : ndarray, shape (n,)
            The right limit.
        moved : sequence of str
            The unknowns that moved by more than their tolerance.
        """
        self.jumps.append((float(t), tuple(moved)))
        self.record(t, x_right, 0)
        self.segments.append(self.m - 1)

    def result(self, *, stats: dict, status: int, message: str, tolerances: dict, failure) -> IntegrationResult:
        """The points so far as an :class:`IntegrationResult` (copies of the buffers)."""
        m = self.m
        t = self.t[:m].copy()
        x = self.x[:m].copy()
        k = self.k[:m].copy()
        names = tuple(self.names[i] for i in self.save)
        return IntegrationResult(
            t=t, x=x, order=k, names=names, save=self.save.copy(),
            dense=Interpolant(t, k, x, names, segments=np.array(self.segments, dtype=np.int64)),
            stats=stats, status=status, message=message, tolerances=dict(tolerances), failure=failure,
            restarts=np.array(self.restart_times), jumps=list(self.jumps), events=list(self.events),
        )
