"""The element kinds: one definition per kind, read by every part of netdae.

An :class:`~netdae.circuit.Element` names its kind by a string (``"resistor"``,
``"diode"``, ..., the values of :class:`Kind`). What a kind *is* lives here,
once: its card letters, its terminals, the branch-current unknowns it adds,
whether constant stamps or a nonlinear device family evaluate it, whether it
is controlled by other circuit quantities, the model types it accepts, its
branches for the topological analysis, what it stores, and how the reports
group it. The reader, the elaboration, the
assembly, the topology, the index analysis, the operating point and the
transient read the views below (:func:`kind_of`, :data:`BRANCH_CURRENT_KINDS`,
...) instead of keeping tables of their own, and compare an element's kind
with a :class:`Kind` member (``el.kind == Kind.RESISTOR``), never with a
string literal: what a consumer needs to know about a kind (whether it is an
independent source, what it stores, whether another module realises it ...)
is a field of its :class:`ElementKind`, and a test for one kind names it
through :class:`Kind`, so that a misspelt kind fails at import.

Adding an element kind
----------------------
1. Add its :class:`ElementKind` to :data:`KINDS` and its member to
   :class:`Kind` (the fields say what each consumer needs; ``family`` names
   its device family as ``"module:Class"``, or ``stamped=True`` for a
   constant stamp in :mod:`netdae.devices.linear`; or ``runs_as="osdi"``
   for an ngspice model run by a bundled compiled module, with its row in
   :mod:`netdae.devices.osdi.spice_models`). A fact a consumer needs about
   the kind is a field here, read there; code about this kind alone compares
   with its :class:`Kind` member.
2. Write its family (:class:`netdae.devices.base.DeviceFamily`, with
   ``kinds`` naming this kind) and its compiled kernel, or its stamp.
3. Teach the reader its card (:mod:`netdae.netlist.elements`).
4. ``tests/test_kinds.py`` checks that every consumer sees every kind (a
   family or a stamp, topology branches, model types), that :class:`Kind`
   and :data:`KINDS` name the same kinds, and that no module outside this one
   compares a kind with a string literal.

Branch classes (the topological analysis)
-----------------------------------------
``CAPACITIVE``, ``INDUCTIVE``, ``RESISTIVE``, ``VOLTAGE``, ``CURRENT`` and
``NULLATOR`` (the input port of an ideal op-amp: zero voltage, zero current;
it takes part in the voltage constraints of loops but carries no current).
A kind's ``branches`` are ``(class, a, b)`` with ``a``, ``b`` positions in
``Element.nodes``; a branch whose terminal is missing (a BJT's optional
substrate) is left out.
"""

from __future__ import annotations

import enum
import importlib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

__all__ = [
    "CAPACITIVE", "INDUCTIVE", "RESISTIVE", "VOLTAGE", "CURRENT", "NULLATOR", "BRANCH_CLASSES", "ROLES", "STORES",
    "Kind", "ElementKind", "KINDS", "kind_of", "resolve",
    "BRANCH_CURRENT_KINDS", "STAMPED_KINDS", "CONTROLLED_KINDS", "STEPPABLE_KINDS", "NO_GAIN_KINDS", "MODEL_TYPES", "KIND_OF_MODEL_TYPE",
    "GROUPS",
]

CAPACITIVE, INDUCTIVE, RESISTIVE, VOLTAGE, CURRENT, NULLATOR = 0, 1, 2, 3, 4, 5
#: Names of the branch classes, by code.
BRANCH_CLASSES = ("capacitive", "inductive", "resistive", "voltage", "current", "nullator")
#: Kinds of attachment (terminals that carry no branch current).
ROLES = ("controlling input", "input", "gate")
#: What an element may store (:attr:`ElementKind.stores`).
STORES = ("charge", "flux", "junction charge")

