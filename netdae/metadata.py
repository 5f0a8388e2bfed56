"""Typed metadata of a :class:`~netdae.results.Result`, one record per kind.

A result's signals and statistics are the same for every analysis; what
else an analysis (or a reader of result files) knows lives in named,
frozen records:

- :class:`TransientInfo` (``result.transient``): the index analysis, the
  initial correction, the jumps and switch events of a transient;
- :class:`NoiseInfo` (``result.noise``): integrated noise and the devices'
  contributions;
- :class:`Provenance` (``result.source``): where a result read from a file
  or from ngspice came from (file, header, ngspice version, method).

The operating point of ``.ac``/``.pz``/``.tf``/``.noise``, the poles and
zeros of ``.pz`` and the analysis card are fields of the result itself.

>>> info = NoiseInfo(totals={"onoise_total": 2e-8})
>>> info.totals["onoise_total"], info.input_unit
(2e-08, None)
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any


if TYPE_CHECKING:
    from .dae.bdf.failures import IntegrationFailure

__all__ = ["TransientInfo", "NoiseInfo", "Provenance", "LEGACY_EXTRA"]


@dataclass(frozen=True)
class TransientInfo:
    """What a transient learned about its circuit on the way (``Result.transient``).

    Parameters
    ----------
    index : int
        Differentiation index of the circuit equations.
    index_method : str
        How the index was found.
    index2 : list of str
        Unknowns of index 2 or more.
    initial_correction : dict or None
        ``{"reason", "changed": {name: [old, new]}}`` when the initial values
        were made consistent, else None.
    impulses : list of str
        Warnings of impulses (derivatives of inputs at corners reaching an
        unknown).
    start : dict of str to float
        The values at t0 before correction.
    failure : IntegrationFailure or None
        Where and why a failed run stopped (:class:`netdae.dae.bdf.failures.IntegrationFailure`:
        ``t``, ``h``, ``what``, ``worst``, ``hint``; ``as_dict()`` for JSON).
    jumps : list of (float, list of str)
        Times the solution jumps and the unknowns that jump.
    events : list of (float, list of str)
        Times switches change state and the switches.
    index_report : object or None
        The structural index report used (:mod:`netdae.dae`).
    """

    index: int = 0
    index_method: str = ""
    index2: list[str] = field(default_factory=list)
    initial_correction: dict | None = None
    impulses: list[str] = field(default_factory=list)
    start: dict[str, float] = field(default_factory=dict)
    failure: IntegrationFailure | None = None
    jumps: list = field(default_factory=list)
    events: list = field(default_factory=list)
    index_report: Any = None


@dataclass(frozen=True)
class NoiseInfo:
    """Integrated noise of a ``.noise`` result (``Result.noise``).

    Parameters
    ----------
    totals : dict of str to float
        ngspice's "Integrated Noise" plot: ``{"onoise_total": V,
        "inoise_total": V or A, ...}``; empty at a single frequency (ngspice
        writes none).
    contributions : dict of str to dict
        Each device's ``onoise_total`` and share of the output noise power.
    input_unit : str or None
        ``"V"`` or ``"A"``: the unit of the input-referred noise (None when
        not known, e.g. read from a file without it).
    """

    totals: dict[str, float] = field(default_factory=dict)
    contributions: dict[str, dict] = field(default_factory=dict)
    input_unit: str | None = None


@dataclass(frozen=True)
class Provenance:
    """Where a result read from a file or from ngspice came from (``Result.source``).

    Every field is optional; a field that a source does not give is None.

    Parameters
    ----------
    path : str, optional
        The file read.
    title, date, plotname : str, optional
        The raw file's header lines.
    plot : str, optional
        ngspice's plot name (``tran1`` ...), results from shared ngspice.
    flags, commands, options : list of str, optional
        The raw file's ``Flags:``, ``Command:`` and ``Option:`` lines (never
        executed).
    dimensions : object, optional
        The raw file's ``Dimensions:`` line.
    circuit : str, optional
        The raw file's ``Circuit:`` line.
    temp, tnom : float, optional
        The raw file's ``Temperature:`` line.
    variable_types : dict of str to str, optional
        Signal name to ngspice's type (``voltage``, ``current`` ...).
    points_announced : int, optional
        The number of points the header announces.
    unknown_header_lines : list of str, optional
        Header lines netdae does not know, kept as read.
    ngspice_version : str, optional
        The ngspice that computed the result.
    backend : str, optional
        How ngspice was run (``"shared"``, ``"batch"``).
    method : str, optional
        ngspice's integration method (``"trap"``, ``"gear"``).
    """

    path: str | None = None
    title: str | None = None
    date: str | None = None
    plotname: str | None = None
    plot: str | None = None
    flags: list[str] | None = None
    commands: list[str] | None = None
    options: list[str] | None = None
    dimensions: Any = None
    circuit: str | None = None
    temp: float | None = None
    tnom: float | None = None
    variable_types: dict[str, str] | None = None
    points_announced: int | None = None
    unknown_header_lines: list[str] | None = None
    ngspice_version: str | None = None
    backend: str | None = None
    method: str | None = None

    def given(self) -> dict[str, Any]:
        """The fields that are set, by name.

        Examples
        --------
        >>> Provenance(path="a.raw", method="gear").given()
        {'path': 'a.raw', 'method': 'gear'}
        """
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}


#: The keys of the former ``Result.extra`` dict and where each lives now
#: (``(attribute of Result, field of the record or None)``).
LEGACY_EXTRA: dict[str, tuple[str, str | None]] = {
    "op": ("operating_point", None), "poles": ("poles", None), "zeros": ("zeros", None),
    "card": ("card", None),
    **{f.name: ("transient", f.name) for f in fields(TransientInfo)},
    **{f.name: ("noise", f.name) for f in fields(NoiseInfo)},
    **{f.name: ("source", f.name) for f in fields(Provenance) if f.name != "path"},
    "source": ("source", "path"),
}
