"""hybrid_leg_biped against the hybrid-leg paper (Che et al., Actuators 2022), with pinocchio.

Independent numbers: link lengths and the fixed angles q30, q40 of the authors' code (DESIGN.md,
"Hybrid leg paper"), restated here; the hip height above the ground (kBodyHigh), the foot's
forward offset (82.54606669 mm) at the zero pose and the hip placement in the body (kBodyWidth,
kBodyLong) from the authors' kinematics.h and plan.cpp (github.com/Gabriel-cjj/Biped_rbt).
The four-bars are checked against closed-form (law of cosines) solutions computed here, after
solving the passive joints numerically on the loop residual.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import least_squares

from robots.catalogue import BUILTIN_ROBOTS
from tests.robots.urdf_facts import (
    floating_model,
    frame_placements,
)

URDF_PATH = BUILTIN_ROBOTS["hybrid_leg_biped"].urdf_path
LENGTH_m = {  # DESIGN.md, from the authors' code [mm] / 1000
    "AO": 0.1545, "AD": 0.150, "CD": 0.42202, "AB": 0.560921, "BC": 0.176009, "BE": 0.549313,
    "CE": 0.42661, "EG": 0.32682, "HI": 0.309991, "GH": 0.065, "IJ": 0.085, "EJ": 0.040,
}  # fmt: skip
Q30_rad, Q40_rad = math.radians(151.92), math.radians(126.85)
AUTHORS_HIP_HEIGHT_m = 1.09067763961  # kinematics.h kBodyHigh: hip centre O above the sole
AUTHORS_FOOT_X_m = 0.08254606669  # plan.cpp foot start x: point M below E, ahead of O
AUTHORS_BODY_WIDTH_m, AUTHORS_BODY_LONG_m = 0.405, 0.112  # kinematics.h: hips O in the body
ANGLE_ROUNDING_TOL_m = 1e-4  # q30, q40 are given to 0.01 deg: ~0.9 m/rad x 8.7e-5 rad
SNAP_TOL_m = 2e-6  # the URDF prints 6 significant digits: joint origins on a micrometre grid
LOOP_TOL_m = 1e-9
SIDES = ("left", "right")
JOINT_KEYS = ("hip_roll", "hip_yaw", "hip_pitch", "knee", "ankle")  # the paper's q1..q5
ACTUATED = [f"{s}_{j}" for s in SIDES for j in JOINT_KEYS]
PASSIVE = [f"{s}_{j}" for s in SIDES for j in ("thigh_a", "shin_c", "foot_e", "ankle_rod_h")]
LOOPS = [(f"{s}_knee_loop_thigh_b", f"{s}_knee_loop_shin_b") for s in SIDES] + [
    (f"{s}_ankle_loop_rod_i", f"{s}_ankle_loop_foot_i") for s in SIDES
]


@pytest.fixture(scope="module")
def model() -> pin.Model:
    return floating_model(URDF_PATH)


def leg_points(model: pin.Model, data: pin.Data, side: str) -> dict[str, np.ndarray]:
    """World positions [m] of the paper's points; B and I from both sides of the cut."""
    joint = {"O": "hip_roll", "A": "thigh_a", "D": "knee", "C": "shin_c", "E": "foot_e"}
    joint |= {"G": "ankle", "H": "ankle_rod_h"}
    frame = {"B": "knee_loop_shin_b", "B_thigh": "knee_loop_thigh_b", "I": "ankle_loop_foot_i"}
    frame |= {"I_rod": "ankle_loop_rod_i", "sole": "sole"}
    out = {
        k: data.oMi[model.getJointId(f"{side}_{v}")].translation.copy() for k, v in joint.items()
    }
    out |= {
        k: data.oMf[model.getFrameId(f"{side}_{v}")].translation.copy() for k, v in frame.items()
    }
    return out


def interior_angle(p: np.ndarray, vertex: np.ndarray, q: np.ndarray) -> float:
    """Angle p-vertex-q [rad] in [0, pi]."""
    u, v = p - vertex, q - vertex
    return math.atan2(np.linalg.norm(np.cross(u, v)), float(u @ v))


def law_of_cosines_angle(adjacent1: float, adjacent2: float, opposite: float) -> float:
    return math.acos((adjacent1**2 + adjacent2**2 - opposite**2) / (2 * adjacent1 * adjacent2))


def side_from_angle(a: float, b: float, angle_rad: float) -> float:
    return math.sqrt(a * a + b * b - 2 * a * b * math.cos(angle_rad))


