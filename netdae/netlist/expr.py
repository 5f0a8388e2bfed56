"""Safe SPICE expressions: a parser to an immutable tree, and scalar evaluation.

netdae never calls Python's ``eval``: expressions are parsed by a small
precedence-climbing parser into the node classes below, and evaluated by
walking the tree.

Two contexts, as in ngspice
---------------------------
``"param"``
    ``.param`` values, ``{...}`` and ``'...'`` element values, subcircuit
    and model parameters, ``.func`` bodies. ngspice evaluates these with its
    numparam code. Numbers are read by
    :func:`netdae.netlist.numbers.scan_param_number` (``1mil`` = 1e-3).
    No circuit quantities are allowed.
``"behavioural"``
    The expression of a B source (``V=...``/``I=...``) and of
    ``E``/``G ... value=...``. ngspice evaluates these with its B-source
    parse trees. Numbers are read by
    :func:`netdae.netlist.numbers.parse_number` (``1mil`` = 25.4e-6). They
    may use ``V(node)``, ``V(n1,n2)``, ``I(vname)`` and ``time``. A
    ``{...}`` inside is a parameter expression (param context).

The two ngspice evaluators disagree on two functions; the parser maps each
spelling to the node that means what ngspice computes in that context:

=============  ==========================  ==========================
written        param context               behavioural context
=============  ==========================  ==========================
``a**b, a^b``  ``Binary('**')``: |a|^b     ``Binary('**')``: |a|^b
``pow(a,b)``   ``Call('pow')``: a^b        ``Binary('**')``: |a|^b
``pwr(a,b)``   ``Binary('**')``: |a|^b     ``Call('pwr')``: sgn(a)|a|^b
=============  ==========================  ==========================

Grammar (lowest precedence first; ``**`` is left-associative and binds
tighter than unary minus, as in ngspice: ``-2**2 = -4``, ``2**3**2 = 64``)::

    expr    := or ['?' expr ':' expr]
    or      := and {'||' and}
    and     := cmp {'&&' cmp}
    cmp     := add {('=='|'!='|'<>'|'<'|'<='|'>'|'>=') add}
    add     := mul {('+'|'-') mul}
    mul     := unary {('*'|'/'|'%') unary}
    unary   := ('-'|'+'|'!') unary | power
    power   := primary {('**'|'^') ('-'|'+'|'!')* primary}
    primary := number | name | name '(' [expr {',' expr}] ')' | '(' expr ')'
             | '{' expr '}' | V(node[,node]) | I(element)

Node types (the tree an evaluator walks)
----------------------------------------
All nodes are frozen dataclasses (hashable, comparable).

:class:`Const` ``(value: float)``
    A number.
:class:`Param` ``(name: str)``
    A parameter reference. Elaboration replaces every one by a
    :class:`Const`; none is left in an elaborated circuit.
:class:`Time` ``()``
    The simulation time ``time`` [s] (behavioural context only).
:class:`Voltage` ``(pos: str, neg: str | None)``
    ``V(pos)`` or ``V(pos, neg)``; after elaboration full node names,
    ground written as ``V(0)`` is folded to ``Const(0)``, ``V(a, 0)`` is
    ``Voltage(a, None)``.
:class:`Current` ``(element: str)``
    ``I(vname)``: the branch current of an element with a current unknown
    (V, L, E, H, behavioural voltage source); full element name after
    elaboration.
:class:`Unary` ``(op: str, operand)``
    ``op`` is ``"-"`` (negation) or ``"!"`` (1.0 if operand == 0 else 0.0).
:class:`Binary` ``(op: str, left, right)``
    ``+ - * /``; ``**`` = ``abs(left) ** right``; ``%`` = C ``fmod``;
    comparisons ``== != < <= > >=`` and ``&& ||`` give 1.0 or 0.0 (operands
    are true when non-zero).
:class:`Ternary` ``(cond, then, other)``
    ``then if cond != 0 else other``. ``if(c, a, b)`` and
    ``ternary_fcn(c, a, b)`` are written as this node.
:class:`Call` ``(func: str, args: tuple)``
    A built-in function, see :data:`FUNCTIONS` for the exact meaning of
    each; a Monte Carlo function (:mod:`netdae.netlist.montecarlo`), drawn
    through the evaluator's ``call``; before elaboration also a call of a
    user ``.func`` (elaboration inlines those). ``log`` is written as ``ln`` (both natural),
    ``arctan`` as ``atan``, ``sqr(x)`` as ``x ** 2``. ``pwl(x, x0, y0, ...)`` (a B source's
    piecewise-linear function, :func:`pwl_point`) and ``table(x, x0, y0, ...)`` (an E/G
    ``TABLE`` card, :func:`table_point`; built by the card parser, never parsed from text)
    take their points as constants after elaboration.

Examples
--------
>>> e = parse_expression("2*V(out, in) + sin(time) ** 2", context="behavioural")
>>> e.op, e.left
('+', Binary(op='*', left=Const(value=2.0), right=Voltage(pos='out', neg='in')))
>>> evaluate(parse_expression("a*2 + max(1, 3)"), {"a": 1.5}.__getitem__)
6.0
>>> evaluate(parse_expression("-2**2"), None), evaluate(parse_expression("2**3**2"), None)
(-4.0, 64.0)
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable, Union

import numpy as np

from ..errors import NetlistError, SourceLocation
from .lines import fold_case
from .montecarlo import RANDOM_FORMS, RANDOM_FUNCTIONS, is_random_call
from .numbers import parse_number, scan_param_number

__all__ = [
    "Expr",
    "Const",
    "Param",
    "Time",
    "Voltage",
    "Current",
    "Unary",
    "Binary",
    "Ternary",
    "Call",
    "FUNCTIONS",
    "POINT_FUNCTIONS",
    "TABLE_DOMAIN",
    "table_point",
    "pwl_point",
    "check_points",
    "PARAM",
    "BEHAVIOURAL",
    "parse_expression",
    "evaluate",
    "evaluate_arrays",
    "transform",
    "fold_constants",
    "walk",
    "jumps_with_state",
    "to_text",
    "depth",
    "time_corners",
    "RESERVED",
    "MAX_DEPTH",
]

PARAM = "param"
BEHAVIOURAL = "behavioural"

#: Deepest expression tree accepted (evaluators walk trees recursively, and
#: Python's recursion limit is about 1000 frames).
MAX_DEPTH = 300
#: Longer chains of ``+``/``-`` are summed as balanced trees (:meth:`_Parser.sum`).
BALANCED_SUM = 64


@dataclass(frozen=True, slots=True)
class Const:
    """A number."""

    value: float


@dataclass(frozen=True, slots=True)
class Param:
    """A parameter reference (replaced by a :class:`Const` during elaboration)."""

    name: str


@dataclass(frozen=True, slots=True)
class Time:
    """The simulation time ``time`` [s]."""

    pass


@dataclass(frozen=True, slots=True)
class Voltage:
    """``V(pos)`` or ``V(pos, neg)``: a node potential or a difference of two."""

    pos: str
    neg: str | None = None


@dataclass(frozen=True, slots=True)
class Current:
    """``I(element)``: the branch current of an element with a current unknown."""

    element: str


@dataclass(frozen=True, slots=True)
class Unary:
    """``-operand`` or ``!operand``."""

    op: str
    operand: "Expr"


@dataclass(frozen=True, slots=True)
class Binary:
    """``left op right``; see the module docstring for each operator's meaning."""

    op: str
    left: "Expr"
    right: "Expr"


