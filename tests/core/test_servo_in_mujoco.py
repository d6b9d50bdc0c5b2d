"""The ideal servo's law moved into MuJoCo's actuators, against its defining equations and
against the law run in Python at every tick (the previous step loop, kept as the reference).

- The actuators' torque, at random set points s and joint angles q, is
  clip(K·dz(s − q, b/2), ±τ_max) with dz(e, h) = sign(e)·max(|e| − h, 0), written out here
  from the equation (not from `ServoLoop`).
- The set point's slew computed a hold at a time (`Setpoints`) equals the per-tick recurrence
  s ← s + clip(c − s, ±ω_max·Δt) iterated here.
- The whole step loop, law in MuJoCo vs law in Python: the same trajectories on servo_biped's
  one-leg squats (play in the leg servos, zero-order hold), with linear ramps, and with
  command jumps large enough for the speed saturation to act.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.model import ServoModel, joint_angles
from app.core.simulation.engine import run_engine
from app.core.simulation.files import default_servos
from app.core.simulation.run import prepare
from app.core.simulation.servo_law import ServoLaw, Setpoints, actuators_xml
from tests.trajectory_slices import first_samples

PENDULUM = (
    """<mujoco><option gravity="0 0 0"/><worldbody>{bodies}</worldbody>{actuators}</mujoco>"""
)
BODY = (
    '<body name="b{i}" pos="{x} 0 0"><joint name="j{i}" type="hinge" axis="0 1 0"/>'
    '<geom type="sphere" size="0.01" mass="0.1"/></body>'
)


def _law(n: int, rng: np.random.Generator, play: bool) -> ServoLaw:
    return ServoLaw(
        stiffness_Nm_per_rad=rng.uniform(5.0, 3000.0, n),
        half_backlash_rad=rng.uniform(0.0, 0.02, n) * play,
        damping_Nms_per_rad=rng.uniform(0.1, 1.0, n),
        effort_Nm=rng.uniform(0.5, 20.0, n),
        velocity_rad_s=rng.uniform(1.0, 8.0, n),
    )


@pytest.mark.parametrize("play", [False, True])
def test_the_actuators_torque_is_the_servo_laws(play):
    rng = np.random.default_rng(3)
    n = 6
    law = _law(n, rng, play)
    names = tuple(f"j{i}" for i in range(n))
    actuators, ctrl_joint = actuators_xml(law, names)
    bodies = "".join(BODY.format(i=i, x=0.1 * i) for i in range(n))
    m = mujoco.MjModel.from_xml_string(PENDULUM.format(bodies=bodies, actuators=actuators))
    d = mujoco.MjData(m)
    for _ in range(200):
        s = rng.uniform(-1.0, 1.0, n)
        # Errors around the dead band's edges and far past the torque limit.
        q = s - rng.choice([-1.0, 1.0], n) * rng.uniform(0.0, 0.05, n) * rng.choice([0.1, 1, 10], n)
        d.qpos[:] = q
        d.ctrl[:] = s[ctrl_joint]
        mujoco.mj_forward(m, d)
        e = s - q
        h = law.half_backlash_rad
        dead = np.sign(e) * np.maximum(np.abs(e) - h, 0.0)
        expected = np.clip(law.stiffness_Nm_per_rad * dead, -law.effort_Nm, law.effort_Nm)
        np.testing.assert_allclose(d.qfrc_actuator, expected, rtol=1e-9, atol=1e-9)


def test_the_set_points_slew_as_the_per_tick_recurrence():
    rng = np.random.default_rng(5)
    n, dt, ticks = 5, 0.001, 10
    law = _law(n, rng, False)
    # Steps within a tick's slew (≥ 1 mrad here) and beyond it, and jumps.
    commands = np.cumsum(rng.normal(0.0, 0.0006, (40, n)) * rng.choice([1, 20], (40, 1)), axis=0)
    commands[10] += 0.3  # jumps the slew needs several ticks (or holds) for
    commands[25] -= 0.5
    for mode in ("hold", "hold_sample", "ramp"):
        ramp = mode == "ramp"
        fast = Setpoints(law, dt, commands[0])
        s, max_step = commands[0].copy(), law.velocity_rad_s * dt
        for k in range(len(commands) - 1):
            end = commands[k + 1]
            wanted = [
                commands[k] + (i * (end - commands[k]) / ticks if ramp else 0.0)
                for i in range(1, ticks + 1)
            ]
            expected = []
            for c in wanted:
                s = s + np.clip(c - s, -max_step, max_step)
                expected.append(s.copy())
            if mode == "ramp":
                rows = fast.ramp(commands[k], end, ticks)
            elif mode == "hold":
                rows = fast.hold(commands[k], ticks)
            else:  # its shortcut for steps within a tick's slew
                rows = fast.hold_sample(commands, k, ticks)
            got = np.tile(commands[k], (ticks, 1)) if rows is None else rows
            if not ramp:  # the rows after `moving` all hold the command
                np.testing.assert_array_equal(
                    got[fast.moving :], commands[k][None].repeat(ticks - fast.moving, 0)
                )
            np.testing.assert_allclose(got, np.array(expected), rtol=0, atol=1e-12)


@pytest.fixture(scope="module")
def squats():
    robot = load_robot("servo_biped")
    traj = run_motion(robot, "one_leg_squats").trajectory
    keep = 300  # 3 s of the motion: the stand on one leg and the first squat
    return robot, traj, joint_angles(robot, traj.q)[:keep]


def _both(inp):
    new = run_engine(inp)
    old = run_engine(dataclasses.replace(inp, servo_in_mujoco=False))
    return new, old


@pytest.mark.parametrize("case", ["hold", "ramps", "jumps"])
def test_law_in_mujoco_gives_the_python_laws_trajectories(squats, case):
    robot, traj, q_cmd = squats
    traj = first_samples(traj, len(q_cmd))
    servo = default_servos(robot)
    if case == "jumps":  # every 20th command 0.05 rad off: the slew takes several ticks
        q_cmd = q_cmd.copy()
        q_cmd[10::20] += 0.05
    inp = prepare(robot, traj, q_cmd, servo)
    if case == "ramps":
        inp = dataclasses.replace(inp, linear_hold=True)
    assert np.any(servo.backlash_deg > 0.0)  # the two-actuator form is exercised
    new, old = _both(inp)
    assert new.fall_index == old.fall_index == -1
    assert new.n_simulated == old.n_simulated
    np.testing.assert_allclose(new.q, old.q, atol=1e-6)
    np.testing.assert_allclose(new.v, old.v, atol=1e-4)
    np.testing.assert_allclose(new.tau_Nm, old.tau_Nm, atol=1e-4)
    np.testing.assert_allclose(new.contact_force_N, old.contact_force_N, atol=1e-3)


def test_rigid_servos_on_roban_too():
    from pathlib import Path

    urdf = Path(__file__).parents[1] / "third_party" / "roban_s14" / "urdf" / "robanS14.urdf"
    if not urdf.exists():
        pytest.skip("Roban S14 not in the tests' third-party folder")
    robot = load_robot(str(urdf))
    traj = run_motion(robot, "one_leg_squats").trajectory
    q_cmd = joint_angles(robot, traj.q)[:150]
    traj = first_samples(traj, 150)
    inp = prepare(robot, traj, q_cmd, ServoModel.rigid(robot.joint_names))
    new, old = _both(inp)
    assert new.fall_index == old.fall_index
    np.testing.assert_allclose(new.q, old.q, atol=1e-6)
    np.testing.assert_allclose(new.tau_Nm, old.tau_Nm, atol=1e-3)
    np.testing.assert_allclose(new.contact_force_N, old.contact_force_N, atol=1e-2)
