"""Closed-form inverse and forward kinematics of one hybrid leg (Che et al., Actuators 2022).

The paper's geometric IK (§2.3): the hip roll q1 and yaw q2 turn the leg plane, which holds
every joint below the hip; the foot pose fixes that plane (eqs. 4–18 reduce to atan2 of its
normal), then the ankle pin E in the plane gives q3 and q4 through triangles of known sides
(eqs. 27, 28), and the foot pitch gives q5 through the ankle four-bar (eqs. 29–32).

Points and angles follow robots/hybrid_leg_biped (README and build.py): leg-plane coordinates
(x forward, z up) [m] from the hip centre O, the hip-pitch axis A, the four-bar ABCD (ground
AD, crank DC, shin B–C–E, thigh AB) and EGHI (shin EG, crank GH, rod HI, foot EI). Paper and
URDF angles: hip_roll = q1, hip_yaw = q2 (the paper's X and Y axes are REP 103's x and z),
hip_pitch = q3, knee = q4, ankle = q5 − ankle_to_paper_q5_offset_rad() (the zero of `ankle`
is the flat foot). The lengths are those of the generated URDF (points snapped to 1 µm).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.core.errors import StudioError
from robots.hybrid_leg_biped import build

URDF_JOINTS = ("hip_roll", "hip_yaw", "hip_pitch", "knee", "ankle")
"""Actuated joints of one leg (prefix "left_" or "right_"), in the paper's order q1..q5."""
P0 = build.reference_points_m()
"""Leg points (x, z) [m] at q = 0, relative to O."""
SOLE_FROM_E = np.array([build.SOLE_FROM_E_m[0], build.SOLE_FROM_E_m[2]])
"""Sole frame origin (x, z) [m] from E in the foot frame."""
Q5_OFFSET_rad = build.ankle_to_paper_q5_offset_rad()
PLANE_TOL_m = 1e-6


class UnreachableFootPose(StudioError):
    """No leg configuration puts the foot where it was asked."""


def _length(a: str, b: str) -> float:
    return float(np.linalg.norm(P0[a] - P0[b]))


def _direction(v: np.ndarray) -> float:
    """Angle [rad] of a leg-plane vector, counter-clockwise from +x towards +z."""
    return math.atan2(v[1], v[0])


def _turn(v: np.ndarray, angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def _from_below(v: np.ndarray) -> float:
    """Signed angle [rad] of a leg-plane vector from straight down, + towards +x (∠DAF, eq. 27)."""
    return math.atan2(v[0], -v[1])


def _side(a: str, b: str, c: str) -> float:
    """+1 if c is counter-clockwise of a->b at q = 0, else -1 (the assembly branch)."""
    u, v = P0[b] - P0[a], P0[c] - P0[a]
    return 1.0 if u[0] * v[1] - u[1] * v[0] > 0 else -1.0


def _angle(adjacent1: float, adjacent2: float, opposite: float, what: str) -> float:
    """Angle [rad] between two sides of a triangle (law of cosines); raises if it cannot close."""
    cos = (adjacent1**2 + adjacent2**2 - opposite**2) / (2.0 * adjacent1 * adjacent2)
    if not -1.0 <= cos <= 1.0:
        raise UnreachableFootPose(f"out of reach: {what}")
    return math.acos(cos)


def _interior(p: np.ndarray, vertex: np.ndarray, q: np.ndarray) -> float:
    u, v = p - vertex, q - vertex
    return math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))


AB, BE, BC, AD, CD = (_length(*pair) for pair in ("AB", "BE", "BC", "AD", "CD"))
EG, EI, GH, HI = (_length(*pair) for pair in ("EG", "EI", "GH", "HI"))
ANGLE_CBE = _interior(P0["C"], P0["B"], P0["E"])
ANGLE_BEG = _interior(P0["B"], P0["E"], P0["G"])
"""Angle BEC of eq. 29 (G is on EC; measured to G so that 1 µm snapping does not show)."""
# Zero-pose angles of the snapped points: q30 = pi - DAF0, q40 = ADC0 and the flat-foot EGH0
# equal the builder's 151.92 deg, 126.85 deg and q50 + Q5_OFFSET_rad to < 3e-6 rad.
DAF0 = _from_below(P0["D"] - P0["A"])
ADC0 = _interior(P0["A"], P0["D"], P0["C"])
EGH0 = _interior(P0["E"], P0["G"], P0["H"])


