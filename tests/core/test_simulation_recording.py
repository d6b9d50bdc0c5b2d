"""The step loop's recording against a plain MuJoCo rollout of the same set points.

`mujoco.rollout` steps the run's model from its start through the settling and every hold
with the set points the servo law sends (`Setpoints`, itself checked against the per-tick
recurrence in test_servo_in_mujoco), in C, with no recording. Each recorded column of
`run_engine` is then rebuilt here from the rollout's states with MuJoCo's own calls:

- configurations and velocities: the rolled-out qpos/qvel at the sample (pinocchio's layout
  written out here: base position, quaternion (x, y, z, w), joints; base linear velocity in
  the base frame);
- roll and pitch: from the base quaternion (ZYX angles, closed form);
- sole centres and the root's origin: `mj_forward` at the sample's state;
- the servo torque after sample k: the actuators' force of the hold's last step (its state,
  its set point);
- the sole forces: `mj_forward` at the sample's state with the actuators off and the torque
  of the step before the sample applied (what the servo applies as the sample is taken),
  its constraints solved to 1e-15 from no warm start, summed over each foot's floor contacts
  with `mj_contactForce`, rotated to the world (the run solves its samples' forces to 1e-10,
  `recording.FORWARD_TOLERANCE`: to a few µN of this).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from mujoco import rollout

from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.model import joint_angles
from app.core.simulation.engine import run_engine, start
from app.core.simulation.files import default_servos
from app.core.simulation.run import prepare
from app.core.simulation.servo_law import Setpoints
from tests.trajectory_slices import first_samples

SAMPLES = 200
ACTUATION_OFF = int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)


@pytest.fixture(scope="module")
def squats_input():
    robot = load_robot("servo_biped")
    traj = first_samples(run_motion(robot, "one_leg_squats").trajectory, SAMPLES)
    q_cmd = joint_angles(robot, traj.q).copy()
    q_cmd[15::25] += 0.04  # jumps the set point's slew needs several ticks for
    return prepare(robot, traj, q_cmd, default_servos(robot))


def _set_points(inp, m, ctrl_joint, ticks) -> np.ndarray:
    """Every physics step's ctrl: the settling, then each command held."""
    dt = float(m.opt.timestep)
    commands = np.asarray(inp.q_cmd_rad)
    setpoints = Setpoints(inp.law, dt, commands[0])
    settle = round(inp.settle_s / dt)
    blocks = []
    for command, n in [(commands[0], settle)] + [(c, ticks) for c in commands]:
        rows = setpoints.hold(command, n)
        blocks.append(np.tile(command, (n, 1)) if rows is None else rows)
    return np.concatenate(blocks)[:, ctrl_joint]


