"""Behavioural expressions as tapes: straight-line programs the compiled kernel runs.

A behavioural source's expression (the tree of :mod:`netdae.netlist.expr`)
is translated once, when the transient is prepared, into a *tape*: a list of
instructions ``(op, a, b, c)`` in evaluation order, instruction ``r``
writing register ``r`` from the registers ``a``, ``b``, ``c`` before it (or,
for :data:`OP_CONST`, constant ``a``; for :data:`OP_LEAF`, the instance's
leaf ``a``). The compiled kernel
(:func:`netdae.devices.kernels.behavioural.eval_behavioural`) runs the tapes
of all instances with forward-mode differentiation: every register carries a
value and its derivatives to the instance's leaves, the rules being those of
:mod:`netdae.devices.autodiff` (which stays the reference; the tests hold
the two equal).

Nothing is generated as source text and nothing is compiled per netlist: the
tape is data, so a new expression costs no JIT compilation, and the netlist's
text is never evaluated.

*Locked* instructions: a comparison (``<``, ``<=``, ``>``, ``>=``) or a
function that jumps (``u``, ``sgn``, ``floor``, ``ceil``, ``int``, ``nint``)
whose operands read the circuit's voltages or currents has ``c = 1``
(:data:`LOCKED`). Its outcome is a discrete value that the transient holds
through each step and changes only at events located between steps
(:func:`netdae.devices.kernels.behavioural.lock_step`), as a switch's state;
``==`` and ``!=`` are not locked (they hold only at isolated points).

Examples
--------
>>> from netdae.netlist.expr import parse_expression
>>> ops, args, consts, leaves = compile_tape(parse_expression("2*v(a)+1", context="behavioural"))
>>> [OP_NAMES[o] for o in ops]
['const', 'leaf', 'mul', 'const', 'add']
>>> consts
[2.0, 1.0]
"""

from __future__ import annotations

from ...netlist.expr import Binary, Call, Const, Current, Expr, Param, Ternary, Time, Unary, Voltage

__all__ = ["compile_tape", "OP_NAMES", "OP_CONST", "OP_TIME", "OP_LEAF", "OP_TABLE", "OP_PWL", "LOCKED",
           "count_locked"]

OP_CONST, OP_TIME, OP_LEAF, OP_NEG, OP_NOT = 0, 1, 2, 3, 4
OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW, OP_MOD, OP_AND, OP_OR = 10, 11, 12, 13, 14, 15, 16, 17
OP_EQ, OP_NE, OP_LT, OP_LE, OP_GT, OP_GE = 18, 19, 20, 21, 22, 23
OP_SELECT = 30
#: One-argument functions, in the order of their opcodes from OP_FUNC1.
FUNCTIONS_1 = ("sqrt", "exp", "ln", "log10", "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh",
               "tanh", "asinh", "acosh", "atanh", "abs", "uramp", "sgn", "floor", "ceil", "int", "nint", "u")
OP_FUNC1 = 40
OP_MIN, OP_MAX, OP_CPOW, OP_PWR, OP_LIMIT = 70, 71, 72, 73, 74
#: ``table(x, points)``/``pwl(x, points)``: ``(op, x register, first constant, number of pairs)``.
OP_TABLE, OP_PWL = 75, 76
#: The third operand of a locked instruction (see the module docstring).
LOCKED = 1
#: Comparisons whose outcome is locked when they read the circuit's state.
_LOCKED_BINARY = frozenset({"<", "<=", ">", ">="})
#: Functions of one argument whose value jumps (locked when their argument reads the state).
_LOCKED_CALLS = frozenset({"u", "sgn", "floor", "ceil", "int", "nint"})
_POINTS = {"table": OP_TABLE, "pwl": OP_PWL}

_BINARY = {"+": OP_ADD, "-": OP_SUB, "*": OP_MUL, "/": OP_DIV, "**": OP_POW, "%": OP_MOD, "&&": OP_AND,
           "||": OP_OR, "==": OP_EQ, "!=": OP_NE, "<": OP_LT, "<=": OP_LE, ">": OP_GT, ">=": OP_GE}
_CALLS = {"min": OP_MIN, "max": OP_MAX, "pow": OP_CPOW, "pwr": OP_PWR, "limit": OP_LIMIT}
_CALLS.update({name: OP_FUNC1 + i for i, name in enumerate(FUNCTIONS_1)})

#: Opcode -> name (for reading tapes).
OP_NAMES = {OP_CONST: "const", OP_TIME: "time", OP_LEAF: "leaf", OP_NEG: "neg", OP_NOT: "not",
            OP_SELECT: "select"}
