"""The studio's error family: every failure the user can cause says what was wrong and what to do.

The UI shows these as notifications, the CLI prints `str(error)` as one line and exits non-zero.
Anything else escaping the core is a bug in the studio, not in the user's input.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence


class StudioError(Exception):
    """Base of every error caused by input: a file, a value, a request."""


class RobotLoadError(StudioError):
    """A robot description could not be loaded; the previously loaded robot stays in place."""


class UrdfSyntaxError(RobotLoadError):
    """The file is not well-formed XML, or refuses to be parsed safely (entities, DTD)."""


class UrdfStructureError(RobotLoadError):
    """The XML is well formed but does not describe a kinematic tree (missing links, cycles…)."""


class NoFeetFound(RobotLoadError):
    """No pair of left/right foot frames could be found, and none was given."""


class UploadError(StudioError):
    """An uploaded file was refused (too large, wrong kind, unsafe archive)."""


def finite_float(cell: str, where: str, error: type[StudioError] = StudioError) -> float:
    """float(cell), or `error` saying where the cell is and what was wrong with it."""
    try:
        value = float(cell)
    except ValueError:
        raise error(f"{where} {cell!r} is not a number") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise error(f"{where} is {cell!r}; give a finite number")
    return value


def refuse_unknown_keys(
    keys: Iterable[str], known: Sequence[str], error: type[StudioError], where: str
) -> None:
    """`error` naming every one of `keys` (a table's) that is not in `known`, and the known
    ones (a typo must never silently drop a value); `where` (a file, a table) starts the line."""
    unknown = sorted(set(keys) - set(known))
    if unknown:
        raise error(f"{where}: unknown key(s) {', '.join(unknown)}; known: {', '.join(known)}")


def refuse_unknown_joints(
    names: Iterable[str],
    joint_names: Sequence[str],
    error: type[StudioError] = StudioError,
    *,
    where: str = "",
    robot: str = "this robot",
) -> None:
    """`error` naming every one of `names` that is not in `joint_names`, and the joints there
    are (a typo must never silently drop a value). `where` (a file, a table) starts the line."""
    unknown = [name for name in names if name not in joint_names]
    if unknown:
        raise error(
            f"{where + ': ' if where else ''}no joint named {', '.join(map(repr, unknown))} on "
            f"{robot}; its joints are: {', '.join(joint_names)}"
        )
