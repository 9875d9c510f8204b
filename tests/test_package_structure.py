"""The house stays walkable: every import runs down the layers of :data:`LAYERS` (the order
``docs/architecture.md`` shows), no import circle anywhere, thruster and vehicle identification
stay in their own rooms, and the command line stays a thin shell (no module in ``cli/`` over 400
lines).  Imports are read from the source (every ``import``, at module level or inside a
function), so a function-local import cannot hide an upward one."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "uuvid"
DOCS_MAP = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
CLI_MAX_LINES = 400

#: The layers, bottom first: a module may import from its own layer and the layers below it.
LAYERS: list[tuple[str, ...]] = [
    ("uuvid", "uuvid.core"),
    ("uuvid.thruster",),
    ("uuvid.vehicle",),
    ("uuvid.io",),
    ("uuvid.simulate",),
    ("uuvid.identify",),
    ("uuvid.analysis",),
    ("uuvid.uncertainty",),
    ("uuvid.papers", "uuvid.examples"),
    ("uuvid.demo",),
    ("uuvid.cli", "uuvid.__main__"),
]

#: Rooms inside one layer that must not import each other (each may use the layer's shared modules).
SIBLINGS = [("uuvid.identify.thruster", "uuvid.identify.vehicle")]


def _modules() -> dict[str, Path]:
    out = {}
    for p in PKG.rglob("*.py"):
        parts = p.relative_to(PKG.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


def _targets(mods: dict[str, Path], name: str, node) -> list[str]:
    if isinstance(node, ast.Import):
        cands = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:
            pkg = name.split(".") if mods[name].name == "__init__.py" else name.split(".")[:-1]
            pkg = pkg[: len(pkg) - (node.level - 1)]
            base = ".".join(pkg + ([base] if base else []))
        cands = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
    out = []
    for c in cands:
        while c and c not in mods:
            c = c.rpartition(".")[0]
        if c and c != name:
            out.append(c)
    return out


def import_graph() -> dict[str, set[str]]:
    mods = _modules()
    graph = {m: set() for m in mods}
    for m, p in mods.items():
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                graph[m].update(_targets(mods, m, node))
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_the_checker_finds_a_circle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


@pytest.mark.slow
def test_no_import_circle_in_the_package():
    found = cycles(import_graph())
    assert not found, "import circles: " + "; ".join(" ↔ ".join(c) for c in found)


@pytest.mark.slow
def test_nothing_outside_cli_imports_cli():
    shell = ("uuvid.cli", "uuvid.__main__")  # python -m uuvid: the command line's own entry
    bad = [(m, t) for m, ts in import_graph().items() if not m.startswith(shell)
           for t in ts if t.startswith("uuvid.cli")]
    assert not bad, bad


def test_cli_modules_are_thin():
    long = {p.name: n for p in (PKG / "cli").glob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > CLI_MAX_LINES}
    assert not long, f"cli/ modules over {CLI_MAX_LINES} lines (move the logic into the library): {long}"


def _within(module: str, room: str) -> bool:
    return module == room or module.startswith(room + ".")


def layer_of(module: str) -> int:
    """Index in :data:`LAYERS` of the longest room containing ``module``."""
    best, depth = None, -1
    for i, rooms in enumerate(LAYERS):
        for room in rooms:
            if _within(module, room) and len(room) > depth:
                best, depth = i, len(room)
    if best is None:
        raise AssertionError(f"{module} is in no layer: add its room to LAYERS and docs/architecture.md")
    return best


def upward(graph: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} (layer {layer_of(m)}) imports {t} (layer {layer_of(t)})"
                  for m, ts in graph.items() for t in ts if layer_of(t) > layer_of(m))


def test_the_checker_finds_an_upward_import():
    fake = {"uuvid.vehicle.model": {"uuvid.simulate.vehicle_sim"}, "uuvid.simulate.vehicle_sim": set(),
            "uuvid.cli.app": {"uuvid.vehicle.model"}}
    assert upward(fake) == ["uuvid.vehicle.model (layer 2) imports uuvid.simulate.vehicle_sim (layer 4)"]


@pytest.mark.slow
def test_every_import_runs_down_the_layers():
    bad = upward(import_graph())
    assert not bad, "imports running up the layers (move the code down, or the caller up):\n" + "\n".join(bad)


def test_a_function_local_import_counts(tmp_path):
    """The graph reads imports inside functions too, so a lazy import cannot dodge the layer test."""
    tree = ast.parse("def f():\n    from uuvid.cli.app import app\n")
    mods = {"uuvid.vehicle.model": tmp_path / "model.py", "uuvid.cli.app": tmp_path / "app.py"}
    found = [t for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
             for t in _targets(mods, "uuvid.vehicle.model", node)]
    assert found == ["uuvid.cli.app"]


@pytest.mark.slow
def test_sibling_rooms_stay_apart():
    bad = [(m, t) for m, ts in import_graph().items() for t in ts for a, b in SIBLINGS
           for x, y in ((a, b), (b, a)) if _within(m, x) and _within(t, y)]
    assert not bad, bad


def test_architecture_map_lists_the_layers():
    """docs/architecture.md's layer table names the rooms of :data:`LAYERS`, bottom first, and every
    top-level room of the package appears in it."""
    rows = [line for line in DOCS_MAP.read_text(encoding="utf-8").splitlines()
            if line.startswith("| ") and line.split("|")[1].strip().isdigit()]
    documented = [tuple(re.findall(r"`(uuvid[\w.]*)`", r.split("|")[2])) for r in rows]
    assert documented == LAYERS, f"docs/architecture.md's layer table {documented} != LAYERS {LAYERS}"
    rooms = {f"uuvid.{p.name}" for p in PKG.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    rooms |= {f"uuvid.{p.stem}" for p in PKG.glob("*.py") if p.stem != "__init__"}
    listed = {room for rooms_ in LAYERS for room in rooms_}
    assert rooms <= listed, f"rooms missing from LAYERS: {sorted(rooms - listed)}"
