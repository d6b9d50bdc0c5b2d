"""Every way a zip can be broken is an UploadError, leaves nothing behind and keeps what the
store held; the whole unpacked archive is the upload's sandbox, however it is opened.

Broken archives are made by writing a good one with zipfile and patching the bytes the
format defines (APPNOTE.TXT): general-purpose flag bit 0 (encrypted), compression method 6
(implode), the CRC-checked data, the central directory's uncompressed size."""

from __future__ import annotations

import io
import os
import struct
import warnings
import zipfile
from pathlib import Path

import pytest
import trimesh

from app.core.errors import UploadError
from app.core.robot import uploads
from app.core.robot.loading import load_robot
from app.core.robot.uploads import UPLOAD_MARKER, store_upload
from tests.conftest import tiny_biped_urdf

LOCAL, CENTRAL = b"PK\x03\x04", b"PK\x01\x02"
URDF = tiny_biped_urdf().encode()


def _zip(entries: dict[str, bytes], method: int = zipfile.ZIP_DEFLATED) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=method) as archive, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "Duplicate name" is what one case wants
        for name, content in entries.items() if isinstance(entries, dict) else entries:
            archive.writestr(name, content)
    return buffer.getvalue()


def _patch_headers(content: bytes, local_offset: int, central_offset: int, value: bytes) -> bytes:
    """Overwrite a field of every local and central header."""
    data = bytearray(content)
    for signature, offset in ((LOCAL, local_offset), (CENTRAL, central_offset)):
        start = 0
        while (start := data.find(signature, start)) >= 0:
            data[start + offset : start + offset + len(value)] = value
            start += 4
    return bytes(data)


def _encrypted() -> bytes:
    return _patch_headers(_zip({"r.urdf": URDF}), 6, 8, struct.pack("<H", 1))


def _implode() -> bytes:
    return _patch_headers(_zip({"r.urdf": URDF}), 8, 10, struct.pack("<H", 6))


def _bad_crc() -> bytes:
    content = _zip({"r.urdf": URDF}, zipfile.ZIP_STORED)
    at = content.find(b'<robot name="tiny">') + 1
    return content[:at] + b"R" + content[at + 1 :]


def _central_size(content: bytes, size: int) -> bytes:
    """The central directory's uncompressed size of every entry (offset 24) set to `size`."""
    data = bytearray(content)
    start = data.find(CENTRAL)
    data[start + 24 : start + 28] = struct.pack("<I", size)
    return bytes(data)


BROKEN = {
    "not-a-zip": (b"this is not a zip", "not a valid zip"),
    "truncated": (_zip({"r.urdf": URDF})[:100], "not a valid zip"),
    "encrypted": (_encrypted(), "encrypted"),
    "implode": (_implode(), "compression method 6"),
    "bad-crc": (_bad_crc(), "damaged archive"),
    "size-smaller-than-data": (
        _central_size(_zip({"r.urdf": URDF}), 100),
        "damaged archive|more than its header",
    ),
    "size-larger-than-data": (_central_size(_zip({"r.urdf": URDF}), len(URDF) + 7), "r.urdf"),
    "long-name": (_zip({"a" * 300 + ".urdf": URDF}), "longer than 200 bytes"),
    "very-long-path": (_zip({"d/" * 300 + "r.urdf": URDF}), "606 characters"),
    "same-name-twice": (_zip([("r.urdf", URDF), ("r.urdf", b"x")]), "unpack to the same file"),
    "names-differ-by-case": (
        _zip({"r.urdf": URDF, "m/Foot.stl": b"a", "m/foot.STL": b"b"}),
        "unpack to the same file",
    ),
    "file-and-folder": (_zip({"r.urdf": URDF, "m": b"a", "m/foot.stl": b"b"}), "file and a folder"),
    "outside": (_zip({"r.urdf": URDF, "../../x.stl": b"a"}), "outside the archive"),
    "no-urdf": (_zip({"readme.txt": b"hi"}), "no .urdf"),
}