@dataclass(frozen=True, slots=True)
class Ternary:
    """``cond ? then : other``."""

    cond: "Expr"
    then: "Expr"
    other: "Expr"


@dataclass(frozen=True, slots=True)
class Call:
    """A call of a built-in function (:data:`FUNCTIONS`) or, before elaboration, a ``.func``."""

    func: str
    args: tuple


Expr = Union[Const, Param, Time, Voltage, Current, Unary, Binary, Ternary, Call]


def _u(x: float) -> float:
    return 1.0 if x > 0 else (0.5 if x == 0 else 0.0)


def _sgn(x: float) -> float:
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


def _pwr(a: float, b: float) -> float:
    return -(abs(a) ** b) if a < 0 else a**b


def _limit(x: float, a: float, b: float) -> float:
    lo, hi = (b, a) if a > b else (a, b)
    return min(max(x, lo), hi)


def _cpow(a: float, b: float) -> float:
    if a < 0 and b != math.floor(b):
        raise ValueError("negative base with a non-integer exponent")
    return math.pow(a, b)


#: The smoothing domain of a ``TABLE`` corner, as a fraction of the shorter adjacent segment
#: (ngspice 39's ``input_domain=0.1 fraction=TRUE`` of the XSPICE ``pwl`` model it builds).
TABLE_DOMAIN = 0.1


def check_points(func: str, points) -> None:
    """Check the points of a ``table``/``pwl`` call: pairs, at least the minimum, x strictly increasing.

    Parameters
    ----------
    func : {"table", "pwl"}
    points : sequence of float
        ``x0, y0, x1, y1, ...``.

    Raises
    ------
    ValueError
        Naming the first offending point.
    """
    if len(points) % 2:
        raise ValueError(f"{func}: the points must be (x, y) pairs, got {len(points)} number(s)")
    need = 2 if func == "table" else 4
    if len(points) < need:
        raise ValueError(f"{func}: needs at least {need // 2} (x, y) pair{'s' if need > 2 else ''}")
    xs = points[0::2]
    for k in range(1, len(xs)):
        if not xs[k] > xs[k - 1]:
            raise ValueError(f"{func}: the x values must increase strictly: x{k} = {xs[k]:g} follows "
                             f"x{k - 1} = {xs[k - 1]:g}")


def table_point(x: float, points) -> tuple[float, float]:
    """Value and slope of ngspice 39's E/G ``TABLE`` at ``x``.

    ngspice 39 realises ``TABLE {expr} = (x0, y0) ... (xn, yn)`` with the XSPICE
    ``pwl`` code model (``input_domain=0.1 fraction=TRUE limit=TRUE``): the table
    extended by one point before and after (``x0 - (x1 - x0)``, ``xn + (xn - x(n-1))``)
    with the end values (``limit``: flat outside the table), linear between the
    points, and every corner (the end points included) replaced within
    ``d = 0.1 min(left segment, right segment)`` of its x by the parabola that joins
    the two slopes (``cm_smooth_corner``). The function is continuous with a
    continuous slope; at a corner ``xi`` its value is ``yi + (s_right - s_left) d / 4``.

    Parameters
    ----------
    x : float
    points : sequence of float
        ``x0, y0, x1, y1, ...``: at least two pairs, x strictly increasing
        (:func:`check_points`). A single pair is a constant, written as such by
        the parser.

    Returns
    -------
    value, slope : float
    """
    n = len(points) // 2
    # the extended table X[0..n+1], Y[0..n+1]
    def px(i):
        if i == 0:
            return 2.0 * points[0] - points[2]
        if i == n + 1:
            return 2.0 * points[2 * n - 2] - points[2 * n - 4]
        return points[2 * i - 2]

    def py(i):
        return points[2 * min(max(i, 1), n) - 1]

    if x <= 0.5 * (px(0) + px(1)):
        return py(0), 0.0
    if x >= 0.5 * (px(n) + px(n + 1)):
        return py(n + 1), 0.0
    i = 1
    while i < n and not x < 0.5 * (px(i) + px(i + 1)):
        i += 1
    xc, yc = px(i), py(i)
    lower, upper = xc - px(i - 1), px(i + 1) - xc
    s_lower, s_upper = (yc - py(i - 1)) / lower, (py(i + 1) - yc) / upper
    d = TABLE_DOMAIN * min(lower, upper)
    if x < xc - d:
        return yc + (x - xc) * s_lower, s_lower
    if x < xc + d:
        a = (s_upper - s_lower) / (4.0 * d)
        u = x - (xc + d)
        return yc + s_upper * d + s_upper * u + a * u * u, s_upper + 2.0 * a * u
    return yc + (x - xc) * s_upper, s_upper


