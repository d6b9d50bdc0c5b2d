"""SweepSpec: what a design sweep varies, how it samples, and which metrics it trades off.

A sweep file (TOML) looks like:

    robot = "dircon_biped"      # a built-in robot, or a .urdf file (gait and servo only)
    package_roots = ["/ws/src"] # a .urdf file's: folders holding its package:// meshes
    feet = ["l_sole", "r_sole"] # a .urdf file's: (left, right) foot links, if not detected
    sampling = "latin"          # grid | random | latin (Latin hypercube)
    samples = 40                # random and latin; a grid multiplies the parameters' levels
    seed = 1
    pareto = { sr = "min", max_torque_Nm = "min" }
    start = "anchor"            # where each solve starts (see START)
    simulate = false            # true: walk, torques, compensation and MuJoCo per point
    walk_steps = 2              # steps of that walk
    servo_files = ["mine.toml"] # the user's own servo files (from this file's folder), whose
                                # servos [part] and a swept servo may name

    [servo]                     # fixed servo parameters (with simulate = true)
    compliance_deg_per_Nm = 1.4
    [part]                      # or a catalogue servo on the legs (app.core.sweeps.part_parameters)
    servo = "mx106"

    [gait]                      # fixed GaitSettings for every point
    knots = 12

    [[parameter]]
    name = "step_length_m"      # a GaitSettings field, a robot parameter, or a servo parameter
    kind = "gait"               # gait | robot | servo | part (servo: choices = [...]; kp)
    min = 0.1
    max = 0.3
    levels = 3                  # grid only (default 3)

The simulation metrics (fell, torso and tracking errors) cost about 1 s more per point on
dircon_biped with 2 steps (app.core.sweeps.servo_metrics); servo parameters act only through
them, so they need `simulate = true`.

Everything is checked before a single point runs: unknown names, NaN, crossed ranges, ranges
outside what the planner's settings (`GaitSettings.validate`) or the robot builder accept, zero
samples, and more than MAX_POINTS points.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Literal

from app.core import input_gate
from app.core.collocation.settings import GaitSettings, GaitSettingsError
from app.core.errors import refuse_unknown_keys
from app.core.sweeps.part_metrics import PART_METRICS, check_part_metrics
from app.core.sweeps.part_parameters import (
    check_parts,
    fixed_part,
    offered_servos,
    user_servo_files,
)
from app.core.sweeps.robot_variants import RobotVariant, SweepSpecError, robot_parameter
from app.core.sweeps.servo_metrics import DEFAULT_WALK_STEPS, MAX_WALK_STEPS
from app.core.sweeps.spec_values import (
    DEFAULT_LEVELS,
    KINDS,
    MAX_POINTS,
    SweepParameter,
    integer,
    servo_table,
    sweep_parameter,
    typed,
)
from robots.catalogue import BUILTIN_ROBOTS

__all__ = [
    "DEFAULT_LEVELS",
    "KINDS",
    "MAX_PACKAGE_ROOTS",
    "MAX_PARAMETERS",
    "MAX_POINTS",
    "METRICS",
    "PART_KINDS",
    "SAMPLINGS",
    "SIMULATION_METRICS",
    "START",
    "TOP_KEYS",
    "Sense",
    "SweepParameter",
    "SweepSpec",
    "read_sweep_toml",
    "sweep_toml_data",
]

MAX_PARAMETERS = 12
MAX_PACKAGE_ROOTS = 16
METRICS = {
    "sr": "specific resistance E / (M g d) (eq. 9)",
    "sr_incl_impacts": "specific resistance with the impact losses",
    "max_torque_Nm": "largest |joint torque| at the knots [N·m]",
    "max_joint_speed_radps": "largest |joint speed| at the knots [rad/s]",
    "energy_J": "positive mechanical work of the joints over the gait [J]",
    "solve_s": "IPOPT time of the point [s]",
}
SIMULATION_METRICS = {
    "fell": "1 if the walk fell in the simulation, 0 if it stayed up",
    "max_torso_error_deg": "largest torso roll or pitch error against the plan [°]",
    "max_tracking_error_deg": "largest |joint angle − plan| in the simulation [°]",
    "rms_joint_error_deg": "RMS joint error against the plan in the simulation [°]",
}
"""Metrics of the simulation (a sweep with simulate = true)."""
METRICS.update(SIMULATION_METRICS)
METRICS.update(PART_METRICS)
"""The metrics a Pareto front may use, with what they mean."""
SAMPLINGS = ("grid", "random", "latin")
TOP_KEYS = (
    "robot", "sampling", "samples", "seed", "pareto", "start", "gait", "parameter",
    "simulate", "walk_steps", "servo", "package_roots", "feet", "part", "user_servos",
)  # fmt: skip
START = {
    "anchor": "from the gait of the [gait] settings on the same NLP (solved once per worker): "
    "fast, and a point's result depends on the point only",
    "cold": "from the planner's own initial guess: slower, depends on the point only",
    "previous": "from the worker's last gait: fastest, but a point's result then depends on "
    "what its worker solved before",
}
"""Where each point's solve starts."""
Sense = Literal["min", "max"]
PART_KINDS = ("servo", "part")
"""Kinds of parameters that act only through the simulation."""


