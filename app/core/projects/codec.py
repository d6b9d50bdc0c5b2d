"""Typed values ↔ JSON plus binary entries: how a project's dataclasses go into the zip.

`encode` walks a value (frozen dataclasses, tuples, dicts, numbers, strings, numpy arrays,
bytes) and returns JSON; every array and byte string goes to a separate entry (an `.npy`
written with allow_pickle=False, or a `.bin`) named by its place in the value, e.g.
`arrays/motion.q.npy`. `decode` is the reverse, driven by the *declared* types of the
dataclass fields, never by the file: a value of the wrong type, a missing field, a NaN where
the type does not allow one, an array of objects or of the wrong dtype kind are refused with a
`ProjectError` naming the field (`motion.q`, `keyframes[2].duration_s`).

A few fields are non-finite by design (a gait's impact loss before it is computed, the DIRCON
forces between modes); they are listed in `NONFINITE_FIELDS` and only they may hold NaN.
"""

from __future__ import annotations

import dataclasses
import functools
import io
import math
import re
import types
import typing
from typing import Any, Literal, Union

import numpy as np

from app.core.errors import StudioError

Json = Any
Blob = np.ndarray | bytes

MAX_TEXT_CHARS = 100_000
"""Longest string accepted in a manifest (names, summaries, notes)."""
MAX_ITEMS = 100_000
"""Longest list accepted in a manifest (e.g. per-sample status of a motion)."""
NONFINITE_FIELDS = frozenset(
    {
        "GaitResult.objective",
        "GaitResult.constraint_violation",
        "GaitResult.slack0",
        "GaitResult.max_abs_tau_Nm",
        "GaitResult.energy_J",
        "GaitResult.sr",
        "GaitResult.exchange_residual",
        "GaitResult.periodicity_residual",
        "GaitResult.impact_loss_J",
        "GaitResult.work_incl_impacts_J",
        "GaitResult.sr_incl_impacts",
        "GaitResult.mid_force",
        "GaitResult.velocity_correction",
        "GaitResult.lam_g",
        "GaitResult.lam_x",
        "FeedForward.qp_time_s",
        "PointResult.sr",
        "PointResult.sr_incl_impacts",
        "PointResult.max_torque_Nm",
        "PointResult.max_joint_speed_radps",
        "PointResult.energy_J",
        "PointResult.solve_s",
        "PointResult.build_s",
        "PointResult.fell",
        "PointResult.fall_time_s",
        "PointResult.max_torso_error_deg",
        "PointResult.max_tracking_error_deg",
        "PointResult.rms_joint_error_deg",
        "PointResult.servo_mass_kg",
        "PointResult.servo_cost",
        "PointResult.electrical_energy_J",
        "PointResult.servo_margin",
    }
)
"""Class.field names whose values may be NaN or infinite (everything else must be finite)."""
NONFINITE = ("nan", "inf", "-inf")
"""How encode writes a non-finite float: {"float": "nan"}."""
_ENTRY_NAME = re.compile(r"[^A-Za-z0-9_.\-\[\]]")


@dataclasses.dataclass(frozen=True)
class JsonConstant:
    """A bare NaN / Infinity / -Infinity in the manifest's JSON (not standard JSON): kept until
    the field it sits in is known, so the refusal can name it."""

    text: str

    def __repr__(self) -> str:
        return self.text


class ProjectError(StudioError):
    """A project file that cannot be written or opened; the current work is untouched."""


def encode(value: Any, where: str, blobs: dict[str, Blob]) -> Json:
    """JSON for `value`; arrays and bytes are added to `blobs` under entry names."""
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        number = float(value)
        return number if math.isfinite(number) else {"float": repr(number)}
    if isinstance(value, np.ndarray):
        name = f"arrays/{_entry(where)}.npy"
        blobs[name] = value
        return {"array": name}
    if isinstance(value, bytes):
        name = f"blobs/{_entry(where)}.bin"
        blobs[name] = value
        return {"bytes": name}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            field.name: encode(getattr(value, field.name), f"{where}.{field.name}", blobs)
            for field in dataclasses.fields(value)
            if field.init
        }
    if isinstance(value, tuple | list):
        if all(_plain(item) for item in value):
            return list(value)  # as the item by item path writes them, without its calls
        return [encode(item, f"{where}[{i}]", blobs) for i, item in enumerate(value)]
    if isinstance(value, dict):
        return {str(k): encode(v, f"{where}.{k}", blobs) for k, v in value.items()}
    raise ProjectError(f"{where}: cannot store a {type(value).__name__} in a project")