def four_bar(
    ground: float, crank: float, coupler: float, rocker: float, crank_angle_rad: float
) -> tuple[float, float, float]:
    """Convex four-bar with the crank turning `crank_angle_rad` from the ground: its interior
    angles at the rocker's pivot (ground-rocker), the crank's tip (crank-coupler) and the
    coupler-rocker joint [rad], by the law of cosines through the diagonal pivot-to-crank tip."""
    diagonal = side_from_angle(ground, crank, crank_angle_rad)
    return (
        law_of_cosines_angle(ground, diagonal, crank)
        + law_of_cosines_angle(rocker, diagonal, coupler),
        law_of_cosines_angle(crank, diagonal, ground)
        + law_of_cosines_angle(coupler, diagonal, rocker),
        law_of_cosines_angle(rocker, coupler, diagonal),
    )


def knee_closed_form(angle_adc_rad: float, L: dict[str, float]) -> dict[str, float]:
    """Four-bar ABCD with ground AD and crank DC: angles BAD, DCB, ABC [rad] (convex A-B-C-D)."""
    angles = four_bar(L["AD"], L["CD"], L["BC"], L["AB"], angle_adc_rad)
    return dict(zip(("BAD", "DCB", "ABC"), angles, strict=True))


def ankle_closed_form(angle_egh_rad: float, L: dict[str, float]) -> dict[str, float]:
    """Four-bar EGHI with ground EG (shin) and crank GH: angles GEI and GHI [rad]."""
    angles = four_bar(L["EG"], L["GH"], L["HI"], L["EI"], angle_egh_rad)
    return {"GEI": angles[0], "GHI": angles[1]}


def q_index(model: pin.Model, name: str) -> int:
    return model.joints[model.getJointId(name)].idx_q


def loop_residual_m(model: pin.Model, q: np.ndarray) -> np.ndarray:
    data = frame_placements(model, q)
    return np.concatenate(
        [
            data.oMf[model.getFrameId(a)].translation - data.oMf[model.getFrameId(b)].translation
            for a, b in LOOPS
        ]
    )


def solve_passive(model: pin.Model, q: np.ndarray, steps: int = 10) -> np.ndarray:
    """q with the eight passive joints solved so that all loops close.

    Levenberg-Marquardt on the loop residual, continued from the zero pose in `steps` equal
    steps of the actuated joints, so that each four-bar stays on its assembly branch.
    """
    passive = [q_index(model, name) for name in PASSIVE]
    actuated = [q_index(model, name) for name in ACTUATED]
    solved = q.copy()
    solved[passive] = 0.0
    for fraction in np.linspace(0.0, 1.0, steps + 1)[1:]:
        solved[actuated] = fraction * q[actuated]

        def residual(x: np.ndarray, trial: np.ndarray = solved) -> np.ndarray:
            trial = trial.copy()
            trial[passive] = x
            return loop_residual_m(model, trial)

        tol = 1e-15
        solved[passive] = least_squares(
            residual, solved[passive], method="lm", xtol=tol, ftol=tol, gtol=tol
        ).x
    return solved


def test_loop_closures_parse_and_name_existing_links_and_passive_joints():
    root = ET.parse(URDF_PATH).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    parent_joint = {j.find("child").get("link"): j for j in joints.values()}

    def path_to_root(link: str) -> list[str]:
        names = []
        while link in parent_joint:
            names.append(parent_joint[link].get("name"))
            link = parent_joint[link].find("parent").get("link")
        return names

    loops = root.findall("loop_closure")
    assert len(loops) == 4
    declared_passive = []
    for loop in loops:
        a, b = loop.get("link_a"), loop.get("link_b")
        assert a in links and b in links, loop.attrib
        for name in (a, b):  # massless frames fixed on each side of the cut
            assert links[name].find("inertial") is None
            assert parent_joint[name].get("type") == "fixed"
        passive = loop.get("passive_joints").split()
        declared_passive += passive
        chain_a, chain_b = path_to_root(a), path_to_root(b)
        loop_joints = set(chain_a) ^ set(chain_b)  # joints of the loop, below the common root
        for name in passive:
            assert name in joints and joints[name].get("type") == "revolute"
            assert name in loop_joints, (name, loop.get("name"))
    assert sorted(declared_passive) == sorted(PASSIVE)


