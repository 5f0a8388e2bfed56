#!/usr/bin/env python3
"""Bad input through every command: mutated netlists that read but mean something wrong.

Usage::

    python scripts/fuzz_commands.py [SOURCES ...] [--seed 1] [--count 300] [--cpu 20]
                                    [--commands run,check,index] [--out fuzz-out] [--spawn]
                                    [--only SUBSTRING]

The reader has its own fuzzers (``tests/test_netlist_fuzz.py``: only
``NetlistError`` leaves ``netdae.load``). This campaign covers what comes
after it: elaboration, assembly, structure analysis, the operating point,
the analyses, the writers and the command line. It takes netlists (by
default netdae's ``netlists/*.cir``, ``tests/data/`` and, when it exists,
the public corpus ``/work/corpus``; each a file or a directory), keeps those
netdae reads, and mutates each one so that it still reads but means
something bad (:data:`MUTATIONS`): a value set to 0, negative, huge, tiny or
to a NaN-producing expression, a model parameter out of range, swapped
nodes, a floating node, a deleted element, a voltage source doubled in
parallel, analysis cards with zero, reversed or negative bounds, ``tstop <
tstep``, ``.ic`` on a missing node, ``.meas`` of a missing signal, ``.save``
of junk, huge ``.step`` counts, bad ``.options``, and analyses the netlist
lacks added with sensible arguments (so that ``.ac``, ``.noise``, ``.tf``,
``.sens``, ``.pz`` and ``.four`` meet every circuit).

Every mutant runs ``netdae run FILE --out DIR``, ``netdae check FILE`` and
``netdae index FILE``, each in its own process (forked from one warm parent,
or with ``--spawn`` a fresh ``python -m netdae``) under a CPU limit and one
at a time. A *failure* is exit status 3, a ``Traceback``, the words "this is
a bug in netdae", or death by a signal other than the CPU limit. A CPU-limit
death is a *timeout* (reported apart, as a hang, not as a failure). Numpy's
``RuntimeWarning`` lines on stderr are counted as *noise*.

The random choices come from ``--seed`` alone, so a run reproduces. Each
failure's mutant is written to ``OUT/failures/`` with its record (source,
mutation, command, exit status, stderr, the traceback taken with
``NETDAE_DEBUG=1``), and the summary groups failures by their signature
(exception type and the innermost netdae frame). Reproduce one with::

    NETDAE_SERVER=0 NETDAE_DEBUG=1 python -m netdae run OUT/failures/NNNN.cir --out /tmp/x

The forked children share the parent's imported modules, so do not edit the
source tree while a campaign runs (a child importing a changed module next to
unchanged ones reports an ``ImportError`` that is not netdae's).

This is a measurement run by hand (a few minutes to an hour), not part of the
test suite; the classes it found are pinned by ``tests/test_bad_input_commands.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SOURCES = (ROOT / "netlists", ROOT / "tests" / "data", Path("/work/corpus"))
NETLIST_SUFFIXES = frozenset({".cir", ".sp", ".net", ".spi", ".spice", ".ckt", ".deck"})
COMMANDS = ("run", "check", "index")
#: Arguments a command gets besides the file (and ``--out DIR`` for run and sweep); ``--commands`` may name these too.
EXTRA_ARGUMENTS = {"sweep": ["--workers", "1", "--no-plot"]}

#: Bad numbers and expressions a value or parameter is set to.
BAD_VALUES = ("0", "-1", "-1e-3", "1e300", "-1e300", "1e-300", "{0/0}", "{sqrt(-1)}", "{log(0)}", "{1/0}",
              "1e308", "{1e200*1e200}")
#: Element letters whose cards are two-terminal with the value fourth.
TWO_TERMINAL = "rclvi"
ELEMENT_NODES = {"r": 2, "c": 2, "l": 2, "v": 2, "i": 2, "d": 2, "e": 4, "g": 4, "f": 2, "h": 2, "q": 3,
                 "m": 4, "j": 3, "z": 3, "s": 4, "w": 2, "b": 2, "t": 4, "k": 0, "o": 4, "u": 3}

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?[a-zA-Z]*$")
_ASSIGN = re.compile(r"^([A-Za-z_]\w*)=(.+)$")
_INCLUDE = re.compile(r"^(\s*\.(?:include|inc|lib)\s+)(['\"]?)([^'\"\s]+)(['\"]?)(.*)$", re.IGNORECASE)


# ---------------------------------------------------------------------------------------------------------------
# netlists as lines

def logical_lines(text: str) -> list[str]:
    """The physical lines with continuations joined (comments kept as they are)."""
    out: list[str] = []
    for raw in text.splitlines():
        if raw.startswith("+") and out:
            out[-1] += " " + raw[1:]
        else:
            out.append(raw)
    return out


def absolute_includes(lines: list[str], directory: Path) -> list[str]:
    """``.include``/``.lib`` names made absolute, so that a mutant written elsewhere reads the same files."""
    out = []
    for line in lines:
        m = _INCLUDE.match(line)
        if m and not os.path.isabs(m.group(3)):
            target = directory / m.group(3)
            if target.exists():
                line = f"{m.group(1)}{m.group(2)}{target}{m.group(4)}{m.group(5)}"
        out.append(line)
    return out


def _cards(lines: list[str]) -> list[tuple[int, list[str]]]:
    """(index, words) of the body's cards outside ``.control`` blocks and subcircuit-free of comments."""
    cards = []
    control = False
    for k, line in enumerate(lines[1:], start=1):
        words = line.split()
        if not words or words[0][0] in "*;$":
            continue
        head = words[0].lower()
        if head == ".control":
            control = True
        elif head == ".endc":
            control = False
        elif not control:
            cards.append((k, words))
    return cards


