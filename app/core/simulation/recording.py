"""The step loop's per-sample recording (numpy and mujoco only): what MuJoCo computes at each
sample's state copied into preallocated rows, converted in bulk afterwards (pinocchio layout,
roll and pitch, sole forces in the world), and the fall and blow-up verdicts checked a block
of samples at a time on what was recorded.

A sample's row is its state (time, qpos, qvel) and the recording's sensors (`sensors_xml`)
from a forward pass at that state with the actuators off and the servo torque of the step
before the sample applied (the torque the servo applies as the sample is taken): every body's
and sole site's position and the root's axes, and, summed in C, each foot body's floor
contacts (count and net force in the world, `mj_contactForce`'s per contact) and the count of
all the floor's contacts. The contact list is read in Python only at a sample where some floor
contact is not a foot's, to name the first such link. The step loop fills the rows either
live (`record`, after its own forward pass) or a block at a time from a batched forward pass
(`app.core.simulation.blocks`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any
from xml.etree import ElementTree
from xml.sax.saxutils import quoteattr

import numpy as np

from app.core.quaternions import wxyz_to_xyzw
from app.core.simulation.errors import SimulationDiverged, SimulationInputError
from app.core.simulation.sim_model import SimModel

FALL_TILT_DEG = 30.0
FALL_HEIGHT_FRACTION = 0.6
NON_FOOT_CLEARANCE_M = 0.005
MAX_SPEED = 1e3
"""Any generalised speed beyond this [m/s or rad/s] is a blown-up simulation."""
NON_FOOT = 2
"""`Scene.side_of_geom` of a geom on neither foot."""
FLOOR_SENSOR = "recording_floor_contacts"
FORWARD_TOLERANCE = 1e-10
"""The constraint solver's tolerance in a sample's forward pass (the physics keeps MuJoCo's
1e-8): its forces are then those of a precise solve to well under 1 µN, whatever warm start
the pass begins from (a batched pass has no step's warm start)."""


def _foot_sides(sim: SimModel) -> dict[str, int]:
    """Each foot body's side (0 left, 1 right; a body on both feet counts as the right's, as
    in `Scene.side_of_geom`)."""
    return {name: side for side, names in enumerate(sim.foot_bodies) for name in names}


def _foot_sensor(i: int) -> str:
    return f"recording_foot_{i}"


def _bodies(sim: SimModel) -> list[str]:
    """The MJCF's bodies, in MuJoCo's order (the world's children depth first)."""
    return [str(body.get("name")) for body in ElementTree.fromstring(sim.xml).iter("body")]


def sensors_xml(sim: SimModel) -> str:
    """The recording's MuJoCo sensors (one `sensordata` row per sample, module docstring):
    per foot body its floor contacts' count and net force (world frame; MuJoCo gives the
    force the body exerts on the floor), the count of all the floor's contacts, every body's
    origin, the root's axes (a floating base) and the sole sites."""
    rows = [
        f"<contact name={quoteattr(_foot_sensor(i))} body1={quoteattr(body)} "
        'geom2="floor" data="found force" reduce="netforce"/>'
        for i, body in enumerate(_foot_sides(sim))
    ]
    rows.append(f'<contact name="{FLOOR_SENSOR}" geom1="floor" data="found"/>')
    rows += [
        f'<framepos name="recording_xpos_{i}" objtype="xbody" objname={quoteattr(body)}/>'
        for i, body in enumerate(_bodies(sim))
    ]
    if sim.floating_base:
        rows += [
            f'<frame{axis}axis name="recording_root_{axis}" objtype="xbody" '
            f"objname={quoteattr(sim.root_body)}/>"
            for axis in "xyz"
        ]
    rows += [
        f'<framepos name="recording_sole_{side}" objtype="site" objname={quoteattr(site)}/>'
        for side, site in enumerate(sim.sole_sites)
    ]
    return f"<sensor>{''.join(rows)}</sensor>"


@dataclasses.dataclass(frozen=True)
class Scene:
    """MuJoCo ids the recording reads, resolved once per run."""

    floor: int
    root: int
    sites: np.ndarray
    """The (left, right) sole sites."""
    side_of_geom: list[int]
    """Per geom: 0 / 1 on the left / right foot (every geom of a foot's bodies), else
    NON_FOOT."""
    non_foot: np.ndarray
    """Bodies (not the world) on neither foot."""
    body_names: tuple[str, ...]
    """Per body, the URDF link it carries (or its MuJoCo name), to name it in a verdict."""
    foot_force_adr: tuple[tuple[int, ...], tuple[int, ...]]
    """`sensordata` address of each (left, right) foot body's net floor force (3 values)."""
    floor_count_adr: int
    """`sensordata` address of the floor's contact count."""
    foot_count_adr: np.ndarray
    """`sensordata` addresses of each foot body's floor contact count."""
    xpos_adr: np.ndarray
    """`sensordata` addresses of bodies 1 … nbody − 1's origins, (3·(nbody − 1),)."""
    xmat_adr: np.ndarray | None
    """`sensordata` addresses of the root's rotation matrix, row-major (9,); None: a fixed
    base (the world's identity)."""
    sole_adr: np.ndarray
    """`sensordata` addresses of the (left, right) sole sites, (6,)."""

    @classmethod
    def of(cls, sim: SimModel, m: Any) -> Scene:
        import mujoco

        def body(name: str) -> int:
            return int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name))

        side_of_body = {body(name): side for name, side in _foot_sides(sim).items()}

        def sensor(name: str) -> int:
            return int(m.sensor_adr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, name)])

        link_of = dict(sim.body_links)
        names = []
        for b in range(m.nbody):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body {b}"
            names.append(link_of.get(name, name))
        found: tuple[list[int], list[int]] = ([], [])
        for i, side in enumerate(_foot_sides(sim).values()):
            found[side].append(sensor(_foot_sensor(i)))
        xpos = [sensor(f"recording_xpos_{i}") for i in range(len(_bodies(sim)))]
        if len(xpos) != m.nbody - 1:
            raise SimulationInputError(f"the MJCF has {len(xpos)} bodies, MuJoCo {m.nbody - 1}")
        xmat = None
        if sim.floating_base:
            x, y, z = (sensor(f"recording_root_{axis}") for axis in "xyz")
            xmat = np.array([x, y, z, x + 1, y + 1, z + 1, x + 2, y + 2, z + 2])  # columns
        soles = [sensor(f"recording_sole_{side}") for side in (0, 1)]
        return cls(
            floor=int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")),
            root=body(sim.root_body) if sim.floating_base else 0,
            sites=np.array(
                [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, n) for n in sim.sole_sites]
            ),
            side_of_geom=[
                side_of_body.get(int(m.geom_bodyid[g]), NON_FOOT) for g in range(m.ngeom)
            ],
            non_foot=np.array([b for b in range(1, m.nbody) if b not in side_of_body], dtype=int),
            body_names=tuple(names),
            foot_force_adr=(tuple(a + 1 for a in found[0]), tuple(a + 1 for a in found[1])),
            floor_count_adr=sensor(FLOOR_SENSOR),
            foot_count_adr=np.array(found[0] + found[1], dtype=int),
            xpos_adr=(np.array(xpos)[:, None] + np.arange(3)).ravel(),
            xmat_adr=xmat,
            sole_adr=(np.array(soles)[:, None] + np.arange(3)).ravel(),
        )


