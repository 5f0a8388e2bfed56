"""The vector u(t) of independent source values, ``phi = H x + B u(t)``.

Which value a source takes follows ngspice (``vsrcload.c``): for ``.op`` and
``.dc`` the DC value when one is written, else the transient function at
t = 0; for a transient (and the operating point that starts it) the transient
function at time t when there is one, else the DC value.

Time-varying sources are evaluated through the reader's vectorised
:class:`~netdae.netlist.waveforms.SourceBank`: one numpy call per waveform
class, no loop over sources.
"""

from __future__ import annotations

import numpy as np

from ..circuit import Element
from ..errors import NetlistError

__all__ = ["SourceVector", "MODE_DC", "MODE_TRAN"]

MODE_DC = "dc"
MODE_TRAN = "tran"


def _check_dc_values(sources: list[Element]) -> None:
    """Refuse a source whose ``.op``/``.dc`` value (its waveform at t = 0) waits for ``.tran`` defaults.

    Raises
    ------
    NetlistError
        At the source's card: a waveform started before t = 0 by a negative
        delay, with a parameter left to its TSTEP/TSTOP default and no DC value.
    """
    for el in sources:
        spec = el.source
        if spec.dc is None and spec.tran is not None and not spec.tran.determined_at(0.0):
            kind = spec.tran.kind.upper()
            raise NetlistError(
                f"{el.name}: the {kind} starts before t = 0 (a negative delay), so its value at t = 0, which "
                ".op and .dc use, depends on parameters left to their .tran step/stop defaults (absent or 0)",
                el.location,
                expected=f"a DC value ('dc v0') or every {kind} parameter written",
                hint=f"add 'dc 0' (or the value the operating point should see) to {el.name}, or write the "
                     f"{kind}'s remaining parameters",
            )


def _same_sources(like: "SourceVector", names: list[str], made: tuple) -> bool:
    """Whether ``like`` was made of sources of these names and equal values, with the same mode, tstep and
    tstop (``made``: ``SourceVector._made``); False where the values do not compare (no sharing then)."""
    try:
        return like.names == names and like._made[:3] == made[:3] and bool(like._made[3] == made[3])
    except (TypeError, ValueError):
        return False


class SourceVector:
    """Values of the independent sources in the column order of ``B``.

    Parameters
    ----------
    sources : list of Element
        Independent V and I sources.
    mode : {"dc", "tran"}
    tstep, tstop : float, optional
        The transient's step and stop time (ngspice's waveform defaults depend on them).
    like : SourceVector, optional
        Another circuit's vector (a sweep's first row's): where its sources have the same names and
        equal values and it was made with the same mode, tstep and tstop, this one shares its
        waveforms (:class:`~netdae.netlist.waveforms.SourceBank`, read only) and copies its values
        instead of resolving and grouping the waveforms again.
    """

    def __init__(self, sources: list[Element], mode: str = MODE_DC, tstep: float | None = None,
                 tstop: float | None = None, like: "SourceVector | None" = None):
        self.names = [el.name for el in sources]
        self.mode = mode
        specs = [el.source for el in sources]
        self._made = (mode, tstep, tstop, specs)  # what the vector is made of (for ``like``)
        if like is not None and _same_sources(like, self.names, self._made):
            # its values as made (a .dc sweep sets them in place afterwards: set_value)
            self.m, self.ac, self.u0, self.timed = like.m, like.ac.copy(), like._u0_made.copy(), like.timed.copy()
            self._u0_made = like._u0_made
            self.bank, self._all_timed = like.bank, like._all_timed
            self._cache_t, self._cache_u = None, None
            return
        m = len(specs)
        self.m = m
        self.ac = np.array(
            [s.ac_mag * np.exp(1j * np.deg2rad(s.ac_phase)) for s in specs], dtype=complex
        ).reshape(m)
        if mode == MODE_DC:
            _check_dc_values(sources)
            self.u0 = np.array([s.dc_value() for s in specs], dtype=float).reshape(m)
            self.timed = np.empty(0, dtype=np.int64)
            self.bank = None
        else:
            self.u0 = np.array([s.dc if s.dc is not None else 0.0 for s in specs], dtype=float).reshape(m)
            self.timed = np.array([i for i, s in enumerate(specs) if s.tran is not None], dtype=np.int64)
            if self.timed.size:
                from ..netlist.waveforms import SourceBank

                ts = tstep if tstep is not None else 0.0
                te = tstop if tstop is not None else 0.0
                self.bank = SourceBank([specs[i].tran.resolved(ts, te) for i in self.timed])
                self.u0[self.timed] = 0.0
            else:
                self.bank = None
        self._u0_made = self.u0.copy()
        self._cache_t: float | None = None
        self._cache_u: np.ndarray | None = None
        # every source has a transient function (u0 is then all zero): u(t) is the bank's output
        self._all_timed = self.bank is not None and self.timed.size == m

    @property
    def time_dependent(self) -> bool:
        """True when some source varies in time."""
        return self.bank is not None

    def values(self, t: float, derivative: int = 0) -> np.ndarray:
        """u(t) or its ``derivative``-th time derivative, shape (m,).

        Notes
        -----
        The last value is cached: a Newton iteration evaluates the same t repeatedly.
        """
        if derivative == 0:
            if self._cache_t == t and self._cache_u is not None:
                return self._cache_u
            if self._all_timed:
                u = self.bank.values(t)  # a new array, in source order
            else:
                u = self.u0.copy()
                if self.bank is not None:
                    u[self.timed] = self.bank.values(t)
            self._cache_t, self._cache_u = t, u
            return u
        u = np.zeros(self.m)
        if self.bank is not None:
            u[self.timed] = self.bank.values(t, derivative=derivative)
        return u

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Sorted instants in [t0, t1] where some source is not smooth."""
        if self.bank is None:
            return np.empty(0)
        return np.asarray(self.bank.breakpoints(t0, t1), dtype=float)

    def set_value(self, name: str, value: float) -> None:
        """Set the DC value of source ``name`` (for ``.dc`` sweeps).

        Raises
        ------
        KeyError
            When there is no such independent source.
        """
        i = self.names.index(name.lower())
        self.u0[i] = value
        self._cache_t = None
