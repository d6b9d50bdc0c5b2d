"""An upload says what it is doing while the studio unpacks, reads and checks it: the Robot
panel's status line goes through each stage in order, one line per mesh file, and ends on the
loaded robot (or, for a refused one, on why)."""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
import zipfile

import pytest
import trimesh
import viser

from tests.conftest import tiny_biped_urdf


def _ros_layout_zip() -> tuple[bytes, int]:
    """urdf/robot.urdf beside meshes/foot.stl; and how many mesh geometries the URDF has
    (counted in its XML, independently of the studio)."""
    urdf = tiny_biped_urdf(foot_geometry='<mesh filename="package://tiny/meshes/foot.stl"/>')
    meshes = len(ET.fromstring(urdf).findall(".//geometry/mesh"))
    stl = trimesh.creation.box(extents=(0.1, 0.05, 0.01)).export(file_type="stl")
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("urdf/robot.urdf", urdf)
        archive.writestr("meshes/foot.stl", stl)
    return buffer.getvalue(), meshes


def test_an_upload_shows_each_stage_then_the_robot(studio):
    content, meshes = _ros_layout_zip()
    assert meshes >= 2
    seen: list[str] = []
    disconnect = studio.robots.stage.connect(seen.append)
    try:
        studio.robots.panel.receive_upload(viser.UploadedFile("tiny.zip", content))
    finally:
        disconnect()
    assert studio.state.robot.name == "tiny" and studio.state.robot.missing_meshes == ()
    assert seen[0].startswith("Received **tiny.zip**") and "kB" in seen[0]
    stages = [re.sub(r" \(\d+\.\d s\)$", "", line.split(": ", 1)[1]) for line in seen[1:]]
    assert stages == [
        "reading the URDF…",
        *(f"mesh {i} of {meshes}…" for i in range(1, meshes + 1)),
        "finding the feet…",
        "checking the robot…",
        "preparing the posing…",
        "building the scene…",
    ]
    elapsed = [
        float(m.group(1)) for line in seen[1:] if (m := re.search(r"\((\d+\.\d) s\)$", line))
    ]
    assert len(elapsed) == len(stages) and elapsed == sorted(elapsed)
    assert "**tiny**" in studio.robots.panel.status.content  # the end: the robot loaded


def test_a_refused_upload_ends_on_why(studio):
    seen: list[str] = []
    disconnect = studio.robots.stage.connect(seen.append)
    try:
        studio.robots.panel.receive_upload(viser.UploadedFile("broken.urdf", b"<robot"))
    finally:
        disconnect()
    assert studio.state.robot.name == "servo_biped"
    assert seen[0].startswith("Received **broken.urdf**")
    status = studio.robots.panel.status.content
    assert status.startswith("⚠️") and "previous robot is still loaded" in status


@pytest.mark.expected_traceback("app.studio.robot_session")
def test_a_library_failure_names_the_stage_it_failed_in(studio, monkeypatch):
    """A failure no check of ours foresaw (injected here: the feet finder raising) is reported
    with the stage the load was in, and the previous robot stays."""
    import app.core.robot.loading as loading

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(loading, "find_foot_links", broken)
    content, _meshes = _ros_layout_zip()
    studio.robots.panel.receive_upload(viser.UploadedFile("tiny.zip", content))
    assert studio.state.robot.name == "servo_biped"
    status = studio.robots.panel.status.content
    assert "ZeroDivisionError while finding the feet: float division by zero" in status
    assert "previous robot is still loaded" in status
