"""Named waveforms: the output of every analysis.

A :class:`Result` holds one analysis: its sweep axes (``time``,
``frequency``, the swept source ``v1`` ...), its signals keyed by the names
ngspice prints (``v(out)``, ``i(v1)``), the statistics of the run and its
status. Signals are real for ``op``, ``dc`` and ``tran`` and complex phasors
for ``ac``.

Examples
--------
>>> import numpy as np
>>> r = Result("tran", axes={"time": np.array([0.0, 1.0])},
...            signals={"v(out)": np.array([0.0, 2.0])})
>>> r["V(OUT)"]
array([0., 2.])
>>> r.axis_name, r.axis.tolist()
('time', [0.0, 1.0])
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

__all__ = ["Result", "STATUS_OK", "STATUS_FAILED"]

STATUS_OK = 0
STATUS_FAILED = -1

#: ``v(a,b)``: the difference of two node voltages.
_DIFFERENCE = re.compile(r"v\(\s*([^,\s()]+)\s*,\s*([^,\s()]+)\s*\)")


@dataclass
class Result:
    """One analysis result.

    Parameters
    ----------
    analysis : str
        ``"op"``, ``"dc"``, ``"ac"`` or ``"tran"``.
    axes : dict of str to ndarray
        Sweep axes in order, primary first (``{"time": t}``; for a two-source
        ``.dc`` sweep ``{"v1": ..., "v2": ...}`` with one entry per point);
        empty for ``op``.
    signals : dict of str to ndarray
        Signal name to values, one per point (shape ``(m,)``; ``(1,)`` for op).
    stats : dict
        Work counters and timings (``steps``, ``rejected``, ``newton``,
        ``factorizations``, ``wall_time`` ...).
    status : int
        0 on success, negative on failure.
    message : str
        What happened, with a hint on failure.
    tolerances : dict
        The tolerances actually used (``reltol``, ``vntol``, ``abstol`` ...).
    dense : callable, optional
        ``dense(t) -> dict of str to ndarray``: the integrator's interpolant
        (transient only), evaluable at any time in the computed range.
    notes : list of str
        Things the user should know (translations, changed initial values ...).
    extra : dict
        Analysis-specific data (e.g. the index report used, the operating point).
    """

    analysis: str
    axes: dict[str, np.ndarray] = field(default_factory=dict)
    signals: dict[str, np.ndarray] = field(default_factory=dict)
    stats: dict[str, Any] = field(default_factory=dict)
    status: int = STATUS_OK
    message: str = ""
    tolerances: dict[str, float] = field(default_factory=dict)
    dense: Callable[[Any], dict[str, np.ndarray]] | None = None
    notes: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when the analysis succeeded."""
        return self.status >= 0

    @property
    def axis_name(self) -> str | None:
        """Name of the primary axis (``"time"``, ``"frequency"``, ...)."""
        return next(iter(self.axes), None)

    @property
    def axis(self) -> np.ndarray | None:
        """The primary axis."""
        name = self.axis_name
        return None if name is None else self.axes[name]

    @property
    def t(self) -> np.ndarray:
        """Time axis of a transient result."""
        return self.axes["time"]

    def __getitem__(self, name: str) -> np.ndarray:
        key = name.lower()
        if key in self.signals:
            return self.signals[key]
        # accept a bare node name for convenience: "out" -> v(out)
        if f"v({key})" in self.signals:
            return self.signals[f"v({key})"]
        raise KeyError(f"no signal {name!r}; have {', '.join(self.signals)}")

    def __contains__(self, name: str) -> bool:
        try:
            self[name]
        except KeyError:
            return False
        return True

    def names(self) -> list[str]:
        """Signal names in order."""
        return list(self.signals)

    def subset(self, names) -> "Result":
        """This result with only the signals ``names`` (``v(a,b)`` is formed from ``v(a)`` and ``v(b)``).

        Raises
        ------
        KeyError
            For a name that is neither a signal nor a difference of two node voltages.

        Examples
        --------
        >>> import numpy as np
        >>> r = Result("op", signals={"v(a)": np.array([3.0]), "v(b)": np.array([1.0])})
        >>> r.subset(["v(a,b)"]).signals
        {'v(a,b)': array([2.])}
        """
        out = {}
        for raw in names:
            name = raw.strip().lower()
            if name in self:
                out[name] = self[name]
                continue
            m = _DIFFERENCE.fullmatch(name)
            if m is None:
                raise KeyError(f"no signal {raw!r}; have {', '.join(self.signals)}")
            a, b = (0.0 if nd in ("0", "gnd") else self[f"v({nd})"] for nd in m.group(1, 2))
            out[f"v({m.group(1)},{m.group(2)})"] = a - b
        return replace(self, signals=out)
