"""Dense output of the BDF integrator: the method's own interpolating polynomials.

After a step from ``t_n`` to ``t_{n+1}`` at order ``k``, the FLC-BDF history
(its modified divided differences) represents the polynomial of degree ``k``
through the ``k + 1`` computed values ``x_{n+1}, x_n, ..., x_{n+1-k}``; IDA
returns exactly this polynomial as its interpolant on ``[t_n, t_{n+1}]``
(``IDAGetSolution``). :class:`Interpolant` rebuilds it from the stored step
values and orders, so dense output costs no memory beyond the saved solution
itself (one extra ``int8`` per step).

Dense output never crosses a restart: the polynomial of a step uses only
points from the segment the step belongs to (the method restarts at order 1
on every breakpoint, so its own history never reaches back either). Where
the solution jumps, the integrator stores two points at the same time, the
left value and the right limit; at that time the interpolant returns the
left value, just after it the polynomial through the right limit.

Evaluation is a compiled loop over the requested times
(:func:`netdae.dae.compiled.dense.lagrange_eval`: a binary search for the
step, the Lagrange weights in scalar arithmetic, as
:meth:`Interpolant._evaluate_one`); :meth:`Interpolant._evaluate` is the same
polynomial vectorised in numpy, kept as the reference the tests hold the
kernel to.

Examples
--------
Values on a parabola: the first step (order 1) interpolates linearly, the
second-order steps reproduce the parabola exactly:

>>> import numpy as np
>>> t = np.array([0.0, 0.5, 1.5, 2.0])
>>> x = (t ** 2)[:, None]
>>> f = Interpolant(t, np.array([0, 1, 2, 2]), x, ("y",))
>>> np.round(f([0.25, 1.0, 1.75])[:, 0], 12).tolist()
[0.125, 1.0, 3.0625]
"""

from __future__ import annotations

import numpy as np

__all__ = ["Interpolant"]

