"""What the Sweep panel offers for the loaded robot, and the sweep data it builds from it.

`SweptRobot` is the robot the panel sweeps (its sweep name, feet, package folders and planner
defaults); `choices` are its parameters with their first ranges; `spec_data` turns the panel's
values into the sweep data `SweepSpec.from_mapping` reads.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from app.core.collocation.controls import CONTROLS
from app.core.errors import StudioError
from app.core.sweeps.robot_variants import ROBOT_PARAMETERS, sweep_robot_of
from app.core.sweeps.servo_metrics import SERVO_PARAMETERS, simulation_cost_s
from robots.catalogue import BUILTIN_ROBOTS

STEP_RANGE = (0.6, 1.4)
"""The panel's first step-length range, × the robot's default step (the planner's defaults
scale with the legs): dircon_biped's 0.2 m gives 0.12–0.28 m."""
H_RANGE = (0.6 / 0.72, 0.9 / 0.72)
"""The panel's first gait-time range, × the robot's default H: dircon_biped's 0.72 s gives
0.6–0.9 s."""


@dataclasses.dataclass(frozen=True)
class SweptRobot:
    """The robot the panel sweeps: sweep_robot_of the loaded robot ("" before one)."""

    robot: str = ""
    name: str = ""
    feet: tuple[str, str] | None = None
    """The loaded robot's (left, right) foot links: a swept .urdf robot's workers use them."""
    package_roots: tuple[str, ...] = ()
    """The studio's --package-root folders: a swept .urdf robot's workers load with them."""
    defaults: Any = None
    """The loaded robot's planner defaults (GaitSettings), or the StudioError why the
    planner cannot walk it."""

    @classmethod
    def of(cls, robot: Any, package_roots: tuple[str, ...]) -> SweptRobot:
        """The sweep of a loaded RobotModel `robot`."""
        from app.core.collocation.defaults import default_settings

        try:
            defaults: Any = default_settings(robot)
        except StudioError as error:  # the planner cannot walk it: said again by Run
            defaults = error
        return cls(
            sweep_robot_of(robot.source),
            robot.name,
            (robot.foot("left").link, robot.foot("right").link),
            package_roots,
            defaults,
        )

    def shown_defaults(self) -> Any:
        """The planner defaults the panel's ranges start from (the planner's own where it
        cannot walk the robot)."""
        from app.core.collocation.settings import GaitSettings

        return GaitSettings() if isinstance(self.defaults, StudioError) else self.defaults

    def spec_data(self, values: dict[str, Any]) -> dict[str, Any]:
        """The sweep data of this robot with the panel's `values`: a .urdf robot's workers
        load it as the studio did (its package folders, its feet)."""
        data: dict[str, Any] = {"robot": self.robot}
        if self.robot not in BUILTIN_ROBOTS and self.feet is not None:
            data |= {"package_roots": list(self.package_roots), "feet": list(self.feet)}
        return {**data, **values}

    def planner_defaults(self) -> Any:
        """The planner defaults, or StudioError why the planner cannot walk the robot."""
        if isinstance(self.defaults, StudioError):
            raise StudioError(f"{self.robot}: the planner cannot walk it: {self.defaults}")
        if self.defaults is None:
            raise StudioError("no robot loaded yet")
        return self.defaults

    def line(self) -> str:
        """Which robot the panel sweeps, and why robot parameters are missing where they are."""
        if self.robot in ROBOT_PARAMETERS:
            return f"Robot: **{self.robot}** (the loaded robot) and its variants."
        if self.robot.lower().endswith(".urdf"):
            why = (
                "its links have no known segment axis or shape to stretch, so no robot "
                "parameters (gait and servo only)"
            )
            return f"Robot: **{self.name}** (`{Path(self.robot).name}`, the loaded robot): {why}."
        return f"Robot: **{self.robot}** (the loaded robot): its builder has no sweep parameters."


def choices(robot: str, defaults: Any) -> dict[str, tuple[float, float]]:
    """The panel's parameters for sweep robot `robot` (sweep_robot_of) with their first ranges:
    step length and gait time around the robot's planner `defaults`, the other gait settings
    over their sliders' ranges, a built-in's robot parameters over what its builder accepts."""
    out = {f"gait:{c.field}": (float(c.minimum), float(c.maximum)) for c in CONTROLS}
    step, h = defaults.step_length_m, defaults.H_s
    out["gait:step_length_m"] = (round(step * STEP_RANGE[0], 4), round(step * STEP_RANGE[1], 4))
    out["gait:H_s"] = (round(h * H_RANGE[0], 3), round(h * H_RANGE[1], 3))
    for p in ROBOT_PARAMETERS.get(robot, {}).values():
        out[f"robot:{p.name}"] = (p.minimum, p.maximum)
    for s in SERVO_PARAMETERS.values():
        out[f"servo:{s.name}"] = (s.minimum, s.maximum)
    return out


def ordered(offered: dict[str, tuple[float, float]]) -> list[str]:
    """The parameters in the panel's order: step length and gait time first."""
    first = ["gait:step_length_m", "gait:H_s"]
    return first + [c for c in offered if c not in first]


def cost_line(steps: int) -> str:
    return (
        f"Simulating costs ~{simulation_cost_s(steps):.1f} s more per point ({steps} "
        f"step{'' if steps == 1 else 's'}; "
        "the progress line shows what it took)."
    )


def whole(value: float, what: str) -> int:
    """`value` as a whole number, or StudioError naming `what`."""
    if not np.isfinite(value) or not float(value).is_integer() or value < 0:
        raise StudioError(f"{what} = {value}: give a whole number")
    return int(value)
