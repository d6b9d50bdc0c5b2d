"""The catalogue of built-in robots: name -> generated URDF shipped with the studio."""

from __future__ import annotations

import dataclasses
from pathlib import Path

ROBOTS_DIR = Path(__file__).resolve().parent


@dataclasses.dataclass(frozen=True)
class BuiltinRobot:
    name: str
    summary: str
    source: str
    """Which paper and tables the numbers come from."""

    @property
    def folder(self) -> Path:
        return ROBOTS_DIR / self.name

    @property
    def urdf_path(self) -> Path:
        return self.folder / f"{self.name}.urdf"


BUILTIN_ROBOTS: dict[str, BuiltinRobot] = {
    robot.name: robot
    for robot in (
        BuiltinRobot(
            name="servo_biped",
            summary="Roban-like servo humanoid, 12 leg DOF, 6.6 kg, 0.70 m",
            source="spring-compensation paper (Wang et al. 2023) and Roban leg dimensions",
        ),
        BuiltinRobot(
            name="dircon_biped",
            summary="10-DOF 1.211 m, 18.532 kg biped of the symmetric gait paper",
            source="symmetric-gait paper (Chen et al. 2023), Tables 1 and 2",
        ),
        BuiltinRobot(
            name="hybrid_leg_biped",
            summary="two Cassie-like hybrid legs with closed four-bar knee and ankle chains",
            source="hybrid-leg paper (Che et al. 2022), link lengths of the authors' code",
        ),
    )
}

DEFAULT_ROBOT = "servo_biped"
