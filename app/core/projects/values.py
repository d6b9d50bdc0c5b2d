"""Every value a project installs, checked as the studio checks what a user loads (after
`check_fits` has checked the sizes): nothing non-physical gets in, to be autosaved and
restored on every start.

- the pose, every keyframe's configuration and the motion's samples are configurations of the
  robot (app.core.robot.configurations: joints within their limits, unit base quaternions, a
  base within reach); the motion's velocities and accelerations within sanity bounds, its
  time step and length within the budgets (app.core.budgets);
- keyframes: rigid foot and pelvis placements within reach, a CoM target within reach, a
  swing height in [0, MAX_SWING_M];
- torques and contact forces below MAX_TORQUE_NM and MAX_FORCE_N;
- a walk: its motion as above, footprints whose contact starts before it ends;
- simulation runs: their configurations (joint limits aside: the physics may press past them),
  times increasing from 0, a fall time and simulated span inside the run;
- servo parts: catalogue servos the simulation can run, firmware settings in their ranges
  (kp within the firmware's, positive voltage and current limit, a dead band of 0 … 10°) and a
  positive battery figure, as a servo.toml is checked (app.core.servo.choice).

A value that fails raises ProjectError naming its field (`project.motion.q, sample 17 (t =
0.170 s): joint left_knee is at 3.1, beyond its limits [0, 2.3]`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from app.core.budgets import check_dt, check_samples
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.projects.codec import ProjectError
from app.core.robot.configurations import (
    MAX_POSITION_M,
    check_configurations,
    check_motion_rates,
)
from app.core.robot.model import RobotModel

MAX_TORQUE_NM = 1.0e6
"""Largest joint torque a project may hold [N·m] (or force [N] on a prismatic joint)."""
MAX_FORCE_N = 1.0e7
"""Largest contact or loop-closure force a project may hold [N]."""
MAX_SWING_M = 10.0
"""Highest swing apex of a keyframe [m]."""


def check_values(project: Any, robot: RobotModel) -> None:  # a Project (project.py calls us)
    """ProjectError naming the first value of `project` that `robot` cannot take."""
    try:
        _check(project, robot)
    except ProjectError:
        raise
    except StudioError as error:
        raise ProjectError(str(error)) from None


def _check(project: Any, robot: RobotModel) -> None:
    check_configurations(robot, project.q, "project.q (the pose)")
    for i, keyframe in enumerate(project.keyframes):
        _keyframe(robot, keyframe, f"project.keyframes[{i}]")
    motion = project.motion
    if motion is not None:
        check_trajectory(robot, motion, "project.motion")
    ff = project.feedforward
    if ff is not None and motion is not None:
        for label, array, bound in (
            ("tau_Nm", ff.tau_Nm, MAX_TORQUE_NM),
            ("contact_forces_N", ff.contact_forces_N, MAX_FORCE_N),
            ("loop_forces_N", ff.loop_forces_N, MAX_FORCE_N),
        ):
            _bounded(array, bound, f"project.feedforward.{label}")
    walk = project.walk
    if walk is not None:
        if walk.trajectory is not motion:
            check_trajectory(robot, walk.trajectory, "project.walk.trajectory")
        for i, footprint in enumerate(walk.footprints):
            where = f"project.walk.footprints[{i}]"
            need(
                max(abs(footprint.x_m), abs(footprint.y_m)) <= MAX_POSITION_M,
                f"{where} is beyond ±{MAX_POSITION_M:g} m",
            )
            need(
                footprint.t_on_s <= footprint.t_off_s,
                f"{where}: the foot leaves the ground ({footprint.t_off_s:g} s) before it lands "
                f"({footprint.t_on_s:g} s)",
            )
    for i, run in enumerate(project.simulation):
        _simulation(robot, run, f"project.simulation[{i}] ({run.label!r})")
    if project.servo_parts is not None:
        from app.core.servo.catalogue import load_catalogue
        from app.core.servo.choice import choice_parts

        choice_parts(
            project.servo_parts, robot.joint_names, load_catalogue(), "project.servo_parts"
        )


def check_trajectory(robot: RobotModel, motion: Trajectory, where: str) -> None:
    """StudioError unless `motion` is a motion `robot` can make (module docstring)."""
    check_dt(motion.dt, f"{where}: the time step")
    check_samples(motion.n_samples, robot.model.nq, where)
    need(abs(float(motion.t[0])) <= 1e-9, f"{where}.t starts at {motion.t[0]:g} s, not 0")
    check_configurations(robot, motion.q, f"{where}.q", t=motion.t)
    check_motion_rates(motion.v, motion.a, where)


def need(ok: bool, message: str) -> None:
    if not ok:
        raise ProjectError(message)


def _keyframe(robot: RobotModel, keyframe: Any, where: str) -> None:
    if keyframe.q is not None:
        check_configurations(robot, keyframe.q, f"{where}.q")
    for label in ("T_world_left", "T_world_right", "T_world_pelvis"):
        T = getattr(keyframe, label)
        if T is None:
            continue
        rotation = T[:3, :3]
        need(
            np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6)
            and abs(np.linalg.det(rotation) - 1.0) <= 1e-6
            and np.allclose(T[3], (0.0, 0.0, 0.0, 1.0)),
            f"{where}.{label} is not a rigid placement (a rotation and a translation)",
        )
        need(
            np.abs(T[:3, 3]).max() <= MAX_POSITION_M,
            f"{where}.{label} is beyond ±{MAX_POSITION_M:g} m",
        )
    if keyframe.com_xy is not None:
        need(
            np.abs(keyframe.com_xy).max() <= MAX_POSITION_M,
            f"{where}.com_xy is beyond ±{MAX_POSITION_M:g} m",
        )
    need(
        math.isfinite(keyframe.swing_height_m) and 0.0 <= keyframe.swing_height_m <= MAX_SWING_M,
        f"{where}.swing_height_m is {keyframe.swing_height_m:g}; give 0 to {MAX_SWING_M:g} m",
    )


def _bounded(array: np.ndarray, bound: float, where: str) -> None:
    if array.size and np.issubdtype(array.dtype, np.number):
        peak = float(np.nanmax(np.abs(array))) if np.isfinite(array).any() else 0.0
        need(peak <= bound, f"{where} reaches {peak:.3g}, beyond {bound:g}")


def _simulation(robot: RobotModel, run: Any, where: str) -> None:
    t = run.t
    need(
        t.ndim == 1 and len(t) == run.q.shape[0] and abs(float(t[0])) <= 1e-9,
        f"{where}.t does not start at 0 with one time per sample",
    )
    need(bool(np.all(np.diff(t) > 0.0)), f"{where}.t does not increase")
    check_configurations(robot, run.q, f"{where}.q", t=t, limits=False)
    _bounded(run.tau_Nm, MAX_TORQUE_NM, f"{where}.tau_Nm")
    _bounded(run.contact_force_N, MAX_FORCE_N, f"{where}.contact_force_N")
    end = float(t[-1]) + 1e-9
    need(
        0.0 <= run.simulated_until_s <= end,
        f"{where}.simulated_until_s is {run.simulated_until_s:g} s, outside the run",
    )
    if run.fall_time_s is not None:
        need(
            math.isfinite(run.fall_time_s) and 0.0 <= run.fall_time_s <= end,
            f"{where}.fall_time_s is {run.fall_time_s:g} s, outside the run",
        )
    need(
        run.wall_time_s >= 0.0 and run.real_time_factor >= 0.0,
        f"{where}: a negative wall time or real-time factor",
    )
