"""Builder of `hybrid_leg_biped`: two hybrid legs of Che et al. (Actuators 2022) on a pelvis.

Each leg has five motors (paper §2.1): hip roll q1, hip yaw q2 and hip pitch q3 at the hip,
the knee q4 that distorts the four-bar ABCD, and the ankle q5 that drives the foot through
the four-bar EGHI. The reconstruction follows the authors' inverse kinematics (paper §2.3.4
and §2.3.5, eqs. 27, 28 and 32, and their public code):

- q3 = pi - angle DAF - q30: the hip-pitch motor at A turns the link AD (F is straight down);
- q4 = angle ADC - q40: the knee motor at D, carried by AD, turns the rod DC;
- shin = rigid triangle BCE plus the point G on the line EC, |EG| from E;
- thigh AB (leaf spring, rigid) pivots at A on AD, and at B on the shin;
- q5 = angle EGH - q50: the ankle motor at G, on the shin, turns the crank GH (here the zero of
  `ankle` is the flat foot: paper q5 = ankle + ankle_to_paper_q5_offset_rad());
- the rod HI pins to the foot at I; the foot pivots at E; the sole line runs through I and J,
  with J |EJ| straight below E and |IJ| behind J.

Each four-bar is cut at one revolute joint (B for ABCD, I for EGHI) and closed by a
`<loop_closure>` between two massless links fixed to the two sides of the cut.

The reference configuration (all joints zero) uses q30 and q40 of DESIGN.md; the foot is flat
there, which puts angle EGH at 75.62 deg rather than the listed q50 = 74.1 deg (see README).
Frames: REP 103 (x forward, y left, z up); the leg plane is x-z. Lengths in metres.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robots.urdf_writer import Joint, Link, LoopClosure, Shape, write_urdf

ROBOT_NAME = "hybrid_leg_biped"

# Link lengths [m]: the authors' public code (github.com/Gabriel-cjj/Biped_rbt), via DESIGN.md.
AO_m = 0.1545
AD_m = 0.150
CD_m = 0.42202
AB_m = 0.560921
BC_m = 0.176009
BE_m = 0.549313
CE_m = 0.42661
EG_m = 0.32682
HI_m = 0.309991
GH_m = 0.065
IJ_m = 0.085
EJ_m = 0.040
# Fixed angles of the zero pose (DESIGN.md): q30 = pi - angle DAF, q40 = angle ADC, q50 = EGH.
Q30_rad = math.radians(151.92)
Q40_rad = math.radians(126.85)
Q50_PAPER_rad = math.radians(74.1)  # only for the paper's q5; the zero pose has the foot flat
BODY_WIDTH_m = 0.405  # between the two hip centres O (authors' code, kBodyWidth)
HIP_BEHIND_BODY_m = 0.112  # hip centres O behind the body frame (authors' code, kBodyLong)
SNAP_m = 1e-6  # the writer prints 6 significant digits: points snap to a micrometre grid

# Assumed (the paper gives no masses): the first prototype "weighed nearly 60 kg" (§4.1).
PELVIS_MASS_kg = 28.0
LINK_MASS_kg = {
    "hip_roll_link": 3.0,  # carries the hip-yaw motor
    "hip_yaw_link": 3.0,  # O to A, carries the hip-pitch motor
    "hip_pitch_link": 3.2,  # link AD, carries the knee motor at D
    "knee_rod_dc": 0.8,
    "thigh_ab": 0.8,
    "shin": 3.5,  # carbon tube B-E, carries the ankle motor at G
    "ankle_crank_gh": 0.15,
    "ankle_rod_hi": 0.3,
    "foot": 1.0,
}
FOOT_LENGTH_m, FOOT_WIDTH_m, FOOT_THICKNESS_m = 0.24, 0.10, 0.03  # assumed; heel at I
# Assumed limits [rad] and motor ratings (the paper gives none): effort [N·m], velocity [rad/s].
ACTUATED_LIMITS_rad = {
    "hip_roll": (-0.5, 0.5),
    "hip_yaw": (-0.5, 0.5),
    "hip_pitch": (-1.0, 1.0),
    "knee": (-0.9, 0.6),  # ABCD is non-Grashof; the transmission angle at B stays above 20 deg
    "ankle": (-0.8, 0.8),  # EGHI is a crank-rocker; the foot stays on one branch
}
MOTOR_EFFORT_Nm, MOTOR_VELOCITY_rad_s = 120.0, 3.0
PASSIVE_VELOCITY_rad_s = 20.0

Y_AXIS = (0.0, 1.0, 0.0)
MINUS_Y_AXIS = (0.0, -1.0, 0.0)


def _circle_intersection(p, r_p: float, q, r_q: float, side: int) -> np.ndarray:
    """Point at r_p from p and r_q from q in the x-z plane; side=+1 is left of p->q (x fwd, z up)."""
    d = q - p
    dist = float(np.hypot(*d))
    along = (r_p**2 - r_q**2 + dist**2) / (2.0 * dist)
    height = math.sqrt(r_p**2 - along**2)
    u = d / dist
    return p + along * u + side * height * np.array([-u[1], u[0]])


def _rotate(v, angle_rad: float) -> np.ndarray:
    """v turned counter-clockwise in the x-z plane seen from the right (about -y in REP 103)."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def reference_points_m() -> dict[str, np.ndarray]:
    """Leg points at q = 0, (x forward, z up) [m] relative to the hip centre O, snapped to SNAP_m.

    ABCD is the convex quadrilateral A-B-C-D with C behind and below D; the shin triangle has
    BC between BA and BE (the branches of the authors' code); H is the branch with GI between
    GE and GH, as in their angle EGH = EGI + HGI.
    """
    a = np.array([0.0, -AO_m])
    angle_daf = math.pi - Q30_rad
    d = a + AD_m * np.array([math.sin(angle_daf), -math.cos(angle_daf)])
    c = d + CD_m * _rotate((a - d) / AD_m, Q40_rad)
    b = _circle_intersection(a, AB_m, c, BC_m, side=-1)
    e = _circle_intersection(b, BE_m, c, CE_m, side=-1)
    g = e + EG_m * (c - e) / CE_m
    i = e + np.array([-IJ_m, -EJ_m])  # foot flat: J below E, I behind J on the sole line
    h = _circle_intersection(g, GH_m, i, HI_m, side=-1)
    points = {"O": np.zeros(2), "A": a, "B": b, "C": c, "D": d, "E": e, "G": g, "H": h, "I": i}
    return {name: np.round(p / SNAP_m) * SNAP_m for name, p in points.items()}


