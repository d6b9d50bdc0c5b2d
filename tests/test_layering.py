"""The architecture's rules, checked on the source (every import, including those under
TYPE_CHECKING): computation never imports the GUI, panels never import the studio, views never
import panels, sessions never import one another, and no import circle among the studio's
modules."""

from __future__ import annotations

import ast
import itertools
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
STUDIO_PACKAGES = ("app", "panels")


def _module(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every module imported by the file, as written (absolute), anywhere in it."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
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
