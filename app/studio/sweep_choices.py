"""What the Sweep panel offers for the loaded robot, and the sweep data it builds from it.

`SweptRobot` is the robot the panel sweeps (its sweep name, feet, package folders and planner
defaults); `choices` are its parameters with their first ranges; `spec_data` turns the panel's
values into the sweep data `SweepSpec.from_mapping` reads.

The servo parts: "part:servo" is categorical, its min and max the first and last of the
servos the simulation can run in key order (`part_servos`: 0 is the first), "part:kp" the
firmware's P gain on them (app.core.sweeps.part_parameters). The project's own servo files
(the Servos folder's *Add servo file*) are offered too: their servos join `part_servos`, and
the sweep data carries the files whose servos it chooses (`user_servos`: name and text), so
the workers and the project's saved sweep have them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from app.core.collocation.controls import CONTROLS
from app.core.errors import StudioError
from app.core.servo.user_files import UserServoFile, records
from app.core.sweeps.part_parameters import runnable_servos
from app.core.sweeps.robot_variants import ROBOT_PARAMETERS, sweep_robot_of
from app.core.sweeps.servo_metrics import SERVO_PARAMETERS, simulation_cost_s
from robots.catalogue import BUILTIN_ROBOTS

STEP_RANGE = (0.6, 1.4)
"""The panel's first step-length range, × the robot's default step (the planner's defaults
scale with the legs): dircon_biped's 0.2 m gives 0.12–0.28 m."""
KP_RANGE = (8.0, 64.0)
"""The panel's first kp range: a quarter to twice BAM's firmware kp of 32."""
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
    user_servos: tuple[Any, ...] = ()
    """The project's own servo files (UserServoFile), offered beside the catalogue."""

    @classmethod
    def of(
        cls, robot: Any, package_roots: tuple[str, ...], user_servos: tuple[Any, ...] = ()
    ) -> SweptRobot:
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
            user_servos,
        )

    def shown_defaults(self) -> Any:
        """The planner defaults the panel's ranges start from (the planner's own where it
        cannot walk the robot)."""
        from app.core.collocation.settings import GaitSettings

        return GaitSettings() if isinstance(self.defaults, StudioError) else self.defaults

    def spec_data(self, values: dict[str, Any]) -> dict[str, Any]:
        """The sweep data of this robot with the panel's `values`: a .urdf robot's workers
        load it as the studio did (its package folders, its feet); the part:servo row's
        min … max (indices of `part_servos`) become its choices."""
        data: dict[str, Any] = {"robot": self.robot}
        if self.robot not in BUILTIN_ROBOTS and self.feet is not None:
            data |= {"package_roots": list(self.package_roots), "feet": list(self.feet)}
        values = dict(values)
        keys = part_servos(self.user_servos)
        if "parameter" in values:
            values["parameter"] = [_with_choices(p, keys) for p in values["parameter"]]
        chosen = {k for p in values.get("parameter", []) for k in p.get("choices", ())}
        chosen |= {dict(values.get("part", {})).get("servo")}
        files = [f for f in self.user_servos if chosen & {r.key for r in records(f)}]
        if files:
            data["user_servos"] = [{"name": f.name, "text": f.text} for f in files]
        return {**data, **values}

    def planner_defaults(self) -> Any:
        """The planner defaults, or StudioError why the planner cannot walk the robot."""
        if isinstance(self.defaults, StudioError):
            raise StudioError(f"{self.robot}: the planner cannot walk it: {self.defaults}")
        if self.defaults is None:
            raise StudioError("no robot loaded yet")
        return self.defaults

    def line(self) -> str:
        """Which robot the panel sweeps, why robot parameters are missing where they are, and
        the servos part:servo's min … max index."""
        servos = ", ".join(f"{i} {key}" for i, key in enumerate(part_servos(self.user_servos)))
        parts = f"  \npart:servo (on the legs, min … max of): {servos}; needs *Simulate*."
        if self.robot in ROBOT_PARAMETERS:
            return f"Robot: **{self.robot}** (the loaded robot) and its variants." + parts
        if self.robot.lower().endswith(".urdf"):
            why = (
                "its links have no known segment axis or shape to stretch, so no robot "
                "parameters (gait, servo and part only)"
            )
            return (
                f"Robot: **{self.name}** (`{Path(self.robot).name}`, the loaded robot): {why}."
                + parts
            )
        return (
            f"Robot: **{self.robot}** (the loaded robot): its builder has no sweep parameters."
            + parts
        )


