"""Servo parts as sweep parameters: which catalogue servo the leg joints get (categorical) and
its firmware kp (discrete), swept or fixed for every point.

    [part]                      # fixed for every point (needs simulate = true)
    servo = "mx106"             # a catalogue servo the simulation can run
    kp = 32                     # optional: the firmware's P gain (default: the record's)

    [[parameter]]
    name = "servo"
    kind = "part"
    choices = ["mx64", "mx106"] # categorical: each point takes one (a grid takes each)

    [[parameter]]
    name = "kp"
    kind = "part"
    min = 16
    max = 64                    # whole numbers (the firmware's register)
    levels = 3

With a part, every leg joint (those the uniform preset compensates) runs the part's motor law
in the simulation (app.core.simulation.part_law; the other joints stay rigid), and
compensation on is eq 7 with k = 1/K of the part and its kp (K = kt·vin·error_gain·kp/R), its
dead band the record's backlash unless the sweep gives dead_band_deg. A categorical value is
stored as the index of its choice (the results tables and the studio show the servo's key).

The user's own servo files (app.core.servo.user_files) may be named too: `servo_files =
["my_servos.toml"]` in a sweep file (paths from the sweep file's folder), read by
`read_sweep_toml` into the data's `user_servos` (name and text of each file, so a project keeps
them), checked like every user servo file; their servos join the choices, and each point's
`PartSetup` carries its servo's record (picklable data) to the worker.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from pathlib import Path
from typing import Any

from app.core.errors import refuse_unknown_keys
from app.core.sweeps.robot_variants import SweepSpecError

PART_NAMES = ("servo", "kp")
"""The part parameters a sweep can vary (kind = "part") or fix ([part])."""
MAX_CHOICES = 64


MAX_USER_JSON_CHARS = 80_000
"""Most characters the user servo files of one sweep take as JSON (a project keeps them in its
sweep's spec, a text of at most 100 000 characters: app.core.projects.codec)."""


@functools.cache
def _builtin_catalogue() -> dict[str, Any]:
    from app.core.servo.catalogue import load_catalogue

    return load_catalogue()


def runnable_servos(files: tuple[Any, ...] = ()) -> dict[str, Any]:
    """The servos the simulation can run (a motor model and firmware): the built-in
    catalogue's and those of the user's `files` (UserServoFile)."""
    from app.core.servo.choice import simulatable

    return simulatable(offered_servos(files))


def offered_servos(files: tuple[Any, ...] = ()) -> dict[str, Any]:
    """The built-in catalogue with the records of the user's `files`; SweepSpecError for a
    file that cannot be used (one line naming it)."""
    from app.core.errors import StudioError
    from app.core.servo.user_files import with_user_files

    try:
        return with_user_files(_builtin_catalogue(), files)
    except StudioError as error:
        raise SweepSpecError(f"user servos: {error}") from None


def user_servo_files(value: Any, source: str) -> tuple[Any, ...]:
    """The data's `user_servos` ([{name, text}, ...]) as checked UserServoFiles."""
    from app.core.servo.user_files import MAX_FILES, UserServoFile

    if not isinstance(value, list) or len(value) > MAX_FILES:
        raise SweepSpecError(
            f"{source}: user_servos is a list of at most {MAX_FILES} {{name, text}} tables"
        )
    files = []
    for i, entry in enumerate(value):
        if (
            not isinstance(entry, dict)
            or set(entry) != {"name", "text"}
            or not all(isinstance(entry[k], str) for k in ("name", "text"))
        ):
            raise SweepSpecError(f"{source}: user_servos {i + 1} is not a {{name, text}} table")
        files.append(UserServoFile(entry["name"], entry["text"]))
    size = len(json.dumps(value))
    if size > MAX_USER_JSON_CHARS:
        raise SweepSpecError(
            f"{source}: the user servo files take {size} characters as a project keeps them; "
            f"at most {MAX_USER_JSON_CHARS} (give the sweep only the servos it chooses from)"
        )
    offered_servos(tuple(files))  # every record checked, no key taken twice
    return tuple(files)


def read_servo_files(value: Any, sweep_file: Path) -> list[dict[str, str]]:
    """A sweep file's `servo_files` (paths, relative ones from the sweep file's folder) read
    into `user_servos` data ([{name, text}]); each file checked as the studio checks an
    upload (app.core.servo.user_files.user_file): one line naming what is wrong."""
    where = f"{sweep_file}: servo_files"
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise SweepSpecError(f'{where}: give a list of file paths, servo_files = ["mine.toml"]')
    paths = [Path(n) if Path(n).is_absolute() else sweep_file.parent / n for n in value]
    return read_servo_paths(paths, where)


def read_servo_paths(paths: list[Path], where: str) -> list[dict[str, str]]:
    """User servo files (`servo_files`, or the sweep command's --servo-file) read into
    `user_servos` data ([{name, text}]), each checked as an upload is; SweepSpecError of one
    line starting with `where` and naming the file and what is wrong."""
    from app.core import input_gate
    from app.core.errors import StudioError
    from app.core.servo.user_files import MAX_FILE_BYTES, MAX_FILES, user_file

    if len(paths) > MAX_FILES:
        raise SweepSpecError(f"{where}: {len(paths)} files; at most {MAX_FILES}")
    kind = input_gate.FileKind("servo TOML", MAX_FILE_BYTES)
    out = []
    for path in paths:
        try:
            file = user_file(path.name, input_gate.read_bytes(path, kind, SweepSpecError))
        except StudioError as error:
            raise SweepSpecError(f"{where}: {error}") from None
        out.append({"name": file.name, "text": file.text})
    return out


def check_servo(key: Any, where: str, files: tuple[Any, ...] = ()) -> str:
    """`key` if it names a servo the simulation can run; SweepSpecError naming the ones it can."""
    servos = runnable_servos(files)
    if not isinstance(key, str) or key not in servos:
        raise SweepSpecError(
            f"{where}: servo {key!r} is not a catalogue servo the simulation can run; give one "
            f"of {', '.join(sorted(servos))}"
        )
    return key


def check_kp(value: Any, where: str) -> float:
    from app.core.servo.parts import KP_MAX

    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SweepSpecError(f"{where}: kp = {value!r}; give a finite number")
    if not 1.0 <= value <= KP_MAX:
        raise SweepSpecError(f"{where}: kp = {value:g}; the firmware's range is 1 … {KP_MAX:g}")
    return float(value)


def choices_of(entry: dict[str, Any], where: str, files: tuple[Any, ...] = ()) -> tuple[str, ...]:
    """The checked `choices` of a categorical servo parameter."""
    raw = entry.get("choices")
    if not isinstance(raw, list) or not raw:
        raise SweepSpecError(
            f'{where}: servo takes choices = ["<key>", ...]: the catalogue servos to try'
        )
    if len(raw) > MAX_CHOICES:
        raise SweepSpecError(f"{where}: {len(raw)} choices; at most {MAX_CHOICES}")
    keys = tuple(check_servo(key, where, files) for key in raw)
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise SweepSpecError(f"{where}: choice(s) {', '.join(twice)} given twice")
    return keys


def fixed_part(value: Any, source: str, files: tuple[Any, ...] = ()) -> tuple[tuple[str, Any], ...]:
    """The [part] table: (("servo", key), ("kp", value)) as given."""
    if not isinstance(value, dict):
        raise SweepSpecError(f"{source}: [part] must be a table (servo, kp)")
    refuse_unknown_keys(value, PART_NAMES, SweepSpecError, f"{source}: [part]")
    out: list[tuple[str, Any]] = []
    if "servo" in value:
        out.append(("servo", check_servo(value["servo"], f"{source}: [part]", files)))
    if "kp" in value:
        out.append(("kp", check_kp(value["kp"], f"{source}: [part]")))
    return tuple(out)


def check_parts(
    parameters: tuple[Any, ...],
    servo: tuple[tuple[str, float], ...],
    part: tuple[tuple[str, Any], ...],
    source: str,
) -> None:
    """A kp needs a servo (swept or in [part]); a part's compliance is its 1/K, so the virtual
    servo's compliance cannot be set beside it."""
    swept = {p.name for p in parameters if p.kind == "part"}
    fixed = {name for name, _ in part}
    if swept & fixed:
        raise SweepSpecError(f"{source}: {', '.join(sorted(swept & fixed))} swept and in [part]")
    given = swept | fixed
    if "kp" in given and "servo" not in given:
        raise SweepSpecError(
            f'{source}: kp needs a servo: give [part] servo = "<key>" or sweep servo'
        )
    compliance = "compliance_deg_per_Nm"
    if "servo" in given and (
        any(p.name == compliance for p in parameters) or any(n == compliance for n, _ in servo)
    ):
        raise SweepSpecError(
            f"{source}: {compliance} is the virtual servo's; with a servo part the compliance "
            "is the part's 1/K (sweep kp instead)"
        )


@dataclasses.dataclass(frozen=True)
class PartSetup:
    """The servo part of a point: picklable (a key and numbers), to travel to a worker."""

    servo: str
    kp: float | None = None
    """None: the record's firmware kp."""
    dead_band_deg: float | None = None
    """None: the record's backlash."""
    records: tuple[Any, ...] = ()
    """The user's own ServoRecords the part may name (frozen dataclasses of numbers and text:
    picklable); the built-in catalogue's are read where the point runs."""

    def catalogue(self) -> dict[str, Any]:
        """The built-in catalogue with this part's user records."""
        from app.core.servo.catalogue import with_user_servos

        return with_user_servos(_builtin_catalogue(), list(self.records))

    def record(self) -> Any:
        """The ServoRecord of this part's servo."""
        return self.catalogue()[self.servo]


def leg_parts(robot: Any, part: PartSetup) -> Any:
    """ServoParts of `part` on every leg joint of `robot` (the joints the uniform preset
    compensates); StudioError (ServoPartsError) for settings the part cannot take."""
    from app.core.servo.parts import parts_from_mapping
    from app.core.servo.presets import uniform_preset

    legs = [
        name
        for name, on in zip(robot.joint_names, uniform_preset(robot).enabled, strict=True)
        if on
    ]
    table: dict[str, Any] = {"servo": part.servo}
    if part.kp is not None:
        table["kp"] = part.kp
    if part.dead_band_deg is not None:
        table["dead_band_deg"] = part.dead_band_deg
    return parts_from_mapping(table, legs, part.catalogue(), f"sweep part {part.servo}")
