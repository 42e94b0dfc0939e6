"""``hacgear list [--json]``: the shipped gear systems, each with its kind, gears, meshes and tables."""
from __future__ import annotations

import argparse
from typing import Any

from hacgear_core.cli._commands import command_help
from hacgear_core.jsonio import dumps
from hacgear_core.kinds import load_model
from hacgear_core.model import shipped_systems, shipped_systems_dir

__all__ = ["register", "run", "systems_list"]


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "list", help=command_help("list"),
        description="The gear systems shipped with hacgear (usable by name as MODEL in every command): kind, gears "
                    "with tooth counts, meshes, operating torque [N*m] and whether their FE tables ship.")
    p.add_argument("--json", action="store_true", help="print JSON (SI units, unit in the key name)")
    p.set_defaults(func=run)


def systems_list() -> list[dict[str, Any]]:
    """One record per shipped system (name, kind, title, gears and teeth, meshes, torque, tables shipped)."""
    out = []
    for name in shipped_systems():
        folder = shipped_systems_dir() / name
        m = load_model(folder)
        out.append({"name": name, "kind": m.kind, "title": m.title,
                    "gears": {g.name: g.teeth for g in m.gears},
                    "meshes": [me.name for me in m.meshes],
                    "torque_Nm": m.operating.torque_Nm,
                    "tables": (folder / "tables.h5").is_file() and not m.lumped,
                    "lumped": m.lumped})
    return out


def run(args: argparse.Namespace) -> int:
    rows = systems_list()
    if args.json:
        print(dumps({"systems": rows, "folder": str(shipped_systems_dir())}))
        return 0
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        gears = ", ".join(f"{g} {z}t" for g, z in r["gears"].items())
        tables = "tables shipped" if r["tables"] else ("lumped, no tables needed" if r["lumped"] else "no tables")
        print(f"{r['name']:<{width}}  {r['kind']:<12}  {gears}; meshes {', '.join(r['meshes'])}; "
              f"{r['torque_Nm']:g} N*m; {tables}")
        if r["title"]:
            print(f"{'':<{width}}  {r['title']}")
    print(f"\n{len(rows)} systems in {shipped_systems_dir()}; use a name as MODEL (e.g. `hacgear info {rows[0]['name']}`)")
    return 0
