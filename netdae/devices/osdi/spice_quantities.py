"""ngspice's operating-point quantities of its models that netdae runs as bundled OSDI ports.

An ``M`` element with a BSIM4 card reports ``@m1[gm]``, ``@m1[id]`` ... as
ngspice's ``b4ask.c`` does, and the bundled port's operating-point variables
differ from that in two ways (ports of MOS2, MOS3, MOS6, MOS9 and JFET2 in
the first, and they spell some of ngspice's names otherwise: ``i_d`` for
``id``, answered to by both names):

- ngspice multiplies every current, conductance, charge and capacitance by
  the instance's ``m``; the ports report one device's (their ``$mfactor`` acts
  on the currents they load, not on their op-vars);
- the BSIM4 port's ``gm``, ``gds``, ``gmbs`` are computed from derivatives
  its Verilog-A code carries by hand, and those are not the drain current's
  (measured: ``gm`` 0.36, ``gds`` 0.87 of ngspice's on a 150 nm card);
  its drain current ``id`` equals ngspice's to rounding.

:class:`SpiceQuantities` says so for one model (a field of
:class:`netdae.devices.osdi.spice_models.ModuleMap`), and :func:`apply`
turns the module's op-vars of such an element into ngspice's: the
derivatives as differences of the module's own ``id`` in the
device's internal node voltages (central; ``gds`` one-sided, so as not to
cross ``vds = 0``) (ngspice's ``vgs``, ``vds``, ``vbs`` are
those of the internal gate, drain, source and body nodes), in the frame
ngspice takes them (the source and drain exchanged when ``vds < 0``), then
the ``m`` scaling.
"""

from __future__ import annotations

import ctypes as C
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SpiceQuantities", "apply", "STEP"]

#: The voltage step of the central differences [V]: truncation and rounding both near 1e-10 of a
#: conductance of a drain current of 1e-6 A or more.
STEP = 1e-6


@dataclass(frozen=True)
class SpiceQuantities:
    """How ngspice reports one model's operating-point quantities, in terms of the module's op-vars.

    Attributes
    ----------
    per_device : frozenset of str
        The op-vars ngspice does not multiply by ``m`` (the voltages); every other op-var that
        ngspice has (``names``) is reported times ``m``.
    names : frozenset of str
        ngspice's names among the module's op-vars; the module's others are its own (no ``m``).
    derivatives : dict of str to (str, str, str)
        Quantities computed as derivatives, by name: (the op-var differentiated, the module node
        whose voltage moves, the node that moves instead when the device runs reversed).
    drain_source : tuple of (str, str) or None
        The internal drain and source nodes: the device runs reversed where ``type (V(d) - V(s)) < 0``.
    one_sided : frozenset of str
        Derivatives along ``vds``, which a central difference would take across the exchange of source
        and drain at ``vds = 0`` (where the current in ngspice's frame has a kink): taken one-sided
        (second order), the moved node's ``type``-weighted voltage rising, in the frame of the point.
    aliases : dict of str to str
        ngspice's names of op-vars the module spells otherwise (``id`` for ``i_d``): the same values.
    saved : tuple of str
        What ``.options savecurrents`` saves of such an element with values (ngspice 39 saves
        ``@m1[id] [is] [ig] [ib]`` of every MOSFET, the last three empty for BSIM3 and BSIM4).
    """

    per_device: frozenset
    names: frozenset
    derivatives: dict[str, tuple[str, str, str]] = field(default_factory=dict)
    drain_source: tuple[str, str] | None = None
    one_sided: frozenset = frozenset()
    aliases: dict[str, str] = field(default_factory=dict)
    saved: tuple = ()


def _node(module, name: str) -> int:
    return [n.name for n in module.nodes].index(name)


def _mapping(inst):
    d = inst.module.descriptor
    return (C.c_uint32 * d.num_nodes).from_address(inst.ptr + d.node_mapping_offset)


def apply(family, k: int, rows: np.ndarray, rules: SpiceQuantities, out: dict) -> None:
    """Make instance ``k``'s columns of ``out`` (op-var -> (T, N) values read at ``rows``) ngspice's.

    ``family`` is the :class:`netdae.devices.osdi.family.OsdiFamily`; its
    sim info and buffer are used for the extra evaluations (the moved node's
    class of the instance, internal nodes collapsed into it included, reads a
    spare slot: no other node moves, whatever circuit node it shares) and
    left as they were.
    """
    inst = family.instances[k]
    mod = inst.module
    sign = float(inst.value("type")) if mod.parameter("type") is not None else 1.0
    if rules.derivatives:
        reps = family.reps[k]
        mapping = _mapping(inst)
        saved = np.array(mapping[:], dtype=np.int64)
        buf = np.zeros(family.n + 2)
        spare = family.n + 1
        info = family.info
        kept = info.prev_solve
        info.prev_solve = buf.ctypes.data_as(C.POINTER(C.c_double))
        call = family._calls[id(mod)].eval
        ref = C.byref(info)
        try:
            for name, (of, node, reverse) in rules.derivatives.items():
                if name not in out or of not in out:
                    continue
                address, ctype = family.opvar_address(k, of)
                for p, row in enumerate(rows):
                    buf[: family.n + 1] = row[: family.n + 1]
                    buf[family.n] = 0.0
                    moved = node
                    if rules.drain_source is not None:
                        d, s = (buf[saved[_node(mod, x)]] for x in rules.drain_source)
                        if sign * (d - s) < 0.0:
                            moved = reverse
                    group = np.nonzero(reps == reps[_node(mod, moved)])[0]
                    base = buf[saved[_node(mod, moved)]]
                    for i in group:
                        mapping[i] = spare
                    one_sided = name in rules.one_sided
                    steps = (0.0, sign * STEP, 2.0 * sign * STEP) if one_sided else (STEP, -STEP)
                    values = []
                    for h in steps:
                        buf[spare] = base + h
                        call(inst.handle, inst.ptr, inst.model.ptr, ref)
                        values.append(ctype.from_address(address).value)
                    for i in group:
                        mapping[i] = int(saved[i])
                    if one_sided:  # (-3 f(0) + 4 f(h) - f(2h)) / 2h along type * V, times type: the same sign
                        out[name][p, k] = (-3.0 * values[0] + 4.0 * values[1] - values[2]) / (2.0 * STEP)
                    else:
                        out[name][p, k] = sign * (values[0] - values[1]) / (2.0 * STEP)
        finally:
            for i, v in enumerate(saved):
                mapping[i] = int(v)
            info.prev_solve = kept
    mfactor = float(inst.value("$mfactor")) if mod.parameter("$mfactor") is not None else 1.0
    if mfactor != 1.0:
        for name in rules.names - rules.per_device:
            if name in out:
                out[name][:, k] *= mfactor
    for alias, name in rules.aliases.items():
        if alias in out and name in out and alias not in rules.names:
            out[alias][:, k] = out[name][:, k]
