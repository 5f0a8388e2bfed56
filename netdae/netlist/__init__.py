"""The SPICE netlist reader (ngspice dialect): text -> :class:`~netdae.circuit.Circuit`.

The reader works in two pure steps that can be used separately:

- :func:`parse` reads the file and everything it includes, and parses every
  card (a :class:`~netdae.netlist.statements.Netlist`: subcircuit
  definitions, elements, models, parameters, analyses; nothing evaluated);
- :func:`elaborate` expands subcircuits with ngspice's naming, evaluates
  parameters and expressions, checks references, and returns the flat
  :class:`~netdae.circuit.Circuit`.

:func:`load` does both. Every problem in the netlist is a
:class:`~netdae.errors.NetlistError` with file, line, column, the expected
form of the card and a hint. The dialect is described in ``docs/netlist.md``.

Examples
--------
>>> from netdae.netlist import load
>>> c = load('''RC low-pass
... V1 in 0 PULSE(0 1 0 1u 1u 1m 2m)
... R1 in out 1k
... C1 out 0 1u ic=0
... .tran 1u 5m
... .end
... ''')
>>> c.title, c.nodes, c.count_by_letter()
('RC low-pass', ['in', 'out'], {'c': 1, 'r': 1, 'v': 1})
>>> c.element("c1").params
{'ic': 0.0}

Top-level parameters can be given without editing the text:

>>> c = load("divider\\n.param r=1k\\nV1 a 0 1\\nR1 a b {r}\\nR2 b 0 1k\\n", params={"r": 3e3})
>>> c.element("r1").value, c.with_params(r=1e3).element("r1").value
(3000.0, 1000.0)
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from ..circuit import Circuit
from .elaborate import elaborate
from .parser import parse

__all__ = ["load", "parse", "elaborate"]


def load(path_or_text: str | os.PathLike, *, path: str | None = None, params: Mapping[str, float] | None = None,
         max_elements: int | None = None, behavior: str | None = None) -> Circuit:
    """Read, parse and elaborate a netlist.

    Parameters
    ----------
    path_or_text : str or os.PathLike
        A file name (a ``PathLike``, or a ``str`` without a newline) or the
        netlist text itself (a ``str`` with at least one newline).
    path : str, optional
        For text: the file name shown in locations; its directory resolves
        relative ``.include``/``.lib`` names (default: the current directory).
    params : mapping of str to float, optional
        Values for top-level ``.param`` parameters, used instead of the
        netlist's (without editing the text). A name that no top-level
        ``.param`` card defines is an error.
    max_elements : int, optional
        Refuse a netlist whose expanded circuit would have more elements
        (default 500,000, about 1 GB while elaborating); the count is
        estimated from the subcircuit definitions before anything is expanded.
    behavior : str, optional
        ngspice's compatibility mode, as ``set ngbehavior=`` gives it (``"psa"``: PSpice's
        idioms translated in every file, ``"ps"``: in included files only; ``""``: none).
        Default: the ``set ngbehavior`` line of the ``.spiceinit`` next to the netlist, else
        in the working directory (nothing else in that file is read; docs/netlist.md).

    Returns
    -------
    Circuit

    Raises
    ------
    NetlistError
        Anything wrong in the netlist, with its location.
    """
    net = parse(path_or_text, path=path, behavior=behavior)
    if net.scripts:  # .control blocks in the control language: run on the circuit's .csparam values
        from .control import elaborate_scripted

        return elaborate_scripted(net, params=params, max_elements=max_elements)[1]
    return elaborate(net, params=params, max_elements=max_elements)