def _roll_pitch(quat_wxyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    w, x, y, z = quat_wxyz.T
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    return roll, pitch


def test_the_recorded_columns_are_a_plain_rollouts(squats_input):
    inp = squats_input
    run = run_engine(inp)
    assert run.fall_index == -1 and run.n_simulated == SAMPLES
    m, d, ctrl_joint, ticks = start(inp)
    control = _set_points(inp, m, ctrl_joint, ticks)
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.zeros(mujoco.mj_stateSize(m, kind))
    mujoco.mj_getState(m, d, state0, kind)
    states, _ = rollout.rollout(m, d, state0[None], control[None])
    states = states[0]
    settle = len(control) - SAMPLES * ticks
    after = settle + np.arange(SAMPLES) * ticks - 1  # the state at sample k: after that step
    qpos = states[after, 1 : 1 + m.nq]
    qvel = states[after, 1 + m.nq : 1 + m.nq + m.nv]
    sim = inp.sim

    # Configurations and velocities, pinocchio's layout written out.
    np.testing.assert_allclose(run.q[:, :3], qpos[:, :3], atol=1e-9)
    np.testing.assert_allclose(run.q[:, 3:7], qpos[:, [4, 5, 6, 3]], atol=1e-9)
    np.testing.assert_allclose(run.q_joints_rad, qpos[:, sim.actuated_qpos], atol=1e-9)
    roll, pitch = _roll_pitch(qpos[:, 3:7])
    np.testing.assert_allclose(run.roll_rad, roll, atol=1e-9)
    np.testing.assert_allclose(run.pitch_rad, pitch, atol=1e-9)

    feet = {
        mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name): side
        for side, names in enumerate(sim.foot_bodies)
        for name in names
    }
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, s) for s in sim.sole_sites]
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, sim.root_body)
    check = mujoco.MjData(m)

    def actuator_torque(step: int) -> np.ndarray:
        """qfrc_actuator of physics step `step` (0-based): its start state, its ctrl."""
        mujoco.mj_setState(m, check, states[step - 1], kind)
        check.ctrl[:] = control[step]
        mujoco.mj_forward(m, check)
        return check.qfrc_actuator.copy()

    f6 = np.zeros(6)
    for k in range(SAMPLES - 1):
        step = after[k] + 1  # the hold's first step
        R_world_base = np.zeros(9)
        mujoco.mju_quat2Mat(R_world_base, qpos[k, 3:7])
        v_base = R_world_base.reshape(3, 3).T @ qvel[k, :3]
        np.testing.assert_allclose(run.v[k, :3], v_base, atol=1e-7)
        np.testing.assert_allclose(
            run.tau_Nm[k], actuator_torque(step + ticks - 1)[sim.actuated_dof], atol=1e-6
        )
        check.qfrc_applied[:] = actuator_torque(step - 1)
        mujoco.mj_setState(m, check, states[after[k]], kind)
        check.qacc_warmstart[:] = 0.0
        tolerance, iterations = m.opt.tolerance, m.opt.iterations
        m.opt.disableflags |= ACTUATION_OFF
        m.opt.tolerance, m.opt.iterations = 1e-15, 1000
        try:
            mujoco.mj_forward(m, check)
        finally:
            m.opt.disableflags &= ~ACTUATION_OFF
            m.opt.tolerance, m.opt.iterations = tolerance, iterations
        check.qfrc_applied[:] = 0.0
        np.testing.assert_allclose(run.sole_position_m[k], check.site_xpos[sites], atol=1e-9)
        np.testing.assert_allclose(run.root_position_m[k], check.xpos[root], atol=1e-9)
        expected = np.zeros((2, 3))
        for c in range(check.ncon):
            g1, g2 = check.contact.geom[c]
            if floor not in (g1, g2):
                continue
            other = g2 if g1 == floor else g1
            side = feet.get(int(m.geom_bodyid[other]))
            assert side is not None, "a squat touches the floor with its feet only"
            mujoco.mj_contactForce(m, check, c, f6)
            world = check.contact.frame[c].reshape(3, 3).T @ f6[:3]
            expected[side] += world if g1 == floor else -world
        assert expected[:, 2].sum() > 0.0
        np.testing.assert_allclose(run.contact_force_N[k], expected, atol=1e-5)


def test_links_on_the_floor_are_a_plain_rollouts():
    """A robot with collision hulls on every link bent over until it falls (no fall verdict,
    so it lies there): at every sample a link touches the floor where, in a plain rollout's
    state, MuJoCo's contact list pairs the floor with a geom on neither foot, or a non-foot
    body's origin is within NON_FOOT_CLEARANCE_M of it (the recording reads the contact list
    only where its sensors count floor contacts that are no foot's)."""
    from app.core.servo.model import ServoModel
    from app.core.simulation.mjcf import SimOptions
    from app.core.simulation.recording import NON_FOOT_CLEARANCE_M

    robot = load_robot("servo_biped")
    n = 160
    traj = first_samples(run_motion(robot, "one_leg_squats").trajectory, n)
    q_cmd = joint_angles(robot, traj.q).copy()
    lower = np.array([joint.lower for joint in robot.joints])
    upper = np.array([joint.upper for joint in robot.joints])
    q_cmd[60:] = np.clip(q_cmd[60:] + 0.6, lower, upper)  # every joint bent far: it falls
    servo = ServoModel.rigid(robot.joint_names)
    inp = prepare(robot, traj, q_cmd, servo, options=SimOptions(hulls=True))
    inp = dataclasses.replace(inp, detect_falls=False)
    run = run_engine(inp)
    assert run.n_simulated == n

    m, d, ctrl_joint, ticks = start(inp)
    control = _set_points(inp, m, ctrl_joint, ticks)
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.zeros(mujoco.mj_stateSize(m, kind))
    mujoco.mj_getState(m, d, state0, kind)
    states = rollout.rollout(m, d, state0[None], control[None])[0][0]
    after = len(control) - n * ticks + np.arange(n) * ticks - 1
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    feet = {
        mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
        for names in inp.sim.foot_bodies
        for name in names
    }
    others = [b for b in range(1, m.nbody) if b not in feet]
    check = mujoco.MjData(m)
    by_contact, by_clearance = np.zeros(n, bool), np.zeros(n, bool)
    for k in range(n):
        mujoco.mj_setState(m, check, states[after[k]], kind)
        mujoco.mj_forward(m, check)
        for g1, g2 in check.contact.geom[: check.ncon]:
            other = g2 if g1 == floor else g1 if g2 == floor else -1
            by_contact[k] |= other >= 0 and int(m.geom_bodyid[other]) not in feet
        by_clearance[k] = check.xpos[others, 2].min() < NON_FOOT_CLEARANCE_M
    assert (by_contact & ~by_clearance).any(), "some samples only a contact can tell"
    np.testing.assert_array_equal(run.non_foot_contact, by_contact | by_clearance)
