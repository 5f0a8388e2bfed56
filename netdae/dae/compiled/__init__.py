"""netdae's compiled engine: numba kernels, and the one place that configures numba.

The transient step loop of netdae runs as compiled code (numba): the kernels
live in the modules of this package (:mod:`netdae.dae.compiled.lu`: the sparse
LU that refactors on a fixed pivot order) and take only arrays and scalars, so
that compiled callers can call them as well as Python.

Every kernel is compiled through :func:`kernel` (``numba.njit`` with
``cache=True`` and numpy's error model: a division by zero gives inf or nan
instead of raising, the callers test pivots themselves). The compiled machine
code is cached on disk, so only the first run on a machine pays the
compilation; later processes load it.

Where the cache goes
--------------------
numba writes its cache next to the module (``__pycache__``) when that
directory is writable. An installed package often is not (a system
site-packages, a read-only container image), and numba's own fallback, the
user-wide ``~/.cache/numba``, may be unwritable too, in which case numba
refuses to define a cached function at all. On import this package therefore
chooses the directory once (:func:`choose_cache_dir`):

1. ``NUMBA_CACHE_DIR`` when the user set it (numba's own setting, respected);
2. the package's ``__pycache__`` when it is writable (numba's default);
3. ``$XDG_CACHE_HOME/netdae/numba`` (``~/.cache/netdae/numba``);
4. ``<tempdir>/netdae-numba-<uid>``;

and uses its subdirectory ``netdae-engine-<key>``, ``<key>`` a hash of the
source of every module that defines kernels or whose constants they read
(:func:`source_key`), as
``NUMBA_CACHE_DIR`` (setting numba's configuration too) before any kernel is
defined. When none is writable the kernels are compiled without a cache
(every process compiles again; nothing fails). :data:`CACHE_DIR` records the
choice (``None``: no cache).

Why the key: numba invalidates a cached function when the file that
defines it changes, not when a function it calls (and inlined) changes in
another file. The step loop inlines the device kernels and the LU of other
modules, so an edited kernel would otherwise run as its stale cached copy.
With the key, any change to the engine's sources selects a new directory
(the previous ones are removed, best effort). Computing the key scans the
sources (0.1-0.2 s at a process's start), so the base directory keeps it in
:data:`KEY_FILE` with the modification time and size of every file read and
the module listing of their directories (:func:`cached_source_key`): while
none changed, a start costs a few dozen ``stat`` calls instead.

Examples
--------
>>> from netdae.dae import compiled
>>> compiled.CACHE_DIR is None or isinstance(compiled.CACHE_DIR, str)
True
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Callable, Mapping

import numba

__all__ = ["CACHE_DIR", "choose_cache_dir", "source_key", "cached_source_key", "kernel", "inlined_kernel",
           "allocating_kernel", "entry_kernel"]

#: numba's environment variable for its cache directory.
CACHE_ENV = "NUMBA_CACHE_DIR"
_PACKAGE_DIR = Path(__file__).resolve().parent
#: Where the compiled code comes from: the modules defining kernels (this package but its pure-Python
#: driver and warm-up, the device kernels) and those whose constants the kernels read at compile time
#: (the integrator's, netdae.dae.bdf.constants and netdae.dae.newton). A file or a directory of modules
#: each. What these modules import by name from other netdae modules counts too (:func:`source_key`).
_KERNEL_SOURCES = (_PACKAGE_DIR, _PACKAGE_DIR.parent.parent / "devices" / "kernels",
                   _PACKAGE_DIR.parent / "bdf" / "constants.py", _PACKAGE_DIR.parent / "newton.py")
#: The directory of the ``netdae`` package (absolute ``netdae.`` imports resolve from its parent).
_NETDAE_DIR = _PACKAGE_DIR.parent.parent
#: Modules of the listed directories that define no kernel (editing them needs no recompilation).
_NOT_KERNELS = frozenset({"driver.py", "steady_driver.py", "warm.py"})
#: Prefix of the cache's content-keyed subdirectories.
ENGINE_PREFIX = "netdae-engine-"


def _writable(path: str) -> bool:
    """True when a file can be created in ``path`` (created if missing)."""
    try:
        os.makedirs(path, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def choose_cache_dir(package_dir: str | os.PathLike, environ: Mapping[str, str],
                     writable: Callable[[str], bool] = _writable) -> str | None:
    """The directory numba's cache of netdae's kernels should use.

    Parameters
    ----------
    package_dir : path
        Directory of the modules defining the kernels.
    environ : mapping
        The environment (``os.environ``).
    writable : callable
        ``writable(path) -> bool`` (creates the directory when it can).

    Returns
    -------
    str or None
        The first of: ``NUMBA_CACHE_DIR`` if set, ``package_dir/__pycache__``,
        ``$XDG_CACHE_HOME/netdae/numba`` (default ``~/.cache``),
        ``<tempdir>/netdae-numba-<uid>`` that is writable (the first is not
        tested: the user's choice is numba's business); ``None`` when none is.

    Examples
    --------
    >>> choose_cache_dir("/pkg", {"HOME": "/home/u"}, writable=lambda p: p.startswith("/home"))
    '/home/u/.cache/netdae/numba'
    """
    if environ.get(CACHE_ENV):
        return environ[CACHE_ENV]
    candidates = [os.path.join(os.fspath(package_dir), "__pycache__")]
    xdg = environ.get("XDG_CACHE_HOME")
    home = environ.get("HOME")
    if xdg:
        candidates.append(os.path.join(xdg, "netdae", "numba"))
    elif home:
        candidates.append(os.path.join(home, ".cache", "netdae", "numba"))
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    candidates.append(os.path.join(tempfile.gettempdir(), f"netdae-numba-{uid}"))
    for path in candidates:
        if writable(path):
            return path
    return None


def source_key(sources=_KERNEL_SOURCES, skip=_NOT_KERNELS, read: set | None = None) -> str:
    """A hash of the compiled code's sources, 16 hex digits.

    The files of ``sources`` count whole; of the other modules they import names from at their
    top level (``from ..junction import BOLTZMANN``, ``from ...netlist.expr import TABLE_DOMAIN``)
    only the definitions of those names count (:func:`_imported_definitions`): a kernel reads
    such a constant when it is compiled, and an edited constant must select a new cache, while
    the rest of its module does not.

    Parameters
    ----------
    sources : sequence of path
        Files, and directories whose ``*.py`` modules count (missing paths are skipped).
    skip : set of str
        Module names in those directories that do not count.
    read : set, optional
        Receives the path of every file read (:func:`cached_source_key` checks them next time).

    Notes
    -----
    Cost: reading about 400 kB and scanning it for imports and definitions, 40 ms in a warm
    process and 0.1-0.2 s in a fresh one (its regular expressions compiled);
    :func:`cached_source_key` avoids it while no file read changed.
    """
    digest = hashlib.sha256()
    cache: dict = {}
    files = []
    for src in sources:
        src = Path(src)
        files += sorted(p for p in src.glob("*.py") if p.name not in skip) if src.is_dir() else \
            [src] if src.is_file() else []
    counted = {path.resolve() for path in files}
    subs: list = []
    for path in files:
        digest.update(path.name.encode())
        text = path.read_bytes()
        digest.update(text)
        for part in _imported_definitions(path, text, counted, cache, subs):
            digest.update(part)
    if read is not None:
        read.update(str(p) for p in files)
        read.update(str(p) for p in cache)
        read.update(str(p) for p in subs)
    return digest.hexdigest()[:16]


#: The file (in the cache's base directory) that keeps the last key with the state of the files it read.
KEY_FILE = "netdae-source-key.json"


def _signature(paths) -> dict:
    """The state of ``paths`` and of the directories holding them: ``{"files": {path: [mtime_ns, size]},
    "dirs": {dir: [names of its .py files]}}`` (a file created next to one read could change what an import
    names: the directories' listings count too)."""
    files, dirs = {}, {}
    for path in sorted(paths):
        st = os.stat(path)
        files[path] = [st.st_mtime_ns, st.st_size]
        folder = os.path.dirname(path)
        if folder not in dirs:
            dirs[folder] = sorted(n for n in os.listdir(folder) if n.endswith(".py"))
    return {"files": files, "dirs": dirs}


def cached_source_key(base: str | None, sources=_KERNEL_SOURCES, skip=_NOT_KERNELS) -> str:
    """:func:`source_key`, taken from ``base``'s :data:`KEY_FILE` while every file it was computed from is
    unchanged (same modification time in nanoseconds and size, same listing of its directory's modules), else
    computed and written there (best effort: a directory that takes no file only costs the scan).

    Parameters
    ----------
    base : str or None
        The cache's base directory (:func:`choose_cache_dir`); None: computed every time.

    Notes
    -----
    Cost: a ``stat`` per file read and a listing per directory (about 50 and 10, under a millisecond),
    against 0.1-0.2 s for the scan at a process's start.
    """
    import json

    where = os.path.join(base, KEY_FILE) if base else None
    names = sorted(str(Path(src)) for src in sources)
    if where is not None:
        try:
            with open(where, encoding="utf-8") as fh:
                kept = json.load(fh)
            # the kernel directories' listings count through the signature (their files are among those read)
            if kept.get("sources") == names and kept.get("skip") == sorted(skip) and \
                    _signature(kept["signature"]["files"]) == kept["signature"]:
                return str(kept["key"])
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            pass  # none yet, unreadable, or a file it names is gone: computed again
    read: set = set()
    key = source_key(sources, skip, read)
    if where is not None:
        tmp = None
        try:
            record = {"key": key, "sources": names, "skip": sorted(skip), "signature": _signature(read)}
            fd, tmp = tempfile.mkstemp(dir=base, prefix=".netdae-key-")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(record, fh)
            os.replace(tmp, where)
        except OSError:  # a full disk: no key kept, and no partial file left behind either
            if tmp is not None:
                try:
                    os.unlink(tmp)
                except OSError:
                    pass
    return key


def _module_file(path: Path, module: str | None, level: int) -> Path | None:
    """The file of the module ``from <level dots><module> import`` names in ``path`` (None: not netdae's)."""
    if level:
        base = path.parent
        for _ in range(level - 1):
            base = base.parent
    elif module and module.split(".")[0] == _NETDAE_DIR.name:
        base, module = _NETDAE_DIR.parent, module
    else:
        return None  # numpy, numba, math: their versions are numba's concern
    target = base.joinpath(*module.split(".")) if module else base
    if target.with_suffix(".py").is_file():
        return target.with_suffix(".py")
    if (target / "__init__.py").is_file():
        return target / "__init__.py"
    return None


#: A top-level ``from <dots><module> import <names>`` (names in parentheses over several lines, or on one).
_IMPORT = re.compile(r"^from\s+(\.*)([\w.]*)\s+import\s+(\([^)]*\)|[^\n]*)", re.MULTILINE)


def _statements(text: str) -> dict:
    """The module's top-level statements by first line: ``{first line: statement text}`` in order."""
    out, current = {}, []
    for line in text.splitlines(keepends=True):
        if line[:1] not in ("", " ", "\t", "\n", "\r", "#", ")", "]", "}") and current:
            out.setdefault(current[0], "".join(current))
            current = []
        current.append(line)
    if current:
        out.setdefault(current[0], "".join(current))
    return out


def _imported_names(text: str):
    """``(dots, module, [(name, asname)])`` of each top-level ``from ... import`` in ``text``."""
    for m in _IMPORT.finditer(re.sub(r"#[^\n]*", "", text)):  # (an import's lines hold no string)
        names = []
        for item in m.group(3).strip("() \n").replace("\n", " ").split(","):
            item = item.strip()
            if item and item != "*":
                parts = item.split()
                names.append((parts[0], parts[-1]))
        yield len(m.group(1)), m.group(2) or None, names


def _imported_definitions(path: Path, text: bytes, counted: set, cache: dict | None = None, subs: list | None = None):
    """The source of each definition ``path`` imports by name at its top level from a module not ``counted``.

    A name defined by assignment, ``def`` or ``class`` gives its statement's source (an assignment with
    those of the module's names its value is computed from); one the module imports in turn is followed
    (to a few levels); a submodule, or a name not found, gives its module's whole text (what cannot be
    narrowed counts whole). Text only, no parsing: the key is computed at every start.
    """
    cache = {} if cache is None else cache
    for level, module, names in _imported_names(text.decode()):
        target = _module_file(path, module, level)
        if target is None or target.resolve() in counted or target.resolve() == path.resolve():
            continue
        for name, _ in names:
            sub = target.parent / f"{name}.py"
            if target.name == "__init__.py" and sub.is_file():
                if subs is not None:
                    subs.append(sub)
                yield sub.read_bytes()
                continue
            yield from _definition(target, name, counted, 0, cache)


def _definition(target: Path, name: str, counted: set, depth: int, cache: dict, whole: bool = True):
    """The source of the top-level definition of ``name`` in ``target`` (see :func:`_imported_definitions`);
    ``whole``: the module's whole text when ``name`` is not defined there (else nothing: ``np``, a built-in)."""
    if target not in cache:
        text = target.read_text()
        cache[target] = (text, _statements(text), list(_imported_names(text)))
    text, statements, imports = cache[target]
    defined = re.compile(rf"^(?:(?:async\s+)?def|class)\s+{re.escape(name)}\b|^{re.escape(name)}\s*(?::[^=\n]*)?=(?!=)")
    for first, statement in statements.items():
        if defined.match(first):
            yield statement.encode()
            if depth < 4 and not first.startswith(("def", "class", "async")):
                value = statement.split("=", 1)[1]
                for used in sorted(set(re.findall(r"\b[A-Za-z_]\w*\b", value)) - {name}):
                    yield from _definition(target, used, counted, depth + 1, cache, whole=False)
            return
    for level, module, names in imports:
        for original, alias in names:
            if alias == name:
                inner = _module_file(target, module, level)
                if inner is not None and inner.resolve() not in counted and depth < 4:
                    yield from _definition(inner, original, counted, depth + 1, cache)
                return
    if whole:
        yield text.encode()


def _prune(base: str, keep: str) -> None:
    """Remove the other engine directories under ``base`` (caches of earlier sources; best effort)."""
    try:
        entries = os.listdir(base)
    except OSError:
        return
    for name in entries:
        if name.startswith(ENGINE_PREFIX) and name != keep:
            shutil.rmtree(os.path.join(base, name), ignore_errors=True)


def _configure() -> str | None:
    environ = dict(os.environ)
    inherited = environ.get(CACHE_ENV, "")
    if os.path.basename(inherited.rstrip(os.sep)).startswith(ENGINE_PREFIX):
        # set by a parent netdae process (children inherit the environment): its base
        environ[CACHE_ENV] = os.path.dirname(inherited.rstrip(os.sep))
    base = choose_cache_dir(_PACKAGE_DIR, environ)
    if base is None:
        return None
    name = ENGINE_PREFIX + cached_source_key(base)
    path = os.path.join(base, name)
    if not _writable(path):
        return None
    if not inherited:
        _prune(base, name)  # (a directory the user chose is not cleaned)
    # numba re-reads its environment before compiling: set both
    os.environ[CACHE_ENV] = path
    numba.config.CACHE_DIR = path
    return path


#: Directory of the compiled kernels' cache (``None``: compiled without a cache).
CACHE_DIR = _configure()


def kernel(fn: Callable) -> Callable:
    """Compile ``fn`` as a netdae kernel: ``numba.njit`` with the disk cache, no reference counting.

    numpy's error model (``x / 0.0`` is inf or nan, not an exception); no
    fastmath (IEEE semantics kept). Compiled without numba's runtime
    (``_nrt=False``): a kernel must not allocate (no ``np.empty``, no
    ``.copy()``: the caller passes work arrays), and in exchange no array
    passed, unpacked from a tuple or sliced costs a reference-count update
    (a call, and an atomic instruction for each release, on every array at
    every call boundary).
    """
    return numba.njit(_nrt=False, cache=CACHE_DIR is not None, error_model="numpy")(fn)


def entry_kernel(fn: Callable) -> Callable:
    """As :func:`kernel`, for a kernel that only Python calls: its disk cache keeps no IR for linking.

    numba's cache of a function holds its machine code and the LLVM bitcode of
    everything it contains, which every process that loads it parses (0.15-0.2 s
    for the step loop, which inlines every device kernel). An entry kernel's
    cache (:class:`~netdae.dae.compiled.entry_cache.EntryCache`) replaces that
    bitcode by a stub of the same symbols whose bodies trap. No compiled
    function may call an entry kernel (it would link the traps);
    ``tests/test_entry_cache.py`` checks that none does.
    """
    dispatcher = numba.njit(_nrt=False, cache=False, error_model="numpy")(fn)
    if CACHE_DIR is not None:
        from .entry_cache import EntryCache

        dispatcher._cache = EntryCache(dispatcher.py_func)
    return dispatcher


def inlined_kernel(fn: Callable) -> Callable:
    """As :func:`kernel`, inlined by numba into every compiled caller (``inline="always"``).

    For the step loop's per-iteration functions whose arguments are the whole system
    (``sysd``, ``devd``: hundreds of machine words once numba flattens the tuples of
    arrays). LLVM does not inline such large functions, and a call copies every word
    onto the stack (about 750 pushes for the corrector's Newton, 700 for an evaluation),
    which cost half the bridge rectifier's step; inlined, only the arrays used are read.
    Called from Python, it compiles and runs as a :func:`kernel` does.
    """
    return numba.njit(_nrt=False, cache=CACHE_DIR is not None, error_model="numpy", inline="always")(fn)


def allocating_kernel(fn: Callable) -> Callable:
    """As :func:`kernel`, with numba's runtime: for the few kernels that allocate (run once, not per step)."""
    return numba.njit(cache=CACHE_DIR is not None, error_model="numpy")(fn)
