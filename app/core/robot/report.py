"""The robot report: what a robotics engineer checks first when handed a URDF."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.robot.loops import loop_residual
from app.core.robot.model import RobotModel

MASSLESS_KG = 1e-6
"""Links lighter than this are treated as frames, not bodies (e.g. SigmaBan's 1e-9 kg tips)."""
LOOP_OPEN_M = 1e-6
HEAVIEST_LINK_KG = 200.0
"""A biped link heavier than this is reported as implausible (a typo in units, 1e308…)."""
MAX_GYRATION_M = 2.0
"""A principal moment above mass × (2 m)² means a link whose mass sits metres from its CoM."""
AXIS_UNIT_TOLERANCE = 1e-3
LIGHTEST_PLACEHOLDER_KG = 1e-12
"""Massless frames often carry a placeholder of 1e-9 kg; below 1e-12 kg it is a typo."""
"""A declared loop whose two sides are further apart than this at the neutral pose is reported."""


@dataclasses.dataclass(frozen=True)
class Problem:
    kind: str
    """"mass", "inertia", "limits", "mesh" or "loop"."""
    subject: str
    """The link, joint or file concerned."""
    message: str


@dataclasses.dataclass(frozen=True)
class RobotReport:
    name: str
    source: str
    n_links: int
    n_joints: int
    n_actuated: int
    actuated_joints: tuple[str, ...]
    passive_joints: tuple[str, ...]
    floating_base: bool
    mass_kg: float
    link_masses_kg: dict[str, float]
    feet: dict[str, str]
    """side -> foot link."""
    sole_size_m: dict[str, tuple[float, float]]
    """side -> (length along the foot's x, width) of the sole rectangle [m]."""
    loops: tuple[str, ...]
    missing_meshes: tuple[dict[str, str], ...]
    problems: tuple[Problem, ...]
    ok: bool = True

    def to_json(self) -> dict:
        out = dataclasses.asdict(self)
        out["problems"] = [dataclasses.asdict(p) for p in self.problems]
        return out

    def lines(self) -> list[str]:
        """Human-readable report, one fact a line."""
        out = [
            f"robot      {self.name}  ({self.source})",
            f"links      {self.n_links}, joints {self.n_joints}, actuated {self.n_actuated}"
            + (f", passive {len(self.passive_joints)}" if self.passive_joints else ""),
            f"base       {'floating' if self.floating_base else 'fixed to the world'}",
            f"mass       {self.mass_kg:.3f} kg",
            "feet       "
            + ", ".join(
                f"{side}: {link} (sole {self.sole_size_m[side][0] * 1000:.0f} × {self.sole_size_m[side][1] * 1000:.0f} mm)"
                for side, link in self.feet.items()
            ),
        ]
        if self.loops:
            out.append(f"loops      {', '.join(self.loops)}")
        out.append(f"meshes     {len(self.missing_meshes)} missing")
        for missing in self.missing_meshes:
            out.append(
                f"  missing  {missing['link']} {missing['role']}: {missing['uri']} — {missing['reason']}"
            )
        out.append(f"problems   {len(self.problems) or 'none'}")
        out.extend(f"  {p.kind:8s} {p.subject}: {p.message}" for p in self.problems)
        return out


def robot_report(robot: RobotModel) -> RobotReport:
    tree = robot.tree
    problems: list[Problem] = []
    for link, inertial in tree.inertials.items():
        problems.extend(_inertia_problems(link, inertial.mass_kg, inertial.inertia_kgm2))
    for joint in tree.joints.values():
        if joint.kind == "fixed":
            continue
        length = float(np.linalg.norm(joint.axis))
        if abs(length - 1.0) > AXIS_UNIT_TOLERANCE:
            problems.append(
                Problem(
                    "axis",
                    joint.name,
                    f"axis ({_fmt(joint.axis)}) has length {length:.6g}, not 1: it is "
                    "normalised, check it points where you meant",
                )
            )
        missing = [
            key
            for key, value in (("lower", joint.lower), ("upper", joint.upper))
            if value is None and joint.kind != "continuous"
        ]
        if joint.name not in robot.passive_joints:  # a passive joint has no motor to rate
            rated = (("effort", joint.effort), ("velocity", joint.velocity))
            missing += [key for key, value in rated if not value]
        if missing:
            problems.append(Problem("limits", joint.name, f"no {' / '.join(missing)} limit"))
        elif joint.lower is not None and joint.upper is not None and joint.lower > joint.upper:
            problems.append(
                Problem(
                    "limits", joint.name, f"lower limit {joint.lower:g} above upper {joint.upper:g}"
                )
            )
    for missing_mesh in robot.missing_meshes:
        problems.append(Problem("mesh", missing_mesh.uri, missing_mesh.reason))

    if tree.loops:
        gaps = loop_residual(robot, robot.q_neutral, robot.model.createData()).reshape(-1, 3)
        for loop, gap in zip(tree.loops, gaps, strict=True):
            if np.linalg.norm(gap) > LOOP_OPEN_M:
                problems.append(
                    Problem(
                        "loop",
                        loop.name,
                        f"open by {np.linalg.norm(gap) * 1000:.2f} mm at the neutral pose",
                    )
                )

    sole_size = {}
    for foot in robot.feet:
        corners = foot.sole_corners_m
        sole_size[foot.side] = (
            float(np.linalg.norm(corners[1] - corners[0])),
            float(np.linalg.norm(corners[2] - corners[1])),
        )
        if sole_size[foot.side][0] < 1e-3:
            problems.append(
                Problem("mesh", foot.link, "the foot has no geometry: its sole is a point")
            )

    return RobotReport(
        name=robot.name,
        source=str(robot.source),
        n_links=len(tree.links),
        n_joints=len(tree.joints),
        n_actuated=robot.n_actuated,
        actuated_joints=robot.joint_names,
        passive_joints=robot.passive_joints,
        floating_base=robot.floating_base,
        mass_kg=robot.mass_kg,
        link_masses_kg={link: inertial.mass_kg for link, inertial in tree.inertials.items()},
        feet={foot.side: foot.link for foot in robot.feet},
        sole_size_m=sole_size,
        loops=tuple(loop.name for loop in tree.loops),
        missing_meshes=tuple(
            {"link": m.link, "role": m.role, "uri": m.uri, "reason": m.reason}
            for m in robot.missing_meshes
        ),
        problems=tuple(problems),
    )


def _inertia_problems(link: str, mass_kg: float, inertia: np.ndarray) -> list[Problem]:
    if mass_kg < MASSLESS_KG:
        if mass_kg == 0.0:
            return [
                Problem("mass", link, "zero mass: fine for a frame, wrong for a body that moves")
            ]
        if mass_kg >= LIGHTEST_PLACEHOLDER_KG:
            return []
        return [
            Problem(
                "mass",
                link,
                f"{mass_kg:.3g} kg: implausibly light (under {LIGHTEST_PLACEHOLDER_KG:g} kg); "
                "give 0 for a massless frame or the link's real mass",
            )
        ]
    if mass_kg > HEAVIEST_LINK_KG:
        return [
            Problem(
                "mass",
                link,
                f"{mass_kg:.3g} kg: implausibly heavy for a robot link (over "
                f"{HEAVIEST_LINK_KG:g} kg); check the unit (kg, not g)",
            )
        ]
    moments = np.linalg.eigvalsh(inertia)
    if moments.max() > mass_kg * MAX_GYRATION_M**2:
        return [
            Problem(
                "inertia",
                link,
                f"principal moments {_fmt(moments)} kg·m² for {mass_kg:.3g} kg: its mass would "
                f"sit over {MAX_GYRATION_M:g} m from the centre of mass; check the units",
            )
        ]
    if moments.min() <= 0.0:
        return [
            Problem(
                "inertia", link, f"principal moments {_fmt(moments)} kg·m²: not positive definite"
            )
        ]
    a, b, c = moments
    if a + b < c * (1.0 - 1e-6):
        return [
            Problem(
                "inertia",
                link,
                f"principal moments {_fmt(moments)} kg·m² violate the triangle inequality",
            )
        ]
    return []


def _fmt(values: np.ndarray) -> str:
    return ", ".join(f"{v:.3g}" for v in values)