class Kind(enum.StrEnum):
    """The element kinds by name, for code about one kind (``el.kind == Kind.RESISTOR``).

    A member equals its kind's string (``Kind.RESISTOR == "resistor"``), so
    ``Element.kind`` stays a plain string; a misspelt member fails at import
    where a misspelt string would silently compare false. One member per kind
    of :data:`KINDS` (``tests/test_kinds.py`` checks).
    """

    RESISTOR = "resistor"
    CAPACITOR = "capacitor"
    INDUCTOR = "inductor"
    COUPLING = "coupling"
    VSOURCE = "vsource"
    ISOURCE = "isource"
    VCVS = "vcvs"
    VCCS = "vccs"
    CCCS = "cccs"
    CCVS = "ccvs"
    OPAMP = "opamp"
    BVOLTAGE = "bvoltage"
    BCURRENT = "bcurrent"
    BCHARGE = "bcharge"
    DIODE = "diode"
    BJT = "bjt"
    MOSFET = "mosfet"
    JFET = "jfet"
    MESFET = "mesfet"
    MESA = "mesa"
    HFET = "hfet"
    VDMOS = "vdmos"
    VSWITCH = "vswitch"
    CSWITCH = "cswitch"
    TLINE = "tline"
    OSDI = "osdi"
    LTRA = "ltra"
    TXL = "txl"
    CPL = "cpl"
    URC = "urc"
    LAPLACE = "laplace"


#: The report groups of kinds outside the topological index theorem's hypotheses.
GROUPS = ("controlled sources", "charge-defined capacitors", "ideal op-amps", "transistors", "switches",
          "compiled devices")


