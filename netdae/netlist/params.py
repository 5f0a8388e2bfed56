"""Parameter scopes: lazy, dependency-ordered evaluation of ``.param`` and subcircuit parameters.

Scoping follows ngspice's numparam, which is *dynamic*: a subcircuit body
sees its own parameters, then those of the instance that called it, and so
on up to the top-level ``.param`` values (verified with ngspice 39: a body
may use a parameter of its caller's subcircuit). Within one scope the order
of ``.param`` cards does not matter (ngspice sorts them by dependency); a
name defined twice takes its last definition, with a warning. A subcircuit
default may use the other parameters of the same subcircuit, including the
values the instance passed.

User functions (``.func``) are expanded where they are called, so their
bodies see the parameters of the calling scope, as ngspice's macro
expansion does.
"""

from __future__ import annotations

import math

import numpy as np

from ..circuit import Diagnostic
from ..errors import NetlistError
from . import expr as ex
from .montecarlo import Draws, is_random_call
from .statements import FuncDef, ParamDef

__all__ = ["Env", "UnknownName", "CallDepthError", "evaluate_val", "inline_calls", "resolve_behavioural", "Trace",
           "Replay", "ReplayMismatch", "INFO", "OTHER"]

#: Deepest nesting of user-function calls netdae evaluates or expands.
MAX_CALL_DEPTH = 64


class CallDepthError(ValueError):
    """User-function calls nested deeper than :data:`MAX_CALL_DEPTH`: the one refusal of every evaluator.

    The message says how deep, shows the chain of calls, and calls it recursion only when a
    function repeats in it (a chain of distinct functions is only deep).

    Parameters
    ----------
    calls : sequence of str
        The functions being called, outermost first, the one refused last.

    Examples
    --------
    >>> print(CallDepthError(["f", "g", "h", "g"]))
    function calls nested deeper than 64 (recursive .func 'g': g -> h -> g)
    >>> print(CallDepthError([f"f{j}" for j in range(65)]))
    function calls nested deeper than 64: f0 -> f1 -> f2 -> ... -> f63 -> f64 (65 distinct functions)
    """

    def __init__(self, calls) -> None:
        self.calls = tuple(calls)
        seen: dict[str, int] = {}
        for k, name in enumerate(self.calls):
            if name in seen:
                cycle = " -> ".join(self.calls[seen[name]:k + 1])
                text = f"function calls nested deeper than {MAX_CALL_DEPTH} (recursive .func '{name}': {cycle})"
                break
            seen[name] = k
        else:
            shown = self.calls if len(self.calls) <= 6 else (*self.calls[:3], "...", *self.calls[-2:])
            text = (f"function calls nested deeper than {MAX_CALL_DEPTH}: {' -> '.join(shown)} "
                    f"({len(self.calls)} distinct functions)")
        super().__init__(text)

    def __reduce__(self):
        return (CallDepthError, (self.calls,))


class UnknownName(Exception):
    """A parameter or function name that no scope defines."""

    def __init__(self, name: str, kind: str = "parameter") -> None:
        super().__init__(name)
        self.name = name
        self.kind = kind


