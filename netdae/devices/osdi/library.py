"""Opening an OSDI library and reading its descriptors into plain data.

:func:`load_library` dlopens a ``.osdi`` file (once per file and
modification time), checks the OSDI version it exports and reads every
descriptor into an :class:`OsdiModule`: the module's terminals, internal
nodes, collapsible node pairs, parameters (name, aliases, type, kind, array
length, description, units) and Jacobian entries (with their resistive and
reactive flags). The module's messages (``$strobe``, ``$display``, errors of
its setup) reach netdae through ``osdi_log``, which the loader sets to a
callback that records them (:func:`drain_messages`); modules that call
``$limit`` get SPICE's limiting functions (:mod:`.limits`).

This module is an I/O edge: it reads files. Everything wrong with the file is
a :class:`~netdae.errors.NetlistError` naming the file and what was expected.
"""

from __future__ import annotations

import ctypes as C
import os
import struct
import threading
from collections import deque
from dataclasses import dataclass, field

from ...errors import NetlistError, SourceLocation
from . import abi

__all__ = ["OsdiParam", "OsdiNodeInfo", "OsdiNoiseInfo", "OsdiJacobianEntry", "OsdiModule", "OsdiLibrary", "load_library",
           "drain_messages", "peek_messages", "message_notes", "LOG_LEVELS"]

#: Names of the ``osdi_log`` levels (``lvl & LOG_LVL_MASK``).
LOG_LEVELS = ("debug", "display", "info", "warning", "error", "fatal")
#: Messages kept (oldest dropped): a model printing every evaluation must not grow memory.
MAX_MESSAGES = 1000

_TYPES = {abi.PARA_TY_REAL: "real", abi.PARA_TY_INT: "int", abi.PARA_TY_STR: "str"}
_KINDS = {abi.PARA_KIND_MODEL: "model", abi.PARA_KIND_INST: "instance", abi.PARA_KIND_OPVAR: "opvar"}


@dataclass(frozen=True)
class OsdiParam:
    """A parameter (or operating-point variable) of an OSDI module.

    Attributes
    ----------
    id : int
        The number ``access`` takes.
    name : str
        Lower-case primary name; ``aliases`` the others (lower case).
    type : {'real', 'int', 'str'}
    kind : {'model', 'instance', 'opvar'}
        Instance parameters may also be given on the ``.model`` card (a default
        for every instance).
    length : int
        0 for a scalar, else the length of an array parameter.
    description, units : str
    """

    id: int
    name: str
    aliases: tuple[str, ...]
    type: str
    kind: str
    length: int
    description: str
    units: str

    @property
    def names(self) -> tuple[str, ...]:
        """The primary name, then the aliases."""
        return (self.name,) + self.aliases


@dataclass(frozen=True)
class OsdiNodeInfo:
    """A node of a module: ``is_flow`` marks a current unknown (a branch), not a potential."""

    index: int
    name: str
    units: str
    is_flow: bool


@dataclass(frozen=True)
class OsdiNoiseInfo:
    """A noise source of a module: a current between nodes ``pos`` and ``neg`` (None: ground).

    ``kind`` is OSDI 0.5's ``noise_source_type`` (``abi.NOISE_TYPE_*``); None for an OSDI 0.4 module,
    which does not say.
    """

    name: str
    pos: int
    neg: int | None
    kind: int | None


@dataclass(frozen=True)
class OsdiJacobianEntry:
    """A Jacobian entry d(residual of ``row``)/d(unknown of ``col``).

    ``resist``/``react`` say which of the two Jacobians it belongs to,
    ``*_const`` that the value does not depend on the unknowns.
    """

    row: int
    col: int
    resist: bool
    react: bool
    resist_const: bool
    react_const: bool
    react_ptr_off: int


