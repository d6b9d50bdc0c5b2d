"""Parametric builder of `dircon_biped`, the 10-DOF biped of the symmetric-gait paper.

Numbers from Chen et al. 2023 (symmetric-gait paper), section 4: 13 links (one baselink, two
hip roll links, two hip yaw links, two hip pitch links, two thighs, two shanks, two feet), two
fixed joints between the hip roll links and the baselink, ten revolute joints; Table 1 (joint
ranges), Table 2 (link masses), rated torques 13.0 N·m (ankle 38.7 N·m), joint speed limit
6.28 rad/s (section 5.1), height 1.211 m, width 275 mm and feet 190 x 75 mm (Figure 2).
Segment lengths and shapes are assumptions documented in README.md.

Reading of the chain (README.md, "Kinematic chain"): the "hip roll link" is the bracket that
carries the hip roll motor and is bolted to the baselink (Table 1, "Baselink-Hip roll: Fixed");
hip roll joint (1, 2) turns the hip yaw link about x, hip yaw joint (3, 4) turns the hip pitch
link about z, hip pitch joint (5, 6) turns the thigh about y, then knee and ankle about y.

Frames: REP 103. At q = 0 the legs are straight and vertical and the soles flat on z = 0 when
the base origin is at BASE_ORIGIN_HEIGHT_M. Regenerate with `python -m robots.build`.
"""

from __future__ import annotations

import functools
import math

from robots.urdf_writer import (
    Joint,
    Link,
    Shape,
    both_legs,
    check_total_mass,
    serial_chain,
    write_urdf,
)

ROBOT_NAME = "dircon_biped"

# Section 4 and Figure 2.
HEIGHT_M = 1.211
"""Top of the baselink above the ground at q = 0 [m] (section 4: "actual height of 1.211 m")."""
WIDTH_M = 0.275
"""Overall width (Figure 2 caption) [m]: the baselink's width and the feet's outer edges."""
DEPTH_M = 0.405
"""Second dimension of the overall size 1.2 x 0.405 x 0.275 m (section 4) [m], read as the
baselink's front-to-back depth since the width is 0.275 m (Figure 2)."""
FOOT_LENGTH_M, FOOT_WIDTH_M = 0.190, 0.075
"""Flat foot of Figure 2 [m]."""

# Table 2 (Mass Distribution) [kg]; the leg entries are per leg.
BASE_MASS_KG = 7.624
LEG_LINK_MASS_KG = {
    "hip_roll_link": 0.922,
    "hip_yaw_link": 0.776,
    "hip_pitch_link": 0.743,
    "thigh": 1.116,
    "shank": 1.597,
    "foot": 0.300,
}
TOTAL_MASS_KG = 18.532

# Section 4 (rated torques) and section 5.1 (joint speed bound) [N·m], [rad/s].
RATED_TORQUE_NM = 13.0
ANKLE_RATED_TORQUE_NM = 38.7
VELOCITY_LIMIT_RAD_S = 6.28

# Table 1 (Joint Range) [deg], the left leg; the right leg is mirrored through the x-z plane
# (robots.urdf_writer.mirrored_limits: ranges about x and z change sign and swap ends).
# Hip roll −15…95 is read as 95° of abduction: positive roll about +x moves the left foot to +y,
# and the right hip roll gets [−95°, 15°] about +x, so both legs abduct up to 95° outward.
LEFT_LEG_JOINTS = (
    # joint, child link, axis, range [deg], rated torque [N·m]
    ("hip_roll", "hip_yaw_link", (1.0, 0.0, 0.0), (-15.0, 95.0), RATED_TORQUE_NM),
    ("hip_yaw", "hip_pitch_link", (0.0, 0.0, 1.0), (-45.0, 45.0), RATED_TORQUE_NM),
    ("hip_pitch", "thigh", (0.0, 1.0, 0.0), (-47.0, 47.0), RATED_TORQUE_NM),
    ("knee", "shank", (0.0, 1.0, 0.0), (-63.0, 63.0), RATED_TORQUE_NM),
    ("ankle_pitch", "foot", (0.0, 1.0, 0.0), (-85.0, 85.0), ANKLE_RATED_TORQUE_NM),
)

