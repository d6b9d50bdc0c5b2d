"""Every link collides with the floor (app.core.simulation.link_geoms), checked without the
studio's own recording: the URDF's collision shapes against the URDF text read here, a
fitted primitive against its mesh's vertices, a pushed-over robot's resting height and the
lowest point of each geom from MuJoCo's own body and geom poses (closed forms per shape),
the first link on the floor against those poses sample by sample; and standing runs the same
bit for bit with and without the links' geoms (the feet keep their soles)."""

from __future__ import annotations

import dataclasses
from xml.etree import ElementTree

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.trajectory import Trajectory
from app.core.robot.loading import load_robot
from app.core.servo.model import joint_angles
from app.core.simulation.engine import pin_to_qpos, run_engine, start
from app.core.simulation.files import sized_servos
from app.core.simulation.mjcf import SimOptions, build_sim_model
from app.core.simulation.run import finish, prepare, simulate_commands
from tests.conftest import ROBAN_URDF
from tests.trajectory_slices import first_samples

REST_PENETRATION_M = 0.001
"""MuJoCo's soft contact lets a body resting on the floor sink into it a little (for
servo_biped lying down, about 0.04 mm); a link through the floor is centimetres below."""
TOUCH_M = 1e-4
"""A geom whose lowest point is this close to the floor (or below) touches it (MuJoCo's
contact margin is 0: a contact exists from penetration on)."""


def _lowest_z(m, d, g: int) -> float:
    """The lowest point of geom g in the world [m], from its pose and size (closed forms)."""
    kind, size = m.geom_type[g], m.geom_size[g]
    R, p = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return float(p[2] - size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return float(p[2] - abs(R[2, 2]) * size[1] - size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return float(p[2] - abs(R[2, 2]) * size[1] - size[0] * np.hypot(R[2, 0], R[2, 1]))
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return float(p[2] - np.abs(R[2, :]) @ size)
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = m.geom_dataid[g]
        a, n = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
        return float((p[2] + m.mesh_vert[a : a + n] @ R[2]).min())
    raise AssertionError(f"geom {g} of type {kind}")


def _pushed(robot, tilt_rad: float, seconds: float) -> Trajectory:
    """The robot's ready stance tilted forward by `tilt_rad` about its base and held so (a
    push at t = 0): standing on its toes' edge, it topples."""
    from app.core.motions.library import run_motion

    q0 = run_motion(robot, "com_shift").trajectory.q[0].copy()
    R = pin.Quaternion(q0[6], q0[3], q0[4], q0[5]).toRotationMatrix()
    tilted = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, tilt_rad, 0.0) @ R)
    q0[3:7] = tilted.x, tilted.y, tilted.z, tilted.w
    n = round(seconds / 0.01) + 1
    zero = np.zeros((n, robot.model.nv))
    q = np.repeat(q0[None], n, axis=0)
    contacts = np.ones((n, 2), bool)
    return Trajectory("pushed", robot.joint_names, np.arange(n) * 0.01, q, zero, zero, contacts)


def _state(inp, q_pin):
    """MuJoCo's model and data of the run at configuration q_pin, forward-computed."""
    m, d, _, _ = start(inp)
    pin_to_qpos(inp.sim, q_pin, d.qpos)
    mujoco.mj_forward(m, d)
    return m, d


@pytest.fixture(scope="module")
def pushed(servo_biped):
    return _pushed(servo_biped, 0.45, 2.0)


@pytest.mark.parametrize("links_collide", [True, False])
def test_a_pushed_over_robot_comes_to_rest_on_its_links(servo_biped, pushed, links_collide):
    """Tilted 26° forward on stiff servos it topples; 2 s later, at rest, its pelvis (the
    root body, MuJoCo's xpos) is above the floor and no geom of it is below the floor by
    more than a soft contact's sinking. Without the links' geoms (the model before) the
    same robot ends with its pelvis under the floor: the check can fail."""
    robot = servo_biped
    servo = sized_servos(robot)
    options = SimOptions(links_collide=links_collide)
    q_plan = joint_angles(robot, pushed.q)
    inp = prepare(robot, pushed, q_plan, servo, options, settle_s=0.0)
    run = run_engine(dataclasses.replace(inp, detect_falls=False))
    m, d = _state(inp, run.q[-1])
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, inp.sim.root_body)
    assert np.linalg.norm(run.root_position_m[-1] - d.xpos[root]) < 1e-9
    start_height = _state(inp, pushed.q[0])[1].xpos[root][2]
    if not links_collide:
        assert d.xpos[root][2] < 0.0  # sunk through the floor
        return
    assert np.abs(run.v[-1]).max() < 0.05  # at rest
    lowest = [_lowest_z(m, d, g) for g in range(m.ngeom) if g != 0]
    assert 0.0 < d.xpos[root][2] < 0.5 * start_height  # down, and above the floor
    assert min(lowest) > -REST_PENETRATION_M
    pelvis = [_lowest_z(m, d, g) for g in range(m.ngeom) if m.geom_bodyid[g] == root]
    assert min(pelvis) < TOUCH_M + REST_PENETRATION_M  # the pelvis lies on the floor


