"""``netdae check FILE [--json]``: read a netlist and summarise what netdae understood.

Parses and elaborates the netlist (subcircuits expanded, parameters
evaluated), builds its device models as a run does (a model value a run
refuses is refused here), and prints the title, nodes, element counts by letter, models,
analyses, options and diagnostics; ``--json`` prints the same as one JSON
object. A netlist error is reported by the dispatcher as one line
``netdae: error: file:line:col: ...`` with exit status 2; with ``--json``
it is also printed as ``{"path": ..., "error": ...}``
(:func:`netdae.errors.error_record`: its type, message, file, line, column,
hint and what it names).

The summary is built by :func:`summarize` (a plain dict) and printed by
:func:`format_summary`; :func:`main` adds the topological findings
(:mod:`netdae.topology`: loops of voltage sources, cutsets of current sources,
CV-loops, LI-cutsets, nodes without DC path, the topological index) under the
key ``topology`` (the full report with ``--json``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json

from . import add_max_elements, add_ngbehavior

__all__ = ["add_parser", "main", "summarize", "format_summary", "topology_lines"]

#: Options shown in the text summary even at their default values.
_MAIN_OPTIONS = ("reltol", "abstol", "vntol", "chgtol", "gmin", "method", "maxord", "temp", "tnom", "rshunt", "cshunt",
                 "rseries")


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "check",
        help="read a netlist and summarise it (nodes, elements, analyses, diagnostics)",
        description="Parse and elaborate a netlist (subcircuits expanded, parameters evaluated) "
                    "and print what netdae understood. Exit status 0 when the netlist is fine, "
                    "2 on a netlist error.",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    add_ngbehavior(p)
    add_max_elements(p)
    return p


def _analysis(a) -> dict:
    out = {"type": type(a).__name__.removesuffix("Analysis").lower()}
    for f in dataclasses.fields(a):
        if f.name == "location":
            continue
        value = getattr(a, f.name)
        if f.name == "sweeps":
            value = [dataclasses.asdict(s) for s in value]
        if f.name == "alter":  # a .control script's changes in force: their commands (none: left out)
            if not value:
                continue
            value = [c.command for c in value]
        out[f.name] = value
    if a.location is not None:
        out["line"] = a.location.line
    return out


def summarize(circuit) -> dict:
    """The summary of an elaborated circuit as plain, JSON-ready data.

    Parameters
    ----------
    circuit : netdae.circuit.Circuit

    Returns
    -------
    dict
        ``title``, ``path``, ``nodes`` (names), ``elements`` (count per
        letter), ``kinds`` (count per element kind), ``models`` (name to
        type), ``analyses`` (one dict per analysis), ``options`` (all
        option values, ``extra`` included), ``params`` (top-level
        parameters), ``ic``, ``nodeset``, ``saves``, ``diagnostics`` (dicts
        with ``severity``, ``message``, ``location``); ``measures`` (``name``,
        ``analysis``, ``function``, ``signals`` of each ``.meas`` card) when
        there are any.
    """
    kinds: dict[str, int] = {}
    for el in circuit.elements:
        kinds[el.kind] = kinds.get(el.kind, 0) + 1
    options = {f.name: getattr(circuit.options, f.name) for f in dataclasses.fields(circuit.options)
               if f.name != "locations"}
    summary = {
        "title": circuit.title,
        "path": circuit.path,
        "nodes": list(circuit.nodes),
        "elements": circuit.count_by_letter(),
        "kinds": dict(sorted(kinds.items())),
        "models": {name: m.type for name, m in circuit.models.items()},
        "analyses": [_analysis(a) for a in circuit.analyses],
        "options": options,
        "params": dict(circuit.params),
        "ic": dict(circuit.ic),
        "nodeset": dict(circuit.nodeset),
        "saves": list(circuit.saves),
        "diagnostics": [
            {"severity": d.severity, "message": d.message,
             "location": str(d.location) if d.location else None}
            for d in circuit.diagnostics
        ],
    }
    if circuit.measures:
        summary["measures"] = [{"name": m.name, "analysis": m.analysis, "function": m.function,
                                "signals": [p.name for p in m.probes()]} for m in circuit.measures]
    if circuit.steps:
        from ..sweeps.plan import make_plan

        plan = make_plan(circuit)
        summary["steps"] = [{"target": a.target, "name": a.name, "values": list(a.values)} for a in plan.axes]
    return summary


def _fmt(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _altered(a: dict) -> str:
    """`` (after alter r1 = 2000.0, ...)`` for an analysis of a .control script that altered the circuit."""
    return f" (after {', '.join(a['alter'])})" if a.get("alter") else ""


def _analysis_text(a: dict) -> str:
    kind = a["type"]
    if kind == "op":
        return ".op"
    if kind == "tran":
        text = f".tran tstep={_fmt(a['tstep'])} tstop={_fmt(a['tstop'])}"
        if a["tstart"]:
            text += f" tstart={_fmt(a['tstart'])}"
        if a["tmax"] is not None:
            text += f" tmax={_fmt(a['tmax'])}"
        return text + (" uic" if a["uic"] else "")
    if kind == "ac":
        return f".ac {a['variation']} {a['points']} {_fmt(a['fstart'])} {_fmt(a['fstop'])}"
    if kind == "pz":
        return f".pz {a['in_pos']} {a['in_neg']} {a['out_pos']} {a['out_neg']} {a['input_type']} {a['what']}"
    if kind == "tf":
        return f".tf {a['written'] or a['output']} {a['source']}"
    if kind == "noise":
        out = f"v({a['output']})" if a["reference"] == "0" else f"v({a['output']},{a['reference']})"
        text = f".noise {out} {a['source']} {a['variation']} {a['points']} {_fmt(a['fstart'])} {_fmt(a['fstop'])}"
        return text + (f" {a['summary']}" if a["summary"] else "")
    if kind == "sens":
        text = f".sens {a['written'] or a['output']}"
        if a["variation"] is None:
            return text + " dc"
        return text + f" ac {a['variation']} {a['points']} {_fmt(a['fstart'])} {_fmt(a['fstop'])}"
    sweeps = "; ".join(f"{s['source']} {_fmt(s['start'])} to {_fmt(s['stop'])} step {_fmt(s['step'])}"
                       for s in a["sweeps"])
    return f".dc {sweeps}"


_STANDARD = {"title", "path", "nodes", "elements", "kinds", "models", "analyses", "options", "params",
             "ic", "nodeset", "saves", "diagnostics", "measures", "steps"}


def format_summary(summary: dict) -> str:
    """The summary as text for a terminal."""
    lines = [f"{summary['path']}: {summary['title'] or '(no title)'}"]
    nodes = summary["nodes"]
    lines.append(f"  nodes ({len(nodes)}): " + (" ".join(nodes[:20]) + (" ..." if len(nodes) > 20 else "")
                                                if nodes else "none"))
    total = sum(summary["elements"].values())
    counts = ", ".join(f"{k.upper()} {v}" for k, v in summary["elements"].items())
    lines.append(f"  elements ({total}): {counts or 'none'}")
    if summary["models"]:
        lines.append("  models: " + ", ".join(f"{n} ({t})" for n, t in summary["models"].items()))
    lines.append("  analyses: " + ("; ".join(_analysis_text(a) + _altered(a) for a in summary["analyses"]) or "none"))
    opts = summary["options"]
    shown = [f"{k}={_fmt(opts[k])}" for k in _MAIN_OPTIONS if opts.get(k) is not None]
    shown += [f"{k}={_fmt(v)}" for k, v in opts["extra"].items()]
    if opts.get("interp"):
        shown.append("interp")
    lines.append("  options: " + " ".join(shown))
    if summary["params"]:
        lines.append("  params: " + " ".join(f"{k}={_fmt(v)}" for k, v in summary["params"].items()))
    for key in ("ic", "nodeset"):
        if summary[key]:
            lines.append(f"  .{key}: " + " ".join(f"v({n})={_fmt(v)}" for n, v in summary[key].items()))
    if summary["saves"]:
        lines.append("  saves: " + " ".join(summary["saves"]))
    if summary.get("steps"):
        rows = 1
        for axis in summary["steps"]:
            rows *= len(axis["values"])
        lines.append(f"  .step ({rows} rows, netdae sweep): " + "; ".join(
            f"{a['name']} ({a['target']}): " + " ".join(_fmt(v) for v in a["values"][:8])
            + (f" ... ({len(a['values'])} values)" if len(a["values"]) > 8 else "") for a in summary["steps"]))
    if summary.get("measures"):
        lines.append("  measures: " + "; ".join(
            f"{m['name']} ({m['analysis']} {m['function']}{' ' if m['signals'] else ''}{' '.join(m['signals'])})"
            for m in summary["measures"]))
    for key, value in summary.items():
        if key in _STANDARD:
            continue
        if isinstance(value, list):
            lines.append(f"  {key}:" + ("" if value else " none"))
            lines.extend(f"    {item}" for item in value)
        else:
            lines.append(f"  {key}: {value}")
    diags = summary["diagnostics"]
    lines.append(f"  diagnostics: {len(diags) or 'none'}")
    for d in diags:
        where = f"{d['location']}: " if d["location"] else ""
        lines.append(f"    {where}{d['severity']}: {d['message']}")
    return "\n".join(lines)


def topology_lines(topo) -> list[str]:
    """The topological findings as text lines, ending with the index statement (reasons once)."""
    return [str(f) for f in topo.findings if f.kind != "not_applicable"] + [topo.index_message]


def main(args) -> int:
    from ..errors import NetdaeError, error_record
    from ..mna import assemble
    from ..netlist import load
    from ..topology import analyze_topology

    try:
        circuit = load(args.file, behavior=args.ngbehavior, max_elements=args.max_elements)
        # the device models built as a run builds them: a value a run refuses (a MOSFET's l = 0, a model's
        # phi = 0) is refused here too, not summarised as "diagnostics: none"
        assemble(circuit)
        topo = analyze_topology(circuit)
    except NetdaeError as exc:
        if args.json:  # the error as data too (its file, line and column); the dispatcher says it on stderr
            print(json.dumps({"path": args.file, "error": error_record(exc)}, indent=2))
        raise
    summary = summarize(circuit)
    summary["topology"] = topology_lines(topo)
    if args.json:
        summary["topology"] = topo.to_dict()
        print(json.dumps(summary, indent=2))
    else:
        print(format_summary(summary))
    return 0
