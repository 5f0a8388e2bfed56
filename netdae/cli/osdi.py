"""``netdae osdi FILE [--module NAME] [--params] [--json]``: what a compiled Verilog-A library offers.

Opens an OSDI library (a ``.osdi`` file; a relative name not found is looked
up among the models ``netdae[models]`` bundles, as ``.osdi`` cards do) and
prints, per module, the terminals (the order ``N`` cards connect), internal
nodes, collapsible node pairs and the parameter count; ``--params`` lists
every parameter with its type, kind (model or instance), default (the value
after ``setup_model`` of a model with nothing given) and description;
``--json`` prints the same as one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os

__all__ = ["add_parser", "main", "describe_library"]


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "osdi",
        help="list the modules, terminals and parameters of a compiled Verilog-A (OSDI) library",
        description="Open an OSDI library and print its modules: terminals, internal nodes, "
                    "collapsible pairs and parameters (with --params: types, kinds, defaults).",
    )
    p.add_argument("file", help=".osdi file (relative names are also looked up among the bundled models)")
    p.add_argument("--module", help="only this module")
    p.add_argument("--params", action="store_true", help="list every parameter with its default")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    return p


def describe_library(path: str, module: str | None = None, params: bool = False) -> dict:
    """The library as plain data: version and, per module, nodes and (optionally) parameters."""
    from ..devices.osdi import OsdiModel, load_library
    from ..devices.osdi.tools import resolve_osdi

    lib = load_library(resolve_osdi(os.getcwd(), path))
    mods = [lib.module(module)] if module else list(lib.modules.values())
    out = {"file": lib.path, "version": "%d.%d" % lib.version, "modules": []}
    for mod in mods:
        entry = {
            "name": mod.name,
            "terminals": list(mod.terminals),
            "internal_nodes": list(mod.internal_nodes),
            "collapsible": [[mod.nodes[a].name, "ground" if b is None else mod.nodes[b].name]
                            for a, b in mod.collapsible],
            "parameters": len(mod.parameters),
            "limiting_states": mod.num_states,
            "absolute_delays": mod.num_delays,  # absdelay(): refused by netdae's N cards
            # the device quantities an instance gives (@m1[gm] ...)
            "operating_point_variables": [p.name for p in mod.params if p.kind == "opvar"],
        }
        if params:
            defaults = OsdiModel(mod, f"{mod.name}-defaults").defaults()
            entry["parameter_list"] = [
                {"name": p.name, "aliases": list(p.aliases), "type": p.type, "kind": p.kind,
                 "default": defaults.get(p.name), "units": p.units, "description": p.description}
                for p in mod.parameters]
        out["modules"].append(entry)
    return out


def main(args) -> int:
    info = describe_library(args.file, args.module, args.params)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    print(f"{info['file']}: OSDI {info['version']}")
    for m in info["modules"]:
        print(f"module {m['name']}({', '.join(m['terminals'])})")
        print(f"  internal nodes: {', '.join(m['internal_nodes']) or 'none'}")
        if m["collapsible"]:
            print("  collapsible: " + ", ".join(f"{a}-{b}" for a, b in m["collapsible"]))
        print(f"  parameters: {m['parameters']}; limiting states: {m['limiting_states']}")
        if m["absolute_delays"]:
            print(f"  absolute delays (absdelay): {m['absolute_delays']}; netdae does not evaluate them, an N card "
                  "of this module is an error")
        if m["operating_point_variables"]:
            print("  operating-point variables (@name[var]): " + ", ".join(m["operating_point_variables"]))
        for p in m.get("parameter_list", []):
            alias = f" ({', '.join(p['aliases'])})" if p["aliases"] else ""
            units = f" [{p['units']}]" if p["units"] else ""
            print(f"    {p['name']}{alias}: {p['type']} {p['kind']} = {p['default']!r}{units}"
                  + (f"  {p['description']}" if p["description"] else ""))
    return 0
