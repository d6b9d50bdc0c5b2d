"""Robot parameters of a sweep: a built-in robot's URDF with segment lengths and masses changed.

The built-in builders (robots/<name>/build.py) build the papers' numbers; apart from the foot
size (a builder argument, below) a sweep changes the generated URDF, where the change is well
defined:

- a segment length (`thigh_length_m`, `shank_length_m`) moves the joint at the segment's end
  (knee, ankle) to the new length on both legs, and stretches the segment's own link along its
  axis by the same ratio: inertial and visual origins, the lengths of the axial cylinders, and
  the inertia about the transverse axes (× ratio², a slender rod);
- a link mass (`base_mass_kg`, `thigh_mass_kg`, ...) sets the mass of that link (both legs' for
  a leg link) and scales its inertia tensor by the same ratio;
- a torque limit (`torque_limit_Nm`, servo_biped) sets the effort limit of every leg joint, and
  the planner's torque bound (`GaitSettings.tau_max_Nm`, which defaults to the smallest effort
  limit) with it;
- the foot size (`sole_length_m`, `sole_width_m`) is an argument of the robot's builder
  (`build_urdf(...)`): the sole plates' visual and collision boxes take that length and width
  (centred under the ankle, the foot's mass shared among its shapes by volume as the builder
  does), so everything read from the sole follows: its corners (`Foot.sole_corners_m`), the
  support polygon, the planner's heel and toe points and MuJoCo's sole boxes. A variant with a
  foot size is built by the builder and then edited for the other parameters; at the defaults
  the builder gives the committed URDF (`python -m robots.build --check`).

dircon_biped and servo_biped have sweep parameters; the ranges keep the robot buildable and its
legs able to stand (the planner refuses what it cannot walk). servo_biped's segments are boxes:
a length moves them along the leg with the joint, their sizes stay. A loaded URDF has none: its
links have no known segment axis or shape to stretch, so "length" is not defined for it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from app.core.errors import StudioError


class SweepSpecError(StudioError):
    """A sweep description that cannot be run: unknown parameter, bad range, too many points."""


@dataclasses.dataclass(frozen=True)
class RobotParameter:
    """One sweepable number of a built-in robot."""

    name: str
    minimum: float
    maximum: float
    default: float
    links: tuple[str, ...]
    """Links changed (both legs)."""
    end_joints: tuple[str, ...] = ()
    """For a length: the joints at the segment's far end, moved to −length along z."""
    hint: str = ""
    effort_joints: tuple[str, ...] = ()
    """For a torque limit: the joints whose URDF effort limit it sets."""
    gait_setting: str = ""
    """A GaitSettings field that follows the value (the planner's torque bound)."""
    builder_arg: str = ""
    """For a builder argument (the foot size): its keyword in `robots.<robot>.build.build_urdf`."""

    @property
    def is_length(self) -> bool:
        return bool(self.end_joints)


def _leg(link: str) -> tuple[str, str]:
    return f"left_{link}", f"right_{link}"


