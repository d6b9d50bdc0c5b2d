"""Facts about a built-in robot's URDF that the robot tests share, computed with pinocchio.

Every helper takes the URDF path (or the model built from it), so each test file keeps its own
robot-specific numbers and only the measuring lives here. This is a plain module, not a test
module: pytest does not rewrite its asserts, so each carries the name of what failed.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest


def floating_model(urdf_path: Path) -> pin.Model:
    """The robot with a free-flyer root joint, as the studio loads it."""
    return pin.buildModelFromUrdf(str(urdf_path), pin.JointModelFreeFlyer())


def frame_placements(model: pin.Model, q: np.ndarray) -> pin.Data:
    """Data with the joint and frame placements at q."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return data


def geometry_bounds(
    model: pin.Model, urdf_path: Path, q: np.ndarray, links: tuple[str, ...] = ()
) -> tuple[np.ndarray, np.ndarray]:
    """World-axis bounds (min xyz, max xyz) [m] of the visual geometry at q, optionally of some links.

    Uses pinocchio's own reading of the URDF geometry (boxes, cylinders, spheres).
    """
    geom = pin.buildGeomFromUrdf(model, str(urdf_path), pin.GeometryType.VISUAL)
    data, geom_data = model.createData(), geom.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, geom, geom_data)
    lows, highs = [], []
    for obj, placement in zip(geom.geometryObjects, geom_data.oMg, strict=True):
        if links and model.frames[obj.parentFrame].name not in links:
            continue
        shape, rot = obj.geometry, placement.rotation
        if isinstance(shape, coal.Box):
            reach = np.abs(rot) @ np.asarray(shape.halfSide)
        elif isinstance(shape, coal.Cylinder):
            axis = np.abs(rot[:, 2])
            reach = axis * shape.halfLength + shape.radius * np.sqrt(np.clip(1 - axis**2, 0, 1))
        elif isinstance(shape, coal.Sphere):
            reach = np.full(3, shape.radius)
        else:
            raise AssertionError(f"unexpected geometry {type(shape).__name__}")
        lows.append(placement.translation - reach)
        highs.append(placement.translation + reach)
    return np.min(lows, axis=0), np.max(highs, axis=0)


def urdf_inertials(urdf_path: Path) -> dict[str, tuple[float, np.ndarray]]:
    """Mass [kg] and inertia matrix [kg·m²] of every massive link, read from the URDF text."""
    out = {}
    for link in ET.parse(urdf_path).getroot().iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        i = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
        matrix = np.array(
            [
                [i["ixx"], i["ixy"], i["ixz"]],
                [i["ixy"], i["iyy"], i["iyz"]],
                [i["ixz"], i["iyz"], i["izz"]],
            ]
        )
        out[link.get("name")] = (float(inertial.find("mass").get("value")), matrix)
    return out


def assert_physical(name: str, inertia: np.ndarray) -> None:
    """A rigid body's inertia: positive principal moments that satisfy the triangle inequality."""
    moments = np.linalg.eigvalsh(inertia)
    assert np.all(moments > 0.0), name
    a, b, c = moments
    assert a + b >= c * (1.0 - 1e-6), name  # triangle inequality of principal moments


def assert_every_inertia_physical(model: pin.Model, urdf_path: Path) -> None:
    """Every massive link of the URDF, and every body pinocchio merges from them, is physical."""
    for name, (mass, inertia) in urdf_inertials(urdf_path).items():
        assert mass > 0.0, name
        assert_physical(name, inertia)
    for i in range(1, model.njoints):
        assert_physical(model.names[i], model.inertias[i].inertia)


def assert_soles_flat_and_symmetric(model: pin.Model) -> None:
    """At q = 0 the sole frames are level, mirror images through the x-z plane, left at +y."""
    data = frame_placements(model, pin.neutral(model))
    left = data.oMf[model.getFrameId("left_sole")]
    right = data.oMf[model.getFrameId("right_sole")]
    for sole in (left, right):
        np.testing.assert_allclose(sole.rotation, np.eye(3), atol=1e-12)
    assert left.translation[1] == pytest.approx(-right.translation[1], abs=1e-12)
    assert left.translation[1] > 0.0
    assert left.translation[[0, 2]] == pytest.approx(right.translation[[0, 2]], abs=1e-12)