@dataclasses.dataclass(frozen=True)
class SweepSpec:
    """A validated sweep; `SweepSpec.from_mapping` is the only way in from user data."""

    robot: str
    parameters: tuple[SweepParameter, ...]
    sampling: str = "latin"
    samples: int = 20
    """Points of random and latin sampling (a grid has the product of the levels)."""
    seed: int = 0
    pareto: tuple[tuple[str, Sense], ...] = (("sr", "min"), ("max_torque_Nm", "min"))
    """(metric, "min" | "max") pairs the Pareto front trades off."""
    gait: tuple[tuple[str, Any], ...] = ()
    """Fixed GaitSettings overrides for every point."""
    start: str = "anchor"
    """A key of START."""
    simulate: bool = False
    """Whether each solved point is walked, compensated and simulated (servo_metrics)."""
    walk_steps: int = DEFAULT_WALK_STEPS
    servo: tuple[tuple[str, float], ...] = ()
    """Fixed servo parameters (names of SERVO_PARAMETERS) for every point."""
    package_roots: tuple[str, ...] = ()
    """A .urdf robot's package folders (RobotVariant.package_roots)."""
    feet: tuple[str, str] | None = None
    """A .urdf robot's (left, right) foot links, when named rather than detected."""

    part: tuple[tuple[str, Any], ...] = ()
    """The fixed servo part on the legs: ("servo", key) and ("kp", value) as given ([part])."""
    user_servos: tuple[Any, ...] = ()
    """The user's servo files (UserServoFile) whose servos the part may name."""

    @property
    def servos(self) -> tuple[str, ...]:
        """The servo keys the sweep puts on the legs (swept or fixed); () without parts."""
        swept = [p.choices for p in self.parameters if p.kind == "part" and p.choices]
        return swept[0] if swept else tuple(v for n, v in self.part if n == "servo")

    def variant(self, values: dict[str, float] | None = None) -> RobotVariant:
        """The swept robot with robot parameters `values` (none: as built)."""
        return RobotVariant.of(self.robot, values or {}, self.package_roots, self.feet)

    @property
    def n_points(self) -> int:
        if self.sampling == "grid":
            return math.prod(p.levels for p in self.parameters)
        return self.samples

    def base_settings(self, defaults: GaitSettings | None = None) -> GaitSettings:
        """The settings every point starts from: `defaults` (the robot's, see
        app.core.collocation.defaults; the paper's if None) with `gait` applied."""
        return GaitSettings.from_mapping(dict(self.gait), source="[gait]", base=defaults)

    @classmethod
    def from_mapping(cls, data: dict[str, Any], source: str = "sweep") -> SweepSpec:
        """Check user data (a parsed TOML, the panel's values) and build the spec."""
        if not isinstance(data, dict):
            raise SweepSpecError(f"{source}: a sweep is a table of keys, not {type(data).__name__}")
        refuse_unknown_keys(data, TOP_KEYS, SweepSpecError, source)
        robot = typed(data.get("robot", "dircon_biped"), str, f"{source}: robot")
        if robot not in BUILTIN_ROBOTS and not robot.lower().endswith(".urdf"):
            raise SweepSpecError(
                f"{source}: robot = {robot!r}; a sweep runs on a built-in robot: "
                f"{', '.join(BUILTIN_ROBOTS)}, or on a .urdf file (gait and servo parameters "
                "only: its links have no known segment axis or shape to stretch, so a length "
                "is not defined for it)"
            )
        package_roots, feet = _urdf_options(data, robot, source)
        sampling = typed(data.get("sampling", "latin"), str, f"{source}: sampling")
        if sampling not in SAMPLINGS:
            raise SweepSpecError(
                f"{source}: sampling = {sampling!r}; give one of {', '.join(SAMPLINGS)}"
            )
        samples = integer(data.get("samples", 20), f"{source}: samples")
        seed = integer(data.get("seed", 0), f"{source}: seed")
        if not 0 <= seed < 2**32:
            raise SweepSpecError(f"{source}: seed = {seed}; give a seed in [0, 2³²)")
        start = typed(data.get("start", "anchor"), str, f"{source}: start")
        if start not in START:
            raise SweepSpecError(f"{source}: start = {start!r}; give one of {', '.join(START)}")
        files = user_servo_files(data.get("user_servos", []), source)
        gait = typed(data.get("gait", {}), dict, f"{source}: [gait]")
        try:
            base = GaitSettings.from_mapping(dict(gait), source=f"{source}: [gait]")
        except GaitSettingsError as error:
            raise SweepSpecError(str(error)) from None
        raw = typed(data.get("parameter", []), list, f"{source}: [[parameter]]")
        if not raw:
            raise SweepSpecError(f"{source}: no [[parameter]]: name at least one to sweep")
        if len(raw) > MAX_PARAMETERS:
            raise SweepSpecError(f"{source}: {len(raw)} parameters; at most {MAX_PARAMETERS}")
        parameters = tuple(
            sweep_parameter(entry, f"{source}: parameter {i + 1}", robot, base, files)
            for i, entry in enumerate(raw)
        )
        names = [p.name for p in parameters]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise SweepSpecError(f"{source}: parameter(s) {', '.join(twice)} given twice")
        for p in parameters:
            setting = robot_parameter(robot, p.name).gait_setting if p.kind == "robot" else ""
            if setting in names:
                raise SweepSpecError(
                    f"{source}: {p.name} sets the planner's {setting} itself; sweep one of them"
                )
        pareto = _pareto(data.get("pareto", {"sr": "min", "max_torque_Nm": "min"}), source)
        simulate = bool(typed(data.get("simulate", False), bool, f"{source}: simulate"))
        walk_steps = integer(data.get("walk_steps", DEFAULT_WALK_STEPS), f"{source}: walk_steps")
        if not 1 <= walk_steps <= MAX_WALK_STEPS:
            raise SweepSpecError(
                f"{source}: walk_steps = {walk_steps}; give 1 to {MAX_WALK_STEPS} steps"
            )
        servo = servo_table(data.get("servo", {}), source)
        part = fixed_part(data.get("part", {}), source, files)
        check_parts(parameters, servo, part, source)
        servos = [v for n, v in part if n == "servo"] + [k for p in parameters for k in p.choices]
        check_part_metrics([m for m, _ in pareto], servos, offered_servos(files), source)
        if not simulate:
            needs = [f"{p.kind} parameter {p.name}" for p in parameters if p.kind in PART_KINDS]
            needs += [f"[servo] {name}" for name, _ in servo]
            needs += [f"[part] {name}" for name, _ in part]
            needs += [f"pareto metric {m}" for m, _ in pareto if m in SIMULATION_METRICS]
            if needs:
                raise SweepSpecError(
                    f"{source}: {', '.join(needs)} act(s) only through the simulation: set "
                    "simulate = true (a walk, its torques and a MuJoCo run per point, about "
                    "1 s more per point)"
                )
        spec = cls(
            robot, parameters, sampling, samples, seed, pareto,
            tuple(sorted(gait.items())), start, simulate, walk_steps, servo,
            package_roots, feet, part, files,
        )  # fmt: skip
        if sampling != "grid" and samples < 1:
            raise SweepSpecError(f"{source}: samples = {samples}; give at least 1 point")
        if spec.n_points > MAX_POINTS:
            raise SweepSpecError(
                f"{source}: {spec.n_points} points is more than the limit of {MAX_POINTS}; "
                "use fewer samples or levels, or split the sweep"
            )
        return spec


