"""Every limit the studio enforces on its inputs, in one table (docs/safety.md, `limits`).

Each row names the limit, its value with its unit, and the module that enforces it; the
values are read from those modules, so the table cannot drift from the code.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Limit:
    what: str
    value: str
    where: str
    """Module that enforces it."""


def safety_limits() -> tuple[Limit, ...]:
    from app.core import budgets, input_gate
    from app.core.collocation import settings
    from app.core.motions import continuity, params
    from app.core.robot import mesh_gate, uploads, urdf_xml
    from app.core.servo import calibration

    def mib(n: int) -> str:
        return f"{n / 2**20:g} MiB"

    rows = [
        Limit(f"{kind.name} file size", mib(kind.max_bytes), "app.core.input_gate")
        for kind in input_gate.KINDS
    ]
    rows += [
        Limit("files read", "regular files only (no pipes, devices, folders); UTF-8 text", "app.core.input_gate"),
        Limit("TOML nesting", f"≤ {input_gate.TOML_MAX_DEPTH} levels", "app.core.input_gate"),
        Limit("TOML integers", "within ±2⁶³; floats finite", "app.core.input_gate"),
        Limit("URDF links", f"≤ {urdf_xml.MAX_LINKS}", "app.core.robot.urdf_xml"),
        Limit("URDF tree depth", f"≤ {urdf_xml.MAX_TREE_DEPTH} joints from the root", "app.core.robot.urdf_xml"),
        Limit("URDF visual/collision elements", f"≤ {urdf_xml.MAX_GEOMETRIES}", "app.core.robot.urdf_xml"),
        Limit("lengths (origins, CoM)", f"|x| ≤ {urdf_xml.MAX_LENGTH_M:g} m", "app.core.robot.urdf_xml"),
        Limit("primitive sizes", f"0 < size ≤ {urdf_xml.MAX_LENGTH_M:g} m; a box has 3", "app.core.robot.urdf_xml"),
        Limit("link mass", f"0 … {urdf_xml.MAX_MASS_KG:g} kg", "app.core.robot.urdf_xml"),
        Limit("inertia entries", f"|I| ≤ {urdf_xml.MAX_INERTIA_KGM2:g} kg·m²", "app.core.robot.urdf_xml"),
        Limit("joint axis", "not zero (non-unit axes are reported)", "app.core.robot.urdf_xml"),
        Limit("compressed meshes", "refused (" + " ".join(mesh_gate.COMPRESSED_SUFFIXES) + ")", "app.core.robot.mesh_gate"),
        Limit("mesh formats", " ".join(mesh_gate.MESH_FORMATS), "app.core.robot.mesh_gate"),
        Limit("triangles per mesh", f"≤ {mesh_gate.MAX_MESH_TRIANGLES:,}", "app.core.robot.mesh_gate"),
        Limit("mesh bytes per robot", mib(mesh_gate.MAX_ROBOT_MESH_BYTES), "app.core.robot.mesh_gate"),
        Limit("triangles per robot", f"≤ {mesh_gate.MAX_ROBOT_TRIANGLES:,}", "app.core.robot.mesh_gate"),
        Limit("upload unpacked size", mib(uploads.MAX_UNPACKED_BYTES), "app.core.robot.uploads"),
        Limit("upload entries", f"≤ {uploads.MAX_ENTRIES}", "app.core.robot.uploads"),
        Limit("upload entry names", f"≤ {uploads.MAX_NAME_CHARS} characters, parts ≤ {uploads.MAX_PART_BYTES} bytes", "app.core.robot.uploads"),
        Limit("upload store", f"≤ {uploads.MAX_STORED_UPLOADS} uploads, {mib(uploads.MAX_STORE_BYTES)}; oldest removed first", "app.core.robot.uploads"),
        Limit("samples per motion", f"≤ {budgets.MAX_SAMPLES:,}", "app.core.budgets"),
        Limit("samples × values", f"≤ {budgets.MAX_SAMPLE_VALUES:,}", "app.core.budgets"),
        Limit("time step", f"{budgets.MIN_DT_S:g} … {budgets.MAX_DT_S:g} s", "app.core.budgets"),
        Limit("motion counts (squats, swings, steps)", f"≤ {params.MAX_COUNT}", "app.core.motions.params"),
        Limit("motion lengths and speeds", f"|x| ≤ {params.MAX_MAGNITUDE:g} m or m/s", "app.core.motions.params"),
        Limit("default joint speed limit", f"{continuity.DEFAULT_SPEED_LIMIT:g} rad/s", "app.core.motions.continuity"),
        Limit("gait knots", f"{settings.MIN_KNOTS} … {settings.MAX_KNOTS}", "app.core.collocation.settings"),
        Limit("IPOPT iterations", f"≤ {settings.MAX_ITER:,}", "app.core.collocation.settings"),
        Limit("measurement rows", f"≤ {calibration.MAX_MEASURED_ROWS:,}", "app.core.servo.calibration"),
    ]  # fmt: skip
    return tuple(rows)