def choices(
    robot: str, defaults: Any, user_servos: tuple[Any, ...] = ()
) -> dict[str, tuple[float, float]]:
    """The panel's parameters for sweep robot `robot` (sweep_robot_of) with their first ranges:
    step length and gait time around the robot's planner `defaults`, the other gait settings
    over their sliders' ranges, a built-in's robot parameters over what its builder accepts,
    part:servo over every servo offered (the project's `user_servos` files' included)."""
    out = {f"gait:{c.field}": (float(c.minimum), float(c.maximum)) for c in CONTROLS}
    step, h = defaults.step_length_m, defaults.H_s
    out["gait:step_length_m"] = (round(step * STEP_RANGE[0], 4), round(step * STEP_RANGE[1], 4))
    out["gait:H_s"] = (round(h * H_RANGE[0], 3), round(h * H_RANGE[1], 3))
    for p in ROBOT_PARAMETERS.get(robot, {}).values():
        out[f"robot:{p.name}"] = (p.minimum, p.maximum)
    for s in SERVO_PARAMETERS.values():
        out[f"servo:{s.name}"] = (s.minimum, s.maximum)
    out["part:servo"] = (0.0, float(len(part_servos(user_servos)) - 1))
    out["part:kp"] = KP_RANGE
    return out


def part_servos(user_servos: tuple[Any, ...] = ()) -> tuple[str, ...]:
    """The servos a sweep's part:servo row picks from, by index: those the simulation can run,
    the user's files' (UserServoFile) included; a file that cannot be used offers none (the
    Servos folder said why when it was added)."""
    try:
        return tuple(sorted(runnable_servos(tuple(user_servos))))
    except StudioError:
        return tuple(sorted(runnable_servos()))


def _with_choices(parameter: dict[str, Any], keys: tuple[str, ...]) -> dict[str, Any]:
    if (parameter.get("kind"), parameter.get("name")) != ("part", "servo"):
        return parameter
    lo, hi = (parameter.get(k) for k in ("min", "max"))
    if not all(isinstance(v, float | int) and np.isfinite(v) for v in (lo, hi)):
        raise StudioError(f"part:servo: min and max are indices 0 … {len(keys) - 1}")
    first, last = round(float(lo)), round(float(hi))  # type: ignore[arg-type]
    if not 0 <= first <= last < len(keys):
        raise StudioError(
            f"part:servo: min {lo:g} and max {hi:g} must be indices 0 ≤ min ≤ max ≤ "
            f"{len(keys) - 1} of {', '.join(f'{i} {k}' for i, k in enumerate(keys))}"
        )
    return {"kind": "part", "name": "servo", "choices": list(keys[first : last + 1])}


def panel_data(data: dict[str, Any], user_servos: tuple[Any, ...] = ()) -> dict[str, Any]:
    """A sweep's data as the panel shows it: a part:servo parameter's choices as its min and
    max indices (of `part_servos` of the project's `user_servos` and the sweep's own files)."""
    names = {f.name for f in user_servos}
    own = [UserServoFile(f["name"], f["text"]) for f in data.get("user_servos", ())]
    keys = part_servos((*user_servos, *(f for f in own if f.name not in names)))
    shown = []
    for p in data.get("parameter", []):
        if "choices" in p:
            at = [keys.index(k) for k in p["choices"] if k in keys]
            p = {**p, "min": float(min(at, default=0)), "max": float(max(at, default=0))}
        shown.append(p)
    return {**data, "parameter": shown}


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