@dataclasses.dataclass(frozen=True)
class LegAngles:
    """Actuated angles of one hybrid leg [rad]."""

    paper_rad: np.ndarray
    """q1..q5 in the paper's convention (eqs. 9, 17, 27, 28, 32), shape (5,)."""
    urdf_rad: np.ndarray
    """hip_roll, hip_yaw, hip_pitch, knee, ankle of the URDF, shape (5,)."""

    def joint_values(self, side: str) -> dict[str, float]:
        """{"left_hip_roll": value, ...} for side "left" or "right"."""
        return {f"{side}_{n}": float(v) for n, v in zip(URDF_JOINTS, self.urdf_rad, strict=True)}


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def plane_ik(E: np.ndarray, foot_pitch_rad: float) -> tuple[float, float, float]:
    """(hip_pitch, knee, ankle) [rad] putting the ankle pin E at (x, z) [m] in the leg plane
    with the foot pitched by foot_pitch_rad about the leg's y axis (0 = flat, + = toe down).

    Knee (eqs. 27, 28): triangle ABE gives ∠BAE; the rigid shin gives ∠ABC = ∠ABE − ∠CBE;
    triangle ABC gives AC and ∠BAC; triangle ACD gives ∠CAD and ∠ADC. With ∠BAD = ∠BAC + ∠CAD
    (convex ABCD), q3 = π − ∠DAF − q30 (F below A; ∠DAF signed, + with D ahead of F) and
    q4 = ∠ADC − q40. Ankle (eqs. 29–32): ∠GEI = θ3 + θ4, the angles of EC and EI from the
    backward horizontal; triangle GEI and the crank triangle GHI give ∠EGH = ∠EGI + ∠IGH, and
    q5 = ∠EGH − q50.
    """
    A = P0["A"]
    AE_vec = np.asarray(E, dtype=float) - A
    AE = float(np.linalg.norm(AE_vec))
    reach = (
        f"the ankle pin E would be {AE * 1e3:.1f} mm from the hip-pitch axis A; thigh AB and "
        f"shin BE span {abs(AB - BE) * 1e3:.0f}–{(AB + BE) * 1e3:.0f} mm"
    )
    angle_bae = _angle(AB, AE, BE, reach)
    angle_abc = _angle(AB, BE, AE, reach) - ANGLE_CBE
    AC = math.sqrt(AB**2 + BC**2 - 2 * AB * BC * math.cos(angle_abc))
    knee_what = (
        f"with E {AE * 1e3:.1f} mm from A the knee four-bar needs a diagonal AC of "
        f"{AC * 1e3:.1f} mm; ABCD closes only for {abs(AD - CD) * 1e3:.0f}–{(AD + CD) * 1e3:.0f} mm"
    )
    angle_bad = _angle(AB, AC, BC, knee_what) + _angle(AC, AD, CD, knee_what)
    angle_adc = _angle(AD, CD, AC, knee_what)
    direction_ab = _direction(AE_vec) + _side("A", "E", "B") * angle_bae
    direction_ad = direction_ab + _side("A", "B", "D") * angle_bad
    angle_daf = _from_below(np.array([math.cos(direction_ad), math.sin(direction_ad)]))
    hip_pitch = DAF0 - angle_daf  # eq. 27, q3 = pi - DAF - q30 with q30 = pi - DAF0
    knee = angle_adc - ADC0  # eq. 28, q4 = ADC - q40

    B = A + AB * np.array([math.cos(direction_ab), math.sin(direction_ab)])
    direction_eg = _direction(B - E) + _side("E", "B", "G") * ANGLE_BEG
    I_vec = _turn(P0["I"] - P0["E"], -foot_pitch_rad)
    theta3 = math.atan2(math.sin(direction_eg), -math.cos(direction_eg))  # EG above the -x axis
    theta4 = math.atan2(-I_vec[1], -I_vec[0])  # EI below the -x axis
    angle_gei = theta3 + theta4  # eq. 31
    GI = math.sqrt(EG**2 + EI**2 - 2 * EG * EI * math.cos(angle_gei))
    ankle_what = (
        f"the ankle four-bar EGHI cannot pitch the foot by {math.degrees(foot_pitch_rad):.1f}° "
        f"(angle GEI {math.degrees(angle_gei):.1f}°)"
    )
    angle_egh = _angle(EG, GI, EI, ankle_what) + _angle(GI, GH, HI, ankle_what)
    ankle = angle_egh - EGH0  # eq. 32 from the flat foot; paper q5 = ankle + Q5_OFFSET_rad
    return hip_pitch, knee, ankle