def _elements(lines, letters=None):
    return [(k, w) for k, w in _cards(lines)
            if w[0][0].isalpha() and (letters is None or w[0][0].lower() in letters)]


def _nodes(lines) -> list[str]:
    nodes = []
    for _, words in _elements(lines):
        n = ELEMENT_NODES.get(words[0][0].lower(), 2)
        nodes += [w for w in words[1:1 + n] if "=" not in w and "(" not in w]
    return sorted({n for n in nodes if n.lower() not in ("0", "gnd")}) or ["1"]


def _sources(lines, letter="v"):
    return [w[0] for _, w in _elements(lines, letter)]


# ---------------------------------------------------------------------------------------------------------------
# mutations: each takes (lines, rng) and returns (new lines, description) or None when it does not apply

def m_value(lines, rng):
    """A value or a parameter of an element set to a bad number."""
    elems = [(k, w) for k, w in _elements(lines) if len(w) > 2]
    if not elems:
        return None
    k, words = rng.choice(elems)
    letter = words[0][0].lower()
    first = 1 + ELEMENT_NODES.get(letter, 2)
    spots = [i for i in range(first, len(words))
             if _NUMBER.match(words[i]) or _ASSIGN.match(words[i]) or words[i].startswith("{")]
    if not spots:
        return None
    i = rng.choice(spots)
    bad = rng.choice(BAD_VALUES)
    m = _ASSIGN.match(words[i])
    words = list(words)
    words[i] = f"{m.group(1)}={bad}" if m else bad
    return _replace(lines, k, " ".join(words)), f"line {k + 1}: {words[0]} word {i} -> {words[i]}"


def m_model(lines, rng):
    """A model parameter set to a bad number (or a level out of range)."""
    models = [(k, w) for k, w in _cards(lines) if w[0].lower() == ".model"]
    if not models:
        return None
    k, words = rng.choice(models)
    text = " ".join(words)
    pairs = list(re.finditer(r"(\w+)\s*=\s*([^\s()=]+)", text))
    bad = rng.choice(BAD_VALUES + ("99", "-5", "1e30"))
    if pairs and rng.random() < 0.85:
        p = rng.choice(pairs)
        new = text[:p.start(2)] + bad + text[p.end(2):]
        what = f"{p.group(1)}={bad}"
    else:
        name = rng.choice(("level", "is", "bf", "br", "vto", "tox", "cjo", "cje", "rs", "rb", "n", "tnom", "kp",
                           "beta", "m", "vj", "fc", "tt", "bv", "ibv", "lambda", "gamma", "phi", "nsub", "uo",
                           "vaf", "ikf", "eg", "xti", "kf", "af", "ron", "roff", "vt", "vh", "it", "ih"))
        new = text.rstrip(")") + (" " if text.endswith(")") else " ") + f"{name}={bad}" + (")" if text.endswith(")") else "")
        what = f"added {name}={bad}"
    return _replace(lines, k, new), f"line {k + 1}: {words[1]} {what}"


