"""netdae: a SPICE-dialect circuit simulator that treats a netlist as a DAE.

The public API (imported lazily so that ``import netdae`` stays cheap):

- :func:`load` -- read and elaborate a netlist into a :class:`~netdae.circuit.Circuit`.
- :func:`analyze_index` -- the structure of the DAE: index, Kronecker form, causes.
- :func:`simulate` -- run a transient analysis.
- :func:`run` -- run every analysis of a netlist.
- :func:`compare` -- run a netlist in netdae and ngspice and compare the waveforms.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

__all__ = ["load", "analyze_index", "simulate", "run", "compare", "__version__"]

# public name -> module that defines it
_EXPORTS = {
    "load": "netdae.netlist",
    "analyze_index": "netdae.analyses.index",
    "simulate": "netdae.analyses.tran",
    "run": "netdae.analyses.runner",
    "compare": "netdae.comparison",
}


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'netdae' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(list(globals()) + list(_EXPORTS))