OP_NAMES.update({code: name for name, code in _CALLS.items()})
OP_NAMES.update({code: name for name, code in _POINTS.items()})
OP_NAMES.update({OP_ADD: "add", OP_SUB: "sub", OP_MUL: "mul", OP_DIV: "div", OP_POW: "pow_abs", OP_MOD: "mod",
                 OP_AND: "and", OP_OR: "or", OP_EQ: "eq", OP_NE: "ne", OP_LT: "lt", OP_LE: "le", OP_GT: "gt",
                 OP_GE: "ge"})


def compile_tape(tree: Expr) -> tuple[list[int], list[tuple[int, int, int]], list[float], list]:
    """Translate an expression tree into a tape.

    Parameters
    ----------
    tree : Expr
        An elaborated expression (parameters resolved).

    Returns
    -------
    ops : list of int
        Opcode of each instruction; the last one writes the result.
    args : list of (int, int, int)
        Operands: register numbers (constant or leaf numbers for
        :data:`OP_CONST`, :data:`OP_LEAF`); unused ones are 0.
    consts : list of float
    leaves : list of Voltage or Current
        The circuit quantities, in the order of their leaf numbers (a
        quantity used twice is one leaf).

    Raises
    ------
    ValueError
        For an unresolved parameter or a function the kernel does not know.

    Notes
    -----
    Cost: one pass over the tree; the tape has one instruction per tree node.
    A comparison or jumping function of the circuit's state is marked
    :data:`LOCKED` in its third operand.
    """
    ops: list[int] = []
    args: list[tuple[int, int, int]] = []
    consts: list[float] = []
    leaves: list = []
    leaf_number: dict = {}
    stateful: list[bool] = []  # per register: reads V(...) or I(...)

    def emit(op: int, a: int = 0, b: int = 0, c: int = 0, state: bool = False) -> int:
        ops.append(op)
        args.append((a, b, c))
        stateful.append(state)
        return len(ops) - 1

    def visit(node: Expr) -> int:
        t = type(node)
        if t is Const:
            consts.append(float(node.value))
            return emit(OP_CONST, len(consts) - 1)
        if t is Time:
            return emit(OP_TIME)
        if t is Voltage or t is Current:
            if node not in leaf_number:
                leaf_number[node] = len(leaves)
                leaves.append(node)
            return emit(OP_LEAF, leaf_number[node], state=True)
        if t is Unary:
            operand = visit(node.operand)
            return emit(OP_NEG if node.op == "-" else OP_NOT, operand, state=stateful[operand])
        if t is Binary:
            left = visit(node.left)
            right = visit(node.right)
            state = stateful[left] or stateful[right]
            locked = LOCKED if state and node.op in _LOCKED_BINARY else 0
            return emit(_BINARY[node.op], left, right, locked, state=state)
        if t is Ternary:
            cond = visit(node.cond)
            then = visit(node.then)
            other = visit(node.other)
            return emit(OP_SELECT, cond, then, other, state=stateful[cond] or stateful[then] or stateful[other])
        if t is Call and node.func in _POINTS:
            x = visit(node.args[0])
            if any(type(a) is not Const for a in node.args[1:]):
                raise ValueError(f"the points of {node.func}() must be constants")
            first = len(consts)
            consts.extend(float(a.value) for a in node.args[1:])
            return emit(_POINTS[node.func], x, first, (len(node.args) - 1) // 2, state=stateful[x])
        if t is Call:
            code = _CALLS.get(node.func)
            if code is None:
                raise ValueError(f"function {node.func}() cannot be evaluated in a behavioural source")
            regs = [visit(a) for a in node.args]
            state = any(stateful[r] for r in regs)
            if node.func in _LOCKED_CALLS and state:
                return emit(code, regs[0], 0, LOCKED, state=True)
            return emit(code, *regs, state=state)
        if t is Param:
            raise ValueError(f"parameter '{node.name}' was not resolved")
        raise ValueError(f"cannot evaluate {node!r}")

    visit(tree)
    return ops, args, consts, leaves


def count_locked(ops: list[int], args: list[tuple[int, int, int]]) -> int:
    """How many instructions of a tape are locked (its comparisons and jumps of the circuit's state).

    Examples
    --------
    >>> from netdae.netlist.expr import parse_expression
    >>> count_locked(*compile_tape(parse_expression("v(a) > 0.3 ? 2 : time < 1u", context="behavioural"))[:2])
    1
    """
    return sum(1 for op, a in zip(ops, args) if a[2] == LOCKED and (op in _LOCKABLE))


#: Opcodes that can be locked (the third operand of the others means something else).
_LOCKABLE = frozenset({_BINARY[o] for o in _LOCKED_BINARY} | {_CALLS[f] for f in _LOCKED_CALLS})
