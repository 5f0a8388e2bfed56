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

import html
import importlib
import types
import warnings
from enum import IntEnum
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

from .signals import canonical, parse_signal
from .metadata import LEGACY_EXTRA, NoiseInfo, Provenance, TransientInfo
from .stats import Statistics

__all__ = ["Result", "Statistics", "Status", "STATUS_OK", "STATUS_FAILED"]


class Status(IntEnum):
    """How an analysis ended: a closed vocabulary that is an ``int`` (compares, sorts and
    serialises as its value; a failed or interrupted analysis is negative).

    Examples
    --------
    >>> Status.FAILED < 0, Status(0) is Status.OK, int(Status.FAILED)
    (True, True, -1)
    """

    OK = 0
    FAILED = -1


STATUS_OK = Status.OK
STATUS_FAILED = Status.FAILED


@dataclass
class Result:
    """One analysis result.

    Parameters
    ----------
    analysis : str
        ``"op"``, ``"dc"``, ``"ac"``, ``"tran"``, ``"pz"``, ``"tf"``, ``"noise"`` or ``"sens"``.
    axes : dict of str to ndarray
        Sweep axes in order, primary first (``{"time": t}``; for a two-source
        ``.dc`` sweep ``{"v1": ..., "v2": ...}`` with one entry per point);
        empty for ``op``.
    signals : dict of str to ndarray
        Signal name to values, one per point (shape ``(m,)``; ``(1,)`` for op).
    stats : Statistics
        Work counters and timings (``steps``, ``rejected``,
        ``newton_iterations``, ``factorizations``, ``wall_time`` ...), one
        vocabulary for every analysis (:class:`netdae.stats.Statistics`, a
        read-only mapping of its set fields). A mapping given here is checked
        against that vocabulary and converted.
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
    measures : list of Measure
        The ``.meas`` measurements made on this result, in netlist order
        (:class:`netdae.measures.Measure`: name, value, status, reason ...).
    fourier : list of Fourier
        The ``.four`` analyses of this transient (:class:`netdae.fourier.Fourier`).
    operating_point : Result, optional
        The operating point a small-signal analysis (``ac``, ``pz``, ``tf``,
        ``noise``) linearised at.
    poles, zeros : ndarray, optional
        The poles and zeros of ``pz`` (complex; None when not asked for).
    card : object, optional
        The analysis card run (``tf``, ``noise``, ``pz``, ``tran``).
    transient : TransientInfo, optional
        Index, initial correction, jumps and events of a transient
        (:class:`netdae.metadata.TransientInfo`).
    noise : NoiseInfo, optional
        Integrated noise and contributions of ``noise``
        (:class:`netdae.metadata.NoiseInfo`).
    source : Provenance, optional
        Where a result read from a file or from ngspice came from
        (:class:`netdae.metadata.Provenance`); None for netdae's own results.

    Notes
    -----
    The former untyped ``extra`` dict is gone; :attr:`extra` remains for a
    transition as a read-only view of the typed fields under the old keys
    that warns (:class:`DeprecationWarning`).
    """

    analysis: str
    axes: dict[str, np.ndarray] = field(default_factory=dict)
    signals: dict[str, np.ndarray] = field(default_factory=dict)
    stats: Statistics = field(default_factory=Statistics)
    status: int = STATUS_OK
    message: str = ""
    tolerances: dict[str, float] = field(default_factory=dict)
    dense: Callable[[Any], dict[str, np.ndarray]] | None = None
    notes: list[str] = field(default_factory=list)
    measures: list[Any] = field(default_factory=list)
    fourier: list[Any] = field(default_factory=list)
    operating_point: "Result | None" = None
    poles: np.ndarray | None = None
    zeros: np.ndarray | None = None
    card: Any = None
    transient: TransientInfo | None = None
    noise: NoiseInfo | None = None
    source: Provenance | None = None

    def __post_init__(self):
        self.status = Status(self.status)
        if not isinstance(self.stats, Statistics):
            self.stats = Statistics.from_counts(self.stats)

    @property
    def noise_totals(self) -> dict[str, float]:
        """The integrated noise of a ``noise`` result (``noise.totals``); empty when there is none.

        Examples
        --------
        >>> Result("noise", noise=NoiseInfo(totals={"onoise_total": 1e-6})).noise_totals
        {'onoise_total': 1e-06}
        >>> Result("op").noise_totals
        {}
        """
        return self.noise.totals if self.noise is not None else {}

    @property
    def extra(self) -> types.MappingProxyType:
        """Deprecated: a read-only view of the typed fields under the former ``extra`` keys.

        ``extra["op"]`` is :attr:`operating_point`, ``extra["totals"]`` is
        ``noise.totals``, ``extra["jumps"]`` is ``transient.jumps``,
        ``extra["source"]`` is ``source.path`` ... (:data:`netdae.metadata.LEGACY_EXTRA`).
        """
        warnings.warn("Result.extra is deprecated: use the typed fields (operating_point, poles, zeros, card, "
                      "transient, noise, source)", DeprecationWarning, stacklevel=2)
        view: dict[str, Any] = {}
        for key, (attr, name) in LEGACY_EXTRA.items():
            holder = getattr(self, attr)
            value = holder if name is None else getattr(holder, name, None)
            if holder is not None and (value is not None or attr in ("transient", "noise")):
                view[key] = value
        return types.MappingProxyType(view)

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


    # -- signals by name ----------------------------------------------------------
    def __getitem__(self, name: str) -> np.ndarray:
        """The values of a signal: ``r["v(out)"]``, ``r["out"]``, ``r["v(a,b)"]``, ``r["i(v1)"]``.

        Case and blanks do not matter; a bare node name means its voltage and
        ``v(a,b)`` is formed from ``v(a)`` and ``v(b)`` when it is not stored.

        Raises
        ------
        KeyError
            For a name the result does not hold (the message lists what it has).
        TypeError
            For a name that is not a string.
        """
        if not isinstance(name, str):
            raise TypeError(f"a signal is named by a string such as 'v(out)' or 'i(v1)', not {name!r} "
                            f"(hint: r.names() lists them; r.signals maps each to its values)")
        key = name.strip().lower()
        if key in self.signals:
            return self.signals[key]
        try:
            sig = parse_signal(key)
        except ValueError as exc:
            raise KeyError(f"{exc}; have {self._have()}") from None
        if sig.name in self.signals:
            return self.signals[sig.name]
        if sig.is_difference:
            a, b = (self._node_voltage(nd, name) for nd in sig.args)
            return a - b
        raise KeyError(f"no signal {name!r}; have {self._have()}")

    def __contains__(self, name: object) -> bool:
        if not isinstance(name, str):
            return False
        try:
            self[name]
        except KeyError:
            return False
        return True

    def _have(self) -> str:
        return ", ".join(self.signals) or "no signals"

    def _node_voltage(self, node: str, asked: str) -> np.ndarray | float:
        if node == "0":
            return 0.0
        key = f"v({node})"
        if key not in self.signals:
            raise KeyError(f"no signal {asked!r}: node voltage {key} is not in the result; have {self._have()}")
        return self.signals[key]

    def names(self) -> list[str]:
        """Signal names in order."""
        return list(self.signals)

    def v(self, a: str, b: str | None = None) -> np.ndarray:
        """The voltage of node ``a``, or of ``a`` against ``b`` (``v(a) - v(b)``).

        Parameters
        ----------
        a, b : str
            Node names (``"0"`` or ``"gnd"`` for ground).

        Returns
        -------
        ndarray, shape (m,)
            Real, or complex phasors for an AC result.

        Examples
        --------
        >>> r = Result("op", signals={"v(a)": np.array([3.0]), "v(b)": np.array([1.0])})
        >>> r.v("a", "b"), r.v("b", "gnd")
        (array([2.]), array([1.]))
        """
        asked = f"v({a})" if b is None else f"v({a},{b})"
        sig = parse_signal(asked)
        if sig.name in self.signals:
            return self.signals[sig.name]
        values = [self._node_voltage(nd, asked) for nd in sig.args]
        diff = values[0] - values[1] if len(values) == 2 else values[0]
        return diff + np.zeros(self.points)  # v(0) is the scalar 0: give it the result's shape

    def i(self, element: str) -> np.ndarray:
        """The branch current ``i(element)`` (ngspice's sign: into n+, through the element)."""
        return self[f"i({element})"]

    def _ac(self, what: str, a: str, b: str | None) -> np.ndarray:
        if self.analysis != "ac":
            raise ValueError(f"{what}() is for AC results; this is a {self.analysis!r} result")
        return self.v(a, b)

    def vdb(self, a: str, b: str | None = None) -> np.ndarray:
        """The magnitude of an AC voltage in decibels, ``20 log10 |v(a) - v(b)|``.

        Raises
        ------
        ValueError
            For a result that is not AC.

        Examples
        --------
        >>> r = Result("ac", axes={"frequency": np.array([1.0])}, signals={"v(out)": np.array([0.1j])})
        >>> r.vdb("out"), r.vp("out")
        (array([-20.]), array([90.]))
        """
        with np.errstate(divide="ignore"):
            return 20.0 * np.log10(np.abs(self._ac("vdb", a, b)))

    def vp(self, a: str, b: str | None = None, *, unwrap: bool = False) -> np.ndarray:
        """The phase of an AC voltage in degrees, in (-180, 180] (``unwrap=True``: continuous along frequency).

        ngspice's ``vp()`` gives radians; this gives degrees.

        Raises
        ------
        ValueError
            For a result that is not AC.
        """
        phase = np.angle(self._ac("vp", a, b))
        return np.degrees(np.unwrap(phase) if unwrap else phase)

    def subset(self, names) -> "Result":
        """This result with only the signals ``names`` (``v(a,b)`` is formed from ``v(a)`` and ``v(b)``).

        Names are keyed by their canonical spelling (:func:`netdae.signals.canonical`).

        Raises
        ------
        KeyError
            For a name that is neither a signal nor a difference of two node voltages.

        Examples
        --------
        >>> r = Result("op", signals={"v(a)": np.array([3.0]), "v(b)": np.array([1.0])})
        >>> r.subset(["v(a,b)", "V(B, GND)"]).signals
        {'v(a,b)': array([2.]), 'v(b)': array([1.])}
        """
        out = {}
        for raw in names:
            values = self[raw]
            key = raw.strip().lower()
            out[key if key in self.signals else canonical_or(key)] = values
        return replace(self, signals=out)

    # -- presentation -------------------------------------------------------------
    def _summary(self) -> tuple[str, str, str]:
        """(points and axis, signals, status) phrases for repr and HTML."""
        axis = self.axis
        if axis is None or axis.size == 0:
            where = "1 point" if self.signals else "no points"
        else:
            unit = _AXIS_UNITS.get(self.axis_name or "", "")
            where = f"{axis.size} points, {self.axis_name} {axis[0]:.4g} to {axis[-1]:.4g}{unit}"
        names = self.names()
        shown = ", ".join(names[:_REPR_SIGNALS]) + (", ..." if len(names) > _REPR_SIGNALS else "")
        sig = f"{len(names)} signal{'s' if len(names) != 1 else ''}" + (f" ({shown})" if names else "")
        state = "ok" if self.ok else f"FAILED: {self.message}"
        return where, sig, state

    def __repr__(self) -> str:
        where, sig, state = self._summary()
        return f"<Result {self.analysis}: {where}; {sig}; {state}>"

    def _repr_html_(self) -> str:
        """A short table for notebooks: the summary, then the first and last point of every signal."""
        where, sig, state = self._summary()
        rows = []
        for name, values in self.signals.items():
            first = _fmt(values[0]) if len(values) else ""
            last = _fmt(values[-1]) if len(values) > 1 else ""
            rows.append(f"<tr><td>{html.escape(name)}</td><td>{first}</td><td>{last}</td></tr>")
        head = "<tr><th>signal</th><th>first</th><th>last</th></tr>"
        return (f"<div><b>netdae {html.escape(self.analysis)}</b>: {html.escape(where)}; "
                f"{html.escape(sig)}; {html.escape(state)}"
                f"<table>{head}{''.join(rows)}</table></div>")

    # -- export -------------------------------------------------------------------
    def to_dict(self, *, values: bool | None = None) -> dict[str, Any]:
        """The result as JSON-ready data, one schema for every analysis.

        Parameters
        ----------
        values : bool, optional
            Include the signal values; default only for a one-point result
            (an operating point). Complex values are ``[re, im]`` pairs.

        Returns
        -------
        dict
            ``analysis``, ``status``, ``ok``, ``message``, ``points``,
            ``axes`` (names, primary first), ``signals`` (names), ``values``
            (``{"axes": {name: list}, "signals": {name: list}}`` of lists,
            one entry per point, or None), ``stats`` (numbers, strings and
            nested dicts of them), ``tolerances``, ``notes``, ``measures``
            (one :meth:`netdae.measures.Measure.to_dict` per measurement).

        Examples
        --------
        >>> r = Result("op", signals={"v(a)": np.array([3.0])}, message="converged")
        >>> d = r.to_dict()
        >>> d["analysis"], d["points"], d["values"]
        ('op', 1, {'axes': {}, 'signals': {'v(a)': [3.0]}})
        """
        points = self.points
        if values is None:
            values = points == 1
        return {
            "analysis": self.analysis,
            "status": int(self.status),
            "ok": self.ok,
            "message": self.message,
            "points": points,
            "axes": list(self.axes),
            "signals": self.names(),
            "values": {"axes": {k: _json_values(v) for k, v in self.axes.items()},
                       "signals": {k: _json_values(v) for k, v in self.signals.items()}} if values else None,
            "stats": _json_scalars(self.stats.to_dict()),
            "tolerances": _json_scalars(self.tolerances),
            "notes": list(self.notes),
            "measures": [m.to_dict() for m in self.measures],
            **({"totals": _json_scalars(self.noise.totals)} if self.noise is not None and self.noise.totals
               else {}),
        }

    @property
    def points(self) -> int:
        """Number of points (1 for an operating point)."""
        if self.axis is not None:
            return int(self.axis.size)
        return int(len(next(iter(self.signals.values())))) if self.signals else 0

    def to_pandas(self):
        """The result as a :class:`pandas.DataFrame`: one row per point, one column per signal.

        The index is the sweep axis (``time``, ``frequency``, the swept
        source; a MultiIndex for a nested ``.dc``), none for an operating
        point. AC columns are complex.

        Raises
        ------
        ImportError
            When pandas is not installed (``pip install 'netdae[results]'``).
        """
        pd = optional_module("pandas", "Result.to_pandas()")
        frame = pd.DataFrame({name: np.asarray(v) for name, v in self.signals.items()})
        if self.axes:
            index = pd.MultiIndex.from_arrays(list(self.axes.values()), names=list(self.axes)) \
                if len(self.axes) > 1 else pd.Index(self.axis, name=self.axis_name)
            frame.index = index
        frame.attrs.update(analysis=self.analysis, status=int(self.status), message=self.message)
        return frame

    def to_xarray(self):
        """The result as an :class:`xarray.Dataset`: one variable per signal along the primary axis.

        The primary axis is the dimension and its coordinate; further ``.dc``
        axes are coordinates along it; an operating point has scalar
        variables. ``attrs`` hold ``analysis``, ``status``, ``message``.

        Raises
        ------
        ImportError
            When xarray is not installed (``pip install 'netdae[results]'``).
        """
        xr = optional_module("xarray", "Result.to_xarray()")
        dim = self.axis_name
        if dim is None:
            data = {name: ((), np.asarray(v)[0]) for name, v in self.signals.items()}
            coords = {}
        else:
            data = {name: ((dim,), np.asarray(v)) for name, v in self.signals.items()}
            coords = {name: ((dim,), np.asarray(v)) for name, v in self.axes.items()}
        return xr.Dataset(data, coords=coords,
                          attrs={"analysis": self.analysis, "status": int(self.status), "message": self.message})