def _plain(item: object) -> bool:
    """A list item that JSON holds as it is (a string, an int, a bool, a finite float): a
    feed-forward's 1 000 sample statuses went one encode call each (a third of a save's
    Python time)."""
    kind = type(item)
    return kind is str or kind is int or kind is bool or (kind is float and math.isfinite(item))  # type: ignore[arg-type]


def _entry(where: str) -> str:
    return _ENTRY_NAME.sub("_", where)[:180]


@dataclasses.dataclass(frozen=True)
class Reader:
    """Decodes JSON by declared types; `blob(name)` returns the bytes of a zip entry,
    `array(name, where)` (when given) the array of an `.npy` entry read straight into its own
    memory (else `read_npy` of its bytes)."""

    blob: typing.Callable[[str], bytes]
    array: typing.Callable[[str, str], np.ndarray] | None = None

    def decode(self, tp: Any, data: Json, where: str, owner: str = "") -> Any:
        """A value of type `tp` from `data`; `owner` is "Class.field" for the finite check."""
        origin = typing.get_origin(tp)
        if origin in (Union, types.UnionType):
            options = [a for a in typing.get_args(tp) if a is not type(None)]
            if data is None and len(options) < len(typing.get_args(tp)):
                return None
            if len(options) != 1:
                raise ProjectError(f"{where}: unsupported union type {tp}")  # our bug, not input
            return self.decode(options[0], data, where, owner)
        if origin is Literal:
            if data not in typing.get_args(tp) or not isinstance(data, str | int | bool):
                allowed = ", ".join(repr(a) for a in typing.get_args(tp))
                raise ProjectError(f"{where} is {_show(data)}; give one of {allowed}")
            return data
        if tp is bool:
            if not isinstance(data, bool):
                raise ProjectError(f"{where} is {_show(data)}; give true or false")
            return data
        if tp is int:
            if not isinstance(data, int) or isinstance(data, bool) or abs(data) >= 2**63:
                raise ProjectError(f"{where} is {_show(data)}; give a whole number")
            return data
        if tp is float:
            return self._float(data, where, owner)
        if tp is str:
            if not isinstance(data, str) or len(data) > MAX_TEXT_CHARS:
                raise ProjectError(f"{where} is {_show(data)}; give a text")
            return data
        if tp is bytes:
            return self.blob(self._entry_of(data, "bytes", where))
        if tp is np.ndarray:
            return self._array(data, where, owner)
        if origin is tuple:
            return self._tuple(tp, data, where, owner)
        if origin is dict:
            _, value_type = typing.get_args(tp)
            if not isinstance(data, dict):
                raise ProjectError(f"{where} is {_show(data)}; give a table")
            return {
                str(k): self.decode(value_type, v, f"{where}.{k}", owner) for k, v in data.items()
            }
        if isinstance(tp, type) and dataclasses.is_dataclass(tp):
            return self._dataclass(tp, data, where)
        raise ProjectError(f"{where}: cannot read a {tp} from a project")  # our bug, not input

    def _float(self, data: Json, where: str, owner: str) -> float:
        if isinstance(data, JsonConstant):
            value = float(data.text.replace("Infinity", "inf"))
        elif isinstance(data, dict) and data.keys() == {"float"} and data["float"] in NONFINITE:
            value = float(data["float"])
        elif isinstance(data, int | float) and not isinstance(data, bool):
            value = float(data)
        else:
            raise ProjectError(f"{where} is {_show(data)}; give a number")
        if not math.isfinite(value) and owner not in NONFINITE_FIELDS:
            raise ProjectError(f"{where} is {value}; give a finite number")
        return value

    def _tuple(self, tp: Any, data: Json, where: str, owner: str) -> tuple:
        args = typing.get_args(tp)
        if not isinstance(data, list) or len(data) > MAX_ITEMS:
            raise ProjectError(f"{where} is {_show(data)}; give a list")
        if len(args) == 2 and args[1] is Ellipsis:
            kinds = set(map(type, data))  # plain items are checked at once, in C loops
            if args[0] is float and kinds <= {float, int}:
                numbers = tuple(map(float, data))
                if all(map(math.isfinite, numbers)):
                    return numbers
            plain = args[0] in (str, bool) and kinds <= {args[0]}
            if plain and (args[0] is bool or max(map(len, data), default=0) <= MAX_TEXT_CHARS):
                return tuple(data)  # plain texts or booleans: nothing more to check
            return tuple(
                self.decode(args[0], item, f"{where}[{i}]", owner) for i, item in enumerate(data)
            )
        if len(data) != len(args):
            raise ProjectError(f"{where} has {len(data)} values; give {len(args)}")
        return tuple(
            self.decode(arg, item, f"{where}[{i}]", owner)
            for i, (arg, item) in enumerate(zip(args, data, strict=True))
        )

    def _dataclass(self, cls: type, data: Json, where: str) -> Any:
        if not isinstance(data, dict):
            raise ProjectError(f"{where} is {_show(data)}; give a table of {cls.__name__} fields")
        hints = _type_hints(cls)
        values = {}
        for field in dataclasses.fields(cls):
            if not field.init:
                continue
            if field.name not in data:
                if (
                    field.default is dataclasses.MISSING
                    and field.default_factory is dataclasses.MISSING
                ):
                    raise ProjectError(f"{where}.{field.name} is missing")
                continue
            values[field.name] = self.decode(
                hints[field.name],
                data[field.name],
                f"{where}.{field.name}",
                f"{cls.__name__}.{field.name}",
            )
        try:
            return cls(**values)
        except StudioError as error:
            raise ProjectError(f"{where}: {error}") from None
        except (TypeError, ValueError) as error:
            raise ProjectError(f"{where}: not a valid {cls.__name__}: {error}") from None

    def _entry_of(self, data: Json, key: str, where: str) -> str:
        if not isinstance(data, dict) or set(data) != {key} or not isinstance(data[key], str):
            raise ProjectError(f"{where} is {_show(data)}; expected a reference to a stored {key}")
        return data[key]

    def _array(self, data: Json, where: str, owner: str) -> np.ndarray:
        entry = self._entry_of(data, "array", where)
        array = self.array(entry, where) if self.array else read_npy(self.blob(entry), where)
        if array.dtype.kind == "f" and owner not in NONFINITE_FIELDS and not all_finite(array):
            raise ProjectError(f"{where} contains NaN or infinite values; give finite numbers")
        return array


