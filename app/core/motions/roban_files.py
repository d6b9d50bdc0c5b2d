"""Roban motion files (LejuLab-Train): headerless CSV, root xyz [m], root quaternion, the
actuated joint angles [rad] in the URDF's joint order; the frame rate is only in the file name.

The files carry no contacts: `sole_contacts` guesses them from the feet's heights.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import Literal

import numpy as np
import pinocchio as pin

from app.core.motions import motion_text
from app.core.motions.motion_text import MotionFileError
from app.core.motions.trajectory import Trajectory, from_configurations
from app.core.quaternions import wxyz_to_xyzw
from app.core.robot.model import RobotModel

SOLE_CONTACT_BAND_M = 0.01
"""Roban import: a sole within this height of the lowest sole of its frame is in contact."""

_FPS_IN_NAME = re.compile(r"(\d+(?:\.\d+)?)\s*fps", re.IGNORECASE)


def read_roban_motion_csv(
    path: str | os.PathLike[str],
    robot: RobotModel,
    fps: float | None = None,
    quaternion_order: Literal["wxyz", "xyzw"] = "wxyz",
) -> Trajectory:
    """Import a headerless Roban (LejuLab-Train) motion file.

    Columns: root position xyz [m], root quaternion in `quaternion_order`, then one angle [rad]
    per actuated joint in the order of the URDF's <joint> elements. The files do not say their
    quaternion order, and the two shipped with Roban S14 differ: the new-year dance is xyzw,
    the prone get-up wxyz (upstream's default). The frame rate is `fps` when given, else read
    from the file name (`…_100fps.csv`). v and a are finite differences of the configurations.

    Contacts are not in the file; they are guessed: in each frame a foot is in contact when
    the lowest corner of its sole is within SOLE_CONTACT_BAND_M (1 cm) of the lowest sole
    corner of both feet. Both feet are thus never in the air at once, even in a jump, and a
    foot resting on something is taken as "in contact" only if it is about as low as the other.
    """
    path = Path(path)
    if quaternion_order not in ("wxyz", "xyzw"):
        raise MotionFileError(f"quaternion order {quaternion_order!r}: use 'wxyz' or 'xyzw'")
    if fps is None:
        found = _FPS_IN_NAME.search(path.stem)
        if found is None:
            raise MotionFileError(
                f"{path.name}: the frame rate is not in the file name (like …_100fps.csv); "
                "give it (fps=…)"
            )
        fps = float(found[1])
    if not (math.isfinite(fps) and fps > 0.0):
        raise MotionFileError(f"{path.name}: frame rate {fps:g} fps; it must be positive")
    if not robot.floating_base:
        raise MotionFileError(
            f"{path.name}: a Roban motion moves a floating base, robot {robot.name!r} is fixed"
        )
    if robot.passive_joints:
        raise MotionFileError(
            f"{path.name}: a Roban motion has no columns for the passive loop joints of robot "
            f"{robot.name!r} ({', '.join(robot.passive_joints)})"
        )
    actuated = {j.name: j for j in robot.joints}
    urdf_order = [actuated[name] for name in robot.tree.joints if name in actuated]
    width = 7 + len(urdf_order)

    file, _, source = motion_text.open_motion(path)
    with file:
        table = list(motion_text.csv_rows(file, path.name))
    values = np.empty((len(table), width))
    for k, (line, cells) in enumerate(table):
        if len(cells) != width:
            raise MotionFileError(
                f"{source}, line {line}: {len(cells)} values; robot {robot.name!r} needs "
                f"{width} (3 position + 4 quaternion + {len(urdf_order)} joint angles)"
            )
        for column, cell in enumerate(cells):
            values[k, column] = motion_text.cell_number(
                cell, line, column + 1, f"column {column + 1}", source
            )
    if len(values) < 2:
        raise MotionFileError(f"{source}: {len(values)} frame(s); a motion needs at least 2")
    lines = [line for line, _ in table]

    quats = values[:, 3:7] if quaternion_order == "xyzw" else wxyz_to_xyzw(values[:, 3:7])
    q = np.tile(robot.q_neutral, (len(values), 1))
    q[:, :3] = values[:, :3]
    q[:, 3:7] = motion_text.normalised(quats, lines, source)
    for column, joint in enumerate(urdf_order, start=7):
        if joint.kind == "continuous":
            q[:, joint.idx_q] = np.cos(values[:, column])
            q[:, joint.idx_q + 1] = np.sin(values[:, column])
        else:
            q[:, joint.idx_q] = values[:, column]
    contacts = sole_contacts(robot, q)
    trajectory = from_configurations(
        robot.model, path.stem, robot.joint_names, 1.0 / fps, q, contacts
    )
    return motion_text.checked(robot, trajectory, source)


def sole_contacts(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    """(T, 2) bool: feet whose lowest sole corner is within 1 cm of the lowest of both feet."""
    data = robot.model.createData()
    heights = np.empty((len(q), 2))
    for k, q_k in enumerate(q):
        pin.framesForwardKinematics(robot.model, data, q_k)
        for side, foot in enumerate(robot.feet):
            T_world_foot = data.oMf[robot.link_frame_ids[foot.link]]
            corners_world = T_world_foot.rotation @ foot.sole_corners_m.T
            heights[k, side] = corners_world[2].min() + T_world_foot.translation[2]
    return heights <= heights.min(axis=1, keepdims=True) + SOLE_CONTACT_BAND_M
