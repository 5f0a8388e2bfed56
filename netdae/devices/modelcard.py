"""Reading ``.model`` cards and instance parameters of the device families.

Each family declares a :class:`ParameterTable`: the parameters netdae
implements (with ngspice's defaults and aliases), those that do not change
the DC, AC or transient solution (noise coefficients, safe-operating-area
limits) and are accepted. A parameter ngspice does not know for the model
(:data:`~netdae.devices.model_names.NGSPICE_PARAMETERS`: LTspice's ``vceo``,
``mfg``, a level-1 MOSFET's ``kappa``) is ignored, as ngspice ignores it,
with a located warning when the circuit is elaborated
(:func:`ignored_parameters`); a parameter ngspice uses and netdae does not
implement is an error naming the model and the parameter, and so is a model
level netdae does not implement (:meth:`ParameterTable.check_level`), before
any parameter is looked at.

Instances are vectorised by :func:`gather`: one array per parameter, one
entry per instance, read once when the family is built.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..circuit import ABSOLUTE_ZERO, Circuit, Element, Model
from ..errors import CircuitError, NetlistError
from ..kinds import KINDS
from .model_names import LEVELS, NGSPICE_PARAMETERS, level_words, table_of

__all__ = ["ParameterTable", "ModelValues", "resolve_model", "gather", "instance_values", "require_positive",
           "ignored_parameters", "unimplemented_level"]

#: What runs a model netdae does not implement.
OSDI_HINT = ("netdae implements level 1 itself and runs M cards of BSIM3 (level 8/49) and BSIM4 (level 14/54) "
             "through netdae[models]; other levels run as compiled Verilog-A models through OSDI: "
             "'.osdi file.osdi', an N element and '.model name <module> ...' (netdae[models] bundles BSIM3, "
             "BSIM4, BSIM-BULK, PSP; docs/devices.md), or simulate this circuit in ngspice")


@dataclass(frozen=True)
class ParameterTable:
    """The parameters of one device model as netdae implements it.

    Parameters
    ----------
    device : str
        Human-readable device name for messages (``"diode (level 1)"``).
    defaults : dict of str to float or None
        Implemented parameters and ngspice's default (``None``: no default,
        only used when given).
    aliases : dict of str to str
        Alternative spellings (``"cj0"`` -> ``"cjo"``).
    inert : frozenset of str
        Accepted parameters without effect on the solution (noise, SOA).
    family : str
        The model family in :data:`~netdae.devices.model_names.NGSPICE_PARAMETERS`
        (``"diode"``, ``"bjt"``, ``"mosfet"``, ``"jfet"``, ``"vdmos"``); names ngspice does not know for
        it are ignored. Empty: every unknown name is an error.
    levels : frozenset of int
        The ``level=`` values netdae implements.
    grading : frozenset of str
        The junction capacitances' grading coefficients (canonical names): at least 0
        (:data:`GRADING_LIMIT` says why).
    grading_max : float or None
        With a number, the grading coefficients also stay at or below it and differ from 1 (a
        family whose model ngspice does not clamp; :data:`GRADING_LIMIT`).
    fc_below_one : bool
        The forward-bias coefficient ``fc`` must lie in [0, 1) (ngspice does not clamp it for this family).
    """

    device: str
    defaults: dict[str, float | None]
    aliases: dict[str, str] = field(default_factory=dict)
    inert: frozenset[str] = frozenset()
    family: str = ""
    levels: frozenset = frozenset({1})
    grading: frozenset = frozenset()
    grading_max: float | None = None
    fc_below_one: bool = False

    def canonical(self, name: str) -> str:
        return self.aliases.get(name, name)

    def check_level(self, model: Model) -> None:
        """Refuse a model whose ``level=`` netdae does not implement.

        Raises
        ------
        NetlistError
            At the level's value, naming the level and what would run it.
        """
        message = unimplemented_level(self.family, model)
        if message is not None:
            raise NetlistError(message, model.locations.get("level", model.location), hint=OSDI_HINT)

    def read(self, model: Model) -> "ModelValues":
        """Values of ``model`` with defaults filled in.

        Raises
        ------
        CircuitError
            For a parameter netdae does not implement for this device.
        NetlistError
            For an impossible value (a negative saturation current, a
            non-positive emission coefficient, a temperature below absolute
            zero ...), located at the value.
        """
        self.check_level(model)
        known = NGSPICE_PARAMETERS.get(self.family)
        given: dict[str, float] = {}
        for raw, value in model.params.items():
            name = self.canonical(raw.lower())
            if name in self.inert:
                continue
            if name not in self.defaults:
                if known is not None and raw.lower() not in known:
                    continue  # ngspice ignores it too (warned when the circuit was elaborated)
                raise CircuitError(
                    f"model {model.name}: parameter '{raw}' of the {self.device} is used by ngspice but "
                    "not implemented by netdae",
                    hint="remove it only if its effect does not matter to you: netdae would compute something "
                         "else than ngspice",
                    location=model.location,
                )
            given[name] = float(value)
            _check_value(model, raw, name, float(value), self)
        return ModelValues(model, given, self.defaults)


#: Model parameters that cannot be negative (saturation currents, series
#: resistances, zero-bias capacitances, transit times, corner currents,
#: Early voltages): a negative value is a typing error, reported at the value
#: rather than as a later convergence failure or a silently odd result.
NONNEGATIVE = frozenset({
    "is", "js", "isr", "ise", "isc", "iss", "rs", "rsh", "rb", "rbm", "re", "rc", "rd", "cjo", "cje", "cjc",
    "cjs", "cbd", "cbs", "cj", "cjsw", "cgso", "cgdo", "cgbo", "cgs", "cgd", "cgdmin", "cgdmax",
    "rg", "rds", "rq", "tt", "tf", "tr", "ikf", "ikr", "irb", "vaf", "var",
})
#: Model parameters that must be positive (emission coefficients, junction potentials, a MOSFET's surface
#: potential, a switch's resistances, a breakdown voltage: ngspice 39 fails to converge with bv=-5 or bv=0).
POSITIVE = frozenset({"n", "nf", "nr", "ne", "nc", "ns", "vj", "vje", "vjc", "vjs", "pb", "phi", "ron", "roff", "bv"})


#: Junction potentials (a subset of :data:`POSITIVE`): below this [V] the depletion charge's ``v / vj``
#: overflows for ordinary voltages (``vj=1e-300``); ngspice's BSIM3 and BSIM4 clamp theirs at 0.01 V too.
JUNCTION_POTENTIALS = frozenset({"vj", "vje", "vjc", "vjs", "pb"})
JUNCTION_POTENTIAL_MIN = 0.01
#: Largest grading coefficient of a family whose model ngspice does not clamp (the MOSFET's
#: ``ParameterTable.grading_max``). Every family's grading coefficients (``ParameterTable.grading``) are at
#: least 0: a negative one is a typing error (the capacitance would fall towards forward bias;
#: ``exp(-m ln(1 - v/vj))`` overflows in reverse bias). The diode and the BJT clamp large ones (as ngspice's
#: diotemp.c does, at 0.9, and netdae's BJT at 0.999), the VDMOS refuses 1 and more
#: (:mod:`netdae.devices.vdmos`); the MOSFET takes at most this and not 1, where the charge
#: ``vj cj0 (1 - (1 - v/vj)^(1-m)) / (1 - m)`` divides by zero (ngspice 39 stops there: "Timestep too small;
#: initial timepoint"). Hyperabrupt junctions reach 2; with ``fc < 1`` the capacitance above ``fc vj``,
#: ``cj0 / (1 - fc)^(1 + m)``, then stays finite (``mjsw=1e300`` overflowed).
GRADING_LIMIT = 10.0


def _check_value(model: Model, raw: str, name: str, value: float, table: ParameterTable) -> None:
    """Refuse a value no device can have, at the value's location."""
    device = table.device
    if name == "tnom":
        bad, need = not value > ABSOLUTE_ZERO, f"above absolute zero ({ABSOLUTE_ZERO:g} degC)"
    elif name in JUNCTION_POTENTIALS:
        bad, need = not value >= JUNCTION_POTENTIAL_MIN, f">= {JUNCTION_POTENTIAL_MIN:g} V"
    elif name in table.grading:
        top = table.grading_max
        if top is not None:
            bad = not 0.0 <= value <= top or value == 1.0
            need = f"between 0 and {top:g}, and not 1"
        else:
            bad, need = not value >= 0.0, ">= 0"
    elif name == "fc" and table.fc_below_one:
        bad, need = not 0.0 <= value < 1.0, "between 0 and 1 (1 excluded)"
    elif name in POSITIVE:
        bad, need = not value > 0.0, "> 0"
    elif name in NONNEGATIVE:
        bad, need = not value >= 0.0, ">= 0"
    else:
        return
    if bad:
        raise NetlistError(f"model {model.name}: {raw}={value:g} is impossible for a {device}: {raw} must be {need}",
                           model.locations.get(raw, model.location),
                           hint="check the sign and the scale suffix of the value")


