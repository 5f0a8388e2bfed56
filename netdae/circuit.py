"""The elaborated, flat circuit: what the netlist reader hands to the rest of netdae.

A :class:`Circuit` is the output of :func:`netdae.netlist.elaborate`: subcircuits
are expanded, parameters evaluated, every name is lower case and fully
qualified, and every element remembers where in the netlist it came from.
It is plain data: no numerics, no I/O.

Naming scheme (as ngspice prints it)
------------------------------------
- Ground is the node ``"0"`` (``gnd`` is an alias and is renamed to ``"0"``).
- A node ``mid`` inside instance ``x1`` of a subcircuit is ``"x1.mid"``; nested
  instances prefix outer first: ``"xa.x1.mid"``. Subcircuit ports take the
  name of the node they are connected to; ``.global`` nodes keep their name.
- An element ``r1`` inside ``xa.x1`` is ``"r.xa.x1.r1"`` (its letter, a dot, the
  instance path, a dot, its own name); top-level elements keep their name.
- Signals: ``v(node)`` for node potentials, ``i(element)`` for branch
  currents, e.g. ``v(xa.x1.mid)`` and ``i(l.xa.x1.l1)``.

Element kinds
-------------
``kind`` names the element kind (the first letter alone is ambiguous: an
``E`` card can be a linear VCVS, a behavioural source or a netdae ideal op-amp).
What each kind is (letters, terminals, branch currents, family, topology) is
defined once, in :mod:`netdae.kinds`; the fields of :class:`Element` each uses:

==============  =========================================
kind            fields used
==============  =========================================
resistor        value [ohm]; params: tc1, tc2, m, ...
capacitor       value [F]; params: ic, m
inductor        value [H]; params: ic, m
coupling        value = k; controls = inductor names
vsource         source
isource         source
vcvs            value = gain
vccs            value = transconductance
cccs            value = gain; controls = (vsource,)
ccvs            value = transresistance; controls = (vsource,)
opamp           netdae extension: ideal op-amp (nullor)
bvoltage        expr: voltage expression
bcurrent        expr: current expression
bcharge         expr: charge expression (``C n+ n- Q={expr}``)
laplace         expr: ``Call("laplace", (u, H(s)))``; elaboration replaces it
                by its state-space block (:mod:`netdae.netlist.laplace`)
diode           model; params: area, ic, off, temp, m
bjt             model; params: area, icvbe, icvce, off, temp, m
mosfet          model; params: w, l, ad, as, pd, ps, m, icvds, icvgs, icvbs, ...
jfet            model; params: area, off, icvds, icvgs, temp, dtemp, m
vdmos           model (vdmos); params: m, off, icvds, icvgs, temp, dtemp
vswitch         model (sw); params: on or off (1.0 when given)
cswitch         model (csw); controls = (controlling element,); params: on, off
tline           params: z0, td (or f and nl)
ltra, txl, cpl  model; params: len (Y, P cards); elaboration replaces each by
                its sections (:mod:`netdae.netlist.lossy`)
osdi            model (of a loaded OSDI module); params: the module's instance parameters
==============  =========================================

Sign conventions (as ngspice): the current of a voltage source, ``i(v1)``,
flows from its + node through the source to its - node; a current source
``I1 n+ n- 1m`` carries 1 mA from n+ through the source to n- (it draws the
current out of n+ and delivers it into n-); an inductor's current flows from
n+ to n-.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from .errors import SourceLocation

__all__ = [
    "GROUND",
    "ABSOLUTE_ZERO",
    "STAMP_MAGNITUDES",
    "Element",
    "SourceSpec",
    "Model",
    "Alteration",
    "OpAnalysis",
    "TranAnalysis",
    "FourierSpec",
    "AcAnalysis",
    "SensAnalysis",
    "DcSweep",
    "DcAnalysis",
    "PzAnalysis",
    "TfAnalysis",
    "NoiseAnalysis",
    "Analysis",
    "Options",
    "Diagnostic",
    "Params",
    "Circuit",
]

GROUND = "0"

#: Absolute zero in degrees Celsius (ngspice's ``CONSTCtoK``): every temperature must lie above it.
ABSOLUTE_ZERO = -273.15

#: The magnitudes a matrix entry of a circuit may have, and so a stamped element's value (a resistance,
#: capacitance, inductance, gain): the dense analyses (norms, balancing, SVDs of the pencil) square
#: entries, and a resistance of 1e-300 is a conductance of 1e300, so values beyond 1e150 either way
#: overflow or vanish there.
STAMP_MAGNITUDES = (1e-150, 1e150)


@dataclass(slots=True)
class SourceSpec:
    """Value of an independent source (V or I card).

    Parameters
    ----------
    dc : float or None
        The DC value when one is written (``V1 a 0 5`` or ``dc 5``); ``None``
        when the card gives only a transient function or nothing.
    ac_mag, ac_phase : float
        AC small-signal magnitude and phase in degrees (``ac 1 0``).
    ac_given : bool
        The card gives an AC value (``ac 0`` included): ngspice's noise input
        must have one.
    tran : Waveform or None
        The transient function (PULSE, SIN, EXP, PWL, SFFM, AM, TRNOISE, TRRANDOM), see
        :mod:`netdae.netlist.waveforms`; ``None`` for a constant source.

    Notes
    -----
    ngspice's rule (``vsrcload.c``), which netdae follows:

    - ``.op`` and ``.dc``: the DC value when given, else the transient function at t = 0.
    - operating point before ``.tran`` and the transient itself: the transient
      function at time t when given, else the DC value (0 when absent).

    A random function (TRNOISE, TRRANDOM: :class:`~netdae.netlist.waveforms.RandomSource`)
    carries the DC value itself, as ngspice adds it to the random value.
    """

    dc: float | None = None
    ac_mag: float = 0.0
    ac_phase: float = 0.0
    tran: Any = None  # netdae.netlist.waveforms.Waveform
    ac_given: bool = False

    def dc_value(self) -> float:
        """Value used by ``.op`` and ``.dc``."""
        if self.dc is not None:
            return self.dc
        if self.tran is not None:
            return float(self.tran.value(0.0))
        return 0.0

    def tran_value_at_zero(self) -> float:
        """Value used by the operating point that starts a transient."""
        if self.tran is not None:
            return float(self.tran.value(0.0))
        return self.dc if self.dc is not None else 0.0


@dataclass(slots=True)
class Element:
    """One element of the flat circuit.

    Parameters
    ----------
    name : str
        Full lower-case name (``"r1"``, ``"r.x1.r1"``).
    kind : str
        Family, see the table in the module docstring.
    nodes : tuple of str
        Full node names in card order; ground is ``"0"``.
    value : float or None
        The primary value (resistance, capacitance, gain, coupling factor ...).
    model : str or None
        Full name of the ``.model`` card for devices (and models of R, C).
    controls : tuple of str
        Controlling elements: the voltage source of F/H, the inductors of K.
    params : dict
        Instance parameters, lower-case keys, evaluated to floats (``ic``,
        ``area``, ``w``, ``l``, ``m``, ``off`` as 1.0 ...).
    source : SourceSpec or None
        For V and I cards.
    expr : object or None
        For behavioural sources: the expression tree (:mod:`netdae.netlist.expr`).
    location : SourceLocation or None
        Where the card is in the netlist (innermost definition for subcircuit
        internals).
    instance_path : tuple of str
        Subcircuit instances this element came from, outermost first (``("xa", "x1")``).
    """

    name: str
    kind: str
    nodes: tuple[str, ...]
    value: float | None = None
    model: str | None = None
    controls: tuple[str, ...] = ()
    params: dict[str, float] = field(default_factory=dict)
    source: SourceSpec | None = None
    expr: Any = None
    location: SourceLocation | None = None
    instance_path: tuple[str, ...] = ()

    @property
    def letter(self) -> str:
        """The SPICE element letter (``"r"`` for ``"r.x1.r1"``)."""
        return self.name[0]


@dataclass(slots=True)
class Model:
    """A ``.model`` card.

    Parameters
    ----------
    name : str
        Full lower-case name; a model defined inside a subcircuit is scoped as
        ngspice names it, with a colon: ``"x1:dmod"``, ``"xb:x3.xdeep:dd"``
        (inner definitions shadow outer ones).
    type : str
        Lower-case type: ``d``, ``npn``, ``pnp``, ``nmos``, ``pmos``, ``r``, ``c``, ...
    params : dict
        Lower-case parameter names to float values (``level`` included when given).
    location : SourceLocation or None
    locations : dict of str to SourceLocation
        Where each parameter's value is written (for messages about a value).
    strings : dict of str to str
        String-valued parameters (``version="4.8"``); only OSDI models use them.
    vectors : dict of str to tuple of float
        Parameters given several numbers (a CPL's matrices, as upper triangles).
    """

    name: str
    type: str
    params: dict[str, float] = field(default_factory=dict)
    location: SourceLocation | None = None
    locations: dict[str, SourceLocation] = field(default_factory=dict)
    strings: dict[str, str] = field(default_factory=dict)
    vectors: dict[str, tuple[float, ...]] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Alteration:
    """One change a ``.control`` block's ``alter`` or ``altermod`` makes to the circuit before an analysis.

    An analysis card's ``alter`` holds every change in force when it runs, in
    command order (a later change of the same target replaces an earlier one);
    :func:`netdae.analyses.altered.altered_circuit` builds the circuit it runs on.

    Parameters
    ----------
    target : {"element", "instance", "model"}
    name : str
        The element's or the model's full lower-case name (``"r1"``, ``"r.x1.r2"``, ``"nmos1"``).
    param : str or None
        None: the element's value (what ``.step`` and ``values=`` set: R, C, L, the
        gains, a source's DC value); a source function (``"sin"``, ``"pulse"`` ...) whose
        parameters ``value`` replaces; ``"acmag"``, a source's AC magnitude; an instance parameter of a top-level element (``"area"``,
        target ``"instance"``); a model parameter (``"vto"``).
    value : float or tuple of float
        A number, or a source function's parameters.
    location : SourceLocation or None
        The command.
    command : str
        The change as an ngspice command with numbers (``"alter @v1[sin] [ 0 3 1.1e+08 ]"``),
        what the ngspice bridge hands ngspice.
    """

    target: str
    name: str
    param: str | None
    value: float | tuple[float, ...]
    location: SourceLocation | None = field(default=None, compare=False)
    command: str = field(default="", compare=False)


@dataclass(slots=True)
class OpAnalysis:
    """``.op``."""

    location: SourceLocation | None = None
    alter: tuple[Alteration, ...] = ()


@dataclass(slots=True)
class TranAnalysis:
    """``.tran tstep tstop [tstart [tmax]] [uic]``."""

    tstep: float
    tstop: float
    tstart: float = 0.0
    tmax: float | None = None
    uic: bool = False
    location: SourceLocation | None = None
    alter: tuple[Alteration, ...] = ()


@dataclass(frozen=True, slots=True)
class FourierSpec:
    """``.four freq signal ...``: the Fourier components of transient signals over their last period.

    Attributes
    ----------
    frequency : float
        The fundamental (Hz).
    signals : tuple of str
        Normalised signal names (``v(out)``, ``v(a,b)``, ``i(v1)``).
    location : SourceLocation, optional
    """

    frequency: float
    signals: tuple[str, ...]
    location: SourceLocation | None = None


@dataclass(slots=True)
class AcAnalysis:
    """``.ac dec|oct|lin n fstart fstop``."""

    variation: str  # "dec", "oct" or "lin"
    points: int
    fstart: float
    fstop: float
    location: SourceLocation | None = None
    alter: tuple[Alteration, ...] = ()


@dataclass(slots=True)
class DcSweep:
    """One sweep of ``.dc``: a source name (or ``temp``) and its range."""

    source: str
    start: float
    stop: float
    step: float


@dataclass(slots=True)
class DcAnalysis:
    """``.dc SRC start stop step [SRC2 start2 stop2 step2]`` (first sweep innermost, as ngspice)."""

    sweeps: list[DcSweep]
    location: SourceLocation | None = None
    alter: tuple[Alteration, ...] = ()


@dataclass(slots=True)
class PzAnalysis:
    """``.pz in+ in- out+ out- cur|vol pol|zer|pz`` (pole-zero analysis).

    ``input_type`` is ``"cur"`` (transfer impedance: the output voltage per
    input current) or ``"vol"`` (voltage gain); ``what`` is ``"pol"``,
    ``"zer"`` or ``"pz"``. Nodes are elaborated names (``"0"`` for ground).
    """

    in_pos: str
    in_neg: str
    out_pos: str
    out_neg: str
    input_type: str = "vol"
    what: str = "pz"
    location: SourceLocation | None = None
    alter: tuple[Alteration, ...] = ()


@dataclass(slots=True)
class TfAnalysis:
    """``.tf outvar insrc`` (small-signal DC transfer function).

    ``output`` is the canonical signal (``v(out)``, ``v(a,b)``, ``i(vload)``),
    ``source`` the independent V or I source whose value is the input;
    ``written`` the output as the card spells it (``v(out,0)``), which names
    ngspice's output impedance (``output_impedance_at_v(out,0)``).
    """

    output: str
    source: str
    location: SourceLocation | None = None
    written: str = ""
    alter: tuple[Alteration, ...] = ()


@dataclass(slots=True)
class NoiseAnalysis:
    """``.noise v(out[,ref]) src dec|oct|lin points fstart fstop [pts_per_summary]`` (small-signal noise).

    ``output``/``reference`` are the output nodes (``"0"`` for ground),
    ``source`` the independent V or I source the input noise is referred to;
    ``variation``, ``points``, ``fstart``, ``fstop`` the frequency grid as
    ``.ac``'s; ``summary`` ngspice's ``pts_per_summary`` (0: not given; else
    the per-generator contributions are kept, at every ``summary``-th point).
    """

    output: str
    reference: str
    source: str
    variation: str
    points: int
    fstart: float
    fstop: float
    summary: int = 0
    location: SourceLocation | None = None
    alter: tuple[Alteration, ...] = ()


@dataclass(slots=True)
class SensAnalysis:
    """``.sens outvar [dc]`` or ``.sens outvar ac dec|oct|lin points fstart fstop`` (sensitivity).

    ``output`` is the canonical signal (``v(out)``, ``v(a,b)``, ``i(vsrc)``),
    ``written`` as the card spells it. ``variation`` is ``None`` for the DC
    sensitivity; for the AC one ``variation``, ``points``, ``fstart`` and
    ``fstop`` are the frequency grid as ``.ac``'s.
    """

    output: str
    location: SourceLocation | None = None
    written: str = ""
    variation: str | None = None
    points: int = 0
    fstart: float = 0.0
    fstop: float = 0.0
    alter: tuple[Alteration, ...] = ()

    @property
    def is_ac(self) -> bool:
        """True for the AC sensitivity."""
        return self.variation is not None


Analysis = OpAnalysis | TranAnalysis | AcAnalysis | DcAnalysis | PzAnalysis | TfAnalysis | NoiseAnalysis | \
    SensAnalysis


#: The smallest absolute tolerance (``abstol``, ``vntol``, ``chgtol``) netdae takes: the error weight of an
#: unknown at zero is ``1 / atol``, and below about 1e-25 (a branch current starting from 0 A) no step passes
#: the error test; 1e-20 A is 62 electrons a second. ngspice takes smaller values (it tests only charges).
TOLERANCE_MIN = 1e-20
#: The highest BDF order netdae integrates with (``.options maxord``; netdae.dae.bdf reads it from here, as
#: the reader does): BDF1-6 are zero-stable, but BDF6's stability region is too narrow for stiff circuits
#: (DASSL's and IDA's limit too). ngspice 39's gear takes 6.
MAX_ORDER = 5


@dataclass(slots=True)
class Options:
    """Simulator options (``.options``) with SPICE defaults.

    Parameters
    ----------
    reltol, abstol, vntol, chgtol : float
        Relative tolerance; absolute tolerances for currents [A], voltages [V]
        and charges [C]. SPICE defaults 1e-3, 1e-12, 1e-6, 1e-14.
    gmin : float
        Conductance added across junctions and used by gmin stepping [S].
    method : str or None
        ``"gear"``/``"trap"`` when the netlist names one, else None.
    maxord : int or None
        Maximum integration order when the netlist gives one, else None.
    temp, tnom : float
        Circuit and nominal temperature [degC].
    itl1, itl4 : int
        Newton iteration limits for the DC operating point and per time step.
    interp : bool
        ``.options interp``: report transient results on the tstep grid.
    seed : int or None
        ``.options seed=``: the seed of the Monte Carlo functions as used
        (``seed=random`` resolved to the number drawn); None when not given.
    rshunt, cshunt, rseries : float or None
        ``.options rshunt=``, ``cshunt=``, ``rseries=``: the resistance and
        capacitance from every node to ground and in series with every inductor
        (elaboration adds them as elements, :mod:`netdae.netlist.shunts`); None
        when not given.
    extra : dict
        Every other option as written (lower-case name to value), kept so that
        nothing is silently dropped; the analyses report the ones they ignore.
    locations : dict
        Where the netlist gives each numeric option (name to the location of its
        value), so that a value the analyses refuse is located on its card.
    """

    reltol: float = 1e-3
    abstol: float = 1e-12
    vntol: float = 1e-6
    chgtol: float = 1e-14
    gmin: float = 1e-12
    method: str | None = None
    maxord: int | None = None
    temp: float = 27.0
    tnom: float = 27.0
    itl1: int = 100
    itl4: int = 10
    interp: bool = False
    seed: int | None = None
    rshunt: float | None = None
    cshunt: float | None = None
    rseries: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    locations: dict[str, SourceLocation] = field(default_factory=dict, repr=False, compare=False)


@dataclass(slots=True)
class Diagnostic:
    """A note or warning about the netlist that is not an error.

    ``in_results``: the analyses repeat the message among their results' notes (what a
    comparison with ngspice should know, e.g. how a lossy line was realised).
    """

    severity: str  # "note" or "warning"
    message: str
    location: SourceLocation | None = None
    in_results: bool = False

    def __str__(self) -> str:
        where = f"{self.location}: " if self.location else ""
        return f"{where}{self.severity}: {self.message}"


class Params(Mapping):
    """A read-only mapping of parameter names to values.

    :attr:`Circuit.params` is one: editing a value would not change the
    elements computed from it, so it cannot be edited; re-elaborate with
    :meth:`Circuit.with_params` instead.

    Examples
    --------
    >>> p = Params({"r": 1e3})
    >>> p["r"], dict(p), p == {"r": 1e3}
    (1000.0, {'r': 1000.0}, True)
    >>> p["r"] = 2e3
    Traceback (most recent call last):
    ...
    TypeError: 'Params' object does not support item assignment
    """

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[str, float] | None = None) -> None:
        self._values = dict(values or {})

    def __getitem__(self, name: str) -> float:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return f"Params({self._values!r})"


@dataclass(slots=True)
class Circuit:
    """The elaborated flat circuit.

    Parameters
    ----------
    title : str
        First line of the netlist.
    elements : list of Element
        In netlist order, subcircuits expanded in place.
    nodes : list of str
        Non-ground node names in order of first appearance.
    models : dict of str to Model
    analyses : list of Analysis
        In netlist order.
    options : Options
    ic : dict of str to float
        ``.ic v(node)=value``: node name to voltage.
    nodeset : dict of str to float
        ``.nodeset v(node)=value``.
    saves : list of str
        Signals named by ``.save``/``.print``/``.probe`` (``"v(out)"``,
        ``"i(v1)"``); empty means all.
    measures : list of MeasureSpec
        The ``.meas`` cards in netlist order (:mod:`netdae.measures`).
    fouriers : list of FourierSpec
        The ``.four`` cards: Fourier analyses of transient signals.
    params : Params
        Top-level ``.param`` values after evaluation (read-only: change them
        with :meth:`with_params`).
    diagnostics : list of Diagnostic
    path : str
        The file the circuit was read from, or ``"<string>"``.
    netlist : Netlist or None
        The parsed netlist this circuit was elaborated from (None for a
        circuit built by hand).
    overrides : dict of str to float
        The top-level parameter values given in place of the netlist's
        (``netdae.load(..., params=)``, :meth:`with_params`).
    max_elements : int or None
        The size limit the circuit was elaborated with.
    seed, sample : int
        The Monte Carlo stream the circuit was elaborated with: the seed
        (``.options seed=``, a sweep's seed, else 1) and the sample index
        (0 for a single run); see :mod:`netdae.netlist.montecarlo`.
    draws : int
        How many Monte Carlo values were drawn (0: the netlist has no
        ``gauss``/``agauss``/``unif``/``aunif``/``limit`` in use).
    uses_temper : bool
        Some value of the circuit was computed from ``temper`` (the circuit
        temperature): at another temperature the netlist elaborates to other
        values (a ``.dc temp`` sweep elaborates it again at each point).
    osdi_files : list of (str, SourceLocation)
        OSDI libraries the netlist loads (``.osdi``, ``pre_osdi``), paths resolved.
    steps : list of StepSpec
        The ``.step`` cards (netdae's extension), in netlist order.
    ic_locations : dict of str to SourceLocation
        Where each ``.ic`` value was written (the last one, when a node is given twice).
    """

    title: str
    elements: list[Element] = field(default_factory=list)
    nodes: list[str] = field(default_factory=list)
    models: dict[str, Model] = field(default_factory=dict)
    analyses: list[Any] = field(default_factory=list)
    options: Options = field(default_factory=Options)
    ic: dict[str, float] = field(default_factory=dict)
    nodeset: dict[str, float] = field(default_factory=dict)
    saves: list[str] = field(default_factory=list)
    measures: list[Any] = field(default_factory=list)
    fouriers: list[Any] = field(default_factory=list)
    params: Params = field(default_factory=Params)
    diagnostics: list[Diagnostic] = field(default_factory=list)
    path: str = "<string>"
    netlist: Any = field(default=None, repr=False, compare=False)
    overrides: dict[str, float] = field(default_factory=dict)
    max_elements: int | None = None
    seed: int = 1
    sample: int = 0
    draws: int = 0
    uses_temper: bool = False
    steps: list[Any] = field(default_factory=list)
    osdi_files: list[tuple[str, SourceLocation | None]] = field(default_factory=list)
    ic_locations: dict[str, SourceLocation] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.params, Params):
            self.params = Params(self.params)

    def with_params(self, values: Mapping[str, float] | None = None, /, **kwargs: float) -> "Circuit":
        """The same netlist elaborated again with other top-level ``.param`` values.

        Parameters
        ----------
        values : mapping of str to float, optional
            New values by parameter name (case-insensitive).
        **kwargs : float
            More new values, as keywords.

        Returns
        -------
        Circuit
            A new circuit; this one is unchanged. Earlier overrides are kept
            unless given again.

        Raises
        ------
        NetlistError
            A name that no top-level ``.param`` card defines, a value that is
            not a finite number, or anything the new values make wrong.
        ValueError
            For a circuit that was not read from a netlist.

        Examples
        --------
        >>> from netdae.netlist import load
        >>> c = load("divider\\n.param r=1k\\nV1 a 0 1\\nR1 a b {r}\\nR2 b 0 {2*r}\\n")
        >>> d = c.with_params(r=5e3)
        >>> [e.value for e in d.elements[1:]], d.params["r"], c.params["r"]
        ([5000.0, 10000.0], 5000.0, 1000.0)
        """
        if self.netlist is None:
            raise ValueError("with_params needs a circuit read from a netlist (netdae.load)")
        return self.variant(dict(values or {}, **kwargs))

    def variant(self, params: Mapping[str, float] | None = None, *, sample: int | None = None,
                seed: int | None = None) -> "Circuit":
        """The same netlist elaborated again: other parameter values, another Monte Carlo sample.

        Parameters
        ----------
        params : mapping of str to float, optional
            New values of top-level ``.param`` parameters (earlier overrides are kept).
        sample : int, optional
            The Monte Carlo sample index (default: this circuit's).
        seed : int, optional
            The Monte Carlo seed (default: this circuit's).

        Returns
        -------
        Circuit

        Raises
        ------
        NetlistError
            As :meth:`with_params`; a sample or seed that is not a
            non-negative integer.
        ValueError
            For a circuit that was not read from a netlist.

        Examples
        --------
        >>> from netdae.netlist import load
        >>> c = load("mc\\nV1 a 0 1\\nR1 a 0 {agauss(1k, 100, 1)}\\n.op\\n")
        >>> r = [c.variant(sample=k).element("r1").value for k in (0, 1, 1)]
        >>> r[0] == c.element("r1").value, r[1] == r[2], r[0] != r[1], c.draws
        (True, True, True, 1)
        """
        if self.netlist is None:
            raise ValueError("a variant needs a circuit read from a netlist (netdae.load)")
        from .netlist.elaborate import elaborate  # the reader builds circuits; import it only here

        merged = dict(self.overrides)
        merged.update({str(k).lower(): v for k, v in (params or {}).items()})
        options = {"params": merged, "max_elements": self.max_elements,
                   "sample": self.sample if sample is None else sample, "seed": self.seed if seed is None else seed}
        if self.netlist.unscripted is not None:  # its .control scripts run again on the new .csparam values
            from .netlist.control import elaborate_scripted

            return elaborate_scripted(self.netlist.unscripted, **options)[1]
        return elaborate(self.netlist, **options)

    def element(self, name: str) -> Element:
        """Element by full name (case-insensitive).

        Raises
        ------
        KeyError
            When there is no such element.
        """
        key = name.lower()
        for el in self.elements:
            if el.name == key:
                return el
        raise KeyError(name)

    def count_by_letter(self) -> dict[str, int]:
        """Number of element cards per SPICE letter, e.g. ``{"r": 3, "c": 1}``.

        The elements netdae adds to realise a card (named ``<card>#...``: the derivative node's
        charge and resistor of a behavioural C or L, the states of a LAPLACE block) are not counted.
        """
        counts: dict[str, int] = {}
        for el in self.elements:
            if "#" in el.name:
                continue
            counts[el.letter] = counts.get(el.letter, 0) + 1
        return dict(sorted(counts.items()))