_type_hints = functools.cache(typing.get_type_hints)
"""A dataclass's field types, resolved once per class (resolving costs ~1 ms a class)."""

FINITE_CHECK_CHUNK = 1 << 20
"""Values checked at a time by `all_finite` (its temporary is this many booleans)."""


def all_finite(array: np.ndarray) -> bool:
    """np.all(np.isfinite(array)) without a temporary of the array's size."""
    flat = array.reshape(-1, order="A")  # a view of a contiguous array
    return all(
        bool(np.isfinite(flat[i : i + FINITE_CHECK_CHUNK]).all())
        for i in range(0, flat.size, FINITE_CHECK_CHUNK)
    )


READ_CHUNK_BYTES = 4 << 20
"""Bytes copied at a time from an entry into its array."""


def read_npy(raw: bytes, where: str) -> np.ndarray:
    """The array of an `.npy` entry's bytes (see `read_npy_stream`)."""
    return read_npy_stream(io.BytesIO(raw), len(raw), where)


def read_npy_stream(stream: typing.Any, size: int, where: str) -> np.ndarray:
    """The array of an `.npy` entry of `size` bytes read from `stream` (a binary file object
    with read, readinto and tell: a zip entry, a BytesIO), its header checked
    against that size *before* anything is allocated (a header that declares a huge shape, a
    byte count that does not match, objects or a dtype that is not numbers or booleans are
    refused with one line), then read straight into the array's own memory in chunks: the
    array is the only copy (a Fortran-order one, which this studio never writes, is made
    C-contiguous: one copy more)."""
    try:
        shape, fortran, dtype, header_bytes = _npy_header(stream)
    except (ValueError, OSError, EOFError, SyntaxError, TypeError) as error:
        raise ProjectError(f"{where}: not a readable array ({error})") from None
    body_bytes = size - header_bytes
    if dtype.hasobject:
        raise ProjectError(f"{where}: not a readable array (it holds Python objects)")
    if dtype.kind not in "fiub":
        raise ProjectError(f"{where}: an array of numbers or booleans is needed")
    count = math.prod(shape)
    if count * dtype.itemsize != body_bytes:
        raise ProjectError(
            f"{where}: its header declares shape {tuple(shape)} of {dtype} "
            f"({count * dtype.itemsize} bytes) but the entry holds {body_bytes} bytes"
        )
    flat = np.empty(count, dtype=dtype)
    target = flat.view(np.uint8).data
    filled = 0
    while filled < body_bytes:
        got = stream.readinto(target[filled : filled + READ_CHUNK_BYTES])
        if not got:
            raise ProjectError(f"{where}: the entry ends before its {body_bytes} bytes")
        filled += got
    array = flat.reshape(shape, order="F" if fortran else "C")
    return np.ascontiguousarray(array) if fortran and array.ndim > 1 else array