class Env:
    """One parameter scope.

    Parameters
    ----------
    parent : Env or None
        The scope of the caller (dynamic scoping).
    funcs : dict of str to FuncDef, optional
        The ``.func`` definitions of this scope.

    Notes
    -----
    Definitions are added with :meth:`define` and evaluated on first use
    (memoised), so the order of ``.param`` cards does not matter and a
    parameter nobody uses costs nothing.
    """

    __slots__ = ("parent", "defs", "values", "funcs", "_active", "draws", "trace")

    def __init__(self, parent: "Env | None", funcs: dict[str, FuncDef] | None = None) -> None:
        self.parent = parent
        #: The sample's random stream (:class:`~netdae.netlist.montecarlo.Draws`), shared by every scope.
        self.draws: Draws | None = parent.draws if parent is not None else None
        #: The elaboration's :class:`Trace` when it is recorded (shared by every scope), else None.
        self.trace: Trace | None = parent.trace if parent is not None else None
        self.defs: dict[str, tuple[ParamDef, Env]] = {}
        self.values: dict[str, float] = {}
        self.funcs = funcs or {}
        self._active: list[str] = []

    def define(self, pdef: ParamDef, where: "Env", diagnostics: list[Diagnostic] | None = None) -> None:
        """Add a definition evaluated lazily in ``where`` (last definition wins)."""
        old = self.defs.get(pdef.name)
        if old is not None and diagnostics is not None and old[0] is not pdef:
            first = old[0].card
            diagnostics.append(Diagnostic(
                "warning", f"parameter '{pdef.name}' redefined (previous definition at {first.file}:"
                f"{first.line}); the last definition is used", pdef.card.location(pdef.offset)))
        self.defs[pdef.name] = (pdef, where)

    def value(self, name: str) -> float:
        """The value of ``name`` in this scope or a calling one.

        Raises
        ------
        UnknownName
            No scope defines it.
        NetlistError
            Its definition fails to evaluate or depends on itself.
        """
        trace = self.trace
        if trace is not None and trace.depth == 0:
            return trace.record(self, ("name", name), lambda: self._lookup(name))
        return self._lookup(name)

    def _lookup(self, name: str) -> float:
        env: Env | None = self
        while env is not None:
            v = env.values.get(name)
            if v is not None:
                return v
            d = env.defs.get(name)
            if d is not None:
                return env._compute(name, d)
            env = env.parent
        raise UnknownName(name)

    def _definition(self, name: str) -> "tuple[Env, tuple[ParamDef, Env]] | None":
        """The scope that defines ``name`` and its definition, None when it has a value or no definition."""
        env: Env | None = self
        while env is not None:
            if name in env.values:
                return None
            d = env.defs.get(name)
            if d is not None:
                return env, d
            env = env.parent
        return None

    def _enter(self, name: str, pdef: ParamDef) -> None:
        """Mark ``name`` as being evaluated; a NetlistError naming the cycle when it already is."""
        if name in self._active:
            chain = self._active[self._active.index(name):] + [name]
            if len(chain) > 12:
                chain = [*chain[:5], f"... ({len(chain) - 1} parameters) ...", *chain[-5:]]
            raise NetlistError(f"parameter cycle: {' -> '.join(chain)}", pdef.card.location(pdef.offset),
                               hint="a parameter cannot depend on itself")
        self._active.append(name)

    def _compute(self, name: str, d: tuple[ParamDef, "Env"]) -> float:
        """Evaluate and memoise ``name`` (defined here as ``d``), its dependencies first.

        The parameters a definition reads before anything that may draw a
        random number, call a ``.func`` or choose a branch (:func:`_read_first`)
        are evaluated first, deepest first, with a stack of their own: a chain
        of thousands of ``.param`` cards, each reading the one before, nests no
        calls (evaluated one inside the other it exceeded Python's recursion
        limit at about 120 cards). They are the parameters the evaluation
        would read first anyway, in the same order, so the values, the random
        draws and their order are the same.
        """
        pdef, where = d
        self._enter(name, pdef)
        try:
            if type(pdef.value[0]) is not float:
                _settle(pdef.value[0], where)
            v = evaluate_val(pdef.value, where, pdef.card, _what(name))
        finally:
            self._active.pop()
        self.values[name] = v
        return v

    def func(self, name: str) -> FuncDef:
        env: Env | None = self
        while env is not None:
            f = env.funcs.get(name)
            if f is not None:
                return f
            env = env.parent
        raise UnknownName(name, "function")

    def all_values(self) -> dict[str, float]:
        """Every parameter of this scope (not its parents), evaluated."""
        return {name: self.value(name) for name in self.defs}


def _read_first(node) -> list[str]:
    """The parameters evaluating ``node`` reads before anything else can happen, in the order it reads them.

    The walk follows :func:`netdae.netlist.expr.evaluate` (operands left to
    right, a call's arguments before the call) and stops at the first step
    whose outcome decides what is read next or draws: a conditional (after its
    condition) and a call that is not a built-in function (a ``.func``, a
    random function).
    """
    out: list[str] = []
    stack = [node]
    while stack:
        n = stack.pop()
        t = type(n)
        if t is ex.Param:
            out.append(n.name)
        elif t is ex.Binary:
            stack.extend((n.right, n.left))
        elif t is ex.Unary:
            stack.append(n.operand)
        elif t is ex.Ternary:
            out.extend(_read_first(n.cond))
            return out
        elif t is ex.Call:
            if n.func not in ex.FUNCTIONS or is_random_call(n.func, len(n.args)):
                for a in n.args:
                    out.extend(_read_first(a))  # (shallow: a .func's or a random function's arguments)
                return out
            stack.extend(reversed(n.args))
    return out


