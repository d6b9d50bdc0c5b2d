"""Every module path the prose names exists: README.md, ARCHITECTURE.md, docs/*.md, and the
docstrings and comments of our Python files. Three forms are checked:

- file paths `app/core/motions/trajectory.py`, `nlp.py` (a file of that name or path tail in the
  repo, or in an installed package for `viser/infra/_infra.py`), and folders `app/core/servo/`;
- dotted modules `app.core.servo.presets` and what follows them (`…presets.PRESETS` must be a
  top-level name of presets.py, read from its syntax tree, nothing imported).

A module moved or removed without its mentions fails here, with every stale mention listed.
"""

from __future__ import annotations

import ast
import importlib.util
import io
import re
import tokenize
from collections.abc import Iterator
from functools import cache
from pathlib import Path

from tests.conftest import REPO

DOCUMENTS = (
    "README.md",
    "ARCHITECTURE.md",
    *sorted(p.relative_to(REPO).as_posix() for p in (REPO / "docs").glob("*.md")),
)
SOURCE_FOLDERS = ("app", "panels", "robots", "tests", "examples", "scripts")
TOP_FOLDERS = ("app", "panels", "robots", "tests", "examples", "scripts", "docs", "static")

FILE_REF = re.compile(r"(?<![\w./<>*{-])([A-Za-z_][\w/-]*\.py)\b")
"""A .py file, bare or with folders (placeholders like `<name>/build.py`, `*_session.py` are
not references)."""
FOLDER_REF = re.compile(r"(?<![\w./<>*{-])((?:app|panels|robots|tests|examples)(?:/\w+)+/)(?!\w)")
DOTTED_REF = re.compile(r"(?<![\w./])(app(?:\.[A-Za-z_]\w*)+)")


def _prose(path: Path) -> Iterator[tuple[int, str]]:
    """(line number, text) of every comment and docstring-like string statement."""
    source = path.read_text(encoding="utf-8")
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Expr) and isinstance(getattr(node.value, "value", None), str):
            for i, line in enumerate(node.value.value.splitlines()):  # type: ignore[attr-defined]
                yield node.lineno + i, line


def _texts() -> Iterator[tuple[str, int, str]]:
    for name in DOCUMENTS:
        for n, line in enumerate((REPO / name).read_text(encoding="utf-8").splitlines(), 1):
            yield name, n, line
    for folder in SOURCE_FOLDERS:
        for path in sorted((REPO / folder).rglob("*.py")):
            where = path.relative_to(REPO).as_posix()
            for n, line in _prose(path):
                yield where, n, line


@cache
def _repo_files() -> tuple[str, ...]:
    return tuple(
        p.relative_to(REPO).as_posix()
        for folder in TOP_FOLDERS
        if (REPO / folder).is_dir()
        for p in (REPO / folder).rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    )


def _file_exists(ref: str) -> bool:
    if (REPO / ref).is_file() or any(f.endswith("/" + ref) for f in _repo_files()):
        return True
    package, _, rest = ref.partition("/")
    spec = importlib.util.find_spec(package) if rest and package.isidentifier() else None
    locations = spec.submodule_search_locations if spec is not None else None
    return bool(locations) and any((Path(loc) / rest).is_file() for loc in locations or ())


@cache
def _top_level_names(path: Path) -> frozenset[str]:
    names: set[str] = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
    return frozenset(names)


def _dotted_exists(ref: str) -> bool:
    """The longest package/module prefix exists, and the next part is a module in it or a
    top-level name of it."""
    folder = REPO
    parts = ref.split(".")
    for i, part in enumerate(parts):
        if (folder / part).is_dir():
            folder = folder / part
            continue
        module = folder / f"{part}.py"
        if module.is_file():
            rest = parts[i + 1 :]
            return not rest or rest[0] in _top_level_names(module)
        init = folder / "__init__.py"
        return init.is_file() and part in _top_level_names(init)
    return True


def _stale() -> list[str]:
    stale = []
    for where, n, line in _texts():
        for match in FILE_REF.finditer(line):
            if not _file_exists(match.group(1)):
                stale.append(f"{where}:{n}: {match.group(1)}")
        for match in FOLDER_REF.finditer(line):
            if not (REPO / match.group(1)).is_dir():
                stale.append(f"{where}:{n}: {match.group(1)}")
        for match in DOTTED_REF.finditer(line):
            if not _dotted_exists(match.group(1)):
                stale.append(f"{where}:{n}: {match.group(1)}")
    return stale


def test_every_module_path_named_in_the_prose_exists() -> None:
    stale = _stale()
    assert not stale, "stale module references:\n" + "\n".join(stale)


def test_the_checks_see_a_stale_reference(tmp_path: Path) -> None:
    """The three forms, on references that exist and ones that do not."""
    assert _file_exists("app/core/motions/trajectory.py") and _file_exists("nlp.py")
    assert _file_exists("viser/infra/_infra.py")
    assert not _file_exists("app/core/trajectory.py") and not _file_exists("no_such_module.py")
    assert _dotted_exists("app.core.servo.presets.PRESETS")
    assert _dotted_exists("app.core.posing.stance.stance_link")
    assert not _dotted_exists("app.core.stance.stance_link")
    assert not _dotted_exists("app.core.servo.presets.NO_SUCH_NAME")
    assert not _dotted_exists("app.core.compensation_files")
    assert FILE_REF.findall("robots/<name>/build.py and *_session.py") == []