def pwl_point(x: float, points) -> tuple[float, float]:
    """Value and slope of a B source's ``pwl(x, x0, y0, x1, y1, ...)`` at ``x`` (ngspice's ``PTpwl``).

    Linear between the points and continued linearly beyond the first and the
    last segment; a point's segment is the one to its right (the slope at ``xi``
    is that of ``[xi, x(i+1)]``), as ngspice's binary search finds it.

    Parameters
    ----------
    x : float
    points : sequence of float
        ``x0, y0, x1, y1, ...``: at least two pairs, x strictly increasing.

    Returns
    -------
    value, slope : float
    """
    k0, k1 = 0, len(points) // 2 - 1
    while k1 - k0 > 1:
        k = (k0 + k1) // 2
        if points[2 * k] > x:
            k1 = k
        else:
            k0 = k
    x0, y0, x1, y1 = points[2 * k0], points[2 * k0 + 1], points[2 * k1], points[2 * k1 + 1]
    slope = (y1 - y0) / (x1 - x0)
    return y0 + (x - x0) * slope, slope


def _points_function(func: str, point: Callable) -> Callable:
    def value(x: float, *points: float) -> float:
        check_points(func, points)
        return point(x, points)[0]
    return value


#: Functions of a variable number of arguments: ``f(x, x0, y0, x1, y1, ...)``, the points constants.
POINT_FUNCTIONS = ("table", "pwl")


#: Built-in functions after canonicalisation: name -> (arity, scalar function).
#: Meanings: ``ln`` natural log; ``log10``; ``int`` truncation toward 0;
#: ``nint`` round half to even; ``u`` unit step (0.5 at 0); ``uramp`` max(x, 0);
#: ``sgn``; ``pow`` C pow (a < 0 needs an integer b); ``pwr`` sgn(a)|a|^b;
#: ``limit(x, a, b)`` clamps x between a and b in either order; ``min``/``max``
#: of two arguments; the rest as in C's math library.
FUNCTIONS: dict[str, tuple[int, Callable]] = {
    "sqrt": (1, math.sqrt),
    "exp": (1, math.exp),
    "ln": (1, math.log),
    "log10": (1, math.log10),
    "sin": (1, math.sin),
    "cos": (1, math.cos),
    "tan": (1, math.tan),
    "asin": (1, math.asin),
    "acos": (1, math.acos),
    "atan": (1, math.atan),
    "sinh": (1, math.sinh),
    "cosh": (1, math.cosh),
    "tanh": (1, math.tanh),
    "asinh": (1, math.asinh),
    "acosh": (1, math.acosh),
    "atanh": (1, math.atanh),
    "abs": (1, abs),
    "sgn": (1, _sgn),
    "floor": (1, lambda x: float(math.floor(x))),
    "ceil": (1, lambda x: float(math.ceil(x))),
    "int": (1, lambda x: float(math.trunc(x))),
    "nint": (1, lambda x: float(round(x))),
    "u": (1, _u),
    "uramp": (1, lambda x: x if x > 0 else 0.0),
    "min": (2, min),
    "max": (2, max),
    "pow": (2, _cpow),
    "pwr": (2, _pwr),
    "limit": (3, _limit),
    # behavioural only, any even number of points after x (arity -1): table() is the E/G TABLE card's
    # form (not written by users: the parser refuses the call), pwl() the B-source function
    "table": (-1, _points_function("table", table_point)),
    "pwl": (-1, _points_function("pwl", pwl_point)),
}

# spelling -> canonical name (context independent)
_ALIASES = {"log": "ln", "arctan": "atan"}
# functions ngspice knows that netdae rejects, with the reason
_REJECTED = {
    "ddt": "a time derivative outside a behavioural source", "sdt": "a time integral inside an expression",
    "table": "a table lookup, PSpice's form; ngspice 39 reads it only in PSpice compatibility mode",
    "tablef": "a table lookup",
}
#: ngspice's comparisons with zero (1 when true, else 0), read as the comparison.
_ZERO_TESTS = {"eq0": "==", "ne0": "!=", "gt0": ">", "lt0": "<", "ge0": ">=", "le0": "<="}
#: Names that cannot be parameters (``pi`` is the constant 3.14159...).
RESERVED = frozenset({"time", "temper", "hertz", "pi"})

_OP = re.compile(r"\*\*|==|!=|<>|<=|>=|&&|\|\||[-+*/%^()<>!?:,{}]")
_NAME = re.compile(r"[a-z_][a-z0-9_.]*")
_SPICE_RUN = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[ed][+-]?\d+)?[a-z0-9_\u00b5]*", re.ASCII)
_WS = re.compile(r"\s*")
_DIGITS = "0123456789"
#: PSpice's single-character logical operators, with ngspice's spelling.
_PSPICE_LOGIC = {"&": ("and", "&&"), "|": ("or", "||"), "~": ("not", "!")}

_NUM, _ID, _OPER, _END = "num", "id", "op", "end"