def m_swap(lines, rng):
    """Two nodes of an element swapped (or a node tied to the other)."""
    elems = [(k, w) for k, w in _elements(lines) if len(w) > 3 and ELEMENT_NODES.get(w[0][0].lower(), 2) >= 2]
    if not elems:
        return None
    k, words = rng.choice(elems)
    words = list(words)
    if rng.random() < 0.5:
        words[1], words[2] = words[2], words[1]
        what = "swapped its nodes"
    else:
        words[2] = words[1]
        what = "both ends on one node"
    return _replace(lines, k, " ".join(words)), f"line {k + 1}: {words[0]} {what}"


def m_float(lines, rng):
    """One node of an element renamed to a fresh node (left floating or dangling)."""
    elems = [(k, w) for k, w in _elements(lines) if len(w) > 2]
    if not elems:
        return None
    k, words = rng.choice(elems)
    n = min(ELEMENT_NODES.get(words[0][0].lower(), 2), len(words) - 1)
    if n < 1:
        return None
    i = rng.randint(1, n)
    words = list(words)
    words[i] = "fz_fresh"
    return _replace(lines, k, " ".join(words)), f"line {k + 1}: {words[0]} node {i} -> fz_fresh"


def m_delete(lines, rng):
    """An element deleted."""
    elems = _elements(lines)
    if len(elems) < 2:
        return None
    k, words = rng.choice(elems)
    return lines[:k] + lines[k + 1:], f"line {k + 1}: deleted {words[0]}"


def m_parallel(lines, rng):
    """A voltage source doubled in parallel with another value (a loop of sources), or an inductor across it."""
    elems = [(k, w) for k, w in _elements(lines, "vle") if len(w) > 3]
    if not elems:
        return None
    k, words = rng.choice(elems)
    choice = rng.random()
    if choice < 0.6:
        extra = f"Vfzdup {words[1]} {words[2]} dc 1.234"
    elif choice < 0.8:
        extra = f"Lfzdup {words[1]} {words[2]} 1u"
    else:
        extra = f"Cfzdup {words[1]} {words[2]} 1p\nVfzser {words[1]} fzmid 0\nCfzser fzmid {words[2]} 1p"
    return lines[:k + 1] + extra.split("\n") + lines[k + 1:], f"after line {k + 1}: added '{extra}'"


def _analysis_lines(lines):
    return [(k, w) for k, w in _cards(lines)
            if w[0].lower() in (".tran", ".ac", ".dc", ".noise", ".tf", ".sens", ".pz", ".four", ".fourier", ".op")]


def m_analysis(lines, rng):
    """An analysis card's numbers made zero, negative, reversed, tiny or huge."""
    cards = _analysis_lines(lines)
    if not cards:
        return None
    k, words = rng.choice(cards)
    head = words[0].lower()
    words = list(words)
    nums = [i for i in range(1, len(words)) if _NUMBER.match(words[i])]
    r = rng.random()
    if head == ".tran" and len(nums) >= 2 and r < 0.3:
        words[nums[0]], words[nums[1]] = words[nums[1]], words[nums[0]]
        what = "tstep and tstop swapped"
    elif len(nums) >= 2 and r < 0.5:
        i, j = nums[-2], nums[-1]
        words[i], words[j] = words[j], words[i]
        what = "last two numbers swapped"
    elif nums:
        i = rng.choice(nums)
        words[i] = rng.choice(("0", "-1", "1e-300", "1e300", "1e12", "0.5", "-1e-9"))
        what = f"word {i} -> {words[i]}"
    else:
        return None
    return _replace(lines, k, " ".join(words)), f"line {k + 1}: {head} {what}"


