"""The samples of a keyframed motion (app.core.motions.keyframes.interpolate), segment by
segment: each solved by the IK from the sample before, or (tracking, and a robot whose motions
fill: app.core.motions.keyframe_fill) solved at nodes every few samples, each from the node
before, the samples between filled from the nodes and checked, an interval that fails a check
solved sample by sample. The first sample, a segment whose samples are too few to fill, a
segment from its first node that says anything (a warning, a slide, a jump) or misses a target
(where targets compete the IK's answers depend on the path: _Sampler._solve_node) and the
samples after the last keyframe's time are solved sample by sample.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from app.core.motions.keyframe_fill import FILL_NODES, FILL_Q, _lagrange, check, fill, fillable
from app.core.motions.keyframe_guards import (
    SOLVE_ITERATIONS,
    _contacts,
    _continuous,
    _keep_stance,
    _placed,
    _shortfalls,
    _where,
)
from app.core.motions.keyframe_records import Keyframe
from app.core.motions.keyframe_targets import on_floor, segment_targets
from app.core.motions.result import SampleWarning
from app.core.posing.ik import IkResult, IkTargets, WholeBodyIK
from app.core.robot.model import RobotModel

FIRST_ITERATIONS = 200
"""For the first sample when the first keyframe has no configuration (solved from the ready
pose)."""


def sample_motion(
    robot: RobotModel,
    ik: WholeBodyIK,
    keyframes: Sequence[Keyframe],
    q: np.ndarray,
    dt: float,
    n: int,
    ends: np.ndarray,
    com_in_support: bool,
    tracking: bool,
    fill_every: int,
) -> tuple[np.ndarray, np.ndarray, list[SampleWarning]]:
    """The n samples of `interpolate` (`ends`: the keyframes' times), the first solved from
    q: configurations, contacts, warnings."""
    data = robot.model.createData()
    scratch = robot.model.createData()  # for the stance-slide checks and the fill's checks
    sampler = _Sampler(robot, ik, keyframes, dt, n, ends, com_in_support, data, scratch, tracking)
    first = keyframes[0]
    iterations = SOLVE_ITERATIONS if first.q is not None else FIRST_ITERATIONS
    # every foot to the first keyframe, so that each sample is an IK solution
    targets = on_floor(
        robot,
        IkTargets(
            first.T_world_left,
            first.T_world_right,
            first.T_world_pelvis,
            first.com_xy,
            keyframes[1].stance,
        ),
    )
    result = ik.solve(
        q, targets, com_in_support=com_in_support, max_iterations=iterations, explain=False
    )
    sampler.finish(0, result.q, result, targets, [])
    t = np.arange(n) * dt
    k = 1
    for segment in range(len(keyframes) - 1):
        if segment + 2 == len(keyframes):
            last = n - 1
        else:  # the samples up to its keyframe's time
            last = k - 1 + int(np.count_nonzero(t[k:] <= ends[segment + 1] + 1e-9))
        if last >= k:
            every = fill_every if tracking else 1
            sampler.segment(segment, k, last, every, q if segment == 0 else None)
            k = last + 1
    warnings = [
        SampleWarning(k, k * dt, keyframes[sampler.segment_of[k] + 1].name if k else first.name, m)
        for k, messages in enumerate(sampler.messages)
        for m in messages
    ]
    return sampler.qs, sampler.contacts, warnings


class _Sampler:
    """The samples of one motion, segment by segment: solved one by one (each from the one
    before, as the module docstring says), or at nodes, the samples between filled and
    checked (app.core.motions.keyframe_fill)."""

    def __init__(
        self,
        robot: RobotModel,
        ik: WholeBodyIK,
        keyframes: Sequence[Keyframe],
        dt: float,
        n: int,
        ends: np.ndarray,
        com_in_support: bool,
        data: pin.Data,
        scratch: pin.Data,
        tracking: bool,
    ) -> None:
        self.robot, self.ik, self.keyframes = robot, ik, keyframes
        self.dt, self.n, self.ends = dt, n, ends
        self.com_in_support, self.tracking = com_in_support, tracking
        self.data, self.scratch = data, scratch
        self.qs = np.empty((n, robot.model.nq))
        self.contacts = np.zeros((n, 2), dtype=bool)
        self.messages: list[list[str]] = [[] for _ in range(n)]
        self.segment_of = np.zeros(n, dtype=int)
        self.can_fill = fillable(robot)
        self.start: dict[str, np.ndarray] = {}
        self.planned: list[IkTargets] = []
        self.first_k = 0

    def segment(
        self, segment: int, k0: int, k1: int, every: int, q_start: np.ndarray | None = None
    ) -> None:
        """Samples k0..k1 (the segment's), a node every `every` samples where they fill."""
        self.segment_of[k0 : k1 + 1] = segment
        # where it starts: the sample before (the first segment: where the motion started)
        q_before = self.qs[k0 - 1] if q_start is None else q_start
        self.start = _where(self.robot, q_before, self.data)
        self.first_k = k0 - 1  # the targets from the sample before (a node when aligned)
        self.planned = _segment(
            self.robot, self.keyframes, segment, self.start, k0 - 1, self.n, self.dt, self.ends
        )
        k = self._filled(segment, k0, k1, every) if every > 1 and self.can_fill else k0
        for j in range(k, k1 + 1):
            self.solve_sample(j)

    def _filled(self, segment: int, k0: int, k1: int, every: int) -> int:
        """Nodes every `every` samples up to the segment's keyframe, each solved from the one
        before; the samples between filled and checked, an interval that fails a check solved
        one by one. Returns the first sample left to solve one by one (after a node or a
        sample solved with a message, and those after the last keyframe's time)."""
        t = np.arange(k0, k1 + 1) * self.dt
        k_end = k0 - 1 + int(np.count_nonzero(t <= self.ends[segment + 1] + 1e-9))
        if abs((k0 - 1) * self.dt - self.ends[segment]) > 1e-9:
            if self.solve_sample(k0):  # the sample before is not the segment's start
                return k0 + 1
            nodes = [k0]
        else:
            nodes = [k0 - 1]
        grid = [*range(nodes[0] + every, k_end, every), k_end]
        if len(nodes) + len(grid) <= FILL_NODES or k_end <= nodes[0]:
            return nodes[-1] + 1
        resume = k_end + 1
        for b in grid:
            if not self._solve_node(nodes, b):
                resume = nodes[-1] + 1
                break
            nodes.append(b)
        if len(nodes) <= FILL_NODES:  # too few nodes to fill from: one by one
            return nodes[0] + 1
        return min(resume, self._fill_between(nodes))

    def _fill_between(self, nodes: list[int]) -> int:
        """The samples between the nodes filled and checked, an interval that fails solved one
        by one. Returns the sample to go on one by one from when one of those says anything
        (the motion's path is a new one from there), else past the last node."""
        nodes_at = np.array(nodes)
        where, q_filled, estimate = fill(self.robot, nodes_at, self.qs)
        self.qs[where] = q_filled
        polygon = None
        if self.com_in_support:
            stance = self.planned[-1].stance
            polygon = self.ik.support_polygon(self.qs[nodes[0]], stance)
        ok, contacts = check(
            self.robot,
            self.scratch,
            self.qs,
            nodes_at,
            where,
            lambda k: self.planned[k - self.first_k],
            polygon,
            self.dt,
        )
        ok &= estimate <= FILL_Q
        self.contacts[where] = contacts
        failed = np.searchsorted(nodes_at, where[~ok])  # the intervals to solve one by one
        for i in np.unique(failed):
            for k in range(nodes[i - 1] + 1, nodes[i]):
                if self.solve_sample(k):
                    return k + 1
        return nodes[-1] + 1

    def _solve_node(self, nodes: list[int], b: int) -> bool:
        """Sample b solved from the last node (its start predicted from up to four nodes
        before); False (nothing kept) when it says anything (a warning, a slide, a jump) or
        misses a target by REACHED_M / REACHED_RAD: where the targets compete, the IK's answer
        depends on the path it is reached by (Roban S14's step in place: its CoM 1.0, 1.5,
        0.9, 1.5 mm from its target on consecutive samples solved one by one, ~0.3 mm from
        nodes solved 30 ms apart), and a fill would smooth over what the samples solved one
        by one show."""
        robot, ik, model = self.robot, self.ik, self.robot.model
        a = nodes[-1]
        q_from, targets = self.qs[a], self.planned[b - self.first_k]
        guess = None
        if len(nodes) > 1:
            before = nodes[-4:]
            steps = np.array([pin.difference(model, q_from, self.qs[k]) for k in before])
            weights = _lagrange(np.array(before, dtype=float), np.array([float(b)]))
            guess = pin.integrate(model, q_from, (weights @ steps)[0])
        result = ik.track(
            q_from,
            targets,
            guess,
            com_in_support=self.com_in_support,
            max_iterations=SOLVE_ITERATIONS,
            explain=False,
        )
        if not result.reached:  # targets that compete: answers that depend on the path
            return False
        result, messages = _keep_stance(ik, q_from, targets, result, self.com_in_support)
        if messages:
            return False
        q, jump = _continuous(
            robot,
            ik,
            q_from,
            result.q,
            self.start,
            targets,
            (b - a) * self.dt,
            self.com_in_support,
            self.scratch,
        )
        if jump is not None or self.finish(b, q, result, targets, []):
            self.messages[b] = []
            return False
        return True

    def solve_sample(self, k: int) -> list[str]:
        """Sample k solved from sample k − 1 (module docstring); returns its messages."""
        robot, ik, model = self.robot, self.ik, self.robot.model
        q, targets = self.qs[k - 1], self.planned[k - self.first_k]
        if not self.tracking:
            result = ik.solve(
                q,
                targets,
                com_in_support=self.com_in_support,
                max_iterations=SOLVE_ITERATIONS,
                explain=False,
            )
        else:
            guess = None
            if k >= 2:
                guess = pin.integrate(model, q, pin.difference(model, self.qs[k - 2], q))
            result = ik.track(
                q,
                targets,
                guess,
                com_in_support=self.com_in_support,
                max_iterations=SOLVE_ITERATIONS,
                explain=False,
            )
        result, messages = _keep_stance(ik, q, targets, result, self.com_in_support)
        q_next, jump = _continuous(
            robot, ik, q, result.q, self.start, targets, self.dt, self.com_in_support, self.scratch
        )
        if jump is not None:
            messages.append(jump)
        return self.finish(k, q_next, result, targets, messages)

    def finish(
        self, k: int, q: np.ndarray, result: IkResult, targets: IkTargets, messages: list[str]
    ) -> list[str]:
        """Sample k kept at q (result: the IK's answer it comes from): its contacts and all
        its messages (returned)."""
        robot = self.robot
        placed = result.placements if q is result.q and result.placements else None
        if placed is None:
            placed = _placed(robot, self.data, q)
        self.contacts[k] = _contacts(robot, placed, targets.stance)
        messages += _shortfalls(robot, placed, targets, result, q)
        if self.com_in_support and result.com_margin_m < 0.0:
            messages.append(f"CoM {-result.com_margin_m * 1000:.1f} mm outside the support polygon")
        self.messages[k] = messages
        self.qs[k] = q
        return messages


def _segment(
    robot: RobotModel,
    keyframes: Sequence[Keyframe],
    segment: int,
    start: dict[str, np.ndarray],
    k: int,
    n: int,
    dt: float,
    ends: np.ndarray,
) -> list[IkTargets]:
    """The targets of the segment's samples from sample k: those up to its end (t ≤ its
    keyframe's time), all the remaining ones for the last segment."""
    t = np.arange(k, n) * dt
    if segment + 2 < len(keyframes):
        t = t[: int(np.count_nonzero(t <= ends[segment + 1] + 1e-9))]
    after = keyframes[segment + 1]
    tau = np.clip((t - float(ends[segment])) / after.duration_s, 0.0, 1.0)
    return segment_targets(robot, keyframes[segment], after, start, tau)