@dataclass
class ModelValues:
    """Parameter values of one model: given ones, else the defaults."""

    model: Model
    given_values: dict[str, float]
    defaults: dict[str, float | None]

    def __getitem__(self, name: str) -> float:
        if name in self.given_values:
            return self.given_values[name]
        value = self.defaults[name]
        if value is None:
            raise KeyError(name)
        return value

    def given(self, name: str) -> bool:
        return name in self.given_values

    def get(self, name: str, default: float) -> float:
        return self.given_values.get(name, default)


def resolve_model(element: Element, circuit: Circuit, types: tuple[str, ...]) -> Model:
    """The ``.model`` card of a device instance.

    Raises
    ------
    CircuitError
        When the model is missing or of the wrong type.
    """
    if element.model is None or element.model not in circuit.models:
        raise CircuitError(
            f"{element.name}: model '{element.model}' is not defined",
            elements=(element.name,),
            hint=f"add a .model card of type {'/'.join(types)}",
            location=element.location,
        )
    model = circuit.models[element.model]
    if model.type.lower() not in types:
        raise CircuitError(
            f"{element.name}: model {model.name} has type '{model.type}', expected {'/'.join(types)}",
            elements=(element.name,),
            location=element.location,
        )
    return model


def instance_values(element: Element, allowed: dict[str, float | None], device: str) -> dict[str, float]:
    """Instance parameters of ``element`` with defaults (``None``: absent).

    Raises
    ------
    CircuitError
        For an instance parameter netdae does not implement for this device.
    """
    out: dict[str, float] = {}
    for name, value in element.params.items():
        if name not in allowed:
            raise CircuitError(
                f"{element.name}: instance parameter '{name}' of the {device} is not supported by netdae",
                elements=(element.name,),
                hint=f"the {device}'s instance parameters netdae reads: {', '.join(allowed)}",
                location=element.location,
            )
        out[name] = float(value)
    for name, default in allowed.items():
        if name not in out and default is not None:
            out[name] = default
    return out


