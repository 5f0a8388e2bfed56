"""ngspice's uniform distributed RC line (``U`` elements, ``.model ... urc``) as the lumped network ngspice builds.

ngspice does not simulate a URC line as a distributed element: its setup
replaces it by ``N`` lumps of resistors and capacitors (or diodes) whose sizes
grow geometrically by the propagation constant ``K`` from both ends of the line
towards its middle, so that the short lumps sit where the fast edges enter
[1]_. netdae builds the same network, element for element, so a netlist with a
URC line means the same in both simulators.

With ``R0 = L rperl``, ``C0 = L cperl``, ``p = K`` and ``N`` lumps (``n=``, or
``max(3, log(2 pi fmax R0 C0 ((p-1)/p)^2) / log p)`` truncated to an integer,
and 3 when ``2 pi fmax R0 C0 < 35``):

- ``r1 = R0 (p-1) / (2 p^N - 2)`` and ``c1 = C0 (p-1) / (p^(N-1) (p+1) - 2)``;
- lump ``i`` (``i = 1 .. N``, ``s = p^(i-1)``) puts ``s r1`` from the left chain's
  last node to a new node ``lo<i>`` and ``s r1`` from a new node ``hi<i>`` to the
  right chain's last node (``n2`` at first); ``s c1`` from ``lo<i>`` to the
  reference, and, except in the last lump, ``s c1`` from ``hi<i>`` to it; the
  last lump's ``lo`` node is its ``hi`` node, which joins the two chains.

The series resistances add up to ``R0`` and the capacitances to ``C0``. With
``isperl`` given the capacitors are diodes of one model (``cjo = c1``,
``is = L isperl (p-1) / (p^(N-1) (p+1) - 2)``, ``rs = L N rsperl``) with area
``s``, anode on the line.

References
----------
.. [1] ngspice 39, ``src/spicelib/devices/urc/urcsetup.c``, and the ngspice
   manual, "Uniform Distributed RC Lines (Lossy)".
"""

from __future__ import annotations

import math

from ..circuit import Element, Model
from ..kinds import Kind

__all__ = ["URC_DEFAULTS", "lumps", "realise"]

#: ngspice 39's defaults of the URC model's parameters.
URC_DEFAULTS = {"k": 1.5, "fmax": 1e9, "rperl": 1000.0, "cperl": 1e-12, "rsperl": 0.0}

#: Below this ``2 pi fmax R0 C0`` ngspice uses three lumps.
_FEW = 35.0


class UrcError(ValueError):
    """A line or model the realisation cannot take; ``param`` names the model parameter at fault
    (None: the card's ``l=`` or ``n=``)."""

    def __init__(self, message: str, param: str | None = None) -> None:
        super().__init__(message)
        self.param = param


def lumps(length: float, model: dict[str, float]) -> int:
    """The number of lumps ngspice gives a line without ``n=``.

    Parameters
    ----------
    length : float
        The line's length ``l=`` [m].
    model : dict of str to float
        The model's parameters (defaults :data:`URC_DEFAULTS`).

    Examples
    --------
    >>> lumps(20e-3, {"cperl": 100e-12, "rperl": 100e3, "fmax": 10e9})
    8
    >>> lumps(1e-6, {})
    3
    """
    p = model.get("k", URC_DEFAULTS["k"])
    r0 = length * model.get("rperl", URC_DEFAULTS["rperl"])
    c0 = length * model.get("cperl", URC_DEFAULTS["cperl"])
    wnorm = model.get("fmax", URC_DEFAULTS["fmax"]) * r0 * c0 * 2.0 * math.pi
    if wnorm < _FEW:
        return 3
    return int(max(3.0, math.log(wnorm * ((p - 1) / p) ** 2) / math.log(p)))


def realise(el: Element, model: Model) -> tuple[list[Element], list[str], Model | None]:
    """The lumped network of the URC line ``el``.

    Parameters
    ----------
    el : Element
        The line (kind ``urc``; nodes ``(n1, n2, ref)``; ``params["l"]``, optional ``params["n"]``).
    model : Model
        Its ``urc`` model.

    Returns
    -------
    elements : list of Element
        Resistors ``<line>#rlo<i>``, ``<line>#rhi<i>`` and capacitors ``<line>#clo<i>``,
        ``<line>#chi<i>`` (or diodes ``<line>#dlo<i>``, ``<line>#dhi<i>``).
    nodes : list of str
        The internal nodes ``<line>#lo<i>``, ``<line>#hi<i>``, as ngspice names them.
    diode_model : Model or None
        The diodes' model ``<line>#diodes`` when ``isperl`` is given.

    Raises
    ------
    UrcError
        ``k`` not above 1, a non-positive ``rperl`` or ``cperl``, a non-positive length or a
        number of lumps that is not a whole number >= 1.
    """
    mp = model.params
    p = mp.get("k", URC_DEFAULTS["k"])
    if not p > 1.0:
        raise UrcError(f"k={p:g}: the propagation constant must be above 1", "k")
    for name in ("rperl", "cperl"):
        if not mp.get(name, URC_DEFAULTS[name]) > 0.0:
            raise UrcError(f"{name}={mp[name]:g} must be positive", name)
    length = el.params["l"]
    if not length > 0.0:
        raise UrcError(f"the length l={length:g} must be positive")
    if "n" in el.params:
        n = el.params["n"]
        if not (n >= 1.0 and n == int(n)):
            raise UrcError(f"the number of lumps n={n:g} must be a whole number >= 1")
        n = int(n)
    else:
        n = lumps(length, mp)
    r0 = length * mp.get("rperl", URC_DEFAULTS["rperl"])
    c0 = length * mp.get("cperl", URC_DEFAULTS["cperl"])
    r1 = r0 * (p - 1) / (2 * p ** n - 2)
    shape = p ** (n - 1) * (p + 1) - 2
    c1 = c0 * (p - 1) / shape
    prefix = f"{el.name}#"  # ngspice's names of the internal nodes: u1#hi1, u.x1.u1#lo2
    diode_model = None
    if "isperl" in mp:
        diode_model = Model(f"{el.name}#diodes", "d", {"cjo": c1, "is": length * mp["isperl"] * (p - 1) / shape,
                                                        "rs": length * n * mp.get("rsperl", URC_DEFAULTS["rsperl"])},
                            location=model.location)
    elements: list[Element] = []
    nodes: list[str] = []

    def add(tag: str, kind: str, ends: tuple[str, str], value: float | None, **kw) -> None:
        elements.append(Element(f"{el.name}#{tag}", kind, ends, value=value, location=el.location,
                                instance_path=el.instance_path, **kw))

    def shunt(tag: str, node: str, scale: float) -> None:
        if diode_model is None:
            add(f"c{tag}", Kind.CAPACITOR.value, (node, ref), scale * c1)
        else:
            add(f"d{tag}", Kind.DIODE.value, (node, ref), None, model=diode_model.name, params={"area": scale})

    left, right, ref = el.nodes[0], el.nodes[1], el.nodes[2]
    scale = 1.0
    for i in range(1, n + 1):
        hi = f"{prefix}hi{i}"
        nodes.append(hi)
        if i == n:
            lo = hi
        else:
            lo = f"{prefix}lo{i}"
            nodes.append(lo)
        add(f"rlo{i}", Kind.RESISTOR.value, (left, lo), scale * r1)
        add(f"rhi{i}", Kind.RESISTOR.value, (hi, right), scale * r1)
        shunt(f"lo{i}", lo, scale)
        if i != n:
            shunt(f"hi{i}", hi, scale)
        scale *= p
        left, right = lo, hi
    return elements, nodes, diode_model
