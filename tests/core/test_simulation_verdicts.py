"""The simulation's verdicts on constructed cases.

The rules alone (`judge`) on arrays built by hand, where every number is known; then MuJoCo
runs on servo_biped built so that the answer is known beforehand: a lifted foot put back on the
floor (leans), a robot tipped by its ankles (falls: the time checked with pinocchio on the
simulated configurations), feet dragged apart on a slippery floor (slips: the slide checked
with pinocchio's forward kinematics), a stepping motion whose servos never move (covers
nothing, each footstep off by exactly its planned stride) and the same motion followed by stiff
servos (its distance read again from MuJoCo's own body positions).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.library import run_motion
from app.core.motions.trajectory import from_configurations
from app.core.robot.loading import load_robot
from app.core.servo.model import ServoModel, base_roll_pitch, joint_angles
from app.core.simulation.engine import FALL_TILT_DEG, pin_to_qpos
from app.core.simulation.mjcf import SimOptions, build_sim_model
from app.core.simulation.run import simulate
from app.core.simulation.verdicts import LEAN_MIN_S, SLIP_M, judge

T, DT, WEIGHT = 200, 0.01, 60.0


def _case(**changes) -> dict:
    """A 2 s run standing still on both feet, as `judge` takes it; `changes` override."""
    t = np.arange(T) * DT
    arrays = {
        "t_s": t,
        "planned_contacts": np.ones((T, 2), bool),
        "contact_force_N": np.zeros((T, 2, 3)),
        "weight_N": WEIGHT,
        "slip_m": np.zeros((T, 2)),
        "sole_xy_m": np.tile([[0.0, 0.05], [0.0, -0.05]], (T, 1, 1)),
        "planned_sole_xy_m": np.tile([[0.0, 0.05], [0.0, -0.05]], (T, 1, 1)),
        "root_xy_m": np.zeros((T, 2)),
        "planned_root_xy_m": np.zeros((T, 2)),
    }
    arrays["contact_force_N"][:, :, 2] = WEIGHT / 2
    arrays.update(changes)
    return arrays


def _lifted_right(load_frac: float, first: int, count: int) -> dict:
    """The right foot planned in the air from sample 50 to 149, loaded with `load_frac` of the
    weight on samples first … first + count − 1."""
    case = _case()
    case["planned_contacts"][50:150, 1] = False
    case["contact_force_N"][50:150, 1, 2] = 0.0
    case["contact_force_N"][first : first + count, 1, 2] = load_frac * WEIGHT
    return case


def test_a_lifted_foot_loaded_for_more_than_a_tenth_of_a_second_leans():
    verdict = judge(**_lifted_right(0.10, 80, 12))  # 0.12 s at 10 % of the weight
    assert verdict.kind == "leans on the lifted foot"
    assert verdict.lean is not None and verdict.lean.side == "right"
    assert verdict.lean.start_s == pytest.approx(0.80)
    assert verdict.lean.duration_s == pytest.approx(0.12)
    assert verdict.lifted_foot_load_s == pytest.approx(0.12)
    assert verdict.lifted_foot_peak_load_frac == pytest.approx(0.10)
    assert verdict.text.startswith("leans on the lifted foot: the right foot")
    assert "from 0.80 s" in verdict.text and "10 %" in verdict.text


def test_a_short_or_light_touch_is_not_leaning():
    short = judge(**_lifted_right(0.10, 80, 10))  # exactly 0.1 s: not longer than 0.1 s
    assert round(LEAN_MIN_S / DT) == 10
    assert short.kind == "stays up" and short.lean is None
    assert short.lifted_foot_load_s == pytest.approx(0.10)
    assert len(short.scuffs) == 1 and short.scuffs[0].start_s == pytest.approx(0.80)
    light = judge(**_lifted_right(0.04, 60, 80))  # 0.8 s at 4 %: below 5 % of the weight
    assert light.kind == "stays up" and light.lifted_foot_load_s == 0.0
    assert light.lifted_foot_peak_load_frac == pytest.approx(0.04)


def test_a_stance_foot_sliding_more_than_a_centimetre_slips():
    slip = np.zeros((T, 2))
    slip[100:, 0] = np.linspace(0.0, 0.015, T - 100)
    verdict = judge(**_case(slip_m=slip))
    assert verdict.kind == "slips" and verdict.slip_side == "left"
    assert verdict.slip_m == pytest.approx(0.015)
    assert verdict.text == "slips: the left foot slides 1.5 cm by 1.99 s"
    # the same slide on a foot planned in the air is no slip
    lifted = _case(slip_m=slip)
    lifted["planned_contacts"][:, 0] = False
    assert judge(**lifted).slip_m == 0.0
    assert judge(**_case(slip_m=slip * (0.9 * SLIP_M / 0.015))).kind == "stays up"


def test_a_fall_wins_and_what_follows_it_is_not_judged():
    case = _lifted_right(0.5, 120, 30)  # leaning only after the fall
    verdict = judge(**case, fall_index=100, fall_reason="the torso's roll is 31° off the plan")
    assert verdict.kind == "falls" and verdict.fall_time_s == pytest.approx(1.0)
    assert verdict.text == "falls at 1.00 s (the torso's roll is 31° off the plan)"
    assert verdict.lean is None and verdict.lifted_foot_load_s == 0.0
    before = judge(**_lifted_right(0.5, 60, 30), fall_index=100, fall_reason="x")
    assert before.kind == "falls" and "before, it leaned on the lifted foot" in before.text


def test_a_walk_is_measured_along_its_planned_direction_with_each_footstep():
    """The plan walks 0.5 m along x; the simulated root ends at (0.3, 0.05): 0.3 m covered
    along the plan. The right foot lifts at 0.5 s and is planned to land 0.2 m ahead at 1.0 s;
    the simulation has it at 0.17 m, 0.01 m aside in mid-stance: 3.16 cm off."""
    case = _case()
    case["planned_root_xy_m"][:, 0] = np.linspace(0.0, 0.5, T)
    case["root_xy_m"][:, 0] = np.linspace(0.0, 0.3, T)
    case["root_xy_m"][:, 1] = np.linspace(0.0, 0.05, T)
    case["planned_contacts"][50:100, 1] = False
    case["planned_sole_xy_m"][100:, 1] = [0.2, -0.05]
    case["sole_xy_m"][100:, 1] = [0.17, -0.04]
    verdict = judge(**case)
    assert verdict.travel is not None
    assert verdict.travel.distance_planned_m == pytest.approx(0.5)
    assert verdict.travel.distance_covered_m == pytest.approx(0.3)
    (step,) = verdict.travel.footsteps
    assert step.side == "right" and step.planned_touchdown_s == pytest.approx(1.0)
    assert step.error_m == pytest.approx(np.hypot(0.03, 0.01))
    assert "covers 0.30 m of 0.50 m planned (60 %), 1 footstep 3.2 cm off" in verdict.text
    summary = verdict.summary()
    assert summary["footstep_errors_m"] == [pytest.approx(np.hypot(0.03, 0.01))]
    # a CoM shift moves the root but lands no foot elsewhere: it does not travel
    shift = _case()
    shift["planned_root_xy_m"][:, 1] = np.linspace(0.0, 0.05, T)
    assert judge(**shift).travel is None and "distance_planned_m" not in judge(**shift).summary()


def test_a_verdict_goes_into_a_project_file_and_comes_back_equal():
    """Projects keep simulations: the verdict record passes the project codec (JSON by the
    declared types) unchanged, with its footsteps, scuffs and lean."""
    import json

    from app.core.projects.codec import Reader, encode
    from app.core.simulation.verdicts import Verdict

    case = _lifted_right(0.3, 60, 30)
    case["planned_sole_xy_m"][150:, 1] = [0.2, -0.05]
    case["planned_root_xy_m"][:, 0] = np.linspace(0.0, 0.2, T)
    case["contact_force_N"][155:158, 0, 2] = 0.0
    verdict = judge(**case)
    assert verdict.lean is not None and verdict.travel is not None and verdict.travel.footsteps
    blobs: dict = {}
    data = json.loads(json.dumps(encode(verdict, "verdict", blobs)))
    assert Reader(blobs.__getitem__).decode(Verdict, data, "verdict") == verdict


# --- MuJoCo runs on servo_biped, built so that the answer is known ------------------------------


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def stand(robot):
    """Standing still on both feet for 3 s (the motions' starting pose)."""
    start = run_motion(robot, "com_shift", shift_m=0.0).trajectory.q[0]
    n = 301
    return from_configurations(
        robot.model, "stand", robot.joint_names, 0.01, np.tile(start, (n, 1)), np.ones((n, 2), bool)
    )


def _within_limits(robot, q_cmd: np.ndarray) -> np.ndarray:
    return np.clip(q_cmd, [j.lower for j in robot.joints], [j.upper for j in robot.joints])


def _ramp(n: int, first: int, length: int) -> np.ndarray:
    return np.clip((np.arange(n) - first) / length, 0.0, 1.0)


def test_a_lifted_foot_put_back_on_the_floor_leans(robot):
    """One-leg stand whose servos are sent back to the starting pose (both feet down, CoM
    between them) from 1.5 s before the end: the right foot, which the plan holds in the air,
    lands and carries weight from then on. The plan itself, on the same stiff servos, does
    not lean."""
    traj = run_motion(robot, "one_leg_stand").trajectory
    q_plan = joint_angles(robot, traj.q)
    n = traj.n_samples
    first = traj.index_at(traj.t[-1] - 1.5)
    back = _ramp(n, first, 30)[:, None]
    q_cmd = q_plan + back * (q_plan[0] - q_plan)
    rigid = ServoModel.rigid(robot.joint_names)
    plan, placed = simulate(robot, traj, q_plan, rigid), simulate(robot, traj, q_cmd, rigid)
    assert plan.outcome.kind == "stays up" and plan.outcome.lean is None
    assert placed.outcome.kind == "leans on the lifted foot", placed.verdict()
    lean = placed.outcome.lean
    assert lean is not None and lean.side == "right"
    assert traj.t[first] < lean.start_s < traj.t[first] + 0.6
    assert placed.outcome.lifted_foot_peak_load_frac > 0.3
    assert placed.verdict().startswith("leans on the lifted foot: the right foot")


def test_a_robot_tipped_over_by_its_ankles_falls(robot, stand):
    """Both ankles pitched 35° over 0.5 s from t = 0.5 s: the robot tips. The fall time is the
    first sample whose torso pitch (pinocchio's convention, from the simulated configurations)
    is more than 30° off the plan's upright stance."""
    q_plan = joint_angles(robot, stand.q)
    tip = np.radians(35.0) * _ramp(stand.n_samples, 50, 50)
    q_cmd = q_plan.copy()
    for name in ("left_ankle_pitch", "right_ankle_pitch"):
        q_cmd[:, robot.joint_names.index(name)] += tip
    result = simulate(
        robot, stand, _within_limits(robot, q_cmd), ServoModel.rigid(robot.joint_names)
    )
    assert result.outcome.kind == "falls" and "pitch" in result.fall_reason
    assert result.verdict().startswith(f"falls at {result.fall_time_s:.2f} s (the torso's pitch")
    _, pitch = base_roll_pitch(result.q)
    off = np.degrees(np.abs(pitch))
    k = stand.index_at(result.fall_time_s)
    assert k > 50 and off[k] > FALL_TILT_DEG and np.all(off[:k] <= FALL_TILT_DEG)


def _sole_centres_fk(robot, q: np.ndarray, side: str) -> np.ndarray:
    """The sole centre of one foot over the samples, by pinocchio's forward kinematics."""
    foot = robot.foot(side)
    frame, centre = robot.link_frame_ids[foot.link], foot.sole_corners_m.mean(axis=0)
    data = robot.model.createData()
    out = []
    for q_k in q:
        pin.framesForwardKinematics(robot.model, data, q_k)
        out.append(data.oMf[frame].act(centre))
    return np.array(out)


def test_feet_dragged_apart_on_a_slippery_floor_slip(robot, stand):
    """Both hips rolled 10° outwards (ankles rolled back to keep the soles flat) on a floor of
    μ = 0.05: the standing feet are dragged apart. The slide the verdict reports is the one
    pinocchio's forward kinematics gives on the simulated configurations; standing still on
    the same floor does not slip."""
    q_plan = joint_angles(robot, stand.q)
    spread = np.radians(10.0) * _ramp(stand.n_samples, 50, 50)
    q_cmd = q_plan.copy()
    for side, sign in (("left", 1.0), ("right", -1.0)):
        q_cmd[:, robot.joint_names.index(f"{side}_hip_roll")] += sign * spread
        q_cmd[:, robot.joint_names.index(f"{side}_ankle_roll")] -= sign * spread
    rigid, slippery = ServoModel.rigid(robot.joint_names), SimOptions(friction=0.05)
    still = simulate(robot, stand, q_plan, rigid, slippery)
    assert still.outcome.kind == "stays up" and still.outcome.slip_m < 0.002
    result = simulate(robot, stand, _within_limits(robot, q_cmd), rigid, slippery)
    assert result.outcome.kind == "slips", result.verdict()
    side = result.outcome.slip_side
    fk = _sole_centres_fk(robot, result.q, side)
    slid = np.linalg.norm(fk[:, :2] - fk[0, :2], axis=1).max()
    assert slid > SLIP_M
    assert result.outcome.slip_m == pytest.approx(slid, abs=0.002)


@pytest.fixture(scope="module")
def steps_forward(robot):
    """Four steps of 4 cm (the hybrid-leg paper's stepping motion, with a stride)."""
    return run_motion(robot, "step_in_place", steps=4, stride_m=0.04).trajectory


def test_servos_that_never_move_cover_nothing_and_miss_every_footstep(robot, steps_forward):
    """Every servo held at its first command: the robot stands where it started. It covers
    nothing of the planned distance, and each footstep is off by exactly how far the plan
    moves that foot from where it stood at the start (pinocchio's forward kinematics)."""
    traj = steps_forward
    q_plan = joint_angles(robot, traj.q)
    held = np.tile(q_plan[0], (traj.n_samples, 1))
    result = simulate(robot, traj, held, ServoModel.rigid(robot.joint_names))
    travel = result.outcome.travel
    assert travel is not None
    assert travel.distance_planned_m == pytest.approx(
        np.linalg.norm(traj.q[-1, :2] - traj.q[0, :2])
    )
    assert travel.distance_planned_m > 0.05
    assert abs(travel.distance_covered_m) < 0.005
    assert len(travel.footsteps) == 4
    for step in travel.footsteps:
        start = _sole_centres_fk(robot, traj.q[:1], step.side)[0, :2]
        k = traj.index_at(step.planned_touchdown_s)
        landing = _sole_centres_fk(robot, traj.q[k : k + 1], step.side)[0, :2]
        assert step.error_m == pytest.approx(np.linalg.norm(landing - start), abs=0.003)
    assert result.summary()["distance_covered_m"] == travel.distance_covered_m


def test_distance_covered_is_read_from_mujocos_body_positions(robot, steps_forward):
    """Stiff servos following the plan: the distance covered is the root body's displacement
    in MuJoCo (a fresh MjData put in the first and last simulated states, `xpos` read after
    mj_kinematics), along the planned direction; stiff servos walk most of the plan."""
    import mujoco

    traj = steps_forward
    result = simulate(robot, traj, joint_angles(robot, traj.q), ServoModel.rigid(robot.joint_names))
    travel = result.outcome.travel
    assert travel is not None
    sim = build_sim_model(robot)
    m = mujoco.MjModel.from_xml_string(sim.xml)
    d = mujoco.MjData(m)
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, sim.root_body)
    ends = []
    for k in (0, traj.index_at(result.simulated_until_s)):
        pin_to_qpos(sim, result.q[k], d.qpos)
        mujoco.mj_kinematics(m, d)
        ends.append(d.xpos[root, :2].copy())
    planned = traj.q[-1, :2] - traj.q[0, :2]
    covered = float((ends[1] - ends[0]) @ planned / np.linalg.norm(planned))
    assert travel.distance_covered_m == pytest.approx(covered, abs=1e-9)
    assert 0.8 < travel.fraction < 1.2


