"""Loading a sweep point into the studio: its robot variant and a walk of its gait.

The point's gait is solved again on a worker (the NLP is warm there); the variant robot is loaded
with `StudioState.set_robot` and a walk of the gait played with `set_motion`. A point of a
simulated sweep also hands its servo settings (the compliance, dead band and compensation it was
simulated with) to the Compensation panel through the `servos` callback, and its servo parts
(a catalogue servo and kp on the legs, or the ideal servo everywhere) to the state's parts,
with the sweep's own user servo files the project does not keep yet (a file removed since
comes back with the point that runs its servo).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import viser

from app.core.errors import StudioError
from app.core.robot.model import RobotModel
from app.core.sweeps.part_parameters import leg_parts
from app.core.sweeps.robot_variants import sweep_robot_of
from app.core.sweeps.sampling import SweepPoint
from app.core.sweeps.servo_metrics import servo_settings
from app.studio.state import StudioState
from robots.catalogue import BUILTIN_ROBOTS

WALK_STEPS = 4
ServoSettings = Callable[[Any, Any], None]
"""Takes (CompensationParams, ServoModel) for the loaded robot: the Compensation panel's."""


@dataclasses.dataclass(frozen=True)
class PointLoader:
    """Loads sweep points into `state` (see the module's docstring)."""

    server: viser.ViserServer
    state: StudioState
    variants_dir: Path
    """Where the URDFs of loaded sweep designs are kept (the data folder's variants/)."""
    servos: ServoSettings | None = None

    def load(self, engine: Any, point: SweepPoint, user_servos: tuple[Any, ...] = ()) -> None:
        """Solve `point`'s gait on `engine` and load its robot and walk (StudioError: why not);
        `user_servos`: the sweep's own servo files (UserServoFile)."""
        from app.core.collocation.planar_model import PlanarModel
        from app.core.robot.report import robot_report
        from app.core.walking.walk import build_walk

        loaded = self.state.robot
        same = loaded is not None and sweep_robot_of(loaded.source) == point.robot.robot
        if point.robot.robot not in BUILTIN_ROBOTS and not same:  # a file: not read again
            raise StudioError(
                f"point {point.index} is of {Path(point.robot.robot).name}: load that robot "
                "first (Robot panel), then its points"
            )
        gait = engine.solve(point)
        if not gait.converged:
            raise StudioError(f"point {point.index} did not solve again: {gait.status}")
        robot = self._robot_of(point, loaded if same else None)
        walk = build_walk(PlanarModel(robot), gait, steps=WALK_STEPS)
        report = robot_report(robot)
        changed = ", ".join(f"{n} = {v:.4g}" for n, v in point.robot.values) or "as built"
        summary = (
            f"**sweep point #{point.index}** — {robot.name} ({changed}), SR {gait.sr:.4f}, "
            f"max |τ| {gait.max_abs_tau_Nm:.2f} N·m; a walk of {WALK_STEPS} steps"
        )
        servos = None
        if point.simulation is not None:
            setup = point.simulation
            servos = servo_settings(robot, setup)
            if setup.part is None:
                summary += (
                    f"; servos {setup.compliance_deg_per_Nm:.3g} °/(N·m), dead band "
                    f"{setup.dead_band_deg:.3g}°"
                )
            else:
                kp = "" if setup.part.kp is None else f" at kp {setup.part.kp:g}"
                summary += f"; {setup.part.servo}{kp} on the legs"
            summary += f", compensation {'on' if setup.compensation else 'off'}"
        with self.state.lock, self.server.atomic():
            if robot is not loaded:
                self.state.set_robot(robot, report)
            self.state.set_motion(walk.trajectory, summary, robot)
        if servos is not None and self.servos is not None:
            self.servos(*servos)  # after the robot: loading it reset the servos
        if servos is not None and point.simulation is not None:
            self._keep_parts(robot, point.simulation, servos, user_servos)
        self.state.on_play.emit(None)

    def _keep_parts(
        self, robot: RobotModel, setup: Any, servos: tuple[Any, Any], user_servos: tuple[Any, ...]
    ) -> None:
        """The point's parts into the state: its servo and kp on the legs (the ideal servo
        elsewhere), or every joint ideal for a point simulated on the virtual servos."""
        from app.core.servo.choice import JointServo, ideal_choice, offered_catalogue
        from app.studio.servo_parts import catalogue

        with self.state.lock:
            if self.state.robot is not robot:
                return
            current = self.state.work.parts
            choice = ideal_choice(robot.joint_names)
            if current is not None:
                choice = dataclasses.replace(choice, user_servos=current.user_servos)
            part = setup.part
            kept = {f.name for f in choice.user_servos}
            missing = tuple(f for f in user_servos if f.name not in kept)
            if part is not None and part.servo not in offered_catalogue(choice, catalogue()):
                with_sweeps = dataclasses.replace(
                    choice, user_servos=(*choice.user_servos, *missing)
                )
                try:  # the sweep's file back, unless its keys clash with the project's own
                    offered_catalogue(with_sweeps, catalogue())
                    choice = with_sweeps
                except StudioError:
                    pass  # the part then says which servo is unknown, in one line
            if part is not None:
                for name in leg_parts(robot, part).joint_names:
                    joint = JointServo(part.servo, kp=part.kp, dead_band_deg=part.dead_band_deg)
                    choice = choice.with_joint(name, joint)
            self.state.work.set_parts(choice, *servos, "sweep")

    def _robot_of(self, point: SweepPoint, swept: Any) -> Any:
        """The point's robot: its variant's file, the robot `swept` on screen (it stays, and the
        panel's choices), or the built-in as built."""
        from app.core.robot.loading import load_robot

        if point.robot.values:  # a file that stays: the gait worker and saves read it
            return load_robot(point.robot.write_urdf(self.variants_dir))
        if swept is not None:
            return swept
        return point.robot.load()