@dataclass(frozen=True, slots=True)
class ElementKind:
    """What one element kind is, for every part of netdae.

    Attributes
    ----------
    name : str
        The kind, as ``Element.kind`` names it.
    letters : str
        The card letters that can read into this kind (``"be"`` for a
        behavioural voltage source written as B or E).
    summary : str
        A few words for messages and documentation.
    terminals : str
        The terminals in card order, for documentation.
    node_counts : tuple of int
        The numbers of nodes an element of this kind may have.
    branches : tuple of (int, int, int)
        Topology: ``(class, a, b)`` per branch, ``a``/``b`` positions in
        ``Element.nodes``. Empty when ``topology`` computes them.
    attachments : tuple of (int, str)
        Terminals that carry no branch current: (position, role in
        :data:`ROLES`).
    currents : tuple of str
        Suffixes of the branch-current unknowns an element adds (``("",)``:
        one unknown named like the element, what ``i(name)`` reads).
    stamped : bool
        Constant stamps in :mod:`netdae.devices.linear` evaluate the kind.
    family : str or None
        ``"module:Class"`` of the nonlinear device family that evaluates it.
    controlled : bool
        Controlled by other circuit quantities (the topological index
        statement's hypotheses exclude it).
    group : str or None
        The report group of a controlled kind (one of :data:`GROUPS`).
    model_types : tuple of str
        The ``.model`` types an element of this kind accepts.
    topology : str or None
        ``"module:function"`` giving the branches that depend on the model
        (``function(circuit, element) -> (internal nodes, branches)``).
    self_loop : bool
        The first two terminals form one branch, which is shorted when they
        coincide.
    stores : str or None
        What an element of this kind stores (one of :data:`STORES`), as the topology's findings and
        the operating point's charge balance name it: ``"charge"`` (a
        capacitor, its branch capacitive: open at DC, and a node set attached
        only through such elements keeps its charge), ``"flux"`` (an
        inductor, its branch inductive: a short at DC), ``"junction charge"``
        (a device whose model may give it a junction capacitance, a
        capacitive branch from ``topology``: a capacitor in a loop of
        capacitors and sources), None (nothing, or charges the topology
        does not show: a transistor's).
    device_ic : tuple of str
        Initial-condition parameters of a semiconductor device (used by
        ngspice's ``uic`` only, not by netdae's start); a transistor's
        ``ic=v1,v2,...`` sets them in this order.
    steppable : bool
        The element's value is one number that a ``.step`` (or a sweep's
        ``values=``) can set directly.
    quantities : dict of str to str
        The device quantities netdae computes (``@r1[p]``), name to meaning.
    realised_by : str or None
        The module that replaces an element of this kind, while elaborating, by
        elements of other kinds (the kind is never assembled).
    saved_currents : tuple of str
        The quantities ``.options savecurrents`` adds (as ngspice 39).
    current_is_quantity : bool
        ``i(name)`` is the device quantity ``@name[i]`` (the kind has no
        branch-current unknown of its own).
    solved_quantities : bool
        Its quantities are values at a solution of nonlinear device
        equations (computed by its family's ``quantities``).
    module_quantities : bool
        Its quantities are the operating-point variables of its compiled
        module (any name, checked when the module is loaded).
    independent : bool
        An independent source: what ``.dc`` sweeps and the input of ``.tf``
        and ``.noise``.
    senses : str or None
        The kind of element its controls name (``"branch"``: any kind in
        :data:`BRANCH_CURRENT_KINDS`).
    no_gain : bool
        Has no gain: a resistance, capacitance, inductance or their coupling, a junction, a
        switch's resistance, a line, or an independent source (its input does not depend on
        the circuit). With positive values a circuit of such elements only has no mode that
        grows: what it stores can only fall, between what the sources put in.
    runs_as : str or None
        The kind elaboration rewrites every element of this kind into
        (``"osdi"``: an ngspice model netdae runs as a bundled compiled
        module, :mod:`netdae.devices.osdi.spice_models`); such a kind has
        neither a stamp nor a family of its own.
    sens : tuple of (str, str, bool)
        The parameters ngspice 39's sensitivity analysis lists for an element
        of this kind, as ``(suffix, how, ac_only)``: the name is the
        element's plus ``suffix`` (``"_m"``, ``":bv_max"``, ``""`` for its
        value), ``how`` what :mod:`netdae.analyses.sens` changes (``"value"``,
        ``"param:<key>"``, ``"dc"``, ``"ac"``, ``"source_m"``; ``"inert"``
        and ``"geometry"`` change nothing), ``ac_only`` listed by the AC
        sensitivity alone. For a semiconductor device the instance parameters
        (``("_area", "param:area", False)``); its model's come from
        :data:`~netdae.devices.model_names.SENS_MODEL_PARAMETERS`.
    parameters : str or None
        ``"module:attribute"`` of the device's
        :class:`~netdae.devices.modelcard.ParameterTable` (a semiconductor
        device whose model parameters the sensitivity analysis changes).
    value_names : tuple of str
        The names ngspice's ``alter`` gives the value of a steppable element
        (``alter @r1[resistance] = 2k``; :mod:`netdae.netlist.control`).
    junctions : tuple of (int, int)
        The terminal pairs that are semiconductor junctions (a BJT's base-emitter,
        base-collector and substrate-collector, a MOSFET's source-bulk and drain-bulk,
        a JFET's gate-source and gate-drain, a VDMOS's body diode; not the channels,
        whose currents a gate bounds): what :mod:`netdae.topology.held` finds held
        by voltage sources alone.
    """

    name: str
    letters: str
    summary: str
    terminals: str
    node_counts: tuple[int, ...]
    branches: tuple[tuple[int, int, int], ...] = ()
    attachments: tuple[tuple[int, str], ...] = ()
    currents: tuple[str, ...] = ()
    stamped: bool = False
    family: str | None = None
    controlled: bool = False
    group: str | None = None
    model_types: tuple[str, ...] = ()
    topology: str | None = None
    self_loop: bool = False
    stores: str | None = None
    device_ic: tuple[str, ...] = ()
    steppable: bool = False
    quantities: dict[str, str] = field(default_factory=dict, compare=False)
    saved_currents: tuple[str, ...] = ()
    current_is_quantity: bool = False
    solved_quantities: bool = False
    module_quantities: bool = False
    independent: bool = False
    senses: str | None = None
    no_gain: bool = False
    runs_as: str | None = None
    sens: tuple[tuple[str, str, bool], ...] = ()
    parameters: str | None = None
    realised_by: str | None = None
    value_names: tuple[str, ...] = ()
    junctions: tuple[tuple[int, int], ...] = ()

    @property
    def noun(self) -> str:
        """The summary with its article, for messages: ``"a resistor"``, ``"an inductor"``."""
        return ("an " if self.summary[0] in "aeiouAEIOU" else "a ") + self.summary

    @property
    def first_class(self) -> int | None:
        """The class of the first branch (None: no fixed branches)."""
        return self.branches[0][0] if self.branches else None

    @property
    def loop_reported(self) -> bool:
        """A shorted element of this kind is reported as a loop (of voltage sources, capacitors, inductors)."""
        return self.first_class in (VOLTAGE, CAPACITIVE, INDUCTIVE)

    @property
    def drives_current(self) -> bool:
        """The kind imposes a current (a shorted one has no effect)."""
        return self.first_class == CURRENT

    @property
    def passive(self) -> bool:
        """A resistor, capacitor or inductor with a value (its sign matters to the topology)."""
        return self.name in _PASSIVE


