"""The import graph, read from the source (every import statement, lazy ones inside functions too).

Rules (``docs/architecture.md``): the core imports no layer; ``frequency`` imports only the core;
``linearize`` imports the core and ``frequency``; ``stability`` imports the core, ``frequency`` and
``linearize`` (the report joins them all); ``linflex.design`` stands on all three (a design is
checked by the report's own margins); nothing outside ``linflex.cli`` imports the command
line (the top floor, which may import every layer); and the graph of modules has no circles. ``if TYPE_CHECKING:`` blocks are annotations only
and are left out.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("linearize", "frequency", "stability")

#: What each part may import (besides itself and third-party packages).
ALLOWED = {
    "core": {"core"},
    "frequency": {"core", "frequency"},
    "linearize": {"core", "frequency", "linearize"},
    "stability": {"core", "frequency", "linearize", "stability"},
    "design": {"core", "frequency", "linearize", "stability", "design"},
    "cli": {"core", "frequency", "linearize", "stability", "design", "cli"},
}


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    if parts[0] != "linflex":
        parts.insert(0, "linflex")
    return ".".join(parts)


def source_modules() -> dict[str, Path]:
    modules = {}
    for top in ("linflex", *LAYERS):
        for path in sorted((ROOT / top).rglob("*.py")):
            modules[module_name(path)] = path
    return modules


def _type_checking_lines(tree: ast.AST) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                for sub in ast.walk(child):
                    if hasattr(sub, "lineno"):
                        lines.add(sub.lineno)
    return lines


def imports_of(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The linflex modules ``name`` imports (resolved to modules that exist in the source)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _type_checking_lines(tree)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()

    def add(target: str) -> None:
        while target and target not in known:
            target = target.rpartition(".")[0]
        if target and target != name:
            found.add(target)

    for node in ast.walk(tree):
        if getattr(node, "lineno", None) in skip:
            continue
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("linflex"):
                    add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("linflex"):
                continue
            for alias in node.names:
                candidate = f"{target}.{alias.name}"
                add(candidate if candidate in known else target)
    return found


def part(module: str) -> str:
    second = module.split(".")[1] if "." in module else ""
    return second if second in (*LAYERS, "design", "cli") else "core"


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    known = source_modules()
    return {name: imports_of(name, path, known) for name, path in known.items()}


def test_the_graph_sees_lazy_and_relative_imports(graph):
    # A lazy import inside a function and a relative import across rooms are both edges.
    assert "linflex.scene._check" in graph["linflex.scene._scene"]
    assert "linflex.system._errors" in graph["linflex.scene._entries"]
    assert "linflex.frequency" in graph["linflex.stability.report._analysis"]


def test_layer_rules(graph):
    bad = [f"{a} imports {b}" for a, targets in graph.items() for b in sorted(targets)
           if part(b) not in ALLOWED[part(a)]]
    assert not bad, "imports against the layer rules:\n" + "\n".join(bad)


def test_only_the_command_line_imports_the_command_line(graph):
    bad = [f"{a} imports {b}" for a, targets in graph.items() for b in targets
           if b.startswith("linflex.cli") and not a.startswith("linflex.cli")]
    assert not bad, "\n".join(bad)


def test_no_circles(graph):
    # Tarjan's strongly connected components: every component must be a single module.
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not circles, "import circles:\n" + "\n".join(" <-> ".join(c) for c in circles)


def test_no_circles_detects_a_circle(tmp_path):
    # The checker itself: a two-module circle through a lazy import is found.
    (tmp_path / "a.py").write_text("from linflex.b import x\n")
    (tmp_path / "b.py").write_text("def f():\n    from linflex.a import y\n")
    known = {"linflex.a": tmp_path / "a.py", "linflex.b": tmp_path / "b.py"}
    assert imports_of("linflex.a", known["linflex.a"], known) == {"linflex.b"}
    assert imports_of("linflex.b", known["linflex.b"], known) == {"linflex.a"}


def test_no_source_file_above_800_lines():
    long = [f"{p.relative_to(ROOT)}: {n} lines" for p in sorted(ROOT.glob("*/**/*.py"))
            if ".venv" not in p.parts and (n := len(p.read_text(encoding="utf-8").splitlines())) > 800]
    assert not long, "\n".join(long)


def test_layers_use_the_cores_declared_api(graph):
    # The layers import the core through its rooms' __init__ (the public names and the declared
    # internal API of linflex.system / linflex.dynamics), never a private module of a room.
    bad = [f"{a} imports {b}" for a, targets in graph.items() if part(a) in LAYERS for b in sorted(targets)
           if part(b) == "core" and any(piece.startswith("_") for piece in b.split(".")[1:])]
    assert not bad, "\n".join(bad)
