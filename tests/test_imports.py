"""The package's import graph, read from the sources (AST): no cycle between modules or between subpackages, and
the lower stages never import the ones built on them (plots and the FMU never import the command line)."""
from __future__ import annotations

import ast
from pathlib import Path

import hacgear_core

ROOT = Path(hacgear_core.__file__).resolve().parent
PKG = "hacgear_core"


def _modules() -> dict[str, Path]:
    """Dotted name -> file of every module of the package (the shipped-systems data folder holds no code)."""
    out = {}
    for p in sorted(ROOT.rglob("*.py")):
        rel = p.relative_to(ROOT)
        if "__pycache__" in rel.parts or rel.parts[0] in ("systems",) or rel.parts[:2] == ("fmu", "slaves"):
            continue
        parts = [PKG, *rel.with_suffix("").parts]
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Modules of the package that module ``name`` imports anywhere in its text (at module level or inside a
    function): ``from a.b import c`` names the module ``a.b.c`` when it is one, else ``a.b``."""
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in modules else mod for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in modules and "." in t:
                t = t.rsplit(".", 1)[0]
            if t in modules and t != name:
                out.add(t)
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {n: _imports(n, p, modules) for n, p in modules.items()}


def _room(module: str) -> str:
    """The subpackage (or top-level module) a module belongs to: ``hacgear_core.kinds.planetary`` ->
    ``kinds``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else PKG


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _room_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    rooms: dict[str, set[str]] = {}
    for a, bs in graph.items():
        rooms.setdefault(_room(a), set()).update(_room(b) for b in bs if _room(b) != _room(a))
    return rooms


def test_scanner_sees_the_package_and_finds_a_planted_cycle():
    """The scan reads every subpackage, resolves ``from pkg import module`` to the module, and reports a cycle
    when one is planted (so an empty result means something)."""
    g = _graph()
    rooms = _room_graph(g)
    for room in ("model", "geometry", "statics", "tables", "dynamics", "kinds", "fmu", "cli", "plots", "studies"):
        assert room in rooms, room
    assert "hacgear_core.dynamics.steady" in g["hacgear_core.studies.direct"]
    assert "hacgear_core.model.schema" in g["hacgear_core.model.toml"]
    planted = {k: set(v) for k, v in g.items()}
    planted["hacgear_core.model.schema"].add("hacgear_core.cli.simulate")
    assert _cycles(planted)
    assert _cycles(_room_graph(planted))


def test_no_import_cycle_between_modules():
    assert _cycles(_graph()) == []


def test_no_import_cycle_between_subpackages():
    assert _cycles(_room_graph(_graph())) == []


def test_lower_stages_do_not_import_the_command_line_or_the_studies():
    """The command line, the plots and the studies sit on top: nothing in the pipeline imports them, and plots
    never import the command line."""
    rooms = _room_graph(_graph())
    for room, deps in rooms.items():
        if room not in ("cli",):
            assert "cli" not in deps, f"{room} imports cli"
        if room not in ("cli", "plots", "studies"):
            assert "studies" not in deps, f"{room} imports studies"
            assert "plots" not in deps, f"{room} imports plots"


def test_kinds_sit_on_the_dynamics_core():
    """The kinds build on the model, the geometry, the tables and the dynamics core; none of those imports a kind
    (a kind is added without touching them)."""
    rooms = _room_graph(_graph())
    assert {"model", "geometry", "tables", "dynamics"} <= rooms["kinds"]
    for room in ("model", "geometry", "tables", "dynamics", "errors", "response"):
        assert "kinds" not in rooms.get(room, set()), f"{room} imports kinds"


def test_kind_names_are_matched_only_in_kinds():
    """No module outside kinds/ tests a kind by name or branches on the helical law (``kind ==``, ``twisted``):
    they ask the kind's registry entry or read the mesh law's fields by name."""
    hits = []
    for p in sorted(ROOT.rglob("*.py")):
        rel = p.relative_to(ROOT)
        if rel.parts[0] in ("kinds", "systems") or rel.parts[:2] == ("fmu", "slaves"):
            continue
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
            if "kind ==" in line or "twisted" in line:
                hits.append(f"{rel}:{i}: {line.strip()}")
    assert hits == []


def test_no_package_folder_is_named_build():
    """Code-structure tools skip folders named ``build``: the package has none."""
    assert [p for p in ROOT.rglob("build") if p.is_dir() and "__pycache__" not in p.parts] == []