class Interpolant:
    """Piecewise-polynomial interpolant of a BDF solution.

    Parameters
    ----------
    t : ndarray, shape (m,)
        Accepted step times, increasing, starting at t0.
    orders : ndarray of int, shape (m,)
        ``orders[i]`` is the order of the step ending at ``t[i]`` (``orders[0]``
        is unused). The polynomial on ``[t[i-1], t[i]]`` interpolates
        ``x[i - orders[i] .. i]``.
    x : ndarray, shape (m, ns)
        Solution values of the saved components.
    names : sequence of str, length ns
        Names of the saved components.
    segments : array_like of int, optional
        Positions in ``t`` where a new segment starts (a restart of the
        method at a breakpoint): no polynomial uses a point before the start
        of its segment. A time listed twice (a jump) always starts a segment
        at its second entry.

    Raises
    ------
    ValueError
        If the arrays disagree in length.
    """

    def __init__(self, t, orders, x, names, segments=None) -> None:
        self.t = np.ascontiguousarray(t, dtype=float)
        self.orders = np.asarray(orders, dtype=np.int64)
        self.x = np.ascontiguousarray(x, dtype=float)
        self.names = tuple(names)
        m = self.t.size
        if self.x.shape[0] != m or self.orders.shape != (m,):
            raise ValueError("t, orders and x must have the same number of points")
        # the start of the segment each point belongs to: a step ending at i interpolates
        # x[start .. i] at most (a step started from a given history, with no stored points
        # before t0, interpolates through the points that exist)
        starts = np.zeros(m, dtype=bool)
        repeated = np.zeros(m, dtype=bool)
        if m:
            repeated[1:] = self.t[1:] == self.t[:-1]
            starts[0] = True
            starts |= repeated
        if segments is not None:
            seg = np.asarray(segments, dtype=np.int64)
            starts[seg[(seg >= 0) & (seg < m)]] = True
        last_start = np.maximum.accumulate(np.where(starts, np.arange(m), 0)) if m else np.zeros(0, np.int64)
        before = np.concatenate([[0], last_start[:-1]]) if m else last_start
        # the step ending at i starts at the segment start of point i - 1
        self.orders = np.minimum(self.orders, np.arange(m) - before)
        self.orders[repeated] = 0
        self.maxorder = int(self.orders[1:].max()) if m > 1 else 0

    @property
    def t_min(self) -> float:
        """Start of the covered range."""
        return float(self.t[0])

    @property
    def t_max(self) -> float:
        """End of the covered range."""
        return float(self.t[-1])

    def __call__(self, t, components=None) -> np.ndarray:
        """Interpolated solution at the times ``t``.

        Parameters
        ----------
        t : float or array_like, shape (p,)
            Times in ``[t_min, t_max]``.
        components : array_like of int or str, optional
            Positions in the saved components, or their names; all by default.

        Returns
        -------
        ndarray, shape (p, nc) (or (nc,) for a scalar ``t``)

        Raises
        ------
        ValueError
            For times outside the covered range or not finite, or unknown component names.
        """
        tq = np.asarray(t, dtype=float)
        scalar = tq.ndim == 0
        tq = np.atleast_1d(tq).ravel()
        cols = self._columns(components)
        if not np.all(np.isfinite(tq)):
            raise ValueError(f"dense output times must be finite numbers, not {float(tq[~np.isfinite(tq)][0])}")
        span = self.t[-1] - self.t[0]
        fuzz = 1e-12 * max(abs(self.t[0]), abs(self.t[-1]), span)
        if tq.size and (tq.min() < self.t[0] - fuzz or tq.max() > self.t[-1] + fuzz):
            raise ValueError(
                f"dense output is available on [{self.t[0]:.6g}, {self.t[-1]:.6g}] only; "
                f"asked for [{tq.min():.6g}, {tq.max():.6g}]"
            )
        if self.t.size == 1:
            xs = self.x[:, cols]
            out = np.empty((tq.size, xs.shape[1]))
            out[:] = xs[0]
            return out[0] if scalar else out
        from .compiled.dense import lagrange_eval

        index = np.arange(self.x.shape[1], dtype=np.int64)[cols]
        out = np.empty((tq.size, index.size))
        lagrange_eval(self.t, self.orders, self.x, np.ascontiguousarray(index), np.ascontiguousarray(tq), out)
        return out[0] if scalar else out

    def _evaluate_one(self, tq: float, xs: np.ndarray) -> np.ndarray:
        """One time: the same polynomial as :meth:`_evaluate`, its weights in scalar arithmetic (~20 us)."""
        tpts = self.t
        last = tpts.size - 1
        i = min(max(int(np.searchsorted(tpts, tq, side="left")), 1), last)
        k = int(self.orders[i])
        ti = float(tpts[i])
        scale = ti - float(tpts[i - 1])
        if not scale > 0.0:
            scale = 1.0
        s = (tq - ti) / scale
        u = [(float(tpts[i - j]) - ti) / scale for j in range(k + 1)]
        weights = []
        for a in range(k + 1):
            w = 1.0
            for b in range(k + 1):
                if b != a:
                    denom = u[a] - u[b]
                    w *= (s - u[b]) / (denom if denom != 0.0 else 1.0)
            weights.append(w)
        return np.asarray(weights) @ xs[i - k:i + 1][::-1] if k else xs[i].copy()

    def _columns(self, components):
        if components is None:
            return slice(None)
        comps = np.atleast_1d(components)
        if comps.dtype.kind in "US":
            lower = {nm.lower(): i for i, nm in enumerate(self.names)}
            try:
                return np.array([lower[str(c).lower()] for c in comps], dtype=np.int64)
            except KeyError as err:
                raise ValueError(f"no saved component {err.args[0]!r}; have {', '.join(self.names)}") from None
        return comps.astype(np.int64)

    def _evaluate(self, tq: np.ndarray, xs: np.ndarray) -> np.ndarray:
        if tq.size == 1:
            return self._evaluate_one(float(tq[0]), xs)[None, :]
        tpts = self.t
        last = tpts.size - 1
        # step i covers [t[i-1], t[i]]; a time on a step boundary uses the step ending there
        i = np.clip(np.searchsorted(tpts, tq, side="left"), 1, last)
        k = self.orders[i]
        nodes = self.maxorder + 1
        j = np.arange(nodes)
        idx = i[:, None] - j[None, :]
        valid = j[None, :] <= k[:, None]
        idx = np.where(valid, idx, i[:, None])
        tau = tpts[idx]
        # normalise by the step length for well-scaled products (a zero-length "step" is the
        # second point of a jump: order 0, it returns its own value)
        scale = tpts[i] - tpts[i - 1]
        scale = np.where(scale > 0.0, scale, 1.0)
        s = (tq - tpts[i]) / scale
        u = (tau - tpts[i][:, None]) / scale[:, None]
        # Lagrange weights l_a(s) = prod_{b != a, b valid} (s - u_b) / (u_a - u_b), all (p, a, b) at once
        both = valid[:, :, None] & valid[:, None, :] & ~np.eye(nodes, dtype=bool)[None]
        denom = u[:, :, None] - u[:, None, :]
        factor = np.where(both, (s[:, None, None] - u[:, None, :]) / np.where(both, denom, 1.0), 1.0)
        weights = np.where(valid, factor.prod(axis=2), 0.0)
        return np.einsum("pj,pjc->pc", weights, xs[idx])
