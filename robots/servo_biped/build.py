"""Parametric builder of `servo_biped`, a Roban-like servo humanoid (the studio's default robot).

Numbers from the spring-compensation paper (Wang et al. 2023, Table 1: 6.6 kg, 0.70 m, 6 DOF per
leg) and the public Roban leg dimensions (DESIGN.md, "Numbers from the papers"). Everything else
(mass split, servo ranges and torques, foot plate, upper-body shapes) is an assumption documented
in README.md. Only the 12 leg joints move; torso, head and arms are fixed to the pelvis.

Frames: REP 103 (x forward, y left, z up). At q = 0 the legs are straight and vertical and the
soles flat. Regenerate with `python -m robots.build`.
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

ROBOT_NAME = "servo_biped"

# Spring-compensation paper, Table 1 ("Specific parameters of Roban robot").
TOTAL_MASS_KG = 6.6
HEIGHT_M = 0.70

# Roban leg dimensions (public, Leju-derived code; DESIGN.md "Numbers from the papers").
HIP_HALF_WIDTH_M = 0.0466
"""Lateral offset of each hip joint from the pelvis centre plane [m]."""
THIGH_LENGTH_M = 0.1028
"""Hip pitch axis to knee axis [m]."""
SHANK_LENGTH_M = 0.129
"""Knee axis to ankle pitch axis [m]."""
ANKLE_HEIGHT_M = 0.035
"""Ankle axes above the sole [m]."""

# Assumptions (README.md, "Assumptions").
HIP_YAW_DROP_M = 0.045
"""Hip yaw joint (in the pelvis) above the crossing of the hip roll and pitch axes [m]."""
SOLE_LENGTH_M, SOLE_WIDTH_M, SOLE_THICKNESS_M = 0.14, 0.08, 0.008
"""The sole plate (foot size): `build_urdf` takes its length and width (the sweeps' foot size);
the defaults are these."""
PELVIS_HEIGHT_M = 0.04
NECK_LENGTH_M = 0.02
HEAD_RADIUS_M = 0.069
SERVO_EFFORT_NM = 6.0
SERVO_VELOCITY_RAD_S = 6.0

UPPER_BODY_MASS_KG = {"base": 0.6, "torso": 1.4, "head": 0.3, "arm": 0.35}
"""Pelvis (floating base), chest, head and each arm [kg]: 3.0 kg with both arms."""
LEG_LINK_MASS_KG = {
    "hip_yaw_link": 0.20,
    "hip_roll_link": 0.30,
    "thigh": 0.40,
    "shank": 0.40,
    "ankle_link": 0.20,
    "foot": 0.30,
}
"""Each leg's links [kg]: 1.8 kg per leg, so 3.0 + 2 x 1.8 = 6.6 kg (Table 1)."""

# Leg joints from the pelvis (Table 2's servo numbering 1-6 / 7-12 follows this order):
# name, child link, axis, lower [rad], upper [rad] for the LEFT leg. Signs: positive hip roll
# moves the left foot outward (abduction); positive hip pitch swings the leg backward; positive
# knee flexes it (shank backward). Table 2's standing pose (hip -37.9°, knee 68.7°,
# ankle -30.8°, summing to 0 for a flat foot) fits these signs.
LEFT_LEG_JOINTS = (
    ("hip_yaw", "hip_yaw_link", (0.0, 0.0, 1.0), -0.8, 0.8),
    ("hip_roll", "hip_roll_link", (1.0, 0.0, 0.0), -0.4, 0.8),
    ("hip_pitch", "thigh", (0.0, 1.0, 0.0), -1.6, 0.6),
    ("knee", "shank", (0.0, 1.0, 0.0), 0.0, 2.3),
    ("ankle_pitch", "ankle_link", (0.0, 1.0, 0.0), -1.0, 1.0),
    ("ankle_roll", "foot", (1.0, 0.0, 0.0), -0.5, 0.5),
)

SERVO_GREY = (0.22, 0.22, 0.25, 1.0)
BRACKET_GREY = (0.78, 0.79, 0.81, 1.0)
ACCENT = (0.95, 0.45, 0.10, 1.0)


def _leg_shapes(
    sole_length_m: float = SOLE_LENGTH_M, sole_width_m: float = SOLE_WIDTH_M
) -> dict[str, list[Shape]]:
    """Shapes of one leg's links in their link frames (centred on the leg axis, so both legs share them)."""
    servo = (0.035, 0.045, 0.03)
    return {
        "hip_yaw_link": [
            Shape("cylinder", (0.02, 0.008), (0.0, 0.0, -0.004), rgba=SERVO_GREY),
            Shape("box", (0.045, 0.035, 0.03), (0.0, 0.0, -0.024), rgba=BRACKET_GREY),
        ],
        "hip_roll_link": [
            Shape("box", (0.05, 0.045, 0.04), (0.0, 0.0, 0.0), rgba=SERVO_GREY),
            Shape("cylinder", (0.012, 0.05), (0.0, 0.0, 0.0), (math.pi / 2, 0.0, 0.0), ACCENT),
        ],
        "thigh": [
            Shape("box", (0.04, 0.04, 0.07), (0.0, 0.0, -0.05), rgba=BRACKET_GREY),
            Shape("box", servo, (0.0, 0.0, -THIGH_LENGTH_M + 0.012), rgba=SERVO_GREY),
        ],
        "shank": [
            Shape("box", (0.04, 0.04, 0.09), (0.0, 0.0, -0.065), rgba=BRACKET_GREY),
            Shape("box", servo, (0.0, 0.0, -SHANK_LENGTH_M + 0.014), rgba=SERVO_GREY),
        ],
        "ankle_link": [
            Shape("box", (0.04, 0.035, 0.02), (0.0, 0.0, 0.0), rgba=SERVO_GREY),
        ],
        "foot": [
            Shape("box", (0.03, 0.04, ANKLE_HEIGHT_M - SOLE_THICKNESS_M - 0.01),
                  (0.0, 0.0, -0.5 * (ANKLE_HEIGHT_M - SOLE_THICKNESS_M + 0.01)), rgba=BRACKET_GREY),
            Shape("box", (sole_length_m, sole_width_m, SOLE_THICKNESS_M),
                  (0.0, 0.0, -ANKLE_HEIGHT_M + 0.5 * SOLE_THICKNESS_M), rgba=ACCENT),
        ],
    }  # fmt: skip


def _leg(
    side_name: str, sole_length_m: float = SOLE_LENGTH_M, sole_width_m: float = SOLE_WIDTH_M
) -> tuple[list[Link], list[Joint]]:
    """Links and joints of one leg, from the pelvis down to the sole frame."""
    side = 1.0 if side_name == "left" else -1.0
    shapes = _leg_shapes(sole_length_m, sole_width_m)
    origins = {
        "hip_yaw": (0.0, side * HIP_HALF_WIDTH_M, 0.0),
        "hip_roll": (0.0, 0.0, -HIP_YAW_DROP_M),
        "hip_pitch": (0.0, 0.0, 0.0),
        "knee": (0.0, 0.0, -THIGH_LENGTH_M),
        "ankle_pitch": (0.0, 0.0, -SHANK_LENGTH_M),
        "ankle_roll": (0.0, 0.0, 0.0),
    }
    return serial_chain(
        side_name,
        "base",
        (
            (joint, link, axis, lower, upper, SERVO_EFFORT_NM)
            for joint, link, axis, lower, upper in LEFT_LEG_JOINTS
        ),
        origins=origins,
        link_masses_kg=LEG_LINK_MASS_KG,
        link_shapes=shapes,
        velocity_rad_s=SERVO_VELOCITY_RAD_S,
        sole_drop_m=ANKLE_HEIGHT_M,
    )


def _upper_body() -> tuple[list[Link], list[Joint]]:
    """Pelvis (floating base, origin between the hip yaw joints), chest, head and fixed arms."""
    pelvis_z_m = ANKLE_HEIGHT_M + SHANK_LENGTH_M + THIGH_LENGTH_M + HIP_YAW_DROP_M
    chest_bottom_m = pelvis_z_m + PELVIS_HEIGHT_M
    chest_height_m = HEIGHT_M - 2.0 * HEAD_RADIUS_M - NECK_LENGTH_M - chest_bottom_m
    chest_size = (0.10, 0.15, chest_height_m)
    shoulder_y_m = 0.5 * chest_size[1] + 0.03
    mass = UPPER_BODY_MASS_KG
    links = [
        Link("base", mass["base"], [
            Shape("box", (0.08, 0.14, PELVIS_HEIGHT_M), (0.0, 0.0, 0.5 * PELVIS_HEIGHT_M),
                  rgba=SERVO_GREY),
        ]),
        Link("torso", mass["torso"], [
            Shape("box", chest_size, (0.0, 0.0, 0.5 * chest_height_m), rgba=BRACKET_GREY),
            Shape("box", (0.006, 0.09, 0.08), (0.053, 0.0, 0.6 * chest_height_m), rgba=ACCENT),
        ]),
        Link("head", mass["head"], [
            Shape("cylinder", (0.02, NECK_LENGTH_M), (0.0, 0.0, 0.5 * NECK_LENGTH_M),
                  rgba=SERVO_GREY),
            Shape("sphere", (HEAD_RADIUS_M,), (0.0, 0.0, NECK_LENGTH_M + HEAD_RADIUS_M),
                  rgba=BRACKET_GREY),
            Shape("box", (0.02, 0.08, 0.03), (0.06, 0.0, NECK_LENGTH_M + HEAD_RADIUS_M),
                  rgba=ACCENT),
        ]),
    ]  # fmt: skip
    joints = [
        Joint("torso_fixed", "base", "torso", kind="fixed", xyz=(0.0, 0.0, PELVIS_HEIGHT_M)),
        Joint("head_fixed", "torso", "head", kind="fixed", xyz=(0.0, 0.0, chest_height_m)),
    ]
    for side_name, side in (("left", 1.0), ("right", -1.0)):
        links.append(
            Link(f"{side_name}_arm", mass["arm"], [
                Shape("box", (0.04, 0.04, 0.04), (0.0, 0.0, 0.0), rgba=SERVO_GREY),
                Shape("box", (0.035, 0.03, 0.09), (0.0, 0.0, -0.065), rgba=BRACKET_GREY),
                Shape("box", (0.03, 0.03, 0.08), (0.0, 0.0, -0.15), rgba=BRACKET_GREY),
                Shape("sphere", (0.018,), (0.0, 0.0, -0.2), rgba=ACCENT),
            ])
        )  # fmt: skip
        joints.append(
            Joint(f"{side_name}_shoulder_fixed", "torso", f"{side_name}_arm", kind="fixed",
                  xyz=(0.0, side * shoulder_y_m, chest_height_m - 0.025))
        )  # fmt: skip
    return links, joints


def build_urdf(sole_length_m: float = SOLE_LENGTH_M, sole_width_m: float = SOLE_WIDTH_M) -> str:
    """URDF text of servo_biped: pelvis, fixed upper body, two 6-DOF legs, sole frames.

    `sole_length_m` × `sole_width_m`: the sole plates (visual and collision boxes, centred under
    the ankle), so the support polygon and the planner's heel and toe follow; each foot's mass
    stays, shared among its shapes by volume as always. The defaults build the robot of the
    papers' numbers (the committed URDF)."""
    upper_links, upper_joints = _upper_body()
    leg = functools.partial(_leg, sole_length_m=sole_length_m, sole_width_m=sole_width_m)
    leg_links, leg_joints = both_legs(leg)
    links, joints = upper_links + leg_links, upper_joints + leg_joints
    check_total_mass(links, TOTAL_MASS_KG, "Table 1")
    comment = (
        "Generated by robots/servo_biped/build.py (python -m robots.build); do not edit. "
        "Roban-like servo humanoid: 6.6 kg, 0.70 m, 12 leg DOF; see README.md."
    )
    return write_urdf(ROBOT_NAME, links, joints, comment=comment)
