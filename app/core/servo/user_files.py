"""The user's own servo files as the studio keeps them: the TOML text of each file uploaded,
kept with the servo choice (`ServoChoice.user_servos`) and so with the project, and read again
(checked again) wherever the choice is resolved into parts, a project's open included.

A file holds the fields of a catalogue record (app.core.servo.catalogue: one record or
[[servo]] tables, every figure with its source). Bounded: a file is at most
MAX_FILE_BYTES of UTF-8 TOML, at most MAX_FILES files, keys short names; a key already in the
catalogue or in another of the user's files is refused with one line naming it.
"""

from __future__ import annotations

import dataclasses
import functools
import re
from collections.abc import Sequence

from app.core import input_gate
from app.core.servo.catalogue import (
    ServoCatalogueError,
    ServoRecord,
    records_from_toml,
    with_user_servos,
)

MAX_FILE_BYTES = 64 * 1024
"""Largest user servo file [bytes] (a record is ≈ 1.5 kB: room for ~40)."""
MAX_FILES = 16
"""Most user servo files kept at once."""
MAX_NAME_CHARS = 100
"""Longest file name, maker or model kept."""
KEY = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.\-]{0,39}")
"""A servo key: what the dropdown, servo.toml and the CLI name it by."""


@dataclasses.dataclass(frozen=True)
class UserServoFile:
    """One servo file the user added: its name (no folders) and its TOML text."""

    name: str
    text: str


def user_file(name: str, content: bytes) -> UserServoFile:
    """An uploaded file, checked (size, UTF-8, TOML, every record's fields and sources); raises
    ServoCatalogueError with one line naming what is wrong."""
    shown = (name.replace("\\", "/").rsplit("/", 1)[-1] or "servos.toml")[:MAX_NAME_CHARS]
    if len(content) > MAX_FILE_BYTES:
        raise ServoCatalogueError(
            f"{shown} is {len(content)} bytes; a servo file over {MAX_FILE_BYTES // 1024} KiB "
            "is refused"
        )
    text = input_gate.decode_text(content, shown, ServoCatalogueError)
    file = UserServoFile(shown, text)
    records(file)
    return file


@functools.lru_cache(maxsize=64)
def records(file: UserServoFile) -> tuple[ServoRecord, ...]:
    """The checked records of `file` (read once per text)."""
    if len(file.text.encode("utf-8")) > MAX_FILE_BYTES:
        raise ServoCatalogueError(
            f"{file.name}: over {MAX_FILE_BYTES // 1024} KiB; a servo file that large is refused"
        )
    data = input_gate.parse_toml(file.text, file.name, ServoCatalogueError)
    found = records_from_toml(data, file.name)
    for record in found:
        if not KEY.fullmatch(record.key):
            raise ServoCatalogueError(
                f"{file.name}: key {record.key[:MAX_NAME_CHARS]!r} is not a servo key; use at "
                "most 40 letters, digits, '_', '.' or '-'"
            )
        for label, value in (("maker", record.maker), ("model", record.model)):
            if len(value) > MAX_NAME_CHARS:
                raise ServoCatalogueError(
                    f"{file.name} [{record.key}]: {label} is {len(value)} characters; give at "
                    f"most {MAX_NAME_CHARS}"
                )
    return tuple(found)


def with_user_files(
    catalogue: dict[str, ServoRecord], files: Sequence[UserServoFile]
) -> dict[str, ServoRecord]:
    """The catalogue and the records of `files` (ServoCatalogueError for too many files, a bad
    record, or a key used twice)."""
    if not files:
        return catalogue
    if len(files) > MAX_FILES:
        raise ServoCatalogueError(
            f"{len(files)} user servo files; at most {MAX_FILES} are kept, merge some into one"
        )
    merged = catalogue
    for file in files:
        merged = with_user_servos(merged, list(records(file)))
    return merged


def adding(files: Sequence[UserServoFile], new: UserServoFile) -> tuple[UserServoFile, ...]:
    """`files` with `new` added, or in place of the file of the same name (an upload of a
    corrected file replaces it)."""
    kept = [f for f in files if f.name != new.name]
    return (*kept, new)