@dataclass(eq=False)
class OsdiModule:
    """One compiled Verilog-A module, as its descriptor describes it.

    Attributes
    ----------
    name : str
        The module's name as written in Verilog-A (lower case).
    library : OsdiLibrary
    nodes : tuple of OsdiNodeInfo
        Terminals first (``num_terminals``), then internal nodes.
    collapsible : tuple of (int, int or None)
        Node pairs the module may merge (``None``: the first node to ground),
        decided per instance by ``setup_instance``.
    params : tuple of OsdiParam
        Parameters (instance ones first), then operating-point variables.
    jacobian : tuple of OsdiJacobianEntry
    num_states : int
        Limiting states per instance.
    noise : tuple of OsdiNoiseInfo
        The noise sources, in the order ``load_noise`` writes their densities.
    num_delays : int
        The module's absolute delays (``absdelay``; OSDI 0.5), which need a
        history netdae does not keep: such a module is refused when used.
    descriptor : ctypes structure
        The raw descriptor (kept for :mod:`.instance`).
    """

    name: str
    library: "OsdiLibrary"
    nodes: tuple[OsdiNodeInfo, ...]
    num_terminals: int
    collapsible: tuple[tuple[int, int | None], ...]
    params: tuple[OsdiParam, ...]
    jacobian: tuple[OsdiJacobianEntry, ...]
    num_states: int
    descriptor: C.Structure = field(repr=False)
    noise: tuple[OsdiNoiseInfo, ...] = ()
    num_delays: int = 0
    _by_name: dict[str, OsdiParam] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        for p in self.params:
            if p.kind == "opvar":
                continue
            for nm in p.names:
                self._by_name.setdefault(nm, p)

    @property
    def terminals(self) -> tuple[str, ...]:
        """Terminal names in connection order."""
        return tuple(n.name for n in self.nodes[: self.num_terminals])

    @property
    def internal_nodes(self) -> tuple[str, ...]:
        """Internal node (and flow unknown) names."""
        return tuple(n.name for n in self.nodes[self.num_terminals:])

    @property
    def parameters(self) -> tuple[OsdiParam, ...]:
        """Model and instance parameters (no operating-point variables)."""
        return tuple(p for p in self.params if p.kind != "opvar")

    def parameter(self, name: str) -> OsdiParam | None:
        """The parameter called ``name`` (any alias, any case), or None."""
        return self._by_name.get(name.lower())

    def lookup(self, name: str, who: str, location: SourceLocation | None = None) -> OsdiParam:
        """The parameter called ``name``, or a NetlistError saying the module has none.

        Parameters
        ----------
        name : str
            Any alias, any case.
        who : str
            The model or instance that gives it (the message starts with it).
        location : SourceLocation, optional
            Where it is given.

        Raises
        ------
        NetlistError
            ``who: OSDI module M (file) has no parameter 'name'``, with the
            first parameters as what was expected.
        """
        p = self.parameter(name)
        if p is None:
            names = ", ".join(q.name for q in self.parameters[:12])
            more = ", ..." if len(self.parameters) > 12 else ""
            raise NetlistError(f"{who}: OSDI module {self.name} ({self.library.path}) has no parameter {name!r}",
                               location, expected=f"one of {names}{more}")
        return p

    def describe(self) -> str:
        """A one-line summary: ``bsim4(d, g, s, b) 4 internal nodes, 893 parameters``."""
        return (f"{self.name}({', '.join(self.terminals)}) {len(self.internal_nodes)} internal nodes, "
                f"{len(self.parameters)} parameters, {len(self.jacobian)} Jacobian entries")


@dataclass(eq=False)
class OsdiLibrary:
    """An opened ``.osdi`` file: its version and modules (by lower-case name)."""

    path: str
    version: tuple[int, int]
    modules: dict[str, OsdiModule]
    handle: C.CDLL = field(repr=False)

    def module(self, name: str, location: SourceLocation | None = None) -> OsdiModule:
        """The module called ``name``; a NetlistError naming the file and its modules if absent."""
        mod = self.modules.get(name.lower())
        if mod is None:
            raise NetlistError(f"OSDI module {name!r} is not in {self.path}", location,
                               expected=f"one of {', '.join(sorted(self.modules))}")
        return mod


