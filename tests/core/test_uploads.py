"""Uploads stay in their own folder, within the caps, and refuse unsafe archives whole."""

from __future__ import annotations

import io
import stat
import zipfile

import pytest
import trimesh

from app.core.errors import UploadError
from app.core.robot.loading import load_robot
from app.core.robot.uploads import store_upload
from tests.conftest import tiny_biped_urdf


def _zip(entries: dict[str, bytes], symlinks: dict[str, str] | None = None) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
        for name, target in (symlinks or {}).items():
            info = zipfile.ZipInfo(name)
            info.external_attr = (stat.S_IFLNK | 0o777) << 16
            archive.writestr(info, target)
    return buffer.getvalue()


def _stl() -> bytes:
    return trimesh.creation.box(extents=(0.1, 0.05, 0.01)).export(file_type="stl")


def test_zip_with_urdf_and_meshes_loads_from_its_own_folder(tmp_path):
    urdf = tiny_biped_urdf(
        foot_geometry='<mesh filename="package://tiny_description/meshes/foot.stl"/>'
    )
    content = _zip(
        {
            "tiny_description/urdf/tiny.urdf": urdf.encode(),
            "tiny_description/meshes/foot.stl": _stl(),
        }
    )
    path = store_upload("tiny.zip", content, tmp_path / "uploads")
    assert path.is_relative_to(tmp_path / "uploads")
    robot = load_robot(path, sandbox=path.parents[2])
    assert robot.missing_meshes == ()


def test_plain_urdf_upload(tmp_path):
    path = store_upload("../../evil name.urdf", tiny_biped_urdf().encode(), tmp_path / "uploads")
    assert path.parent.parent == (tmp_path / "uploads").resolve()
    assert path.name == "evil_name.urdf"
    assert load_robot(path).n_actuated == 4


def test_upload_over_the_size_cap(tmp_path):
    with pytest.raises(UploadError, match=r"over the 1 MB upload limit"):
        store_upload("big.urdf", b" " * (2**20 + 1), tmp_path, max_bytes=2**20)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    "bad", ["../escape.urdf", "a/../../escape.stl", "/etc/evil.urdf", "C:/evil.urdf"]
)
def test_zip_slip_is_refused_and_nothing_written(tmp_path, bad):
    content = _zip({"robot/robot.urdf": tiny_biped_urdf().encode(), bad: b"x"})
    with pytest.raises(UploadError, match="points outside the archive's folder"):
        store_upload("slip.zip", content, tmp_path / "uploads")
    assert not (tmp_path / "uploads").exists()
    assert not (tmp_path / "escape.urdf").exists()


def test_zip_symlink_is_refused(tmp_path):
    content = _zip({"robot.urdf": tiny_biped_urdf().encode()}, symlinks={"meshes": "/etc"})
    with pytest.raises(UploadError, match="symbolic link"):
        store_upload("link.zip", content, tmp_path / "uploads")


def test_zip_bomb_by_declared_size_is_refused(tmp_path):
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("robot.urdf", tiny_biped_urdf())
        archive.writestr("zeros.bin", b"\0" * (600 * 2**20))
    with pytest.raises(UploadError, match="unpacks to 600 MB"):
        store_upload("bomb.zip", buffer.getvalue(), tmp_path / "uploads")


def test_wrong_kind_and_broken_archives(tmp_path):
    with pytest.raises(UploadError, match=r"upload a \.urdf file, or a \.zip"):
        store_upload("robot.sdf", b"<sdf/>", tmp_path)
    with pytest.raises(UploadError, match="not a valid zip"):
        store_upload("robot.zip", b"PK not really", tmp_path)
    with pytest.raises(UploadError, match=r"holds no \.urdf"):
        store_upload("meshes.zip", _zip({"a.stl": _stl()}), tmp_path)
