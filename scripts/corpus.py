#!/usr/bin/env python3
"""How many public ngspice netlists netdae reads and runs: a measurement over a corpus directory.

Usage::

    python scripts/corpus.py CORPUS_DIR [--compare] [--timeout 60] [--jobs 2]
                             [--json report.json] [--markdown report.md] [--docs docs/validation.md]
                             [--only SUBSTRING ...]

``CORPUS_DIR`` is a directory of netlists kept outside the repository (for
instance the ``examples/`` and ``tests/`` trees of ngspice's sources, with
their layout kept so that ``.include`` names resolve). Every file whose
suffix is a netlist's (:data:`SUFFIXES`) is classified:

1. statically, from its text and the files it includes: *not a top-level
   netlist* (no analysis card and no analysis command in a ``.control``
   block: an include or library file), *incomplete* (an ``.include``/``.lib``
   file the corpus lacks, so ngspice cannot run it either), or *out of scope*
   (the reason: XSPICE code models, digital U devices, CIDER numerical
   devices, S-parameter analysis and RF ports, PSS, BSIM/SOI/HiSIM/PSP
   MOSFET levels);
2. then, in its own process (``NETDAE_SERVER=0``, a CPU and a wall-clock
   limit, so that a hang or a crash is contained), by what netdae does with
   it: ``netdae.load`` (what ``netdae check`` does), then every analysis
   (``netdae.run``; a ``.step`` netlist through ``netdae.sweep``) and, with
   ``--compare``, ``netdae.compare`` against ngspice.

The outcome of an in-scope netlist is one of: *runs* (and, compared,
*agrees* / *disagrees* / *ngspice failed*), *refused* with a named
unsupported feature (bucketed by feature), *refused unclearly* (a netlist
error that does not say which feature netdae lacks), *run failed* (a
convergence or circuit error while simulating), *timeout*, *internal error*
(a traceback) or *crash* (the process died).

The summary is printed; ``--json`` writes every file's record, ``--markdown``
the tables, and ``--docs`` puts them into a page between the markers
:data:`BEGIN` and :data:`END` (the "Public netlists" section of
docs/validation.md).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import re
import resource
import subprocess
import sys
import time
import traceback
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: File suffixes read as netlists (then judged by their content).
SUFFIXES = frozenset({".cir", ".sp", ".net", ".spi", ".spice", ".ckt", ".deck", ".inc", ".lib", ".mod", ".sub",
                      ".cmd", ".txt"})
#: The page section written by ``--docs``.
BEGIN = "<!-- CORPUS: begin (written by scripts/corpus.py --docs) -->"
END = "<!-- CORPUS: end -->"

#: MOSFET levels netdae runs only through OSDI (BSIM, SOI, HiSIM, PSP families), by ngspice 39's numbers.
COMPACT_MOS_LEVELS = {4: "BSIM1", 5: "BSIM2", 8: "BSIM3", 49: "BSIM3", 10: "B4SOI", 58: "B4SOI", 14: "BSIM4",
                      54: "BSIM4", 55: "B3SOI", 56: "B3SOI", 57: "B3SOI", 61: "HiSIM2", 68: "HiSIM2",
                      62: "HiSIM_HV", 73: "HiSIM_HV", 69: "PSP", 103: "PSP", 44: "EKV", 45: "PSP"}
COMPACT_MOS_TYPES = re.compile(r"^(bsim\w*|b3soi\w*|b4soi\w*|hisim\w*|psp\w*)$")
CIDER_TYPES = frozenset({"numd", "nbjt", "numos"})
ANALYSIS_CARDS = frozenset({".op", ".tran", ".ac", ".dc", ".pz", ".tf", ".noise", ".sens", ".disto", ".four",
                            ".fourier", ".pss", ".sp", ".hb"})
ANALYSIS_COMMANDS = frozenset({"op", "tran", "ac", "dc", "pz", "tf", "noise", "sens", "disto", "pss", "sp", "hb",
                               "run"})
#: Words of a refusal that names what netdae does not have.
NAMED = re.compile(r"not supported|unsupported|does not (?:have|implement|support|run|read|know)|not implemented|"
                   r"netdae (?:has no|runs only|reads only|runs one|evaluates '\w+' once)|no model of|is an ngspice|"
                   r"ngspice (?:feature|only)",
                   re.IGNORECASE)

# ---------------------------------------------------------------------------------------------------------------
# static classification


def _logical_lines(text: str) -> list[str]:
    """Lines with continuations joined, comments dropped, lower case."""
    out: list[str] = []
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line[0] in "*;":
            if line[:1] != "+" or not out:
                continue
        if line.startswith("+") and out:
            out[-1] += " " + line[1:]
            continue
        for mark in (" ;", "\t;", "$ ", " $", "//"):
            k = line.find(mark)
            if k > 0:
                line = line[:k]
        out.append(line.lower())
    return out


_INCLUDE = re.compile(r"^\.(include|inc|lib)\s+(.*)$")


def _include_target(rest: str) -> str:
    rest = rest.strip()
    if rest[:1] in "'\"":
        q = rest[0]
        return rest[1:rest.find(q, 1)] if rest.find(q, 1) > 0 else rest[1:]
    return rest.split()[0] if rest else ""


def scan(path: Path, _seen: set | None = None, _top: bool = True) -> dict:
    """What a netlist file and the files it includes hold, read as text."""
    seen = _seen if _seen is not None else set()
    info = {"analysis": False, "control": False, "a": 0, "u_digital": 0, "cider": [], "rf": [], "pss": False,
            "compact": [], "missing": [], "lines": 0, "includes": []}
    try:
        raw = path.read_bytes()
    except OSError:
        info["missing"].append(str(path))
        return info
    seen.add(path.resolve())
    text = raw.decode("utf-8", errors="replace")
    lines = _logical_lines(text)
    info["lines"] = len(lines)
    body = lines[1:] if _top else lines  # the first line of a top-level netlist is its title
    in_control = False
    models: list[tuple[str, str, str]] = []
    for line in body:
        words = line.split()
        if not words:
            continue
        head = words[0]
        if head == ".control":
            in_control = True
            info["control"] = True
            continue
        if head == ".endc":
            in_control = False
            continue
        if in_control:
            if head in ANALYSIS_COMMANDS:
                info["analysis"] = True
            if head in ("sp",):
                info["rf"].append("sp command")
            if head == "pss":
                info["pss"] = True
            if head == "pre_osdi":
                pass
            continue
        if head in ANALYSIS_CARDS:
            info["analysis"] = True
        if head == ".sp":
            info["rf"].append(".sp analysis")
        if head == ".pss":
            info["pss"] = True
        if head == ".model" and len(words) >= 3:
            mtype = re.split(r"[ (]", words[2])[0]
            models.append((words[1], mtype, line))
        m = _INCLUDE.match(line)
        if m:
            target = _include_target(m.group(2))
            if m.group(1) == "lib" and not target:
                continue
            if m.group(1) == "lib" and len(m.group(2).split()) < 2 and not Path(target).suffix:
                continue  # '.lib section' opens a section of this file
            candidate = (path.parent / target) if not os.path.isabs(target) else Path(target)
            if not candidate.exists():
                # a name can be written in a case the corpus does not have; look case-insensitively
                alt = None
                if candidate.parent.is_dir():
                    alt = next((p for p in candidate.parent.iterdir() if p.name.lower() == candidate.name.lower()),
                               None)
                if alt is None:
                    info["missing"].append(target)
                    continue
                candidate = alt
            if candidate.is_dir():
                continue
            info["includes"].append(str(candidate.resolve()))
            if candidate.resolve() in seen:
                continue
            sub = scan(candidate, seen, _top=False)
            for key in ("a", "u_digital"):
                info[key] += sub[key]
            for key in ("cider", "rf", "compact", "missing", "includes"):
                info[key] += sub[key]
            info["pss"] |= sub["pss"]
            continue
        if head[0] == "a" and not head.startswith("."):
            info["a"] += 1
        elif head[0] == "u" and len(words) > 1 and (re.match(r"^[a-z_]+\s*\(", " ".join(words[1:2]))
                                                    or words[1] in {"stim", "inv", "and", "nand", "or", "nor",
                                                                     "xor", "buf", "dff", "jkff", "pullup",
                                                                     "pulldn"}):
            info["u_digital"] += 1
        elif head.startswith("v") and "portnum" in line:
            info["rf"].append("RF port (portnum)")
    for name, mtype, line in models:
        if mtype in CIDER_TYPES:
            info["cider"].append(f"{name} ({mtype})")
        elif COMPACT_MOS_TYPES.match(mtype):
            info["compact"].append(f"{name} ({mtype})")
        elif mtype in ("nmos", "pmos"):
            lv = re.search(r"\blevel\s*=?\s*([0-9.]+)", line)
            if lv:
                try:
                    level = int(float(lv.group(1)))
                except ValueError:
                    continue
                if level in COMPACT_MOS_LEVELS:
                    info["compact"].append(f"{name} (level {level}, {COMPACT_MOS_LEVELS[level]})")
    return info


def static_class(info: dict) -> tuple[str, str] | None:
    """(category, reason) decided from the text alone, or None when the netlist is to be run."""
    if not info["analysis"]:
        return "not_netlist", "no analysis card or command (an include or library file)"
    reasons = []
    if info["a"]:
        reasons.append("XSPICE code models (A elements)")
    if info["u_digital"]:
        reasons.append("digital U devices")
    if info["cider"]:
        reasons.append("CIDER numerical devices")
    if info["rf"]:
        reasons.append("S-parameters / RF ports")
    if info["pss"]:
        reasons.append("PSS analysis")
    if info["compact"]:
        kinds = sorted({re.sub(r".*\((?:level \d+, )?(\w+?)(?:v?\d+)?\)$", r"\1", c).upper()
                        for c in info["compact"]})
        reasons.append("compact MOSFET models (" + ", ".join(kinds) + ")")
    if reasons:
        return "out_of_scope", "; ".join(reasons)
    if info["missing"]:
        return "incomplete", "missing file " + ", ".join(sorted(set(info["missing"]))[:3])
    return None


# ---------------------------------------------------------------------------------------------------------------
# the worker: one netlist in its own process


def _message(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:600]


def work(path: str, compare: bool, timeout: float, emit=None) -> dict:
    """Read, run and (optionally) compare one netlist; a plain dict of what happened.

    ``emit(record)``, when given, receives the record of a netlist that ran
    before its comparison starts (the worker prints it: a comparison stopped
    by the time limit leaves the run's outcome behind).
    """
    os.environ["NETDAE_SERVER"] = "0"
    import netdae
    from netdae.errors import CircuitError, ConvergenceError, NetdaeError, NetlistError

    rec: dict = {"stage": "read"}
    t0 = time.perf_counter()
    try:
        circuit = netdae.load(path)
    except NetlistError as exc:
        rec.update(outcome="refused", error="NetlistError", message=_message(exc))
        return rec
    except NetdaeError as exc:
        rec.update(outcome="refused", error=type(exc).__name__, message=_message(exc))
        return rec
    except RecursionError as exc:
        rec.update(outcome="internal", error="RecursionError", message=_message(exc))
        return rec
    except Exception as exc:  # noqa: BLE001 - the point is to catch what netdae did not mean to raise
        rec.update(outcome="internal", error=type(exc).__name__, message=_message(exc),
                   traceback=traceback.format_exc()[-3000:])
        return rec
    rec["read_s"] = round(time.perf_counter() - t0, 3)
    rec["analyses"] = [type(a).__name__.removesuffix("Analysis").lower() for a in circuit.analyses]
    rec["elements"] = len(circuit.elements)
    rec["stage"] = "run"
    t1 = time.perf_counter()
    try:
        if circuit.steps:
            res = netdae.sweep(circuit, workers=1)
            failed = [e for e in (res.errors or []) if e]
            rec["swept_rows"] = len(res.errors or [])
        else:
            results = netdae.run(circuit)
            failed = [f"{r.analysis}: {r.message}" for r in results if r.status < 0]
        if failed:
            rec.update(outcome="run_failed", error="failed", message=_message(Exception("; ".join(failed))))
            return rec
    except NetlistError as exc:
        rec.update(outcome="refused", error="NetlistError", message=_message(exc))
        return rec
    except (ConvergenceError, CircuitError) as exc:
        rec.update(outcome="run_failed", error=type(exc).__name__, message=_message(exc))
        return rec
    except NetdaeError as exc:
        rec.update(outcome="refused", error=type(exc).__name__, message=_message(exc))
        return rec
    except Exception as exc:  # noqa: BLE001
        rec.update(outcome="internal", error=type(exc).__name__, message=_message(exc),
                   traceback=traceback.format_exc()[-3000:])
        return rec
    rec["run_s"] = round(time.perf_counter() - t1, 3)
    rec["outcome"] = "runs"
    if compare and not circuit.steps:
        rec["stage"] = "compare"
        if emit is not None:  # what ran is known even if the comparison runs out of time
            emit(dict(rec, compare="timeout", compare_message="the comparison ran out of time"))
        try:
            cmp = netdae.compare(path, timeout=timeout)
            if cmp.ngspice_error:
                rec["compare"] = "ngspice_failed"
                rec["compare_message"] = _message(Exception(cmp.ngspice_error))
            else:
                rec["compare"] = "agrees" if cmp.passed else "disagrees"
                worst = []
                for item in cmp.analyses:
                    if item.error:
                        worst.append(f"{item.analysis}: {item.error}")
                    elif item.passed is False:
                        bad = [s for s in item.signals if s.passed is False]
                        if bad:
                            s = max(bad, key=lambda s: s.max_rel)
                            worst.append(f"{item.analysis}: {s.name} max rel err {s.max_rel:.2g}")
                rec["compare_message"] = "; ".join(worst)[:600]
                if not cmp.passed:
                    # ngspice's step control at the netlist's tolerances, or the models? (compare --tight)
                    tight = netdae.compare(path, timeout=timeout, tight=True)
                    rec["compare_tight"] = "agrees" if tight.passed and not tight.ngspice_error else "disagrees"
        except Exception as exc:  # noqa: BLE001
            rec["compare"] = "error"
            rec["compare_message"] = f"{type(exc).__name__}: {_message(exc)}"
    return rec


def _limits(cpu: float, memory_gb: float):
    def apply():
        resource.setrlimit(resource.RLIMIT_CPU, (int(cpu), int(cpu) + 5))
        gb = int(memory_gb * 2 ** 30)
        resource.setrlimit(resource.RLIMIT_AS, (gb, gb))
        os.setsid()
    return apply


#: ngspice's batch output when it rejects a netlist (not a plot it cannot draw in batch mode).
NGSPICE_REJECTS = re.compile(r"Error on line|fatal error in ngspice|Simulation interrupted due to error|"
                             r"unknown device type|unimplemented control card|unrecognized analysis type|"
                             r"Error: no such function|Undefined parameter", re.IGNORECASE)


def ngspice_verdict(path: Path, timeout: float) -> str | None:
    """ngspice's first complaint about a netlist it rejects (``ngspice -b``), None when it runs it."""
    try:
        proc = subprocess.run(["ngspice", "-b", path.name], cwd=path.parent, capture_output=True, text=True,
                              timeout=timeout, stdin=subprocess.DEVNULL, errors="replace")
    except subprocess.TimeoutExpired:
        return None
    except OSError as exc:
        return f"ngspice did not start: {exc}"
    lines = (proc.stdout + "\n" + proc.stderr).splitlines()
    for k, line in enumerate(lines):
        if NGSPICE_REJECTS.search(line):
            detail = " ".join(x.strip() for x in lines[k:k + 3] if x.strip())
            return detail[:300]
    return None


def run_one(path: Path, compare: bool, timeout: float, memory_gb: float, check_ngspice: bool = False) -> dict:
    """One netlist in a child process; with ``check_ngspice`` a refusal is checked against ngspice 39."""
    rec = _run_one(path, compare, timeout, memory_gb)
    if check_ngspice and rec.get("outcome") in ("refused", "internal", "run_failed") \
            and classify(rec)[0] not in ("out_of_scope", "incomplete"):
        # a netlist ngspice still simulates after 20 s is one it accepts
        verdict = ngspice_verdict(path, 20)
        if verdict:
            rec["ngspice_rejects"] = verdict
    return rec


def _run_one(path: Path, compare: bool, timeout: float, memory_gb: float) -> dict:
    """One netlist in a child process under a CPU and a wall-clock limit."""
    env = dict(os.environ, NETDAE_SERVER="0", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", str(path), "--timeout", str(timeout)]
    if compare:
        cmd.append("--compare")
    wall = timeout * (2.5 if compare else 1.0) + 20
    t0 = time.perf_counter()
    try:
        proc = subprocess.Popen(cmd, cwd=path.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, preexec_fn=_limits(timeout * (2.5 if compare else 1.0) + 15, memory_gb))
        try:
            out, err = proc.communicate(timeout=wall)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, 9)
            out, _ = proc.communicate()
            wall_s = round(time.perf_counter() - t0, 1)
            return _last_record(out, wall_s) or {"outcome": "timeout", "wall_s": wall_s,
                                                 "message": f"no answer within {wall:.0f} s (wall clock)"}
    except OSError as exc:
        return {"outcome": "crash", "message": str(exc)}
    wall_s = round(time.perf_counter() - t0, 1)
    rec = _last_record(out, wall_s)
    if rec is not None:
        return rec
    if proc.returncode in (-9, -24) or proc.returncode == 137 or "CPU time limit" in err:
        return {"outcome": "timeout", "message": f"CPU time limit (signal {-proc.returncode})", "wall_s": wall_s}
    tail = " ".join(err.strip().splitlines()[-3:])[-400:]
    return {"outcome": "crash", "message": f"exit status {proc.returncode}: {tail}", "wall_s": wall_s}


def _last_record(out: str, wall_s: float) -> dict | None:
    """The last JSON record a worker printed (its final one, or the run's before a comparison), or None."""
    for line in reversed((out or "").splitlines()):
        if line.startswith("{"):
            try:
                rec = json.loads(line)
            except ValueError:
                break
            rec["wall_s"] = wall_s
            return rec
    return None


# ---------------------------------------------------------------------------------------------------------------
# buckets and the report

_LOCATION = re.compile(r"^\S+?:\d+:\d+:\s*")


def feature(message: str) -> str:
    """The feature a named refusal names, as a short bucket key."""
    msg = _LOCATION.sub("", message)
    msg = re.split(r" \((?:expected|hint):", msg)[0]
    patterns = [
        (r"was skipped because (.*?)(?:; netdae (?:does not run|runs a subset)|$)",
         lambda m: f".control analyses skipped: {m.group(1)}"),
        (r"\.control: '(\w+)'", lambda m: f"{m.group(1)} analysis (.control)"),
        (r"(\.\w+) \(([^)]*)\) is not supported", lambda m: f"{m.group(2)} ({m.group(1)})"),
        (r"^\w+: (.*?) \((\w)\) (?:is not supported|element)", lambda m: f"{m.group(1)} ({m.group(2).upper()})"),
        (r"(\w[\w ./-]*?) (?:is|are) not supported", lambda m: m.group(1)),
    ]
    for pat, key in patterns:
        m = re.search(pat, msg, re.IGNORECASE)
        if m:
            return key(m)
    msg = re.sub(r"^[\w.:#]+: ", "", msg)
    msg = re.sub(r"'[^']*'", "'…'", msg)
    msg = re.sub(r"\b\d[\w.+-]*", "N", msg)
    return msg[:110]


#: Refusals that say a feature is out of scope: the reader found what the text scan did not (a model level in a
#: library section, an element in a file the scan could not resolve).
OUT_OF_SCOPE_MESSAGES = (
    (re.compile(r"MOSFET level \d+ \((BSIM\w*|B\dSOI\w*|HiSIM\w*|PSP\w*)"),
     lambda m: f"compact MOSFET models ({re.sub(r'[0-9]+$', '', m.group(1)).upper()}, found by the reader)"),
    (re.compile(r"\(XSPICE code model\)"), lambda m: "XSPICE code models (A elements)"),
)
#: A refusal because the corpus lacks a file the netlist names (ngspice cannot run it either).
MISSING_FILE = re.compile(r"(?:file|OSDI file) '?(.+?)'? (?:not found|does not exist)")
#: Files whose refusal was reviewed by hand: the netlist is deliberately wrong, and ngspice reports it too.
REVIEWED = {
    "examples/measure/buggy-meas-tran.sp": "a deliberately malformed .meas card (ngspice: unrecognized analysis "
                                           "type 'tra')",
    "examples/probe/mos-test.cir": "deliberately malformed .probe cards ('many buggy .probe commands')",
    "examples/inductive-systems/positive-definite-1.cir": "an inductance matrix that is not positive definite "
                                                          "(ngspice reports it)",
    "examples/inductive-systems/positive-definite-2.cir": "an inductance matrix that is not positive definite "
                                                          "(ngspice reports it)",
    "tests/regression/misc/empty-1.cir": "a circuit without elements (ngspice's edge-case test; netdae says there "
                                         "is nothing to simulate)",
}


def classify(rec: dict, rel: str = "") -> tuple[str, str]:
    """(category, bucket) of a record."""
    out = rec["outcome"]
    if out in ("not_netlist", "incomplete", "out_of_scope"):
        return out, rec["reason"]
    if out == "refused":
        msg = rec.get("message", "")
        for pattern, reason in OUT_OF_SCOPE_MESSAGES:
            m = pattern.search(msg)
            if m:
                return "out_of_scope", reason(m)
        m = MISSING_FILE.search(msg)
        if m:
            return "incomplete", "missing file " + os.path.basename(m.group(1).replace("\\", "/"))
        if rel in REVIEWED:
            return "invalid", REVIEWED[rel]
        if rec.get("ngspice_rejects"):
            return "ngspice_rejects", feature(rec["ngspice_rejects"])
        if NAMED.search(msg):
            return "refused_named", feature(msg)
        return "refused_unclear", feature(msg)
    if out == "runs":
        return "runs", rec.get("compare", "")
    if out == "run_failed" and NAMED.search(rec.get("message", "")):
        return "refused_named", feature(rec["message"])
    return out, feature(rec.get("message", "")) if out not in ("timeout",) else rec.get("message", "")


CATEGORY_ORDER = ["runs", "refused_named", "refused_unclear", "run_failed", "no_analysis", "timeout", "internal",
                  "crash", "out_of_scope", "incomplete", "invalid", "ngspice_rejects", "not_netlist"]
#: Categories outside the in-scope count.
NOT_COUNTED = ("out_of_scope", "incomplete", "invalid", "ngspice_rejects", "not_netlist")
CATEGORY_TEXT = {
    "runs": "runs (read, elaborated, every analysis finished)",
    "refused_named": "refused, naming the unsupported feature",
    "refused_unclear": "refused, the message not naming the cause",
    "run_failed": "read, but a simulation failed (convergence, circuit)",
    "no_analysis": "read, but no analysis netdae runs",
    "timeout": "timeout",
    "internal": "internal error (traceback)",
    "crash": "process died",
    "out_of_scope": "out of scope",
    "incomplete": "incomplete in the corpus (a file it includes is missing)",
    "invalid": "a deliberately invalid netlist (ngspice reports the error too; reviewed by hand)",
    "ngspice_rejects": "refused by netdae and rejected by ngspice 39 too (newer ngspice or invalid; --check-ngspice)",
    "not_netlist": "not a top-level netlist (include/library file)",
}


def summarize(records: dict[str, dict]) -> dict:
    cats = Counter()
    buckets: dict[str, Counter] = {}
    for rel, rec in records.items():
        cat, bucket = classify(rec, rel)
        rec["category"], rec["bucket"] = cat, bucket
        cats[cat] += 1
        buckets.setdefault(cat, Counter())[bucket] += 1
    in_scope = sum(n for c, n in cats.items() if c not in NOT_COUNTED)
    runs = cats["runs"]
    compared = Counter(r.get("compare") for r in records.values() if r.get("category") == "runs" and r.get("compare"))
    compared["agrees_tight"] = sum(1 for r in records.values() if r.get("category") == "runs"
                                   and r.get("compare") == "disagrees" and r.get("compare_tight") == "agrees")
    return {"files": len(records), "categories": dict(cats), "buckets": {c: dict(b) for c, b in buckets.items()},
            "in_scope": in_scope, "runs": runs, "run_fraction": runs / in_scope if in_scope else None,
            "compared": dict(compared)}


def render(summary: dict, records: dict, command: str, ngspice: str | None, baseline: dict | None = None,
           baseline_label: str = "before") -> str:
    """The Markdown section: outcomes (next to a baseline's when given), the in-scope fraction, the buckets."""
    cats = summary["categories"]
    if baseline is not None:
        return _render_with_baseline(summary, records, command, ngspice, baseline, baseline_label)
    lines = ["## Public netlists", "",
             "How many of ngspice's own example and test netlists netdae reads, runs and agrees on: "
             f"{summary['files']} files with a netlist's suffix (`.cir .sp .net .spi .spice .ckt .deck .inc .lib "
             ".mod .sub .cmd .txt`) under `examples/` and `tests/` of ngspice's sources (`git archive HEAD "
             "examples tests` of the ngspice repository, unpacked outside netdae's tree as CORPUS). Measured with",
             "", f"    {command}", "",
             "Each file is first classified from its text and the files it includes: not a top-level netlist (no "
             "analysis card or command, or included by another file), out of scope (XSPICE code models, digital "
             "U devices, CIDER numerical devices, S-parameters and RF ports, PSS, BSIM/SOI/HiSIM/PSP MOSFET levels, "
             "which netdae runs only through OSDI), or incomplete (a file it includes is not in the corpus). "
             "The rest are read, elaborated and run by netdae (`netdae.load`, then every analysis; "
             "`NETDAE_SERVER=0`), each in a process of its own under a CPU and wall-clock limit"
             + (", and compared with " + ngspice + " (`netdae.compare`, the netlist's own tolerances, else 1e-3 of "
                "each signal's scale)" if ngspice else "") + ". A refusal is *named* when its message says which "
             "feature netdae lacks; with `--check-ngspice` a netlist netdae refuses and ngspice 39 rejects too "
             "(a newer ngspice's feature, or a deliberately broken test) is not counted in scope. In scope is "
             "everything else.", "",
             "| outcome | files |", "|---|---:|"]
    for cat in CATEGORY_ORDER:
        if cats.get(cat):
            lines.append(f"| {CATEGORY_TEXT[cat]} | {cats[cat]} |")
    frac = summary["run_fraction"]
    lines += ["", f"In scope: {summary['in_scope']}; run: {summary['runs']} ({100 * frac:.0f} %)."
              if frac is not None else ""]
    if summary["compared"]:
        c = summary["compared"]
        judged = c.get("agrees", 0) + c.get("disagrees", 0)
        lines += [f"Compared with ngspice: {c.get('agrees', 0)} agree, {c.get('disagrees', 0)} disagree"
                  + (f" ({100 * c.get('agrees', 0) / judged:.0f} % agree)" if judged else "")
                  + f", ngspice failed on {c.get('ngspice_failed', 0)}, comparison error {c.get('error', 0)}"
                  + (f", the comparison ran out of time on {c['timeout']}" if c.get("timeout") else "") + ". "
                  f"Of the disagreements {c.get('agrees_tight', 0)} agree with both simulators at tight settings "
                  "(`netdae compare --tight`: the difference was ngspice's step control); the rest are listed "
                  "below."]
    named = summary["buckets"].get("refused_named", {})
    if named:
        families = Counter()
        for key, n in named.items():
            families[_family(key)] += n
        lines += ["", "Named refusals by kind: " + ", ".join(f"{k} {n}" for k, n in families.most_common()) + "."]
    for cat, title in (("out_of_scope", "Out of scope, by reason"),
                       ("refused_named", "Refused, by the feature named"),
                       ("refused_unclear", "Refused with an unclear message"),
                       ("run_failed", "Simulation failures"),
                       ("internal", "Internal errors"),
                       ("incomplete", "Incomplete in the corpus"),
                       ("invalid", "Deliberately invalid"),
                       ("ngspice_rejects", "Rejected by ngspice 39 too")):
        b = summary["buckets"].get(cat)
        if not b:
            continue
        lines += ["", f"### {title}", "", "| reason | files |", "|---|---:|"]
        for key, n in sorted(b.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"| {key.replace('|', '/')} | {n} |")
    for verdict, title in (("disagrees", "Disagreements with ngspice"), ("ngspice_failed", "ngspice failed"),
                           ("error", "Comparison errors")):
        rows = [(rel, rec.get("compare_message", ""), rec.get("compare_tight", "")) for rel, rec in records.items()
                if rec.get("category") == "runs" and rec.get("compare") == verdict]
        if rows:
            lines += ["", f"### {title}", "", "| netlist | worst | tight |", "|---|---|---|"]
            lines += [f"| {rel} | {msg.replace('|', '/')[:160]} | {tight} |" for rel, msg, tight in rows]
    return "\n".join(lines) + "\n"


def _family(bucket: str) -> str:
    """What kind of feature a named refusal lacks: a device model, an analysis, or a netlist construct."""
    b = bucket.lower()
    if any(w in b for w in ("element type", " level ", "vdmos", "five nodes", "thermal", "excess phase")):
        return "device models or elements"
    if "analys" in b or ".control" in b:
        return "analyses and ngspice's control language"
    return "netlist constructs"


def _render_with_baseline(summary, records, command, ngspice, baseline, label) -> str:
    text = render(summary, records, command, ngspice)
    head, sep, rest = text.partition("| outcome | files |\n|---|---:|\n")
    table = [f"| outcome | {label} | now |", "|---|---:|---:|"]
    for cat in CATEGORY_ORDER:
        a, b = baseline["categories"].get(cat, 0), summary["categories"].get(cat, 0)
        if a or b:
            table.append(f"| {CATEGORY_TEXT[cat]} | {a} | {b} |")
    rest = rest[rest.index("\n\n"):]  # drop the one-column table
    frac = baseline["run_fraction"]
    before = (f"The first column is the same corpus read by netdae before the reader changes this measurement "
              f"led to (static classes and ngspice's verdicts as now): in scope {baseline['in_scope']}, run "
              f"{baseline['runs']} ({100 * frac:.0f} %). " if frac is not None else "")
    return head + "\n".join(table) + "\n\n" + before + rest.lstrip("\n")


def write_docs(page: Path, section: str) -> None:
    text = page.read_text()
    block = f"{BEGIN}\n\n{section}\n{END}"
    start, end = text.find(BEGIN), text.find(END)
    if start >= 0 and end > start:
        text = text[:start] + block + text[end + len(END):]
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    page.write_text(text)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("corpus", nargs="?", help="directory of netlists (kept outside the repository)")
    parser.add_argument("--compare", action="store_true", help="compare every netlist that runs with ngspice")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per netlist (CPU and wall clock)")
    parser.add_argument("--memory", type=float, default=3.0, help="GiB of address space per netlist")
    parser.add_argument("--jobs", type=int, default=2, help="netlists at once")
    parser.add_argument("--only", nargs="*", help="only files whose relative path contains one of these")
    parser.add_argument("--json", help="write every file's record here")
    parser.add_argument("--markdown", help="write the tables here")
    parser.add_argument("--docs", help="put the tables into this page between the CORPUS markers")
    parser.add_argument("--check-ngspice", action="store_true",
                        help="run ngspice -b on every netlist netdae refuses: one ngspice 39 rejects too is not "
                             "counted in scope")
    parser.add_argument("--records", help="summarise the records of an earlier --json file instead of running")
    parser.add_argument("--baseline", help="an earlier --json file whose outcomes are shown next to these")
    parser.add_argument("--baseline-label", default="before", help="the column title of --baseline")
    parser.add_argument("--command", help="the measuring command shown in the report (with --records)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(work(args.worker, args.compare, args.timeout,
                              emit=lambda rec: print(json.dumps(rec), flush=True))))
        return 0
    baseline = None
    if args.baseline:
        baseline = summarize(json.loads(Path(args.baseline).read_text())["files"])
    if args.records:
        data = json.loads(Path(args.records).read_text())
        records = data["files"]
        summary = summarize(records)
        command = args.command or data.get("command") or "python scripts/corpus.py " + " ".join(argv or sys.argv[1:])
        text = render(summary, records, command, data.get("ngspice"), baseline, args.baseline_label)
        print(text)
        if args.markdown:
            Path(args.markdown).write_text(text)
        if args.json:
            Path(args.json).write_text(json.dumps({**data, "summary": summary, "files": records}, indent=1))
        if args.docs:
            write_docs(Path(args.docs), text)
        return 0
    root = Path(args.corpus).resolve()
    files = sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)
    if args.only:
        files = [p for p in files if any(s in str(p.relative_to(root)) for s in args.only)]
    records: dict[str, dict] = {}
    to_run = []
    infos = {p: scan(p) for p in files}
    included_by: dict[str, str] = {}
    for p, info in infos.items():
        for target in info["includes"]:
            if target != str(p.resolve()):
                included_by.setdefault(target, str(p.relative_to(root)))
    for p in files:
        rel = str(p.relative_to(root))
        info = infos[p]
        decided = static_class(info)
        if str(p.resolve()) in included_by and (decided is None or decided[0] != "not_netlist"):
            decided = ("not_netlist", "included by another netlist")
        if decided:
            records[rel] = {"outcome": decided[0], "reason": decided[1]}
        else:
            to_run.append((rel, p))
    print(f"{len(files)} files, {len(to_run)} to run", file=sys.stderr)
    t0 = time.perf_counter()
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_one, p, args.compare, args.timeout, args.memory, args.check_ngspice): rel for rel, p in to_run}
        for k, fut in enumerate(concurrent.futures.as_completed(futures), 1):
            rel = futures[fut]
            records[rel] = fut.result()
            rec = records[rel]
            print(f"[{k}/{len(to_run)} {time.perf_counter() - t0:.0f}s] {rel}: {rec['outcome']}"
                  f"{' ' + rec['compare'] if rec.get('compare') else ''} {rec.get('message', '')[:150]}",
                  file=sys.stderr)
    records = dict(sorted(records.items()))
    summary = summarize(records)
    ngspice = None
    if args.compare:
        try:
            ngspice = subprocess.run(["ngspice", "-v"], capture_output=True, text=True, timeout=20).stdout
            ngspice = next((w for w in ngspice.split() if w.startswith("ngspice-")), "ngspice")
        except (OSError, subprocess.SubprocessError):
            ngspice = "ngspice"
    shown = [a for a in (argv if argv is not None else sys.argv[1:])]
    shown = ["CORPUS" if a == args.corpus else a for a in shown]
    command = "python scripts/corpus.py " + " ".join(shown)
    text = render(summary, records, command, ngspice, baseline, args.baseline_label)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps({"command": command, "ngspice": ngspice, "summary": summary,
                                               "files": records}, indent=1))
    if args.markdown:
        Path(args.markdown).write_text(text)
    if args.docs:
        write_docs(Path(args.docs), text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