def test_ten_actuated_and_eight_passive_joints(model):
    revolute = [n for n, j in zip(model.names[1:], model.joints[1:], strict=True) if j.nq == 1]
    assert sorted(revolute) == sorted(ACTUATED + PASSIVE)
    assert model.nq == 7 + 18 and model.nv == 6 + 18
    for name in PASSIVE:
        assert model.effortLimit[model.joints[model.getJointId(name)].idx_v] == 0.0
    for name in ACTUATED:
        assert model.effortLimit[model.joints[model.getJointId(name)].idx_v] > 0.0


@pytest.mark.parametrize("side", SIDES)
def test_link_lengths_match_the_authors_code(model, side):
    p = leg_points(model, frame_placements(model, pin.neutral(model)), side)
    pairs = {
        "AO": ("A", "O"), "AD": ("A", "D"), "CD": ("C", "D"), "AB": ("A", "B_thigh"),
        "BC": ("B", "C"), "BE": ("B", "E"), "CE": ("C", "E"), "EG": ("E", "G"),
        "HI": ("H", "I_rod"), "GH": ("G", "H"),
    }  # fmt: skip
    for name, (start, end) in pairs.items():
        assert np.linalg.norm(p[end] - p[start]) == pytest.approx(LENGTH_m[name], abs=SNAP_TOL_m)
    # G lies on the shin line EC (the paper's angle GEI = theta3 + theta4 measures EC).
    assert interior_angle(p["G"], p["E"], p["C"]) == pytest.approx(0.0, abs=1e-5)
    # Foot: J straight below E by EJ on the sole plane, I behind J by IJ, feet flat.
    assert p["I"] - p["E"] == pytest.approx([-LENGTH_m["IJ"], 0, -LENGTH_m["EJ"]], abs=SNAP_TOL_m)
    assert p["sole"][2] == pytest.approx(p["I"][2], abs=1e-12)


@pytest.mark.parametrize("side", SIDES)
def test_zero_pose_is_the_authors_standing_pose(model, side):
    data = frame_placements(model, pin.neutral(model))
    p = leg_points(model, data, side)
    down = np.array([0.0, 0.0, -1.0])
    assert interior_angle(p["D"], p["A"], p["A"] + down) == pytest.approx(
        math.pi - Q30_rad, abs=2e-5
    )
    assert interior_angle(p["A"], p["D"], p["C"]) == pytest.approx(Q40_rad, abs=2e-5)
    assert p["O"][2] - p["sole"][2] == pytest.approx(AUTHORS_HIP_HEIGHT_m, abs=ANGLE_ROUNDING_TOL_m)
    assert p["E"][0] - p["O"][0] == pytest.approx(AUTHORS_FOOT_X_m, abs=ANGLE_ROUNDING_TOL_m)
    hip_y_m = (1.0 if side == "left" else -1.0) * AUTHORS_BODY_WIDTH_m / 2
    assert p["O"] == pytest.approx([-AUTHORS_BODY_LONG_m, hip_y_m, 0.0], abs=1e-12)
    sole = data.oMf[model.getFrameId(f"{side}_sole")]
    assert np.allclose(sole.rotation, np.eye(3), atol=1e-12)  # flat and parallel to the ground


def test_loops_closed_at_zero(model):
    assert np.abs(loop_residual_m(model, pin.neutral(model))).max() < LOOP_TOL_m


def test_four_bar_classes_and_limits_stay_on_one_branch(model):
    L = LENGTH_m | {"EI": math.hypot(LENGTH_m["IJ"], LENGTH_m["EJ"])}
    abcd = sorted([L["AD"], L["CD"], L["BC"], L["AB"]])
    assert abcd[0] + abcd[3] > abcd[1] + abcd[2]  # non-Grashof: the knee crank cannot turn fully
    eghi = sorted([L["EG"], L["GH"], L["HI"], L["EI"]])
    assert eghi[0] + eghi[3] < eghi[1] + eghi[2] and eghi[0] == L["GH"]  # crank-rocker
    for side in SIDES:
        knee = model.joints[model.getJointId(f"{side}_knee")].idx_q
        for knee_rad in (model.lowerPositionLimit[knee], model.upperPositionLimit[knee]):
            angle_abc = knee_closed_form(Q40_rad + knee_rad, L)["ABC"]
            assert math.radians(20) < angle_abc < math.radians(160)  # transmission angle at B


CASES = [  # (knee, ankle) [rad] for the left leg; the right leg gets other values
    (-0.8, -0.7),
    (-0.4, 0.3),
    (0.0, 0.6),
    (0.25, -0.3),
    (0.55, 0.75),
]