def ankle_to_paper_q5_offset_rad() -> float:
    """Paper q5 minus the URDF `ankle` angle [rad]: angle EGH at q = 0 minus q50 (about 1.52 deg)."""
    p = reference_points_m()
    u, v = p["E"] - p["G"], p["H"] - p["G"]
    angle_egh_rad = math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))
    return angle_egh_rad - Q50_PAPER_rad


def _offset(points: dict[str, np.ndarray], start: str, end: str) -> tuple[float, float, float]:
    """Joint origin xyz [m] from point start to point end, in the (world-aligned) parent frame."""
    dx, dz = np.round((points[end] - points[start]) / SNAP_m) * SNAP_m
    return (float(dx), 0.0, float(dz))


def _bar(
    points,
    start: str,
    end: str,
    width_m: float,
    height_m: float,
    y_m: float,
    rgba,
    trim_end_m: float = 0.0,
) -> Shape:
    """Box from point start to point end (less trim_end_m at the end), in the frame of the link
    whose origin is at start. The trim keeps a rod that ends at the sole line above the ground."""
    dx, _, dz = _offset(points, start, end)
    length_m = math.hypot(dx, dz) - trim_end_m
    unit = np.array([dx, dz]) / math.hypot(dx, dz)
    cx, cz = unit * length_m / 2
    pitch_rad = math.atan2(-dz, dx)  # turns the box's x axis onto (dx, 0, dz)
    return Shape(
        "box", (length_m, width_m, height_m), (float(cx), y_m, float(cz)), (0, pitch_rad, 0), rgba
    )


def _motor(xyz, radius_m: float, length_m: float, axis: str) -> Shape:
    """A motor drawn as a cylinder along the given axis ("x", "y" or "z")."""
    rpy = {"x": (0.0, math.pi / 2, 0.0), "y": (math.pi / 2, 0.0, 0.0), "z": (0.0, 0.0, 0.0)}[axis]
    return Shape("cylinder", (radius_m, length_m), tuple(xyz), rpy, (0.25, 0.25, 0.3, 1.0))


