"""Work restored from autosave keeps the project it was: its name in the Project panel's title
and its file, so *Save* writes there again; untitled work comes back as "untitled (restored)"."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.config import StudioConfig
from app.core.projects.files import project_bytes, read_project
from app.studio import Studio
from tests.same_values import assert_same
from tests.studio.conftest import free_port, start_studio, wait_for_signal


def _restart(data) -> Studio:
    return Studio(StudioConfig(port=free_port(), data_dir=data, restore_autosave=True))


def test_a_restored_project_keeps_its_name_and_file(tmp_path):
    data = tmp_path / "data"
    first = start_studio(data)
    try:
        assert first.project.save_as("walker")
        path = data / "projects" / "walker.bstudio"
        assert first.project.path == path
        wait_for_signal(
            first.project.autosave.written, lambda: first.joints.set_joint_angle(1, 0.2)
        )
        q = first.state.q.copy()
    finally:
        first.stop()
    second = _restart(data)
    try:
        project = second.project
        assert_same(second.state.q, q, "restored q")
        assert project.name == "walker" and project.path == path
        assert project.panel.title.content.startswith("**walker** ● unsaved changes")
        assert project.panel.path.value == str(path)
        assert "walker" in project.welcome
        # Save (no path typed) goes to the project's own file, which then holds the work.
        assert not np.array_equal(read_project(path).q, q)  # the file: the work before the edit
        assert project.save()
        assert_same(read_project(path).q, q, "saved q")
        assert "● unsaved" not in project.panel.title.content
    finally:
        second.stop()


def test_untitled_work_is_restored_as_untitled(tmp_path):
    data = tmp_path / "data"
    first = start_studio(data)
    try:
        autosave = wait_for_signal(
            first.project.autosave.written, lambda: first.joints.set_joint_angle(0, -0.1)
        )
        assert read_project(autosave).autosave_of == ""
    finally:
        first.stop()
    # An edited autosave naming a relative path: the name stays, the path is not trusted.
    edited = dataclasses.replace(
        read_project(autosave), autosave_of="kept", autosave_path="../x.bstudio"
    )
    (autosave.parent / "autosave-29990101T000000-000000Z.bstudio").write_bytes(
        project_bytes(edited)
    )
    second = _restart(data)
    try:
        assert second.project.name == "kept" and second.project.path is None
    finally:
        second.stop()
    for newest in sorted((data / "autosave").iterdir())[-1:]:
        newest.unlink()  # back to the studio's own autosave
    third = _restart(data)
    try:
        assert third.project.name == "untitled (restored)" and third.project.path is None
        assert third.project.panel.title.content.startswith("**untitled (restored)**")
    finally:
        third.stop()