def _settle(node, env: Env) -> None:
    """Evaluate the not yet evaluated parameters ``node`` reads first in ``env``, deepest first, without recursion.

    Each one's own first reads are settled before it (a depth-first walk on an
    explicit stack), so evaluating it afterwards reads only values; a cycle
    among them is the error :meth:`Env._compute` gives.
    """
    frames: list = [(None, "", None, iter(_read_first(node)), env)]
    try:
        while frames:
            owner, name, pdef, todo, where = frames[-1]
            for dep in todo:
                found = where._definition(dep)
                if found is not None:
                    dep_owner, (dep_def, dep_where) = found
                    dep_owner._enter(dep, dep_def)
                    value = dep_def.value[0]
                    frames.append((dep_owner, dep, dep_def, iter(() if type(value) is float else _read_first(value)),
                                   dep_where))
                    break
            else:
                if owner is not None:
                    owner.values[name] = evaluate_val(pdef.value, where, pdef.card, _what(name))
                    owner._active.pop()
                frames.pop()
    finally:
        for owner, *_ in reversed(frames):  # after an error: the names still being evaluated
            if owner is not None:
                owner._active.pop()


def _call(env: Env, calls: tuple[str, ...]):
    """The function-call hook of :func:`netdae.netlist.expr.evaluate` in ``env``, inside the user functions
    ``calls`` (outermost first)."""
    def call(name: str, args: list[float]) -> float:
        if is_random_call(name, len(args)):
            if env.draws is None:
                raise ValueError(f"the Monte Carlo function {name}() has no random stream here")
            return env.draws.draw(name, args)
        if len(calls) >= MAX_CALL_DEPTH:
            raise CallDepthError((*calls, name))
        f = env.func(name)
        if f.circuit:
            raise ValueError(circuit_function_message(f))
        if f.param_refusal is not None:
            raise ValueError(f.param_refusal)
        if len(args) != len(f.args):
            raise ValueError(f"{name}() takes {len(f.args)} argument(s), got {len(args)}")
        local = Env(env)
        local.values.update(zip(f.args, args))
        return ex.evaluate(f.body, local.value, _call(local, (*calls, name)))
    return call


def circuit_function_message(f: FuncDef) -> str:
    """Why a ``.func`` whose body reads the circuit has no value where a number is needed."""
    ref = next(n for n in ex.walk(f.body) if type(n) in (ex.Voltage, ex.Current, ex.Time))
    where = f.card.location(0)
    return (f"function {f.name}() reads the circuit ({ex.to_text(ref)}, .func at {where.file}:{where.line}): "
            "ngspice 39 expands it only into behavioural expressions (B sources, E/G value=, an R, C or L "
            "value, which it makes behavioural) and has no value where a number is needed")


def _what(name: str) -> str:
    """How a message names the parameter ``name``: an alias a subcircuit scope keeps for the caller's value
    (``r#outer``, :data:`netdae.netlist.elaborate.OUTER`) is named as the caller's parameter it reads.

    >>> _what("r")
    "parameter 'r'"
    >>> _what("r#outer").startswith("the value of 'r' where the subcircuit is called (the instance's own 'r'")
    True
    """
    base, alias, _ = name.partition("#")
    if not alias:
        return f"parameter '{name}'"
    return (f"the value of '{base}' where the subcircuit is called (the instance's own '{base}' is not assigned "
            "before the parameter that reads it)")


def evaluate_val(val, env: Env, card, what: str = "value") -> float:
    """Evaluate a :data:`~netdae.netlist.statements.Val` in ``env``.

    Raises
    ------
    NetlistError
        At the value's token: unknown parameter or function, division by
        zero, domain error, non-finite result.
    """
    trace = env.trace
    if trace is not None and trace.depth == 0:
        return trace.record(env, ("val", val, card, what), lambda: _evaluate_val(val, env, card, what))
    return _evaluate_val(val, env, card, what)


def _evaluate_val(val, env: Env, card, what: str) -> float:
    value, offset = val
    if type(value) is float:
        return value
    try:
        return ex.evaluate(value, env.value, _call(env, ()))
    except NetlistError:
        raise
    except UnknownName as exc:
        raise NetlistError(f"{_card_name(card)}: unknown {exc.kind} '{exc.name}' in {what}",
                           card.location(offset),
                           hint="define it with .param (or .func), or pass it to the subcircuit"
                           if exc.kind == "parameter" else "define it with .func") from None
    except ValueError as exc:
        raise NetlistError(f"{_card_name(card)}: cannot evaluate {what}: {exc}", card.location(offset)) from None