# --- the log callback -------------------------------------------------------------------------

_MESSAGES: deque[tuple[str, str, str]] = deque(maxlen=MAX_MESSAGES)
_HANDLES: dict[int, str] = {}
_HANDLE_LOCK = threading.Lock()


def _log(handle, msg, lvl):  # called from C: must never raise
    try:
        who = _HANDLES.get(handle or 0, "?")
        text = (msg or b"").decode("utf-8", "replace").rstrip("\n")
        level = LOG_LEVELS[lvl & abi.LOG_LVL_MASK] if (lvl & abi.LOG_LVL_MASK) < len(LOG_LEVELS) else str(lvl)
        if lvl & abi.LOG_FMT_ERR:
            text = f"(message could not be formatted) {text}"
        _MESSAGES.append((who, level, text))
    except Exception:  # noqa: BLE001 - an exception cannot cross into C
        pass


_LOG_CALLBACK = abi.LOG_FUNCTION(_log)


def register_handle(name: str) -> int:
    """A handle (a small integer passed as ``void *``) under which the module's messages are named."""
    with _HANDLE_LOCK:
        key = len(_HANDLES) + 1
        _HANDLES[key] = name
    return key


def drain_messages() -> list[tuple[str, str, str]]:
    """The messages OSDI modules logged since the last call: (who, level, text)."""
    out = list(_MESSAGES)
    _MESSAGES.clear()
    return out


def peek_messages() -> list[tuple[str, str, str]]:
    """The messages OSDI modules logged since the last :func:`drain_messages`, left in place."""
    return list(_MESSAGES)


#: Groups of messages (instance and level) :func:`message_notes` shows; the others are counted.
SHOWN_MESSAGE_GROUPS = 5


def message_notes(messages: list[tuple[str, str, str]]) -> list[str]:
    """What the modules said, as notes for a result: one per instance and level, the first text and a count.

    A module's ``$strobe``, ``$display``, ``$warning``, ``$error`` and
    ``$fatal`` during an analysis are messages netdae would otherwise never
    show; a model printing at every evaluation says the same thing thousands
    of times, so each instance's messages of one level become one note (its
    first and last texts and how many there were), and instances whose notes
    would read alike (a card's warning at each of its instances) share one.

    Parameters
    ----------
    messages : list of (str, str, str)
        ``(who, level, text)`` as :func:`drain_messages` returns them.

    Returns
    -------
    list of str
        ``"OSDI n1 error: g too large: 2 (3 messages, the last: ...)"``,
        ``"OSDI m1, m2 warning: ..."``; at most :data:`SHOWN_MESSAGE_GROUPS`
        notes and one counting the rest.
    """
    groups: dict[tuple[str, str], list[str]] = {}
    for who, level, text in messages:
        text = text.strip()
        if text:
            groups.setdefault((who, level), []).append(text)
    said: dict[str, list[str]] = {}  # instances saying the same thing (a card's warning at every instance) together
    counts: dict[str, int] = {}
    for (who, level), texts in groups.items():
        more = ""
        if len(texts) > 1:
            more = f" ({len(texts)} messages" + (f", the last: {texts[-1]}" if texts[-1] != texts[0] else "") + ")"
        key = f"{level}: {texts[0]}{more}"
        said.setdefault(key, []).append(who)
        counts[key] = counts.get(key, 0) + len(texts)
    notes = []
    for key, whos in list(said.items())[:SHOWN_MESSAGE_GROUPS]:
        named = ", ".join(whos[:4]) + (f" and {len(whos) - 4} more" if len(whos) > 4 else "")
        notes.append(f"OSDI {named} {key}")
    if len(said) > SHOWN_MESSAGE_GROUPS:
        rest = sum(counts[k] for k in list(said)[SHOWN_MESSAGE_GROUPS:])
        notes.append(f"OSDI modules: {rest} more messages ({len(said) - SHOWN_MESSAGE_GROUPS} more kinds; "
                     "netdae.devices.osdi.drain_messages() in Python has them)")
    if len(messages) >= MAX_MESSAGES:
        notes.append(f"OSDI modules: only the last {MAX_MESSAGES} messages were kept")
    return notes