def test_the_fall_verdict_names_the_first_link_on_the_floor(servo_biped, pushed):
    """The verdict names a link and a time: at that sample a geom of that link (or its
    origin) is on the floor by MuJoCo's poses, and at the sample before no link but a foot
    was."""
    robot = servo_biped
    q_plan = joint_angles(robot, pushed.q)
    inp = prepare(robot, pushed, q_plan, sized_servos(robot), settle_s=0.0)
    result = finish(robot, pushed, inp, run_engine(inp), "pushed")
    outcome = result.outcome
    assert outcome is not None and outcome.kind == "falls"
    assert outcome.floor_link and outcome.floor_link_time_s is not None
    assert outcome.floor_link in result.verdict()
    assert result.summary()["fall_link"] == outcome.floor_link
    sim = inp.sim
    feet = {name for names in sim.foot_bodies for name in names}
    link_of = dict(sim.body_links)
    k = pushed.index_at(outcome.floor_link_time_s)

    def on_floor(q_pin) -> set[str]:
        m, d = _state(inp, q_pin)
        links = set()
        for g in range(1, m.ngeom):
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, m.geom_bodyid[g])
            if body not in feet and _lowest_z(m, d, g) < TOUCH_M:
                links.add(link_of[body])
        return links

    assert 0 < result.fall_time_s < outcome.floor_link_time_s  # it tipped, then came down
    assert outcome.floor_link in on_floor(result.q[k])
    assert not on_floor(result.q[k - 1])


def test_standing_runs_are_the_same_with_the_links_geoms(servo_biped):
    """The paper's 4.3 cm one-leg squats without compensation, their first 3 s (the lifted
    foot touches down from 2.25 s: the busiest contacts of the four experiments): with and
    without the links' geoms the same run bit for bit, as no link but the feet comes near
    the floor."""
    from app.core.motions.library import run_motion

    squats = run_motion(servo_biped, "one_leg_squats", shift_m=0.043).trajectory
    traj = first_samples(squats, 301)
    q_plan = joint_angles(servo_biped, traj.q)
    servo = sized_servos(servo_biped)
    runs = [
        simulate_commands(
            servo_biped, traj, {"x": q_plan}, servo, SimOptions(links_collide=lc), parallel=False
        )["x"]
        for lc in (False, True)
    ]
    assert runs[0].outcome is not None and runs[0].outcome.kind == "leans on the lifted foot"
    np.testing.assert_array_equal(runs[0].q, runs[1].q)
    np.testing.assert_array_equal(runs[0].contact_force_N, runs[1].contact_force_N)
    assert runs[0].verdict() == runs[1].verdict()


