"""Built-in motions, checked on the sampled configurations with pinocchio (FK, centre of mass)
against the papers' parameters: the 5 cm CoM shift, three one-leg squats (2 cm deeper, twice
as fast), the semi-elliptical step with a trapezoidal speed profile, planted stance feet."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.signal import find_peaks

from app.core.errors import StudioError
from app.core.motions.keyframes import interpolate
from app.core.motions.library import MOTIONS, resolve_params, run_motion
from tests.conftest import load_robots

DT = 0.02


@pytest.fixture(scope="module")
def robots():
    return load_robots("servo_biped", "roban", "dircon_biped", "hybrid_leg_biped")


def frame_positions(robot, q, link):
    model, data = robot.model, robot.model.createData()
    fid = model.getFrameId(link)
    out = []
    for q_k in q:
        pin.framesForwardKinematics(model, data, q_k)
        out.append(data.oMf[fid].translation.copy())
    return np.array(out)


def com_path(robot, q):
    data = robot.model.createData()
    return np.array([pin.centerOfMass(robot.model, data, q_k) for q_k in q])


def local_minima(z, prominence_m=0.005):
    """Indices of the dips of a height profile deeper than prominence_m."""
    return find_peaks(-z, prominence=prominence_m)[0]


def test_registry_declares_every_parameter():
    assert set(MOTIONS) == {
        "com_shift",
        "one_leg_stand",
        "one_leg_squats",
        "side_swing",
        "front_swing",
        "step_in_place",
    }
    for spec in MOTIONS.values():
        assert spec.description
        for param in spec.params:
            assert param.help and isinstance(param.unit, str)
    squats = {p.name: p for p in MOTIONS["one_leg_squats"].params}
    assert squats["squats"].default == 3 and squats["speed"].default == 1.0
    assert squats["shift_m"].default == 0.05 and squats["shift_m"].unit == "m"
    step = {p.name: p for p in MOTIONS["step_in_place"].params}
    assert step["foot_speed_mps"].default == pytest.approx(0.0417)  # hybrid-leg paper, Exp. A


@pytest.mark.parametrize(
    "name, given, words",
    [
        ("jump", {}, ["'jump'", "com_shift", "step_in_place"]),
        ("com_shift", {"shfit_m": "0.05"}, ["'shfit_m'", "shift_m", "speed"]),
        ("com_shift", {"shift_m": "five"}, ["shift_m", "not a number"]),
        ("com_shift", {"shift_m": "nan"}, ["shift_m", "finite"]),
        ("com_shift", {"shift_m": "-0.1"}, ["shift_m", "minimum"]),
        ("one_leg_squats", {"squats": "2.5"}, ["squats", "whole number"]),
        ("com_shift", {"side": "up"}, ["side", "left", "right"]),
    ],
)
def test_bad_parameters_raise_clear_errors(name, given, words):
    with pytest.raises(StudioError) as error:
        resolve_params(name, given)
    for word in words:
        assert word in str(error.value)


def test_parameters_from_text():
    values = resolve_params("one_leg_squats", {"speed": "2", "squats": "3", "depth_m": "auto"})
    assert values["speed"] == 2.0 and values["squats"] == 3 and values["depth_m"] is None


@pytest.mark.parametrize("robot_name", ["servo_biped", "roban"])
@pytest.mark.parametrize("name", list(MOTIONS))
def test_stance_feet_stay_planted(robots, robot_name, name):
    robot = robots[robot_name]
    plan = MOTIONS[name].build(robot, **resolve_params(name, {}))
    traj = interpolate(robot, plan.keyframes, dt=DT).trajectory
    ends = np.cumsum([0.0] + [kf.duration_s for kf in plan.keyframes[1:]])
    assert traj.duration == pytest.approx(ends[-1], abs=DT)
    feet = {foot.side: frame_positions(robot, traj.q, foot.link) for foot in robot.feet}
    for i, kf in enumerate(plan.keyframes[1:]):
        segment = (traj.t >= ends[i] - 1e-9) & (traj.t <= ends[i + 1] + 1e-9)
        for side in ("left", "right"):
            if kf.stance in (side, "both"):
                path = feet[side][segment]
                assert np.linalg.norm(path - path[0], axis=1).max() < 1e-3, (kf.name, side)
                assert traj.contacts[segment, 0 if side == "left" else 1].all()


@pytest.mark.parametrize("robot_name", ["servo_biped", "roban"])
@pytest.mark.parametrize("shift_m, side", [(0.05, "left"), (0.043, "right")])
def test_com_shift_reaches_the_papers_shift(robots, robot_name, shift_m, side):
    robot = robots[robot_name]
    result = run_motion(robot, "com_shift", dt=DT, shift_m=shift_m, side=side)
    com = com_path(robot, result.trajectory.q)
    towards = 1.0 if side == "left" else -1.0
    assert com[-1, 1] - com[0, 1] == pytest.approx(towards * shift_m, abs=2e-3)
    assert com[-1, 0] == pytest.approx(com[0, 0], abs=2e-3)
    assert result.warnings == ()


@pytest.fixture(scope="module")
def squats(robots):
    robot = robots["servo_biped"]
    runs = {
        key: run_motion(robot, "one_leg_squats", dt=DT, **params)
        for key, params in {
            "normal": {},
            "deeper": {"extra_depth_m": 0.02},
            "fast": {"speed": 2.0},
        }.items()
    }
    return robot, runs


def test_three_squats_on_one_leg(squats):
    robot, runs = squats
    traj = runs["normal"].trajectory
    pelvis_z = frame_positions(robot, traj.q, robot.tree.root)[:, 2]
    com_z = com_path(robot, traj.q)[:, 2]
    assert len(local_minima(pelvis_z)) == 3
    assert len(local_minima(com_z)) == 3
    right = frame_positions(robot, traj.q, robot.foot("right").link)
    squatting = traj.t > traj.t[local_minima(pelvis_z)[0]] - 0.5
    assert (right[squatting, 2] > 0.02).all()  # the free foot stays up
    assert not traj.contacts[squatting, 1].any() and traj.contacts[:, 0].all()
    assert runs["normal"].warnings == ()


def test_deeper_squat_is_2_cm_deeper(squats):
    robot, runs = squats
    lows = {}
    for key in ("normal", "deeper"):
        pelvis_z = frame_positions(robot, runs[key].trajectory.q, robot.tree.root)[:, 2]
        lows[key] = pelvis_z[local_minima(pelvis_z)]
        assert len(lows[key]) == 3
    assert lows["normal"] - lows["deeper"] == pytest.approx(np.full(3, 0.02), abs=1e-3)


def test_fast_squats_take_half_the_time(squats):
    _, runs = squats
    normal, fast = runs["normal"].trajectory, runs["fast"].trajectory
    assert fast.duration == pytest.approx(normal.duration / 2, abs=DT)
    assert np.abs(fast.v).max() > 1.8 * np.abs(normal.v).max()


def trapezoid_law(tau, ramp):
    """Position along a path with a trapezoidal speed: accelerate for `ramp`, cruise, brake."""
    peak = 1.0 / (1.0 - ramp)
    return np.where(
        tau < ramp,
        0.5 * peak * tau**2 / ramp,
        np.where(
            tau > 1.0 - ramp,
            1.0 - 0.5 * peak * (1.0 - tau) ** 2 / ramp,
            peak * (tau - 0.5 * ramp),
        ),
    )


def test_step_in_place_foot_path_is_a_semi_ellipse(robots):
    robot = robots["servo_biped"]
    stride, height, dt = 0.03, 0.025, 0.01
    given = {"steps": 1, "stride_m": stride, "height_m": height}
    plan = MOTIONS["step_in_place"].build(robot, **resolve_params("step_in_place", given))
    result = interpolate(robot, plan.keyframes, dt=dt)
    assert result.warnings == ()
    i = [kf.name for kf in plan.keyframes].index("step 1")
    step, begin = plan.keyframes[i], sum(kf.duration_s for kf in plan.keyframes[1:i])
    t = result.trajectory.t
    during = (t >= begin - 1e-9) & (t <= begin + step.duration_s + 1e-9)
    foot = frame_positions(robot, result.trajectory.q, robot.foot("right").link)[during]
    x0, z0 = foot[0, 0], foot[0, 2]
    assert foot[:, 2].max() - z0 == pytest.approx(height, abs=1e-3)  # apex as parametrised
    assert foot[-1, 0] - x0 == pytest.approx(stride, abs=1e-3)
    a, centre = stride / 2, x0 + stride / 2
    ellipse = ((foot[:, 0] - centre) / a) ** 2 + ((foot[:, 2] - z0) / height) ** 2
    assert np.abs(ellipse - 1.0).max() < 0.1
    # Time law: the phase φ of x = centre − a·cos φ, z = z0 + h·sin φ has a trapezoidal speed
    # profile (hybrid-leg paper's "T-shaped" curve; our ramp: a quarter of the step).
    phase = np.pi * trapezoid_law((t[during] - begin) / step.duration_s, ramp=0.25)
    expected_x = centre - a * np.cos(phase)
    expected_z = z0 + height * np.sin(phase)
    assert np.abs(foot[:, 0] - expected_x).max() < 1e-3
    assert np.abs(foot[:, 2] - expected_z).max() < 1e-3
    # Mean foot speed along its path: the paper's 41.7 mm/s.
    length = np.sum(np.linalg.norm(np.diff(foot, axis=0), axis=1))
    assert length / step.duration_s == pytest.approx(0.0417, rel=0.05)


def test_step_in_place_alternates_feet(robots):
    robot = robots["servo_biped"]
    result = run_motion(robot, "step_in_place", dt=DT, steps=2)
    contacts = result.trajectory.contacts
    in_air = ~contacts
    assert in_air[:, 1].any() and in_air[:, 0].any()
    first_right = np.flatnonzero(in_air[:, 1])[0]
    first_left = np.flatnonzero(in_air[:, 0])[0]
    assert first_right < first_left and not (in_air[:, 0] & in_air[:, 1]).any()


@pytest.mark.parametrize("robot_name", ["dircon_biped", "hybrid_leg_biped"])
def test_robots_without_ankle_roll_get_the_closest_motion_and_a_com_warning(robots, robot_name):
    robot = robots[robot_name]
    small = {"squats": 1, "swings": 1, "steps": 2}
    for name, spec in MOTIONS.items():
        params = {
            key: value for key, value in small.items() if key in {p.name for p in spec.params}
        }
        result = run_motion(robot, name, dt=0.05, **params)
        assert result.trajectory.n_samples > 2
        assert np.all(np.isfinite(result.trajectory.q))
        assert any("CoM" in w.message for w in result.warnings), name
        assert any("CoM" in line for line in result.summary()), name
