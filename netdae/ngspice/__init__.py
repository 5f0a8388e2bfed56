"""Run a netlist in ngspice and collect its results as netdae Results.

ngspice is netdae's reference: every waveform netdae computes can be set
against ngspice's on the same netlist. Two ways to run it:

``"shared"``
    ngspice's shared library (``libngspice``) in this process, through
    PySpice's binding (:mod:`netdae.ngspice.shared`, the only module of netdae
    that imports PySpice). Results come straight from ngspice's memory.
``"subprocess"``
    ``ngspice -b -n -r out.raw netlist.cir`` in a temporary directory
    (:mod:`netdae.ngspice.batch`); the binary raw file is read with netdae's
    own reader, :func:`netdae.io.raw.read_raw`.
``"auto"`` (default)
    The shared library, or the subprocess when the library cannot be loaded
    or has exited; the run's notes say so.

Both give the same doubles: a transient result holds ngspice's own accepted
time points at full precision.

Before running, the netlist is translated (:func:`translate_for_ngspice`):
netdae writes it out as one self-contained netlist (includes and library
sections expanded by netdae's reader, no control-language card, nothing after
``.end``; :mod:`netdae.ngspice.deck`), netdae's ideal op-amp becomes a
high-gain VCVS, ``.options interp`` and ``filetype`` are removed; on request,
options are overridden (:func:`override_options`). Nothing else is changed:
ngspice runs with its own defaults. Every change is a note in the returned
:class:`NgspiceRun` and in each of its results.

ngspice never runs a command of the netlist's: no ``.control`` block, script
title, ``*#`` line or ``.include`` reaches it, it never reads the user's
files or ``.spiceinit``, and it runs in a private temporary directory (both
backends). See ``docs/ngspice.md``, "What ngspice is allowed to do".

Signals are named as netdae names them: ``v(node)``, ``i(element)`` (ngspice's
``l.xa.x1.l1#branch`` becomes ``i(l.xa.x1.l1)``), the axis of a ``.dc``
sweep by the swept source (``v1``; a nested sweep has two axes).

Examples
--------
>>> from netdae.ngspice import run_ngspice, available
>>> if available():  # doctest: +SKIP
...     run = run_ngspice("divider\\nV1 in 0 1\\nR1 in out 1k\\nR2 out 0 1k\\n.op\\n.end\\n")
...     run.result("op")["v(out)"]
array([0.5])
"""

from __future__ import annotations

import dataclasses
import os
import re
import shutil
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import NgspiceError
from ..metadata import Provenance
from ..netlist.reader import resolve_behavior
from ..results import Result
from .measures import read_measures
from .translate import (
    OPAMP_GAIN,
    DcSweepCard,
    classify_output,
    dc_sweeps,
    effective_tolerances,
    override_options,
    translate_for_ngspice,
)

__all__ = [
    "INSTALL_HINT",
    "BACKENDS",
    "DEFAULT_TIMEOUT",
    "check_timeout",
    "OPAMP_GAIN",
    "NgspiceRun",
    "run_ngspice",
    "run_ngspice_file",
    "available",
    "ngspice_version",
    "translate_for_ngspice",
    "override_options",
    "RUNS_LAST_TO_FIRST",
]

#: How to install what this module needs on Debian/Ubuntu.
INSTALL_HINT = "sudo apt-get install ngspice libngspice0 libngspice0-dev"
BACKENDS = ("auto", "shared", "subprocess")

#: What ngspice says about a plot without vectors (a .pz with no finite pole or zero).
_NO_VECTORS = re.compile(r"there are no vectors currently active", re.I)
#: Seconds a run may take before it is stopped (a generous bound: the
#: netlists netdae compares run in well under a second).
DEFAULT_TIMEOUT = 300.0
#: Error lines quoted in an NgspiceError (ngspice can print hundreds).
_MAX_ERROR_LINES = 12
#: ngspice 39 runs several cards of these analyses last to first (measured; the analysis commands of
#: a ``.control`` block reach it as cards): its k-th result of such a kind is the k-th card from the end.
RUNS_LAST_TO_FIRST = frozenset({"ac", "dc", "pz", "tf", "noise"})
#: ``DBL_EPSILON * 1e3``: ngspice's tolerance for the end of a dc sweep.
_SWEEP_END_TOLERANCE = np.finfo(float).eps * 1e3


@dataclass
class BackendOutput:
    """What a backend hands back: raw material for :class:`NgspiceRun`.

    ``results`` have netdae's signal names but ngspice's dc axis names
    (``v-sweep``); ``read_error`` is set when the results could not be
    collected (a raw file cut short by an error ngspice reported).
    """

    results: list[Result]
    stdout: list[str]
    stderr: list[str]
    version: str
    returncode: int | None = None
    read_error: str | None = None
    notes: list[str] = field(default_factory=list)


