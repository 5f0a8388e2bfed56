"""numba's disk cache for entry kernels: machine code kept, the IR for linking left out.

numba caches a compiled function as its object code *and* the LLVM bitcode of
every function it contains, made linkable ("shared bitcode"), so that another
function compiled later can link it in and inline it. A process that loads
the function from the cache parses that bitcode whether or not anything will
ever link it. For the step loop (:func:`netdae.dae.compiled.bdf_loop.run`,
which inlines every device kernel, the LU and the sources) that bitcode is
2.4 MB, and parsing it was 0.15-0.2 s of every fresh process's start (the
object code itself loads in a few milliseconds).

An *entry kernel* is one that only Python calls (:func:`netdae.dae.compiled.entry_kernel`).
Its cache (:class:`EntryCache`) keeps the object code and replaces the shared
bitcode by a *symbol stub*: a module that defines the same names (numba
reads them to find the function's entry points) with bodies that trap. A
compiled caller linking an entry kernel would link those traps and stop at
the first call (SIGILL), not compute with them: entry kernels must not be
called from compiled code (``tests/test_entry_cache.py`` checks the package's).

Where the cached payload is not the shape this module knows (another
numba's serialisation), it is saved unchanged.
"""

from __future__ import annotations

import llvmlite.binding as ll
from numba.core import caching

__all__ = ["EntryCache", "symbol_stub", "strip_linking_ir"]


def _quoted(name: str) -> str:
    """``name`` as an LLVM IR quoted identifier (``"`` and ``\\`` and non-printables as ``\\XX``)."""
    out = []
    for ch in name:
        code = ord(ch)
        if ch in '"\\' or code < 32 or code > 126:
            out.extend(f"\\{b:02X}" for b in ch.encode("utf-8"))
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def symbol_stub(bitcode: bytes) -> bytes:
    """Bitcode of a module defining the same functions and globals as ``bitcode``, each a stub.

    Parameters
    ----------
    bitcode : bytes
        An LLVM module as bitcode (numba's shared module of a library).

    Returns
    -------
    bytes
        A module whose every function defined in ``bitcode`` is ``void name()``
        that calls ``llvm.trap``, and every defined global an ``i8``, all
        ``linkonce_odr``; declarations are left out.

    Notes
    -----
    Cost: one parse of ``bitcode`` (when the cache is written, not when it is
    read) and one of the small stub.
    """
    module = ll.parse_bitcode(bitcode)
    lines = ["declare void @llvm.trap() noreturn nounwind"]
    for fn in module.functions:
        if not fn.is_declaration and not fn.name.startswith("llvm."):
            lines.append(f"define linkonce_odr void @{_quoted(fn.name)}() noreturn nounwind {{\n"
                         "  call void @llvm.trap()\n  unreachable\n}")
    for gv in module.global_variables:
        if not gv.is_declaration:
            lines.append(f"@{_quoted(gv.name)} = linkonce_odr global i8 0")
    stub = ll.parse_assembly("\n".join(lines) + "\n")
    stub.verify()
    return stub.as_bitcode()


def strip_linking_ir(payload: tuple) -> tuple:
    """numba's cached payload of a compile result with its library's shared bitcode stubbed.

    ``payload[0]`` is the library's serialisation, ``(name, "object",
    (object_code, shared_bitcode))`` in the numba versions netdae supports;
    any other shape is returned unchanged.
    """
    if not (isinstance(payload, tuple) and payload and isinstance(payload[0], tuple) and len(payload[0]) == 3):
        return payload
    name, kind, data = payload[0]
    if kind != "object" or not (isinstance(data, tuple) and len(data) == 2 and isinstance(data[1], bytes)):
        return payload
    object_code, shared = data
    return ((name, kind, (object_code, symbol_stub(shared))),) + payload[1:]


class _EntryCacheImpl(caching.CompileResultCacheImpl):
    """numba's cache implementation for compiled functions, saving no IR for linking."""

    def reduce(self, cres):
        return strip_linking_ir(super().reduce(cres))


class EntryCache(caching.FunctionCache):
    """numba's per-function disk cache, for a kernel that no compiled code calls (see the module docstring)."""

    _impl_class = _EntryCacheImpl
