"""What a mesh file must be before trimesh sees it: a known, uncompressed format, bounded size.

trimesh decompresses `.bz2`/`.gz`/`.zip` meshes whole in memory and trusts a binary STL's
triangle count; a 1.5 KB file can thus claim gigabytes. Here:

- compressed meshes (.gz .bz2 .xz .zip .zst .7z .tar .tgz .lzma, also inside a double suffix
  such as `.stl.gz`) are refused: unpack them first;
- only STL, OBJ, DAE, PLY, OFF and GLB are read (GLTF is not: it names further files);
- sizes: 64 MiB per file, 16 MiB for OBJ and DAE (text parsed in memory), see
  app.core.input_gate;
- a DAE (XML) declaring a DOCTYPE or entities is refused (entity expansion, external files);
- one robot reads at most MAX_ROBOT_MESH_BYTES (256 MiB) of mesh files and keeps at most
  MAX_ROBOT_TRIANGLES (4 000 000) triangles (app.core.robot.meshes);
- a binary STL's 32-bit triangle count (bytes 80–84) must match the file size
  (84 + 50·n bytes) and be ≤ MAX_MESH_TRIANGLES; a PLY header's element counts too;
- after loading, any mesh over MAX_MESH_TRIANGLES faces is dropped.

The bytes are handed to trimesh as a file object with its type, never as a path: trimesh then
has no folder to look for other files in, so a mesh cannot pull in a file from elsewhere.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

from app.core import input_gate
from app.core.input_gate import InputRefused

MAX_MESH_TRIANGLES = 1_000_000
"""Triangles in one mesh file."""
MAX_ROBOT_MESH_BYTES = 256 * 2**20
"""Mesh file bytes read for one robot (the same file at several scales counts each time)."""
MAX_ROBOT_TRIANGLES = 4_000_000
"""Triangles kept for one robot, primitives included."""
MESH_FORMATS = (".stl", ".obj", ".dae", ".ply", ".off", ".glb")
COMPRESSED_SUFFIXES = (".gz", ".bz2", ".xz", ".zip", ".zst", ".7z", ".tar", ".tgz", ".lzma")

_PLY_ELEMENT = re.compile(rb"^element\s+(\w+)\s+(\d+)\s*$", re.MULTILINE)


def read_mesh_file(path: Path) -> tuple[bytes, str]:
    """(bytes, trimesh file type) of a mesh file that passed every check; InputRefused if not."""
    suffixes = [suffix.lower() for suffix in path.suffixes]
    if any(suffix in COMPRESSED_SUFFIXES for suffix in suffixes):
        raise InputRefused(
            f"mesh {path.name} is compressed; unpack it (compressed meshes are refused, "
            "they can inflate to gigabytes)"
        )
    suffix = path.suffix.lower()
    if suffix not in MESH_FORMATS:
        raise InputRefused(
            f"mesh {path.name}: format {suffix or '(none)'} is not read; use one of "
            + ", ".join(MESH_FORMATS)
        )
    kind = input_gate.TEXT_MESH if suffix in (".obj", ".dae") else input_gate.MESH
    data = input_gate.read_bytes(path, kind)
    if suffix == ".stl":
        check_stl(data, path.name)
    elif suffix == ".dae" and (b"<!DOCTYPE" in data or b"<!ENTITY" in data):
        raise InputRefused(
            f"mesh {path.name} declares a DOCTYPE or XML entities; COLLADA needs neither, "
            "remove them (entities can expand to gigabytes or read other files)"
        )
    elif suffix == ".ply":
        check_ply_header(data, path.name)
    return data, suffix[1:]


def check_stl(data: bytes, name: str) -> int:
    """The triangle count of an STL, checked against the file's size and MAX_MESH_TRIANGLES.

    Binary STL: 80-byte header, uint32 little-endian count n, then n records of 50 bytes, so
    the file holds exactly 84 + 50·n bytes (some writers add a few trailing bytes). ASCII STL
    starts with "solid" and has one "facet" per triangle."""
    if len(data) >= 84:
        (claimed,) = struct.unpack("<I", data[80:84])
        needed = 84 + 50 * claimed
        if needed <= len(data) <= needed + 1024:
            count = claimed
        elif data.lstrip()[:5].lower() == b"solid":
            count = data.count(b"facet normal")
        else:
            raise InputRefused(
                f"mesh {name}: its binary STL header claims {claimed} triangles "
                f"({needed} bytes) but the file has {len(data)} bytes; the file is damaged"
            )
    elif data.lstrip()[:5].lower() == b"solid":
        count = data.count(b"facet normal")
    else:
        raise InputRefused(f"mesh {name}: {len(data)} bytes, too short for an STL file")
    if count > MAX_MESH_TRIANGLES:
        raise InputRefused(
            f"mesh {name} has {count} triangles, over the limit of {MAX_MESH_TRIANGLES}; "
            "simplify it (a visual mesh rarely needs more than 100 000)"
        )
    return count


def check_ply_header(data: bytes, name: str) -> None:
    """Element counts in a PLY header must not exceed MAX_MESH_TRIANGLES (nor the file)."""
    end = data.find(b"end_header")
    header = data[: end if end >= 0 else 4096]
    for element, count_text in _PLY_ELEMENT.findall(header):
        count = int(count_text)
        if count > MAX_MESH_TRIANGLES or count > len(data):
            raise InputRefused(
                f"mesh {name}: its header declares {count} {element.decode(errors='replace')} "
                f"elements, over the limit of {MAX_MESH_TRIANGLES} or the file's size"
            )
