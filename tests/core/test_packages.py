"""package://, relative and file:// mesh paths resolve where a ROS user would put the files."""

from __future__ import annotations

import pytest
import trimesh

from app.core.robot.loading import load_robot
from app.core.robot.packages import PackageResolver
from tests.conftest import tiny_biped_urdf


def _mesh(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(0.1, 0.05, 0.01)).export(path)
    return path


def test_package_is_an_ancestor_of_the_urdf(tmp_path, write_urdf):
    _mesh(tmp_path / "my_robot_description" / "meshes" / "foot.stl")
    urdf = write_urdf(
        tiny_biped_urdf(
            foot_geometry='<mesh filename="package://my_robot_description/meshes/foot.stl"/>'
        ),
        name="my_robot_description/urdf/robot.urdf",
    )
    robot = load_robot(urdf)
    assert robot.missing_meshes == ()
    # The feet stand on their meshes: 0.10 x 0.05 m soles.
    corners = robot.feet[0].sole_corners_m
    assert abs(corners[1, 0] - corners[0, 0]) == pytest.approx(0.10)


def test_package_is_a_sibling_of_an_ancestor(tmp_path, write_urdf):
    mesh = _mesh(tmp_path / "ws" / "src" / "shared_meshes" / "foot.stl")
    urdf = write_urdf(
        tiny_biped_urdf(foot_geometry='<mesh filename="package://shared_meshes/foot.stl"/>'),
        name="ws/src/my_robot/urdf/robot.urdf",
    )
    resolution = PackageResolver(urdf.parent).resolve("package://shared_meshes/foot.stl")
    assert resolution.path == mesh.resolve()
    assert load_robot(urdf).missing_meshes == ()


def test_package_found_through_user_roots_and_ros_package_path(tmp_path, monkeypatch):
    mesh = _mesh(tmp_path / "elsewhere" / "pkg_a" / "m.stl")
    other = _mesh(tmp_path / "ros" / "pkg_b" / "m.stl")
    urdf_dir = tmp_path / "robot"
    urdf_dir.mkdir()
    assert PackageResolver(urdf_dir).resolve("package://pkg_a/m.stl").path is None
    assert (
        PackageResolver(urdf_dir, (tmp_path / "elsewhere",)).resolve("package://pkg_a/m.stl").path
        == mesh.resolve()
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros"))
    assert PackageResolver(urdf_dir).resolve("package://pkg_b/m.stl").path == other.resolve()


def test_relative_and_file_uris(tmp_path):
    mesh = _mesh(tmp_path / "meshes" / "a.stl")
    resolver = PackageResolver(tmp_path)
    assert resolver.resolve("meshes/a.stl").path == mesh.resolve()
    assert resolver.resolve(f"file://{mesh}").path == mesh.resolve()
    assert "malformed" in resolver.resolve("package://just_a_name").reason


def test_sandbox_keeps_lookups_inside_the_upload_folder(tmp_path):
    outside = _mesh(tmp_path / "secret" / "a.stl")
    upload = tmp_path / "upload"
    upload.mkdir()
    resolver = PackageResolver(upload, sandbox=upload)
    for uri in (str(outside), f"file://{outside}", "../secret/a.stl"):
        result = resolver.resolve(uri)
        assert result.path is None and "outside the upload folder" in result.reason, uri
    assert PackageResolver(upload).resolve("../secret/a.stl").path == outside.resolve()


def test_corrupt_mesh_is_reported_not_raised(tmp_path, write_urdf):
    (tmp_path / "foot.stl").write_bytes(b"solid nonsense\nthis is not an stl\n")
    robot = load_robot(write_urdf(tiny_biped_urdf(foot_geometry='<mesh filename="foot.stl"/>')))
    assert len(robot.missing_meshes) == 2
    assert all(m.uri == "foot.stl" for m in robot.missing_meshes)


@pytest.mark.parametrize("suffix", ["stl", "obj", "dae"])
def test_mesh_formats_and_scale(tmp_path, write_urdf, suffix):
    """STL, OBJ and COLLADA meshes load through trimesh; the URDF's scale is applied per axis."""
    trimesh.creation.box(extents=(100.0, 50.0, 10.0)).export(tmp_path / f"foot.{suffix}")
    geometry = f'<mesh filename="foot.{suffix}" scale="0.001 0.001 0.001"/>'
    robot = load_robot(write_urdf(tiny_biped_urdf(foot_geometry=geometry)))
    assert robot.missing_meshes == ()
    corners = robot.feet[0].sole_corners_m
    assert abs(corners[1, 0] - corners[0, 0]) == pytest.approx(0.10)
    assert abs(corners[2, 1] - corners[1, 1]) == pytest.approx(0.05)