class _Parser:
    """Precedence-climbing parser over one expression text."""

    def __init__(self, text: str, context: str, locate: Callable[[int], SourceLocation | None],
                 warn: Callable[[int, str], None] | None = None, params: frozenset[str] = frozenset()):
        self.text = text
        self.context = context
        #: Names that are parameters here even where they are reserved words (a measurement named pi).
        self.params = params
        self.locate = locate
        self.warn = warn
        self.pos = 0
        #: Inside {...} or '...' of a behavioural expression: ngspice reads circuit references there too.
        self.behavioural_group = False
        self.quoted = False
        self.kind = self.value = None
        self.start = 0
        self.advance()

    # -- lexer ---------------------------------------------------------
    def error(self, message: str, at: int | None = None, hint: str | None = None) -> NetlistError:
        return NetlistError(message, self.locate(self.start if at is None else at), hint=hint)

    def advance(self) -> None:
        text = self.text
        pos = _WS.match(text, self.pos).end()
        self.start = pos
        if pos >= len(text):
            self.kind, self.value, self.pos = _END, None, pos
            return
        c = text[pos]
        if c in _DIGITS or (c == "." and pos + 1 < len(text) and text[pos + 1] in _DIGITS):
            if self.context == PARAM:
                value, end = scan_param_number(text, pos)
            else:
                end = _SPICE_RUN.match(text, pos).end()
                value = parse_number(text[pos:end])
            self.kind, self.value, self.pos = _NUM, value, end
            return
        m = _NAME.match(text, pos)
        if m is not None:
            self.kind, self.value, self.pos = _ID, m.group(), m.end()
            return
        if c == "'":
            # 'expr' inside an expression is a group, as {expr} is (ngspice's numparam quotes)
            self.quoted = not self.quoted
            self.kind, self.value, self.pos = _OPER, "{" if self.quoted else "}", pos + 1
            return
        m = _OP.match(text, pos)
        if m is None:
            if c in _PSPICE_LOGIC:
                spelled, ours = _PSPICE_LOGIC[c]
                from .compat import MODE_HINT  # (compat builds expressions: imported when needed)

                raise self.error(f"'{c}' (PSpice's logical {spelled}) is not supported by netdae, nor by ngspice 39 "
                                 "outside its PSpice compatibility mode", hint=f"write '{ours}', or {MODE_HINT}")
            raise self.error(f"unexpected character {c!r} in expression")
        op = m.group()
        self.kind, self.value, self.pos = _OPER, ("!=" if op == "<>" else "**" if op == "^" else op), m.end()

    def expect(self, op: str) -> None:
        if self.kind != _OPER or self.value != op:
            found = "the end of the expression" if self.kind == _END else repr(self.text[self.start:self.pos])
            raise self.error(f"expected {op!r} in expression, found {found}")
        self.advance()

    def is_op(self, *ops: str) -> bool:
        return self.kind == _OPER and self.value in ops

    # -- grammar -------------------------------------------------------
    def parse(self) -> Expr:
        if self.kind == _END:
            raise self.error("empty expression")
        node = self.expr()
        if self.kind != _END:
            raise self.error(f"unexpected {self.text[self.start:self.pos]!r} in expression",
                             hint="check for a missing operator or parenthesis")
        return node

    def expr(self) -> Expr:
        cond = self.binary(0)
        if not self.is_op("?"):
            return cond
        self.advance()
        inner = self.start
        then = self.binary(0)
        if self.is_op("?"):
            if self.context == PARAM and not self.behavioural_group:
                raise self.error(
                    "a conditional c2 ? a : b written unparenthesised in the true branch of another "
                    "(c1 ? c2 ? a : b : e) is not read as written by ngspice 39's parameter evaluator "
                    "(it gives a whenever c1 holds)", inner,
                    hint="put the inner conditional in parentheses: c1 ? (c2 ? a : b) : e")
            self.advance()
            inner_then = self.expr()
            self.expect(":")
            then = Ternary(then, inner_then, self.expr())
        self.expect(":")
        other = self.expr()
        return Ternary(cond, then, other)

    _LEVELS = (("||",), ("&&",), ("==", "!=", "<", "<=", ">", ">="), ("+", "-"), ("*", "/", "%"))

    def binary(self, level: int) -> Expr:
        if level == len(self._LEVELS):
            return self.unary()
        ops = self._LEVELS[level]
        left = self.binary(level + 1)
        if ops == ("+", "-"):
            return self.sum(left, level)
        while self.is_op(*ops):
            op = self.value
            self.advance()
            left = Binary(op, left, self.binary(level + 1))
        return left

    def sum(self, first: Expr, level: int) -> Expr:
        """A chain of ``+`` and ``-``: left to right, as ngspice adds; beyond :data:`BALANCED_SUM` terms a
        balanced tree of the terms (``a - b`` as ``a + -b``, the same number), so a generated netlist's
        sum of hundreds of terms is not a tree hundreds of levels deep (its order of additions, and so
        its last bits, differ from ngspice's there)."""
        terms: list[tuple[str, Expr]] = [("+", first)]
        while self.is_op("+", "-"):
            op = self.value
            self.advance()
            terms.append((op, self.binary(level + 1)))
        if len(terms) <= BALANCED_SUM:
            left = first
            for op, term in terms[1:]:
                left = Binary(op, left, term)
            return left
        return _balanced([term if op == "+" else _negate(term) for op, term in terms])

    def unary(self) -> Expr:
        if self.is_op("-", "+", "!"):
            op = self.value
            self.advance()
            operand = self.unary()
            return _negate(operand) if op == "-" else operand if op == "+" else Unary("!", operand)
        return self.power()

    def power(self) -> Expr:
        left = self.primary()
        while self.is_op("**"):
            self.advance()
            signs = []
            while self.is_op("-", "+", "!"):
                signs.append(self.value)
                self.advance()
            right = self.primary()
            for op in reversed(signs):
                right = _negate(right) if op == "-" else right if op == "+" else Unary("!", right)
            left = Binary("**", left, right)
        return left

    def primary(self) -> Expr:
        kind, value, start = self.kind, self.value, self.start
        if kind == _NUM:
            self.advance()
            return Const(value)
        if kind == _OPER and value == "(":
            self.advance()
            node = self.expr()
            self.expect(")")
            return node
        if kind == _OPER and value == "{":
            saved, saved_group = self.context, self.behavioural_group
            self.behavioural_group = saved_group or saved == BEHAVIOURAL
            self.context = PARAM
            self.advance()
            node = self.expr()
            self.context, self.behavioural_group = saved, saved_group
            self.expect("}")
            return node
        if kind == _ID:
            self.advance()
            if self.is_op("("):
                if value in ("v", "i"):
                    return self.branch_reference(value, start)
                return self.call(value, start)
            return self.name(value, start)
        if kind == _END:
            raise self.error("expression ends where a value is expected",
                             hint="an operator is missing its right operand")
        raise self.error(f"unexpected {value!r} where a value is expected")

    def name(self, name: str, start: int) -> Expr:
        if name in self.params:
            return Param(name)
        if name == "time":
            if self.context != BEHAVIOURAL and not self.behavioural_group:
                raise self.error("'time' is only available in behavioural sources (B, E/G value=)", start)
            return Time()
        if name == "hertz":
            raise self.error("'hertz' is not supported by netdae", start)
        if name == "temper":  # the circuit temperature, given its value when the circuit is elaborated
            return Param(name)
        if name == "pi":
            return Const(math.pi)
        if name == "e" and (self.context == BEHAVIOURAL or self.behavioural_group):
            # ngspice's B-source parser knows the constants e and pi (inpptree.c), before any .param e
            return Const(math.e)
        return Param(name)

    def branch_reference(self, which: str, start: int) -> Expr:
        if self.context != BEHAVIOURAL and not self.behavioural_group:
            raise self.error(f"circuit reference {which.upper()}(...) is only allowed in behavioural "
                             "sources (B, E/G value=)", start,
                             hint="element values and parameters are numbers fixed before simulation")
        close = self.text.find(")", self.pos)
        if close < 0:
            raise self.error(f"{which.upper()}(...): missing ')'", start)
        names = [s.strip() for s in self.text[self.pos : close].split(",")]
        if any(not s or " " in s or "(" in s for s in names) or len(names) > (2 if which == "v" else 1):
            form = "V(node) or V(node1, node2)" if which == "v" else "I(vname)"
            raise self.error(f"malformed {which.upper()}(...) reference", start, hint=f"write {form}")
        self.pos = close + 1
        self.advance()
        if which == "i":
            return Current(names[0])
        return Voltage(names[0], names[1] if len(names) == 2 else None)

    def call(self, name: str, start: int) -> Expr:
        self.advance()  # '('
        args: list[Expr] = []
        if not self.is_op(")"):
            args.append(self.expr())
            while self.is_op(","):
                self.advance()
                args.append(self.expr())
        self.expect(")")
        name = _ALIASES.get(name, name)
        if name == "ddt" and (self.context == BEHAVIOURAL or self.behavioural_group):
            # realised by the element reader as a node holding the derivative (elements.realise_ddt)
            self.arity(name, args, 1, start)
            return Call(name, tuple(args))
        if name in _REJECTED:
            raise self.error(f"function {name}() ({_REJECTED[name]}) is not supported by netdae", start)
        if name in ("if", "ternary_fcn"):
            self.arity(name, args, 3, start)
            return Ternary(*args)
        if name == "sqr":
            self.arity(name, args, 1, start)
            return Binary("**", args[0], Const(2.0))
        if name in _ZERO_TESTS:
            self.arity(name, args, 1, start)
            return Binary(_ZERO_TESTS[name], args[0], Const(0.0))
        if name == "u2":  # ngspice's ramp clipped at 1: 0 below 0, x up to 1, then 1
            self.arity(name, args, 1, start)
            return Call("min", (Call("max", (args[0], Const(0.0))), Const(1.0)))
        if name in RANDOM_FUNCTIONS and not (name == "limit" and len(args) == 3):
            self.arity(name, args, RANDOM_FUNCTIONS[name], start)
            return Call(name, tuple(args))
        if name == "pwl":
            if self.context != BEHAVIOURAL:
                raise self.error("pwl() is only available in behavioural sources (B, E/G value=)", start)
            if len(args) < 5 or len(args) % 2 == 0:
                raise self.error(f"pwl() takes the input and at least two (x, y) pairs, got {len(args)} "
                                 "argument(s)", start, hint="write pwl(expr, x0, y0, x1, y1, ...)")
            return Call(name, tuple(args))
        if name == "limit" and len(args) == 3 and self.warn is not None:
            self.warn(start, "limit(x, lo, hi) is the clamp in netdae, but not in ngspice 39: its parameter "
                             "expressions read ngspice's Monte Carlo limit(nom, avar) (x + lo or x - lo at random, "
                             "hi ignored) and its behavioural sources give 0; write min(max(x, lo), hi) for a clamp "
                             "both simulators compute")
        if name in ("min", "max") and len(args) == 1 and self.context == PARAM and self.warn is not None:
            # ngspice's parameter evaluator reads a missing second operand of min/max as 1
            self.warn(start, f"{name}() with one argument: read as {name}(x, 1), as ngspice 39 reads it "
                             f"in parameter expressions")
            args.append(Const(1.0))
        if name == "pow" and self.context == BEHAVIOURAL or name == "pwr" and self.context == PARAM:
            self.arity(name, args, 2, start)
            return Binary("**", args[0], args[1])
        if name in FUNCTIONS:
            self.arity(name, args, FUNCTIONS[name][0], start)
        return Call(name, tuple(args))

    def arity(self, name: str, args: list, n: int, start: int) -> None:
        if len(args) != n:
            form = RANDOM_FORMS.get(name)
            raise self.error(f"{name}() takes {n} argument{'s' if n != 1 else ''}, got {len(args)}", start,
                             hint=f"write {form}, as ngspice's manual gives it" if form else None)


