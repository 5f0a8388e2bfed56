"""The limiting functions a module's ``$limit`` calls: SPICE's, as C callbacks (numba ``cfunc``).

OpenVAF compiles ``$limit(V(a, c), "pnjlim", vt, vcrit)`` into a call through
the module's ``OSDI_LIM_TABLE``, whose entries the simulator fills in:
``double f(bool init, bool *check, double vnew, double vold, args...)``. netdae
supplies ngspice's ``pnjlim``, ``fetlim`` and ``limvds`` (the kernels of
:mod:`netdae.devices.kernels.junction`, compiled as C functions, so that the
compiled engine calls them without Python), ``init`` giving the starting
value SPICE's ``MODEINITJCT`` gives (``vcrit`` for a junction, the
threshold for a gate, 0 otherwise); ``check`` is set when the value changed.
Any other name passes the iterate through (``vnew``).
"""

from __future__ import annotations

from numba import cfunc, types

from ..kernels.junction import fetlim, limvds, pnjlim

__all__ = ["limit_function_address", "KNOWN"]

_B = types.uint8  # C bool (one byte)
_P = types.CPointer(types.uint8)
_F = types.float64


@cfunc(_F(_B, _P, _F, _F, _F, _F), cache=True)
def _pnjlim(init, check, vnew, vold, vt, vcrit):
    if init:
        check[0] = 1
        return vcrit
    v, changed = pnjlim(vnew, vold, vt, vcrit)
    if changed:
        check[0] = 1
    return v


@cfunc(_F(_B, _P, _F, _F, _F), cache=True)
def _fetlim(init, check, vnew, vold, vto):
    if init:
        check[0] = 1
        return vto
    v = fetlim(vnew, vold, vto)
    if v != vnew:
        check[0] = 1
    return v


@cfunc(_F(_B, _P, _F, _F), cache=True)
def _limvds(init, check, vnew, vold):
    if init:
        check[0] = 1
        return 0.0
    v = limvds(vnew, vold)
    if v != vnew:
        check[0] = 1
    return v


@cfunc(_F(_B, _P, _F, _F), cache=True)
def _passthrough(init, check, vnew, vold):
    return vnew


#: name -> (number of extra arguments, compiled function)
KNOWN = {"pnjlim": (2, _pnjlim), "fetlim": (1, _fetlim), "limvds": (0, _limvds)}


def limit_function_address(name: str, num_args: int) -> tuple[int, bool]:
    """The address of the limiting function ``name`` with ``num_args`` extra arguments; False: a pass-through."""
    known = KNOWN.get(name.lower())
    if known is not None and known[0] == num_args:
        return known[1].address, True
    return _passthrough.address, False
