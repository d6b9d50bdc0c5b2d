"""The core readers directly: the input gate, the mesh gate, the allowed-folders policy, the
atomic writer and the run budgets, each fed what a hostile user would feed it."""

from __future__ import annotations

import io
import os
import struct
from pathlib import Path

import numpy as np
import pytest

from app.core import input_gate
from app.core.atomic_write import OutputError, write_atomically
from app.core.budgets import MAX_SAMPLES, BudgetExceeded
from app.core.errors import StudioError
from app.core.file_access import FileAccess, PathNotAllowed
from app.core.input_gate import InputRefused
from app.core.motions.csv_files import read_trajectory_csv
from app.core.robot.loading import load_robot
from app.core.robot.mesh_gate import MAX_MESH_TRIANGLES, check_stl, read_mesh_file
from app.core.servo.calibration import read_measured_csv
from app.core.servo.files import check_commands, read_coefficients_toml, read_torque_csv
from tests.conftest import tiny_biped_urdf


@pytest.fixture
def fifo(tmp_path: Path) -> Path:
    path = tmp_path / "pipe"
    os.mkfifo(path)
    return path


READERS = {
    "urdf": lambda path: load_robot(path),
    "motion-csv": lambda path: read_trajectory_csv(path, load_robot("servo_biped")),
    "torque-csv": lambda path: read_torque_csv(path, ("a",)),
    "measured-csv": read_measured_csv,
    "k-toml": read_coefficients_toml,
    "plan-toml": lambda path: input_gate.read_toml(path),
    "mesh": lambda path: read_mesh_file(Path(str(path) + ".stl")),
}


@pytest.mark.parametrize("reader", READERS, ids=list(READERS))
@pytest.mark.parametrize("what", ["fifo", "/dev/zero", "folder"])
def test_every_reader_refuses_what_is_not_a_regular_file(reader, what, fifo, tmp_path) -> None:
    """A pipe with no writer would block a plain open() forever; the gate never opens it."""
    if what == "fifo":
        path = fifo
    elif what == "folder":
        path = tmp_path / "folder"
        path.mkdir()
    else:
        path = Path(what)
    if reader == "mesh":
        target = Path(str(path) + ".stl")
        if not target.exists():
            target.symlink_to(path)
    with pytest.raises(StudioError, match="pipe|device|folder"):
        READERS[reader](path)


def test_size_is_checked_before_reading(tmp_path: Path) -> None:
    path = tmp_path / "huge.toml"
    with open(path, "wb") as file:
        file.truncate(input_gate.TOML.max_bytes + 1)
    with pytest.raises(InputRefused, match="over 1.0 MiB"):
        input_gate.read_bytes(path, input_gate.TOML)
    path.write_bytes(b"x" * input_gate.TOML.max_bytes)  # exactly at the limit is read
    assert len(input_gate.read_bytes(path, input_gate.TOML)) == input_gate.TOML.max_bytes


def test_not_utf8_names_the_byte(tmp_path: Path) -> None:
    path = tmp_path / "latin1.csv"
    path.write_bytes("t [s],caf\xe9\n".encode("latin-1"))
    with pytest.raises(InputRefused, match=r"byte 9 is 0xe9"):
        input_gate.read_text(path, input_gate.MOTION_CSV)
    path.write_bytes("\ufefft [s]\n".encode())  # a byte-order mark is not part of the text
    assert input_gate.read_text(path, input_gate.MOTION_CSV) == "t [s]\n"


@pytest.mark.parametrize(
    "text, message",
    [
        ("a = " + "[" * 1000 + "]" * 1000, "nested"),
        ("a = " + "[" * 17 + "]" * 17, "nested 17 levels"),
        ("[" + ".".join(["t"] * 20) + "]\nx = 1", "nested"),
        ("a = " + "9" * 5000, "cannot be read"),
        ("a = " + "9" * 20, "20 digits"),
        ("a = -" + "9" * 19, "19 digits"),
        ("a = nan", "finite"),
        ("a = -inf", "finite"),
        ("a = [1, 2", "not valid TOML"),
    ],
)
def test_toml_limits(text: str, message: str) -> None:
    with pytest.raises(InputRefused, match=message):
        input_gate.parse_toml(text, "x.toml")


def test_toml_within_limits_is_read() -> None:
    text = "a = " + "[" * 16 + "1" + "]" * 16 + f"\nb = {2**63 - 1}\nc = 1.5e300\n"
    data = input_gate.parse_toml(text, "x.toml")
    assert data["b"] == 2**63 - 1 and data["c"] == 1.5e300


# --- meshes ------------------------------------------------------------------------------


