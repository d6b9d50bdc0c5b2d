"""The architecture's rules, checked on the source: computation never imports the GUI."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_core_never_imports_viser_or_the_studio():
    offenders = {}
    for path in sorted((REPO / "app" / "core").rglob("*.py")):
        bad = _imports(path) & {"viser", "panels"}
        bad |= {"app.studio"} if "app.studio" in path.read_text() else set()
        if bad:
            offenders[path.name] = bad
    assert offenders == {}


def test_robots_package_is_pure_data_and_builders():
    for path in (REPO / "robots").rglob("*.py"):
        assert not _imports(path) & {"viser", "panels", "app"}, path