def m_add_analysis(lines, rng):
    """An analysis the netlist may lack, with sensible or bad arguments, on its nodes and sources."""
    nodes = _nodes(lines)
    vs = _sources(lines, "v") or ["vnone"]
    isrc = _sources(lines, "vi")
    n = rng.choice(nodes)
    v = rng.choice(vs)
    src = rng.choice(isrc) if isrc else "vnone"
    cards = [
        ".op",
        ".ac dec 10 1 1meg", ".ac lin 0 1 1k", ".ac dec 10 0 1k", ".ac oct 5 1k 10",
        f".tf v({n}) {src}", f".tf i({v}) {src}", f".tf v({n}) nosuchsrc",
        f".noise v({n}) {src} dec 5 1 1meg", f".noise v({n}) {src} dec 5 10 1", f".noise v({n}) {v} lin 0 1 10",
        f".sens v({n})", f".sens i({v})", f".sens v({n}) ac dec 5 1 1k",
        f".pz {n} 0 {n} 0 vol pz", f".pz {n} 0 {n} 0 cur pol", f".pz {n} 0 {n} {n} vol zer",
        f".dc {src} 0 1 0.1", f".dc {src} 1 0 0.1", f".dc {src} 0 1 0", f".dc {src} 0 1 -0.1", f".dc {src} 0 1e9 1e-3",
        ".dc temp -300 100 50", ".dc temp 27 27 0",
        ".tran 1n 10n", ".tran 10n 1n", ".tran 0 1u", ".tran 1n 0", ".tran -1n 1u", ".tran 1n 1u 2u",
        ".tran 1n 1u 0 1e-30", ".tran 1p 1", ".tran 1n 1u uic",
        f".four 1k v({n})", f".four 0 v({n})", f".four -1 v({n})", ".four 1k v(nosuchnode)",
        f".tran 1u 1m\n.four 1k 0 v({n})",
    ]
    card = rng.choice(cards)
    return _append(lines, card), f"appended '{card}'"


def m_directive(lines, rng):
    """A control card pointing nowhere or out of range: .ic/.nodeset on missing nodes, .meas, .save, .step, .options, .temp."""
    nodes = _nodes(lines)
    n = rng.choice(nodes)
    v = rng.choice(_sources(lines, "v") or ["vnone"])
    params = [w[1].split("=")[0] for _, w in _cards(lines) if w[0].lower() == ".param" and len(w) > 1]
    p = rng.choice(params) if params else "fzp"
    cards = [
        ".ic v(nosuchnode)=1", f".ic v({n})=1e300", f".ic v({n})={{0/0}}", ".nodeset v(nosuchnode)=1",
        f".nodeset v({n})=-1e300", f".ic i({v})=1",
        ".meas tran fzm max v(nosuchnode)", ".meas tran fzm avg v(1) from=1 to=0", ".meas ac fzm max vdb(nosuch)",
        f".meas tran fzm when v({n})=1e300", f".meas tran fzm trig v({n}) val=0 rise=1000 targ v({n}) val=1 fall=1",
        f".meas dc fzm find v({n}) at=-1e300", f".meas tran fzm integ v({n}) from=0 to=0",
        ".meas tran fzm param='1/0'", f".meas op fzm find v({n})", ".meas tran fzm deriv v(nosuch) at=0",
        ".save junk", ".save v(nosuch) i(nosuch) @nosuch[x]", f".save v({n},nosuch)", ".save @r1[zz]", ".save all @",
        ".print tran v(nosuch)", ".probe i(nosuch)",
        f".step param {p} 1 1e9 1", f".step param {p} 1 0 1", f".step param {p} 1 2 0", f".step param {p} list",
        f".step dec param {p} 0 1 10", f".step {v} 0 1 0.5", ".step temp -300 0 100",
        ".options reltol=0", ".options reltol=-1", ".options abstol=1e300", ".options gmin=-1", ".options gmin=0",
        ".options method=junk", ".options maxord=0", ".options maxord=99", ".options itl1=0", ".options itl4=-1",
        ".options temp=-300", ".options tnom=-274", ".options vntol=0", ".options chgtol=-1", ".options trtol=0",
        ".options maxstep=0", ".options minstep=1", ".options gminsteps=-1", ".options srcsteps=1e12",
        ".temp -300", ".temp -273.15", ".temp 1e6", ".temp {0/0}",
        f".param {p}={{0/0}}", f".param {p}=1e300", f".param {p}=-1",
        f".global {n}", ".end",
    ]
    card = rng.choice(cards)
    return _append(lines, card), f"appended '{card}'"


def m_source(lines, rng):
    """A waveform of an independent source given bad numbers."""
    elems = _elements(lines, "vi")
    if not elems:
        return None
    k, words = rng.choice(elems)
    name, a, b = words[0], words[1], words[2]
    form = rng.choice((
        "pulse(0 1 0 0 0 0 0)", "pulse(0 1 -1 1n 1n 1u 0)", "pulse(0 1 0 -1n 1n 1u 2u)", "pulse(0 1e300 0 1n 1n 1u 2u)",
        "sin(0 1 0)", "sin(0 1 -1k)", "sin(0 1 1e300)", "sin(0 1 1k 0 -1e9)", "exp(0 1 0 0 0 0)",
        "exp(0 1 1u -1u 2u 1u)", "pwl(0 0 0 1 0 2)", "pwl(1 0 0 1)", "pwl(0 0)", "pwl(0 {0/0} 1 1)",
        "sffm(0 1 0 0 0)", "am(1 0 0 0 0)", "dc {0/0}", "dc 0 ac 1e300", "ac 1 {0/0}",
        "trnoise(0 0 0 0)", "trnoise(1 -1n 0 0)", "trrandom(1 0 0 1 0)",
    ))
    return _replace(lines, k, f"{name} {a} {b} {form}"), f"line {k + 1}: {name} -> {form}"