def _balanced(terms: list[Expr]) -> Expr:
    """The sum of ``terms`` as a tree of depth ``log2(len(terms))``."""
    if len(terms) == 1:
        return terms[0]
    mid = len(terms) // 2
    return Binary("+", _balanced(terms[:mid]), _balanced(terms[mid:]))


def _negate(node: Expr) -> Expr:
    if isinstance(node, Const):
        return Const(-node.value)
    return Unary("-", node)


def parse_expression(
    text: str,
    *,
    context: str = PARAM,
    locate: Callable[[int], SourceLocation | None] | None = None,
    warn: Callable[[int, str], None] | None = None,
    params: frozenset[str] = frozenset(),
) -> Expr:
    """Parse an expression into a tree.

    Parameters
    ----------
    text : str
        Expression text without surrounding braces or quotes (case-insensitive).
    context : {"param", "behavioural"}
        Which ngspice evaluator's rules apply (see the module docstring).
    locate : callable, optional
        Maps an offset in ``text`` to a :class:`SourceLocation` for errors.
    warn : callable, optional
        ``warn(offset, message)`` receives ngspice's lenient readings that
        are accepted with a warning (``max(x)`` in a parameter expression is
        ``max(x, 1)``); without it they are errors.
    params : frozenset of str, optional
        Names read as parameters even where they are reserved words
        (``time``, ``pi`` ...): a ``.meas`` ``PARAM`` expression reads a
        measurement of that name, as ngspice does.

    Returns
    -------
    Expr

    Raises
    ------
    NetlistError
        On a syntax error, a wrong number of arguments of a built-in
        function, an unsupported function, or a circuit reference outside a
        behavioural source; located at the offending character.

    Notes
    -----
    Linear in the length of the text.
    """
    locate = locate or (lambda offset: None)
    try:
        tree = _Parser(fold_case(text), context, locate, warn, params).parse()
    except RecursionError:
        tree = None
    if tree is None or depth(tree) > MAX_DEPTH:
        raise NetlistError(f"expression nested deeper than {MAX_DEPTH} levels", locate(0),
                           hint="split it into parameters or .func definitions")
    return tree


