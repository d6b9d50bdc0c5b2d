"""The samples of a keyframed motion between IK solutions, filled in and checked (issue 28).

Within a segment every target follows a smooth time law (keyframes' module docstring), and so
does the IK's answer, as long as nothing switches on or off (a joint limit, the CoM polygon, a
speed limit, a warning). interpolate (app.core.motions.keyframes) therefore solves only every
FILL_EVERY-th sample of a segment by the IK (its *nodes*, each solved from the node before)
and fills the samples in between from the nodes, then checks every filled sample in one pass;
an interval between two nodes with a sample that fails a check is solved sample by sample by
the IK as before.

The fill: in each interval, the Lagrange polynomial through FILL_NODES nodes around it (degree
5, the configuration's entries, the floating base's quaternion normalised after), whose error
is ω(t)·q⁽⁶⁾/720 with ω(t) = Π(t − t_i): at 10 ms samples and a node every 30 ms, ~2e-11·q⁽⁶⁾.
It is *estimated* per sample as the difference to the polynomial through one node more (the
standard embedded estimate: their difference is the degree-5 polynomial's error to leading
order), and the estimate must be below FILL_Q: where the IK's answer is not smooth (a
constraint that becomes active, a segment start where the held feet change), the two
polynomials disagree and the interval is solved.

The checks, per filled sample, from pinocchio's forward kinematics (the same measures as the
IK's own result, app.core.posing.ik_verdict): the stance feet within HELD_M of where they
stand; the moving feet and the pelvis within REACHED_M / REACHED_RAD of their targets (the
pelvis's horizontal position yields to a CoM target, as in keyframe_guards._shortfalls), the
CoM within REACHED_M of its target and (when the motion keeps it there) inside the support
polygon; every joint within its limits and its speed limit (app.core.motions.continuity) from
the sample before. A filled sample therefore has no warning of its own (a sample whose IK
answer would have one fails a check), and its contacts are measured from the same forward
kinematics as a solved sample's.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from app.core.motions.continuity import _joint_speeds
from app.core.motions.keyframe_guards import CONTACT_BAND_M, REPORT_M, REPORT_RAD
from app.core.posing.ik import REACHED_M, IkTargets
from app.core.robot.model import RobotModel

FILL_EVERY = 3
"""A node every this many samples (30 ms at 100 Hz)."""
FILL_NODES = 6
"""Nodes per interpolating polynomial (degree 5); the estimate uses one more."""
FILL_Q = 1e-6
"""[rad, m] The estimated fill error allowed per configuration entry: below the accuracy of a
solved sample itself (one Gauss–Newton step leaves up to ~2.4e-6 from placo's fixed point,
tests/core/test_keyframes_trimmed.py)."""
FILL_TASK = 2e-6
"""[m, rad] How far a filled sample's misses of its targets (feet, pelvis, CoM: position and
sin θ·axis of the turn) may be from the same polynomials through the nodes' misses: the
IK's answer and the targets are smooth between nodes where this holds, and a fill error within
FILL_Q moves a foot ~1e-6 m (a target that steps between nodes, put back on the floor, does
not pass)."""
CLEAR_OF = 1e-5
"""[m, rad] A filled sample's misses must be this far inside the thresholds at which a miss is
reported (REPORT_M, REPORT_RAD; the CoM's REACHED_M): closer, the IK's own answer could fall
on the other side, and the sample is solved (Roban S14's step in place, whose CoM misses
hover at 1 mm)."""
HELD_M = 1e-6
"""[m] How far a filled sample's stance foot may be from where it stands (solved samples: the
anchor puts it there to ~1e-10; STANCE_SLIDE_M, the guard of solved samples, is 5e-4)."""

LIMIT_SLACK = 1e-9
"""[rad, m] A filled joint this little beyond its limit is rounding (a joint held at its limit
at every node is filled with weights that sum to 1 to rounding), not a limit crossed."""


def fillable(robot: RobotModel) -> bool:
    """Whether this robot's motions can be filled: no kinematic loop (a filled sample would
    open it) and every joint a one-number joint besides the floating base (the fill is on the
    configuration's entries)."""
    if robot.tree.loops:
        return False
    model = robot.model
    first = 2 if robot.floating_base else 1
    return all(model.joints[j].nq == 1 == model.joints[j].nv for j in range(first, model.njoints))


def fill(
    robot: RobotModel, nodes: np.ndarray, qs: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples strictly between consecutive `nodes` (sorted sample indices, at least
    FILL_NODES + 1 of them) filled from qs[nodes]. Returns (their indices, their
    configurations, the estimated error of each, the largest over its entries)."""
    where, q_filled, estimate = fill_values(nodes, qs[nodes])
    if robot.floating_base:
        quaternion = q_filled[:, 3:7]
        quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
    return where, q_filled, estimate


def fill_values(nodes: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """fill's polynomials on any values (rows: the nodes'): (indices, filled rows, estimates)."""
    count = len(nodes)
    filled, estimates, where = [], [], []
    weights: dict[bytes, np.ndarray] = {}  # by the nodes and samples relative to the interval's

    def weighed(lo: int, size: int, inside: np.ndarray) -> np.ndarray:
        relative = np.concatenate([nodes[lo : lo + size], inside]) - nodes[i]
        key = relative.tobytes()
        if key not in weights:
            weights[key] = _lagrange(relative[:size].astype(float), relative[size:].astype(float))
        return weights[key] @ values[lo : lo + size]

    for i in range(count - 1):
        inside = np.arange(nodes[i] + 1, nodes[i + 1])
        if not len(inside):
            continue
        q = weighed(min(max(i - FILL_NODES // 2 + 1, 0), count - FILL_NODES), FILL_NODES, inside)
        q_wide = weighed(
            min(max(i - FILL_NODES // 2, 0), count - FILL_NODES - 1), FILL_NODES + 1, inside
        )
        filled.append(q)
        estimates.append(np.abs(q - q_wide).max(axis=1))
        where.append(inside)
    return np.concatenate(where), np.concatenate(filled), np.concatenate(estimates)


def _lagrange(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(len(x), len(nodes)) weights of the Lagrange polynomial through `nodes` at x (no x a
    node): Π_i (x − t_i) / ((x − t_j) Π_i≠j (t_j − t_i))."""
    differences = x[:, None] - nodes[None, :]
    gaps = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(gaps, 1.0)
    return differences.prod(axis=1)[:, None] / (differences * gaps.prod(axis=1)[None, :])


def check(
    robot: RobotModel,
    data: pin.Data,
    qs: np.ndarray,
    nodes: np.ndarray,
    where: np.ndarray,
    targets_at: Callable[[int], IkTargets],
    polygon: np.ndarray | None,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The checks (module docstring) of the samples `where` of one segment, filled in qs from
    its `nodes` (both in the order fill gives them); `targets_at(k)`: sample k's targets,
    `polygon` the support polygon the CoM must stay in (None: not kept there). Returns
    (whether each passes, (len(where), 2) contacts)."""
    model = robot.model
    ids = robot.link_frame_ids
    frames = {
        "left": ids[robot.foot("left").link],
        "right": ids[robot.foot("right").link],
        "pelvis": ids[robot.tree.root],
    }
    samples = np.concatenate([nodes, where])
    count = len(samples)
    placed = {label: np.empty((count, 4, 4)) for label in frames}
    com = np.empty((count, 2))
    oMf = data.oMf
    for row, k in enumerate(samples):  # the only loop over samples: pinocchio's FK and CoM
        pin.framesForwardKinematics(model, data, qs[k])
        for label, frame in frames.items():
            placed[label][row] = oMf[frame].homogeneous
        com[row] = pin.centerOfMass(model, data, False)[:2]
    targets = [targets_at(int(k)) for k in samples]
    wanted = _wanted(targets)
    residuals = np.concatenate(
        [_residual(placed[label], T) for label, T in wanted.items() if label != "com"]
        + ([com - wanted["com"][:, :2, 3]] if "com" in wanted else []),
        axis=1,
    )
    first = len(nodes)
    _, predicted, _ = fill_values(nodes, residuals[:first])
    ok = np.abs(residuals[first:] - predicted).max(axis=1) <= FILL_TASK
    stance = targets[0].stance
    contacts = np.ones((len(where), 2), dtype=bool)
    for i, foot in enumerate(robot.feet):
        T, T_target = placed[foot.side][first:], wanted[foot.side][first:]
        if stance in (foot.side, "both"):
            ok &= np.abs(T[:, :3, :] - T_target[:, :3, :]).max(axis=(1, 2)) < HELD_M
            continue
        lowest = np.einsum("cj,mj->mc", foot.sole_corners_m, T[:, 2, :3]).min(axis=1) + T[:, 2, 3]
        contacts[:, i] = lowest <= CONTACT_BAND_M
        ok &= _reported(T, T_target, horizontal=True)
    if "pelvis" in wanted:
        pelvis = placed["pelvis"][first:]
        ok &= _reported(pelvis, wanted["pelvis"][first:], horizontal="com" not in wanted)
    if "com" in wanted:
        miss = np.linalg.norm(com[first:] - wanted["com"][first:, :2, 3], axis=1)
        ok &= miss < REACHED_M - CLEAR_OF
    if polygon is not None:
        ok &= _margins(com[first:], polygon) >= 0.0
    return ok & _within_limits(robot, qs, where, dt), contacts


def _wanted(targets: Sequence[IkTargets]) -> dict[str, np.ndarray]:
    """The samples' targets stacked by label, (m, 4, 4) (the CoM's xy in the translation)."""
    wanted = {
        "left": np.stack([np.asarray(t.T_world_left) for t in targets]),
        "right": np.stack([np.asarray(t.T_world_right) for t in targets]),
    }
    if targets[0].T_world_pelvis is not None:
        wanted["pelvis"] = np.stack([np.asarray(t.T_world_pelvis) for t in targets])
    if targets[0].com_xy is not None:
        com = np.zeros((len(targets), 4, 4))
        com[:, :2, 3] = [np.asarray(t.com_xy, dtype=float)[:2] for t in targets]
        wanted["com"] = com
    return wanted


def _residual(T: np.ndarray, T_target: np.ndarray) -> np.ndarray:
    """(m, 6) How placements miss their targets: the position, and sin θ·axis of the turn
    R_targetᵀR (smooth in the configuration, as the IK's own residual is)."""
    relative = np.einsum("mji,mjk->mik", T_target[:, :3, :3], T[:, :3, :3])
    turn = 0.5 * np.stack(
        [
            relative[:, 2, 1] - relative[:, 1, 2],
            relative[:, 0, 2] - relative[:, 2, 0],
            relative[:, 1, 0] - relative[:, 0, 1],
        ],
        axis=1,
    )
    return np.concatenate([T[:, :3, 3] - T_target[:, :3, 3], turn], axis=1)


def _within_limits(robot: RobotModel, qs: np.ndarray, where: np.ndarray, dt: float) -> np.ndarray:
    """(m,) The samples `where` with every joint within its limits (LIMIT_SLACK) and within its
    speed limit from the sample before and to the sample after."""
    model = robot.model
    idx_q = np.array([joint.idx_q for joint in robot.joints], dtype=int)
    angles = qs[where][:, idx_q]
    lower, upper = model.lowerPositionLimit[idx_q], model.upperPositionLimit[idx_q]
    ok = ((angles >= lower - LIMIT_SLACK) & (angles <= upper + LIMIT_SLACK)).all(axis=1)
    _, v_max = _joint_speeds(robot)
    limit = v_max * dt * (1.0 + 1e-9)
    ok &= (np.abs(angles - qs[where - 1][:, idx_q]) <= limit).all(axis=1)
    return ok & (np.abs(qs[where + 1][:, idx_q] - angles) <= limit).all(axis=1)


def _reported(T: np.ndarray, T_target: np.ndarray, horizontal: bool) -> np.ndarray:
    """(m,) Placements within REPORT_M and REPORT_RAD of their targets (the horizontal position
    left out when not `horizontal`): no miss reported (keyframe_guards._shortfalls)."""
    miss = T[:, :3, 3] - T_target[:, :3, 3]
    if not horizontal:
        miss = miss[:, 2:]
    relative = np.einsum("mji,mjk->mik", T_target[:, :3, :3], T[:, :3, :3])
    cos_angle = np.clip((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return (np.linalg.norm(miss, axis=1) < REPORT_M - CLEAR_OF) & (
        cos_angle > np.cos(REPORT_RAD - CLEAR_OF)
    )


def _margins(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(m,) Signed distances of points (m, 2) inside a counter-clockwise convex polygon (as
    app.core.posing.support_polygon measures the CoM's margin)."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1)[:, None]
    offsets = np.einsum("ij,ij->i", polygon, normals)
    return (offsets[None, :] - points @ normals.T).min(axis=1)