_PASSIVE = frozenset({"resistor", "capacitor", "inductor"})
#: Sensitivity parameters (``ElementKind.sens``), measured with ngspice 39.
_SENS_R = (("", "value", False), ("_m", "param:m", False), ("_scale", "param:scale", False), ("_l", "geometry", False),
           ("_w", "geometry", False), ("_bv_max", "inert", False), (":bv_max", "inert", False),
           (":ef", "inert", False), (":lf", "inert", False), (":wf", "inert", False), ("_ac", "param:ac", True))
_SENS_C = (("", "value", True), ("_m", "param:m", False), ("_scale", "param:scale", False), ("_w", "geometry", True),
           ("_bv_max", "inert", False), (":bv_max", "inert", False))
_SENS_L = (("", "value", True), ("_m", "param:m", False), ("_scale", "param:scale", False), (":mu", "geometry", True))
_SENS_GAIN = (("_gain", "value", False),)


def _sens_instance(*keys: str) -> tuple[tuple[str, str, bool], ...]:
    return tuple((f"_{k}", f"param:{k}", False) for k in keys)
_CONTROL_INPUTS = ((2, "controlling input"), (3, "controlling input"))
#: Most terminals an OSDI device may have in the topological analysis.
OSDI_MAX_TERMINALS = 16
#: Most conductors of a coupled line (ngspice 39's CPL holds at most 8, ``MAX_CP_TX_LINES``).
MAX_CPL_CONDUCTORS = 8


#: The module that realises the lossy lines.
_LINES = "netdae.netlist.lossy"


def _two(cls: int) -> tuple[tuple[int, int, int], ...]:
    return ((cls, 0, 1),)