def depth(node: Expr) -> int:
    """Depth of a tree (a leaf has depth 1), computed without recursion."""
    best = 0
    stack = [(node, 1)]
    while stack:
        n, d = stack.pop()
        best = max(best, d)
        t = type(n)
        if t is Binary:
            stack.extend(((n.left, d + 1), (n.right, d + 1)))
        elif t is Unary:
            stack.append((n.operand, d + 1))
        elif t is Ternary:
            stack.extend(((n.cond, d + 1), (n.then, d + 1), (n.other, d + 1)))
        elif t is Call:
            stack.extend((a, d + 1) for a in n.args)
    return best



# ---------------------------------------------------------------- corners in time
#: Comparisons: their value jumps where the two sides cross.
_COMPARISONS = frozenset({"==", "!=", "<", "<=", ">", ">="})
#: Functions of one argument that jump (u, sgn) or kink (abs, uramp) where it is zero.
_ZERO_CORNERS = frozenset({"u", "sgn", "abs", "uramp"})
#: Functions that jump where their argument is an integer (nint: a half-integer).
_STAIRS = {"floor": 0.0, "ceil": 0.0, "int": 0.0, "nint": 0.5}


def jumps_with_state(node: Expr) -> bool:
    """True when the expression's value can jump as the circuit's voltages or currents move.

    A comparison, a ternary's condition, or a jumping function (``u``, ``sgn``, ``floor``, ``ceil``,
    ``int``, ``nint``) whose operands read ``V(...)`` or ``I(...)``. Such a jump is not at a time
    known in advance (:func:`time_corners` finds those of ``time``): the transient meets it as an
    algebraic unknown that jumps between two steps.

    Examples
    --------
    >>> b = lambda text: parse_expression(text, context=BEHAVIOURAL)
    >>> jumps_with_state(b("v(a) > 0.5 ? 1 : 0")), jumps_with_state(b("time > 1u ? 1 : 0"))
    (True, False)
    """
    def reads_state(n) -> bool:
        return any(isinstance(m, (Voltage, Current)) for m in walk(n))

    for n in walk(node):
        if isinstance(n, Binary) and n.op in _COMPARISONS and reads_state(n):
            return True
        if isinstance(n, Ternary) and reads_state(n.cond):
            return True
        if isinstance(n, Call) and (n.func in ("u", "sgn") or n.func in _STAIRS) and any(map(reads_state, n.args)):
            return True
    return False


def _affine(node) -> tuple[float, float] | None:
    """``(a, b)`` when ``node`` is ``a*time + b`` with constant a, b (else None)."""
    t = type(node)
    if t is Const:
        return 0.0, node.value
    if t is Time:
        return 1.0, 0.0
    if t is Unary and node.op == "-":
        inner = _affine(node.operand)
        return None if inner is None else (-inner[0], -inner[1])
    if t is Binary and node.op in ("+", "-", "*", "/"):
        left, right = _affine(node.left), _affine(node.right)
        if left is None or right is None:
            return None
        if node.op == "+":
            return left[0] + right[0], left[1] + right[1]
        if node.op == "-":
            return left[0] - right[0], left[1] - right[1]
        if node.op == "*":
            if left[0] == 0.0:
                return left[1] * right[0], left[1] * right[1]
            if right[0] == 0.0:
                return right[1] * left[0], right[1] * left[1]
            return None
        if right[0] == 0.0 and right[1] != 0.0:
            return left[0] / right[1], left[1] / right[1]
    return None


def time_corners(node: Expr, t0: float, t1: float, limit: int = 10_000) -> list[float]:
    """Instants in [t0, t1] where a behavioural expression jumps or kinks in ``time``.

    Found structurally, where the quantities that meet are affine in ``time``
    with constant coefficients: the crossings of a comparison (``time < 1m``,
    ``time*2 >= tdel``), the zeros of the arguments of ``u``, ``sgn``,
    ``abs`` and ``uramp``, the crossings of ``min``/``max``/``limit``
    arguments, the points of ``pwl(time, ...)``, and the steps of ``floor``,
    ``ceil``, ``int``, ``nint`` and ``%`` (at most ``limit`` of them). A
    corner of a quantity that depends on the circuit (``v(a) > 1``) is not a
    time corner: the step control meets it.

    Parameters
    ----------
    node : Expr
        An elaborated tree (parameters replaced by constants).
    t0, t1 : float
        The interval.
    limit : int
        Largest number of corners one periodic function contributes.

    Returns
    -------
    list of float
        Unsorted, possibly repeated.

    Notes
    -----
    One pass over the tree; the affine test is repeated on subtrees
    (quadratic in the depth of nested sums, which are shallow).
    """
    out: list[float] = []

    def crossing(a, b) -> None:  # where a(t) == b(t)
        if a is not None and b is not None and a[0] != b[0]:
            out.append((b[1] - a[1]) / (a[0] - b[0]))

    def stairs(a, period: float, offset: float) -> None:  # where a(t) = offset + k period
        if a is None or a[0] == 0.0 or not period > 0.0:
            return
        lo, hi = sorted((a[0] * t0 + a[1], a[0] * t1 + a[1]))
        first, last = math.ceil((lo - offset) / period), math.floor((hi - offset) / period)
        if 0 <= last - first < limit:
            out.extend(((offset + k * period) - a[1]) / a[0] for k in range(first, last + 1))

    for n in walk(node):
        t = type(n)
        if t is Binary:
            if n.op in _COMPARISONS:
                crossing(_affine(n.left), _affine(n.right))
            elif n.op == "%" and type(n.right) is Const:
                stairs(_affine(n.left), abs(n.right.value), 0.0)
        elif t is Ternary:
            crossing(_affine(n.cond), (0.0, 0.0))
        elif t is Call:
            args = n.args
            if n.func in _ZERO_CORNERS and len(args) == 1:
                crossing(_affine(args[0]), (0.0, 0.0))
            elif n.func in _STAIRS and len(args) == 1:
                stairs(_affine(args[0]), 1.0, _STAIRS[n.func])
            elif n.func in ("min", "max") and len(args) == 2:
                crossing(_affine(args[0]), _affine(args[1]))
            elif n.func == "limit" and len(args) == 3:
                x = _affine(args[0])
                crossing(x, _affine(args[1]))
                crossing(x, _affine(args[2]))
            elif n.func == "pwl" and len(args) >= 3:
                x = _affine(args[0])
                for point in args[1::2]:
                    if type(point) is Const:
                        crossing(x, (0.0, point.value))
    return [c for c in out if t0 <= c <= t1 and math.isfinite(c)]

