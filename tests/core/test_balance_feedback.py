"""The optional balance feedback (app.core.simulation.balance_feedback) against independent
references: the IMU's Euler rates against a finite difference of pinocchio's rotations; the
offsets on a standing robot whose base is tilted by a known angle against the PD law's
closed form, their sign checked by pinocchio turning the torso back with the feet held;
and a soft-servo stand that the linearised stiffness balance says cannot stand and that
falls without the feedback (MuJoCo's own body heights) but stands with it."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.dynamics.stand_stiffness import stand_check
from app.core.motions.trajectory import Trajectory
from app.core.quaternions import matrix_to_wxyz
from app.core.servo.model import ServoModel, joint_angles
from app.core.simulation.balance_feedback import (
    BalanceFeedback,
    BalanceGains,
    Balancer,
    gains_from_pairs,
    imu_roll_pitch,
)
from app.core.simulation.engine import run_engine
from app.core.simulation.errors import SimulationInputError
from app.core.simulation.files import sized_servos
from app.core.simulation.run import prepare, simulate_commands

GAINS = BalanceGains(ankle_kp=1.0, ankle_kd=0.05, hip_kp=0.5, hip_kd=0.02, max_offset_deg=10.0)


def _stand(robot, first_q: np.ndarray, seconds: float) -> Trajectory:
    """The robot held at `first_q` on both feet for `seconds`."""
    n = round(seconds / 0.01) + 1
    q = np.repeat(first_q[None], n, axis=0)
    zero = np.zeros((n, robot.model.nv))
    return Trajectory(
        "stand", robot.joint_names, np.arange(n) * 0.01, q, zero, zero.copy(), np.ones((n, 2), bool)
    )


@pytest.fixture(scope="module")
def stand(servo_biped, com_shift):
    return _stand(servo_biped, com_shift.q[0], 3.0)


def _rpy(R: np.ndarray) -> np.ndarray:
    return np.asarray(pin.rpy.matrixToRpy(R))


def test_the_imu_rates_are_the_euler_angles_rates():
    """roll/pitch rates from the gyro's body rates equal the finite difference of the ZYX
    angles along a rotation R(t) = rpy(φ0 + φ̇t, θ0 + θ̇t, ψ0 + ψ̇t) (pinocchio)."""
    rpy0, rpy_rate, h = np.array([0.3, -0.2, 1.1]), np.array([0.7, -1.3, 0.4]), 1e-6
    R = [pin.rpy.rpyToMatrix(*(rpy0 + s * h * rpy_rate)) for s in (-1.0, 0.0, 1.0)]
    omega_body = pin.log3(R[0].T @ R[2]) / (2 * h)
    tilt, rates = imu_roll_pitch(matrix_to_wxyz(R[1]), omega_body)
    np.testing.assert_allclose(tilt, rpy0[:2], atol=1e-12)
    np.testing.assert_allclose(rates, rpy_rate[:2], rtol=1e-6)


def test_the_offsets_are_the_pd_law_with_its_saturation():
    """Two joints (a pitch and a roll axis, one with its axis reversed): Δq = clip(Kp·(a·e) +
    Kd·(a·ė), ±max), none on a leg the plan has in the air."""
    feedback = BalanceFeedback(
        gains=GAINS,
        columns=np.array([2, 0]),
        legs=np.array([0, 1]),
        names=("pitch", "roll"),
        axis_xy=np.array([[0.0, -1.0], [1.0, 0.0]]),
        kp=np.array([1.0, 0.5]),
        kd=np.array([0.05, 0.02]),
        stance=np.array([[True, True], [True, False]]),
        tilt_planned_rad=np.array([[0.01, -0.02], [0.0, 0.0]]),
        rate_planned_rad_s=np.array([[0.1, 0.0], [0.0, 0.0]]),
        lower_rad=np.full(3, -1.0),
        upper_rad=np.full(3, 1.0),
    )
    balancer = Balancer(feedback, 2, 3)
    roll, pitch = 0.05, 0.03
    qpos = np.zeros(7)
    qpos[3:7] = matrix_to_wxyz(pin.rpy.rpyToMatrix(roll, pitch, 0.0))
    qvel = np.zeros(6)  # at rest: ė = −the plan's rate
    out = balancer.offsets(0, qpos, qvel)
    e, e_dot = np.array([roll - 0.01, pitch + 0.02]), np.array([-0.1, 0.0])
    assert out[2] == pytest.approx(1.0 * -e[1] + 0.05 * -e_dot[1])
    assert out[0] == pytest.approx(0.5 * e[0] + 0.02 * e_dot[0])
    assert out[1] == 0.0
    qpos[3:7] = matrix_to_wxyz(pin.rpy.rpyToMatrix(0.0, 0.5, 0.0))  # 28.6° of pitch
    out = balancer.offsets(1, qpos, qvel)
    assert out[2] == pytest.approx(-math.radians(10.0))  # saturated
    assert out[0] == 0.0  # the right leg is in the air at sample 1


def _tilted_offsets(robot, stand: Trajectory, rpy_tilt: np.ndarray) -> np.ndarray:
    """The offsets the feedback adds at the first sample of a stand whose base is tilted by
    `rpy_tilt` (at rest: no settling)."""
    q_plan = joint_angles(robot, stand.q)
    inp = prepare(robot, stand, q_plan, sized_servos(robot), balance=GAINS)
    q0 = inp.q0.copy()
    R = pin.rpy.rpyToMatrix(*rpy_tilt) @ pin.Quaternion(q0[3:7]).toRotationMatrix()
    q0[3:7] = pin.Quaternion(R).coeffs()
    short = dataclasses.replace(inp, q0=q0, settle_s=0.0, q_cmd_rad=q_plan[:3])
    run = run_engine(short)
    assert run.balance_offsets_rad is not None
    return run.balance_offsets_rad[0]


@pytest.mark.parametrize(
    ("tilt_deg", "axis"), [(3.0, "pitch"), (-4.0, "pitch"), (2.0, "roll"), (15.0, "pitch")]
)
def test_a_tilted_base_turns_the_torso_back_by_the_gains(servo_biped, stand, tilt_deg, axis):
    """A standing robot put down with its base tilted by a known angle e: at the first sample
    the offsets on each stance leg, applied with that foot held (pinocchio), turn the torso
    by −(Kp_ankle + Kp_hip)·e about the tilted axis and not about the other one; each ankle
    and hip joint turns by its gain × e (saturated at 10°)."""
    robot = servo_biped
    k = 0 if axis == "roll" else 1
    rpy_tilt = np.zeros(3)
    rpy_tilt[k] = math.radians(tilt_deg)
    plan_rpy = _rpy(pin.Quaternion(stand.q[0, 3:7]).toRotationMatrix())
    tilted = _rpy(pin.rpy.rpyToMatrix(*rpy_tilt) @ pin.rpy.rpyToMatrix(*plan_rpy))
    error = tilted[k] - plan_rpy[k]  # the IMU's error e, as pinocchio reads it
    assert error == pytest.approx(math.radians(tilt_deg), abs=1e-9)
    offsets = _tilted_offsets(robot, stand, rpy_tilt)

    cap = math.radians(GAINS.max_offset_deg)
    expected = min(GAINS.ankle_kp * abs(error), cap) + min(GAINS.hip_kp * abs(error), cap)
    model, data = robot.model, robot.model.createData()
    q = stand.q[0].copy()
    for foot in robot.feet:
        frame = robot.link_frame_ids[foot.link]
        chain, jid = [], model.frames[frame].parentJoint
        while jid > 1:
            chain.append(jid)
            jid = model.parents[jid]
        columns = [i for i, j in enumerate(robot.joints) if model.getJointId(j.name) in chain]
        moved = q.copy()
        for i in columns:
            moved[robot.joints[i].idx_q] += offsets[i]

        def torso_in_foot(config: np.ndarray, frame: int = frame) -> np.ndarray:
            pin.framesForwardKinematics(model, data, config)
            return data.oMf[frame].rotation.T @ data.oMi[1].rotation

        R_world_foot = pin.rpy.rpyToMatrix(*tilted) @ torso_in_foot(q).T  # held on the floor
        turned = _rpy(R_world_foot @ torso_in_foot(moved)) - tilted
        assert turned[k] == pytest.approx(-math.copysign(expected, error), abs=2e-4), turned
        assert abs(turned[1 - k]) < 2e-4, turned
        magnitudes = sorted(np.abs(offsets[columns]))  # one ankle and one hip joint answer
        np.testing.assert_allclose(
            magnitudes[-2:],
            sorted([min(GAINS.ankle_kp * abs(error), cap), min(GAINS.hip_kp * abs(error), cap)]),
            atol=1e-6,
        )
        assert max(magnitudes[:-2]) < 0.01 * abs(error), offsets[columns]


def test_the_feedback_saves_a_soft_servo_stand(servo_biped, stand):
    """Leg servos of 5 °/(N·m): the stiffness balance says servo_biped cannot stand on them;
    without the feedback its root body (MuJoCo's xpos) drops below 75 % of its start height,
    with it the root stays within 1 cm of where it started for 3 s, and the verdict says
    "stays up with balance feedback"."""
    robot = servo_biped
    base = sized_servos(robot)
    legs = base.compliance_deg_per_Nm > 0.0
    soft = ServoModel(robot.joint_names, np.where(legs, 5.0, 0.0), base.backlash_deg)
    assert not stand_check(robot, stand.q[0], soft.compliance_deg_per_Nm).stands
    q_plan = joint_angles(robot, stand.q)
    off = simulate_commands(robot, stand, {"off": q_plan}, soft, parallel=False)["off"]
    on = simulate_commands(robot, stand, {"on": q_plan}, soft, parallel=False, balance=GAINS)["on"]
    start = stand.q[0, 2]
    assert off.root_position_m[:, 2].min() < 0.75 * start  # it went down (and over)
    assert np.abs(on.root_position_m[:, 2] - start).max() < 0.01
    assert on.verdict().startswith("stays up with balance feedback")
    assert off.verdict().startswith("falls") and "balance" not in off.verdict()
    summary = on.summary()["balance_feedback"]
    assert summary == {"on": True, "gains": GAINS.to_json()}
    assert off.summary()["balance_feedback"] == {"on": False, "gains": None}
    assert on.balance_offsets_rad is not None
    np.testing.assert_allclose(on.q_cmd_rad, q_plan + on.balance_offsets_rad)


def test_zero_gains_step_the_physics_as_without_the_feedback(servo_biped, com_shift):
    """With every gain 0 a run steps a sample at a time and corrects nothing: the same run as
    without the feedback, bit for bit (only the verdict's words differ)."""
    q_plan = joint_angles(servo_biped, com_shift.q)
    servo = sized_servos(servo_biped)
    zero = BalanceGains(0.0, 0.0, 0.0, 0.0)
    a = simulate_commands(servo_biped, com_shift, {"x": q_plan}, servo, parallel=False)["x"]
    b = simulate_commands(
        servo_biped, com_shift, {"x": q_plan}, servo, parallel=False, balance=zero
    )["x"]
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.contact_force_N, b.contact_force_N)
    assert b.verdict() == a.verdict().replace("stays up", "stays up with balance feedback", 1)


def test_bad_gains_say_what_to_give():
    with pytest.raises(SimulationInputError, match="ankle_kp = -1.0; give a finite number ≥ 0"):
        gains_from_pairs(["ankle_kp=-1"])
    with pytest.raises(SimulationInputError, match="NAME one of ankle_kp, ankle_kd"):
        gains_from_pairs(["knee_kp=1"])
    with pytest.raises(SimulationInputError, match="give a number"):
        gains_from_pairs(["hip_kd=soft"])
    with pytest.raises(SimulationInputError, match="0 < … ≤ 45°"):
        BalanceGains(max_offset_deg=0.0)
    assert gains_from_pairs(["hip_kp=0.8"]) == BalanceGains(hip_kp=0.8)
