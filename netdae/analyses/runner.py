"""Run the analyses of a netlist: :func:`run` (every card) and :func:`simulate` (its ``.tran``).

This is what ``netdae run FILE``, :func:`netdae.run` and
:func:`netdae.simulate` do: check the options (the netlist's ``.options``
and the caller's overrides) against their valid ranges, dispatch each
``.op``, ``.dc``, ``.ac``, ``.tran``, ``.pz``, ``.tf``, ``.noise`` and ``.sens`` card of
the circuit to its analysis and collect the :class:`~netdae.results.Result`
objects.

The module imports no numerics at load time, so the command line can use
:func:`option_problem` to check its arguments without loading numpy.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..circuit import STAMP_MAGNITUDES, TOLERANCE_MIN, AcAnalysis, Circuit, DcAnalysis, NoiseAnalysis, OpAnalysis, PzAnalysis, \
    SensAnalysis, TfAnalysis, TranAnalysis
from ..errors import CircuitError, NetdaeError, NetlistError
from ..kinds import Kind

if TYPE_CHECKING:
    from ..results import Result

__all__ = ["run", "simulate", "measure", "fourier", "analysis_name", "unused_options", "option_problem", "check_options",
           "OPTION_RANGES", "USED_EXTRA_OPTIONS", "ABSOLUTE_ZERO", "refuse_steps"]

#: Absolute zero in degrees Celsius: the lowest ``temp``/``tnom``.
ABSOLUTE_ZERO = -273.15


def _positive(v: float) -> bool:
    return math.isfinite(v) and 0.0 < v <= STAMP_MAGNITUDES[1]  # beyond, residuals and weights overflow


def _tolerance(v: float) -> bool:
    return math.isfinite(v) and TOLERANCE_MIN <= v <= STAMP_MAGNITUDES[1]  # below, no step from zero passes


def _fraction(v: float) -> bool:
    return 0.0 < v < 1.0


def _temperature(v: float) -> bool:
    return math.isfinite(v) and v > ABSOLUTE_ZERO


def _order(v: float) -> bool:
    from ..dae.bdf import MAX_ORDER

    return v == int(v) and 1 <= v <= MAX_ORDER


def _count(v: float) -> bool:
    return math.isfinite(v) and v == int(v) and v >= 1


#: Options kept in ``Options.extra`` that netdae's devices read (the MOSFET defaults).
USED_EXTRA_OPTIONS = frozenset({"defl", "defw", "defad", "defas", "savecurrents", "nfreqs", "fourgridsize"})
#: Those the M elements run as bundled ports read (BSIM3, BSIM4, MOS2, MOS3 sizes; BSIM bins):
#: :mod:`netdae.devices.osdi.spice_models`.
BSIM_OPTIONS = frozenset({"scale", "wnflag"})

#: The options netdae uses, with their valid values: name -> (test, what is expected).
OPTION_RANGES: dict[str, tuple[Callable[[float], bool], str]] = {
    "reltol": (_fraction, "a relative tolerance between 0 and 1 (exclusive), e.g. 1e-3"),
    "abstol": (_tolerance, f"a current tolerance in amperes from {TOLERANCE_MIN:g} (netdae's error test meets no "
                           "smaller one; ngspice, which tests only charges, takes it) up to 1e150, e.g. 1e-12"),
    "vntol": (_tolerance, f"a voltage tolerance in volts from {TOLERANCE_MIN:g} up to 1e150, e.g. 1e-6"),
    "chgtol": (_tolerance, f"a charge tolerance in coulombs from {TOLERANCE_MIN:g} up to 1e150, e.g. 1e-14"),
    "gmin": (_positive, "a positive conductance in siemens up to 1e150, e.g. 1e-12"),
    "temp": (_temperature, f"a temperature in degC above absolute zero ({ABSOLUTE_ZERO})"),
    "tnom": (_temperature, f"a temperature in degC above absolute zero ({ABSOLUTE_ZERO})"),
    "maxord": (_order, "a BDF order from 1 to 5"),
    "itl1": (_count, "a positive number of Newton iterations"),
    "itl4": (_count, "a positive number of Newton iterations"),
    "max_step": (_positive, "a positive time step in seconds up to 1e150"),
}


def option_problem(name: str, value: Any) -> str | None:
    """What is wrong with an option value, or None when it is valid.

    Parameters
    ----------
    name : str
        An option netdae uses (``reltol``, ``abstol``, ``vntol``, ``chgtol``,
        ``gmin``, ``temp``, ``tnom``, ``maxord``, ``itl1``, ``itl4``,
        ``max_step``).
    value : float

    Returns
    -------
    str or None
        ``"expected ..."`` naming the valid values.

    Examples
    --------
    >>> option_problem("reltol", 1e-4) is None
    True
    >>> option_problem("reltol", 2.0)
    'expected a relative tolerance between 0 and 1 (exclusive), e.g. 1e-3'
    """
    test, expected = OPTION_RANGES[name]
    try:
        ok = test(float(value))
    except (TypeError, ValueError, OverflowError):
        ok = False
    return None if ok else f"expected {expected}"


def check_options(circuit: Circuit, **overrides: Any) -> None:
    """Check the circuit's ``.options`` and the caller's overrides against :data:`OPTION_RANGES`.

    Parameters
    ----------
    circuit : Circuit
    **overrides
        Values given by the caller (None: not given), e.g. ``reltol=1e-4``.

    Raises
    ------
    NetlistError
        For an ``.options`` value out of range (``reltol=2``, ``temp=-300``).
    ValueError
        For an override out of range.
    TypeError
        For an override that is not a number (``reltol="1e-3"``).
    """
    for name, value in overrides.items():
        if value is not None and (isinstance(value, (bool, str, bytes)) or not isinstance(value, numbers.Real)):
            raise TypeError(f"{name} must be a number, not {type(value).__name__} ({value!r})")
        if value is not None and (problem := option_problem(name, value)) is not None:
            raise ValueError(f"{name}={value!r}: {problem}")
    o = circuit.options
    for name in OPTION_RANGES:
        value = getattr(o, name, None)
        if value is None or overrides.get(name) is not None:
            continue
        if option_problem(name, value) is not None:
            card = ".options temp (or .temp)" if name == "temp" else f".options {name}"
            where = o.locations.get(name)
            raise NetlistError(f"{card}={value:g} is out of range" if where is not None
                               else f"{circuit.path}: {card}={value:g} is out of range", where,
                               expected=f"{name}: {OPTION_RANGES[name][1]}",
                               hint=f"correct or remove {name} in the .options card")


def check_callable(value, name: str, form: str) -> None:
    """Refuse an argument that should be a callback before anything runs (not when it is first called, after
    the work it reports on).

    Raises
    ------
    TypeError
        ``value`` is neither None nor callable.

    >>> check_callable(print, "progress", "progress(done, total)")
    >>> check_callable(3, "progress", "progress(done, total)")
    Traceback (most recent call last):
    ...
    TypeError: progress must be a function called as progress(done, total), not int (3)
    """
    if value is not None and not callable(value):
        raise TypeError(f"{name} must be a function called as {form}, not {type(value).__name__} ({value!r})")


def string_entries(value: Any, what: str) -> tuple[str, ...] | None:
    """An API argument that names things (``save=``, ``measures=``, ``analyses=``) as a tuple of strings.

    One string is one entry (``save="v(out)"`` saves ``v(out)``); None stays None.

    Raises
    ------
    TypeError
        Neither a string nor an iterable of strings.

    Examples
    --------
    >>> string_entries(("v(out)", "i(v1)"), "save")
    ('v(out)', 'i(v1)')
    >>> string_entries("v(out)", "save")
    ('v(out)',)
    """
    if value is None:
        return None
    if isinstance(value, str):
        return (value,)
    if isinstance(value, bytes):
        raise TypeError(f"{what} must be a string or a list of strings, not bytes ({value!r})")
    try:
        items = tuple(value)
    except TypeError:
        raise TypeError(f"{what} must be a string or a list of strings, not {type(value).__name__}") from None
    for item in items:
        if not isinstance(item, str):
            raise TypeError(f"{what} must hold strings, not {type(item).__name__} ({item!r})")
    return items


def analysis_name(card: Any) -> str:
    """``"op"``, ``"dc"``, ``"ac"``, ``"tran"``, ``"pz"``, ``"tf"``, ``"noise"`` or ``"sens"`` for an analysis card."""
    if isinstance(card, OpAnalysis):
        return "op"
    if isinstance(card, DcAnalysis):
        return "dc"
    if isinstance(card, AcAnalysis):
        return "ac"
    if isinstance(card, TranAnalysis):
        return "tran"
    if isinstance(card, PzAnalysis):
        return "pz"
    if isinstance(card, TfAnalysis):
        return "tf"
    if isinstance(card, NoiseAnalysis):
        return "noise"
    if isinstance(card, SensAnalysis):
        return "sens"
    raise TypeError(f"not an analysis card: {card!r}")


def _circuit(circuit: Circuit | str | os.PathLike) -> Circuit:
    if isinstance(circuit, Circuit):
        return circuit
    from ..netlist import load

    return load(circuit)


def refuse_steps(circuit: Circuit) -> None:
    """A netlist with ``.step`` cards is a sweep: say how to run it."""
    if circuit.steps:
        first = circuit.steps[0]
        where = f"{first.location}: " if first.location else ""
        names = ", ".join(s.name for s in circuit.steps)
        raise NetdaeError(f"{where}the netlist steps {names} (.step): a sweep, which 'netdae sweep FILE --out DIR' "
                          "or netdae.sweep() runs; run, simulate and compare run one point")


def run(circuit: Circuit | str | os.PathLike, *, save: list[str] | None = None,
        reltol: float | None = None, abstol: float | None = None, vntol: float | None = None,
        progress: Callable[[float, float, int], None] | None = None,
        output: Callable[[int, int, Result], str | None] | None = None, bounded: bool = False,
        room: int | None = None) -> list[Result]:
    """Run every analysis of a circuit, in netlist order.

    Parameters
    ----------
    circuit : Circuit, str or path-like
        An elaborated circuit, or a netlist file or text for :func:`netdae.load`.
    save : list of str, optional
        Signals to keep in every result (``v(out)``, ``v(a,b)``, ``i(v1)``);
        default: the netlist's ``.save``/``.print``/``.probe`` signals, or
        every unknown. Noise vectors (``onoise_spectrum``, ``onoise_q1`` ...)
        select a ``.noise`` result's densities (all without them).
    reltol, abstol, vntol : float, optional
        Tolerances for every analysis (default: the netlist's ``.options``,
        else SPICE's 1e-3, 1e-12 A, 1e-6 V).
    progress : callable, optional
        ``progress(t, tstop, steps)`` for transients, called a few times per second.
    output : callable, optional
        ``output(position, start, block) -> str | None``: a transient's points
        as they are computed (``position`` the card's among the analyses;
        ``start`` and ``block`` as for :func:`netdae.analyses.tran.transient`,
        the block holding the signals of the returned result, in its order);
        a text returned stops the transient with that reason. Only for the
        transients whose result is their integrator's accepted points and
        holds no device quantity (``i(r1)``, ``@q1[gm]``, computed after the
        run); the others are never streamed.
    bounded : bool
        With ``output``: a streamed transient keeps only its last points in
        memory (``bounded`` of :func:`netdae.analyses.tran.transient`) unless
        a ``.meas`` card needs them all.
    room : int, optional
        With ``bounded``: the bytes free where ``output`` writes, against
        which a bounded transient's size is checked before it runs (instead
        of the memory).

    Returns
    -------
    list of Result
        One per analysis card, in netlist order.

    Raises
    ------
    NetlistError
        Bad input, or an ``.options`` value out of range.
    ValueError
        A tolerance out of range.
    NetdaeError
        No analysis card; a ``save`` name the circuit does not have; ``.step``
        cards (a sweep: :func:`netdae.sweep`).
    CircuitError, ConvergenceError
        A circuit that cannot be simulated, a failed operating point; a
        transient that fails mid-way, and a ``.dc`` sweep whose point fails
        after its first, return a Result with a failure status instead (the
        points computed before it), and the analyses after it run.
    KeyboardInterrupt
        Ctrl-C (or, on the command line, SIGTERM or SIGHUP) during an analysis;
        its ``results`` attribute holds the results of the analyses before it
        and a transient or ``.dc`` sweep up to where it stopped (status
        failed, the message saying so).

    Examples
    --------
    >>> import netdae
    >>> op, dc = netdae.run("netlists/voltage_divider.cir", save=["v(out)"])
    >>> op.names(), round(float(op["v(out)"][0]), 6), dc.axis_name
    (['v(out)'], 3.333333, 'v1')
    """
    circuit = _circuit(circuit)
    refuse_steps(circuit)
    check_callable(progress, "progress", "progress(t, tstop, steps)")
    check_callable(output, "output", "output(position, start, block)")
    options = {k: v for k, v in (("reltol", reltol), ("abstol", abstol), ("vntol", vntol)) if v is not None}
    check_options(circuit, **options)
    if not circuit.analyses:
        raise NetdaeError(
            f"{circuit.path}: the netlist has no analysis card (.op, .dc, .ac, .tran, .pz, .tf, .noise or .sens); nothing "
            "to run"
            + _skipped_analyses(circuit)
        )
    names = list(string_entries(save, "save")) if save is not None else circuit.saves
    from ..results import canonical_or
    from .noise import is_noise_name
    from .magnitude import absurd_values_note
    from .op import shared_operating_points
    from .quantities import add_quantities, measured_quantities, plan_quantities, saved_currents

    noise_names = [n for n in names or () if is_noise_name(n)]  # only noise results have them
    if noise_names:
        names = [n for n in names if not is_noise_name(n)]
    if save is not None:
        check_saved_names(circuit, names)
    wanted = _with_measured(names, circuit)

    computed_from, quantities = plan_quantities(circuit, wanted)
    if not names:  # every unknown is kept: what the quantities are computed from too
        quantities = saved_currents(circuit) + measured_quantities(circuit)
    unused = unused_options(circuit)
    results = []
    from .altered import altered_circuit

    altered: dict = {}
    original = circuit
    said = _module_messages(circuit)  # what compiled models say ($strobe, $error ...): notes of each analysis
    said()  # earlier runs' messages are not this one's
    # one operating point for .op, .ac, .noise, .tf, .pz and .sens of the circuit
    with shared_operating_points():
        for position, card in enumerate(original.analyses):
            kind = analysis_name(card)
            circuit = altered_circuit(original, card.alter, altered)  # after a .control script's alter commands
            try:
                if kind == "tran":
                    from .tran import transient

                    stream = None if output is None or quantities else _stream(output, position, names, wanted)
                    res = transient(circuit, card, save=computed_from, progress=progress, output=stream,
                                    bounded=bounded and not circuit.measures and not circuit.fouriers, room=room,
                                    **options)
                else:
                    res = _other_analysis(kind, circuit, card, options)
            except KeyboardInterrupt as exc:
                # Ctrl-C (or SIGTERM): hand on every result computed so far, and the interrupted transient or
                # .dc sweep up to where it stopped (a sweep's partial holds every unknown: the saved ones kept)
                partial = getattr(exc, "partial", None)
                if partial is not None and names and kind != "tran":
                    partial = partial.subset([n for n in wanted if canonical_or(n) in partial.signals])
                exc.results = _finish(original, results + ([partial] if partial is not None else []), names, wanted)
                raise
            absent = add_quantities(circuit, res, quantities)
            absurd = absurd_values_note(circuit, res.signals) if kind in ("op", "dc", "tran") else None
            if absurd:
                res.notes.append(absurd)
            if quantities and kind == "tran" and names:  # it kept what the quantities are computed from
                res.notes = [n for n in res.notes if not n.startswith("saved: ")]
                res.notes.append("saved: " + ", ".join(n for n in wanted if canonical_or(n) not in absent))
            if kind == "noise":
                res = _noise_subset(res, noise_names)
            elif names and kind not in ("pz", "tf", "sens"):  # their quantities are not signals to select
                try:
                    res = res.subset([n for n in wanted if canonical_or(n) not in absent])
                except KeyError as exc:
                    raise NetdaeError(f"cannot save: {exc.args[0]}") from None
            if unused:
                res.notes.append(unused)
            if card.alter:
                res.notes.append("circuit altered: " + "; ".join(f"{c.command} ({c.location})" for c in card.alter))
            res.notes.extend(said())
            results.append(res)
    return _finish(original, results, names, wanted)


def _module_messages(circuit: Circuit) -> Callable[[], list[str]]:
    """A function giving, as notes, what the circuit's OSDI modules logged since its last call.

    A Verilog-A model's ``$strobe``, ``$display``, ``$warning``, ``$error`` and
    ``$fatal`` reach netdae through the OSDI log callback
    (:func:`netdae.devices.osdi.drain_messages`); without this they were never
    shown. A circuit without OSDI devices gets a function returning nothing
    (and no ctypes import).
    """
    if not any(el.kind == Kind.OSDI for el in circuit.elements):
        return list
    from ..devices.osdi.library import drain_messages, message_notes

    return lambda: message_notes(drain_messages())


def _other_analysis(kind: str, circuit: Circuit, card, options: dict) -> Result:
    """The analysis ``card`` of ``kind`` (any but ``tran``) on ``circuit``."""
    if kind == "op":
        from .op import operating_point

        return operating_point(circuit, **options)
    if kind == "dc":
        from .dc import dc_sweep

        return dc_sweep(circuit, card, **options)
    if kind == "pz":
        from .pz import pz_analysis

        return pz_analysis(circuit, card, **options)
    if kind == "tf":
        from .tf import tf_analysis

        return tf_analysis(circuit, card, **options)
    if kind == "noise":
        from .noise import noise_analysis

        return noise_analysis(circuit, card, **options)
    if kind == "sens":
        from .sens import sens_analysis

        return sens_analysis(circuit, card, **options)
    from .ac import ac_analysis

    return ac_analysis(circuit, card, **options)


def _stream(output: Callable, position: int, names, wanted) -> Callable:
    """A transient's ``output(start, block)`` handing on each block as :func:`run` returns the result:
    the signals selected as :func:`run` and :func:`_finish` select them (a transient without quantities)."""

    def block_out(start: int, block: Result) -> str | None:
        if names:
            try:
                block = block.subset(wanted)
                if wanted != names:
                    block = block.subset(names)
            except KeyError:  # the result's own selection says what is missing, after the run
                return None
        return output(position, start, block)

    return block_out


def _skipped_analyses(circuit: Circuit) -> str:
    """Why the analysis commands of a ``.control`` block were not read ("" when it has none)."""
    from ..netlist.control import ANALYSIS_COMMANDS

    for diag in circuit.diagnostics:
        if diag.message.startswith(".control: '"):
            command = diag.message[len(".control: '"):].split("'", 1)[0]
            word = command.split()[0].lower() if command.split() else ""
            if word in ANALYSIS_COMMANDS:
                why = diag.message.split(": ", 2)[-1]
                return (f" (the .control block's analyses are not read: '{command}' at {diag.location} was skipped "
                        f"because {why}; netdae runs a subset of ngspice's control language: docs/netlist.md, "
                        "Control blocks)")
    return ""


def _finish(circuit: Circuit, results: list[Result], names, wanted) -> list[Result]:
    """Measure ``results`` (the ``.meas`` and ``.four`` cards), then keep only the signals asked for."""
    measure(circuit, results)
    fourier(circuit, results)
    if wanted == names:
        return results
    return [selection(r, names) for r in results]


def selection(result: Result, names: list[str]) -> Result:
    """``result`` holding the signals ``names`` only (pz, tf, noise and sens results as they are).

    Its ``saved:`` note, which said what the run kept for the ``.meas`` cards too, says what the
    result holds.
    """
    if result.analysis in ("pz", "tf", "noise", "sens"):
        return result
    r = result.subset(names)
    r.notes = [f"saved: {', '.join(names)}" if n.startswith("saved: ") else n for n in r.notes]
    return r


def _noise_subset(res: Result, names: list[str]) -> Result:
    """A noise result with the noise vectors ``.save``/``.print`` name (all when they name none).

    Raises
    ------
    NetdaeError
        A noise vector the result does not have (``onoise_r1`` without a summary).
    """
    wanted = [n for n in names if n.strip().lower() not in res.noise_totals]
    if not wanted:
        return res
    try:
        return res.subset(wanted)
    except KeyError as exc:
        raise NetdaeError(f"cannot save: {exc.args[0]} (the per-device noise vectors need pts_per_summary on the "
                          ".noise card)") from None


def _with_measured(names: list[str] | None, circuit: Circuit) -> list[str] | None:
    """The signals to keep: ``names`` and, when it is a selection, what the ``.meas`` cards read."""
    if not names:
        return names
    from ..signals import canonical

    have = {canonical(n) for n in names if not n.startswith("@")}
    extra = []
    read = [name for spec in circuit.measures for name in spec.signals()]
    read += [name for spec in circuit.fouriers for name in spec.signals if not name.startswith("@")]
    for name in read:
        if name not in have:
            have.add(name)
            extra.append(name)
    return list(names) + extra


def measure(circuit: Circuit, results: list[Result]) -> None:
    """Evaluate the circuit's ``.meas`` cards on ``results`` and attach them (``result.measures``).

    Each measurement is made on the first result of its analysis kind and
    attached to that result; ``PARAM`` measurements go with their card's
    analysis. Does nothing for a circuit without ``.meas`` cards.
    """
    if not circuit.measures:
        return
    from .measure import evaluate_measures

    first: dict[str, Result] = {}
    for res in results:
        first.setdefault(res.analysis, res)
    for m in evaluate_measures(circuit.measures, first):
        target = first.get(m.analysis)
        if target is not None:
            target.measures.append(m)


def fourier(circuit: Circuit, results: list[Result]) -> None:
    """Evaluate the circuit's ``.four`` cards on the first transient of ``results`` (``result.fourier``).

    Does nothing for a circuit without ``.four`` cards or without a transient (ngspice: "no transient
    data available for fourier analysis"; the run's notes say so).
    """
    if not circuit.fouriers:
        return
    tran = next((r for r in results if r.analysis == "tran"), None)
    if tran is None:
        return
    from .fourier import evaluate_fouriers, fourier_sizes

    nfreqs, gridsize = fourier_sizes(circuit.options.extra)
    tran.fourier.extend(evaluate_fouriers(circuit.fouriers, tran, nfreqs=nfreqs, gridsize=gridsize))


def simulate(circuit: Circuit | str | os.PathLike, *, card: TranAnalysis | None = None,
             save: list[str] | None = None, reltol: float | None = None, abstol: float | None = None,
             vntol: float | None = None, maxord: int | None = None, initial: str = "consistent",
             max_step: float | None = None, raise_on_failure: bool = False,
             progress: Callable[[float, float, int], None] | None = None) -> Result:
    """Run a circuit's transient analysis (its first ``.tran``, or ``card``).

    Parameters
    ----------
    circuit : Circuit, str or path-like
        An elaborated circuit, or a netlist file or text for :func:`netdae.load`.
    card : TranAnalysis, optional
        The analysis to run (default: the circuit's first ``.tran`` card).
    save : list of str, optional
        Signals to keep (``v(out)``, ``v(a,b)``, ``i(v1)``); default the
        netlist's ``.save``/``.print``/``.probe`` signals, else every unknown.
    reltol, abstol, vntol : float, optional
        Tolerances (default: the netlist's ``.options``, else SPICE's).
    maxord : int, optional
        Highest BDF order, 1 to 5 (default ``.options maxord``, else 5).
    initial : {"consistent", "ngspice"}
        ``"consistent"`` replaces an inconsistent start (the hidden
        constraints of an index-2 circuit) by consistent values and says what
        changed; ``"ngspice"`` keeps the operating point as ngspice does.
    max_step : float, optional
        Largest step [s] (default the card's tmax, else
        ``min(tstep, (tstop - tstart)/50)``).
    raise_on_failure : bool
        Raise :class:`~netdae.errors.ConvergenceError` instead of returning
        a failed result.
    progress : callable, optional
        ``progress(t, tstop, steps)``, called a few times per second.

    Returns
    -------
    Result
        ``analysis == "tran"``, axis ``time``, ``dense(t) -> dict``; see
        :func:`netdae.analyses.tran.transient` for ``transient``.

    Raises
    ------
    NetlistError
        Bad input, or an ``.options`` value out of range.
    ValueError
        A tolerance, order or step out of range; an unknown ``initial``.
    NetdaeError
        No ``.tran`` card, ``method=trap``, an unknown save name.
    CircuitError, SingularPencilError, ConvergenceError
        A circuit that cannot be simulated.

    Examples
    --------
    >>> import netdae
    >>> r = netdae.simulate("netlists/rc_lowpass.cir", save=["v(out)"], reltol=1e-6)
    >>> r.names(), float(r.t[-1])
    (['v(out)'], 0.005)
    """
    circuit = _circuit(circuit)
    refuse_steps(circuit)
    if card is not None and not isinstance(card, TranAnalysis):
        raise TypeError(f"card must be a TranAnalysis (a .tran card: netdae.load(...).analyses holds them), not "
                        f"{card!r} (hint: netdae.run runs every analysis card of a netlist)")
    if initial not in ("consistent", "ngspice"):
        raise ValueError(f"initial must be 'consistent' or 'ngspice', not {initial!r}")
    check_callable(progress, "progress", "progress(t, tstop, steps)")
    check_options(circuit, reltol=reltol, abstol=abstol, vntol=vntol, maxord=maxord, max_step=max_step)
    from .tran import transient

    names = list(string_entries(save, "save")) if save is not None else circuit.saves
    if save is not None:
        check_saved_names(circuit, names)
    wanted = _with_measured(names, circuit)
    from .quantities import add_quantities, measured_quantities, plan_quantities

    computed_from, quantities = plan_quantities(circuit, wanted)
    if not names:
        quantities = measured_quantities(circuit)
    said = _module_messages(circuit)
    said()  # earlier runs' messages are not this one's
    result = transient(circuit, card, save=computed_from, reltol=reltol, abstol=abstol, vntol=vntol,
                       maxord=maxord, initial=initial, max_step=max_step, raise_on_failure=raise_on_failure,
                       progress=progress)
    result.notes.extend(said())
    if quantities:
        add_quantities(circuit, result, quantities)
        if names:
            result = result.subset(wanted)
    from .magnitude import absurd_values_note

    absurd = absurd_values_note(circuit, result.signals)
    if absurd:
        result.notes.append(absurd)
    if card is None or card is next((a for a in circuit.analyses if isinstance(a, TranAnalysis)), None):
        measure(circuit, [result])  # the .meas tran cards measure the first .tran
        fourier(circuit, [result])
    return result.subset(names) if wanted != names else result


def check_saved_names(circuit: Circuit, names) -> None:
    """Refuse a ``save=`` name of a node or element the circuit does not have, before anything runs.

    Raises
    ------
    CircuitError
        ``cannot save 'v(zz)': no node 'zz' in the circuit`` (the message of ``netdae sweep``).
    """
    from ..signals import missing_name, parse_signal

    nodes = set(circuit.nodes) | {"0"}
    elements = {el.name for el in circuit.elements}
    for text in names:
        try:
            sig = parse_signal(text)
        except ValueError:
            continue  # not a signal name: the analyses say what they cannot keep
        missing = missing_name(sig, nodes, elements)
        if missing:
            raise CircuitError(f"cannot save {text!r}: {missing}")


def unused_options(circuit: Circuit) -> str | None:
    """A note naming the ``.options`` netdae does not use, or None.

    ``chgtol`` and ``itl4`` have SPICE meanings netdae's integrator does not
    share (it controls the error of the unknowns, and its Newton iteration per
    step is limited by its own convergence test); the options netdae does not
    know are kept as written in ``Options.extra`` (those netdae's devices
    read from there, :data:`USED_EXTRA_OPTIONS`, with OSDI devices ``bypass``,
    and with BSIM3/BSIM4 ``M`` elements :data:`BSIM_OPTIONS`, are used).

    Examples
    --------
    >>> from netdae.circuit import Options
    >>> c = Circuit("t", options=Options(extra={"defl": 2e-6, "trtol": 7.0}))
    >>> unused_options(c)
    'options not used by netdae: trtol'
    """
    o = circuit.options
    used = USED_EXTRA_OPTIONS
    if any(el.kind == Kind.OSDI for el in circuit.elements):
        used = used | {"bypass"}  # the compiled transient's bypass of OSDI instances (OsdiFamily.bypass_allowed)
    if any(el.kind == Kind.OSDI and el.letter == "m" for el in circuit.elements):
        used = used | BSIM_OPTIONS
    names = sorted(name for name in o.extra if name not in used)
    if o.chgtol != type(o)().chgtol:
        names.insert(0, "chgtol")
    if o.itl4 != type(o)().itl4:
        names.insert(0, "itl4")
    if not names:
        return None
    return "options not used by netdae: " + ", ".join(names)