_DEFINITIONS = (
    ElementKind("resistor", "r", "resistor", "(n+, n-)", (2,), _two(RESISTIVE), stamped=True,
                model_types=("r", "res"), self_loop=True, steppable=True, current_is_quantity=True, sens=_SENS_R,
                value_names=("resistance", "r"), no_gain=True),
    ElementKind("capacitor", "c", "capacitor", "(n+, n-)", (2,), _two(CAPACITIVE), stamped=True,
                model_types=("c",), self_loop=True, stores="charge", steppable=True, current_is_quantity=True,
                sens=_SENS_C, value_names=("capacitance", "cap", "c"), no_gain=True),
    ElementKind("inductor", "l", "inductor", "(n+, n-)", (2,), _two(INDUCTIVE), currents=("",), stamped=True,
                model_types=("l",), self_loop=True, stores="flux", steppable=True, sens=_SENS_L,
                value_names=("inductance", "ind", "l"), no_gain=True),
    ElementKind("coupling", "k", "mutual inductance", "()", (0,), stamped=True, senses="inductor",
                sens=(("", "value", True),), no_gain=True),
    ElementKind("vsource", "v", "voltage source", "(n+, n-)", (2,), _two(VOLTAGE), currents=("",), stamped=True,
                independent=True, self_loop=True, steppable=True, sens=(("", "dc", False), ("_acmag", "ac", True)),
                value_names=("dc",), no_gain=True),
    ElementKind("isource", "i", "current source", "(n+, n-)", (2,), _two(CURRENT), stamped=True, independent=True,
                self_loop=True, steppable=True,
                sens=(("", "dc", False), ("_acmag", "ac", True), ("_m", "source_m", False)), value_names=("dc",), no_gain=True),
    ElementKind("vcvs", "e", "voltage-controlled voltage source", "(n+, n-, nc+, nc-)", (4,), _two(VOLTAGE),
                _CONTROL_INPUTS, currents=("",), stamped=True, controlled=True, group="controlled sources",
                self_loop=True, steppable=True, sens=_SENS_GAIN, value_names=("gain",)),
    ElementKind("vccs", "g", "voltage-controlled current source", "(n+, n-, nc+, nc-)", (4,), _two(CURRENT),
                _CONTROL_INPUTS, stamped=True, controlled=True, group="controlled sources", self_loop=True,
                steppable=True, sens=_SENS_GAIN, value_names=("gain",)),
    ElementKind("cccs", "f", "current-controlled current source", "(n+, n-)", (2,), _two(CURRENT), stamped=True,
                senses="vsource", controlled=True, group="controlled sources", self_loop=True, steppable=True,
                sens=_SENS_GAIN, value_names=("gain",)),
    ElementKind("ccvs", "h", "current-controlled voltage source", "(n+, n-)", (2,), _two(VOLTAGE), currents=("",),
                stamped=True, senses="vsource", controlled=True, group="controlled sources", self_loop=True,
                steppable=True, sens=_SENS_GAIN, value_names=("gain",)),
    ElementKind("opamp", "e", "ideal op-amp (nullor)", "(out+, out-, in+, in-)", (4,),
                ((VOLTAGE, 0, 1), (NULLATOR, 2, 3)), ((2, "input"), (3, "input")), currents=("",), stamped=True,
                controlled=True, group="ideal op-amps", self_loop=True),
    ElementKind("bvoltage", "behl", "behavioural voltage source", "(n+, n-)", (2,), _two(VOLTAGE), currents=("",),
                family="netdae.devices.behavioral:BehaviouralFamily", controlled=True, group="controlled sources",
                self_loop=True),
    ElementKind("bcurrent", "bgfrc", "behavioural current source", "(n+, n-)", (2,), _two(CURRENT),
                family="netdae.devices.behavioral:BehaviouralFamily", controlled=True, group="controlled sources",
                self_loop=True),
    ElementKind("bcharge", "c", "charge-defined capacitor", "(n+, n-)", (2,), _two(CAPACITIVE),
                family="netdae.devices.behavioral:BehaviouralFamily", controlled=True,
                group="charge-defined capacitors", self_loop=True, stores="charge"),
    ElementKind("diode", "d", "diode", "(anode, cathode)", (2,), model_types=("d",),
                family="netdae.devices.diode:DiodeFamily", topology="netdae.devices.diode:diode_branches",
                self_loop=True, stores="junction charge", solved_quantities=True, device_ic=("ic",),
                sens=_sens_instance("area", "m", "temp"), parameters="netdae.devices.diode:DIODE_PARAMETERS", no_gain=True),
    ElementKind("bjt", "q", "bipolar transistor", "(c, b, e[, substrate])", (3, 4),
                ((RESISTIVE, 0, 2), (RESISTIVE, 1, 2), (RESISTIVE, 1, 0), (RESISTIVE, 3, 0)),
                model_types=("npn", "pnp"), family="netdae.devices.bjt:BjtFamily", controlled=True,
                group="transistors", solved_quantities=True, device_ic=("icvbe", "icvce"),
                sens=_sens_instance("area", "areab", "areac", "m", "temp"),
                parameters="netdae.devices.bjt:BJT_PARAMETERS"),
    ElementKind("mosfet", "m", "MOSFET", "(d, g, s, b)", (4,),
                ((RESISTIVE, 0, 2), (RESISTIVE, 0, 3), (RESISTIVE, 2, 3)), ((1, "gate"),),
                model_types=("nmos", "pmos"), family="netdae.devices.mosfet:MosfetFamily", controlled=True,
                group="transistors", solved_quantities=True, device_ic=("icvds", "icvgs", "icvbs"),
                sens=_sens_instance("l", "m", "nrd", "nrs", "temp", "w"),
                parameters="netdae.devices.mosfet:MOS1_PARAMETERS"),
    ElementKind("jfet", "j", "JFET", "(d, g, s)", (3,), ((RESISTIVE, 0, 2), (RESISTIVE, 1, 2), (RESISTIVE, 1, 0)),
                model_types=("njf", "pjf"), family="netdae.devices.jfet:JfetFamily", controlled=True,
                group="transistors", solved_quantities=True, device_ic=("icvds", "icvgs"),
                sens=_sens_instance("area", "m", "temp"), parameters="netdae.devices.jfet:JFET_PARAMETERS"),
    # ngspice's MESFET (Z cards): elaboration maps it to the bundled port of ngspice's model (an osdi element)
    ElementKind("mesfet", "z", "MESFET", "(d, g, s)", (3,), ((RESISTIVE, 0, 2), (RESISTIVE, 1, 2), (RESISTIVE, 1, 0)),
                model_types=("nmf", "pmf"), controlled=True, group="transistors", device_ic=("icvds", "icvgs"),
                runs_as="osdi"),
    # a MESFET whose model is ngspice's MESA (level 2): map_devices gives its Z card this kind; the model types
    # stay the MESFET's (a card's type names the mesfet kind)
    ElementKind("mesa", "z", "MESFET (MESA)", "(d, g, s)", (3,), ((RESISTIVE, 0, 2), (RESISTIVE, 1, 2), (RESISTIVE, 1, 0)),
                family="netdae.devices.mesa:MesaFamily", controlled=True, group="transistors", solved_quantities=True,
                device_ic=("icvds", "icvgs"), parameters="netdae.devices.mesa:MESA_PARAMETERS"),
    # a Z card whose model is ngspice's HFET1 or HFET2 (nhfet/phfet, level 5 or 6): map_devices gives it this kind
    ElementKind("hfet", "z", "HFET", "(d, g, s)", (3,), ((RESISTIVE, 0, 2), (RESISTIVE, 1, 2), (RESISTIVE, 1, 0)),
                model_types=("nhfet", "phfet"), family="netdae.devices.hfet:HfetFamily", controlled=True,
                group="transistors", solved_quantities=True, device_ic=("icvds", "icvgs"),
                parameters="netdae.devices.hfet:HFET_PARAMETERS"),
    ElementKind("vdmos", "m", "power MOSFET (VDMOS)", "(d, g, s)", (3,), ((RESISTIVE, 0, 2),), ((1, "gate"),),
                model_types=("vdmos",), family="netdae.devices.vdmos:VdmosFamily", controlled=True,
                group="transistors", device_ic=("icvds", "icvgs")),
    ElementKind("vswitch", "s", "voltage-controlled switch", "(n+, n-, nc+, nc-)", (4,), _two(RESISTIVE),
                _CONTROL_INPUTS, model_types=("sw",), family="netdae.devices.switch:SwitchFamily", controlled=True,
                group="switches", self_loop=True, solved_quantities=True, no_gain=True),
    ElementKind("cswitch", "w", "current-controlled switch", "(n+, n-)", (2,), _two(RESISTIVE),
                model_types=("csw",), family="netdae.devices.switch:SwitchFamily", controlled=True, senses="branch",
                group="switches", self_loop=True, solved_quantities=True, no_gain=True),
    # a lossless line's ports: in the transient each is a resistance z0 in series with the delayed wave (an
    # input); at DC the line joins the ports (both views have this topology)
    ElementKind("tline", "t", "lossless transmission line", "(p1+, p1-, p2+, p2-)", (4,),
                ((RESISTIVE, 0, 1), (RESISTIVE, 2, 3)), currents=("#i1", "#i2"), stamped=True, no_gain=True),
    ElementKind("osdi", "nm", "compiled Verilog-A device (OSDI)", "(terminals of the module)",
                tuple(range(1, OSDI_MAX_TERMINALS + 1)),
                tuple((RESISTIVE, 0, k) for k in range(1, OSDI_MAX_TERMINALS)),
                family="netdae.devices.osdi.family:OsdiFamily", controlled=True, group="compiled devices", solved_quantities=True,
                module_quantities=True),
    # ngspice's lossy lines: elaboration replaces each by its sections (netdae.netlist.lossy); never assembled.
    # At DC each is a path between its ports (the sections' series resistances), which the sections show.
    ElementKind("ltra", "o", "lossy transmission line (LTRA)", "(p1+, p1-, p2+, p2-)", (4,), model_types=("ltra",),
                realised_by=_LINES, no_gain=True),
    ElementKind("txl", "y", "single lossy transmission line (TXL)", "(in, ref1, out, ref2)", (4,),
                model_types=("txl",), realised_by=_LINES, no_gain=True),
    ElementKind("cpl", "py", "coupled multiconductor line (CPL)", "(in1 .. inN, ref1, out1 .. outN, ref2)",
                tuple(range(4, 2 * MAX_CPL_CONDUCTORS + 3, 2)), model_types=("cpl",), realised_by=_LINES, no_gain=True),
    # ngspice's uniform RC line: elaboration replaces it by ngspice's lumped network (netdae.netlist.urc)
    ElementKind("urc", "u", "uniform distributed RC line (URC)", "(n1, n2, ref)", (3,), model_types=("urc",),
                realised_by="netdae.netlist.urc", no_gain=True),
    # E/G LAPLACE: elaboration replaces it by its state-space block (netdae.netlist.laplace); never assembled
    ElementKind("laplace", "eg", "Laplace-transfer source", "(n+, n-)", (2,), realised_by="netdae.netlist.laplace"),
)

