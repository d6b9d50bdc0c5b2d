"""The ghosts' batched scene nodes show the same poses as one scene node per link would."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import viser

from app.core.quaternions import wxyz_to_matrix
from app.core.robot.loading import load_robot
from app.views.ghosts_view import GhostsView
from app.views.robot_view import RobotView
from tests.studio.conftest import free_port

ROBAN = Path(__file__).resolve().parents[1] / "third_party/roban_s14/urdf/robanS14.urdf"


@pytest.fixture(scope="module")
def server():
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    yield server
    server.stop()


def random_configurations(robot, rng, count):
    q0 = robot.q_neutral
    lower = np.array([j.lower for j in robot.joints])
    upper = np.array([j.upper for j in robot.joints])
    out = []
    for _ in range(count):
        q = robot.with_joint_angles(q0, rng.uniform(lower, upper))
        q[:3] += rng.normal(scale=0.1, size=3)
        quat = rng.normal(size=4)
        q[3:7] = quat / np.linalg.norm(quat)
        out.append(q)
    return out


@pytest.mark.parametrize("name", ["servo_biped", str(ROBAN)])
def test_batched_ghosts_match_the_per_node_robot_views(server, name):
    if name != "servo_biped" and not ROBAN.exists():
        pytest.skip("Roban S14 not available")
    robot = load_robot(name)
    ghosts = GhostsView(server, robot, root="/test_ghosts")
    views = {
        ghost: RobotView(server, robot, root=f"/test_views/{ghost}", with_collision=False)
        for ghost in ("command", "without", "with")
    }
    visuals = [mesh for mesh in robot.meshes if mesh.role != "collision"]
    rng = np.random.default_rng(2)
    previous: dict[str, np.ndarray] = {}
    try:
        for _frame in range(5):
            poses = dict(zip(views, random_configurations(robot, rng, 3), strict=True))
            if previous:  # one ghost stays put: nothing of it need be sent again
                poses["with"] = previous["with"]
            with server.atomic():
                ghosts.update(poses)
                for ghost, q in poses.items():
                    views[ghost].update(q)
            previous = poses
            for ghost, view in views.items():
                positions, wxyzs = ghosts.mesh_poses(ghost)
                for i, mesh in enumerate(visuals):
                    link_position, link_wxyz = view.link_pose(mesh.link)
                    T_world_link = np.eye(4)
                    T_world_link[:3, :3] = wxyz_to_matrix(link_wxyz)
                    T_world_link[:3, 3] = link_position
                    expected = T_world_link @ mesh.T_link_mesh
                    np.testing.assert_allclose(positions[i], expected[:3, 3], atol=1e-9)
                    np.testing.assert_allclose(
                        wxyz_to_matrix(wxyzs[i]), expected[:3, :3], atol=1e-9
                    )
        # hidden ghosts are drawn at scale 0 and come back where they were asked to be
        assert ghosts.shown("with") and not ghosts.shown("planned")
        ghosts.set_visible("with", False)
        assert not ghosts.shown("with")
        ghosts.set_visible("with", True)
        assert ghosts.shown("with")
        ghosts.forget("with")
        assert not ghosts.shown("with")
    finally:
        ghosts.remove()
        for view in views.values():
            view.remove()
