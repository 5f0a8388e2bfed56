"""Wording of the findings: short lists of names, loops, node sets."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["NAME_LIMIT", "PATH_LIMIT", "name_list", "node_phrase", "plural", "with_inputs"]

#: Names listed in one message before "... and N more" (the finding's fields keep all).
NAME_LIMIT = 8

#: Steps of a loop spelled out in a message (the Loop itself keeps all).
PATH_LIMIT = 16


def name_list(names: Sequence[str], limit: int = NAME_LIMIT) -> str:
    """``"a"``, ``"a and b"``, ``"a, b and c"``, ``"a, b, ... and 12 more"``.

    >>> name_list(["v1", "v2", "c1"])
    'v1, v2 and c1'
    >>> name_list([f"r{i}" for i in range(12)], limit=3)
    'r0, r1, r2 and 9 more'
    """
    names = list(names)
    if len(names) > limit:
        return f"{', '.join(names[:limit])} and {len(names) - limit:,} more"
    if len(names) <= 1:
        return "".join(names)
    return f"{', '.join(names[:-1])} and {names[-1]}"


def node_phrase(nodes: Sequence[str]) -> str:
    """``"node 'a'"`` or ``"nodes 'a' and 'b'"``.

    >>> node_phrase(["a", "b"])
    "nodes 'a' and 'b'"
    """
    quoted = [f"'{n}'" for n in nodes]
    return f"node {quoted[0]}" if len(quoted) == 1 else f"nodes {name_list(quoted)}"


def plural(count: int, singular: str, many: str) -> str:
    """The word that agrees with ``count``."""
    return singular if count == 1 else many


def with_inputs(names: list[str], opamps: list[str], one: str, many: str, *more: str) -> str:
    """``"the voltage source v1, the capacitor c1 and the input of op-amp e1"``: the given
    names under ``one``/``many``, any further phrases, then the op-amp inputs (parts may be absent)."""
    parts = [f"{plural(len(names), one, many)} {name_list(names)}"] if names else []
    parts += [m for m in more if m]
    if opamps:
        parts.append(f"{plural(len(opamps), 'the input of op-amp', 'the inputs of op-amps')} {name_list(opamps)}")
    return name_list(parts)
