"""Binding a circuit's ``N`` elements to OSDI modules, models and instances.

A netlist loads libraries with ``.osdi file.osdi`` (or ``pre_osdi`` in a
``.control`` block); a ``.model name module [params]`` card whose type is a
module of a loaded library makes an OSDI model, and ``Nname n1 n2 ... name
[params]`` an instance of it, connecting the module's terminals in order
(fewer nodes leave the last terminals unconnected, as in ngspice and VACASK).
:func:`build` creates the :class:`~.instance.OsdiModel` and
:class:`~.instance.OsdiInstance` objects (one model per ``.model`` card
used); :func:`check_circuit` does so once when the netlist is elaborated, so
that every mistake is a located :class:`~netdae.errors.NetlistError` before
anything is simulated.
"""

from __future__ import annotations

from ...circuit import Circuit, Diagnostic, Element
from ...errors import NetlistError
from ...kinds import Kind
from .instance import KELVIN, OsdiInstance, OsdiModel, SimParameters
from .library import OsdiModule, load_library
from .spice_models import INSTANCE_TEMPERATURE

__all__ = ["circuit_modules", "build", "check_circuit"]


def circuit_modules(circuit: Circuit) -> dict[str, OsdiModule]:
    """Every module of the circuit's OSDI libraries by name (the first library defining a name wins)."""
    modules: dict[str, OsdiModule] = {}
    for path, location in circuit.osdi_files:
        for name, mod in load_library(path, location).modules.items():
            modules.setdefault(name, mod)
    return modules


def _module_of(el: Element, circuit: Circuit, modules: dict[str, OsdiModule]) -> OsdiModule:
    model = circuit.models[el.model]
    mod = modules.get(model.type)
    if mod is None:
        loaded = ", ".join(sorted(modules)) or "none (no .osdi card)"
        raise NetlistError(f"{el.name}: model {model.name} is of type '{model.type}', which is not a module of a "
                           f"loaded OSDI library", model.location or el.location,
                           expected=f"an OSDI module name: {loaded}",
                           hint="load the compiled model with '.osdi file.osdi' (or 'pre_osdi file.osdi' in .control)")
    if mod.num_delays:
        raise NetlistError(f"{el.name}: model {model.name} is OSDI module {mod.name} ({mod.library.path}), which "
                           f"delays {mod.num_delays} quantit{'y' if mod.num_delays == 1 else 'ies'} with absdelay(); "
                           "netdae does not evaluate absolute delays in compiled models", el.location,
                           expected="an OSDI module without absdelay()",
                           hint="a lossless transmission line is netdae's T element (Tname p1 n1 p2 n2 z0=50 td=1n)")
    nt = mod.num_terminals
    if len(el.nodes) > nt:
        raise NetlistError(f"{el.name}: model {model.name} is OSDI module {mod.name} ({mod.library.path}) with {nt} "
                           f"terminals ({', '.join(mod.terminals)}), the instance connects {len(el.nodes)} nodes",
                           el.location, expected=f"{el.name} {' '.join(mod.terminals)} {model.name} [name=value ...]",
                           hint="fewer nodes leave the last terminals unconnected, more are an error")
    return mod


def _instance_params(mod: OsdiModule, params: dict) -> dict:
    """ngspice's ``m=`` is OpenVAF's ``$mfactor`` when the module has no parameter ``m`` of its own."""
    params = dict(params)
    if "m" in params and mod.parameter("m") is None and mod.parameter("$mfactor") is not None:
        params["$mfactor"] = params.pop("m")
    return params


def build(circuit: Circuit, elements: list[Element] | None = None) -> tuple[dict[str, OsdiModel], list[OsdiInstance]]:
    """The OSDI models (by ``.model`` name) and one instance per element (default: every ``N`` element).

    Raises
    ------
    NetlistError
        A library missing or of another OSDI version, a model type that is
        no loaded module, a terminal count that differs from the module's,
        an unknown parameter or one of the wrong type, values the module's
        setup rejects.
    """
    els = [el for el in circuit.elements if el.kind == Kind.OSDI] if elements is None else elements
    modules = circuit_modules(circuit)
    opts = circuit.options
    sim = SimParameters(tnom=opts.tnom, gmin=opts.gmin, reltol=opts.reltol, abstol=opts.abstol,
                        vntol=opts.vntol)
    models: dict[str, OsdiModel] = {}
    instances = []
    for el in els:
        mod = _module_of(el, circuit, modules)
        model = models.get(el.model)
        if model is None:
            card = circuit.models[el.model]
            model = models[el.model] = OsdiModel(mod, card.name, {**card.params, **card.strings}, sim=sim,
                                                 location=card.location, locations=card.locations)
        params = _instance_params(mod, el.params)
        temp = params.pop(INSTANCE_TEMPERATURE, opts.temp)
        instances.append(OsdiInstance(model, el.name, params, temperature=temp + KELVIN, connected=len(el.nodes),
                                      location=el.location))
    return models, instances


def _shadowed_modules(circuit: Circuit) -> list[Diagnostic]:
    """A warning at each ``.osdi`` card whose library defines a module an earlier card's library defines too.

    The first definition is the one models use (:func:`circuit_modules`); a second
    library with a module of the same name (a user's ``diode`` beside another
    ``diode``) is otherwise ignored without a word.
    """
    import os

    first: dict[str, str] = {}
    notes = []
    for path, location in circuit.osdi_files:
        lib = load_library(path, location)
        for name in lib.modules:
            earlier = first.setdefault(name, lib.path)
            if earlier != lib.path and os.path.realpath(earlier) != os.path.realpath(lib.path):
                notes.append(Diagnostic("warning", f"OSDI module {name} of {lib.path} is ignored: {earlier}, loaded "
                                        f"before it, defines a module {name} too, and models of type {name} use "
                                        "that one", location))
    return notes


def check_circuit(circuit: Circuit) -> list[Diagnostic]:
    """Load the circuit's OSDI libraries and set up every model and instance once (raising what is wrong).

    Returns
    -------
    list of Diagnostic
        A warning at an ``.osdi`` card whose library defines a module an earlier
        card's library defines too, and a note at each ``N`` card that connects fewer nodes
        than its module has terminals: which terminals it leaves to the module (allowed, as in
        ngspice and VACASK, but a forgotten node should not pass unseen).
    """
    build(circuit)
    modules = circuit_modules(circuit)
    notes = _shadowed_modules(circuit)
    for el in circuit.elements:
        if el.kind != Kind.OSDI or not el.name.startswith("n"):  # M, Q, J ... cards of ngspice's models: mapped
            continue
        mod = modules[circuit.models[el.model].type]
        if len(el.nodes) < mod.num_terminals:
            free = mod.terminals[len(el.nodes):]
            notes.append(Diagnostic(
                "note", f"{el.name}: connects {len(el.nodes)} of OSDI module {mod.name}'s {mod.num_terminals} "
                f"terminals ({', '.join(mod.terminals)}); {', '.join(free)} {'is' if len(free) == 1 else 'are'} "
                "left unconnected (nodes of the instance's own)", el.location))
    return notes
