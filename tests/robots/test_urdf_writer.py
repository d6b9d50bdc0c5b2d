"""The shared URDF writer: inertial checks and the serial leg chain helper."""

from __future__ import annotations

import pytest

from robots.urdf_writer import Link, Shape, serial_chain, write_urdf

CHAIN = (  # joint, child link, axis, lower [rad], upper [rad], effort [N·m]
    ("hip_roll", "hip", (1.0, 0.0, 0.0), -0.2, 0.9, 5.0),
    ("knee", "shank", (0.0, 1.0, 0.0), 0.0, 2.0, 7.0),
)


def chain(side_name: str):
    return serial_chain(
        side_name,
        "base",
        CHAIN,
        origins={"hip_roll": (0.0, 0.1, 0.0), "knee": (0.0, 0.0, -0.3)},
        link_masses_kg={"hip": 1.0, "shank": 2.0},
        link_shapes={"hip": [Shape("sphere", (0.05,))], "shank": [Shape("box", (1, 1, 1))]},
        velocity_rad_s=4.0,
        sole_drop_m=0.05,
    )


def test_link_with_mass_and_no_shapes_is_an_error():
    with pytest.raises(ValueError, match="'heavy' has mass 2 kg but no shapes"):
        Link("heavy", 2.0).inertial()
    with pytest.raises(ValueError, match="no shapes"):
        write_urdf("r", [Link("heavy", 2.0)], [])


def test_massless_link_without_shapes_is_a_frame():
    assert "<inertial>" not in write_urdf("r", [Link("frame", 0.0)], [])


def test_serial_chain_names_parents_and_sole():
    links, joints = chain("left")
    assert [link.name for link in links] == ["left_hip", "left_shank", "left_sole"]
    assert [link.mass_kg for link in links] == [1.0, 2.0, 0.0]
    assert [(j.name, j.parent, j.child, j.kind) for j in joints] == [
        ("left_hip_roll", "base", "left_hip", "revolute"),
        ("left_knee", "left_hip", "left_shank", "revolute"),
        ("left_sole_fixed", "left_shank", "left_sole", "fixed"),
    ]
    assert [j.xyz for j in joints] == [(0.0, 0.1, 0.0), (0.0, 0.0, -0.3), (0.0, 0.0, -0.05)]
    assert [(j.effort_Nm, j.velocity_rad_s) for j in joints[:2]] == [(5.0, 4.0), (7.0, 4.0)]


def test_serial_chain_mirrors_limits_about_x_and_z_on_the_right():
    left, right = chain("left")[1], chain("right")[1]
    assert [(j.lower, j.upper) for j in left[:2]] == [(-0.2, 0.9), (0.0, 2.0)]
    assert [(j.lower, j.upper) for j in right[:2]] == [(-0.9, 0.2), (0.0, 2.0)]