def _card_name(card) -> str:
    return card.text.split(None, 1)[0]


def inline_calls(node: ex.Expr, env: Env, calls: tuple[str, ...] = (), behavioural: bool = False) -> ex.Expr:
    """Replace calls of user functions by their bodies with the arguments substituted.

    Parameters
    ----------
    node : Expr
        The expression.
    env : Env
        The scope whose functions the calls name.
    calls : tuple of str
        The user functions already being expanded around ``node``, outermost first.
    behavioural : bool
        Expand the bodies as read by the behavioural rules (``FuncDef.behavioural``):
        ngspice expands a call textually, so in a B source its B-source parser reads
        the body (``pwr(x, 2)`` is ``sgn(x) x**2`` there, ``1mil`` 25.4e-6).

    Raises
    ------
    UnknownName
        A function no scope defines.
    ValueError
        Wrong argument count; :class:`CallDepthError` for calls nested deeper than :data:`MAX_CALL_DEPTH`.
    """
    def leaf(m):
        if type(m) is not ex.Call or m.func in ex.FUNCTIONS or m.func == "laplace" or is_random_call(m.func,
                                                                                                     len(m.args)):
            return None
        if len(calls) >= MAX_CALL_DEPTH:
            raise CallDepthError((*calls, m.func))
        f = env.func(m.func)
        if len(m.args) != len(f.args):
            raise ValueError(f"{m.func}() takes {len(f.args)} argument(s), got {len(m.args)}")
        bound = dict(zip(f.args, (inline_calls(a, env, calls, behavioural) for a in m.args)))
        tree = f.behavioural if behavioural and f.behavioural is not None else f.body
        body = ex.transform(tree, lambda q: bound.get(q.name) if type(q) is ex.Param else None)
        return inline_calls(body, env, (*calls, m.func), behavioural)
    return ex.transform(node, leaf)


def resolve_behavioural(node: ex.Expr, env: Env, card, offset: int, node_map, elem_map) -> ex.Expr:
    """A behavioural expression with parameters replaced by numbers.

    User functions are inlined, node and element names mapped to their
    full names (``node_map``, ``elem_map``: dicts from the names as written),
    ground references folded, constant subtrees folded.

    Raises
    ------
    NetlistError
        Unknown parameter or function, wrong argument count, recursion.
    """
    def leaf(m):
        t = type(m)
        if t is ex.Param:
            return ex.Const(env.value(m.name))
        if t is ex.Voltage:
            for name in (m.pos, m.neg):
                if name is not None and name not in node_map:  # read by a .func the card's scope cannot see
                    raise ValueError(f"node '{name}' of {ex.to_text(m)} comes from a .func body defined outside "
                                     "the subcircuit that calls it: define the function where it is called")
            pos = node_map[m.pos]
            neg = node_map[m.neg] if m.neg is not None else "0"
            if pos == neg:
                return ex.Const(0.0)
            if neg == "0":
                return ex.Voltage(pos, None)
            if pos == "0":
                return ex.Unary("-", ex.Voltage(neg, None))
            return ex.Voltage(pos, neg)
        if t is ex.Current:
            if m.element not in elem_map:
                raise ValueError(f"element '{m.element}' of {ex.to_text(m)} comes from a .func body defined "
                                 "outside the subcircuit that calls it: define the function where it is called")
            return ex.Current(elem_map[m.element])
        if t is ex.Call and is_random_call(m.func, len(m.args)):  # drawn once, when the card is elaborated
            return ex.Const(ex.evaluate(m, env.value, _call(env, ())))
        return None

    try:
        tree = ex.fold_constants(ex.transform(inline_calls(node, env, behavioural=True), leaf))
    except NetlistError:
        raise
    except RecursionError:
        raise NetlistError(f"{_card_name(card)}: expression nested deeper than {ex.MAX_DEPTH} levels after "
                           "expanding .func calls", card.location(offset)) from None
    except UnknownName as exc:
        raise NetlistError(f"{_card_name(card)}: unknown {exc.kind} '{exc.name}' in the expression",
                           card.location(offset)) from None
    except ValueError as exc:
        raise NetlistError(f"{_card_name(card)}: {exc}", card.location(offset)) from None
    if ex.depth(tree) > ex.MAX_DEPTH:
        raise NetlistError(f"{_card_name(card)}: expression nested deeper than {ex.MAX_DEPTH} levels after "
                           "expanding .func calls", card.location(offset))
    for m in ex.walk(tree):
        if type(m) is ex.Call and m.func in ex.POINT_FUNCTIONS:
            if any(type(a) is not ex.Const for a in m.args[1:]):
                raise NetlistError(f"{_card_name(card)}: the points of {m.func}() must be constants (numbers or "
                                   "parameters), not circuit quantities or time", card.location(offset))
            try:
                ex.check_points(m.func, [a.value for a in m.args[1:]])
            except ValueError as exc:
                raise NetlistError(f"{_card_name(card)}: {exc}", card.location(offset)) from None
    return tree


