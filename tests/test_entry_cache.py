"""Entry kernels' disk cache (netdae/dae/compiled/entry_cache.py): machine code kept, no IR for linking.

A fresh process loading the step loop from numba's cache used to parse 2.4 MB of
bitcode kept only for linking the loop into other compiled functions, which nothing
does. These tests check that an entry kernel's cache still loads and computes, that its
stored module is the stub, and that no compiled function of netdae calls an entry kernel
(it would link the stub's traps).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import llvmlite.binding as ll
import pytest

from netdae.dae.compiled import entry_cache

ROOT = Path(__file__).resolve().parent.parent

_SCRIPT = textwrap.dedent('''
    import sys
    import numba
    from netdae.dae.compiled.entry_cache import EntryCache

    @numba.njit(cache=True)
    def inner(x, k):
        s = 0.0
        for i in range(x.size):
            s += x[i] ** k
        return s

    def outer(x, k):
        return inner(x, k) + 1.0

    entry = numba.njit(cache=False)(outer)
    entry._cache = EntryCache(entry.py_func)

    import numpy as np
    value = entry(np.arange(5.0), 3)
    (sig,) = entry.signatures
    shared = entry.overloads[sig].library._shared_module
    bodies = [f.name for f in shared.functions if not f.is_declaration]
    blocks = sorted({len(list(f.blocks)) for f in shared.functions if not f.is_declaration})
    print(value, entry.stats.cache_hits[sig], len(bodies), blocks)
''')


def _run(script: Path, cache: Path) -> list[str]:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.split(None, 3)


def test_entry_kernel_cache_loads_and_computes(tmp_path):
    script = tmp_path / "entry_toy.py"
    script.write_text(_SCRIPT)
    expected = sum(float(i) ** 3 for i in range(5)) + 1.0
    # first process: compiled, saved with the stub
    value, hits, _, _ = _run(script, tmp_path / "cache")
    assert float(value) == expected and int(hits) == 0
    # second process: loaded from the cache; its module for linking is the stub (one block a body: the trap)
    value, hits, bodies, blocks = _run(script, tmp_path / "cache")
    assert float(value) == expected and int(hits) == 1
    assert int(bodies) >= 2  # the entry point, its cpython wrapper and what it links (inner)
    assert blocks.strip() == "[1]"


def test_symbol_stub_defines_the_same_names():
    module = ll.parse_assembly(textwrap.dedent('''
        @"g.const\\22x" = internal constant i64 3
        @env = global i8* null
        declare double @ext(double)
        define double @"_ZN3f$1"(double %x) {
          %y = call double @ext(double %x)
          ret double %y
        }
        define i32 @wrapper() {
          ret i32 0
        }
    '''))
    stub = ll.parse_bitcode(entry_cache.symbol_stub(module.as_bitcode()))
    defined = {f.name for f in stub.functions if not f.is_declaration}
    assert defined == {'_ZN3f$1', "wrapper"}
    assert {g.name for g in stub.global_variables if not g.is_declaration} == {'g.const"x', "env"}
    for fn in stub.functions:
        if not fn.is_declaration:
            (block,) = fn.blocks
            assert [i.opcode for i in block.instructions] == ["call", "unreachable"]


def test_strip_linking_ir_leaves_unknown_payloads():
    assert entry_cache.strip_linking_ir(("x",)) == ("x",)
    payload = (("lib", "bitcode", b"..."), "fndesc")
    assert entry_cache.strip_linking_ir(payload) is payload


def _entry_kernels(tree: ast.Module) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            for dec in node.decorator_list:
                if isinstance(dec, ast.Name) and dec.id == "entry_kernel":
                    names.add(node.name)
    return names


def test_no_compiled_function_calls_an_entry_kernel():
    """Entry kernels are called from Python only: a compiled caller would link the stub's traps."""
    sources = sorted((ROOT / "netdae" / "dae" / "compiled").glob("*.py")) + sorted(
        (ROOT / "netdae" / "devices" / "kernels").glob("*.py"))
    trees = {p: ast.parse(p.read_text()) for p in sources}
    entries = set().union(*(_entry_kernels(t) for t in trees.values()))
    assert {"run", "newton_dc", "sweep_dc"} <= entries
    kernel_decorators = {"kernel", "inlined_kernel", "allocating_kernel", "entry_kernel", "njit", "jit"}
    offenders = []
    for path, tree in trees.items():
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef):
                continue
            decorators = {d.id if isinstance(d, ast.Name) else getattr(d, "attr", None) for d in fn.decorator_list}
            decorators |= {getattr(d.func, "id", getattr(d.func, "attr", None))
                           for d in fn.decorator_list if isinstance(d, ast.Call)}
            if not decorators & kernel_decorators:
                continue
            for call in ast.walk(fn):
                if isinstance(call, ast.Call):
                    name = call.func.id if isinstance(call.func, ast.Name) else getattr(call.func, "attr", None)
                    if name in entries:
                        offenders.append(f"{path.name}: {fn.name} calls {name}")
    assert offenders == []


@pytest.mark.parametrize("module", ["netdae.dae.compiled.bdf_loop", "netdae.dae.compiled.steady"])
def test_entry_kernels_use_the_entry_cache(module):
    import importlib

    from netdae.dae import compiled

    mod = importlib.import_module(module)
    names = _entry_kernels(ast.parse(Path(mod.__file__).read_text()))
    for name in names:
        dispatcher = getattr(mod, name)
        if compiled.CACHE_DIR is None:
            assert dispatcher._cache.__class__.__name__ == "NullCache"
        else:
            assert isinstance(dispatcher._cache, entry_cache.EntryCache)
