"""The compiled engine's costs: start-up, loading the compiled loop, and a step in a warm process.

Usage::

    python benchmarks/engine.py [--reps N] [--only NAMES]

Prints three tables (docs/performance.md quotes them):

1. start-up, each in a fresh process (median of ``--reps``): the interpreter,
   ``import numpy``, ``import scipy.sparse``, ``import numba``, ``import
   netdae.analyses.tran``, and the first transient of a process split into
   the loading of the compiled loop (``load_time``: numba's target
   initialisation and its cache) and the rest;
2. the transient of each benchmark circuit in a warm process (the compiled
   loop loaded; best of ``--reps``): the integrator's time, per accepted step,
   and the whole ``netdae.simulate`` (operating point and structure analysis
   included), with the step counts;
3. ngspice's transient time of the same netlists (``.options acct``), per
   accepted step, for the ratio;
4. a ``.dc`` transfer curve of the CMOS inverter (10,001 points) in a warm
   process (best CPU of the reps) against ngspice's "Total analysis time" of
   the same netlist (best of the reps);
5. an ``.ac`` sweep of a 2,000-section RC ladder (2,002 unknowns, 1,201
   frequencies), measured the same way.

Times are CPU-bound medians/minima on a shared machine: quote ranges from
several runs.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import circuits as C  # noqa: E402
from benchmarks import measure as M  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

_IMPORTS = {
    "python -c pass": "pass",
    "import numpy": "import numpy",
    "import scipy.sparse": "import scipy.sparse",
    "import numba": "import numba",
    "import netdae.analyses.tran": "import netdae.analyses.tran",
}

_FIRST = """
import json, sys, time
t0 = time.perf_counter()
import netdae
c = netdae.load(sys.argv[1])
t1 = time.perf_counter()
r = netdae.simulate(c)
t2 = time.perf_counter()
i = r.stats["integrator"]
print(json.dumps({"imports_and_read": t1 - t0, "simulate": t2 - t1, "load": i.get("load_time", 0.0),
                  "integration": i["wall_time"] - i.get("load_time", 0.0)}))
"""

_WARM = """
import json, sys, time
import netdae
c = netdae.load(sys.argv[1])
netdae.simulate(c)
best = None
for _ in range(int(sys.argv[2])):
    t0 = time.perf_counter()
    r = netdae.simulate(c)
    t1 = time.perf_counter()
    i = r.stats["integrator"]
    row = {"simulate": t1 - t0, "integration": i["wall_time"], "steps": r.stats["steps"],
           "newton": r.stats["newton_iterations"], "rejected": r.stats["rejected"]}
    if best is None or row["integration"] < best["integration"]:
        best = row
print(json.dumps(best))
"""


_SWEEP = """
import importlib, json, sys, time
import netdae
module, function, card_class = sys.argv[3].split(":")
analysis = getattr(importlib.import_module(module), function)
kind = getattr(importlib.import_module("netdae.circuit"), card_class)
c = netdae.load(sys.argv[1])
card = next(a for a in c.analyses if isinstance(a, kind))
analysis(c, card)
best = None
for _ in range(int(sys.argv[2])):
    t0 = time.process_time()
    r = analysis(c, card)
    row = {"cpu": time.process_time() - t0, "points": int(r.axis.size), "newton": int(r.stats["newton_iterations"]),
           "unknowns": int(r.stats["n_unknowns"])}
    if best is None or row["cpu"] < best["cpu"]:
        best = row
print(json.dumps(best))
"""

#: The AC sweep: an RC ladder of this many sections, 200 points a decade from 1 kHz to 1 GHz.
AC_SECTIONS = 2000


def ac_netlist(simulator: str) -> str:
    """The RC ladder's ``.ac`` netlist (ngspice: ``.options acct``)."""
    lines = ["RC ladder, .ac", "V1 n0 0 DC 0 AC 1"]
    for k in range(AC_SECTIONS):
        lines += [f"R{k} n{k} n{k + 1} 10", f"C{k} n{k + 1} 0 1n"]
    lines += [".ac dec 200 1k 1g", f".save v(n{AC_SECTIONS})"]
    lines += ([".options acct"] if simulator == "ngspice" else []) + [".end"]
    return "\n".join(lines) + "\n"


#: The DC sweep: the CMOS inverter's transfer curve, 10,001 points.
DC_POINTS_STEP = 0.0005


def dc_netlist(simulator: str) -> str:
    """``netlists/cmos_inverter.cir`` with only its ``.dc`` card, 10,001 points (ngspice: ``.options acct``)."""
    lines = []
    for line in (ROOT / "netlists" / "cmos_inverter.cir").read_text().splitlines():
        card = line.strip().lower().split()[:1]
        if card in ([".tran"], [".op"], [".end"]):
            continue
        if card == [".dc"]:
            parts = line.split()
            line = " ".join(parts[:4] + [f"{DC_POINTS_STEP:g}"])
        lines.append(line)
    lines += [".save v(out)"] + ([".options acct"] if simulator == "ngspice" else []) + [".end"]
    return "\n".join(lines) + "\n"


#: What each sweep row of :func:`analysis_sweep` runs: its netlist, netdae's function and card class.
SWEEPS = {"dc": (dc_netlist, "netdae.analyses.dc:dc_sweep:DcAnalysis"),
          "ac": (ac_netlist, "netdae.analyses.ac:ac_analysis:AcAnalysis")}