def walk(node: Expr):
    """Yield every node of a tree (pre-order)."""
    stack = [node]
    while stack:
        n = stack.pop()
        yield n
        if isinstance(n, Binary):
            stack.extend((n.right, n.left))
        elif isinstance(n, Unary):
            stack.append(n.operand)
        elif isinstance(n, Ternary):
            stack.extend((n.other, n.then, n.cond))
        elif isinstance(n, Call):
            stack.extend(reversed(n.args))


def transform(node: Expr, leaf: Callable[[Expr], Expr | None]) -> Expr:
    """Rebuild a tree bottom-up, replacing nodes for which ``leaf`` returns a node.

    ``leaf(n)`` is called for every node before its children; when it returns
    a node, that node replaces ``n`` (and is not visited further).
    """
    new = leaf(node)
    if new is not None:
        return new
    if isinstance(node, Binary):
        return Binary(node.op, transform(node.left, leaf), transform(node.right, leaf))
    if isinstance(node, Unary):
        return Unary(node.op, transform(node.operand, leaf))
    if isinstance(node, Ternary):
        return Ternary(transform(node.cond, leaf), transform(node.then, leaf), transform(node.other, leaf))
    if isinstance(node, Call):
        return Call(node.func, tuple(transform(a, leaf) for a in node.args))
    return node


def _binary(op: str, a: float, b: float) -> float:
    if op == "+":
        return a + b
    if op == "-":
        return a - b
    if op == "*":
        return a * b
    if op == "/":
        return a / b
    if op == "**":
        return abs(a) ** b
    if op == "%":
        if b == 0:  # math.fmod's own word for it is "math domain error"
            raise ValueError(f"{a:g} % 0 (the remainder of a division by zero) is undefined")
        return math.fmod(a, b)
    if op == "&&":
        return 1.0 if (a != 0 and b != 0) else 0.0
    if op == "||":
        return 1.0 if (a != 0 or b != 0) else 0.0
    if op == "==":
        return 1.0 if a == b else 0.0
    if op == "!=":
        return 1.0 if a != b else 0.0
    if op == "<":
        return 1.0 if a < b else 0.0
    if op == "<=":
        return 1.0 if a <= b else 0.0
    if op == ">":
        return 1.0 if a > b else 0.0
    return 1.0 if a >= b else 0.0


def evaluate(
    node: Expr,
    lookup: Callable[[str], float] | None,
    call: Callable[[str, list[float]], float] | None = None,
) -> float:
    """Evaluate a tree without circuit references to a float.

    Parameters
    ----------
    node : Expr
    lookup : callable
        ``lookup(name) -> float`` for :class:`Param` nodes (may raise).
    call : callable, optional
        ``call(name, args) -> float`` for calls of user functions.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        ``"division by zero"``, a math domain error, an overflow, a
        non-finite result, or a circuit reference (callers turn it into a
        :class:`NetlistError` at the card).
    """
    try:
        value = _eval(node, lookup, call)
    except ZeroDivisionError:
        raise ValueError("division by zero") from None
    except OverflowError:
        raise ValueError("overflow") from None
    except RecursionError:
        raise ValueError(f"expression nested deeper than {MAX_DEPTH} levels") from None
    if not math.isfinite(value):
        raise ValueError(f"the result is {value}")
    return value


def _eval(node, lookup, call) -> float:
    t = type(node)
    if t is Const:
        return node.value
    if t is Param:
        return float(lookup(node.name))
    if t is Binary:
        return float(_binary(node.op, _eval(node.left, lookup, call), _eval(node.right, lookup, call)))
    if t is Unary:
        v = _eval(node.operand, lookup, call)
        return -v if node.op == "-" else (1.0 if v == 0 else 0.0)
    if t is Ternary:
        c = _eval(node.cond, lookup, call)
        return _eval(node.then if c != 0 else node.other, lookup, call)
    if t is Call:
        args = [_eval(a, lookup, call) for a in node.args]
        spec = FUNCTIONS.get(node.func)
        if spec is None or is_random_call(node.func, len(args)):
            if call is None:
                raise ValueError(f"unknown function {node.func}()")
            return float(call(node.func, args))
        try:
            return float(spec[1](*args))
        except ValueError:
            raise ValueError(f"{node.func}({', '.join(f'{a:g}' for a in args)}) is undefined") from None
    if t is Time:
        raise ValueError("'time' has no value here")
    raise ValueError(f"circuit reference {to_text(node)} has no value here")


