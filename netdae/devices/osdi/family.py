"""The device family of OSDI instances: every ``N`` element of a circuit, evaluated in one pass.

Each instance is connected to the MNA system once (:meth:`OsdiFamily.bind`):
its node mapping points at the global unknowns (ground at the extra slot
``n`` of the extended iterate, which is 0), its Jacobian pointers at the
family's scratch arrays (one place per distinct row and column of an
instance's entries, its pairs: the module sums the entries of one pair
there), whose values are scattered into the fixed sparsity pattern through
precomputed slots. :meth:`OsdiFamily.evaluate` copies the iterate into the
buffer ``eval`` reads, calls ``eval`` and the four ``load_*`` functions of
every instance, and adds ``-f`` to ``phi`` and ``q`` to ``q`` (OSDI's
``f(x) + d/dt q(x) = 0`` with ``f`` the currents leaving a node; netdae's
node rows are the currents entering it).

Internal nodes that survive collapse become internal unknowns named
``<element>#<node>``; flow unknowns (the currents of Verilog-A branches with
a potential contribution, such as an inductor's) become branch currents,
``i(<element>)`` when the module has one, ``i(<element>#<branch>)`` otherwise.
Modules with limiting states (``$limit``) limit in Newton iterations as SPICE
devices do: the family's state is the modules' state vector (the limited
values of the previous iteration), ``INIT_LIM`` starts a solve from scratch.
The evaluation runs through ctypes, a few microseconds per instance; its
compiled twin, for the compiled transient engine, is
:func:`netdae.devices.kernels.osdi.eval_osdi`.
"""

from __future__ import annotations

import ctypes as C
import math
import os
import re

import numpy as np

from ..base import Accumulator, DeviceFamily, SlotMap
from ..companion import LimitState
from . import abi
from .bind import build
from .evaluate import eval_flags

__all__ = ["OsdiFamily"]

_NOT_NAME = re.compile(r"[^0-9a-z_]+")
#: eval() flags of limiting against the previous iteration (with the limiting right-hand sides) ...
LIMIT_AGAINST = abi.ENABLE_LIM | abi.CALC_RESIST_LIM_RHS | abi.CALC_REACT_LIM_RHS
#: ... and of a solve from scratch (the modules' initial values: SPICE's MODEINITJCT).
LIMIT_INITIAL = LIMIT_AGAINST | abi.INIT_LIM
#: Set to ``0``, the compiled transient evaluates every instance at every call (no device bypass).
BYPASS_ENV = "NETDAE_OSDI_BYPASS"


def bound_step_address(inst) -> int:
    """The address of an instance's ``$bound_step`` value in its data (0: its module has none).

    OSDI keeps the step bound a module asks for (``$bound_step(dt)``) in the
    instance data at the descriptor's ``bound_step_offset`` (``UINT32_MAX``:
    the module never asks); the transient caps its next step by the shortest
    one after each accepted point, as ngspice's ``OSDItrunc`` does.
    """
    offset = inst.module.descriptor.bound_step_offset
    return 0 if offset == abi.UINT32_MAX else int(inst.ptr) + int(offset)


def set_bypass(compiled: tuple, tolerances: tuple[float, float, float] | None) -> None:
    """Switch the compiled kernel's device bypass on for an analysis, or off (``tolerances`` None).

    Parameters
    ----------
    compiled : tuple
        The family's :meth:`OsdiFamily.compiled` arrays.
    tolerances : (reltol, vntol, abstol) or None
        The analysis' tolerances, which the bypass's tests take (the charges' is the
        circuit's ``chgtol``, as the modules see it); None, or ``NETDAE_OSDI_BYPASS=0``
        in the environment: off.

    Every instance's last evaluation is forgotten (each analysis evaluates its
    instances before it continues one) and the count of bypassed evaluations starts
    at 0.
    """
    from ..kernels import osdi as ko

    inst, info_i, info_f = compiled[0], compiled[3], compiled[4]
    on = tolerances is not None and os.environ.get(BYPASS_ENV, "1") != "0" and inst.shape[0] > 0
    info_i[ko.W_BYPASS] = int(on)
    info_i[ko.W_BYPASSED] = 0
    if inst.shape[0]:
        info_f[inst[:, ko.I_REF] + ko.REF_OK] = 0.0
    if on:
        info_f[[ko.W_RTOL, ko.W_VTOL, ko.W_ITOL]] = tolerances