def _replace(lines, k, new):
    return lines[:k] + [new] + lines[k + 1:]


def _append(lines, cards: str):
    """``cards`` (lines separated by newlines) added before the top-level ``.end`` (what follows it is not read)."""
    end = next((k for k in range(len(lines) - 1, 0, -1) if lines[k].strip().lower() == ".end"), len(lines))
    return lines[:end] + cards.split("\n") + lines[end:]


#: The mutation operators and their weights.
MUTATIONS = {
    "value": (m_value, 4), "model": (m_model, 2), "swap": (m_swap, 1), "float": (m_float, 1),
    "delete": (m_delete, 1), "parallel": (m_parallel, 1), "analysis": (m_analysis, 2),
    "add_analysis": (m_add_analysis, 3), "directive": (m_directive, 3), "source": (m_source, 2),
}


def mutate(lines: list[str], rng: random.Random, rounds: int) -> tuple[list[str], list[str]]:
    """Apply ``rounds`` mutations chosen by weight; the new lines and what was done."""
    names = list(MUTATIONS)
    weights = [MUTATIONS[n][1] for n in names]
    done = []
    for _ in range(rounds):
        for _attempt in range(6):
            name = rng.choices(names, weights)[0]
            out = MUTATIONS[name][0](lines, rng)
            if out is not None:
                lines, what = out
                done.append(f"{name}: {what}")
                break
    return lines, done


# ---------------------------------------------------------------------------------------------------------------
# sources

def collect(sources, only=None, max_bytes=60_000) -> list[Path]:
    """Top-level netlists under the sources: an analysis card, netdae reads them (checked in this process)."""
    import netdae
    from netdae.errors import NetdaeError

    files = []
    for src in sources:
        src = Path(src)
        if src.is_file():
            files.append(src)
        elif src.is_dir():
            files += sorted(p for p in src.rglob("*") if p.is_file() and p.suffix.lower() in NETLIST_SUFFIXES)
    if only:
        files = [f for f in files if any(s in str(f) for s in only)]
    good = []
    for f in files:
        try:
            text = f.read_text(errors="replace")
        except OSError:
            continue
        if not re.search(r"^\s*\.(tran|ac|dc|op|noise|tf|sens|pz)\b", text, re.IGNORECASE | re.MULTILINE):
            continue
        if re.search(r"^\s*a\w*\s", text, re.IGNORECASE | re.MULTILINE) or len(text) > max_bytes:
            continue  # XSPICE code models: out of netdae's scope
        try:
            netdae.load(str(f))
        except (NetdaeError, OSError, RecursionError):
            continue
        except Exception:  # noqa: BLE001 - the reader's own bug: report it, do not mutate it
            print(f"reader bug on the unmutated {f}:\n{traceback.format_exc()}", file=sys.stderr)
            continue
        good.append(f)
    return good


# ---------------------------------------------------------------------------------------------------------------
# running one command

FAILURE_WORDS = ("Traceback", "this is a bug in netdae")