class Recorder:
    """Preallocated rows, one per sample (module docstring): the state and sensors as
    recorded, the bodies, soles and root axes derived from the sensors a block at a time
    (`derive`)."""

    def __init__(
        self, m: Any, d: Any, scene: Scene, n_samples: int, n_joints: int, dt_cmd_s: float
    ) -> None:
        self.m, self.d, self.scene, self.dt_cmd_s = m, d, scene, dt_cmd_s
        self.time = np.zeros(n_samples)
        self.qpos = np.zeros((n_samples, m.nq))
        self.qvel = np.zeros((n_samples, m.nv))
        self.sensed = np.zeros((n_samples, m.nsensordata))
        """The recording's sensors at each sample (`sensors_xml`)."""
        self.tau = np.zeros((n_samples, n_joints))
        self.xmat_root = np.tile(np.eye(3).ravel(), (n_samples, 1))
        self.sole = np.zeros((n_samples, 2, 3))
        self.body_xpos = np.zeros((n_samples, m.nbody, 3))
        self.touched_body = np.full(n_samples, -1, dtype=int)
        """The body of the first non-foot geom found touching the floor at a sample, −1 if none."""
        # MjData's fixed arrays, bound once (each attribute read builds a new numpy view).
        self._d_qpos, self._d_qvel, self._d_sensordata = d.qpos, d.qvel, d.sensordata

    def record(self, k: int) -> None:
        """Sample k from the live MjData, after a forward pass at its state (module
        docstring); the contact list read there where needed."""
        d = self.d
        self.time[k] = d.time
        self.qpos[k] = self._d_qpos
        self.qvel[k] = self._d_qvel
        self.sensed[k] = self._d_sensordata
        if len(self.off_feet(k, k + 1)):
            self.touched_body[k] = self.first_non_foot_body(d)

    def off_feet(self, begin: int, end: int) -> np.ndarray:
        """Samples of [begin, end) at which some floor contact is not a foot's."""
        sensed, scene = self.sensed[begin:end], self.scene
        feet = sensed[:, scene.foot_count_adr].sum(axis=1)
        return begin + np.flatnonzero(sensed[:, scene.floor_count_adr] > feet + 0.5)

    def derive(self, begin: int, end: int) -> None:
        """The bodies' origins, the soles and the root's axes of samples [begin, end) from
        their sensors."""
        scene, sensed = self.scene, self.sensed[begin:end]
        self.body_xpos[begin:end, 1:] = sensed[:, scene.xpos_adr].reshape(end - begin, -1, 3)
        self.sole[begin:end] = sensed[:, scene.sole_adr].reshape(end - begin, 2, 3)
        if scene.xmat_adr is not None:
            self.xmat_root[begin:end] = sensed[:, scene.xmat_adr]

    def first_non_foot_body(self, d: Any) -> int:
        """The body of the first contact in d's contact list between the floor and a geom on
        neither foot, −1 if none."""
        floor, side_of = self.scene.floor, self.scene.side_of_geom
        for g1, g2 in d.contact.geom.tolist():
            other = g2 if g1 == floor else g1 if g2 == floor else -1
            if other >= 0 and side_of[other] == NON_FOOT:
                return int(self.m.geom_bodyid[other])
        return -1

    def first_diverged(self, begin: int, end: int) -> int:
        """First sample in [begin, end) that has blown up (NaN, a runaway speed, or MuJoCo's
        reset after a bad position, speed or acceleration: its clock back to 0), −1 if none."""
        expected = self.time[0] + np.arange(begin, end) * self.dt_cmd_s
        bad = (
            (np.abs(self.time[begin:end] - expected) > 0.25 * self.dt_cmd_s)
            | ~np.all(np.isfinite(self.qpos[begin:end]), axis=1)
            | ~np.all(np.abs(self.qvel[begin:end]) < MAX_SPEED, axis=1)
        )
        return begin + int(np.argmax(bad)) if bad.any() else -1

    def roll_pitch(self, begin: int = 0, end: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The root's roll and pitch [rad] (ZYX convention) at the samples [begin, end)."""
        R = self.xmat_root[begin:end]
        roll = np.arctan2(R[:, 7], R[:, 8])
        pitch = np.arctan2(-R[:, 6], np.hypot(R[:, 0], R[:, 3]))
        return roll, pitch

    def touching(self, begin: int = 0, end: int | None = None) -> np.ndarray:
        """(samples,) bool: a non-foot geom on the floor or a non-foot body's origin within
        NON_FOOT_CLEARANCE_M of it."""
        contact = self.touched_body[begin:end] >= 0
        if not self.scene.non_foot.size:
            return contact
        low = self.body_xpos[begin:end, self.scene.non_foot, 2].min(axis=1)
        return contact | (low < NON_FOOT_CLEARANCE_M)

    def first_touching(self, begin: int, end: int) -> int:
        """The first sample of [begin, end) at which a link other than a foot is on the floor
        (`touching`), −1 if none."""
        touching = self.touching(begin, end)
        return begin + int(np.argmax(touching)) if touching.any() else -1

    def touched_link(self, k: int) -> str:
        """The first non-foot link found on the floor at sample k ("" if none)."""
        body = int(self.touched_body[k])
        if body < 0 and self.scene.non_foot.size:
            z = self.body_xpos[k, self.scene.non_foot, 2]
            if z.min() < NON_FOOT_CLEARANCE_M:
                body = int(self.scene.non_foot[np.argmin(z)])
        return self.scene.body_names[body] if body >= 0 else ""

    def contact_forces(self, n_samples: int) -> np.ndarray:
        """Floor force on each sole, world frame (T, 2, 3) [N]: minus the force the foot's
        bodies exert on the floor, summed over them."""
        forces = np.zeros((n_samples, 2, 3))
        for side, addresses in enumerate(self.scene.foot_force_adr):
            for adr in addresses:
                forces[:, side] -= self.sensed[:n_samples, adr : adr + 3]
        return forces


def check_diverged(recorder: Recorder, begin: int, end: int, dt_cmd_s: float) -> None:
    """Raise SimulationDiverged at the first blown-up sample of [begin, end)."""
    k = recorder.first_diverged(begin, end)
    if k >= 0:
        raise SimulationDiverged(diverged_message(k * dt_cmd_s))


def diverged_message(t_s: float) -> str:
    return (
        f"the simulation blew up at t = {t_s:.3f} s (NaN or runaway speed); the servos are "
        "too stiff for the time step: lower the stiffness or the time step"
    )


def first_fall(
    recorder: Recorder,
    begin: int,
    end: int,
    sim: SimModel,
    planned: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[int, str]:
    """The first sample of [begin, end) at which the robot has fallen and why, (−1, "") if
    none. `planned`: the plan's (roll, pitch, root height) per sample. Candidates are found
    vectorised with a margin, each confirmed by `fall_reason` (the one statement of the
    rules)."""
    candidate = recorder.touching(begin, end)
    if sim.floating_base:
        roll, pitch = recorder.roll_pitch(begin, end)
        margin = 1e-6
        for actual, plan in ((roll, planned[0]), (pitch, planned[1])):
            off = np.mod(actual - plan[begin:end], 2.0 * np.pi)
            off = np.degrees(np.minimum(off, 2.0 * np.pi - off))
            candidate |= off > FALL_TILT_DEG - margin
        z = recorder.body_xpos[begin:end, recorder.scene.root, 2]
        candidate |= z < FALL_HEIGHT_FRACTION * planned[2][begin:end] + margin
    for i in np.flatnonzero(candidate).tolist():
        k = begin + i
        roll_k, pitch_k = recorder.roll_pitch(k, k + 1)
        reason = fall_reason(
            float(roll_k[0]),
            float(pitch_k[0]),
            float(recorder.body_xpos[k, recorder.scene.root, 2]),
            recorder.touched_link(k),
            sim,
            (float(planned[0][k]), float(planned[1][k]), float(planned[2][k])),
        )
        if reason:
            return k, reason
    return -1, ""


def fall_reason(
    roll: float,
    pitch: float,
    z: float,
    touched: str,
    sim: SimModel,
    planned: tuple[float, float, float],
) -> str:
    """Why a sample has fallen ("" if it has not); `touched`: the first non-foot link found
    on the floor ("" if none); `planned`: the plan's roll, pitch and root height there."""
    if touched:
        return f"the link {touched} touches the floor"
    if not sim.floating_base:
        return ""
    for label, actual, plan in (("roll", roll, planned[0]), ("pitch", pitch, planned[1])):
        error = math.degrees(abs(math.remainder(actual - plan, 2.0 * math.pi)))
        if error > FALL_TILT_DEG:
            return f"the torso's {label} is {error:.0f}° off the plan"
    if z < FALL_HEIGHT_FRACTION * planned[2]:
        return f"the torso is down to {z * 100:.1f} cm (planned {planned[2] * 100:.1f} cm)"
    return ""


def qpos_to_pin(sim: SimModel, qpos: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """MuJoCo's qpos (…, nq) as pinocchio configurations (…, nq_pin) (into `out` when given)."""
    qpos = np.asarray(qpos)
    q = np.zeros((*qpos.shape[:-1], sim.nq_pin)) if out is None else out
    if sim.floating_base:
        q[..., :3] = qpos[..., :3]
        q[..., 3:7] = wxyz_to_xyzw(qpos[..., 3:7])
    scalar, continuous = np.asarray(sim.pin_scalar_q), np.asarray(sim.pin_continuous_q)
    if len(scalar):
        q[..., scalar[:, 0]] = qpos[..., scalar[:, 1]]
    if len(continuous):
        angle = qpos[..., continuous[:, 1]]
        q[..., continuous[:, 0]], q[..., continuous[:, 0] + 1] = np.cos(angle), np.sin(angle)
    return q


def qvel_to_pin(
    sim: SimModel, qvel: np.ndarray, R_world_base: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """MuJoCo's qvel (…, nv) as pinocchio velocities (…, nv_pin): MuJoCo's free joint has its
    linear velocity in the world, pinocchio's in the base (R_world_base (…, 3, 3))."""
    qvel = np.asarray(qvel)
    v = np.zeros((*qvel.shape[:-1], sim.nv_pin)) if out is None else out
    if sim.floating_base:
        v[..., :3] = np.einsum("...ji,...j->...i", R_world_base, qvel[..., :3])
        v[..., 3:6] = qvel[..., 3:6]
    dofs = np.asarray(sim.pin_dof)
    if len(dofs):
        v[..., dofs[:, 0]] = qvel[..., dofs[:, 1]]
    return v