def test_the_papers_43_mm_squats_lean_without_compensation_and_stand_with_eq_7(robot):
    """The spring-compensation paper's Figs. 16–18 on servo_biped with the paper's servo
    (1.4 °/(N·m), 0.5° dead band): without compensation the robot tips onto its lifted foot,
    which the independent audit saw carrying up to 25 % of the weight; eq 7 (k = the servo's
    compliance) keeps it off the floor (the audit: 0.01 s)."""
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.servo.compensation import compensated_command
    from app.core.simulation.experiments import PAPER_EXPERIMENTS, compensations
    from app.core.simulation.files import default_servos
    from app.core.simulation.run import simulate_commands

    experiment = next(e for e in PAPER_EXPERIMENTS if e.key == "squats_4.3cm")
    assert experiment.paper_without == "falls" and experiment.paper_with == "stays up"
    traj = run_motion(robot, experiment.motion, **experiment.params).trajectory
    servo = default_servos(robot)
    eq7 = compensations(servo)["eq 7"]
    assert eq7 is not None
    q_plan = joint_angles(robot, traj.q)
    q_eq7 = compensated_command(q_plan, torque_feedforward(robot, traj).tau_Nm, eq7)
    runs = simulate_commands(robot, traj, {"none": q_plan, "eq 7": q_eq7}, servo)
    without, with_eq7 = runs["none"].outcome, runs["eq 7"].outcome
    assert without.kind == "leans on the lifted foot", without.text
    assert without.lean is not None and without.lean.side == "right"  # the paper lifts it
    assert 0.15 < without.lifted_foot_peak_load_frac < 0.35
    assert with_eq7.kind == "stays up", with_eq7.text
    assert with_eq7.lifted_foot_load_s <= LEAN_MIN_S


@pytest.mark.parametrize("source", ["servo_biped", "hybrid_leg_biped"])
def test_a_fall_names_the_urdf_link_each_mujoco_body_carries(source):
    """The link named when a body touches the floor is the child link of that body's joint
    in the URDF itself (and the root body carries the root link)."""
    robot = load_robot(source)
    sim = build_sim_model(robot)
    links = dict(sim.body_links)
    assert len(links) == robot.model.njoints - 1
    for name, joint in robot.tree.joints.items():
        if robot.model.existJointName(name):
            body = f"j{robot.model.getJointId(name)}_{name}"
            assert links[body] == joint.child
    assert links[sim.root_body] == robot.tree.root