def read_sweep_toml(path: Path) -> SweepSpec:
    """A sweep file (TOML, ≤ 1 MiB) checked into a SweepSpec; its `servo_files` (paths from
    the file's folder) read into the data's `user_servos`."""
    return SweepSpec.from_mapping(sweep_toml_data(path), str(path))


def sweep_toml_data(path: Path) -> dict[str, Any]:
    """The data of a sweep file, its `servo_files` read (part_parameters.read_servo_files)."""
    from app.core.sweeps.part_parameters import read_servo_files

    data = input_gate.read_toml(path, SweepSpecError)
    if "servo_files" in data:
        data["user_servos"] = read_servo_files(data.pop("servo_files"), path)
    return data


def _urdf_options(
    data: dict[str, Any], robot: str, source: str
) -> tuple[tuple[str, ...], tuple[str, str] | None]:
    """`package_roots` and `feet`: how a .urdf robot loads (the studio's --package-root and
    --feet); a built-in robot has no use for them."""
    given = [key for key in ("package_roots", "feet") if key in data]
    if given and robot in BUILTIN_ROBOTS:
        raise SweepSpecError(
            f"{source}: {' and '.join(given)} are for a robot loaded from a .urdf file; "
            f"{robot} is built in"
        )
    roots = typed(data.get("package_roots", []), list, f"{source}: package_roots")
    for root in roots:
        typed(root, str, f"{source}: package_roots entry")
    if len(roots) > MAX_PACKAGE_ROOTS:
        raise SweepSpecError(f"{source}: {len(roots)} package_roots; at most {MAX_PACKAGE_ROOTS}")
    feet = None
    if "feet" in data:
        links = typed(data["feet"], list, f"{source}: feet")
        if len(links) != 2 or not all(isinstance(link, str) and link for link in links):
            raise SweepSpecError(
                f"{source}: feet = {links!r}; give the left and the right foot link's names"
            )
        feet = (links[0], links[1])
    return tuple(roots), feet


def _pareto(value: Any, source: str) -> tuple[tuple[str, Sense], ...]:
    table = typed(value, dict, f"{source}: pareto")
    if len(table) != 2:
        raise SweepSpecError(f"{source}: pareto names {len(table)} metrics; give exactly two")
    out: list[tuple[str, Sense]] = []
    for metric, sense in table.items():
        if metric not in METRICS:
            raise SweepSpecError(
                f"{source}: pareto metric {metric!r} is unknown; known: {', '.join(METRICS)}"
            )
        if sense not in ("min", "max"):
            raise SweepSpecError(f"{source}: pareto {metric} = {sense!r}; give 'min' or 'max'")
        out.append((metric, sense))
    return tuple(out)