#: The device quantities netdae computes, per element kind, with ngspice 39's
#: names (``@r1[i]``, ``@q1[gm]``) and their meaning; ``i(r1)`` is ``@r1[i]`` for
#: the two-terminal elements without a branch current of their own. The
#: nonlinear devices' signs are ngspice's: a diode's and a bipolar
#: transistor's currents flow into the terminal (a PNP's ``ic`` is negative in
#: the active region), a MOSFET's and a JFET's currents and voltages are
#: *type-normalised* (for a PMOS or PJF they are those of the equivalent
#: N-channel device: ``@m1[vgs]`` is ``v(s) - v(g)``, ``@m1[id]`` the current
#: flowing out of the drain), and so are a bipolar transistor's ``vbe`` and
#: ``vbc``. Their conductances and capacitances are small-signal values at
#: the solution.
_QUANTITIES: dict[str, dict[str, str]] = {
    "resistor": {"i": "current from n+ through the resistor to n-", "p": "power dissipated"},
    "capacitor": {"i": "current from n+ through the capacitor to n-", "p": "power absorbed"},
    "inductor": {"i": "current from n+ through the inductor to n-", "p": "power absorbed"},
    "vsource": {"i": "current from n+ through the source to n-", "p": "power absorbed"},
    "isource": {"v": "voltage from n- to n+", "p": "power absorbed",
                "current": "its current, from n+ through the source to n-"},
    "diode": {
        "vd": "junction voltage (behind RS)", "id": "current from anode to cathode (charge current included)",
        "c": "the same as id", "gd": "junction conductance", "cd": "junction capacitance (depletion and TT)",
        "charge": "junction charge", "p": "power, vd id + id^2 RS",
    },
    "bjt": {
        "ic": "collector current (into the terminal)", "ib": "base current (into the terminal)",
        "ie": "emitter current (into the terminal)", "is": "substrate current (out of the terminal, as ngspice)",
        "vbe": "internal base-emitter voltage (type-normalised)",
        "vbc": "internal base-collector voltage (type-normalised)",
        "gm": "transconductance", "gpi": "input conductance (base-emitter)",
        "gmu": "feedback conductance (base-collector)", "go": "output conductance",
        "gx": "conductance of the base resistance", "cpi": "base-emitter capacitance (depletion and TF)",
        "cmu": "internal base-collector capacitance", "cbx": "external base to collector capacitance",
        "csub": "substrate capacitance", "qbe": "base-emitter charge", "qbc": "base-collector charge",
        "qbx": "external base-collector charge", "qsub": "substrate charge",
        "p": "power absorbed: each terminal's current times its voltage",
    },
    "mosfet": {
        "id": "drain current (type-normalised)", "is": "source current (type-normalised)",
        "ig": "gate current (type-normalised; charge currents)", "ib": "bulk current (type-normalised)",
        "ibd": "bulk-drain junction current", "ibs": "bulk-source junction current",
        "vgs": "gate-source voltage (type-normalised)", "vds": "drain-source voltage (type-normalised)",
        "vbs": "bulk-source voltage (type-normalised)", "vbd": "bulk-drain voltage (type-normalised)",
        "von": "threshold voltage", "vdsat": "saturation voltage",
        "gm": "transconductance", "gds": "output conductance", "gmb": "bulk transconductance",
        "gmbs": "the same as gmb", "gbd": "bulk-drain junction conductance",
        "gbs": "bulk-source junction conductance", "cbd": "bulk-drain junction capacitance",
        "cbs": "bulk-source junction capacitance", "cgs": "gate-source capacitance (overlap included)",
        "cgd": "gate-drain capacitance (overlap included)", "cgb": "gate-bulk capacitance (overlap included)",
        "p": "power absorbed: each terminal's current times its voltage",
    },
    "jfet": {
        "id": "drain current (type-normalised)", "ig": "gate current (type-normalised)",
        "is": "source current (type-normalised)", "igd": "gate-drain current (type-normalised)",
        "vgs": "gate-source voltage (type-normalised)", "vgd": "gate-drain voltage (type-normalised)",
        "gm": "transconductance", "gds": "output conductance", "ggs": "gate-source junction conductance",
        "ggd": "gate-drain junction conductance", "qgs": "gate-source junction charge",
        "qgd": "gate-drain junction charge",
        "p": "power absorbed: each terminal's current times its voltage",
    },
    "mesa": {
        "cd": "drain current (into the terminal; channel less gate-drain diode, charge currents included)",
        "cg": "gate current (into the terminal)", "cs": "source current (into the terminal)",
        "vgs": "internal gate-source voltage", "vgd": "internal gate-drain voltage",
        "gm": "transconductance (of the mode)", "gds": "output conductance (of the mode)",
        "ggs": "gate-source diode conductance", "ggd": "gate-drain diode conductance",
        "cgs": "gate-source capacitance (what ngspice prints as qgs after .op)",
        "cgdq": "gate-drain capacitance (what ngspice prints as qgd after .op)",
        "qgs": "gate-source charge (netdae's charge form)", "qgd": "gate-drain charge (netdae's charge form)",
    },
    "hfet": {
        "cd": "drain current (into the terminal, type-normalised as ngspice's; channel less gate-drain current, "
              "charge currents included)",
        "cg": "gate current (into the terminal)", "cs": "source current (into the terminal)",
        "vgs": "internal gate-source voltage (type-normalised)", "vgd": "internal gate-drain voltage (type-normalised)",
        "gm": "transconductance (of the mode)", "gds": "output conductance (of the mode)",
        "ggs": "gate-source conductance", "ggd": "gate-drain conductance", "cgd": "gate-drain current",
        "capgs": "gate-source capacitance (ngspice's)", "capgd": "gate-drain capacitance (ngspice's)",
        "qgs": "gate-source charge (netdae's charge form)", "qgd": "gate-drain charge (netdae's charge form)",
    },
    "vswitch": {"i": "current from n+ through the switch to n-", "p": "power absorbed"},
    "cswitch": {"i": "current from n+ through the switch to n-", "p": "power absorbed"},
}
#: The quantities ``.options savecurrents`` adds to a result that keeps every unknown (as ngspice 39).
_SAVECURRENTS = {"resistor": ("i",), "capacitor": ("i",), "inductor": ("i",), "isource": ("current",),
                 "bjt": ("ic", "ie", "ib", "is"), "diode": ("id",), "mosfet": ("id", "is", "ig", "ib"),
                 "jfet": ("id", "is", "ig", "igd")}
