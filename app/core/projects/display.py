"""How the studio was shown: the camera, the Display, Playback and Pose toggles, the ghosts and
the plots' choice of joints, as one typed, versioned value (the `display` section of a project).

A project saved before this section existed opens with `DisplaySettings()` (the studio's
defaults). Every value is checked on construction, so a manifest with a bad one is refused by
the codec with a message naming the field (`project.display: speed is 3.0; give one of …`).
"""

from __future__ import annotations

import dataclasses
import math

from app.core.errors import StudioError

DISPLAY_VERSION = 1
"""Bump when a field of DisplaySettings changes meaning; older versions stay readable."""
SPEEDS = (0.25, 0.5, 1.0, 2.0)
"""The playback speeds the Playback panel offers (× real time)."""
GHOST_NAMES = ("planned", "command", "without", "with", "sim_without", "sim_with")
"""The ghosts the studio draws (app.views.ghosts_view.GHOSTS, same order)."""
DEFAULT_GHOSTS = ("planned", "command")
"""Shown unless hidden: the plan and one comparison (the compensated servo command); five
translucent ghosts at once overlap into a blur."""
ALL_JOINTS = "all joints"
"""The plots' joint choice that shows every joint (else "left leg", "right leg" or a joint)."""
MAX_CAMERA_M = 1.0e4
"""Farthest camera position or look-at point accepted [m] from the origin."""


class DisplayError(StudioError):
    """A display setting out of its range (the codec adds where it was read)."""


@dataclasses.dataclass(frozen=True)
class CameraView:
    """One tab's camera, world frame (z up)."""

    position: tuple[float, float, float]
    """Camera position [m]."""
    look_at: tuple[float, float, float]
    """The point the camera orbits and looks at [m]."""
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    """Up direction (any non-zero length)."""
    fov_deg: float = 75.0
    """Vertical field of view [°]."""

    def __post_init__(self) -> None:
        for name in ("position", "look_at", "up"):
            value = getattr(self, name)
            if len(value) != 3 or not all(math.isfinite(x) for x in value):
                raise DisplayError(f"camera.{name} is {value}; give three finite numbers")
            if max(abs(x) for x in value) > MAX_CAMERA_M:
                raise DisplayError(
                    f"camera.{name} is {value}; give values within ±{MAX_CAMERA_M:g} m"
                )
        if math.dist(self.position, self.look_at) < 1e-6:
            raise DisplayError("camera.look_at equals camera.position; the view has no direction")
        if math.hypot(*self.up) < 1e-9:
            raise DisplayError("camera.up is zero; give a direction")
        if not (math.isfinite(self.fov_deg) and 1.0 <= self.fov_deg <= 170.0):
            raise DisplayError(f"camera.fov_deg is {self.fov_deg}; give 1 to 170 degrees")

    def near(self, other: CameraView | None, tol: float = 1e-4) -> bool:
        """The same view up to `tol` (a tab's echo of a camera set from the studio)."""
        if other is None:
            return False
        pairs = zip(
            (*self.position, *self.look_at, *_unit(self.up), self.fov_deg),
            (*other.position, *other.look_at, *_unit(other.up), other.fov_deg),
            strict=True,
        )
        return all(abs(a - b) <= tol * max(1.0, abs(a)) for a, b in pairs)


@dataclasses.dataclass(frozen=True)
class DisplaySettings:
    """The studio's view of the work: restored with a project, never part of the results."""

    version: int = DISPLAY_VERSION
    """Format of this section."""
    camera: CameraView | None = None
    """The presenter's (last active tab's) camera; None: the studio frames the robot."""
    visual: bool = True
    """Display: visual meshes."""
    collision: bool = False
    """Display: collision meshes."""
    frames: bool = False
    """Display: link frames."""
    com: bool = True
    """Display: centre of mass."""
    dark: bool = False
    """Display: dark mode."""
    ghosts: tuple[str, ...] = DEFAULT_GHOSTS
    """The ghosts shown (names of GHOST_NAMES)."""
    traces: bool = True
    """Playback: the feet and pelvis traces."""
    follow: bool = False
    """Playback: the cameras follow the robot."""
    loop: bool = True
    """Playback: start again at the end."""
    speed: float = 1.0
    """Playback speed (× real time), one of SPEEDS."""
    plot_joints: str = ALL_JOINTS
    """Plots: which joints the torque and offset plots draw."""
    wide_plots: bool = False
    """Plots: in the wide window docked at the left."""
    handles: bool = True
    """Pose: the drag handles shown."""
    keep_com: bool = True
    """Pose: the CoM kept over the support polygon while dragging."""

    def __post_init__(self) -> None:
        if not 1 <= self.version <= DISPLAY_VERSION:
            raise DisplayError(
                f"version is {self.version}; this studio reads display settings up to version "
                f"{DISPLAY_VERSION}"
            )
        if self.speed not in SPEEDS:
            speeds = ", ".join(f"{s:g}" for s in SPEEDS)
            raise DisplayError(f"speed is {self.speed}; give one of {speeds}")
        unknown = [name for name in self.ghosts if name not in GHOST_NAMES]
        if unknown or len(set(self.ghosts)) != len(self.ghosts):
            raise DisplayError(
                f"ghosts is {self.ghosts}; give distinct names among {', '.join(GHOST_NAMES)}"
            )
        if not self.plot_joints or len(self.plot_joints) > 200:
            raise DisplayError(
                f"plot_joints is empty or too long; give a joint, a leg or {ALL_JOINTS!r}"
            )


def same_display(a: DisplaySettings, b: DisplaySettings) -> bool:
    """The same settings, cameras equal up to a browser's rounding (CameraView.near)."""
    if dataclasses.replace(a, camera=None) != dataclasses.replace(b, camera=None):
        return False
    return a.camera == b.camera or (a.camera is not None and a.camera.near(b.camera))


def _unit(v: tuple[float, float, float]) -> tuple[float, ...]:
    """`v` scaled to length 1 (a browser reports its up direction normalised)."""
    norm = math.hypot(*v)
    return tuple(x / norm for x in v)


def plot_choices(joint_names: tuple[str, ...]) -> tuple[str, ...]:
    """What the plots' joint choice may be for a robot with these joints."""
    legs = [side for side in ("left", "right") if any(n.startswith(side) for n in joint_names)]
    return (ALL_JOINTS, *(f"{side} leg" for side in legs), *joint_names)
