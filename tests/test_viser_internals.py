"""viser's private API is reached only from app/web/viser_internals.py, for the viser version
pyproject.toml pins, and every reach there works on the installed viser.

The private names are read from viser's own source (every `_name` it defines: attributes it
assigns, methods, classes, module-level names), not from a list of ours; the studio's source
is then searched for them: attribute access (`handle._impl`), imports (`from viser import
_messages`, `viser.infra._infra`) and strings (`getattr(server, "_thread_executor")`).
"""

from __future__ import annotations

import ast
import re
import tomllib
from concurrent.futures import ThreadPoolExecutor
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import viser

from app.web import viser_internals
from app.web.hook import guard_requests, hooked_viser_server
from app.web.viser_internals import PINNED_VISER, ViserHookError, check_viser_version
from tests.conftest import REPO

ADAPTER = REPO / "app" / "web" / "viser_internals.py"
SOURCE_FOLDERS = ("app", "panels", "robots")


@cache
def viser_private_names() -> frozenset[str]:
    names: set[str] = set()
    for path in Path(viser.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                names.add(node.attr)
            elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(node.name)
            elif isinstance(node, ast.AnnAssign | ast.Assign):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                names.update(t.id for t in targets if isinstance(t, ast.Name))
        names.add(path.stem)  # private modules: _messages, _infra
    return frozenset(n for n in names if len(n) > 1 and n[0] == "_" and n[1] != "_")


def private_reaches(source: str) -> list[str]:
    """Where `source` uses a private viser name (line: what)."""
    private = viser_private_names()
    tree = ast.parse(source)
    in_fstrings = {
        id(part)
        for node in ast.walk(tree)
        if isinstance(node, ast.JoinedStr)
        for part in node.values
    }
    found = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.Attribute) and node.attr in private:
            owner = node.value
            if not (isinstance(owner, ast.Name) and owner.id in ("self", "cls")):
                found.append(f"{line}: .{node.attr}")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("viser"):
            parts = [*(node.module or "").split("."), *(a.name for a in node.names)]
            found += [f"{line}: import {p}" for p in parts if p.startswith("_")]
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("viser") and any(
                    p.startswith("_") for p in alias.name.split(".")
                ):
                    found.append(f"{line}: import {alias.name}")
        elif (
            isinstance(node, ast.Constant) and node.value in private and id(node) not in in_fstrings
        ):
            found.append(f"{line}: {node.value!r}")
    return found


def test_the_names_are_read_from_viser_and_found_in_code() -> None:
    assert {"_impl", "_queue_scene_message", "_websock_server", "_messages"} <= (
        viser_private_names()
    )
    sample = (
        "from viser import _messages\nimport viser.infra._infra as i\n"
        "u = handle._impl.uuid\ne = getattr(server, '_thread_executor')\nself._impl = 1\n"
    )
    assert private_reaches(sample) == [
        "1: import _messages",
        "2: import viser.infra._infra",
        "3: ._impl",
        "4: '_thread_executor'",
    ]


def test_nothing_but_the_adapter_reaches_into_viser() -> None:
    reaches = {
        path.relative_to(REPO).as_posix(): found
        for folder in SOURCE_FOLDERS
        for path in sorted((REPO / folder).rglob("*.py"))
        if path != ADAPTER and (found := private_reaches(path.read_text(encoding="utf-8")))
    }
    assert reaches == {}
    assert private_reaches(ADAPTER.read_text(encoding="utf-8"))  # it does reach: the one place


def test_the_pin_is_pyprojects_and_the_installed_viser() -> None:
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    pins = [d for d in project["project"]["dependencies"] if re.match(r"viser\s*==", d)]
    assert [p.split("==")[1].strip() for p in pins] == [PINNED_VISER]
    check_viser_version()  # the installed one
    with pytest.raises(ViserHookError, match=f"install viser=={PINNED_VISER}"):
        check_viser_version("1.2.0")


def test_another_viser_version_is_refused_before_a_server_starts(monkeypatch) -> None:
    made: list[int] = []
    monkeypatch.setattr(viser, "__version__", "9.9.9")
    policy_wrap = guard_requests(None)  # type: ignore[arg-type]  # never reached
    with pytest.raises(ViserHookError, match="viser 9.9.9 is installed"):
        hooked_viser_server(lambda: made.append(1), policy_wrap)  # type: ignore[arg-type,return-value]
    assert made == []


@pytest.fixture(scope="module")
def server():
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        yield server
    finally:
        server.stop()


def test_every_reach_works_on_the_installed_viser(server: viser.ViserServer) -> None:
    slots = viser_internals.gui_edit_handlers(server)
    assert [s.message_cls for s in slots] == [
        viser_internals.GuiUpdateMessage,
        viser_internals.FileTransferStartUpload,
        viser_internals.CommandTriggerMessage,
    ]
    assert all(s.registered[s.index] == s.original for s in slots)
    assert isinstance(viser_internals.callback_executor(server), ThreadPoolExecutor)
    assert viser_internals.upload_states(server) == {}
    assert callable(viser_internals.websock_server(server).register_handler)
    assert callable(viser_internals.viser_websockets().asyncio.server.serve)
    viser_internals.send_upload_receipts_to_their_tab(server)  # reads viser's private names

    a, b = server.gui.add_checkbox("a", False), server.gui.add_checkbox("b", True)
    ids = {viser_internals.gui_input_id(a), viser_internals.gui_input_id(b)}
    assert len(ids) == 2 and all(ids)
    assert viser_internals.gui_input_values(server, viser_internals.gui_input_id(b), ["value"]) == {
        "value": True
    }
    assert viser_internals.gui_input_values(server, "no such input", ["value"]) == {}


def test_a_queued_pose_reads_back_as_after_an_assignment(server: viser.ViserServer) -> None:
    node = server.scene.add_frame("/pose_test", show_axes=False)
    viser_internals.queue_node_pose(node, (0.1, -0.2, 0.3), (0.0, 1.0, 0.0, 0.0))
    np.testing.assert_array_equal(node.position, [0.1, -0.2, 0.3])
    np.testing.assert_array_equal(node.wxyz, [0.0, 1.0, 0.0, 0.0])
    node.remove()
    with pytest.raises(RuntimeError, match="removed scene node /pose_test"):
        viser_internals.queue_node_pose(node, (0.0, 0.0, 0.0), None)