@pytest.mark.parametrize(("knee_rad", "ankle_rad"), CASES)
def test_passive_joints_close_the_loops_as_the_closed_form_predicts(model, knee_rad, ankle_rad):
    rng = np.random.default_rng(CASES.index((knee_rad, ankle_rad)))
    q0 = pin.neutral(model)
    p0 = {side: leg_points(model, frame_placements(model, q0), side) for side in SIDES}
    # Lengths measured on the URDF (checked against the paper above, to the micrometre grid).
    L = {k: np.linalg.norm(p0["left"][k[0]] - p0["left"][k[1]]) for k in ("AD", "CD", "EG", "GH")}
    L |= {"AB": np.linalg.norm(p0["left"]["B_thigh"] - p0["left"]["A"])}
    L |= {"BC": np.linalg.norm(p0["left"]["B"] - p0["left"]["C"])}
    L |= {"HI": np.linalg.norm(p0["left"]["I_rod"] - p0["left"]["H"])}
    L |= {"EI": np.linalg.norm(p0["left"]["I"] - p0["left"]["E"])}

    q = q0.copy()
    q[:3] = rng.uniform(-1.0, 1.0, 3)
    q[3:7] = pin.Quaternion(pin.exp3(rng.uniform(-0.5, 0.5, 3))).coeffs()
    actuated = {}
    for side, sign in (("left", 1.0), ("right", -0.6)):
        hips = rng.uniform(-0.4, 0.4, 3)
        values = (*hips, sign * knee_rad, sign * ankle_rad)
        for name, value in zip(JOINT_KEYS, values, strict=True):
            q[q_index(model, f"{side}_{name}")] = actuated[f"{side}_{name}"] = value

    solved = solve_passive(model, q)
    assert np.abs(loop_residual_m(model, solved)).max() < LOOP_TOL_m
    for name, value in actuated.items():  # the solve moved only passive joints
        assert solved[q_index(model, name)] == value

    data = frame_placements(model, solved)
    for side in SIDES:
        p, ref = leg_points(model, data, side), p0[side]
        knee, ankle, pitch = (actuated[f"{side}_{j}"] for j in ("knee", "ankle", "hip_pitch"))
        # Paper eq. 28 and 27: q4 = angle ADC - q40; q3 = pi - angle DAF - q30 (F below A).
        angle_adc = interior_angle(ref["A"], ref["D"], ref["C"]) + knee
        assert interior_angle(p["A"], p["D"], p["C"]) == pytest.approx(angle_adc, abs=1e-9)
        hip_down = -data.oMi[model.getJointId(f"{side}_hip_yaw")].rotation[:, 2]
        angle_daf = interior_angle(ref["D"], ref["A"], ref["A"] + [0, 0, -1]) - pitch
        assert interior_angle(p["D"], p["A"], p["A"] + hip_down) == pytest.approx(
            angle_daf, abs=1e-9
        )
        expected = knee_closed_form(angle_adc, L)
        assert interior_angle(p["B"], p["A"], p["D"]) == pytest.approx(expected["BAD"], abs=1e-8)
        assert interior_angle(p["D"], p["C"], p["B"]) == pytest.approx(expected["DCB"], abs=1e-8)
        assert interior_angle(p["A"], p["B"], p["C"]) == pytest.approx(expected["ABC"], abs=1e-8)
        # Paper eq. 32: q5 = angle EGH - q50, the crank GH turning on the shin.
        angle_egh = interior_angle(ref["E"], ref["G"], ref["H"]) + ankle
        assert interior_angle(p["E"], p["G"], p["H"]) == pytest.approx(angle_egh, abs=1e-9)
        expected = ankle_closed_form(angle_egh, L)
        assert interior_angle(p["G"], p["E"], p["I"]) == pytest.approx(expected["GEI"], abs=1e-8)
        assert interior_angle(p["G"], p["H"], p["I"]) == pytest.approx(expected["GHI"], abs=1e-8)
        # Passive joint values (axes +y, clockwise seen from the right): the thigh opens angle
        # BAD, the foot closes angle GEI.
        thigh, foot = (solved[q_index(model, f"{side}_{j}")] for j in ("thigh_a", "foot_e"))
        bad0 = interior_angle(ref["B"], ref["A"], ref["D"])
        gei0 = interior_angle(ref["G"], ref["E"], ref["I"])
        assert thigh == pytest.approx(knee_closed_form(angle_adc, L)["BAD"] - bad0, abs=1e-8)
        assert foot == pytest.approx(gei0 - expected["GEI"], abs=1e-8)