# -- a recorded elaboration, repeated for other samples -------------------------------------------
#: Role of a traced evaluation that only reports or checks (every parameter of an instance, the
#: top-level parameters of ``Circuit.params``): its value goes into nothing a simulation reads.
INFO = "info"
#: Role of a traced evaluation nobody claimed (model parameters, analysis cards, measures ...).
OTHER = "other"


class ReplayMismatch(Exception):
    """A replayed elaboration that does not follow the recorded one (a draw in another place)."""


class _Event:
    """One top-level evaluation of a traced elaboration."""

    __slots__ = ("what", "env", "value", "error", "role", "draws")

    def __init__(self, what: tuple, env: Env, role) -> None:
        self.what = what
        self.env = env
        self.value: float | None = None
        self.error: type | None = None
        self.role = role
        self.draws = 0  # the sample's draw count after this evaluation


class Trace:
    """The top-level parameter evaluations of one elaboration, in order, with what each value became.

    An elaboration given a trace (``elaborate(..., trace=)``) records every
    evaluation that is not part of another one: a value on a card
    (:func:`evaluate_val`) or a parameter asked for by name (:meth:`Env.value`).
    Parameters are evaluated lazily and memoised, so repeating these
    evaluations in the same order, in fresh scopes with another sample's
    random stream (:class:`Replay`), makes the same draws in the same order as
    elaborating that sample would: the draws of sample ``k`` stay those of
    :class:`~netdae.netlist.montecarlo.Draws` ``(seed, k)``, the one owner of
    the stream. Each evaluation has a *role*: the element field it became
    (``(element, "value")``, ``(element, "param", name)``, ``(element, "dc")``,
    ``(element, "ac_mag")``, ``(element, "ac_phase")``), :data:`INFO`, or
    :data:`OTHER`.

    Attributes
    ----------
    events : list
        The evaluations in order.
    broken : str or None
        Why the elaboration cannot be replayed (a draw made outside a
        parameter evaluation, e.g. in a behavioural expression), else None.
    initial : dict of str to float
        The top-level parameter values given before the first evaluation.
    """

    __slots__ = ("events", "depth", "broken", "initial", "_role", "_drawn")

    def __init__(self) -> None:
        self.events: list[_Event] = []
        self.depth = 0
        self.broken: str | None = None
        self.initial: dict[str, float] = {}
        self._role = OTHER
        self._drawn = 0

    def start(self, root: Env) -> None:
        """Attach to the top-level scope ``root`` after its given values are set."""
        root.trace = self
        self.initial = dict(root.values)

    def record(self, env: Env, what: tuple, evaluate) -> float:
        """Evaluate ``evaluate()`` as one top-level evaluation in ``env`` and record it."""
        drawn = env.draws.count if env.draws is not None else 0
        if drawn != self._drawn and self.broken is None:
            self.broken = "a Monte Carlo function is evaluated outside a parameter or value"
        event = _Event(what, env, self._role)
        self.events.append(event)
        self.depth += 1
        try:
            event.value = evaluate()
            return event.value
        except Exception as exc:
            event.error = type(exc)
            raise
        finally:
            self.depth -= 1
            self._drawn = event.draws = env.draws.count if env.draws is not None else 0

    def finish(self, draws: Draws) -> None:
        """End the recording: a draw made after the last evaluation breaks the trace too."""
        if draws.count != self._drawn and self.broken is None:
            self.broken = "a Monte Carlo function is evaluated outside a parameter or value"

    def bind(self, role: tuple) -> None:
        """The last evaluation became the element field ``role``."""
        if self.events:
            self.events[-1].role = role

    def informative(self, on: bool) -> None:
        """Mark the evaluations from now on as :data:`INFO` (``on``) or :data:`OTHER`."""
        self._role = INFO if on else OTHER