class BackendUnavailable(NgspiceError):
    """A backend cannot run here (library missing, exited, crashed): try the other."""


@dataclass
class NgspiceRun:
    """The outcome of one ngspice run.

    Attributes
    ----------
    results : list of Result
        One per analysis, in the order ngspice ran them. Each carries the
        notes below, ``tolerances`` (ngspice's defaults overridden by the
        netlist's ``.options``) and ``source`` (:class:`netdae.metadata.Provenance`) with
        ``ngspice_version``, ``backend`` and ``method``.
    version : str
        ``"ngspice-39"``.
    backend : str
        ``"shared"`` or ``"subprocess"``.
    netlist : str
        The text ngspice actually ran.
    notes : list of str
        Every change made to the netlist and every choice made for the run.
    warnings : list of str
        ngspice's own warnings and notes (stderr).
    stdout, stderr : str
        ngspice's output.
    elapsed : float
        Wall time of the run [s].
    measures : list of Measure
        ngspice's value (or failure and reason) of every ``.meas`` card, in
        card order (:func:`netdae.ngspice.measures.read_measures`).
    """

    results: list[Result]
    version: str
    backend: str
    netlist: str
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    stdout: str = ""
    stderr: str = ""
    elapsed: float = 0.0
    measures: list = field(default_factory=list)

    def result(self, analysis: str) -> Result:
        """The first result of an analysis (``"op"``, ``"dc"``, ``"ac"``, ``"tran"``)."""
        for result in self.results:
            if result.analysis == analysis:
                return result
        have = ", ".join(r.analysis for r in self.results) or "none"
        raise KeyError(f"no {analysis} result in this ngspice run (have: {have})")


def available() -> bool:
    """True when the ngspice executable or its shared library is installed."""
    from . import shared

    path = shared.library_path()
    library = path is not None and (os.sep not in path or os.path.exists(path))
    return shutil.which("ngspice") is not None or library


def ngspice_version(backend: str = "auto") -> str:
    """The ngspice version, e.g. ``"ngspice-39"``.

    Raises
    ------
    NgspiceError
        When ngspice is not installed (with the command that installs it).
    """
    _check_backend(backend)
    from . import batch, shared

    if backend in ("auto", "shared"):
        try:
            return shared.version()
        except BackendUnavailable:
            if backend == "shared":
                raise
    return batch.version()