def _binary_arrays(op: str, a, b):
    """:func:`_binary` on arrays (elementwise, the same meanings; division by zero gives inf or nan)."""
    if op == "+":
        return a + b
    if op == "-":
        return a - b
    if op == "*":
        return a * b
    if op == "/":
        return a / b
    if op == "**":
        return np.abs(a) ** b
    if op == "%":
        return np.fmod(a, b)
    if op == "&&":
        return ((a != 0) & (b != 0)).astype(float)
    if op == "||":
        return ((a != 0) | (b != 0)).astype(float)
    test = {"==": np.equal, "!=": np.not_equal, "<": np.less, "<=": np.less_equal, ">": np.greater}
    return test.get(op, np.greater_equal)(a, b).astype(float)


def _call_pointwise(func: Callable, args: list) -> np.ndarray:
    """A scalar built-in at every point of its (broadcast) arguments; nan where it is undefined."""
    arrays = np.broadcast_arrays(*[np.asarray(a, dtype=float) for a in args])
    out = np.empty(arrays[0].shape)
    flat = [a.ravel() for a in arrays]
    view = out.reshape(-1)
    for k in range(view.size):
        try:
            view[k] = func(*[float(a[k]) for a in flat])
        except (ValueError, ZeroDivisionError, OverflowError):
            view[k] = math.nan
    return out


def evaluate_arrays(node: Expr, lookup: Callable[[Expr], np.ndarray | float]) -> np.ndarray:
    """Evaluate a tree point by point on arrays: what :func:`evaluate` gives at each point.

    Parameters
    ----------
    node : Expr
    lookup : callable
        ``lookup(leaf) -> array or float`` for the :class:`Voltage`, :class:`Current`,
        :class:`Time` and :class:`Param` leaves (may raise).

    Returns
    -------
    ndarray of float
        The broadcast shape of the leaves' arrays. Where :func:`evaluate` would raise
        (a division by zero, a function outside its domain, an overflow) the value is
        not finite: the caller decides what that means.

    Notes
    -----
    Operators are numpy calls on the whole arrays; built-in functions run their scalar
    definitions (:data:`FUNCTIONS`, the one owner of their meaning) at each point, about
    a microsecond a point. Both branches of ``c ? a : b`` are evaluated everywhere.

    Examples
    --------
    >>> tree = parse_expression("v(a) > 1 ? sqrt(v(a)) : -v(a)*2", context=BEHAVIOURAL)
    >>> evaluate_arrays(tree, lambda leaf: np.array([0.5, 4.0])).tolist()
    [-1.0, 2.0]
    """
    with np.errstate(all="ignore"):
        return np.asarray(_eval_arrays(node, lookup), dtype=float)


def _eval_arrays(node, lookup):
    t = type(node)
    if t is Const:
        return node.value
    if t in (Param, Voltage, Current, Time):
        return np.asarray(lookup(node), dtype=float)
    if t is Binary:
        return _binary_arrays(node.op, np.asarray(_eval_arrays(node.left, lookup), dtype=float),
                              np.asarray(_eval_arrays(node.right, lookup), dtype=float))
    if t is Unary:
        v = np.asarray(_eval_arrays(node.operand, lookup), dtype=float)
        return -v if node.op == "-" else (v == 0).astype(float)
    if t is Ternary:
        c = np.asarray(_eval_arrays(node.cond, lookup), dtype=float)
        return np.where(c != 0, _eval_arrays(node.then, lookup), _eval_arrays(node.other, lookup))
    if t is Call:
        spec = FUNCTIONS.get(node.func)
        if spec is None:
            raise ValueError(f"unknown function {node.func}()")
        return _call_pointwise(spec[1], [_eval_arrays(a, lookup) for a in node.args])
    raise ValueError(f"{to_text(node)} has no value here")


def _is_const(node) -> bool:
    return type(node) is Const


def fold_constants(node: Expr) -> Expr:
    """Replace every subtree without variables by its value.

    Subtrees whose evaluation fails (e.g. ``1/0``) are left as they are.
    """
    if isinstance(node, Binary):
        left, right = fold_constants(node.left), fold_constants(node.right)
        out = Binary(node.op, left, right)
        if _is_const(left) and _is_const(right):
            return _try_const(out)
        return out
    if isinstance(node, Unary):
        operand = fold_constants(node.operand)
        out = Unary(node.op, operand)
        return _try_const(out) if _is_const(operand) else out
    if isinstance(node, Ternary):
        cond = fold_constants(node.cond)
        then, other = fold_constants(node.then), fold_constants(node.other)
        if _is_const(cond):
            return then if cond.value != 0 else other
        return Ternary(cond, then, other)
    if isinstance(node, Call):
        args = tuple(fold_constants(a) for a in node.args)
        out = Call(node.func, args)
        if node.func in FUNCTIONS and not is_random_call(node.func, len(args)) and all(_is_const(a) for a in args):
            return _try_const(out)
        return out
    return node


def _try_const(node: Expr) -> Expr:
    try:
        return Const(evaluate(node, None))
    except ValueError:
        return node


def to_text(node: Expr) -> str:
    """The tree as expression text that parses back to the same tree.

    Every compound operand is parenthesised. ``pwr`` and ``pow`` are written
    as calls: read a text containing ``pwr`` back in the behavioural context
    and one containing ``pow`` in the param context.
    """
    return _text(node, True)


def _text(node, top: bool) -> str:
    t = type(node)
    if t is Const:
        s = repr(node.value)
        return f"({s})" if node.value < 0 and not top else s
    if t is Param:
        return node.name
    if t is Time:
        return "time"
    if t is Voltage:
        return f"v({node.pos})" if node.neg is None else f"v({node.pos},{node.neg})"
    if t is Current:
        return f"i({node.element})"
    if t is Unary:
        s = f"{node.op}{_text(node.operand, False)}"
    elif t is Binary:
        s = f"{_text(node.left, False)} {node.op} {_text(node.right, False)}"
    elif t is Ternary:
        s = f"{_text(node.cond, False)} ? {_text(node.then, False)} : {_text(node.other, False)}"
    else:
        return f"{node.func}({', '.join(_text(a, True) for a in node.args)})"
    return s if top else f"({s})"