# --- reading ----------------------------------------------------------------------------------

_CACHE: dict[tuple[str, float], OsdiLibrary] = {}


def _text(p) -> str:
    return p.decode("utf-8", "replace") if p else ""


def _u32(lib: C.CDLL, name: str) -> int | None:
    try:
        return C.c_uint32.in_dll(lib, name).value
    except ValueError:
        return None


_ELF_MAGIC = b"\x7fELF"
_ET_DYN = 3
_SHT_NOBITS = 8


def elf_problem(path: str) -> str | None:
    """What makes a file unfit to hand to ``dlopen``, read from its ELF headers alone.

    ``dlopen`` maps a library's segments without checking that the file
    holds them: a truncated library maps pages past the end of the file, and
    the first read of one kills the process with a bus error (no message, no
    exception). This reads the ELF header, the program headers and the
    section headers with :mod:`struct` and checks that each of them, and every
    segment and section that has bytes in the file, lies within the file.

    Parameters
    ----------
    path : str
        The file.

    Returns
    -------
    str or None
        None for a complete ELF shared object; else what is wrong, e.g.
        ``"truncated: ... program header 2 needs bytes up to 14336, the file
        has 8192"``.
    """
    try:
        with open(path, "rb") as f:
            return _elf_problem(f, os.fstat(f.fileno()).st_size)
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"


def _elf_problem(f, size: int) -> str | None:
    """:func:`elf_problem` of an open file of ``size`` bytes (reads the headers only)."""

    def read(offset: int, count: int) -> bytes:
        f.seek(offset)
        return f.read(count)

    data = read(0, 64)
    if data[:4] != _ELF_MAGIC:
        return "no ELF header (not a compiled shared library)"
    if size < 16:
        return f"truncated: the ELF identification needs 16 bytes, the file has {size}"
    if data[4] not in (1, 2) or data[5] not in (1, 2):
        return "damaged ELF header (unknown class or byte order)"
    wide, order = data[4] == 2, "<" if data[5] == 1 else ">"
    head = order + ("HHIQQQIHHHHHH" if wide else "HHIIIIIHHHHHH")
    if size < 16 + struct.calcsize(head):
        return f"truncated: the ELF header needs {16 + struct.calcsize(head)} bytes, the file has {size}"
    (e_type, _machine, _version, _entry, phoff, shoff, _flags, _ehsize, phentsize, phnum, shentsize, shnum,
     _shstrndx) = struct.unpack_from(head, data, 16)
    if e_type != _ET_DYN:
        return f"an ELF file of type {e_type}, not a shared object (type {_ET_DYN})"

    def beyond(what: str, end: int) -> str | None:
        return f"truncated: {what} needs bytes up to {end}, the file has {size}" if end > size else None

    ph = order + ("IIQQQQQQ" if wide else "IIIIIIII")
    if phnum and phentsize < struct.calcsize(ph):
        return f"damaged ELF header (program headers of {phentsize} bytes)"
    if (msg := beyond("the program header table", phoff + phnum * phentsize)) is not None:
        return msg
    table = read(phoff, phnum * phentsize)
    for i in range(phnum):
        fields = struct.unpack_from(ph, table, i * phentsize)
        offset, filesz = (fields[2], fields[5]) if wide else (fields[1], fields[4])
        if (msg := beyond(f"program header {i} (a segment)", offset + filesz)) is not None:
            return msg
    sh = order + ("IIQQQQIIQQ" if wide else "IIIIIIIIII")
    if shoff == 0:
        return None
    if shentsize < struct.calcsize(sh):
        return f"damaged ELF header (section headers of {shentsize} bytes)"
    if (msg := beyond("the section header table", shoff + max(shnum, 1) * shentsize)) is not None:
        return msg
    if shnum == 0:  # more than 0xff00 sections: the count is section 0's size
        shnum = struct.unpack_from(sh, read(shoff, shentsize))[5]
        if (msg := beyond("the section header table", shoff + shnum * shentsize)) is not None:
            return msg
    table = read(shoff, shnum * shentsize)
    for i in range(shnum):
        fields = struct.unpack_from(sh, table, i * shentsize)
        if fields[1] != _SHT_NOBITS and (msg := beyond(f"section {i}", fields[4] + fields[5])) is not None:
            return msg
    return None