def _binary_stl(n: int, extra: bytes = b"") -> bytes:
    return b"\0" * 80 + struct.pack("<I", n) + b"\0" * (50 * n) + extra


def test_binary_stl_count_must_match_the_size() -> None:
    assert check_stl(_binary_stl(3), "ok.stl") == 3
    assert check_stl(_binary_stl(3, b"\0" * 2), "ok.stl") == 3  # a few trailing bytes
    with pytest.raises(InputRefused, match="claims 4 triangles"):
        check_stl(_binary_stl(3)[:84].replace(struct.pack("<I", 3), struct.pack("<I", 4)), "x")
    too_many = MAX_MESH_TRIANGLES + 1
    header_only = b"\0" * 80 + struct.pack("<I", too_many)
    with pytest.raises(InputRefused, match=f"claims {too_many}"):
        check_stl(header_only, "x.stl")


def test_ascii_stl_counts_facets() -> None:
    facet = b"facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
    assert check_stl(b"solid x\n" + facet * 2 + b"endsolid x\n", "a.stl") == 2


@pytest.mark.parametrize("name", ["m.stl.gz", "m.bz2", "m.zip", "m.tar.gz", "m.dae.xz"])
def test_compressed_meshes_are_refused_unread(name: str, tmp_path: Path) -> None:
    (tmp_path / name).write_bytes(b"anything")
    with pytest.raises(InputRefused, match="compressed"):
        read_mesh_file(tmp_path / name)


def test_ply_header_counts_are_bounded(tmp_path: Path) -> None:
    path = tmp_path / "m.ply"
    path.write_bytes(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nend_header\n"
    )
    with pytest.raises(InputRefused, match="4000000000 vertex"):
        read_mesh_file(path)


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".dae", ".ply", ".off", ".glb"])
def test_every_accepted_format_loads_from_bytes(suffix: str, tmp_path: Path) -> None:
    """A 0.1 × 0.2 × 0.3 m box written by trimesh in each accepted format loads back with
    its 12 triangles and its extents (the gate hands trimesh bytes, not a path)."""
    import trimesh

    from app.core.robot.meshes import _load_file

    exported = trimesh.creation.box((0.1, 0.2, 0.3)).export(file_type=suffix[1:])
    path = tmp_path / f"box{suffix}"
    path.write_bytes(exported if isinstance(exported, bytes) else exported.encode())
    mesh = _load_file(path, np.ones(3))
    assert not isinstance(mesh, str), mesh
    assert len(mesh.faces) == 12
    np.testing.assert_allclose(mesh.extents, (0.1, 0.2, 0.3), atol=1e-6)


def test_dae_with_entities_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "m.dae"
    path.write_text(
        '<?xml version="1.0"?><!DOCTYPE c [<!ENTITY x SYSTEM "file:///etc/hostname">]>'
        '<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema">&x;</COLLADA>'
    )
    with pytest.raises(InputRefused, match="DOCTYPE or XML entities"):
        read_mesh_file(path)