#: The terminal pairs that are junctions (``ElementKind.junctions``; a diode's junction sits behind an internal
#: node when its model has a series resistance, and its branch then joins other nodes).
_JUNCTIONS = {"diode": ((0, 1),), "bjt": ((1, 2), (1, 0), (3, 0)), "mosfet": ((2, 3), (0, 3)),
              "jfet": ((1, 2), (1, 0)), "mesa": ((1, 2), (1, 0)), "hfet": ((1, 2), (1, 0)), "vdmos": ((2, 0),)}
_DEFINITIONS = tuple(replace(k, quantities=_QUANTITIES.get(k.name, {}), saved_currents=_SAVECURRENTS.get(k.name, ()),
                             junctions=_JUNCTIONS.get(k.name, ()))
                     for k in _DEFINITIONS)

#: Every element kind, by name.
KINDS: dict[str, ElementKind] = {k.name: k for k in _DEFINITIONS}

#: Kinds whose branch current is an unknown (what ``i(name)`` may name).
BRANCH_CURRENT_KINDS = frozenset(k.name for k in _DEFINITIONS if k.currents == ("",))
#: Kinds evaluated by the constant stamps of :mod:`netdae.devices.linear`.
STAMPED_KINDS = frozenset(k.name for k in _DEFINITIONS if k.stamped)
#: Kinds controlled by other circuit quantities.
CONTROLLED_KINDS = frozenset(k.name for k in _DEFINITIONS if k.controlled)
#: Kinds whose value a ``.step`` (or ``values=``) can set directly.
STEPPABLE_KINDS = frozenset(k.name for k in _DEFINITIONS if k.steppable)
#: The kinds without gain (:attr:`ElementKind.no_gain`).
NO_GAIN_KINDS = frozenset(k.name for k in _DEFINITIONS if k.no_gain)
#: Model types each kind accepts (kinds without models left out).
MODEL_TYPES: dict[str, tuple[str, ...]] = {k.name: k.model_types for k in _DEFINITIONS if k.model_types}
#: The kind of element each model type belongs to.
KIND_OF_MODEL_TYPE: dict[str, str] = {t: k.name for k in _DEFINITIONS for t in k.model_types}


def kind_of(name: str) -> ElementKind:
    """The definition of an element kind.

    Raises
    ------
    KeyError
        For a name that is not an element kind.
    """
    return KINDS[name]


_RESOLVED: dict[str, Any] = {}


def resolve(ref: str) -> Callable[..., Any] | type:
    """Import ``"module:attribute"`` (the families and topology hooks, imported on first use)."""
    found = _RESOLVED.get(ref)
    if found is None:
        module, _, attr = ref.partition(":")
        found = _RESOLVED[ref] = getattr(importlib.import_module(module), attr)
    return found
