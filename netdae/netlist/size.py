"""The size of a netlist before it is expanded: elements per subcircuit definition.

Twenty lines of nested subcircuits, each instantiating the next twice, expand
to a million elements. :func:`check_size` counts the flat size from the
parsed definitions (the counts of a definition's instances multiply) without
expanding anything, and refuses a netlist above a limit with a message that
names the chain of subcircuits responsible. It also bounds how deeply
subcircuits may nest, so that expansion never runs out of stack.

Examples
--------
>>> from netdae.netlist import parse
>>> net = parse("t\\n.subckt two a b\\nR1 a m 1\\nR2 m b 1\\n.ends\\nX1 1 2 two\\nX2 2 0 two\\nV1 1 0 1\\n")
>>> flat_element_count(net.top)
5
"""

from __future__ import annotations

from ..errors import NetlistError
from .statements import Definition, ElementCard, InstanceCard
from .syntax import ELEMENTS

__all__ = ["DEFAULT_MAX_ELEMENTS", "MAX_SUBCKT_DEPTH", "flat_element_count", "check_size"]

#: Largest flat circuit :func:`netdae.load` builds unless told otherwise
#: (``max_elements=``). Elaboration holds about 2 kB per element (measured:
#: 131,072 resistors from nested subcircuits, 300 MB peak, 3 s), so this is
#: about 1 GB.
DEFAULT_MAX_ELEMENTS = 500_000

#: Deepest chain of subcircuit instances (and of definitions written inside
#: one another). Real designs nest a few levels; the limit keeps the
#: recursive expansion far from Python's stack limit.
MAX_SUBCKT_DEPTH = 100

#: Links of a long chain shown at each end of a message.
_CHAIN_SHOWN = 4


class _Counter:
    def __init__(self) -> None:
        self.memo: dict[int, int] = {}
        self.active: list[tuple[Definition, InstanceCard]] = []

    def count(self, defn: Definition) -> int:
        key = id(defn)
        total = self.memo.get(key)
        if total is not None:
            return total
        total = 0
        for item in defn.items:
            kind = type(item)
            if kind is ElementCard:
                total += 1
            elif kind is InstanceCard:
                sub = defn.lookup_subckt(item.subckt)
                if sub is None or sub is defn or any(d is sub for d, _ in self.active):
                    continue  # unknown subcircuit, or recursion: elaboration reports them
                if len(self.active) >= MAX_SUBCKT_DEPTH:
                    chain = " -> ".join(d.name for d, _ in self.active[-_CHAIN_SHOWN:])
                    raise NetlistError(
                        f"{item.name}: subcircuits nested deeper than {MAX_SUBCKT_DEPTH} levels (... -> {chain} -> "
                        f"{sub.name})", item.card.location(item.subckt_offset), expected=ELEMENTS["x"].form,
                        hint="flatten the hierarchy")
                self.active.append((sub, item))
                try:
                    total += self.count(sub)
                finally:
                    self.active.pop()
        self.memo[key] = total
        return total


def flat_element_count(top: Definition) -> int:
    """Number of elements of the expanded circuit, computed without expanding it.

    Parameters
    ----------
    top : Definition
        The top level of a parsed :class:`~netdae.netlist.statements.Netlist`.

    Returns
    -------
    int

    Raises
    ------
    NetlistError
        Subcircuit instances nested deeper than :data:`MAX_SUBCKT_DEPTH`.

    Notes
    -----
    Cost O(cards): each definition is counted once. Instances of unknown or
    recursive subcircuits count nothing here (elaboration reports them).
    """
    return _Counter().count(top)


def _chain(counter: _Counter, defn: Definition) -> list[tuple[str, int, int, InstanceCard]]:
    """Follow the biggest contributor down: (subcircuit, instances in the body, elements each, first card)."""
    out = []
    seen: set[int] = set()
    while id(defn) not in seen:
        seen.add(id(defn))
        per_sub: dict[int, list] = {}
        for item in defn.items:
            if type(item) is InstanceCard:
                sub = defn.lookup_subckt(item.subckt)
                if sub is not None:
                    entry = per_sub.setdefault(id(sub), [sub, 0, item])
                    entry[1] += 1
        if not per_sub:
            break
        sub, times, card = max(per_sub.values(), key=lambda e: e[1] * counter.memo.get(id(e[0]), 0))
        out.append((sub.name, times, counter.memo.get(id(sub), 0), card))
        defn = sub
    return out


def check_size(top: Definition, max_elements: int) -> int:
    """Refuse a netlist whose expanded circuit would have more than ``max_elements`` elements.

    Returns
    -------
    int
        The flat element count.

    Raises
    ------
    NetlistError
        Above the limit, located at the top-level instance that contributes
        most, naming the chain of subcircuits and the count; or subcircuits
        nested too deeply.
    """
    counter = _Counter()
    total = counter.count(top)
    if total <= max_elements:
        return total
    chain = _chain(counter, top)
    links = [f"{times} x {name} ({each:,} element{'' if each == 1 else 's'} each)" for name, times, each, _ in chain]
    if len(links) > 2 * _CHAIN_SHOWN:
        links = links[:_CHAIN_SHOWN] + ["..."] + links[-_CHAIN_SHOWN:]
    where = chain[0][3] if chain else None
    message = (f"the expanded circuit would have {total:,} elements, more than the limit of {max_elements:,}"
               + (f": {' -> '.join(links)}" if links else ""))
    if where is not None:
        message = f"{where.name}: {message}"
    raise NetlistError(message, where.card.location(where.subckt_offset) if where is not None else None,
                       hint="if this size is intended, raise the limit: --max-elements N on the command line, "
                            "netdae.load(..., max_elements=N) in Python")