def run_ngspice(
    text: str,
    *,
    backend: str = "auto",
    workdir: str | os.PathLike | None = None,
    timeout: float | None = None,
    options: dict | None = None,
    opamp_gain: float = OPAMP_GAIN,
    strict: bool = True,
    source: str = "<string>",
    behavior=None,
) -> NgspiceRun:
    """Run a netlist in ngspice and return its results as netdae Results.

    Parameters
    ----------
    text : str
        The netlist (netdae's dialect; translated for ngspice, see
        :func:`translate_for_ngspice`).
    backend : {"auto", "shared", "subprocess"}
        How to run ngspice (module docstring).
    workdir : path-like, optional
        Directory relative ``.include``/``.lib`` paths refer to (the
        netlist's directory); the current directory by default.
    timeout : float, optional
        Seconds before the run is stopped (the subprocess killed, the
        library's thread halted) and an error raised; default
        :data:`DEFAULT_TIMEOUT`, ``math.inf`` for no limit.
    options : dict, optional
        Options to override, e.g. ``{"reltol": 1e-6, "method": "gear",
        "maxstep": 1e-7}`` (:func:`override_options`).
    opamp_gain : float
        Gain of the VCVS standing for netdae's ideal op-amp.
    strict : bool
        When True (default), ngspice's "singular matrix" warning is an error:
        ngspice then continues with gmin or source stepping and its answer
        depends on them.
    source : str
        Name of the netlist in messages.
    behavior : str, optional
        ngspice's compatibility mode (``set ngbehavior=`` value, ``""``: none); default: the
        ``.spiceinit`` next to the netlist (in ``workdir``), else in the working directory, as
        netdae reads it (:func:`netdae.netlist.compat.find_behavior`). ngspice runs in it: the
        backends set ``ngbehavior`` (nothing else of the user's file), with ``a`` added to a
        PSpice mode without it (:attr:`netdae.netlist.compat.Behavior.ngspice_value`).

    Returns
    -------
    NgspiceRun

    Raises
    ------
    NgspiceError
        When ngspice is not installed (the message gives the install command),
        reports an error (its message is quoted), times out, or produces no
        analysis result.
    NetlistError
        When a netdae extension in the netlist is malformed, a file it
        includes cannot be read, or it holds a card netdae does not hand to
        ngspice (:func:`netdae.ngspice.deck.self_contained`).
    """
    _check_backend(backend)
    seconds = check_timeout(timeout)
    limit = None if seconds == float("inf") else seconds
    start = time.perf_counter()
    base_dir = os.fspath(workdir) if workdir is not None else os.getcwd()
    mode, _ = resolve_behavior(behavior, base_dir)
    netlist, notes = translate_for_ngspice(text, opamp_gain=opamp_gain, base_dir=base_dir, source=source,
                                           behavior=mode if mode is not None else "")
    if options:
        netlist, more = override_options(netlist, **options)
        notes += more
    ngbehavior = mode.ngspice_value if mode is not None else None
    if ngbehavior is not None and mode.all or (ngbehavior is not None and ngbehavior != mode.value):
        # ngspice 39 translates all cards but the first after the title (pspice_compat_a starts at its
        # successor): a comment stands there, as the '*.include' line of an include does in ngspice's own deck
        title, _, rest = netlist.partition("\n")
        netlist = f"{title}\n* netdae: the card ngspice's all-files compatibility mode does not translate\n{rest}"
    if ngbehavior is not None:
        notes.append(f"ngspice run with 'set ngbehavior={ngbehavior}'" + (
            f" (the netlist's {mode.value} with 'a': netdae hands ngspice one file, its includes expanded, so the "
            "main file's cards are translated too)" if ngbehavior != mode.value else ""))
    output, used = _run_backend(netlist, backend, limit, notes, ngbehavior)
    notes += output.notes
    measures, rest_out, rest_err = read_measures(netlist, output.stdout, output.stderr)
    if any(r.analysis == "pz" and not r.signals for r in output.results):
        # a .pz without finite poles or zeros (a resistive circuit) makes an empty plot, and ngspice says
        # 'Error: There are no vectors currently active.' about it: its answer, not a failure
        rest_err = [line for line in rest_err if not _NO_VECTORS.search(line)]
        rest_out = [line for line in rest_out if not _NO_VECTORS.search(line)]
        notes.append("ngspice's .pz found no finite pole or zero (its empty plot made it say 'There are no "
                     "vectors currently active')")
    errors, warnings = classify_output(rest_err, rest_out, strict=strict)
    if errors:
        raise NgspiceError(_failure_message(source, errors, strict))
    if output.returncode not in (None, 0):
        tail = "\n".join(output.stderr[-_MAX_ERROR_LINES:])
        raise NgspiceError(f"ngspice failed on {source}: it exited with status {output.returncode}\n{tail}")
    if output.read_error:
        raise NgspiceError(f"ngspice ran {source} but its results cannot be read: {output.read_error}")
    if not output.results:
        raise NgspiceError(
            f"ngspice produced no results for {source}: the netlist has no analysis card "
            "(.op, .dc, .ac, .tran, .pz, .tf, .noise or .sens)"
        )
    results = output.results
    from .deck import SCRIPT_MARK

    _name_dc_axes(results, dc_sweeps(netlist), notes, in_order=SCRIPT_MARK in netlist.split("\n"))
    tolerances, method = effective_tolerances(netlist)
    for result in results:
        result.notes = [*notes, *(f"ngspice: {w}" for w in warnings), *result.notes]
        result.tolerances = dict(tolerances)
        result.source = dataclasses.replace(result.source or Provenance(), ngspice_version=output.version,
                                            backend=used, method=method or "trap")
    return NgspiceRun(
        results=results,
        version=output.version,
        backend=used,
        netlist=netlist,
        notes=notes,
        warnings=warnings,
        stdout="\n".join(output.stdout),
        stderr="\n".join(output.stderr),
        elapsed=time.perf_counter() - start,
        measures=measures,
    )


def run_ngspice_file(path: str | os.PathLike, **kwargs) -> NgspiceRun:
    """Run a netlist file; relative includes refer to its directory.

    Parameters
    ----------
    path : path-like
        The netlist.
    **kwargs
        As for :func:`run_ngspice` (``workdir`` defaults to the file's directory).

    Raises
    ------
    NgspiceError
        When the file cannot be read, and as :func:`run_ngspice`.
    """
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            text = handle.read()
    except OSError as exc:
        raise NgspiceError(f"{path}: cannot read netlist: {exc.strerror}") from None
    kwargs.setdefault("workdir", os.path.dirname(os.path.abspath(path)))
    kwargs.setdefault("source", os.fspath(path))
    return run_ngspice(text, **kwargs)