#: Instance parameters that scale a device (its multiplier and areas): ngspice 39 runs them when they are not
#: positive (0: a device that conducts nothing, negative: one whose currents are reversed; checked with BJT,
#: MOSFET levels 1-3, diode and JFET cards), netdae refuses them and its hint says so.
SCALE_PARAMETERS = frozenset({"m", "area", "areab", "areac"})


def require_positive(element: Element, values: dict[str, float], names) -> None:
    """Refuse an instance parameter of ``element`` that is not positive, located at its line.

    Parameters
    ----------
    element : Element
        The instance (its location and name start the message).
    values : dict
        Its values, by the keys of ``names``.
    names : iterable of (str, str)
        ``(key, shown)``: the key in ``values`` and the parameter's name on
        the card. A NaN is refused too.

    Raises
    ------
    CircuitError
        For the first value that is not positive; for a multiplier or an
        area (:data:`SCALE_PARAMETERS`) the hint says what ngspice does instead.
    """
    for key, shown in names:
        value = values[key]
        if value > 0.0:
            continue
        hint = f"give {shown} a positive value"
        if shown in SCALE_PARAMETERS:
            hint += (f", 1 by default (ngspice 39 runs {shown} = 0 as a device that conducts nothing and "
                     f"{shown} < 0 as one whose currents are reversed)")
        raise CircuitError(f"{element.name}: {shown} = {value:g} must be positive",
                           elements=(element.name,), hint=hint, location=element.location)


def gather(rows: list[dict[str, float]], name: str, default: float = np.nan) -> np.ndarray:
    """One parameter of every instance as an array (``default`` where absent)."""
    return np.array([r.get(name, default) for r in rows], dtype=float)


def unimplemented_level(family: str, model: Model) -> str | None:
    """The message refusing ``model``'s level, or None when netdae implements it (level 1).

    ``family`` is the element kind of the model's type. A kind that ngspice
    models at several levels (:data:`~netdae.devices.model_names.LEVELS`) and
    netdae evaluates by a device family of its own (``ElementKind.family``)
    runs level 1; the other levels are refused.

    Examples
    --------
    >>> unimplemented_level("mosfet", Model("mm", "nmos", {"level": 49.0}))
    'model mm: MOSFET level 49 (BSIM3 in ngspice) is not implemented by netdae'
    """
    level = model.params.get("level", 1.0)
    spec = KINDS.get(family)
    if spec is None or spec.family is None or family not in LEVELS or level == 1.0:
        return None  # no levels, or no family of netdae's own (the MESFET runs as a compiled module), or level 1
    return f"model {model.name}: {spec.summary} level {level:g} ({level_words(family, level)}) is not implemented by netdae"


def ignored_parameters(family: str, model: Model) -> list[str]:
    """Parameters of ``model`` that ngspice 39 does not know for its family, in card order.

    ngspice reports each ("unrecognized parameter (x) - ignored") and simulates
    without it; netdae does the same. Nothing is listed for a family netdae
    has no table of, or for a level netdae does not implement (that model is
    refused as a whole).

    Examples
    --------
    >>> ignored_parameters("bjt", Model("q", "npn", {"is": 1e-15, "vceo": 40.0, "mfg": 1.0}))
    ['vceo', 'mfg']
    """
    known = NGSPICE_PARAMETERS.get(table_of(family, model.params.get("level", 1.0)))
    if known is None or unimplemented_level(family, model) is not None:
        return []
    return [name for name in model.params if name.lower() not in known]