ROBOT_PARAMETERS: dict[str, dict[str, RobotParameter]] = {
    "dircon_biped": {
        p.name: p
        for p in (
            RobotParameter(
                "thigh_length_m",
                0.25,
                0.55,
                0.3905,
                _leg("thigh"),
                _leg("knee"),
                "Hip pitch to knee axis [m] (built: 0.3905)",
            ),
            RobotParameter(
                "shank_length_m",
                0.25,
                0.55,
                0.3905,
                _leg("shank"),
                _leg("ankle_pitch"),
                "Knee to ankle axis [m] (built: 0.3905)",
            ),
            RobotParameter("base_mass_kg", 2.0, 20.0, 7.624, ("base",), (), "Table 2: 7.624"),
            RobotParameter("thigh_mass_kg", 0.3, 4.0, 1.116, _leg("thigh"), (), "Table 2: 1.116"),
            RobotParameter("shank_mass_kg", 0.3, 4.0, 1.597, _leg("shank"), (), "Table 2: 1.597"),
            RobotParameter("foot_mass_kg", 0.1, 2.0, 0.300, _leg("foot"), (), "Table 2: 0.300"),
            RobotParameter(
                "sole_length_m", 0.12, 0.28, 0.190, (), (),
                "sole length, heel to toe [m] (Figure 2: 0.190)", builder_arg="foot_length_m",
            ),
            RobotParameter(
                "sole_width_m", 0.05, 0.15, 0.075, (), (),
                "sole width [m] (Figure 2: 0.075; the feet touch above 0.2)",
                builder_arg="foot_width_m",
            ),
        )
    },
    "servo_biped": {
        p.name: p
        for p in (
            RobotParameter(
                "thigh_length_m", 0.07, 0.16, 0.1028, _leg("thigh"), _leg("knee"),
                "Hip pitch to knee axis [m] (built: 0.1028, Roban)",
            ),
            RobotParameter(
                "shank_length_m", 0.09, 0.19, 0.129, _leg("shank"), _leg("ankle_pitch"),
                "Knee to ankle pitch axis [m] (built: 0.129, Roban)",
            ),
            RobotParameter("base_mass_kg", 0.2, 3.0, 0.6, ("base",), (), "pelvis (built: 0.6)"),
            RobotParameter("torso_mass_kg", 0.4, 4.0, 1.4, ("torso",), (), "chest (built: 1.4)"),
            RobotParameter("thigh_mass_kg", 0.1, 1.5, 0.4, _leg("thigh"), (), "built: 0.4"),
            RobotParameter("shank_mass_kg", 0.1, 1.5, 0.4, _leg("shank"), (), "built: 0.4"),
            RobotParameter("foot_mass_kg", 0.1, 1.0, 0.3, _leg("foot"), (), "built: 0.3"),
            RobotParameter(
                "sole_length_m", 0.09, 0.22, 0.14, (), (), "sole length [m] (built: 0.14)",
                builder_arg="sole_length_m",
            ),
            RobotParameter(
                "sole_width_m", 0.05, 0.09, 0.08, (), (),
                "sole width [m] (built: 0.08; the feet touch above 0.093)",
                builder_arg="sole_width_m",
            ),
            RobotParameter(
                "torque_limit_Nm", 2.0, 20.0, 6.0, (), (), "leg servos' torque (built: 6.0)",
                effort_joints=tuple(
                    f"{side}_{joint}"
                    for side in ("left", "right")
                    for joint in (
                        "hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"
                    )
                ),
                gait_setting="tau_max_Nm",
            ),
        )
    },
}  # fmt: skip


def robot_parameter(robot: str, name: str) -> RobotParameter:
    """The parameter `name` of built-in `robot`, or SweepSpecError naming the known ones."""
    known = ROBOT_PARAMETERS.get(robot)
    if known is None:
        robots = ", ".join(sorted(ROBOT_PARAMETERS))
        raise SweepSpecError(
            f"robot parameter {name!r}: {robot!r} has no sweepable robot parameters "
            f"(robots with some: {robots}); sweep its gait parameters only"
        )
    if name not in known:
        raise SweepSpecError(
            f"unknown robot parameter {name!r} for {robot}; known: {', '.join(known)}"
        )
    return known[name]


def sweep_robot_of(source: str | Path) -> str:
    """The `robot` a sweep of the robot loaded from `source` names: the built-in's name when
    `source` is a built-in robot's URDF (or name), else the .urdf file itself (a sweep of its
    gait and servo parameters; the workers read the file, so they must see it)."""
    from robots.catalogue import BUILTIN_ROBOTS

    if str(source) in BUILTIN_ROBOTS:
        return str(source)
    path = Path(source)
    for name, builtin in BUILTIN_ROBOTS.items():
        if path.resolve() == builtin.urdf_path.resolve():
            return name
    return str(path)


