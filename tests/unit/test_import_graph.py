"""No import circles among the project's own modules (the architecture's rule: no import circles).

The graph is read from the source with :mod:`ast`, not by importing anything: every top-level
package of the repository (a folder with an ``__init__.py`` beside ``pyproject.toml``) and every
module below it. Every import counts — at module level, inside functions, and under
``if TYPE_CHECKING:`` — because each is a dependency a reader has to follow. Relative imports are
resolved against the importing module's package. ``import a.b.c`` and ``from a.b import c`` point at
the deepest project module they name (``a.b.c`` when it is a module, else ``a.b``); the parent
packages that Python initialises on the way are not counted as edges (a package ``__init__`` that
re-exports its submodules is not a circle).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# Circles known on main and to be removed; empty this
# list when that branch is merged. Each entry is the exact set of modules of one circle (a strongly
# connected component of the graph): a circle that grows, shrinks or disappears fails the test too,
# so an entry can never hide anything but the circle it names.
EXPECTED_TO_BE_FIXED: list[frozenset[str]] = []


def project_modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> file, for every top-level package of the repository."""
    modules: dict[str, Path] = {}
    for top in sorted(p for p in root.iterdir() if p.is_dir() and (p / "__init__.py").is_file()):
        if top.name.startswith("."):
            continue
        for path in sorted(top.rglob("*.py")):
            rel = path.relative_to(root).with_suffix("")
            parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
            if all((root.joinpath(*parts[:i]) / "__init__.py").is_file() for i in range(1, len(parts))):
                modules[".".join(parts)] = path
    return modules


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The deepest project module that ``name`` (a dotted path) names, if any."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        candidate = ".".join(parts[:i])
        if candidate in modules:
            return candidate
    return None


def imports_of(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules that ``module`` imports anywhere in its source."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)] if package else []
                prefix = ".".join([*base, node.module] if node.module else base)
            else:
                prefix = node.module or ""
            targets = [f"{prefix}.{alias.name}" for alias in node.names]  # a submodule, or a name in prefix
        else:
            continue
        for target in targets:
            resolved = _resolve(target, modules)
            if resolved is not None and resolved != module:
                out.add(resolved)
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    modules = project_modules(root)
    return {m: imports_of(m, p, modules) for m, p in modules.items()}


def circles(graph: dict[str, set[str]]) -> list[tuple[frozenset[str], list[str]]]:
    """Every strongly connected component of more than one module (Tarjan): its modules, and one
    circle through some of them in import order, starting from its smallest name."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []

    def visit(v: str) -> None:  # recursive: the graph is a few hundred modules, a few levels deep
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(component)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return [(frozenset(c), _one_circle(graph, c)) for c in sorted(components, key=min)]


def _one_circle(graph: dict[str, set[str]], component: set[str]) -> list[str]:
    """A shortest way from the component's smallest module back to itself, inside the component."""
    start = min(component)
    paths = {start: [start]}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & component):
                if w == start:
                    return [*paths[v], start]
                if w not in paths:
                    paths[w] = [*paths[v], w]
                    nxt.append(w)
        frontier = nxt
    raise AssertionError(f"{sorted(component)} is not strongly connected")  # cannot happen


def test_the_project_has_no_import_circle():
    graph = import_graph()
    found = circles(graph)
    unexpected = [(modules, circle) for modules, circle in found if modules not in EXPECTED_TO_BE_FIXED]
    gone = [sorted(e) for e in EXPECTED_TO_BE_FIXED if e not in {modules for modules, _ in found}]
    lines = [" -> ".join(circle) + f"   (one circle; {len(modules)} modules import each other: {', '.join(sorted(modules))})"
             for modules, circle in unexpected]
    lines += [f"listed in EXPECTED_TO_BE_FIXED but not found as such (fixed or changed: update the list): {e}" for e in gone]
    assert not lines, "import circles among the project's modules:\n" + "\n".join(lines)


def test_the_graph_sees_every_kind_of_import(tmp_path):
    """The reader finds relative imports, imports inside functions and under TYPE_CHECKING, and
    reports a circle through them."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    for f in ("__init__.py", "sub/__init__.py"):
        (pkg / f).write_text("")
    (pkg / "a.py").write_text("from .sub import b\n")
    (pkg / "sub" / "b.py").write_text("def f():\n    from ..c import g\n")
    (pkg / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import pkg.a\n")
    (pkg / "d.py").write_text("from pkg import c\nfrom . import sub\n")
    (tmp_path / "notapackage").mkdir()
    (tmp_path / "notapackage" / "x.py").write_text("import pkg.d\n")
    graph = import_graph(tmp_path)
    assert graph == {"pkg": set(), "pkg.sub": set(), "pkg.a": {"pkg.sub.b"}, "pkg.sub.b": {"pkg.c"},
                     "pkg.c": {"pkg.a"}, "pkg.d": {"pkg.c", "pkg.sub"}}
    assert circles(graph) == [(frozenset({"pkg.a", "pkg.sub.b", "pkg.c"}), ["pkg.a", "pkg.sub.b", "pkg.c", "pkg.a"])]


MIDDLEWARE = "petswarm_env.middleware"
MANAGERS = ("join", "token_ring", "sequence", "modes")


def test_a_robots_managers_see_only_its_station():
    """Each robot's managers import neither the node that builds them, nor the per-user swarm,
    nor the fleet that wires the robots to the media (seed 000 Fig. 5: per robot); and no module
    of the middleware imports the fleet (the env alone does)."""
    graph = import_graph()
    above = {f"{MIDDLEWARE}.{m}" for m in ("node", "swarm", "fleet", "user_session")}
    for manager in (*MANAGERS, "station", "knowledge"):
        reached = graph[f"{MIDDLEWARE}.{manager}"] & above
        assert not reached, f"{manager} imports {sorted(reached)}"
    fleet_importers = {m for m, deps in graph.items() if f"{MIDDLEWARE}.fleet" in deps}
    assert not {m for m in fleet_importers if m.startswith(MIDDLEWARE)}, sorted(fleet_importers)
