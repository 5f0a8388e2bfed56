"""Signal names as ngspice writes them: ``v(out)``, ``v(a,b)``, ``i(v1)``, ``@r1[i]``.

The one parser of signal names in netdae's results and command line. It knows
nothing of a particular circuit: it says what a name *means* (a node voltage,
a difference of two, a branch current, a device quantity) and spells it the
way netdae's results key their signals (lower case, no blanks, ground ``0``,
``v(a,0)`` is ``v(a)``). Standard library only, so the command line can use it
without loading numpy.

Examples
--------
>>> parse_signal("V(Out, GND)")
Signal(kind='v', args=('out',))
>>> parse_signal("v(in,minus)").name
'v(in,minus)'
>>> parse_signal("I(V1)").name
'i(v1)'
>>> parse_signal("out").name            # a bare node name is its voltage
'v(out)'
>>> parse_signal("@r1[i]")
Signal(kind='@', args=('r1', 'i'))
>>> split_signals("v(out), v(in,minus),i(v1)")
['v(out)', 'v(in,minus)', 'i(v1)']
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .kinds import KINDS

__all__ = ["Signal", "parse_signal", "split_signals", "canonical", "GROUND_NAMES", "SIGNAL_FORMS",
           "DEVICE_QUANTITIES", "QUANTITY_UNITS", "NONLINEAR_QUANTITY_KINDS", "device_quantity", "signal_unit",
           "subcircuit_name_hint"]

#: Node names that mean ground (ngspice accepts ``gnd`` for ``0``).
GROUND_NAMES = frozenset({"0", "gnd"})

#: The forms a signal name may take, for error messages.
SIGNAL_FORMS = "v(node), v(node1,node2), i(element), @device[param], or a bare node name"

#: The device quantities netdae computes, per element kind, with ngspice 39's
#: names (``@r1[i]``, ``@q1[gm]``) and their meaning: a view of the kinds'
#: definitions (``ElementKind.quantities``, :mod:`netdae.kinds`, which states
#: their sign conventions).
DEVICE_QUANTITIES: dict[str, dict[str, str]] = {k.name: dict(k.quantities) for k in KINDS.values() if k.quantities}

#: The unit of each device quantity name (the same name has the same unit in every kind).
QUANTITY_UNITS: dict[str, str] = {
    "i": "A", "p": "W", "v": "V", "current": "A", "vd": "V", "id": "A", "c": "A", "gd": "S", "cd": "F",
    "charge": "C", "ic": "A", "ib": "A", "ie": "A", "is": "A", "vbe": "V", "vbc": "V", "gm": "S", "gpi": "S",
    "gmu": "S", "go": "S", "gx": "S", "cpi": "F", "cmu": "F", "cbx": "F", "csub": "F", "qbe": "C", "qbc": "C",
    "qbx": "C", "qsub": "C", "ig": "A", "ibd": "A", "ibs": "A", "vgs": "V", "vds": "V", "vbs": "V", "vbd": "V",
    "von": "V", "vdsat": "V", "gds": "S", "gmb": "S", "gmbs": "S", "gbd": "S", "gbs": "S", "cbd": "F",
    "cbs": "F", "cgs": "F", "cgd": "F", "cgb": "F", "igd": "A", "vgd": "V", "ggs": "S", "ggd": "S",
    "qgs": "C", "qgd": "C", "cg": "A", "cs": "A", "cgdq": "F", "capgs": "F", "capgd": "F",
}

#: Kinds whose quantities are values at a solution of the nonlinear device equations (an OSDI
#: device's are its module's operating-point variables, ``@m1[gm]`` of a BSIM4).
NONLINEAR_QUANTITY_KINDS = frozenset(k.name for k in KINDS.values() if k.solved_quantities)

_NAME = r"[^\s(),\[\]@]+"
_CALL = re.compile(rf"([vi])\(\s*({_NAME})\s*(?:,\s*({_NAME})\s*)?\)")
_DEVICE = re.compile(rf"@\s*({_NAME})\s*\[\s*({_NAME})\s*\]")
_BARE = re.compile(_NAME)


@dataclass(frozen=True)
class Signal:
    """What a signal name means.

    Parameters
    ----------
    kind : {"v", "i", "@"}
        ``"v"``: a node voltage (one node) or the difference of two
        (``args == (a, b)``); ``"i"``: the branch current of the element
        ``args[0]``; ``"@"``: the quantity ``args[1]`` of the device
        ``args[0]`` (ngspice's ``@r1[i]``).
    args : tuple of str
        Node names (ground is ``"0"``), or the element name, or device and
        quantity; lower case.
    """

    kind: str
    args: tuple[str, ...]

    @property
    def name(self) -> str:
        """The canonical spelling, as netdae's results key their signals."""
        if self.kind == "@":
            return f"@{self.args[0]}[{self.args[1]}]"
        return f"{self.kind}({','.join(self.args)})"

    @property
    def is_difference(self) -> bool:
        """True for ``v(a,b)``: a difference of two node voltages."""
        return self.kind == "v" and len(self.args) == 2

    @property
    def nodes(self) -> tuple[str, ...]:
        """The nodes of a voltage signal (empty for currents)."""
        return self.args if self.kind == "v" else ()


def _node(text: str) -> str:
    return "0" if text in GROUND_NAMES else text


def parse_signal(text: str) -> Signal:
    """Parse one signal name.

    Parameters
    ----------
    text : str
        ``v(node)``, ``v(node1,node2)``, ``i(element)``, ``@device[param]``
        or a bare node name (its voltage); case and blanks do not matter.

    Returns
    -------
    Signal
        ``v(a,0)`` and ``v(a,gnd)`` are ``v(a)``.

    Raises
    ------
    ValueError
        For text of none of these forms (the message lists them).
    """
    s = text.strip().lower()
    m = _CALL.fullmatch(s)
    if m is not None:
        kind, first, second = m.groups()
        if kind == "i":
            if second is not None:
                raise ValueError(f"bad signal name {text!r}: i() takes one element name, "
                                 f"e.g. i(v1) (expected {SIGNAL_FORMS})")
            return Signal("i", (first,))
        nodes = (_node(first),) if second is None or _node(second) == "0" else (_node(first), _node(second))
        return Signal("v", nodes)
    m = _DEVICE.fullmatch(s)
    if m is not None:
        return Signal("@", m.groups())
    if _BARE.fullmatch(s):
        return Signal("v", (_node(s),))
    raise ValueError(f"bad signal name {text!r} (expected {SIGNAL_FORMS})")


def device_quantity(sig: Signal, kind: str) -> str | None:
    """The device quantity a current or ``@`` signal of an element of ``kind`` asks for.

    Parameters
    ----------
    sig : Signal
        ``i(name)`` or ``@name[param]``.
    kind : str
        The element's kind (:mod:`netdae.circuit`).

    Returns
    -------
    str or None
        The quantity (``"i"``, ``"p"``, ...) to compute after the analysis;
        None for ``i(name)`` of an element whose current is an unknown
        (voltage sources, inductors, ...).

    Raises
    ------
    ValueError
        For a quantity the element does not have (the message names the
        element and the quantities it has).

    Examples
    --------
    >>> device_quantity(parse_signal("i(r1)"), "resistor")
    'i'
    >>> device_quantity(parse_signal("@R1[P]"), "resistor")
    'p'
    >>> device_quantity(parse_signal("i(v1)"), "vsource") is None
    True
    """
    name = sig.args[0]
    spec = KINDS[kind]
    have = DEVICE_QUANTITIES.get(kind, {})
    if sig.kind == "i":
        return "i" if spec.current_is_quantity else None
    if sig.kind != "@":
        raise ValueError(f"{sig.name} is not a device quantity")
    param = sig.args[1]
    if spec.module_quantities:  # its module's operating-point variables (checked when the module is loaded)
        return param
    if param not in have:
        if len(have) > 5:
            offer = " ".join(f"@{name}[{q}]" for q in have)
        else:
            offer = ", ".join(f"@{name}[{q}] ({what})" for q, what in have.items())
        raise ValueError(f"{sig.name}: '{name}' is a {spec.summary}, which has no quantity '{param}' "
                         "in netdae"
                         + (f"; it has {offer}" if offer else "; netdae computes no quantities of it"))
    return param


def missing_name(sig: Signal, nodes, elements) -> str | None:
    """What a signal names that the circuit lacks (``"no node 'zz' in the circuit"``), or None.

    Parameters
    ----------
    sig : Signal
    nodes, elements : container of str
        The circuit's node names (ground ``"0"`` included) and element names.

    Examples
    --------
    >>> missing_name(parse_signal("v(zz)"), {"0", "a"}, {"r1"})
    "no node 'zz' in the circuit"
    >>> missing_name(parse_signal("i(r1)"), {"0", "a"}, {"r1"}) is None
    True
    """
    missing = [n for n in sig.nodes if n not in nodes and "#" not in n]
    if sig.kind in ("i", "@") and sig.args[0] not in elements:
        return f"no element '{sig.args[0]}' in the circuit" + subcircuit_name_hint(sig.args[0], elements)
    if not missing:
        return None
    return f"no node '{missing[0]}' in the circuit"


def subcircuit_name_hint(written: str, elements) -> str:
    """Where an element named by its instance path first (``x1.v9``, PSpice's ``x1:v9``) is, in ngspice's names.

    ngspice (and netdae) name an element inside a subcircuit instance by its letter, the instance path
    and its own name (``v.x1.v9``); ``""`` when ``written`` is no such name of an element of ``elements``.

    Examples
    --------
    >>> subcircuit_name_hint("x1.v9", {"v.x1.v9"})
    ": inside subcircuits it is named 'v.x1.v9' (ngspice's names)"
    >>> subcircuit_name_hint("x1:x2:r1", {"r.x1.x2.r1"})
    ": inside subcircuits it is named 'r.x1.x2.r1' (ngspice's names)"
    >>> subcircuit_name_hint("x1.v8", {"v.x1.v9"})
    ''
    """
    *path, name = re.split(r"[.:]", written)
    full = f"{name[0]}.{'.'.join(path)}.{name}" if path and name and all(path) else None
    return f": inside subcircuits it is named '{full}' (ngspice's names)" if full in elements else ""


def signal_unit(name: str) -> str:
    """The unit of a signal: ``"V"``, ``"A"``, ``"W"`` (powers ``@d[p]``), ``"S"``, ``"F"``, ``"C"`` or ``""``.

    >>> signal_unit("v(out)"), signal_unit("i(r1)"), signal_unit("@r1[p]"), signal_unit("@i1[v]")
    ('V', 'A', 'W', 'V')
    >>> signal_unit("@q1[gm]"), signal_unit("@m1[cgs]"), signal_unit("@d1[charge]"), signal_unit("@x1[zz]")
    ('S', 'F', 'C', '')
    """
    try:
        sig = parse_signal(name)
    except ValueError:
        return ""
    if sig.kind == "@":
        q = sig.args[1]
        if q in QUANTITY_UNITS:
            return QUANTITY_UNITS[q]
        return "V" if q.startswith("v") else "A" if q.startswith("i") else ""
    return "V" if sig.kind == "v" else "A"


def canonical(text: str) -> str:
    """The canonical spelling of a signal name (:attr:`Signal.name`).

    >>> canonical(" V( a , 0 ) ")
    'v(a)'
    """
    return parse_signal(text).name


def split_signals(text: str | None) -> list[str] | None:
    """Split a comma-separated signal list, keeping ``v(a,b)`` and ``@d[p]`` whole.

    Blank entries are dropped and names are lower-cased; None stays None.
    The names are not parsed (:func:`parse_signal` does that).

    Raises
    ------
    ValueError
        For unbalanced parentheses or brackets.
    """
    if text is None:
        return None
    parts, depth, cur = [], 0, []
    for ch in text:
        if ch == "," and depth == 0:
            parts.append("".join(cur))
            cur = []
            continue
        depth += (ch in "([") - (ch in ")]")
        if depth < 0:
            break
        cur.append(ch)
    if depth != 0:
        raise ValueError(f"unbalanced parentheses in the signal list {text!r}")
    parts.append("".join(cur))
    return [p.strip().lower() for p in parts if p.strip()]