# Assumptions (README.md, "Assumptions") [m].
BASE_HEIGHT_M = 0.20
HIP_ROLL_DROP_M = 0.04
"""Baselink bottom to the hip roll axis (the fixed hip roll link)."""
HIP_YAW_DROP_M = 0.06
"""Hip roll axis to the hip yaw joint."""
HIP_PITCH_DROP_M = 0.06
"""Hip yaw joint to the hip pitch axis."""
ANKLE_HEIGHT_M = 0.07
"""Ankle pitch axis above the sole (about 0.039 x 1.85 m, the human ankle height ratio)."""
SOLE_THICKNESS_M = 0.02
HIP_HALF_WIDTH_M = 0.5 * WIDTH_M - 0.5 * FOOT_WIDTH_M
"""Leg axis from the centre plane, so the feet's outer edges span WIDTH_M (0.100 m)."""
LEG_SEGMENT_M = 0.5 * (
    HEIGHT_M - BASE_HEIGHT_M - HIP_ROLL_DROP_M - HIP_YAW_DROP_M - HIP_PITCH_DROP_M - ANKLE_HEIGHT_M
)
"""Thigh = shank length, hip pitch to knee and knee to ankle (0.3905 m): what the height leaves."""
THIGH_LENGTH_M = SHANK_LENGTH_M = LEG_SEGMENT_M
BASE_ORIGIN_HEIGHT_M = HEIGHT_M - BASE_HEIGHT_M
"""Base frame: centre of the baselink's bottom face, where the hip roll links are bolted."""

ALUMINIUM = (0.74, 0.76, 0.79, 1.0)
CARBON = (0.14, 0.14, 0.16, 1.0)
MOTOR = (0.80, 0.16, 0.14, 1.0)
ALONG_X = (0.0, math.pi / 2, 0.0)
ALONG_Y = (math.pi / 2, 0.0, 0.0)


def _leg_shapes(
    foot_length_m: float = FOOT_LENGTH_M, foot_width_m: float = FOOT_WIDTH_M
) -> dict[str, list[Shape]]:
    """Shapes of one leg's links in their frames, centred on the leg axis (both legs share them)."""
    seg = LEG_SEGMENT_M
    bracket_h = ANKLE_HEIGHT_M - SOLE_THICKNESS_M
    return {
        "hip_roll_link": [
            Shape("box", (0.08, 0.07, 0.02), (0.0, 0.0, -0.01), rgba=ALUMINIUM),
            Shape("cylinder", (0.035, 0.08), (0.0, 0.0, -HIP_ROLL_DROP_M), ALONG_X, MOTOR),
        ],
        "hip_yaw_link": [
            Shape("box", (0.05, 0.06, 0.02), (0.0, 0.0, -0.01), rgba=ALUMINIUM),
            Shape("cylinder", (0.035, 0.04), (0.0, 0.0, -HIP_YAW_DROP_M + 0.02), rgba=MOTOR),
        ],
        "hip_pitch_link": [
            Shape("box", (0.05, 0.05, 0.02), (0.0, 0.0, -0.01), rgba=ALUMINIUM),
            Shape("cylinder", (0.035, 0.065), (0.0, 0.0, -HIP_PITCH_DROP_M), ALONG_Y, MOTOR),
        ],
        "thigh": [
            Shape("cylinder", (0.022, seg - 0.07), (0.0, 0.0, -0.5 * seg), rgba=CARBON),
            Shape("cylinder", (0.035, 0.065), (0.0, 0.0, -seg), ALONG_Y, MOTOR),
        ],
        "shank": [
            Shape("cylinder", (0.022, seg - 0.08), (0.0, 0.0, -0.5 * seg), rgba=CARBON),
            Shape("cylinder", (0.045, 0.07), (0.0, 0.0, -seg), ALONG_Y, MOTOR),
        ],
        "foot": [
            Shape("box", (0.05, 0.04, bracket_h - 0.03), (0.0, 0.0, -0.5 * (bracket_h + 0.03)),
                  rgba=ALUMINIUM),
            Shape("box", (foot_length_m, foot_width_m, SOLE_THICKNESS_M),
                  (0.0, 0.0, -ANKLE_HEIGHT_M + 0.5 * SOLE_THICKNESS_M), rgba=CARBON),
        ],
    }  # fmt: skip


