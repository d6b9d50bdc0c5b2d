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

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from app.core.motions.continuity import _joint_speeds
from app.core.motions.keyframe_guards import CONTACT_BAND_M
from app.core.posing.ik import REACHED_M, REACHED_RAD, IkTargets
from app.core.robot.model import RobotModel

FILL_EVERY = 3
"""A node every this many samples (30 ms at 100 Hz)."""
FILL_NODES = 6
"""Nodes per interpolating polynomial (degree 5); the estimate uses one more."""
FILL_Q = 1e-6
"""[rad, m] The estimated fill error allowed per configuration entry: below the accuracy of a
solved sample itself (one Gauss–Newton step leaves up to ~2.4e-6 from placo's fixed point,
tests/core/test_keyframes_trimmed.py)."""
HELD_M = 1e-6
"""[m] How far a filled sample's stance foot may be from where it stands (solved samples: the
anchor puts it there to ~1e-10; STANCE_SLIDE_M, the guard of solved samples, is 5e-4)."""


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
    count = len(nodes)
    values = qs[nodes]
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
    q_filled = np.concatenate(filled)
    if robot.floating_base:
        quaternion = q_filled[:, 3:7]
        quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
    return np.concatenate(where), q_filled, np.concatenate(estimates)


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
    q: np.ndarray,
    before: np.ndarray,
    after: np.ndarray,
    targets: Sequence[IkTargets],
    polygon: np.ndarray | None,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The checks of the filled samples q (m, nq) of one segment (module docstring): `before`
    (m, nq) the sample before each, `after` (m, nq) the sample after each (for the speed limit
    into the next node), `targets` theirs, `polygon` the support polygon the CoM must stay in
    (None: not kept there). Returns (whether each passes, (m, 2) contacts)."""
    model = robot.model
    ids = robot.link_frame_ids
    feet = {foot.side: ids[foot.link] for foot in robot.feet}
    pelvis_id = ids[robot.tree.root]
    m = len(q)
    placed = {label: np.empty((m, 4, 4)) for label in ("left", "right", "pelvis")}
    com = np.empty((m, 2))
    oMf = data.oMf
    for k in range(m):  # the only loop over samples: pinocchio's kinematics and CoM
        pin.framesForwardKinematics(model, data, q[k])
        placed["left"][k] = oMf[feet["left"]].homogeneous
        placed["right"][k] = oMf[feet["right"]].homogeneous
        placed["pelvis"][k] = oMf[pelvis_id].homogeneous
        com[k] = pin.centerOfMass(model, data, False)[:2]
    stance = targets[0].stance
    ok = np.ones(m, dtype=bool)
    contacts = np.zeros((m, 2), dtype=bool)
    for i, foot in enumerate(robot.feet):
        T = placed[foot.side]
        T_target = np.stack(
            [t.T_world_left if foot.side == "left" else t.T_world_right for t in targets]
        )
        if stance in (foot.side, "both"):
            contacts[:, i] = True
            ok &= np.abs(T[:, :3, :] - T_target[:, :3, :]).max(axis=(1, 2)) < HELD_M
            continue
        lowest = np.einsum("cj,mj->mc", foot.sole_corners_m, T[:, 2, :3]).min(axis=1) + T[:, 2, 3]
        contacts[:, i] = lowest <= CONTACT_BAND_M
        ok &= _reached(T, T_target, horizontal=True)
    if targets[0].T_world_pelvis is not None:
        T_target = np.stack([t.T_world_pelvis for t in targets])  # type: ignore[misc]
        ok &= _reached(placed["pelvis"], T_target, horizontal=targets[0].com_xy is None)
    if targets[0].com_xy is not None:
        wanted = np.stack([np.asarray(t.com_xy, dtype=float)[:2] for t in targets])
        ok &= np.linalg.norm(com - wanted, axis=1) < REACHED_M
    if polygon is not None:
        ok &= _margins(com, polygon) >= 0.0
    idx_q = np.array([joint.idx_q for joint in robot.joints], dtype=int)
    angles = q[:, idx_q]
    lower, upper = model.lowerPositionLimit[idx_q], model.upperPositionLimit[idx_q]
    ok &= ((angles >= lower) & (angles <= upper)).all(axis=1)
    _, v_max = _joint_speeds(robot)
    limit = v_max * dt * (1.0 + 1e-9)
    ok &= (np.abs(angles - before[:, idx_q]) <= limit).all(axis=1)
    ok &= (np.abs(after[:, idx_q] - angles) <= limit).all(axis=1)
    return ok, contacts


def _reached(T: np.ndarray, T_target: np.ndarray, horizontal: bool) -> np.ndarray:
    """(m,) Placements within REACHED_M and REACHED_RAD of their targets (the horizontal
    position left out when not `horizontal`)."""
    miss = T[:, :3, 3] - T_target[:, :3, 3]
    if not horizontal:
        miss = miss[:, 2:]
    relative = np.einsum("mji,mjk->mik", T_target[:, :3, :3], T[:, :3, :3])
    cos_angle = np.clip((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return (np.linalg.norm(miss, axis=1) < REACHED_M) & (cos_angle > np.cos(REACHED_RAD))


def _margins(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(m,) Signed distances of points (m, 2) inside a counter-clockwise convex polygon (as
    app.core.posing.support_polygon measures the CoM's margin)."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1)[:, None]
    offsets = np.einsum("ij,ij->i", polygon, normals)
    return (offsets[None, :] - points @ normals.T).min(axis=1)