def end_message(flags: int, name: str) -> str:
    """What a module's ``$stop`` or ``$finish`` (``eval``'s return ``flags``) at instance ``name`` did to the
    analysis (both integrators' messages say it this way)."""
    task = "$stop" if flags & abi.EVAL_RET_FLAG_STOP else "$finish"
    return f"{task} in {name} (an OSDI module) ended the analysis there"


def _name(node: str) -> str:
    """A module's node name as part of an unknown's name: ``flow(br)`` -> ``br``."""
    if node.startswith("flow(") and node.endswith(")"):
        node = node[5:-1]
    return _NOT_NAME.sub("_", node).strip("_") or "node"


class _Calls:
    """The descriptor's functions of one module, cast once."""

    def __init__(self, descriptor) -> None:
        self.eval = abi.EVAL(descriptor.eval)
        self.res_f = abi.LOAD_RESIDUAL(descriptor.load_residual_resist)
        self.res_q = abi.LOAD_RESIDUAL(descriptor.load_residual_react)
        self.jac_f = abi.LOAD_JACOBIAN_RESIST(descriptor.load_jacobian_resist)
        self.jac_q = abi.LOAD_JACOBIAN_REACT(descriptor.load_jacobian_react)
        self.lim_f = abi.LOAD_RESIDUAL(descriptor.load_limit_rhs_resist)
        self.lim_q = abi.LOAD_RESIDUAL(descriptor.load_limit_rhs_react)
        self.noise = abi.LOAD_NOISE(descriptor.load_noise)


def _noise_refused(el, mod, src, why: str):
    """The located error of instance ``el``'s noise source ``src`` (of module ``mod``) that netdae cannot take."""
    from ...errors import CircuitError

    return CircuitError(f"{el.name}: noise source '{src.name}' of OSDI module {mod.name} {why}",
                        elements=(el.name,), location=el.location)


def _flow_noise_scale(inst) -> np.ndarray:
    """Per noise source of ``inst``'s module, the factor that makes its density right under ``$mfactor``.

    A module scales every noise density by its instance's ``$mfactor`` ``m``,
    as it scales the currents its branches put into the nodes: right for a
    source between nodes (``m`` independent generators in parallel). A source
    in the equation of a flow unknown (the current of a branch the module
    probes, ``I(br) <+ white_noise(...)`` beside ``I(d, s) <+ k * I(br)``:
    PSP103's correlated gate-drain noise, BSIM4's ``tnoimod=2``) is different:
    that equation is not scaled, the one flow stands for each of the ``m``
    devices' own, and the nodes receive ``m`` times it. ``m`` devices put
    ``m k^2 S`` into a node, the one flow of density ``D`` puts ``m^2 k^2 D``,
    so ``D`` must be ``S / m``, where the module gives ``m S``: such a source's
    density is divided by ``m^2``.

    Returns
    -------
    ndarray of float
        One factor per source of the module (1 where the source touches no
        flow unknown, or ``m`` is 1 or 0).
    """
    mod = inst.module
    scale = np.ones(len(mod.noise))
    if mod.parameter("$mfactor") is None:
        return scale
    m = float(inst.value("$mfactor"))
    if m in (0.0, 1.0):
        return scale
    for k, src in enumerate(mod.noise):
        ends = [src.pos] + ([] if src.neg is None else [src.neg])
        if any(i < len(mod.nodes) and mod.nodes[i].is_flow for i in ends):
            scale[k] = 1.0 / (m * m)
    return scale