LOOP_FRAMES = ("knee_loop_thigh_b", "knee_loop_shin_b", "ankle_loop_rod_i", "ankle_loop_foot_i")
SOLE_FROM_E_m = (FOOT_LENGTH_m / 2 - IJ_m, 0.0, -EJ_m)  # centre of the sole's bottom face
# One leg's joints: name, parent, child, origin (from point, to point) or xyz [m], axis. Motors
# are the names in ACTUATED_LIMITS_rad, axis None is fixed, the others are passive. Axis signs:
# +q3 lowers angle DAF (eq. 27) and +q5 opens angle EGH (eq. 32), clockwise seen from the right
# (+y); +q4 opens angle ADC (eq. 28), counter-clockwise about D (-y).
LEG_JOINTS = (
    ("hip_roll", "pelvis", "hip_roll_link", ("O", "O"), (1.0, 0.0, 0.0)),
    ("hip_yaw", "hip_roll_link", "hip_yaw_link", ("O", "O"), (0.0, 0.0, 1.0)),
    ("hip_pitch", "hip_yaw_link", "hip_pitch_link", ("O", "A"), Y_AXIS),
    ("knee", "hip_pitch_link", "knee_rod_dc", ("A", "D"), MINUS_Y_AXIS),
    ("shin_c", "knee_rod_dc", "shin", ("D", "C"), Y_AXIS),
    ("thigh_a", "hip_pitch_link", "thigh_ab", ("A", "A"), Y_AXIS),
    ("knee_loop_thigh_b_fixed", "thigh_ab", "knee_loop_thigh_b", ("A", "B"), None),
    ("knee_loop_shin_b_fixed", "shin", "knee_loop_shin_b", ("C", "B"), None),
    ("ankle", "shin", "ankle_crank_gh", ("C", "G"), Y_AXIS),
    ("ankle_rod_h", "ankle_crank_gh", "ankle_rod_hi", ("G", "H"), Y_AXIS),
    ("foot_e", "shin", "foot", ("C", "E"), Y_AXIS),
    ("ankle_loop_rod_i_fixed", "ankle_rod_hi", "ankle_loop_rod_i", ("H", "I"), None),
    ("ankle_loop_foot_i_fixed", "foot", "ankle_loop_foot_i", ("E", "I"), None),
    ("sole_fixed", "foot", "sole", SOLE_FROM_E_m, None),
)


def _leg_links(side: str, points: dict[str, np.ndarray]) -> list[Link]:
    """The leg's bodies (masses of LINK_MASS_kg) and its massless sole and loop frames.

    Link frames sit on their parent joint and are world-aligned at q = 0. Rods are drawn
    beside the leg plane (y offsets) so that they do not hide each other.
    """
    out = 1.0 if side == "left" else -1.0  # +y is outboard on the left leg
    metal, rod, dark = (0.7, 0.7, 0.75, 1.0), (0.85, 0.5, 0.2, 1.0), (0.2, 0.2, 0.2, 1.0)
    sole_x_m, bracket_m = SOLE_FROM_E_m[0], EJ_m - FOOT_THICKNESS_m
    shapes = {
        "hip_roll_link": [_motor((0, 0, -0.02), 0.055, 0.08, "z")],
        "hip_yaw_link": [
            Shape("box", (0.06, 0.08, AO_m), (0, 0, -AO_m / 2), rgba=metal),
            _motor((0, 0, -AO_m), 0.06, 0.08, "y"),
        ],
        "hip_pitch_link": [
            _bar(points, "A", "D", 0.05, 0.03, 0.0, metal),
            _motor(_offset(points, "A", "D"), 0.055, 0.08, "y"),
        ],
        "knee_rod_dc": [_bar(points, "D", "C", 0.02, 0.025, -0.05 * out, rod)],
        "thigh_ab": [_bar(points, "A", "B", 0.03, 0.02, 0.05 * out, metal)],
        "shin": [
            _bar(points, "C", "B", 0.04, 0.04, 0.0, metal),
            _bar(points, "C", "E", 0.04, 0.04, 0.0, dark),
            _motor(_offset(points, "C", "G"), 0.045, 0.07, "y"),
        ],
        "ankle_crank_gh": [_bar(points, "G", "H", 0.02, 0.015, -0.04 * out, rod)],
        "ankle_rod_hi": [_bar(points, "H", "I", 0.015, 0.015, -0.04 * out, rod, trim_end_m=0.012)],
        "foot": [
            Shape("box", (FOOT_LENGTH_m, FOOT_WIDTH_m, FOOT_THICKNESS_m),
                  (sole_x_m, 0, FOOT_THICKNESS_m / 2 - EJ_m), rgba=dark),
            Shape("box", (0.04, 0.04, bracket_m), (0, 0, -bracket_m / 2), rgba=dark),
        ],
    }  # fmt: skip
    links = [Link(f"{side}_{key}", LINK_MASS_kg[key], s) for key, s in shapes.items()]
    return links + [Link(f"{side}_{key}", 0.0) for key in ("sole", *LOOP_FRAMES)]