#: Signals named in the repr.
_REPR_SIGNALS = 4
#: Units of the usual primary axes, for the repr.
_AXIS_UNITS = {"time": " s", "frequency": " Hz"}


def canonical_or(key: str) -> str:
    """The canonical spelling of a signal name, or the name as given when it does not parse."""
    try:
        return canonical(key)
    except ValueError:
        return key


def _fmt(value) -> str:
    if np.iscomplexobj(value):
        return f"{complex(value):.6g}"
    return f"{float(value):.6g}"


def _json_values(values) -> list:
    arr = np.asarray(values)
    if np.iscomplexobj(arr):
        return [[float(z.real), float(z.imag)] for z in arr]
    return [v if isinstance(v, str) else float(v) for v in arr.tolist()]


def _json_scalars(data: dict) -> dict:
    """The numbers, strings and booleans of a dict (nested dicts of them included), JSON-ready."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        if isinstance(v, (bool, np.bool_)):
            out[k] = bool(v)
        elif isinstance(v, (int, np.integer)):
            out[k] = int(v)
        elif isinstance(v, (float, np.floating)):
            out[k] = float(v)
        elif isinstance(v, str) or v is None:
            out[k] = v
        elif isinstance(v, dict):
            out[k] = _json_scalars(v)
    return out


def optional_module(module: str, what: str):
    """Import an optional dependency of the results (pandas, xarray) or say how to install it.

    Raises
    ------
    ImportError
        Naming ``what`` needs it and the ``results`` extra.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"{what} needs {module}, which is not installed; install netdae's "
                          f"'results' extra: pip install 'netdae[results]'") from None