def load_library(path: str, location: SourceLocation | None = None) -> OsdiLibrary:
    """Open an OSDI library and read its modules.

    Parameters
    ----------
    path : str
        The ``.osdi`` file.
    location : SourceLocation, optional
        The card that asked for it (for messages).

    Returns
    -------
    OsdiLibrary
        Cached per (real path, modification time): a file is opened once.

    Raises
    ------
    NetlistError
        The file does not exist, is not a shared library, exports no OSDI
        descriptors, or an OSDI version other than 0.4 and 0.5.
    """
    real = os.path.realpath(path)
    if not os.path.isfile(real):
        what = ("does not exist" if not os.path.exists(real) else "is a directory" if os.path.isdir(real)
                else "is not a regular file")
        raise NetlistError(f"OSDI file {path} {what}", location,
                           expected="a compiled Verilog-A model (.osdi), e.g. from openvaf-r model.va")
    key = (real, os.path.getmtime(real))
    if key in _CACHE:
        return _CACHE[key]
    problem = elf_problem(real)
    if problem is not None:
        source = real.lower().endswith((".va", ".vams"))
        raise NetlistError(f"{path} is not a loadable OSDI library: {problem}", location,
                           expected="a shared library compiled by OpenVAF (.osdi)",
                           hint=("the file is incomplete (an interrupted copy, download or compilation?): "
                                 "compile or copy it again" if problem.startswith(("truncated", "damaged")) else
                                 "this is Verilog-A source: compile it first (openvaf-r model.va, or in Python "
                                 "netdae.devices.osdi.compile_va('model.va'), which caches the result) and load "
                                 "the .osdi file" if source else None))
    try:
        lib = C.CDLL(real, mode=os.RTLD_NOW | os.RTLD_LOCAL)
    except OSError as exc:
        raise NetlistError(f"{path} is not a loadable OSDI library: {exc}", location,
                           expected="a shared library compiled by OpenVAF (.osdi)") from None
    major, minor = _u32(lib, "OSDI_VERSION_MAJOR"), _u32(lib, "OSDI_VERSION_MINOR")
    count = _u32(lib, "OSDI_NUM_DESCRIPTORS")
    if major is None or minor is None or count is None:
        raise NetlistError(f"{path} is a shared library but not an OSDI model (no OSDI_VERSION_MAJOR, "
                           "OSDI_VERSION_MINOR or OSDI_NUM_DESCRIPTORS)", location,
                           expected="a shared library compiled by OpenVAF (.osdi)")
    dtype = abi.descriptor_type(major, minor)
    if dtype is None:
        wanted = " or ".join(f"{a}.{b}" for a, b in abi.SUPPORTED_VERSIONS)
        raise NetlistError(f"{path} exports OSDI version {major}.{minor}, which netdae does not read", location,
                           expected=f"OSDI version {wanted}",
                           hint="recompile the Verilog-A source with an OpenVAF that writes OSDI 0.4 or 0.5 "
                                "(openvaf-r from netdae[models])")
    size = _u32(lib, "OSDI_DESCRIPTOR_SIZE")
    if size is not None and size != C.sizeof(dtype):
        raise NetlistError(f"{path}: OSDI {major}.{minor} descriptor of {size} bytes, netdae expects "
                           f"{C.sizeof(dtype)}", location, expected=f"the OSDI {major}.{minor} layout")
    _install_callbacks(lib)
    table = (dtype * count).in_dll(lib, "OSDI_DESCRIPTORS")
    out = OsdiLibrary(path=path, version=(major, minor), modules={}, handle=lib)
    for d in table:
        mod = _read_module(d, out)
        out.modules[mod.name] = mod
    _CACHE[key] = out
    return out


