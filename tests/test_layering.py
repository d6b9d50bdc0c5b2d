"""The architecture's rules, checked on the source (every import, including those under
TYPE_CHECKING): computation never imports the GUI, panels never import the studio, views never
import panels, sessions never import one another, and no import circle among the studio's
modules; and the sizes a reader can hold (issue 25): no module of app/ or panels/ over
MAX_MODULE_LINES lines, no function there over MAX_FUNCTION_LINES, no class of the studio over
MAX_METHODS methods or MAX_ATTRIBUTES attributes."""

from __future__ import annotations

import ast
import functools
import itertools
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
STUDIO_PACKAGES = ("app", "panels")
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 100
MAX_METHODS = 20
MAX_ATTRIBUTES = 15
"""Distinct `self.X` stores and class-level annotated fields of one class."""


def _module(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def _parsed(path: Path) -> tuple[int, ast.Module]:
    """The file's number of lines and its syntax tree (parsed once for every rule here)."""
    text = path.read_text()
    return len(text.splitlines()), ast.parse(text)


def _imports(path: Path) -> set[str]:
    """Every module imported by the file, as written (absolute), anywhere in it."""
    names = set()
    for node in ast.walk(_parsed(path)[1]):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def _graph() -> dict[str, set[str]]:
    files = [p for package in STUDIO_PACKAGES for p in (REPO / package).rglob("*.py")]
    modules = {_module(p): p for p in files}
    return {
        name: {m for m in _imports(path) if m in modules and m != name}
        for name, path in modules.items()
    }


def _offenders(prefix: str, forbidden: tuple[str, ...]) -> dict[str, set[str]]:
    out = {}
    for name, path in (
        (_module(p), p)
        for package in (*STUDIO_PACKAGES, "robots")
        for p in (REPO / package).rglob("*.py")
    ):
        if name == prefix or name.startswith(prefix + "."):
            bad = {
                m for m in _imports(path) if m.split(".")[0] in forbidden or m.startswith(forbidden)
            }
            if bad:
                out[name] = bad
    return out


def test_core_never_imports_viser_panels_or_the_studio():
    assert (
        _offenders(
            "app.core", ("viser", "panels", "app.studio", "app.views", "app.jobs", "app.cli")
        )
        == {}
    )


def test_robots_package_is_pure_data_and_builders():
    assert _offenders("robots", ("viser", "panels", "app")) == {}


def test_panels_never_import_the_studio_sessions_or_views():
    assert _offenders("panels", ("app.studio", "app.views", "app.jobs", "app.cli")) == {}


def test_views_never_import_panels_or_the_studio():
    assert _offenders("app.views", ("panels", "app.studio", "app.cli")) == {}


def test_sessions_never_import_one_another():
    graph = _graph()
    sessions = {
        name for name in graph if name.startswith("app.studio.") and name.endswith("_session")
    }
    assert sessions, "no sessions found"
    crossing = {name: graph[name] & sessions for name in sessions if graph[name] & sessions}
    assert crossing == {}


def test_no_import_circle_among_the_studio_modules():
    graph = _graph()
    state: dict[str, int] = {}  # 1 = on the current path, 2 = done
    cycles: list[list[str]] = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycles.append([*path[path.index(nxt) :], nxt] if nxt in path else [node, nxt])
            elif nxt not in state:
                visit(nxt, [*path, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    # A package __init__ re-exporting one of its modules is not a design circle.
    real = [
        c
        for c in cycles
        if not any(a.startswith(b + ".") or b.startswith(a + ".") for a, b in itertools.pairwise(c))
    ]
    assert real == []


def _own_nodes(node: ast.AST) -> list[ast.AST]:
    """The nodes below `node`, not entering a class defined inside it."""
    found = []
    for child in ast.iter_child_nodes(node):
        found.append(child)
        if not isinstance(child, ast.ClassDef):
            found += _own_nodes(child)
    return found


def class_size(cls: ast.ClassDef) -> tuple[int, int]:
    """(methods, attributes) of `cls`: its body's functions (properties included); the distinct
    names it stores on `self` and its class-level annotated fields."""
    methods = [n for n in cls.body if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]
    attributes = {
        n.target.id
        for n in cls.body
        if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)
    }
    attributes |= {
        n.attr
        for n in _own_nodes(cls)
        if isinstance(n, ast.Attribute)
        and isinstance(n.ctx, ast.Store)
        and isinstance(n.value, ast.Name)
        and n.value.id == "self"
    }
    return len(methods), len(attributes)


def test_no_module_function_or_studio_class_outgrows_a_reader():
    too_long, long_functions, big_classes = {}, {}, {}
    for path in (p for package in STUDIO_PACKAGES for p in (REPO / package).rglob("*.py")):
        name = str(path.relative_to(REPO))
        lines, tree = _parsed(path)
        if lines > MAX_MODULE_LINES:
            too_long[name] = lines
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1  # type: ignore[operator]
                if length > MAX_FUNCTION_LINES:
                    long_functions[f"{name}:{node.lineno} {node.name}"] = length
            elif isinstance(node, ast.ClassDef) and name.startswith("app/studio/"):
                methods, attributes = class_size(node)
                if methods > MAX_METHODS or attributes > MAX_ATTRIBUTES:
                    big_classes[f"{name} {node.name}"] = (methods, attributes)
    assert too_long == {}, f"modules over {MAX_MODULE_LINES} lines"
    assert long_functions == {}, f"functions over {MAX_FUNCTION_LINES} lines"
    assert big_classes == {}, f"(methods, attributes) over ({MAX_METHODS}, {MAX_ATTRIBUTES})"


def test_class_size_counts_methods_stores_and_fields():
    """The counting itself, on a class whose numbers are known by eye."""
    (cls,) = ast.parse(
        "class A:\n"
        "    x: int = 0\n"
        "    y = 1\n"  # not annotated: not counted
        "    def __init__(self):\n"
        "        self.a, self.b = 1, 2\n"
        "        self.a += 1\n"
        "        other.c = 3\n"
        "        class Inner:\n"
        "            def f(self):\n"
        "                self.d = 4\n"
        "    @property\n"
        "    def p(self):\n"
        "        return self.a\n"
        "    async def q(self):\n"
        "        for self.e in ():\n"
        "            pass\n"
    ).body
    assert isinstance(cls, ast.ClassDef)
    assert class_size(cls) == (3, 4)  # __init__, p, q; x, a, b, e