def test_mesh_is_read_without_its_folder(tmp_path: Path) -> None:
    """An OBJ naming a material library elsewhere loads, without trimesh reading that file:
    the loader is given bytes, not a path (an unreadable mtllib would make it fail)."""
    obj = tmp_path / "m.obj"
    obj.write_text("mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    urdf = tmp_path / "r.urdf"
    urdf.write_text(tiny_biped_urdf(foot_geometry='<mesh filename="m.obj"/>'))
    robot = load_robot(urdf)
    assert robot.missing_meshes == ()


# --- the allowed-folders policy ---------------------------------------------------------


def test_paths_outside_the_allowed_folders_are_refused_alike(tmp_path: Path) -> None:
    """The message for a file that exists outside is the same as for one that does not."""
    inside, outside = tmp_path / "work", tmp_path / "elsewhere"
    inside.mkdir()
    outside.mkdir()
    (outside / "secret.urdf").write_text(tiny_biped_urdf())
    access = FileAccess.for_studio(inside)
    messages = []
    for path in (outside / "secret.urdf", outside / "nothing.urdf", outside, Path("/dev/zero")):
        with pytest.raises(PathNotAllowed) as refused:
            load_robot(str(path), access=access)
        messages.append(str(refused.value).replace(str(path), "PATH"))
    assert len(set(messages)) == 1, messages


def test_a_link_out_of_an_allowed_folder_is_refused(tmp_path: Path) -> None:
    inside, outside = tmp_path / "work", tmp_path / "elsewhere"
    inside.mkdir()
    outside.mkdir()
    (outside / "robot.urdf").write_text(tiny_biped_urdf())
    (inside / "robot.urdf").symlink_to(outside / "robot.urdf")
    access = FileAccess.for_studio(inside)
    assert not access.allows(inside / "robot.urdf")
    with pytest.raises(PathNotAllowed):
        load_robot(inside / "robot.urdf", access=access)


def test_a_folder_whose_urdf_links_outside_is_refused(tmp_path: Path) -> None:
    inside, outside = tmp_path / "work", tmp_path / "elsewhere"
    (inside / "robot").mkdir(parents=True)
    outside.mkdir()
    (outside / "robot.urdf").write_text(tiny_biped_urdf())
    (inside / "robot" / "robot.urdf").symlink_to(outside / "robot.urdf")
    with pytest.raises(PathNotAllowed):
        load_robot(inside / "robot", access=FileAccess.for_studio(inside))


def test_meshes_stay_in_the_allowed_folders(tmp_path: Path) -> None:
    inside, outside = tmp_path / "work", tmp_path / "elsewhere"
    inside.mkdir()
    outside.mkdir()
    import trimesh

    (outside / "foot.stl").write_bytes(
        trimesh.creation.box((0.1, 0.05, 0.01)).export(file_type="stl")
    )
    urdf = inside / "robot.urdf"
    urdf.write_text(tiny_biped_urdf(foot_geometry='<mesh filename="../elsewhere/foot.stl"/>'))
    assert load_robot(urdf).missing_meshes == ()  # without a policy (the CLI): found
    robot = load_robot(urdf, access=FileAccess.for_studio(inside))
    assert [m.reason for m in robot.missing_meshes] == [
        "../elsewhere/foot.stl: outside the allowed folders; refused"
    ] * 2


def test_builtins_are_allowed_by_name_and_path(tmp_path: Path) -> None:
    from robots.catalogue import BUILTIN_ROBOTS

    access = FileAccess.for_studio(tmp_path)
    assert load_robot("servo_biped", access=access).name
    assert access.allows(BUILTIN_ROBOTS["servo_biped"].urdf_path)


# --- writing -----------------------------------------------------------------------------


def test_a_writer_that_fails_leaves_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"
    target.write_text("old\n")

    def half_then_fail(file) -> None:
        file.write("new, half")
        raise OSError(28, "No space left on device")

    with pytest.raises(OutputError, match="No space left on device; nothing was written"):
        write_atomically(target, half_then_fail)
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_write_into_a_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="No such file or directory"):
        write_atomically(tmp_path / "no" / "out.csv", lambda file: file.write("x"))


def test_command_check_names_joint_and_sample() -> None:
    t = np.array([0.0, 0.1, 0.2])
    q = np.zeros((3, 2))
    q[2, 1] = 0.6
    lower, upper = np.array([-1.0, -0.5]), np.array([1.0, 0.5])
    with pytest.raises(StudioError, match=r"of b at sample 2 \(t = 0.2 s\) is 34.3775°"):
        check_commands(t, ("a", "b"), q, lower, upper)
    q[2, 1] = np.inf
    with pytest.raises(StudioError, match="of b at sample 2 .* is inf"):
        check_commands(t, ("a", "b"), q)
    q[2, 1] = 0.5  # exactly at the limit is allowed
    check_commands(t, ("a", "b"), q, lower, upper)


# --- budgets -----------------------------------------------------------------------------


def test_too_many_rows_are_refused_while_reading() -> None:
    rows = "t [s],tau:a [N·m]\n" + "".join(f"{k},0\n" for k in range(MAX_SAMPLES + 1))
    with pytest.raises(StudioError, match=f"more than {MAX_SAMPLES} samples"):
        read_torque_csv(io.StringIO(rows), ("a",))


def test_motion_budget_is_checked_before_solving() -> None:
    from app.core.motions.library import run_motion

    robot = load_robot("servo_biped")
    with pytest.raises(BudgetExceeded, match="samples; at most 100000"):
        run_motion(robot, "one_leg_squats", dt=1e-4, squats=100)


def test_a_nul_in_a_typed_path_is_one_line_everywhere(tmp_path: Path) -> None:
    """*Save as*, *Open* and *Open path* with a NUL byte in the path: refused in one line, no
    traceback (os calls raise ValueError on such a name), the work kept."""
    from tests.studio.conftest import start_studio

    studio = start_studio(tmp_path / "data")
    try:
        robot = studio.state.robot
        for action in (
            lambda: studio.project.save_as("my\0project"),
            lambda: studio.project.open("my\0project.bstudio"),
            lambda: studio.robots.load("robot\0.urdf"),
        ):
            assert action() is False
            assert "NUL" in studio.notifier.last_error
            assert "\n" not in studio.notifier.last_error
        assert studio.state.robot is robot
    finally:
        studio.stop()