class Replay:
    """A :class:`Trace` repeated for other samples and other top-level parameter values.

    Parameters
    ----------
    trace : Trace
        A complete trace (``trace.broken`` None).
    seed : int
        The Monte Carlo seed.

    Notes
    -----
    The scopes are copied once (their definitions, the functions, the
    parents); each :meth:`values` call resets their memoised values and
    evaluates only the events that are not constants.
    """

    def __init__(self, trace: Trace, seed: int) -> None:
        self.trace = trace
        self.seed = int(seed)
        self._scopes: dict[int, Env] = {}
        self._root: Env | None = None
        self._steps = []
        for k, event in enumerate(trace.events):
            env = self._copy(event.env)
            kind = event.what[0]
            if kind == "val" and type(event.what[1][0]) is float:
                continue  # a constant
            self._steps.append((k, env, event.what, event.draws, event.error))
        self._envs = list(self._scopes.values())
        self._recorded = [e.value for e in trace.events]
        self.draws = trace.events[-1].draws if trace.events else 0

    def _copy(self, env: Env) -> Env:
        new = self._scopes.get(id(env))
        if new is not None:
            return new
        parent = self._copy(env.parent) if env.parent is not None else None
        new = Env(parent, env.funcs)
        new.trace = None
        self._scopes[id(env)] = new
        if parent is None:
            self._root = new
        new.defs = {name: (pdef, self._copy(where)) for name, (pdef, where) in env.defs.items()}
        return new

    def values(self, sample: int, params: dict[str, float] | None = None) -> list[float | None]:
        """The value of every recorded evaluation when elaborating ``sample`` with the top-level ``params``.

        Parameters
        ----------
        sample : int
            The Monte Carlo sample.
        params : dict of str to float, optional
            Top-level parameter values replacing those given to the traced
            elaboration (names the trace's elaboration was given).

        Returns
        -------
        list of float or None
            In event order (None where the recorded evaluation failed too).

        Raises
        ------
        NetlistError
            An evaluation fails for this sample (a sigma that is not positive ...).
        ReplayMismatch
            The evaluations do not follow the recorded ones (one fails that did
            not, or the draws differ in number).
        """
        draws = Draws(self.seed, sample)
        for env in self._envs:
            env.values = {}
            env.draws = draws
        if self._root is not None:
            self._root.values = {**self.trace.initial, **params} if params else dict(self.trace.initial)
        out: list[float | None] = self._recorded.copy()
        for k, env, what, drawn, error in self._steps:
            try:
                out[k] = evaluate_val(what[1], env, what[2], what[3]) if what[0] == "val" else env.value(what[1])
            except Exception as exc:
                if error is not None and isinstance(exc, error):
                    out[k] = None
                    continue
                raise
            if error is not None:
                raise ReplayMismatch(f"an evaluation that failed when recorded succeeds in sample {sample}")
            if draws.count != drawn:
                raise ReplayMismatch(f"sample {sample} draws in another place than the recorded elaboration")
        if draws.count != self.draws:
            raise ReplayMismatch(f"sample {sample} draws {draws.count} values, the recorded elaboration "
                                 f"{self.draws}")
        return out

    def rows(self, samples, params: list[dict[str, float]] | None = None) -> tuple[list, "np.ndarray"]:
        """:meth:`values` for many rows at once, the expression arithmetic on arrays over the rows.

        Parameters
        ----------
        samples : sequence of int
            Each row's Monte Carlo sample; its draws come from that sample's own
            stream (:class:`~netdae.netlist.montecarlo.Draws` ``(seed, sample)``), in
            the recorded order.
        params : list of dict, optional
            Each row's top-level parameter values (as :meth:`values` takes them);
            every row must give the same names.

        Returns
        -------
        values : list
            Per recorded evaluation, in event order: an array over the rows, a
            float (the same in every row), or None (it failed, as recorded).
        ok : ndarray of bool
            The rows whose values are those :meth:`values` gives, bit for bit:
            the rows that took the branches the first of them took at every
            ``c ? a : b``, and where every intermediate value is finite and every
            sigma positive (where :meth:`values` could raise). For the other rows
            call :meth:`values`.

        Notes
        -----
        The evaluations, lookups, memoisation and draws follow :meth:`values` step
        for step; ``+ - * /``, comparisons and logic are numpy's on arrays (the same
        IEEE operations as on floats); ``**`` and the built-in functions run their
        scalar definitions at each row (a vectorised ``sin`` or ``pow`` need not
        round as the scalar one does). Anything else that could make a row's
        evaluation differ (an evaluation that fails where the recorded one did
        not, the draws in another place) leaves every row to :meth:`values`.
        """
        m = len(samples)
        try:
            return _RowsPass(self, [int(s) for s in samples], params).run()
        except _Fallback:
            return [None] * len(self._recorded), np.zeros(m, dtype=bool)