def leg_ik(T_hip_sole: np.ndarray, *, check_limits: bool = True) -> LegAngles:
    """Actuated angles putting the sole frame at T_hip_sole (4x4, in the hip frame: pelvis axes,
    origin at O). The foot's y axis must be the normal of a plane through O (the leg plane):
    q1 and q2 turn e_y onto it, Rx(q1) Rz(q2) e_y = y_foot (eqs. 4–18)."""
    T = np.asarray(T_hip_sole, dtype=float)
    normal = T[:3, 1]
    off_plane_m = float(normal @ T[:3, 3])
    if abs(off_plane_m) > PLANE_TOL_m:
        raise UnreachableFootPose(
            f"out of reach: the sole is {off_plane_m * 1e3:.2f} mm off the plane through the hip "
            "normal to the foot's y axis; a 5-DOF leg cannot roll its foot about the toe"
        )
    hip_yaw = math.asin(float(np.clip(-normal[0], -1.0, 1.0)))
    hip_roll = math.atan2(normal[2], normal[1])
    R_leg = _rot_x(hip_roll) @ _rot_z(hip_yaw)
    R_leg_foot = R_leg.T @ T[:3, :3]
    foot_pitch = math.atan2(R_leg_foot[0, 2], R_leg_foot[0, 0])
    sole = (R_leg.T @ T[:3, 3])[[0, 2]]
    E = sole - _turn(SOLE_FROM_E, -foot_pitch)
    angles = np.array([hip_roll, hip_yaw, *plane_ik(E, foot_pitch)])
    if check_limits:
        for name, value in zip(URDF_JOINTS, angles, strict=True):
            lower, upper = build.ACTUATED_LIMITS_rad[name]
            if not lower <= value <= upper:
                raise UnreachableFootPose(
                    f"out of reach: {name} would be {value:.3f} rad, outside {lower}…{upper} rad"
                )
    paper = angles.copy()
    paper[4] += Q5_OFFSET_rad
    return LegAngles(paper, angles)


def _circle(p: np.ndarray, r_p: float, q: np.ndarray, r_q: float, side: float) -> np.ndarray:
    """Point at r_p from p and r_q from q on the given side (+1: counter-clockwise of p->q)."""
    d = q - p
    dist = float(np.linalg.norm(d))
    along = (r_p**2 - r_q**2 + dist**2) / (2.0 * dist)
    if r_p**2 - along**2 < -1e-12:
        raise UnreachableFootPose("out of reach: a four-bar cannot close at these joint angles")
    height = math.sqrt(max(r_p**2 - along**2, 0.0))
    u = d / dist
    return p + along * u + side * height * np.array([-u[1], u[0]])


def leg_fk(urdf_rad: np.ndarray) -> np.ndarray:
    """T_hip_sole (4x4) of the URDF angles (hip_roll, hip_yaw, hip_pitch, knee, ankle) [rad],
    the four-bars closed in closed form on the branches of the zero pose."""
    hip_roll, hip_yaw, hip_pitch, knee, ankle = (float(a) for a in urdf_rad)
    A = P0["A"]
    D = A + _turn(P0["D"] - A, -hip_pitch)
    C = D + _turn(P0["C"] - P0["D"], knee - hip_pitch)
    B = _circle(A, AB, C, BC, _side("A", "C", "B"))
    shin = _direction(C - B) - _direction(P0["C"] - P0["B"])
    E = B + _turn(P0["E"] - P0["B"], shin)
    G = E + _turn(P0["G"] - P0["E"], shin)
    H = G + _turn(P0["H"] - P0["G"], shin - ankle)
    heel = _circle(E, EI, H, HI, _side("E", "H", "I"))  # the pin I
    foot = _direction(heel - E) - _direction(P0["I"] - P0["E"])
    sole = E + _turn(SOLE_FROM_E, foot)
    R_leg = _rot_x(hip_roll) @ _rot_z(hip_yaw)
    T = np.eye(4)
    T[:3, :3] = R_leg @ _rot_y(-foot)
    T[:3, 3] = R_leg @ np.array([sole[0], 0.0, sole[1]])
    return T