def _leg_joints(side: str, points: dict[str, np.ndarray]) -> list[Joint]:
    """The leg's joints of LEG_JOINTS; the hip centre O is beside and behind the pelvis frame."""
    hip_y_m = (1.0 if side == "left" else -1.0) * BODY_WIDTH_m / 2
    joints = []
    for name, parent, child, origin, axis in LEG_JOINTS:
        xyz = _offset(points, *origin) if isinstance(origin[0], str) else origin
        parent = parent if parent == "pelvis" else f"{side}_{parent}"
        if parent == "pelvis":
            xyz = (-HIP_BEHIND_BODY_m, hip_y_m, 0.0)
        joint_axis = axis or Y_AXIS
        if axis is None:
            joints.append(Joint(f"{side}_{name}", parent, f"{side}_{child}", "fixed", xyz=xyz))
        elif name in ACTUATED_LIMITS_rad:
            lower, upper = ACTUATED_LIMITS_rad[name]
            joints.append(
                Joint(f"{side}_{name}", parent, f"{side}_{child}", lower=lower, upper=upper,
                      effort_Nm=MOTOR_EFFORT_Nm, velocity_rad_s=MOTOR_VELOCITY_rad_s, xyz=xyz, axis=joint_axis)
            )  # fmt: skip
        else:
            joints.append(
                Joint(f"{side}_{name}", parent, f"{side}_{child}", lower=-math.pi, upper=math.pi,
                      velocity_rad_s=PASSIVE_VELOCITY_rad_s, xyz=xyz, axis=joint_axis)
            )  # fmt: skip
    return joints


def _leg_loops(side: str) -> list[LoopClosure]:
    """The two loop closures: ABCD cut at the knee pin B, EGHI cut at the heel pin I."""
    return [
        LoopClosure(f"{side}_knee_loop", f"{side}_knee_loop_thigh_b", f"{side}_knee_loop_shin_b",
                    (f"{side}_thigh_a", f"{side}_shin_c")),
        LoopClosure(f"{side}_ankle_loop", f"{side}_ankle_loop_rod_i",
                    f"{side}_ankle_loop_foot_i", (f"{side}_ankle_rod_h", f"{side}_foot_e")),
    ]  # fmt: skip


def build_urdf() -> str:
    """URDF text of the robot: pelvis (floating base) and two hybrid legs with four loops."""
    points = reference_points_m()
    pelvis = Link(
        "pelvis",
        PELVIS_MASS_kg,
        [
            Shape("box", (0.30, 0.50, 0.22), (0.0, 0.0, 0.17), rgba=(0.3, 0.45, 0.7, 1.0)),
            _motor((-HIP_BEHIND_BODY_m, BODY_WIDTH_m / 2, 0.0), 0.06, 0.12, "x"),
            _motor((-HIP_BEHIND_BODY_m, -BODY_WIDTH_m / 2, 0.0), 0.06, 0.12, "x"),
        ],
    )
    links, joints, loops = [pelvis], [], []
    for side in ("left", "right"):
        links += _leg_links(side, points)
        joints += _leg_joints(side, points)
        loops += _leg_loops(side)
    comment = (
        "Generated by robots/hybrid_leg_biped/build.py from Che et al., Actuators 2022 "
        "(hybrid leg) and the authors' link lengths; do not edit by hand."
    )
    return write_urdf(ROBOT_NAME, links, joints, loops, comment=comment)


if __name__ == "__main__":
    out_path = Path(__file__).with_name(f"{ROBOT_NAME}.urdf")
    out_path.write_text(build_urdf())
    print(f"wrote {out_path}")