_NPY_MAGIC = b"\x93NUMPY"
_NPY_HEADER = re.compile(
    rb"\{'descr': '([<>|=][fiub][1248])', 'fortran_order': (False|True), "
    rb"'shape': \(((?:[0-9]{1,19}, )*(?:[0-9]{1,19},?)?)\), \} *\n"
)
"""The header `np.save` writes for an array of numbers or booleans, read without numpy's
`ast.literal_eval` (a third of a small array's read); any other header goes to numpy's
parser, which refuses what it cannot read."""


def _npy_header(stream: typing.Any) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """(shape, Fortran order, dtype, bytes before the data) of the `.npy` at the stream's start
    (numpy's format 1.0 or 2.0)."""
    lead = stream.read(10)
    if len(lead) < 10 or lead[:6] != _NPY_MAGIC:
        raise ValueError("it does not start as an .npy array")
    if lead[6:8] == b"\x01\x00":
        prefix, header_size = 10, int.from_bytes(lead[8:10], "little")
    elif lead[6:8] == b"\x02\x00":
        more = stream.read(2)
        prefix, header_size = 12, int.from_bytes(lead[8:10] + more, "little")
    else:
        raise ValueError(f".npy format version {lead[6]}.{lead[7]} is not read")
    if header_size > NPY_MAX_HEADER_BYTES:
        raise ValueError(f"its header of {header_size} bytes is too long")
    header = stream.read(header_size)
    if len(header) != header_size:
        raise EOFError("the entry ends inside its header")
    match = _NPY_HEADER.fullmatch(header)
    if match is None:  # not as np.save writes it: numpy's own parser decides
        again = io.BytesIO(lead[:prefix] + header)
        version = np.lib.format.read_magic(again)
        parse = (
            np.lib.format.read_array_header_1_0
            if version == (1, 0)
            else np.lib.format.read_array_header_2_0
        )
        shape, fortran, dtype = parse(again)  # its own limit is NPY_MAX_HEADER_BYTES too
        return tuple(shape), bool(fortran), dtype, prefix + header_size
    descr, fortran, dims = match.groups()
    shape = tuple(int(d) for d in dims.split(b",") if d.strip())
    return shape, fortran == b"True", np.dtype(descr.decode()), prefix + header_size


NPY_MAX_HEADER_BYTES = 10_000
"""Longest `.npy` header read (numpy's own limit for untrusted files)."""


def _show(data: Json) -> str:
    text = repr(data)
    return text if len(text) <= 40 else text[:37] + "…"