def _install_callbacks(lib: C.CDLL) -> None:
    """Point ``osdi_log`` at netdae's recorder and fill the limiting-function table."""
    try:
        C.c_void_p.in_dll(lib, "osdi_log").value = C.cast(_LOG_CALLBACK, C.c_void_p).value
    except ValueError:
        pass
    n = _u32(lib, "OSDI_LIM_TABLE_LEN")
    if n:
        from .limits import limit_function_address  # numba: only for modules that limit

        table = (abi.OsdiLimFunction * n).in_dll(lib, "OSDI_LIM_TABLE")
        for entry in table:
            entry.func_ptr, _ = limit_function_address(_text(entry.name), entry.num_args)


def _read_module(d, library: OsdiLibrary) -> OsdiModule:
    nodes = tuple(OsdiNodeInfo(i, _text(d.nodes[i].name).lower(), _text(d.nodes[i].units), bool(d.nodes[i].is_flow))
                  for i in range(d.num_nodes))
    collapsible = tuple(
        (d.collapsible[i].node_1, None if d.collapsible[i].node_2 == abi.UINT32_MAX else d.collapsible[i].node_2)
        for i in range(d.num_collapsible))
    params = []
    for i in range(d.num_params + d.num_opvars):
        p = d.param_opvar[i]
        names = [_text(p.name[j]).lower() for j in range(1 + p.num_alias)]
        params.append(OsdiParam(
            id=i, name=names[0], aliases=tuple(names[1:]),
            type=_TYPES.get(p.flags & abi.PARA_TY_MASK, "unknown"),
            kind=_KINDS.get(p.flags & abi.PARA_KIND_MASK, "unknown"),
            length=int(p.len), description=_text(p.description), units=_text(p.units)))
    jac = []
    for i in range(d.num_jacobian_entries):
        e = d.jacobian_entries[i]
        jac.append(OsdiJacobianEntry(
            row=e.nodes.node_1, col=e.nodes.node_2,
            resist=bool(e.flags & abi.JACOBIAN_ENTRY_RESIST), react=bool(e.flags & abi.JACOBIAN_ENTRY_REACT),
            resist_const=bool(e.flags & abi.JACOBIAN_ENTRY_RESIST_CONST),
            react_const=bool(e.flags & abi.JACOBIAN_ENTRY_REACT_CONST),
            react_ptr_off=int(e.react_ptr_off)))
    kinds = getattr(d, "noise_source_type", None)  # OSDI 0.5 only
    noise = tuple(OsdiNoiseInfo(
        _text(d.noise_sources[i].name).lower(), int(d.noise_sources[i].nodes.node_1),
        None if d.noise_sources[i].nodes.node_2 == abi.UINT32_MAX else int(d.noise_sources[i].nodes.node_2),
        int(kinds[i]) if kinds else None) for i in range(d.num_noise_src))
    return OsdiModule(name=_text(d.name).lower(), library=library, nodes=nodes, num_terminals=int(d.num_terminals),
                      collapsible=collapsible, params=tuple(params), jacobian=tuple(jac),
                      num_states=int(d.num_states), descriptor=d, noise=noise,
                      num_delays=int(getattr(d, "num_delay", 0)))