@pytest.mark.parametrize("case", BROKEN, ids=list(BROKEN))
def test_broken_zip_is_an_upload_error_and_leaves_nothing(case: str, tmp_path: Path) -> None:
    content, message = BROKEN[case]
    root = tmp_path / "uploads"
    kept = store_upload("kept.urdf", URDF, root)
    with pytest.raises(UploadError, match=message):
        store_upload("robot.zip", content, root)
    assert sorted(p.name for p in root.iterdir()) == [kept.parent.name]
    assert kept.read_bytes() == URDF


def _stl() -> bytes:
    return trimesh.creation.box(extents=(0.1, 0.05, 0.01)).export(file_type="stl")


@pytest.mark.parametrize(
    "uri",
    ["package://my_robot/meshes/foot.stl", "../meshes/foot.stl", "package://other/meshes/foot.stl"],
)
def test_ros_layout_zip_finds_its_meshes(uri: str, tmp_path: Path) -> None:
    """urdf/robot.urdf and meshes/ side by side at the archive's root: package://NAME is the
    archive's root when it holds no folder NAME."""
    urdf = tiny_biped_urdf(foot_geometry=f'<mesh filename="{uri}"/>').encode()
    path = store_upload(
        "robot.zip", _zip({"urdf/robot.urdf": urdf, "meshes/foot.stl": _stl()}), tmp_path
    )
    assert path.parent.name == "urdf"
    assert load_robot(path).missing_meshes == ()
    assert load_robot(path, sandbox=path.parent).missing_meshes == ()  # what the studio passes


def test_opening_a_stored_upload_by_path_keeps_its_sandbox(tmp_path: Path) -> None:
    """Issue 16's bypass: a mesh outside the upload was refused on upload but loaded when
    the stored URDF was opened by path. The upload's marker confines it either way."""
    secret = tmp_path / "secret"
    secret.mkdir()
    (secret / "foot.stl").write_bytes(_stl())
    root = tmp_path / "uploads"
    urdf = tiny_biped_urdf(foot_geometry='<mesh filename="../../secret/foot.stl"/>').encode()
    path = store_upload("robot.urdf", urdf, root)
    assert (path.parent / "../../secret/foot.stl").resolve().is_file()  # it does point there
    for robot in (load_robot(path), load_robot(str(path)), load_robot(path, sandbox=tmp_path)):
        assert [m.reason for m in robot.missing_meshes] == [
            "../../secret/foot.stl: outside the upload folder; refused"
        ] * 2


def test_a_marker_inside_the_archive_cannot_widen_the_sandbox(tmp_path: Path) -> None:
    content = _zip({"sub/robot.urdf": URDF, f"sub/{UPLOAD_MARKER}": b""})
    path = store_upload("robot.zip", content, tmp_path)
    assert uploads.upload_sandbox_of(path) == path.parents[1]  # the outermost marker


def test_store_keeps_the_newest_uploads_within_the_quota(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(uploads, "MAX_STORED_UPLOADS", 3)
    paths = []
    for k in range(5):
        paths.append(store_upload(f"r{k}.urdf", URDF + b" " * k, tmp_path))
        os.utime(paths[-1].parent, (1000 + k, 1000 + k))  # distinct ages
    remaining = sorted(p.name for p in tmp_path.iterdir())
    assert remaining == sorted(p.parent.name for p in paths[2:])


def test_store_bytes_quota(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(uploads, "MAX_STORE_BYTES", 3 * len(URDF) + 100)
    paths = []
    for k in range(4):
        paths.append(store_upload(f"r{k}.urdf", URDF + b" " * k, tmp_path))
        os.utime(paths[-1].parent, (1000 + k, 1000 + k))
    assert not paths[0].exists() and all(p.exists() for p in paths[1:])


def test_same_upload_twice_reuses_its_folder(tmp_path: Path) -> None:
    content = _zip({"robot.urdf": URDF})
    first = store_upload("a.zip", content, tmp_path)
    second = store_upload("b.zip", content, tmp_path)
    assert first == second and len(list(tmp_path.iterdir())) == 1


def test_interrupted_unpack_leftovers_are_cleaned(tmp_path: Path) -> None:
    (tmp_path / ".incoming-abc").mkdir()
    (tmp_path / ".incoming-abc" / "half.stl").write_bytes(b"x")
    store_upload("robot.urdf", URDF, tmp_path)
    assert not (tmp_path / ".incoming-abc").exists()
