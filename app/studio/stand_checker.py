"""The stand check in the studio: can the robot stand on its virtual servos, asked before any
motion (`app.core.dynamics.stand_stiffness` at the robot's ready, bent-knee pose).

A check takes 0.1–1.5 s (a robot's ready pose once, then the Hessian's leg IK solves), so it
runs on one named worker thread, never on viser's callback threads: `request` shows
"checking…" at once and returns; the newest request wins (an older one still queued is
skipped, an older result arriving late is dropped). `checked` is emitted with each line shown.
The line ends with the robot's default servo (the paper's, sized to it: app.core.servo.scaling).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from app.core.dynamics.stand_stiffness import stand_check
from app.core.errors import StudioError
from app.core.posing.ready_pose import ready_pose
from app.core.robot.model import RobotModel
from app.core.servo.model import ServoModel
from app.core.servo.scaling import scaled_ideal_servo
from app.studio.signals import Signal

log = logging.getLogger(__name__)

CHECKING = "**Stand check** (ready pose, the servos below): checking…"


def stand_line(robot: RobotModel, q_ready: np.ndarray, servo: ServoModel) -> str:
    """The panel's line: the stiffness balance at the ready pose with these servos."""
    compliance = servo.for_joints(robot.joint_names).compliance_deg_per_Nm
    check = stand_check(robot, q_ready, compliance)
    text = check.text()
    if check.stands and check.max_ankle_compliance_deg_per_Nm is not None:
        return f"✅ **Stand check** (ready pose): {text}"
    return (
        f"⚠️ **Stand check** (ready pose): {robot.name} {text}. Any motion on these servos "
        "starts by falling: stiffen the servos (the servo compliance below)."
    )


class StandChecker:
    def __init__(self, show: Callable[[str], None]) -> None:
        self._show = show
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="stand-check")
        self._lock = threading.Lock()
        self._generation = 0
        self._asked: tuple[RobotModel, bytes] | None = None
        """The robot and compliance last asked about (a repeat is not checked again)."""
        self._ready: tuple[RobotModel, np.ndarray | str] | None = None
        """The current robot's ready pose, or why it has none."""
        self.checked: Signal[str] = Signal("stand_checked")
        """Emitted with each line shown (after "checking…")."""

    def request(self, robot: RobotModel, servo: ServoModel) -> None:
        """Check `robot` on `servo` in the background (module docstring)."""
        compliance = np.asarray(servo.for_joints(robot.joint_names).compliance_deg_per_Nm)
        asked = (robot, compliance.tobytes())
        with self._lock:
            if self._asked is not None and self._asked[0] is robot and self._asked[1] == asked[1]:
                return
            self._asked = asked
            self._generation += 1
            generation = self._generation
        self._show(CHECKING)
        self._executor.submit(self._check, generation, robot, servo)

    def _check(self, generation: int, robot: RobotModel, servo: ServoModel) -> None:
        if generation != self._generation:
            return  # a newer request is queued behind this one
        try:
            text = self._line(robot, servo)
        except Exception as error:  # a thread pool keeps exceptions to itself: say it here
            log.exception("the stand check of %s failed", robot.name)
            text = f"⚠️ **Stand check** failed: {error}"
        with self._lock:
            if generation != self._generation:
                return
            self._show(text)
        self.checked.emit(text)

    def _line(self, robot: RobotModel, servo: ServoModel) -> str:
        if self._ready is None or self._ready[0] is not robot:
            try:
                self._ready = (robot, ready_pose(robot).q)
            except StudioError as error:
                self._ready = (robot, str(error))
        q = self._ready[1]
        default = f"  \nDefault {scaled_ideal_servo(robot).text()}."
        if isinstance(q, str):
            return f"**Stand check**: not for {robot.name} ({q}){default}"
        try:
            return stand_line(robot, q, servo) + default
        except StudioError as error:
            return f"**Stand check**: not for {robot.name} ({error}){default}"

    def close(self) -> None:
        with self._lock:
            self._generation += 1  # whatever still runs shows nothing
        self._executor.shutdown(wait=False, cancel_futures=True)