class OsdiFamily(DeviceFamily):
    """Every OSDI instance of a circuit (element kind ``osdi``)."""


    def __init__(self, elements, circuit) -> None:
        super().__init__(elements, circuit)
        self.models, self.instances = build(circuit, self.elements)
        self.reps = [inst.node_classes(el.nodes) for el, inst in zip(self.elements, self.instances)]
        self._calls: dict[int, _Calls] = {}
        for inst in self.instances:
            key = id(inst.module)
            if key not in self._calls:
                self._calls[key] = _Calls(inst.module.descriptor)
        self._bounds = [bound_step_address(inst) for inst in self.instances]
        #: the shortest $bound_step, and the $finish / $stop raised, at the last evaluation (inf, None: none)
        self.step_bound: float = math.inf
        self.ended: str | None = None

    def noise(self, x, temp):
        """The modules' noise sources at the operating point ``x`` (extended), as current generators.

        Every instance is evaluated at ``x`` with ``CALC_NOISE`` (as ngspice's noise analysis
        evaluates it) and its module's ``load_noise`` gives each source's density at a frequency.
        A ``white_noise`` source is its density; a ``flicker_noise`` source ``c / f^a`` is read at
        1 Hz and 10 Hz (``c`` and ``a``: its exponent may depend on the bias, not on the
        frequency) and checked at 1 kHz. The instance's temperature is the one it was set up
        at (``temp`` is not used). Generators are named ``<instance>_<source>`` after the
        module's names of its sources (blanks as ``_``; a name used again in one module gets
        ``_2``, ``_3`` ...).

        Returns
        -------
        NoiseSources

        Raises
        ------
        CircuitError
            A source given as a table (``noise_table``: no power law), or a density that is not
            finite or not the white or power law its kind says, naming the instance and the source.

        Notes
        -----
        Cost: one ``eval`` and three ``load_noise`` calls per instance.
        """
        from ..base import NoiseSources

        out = NoiseSources()
        if not self.instances:
            return out
        info = self.info
        info.abstime = 0.0
        info.flags = eval_flags("ac") | abi.CALC_NOISE | abi.ANALYSIS_NOISE
        self.xbuf[:] = np.asarray(x, dtype=float)[: self.n + 1]
        self.xbuf[self.n] = 0.0
        self.next_state[:] = 0.0
        ref = C.byref(info)
        pos, neg, white, coef, expo = [], [], [], [], []
        for el, inst, g in zip(self.elements, self.instances, self.glob):
            mod = inst.module
            if not mod.noise:
                continue
            calls = self._calls[id(mod)]
            ret = calls.eval(inst.handle, inst.ptr, inst.model.ptr, ref)
            dens = np.zeros((3, len(mod.noise)))
            for row, f in enumerate((1.0, 10.0, 1e3)):
                calls.noise(inst.ptr, inst.model.ptr, f, dens[row].ctypes.data)
            dens *= _flow_noise_scale(inst)[None, :]
            seen: dict[str, int] = {}
            for k, src in enumerate(mod.noise):
                name = re.sub(r"\s+", "_", src.name.strip()) or str(k)
                seen[name] = seen.get(name, 0) + 1
                suffix = f"_{name}" if seen[name] == 1 else f"_{name}_{seen[name]}"
                d1, d10, d1k = dens[:, k]

                if ret & abi.EVAL_RET_FLAG_FATAL or not np.all(np.isfinite(dens[:, k])):
                    raise _noise_refused(el, mod, src, "has no finite density at the operating point")
                if src.kind == abi.NOISE_TYPE_TABLE:
                    raise _noise_refused(el, mod, src, "is a table (noise_table), which netdae's noise analysis "
                                         "does not take (it needs white or 1/f^a densities)")
                if d1 == d10 == d1k or (src.kind == abi.NOISE_TYPE_WHITE and d1 == 0.0):
                    w, c, a = d1, 0.0, 1.0
                elif src.kind == abi.NOISE_TYPE_WHITE:
                    raise _noise_refused(el, mod, src, "is white but its density depends on the frequency")
                elif d1 > 0.0 and d10 > 0.0:
                    a = float(np.log10(d1 / d10))
                    w, c = 0.0, d1
                    if not np.isclose(d1k, c / 1e3 ** a, rtol=1e-9, atol=0.0):
                        raise _noise_refused(el, mod, src, "does not fall as a power of the frequency (white "
                                             "plus 1/f^a in one source, or a table)")
                else:
                    raise _noise_refused(el, mod, src, "has a density of changing sign or one vanishing at some "
                                         "frequencies only")
                out.element.append(el.name)
                out.suffix.append(suffix)
                pos.append(-1 if src.pos >= len(g) else int(g[src.pos]))
                neg.append(-1 if src.neg is None or src.neg >= len(g) else int(g[src.neg]))
                white.append(w)
                coef.append(c)
                expo.append(a)
        out.pos = np.array(pos, dtype=np.int64)
        out.neg = np.array(neg, dtype=np.int64)
        out.white, out.coefficient, out.exponent = np.array(white), np.array(coef), np.array(expo)
        return out

    # -- topology ----------------------------------------------------------
    def add_nodes(self, layout) -> None:
        """Terminals to the circuit's nodes, surviving internal potentials to new node unknowns."""
        self.glob = []
        for el, inst, reps in zip(self.elements, self.instances, self.reps):
            mod = inst.module
            nt = inst.connected
            g = np.full(len(mod.nodes), -2, dtype=np.int64)  # -2: a flow unknown, numbered in add_branches
            for i, node in enumerate(mod.nodes):
                r = reps[i]
                if r < 0:
                    g[i] = -1
                elif r < nt:
                    g[i] = layout.node(el.nodes[r])
                elif r == i and not node.is_flow:
                    g[i] = layout.add_node(f"{el.name}#{_name(node.name)}", internal=True)
            self.glob.append(g)

    def add_branches(self, layout) -> None:
        """Surviving flow unknowns (currents of Verilog-A branches) to branch currents: ``i(<element>)``
        for a module with one, ``i(<element>#<branch>)`` otherwise."""
        for el, inst, reps, g in zip(self.elements, self.instances, self.reps, self.glob):
            mod = inst.module
            flows = [i for i, node in enumerate(mod.nodes) if node.is_flow and reps[i] == i]
            for i in flows:
                name = el.name if len(flows) == 1 else f"{el.name}#{_name(mod.nodes[i].name)}"
                g[i] = layout.add_branch(name)
            for i in range(len(mod.nodes)):
                if reps[i] >= inst.connected:
                    g[i] = g[reps[i]]

    def coordinates(self, layout):
        rows, cols = [], []
        for inst, g in zip(self.instances, self.glob):
            jac = inst.module.jacobian
            rows.append(np.array([g[e.row] for e in jac], dtype=np.int64))
            cols.append(np.array([g[e.col] for e in jac], dtype=np.int64))
        self._rows, self._cols = rows, cols
        if not rows:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        return np.concatenate(rows), np.concatenate(cols)

    def charge_rows(self) -> np.ndarray:
        """The rows of the modules' reactive Jacobian entries (their residuals ``q`` are written there)."""
        rows = [g[e.row] for inst, g in zip(self.instances, self.glob) for e in inst.module.jacobian
                if e.react or e.react_const]
        return np.unique(np.asarray(rows, dtype=np.int64))

    def bind(self, slots: SlotMap, n: int) -> None:
        """Connect every instance: node mapping into the extended iterate, Jacobian pointers into scratch."""
        self.n = n
        self._pairs()
        total = len(self._pair_rows)
        self.jr = np.zeros(max(total, 1))
        self.jc = np.zeros(max(total, 1))
        self.slots = slots(self._pair_rows, self._pair_cols) if total else np.zeros(0, np.int64)
        self.nstates = nstates = sum(inst.module.num_states for inst in self.instances)
        self.prev_state = np.zeros(max(nstates, 1))
        self.next_state = np.zeros(max(nstates, 1))
        self.xbuf = np.zeros(n + 1)
        self.fbuf = np.zeros(n + 1)
        self.qbuf = np.zeros(n + 1)
        soff = 0
        for inst, g, p0, places in zip(self.instances, self.glob, self._pair0, self._places):
            ns = inst.module.num_states
            mapping = np.where(g < 0, n, g).astype(np.uint32)
            inst.connect(mapping, self.jr[p0:], self.jc[p0:], np.arange(soff, soff + ns), places)
            soff += ns
        self.info = abi.OsdiSimInfo()
        if self.instances:  # the models of one circuit share their simulator parameters (bind.build)
            self.sim = self.instances[0].model.sim
            self.info.paras = self.sim.struct
        self.info.prev_solve = self.xbuf.ctypes.data_as(C.POINTER(C.c_double))
        self.info.prev_state = self.prev_state.ctypes.data_as(C.POINTER(C.c_double))
        self.info.next_state = self.next_state.ctypes.data_as(C.POINTER(C.c_double))
        self._flags = (eval_flags("tran"), eval_flags("tran") & ~(abi.CALC_RESIST_JACOBIAN | abi.CALC_REACT_JACOBIAN))

    def _pairs(self) -> None:
        """Each instance's Jacobian entries on its distinct (row, column) pairs, one more for every entry
        with a ground row or column: the modules load an instance's entries of one pair into one place
        (``load_jacobian_*`` add them in the order of the entries), and the pairs are scattered into the
        pattern, a few a transistor instead of its entries (BSIM4's 86 entries are 4 pairs on an
        inverter's n-channel transistor). Sets per instance its first pair (``_pair0``), its entries'
        places among its pairs (``_places``) and its pairs' (row, column) (``_distinct``); the pairs'
        rows and columns (``_pair_rows``, ``_pair_cols``, ground as -1)."""
        self._pair0, self._places, self._distinct = [], [], []
        rows_all, cols_all, base = [], [], 0
        for rows, cols in zip(self._rows, self._cols):
            seen: dict[tuple[int, int], int] = {}
            places = []
            for r, c in zip(rows.tolist(), cols.tolist()):
                key = (r, c) if r >= 0 and c >= 0 else (-1, -1)
                if key not in seen:
                    seen[key] = len(seen)
                places.append(seen[key])
            self._pair0.append(base)
            self._places.append(np.asarray(places, dtype=np.int64))
            self._distinct.append(list(seen))
            rows_all += [r for r, _ in seen]
            cols_all += [c for _, c in seen]
            base += len(seen)
        self._pair_rows = np.asarray(rows_all, dtype=np.int64)
        self._pair_cols = np.asarray(cols_all, dtype=np.int64)

    @property
    def bypass_allowed(self) -> bool:
        """Whether the netlist lets the compiled transient bypass these instances: ngspice's
        ``.options bypass`` (``bypass=0`` turns it off; absent or nonzero, netdae's default, on;
        ``NETDAE_OSDI_BYPASS=0`` in the environment turns it off too, :func:`set_bypass`)."""
        return bool(self.circuit.options.extra.get("bypass", True))

    def compiled(self, slots: SlotMap, n: int) -> tuple:
        """Pack the family for :func:`netdae.devices.kernels.osdi.eval_osdi` (after ``bind``).

        Returns
        -------
        tuple
            ``(inst, fns, slots, info_i, info_f, xbuf, fbuf, qbuf, jr, jc)``: the
            family's own buffers (the instances hold their addresses) and the
            function addresses of its modules. The limiting state vectors
            (``vold``, ``vnew``: float64[max(1, S)]) are the caller's.
        """
        from ..kernels import osdi as ko

        modules: dict[int, int] = {}
        fns = []
        inst = np.zeros((len(self.instances), ko.N_INST), dtype=np.int64)
        node_lists = [sorted({int(v) for v in g if v >= 0}) for g in self.glob]  # each instance's nodes
        most = max([1] + [len(nodes) for nodes in node_lists])
        words: list[int] = [0] * most  # the work, then the instances' node lists and entries' places
        blocks = 0  # the reference blocks' words, after those
        soff = 0
        for k, (i, g) in enumerate(zip(self.instances, self.glob)):
            d = i.module.descriptor
            row = modules.get(id(i.module))
            if row is None:
                row = modules[id(i.module)] = len(fns)
                fns.append((d.eval, d.load_residual_resist, d.load_residual_react, d.load_jacobian_resist,
                            d.load_jacobian_react, d.load_limit_rhs_resist, d.load_limit_rhs_react))
            ns = i.module.num_states
            pairs = self._distinct[k]
            nodes = node_lists[k]
            position = {v: j for j, v in enumerate(nodes)}
            # only an instance whose unknowns are all potentials in volts is bypassed (the tolerances are a
            # voltage's): not one with a flow unknown (a branch current) or an implicit equation's unknown
            nn = -1 if any(node.units != "V" and g[j] >= 0 for j, node in enumerate(i.module.nodes)) else len(nodes)
            p0 = self._pair0[k]
            inst[k, :ko.I_NODES] = (i.handle, i.ptr, i.model.ptr, row, p0, p0 + len(pairs), bound_step_address(i))
            inst[k, ko.I_NODES] = ko.INFO_WORDS + len(words)
            words += nodes
            inst[k, ko.I_PLACE] = ko.INFO_WORDS + len(words)
            words += [position[r] * len(nodes) + position[c] if r >= 0 else -1 for r, c in pairs]
            inst[k, ko.I_NN] = nn
            inst[k, ko.I_S0], inst[k, ko.I_NS] = soff, ns
            inst[k, ko.I_REF] = blocks
            blocks += ko.REF_V + 3 * len(nodes) + ns + 2 * len(pairs) + 2 * len(nodes)
            soff += ns
        npairs = len(self._pair_rows)
        head = ko.INFO_WORDS + len(words)
        inst[:, ko.I_REF] += head
        info_i = np.zeros(head + blocks, dtype=np.int64)
        info_i[ko.INFO_WORDS:head] = words
        info_f = info_i.view(np.float64)
        if self.instances:
            sim = self.sim
            info_i[:4] = [C.addressof(sim.names), C.addressof(sim.vals), C.addressof(sim.names_str),
                          C.addressof(sim.vals_str)]
            info_i[ko.W_MAXNODES] = most
            info_f[ko.W_QTOL] = sim.value("chgtol")
        info_i[ko.W_PREV_SOLVE] = self.xbuf.ctypes.data
        info_i[ko.W_PREV_STATE] = self.prev_state.ctypes.data
        info_i[ko.W_NEXT_STATE] = self.next_state.ctypes.data
        self._info_words = info_i  # the kernel's OsdiSimInfo (kept alive with the family)
        return (inst, np.array(fns, dtype=np.int64).reshape(-1, ko.N_FNS), np.asarray(self.slots, dtype=np.int64),
                info_i, info_f, self.xbuf, self.fbuf, self.qbuf, self.jr[:npairs], self.jc[:npairs])

    def junction_nodes(self) -> list[tuple[str, str]]:
        """Terminals joined through the module's resistive Jacobian entries (a DC path, structurally)."""
        pairs = []
        for el, inst in zip(self.elements, self.instances):
            mod = inst.module
            parent = list(range(len(mod.nodes)))

            def find(i):
                while parent[i] != i:
                    i = parent[i]
                return i

            for e in mod.jacobian:
                if e.resist and e.row != e.col:
                    a, b = find(e.row), find(e.col)
                    if a != b:
                        parent[max(a, b)] = min(a, b)
            for t in range(1, inst.connected):
                for s in range(t):
                    if find(s) == find(t):
                        pairs.append((el.nodes[s], el.nodes[t]))
                        break
        return pairs

    # -- device quantities ---------------------------------------------------
    def read_unknowns(self, k: int | None = None) -> np.ndarray:
        """The unknowns instance ``k`` (None: every instance) connects to (ground -1 included)."""
        globs = self.glob if k is None else [self.glob[k]]
        return np.unique(np.concatenate([g for g in globs] or [np.zeros(0, np.int64)]))

    def _opvars(self, k: int) -> tuple[str, ...]:
        """The operating-point variables (Verilog-A ``(*desc=...*)`` op-vars) of instance ``k``'s module."""
        return tuple(p.name for p in self.instances[k].module.params if p.kind == "opvar" and not p.length
                     and p.type in ("real", "int"))

    def _spice_rules(self, k: int):
        """How ngspice reports instance ``k``'s quantities (None: as its module does)."""
        from .spice_models import spice_quantities

        return spice_quantities(self.elements[k].name, self.instances[k].module.name)

    def quantity_names(self, k: int) -> tuple[str, ...]:
        """Instance ``k``'s quantities: its module's op-vars, and ngspice's names for some of them.

        An element of an ngspice model run through its port (an ``M`` card of
        MOS2 ...) also answers to ngspice's name of an op-var the port spells
        otherwise (``id`` for the port's ``i_d``).
        """
        own = self._opvars(k)
        rules = self._spice_rules(k)
        if rules is None:
            return own
        return own + tuple(a for a, of in rules.aliases.items() if of in own and a not in own)

    def opvar_address(self, k: int, name: str):
        """The address of instance ``k``'s op-var ``name`` in its data, and its ctypes type."""
        inst = self.instances[k]
        p = inst.module.parameter(name) or next(q for q in inst.module.params if q.name == name)
        address = inst.model._access(inst.ptr, inst.model.ptr, p.id, abi.ACCESS_FLAG_INSTANCE)
        return address, C.c_double if p.type == "real" else C.c_int32

    def quantities(self, x, dxdt=None):
        """The modules' operating-point variables (``@m1[gm]`` of a BSIM4 ...) at solutions ``x``.

        Every instance is evaluated at each point (``eval`` with ``CALC_OP``,
        as for ngspice's ``.op`` output) and its op-vars are read from its
        instance data; a variable another instance's module lacks is NaN
        there. An element of an ngspice model netdae runs through its port
        (an ``M`` card of BSIM4 ...) reports them as ngspice does
        (:mod:`netdae.devices.osdi.spice_quantities`). Shape (T, N) each;
        ``dxdt`` is not used (the modules compute their op-vars from the voltages).
        """
        from .spice_quantities import apply

        x = np.atleast_2d(x)
        count = len(self.instances)
        names = list(dict.fromkeys(q for k in range(count) for q in self.quantity_names(k)))
        out = {q: np.full((x.shape[0], count), np.nan) for q in names}
        reads = [[(q, *self.opvar_address(k, q)) for q in self._opvars(k)] for k in range(count)]
        info = self.info
        info.abstime = 0.0
        info.flags = eval_flags("dc", operating_point=True)
        self.next_state[:] = 0.0
        ref = C.byref(info)
        for p, row in enumerate(x):
            self.xbuf[:] = row
            self.xbuf[self.n] = 0.0
            for k, inst in enumerate(self.instances):
                self._calls[id(inst.module)].eval(inst.handle, inst.ptr, inst.model.ptr, ref)
                for q, address, ctype in reads[k]:
                    out[q][p, k] = ctype.from_address(address).value
        for k in range(count):
            rules = self._spice_rules(k)
            if rules is not None:
                apply(self, k, x, rules, out)
        return out

    # -- evaluation --------------------------------------------------------
    def initial_state(self) -> LimitState | None:
        """SPICE's ``MODEINITJCT`` for the modules that limit (``INIT_LIM``); None without states."""
        if not self.nstates:
            return None
        return LimitState(np.zeros((1, self.nstates)), initial=True)

    def _limit_mode(self, x, state) -> int:
        """The eval flags of limiting: none (at x), against ``state``, or the modules' initial values."""
        if state is None or not self.nstates:
            self.next_state[:] = 0.0
            return 0
        self.prev_state[: self.nstates] = state.v[0]
        if state.initial:
            self.next_state[:] = 0.0
            return LIMIT_INITIAL if not np.any(x[: self.n]) else 0
        # a state a module does not write this time keeps its value (ngspice updates the states in place)
        self.prev_state[: self.nstates] = state.v[0]
        self.next_state[: self.nstates] = state.v[0]
        return LIMIT_AGAINST

    def evaluate(self, x, t, acc: Accumulator, state, jacobian):
        """Every instance at ``x``; with a limiting state, the modules limit (``$limit``) against it.

        Where a module limited, its residuals are continued linearly from the
        limited point to ``x`` with the module's limiting right-hand sides
        (``f(v_lim) + J (x - v_lim)``: SPICE's companion model), and the
        evaluation is marked limited (another Newton iteration).
        """
        self.xbuf[:] = x
        self.xbuf[self.n] = 0.0
        self.fbuf[:] = 0.0
        self.qbuf[:] = 0.0
        lim = self._limit_mode(x, state)
        info = self.info
        info.abstime = float(t)
        info.flags = (self._flags[0] if jacobian else self._flags[1]) | lim
        if jacobian:
            self.jr[:] = 0.0
            self.jc[:] = 0.0
        fptr, qptr = self.fbuf.ctypes.data, self.qbuf.ctypes.data
        ref = C.byref(info)
        limited = 0
        self.step_bound, self.ended = math.inf, None
        for k, inst in enumerate(self.instances):
            calls = self._calls[id(inst.module)]
            mptr = inst.model.ptr
            ret = calls.eval(inst.handle, inst.ptr, mptr, ref)
            if ret & abi.EVAL_RET_FLAG_FATAL:
                acc.ok = False
            limited |= ret & abi.EVAL_RET_FLAG_LIM
            if ret & (abi.EVAL_RET_FLAG_FINISH | abi.EVAL_RET_FLAG_STOP) and self.ended is None:
                self.ended = end_message(ret, self.elements[k].name)
            if self._bounds[k]:
                b = C.c_double.from_address(self._bounds[k]).value
                if 0.0 < b < self.step_bound:
                    self.step_bound = b
            calls.res_f(inst.ptr, mptr, fptr)
            calls.res_q(inst.ptr, mptr, qptr)
            if lim:
                calls.lim_f(inst.ptr, mptr, fptr)
                calls.lim_q(inst.ptr, mptr, qptr)
            if jacobian:
                calls.jac_f(inst.ptr, mptr)
                calls.jac_q(inst.ptr, mptr, 1.0)
        acc.phi -= self.fbuf
        acc.q += self.qbuf
        if jacobian and len(self.slots):
            jr, jc = self.jr[: len(self.slots)], self.jc[: len(self.slots)]
            if not (np.isfinite(jr).all() and np.isfinite(jc).all()):  # an infinite slope at a finite value: 0
                jr, jc = np.where(np.isfinite(jr), jr, 0.0), np.where(np.isfinite(jc), jc, 0.0)
            acc.add_dphi(self.slots, -jr)
            acc.add_dq(self.slots, jc)
        if not (np.isfinite(self.fbuf).all() and np.isfinite(self.qbuf).all()):
            acc.ok = False
        if limited:
            acc.limited = True
        if state is None or not self.nstates:
            return None
        return LimitState(self.next_state[None, : self.nstates].copy())