def _power(a: float, b: float) -> float:
    return ex._binary("**", a, b)


class _Fallback(Exception):
    """The vectorised pass of :meth:`Replay.rows` cannot stand for the rows' own replays."""


class _Scope:
    """A scope of :meth:`Replay.rows`: a replayed :class:`Env`'s definitions with values over rows."""

    __slots__ = ("env", "parent", "values", "active")

    def __init__(self, env: Env | None, parent: "_Scope | None") -> None:
        self.env = env  # None: a function call's scope (its arguments only)
        self.parent = parent
        self.values: dict[str, object] = {}
        self.active: list[str] = []


class _RowsPass:
    """One pass of :meth:`Replay.rows` over a set of rows (arrays of shape (rows,))."""

    def __init__(self, replay: Replay, samples: list[int], params: list[dict] | None) -> None:
        self.replay = replay
        self.samples = samples
        self.m = len(samples)
        self.bad = np.zeros(self.m, dtype=bool)
        self.count = 0  # draws made, in every row alike
        self.generators: list | None = None
        self.scopes: dict[int, _Scope] = {}
        for env in replay._envs:
            self._scope(env)
        root = self.scopes[id(replay._root)] if replay._root is not None else None
        if root is not None:
            given = dict(replay.trace.initial)
            if params:
                names = set(params[0])
                if any(set(p) != names for p in params):
                    raise _Fallback
                for name in names:
                    given[name] = np.array([float(p[name]) for p in params])
            root.values = given

    def _scope(self, env: Env) -> _Scope:
        scope = self.scopes.get(id(env))
        if scope is None:
            parent = self._scope(env.parent) if env.parent is not None else None
            scope = self.scopes[id(env)] = _Scope(env, parent)
        return scope

    def run(self):
        replay = self.replay
        out: list = list(replay._recorded)
        for k, env, what, drawn, error in replay._steps:
            scope = self.scopes[id(env)]
            try:
                out[k] = self.val(what[1], scope, what[2], what[3]) if what[0] == "val" else self.lookup(scope,
                                                                                                       what[1])
            except _Fallback:
                raise
            except Exception as exc:
                if error is not None and isinstance(exc, error):
                    out[k] = None
                    continue
                raise _Fallback from None
            if error is not None or self.count != drawn:
                raise _Fallback
        if self.count != replay.draws or bool(np.all(self.bad)):
            raise _Fallback
        return out, ~self.bad

    # -- the scalar evaluation's steps over rows ---------------------------------------------------
    def lookup(self, scope: _Scope, name: str):
        s: _Scope | None = scope
        while s is not None:
            v = s.values.get(name)
            if v is not None:
                return v
            if s.env is not None:
                d = s.env.defs.get(name)
                if d is not None:
                    return self._compute(s, name, d)
            s = s.parent
        raise UnknownName(name)

    def _compute(self, s: _Scope, name: str, d):
        pdef, where = d
        if name in s.active:
            raise _Fallback  # a cycle: the rows' own replays say which
        s.active.append(name)
        try:
            v = self.val(pdef.value, self._scope(where), pdef.card, _what(name))
        finally:
            s.active.pop()
        s.values[name] = v
        return v

    def val(self, val, scope: _Scope, card, what: str):
        value, offset = val
        if type(value) is float:
            return value
        try:
            return self.expr(value, scope, ())
        except (NetlistError, _Fallback):
            raise
        except UnknownName as exc:
            raise NetlistError(f"{_card_name(card)}: unknown {exc.kind} '{exc.name}' in {what}",
                               card.location(offset)) from None
        except ValueError as exc:
            raise NetlistError(f"{_card_name(card)}: cannot evaluate {what}: {exc}", card.location(offset)) from None

    def _checked(self, v):
        """``v`` with the rows where it is not finite marked (their own evaluation may raise there)."""
        if type(v) is not float:
            self.bad |= ~np.isfinite(v)
        elif not math.isfinite(v):
            self.bad[:] = True
        return v

    def _pointwise(self, func, args: list):
        if all(type(a) is float for a in args):
            try:
                return float(func(*args))
            except (ValueError, ZeroDivisionError, OverflowError):
                return math.nan
        rows = [np.broadcast_to(a, (self.m,)) if type(a) is float else a for a in args]
        out = np.empty(self.m)
        for r in range(self.m):
            if self.bad[r]:
                out[r] = math.nan
                continue
            try:
                out[r] = func(*[float(a[r]) for a in rows])
            except (ValueError, ZeroDivisionError, OverflowError):
                out[r] = math.nan
        return out

    def expr(self, node, scope: _Scope, calls: tuple):
        t = type(node)
        if t is ex.Const:
            return node.value
        if t is ex.Param:
            v = self.lookup(scope, node.name)
            return float(v) if type(v) is not np.ndarray else v
        if t is ex.Binary:
            a, b = self.expr(node.left, scope, calls), self.expr(node.right, scope, calls)
            op = node.op
            if op in ("+", "-", "*", "/", "%"):
                if op == "/" or op == "%":
                    zero = b == 0
                    if type(zero) is bool:
                        if zero:
                            raise _Fallback  # every row divides by zero: its own evaluation raises
                    else:
                        self.bad |= zero
                with np.errstate(all="ignore"):
                    v = (a + b if op == "+" else a - b if op == "-" else a * b if op == "*" else a / b if op == "/"
                         else np.fmod(a, b))
                if type(v) is not float and type(v) is not np.ndarray:
                    v = float(v)
                return self._checked(v)
            if op == "**":
                return self._checked(self._pointwise(_power, [a, b]))
            if type(a) is float and type(b) is float:
                return ex._binary(op, a, b)
            return ex._binary_arrays(op, np.asarray(a, dtype=float), np.asarray(b, dtype=float))
        if t is ex.Unary:
            v = self.expr(node.operand, scope, calls)
            if node.op == "-":
                return -v
            return (1.0 if v == 0 else 0.0) if type(v) is float else (v == 0).astype(float)
        if t is ex.Ternary:
            c = self.expr(node.cond, scope, calls)
            if type(c) is float:
                take = c != 0
            else:
                good = np.flatnonzero(~self.bad)
                if good.size == 0:
                    raise _Fallback
                take = bool(c[good[0]] != 0)
                self.bad |= (c != 0) != take
            return self.expr(node.then if take else node.other, scope, calls)
        if t is ex.Call:
            args = [self.expr(a, scope, calls) for a in node.args]
            spec = ex.FUNCTIONS.get(node.func)
            if spec is None or is_random_call(node.func, len(args)):
                return self._call(node.func, args, scope, calls)
            return self._checked(self._pointwise(spec[1], args))
        if t is ex.Time:
            raise ValueError("'time' has no value here")
        raise ValueError(f"circuit reference {ex.to_text(node)} has no value here")

    def _call(self, name: str, args: list, scope: _Scope, calls: tuple):
        if is_random_call(name, len(args)):
            return self._draw(name, args)
        if len(calls) >= MAX_CALL_DEPTH:
            raise CallDepthError((*calls, name))
        f = self._func(scope, name)
        if f.circuit:
            raise ValueError(circuit_function_message(f))
        if f.param_refusal is not None:
            raise ValueError(f.param_refusal)
        if len(args) != len(f.args):
            raise ValueError(f"{name}() takes {len(f.args)} argument(s), got {len(args)}")
        local = _Scope(None, scope)
        local.values.update(zip(f.args, args))
        return self._checked(self.expr(f.body, local, (*calls, name)))

    @staticmethod
    def _func(scope: _Scope, name: str) -> FuncDef:
        s: _Scope | None = scope
        while s is not None:
            if s.env is not None:
                f = s.env.funcs.get(name)
                if f is not None:
                    return f
            s = s.parent
        raise UnknownName(name, "function")

    def _draw(self, name: str, args: list):
        """:meth:`~netdae.netlist.montecarlo.Draws.draw` in every row, each from its own sample's stream."""
        from .montecarlo import RANDOM_FUNCTIONS, deviate, generators, random_value

        arity = RANDOM_FUNCTIONS[name]
        if len(args) != arity:
            raise _Fallback
        if self.generators is None:
            seed = self.replay.seed
            made = iter(generators([(seed, s) for s, bad in zip(self.samples, self.bad) if not bad]))
            self.generators = [None if bad else next(made) for bad in self.bad]
        self.count += 1
        if arity == 3:
            positive = args[2] > 0.0
            if type(positive) is bool:
                if not positive:
                    raise _Fallback
            else:
                self.bad |= ~positive
        d = np.array([0.0 if g is None else deviate(name, g) for g in self.generators])
        with np.errstate(all="ignore"):
            return self._checked(random_value(name, args, d))