@dataclasses.dataclass(frozen=True)
class RobotVariant:
    """A built-in robot with some parameters changed (or a .urdf file as it is): hashable and
    picklable, so a Dask worker can rebuild it (and key its cache of built NLPs on it)."""

    robot: str = "dircon_biped"
    """A built-in robot's name, or the path of a .urdf file (which has no parameters)."""
    values: tuple[tuple[str, float], ...] = ()
    """(parameter, value) pairs, sorted by name."""
    package_roots: tuple[str, ...] = ()
    """A .urdf file's folders to find its `package://` meshes in (the studio's --package-root),
    beside the look-up next to the file that needs none."""
    feet: tuple[str, str] | None = None
    """A .urdf file's (left, right) foot links, when they were named rather than detected."""

    @classmethod
    def of(
        cls,
        robot: str,
        values: dict[str, float],
        package_roots: tuple[str, ...] = (),
        feet: tuple[str, str] | None = None,
    ) -> RobotVariant:
        for name, value in values.items():
            p = robot_parameter(robot, name)
            if not (math.isfinite(value) and p.minimum <= value <= p.maximum):
                raise SweepSpecError(
                    f"{name} = {value}: give a value in [{p.minimum:g}, {p.maximum:g}]"
                )
        ordered = tuple(sorted((k, float(v)) for k, v in values.items()))
        return cls(robot, ordered, package_roots, feet)

    def urdf_text(self) -> str:
        """The built-in robot's URDF with this variant's values."""
        from robots.catalogue import BUILTIN_ROBOTS

        if self.robot not in BUILTIN_ROBOTS:
            raise SweepSpecError(f"{self.robot!r} is not a built-in robot")
        text = BUILTIN_ROBOTS[self.robot].urdf_path.read_text(encoding="utf-8")
        if not self.values:
            return text
        parameters = [(robot_parameter(self.robot, name), value) for name, value in self.values]
        built = {p.builder_arg: value for p, value in parameters if p.builder_arg}
        if built:
            import importlib

            builder = importlib.import_module(f"robots.{self.robot}.build")
            text = builder.build_urdf(**built)
        root = ET.fromstring(text)
        for p, value in parameters:
            if not p.builder_arg:
                _apply(root, p, value)
        return ET.tostring(root, encoding="unicode")

    def write_urdf(self, folder: Path) -> Path:
        """The variant's URDF as a file in `folder` that stays (named by its content), for a
        robot the studio keeps using: its gait worker, project saves and autosave read the
        robot's source file again."""
        from app.core.atomic_write import write_atomically

        text = self.urdf_text()
        digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
        path = folder / f"{self.robot}_variant_{digest}.urdf"
        if not path.is_file():
            folder.mkdir(parents=True, exist_ok=True)
            write_atomically(path, lambda file: file.write(text))
        return path

    def load(self):  # -> RobotModel (imported lazily: pinocchio is heavy)
        """The variant as a RobotModel (loaded from a temporary URDF, removed at once: for a
        robot kept in the studio, load `write_urdf`'s file instead)."""
        from app.core.robot.loading import load_robot

        if not self.values:
            roots = tuple(Path(root) for root in self.package_roots)
            return load_robot(self.robot, package_roots=roots, feet=self.feet)
        handle, name = tempfile.mkstemp(suffix=".urdf", prefix=f"{self.robot}_variant_")
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as file:
                file.write(self.urdf_text())
            return load_robot(Path(name))
        finally:
            os.unlink(name)


def _floats(text: str | None) -> list[float]:
    return [float(x) for x in (text or "0 0 0").split()]


def _fmt(values: list[float]) -> str:
    return " ".join(f"{x:.9g}" for x in values)


def _apply(root: ET.Element, p: RobotParameter, value: float) -> None:
    links = {link.get("name"): link for link in root.iter("link")}
    joints = {joint.get("name"): joint for joint in root.iter("joint")}
    for link_name in p.links:
        link = links[link_name]
        inertial = link.find("inertial")
        assert inertial is not None
        mass = inertial.find("mass")
        inertia = inertial.find("inertia")
        assert mass is not None and inertia is not None
        if p.is_length:
            ratio = value / p.default
            for element in link.iter("origin"):
                xyz = _floats(element.get("xyz"))
                element.set("xyz", _fmt([xyz[0], xyz[1], xyz[2] * ratio]))
            for visual in (*link.findall("visual"), *link.findall("collision")):
                origin, cylinder = visual.find("origin"), visual.find("geometry/cylinder")
                axial = origin is None or not any(_floats(origin.get("rpy")))
                if cylinder is not None and axial:
                    length = float(cylinder.get("length", "0"))
                    cylinder.set("length", f"{length * ratio:.9g}")
            for axis in ("ixx", "iyy"):
                inertia.set(axis, f"{float(inertia.get(axis, '0')) * ratio**2:.9g}")
        else:
            ratio = value / float(mass.get("value", "1"))
            mass.set("value", f"{value:.9g}")
            for axis in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
                inertia.set(axis, f"{float(inertia.get(axis, '0')) * ratio:.9g}")
    for joint_name in p.effort_joints:
        limit = joints[joint_name].find("limit")
        assert limit is not None
        limit.set("effort", f"{value:.9g}")
    for joint_name in p.end_joints:
        origin = joints[joint_name].find("origin")
        assert origin is not None
        xyz = _floats(origin.get("xyz"))
        origin.set("xyz", _fmt([xyz[0], xyz[1], -value]))