def analysis_sweep(name: str, reps: int, tmp: Path) -> tuple[dict, float]:
    """netdae's best CPU of the ``.dc`` or ``.ac`` sweep (``name``) in a warm process, and ngspice's best
    analysis time of the same netlist."""
    netlist, target = SWEEPS[name]
    nd_path, ng_path = tmp / f"{name}_netdae.cir", tmp / f"{name}_ngspice.cir"
    nd_path.write_text(netlist("netdae"))
    ng_path.write_text(netlist("ngspice"))
    nd = _child(_SWEEP, nd_path, reps, target)
    exe = M.shutil.which("ngspice") or "ngspice"
    times = []
    for _ in range(reps):
        done = M.run_child([exe, "-b", "-n", "-r", str(tmp / f"{name}.raw"), str(ng_path)], cwd=tmp, timeout=600)
        times.append(M.parse_acct(done.stdout + done.stderr).get("analysis_time", float("nan")))
    return nd, min(times)


def _child(code: str, *args) -> dict | float:
    done = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, env={**M.CHILD_ENV, **_env()}, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1]) if done.stdout.strip() else 0.0


def _env():
    import os

    return {k: v for k, v in os.environ.items()}


def startup(reps: int) -> list[tuple[str, float]]:
    import time

    rows = []
    for label, code in _IMPORTS.items():
        walls = []
        for _ in range(reps):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)
            walls.append(time.perf_counter() - t0)
        rows.append((label, statistics.median(walls)))
    firsts = [_child(_FIRST, ROOT / "netlists" / "rc_lowpass.cir") for _ in range(reps)]
    for key in ("imports_and_read", "load", "integration", "simulate"):
        rows.append((f"rc_lowpass first transient: {key}", statistics.median(f[key] for f in firsts)))
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--only", default="", help="comma-separated circuit names (default: the small nonlinear ones)")
    args = p.parse_args(argv)
    benches = [C.bridge_rectifier(50), C.voltage_multiplier(4, 50), C.ring_oscillator(11, 50e-9), C.pulse_train(50)]
    if args.only:
        keys = args.only.split(",")
        benches = [b for b in benches if any(k in b.name for k in keys)]
    print("start-up (fresh processes, median):")
    for label, value in startup(args.reps):
        print(f"  {label:<45} {value * 1e3:8.1f} ms")
    print("\ntransient in a warm process (best integration of the reps) against ngspice's transient time:")
    print(f"  {'circuit':<22} {'variant':<8} {'steps':>7} {'integr. ms':>10} {'us/step':>8} {'simulate ms':>11}"
          f" {'ngspice steps':>13} {'ngspice ms':>10} {'us/step':>8} {'ratio':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for bench in benches:
            for tight in (False, True):
                d = Path(tmp) / f"{bench.name}-{tight}"
                d.mkdir()
                nd_path = d / "netdae.cir"
                nd_path.write_text(bench.netlist(tight, "netdae"))
                ng_path = d / "ngspice.cir"
                ng_path.write_text(bench.netlist(tight, "ngspice"))
                nd = _child(_WARM, nd_path, args.reps)
                ng_times = []
                ng = None
                for _ in range(args.reps):
                    ng = M.run_ngspice(ng_path, d, bench.signals, timeout=600)
                    ng_times.append(ng.stats.get("tran_time", float("nan")))
                ng_t = min(ng_times)
                ng_steps = ng.stats.get("steps", 0)
                ratio = nd["integration"] / ng_t if ng_t else float("nan")
                print(f"  {bench.name:<22} {'tight' if tight else 'default':<8} {nd['steps']:>7} "
                      f"{nd['integration'] * 1e3:>10.1f} {nd['integration'] / nd['steps'] * 1e6:>8.2f} "
                      f"{nd['simulate'] * 1e3:>11.1f} {ng_steps:>13} {ng_t * 1e3:>10.1f} "
                      f"{ng_t / max(ng_steps, 1) * 1e6:>8.2f} {ratio:>6.2f}")
        nd, ng_t = analysis_sweep("dc", args.reps, Path(tmp))
        print("\n.dc transfer curve of the CMOS inverter in a warm process (best CPU) against ngspice's analysis time:")
        print(f"  netdae {nd['cpu'] * 1e3:.0f} ms for {nd['points']} points ({nd['cpu'] / nd['points'] * 1e6:.0f} us "
              f"per point, {nd['newton']} Newton iterations); ngspice {ng_t * 1e3:.0f} ms "
              f"({ng_t / nd['points'] * 1e6:.1f} us per point); ratio {nd['cpu'] / ng_t:.1f}x")
        nd, ng_t = analysis_sweep("ac", args.reps, Path(tmp))
        print(f"\n.ac of a {AC_SECTIONS:,}-section RC ladder in a warm process (best CPU) against ngspice's "
              "analysis time:")
        print(f"  netdae {nd['cpu'] * 1e3:.0f} ms for {nd['points']} frequencies of {nd['unknowns']} unknowns "
              f"({nd['cpu'] / nd['points'] * 1e6:.0f} us per frequency); ngspice {ng_t * 1e3:.0f} ms "
              f"({ng_t / nd['points'] * 1e6:.0f} us per frequency); ratio {nd['cpu'] / ng_t:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