def check_timeout(timeout: float | None) -> float:
    """The caller's ``timeout`` as seconds (None: :data:`DEFAULT_TIMEOUT`).

    Raises
    ------
    NgspiceError
        When it is not a positive number (``math.inf`` is allowed: no limit).
    """
    if timeout is None:
        return DEFAULT_TIMEOUT
    try:
        value = float(timeout)
    except (TypeError, ValueError):
        raise NgspiceError(f"the ngspice timeout must be a number of seconds, got {timeout!r}") from None
    if not value > 0:
        raise NgspiceError(f"the ngspice timeout must be positive, got {timeout!r}")
    return value


def _check_backend(backend: str) -> None:
    if backend not in BACKENDS:
        raise NgspiceError(f"unknown ngspice backend {backend!r}; choose one of {', '.join(BACKENDS)}")


def _run_backend(netlist: str, backend: str, timeout: float | None, notes: list[str],
                 ngbehavior: str | None = None) -> tuple[BackendOutput, str]:
    from . import batch, shared

    if backend == "subprocess":
        return batch.run(netlist, timeout=timeout, ngbehavior=ngbehavior), "subprocess"
    try:
        return shared.run(netlist, timeout=timeout, ngbehavior=ngbehavior), "shared"
    except BackendUnavailable as exc:
        if backend == "shared":
            raise
        reason = str(exc)
    try:
        output = batch.run(netlist, timeout=timeout, ngbehavior=ngbehavior)
    except BackendUnavailable as exc:
        raise NgspiceError(
            f"ngspice cannot be run: {reason}; and {exc}. Install it with: {INSTALL_HINT}"
        ) from None
    notes.append(f"ngspice's shared library cannot be used ({reason}); ran ngspice as a subprocess")
    return output, "subprocess"


def _failure_message(source: str, errors: list[str], strict: bool) -> str:
    quoted = "\n  ".join(errors[:_MAX_ERROR_LINES])
    more = f"\n  ... ({len(errors) - _MAX_ERROR_LINES} more lines)" if len(errors) > _MAX_ERROR_LINES else ""
    text = f"ngspice failed on {source}:\n  {quoted}{more}"
    if strict and any("singular matrix" in e.lower() for e in errors):
        text += (
            "\n(hint: ngspice found a singular matrix, typically a node without a DC path to ground or a "
            "loop of voltage sources or inductors; 'netdae check FILE' names the elements; ngspice may go on "
            "with gmin stepping, whose result netdae.ngspice.run(..., strict=False) accepts)"
        )
    return text


def _sweep_values(start: float, stop: float, step: float) -> np.ndarray:
    """The values ngspice visits: ``start``, then ``+= step`` while not past ``stop``."""
    values = []
    value = start
    if step == 0.0:
        return np.array([start])
    while np.sign(step) * (value - stop) <= _SWEEP_END_TOLERANCE:
        values.append(value)
        value += step
    return np.array(values)


def _name_dc_axes(results: list[Result], cards: list[DcSweepCard], notes: list[str], in_order: bool = False) -> None:
    """Rename dc axes after the swept sources; add the outer axis of a nested sweep.

    ngspice runs several ``.dc`` cards last to first, the ``dc`` commands of netdae's
    control block (``in_order``) in order.
    """
    dc_results = [r for r in results if r.analysis == "dc"]
    if not dc_results:
        return
    if len(dc_results) != len(cards):
        notes.append(
            f"{len(dc_results)} dc results but {len(cards)} .dc cards: dc axes keep ngspice's names (v-sweep ...)"
        )
        return
    for result, card in zip(dc_results, cards if in_order else reversed(cards)):
        (old_name, inner), *_ = result.axes.items()
        axes = {card.sources[0]: inner}
        if len(card.sources) == 2:
            outer = _outer_axis(inner, card)
            if outer is None:
                notes.append(
                    f".dc {' '.join(card.sources)}: cannot rebuild the values of {card.sources[1]} "
                    "(ngspice writes only the inner sweep); the result has one axis"
                )
            else:
                axes[card.sources[1]] = outer
        result.axes = axes


def _outer_axis(inner: np.ndarray, card: DcSweepCard) -> np.ndarray | None:
    if None in card.ranges:
        return None
    n_inner = len(_sweep_values(*card.ranges[0]))
    outer = _sweep_values(*card.ranges[1])
    if n_inner == 0 or len(inner) != n_inner * len(outer):
        return None
    return np.repeat(outer, n_inner)