def _leg(
    side_name: str, foot_length_m: float = FOOT_LENGTH_M, foot_width_m: float = FOOT_WIDTH_M
) -> tuple[list[Link], list[Joint]]:
    """Links and joints of one leg: fixed hip roll link, five revolute joints, sole frame."""
    side = 1.0 if side_name == "left" else -1.0
    shapes = _leg_shapes(foot_length_m, foot_width_m)
    origins = {
        "hip_roll": (0.0, 0.0, -HIP_ROLL_DROP_M),
        "hip_yaw": (0.0, 0.0, -HIP_YAW_DROP_M),
        "hip_pitch": (0.0, 0.0, -HIP_PITCH_DROP_M),
        "knee": (0.0, 0.0, -THIGH_LENGTH_M),
        "ankle_pitch": (0.0, 0.0, -SHANK_LENGTH_M),
    }
    mount = f"{side_name}_hip_roll_link"
    links = [Link(mount, LEG_LINK_MASS_KG["hip_roll_link"], shapes["hip_roll_link"])]
    joints = [
        Joint(f"{side_name}_hip_roll_mount", "base", mount, kind="fixed",
              xyz=(0.0, side * HIP_HALF_WIDTH_M, 0.0))
    ]  # fmt: skip
    chain_links, chain_joints = serial_chain(
        side_name,
        mount,
        (
            (joint, link, axis, math.radians(lower_deg), math.radians(upper_deg), effort_Nm)
            for joint, link, axis, (lower_deg, upper_deg), effort_Nm in LEFT_LEG_JOINTS
        ),
        origins=origins,
        link_masses_kg=LEG_LINK_MASS_KG,
        link_shapes=shapes,
        velocity_rad_s=VELOCITY_LIMIT_RAD_S,
        sole_drop_m=ANKLE_HEIGHT_M,
    )
    return links + chain_links, joints + chain_joints


def _base() -> Link:
    """Baselink: carbon trunk (full width) with front and back equipment bays at its top."""
    bay_depth_m = 0.25 * DEPTH_M
    bay_height_m = 0.6 * BASE_HEIGHT_M
    bay_x_m = 0.5 * DEPTH_M - 0.5 * bay_depth_m
    bay_z_m = BASE_HEIGHT_M - 0.5 * bay_height_m
    return Link("base", BASE_MASS_KG, [
        Shape("box", (0.5 * DEPTH_M, WIDTH_M, BASE_HEIGHT_M), (0.0, 0.0, 0.5 * BASE_HEIGHT_M),
              rgba=CARBON),
        Shape("box", (bay_depth_m, 0.85 * WIDTH_M, bay_height_m), (bay_x_m, 0.0, bay_z_m),
              rgba=ALUMINIUM),
        Shape("box", (bay_depth_m, 0.85 * WIDTH_M, bay_height_m), (-bay_x_m, 0.0, bay_z_m),
              rgba=ALUMINIUM),
    ])  # fmt: skip


def build_urdf(foot_length_m: float = FOOT_LENGTH_M, foot_width_m: float = FOOT_WIDTH_M) -> str:
    """URDF text of dircon_biped: 13 massive links, 10 revolute joints, 2 fixed hip mounts.

    `foot_length_m` × `foot_width_m`: the sole plates (visual and collision boxes, centred under
    the ankle), so the support polygon and the planner's heel and toe follow; each foot's mass
    stays (shared among its shapes by volume) and the hips stay where Figure 2's feet put them.
    The defaults build Figure 2's robot (the committed URDF)."""
    leg = functools.partial(_leg, foot_length_m=foot_length_m, foot_width_m=foot_width_m)
    leg_links, leg_joints = both_legs(leg)
    links = [_base(), *leg_links]
    check_total_mass(links, TOTAL_MASS_KG, "Table 2")
    comment = (
        "Generated by robots/dircon_biped/build.py (python -m robots.build); do not edit. "
        "10-DOF biped of the symmetric-gait paper (Chen et al. 2023): Tables 1 and 2; see README.md."
    )
    return write_urdf(ROBOT_NAME, links, leg_joints, comment=comment)