def test_the_links_collide_by_their_urdf_shapes_or_a_fitted_primitive():
    """servo_biped: each non-foot link's URDF collision boxes, cylinders and spheres are geoms
    of the same sizes (read from the URDF text here); Roban S14's links without collision
    shapes get one box equal to their visual mesh's bounds, or a capsule as long as them
    on their longest side and within them on the next; the feet only their
    soles; no geom collides with another but the floor; standing, every link's geom is above
    the floor."""
    robot = load_robot("servo_biped")
    sim = build_sim_model(robot)
    m = mujoco.MjModel.from_xml_string(sim.xml)
    feet = {name for names in sim.foot_bodies for name in names}
    foot_links = {link for body, link in sim.body_links if body in feet}
    expected: list[tuple[str, tuple[float, ...]]] = []
    for link in ElementTree.parse(robot.source).getroot().iter("link"):
        if link.get("name") in foot_links:
            continue
        for shape in link.iterfind("collision/geometry/*"):
            if shape.tag == "box":
                sizes = tuple(0.5 * float(x) for x in shape.get("size", "").split())
            elif shape.tag == "cylinder":
                sizes = (float(shape.get("radius", 0)), 0.5 * float(shape.get("length", 0)))
            else:
                sizes = (float(shape.get("radius", 0)),)
            expected.append((shape.tag, sizes))
    names = {int(mujoco.mjtGeom.mjGEOM_BOX): "box", int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder"}
    names[int(mujoco.mjtGeom.mjGEOM_SPHERE)] = "sphere"
    made = []
    for g in range(m.ngeom):
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, m.geom_bodyid[g])
        if g == 0 or body in feet:
            continue
        kind = names[int(m.geom_type[g])]
        count = {"box": 3, "cylinder": 2, "sphere": 1}[kind]
        made.append((kind, tuple(float(x) for x in m.geom_size[g][:count])))
    assert sorted(made) == pytest.approx(sorted(expected), abs=1e-12)
    foot_geoms = [
        g for g in range(m.ngeom) if m.geom_bodyid[g] and m.body(m.geom_bodyid[g]).name in feet
    ]
    assert sorted(m.geom(g).name for g in foot_geoms) == ["left_sole", "right_sole"]
    pairs = np.bitwise_and.outer(m.geom_contype, m.geom_conaffinity)
    pairs = pairs | pairs.T
    assert np.flatnonzero(pairs.sum(axis=1) > 0).tolist() == list(range(m.ngeom))
    assert (pairs[1:, 1:] == 0).all()  # the floor is geom 0: nothing else collides

    s14 = load_robot(str(ROBAN_URDF))
    sim14 = build_sim_model(s14)
    m14 = mujoco.MjModel.from_xml_string(sim14.xml)
    d14 = mujoco.MjData(m14)
    pin_to_qpos(sim14, s14.q_neutral, d14.qpos)
    mujoco.mj_forward(m14, d14)
    data = s14.model.createData()
    placements = s14.link_placements(s14.q_neutral, data)
    shaped = {g.link for g in s14.tree.geometries if g.role == "collision"}
    body_of = {link: body for body, link in sim14.body_links}
    fitted = [link for link in {mesh.link for mesh in s14.meshes} - shaped if link in body_of]
    assert "leg_l5_link" in fitted
    for link in fitted:
        body = mujoco.mj_name2id(m14, mujoco.mjtObj.mjOBJ_BODY, body_of[link])
        geoms = [g for g in range(m14.ngeom) if m14.geom_bodyid[g] == body]
        if body_of[link] in {n for names in sim14.foot_bodies for n in names}:
            continue
        assert len(geoms) >= 1
        points = np.concatenate(
            [
                mesh.T_link_mesh[:3, :3] @ mesh.mesh.vertices.T + mesh.T_link_mesh[:3, 3:4]
                for mesh in s14.meshes
                if mesh.link == link and mesh.role == "visual"
            ],
            axis=1,
        )
        low, high = points.min(axis=1), points.max(axis=1)  # the mesh's bounds, link frame
        (g,) = geoms
        T_link_geom = np.linalg.inv(placements[link]) @ _pose_of(d14, g)
        geom_low, geom_high = _bounds(m14, g, T_link_geom)
        sides = np.argsort(high - low)[::-1]
        capsule = m14.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE
        held = sides[:2] if capsule else sides  # a capsule's round side: the next side's
        assert np.all(geom_low[held] >= low[held] - 1e-6), link
        assert np.all(geom_high[held] <= high[held] + 1e-6), link
        full = sides[:1] if capsule else sides
        np.testing.assert_allclose(geom_low[full], low[full], atol=1e-6)
        np.testing.assert_allclose(geom_high[full], high[full], atol=1e-6)
    for one, one_sim in ((s14, sim14), (robot, sim)):  # standing at q_neutral: soles on z = 0
        model = mujoco.MjModel.from_xml_string(one_sim.xml)
        data = mujoco.MjData(model)
        pin_to_qpos(one_sim, one.q_neutral, data.qpos)
        mujoco.mj_forward(model, data)
        on_feet = {n for names in one_sim.foot_bodies for n in names}
        links = [
            _lowest_z(model, data, g)
            for g in range(1, model.ngeom)
            if model.body(model.geom_bodyid[g]).name not in on_feet
        ]
        assert min(links) > 0.005, one.name  # no link near the floor


def _pose_of(d, g: int) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g]
    return T


def _bounds(m, g: int, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds of a box or capsule geom placed at T (its frame's axes: MuJoCo's,
    a capsule along z)."""
    size = m.geom_size[g]
    if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        corners = (T[:3, :3] @ (signs * size).T).T + T[:3, 3]
        return corners.min(axis=0), corners.max(axis=0)
    assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE
    ends = np.array([T[:3, 3] - T[:3, 2] * size[1], T[:3, 3] + T[:3, 2] * size[1]])
    return ends.min(axis=0) - size[0], ends.max(axis=0) + size[0]