def _child(argv, out_path, err_path, cpu, memory_gb):
    """In the forked child: limits, streams to files, the command line in process; never returns."""
    try:
        os.setsid()
        resource.setrlimit(resource.RLIMIT_CPU, (int(cpu), int(cpu) + 2))
        gb = int(memory_gb * 2 ** 30)
        resource.setrlimit(resource.RLIMIT_AS, (gb, gb))
        fo = os.open(out_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        fe = os.open(err_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fo, 1)
        os.dup2(fe, 2)
        sys.stdout = os.fdopen(1, "w", buffering=1)
        sys.stderr = os.fdopen(2, "w", buffering=1)
        from netdae.cli import main

        try:
            code = main(argv)
        except BaseException:  # NETDAE_DEBUG=1: the CLI re-raises what it would call a bug
            traceback.print_exc()
            code = 3
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(int(code))
    except BaseException:  # noqa: BLE001 - the child must never return into the parent's loop
        try:
            traceback.print_exc()
            sys.stderr.flush()
        finally:
            os._exit(99)


def run_command(argv, workdir: Path, cpu: float, memory_gb: float, spawn: bool) -> dict:
    """One command line in its own process; exit status, stderr, wall time, and the verdict."""
    out_path, err_path = workdir / "stdout.txt", workdir / "stderr.txt"
    wall = cpu * 3 + 30
    t0 = time.perf_counter()
    if spawn:
        env = dict(os.environ, NETDAE_SERVER="0", NETDAE_DEBUG="1", PYTHONPATH=str(ROOT))

        def limits():
            os.setsid()
            resource.setrlimit(resource.RLIMIT_CPU, (int(cpu), int(cpu) + 2))
        with open(out_path, "w") as fo, open(err_path, "w") as fe:
            proc = subprocess.Popen([sys.executable, "-m", "netdae", *argv], stdout=fo, stderr=fe, env=env,
                                    cwd=workdir, preexec_fn=limits)
            try:
                status = proc.wait(timeout=wall)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                status = proc.wait()
        pid = None
    else:
        pid = os.fork()
        if pid == 0:
            _child(argv, out_path, err_path, cpu, memory_gb)
        deadline = time.monotonic() + wall
        status = None
        while status is None:
            done, raw = os.waitpid(pid, os.WNOHANG)
            if done:
                status = os.waitstatus_to_exitcode(raw)
            elif time.monotonic() > deadline:
                os.killpg(pid, signal.SIGKILL)
                _, raw = os.waitpid(pid, 0)
                status = os.waitstatus_to_exitcode(raw)
            else:
                time.sleep(0.02)
    wall_s = time.perf_counter() - t0
    err = err_path.read_text(errors="replace")
    if status in (-signal.SIGXCPU, -signal.SIGKILL):
        verdict = "timeout"
    elif status < 0 or status == 99:
        verdict = "failure"
    elif status == 3 or any(w in err for w in FAILURE_WORDS):
        verdict = "failure"
    elif "RuntimeWarning" in err or "ComplexWarning" in err:
        verdict = "noise"
    else:
        verdict = "ok"
    return {"argv": argv, "status": status, "verdict": verdict, "wall_s": round(wall_s, 2), "stderr": err[-6000:]}


def signature(rec: dict) -> str:
    """What makes two failures the same: the exception type and the innermost frame inside netdae."""
    err = rec["stderr"]
    if rec["status"] is not None and rec["status"] < 0:
        return f"signal {-rec['status']}"
    frames = re.findall(r'File "([^"]*netdae/[^"]*)", line \d+, in (\w+)', err)
    last = err.strip().splitlines()[-1] if err.strip() else ""
    exc = re.match(r"^([\w.]+(?:Error|Exception|Warning|Interrupt))\b", last)
    kind = exc.group(1) if exc else re.sub(r"\d+(\.\d+)?(e[-+]?\d+)?", "#", last)[:80]
    where = f"{Path(frames[-1][0]).relative_to(ROOT) if frames[-1][0].startswith(str(ROOT)) else frames[-1][0]}" \
            f":{frames[-1][1]}" if frames else "?"
    return f"{kind} at {where}"


# ---------------------------------------------------------------------------------------------------------------

def warm_up() -> None:
    """Import the command line and load the compiled engine once, so that every forked child starts warm."""
    import netdae
    import netdae.cli  # noqa: F401

    text = "warm\nv1 1 0 pulse(0 1 0 1n 1n 1u 2u)\nr1 1 2 1k\nc1 2 0 1n\nd1 2 0 dmod\n.model dmod d\n" \
           ".tran 10n 1u\n.ac dec 2 1 1k\n.end\n"
    netdae.run(netdae.load(text))
    for module in ("netdae.cli.run", "netdae.cli.check", "netdae.cli.index", "netdae.io.csv", "netdae.io.raw",
                   "netdae.analyses.noise", "netdae.analyses.pz", "netdae.analyses.sens", "netdae.analyses.tf",
                   "netdae.topology", "netdae.sweeps"):
        try:
            __import__(module)
        except ImportError:
            pass


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sources", nargs="*", help="netlist files or directories (default: netlists/, tests/data/, "
                                                "/work/corpus)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=300, help="mutants to run")
    ap.add_argument("--rounds", type=int, default=0, help="mutations per mutant (0: 1 or 2 at random)")
    ap.add_argument("--cpu", type=float, default=20.0, help="CPU seconds per command")
    ap.add_argument("--memory-gb", type=float, default=3.0)
    ap.add_argument("--commands", default=",".join(COMMANDS))
    ap.add_argument("--out", default="fuzz-out", help="directory for the failures and the report")
    ap.add_argument("--spawn", action="store_true", help="a fresh interpreter per command instead of a fork")
    ap.add_argument("--only", action="append", help="only sources whose path contains this")
    ap.add_argument("--max-bytes", type=int, default=60_000,
                    help="skip netlists longer than this (the large gate-level circuits mostly hit the CPU limit)")
    ap.add_argument("--operators", help="comma-separated mutation operators (default: all)")
    args = ap.parse_args(argv)

    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    os.environ["NETDAE_SERVER"] = "0"
    os.environ["NETDAE_DEBUG"] = "1"
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.path.insert(0, str(ROOT))
    if args.operators:
        keep = set(args.operators.split(","))
        for name in list(MUTATIONS):
            if name not in keep:
                del MUTATIONS[name]
    sources = args.sources or [s for s in DEFAULT_SOURCES if s.exists()]
    files = collect(sources, args.only, args.max_bytes)
    print(f"{len(files)} readable netlists with an analysis", file=sys.stderr)
    if not files:
        return 2
    if not args.spawn:
        warm_up()
    commands = args.commands.split(",")
    out = Path(args.out)
    (out / "failures").mkdir(parents=True, exist_ok=True)
    rng = random.Random(args.seed)
    records = []
    counts = Counter()
    by_signature: dict[str, list[int]] = defaultdict(list)
    t_start = time.perf_counter()
    for number in range(args.count):
        base = rng.choice(files)
        lines = absolute_includes(logical_lines(base.read_text(errors="replace")), base.parent.resolve())
        rounds = args.rounds or rng.choice((1, 1, 2))
        mutant, done = mutate(lines, rng, rounds)
        with tempfile.TemporaryDirectory(prefix="netdae-fuzz-") as tmp:
            tmp = Path(tmp)
            path = tmp / f"mutant{number:04d}.cir"
            path.write_text("\n".join(mutant) + "\n")
            for cmd in commands:
                argv = [cmd, str(path)] + EXTRA_ARGUMENTS.get(cmd, []) + (
                    ["--out", str(tmp / "out")] if cmd in ("run", "sweep") else [])
                if cmd == "sweep":  # three temperatures recording a node of the mutant (else, without a .meas
                    # card or a random draw, the sweep refuses at once: nothing to record, nothing to vary)
                    argv += ["--step", "temp=0:50:25", "--save", f"v({_nodes(mutant)[0]})"]
                rec = run_command(argv, tmp, args.cpu, args.memory_gb, args.spawn)
                rec.update(number=number, source=str(base), mutation=done)
                counts[rec["verdict"]] += 1
                if rec["verdict"] == "failure":
                    sig = signature(rec)
                    rec["signature"] = sig
                    by_signature[sig].append(number)
                    keep = out / "failures" / f"{number:04d}.cir"
                    shutil.copy(path, keep)
                    rec["mutant"] = str(keep)
                    (out / "failures" / f"{number:04d}-{cmd}.json").write_text(json.dumps(rec, indent=1))
                    print(f"[{number}] FAILURE {cmd} {base.name} {done}: {sig}", file=sys.stderr)
                elif rec["verdict"] == "timeout":
                    print(f"[{number}] timeout {cmd} {base.name} {done}", file=sys.stderr)
                rec.pop("stderr") if rec["verdict"] in ("ok",) else None
                records.append(rec)
        if (number + 1) % 25 == 0 or number + 1 == args.count:
            print(f"... {number + 1} mutants, {dict(counts)}, {time.perf_counter() - t_start:.0f} s",
                  file=sys.stderr)
            summary = {"seed": args.seed, "mutants": number + 1, "commands": commands, "verdicts": dict(counts),
                       "failures": {sig: nums for sig, nums in sorted(by_signature.items())},
                       "seconds": round(time.perf_counter() - t_start)}
            (out / "report.json").write_text(json.dumps({"summary": summary, "records": records}, indent=1))
    print(json.dumps(summary, indent=1))
    return 1 if by_signature else 0


if __name__ == "__main__":
    sys.exit(main())
