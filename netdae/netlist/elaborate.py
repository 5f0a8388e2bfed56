"""Elaboration: a parsed :class:`Netlist` to a flat :class:`~netdae.circuit.Circuit`.

Subcircuit expansion follows ngspice's ``subckt.c`` step by step, so that
every hierarchical name is the one ngspice prints:

1. A definition's body is expanded first on its own (memoised): instances
   of subcircuits defined *inside* it are replaced by their (expanded)
   bodies; other instances stay, to be expanded where their subcircuit is
   defined.
2. Replacing instance ``X`` (current name ``N``) by a body renames every
   card of the body: an element ``r1`` becomes ``r.N.r1`` (its letter, a dot,
   ``N``, a dot, its current name, so an element already renamed by an inner
   expansion, ``r.x3.rl``, becomes ``r.N.r.x3.rl``); an instance ``x1``
   becomes ``N.x1``; a model ``dm`` becomes ``N:dm``; a node becomes ``N.node``
   unless it is ground, a ``.global`` node, or a port (then the node the
   instance connects). Controlling names (F, H, K, ``I()``) are renamed like
   elements, ``V()`` nodes like nodes.
3. A device uses the innermost model of that name, looking outward from the
   definition where the device is written.

Parameters are scoped dynamically (:mod:`netdae.netlist.params`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from ..circuit import (ABSOLUTE_ZERO, MAX_ORDER, STAMP_MAGNITUDES, AcAnalysis, Circuit, DcAnalysis, DcSweep,
                       Diagnostic, Element, FourierSpec, Model, NoiseAnalysis, OpAnalysis, Options, Params, PzAnalysis,
                       SensAnalysis, SourceSpec, TfAnalysis, TranAnalysis)
from ..devices.model_names import FLAG_PARAMETERS, NGSPICE_PARAMETERS, OUTPUT_ONLY, table_of
from ..devices.modelcard import OSDI_HINT, ignored_parameters, unimplemented_level
from ..errors import NetlistError
from ..kinds import BRANCH_CURRENT_KINDS, KIND_OF_MODEL_TYPE, KINDS, MODEL_TYPES, STEPPABLE_KINDS, Kind
from ..signals import subcircuit_name_hint
from . import expr as ex
from . import lossy, shunts, urc
from .shunts import DEFAULT_RSERIES
from .elements import error, parse_value, unknown_node_hint
from .compat import MODE_HINT, realise_switch
from .laplace import LAPLACE_KINDS, LaplaceError, realise
from .lines import EXPR, STRING, WORD, Card, no_gc
from .measure import elaborate_measures
from .montecarlo import DEFAULT_SEED, MAX_SEED, Draws, is_random_call, random_seed, seed_problem
from .steps import StepSpec, model_parameter, step_values, unseen_step
from .numbers import parse_number
from .option_names import option_warning
from .params import Env, Trace, UnknownName, evaluate_val, resolve_behavioural
from .size import DEFAULT_MAX_ELEMENTS, check_size
from .statements import Definition, ElementCard, InitialCard, InstanceCard, ModelCard, Netlist, ParamDef
from .syntax import DOT_CARDS, ELEMENTS, SOURCE_FUNCTIONS
from .waveforms import WAVEFORMS, Pwl, RandomSource

__all__ = ["elaborate"]

#: Instance parameters ngspice 39 takes from a .model card as the default of every instance that does not give them.
INSTANCE_DEFAULTS = {"mosfet": ("l", "w", "ad", "as", "pd", "ps", "nrd", "nrs")}
#: PSpice's model types that ngspice names otherwise.
_PSPICE_MODEL_TYPES = {"vswitch": "PSpice's voltage-controlled switch (ngspice's sw)",
                       "iswitch": "PSpice's current-controlled switch (ngspice's csw)"}
#: The PSpice switch model each switch kind runs in ngspice's PSpice mode (:func:`netdae.netlist.compat.realise_switch`).
_PSPICE_SWITCHES = {Kind.VSWITCH: "vswitch", Kind.CSWITCH: "iswitch"}

# ``m=`` on a subcircuit instance whose subcircuit declares no parameter ``m`` multiplies the
# elements inside, as ngspice 39 does (``inp_fix_subckt_multiplier``: ``m={m}`` on every card of
# the body but B, V, E and H): the kinds whose own ``m`` netdae applies take the product; a
# coupling K relates two inductors that are both multiplied, so it stays; the other kinds are
# refused when the product is not 1.
_INSTANCE_MULTIPLIED = frozenset({Kind.RESISTOR, Kind.CAPACITOR, Kind.INDUCTOR, Kind.VCCS, Kind.CCCS,
                                  Kind.DIODE, Kind.BJT, Kind.MOSFET, Kind.JFET, Kind.MESA, Kind.HFET,
                                  Kind.VDMOS, Kind.OSDI})
_INSTANCE_M_EXEMPT = frozenset("bveh")
#: Model types ngspice 39 has for an element letter netdae reads, whose models netdae does not implement.
_UNIMPLEMENTED_MODEL_TYPES: dict[str, str] = {}
#: Model types a card of another kind reads (ngspice 39): a Z card (MESFET) takes ngspice's HFET models,
#: which :func:`netdae.devices.osdi.spice_models.map_devices` gives the HFET kind.
_ALSO_READS = {Kind.MESFET: (Kind.HFET,)}
#: Bare names on a .model card that restate its type.
_TYPE_FLAGS = frozenset({"npn", "pnp", "nmos", "pmos", "njf", "pjf", "sw", "csw", "pchan", "nchan"})
#: LTspice's annotations on a VDMOS card (datasheet figures and the maker), which ngspice's reader drops.
VDMOS_ANNOTATIONS = frozenset({"vds", "ron", "qg", "mfg"})
#: Model parameters of R, C and L that netdae uses (the others size an element without a value,
#: and netdae needs the value on the element card); aliases as in ngspice's res.c.
_PASSIVE_MODEL_PARAMS = {"resistor": {"tc1": "tc1", "tc1r": "tc1", "tc2": "tc2", "tc2r": "tc2", "tce": "tce",
                                      "tnom": "tnom"},
                         "capacitor": {"tc1": "tc1", "tc2": "tc2", "tnom": "tnom"},
                         "inductor": {"tc1": "tc1", "tc2": "tc2", "tnom": "tnom"}}

#: The temperature (C) from which ngspice 39's B sources measure their tc1 and tc2 (300.15 K, not tnom).
ASRC_REFERENCE_TEMPERATURE = 27.0
#: The name expressions use for the circuit temperature.
TEMPER = "temper"
_INT_OPTIONS = {"maxord", "itl1", "itl4"}
#: The highest integration order ngspice 39 takes (``.options maxord``, gear); netdae's is
#: :data:`netdae.circuit.MAX_ORDER`.
NGSPICE_MAXORD = 6
_FLOAT_OPTIONS = {"reltol", "abstol", "vntol", "chgtol", "gmin", "temp", "tnom"}
#: The options that add elements (:mod:`netdae.netlist.shunts`).
_SHUNT_OPTIONS = {"rshunt", "cshunt", "rseries"}
_METHODS = {"gear": "gear", "trap": "trap", "trapezoidal": "trap"}
#: The options netdae reads (:func:`netdae.netlist.option_names.option_warning` compares typos with them).
_KNOWN_OPTIONS = frozenset(_INT_OPTIONS | _FLOAT_OPTIONS | _SHUNT_OPTIONS | {"method", "interp", "seed"})


class _Frame:
    """One instance on a call chain: its card and the subcircuit it instantiates."""

    __slots__ = ("inst", "sub")

    def __init__(self, inst: InstanceCard, sub: Definition) -> None:
        self.inst = inst
        self.sub = sub


#: Suffix of the name under which a subcircuit scope keeps the caller's value of a parameter that
#: one of its definitions reads before the scope assigns it; '#' is in no parameter name.
OUTER = "#outer"


def _local_order(defn: Definition) -> dict[str, int]:
    """The position of each parameter of ``defn`` in ngspice 39's order of its ``.subckt`` line.

    ngspice appends the body's ``.param`` cards to the subcircuit's parameters
    (a later definition of a name replacing an earlier one) and sorts the list
    by dependency, on the texts of the definition (``inp_sort_params``): a
    parameter comes after those it reads (its own name aside), ties in the
    written order.
    """
    written: dict[str, ParamDef] = {}
    for d in (*defn.defaults, *defn.params):
        written.pop(d.name, None)
        written[d.name] = d
    reads = {name: {n.name for n in ex.walk(d.value[0]) if type(n) is ex.Param and n.name in written
                    and n.name != name} if type(d.value[0]) is not float else set()
             for name, d in written.items()}
    level: dict[str, int] = {}
    for start in written:
        stack, seen = [start], {start}
        while stack:  # depth first, without recursion; a cycle (netdae's error later) counts as level 0
            name = stack[-1]
            todo = [n for n in reads[name] if n not in level and n not in seen]
            if todo:
                seen.update(todo)
                stack.extend(todo)
                continue
            stack.pop()
            level[name] = 1 + max((level.get(n, -1) for n in reads[name]), default=-1)
    names = sorted(written, key=lambda n: level[n])  # stable: ties in the written order
    return {name: k for k, name in enumerate(names)}


def _unassigned_reads_outward(env: Env, parent: Env, defn: Definition) -> None:
    """Make each definition of ``env`` read the caller's value of every local name not yet assigned.

    ngspice 39 assigns an instance's parameters one after the other in its
    scope (``nupa_subcktcall``): first those whose value is a plain number,
    then the others in the order of :func:`_local_order`, each expression
    reading the names assigned before it and, for every other name, the value
    visible where the subcircuit is called. An instance's ``r2={r1}`` thus
    reads the instance's ``r1`` when that is a number or comes first, a
    definition ``r={r*2}`` the caller's ``r``. A name read that way is read as
    ``name#outer``, defined in ``env`` as ``name`` evaluated in ``parent``.
    """
    position = _local_order(defn)

    def plain(pdef: ParamDef) -> bool:
        value = pdef.value[0]
        return type(value) is float or type(value) is ex.Const

    numbers = {name for name, (pdef, _) in env.defs.items() if plain(pdef)}
    for name, (pdef, where) in list(env.defs.items()):
        tree = pdef.value[0]
        if where is not env or plain(pdef):
            continue
        at = position.get(name, len(position))
        outside = {n.name for n in ex.walk(tree) if type(n) is ex.Param and n.name in env.defs
                   and n.name not in numbers and (n.name == name or position.get(n.name, len(position)) >= at)}
        if not outside:
            continue
        for other in outside:
            alias = other + OUTER
            if alias not in env.defs:
                env.defs[alias] = (ParamDef(alias, (ex.Param(other), pdef.value[1]), pdef.card, pdef.offset), parent)
        tree = ex.transform(tree, lambda n: ex.Param(n.name + OUTER)
                            if type(n) is ex.Param and n.name in outside else None)
        env.defs[name] = (ParamDef(name, (tree, pdef.value[1]), pdef.card, pdef.offset), env)


def _multiplier_instance(inst: InstanceCard, sub: Definition) -> bool:
    """True when the instance's ``m`` is ngspice's multiplier, not a parameter of the subcircuit."""
    return "m" in inst.params and not any(d.name == "m" for d in sub.defaults) \
        and not any(p.name == "m" for p in sub.params)


class _Placed:
    """A card during expansion: its current name, nodes and references."""

    __slots__ = ("item", "name", "nodes", "refs", "crefs", "model", "bound", "frames", "path")

    def __init__(self, item, name, nodes, refs, crefs, model, bound, frames, path) -> None:
        self.item = item
        self.name = name
        self.nodes = nodes
        self.refs = refs
        self.crefs = crefs
        self.model = model
        self.bound = bound
        self.frames = frames
        self.path = path


NGSPICE_DUPLICATE = ("ngspice 39 refuses it too: it reports 'device already exists' and does not parse the "
                     "circuit, so no analysis runs")


def _duplicate(el: Element, placed: _Placed, earlier: _Placed) -> NetlistError:
    """The error for a second element named like an earlier one (``earlier``: the first one's card).

    When the name comes from two subcircuit instances of the same name (``xrcv 3 4 vcc bjtdrvr``
    and ``xrcv 3 4 vcc dioload``, both with an element ``d1``), the error is placed on the second
    instance card and names both instances: that is the cause, as ngspice's ``d.xrcv.d1`` is.
    Where the instances' elements do not collide, ngspice and netdae keep both instances, and
    nodes of the same name inside them are one node.
    """
    for depth, (a, b) in enumerate(zip(earlier.frames, placed.frames)):
        if a.inst is not b.inst:
            instance = ".".join(placed.path[:depth + 1])
            one, two = a.inst, b.inst
            at = one.card.location(0)
            return error(two.card, 0, f"duplicate element name '{el.name}': two subcircuit instances are named "
                         f"'{instance}' (at {at.file}:{at.line}, subcircuit {a.sub.name}, and here, "
                         f"subcircuit {b.sub.name}) and both contain an element "
                         f"'{placed.item.card.text.split(None, 1)[0].lower()}'; {NGSPICE_DUPLICATE}",
                         hint="give each subcircuit instance its own name")
    where = earlier.item.card.location(0)
    return error(placed.item.card, 0, f"duplicate element name '{el.name}' (first defined at "
                 f"{where.file}:{where.line}); {NGSPICE_DUPLICATE}", hint="element names must be unique")


def _expr_refs(item: ElementCard, defn: Definition) -> tuple[tuple, tuple]:
    """Node and element names an element's expression refers to, as written.

    The bodies of the ``.func`` functions it calls (``defn``: the definition the card is in, whose
    functions and its parents' it sees) count as written on the card: ngspice expands a call in
    place, so ``.func f(x) 'v(mid)*x'`` called in a subcircuit reads that instance's node ``mid``.
    """
    if item.expr is None:
        return (), ()
    nodes: dict[str, None] = {}
    elems: dict[str, None] = {}
    seen: set[str] = set()
    trees = [item.expr[0]]
    while trees:
        for n in ex.walk(trees.pop()):
            t = type(n)
            if t is ex.Voltage:
                nodes[n.pos] = None
                if n.neg is not None:
                    nodes[n.neg] = None
            elif t is ex.Current:
                elems[n.element] = None
            elif t is ex.Call and n.func not in ex.FUNCTIONS and n.func not in seen:
                seen.add(n.func)
                func = defn.lookup_func(n.func)
                if func is not None:
                    trees.append(func.body)
    return tuple(nodes), tuple(elems)


def _first_bin(name: str, models: Mapping) -> ModelCard | None:
    """The first binned card of ``name`` among ``models`` (``name.1`` ...: BSIM binning), or None."""
    head = name + "."
    if not any(key.startswith(head) for key in models):
        return None
    from ..devices.osdi.spice_models import first_bin  # the binning rules' owner (imported only for bins)

    return first_bin(name, models)


def _undefined(env: Env, node: ex.Param) -> bool:
    """True when no scope defines the parameter ``node`` names."""
    try:
        env.value(node.name)
    except UnknownName:
        return True
    return False


def _may_run_as_port(el: Element, models: Mapping) -> bool:
    """The element may be one that :func:`netdae.devices.osdi.spice_models.map_devices` rewrites.

    A kind that only runs through a port, a node count beyond the kind's (a
    VBIC's thermal node), a model of a level other than 1, or a model name
    without a card (BSIM bins).
    """
    spec = KINDS[el.kind]
    if spec.runs_as is not None or len(el.nodes) not in spec.node_counts:
        return True
    if not spec.model_types or el.model is None:
        return False
    model = models.get(el.model)
    return model is None or model.params.get("level", 1.0) != 1.0


def _ground(name: str) -> str:
    return "0" if name == "gnd" else name


class _Elaborator:
    def __init__(self, net: Netlist, overrides: dict[str, float], max_elements: int, sample: int = 0,
                 seed: int | None = None, values: dict[str, float] | None = None,
                 trace: Trace | None = None) -> None:
        self.net = net
        self.values = values or {}
        self.overrides = overrides
        self.max_elements = max_elements
        self.globals = {"0", *net.globals}
        self.diagnostics: list[Diagnostic] = list(net.diagnostics)
        self.bodies: dict[int, list[_Placed]] = {}
        self.frames: dict[int, _Frame] = {}
        self.refs: dict[int, tuple[tuple, tuple]] = {}
        self.local_initial: list[_Placed] = []
        self.model_cards: dict[str, ModelCard] = {}
        self.model_words: dict[str, dict[str, tuple[str, int]]] = {}
        self._non_ascii_warned = False
        self.root = self._scope(None, net.top, None)
        self.root.draws = Draws(self._seed(net) if seed is None else seed, sample)
        self.root.defs[TEMPER] = (self._temper(net), self.root)
        self._override(self.root, overrides)
        self.given = frozenset(overrides)  # top-level parameters the caller fixed
        self.trace = trace
        if trace is not None:
            trace.start(self.root)
        self.envs: dict[tuple, Env] = {(): self.root}
        self._used: set[int] = set()  # the subcircuit definitions instantiated (by id)
        # ``x1.out`` -> the node instance x1 connects its port ``out`` to: the name a port is *not*
        # known by (its hierarchical name), for the hint at a card that names it
        self.port_nodes = PortNodes(self.globals)

    @staticmethod
    def _temper(net: Netlist) -> ParamDef:
        """``temper``: the circuit temperature of the last ``.temp`` card, else of ``.options temp=``, else 27."""
        for val, card in reversed(net.temps):
            return ParamDef(TEMPER, val, card, val[1])
        for name, value, offset, card in reversed(net.options):
            if name == "temp" and value is not True and value.kind in (WORD, EXPR):
                return ParamDef(TEMPER, parse_value(card, value, DOT_CARDS[".options"], "option value"), card,
                                value.start)
        return ParamDef(TEMPER, (Options().temp, 0), None, 0)

    def _seed(self, net: Netlist) -> int:
        """The seed of the Monte Carlo functions: the last ``.options seed=``, else :data:`DEFAULT_SEED`.

        ``seed=random`` takes a fresh seed from the operating system and says which (a note), so the
        run can be repeated.
        """
        for name, value, offset, card in reversed(net.options):
            if name != "seed":
                continue
            form = DOT_CARDS[".options"]
            if value is not True and value.kind == WORD and value.text == "random":
                seed = random_seed()
                self.diagnostics.append(Diagnostic("note", f"seed=random: the Monte Carlo functions draw with seed "
                                                   f"{seed} (.options seed={seed} repeats this run)",
                                                   card.location(offset)))
                return seed
            if value is True or value.kind == STRING:
                raise error(card, offset, "option 'seed' needs a non-negative integer or 'random'", form)
            hint = f"a seed is an integer from 0 to {MAX_SEED}, or 'random'"
            if value.kind == WORD and value.text.lstrip("+").isdigit() and value.text.isascii():
                seed = int(value.text)  # exactly as written (a float holds integers exactly up to 2**53 only)
            else:
                number = self._value(parse_value(card, value, form, "option value"), card, "option value")
                if not math.isfinite(number) or number != int(number) or number < 0:
                    raise error(card, value.start, f"option 'seed' needs a non-negative integer or 'random', "
                                f"not {number:g}", form, hint=hint)
                if number > 2**53:
                    raise error(card, value.start, f"option 'seed' = {number:g} is computed in floating point, "
                                "which holds integers exactly only up to 2**53 = 9007199254740992", form,
                                hint="write a larger seed as its digits (seed=12345678901234567)")
                seed = int(number)
            if seed_problem(seed) is not None:
                raise error(card, value.start, f"option 'seed' = {seed} is beyond the largest seed, {MAX_SEED}",
                            form, hint=hint)
            return seed
        return DEFAULT_SEED

    @staticmethod
    def _override(root: Env, overrides: dict[str, float]) -> None:
        """Top-level parameter values given by the caller replace their ``.param`` definitions."""
        for name, value in overrides.items():
            if name == TEMPER:  # the circuit temperature, as .temp would give it
                if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > ABSOLUTE_ZERO:
                    raise NetlistError(f"params: temper must be a temperature above {ABSOLUTE_ZERO} degC, "
                                       f"got {value!r}")
                root.values[TEMPER] = float(value)
                continue
            if name not in root.defs:
                known = ", ".join(sorted(k for k in root.defs if k != TEMPER)) or "none"
                raise NetlistError(f"params: no top-level .param defines '{name}' (defined: {known})",
                                   hint="only parameters of top-level .param cards can be given")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise NetlistError(f"params: the value of '{name}' must be a finite number, got {value!r}")
            root.values[name] = float(value)

    # -- parameter scopes -------------------------------------------------
    def _scope(self, parent: Env | None, defn: Definition, frame: _Frame | None) -> Env:
        """The parameter scope of one instance of ``defn`` (the top level: ``frame`` None).

        As ngspice 39 evaluates them, the subcircuit's parameters (the instance's
        values, else the defaults) and its body's ``.param`` cards (the instance's
        value replacing one of the same name) are one set of definitions evaluated
        in the instance's own scope, in ngspice's order: an instance value ``r2={r1}``
        reads the instance's ``r1``, not the caller's; a name not yet assigned there
        (its own, above all) is read where the subcircuit is called
        (:func:`_unassigned_reads_outward`).
        """
        env = Env(parent, dict(defn.funcs))
        if frame is not None:
            for d in defn.defaults:
                if d.name in frame.inst.params:
                    val = frame.inst.params[d.name]
                    env.define(ParamDef(d.name, val, frame.inst.card, val[1]), env)
                else:
                    env.define(d, env)
        for p in defn.params:
            if frame is not None and p.name in frame.inst.params:
                # ngspice: the instance's value replaces the body's .param of that name too
                val = frame.inst.params[p.name]
                env.define(ParamDef(p.name, val, frame.inst.card, val[1]), env)
            else:
                env.define(p, env, self.diagnostics)
        if frame is not None:
            _unassigned_reads_outward(env, parent, defn)
        return env

    def env(self, frames: tuple) -> Env:
        env = self.envs.get(frames)
        if env is None:
            parent = self.env(frames[:-1])
            frame = frames[-1]
            env = self._scope(parent, frame.sub, frame)
            self._informative(True)
            env.all_values()  # every parameter of the instance is evaluated, used or not (as ngspice)
            self._informative(False)
            self.envs[frames] = env
        return env

    # -- expansion ----------------------------------------------------------
    def _fresh(self, item, defn: Definition) -> _Placed:
        if type(item) is ElementCard:
            if item.expr is None and not item.controls:
                return _Placed(item, item.name, item.nodes, (), (),
                               item.model[0] if item.model is not None else None, None, (), ())
            refs = self.refs.get(id(item))
            if refs is None:
                refs = _expr_refs(item, defn)
                self.refs[id(item)] = refs
            nodes, elems = refs
            crefs = tuple(c for c, _ in item.controls) + elems
            model = item.model[0] if item.model is not None else None
            return _Placed(item, item.name, item.nodes, tuple(_ground(n) for n in nodes), crefs, model,
                           None, (), ())
        if type(item) is InitialCard:
            return _Placed(item, item.name, tuple(_ground(e[0]) for e in item.entries), (), (), None, None, (), ())
        return _Placed(item, item.name, getattr(item, "nodes", ()), (), (), None, None, (), ())

    def body(self, defn: Definition) -> list[_Placed]:
        """The definition's cards with its own local instances expanded (memoised)."""
        key = id(defn)
        cached = self.bodies.get(key)
        if cached is not None:
            return cached
        out: list[_Placed] = []
        stack = [self._fresh(item, defn) for item in reversed(defn.items)]
        while stack:
            p = stack.pop()
            if type(p.item) is InstanceCard:
                sub = defn.subckts.get(p.item.subckt)
                if sub is not None:
                    stack.extend(reversed(self._instantiate(p, sub)))
                    continue
            out.append(p)
        self.bodies[key] = out
        return out

    def _unused_errors(self, scope: Definition) -> None:
        """Warn of the unreadable cards of subcircuits never instantiated (ngspice never reads them)."""
        for sub in scope.subckts.values():
            if sub.errors and id(sub) not in self._used:
                first = sub.errors[0]
                more = f" (and {len(sub.errors) - 1} more)" if len(sub.errors) > 1 else ""
                self.diagnostics.append(Diagnostic(
                    "warning", f".subckt {sub.name} is never used, so its card that cannot be read is ignored, "
                    f"as ngspice ignores it{more}: {first.message}", first.location))
            self._unused_errors(sub)

    def _instantiate(self, x: _Placed, sub: Definition) -> list[_Placed]:
        inst: InstanceCard = x.item
        if sub.errors:
            raise sub.errors[0]
        self._used.add(id(sub))
        for f in x.frames:
            if f.sub is sub:
                chain = " -> ".join([fr.sub.name for fr in x.frames[x.frames.index(f):]] + [sub.name])
                raise error(inst.card, inst.subckt_offset, f"recursive subcircuit instantiation: {chain}",
                            ELEMENTS["x"])
        if len(x.nodes) != len(sub.ports):
            raise error(inst.card, inst.subckt_offset,
                        f"subcircuit '{sub.name}' has {len(sub.ports)} port(s) ({' '.join(sub.ports) or '-'}), "
                        f"the instance connects {len(x.nodes)} node(s)", ELEMENTS["x"],
                        hint=f"defined at {sub.card.file}:{sub.card.line}")
        frame = self.frames.get(id(inst))
        if frame is None:
            declared = {d.name for d in sub.defaults}
            local = {p.name for p in sub.params}
            for name, val in inst.params.items():
                if name == "m" and _multiplier_instance(inst, sub):
                    continue
                if name not in declared and name not in local:
                    known = ", ".join(sorted(declared | local)) or "none"
                    raise error(inst.card, val[1], f"subcircuit '{sub.name}' has no parameter '{name}' "
                                f"(its parameters: {known})", ELEMENTS["x"])
            frame = self.frames[id(inst)] = _Frame(inst, sub)
        prefix = x.name
        ports = dict(zip(sub.ports, x.nodes))
        glob = self.globals
        self.port_nodes.add(prefix, ports)
        frames = x.frames + (frame,)
        path = x.path + (inst.name,)
        own_models = sub.models

        def node(n: str) -> str:
            if n in glob:
                return n
            m = ports.get(n)
            return m if m is not None else f"{prefix}.{n}"

        def elem(n: str) -> str:
            return f"{prefix}.{n}" if n[0] == "x" else f"{n[0]}.{prefix}.{n}"

        out = []
        for b in self.body(sub):
            item = b.item
            kind = type(item)
            if kind is ElementCard:
                model, bound = b.model, b.bound
                if model is not None:
                    if bound is not None:
                        model = f"{prefix}:{model}"
                    elif model in own_models:
                        bound = own_models[model]
                        model = f"{prefix}:{model}"
                    elif own_models and kind is ElementCard and b.item.kind == Kind.MOSFET:
                        binned = _first_bin(model, own_models)
                        if binned is not None:  # nch.1, nch.2 ... of this subcircuit (BSIM binning)
                            bound, model = binned, f"{prefix}:{model}"
                out.append(_Placed(item, elem(b.name), tuple(map(node, b.nodes)), tuple(map(node, b.refs)),
                                   tuple(map(elem, b.crefs)), model, bound, frames + b.frames, path + b.path))
            elif kind is InstanceCard:
                out.append(_Placed(item, f"{prefix}.{b.name}", tuple(map(node, b.nodes)), (), (), None, None,
                                   frames + b.frames, path + b.path))
            elif kind is InitialCard:
                out.append(_Placed(item, b.name, tuple(map(node, b.nodes)), (), (), None, None, frames + b.frames,
                                   path + b.path))
            else:
                out.append(_Placed(item, f"{prefix}:{b.name}", (), (), (), None, None, frames + b.frames,
                                   path + b.path))
        return out

    # -- circuit --------------------------------------------------------------
    def run(self) -> Circuit:
        net = self.net
        check_size(net.top, self.max_elements)
        placed = self.body(net.top)
        circuit = Circuit(title=net.title, path=net.path, netlist=net, overrides=dict(self.overrides),
                          max_elements=self.max_elements)
        elements: dict[str, Element] = {}
        first: dict[str, _Placed] = {}
        nodes: dict[str, None] = {}
        pending: list[tuple[Element, _Placed]] = []
        lines: list[tuple[Element, _Placed]] = []
        for p in placed:
            item = p.item
            kind = type(item)
            if kind is InstanceCard:
                raise error(item.card, item.subckt_offset, f"unknown subcircuit '{item.subckt}'", ELEMENTS["x"],
                            hint="define it with .subckt ... .ends (or .include the file that does)")
            if kind is ModelCard:
                circuit.models[p.name] = self._model(p)
                continue
            if kind is InitialCard:
                self.local_initial.append(p)
                continue
            el = self._element(p)
            if el.name in self.values:
                _set_value(el, self.values[el.name])
            old = elements.get(el.name)
            if old is not None:
                raise _duplicate(el, p, first[el.name])
            elements[el.name] = el
            first[el.name] = p
            if not self._non_ascii_warned and not (el.name.isascii() and all(n.isascii() for n in el.nodes)):
                self._warn_non_ascii_name(p)
            for n in el.nodes:
                if n != "0" and n not in nodes:
                    nodes[n] = None
            if el.controls or el.expr is not None:
                pending.append((el, p))
            if el.kind in lossy.LINE_KINDS:
                lines.append((el, p))
            circuit.elements.append(el)
        for el, p in pending:
            self._check_references(el, p, elements, nodes)
        self._check_duplicate_couplings(circuit.elements)
        if any(el.kind in LAPLACE_KINDS for el in circuit.elements):
            cards = {el.name: (p.item.card, p.item.expr[1]) for el, p in pending if el.kind in LAPLACE_KINDS}
            circuit.elements = self._realise_laplace(circuit.elements, elements, nodes, cards)
        if any(el.kind in _PSPICE_SWITCHES and circuit.models.get(el.model) is not None
               and circuit.models[el.model].type == _PSPICE_SWITCHES[el.kind] for el in circuit.elements):
            circuit.elements = self._realise_pspice_switches(circuit, elements)
        circuit.osdi_files = list(net.osdi)
        self._scale_warning = None
        self._options(circuit)  # (BSIM binning and sizes read .options scale and wnflag)
        self._apply_models(circuit)
        if self._scale_warning is not None and not any(el.kind == Kind.OSDI and el.letter == "m"
                                                       for el in circuit.elements):
            self.diagnostics.append(self._scale_warning)
        if any(el.kind == Kind.URC for el in circuit.elements):
            self._realise_urc(circuit, elements, nodes)
        self._realise_shunts(circuit, elements, nodes)
        circuit.nodes = list(nodes)
        self._check_zero_capacitor_nodes(circuit.elements)
        circuit.params = Params(self._top_params())
        for name in self.values:
            mp = model_parameter(name)
            if mp is not None:
                self._check_model_parameter(circuit, mp[0], mp[1], None)
            elif name not in elements:
                raise NetlistError(f"values: no element '{name}' in the circuit",
                                   hint="name elements in full, e.g. r1 or r.x1.r2 inside subcircuit x1")
        self._analyses(circuit, elements)
        if any(el.kind in lossy.LINE_KINDS for el in circuit.elements):
            cards = {el.name: p.item for el, p in lines}
            self._realise_lines(circuit, elements, cards)
        self._check_random_sources(circuit)
        circuit.steps = self._steps(elements, circuit)
        if circuit.analyses and not nodes:
            card = self.net.analyses[0].card
            what = "no elements" if not elements else "no node other than ground"
            raise error(card, 0, f"the circuit has {what}: nothing to simulate",
                        hint="connect elements between nodes and ground (0)")
        if circuit.osdi_files or any(el.kind == Kind.OSDI for el in circuit.elements):
            from ..devices.osdi.bind import check_circuit  # loads the libraries (ctypes): only when used
            self.diagnostics.extend(check_circuit(circuit))
        self._initial(circuit, nodes)
        self._saves(circuit, nodes, elements)
        self._fouriers(circuit, nodes, elements)
        circuit.measures = elaborate_measures(self.net.measures, circuit, nodes, elements, self._value,
                                              BRANCH_CURRENT_KINDS, functions=self.root,
                                              port_nodes=self.port_nodes)
        for m in self.net.measures:
            self.diagnostics.extend(m.card.take_notes())
        self._unused_errors(self.net.top)
        circuit.diagnostics = _unique(self.diagnostics)
        draws = self.root.draws
        if self.trace is not None:
            self.trace.finish(draws)
        circuit.seed, circuit.sample, circuit.draws = draws.seed, draws.sample, draws.count
        circuit.uses_temper = TEMPER in self.root.values
        return circuit

    @staticmethod
    def _check_random_sources(circuit: Circuit) -> None:
        """Every TRNOISE/TRRANDOM realisation fits for each ``.tran`` card (else its located error)."""
        tstops = sorted({a.tstop for a in circuit.analyses if isinstance(a, TranAnalysis) and a.tstop > 0})
        for el in circuit.elements:
            wave = el.source.tran if el.source is not None else None
            if isinstance(wave, RandomSource):
                for tstop in tstops:
                    wave.check_size(tstop)

    @staticmethod
    def _realise_laplace(placed: list[Element], elements: dict, nodes: dict, cards: dict) -> list[Element]:
        """Every E/G LAPLACE element replaced by its state-space block (:mod:`netdae.netlist.laplace`)."""
        out = []
        for el in placed:
            if el.kind not in LAPLACE_KINDS:
                out.append(el)
                continue
            parts = el.name.split(".")
            try:
                block = realise(el, "".join(f"{q}." for q in parts[1:-1]))
            except LaplaceError as exc:
                card, offset = cards[el.name]
                raise error(card, offset, str(exc), f"{parts[-1][0].upper()}name n+ n- LAPLACE {{expr}} = {{H(s)}}",
                            hint="write H(s) as a ratio of polynomials in s") from None
            for part in block[1:]:
                if part.name in elements:
                    raise NetlistError(f"{parts[-1]}: the internal element name '{part.name}' is taken",
                                       el.location, hint="rename the element")
                elements[part.name] = part
                for n in part.nodes:
                    if n != "0":
                        nodes.setdefault(n, None)
            elements[el.name] = block[0]
            out.extend(block)
        return out

    @staticmethod
    def _realise_pspice_switches(circuit: Circuit, elements: dict) -> list[Element]:
        """Every S/W element of a PSpice switch model replaced as ngspice's PSpice mode runs it.

        (:func:`netdae.netlist.compat.realise_switch`: a behavioural current with the
        resistance law of ngspice's XSPICE ``pswitch``/``aswitch``.)
        """
        out = []
        for el in circuit.elements:
            model = circuit.models.get(el.model) if el.kind in _PSPICE_SWITCHES else None
            if model is None or model.type != _PSPICE_SWITCHES[el.kind]:
                out.append(el)
                continue
            try:
                parts = realise_switch(el, model.type, model.params)
            except ValueError as exc:
                raise NetlistError(f"{el.name}: model {model.name}: {exc}", model.location,
                                   expected=".model mname vswitch (von= voff= ron= roff=) | .model mname iswitch "
                                   "(ion= ioff= ron= roff=)") from None
            for part in parts[1:]:
                if part.name in elements:
                    raise NetlistError(f"{el.name}: the internal element name '{part.name}' is taken",
                                       el.location, hint="rename the element")
                elements[part.name] = part
            elements[el.name] = parts[0]
            out.extend(parts)
        return out

    @staticmethod
    def _realise_urc(circuit: Circuit, elements: dict, nodes: dict) -> None:
        """Every URC line (U) replaced by ngspice's lumped network (:mod:`netdae.netlist.urc`).

        Raises
        ------
        NetlistError
            A model the line cannot take (located at its parameter), or a part's name that is taken.
        """
        out: list[Element] = []
        for el in circuit.elements:
            if el.kind != Kind.URC:
                out.append(el)
                continue
            model = circuit.models[el.model]
            try:
                parts, inner, diodes = urc.realise(el, model)
            except urc.UrcError as exc:
                if exc.param is None:
                    raise NetlistError(f"{el.name}: {exc}", el.location,
                                       expected=ELEMENTS["u"].form) from None
                raise NetlistError(f"{el.name}: model {model.name}: {exc}",
                                   model.locations.get(exc.param, model.location)) from None
            if diodes is not None:
                circuit.models[diodes.name] = diodes
            del elements[el.name]
            for part in parts:
                if part.name in elements:
                    raise NetlistError(f"{el.name}: the internal element name '{part.name}' is taken", el.location,
                                       hint="rename the element")
                elements[part.name] = part
            for n in inner:
                nodes.setdefault(n, None)
            out.extend(parts)
        circuit.elements = out

    @staticmethod
    def _realise_shunts(circuit: Circuit, elements: dict, nodes: dict) -> None:
        """The resistors and capacitors of ``.options rseries``, ``rshunt`` and ``cshunt`` added.

        Raises
        ------
        NetlistError
            A series resistor's name (``rl1_intern__``) or its node that the circuit already has.
        """
        o = circuit.options
        if o.rseries is not None:
            circuit.elements, added, inner = shunts.series_resistors(circuit.elements, o.rseries)
            for part, node in zip(added, inner):
                if part.name in elements or node in nodes:
                    what = f"element name '{part.name}'" if part.name in elements else f"node name '{node}'"
                    raise NetlistError(f"{part.name[1:]}: .options rseries: the internal {what} is taken",
                                       part.location, hint="rename it (ngspice 39 names them so too)")
                elements[part.name] = part
                nodes[node] = None
        extra = shunts.shunt_elements([n for n in nodes], o.rshunt, o.cshunt)
        for part in extra:
            elements[part.name] = part
        circuit.elements.extend(extra)

    def _realise_lines(self, circuit: Circuit, elements: dict, cards: dict) -> None:
        """Every lossy line (O, Y, P) replaced by its sections (:mod:`netdae.netlist.lossy`).

        The number of sections follows from the circuit's analyses (their finest time
        scale); the internal nodes and elements are named after the line.

        Raises
        ------
        NetlistError
            A model the line cannot take, located at the model's parameter (or the card's ``len=``).
        """
        scale = lossy.resolution(circuit.analyses)
        warned: set[str] = set()
        realised: dict[str, list] = {}
        out: list[Element] = []
        nodes = set(circuit.nodes)
        for el in circuit.elements:
            if el.kind not in lossy.LINE_KINDS:
                out.append(el)
                continue
            item = cards[el.name]
            model = circuit.models[el.model]
            try:
                if el.kind == Kind.TXL and model.type in MODEL_TYPES[Kind.CPL]:
                    el.kind = Kind.CPL.value  # ngspice 39 reads a Y card with a CPL model as a one-conductor CPL
                line, notes = lossy.line_parameters(el, model)
                lossy.check_magnitudes(line)
            except lossy.LossyLineError as exc:
                if exc.on_card:
                    where = item.card.location(item.params[exc.param][1])
                else:
                    where = model.locations.get(exc.param, model.location) if exc.param else model.location
                raise NetlistError(f"{el.name}: model {model.name}: {exc}", where,
                                   expected=lossy.MODEL_FORMS[model.type],
                                   hint=exc.hint) from None
            controls = sorted(lossy.NUMERICAL_CONTROLS.get(model.type, frozenset()) & (
                set(model.params) | set(self.model_cards[model.name].flags)))
            if controls and model.name not in warned:
                warned.add(model.name)
                self.diagnostics.append(Diagnostic(
                    "warning", f"model {model.name}: {', '.join(controls)} ignored: they steer ngspice's "
                    "convolution of the line, not the line (netdae's sections and error control replace them)",
                    model.locations.get(controls[0], model.location)))
            for message, param in notes:
                self.diagnostics.append(Diagnostic("warning", f"{el.name}: model {model.name}: {message}",
                                                   model.locations.get(param, model.location) if param
                                                   else model.location))
            refs = [el.nodes[len(el.nodes) // 2 - 1], el.nodes[-1]] if el.kind != Kind.LTRA else []
            for ref in refs:
                if ref != "0":
                    self.diagnostics.append(Diagnostic(
                        "warning", f"{el.name}: reference node '{ref}' is not ground: ngspice 39 reads and ignores "
                        "a TXL's or CPL's reference nodes (the line is referenced to ground), and so does netdae",
                        el.location))
            if refs:
                el.nodes = tuple("0" if k in (len(el.nodes) // 2 - 1, len(el.nodes) - 1) else n
                                 for k, n in enumerate(el.nodes))
            n, wanted = lossy.section_count(line, scale)
            if wanted > n:
                self.diagnostics.append(Diagnostic(
                    "warning", f"{el.name}: the line would need {wanted} sections at the analyses' time scale; "
                    f"netdae uses {n} (its most), so its waveforms are coarser than the stated accuracy",
                    el.location))
            realised.setdefault(line.kind, []).append((el.name, line, n))
            parts, inner = lossy.realise(el, line, n)
            del elements[el.name]
            for part in parts:
                if part.name in elements:
                    raise NetlistError(f"{el.name}: the internal element name '{part.name}' is taken",
                                       part.location, hint="rename the element")
                elements[part.name] = part
            for node in inner:
                if node in nodes:
                    raise NetlistError(f"{el.name}: the internal node name '{node}' is taken", el.location,
                                       hint="rename the node")
                nodes.add(node)
                circuit.nodes.append(node)
            out.extend(parts)
        circuit.elements = out
        for kind, lines in realised.items():
            self.diagnostics.append(Diagnostic("note", lossy.realisation_note(kind, lines), in_results=True))

    def _apply_models(self, circuit: Circuit) -> None:
        """Check the models elements use, once each; give R, C, L their model's coefficients.

        A device model of a level netdae lacks is refused; parameters ngspice
        ignores are warned about (models nobody uses are not looked at, as in ngspice).
        """
        models = circuit.models
        if any(_may_run_as_port(el, models) for el in circuit.elements):
            from ..devices.osdi.spice_models import map_devices  # ngspice's models as the bundled OSDI ports
            flags = {name: [(flag, card.card.location(offset)) for flag, offset in card.flags.items()]
                     for name, card in self.model_cards.items() if card.flags}
            self.diagnostics.extend(map_devices(circuit, flags, behavior=self.net.behavior))
        seen: set[str] = set()
        for el in circuit.elements:
            if el.model is not None and el.kind == Kind.OSDI:
                name = el.model.split("#", 1)[0]  # (map_devices names a card's second module model#module)
                if name not in seen:
                    self._screen_compiled_model(circuit, name)
                    seen.add(name)
            if el.model is None or el.kind == Kind.OSDI:
                continue
            model = circuit.models.get(el.model)
            if model is None:
                continue
            if model.name not in seen:
                self._screen_model(model, self.model_cards[model.name])
            passive = _PASSIVE_MODEL_PARAMS.get(el.kind)
            if passive is not None:
                for name, value in model.params.items():
                    key = passive.get(name)
                    if key is not None and key not in el.params:
                        el.params[key] = value
                if el.kind == Kind.RESISTOR and el.value is None:
                    el.value = self._resistance_from_model(el, model)
                elif el.kind == Kind.CAPACITOR and el.value is None:
                    el.value = _capacitance_from_model(el, model)
            else:
                for name in INSTANCE_DEFAULTS.get(KIND_OF_MODEL_TYPE.get(model.type, ""), ()):
                    if name in model.params and name not in el.params:
                        el.params[name] = model.params[name]
            if passive is None and model.name not in seen:
                message = unimplemented_level(KIND_OF_MODEL_TYPE.get(model.type, ""), model)
                if message is not None:
                    raise NetlistError(f"{el.name}: {message}", model.locations.get("level", model.location),
                                       hint=OSDI_HINT)
            seen.add(model.name)

    def _resistance_from_model(self, el: Element, model) -> float:
        """The resistance of ``Rname n+ n- mname [l=] [w=]``, as ngspice 39's resistor computes it.

        ``(l - 2 short) / (w - 2 narrow) * rsh`` when ``l * w * rsh > 0`` (``l`` and ``w`` from the
        instance, else the model's ``l`` and ``w``/``defw``, else 10 um), else the model's ``r``
        (``res``), else 1 milliohm with a warning (``REStemp``/``RESsetup`` of ngspice's res
        device). The model's tc1, tc2 and tce then apply as to any resistor.
        """
        mp = model.params
        if "resistance" in mp:
            raise NetlistError(f"{el.name}: model {model.name} gives the resistance as an instance parameter "
                               "(ngspice's instance defaults on a .model card), which netdae does not support",
                               model.locations.get("resistance", model.location), hint=f"write r= on {model.name}")
        length = el.params.get("l", mp.get("l", 10e-6))
        width = el.params.get("w", mp.get("w", mp.get("defw", 10e-6)))
        rsh = mp.get("rsh", 0.0)
        if length * width * rsh > 0.0:
            short, narrow = mp.get("short", mp.get("dlr", 0.0)), mp.get("narrow", mp.get("dw", 0.0))
            if width - 2 * narrow == 0.0:  # ngspice 39: an infinite resistance, an open circuit
                self.diagnostics.append(Diagnostic(
                    "warning", f"{el.name}: model {model.name} leaves no width (w - 2 narrow = 0): its resistance "
                    "is infinite, an open circuit, as in ngspice", el.location))
                return math.inf
            if width - 2 * narrow < 0.0:
                raise NetlistError(f"{el.name}: model {model.name} leaves a negative width (w - 2 narrow = "
                                   f"{width - 2 * narrow:g} m)", el.location,
                                   hint="give w greater than 2 narrow, or a value")
            value = (length - 2 * short) / (width - 2 * narrow) * rsh
        elif "r" in mp or "res" in mp:
            value = mp.get("r", mp.get("res"))
        else:
            self.diagnostics.append(Diagnostic("warning", f"{el.name}: model {model.name} gives no resistance (no "
                                               "r=, no rsh with l and w): 1 milliohm, as ngspice sets",
                                               el.location))
            value = 1e-3
        if not value > 0.0 or not math.isfinite(value):
            raise NetlistError(f"{el.name}: model {model.name} gives the resistance {value:g} (from rsh, l, w, "
                               "short and narrow)", el.location, hint="the resistance must be positive")
        return value

    def _check_duplicate_couplings(self, elements: list[Element]) -> None:
        """A warning at each K card coupling a pair of inductors an earlier K card couples (the factors add)."""
        first: dict[frozenset, Element] = {}
        for el in elements:
            if el.kind != Kind.COUPLING:
                continue
            pair = frozenset(el.controls)
            if pair in first:
                a, b = el.controls
                self.diagnostics.append(Diagnostic(
                    "warning", f"{el.name}: couples {a} and {b} as {first[pair].name} does: the coupling factors "
                    "add (ngspice 39 warns 'duplicate K instances' and adds them too)", el.location))
            else:
                first[pair] = el

    def _check_zero_capacitor_nodes(self, elements: list[Element]) -> None:
        """A node reached only through zero capacitances has no equation (ngspice: singular matrix)."""
        zero_caps = [el for el in elements if el.kind == Kind.CAPACITOR and el.value == 0.0]
        if not zero_caps:
            return
        only_zero: dict[str, Element] = {}
        for el in zero_caps:
            for n in el.nodes:
                if n != "0":
                    only_zero.setdefault(n, el)
        for el in elements:
            if el.kind == Kind.CAPACITOR and el.value == 0.0:
                continue
            for n in el.nodes:
                only_zero.pop(n, None)
            if el.expr is not None:
                for m in ex.walk(el.expr):
                    if type(m) is ex.Voltage:
                        only_zero.pop(m.pos, None)
                        only_zero.pop(m.neg, None)
        if only_zero:
            node, el = next(iter(only_zero.items()))
            raise NetlistError(f"{el.name}: node '{node}' is connected only through zero capacitances, so its "
                               "voltage is undetermined", el.location, expected=ELEMENTS["c"].form,
                               hint="give the capacitance a value, or remove the capacitor")

    def _top_params(self) -> dict[str, float]:
        self._informative(True)
        out = {name: self.root.value(name) for name in self.root.defs if name != TEMPER}
        self._informative(False)
        return out

    def _informative(self, on: bool) -> None:
        """Evaluations from now on only report (``on``): a :class:`Trace` need not repeat them exactly."""
        if self.trace is not None:
            self.trace.informative(on)

    def _bind(self, *role) -> None:
        """The last evaluation became the element field ``role`` (for a :class:`Trace`)."""
        if self.trace is not None:
            self.trace.bind(role)

    def _model(self, p: _Placed) -> Model:
        item: ModelCard = p.item
        env = self.env(p.frames)
        known = NGSPICE_PARAMETERS.get(KIND_OF_MODEL_TYPE.get(item.type, ""), frozenset())
        params = {}
        vdmos = item.type in MODEL_TYPES[Kind.VDMOS]
        if vdmos and "pchan" in item.flags:
            params["pchan"] = 1.0  # ngspice's reader: 'pchan' after 'vdmos' makes a p-channel VDMOS
        words = {}
        for k, v in item.params.items():
            if vdmos and k in VDMOS_ANNOTATIONS:
                continue
            if type(v[0]) is ex.Param and k not in known and _undefined(env, v[0]):
                words[k] = v  # LTspice's mfg=OnSemi: ignored where the model does not read the name
                continue
            params[k] = evaluate_val(v, env, item.card, f"model parameter '{k}'")
        for k, v in words.items():
            if self._compiled_reads(Model(p.name, item.type, params, item.card.location(0)), k):
                evaluate_val(v, env, item.card, f"model parameter '{k}'")  # raises: the word names nothing
            word = item.card.raw[v[1] : v[1] + len(v[0].name)]
            self.model_words.setdefault(p.name, {})[k] = (word, v[1])
        for key, value in self.values.items():  # stepped model parameters (.step NPN 2N2222(VAF) ...)
            mp = model_parameter(key)
            if mp is not None and mp[0] == p.name:
                params[mp[1]] = _stepped_number(key, value)
        vectors = {k: tuple(evaluate_val(v, env, item.card, f"model parameter '{k}'") for v in vals)
                   for k, vals in item.vectors.items()}
        locations = {k: item.card.location(v[1]) for k, v in item.params.items() if k in params}
        locations.update({k: item.card.location(vals[0][1]) for k, vals in item.vectors.items()})
        if "pchan" in params:
            locations["pchan"] = item.card.location(item.flags["pchan"])
        if "tnom" in params:
            self._check_temperature(params["tnom"], item.card, item.params["tnom"][1], "tnom")
        self.model_cards[p.name] = item
        strings = {k: text for k, (text, _) in item.strings.items() if not (vdmos and k in VDMOS_ANNOTATIONS)}
        locations.update({k: item.card.location(offset) for k, (_, offset) in item.strings.items() if k in strings})
        return Model(p.name, item.type, params, item.card.location(0), locations, strings, vectors)

    def _warn_non_ascii_name(self, p: _Placed) -> None:
        """One warning, at the first element or node name with characters outside ASCII.

        ngspice 39 reads each byte of such a character (UTF-8) as ``_``: ``é``
        and ``ü`` are both the node ``__`` there, two nodes in netdae; the
        circuits then differ without a word. Comments and titles are not names.
        """
        item = p.item
        names = [item.name, *getattr(item, "nodes", ())]
        name = next((n for n in names if not n.isascii()), None)
        if name is None:
            return
        self._non_ascii_warned = True
        offset = 0 if name == item.name else max(item.card.text.find(name, len(item.name)), 0)
        ngspice = "".join(c if c.isascii() else "_" * len(c.encode("utf-8", "replace")) for c in name)
        what = "element" if name == item.name else "node"
        self.diagnostics.append(Diagnostic(
            "warning", f"{what} name '{name}' has characters outside ASCII: ngspice 39 reads each of their "
            f"bytes as '_' ('{ngspice}'), so names that differ only there are one name in ngspice and two in "
            "netdae (the first such name; use ASCII names for the same circuit in both)", item.card.location(offset)))

    def _compiled_reads(self, model: Model, name: str) -> bool:
        """The card runs through a compiled (OSDI) module that reads the parameter ``name``.

        A card whose type is no ngspice model type, in a netlist that loads
        ``.osdi`` libraries, is a module's: the module's table checks every
        name, so each one is read. A card of ngspice's that runs through a
        bundled port reads the names ngspice's model of that level has
        (:func:`~netdae.devices.osdi.spice_models.reads_parameter`).
        """
        if KIND_OF_MODEL_TYPE.get(model.type) is None:
            return bool(self.net.osdi)
        from ..devices.osdi.spice_models import reads_parameter  # the mapping's owner (only for undefined words)

        return reads_parameter(model, name)

    def _warn_model_words(self, name: str, item: ModelCard) -> None:
        """One warning per parameter of model ``name`` whose value is an undefined word (ignored, as in ngspice)."""
        for param, (text, offset) in self.model_words.get(name, {}).items():
            self.diagnostics.append(Diagnostic(
                "warning", f"model {name}: parameter {param}={text} ignored, as ngspice ignores '{param}' (but "
                f"ngspice 39 stops at the undefined word '{text}': write {param}=\"{text}\")",
                item.card.location(offset)))

    def _screen_compiled_model(self, circuit: Circuit, name: str) -> None:
        """What :meth:`_screen_model` checks, for a model that runs through an OSDI module.

        The card's undefined words are warned about; on a card of a module
        loaded with ``.osdi`` a bare word is refused: a parameter of the
        module needs a value, any other name is not the module's.

        Raises
        ------
        NetlistError
            A bare word on a module's card.
        """
        item = self.model_cards.get(name)
        if item is None:
            return
        self._warn_model_words(name, item)
        if KIND_OF_MODEL_TYPE.get(item.type) is not None or not item.flags:
            return  # ngspice's model through a bundled port: map_devices screens its flags
        from ..devices.osdi.bind import circuit_modules  # loads the libraries (ctypes): only when used

        module = circuit_modules(circuit).get(item.type)
        if module is None:
            return  # no such module: refused where the model is bound
        for flag, offset in item.flags.items():
            where = item.card.location(offset)
            module.lookup(flag, name, where)
            raise error(item.card, offset, f"model parameter '{flag}' needs a value ({flag}=value)",
                        DOT_CARDS[".model"])

    def _screen_model(self, model: Model, item: ModelCard) -> None:
        """Warn about the parameters ngspice ignores for this model (one located warning each).

        Raises
        ------
        NetlistError
            A string value or a bare name for a parameter ngspice knows.
        """
        family = KIND_OF_MODEL_TYPE.get(item.type)
        if family is None or unimplemented_level(family, model) is not None:
            return  # a level netdae lacks is refused as a whole
        table = table_of(family, model.params.get("level", 1.0))
        known = NGSPICE_PARAMETERS[table]
        form = DOT_CARDS[".model"]
        first = len(self.diagnostics)
        for name in ignored_parameters(family, model):
            if name in INSTANCE_DEFAULTS.get(family, ()):
                continue  # a default for the instances (_apply_models)
            self.diagnostics.append(Diagnostic(
                "warning", f"model {model.name}: parameter '{name}' is not a parameter of ngspice's {family} "
                "model: ignored, as ngspice ignores it", model.locations.get(name, model.location)))
        self._warn_model_words(model.name, item)
        outputs = OUTPUT_ONLY.get(table, frozenset())
        dropped = VDMOS_ANNOTATIONS if family == Kind.VDMOS else frozenset()
        for name in (*item.params, *item.strings, *item.flags):
            if name in outputs:
                offset = (item.params.get(name) or item.strings.get(name) or (None, item.flags.get(name)))[1]
                why = " (the type is the card's npn/pnp/nmos/pmos/njf/pjf)" if name == "type" else ""
                raise error(item.card, offset, f"'{name}' is an output of ngspice's {family} model, not an input: "
                            "ngspice 39 stops at it on a .model card", form, hint="remove it" + why)
        for name, (text, offset) in item.strings.items():
            if name in dropped:
                continue
            if name in known:
                raise error(item.card, offset, f"model parameter '{name}' needs a number, found the string "
                            f'"{text}"', form)
            self.diagnostics.append(Diagnostic(
                "warning", f"model {model.name}: string parameter {name}=\"{text}\" ignored, as ngspice "
                "ignores it", item.card.location(offset)))
        for name, offset in item.flags.items():
            if name in _TYPE_FLAGS or name in FLAG_PARAMETERS.get(family, ()):
                continue
            if name in known:
                raise error(item.card, offset, f"model parameter '{name}' needs a value ({name}=value)", form)
            self.diagnostics.append(Diagnostic(
                "warning", f"model {model.name}: flag '{name}' is not a parameter of ngspice's {family} model: "
                "ignored, as ngspice ignores it", item.card.location(offset)))
        self.diagnostics[first:] = sorted(self.diagnostics[first:], key=lambda d: (d.location.line, d.location.column))

    @staticmethod
    def _check_temperature(value: float, card, offset: int, what: str) -> None:
        if not value > ABSOLUTE_ZERO:
            raise error(card, offset, f"{what} = {value:g} degC is not above absolute zero ({ABSOLUTE_ZERO:g} degC)",
                        hint="temperatures are in degrees Celsius")

    def _element(self, p: _Placed) -> Element:
        item: ElementCard = p.item
        card = item.card
        kind = item.kind
        env = self.env(p.frames) if p.frames else self.root
        value = None
        if item.value is not None:
            value = evaluate_val(item.value, env, card)
            self._bind(p.name, "value")
        el = Element(p.name, kind, p.nodes, value=value, location=card.location(0), instance_path=p.path)
        if item.params:
            el.params = {}
            for k, v in item.params.items():
                el.params[k] = evaluate_val(v, env, card, f"parameter '{k}'")
                self._bind(p.name, "param", k)
            for k, v in el.params.items():
                if isinstance(v, float) and abs(v) > STAMP_MAGNITUDES[1]:
                    raise error(card, item.params[k][1], f"parameter {k}={v:g} is beyond the magnitudes netdae's "
                                f"solvers hold (up to {STAMP_MAGNITUDES[1]:g})", ELEMENTS.get(item.name[0]),
                                hint="a value this large is usually a typo or a runaway expression; check its "
                                     "unit suffix")
            if "temp" in el.params:
                self._check_temperature(el.params["temp"], card, item.params["temp"][1], "instance temperature")
        if item.flags:
            for flag in item.flags:
                el.params[flag] = 1.0
        if p.model is not None:
            el.model = self._model_name(p, item)
        if item.source is not None:
            el.source = self._source(item, env, el.name)
        if item.expr is not None:
            nodes_written, elems_written = self.refs[id(item)]
            node_map = dict(zip(nodes_written, p.refs))
            elem_map = dict(zip(tuple(c for c, _ in item.controls) + elems_written, p.crefs))
            el.expr = resolve_behavioural(item.expr[0], env, card, item.expr[1], node_map, elem_map)
            if el.kind in (Kind.BVOLTAGE, Kind.BCURRENT) and ("tc1" in el.params or "tc2" in el.params):
                el.expr = self._temperature_scaled(el, env, card)
        if item.controls:
            el.controls = p.crefs[: len(item.controls)]
        if p.frames:
            self._instance_multiplier(el, item, p.frames)
        self._check_value(el, item)
        return el

    def _instance_multiplier(self, el: Element, item: ElementCard, frames: tuple) -> None:
        """Multiply an element inside subcircuit instances by their ``m=`` (ngspice 39's rule).

        ngspice 39 adds ``m={m}`` to the body's cards (not to B, V, E, H) of a subcircuit one of
        whose instances gives ``m=``: an element's or an inner instance's own ``m`` is then
        replaced, not multiplied, and the subcircuit's other instances set it to 1. netdae
        multiplies where that replacement cannot differ (one multiplier on the chain, the element
        without its own ``m``) and refuses the rest rather than reproduce the replacement.
        """
        given = [(i, f) for i, f in enumerate(frames) if "m" in f.inst.params and _multiplier_instance(f.inst, f.sub)]
        if not given or item.name[0] in _INSTANCE_M_EXEMPT or el.kind == Kind.COUPLING:
            return
        card = item.card
        values = []
        for i, f in given:
            env = self.env(frames[:i]) if i else self.root
            values.append(evaluate_val(f.inst.params["m"], env, f.inst.card, "multiplier m"))
        mult = math.prod(values)
        if len(given) > 1 or "m" in el.params:
            own = "its own m=" if "m" in el.params else "another instance's m="
            raise error(card, 0, f"{el.name} has {own} and sits in subcircuit instance "
                        f"{given[-1][1].inst.name} with m=: ngspice 39 replaces the inner m by the instance's "
                        f"(it does not multiply them); netdae does not reproduce that replacement",
                        ELEMENTS.get(item.name[0]),
                        hint="give m= on one level only: on the instance, or on the elements inside")
        if mult == 1.0:
            return
        if el.kind not in _INSTANCE_MULTIPLIED:
            raise error(card, 0, f"{el.name} ({el.kind}) sits in subcircuit instance {given[-1][1].inst.name} "
                        f"with m={mult:g}: netdae multiplies resistors, capacitors, inductors, linear G and F, "
                        f"diodes, transistors and OSDI devices by an instance's m=, not this element",
                        ELEMENTS.get(item.name[0]),
                        hint="scale the element's value inside the subcircuit with a parameter instead")
        el.params = dict(el.params) if el.params else {}
        el.params["m"] = mult
        self._bind(el.name, "param", "m")

    def _temperature_scaled(self, el: Element, env, card) -> ex.Expr:
        """A B source's expression times ``1 + tc1 dT + tc2 dT^2`` (divided by it with ``reciproctc``).

        ``dT`` is the instance temperature (``temp=``, else the circuit temperature plus
        ``dtemp=``) minus 27 C, as ngspice 39's ASRC device scales its
        value (``asrcload.c`` measures from 300.15 K whatever ``tnom`` is); ngspice gives a
        resistor whose value is an expression, turned into a B source, ``reciproctc=1``:
        its resistance is scaled.
        """
        temper = evaluate_val((ex.Param(TEMPER), 0), env, card, "temper")
        temp = el.params.pop("temp", None)  # the instance's temperature: temp=, else the circuit's plus dtemp=
        dt = (temp if temp is not None else temper + el.params.pop("dtemp", 0.0)) - ASRC_REFERENCE_TEMPERATURE
        factor = 1.0 + el.params.pop("tc1", 0.0) * dt + el.params.pop("tc2", 0.0) * dt * dt
        reciprocal = el.params.pop("reciproctc", 0.0) != 0.0
        return ex.Binary("/" if reciprocal else "*", el.expr, ex.Const(factor))

    def _check_value(self, el: Element, item: ElementCard) -> None:
        definition = KINDS[el.kind]
        if (definition.stamped and not definition.independent and isinstance(el.value, float) and el.value != 0.0
                and not STAMP_MAGNITUDES[0] <= abs(el.value) <= STAMP_MAGNITUDES[1]):
            low, high = STAMP_MAGNITUDES
            raise error(item.card, item.value[1], f"value {el.value:g} is outside the magnitudes netdae's matrices "
                        f"hold ({low:g} to {high:g}, or 0 where the element allows it)",
                        ELEMENTS.get(item.name[0]), hint="a value this large or this small is usually a typo "
                        "or a runaway expression; check its unit suffix and its parameters")
        if el.kind == Kind.RESISTOR and el.value == 0.0:
            raise error(item.card, item.value[1], "zero resistance", ELEMENTS["r"],
                        hint="use a 0 V voltage source for a short circuit")
        if el.kind == Kind.RESISTOR and el.params.get("ac", 1.0) == 0.0:
            raise error(item.card, item.params["ac"][1], "zero AC resistance (ac=0)", ELEMENTS["r"])
        if "temp" in el.params and "dtemp" in el.params:
            self.diagnostics.append(Diagnostic(
                "warning", f"{item.name}: instance temperature temp= given, dtemp= ignored (as ngspice does)",
                item.card.location(item.params["dtemp"][1])))
        if el.kind == Kind.COUPLING and not -1.0 <= el.value <= 1.0:
            raise error(item.card, item.value[1], f"coupling factor {el.value:g} outside [-1, 1]", ELEMENTS["k"])
        if el.kind == Kind.TLINE:
            self._check_tline(el, item)

    def _check_tline(self, el: Element, item: ElementCard) -> None:
        """z0 > 0 and the delay (``td=``, else ``nl / f`` with ngspice's nl = 0.25) positive."""
        syntax, at = ELEMENTS["t"], lambda key: item.params[key][1]
        if not el.params["z0"] > 0.0:
            raise error(item.card, at("z0"), f"characteristic impedance z0={el.params['z0']:g}: must be positive",
                        syntax)
        if "td" in el.params:
            if not el.params["td"] > 0.0:
                raise error(item.card, at("td"), f"delay td={el.params['td']:g}: must be positive", syntax)
            for key in ("f", "nl"):
                if key in el.params:
                    self.diagnostics.append(Diagnostic(
                        "warning", f"{item.name}: {key}= ignored, td= gives the delay (as in ngspice)",
                        item.card.location(at(key))))
                    del el.params[key]
        else:
            for key in ("f", "nl"):
                if key in el.params and not el.params[key] > 0.0:
                    raise error(item.card, at(key), f"{key}={el.params[key]:g}: must be positive", syntax)
            el.params["td"] = el.params.pop("nl", 0.25) / el.params.pop("f")
        for key in ("rel", "abs"):
            if key in el.params:
                self.diagnostics.append(Diagnostic(
                    "warning", f"{item.name}: {key}= ignored: ngspice's breakpoint control of the line's "
                    "slope; netdae places a breakpoint at every delayed corner of the sources",
                    item.card.location(at(key))))
                del el.params[key]

    def _model_name(self, p: _Placed, item: ElementCard) -> str:
        if p.bound is not None:
            mcard = p.bound
        else:
            mcard = self.net.top.models.get(p.model)
            if mcard is None and item.kind == Kind.MOSFET:
                mcard = _first_bin(p.model, self.net.top.models)  # binned: the bin is chosen with the models
            if mcard is None and item.kind == Kind.OSDI and item.nodes and item.nodes[-1] in self.net.top.models:
                # N a 0 rm off: the last bare word is read as the model, and the real one as a node
                raise error(item.card, item.model[1], f"'{item.model[0]}' after the model '{item.nodes[-1]}': "
                            "an N card takes name=value parameters after its model, no flags",
                            ELEMENTS[item.name[0]], hint=f"remove '{item.model[0]}' (OSDI modules have no off or "
                            "ic= of ngspice's built-in devices)")
            if mcard is None:
                raise error(item.card, item.model[1], f"undefined model '{item.model[0]}'",
                            ELEMENTS[item.name[0]], hint="define it with .model (in this subcircuit or above)")
        allowed = MODEL_TYPES.get(item.kind)
        if item.kind == Kind.TXL:
            allowed = allowed + MODEL_TYPES[Kind.CPL]  # a Y card reads a CPL model as one conductor (ngspice 39)
        for other in _ALSO_READS.get(item.kind, ()):
            allowed = allowed + MODEL_TYPES[other]
        if (allowed is not None and mcard.type == _PSPICE_SWITCHES.get(item.kind) and item.card.compat
                and mcard.card.compat):
            return p.model  # PSpice's switch in ngspice's PSpice mode: realised by _realise_pspice_switches
        if allowed is not None and mcard.type not in allowed and mcard.type in _PSPICE_MODEL_TYPES:
            raise error(item.card, item.model[1], f"model '{item.model[0]}' is of type '{mcard.type}', "
                        f"{_PSPICE_MODEL_TYPES[mcard.type]}, which netdae does not support (nor does ngspice 39 "
                        "outside its PSpice compatibility mode)", ELEMENTS[item.name[0]],
                        hint=f"write a {' or '.join(allowed)} model, or {MODE_HINT}")
        if allowed is not None and mcard.type not in allowed and mcard.type in _UNIMPLEMENTED_MODEL_TYPES:
            raise error(item.card, item.model[1], f"model '{item.model[0]}' is of type '{mcard.type}', "
                        f"{_UNIMPLEMENTED_MODEL_TYPES[mcard.type]}, which is not implemented by netdae",
                        ELEMENTS[item.name[0]], hint=f"netdae runs {' or '.join(allowed)} models on this card")
        if allowed is not None and mcard.type.startswith("ako:"):
            raise error(item.card, item.model[1], f"model '{item.model[0]}' is a PSpice AKO model ('a kind of' "
                        f"{mcard.type[4:]}), which netdae does not support (nor does ngspice 39 outside its PSpice "
                        "compatibility mode)", ELEMENTS[item.name[0]],
                        hint=f"copy the parameters of {mcard.type[4:]} into a {' or '.join(allowed)} model, or "
                        f"{MODE_HINT}")
        if item.kind == Kind.MOSFET and mcard.type in MODEL_TYPES[Kind.VDMOS]:
            raise error(item.card, item.model[1], f"model '{item.model[0]}' is a VDMOS (power MOSFET): its M card "
                        "has three nodes (drain gate source)", ELEMENTS["m"],
                        hint="remove the bulk node, or use an nmos/pmos model")
        if allowed is not None and mcard.type not in allowed:
            raise error(item.card, item.model[1], f"model '{item.model[0]}' is of type '{mcard.type}', a "
                        f"{ELEMENTS[item.name[0]].description} needs {' or '.join(allowed)}",
                        ELEMENTS[item.name[0]])
        return p.model

    @staticmethod
    def _source_number(value: float, card, offset: int, what: str) -> float:
        """A source's value or waveform parameter, refused beyond ``STAMP_MAGNITUDES[1]`` (the solution's scale)."""
        if abs(value) > STAMP_MAGNITUDES[1]:
            raise error(card, offset, f"{what} {value:g} is beyond the magnitudes netdae's solvers hold "
                        f"(up to {STAMP_MAGNITUDES[1]:g})", SOURCE_FUNCTIONS,
                        hint="a value this large is usually a typo or a runaway expression; check its unit "
                             "suffix and its parameters")
        return value

    def _source(self, item: ElementCard, env: Env, name: str) -> SourceSpec:
        src = item.source
        card = item.card
        spec = SourceSpec()
        if src.dc is not None:
            spec.dc = self._source_number(evaluate_val(src.dc, env, card, "DC value"), card, src.dc[1], "DC value")
            self._bind(name, "dc")
        if src.ac_mag is not None:
            spec.ac_mag = self._source_number(evaluate_val(src.ac_mag, env, card, "AC magnitude"), card,
                                              src.ac_mag[1], "AC magnitude")
            self._bind(name, "ac_mag")
            spec.ac_given = True
        if src.ac_phase is not None:
            spec.ac_phase = evaluate_val(src.ac_phase, env, card, "AC phase")
            self._bind(name, "ac_phase")
        if src.tran is not None:
            kind, vals, extras, offset = src.tran
            args = [self._source_number(evaluate_val(v, env, card, f"{kind.upper()} parameter"), card, v[1],
                                        f"{kind.upper()} parameter") for v in vals]
            try:
                if kind == "pwl":
                    if len(args) < 2 or len(args) % 2:
                        raise ValueError(f"PWL needs time-value pairs, got {len(args)} number(s)")
                    extra = {k: evaluate_val(v, env, card, f"PWL {k}=") for k, v in extras.items()}
                    spec.tran = Pwl(args[0::2], args[1::2], repeat=extra.get("r"), delay=extra.get("td", 0.0))
                elif issubclass(WAVEFORMS[kind], RandomSource):
                    # ngspice adds the DC value to the random function; its stream is the source's own
                    spec.tran = WAVEFORMS[kind](*args, dc=spec.dc or 0.0, key=self.root.draws.source_key(name),
                                                name=name, location=card.location(offset))
                else:
                    spec.tran = WAVEFORMS[kind](*args)
            except ValueError as exc:
                raise error(card, offset, str(exc), SOURCE_FUNCTIONS) from None
        return spec

    def _check_references(self, el: Element, p: _Placed, elements: dict, nodes: dict) -> None:
        item: ElementCard = p.item
        card = item.card
        syntax = ELEMENTS[item.name[0]]
        senses = KINDS[el.kind].senses
        for (written, offset), full in zip(item.controls, el.controls):
            target = elements.get(full)
            if target is None:
                hint = ("a controlling element must be in the same subcircuit as the element it controls"
                        if p.path else None)
                raise error(card, offset, f"'{written}' names no element (looked for '{full}')", syntax, hint=hint)
            what = KINDS[target.kind].noun
            if senses == "branch" and target.kind not in BRANCH_CURRENT_KINDS:
                raise error(card, offset, f"'{written}' is {what}, which has no branch current (W senses "
                            "the current of a V source, inductor, E/H source or B voltage source)", syntax,
                            hint="add a 0 V source in series with the branch and name it")
            if senses in KINDS and target.kind != senses:
                sensed = KINDS[senses]
                raise error(card, offset, f"'{written}' is {what}, not {sensed.noun}"
                            + (f" ({KINDS[el.kind].summary}s sense the current of {sensed.noun})"
                               if sensed.currents else ""), syntax,
                            hint="add a 0 V source in series with the branch and name it" if sensed.currents else None)
        if el.expr is None:
            return
        for n in ex.walk(el.expr):
            if type(n) is ex.Voltage:
                for name in (n.pos, n.neg):
                    if name is not None and name not in nodes:
                        raise error(card, item.expr[1], f"V({name}): no element connects node '{name}'", syntax)
            elif type(n) is ex.Current:
                target = elements.get(n.element)
                if item.name[0] in "fh" and (target is None or target.kind != Kind.VSOURCE):  # F/H POLY controls
                    what = "names no element" if target is None else f"is a {target.kind}"
                    raise error(card, item.expr[1], f"POLY control '{n.element}' {what}, not a voltage source "
                                "(F and H sense the current of a V source)", syntax,
                                hint="add a 0 V source in series with the branch and name it")
                if target is None or target.kind not in BRANCH_CURRENT_KINDS:
                    what = "names no element" if target is None else f"names a {target.kind}, which has no branch current"
                    raise error(card, item.expr[1], f"I({n.element}) {what}", syntax,
                                hint="I() names a V source, inductor, E/H source or B voltage source")

    # -- analyses and control cards ------------------------------------------
    def _value(self, val, card, what: str) -> float:
        return evaluate_val(val, self.root, card, what)

    def _analyses(self, circuit: Circuit, elements: dict) -> None:
        for a in self.net.analyses:
            card, args = a.card, a.args
            form = DOT_CARDS["." + a.kind]
            loc = card.location(0)
            if a.kind == "op":
                circuit.analyses.append(OpAnalysis(loc))
            elif a.kind == "tran":
                v = {k: self._value(args[k], card, k) for k in ("tstep", "tstop", "tstart", "tmax") if k in args}
                if v["tstep"] <= 0:
                    raise error(card, args["tstep"][1], f"tstep must be > 0, got {v['tstep']:g}", form)
                if v["tstop"] <= 0:
                    raise error(card, args["tstop"][1], f"tstop must be > 0, got {v['tstop']:g}", form)
                tstart = v.get("tstart", 0.0)
                if not 0 <= tstart < v["tstop"]:
                    raise error(card, args["tstart"][1], f"tstart must be in [0, tstop), got {tstart:g}", form)
                if v["tstep"] > v["tstop"]:
                    self.diagnostics.append(Diagnostic(
                        "warning", f".tran: tstep {v['tstep']:g} is larger than tstop {v['tstop']:g}: swapped? "
                        "(.tran tstep tstop: the print step comes first)", card.location(args["tstep"][1])))
                tmax = v.get("tmax") or None  # tmax = 0: not given, as ngspice 39 reads it
                if tmax is not None and tmax < 0:
                    raise error(card, args["tmax"][1], f"tmax must be > 0, got {tmax:g}", form)
                circuit.analyses.append(TranAnalysis(v["tstep"], v["tstop"], tstart, tmax, args["uic"], loc))
            elif a.kind == "ac":
                points, fstart, fstop = self._sweep(card, args, form)
                circuit.analyses.append(AcAnalysis(args["variation"], points, fstart, fstop, loc))
            elif a.kind == "pz":
                circuit.analyses.append(self._pz(card, args, form, set(circuit.nodes), loc))
            elif a.kind == "tf":
                circuit.analyses.append(self._tf(card, args, form, set(circuit.nodes), elements, loc))
            elif a.kind == "sens":
                circuit.analyses.append(self._sens(card, args, form, set(circuit.nodes), elements, loc))
            elif a.kind == "noise":
                circuit.analyses.append(self._noise(card, args, form, set(circuit.nodes), elements, loc))
            else:
                sweeps = []
                for name, offset, start, stop, step in args["sweeps"]:
                    target = None
                    if sweeps and sweeps[0].source == name:
                        raise error(card, offset, f"'{name}' is swept twice: the outer sweep would overwrite the "
                                    "inner one's values at every point", form,
                                    hint="the second sweep steps another source, a resistor or temp; "
                                         ".step or 'netdae sweep --step' steps anything else")
                    if name != "temp":
                        target = elements.get(name)
                        resistor = target is not None and target.kind == Kind.RESISTOR
                        if target is None or not (KINDS[target.kind].independent or resistor):
                            what = "no element" if target is None else KINDS[target.kind].noun
                            raise error(card, offset, f"sweep source '{name}' is {what}", form,
                                        hint="netdae sweeps V or I sources, resistors, or temp")
                    lo = self._value(start, card, "start")
                    hi = self._value(stop, card, "stop")
                    inc = self._value(step, card, "step")
                    if target is not None and target.kind == Kind.RESISTOR and lo * hi <= 0:
                        raise error(card, start[1], f"a resistance sweep from {lo:g} to {hi:g} reaches 0 ohm", form,
                                    hint="sweep a resistance of one sign; a short circuit is a 0 V source")
                    if name == "temp":
                        self._check_temperature(lo, card, start[1], "sweep start temperature")
                        self._check_temperature(hi, card, stop[1], "sweep stop temperature")
                    if inc == 0 or (hi - lo) * inc < 0:
                        raise error(card, step[1], f"step {inc:g} does not lead from {lo:g} to {hi:g}", form)
                    sweeps.append(DcSweep(name, lo, hi, inc))
                circuit.analyses.append(DcAnalysis(sweeps, loc))
            circuit.analyses[-1].alter = card.alter  # the .control script's alter/altermod changes in force

    @staticmethod
    def _node(card, name: str, offset: int, form: str, nodes: set, what: str) -> str:
        if name != "0" and name not in nodes:
            raise error(card, offset, f"{what} '{name}' is not a node of the circuit", form,
                        hint="name a node an element connects (subcircuit nodes hierarchically, e.g. x1.mid), "
                             "or 0 for ground")
        return name

    def _pz(self, card, args: dict, form: str, nodes: set, loc) -> PzAnalysis:
        """``.pz``: the four nodes exist, neither port is shorted (ngspice's checks)."""
        names = [self._node(card, n, off, form, nodes, what) for (n, off), what in
                 zip(args["nodes"], ("input node", "input node", "output node", "output node"))]
        (_, in_off), _, (_, out_off), _ = args["nodes"]
        if names[0] == names[1]:
            raise error(card, in_off, f"the input port is shorted: in+ and in- are both '{names[0]}'", form,
                        hint="the input port is two different nodes, e.g. .pz in 0 out 0 vol pz")
        if names[2] == names[3]:
            raise error(card, out_off, f"the output port is shorted: out+ and out- are both '{names[2]}'", form,
                        hint="the output port is two different nodes")
        return PzAnalysis(*names, args["input_type"], args["what"], loc)

    def _output(self, card, args: dict, form: str, nodes: set, elements: dict) -> tuple[str, str]:
        """The output of ``.tf`` and ``.sens``: a voltage of existing nodes or a branch current.

        Returns the canonical signal and the signal as written.
        """
        letter, parts, offset = args["output"]
        if letter == "v":
            names = [self._node(card, n, off, form, nodes, "output node") for n, off in parts]
            written = f"v({','.join(names)})"
            if names[-1] == "0":
                names.pop()
            if not names or len(names) == 2 and names[0] == names[1]:
                raise error(card, offset, "the output voltage is identically zero (both nodes are the same)", form)
            output = f"v({','.join(names)})"
        else:
            (name, off), = parts
            target = elements.get(name)
            if target is None or target.kind not in BRANCH_CURRENT_KINDS:
                what = "names no element" if target is None else f"names a {target.kind}, which has no branch current"
                raise error(card, off, f"output i({name}) {what}", form,
                            hint="i() names a V source, inductor, E/H source or B voltage source")
            output = written = f"i({name})"
        return output, written

    def _tf(self, card, args: dict, form: str, nodes: set, elements: dict, loc) -> TfAnalysis:
        """``.tf``: an output voltage of existing nodes or a branch current, an independent source as input."""
        output, written = self._output(card, args, form, nodes, elements)
        name, off = args["source"]
        target = elements.get(name)
        if target is None or not KINDS[target.kind].independent:
            what = "names no element" if target is None else f"is {KINDS[target.kind].noun}"
            raise error(card, off, f"input source '{name}' {what}, not an independent V or I source", form,
                        hint="the input is the value of an independent V or I source of the circuit")
        return TfAnalysis(output, name, loc, written)

    def _sens(self, card, args: dict, form: str, nodes: set, elements: dict, loc) -> SensAnalysis:
        """``.sens``: the output as ``.tf``'s; the AC sweep checked as ``.ac``'s."""
        output, written = self._output(card, args, form, nodes, elements)
        if "variation" not in args:
            return SensAnalysis(output, loc, written)
        points, fstart, fstop = self._sweep(card, args, form)
        return SensAnalysis(output, loc, written, args["variation"], points, fstart, fstop)

    def _sweep(self, card, args: dict, form: str) -> tuple[int, float, float]:
        """The frequency sweep of ``.ac`` and ``.sens ... ac``: points, fstart, fstop, checked."""
        points = self._value(args["points"], card, "points")
        fstart = self._value(args["fstart"], card, "fstart")
        fstop = self._value(args["fstop"], card, "fstop")
        if points < 1 or points != int(points):
            raise error(card, args["points"][1], f"points must be a positive integer, got {points:g}", form)
        if fstart <= 0 and args["variation"] != "lin" or fstart < 0:
            raise error(card, args["fstart"][1], f"fstart must be > 0, got {fstart:g}", form)
        if fstop < fstart:
            raise error(card, args["fstop"][1], f"fstop {fstop:g} is below fstart {fstart:g}", form)
        return int(points), fstart, fstop

    def _check_model_parameter(self, circuit: Circuit, model: str, param: str, where) -> None:
        """A stepped model parameter names a top-level model and a parameter ngspice knows for its type.

        Raises
        ------
        NetlistError
            At ``where`` (``(card, offset, declared type)``), or unlocated for ``values=``.
        """
        def fail(message, hint=None):
            if where is None:
                return NetlistError(f"values: {message}", hint=hint)
            return error(where[0], where[1], message, DOT_CARDS[".step"], hint=hint)

        mod = circuit.models.get(model)
        if mod is None:
            known = ", ".join(sorted(circuit.models)) or "none"
            raise fail(f"no model '{model}' to step (models: {known})",
                       hint="step a top-level .model's parameter as MODEL(PARAM)")
        if where is not None and where[2] is not None and where[2] != mod.type:
            raise fail(f"model '{model}' is of type '{mod.type}', not '{where[2]}'")
        family = KIND_OF_MODEL_TYPE.get(mod.type)
        if family is None and circuit.osdi_files:  # a compiled module's model: its own parameter table
            from ..devices.osdi.bind import circuit_modules  # loads the libraries (ctypes): only when used

            module = circuit_modules(circuit).get(mod.type)
            if module is not None and module.parameter(param) is None:
                names = [p.name for p in module.parameters]
                raise fail(f"model '{model}' (OSDI module {module.name}) has no parameter '{param}'",
                           hint=f"the module's parameters: {', '.join(names[:12])}{' ...' if len(names) > 12 else ''}"
                           f" (netdae osdi {module.library.path} --params lists them)")
        known = NGSPICE_PARAMETERS.get(family or "", frozenset())
        if known and param not in known:
            raise fail(f"model '{model}' ({mod.type}) has no parameter '{param}'",
                       hint=f"ngspice's {family} model parameters, e.g. {', '.join(sorted(known)[:12])} ...")
        if param in OUTPUT_ONLY.get(family or "", ()):
            raise fail(f"'{param}' is an output of ngspice's {family} model, not a parameter to set")

    def _noise(self, card, args: dict, form: str, nodes: set, elements: dict, loc) -> NoiseAnalysis:
        """``.noise``: output nodes of the circuit, an independent source with an AC value, a valid grid."""
        names = [self._node(card, n, off, form, nodes, "output node") for n, off in args["nodes"]]
        output, reference = names[0], names[1] if len(names) == 2 else "0"
        if output == reference:
            raise error(card, args["nodes"][0][1], f"the output voltage v({output},{reference}) is identically zero "
                        "(both nodes are the same)", form)
        name, off = args["source"]
        target = elements.get(name)
        if target is None or not KINDS[target.kind].independent:
            what = "names no element" if target is None else f"is {KINDS[target.kind].noun}"
            raise error(card, off, f"input source '{name}' {what}, not an independent V or I source", form,
                        hint="the input noise is referred to an independent V or I source of the circuit")
        if target.source is None or not target.source.ac_given:
            raise error(card, off, f"input source '{name}' has no AC value: ngspice refuses it as the noise input",
                        form, hint=f"give {name} an AC value, e.g. '{name} ... ac 1'")
        points = self._value(args["points"], card, "points")
        fstart = self._value(args["fstart"], card, "fstart")
        fstop = self._value(args["fstop"], card, "fstop")
        if points < 1 or points != int(points):
            raise error(card, args["points"][1], f"points must be a positive integer, got {points:g}", form)
        if not fstart > 0:
            raise error(card, args["fstart"][1], f"fstart must be > 0, got {fstart:g}", form,
                        hint="noise densities are computed at positive frequencies (flicker noise grows as 1/f)")
        if fstop < fstart:
            raise error(card, args["fstop"][1], f"fstop {fstop:g} is below fstart {fstart:g}", form)
        summary = 0.0
        if "summary" in args:
            summary = self._value(args["summary"], card, "pts_per_summary")
            if summary < 0 or summary != int(summary):
                raise error(card, args["summary"][1], f"pts_per_summary must be a non-negative integer, got "
                            f"{summary:g}", form)
        return NoiseAnalysis(output, reference, name, args["variation"], int(points), fstart, fstop, int(summary),
                             loc)

    def _steps(self, elements: dict[str, Element], circuit: Circuit) -> list[StepSpec]:
        """The ``.step`` cards: what each sets, and its points."""
        out: list[StepSpec] = []
        seen: dict[str, Card] = {}
        swept = {s.source for a in circuit.analyses if isinstance(a, DcAnalysis) for s in a.sweeps}
        for st in self.net.steps:
            card, form = st.card, DOT_CARDS[".step"]
            name = st.name
            mp = model_parameter(name)
            if mp is not None:
                self._check_model_parameter(circuit, mp[0], mp[1], (card, st.name_offset, st.model_type))
                target = "model"
            elif st.keyword_param or (name != "temp" and name not in elements and name in self.root.defs):
                if name not in self.root.defs or name == TEMPER:
                    known = ", ".join(sorted(k for k in self.root.defs if k != TEMPER)) or "none"
                    raise error(card, st.name_offset, f"no top-level .param defines '{name}' (defined: {known})",
                                form, hint="define it with .param, or step an element or temp")
                target = "param"
            elif name == "temp":
                target = "temp"
            elif name in elements:
                el = elements[name]
                if el.kind not in STEPPABLE_KINDS:
                    raise error(card, st.name_offset, f"cannot step '{name}', a {el.kind}", form,
                                hint="step a .param used in its value or model instead; elements stepped "
                                "directly: R C L, V I (DC value), E F G H (gain)")
                target = "element"
            else:
                raise error(card, st.name_offset, f"no parameter or element '{name}' to step", form,
                            hint="write .step param NAME ... for a top-level .param; elements by full name; "
                            "a model parameter as MODEL(PARAM)")
            if name in seen:
                raise error(card, st.name_offset, f"'{name}' is already stepped (line {seen[name].line})", form)
            seen[name] = card
            if target in ("element", "temp") and name in swept:
                card.warn(st.name_offset, f"'{name}' is what the .dc card sweeps: .dc sets it at each of its points, "
                          "so this step changes nothing in the .dc result (it does in the other analyses)")
                self.diagnostics.extend(card.take_notes())
            why = unseen_step(elements[name], circuit.analyses) if target == "element" else None
            if why is not None:
                card.warn(st.name_offset, why)
                self.diagnostics.extend(card.take_notes())
            for val in st.values:
                drawn = self._draw_in(val[0])
                if drawn is not None:
                    raise error(card, val[1], f"a .step value draws a random number ({drawn}): it would be drawn "
                                "once, and every row and Monte Carlo sample would get that one value", form,
                                hint="the values of a step are fixed numbers: put the draw in a .param the "
                                     "circuit uses and step something else, or vary it per row with Monte Carlo "
                                     "samples (--mc N, samples=N)")
            numbers = [self._value(v, card, "step value") for v in st.values]
            values = step_values(st, numbers)
            if target == "temp":
                for v, (_, offset) in zip(values if st.variation == "list" else numbers[:2], st.values):
                    self._check_temperature(v, card, offset, "step temperature")
            out.append(StepSpec(target, name, values, card.location(st.name_offset)))
        return out

    def _draw_in(self, tree, seen: set[tuple[str, str]] | None = None) -> str | None:
        """The Monte Carlo function a top-level value calls (``"agauss()"``, ``"unif() through .param r"``),
        directly or through top-level ``.param`` and ``.func`` definitions; None when it draws nothing.

        A parameter the caller gives a value (``params=``) draws nothing.
        """
        if type(tree) is float:
            return None
        seen = set() if seen is None else seen
        for node in ex.walk(tree):
            if type(node) is ex.Call:
                if is_random_call(node.func, len(node.args)):
                    return f"{node.func}()"
                f = self.root.funcs.get(node.func)
                if f is not None and (".func", f.name) not in seen:
                    seen.add((".func", f.name))
                    body = ex.transform(f.body, lambda n: ex.Const(0.0) if type(n) is ex.Param
                                        and n.name in f.args else None)
                    inner = self._draw_in(body, seen)
                    if inner is not None:
                        return f"{inner} through .func {f.name}"
            elif type(node) is ex.Param and (".param", node.name) not in seen and node.name not in self.given:
                seen.add((".param", node.name))
                d = self.root.defs.get(node.name)
                inner = None if d is None else self._draw_in(d[0].value[0], seen)
                if inner is not None:
                    return f"{inner} through .param {node.name}"
        return None

    def _options(self, circuit: Circuit) -> None:
        opts = Options()
        for name, value, offset, card in self.net.options:
            form = DOT_CARDS[".options"]
            if name == "rseries" and value is True:
                opts.rseries = DEFAULT_RSERIES
                continue
            if name in _FLOAT_OPTIONS or name in _INT_OPTIONS or name in _SHUNT_OPTIONS:
                if value is True or value.kind == STRING:
                    raise error(card, offset, f"option '{name}' needs a number", form)
                number = self._option_number(value, card)
                if name in _INT_OPTIONS:
                    if number != int(number) or number < 1:
                        raise error(card, value.start, f"option '{name}' needs a positive integer", form)
                    number = int(number)
                    if name == "maxord" and number == NGSPICE_MAXORD:
                        # ngspice 39's gear takes order 6 (it warns above it); netdae's BDF, as DASSL's and
                        # IDA's, stops at 5 (BDF6's stability region is too narrow for stiff circuits)
                        self.diagnostics.append(Diagnostic(
                            "warning", f"option maxord={number}: netdae's BDF has orders 1 to {MAX_ORDER}, "
                            f"so it runs with maxord={MAX_ORDER} (ngspice 39's gear takes order "
                            f"{NGSPICE_MAXORD})", card.location(value.start)))
                        number = MAX_ORDER
                elif name not in ("temp", "tnom") and number <= 0:
                    raise error(card, value.start, f"option '{name}' must be > 0", form)
                elif name not in ("temp", "tnom") and number > STAMP_MAGNITUDES[1]:
                    raise error(card, value.start, f"option '{name}' = {number:g} is beyond the magnitudes netdae's "
                                f"solvers hold (up to {STAMP_MAGNITUDES[1]:g})", form,
                                hint="a tolerance or conductance this large enters every residual and weight and "
                                     "overflows them; check its unit suffix")
                elif name in ("temp", "tnom"):
                    self._check_temperature(number, card, value.start, f"option {name}")
                self._option_again(opts, name, number, getattr(opts, name), card.location(value.start))
                setattr(opts, name, number)
                opts.locations[name] = card.location(value.start)
            elif name == "method":
                word = value.text if value is not True else ""
                if word not in _METHODS:
                    raise error(card, offset, f"unknown integration method '{word}'", form,
                                hint="method=gear or method=trap")
                self._option_again(opts, name, _METHODS[word], opts.method, card.location(value.start))
                opts.method = _METHODS[word]
                opts.locations[name] = card.location(value.start)
            elif name == "interp":
                opts.interp = True
            elif name == "seed":
                opts.seed = self.root.draws.seed  # read (and checked) before the parameters, by _seed
            else:
                opts.extra[name] = self._extra_option(circuit, name, value, offset, card)
        for val, card in self.net.temps:
            opts.temp = self._value(val, card, "temperature")
            self._check_temperature(opts.temp, card, val[1], ".temp")
        if TEMPER in self.overrides:
            opts.temp = float(self.overrides[TEMPER])
        circuit.options = opts

    def _option_again(self, opts: Options, name: str, value, old, location) -> None:
        """A located warning for an option given a second time with another value (the last value holds, as in
        ngspice 39, which says nothing), naming the value it replaces and where that was given."""
        before = opts.locations.get(name)
        if before is not None and before != location and value != old:
            shown = [f"{v:g}" if isinstance(v, (int, float)) else str(v) for v in (value, old)]
            self.diagnostics.append(Diagnostic(
                "warning", f"option {name}={shown[0]} replaces {name}={shown[1]} given at {before} (the last value "
                "holds, as in ngspice)", location))

    def _extra_option(self, circuit: Circuit, name: str, value, offset: int, card):
        """The value of an option netdae keeps as written; a located warning when ngspice 39
        simulates another circuit with it, or when the name is unknown to both (a typo)."""
        text = option_warning(name, _KNOWN_OPTIONS)
        if text is not None and name == "scale":
            # BSIM M elements read it (binning, sizes): judged once the models made them OSDI instances
            self._scale_warning = Diagnostic("warning", text, card.location(offset))
        elif text is not None:
            self.diagnostics.append(Diagnostic("warning", text, card.location(offset)))
        if value is True:
            return True
        if value.kind == EXPR or (value.kind == WORD and parse_number(value.text) is not None):
            return self._option_number(value, card)
        return value.text

    def _option_number(self, tok, card) -> float:
        val = parse_value(card, tok, DOT_CARDS[".options"], "option value")
        self.diagnostics.extend(card.take_notes())
        return self._value(val, card, "option value")

    @staticmethod
    def _initial_number(value: float, card, offset: int, what: str) -> float:
        """An ``.ic``/``.nodeset`` voltage, refused beyond ``STAMP_MAGNITUDES[1]`` (as a source's value)."""
        if abs(value) > STAMP_MAGNITUDES[1]:
            raise error(card, offset, f"initial value {value:g} is beyond the magnitudes netdae's solvers hold "
                        f"(up to {STAMP_MAGNITUDES[1]:g})", DOT_CARDS[what],
                        hint="a value this large is usually a typo or a runaway expression")
        return value

    def _initial(self, circuit: Circuit, nodes: dict) -> None:
        where: dict[str, dict] = {".ic": circuit.ic_locations, ".nodeset": {}}
        for target, entries, what in ((circuit.ic, self.net.ic, ".ic"), (circuit.nodeset, self.net.nodeset, ".nodeset")):
            for node, val, offset, card in entries:
                if node == "0":
                    self._ground_initial(what, "0", card.location(offset))
                    continue
                if node not in nodes:
                    raise error(card, offset, f"unknown node '{node}'", DOT_CARDS[what],
                                hint=unknown_node_hint(node, self.port_nodes, "x1.mid",
                                                       "ngspice 39 ignores the entry, with a warning"))
                value = self._initial_number(self._value(val, card, f"initial value of v({node})"), card, val[1], what)
                self._set_initial(target, where[what], what, node, value, card.location(offset))
        for p in self.local_initial:  # .ic/.nodeset cards inside subcircuits, one per instance
            item: InitialCard = p.item
            target = circuit.ic if item.name == ".ic" else circuit.nodeset
            env = self.env(p.frames)
            for (written, val, offset), node in zip(item.entries, p.nodes):
                if node == "0":
                    self._ground_initial(item.name, written, item.card.location(offset))
                    continue
                if node not in nodes:
                    raise error(item.card, offset, f"unknown node '{written}' (looked for '{node}')",
                                DOT_CARDS[item.name])
                value = self._initial_number(evaluate_val(val, env, item.card, f"initial value of v({written})"),
                                             item.card, val[1], item.name)
                self._set_initial(target, where[item.name], item.name, node, value, item.card.location(offset))

    def _ground_initial(self, what: str, written: str, location) -> None:
        """An ``.ic``/``.nodeset`` entry of the ground node (``v(0)``, or a subcircuit port an instance grounds):
        ignored, as ngspice 39 ignores it, with a warning (its value was refused as an unknown node, or
        dropped without a word inside a subcircuit)."""
        whose = "the ground node is" if written == "0" else "the instance connects this node to ground,"
        self.diagnostics.append(Diagnostic(
            "warning", f"{what} v({written}): {whose} always 0 V: the entry is ignored, as ngspice 39 ignores it",
            location))

    def _set_initial(self, target: dict, where: dict, what: str, node: str, value: float, location) -> None:
        """One ``.ic``/``.nodeset`` value; a node given again takes the later value (as in ngspice), with a
        warning at it naming the earlier one, rather than dropping one of the two without a word."""
        if node in target and (node not in where or where[node] != location):
            before = where.get(node)
            self.diagnostics.append(Diagnostic(
                "warning", f"{what}: v({node}) is given twice: {value:g} here replaces {target[node]:g}"
                + (f" (at {before})" if before is not None else "") + " (the last value holds, as in ngspice)",
                location))
        target[node] = value
        where[node] = location

    def _saves(self, circuit: Circuit, nodes: dict, elements: dict) -> None:
        seen: dict[str, None] = {}
        for signal, offset, card in self.net.saves:
            text, problem = _save_signal(signal, nodes, elements, self.port_nodes)
            if text is None:
                continue
            if problem is not None:
                # ngspice skips an output it cannot make too; the analyses run without it
                self.diagnostics.append(Diagnostic("warning", f"{card.text.split()[0]} {signal}: {problem} "
                                                   "(not kept)", card.location(offset)))
                continue
            seen.setdefault(text, None)
        circuit.saves = list(seen)

    def _fouriers(self, circuit: Circuit, nodes: dict, elements: dict) -> None:
        """The ``.four`` cards: the fundamental evaluated, the signals named as the saves name them (one
        the saves could not keep has had its warning there and is left out here too)."""
        form = DOT_CARDS[".four"]
        for freq, signals, card in self.net.fouriers:
            f = self._value(freq, card, "the fundamental frequency")
            if not (math.isfinite(f) and f > 0.0):
                raise error(card, freq[1], f"the fundamental frequency must be positive, got {f:g}", form)
            names = []
            for signal, offset in signals:
                text, problem = _save_signal(signal, nodes, elements)
                if text is not None and problem is None and (text.startswith(("v(", "i(")) or text[0] == "@"):
                    names.append(text)
            if names:
                circuit.fouriers.append(FourierSpec(f, tuple(dict.fromkeys(names)), card.location(0)))


def _save_signal(signal: str, nodes: dict, elements: dict,
                 port_nodes: Mapping[str, str] | None = None) -> tuple[str | None, str | None]:
    """``(name, problem)`` of a ``.save``/``.print``/``.four`` signal: its normalised name (``v(a)``,
    ``v(a,b)``, ``i(v1)``, ``@q1[ic]``, a noise vector) and why netdae cannot keep it (None when it can);
    ``(None, None)`` for ``all``. A subcircuit port named hierarchically (``x1.out``, ``port_nodes``)
    gets the node it is in the problem."""
    if signal.endswith("#branch") and "(" not in signal:
        signal = f"i({signal[:-len('#branch')]})"  # ngspice's vector name of a branch current
    text = signal
    problem = None
    if "(" in signal:
        head, args = signal[:-1].split("(", 1)
        parts = [_ground(a) for a in args.split(",")]
        if head not in ("v", "i"):
            problem = (f"{head}() is an ngspice .probe quantity (vd: a voltage across a device, p: its "
                       "power) that netdae does not compute")
        elif head == "v":
            if len(parts) == 2 and parts[1] == "0":
                parts = parts[:1]
            text = f"v({','.join(parts)})"
            problem = next((_no_node(n, port_nodes) for n in parts if n != "0" and n not in nodes), None)
        elif head == "i":
            target = elements.get(parts[0]) if len(parts) == 1 else None
            if target is None:
                problem = f"no element '{parts[0]}'" + subcircuit_name_hint(parts[0], elements)
            elif target.kind not in BRANCH_CURRENT_KINDS and not KINDS[target.kind].current_is_quantity:
                problem = f"'{parts[0]}' is a {target.kind}, which has no current netdae computes"
    elif signal == "all":
        return None, None
    elif signal.startswith(("onoise_", "inoise_")):
        pass  # a noise vector: the .noise results keep it (netdae.analyses.noise)
    elif signal[0] == "@":
        problem = _device_quantity_problem(signal, elements)
    else:
        text = f"v({_ground(signal)})"
        if _ground(signal) not in nodes:
            problem = _no_node(signal, port_nodes)
    return text, problem


class PortNodes(Mapping):
    """``x1.out`` -> the node instance ``x1`` connects its port ``out`` to (a port has no hierarchical
    name of its own), read only for the hint at a card that names one: one entry per instance (its
    ports' mapping, made anyway), not per port, so a netlist of many instances pays nothing for it."""

    def __init__(self, globals_: Mapping | set) -> None:
        self._instances: dict[str, dict[str, str]] = {}
        self._globals = globals_

    def add(self, instance: str, ports: dict[str, str]) -> None:
        self._instances.setdefault(instance, ports)

    def __getitem__(self, name: str) -> str:
        instance, _, port = name.rpartition(".")
        ports = self._instances.get(instance)
        if ports is None or port not in ports or port in self._globals:
            raise KeyError(name)
        return ports[port]

    def __iter__(self):
        return (f"{i}.{p}" for i, ports in self._instances.items() for p in ports if p not in self._globals)

    def __len__(self) -> int:
        return sum(1 for _ in self)


def _no_node(node: str, port_nodes: Mapping[str, str] | None) -> str:
    connected = (port_nodes or {}).get(node)
    if connected is None:
        return f"no node '{node}'"
    instance, _, port = node.rpartition(".")
    if connected == "0":
        return f"no node '{node}' ('{port}' is a port of {instance}, which connects ground to it: 0 V)"
    return f"no node '{node}' ('{port}' is a port of {instance}, which connects '{connected}' to it: save v({connected}))"


def _capacitance_from_model(el: Element, model) -> float:
    """The capacitance of ``Cname n+ n- mname [l=] [w=]``, as ngspice 39's capacitor computes it.

    The model's ``cap`` when given, else ``cj (w - narrow)(l - short) + 2 cjsw ((l - short) +
    (w - narrow))`` (``captemp.c``), with ``cj`` (``cox``) from ``di eps0 / thick`` (``thick`` alone:
    silicon dioxide, 3.9 eps0) when not given, ``narrow`` and ``short`` twice ``del`` when not
    given, ``w`` from the instance else the model's ``defw`` (``w``) else 10 um, and ``l`` from the
    instance else 0 (ngspice uses no default length here). The model's tc1, tc2 then apply as to
    any capacitor; ``l`` and ``w`` are consumed.

    Raises
    ------
    NetlistError
        A negative capacitance (the geometry smaller than ``narrow`` or ``short``).
    """
    mp = model.params
    first = lambda *names, default=0.0: next((mp[n] for n in names if n in mp), default)  # noqa: E731
    if "cap" in mp:
        value = mp["cap"]
    else:
        cj = first("cj", "cox", default=None)
        if cj is None:
            eps0 = 8.854187817e-12  # ngspice 39's CONSTepsZero
            thick = mp.get("thick", 0.0)
            cj = (mp["di"] * eps0 if "di" in mp else 3.9 * eps0) / thick if thick > 0.0 else 0.0
        delta = mp.get("del", 0.0)
        width = el.params.get("w", first("defw", "w", default=10e-6)) - mp.get("narrow", 2.0 * delta)
        length = el.params.get("l", 0.0) - mp.get("short", 2.0 * delta)
        value = cj * width * length + first("cjsw", "capsw") * 2.0 * (length + width)
    el.params.pop("l", None)
    el.params.pop("w", None)
    if not (value >= 0.0 and math.isfinite(value)):
        raise NetlistError(f"{el.name}: model {model.name} gives the capacitance {value:g} (from cj, cjsw, l, w, "
                           "short and narrow)", el.location, hint="the capacitance must not be negative")
    return float(value)


def _unique(diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    """``diagnostics`` without repeats: a card inside a subcircuit is read once per instance, and a warning
    about it (a .param redefined in the body) was said once per instance, alike."""
    seen: set = set()
    out = []
    for d in diagnostics:
        key = (d.severity, d.message, d.location, d.in_results)
        if key not in seen:
            seen.add(key)
            out.append(d)
    return out


def _stepped_number(name: str, value) -> float:
    """A stepped value given through ``values=``: a finite number.

    Raises
    ------
    NetlistError
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise NetlistError(f"values: the value of '{name}' must be a finite number, got {value!r}")
    return float(value)

def _device_quantity_problem(signal: str, elements: dict) -> str | None:
    """Why ``@device[param]`` names nothing netdae computes (None when it does)."""
    from ..signals import device_quantity, parse_signal

    try:
        sig = parse_signal(signal)
    except ValueError as exc:
        return str(exc)
    target = elements.get(sig.args[0])
    if target is None:
        return f"no device '{sig.args[0]}'" + subcircuit_name_hint(sig.args[0], elements)
    try:
        device_quantity(sig, target.kind)
    except ValueError as exc:
        return str(exc)
    return None


def _set_value(el: Element, value: float) -> None:
    """Give an element a stepped value: the value of R C L and the gains, a source's DC value."""
    if el.kind not in STEPPABLE_KINDS:
        raise NetlistError(f"values: cannot set the value of '{el.name}', a {el.kind}",
                           hint="set a .param used in its value or model instead")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise NetlistError(f"values: the value of '{el.name}' must be a finite number, got {value!r}")
    value = float(value)
    low, high = STAMP_MAGNITUDES
    if el.source is not None:
        if abs(value) > high:
            raise NetlistError(f"values: the DC value {value:g} of '{el.name}' is beyond the magnitudes netdae's "
                               f"solvers hold (up to {high:g})", el.location)
        el.source = dataclasses.replace(el.source, dc=value)
        return
    if el.kind == Kind.RESISTOR and value == 0.0:
        raise NetlistError(f"values: zero resistance for '{el.name}'", el.location,
                           hint="use a 0 V voltage source for a short circuit")
    if value != 0.0 and not low <= abs(value) <= high:
        raise NetlistError(f"values: the value {value:g} of '{el.name}' is outside the magnitudes netdae's "
                           f"matrices hold ({low:g} to {high:g}, or 0 where the element allows it)", el.location)
    el.value = value


def elaborate(netlist: Netlist, *, params: Mapping[str, float] | None = None,
              max_elements: int | None = None, sample: int = 0, seed: int | None = None,
              values: Mapping[str, float] | None = None, trace: Trace | None = None) -> Circuit:
    """Expand subcircuits, evaluate parameters, and build the flat circuit.

    Parameters
    ----------
    netlist : Netlist
        From :func:`netdae.netlist.parse`.
    params : mapping of str to float, optional
        Values of top-level ``.param`` parameters that replace the netlist's
        (names are case-insensitive; a name no top-level ``.param`` card
        defines is an error).
    max_elements : int, optional
        Largest number of elements the expanded circuit may have (default
        :data:`~netdae.netlist.size.DEFAULT_MAX_ELEMENTS`); counted before
        expanding.
    sample : int
        The Monte Carlo sample to draw (:mod:`netdae.netlist.montecarlo`).
    seed : int, optional
        The Monte Carlo seed, an integer from 0 to :data:`~netdae.netlist.montecarlo.MAX_SEED`
        (default: ``.options seed=``, else 1).
    values : mapping of str to float, optional
        Element values that replace the netlist's, by full element name: the
        value of R, C, L, the gain of E, F, G, H, the DC value of V and I
        (what ``.step R1 ...`` sets).
    trace : Trace, optional
        Filled with the elaboration's parameter evaluations and what each
        became (:class:`~netdae.netlist.params.Trace`), so that other samples'
        values can be computed without elaborating again (sweeps).

    Returns
    -------
    Circuit

    Raises
    ------
    NetlistError
        Unknown subcircuit, wrong number of ports, unknown or cyclic
        parameter, undefined model or wrong model type, duplicate element
        name, a K naming a non-inductor, an F/H naming a non-voltage-source,
        an I()/V() naming nothing, bad analysis values, unknown
        ``.ic`` nodes ... each at its token; a circuit larger than
        ``max_elements`` (naming the subcircuit chain); an unknown name or
        a bad value in ``params``.
    TypeError
        ``params`` that is not a mapping, ``max_elements`` that is not an integer.

    Notes
    -----
    Linear in the size of the expanded circuit: each definition's body is
    expanded once and copied per instance; each parameter scope is
    evaluated once per instance chain.
    """
    if params is not None and not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping of parameter names to values, e.g. params={{'r': 1e3}}, not "
                        f"{type(params).__name__}")
    if max_elements is not None and (isinstance(max_elements, bool) or not isinstance(max_elements, int)):
        raise TypeError(f"max_elements must be an integer, not {type(max_elements).__name__}")
    if max_elements is not None and max_elements < 1:
        raise ValueError(f"max_elements must be a positive integer (a limit on the expanded circuit's elements), "
                         f"not {max_elements}")
    overrides = {str(k).lower(): v for k, v in (params or {}).items()}
    limit = DEFAULT_MAX_ELEMENTS if max_elements is None else max_elements
    if sample is not None and (isinstance(sample, bool) or not isinstance(sample, int) or sample < 0):
        raise NetlistError(f"sample: expected a non-negative integer, got {sample!r}")
    if seed is not None and seed_problem(seed) is not None:
        raise NetlistError(f"seed: {seed_problem(seed)}")
    with no_gc():
        return _Elaborator(netlist, overrides, limit, sample, seed,
                           {str(k).lower(): v for k, v in (values or {}).items()}, trace).run()
