"""Each kind of bad robot file gets a clear, specific message (and never a traceback)."""

from __future__ import annotations

import re

import pytest

from app.core.errors import NoFeetFound, RobotLoadError, UrdfStructureError, UrdfSyntaxError
from app.core.robot.loading import load_robot
from app.core.robot.report import robot_report
from tests.conftest import tiny_biped_urdf

BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [
 <!ENTITY lol "lol">
 <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
 <!ENTITY lol9 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
]>
<robot name="&lol9;"><link name="a"/></robot>
"""


def test_the_tiny_biped_itself_loads(write_urdf):
    robot = load_robot(write_urdf(tiny_biped_urdf()))
    assert robot.n_actuated == 4
    assert [foot.link for foot in robot.feet] == ["left_foot", "right_foot"]


def test_malformed_xml(write_urdf):
    path = write_urdf(tiny_biped_urdf().replace("</robot>", ""))
    with pytest.raises(UrdfSyntaxError, match="not well-formed XML"):
        load_robot(path)


def test_billion_laughs_is_refused_before_expansion(write_urdf):
    with pytest.raises(UrdfSyntaxError, match="DTD or XML entities"):
        load_robot(write_urdf(BILLION_LAUGHS))


def test_external_entity_is_refused(write_urdf):
    text = '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]><robot name="&x;"/>'
    with pytest.raises(UrdfSyntaxError, match="refused"):
        load_robot(write_urdf(text))


def test_joint_with_missing_parent_link(write_urdf):
    text = tiny_biped_urdf().replace('<parent link="left_thigh"/>', '<parent link="left_thighh"/>')
    with pytest.raises(
        UrdfStructureError, match="left_knee.*parent link 'left_thighh', which does not exist"
    ):
        load_robot(write_urdf(text))


def test_kinematic_cycle(write_urdf):
    # pelvis -> thigh -> shin, and shin -> pelvis: the pelvis gets a parent, a cycle with no root.
    extra = (
        '<joint name="loop" type="fixed"><parent link="left_shin"/><child link="pelvis"/></joint>'
    )
    with pytest.raises(UrdfStructureError, match="kinematic cycle"):
        load_robot(write_urdf(tiny_biped_urdf(extra)))


def test_link_with_two_parents(write_urdf):
    extra = '<joint name="second" type="fixed"><parent link="right_shin"/><child link="left_foot"/></joint>'
    with pytest.raises(UrdfStructureError, match="child of two joints"):
        load_robot(write_urdf(tiny_biped_urdf(extra)))


def test_two_roots(write_urdf):
    extra = '<link name="floating_box"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    with pytest.raises(UrdfStructureError, match="2 root links .*pelvis.*floating_box"):
        load_robot(write_urdf(tiny_biped_urdf(extra)))


def test_missing_mesh_loads_and_is_reported(write_urdf):
    path = write_urdf(tiny_biped_urdf(foot_geometry='<mesh filename="meshes/foot.stl"/>'))
    robot = load_robot(path)
    report = robot_report(robot)
    assert {m["uri"] for m in report.missing_meshes} == {"meshes/foot.stl"}
    assert "file not found" in report.missing_meshes[0]["reason"]
    assert any(p.kind == "mesh" for p in report.problems)


def test_unresolvable_package_uri_is_reported(write_urdf):
    path = write_urdf(
        tiny_biped_urdf(foot_geometry='<mesh filename="package://no_such_pkg/meshes/foot.stl"/>')
    )
    report = robot_report(load_robot(path))
    reasons = [m["reason"] for m in report.missing_meshes]
    assert len(reasons) == 2 and all("package 'no_such_pkg' not found" in r for r in reasons)


@pytest.mark.parametrize("mass", ["-1.0", "-0.001"])
def test_negative_mass_is_refused(write_urdf, mass):
    text = tiny_biped_urdf().replace(
        '<link name="left_shin"><inertial><mass value="0.3"/>',
        f'<link name="left_shin"><inertial><mass value="{mass}"/>',
    )
    with pytest.raises(UrdfStructureError, match=f"left_shin.*negative mass {float(mass):g} kg"):
        load_robot(write_urdf(text))


def test_zero_mass_link_is_reported(write_urdf):
    text = tiny_biped_urdf().replace(
        '<link name="left_shin"><inertial><mass value="0.3"/>',
        '<link name="left_shin"><inertial><mass value="0"/>',
    )
    report = robot_report(load_robot(write_urdf(text)))
    assert [p.subject for p in report.problems if p.kind == "mass"] == ["left_shin"]


def test_zero_total_mass_is_refused(write_urdf):
    text = tiny_biped_urdf()
    for mass in ("2.0", "0.4", "0.3", "0.1"):
        text = text.replace(f'<mass value="{mass}"/>', '<mass value="0"/>')
    with pytest.raises(UrdfStructureError, match="total mass is 0 kg"):
        load_robot(write_urdf(text))


def test_inertia_violating_triangle_inequality_is_reported(write_urdf):
    bad = '<inertia ixx="0.001" iyy="0.001" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
    text = tiny_biped_urdf().replace(
        '<link name="left_thigh"><inertial><mass value="0.4"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/>',
        f'<link name="left_thigh"><inertial><mass value="0.4"/>{bad}',
    )
    problems = robot_report(load_robot(write_urdf(text))).problems
    assert [(p.kind, p.subject) for p in problems] == [("inertia", "left_thigh")]
    assert "triangle inequality" in problems[0].message


def test_no_feet_found(write_urdf):
    # One leg only: nothing stands on the right side.
    text = tiny_biped_urdf()
    start = text.index('<link name="right_thigh">')
    text = text[:start] + "</robot>\n"
    with pytest.raises(NoFeetFound, match="no feet found in 'tiny'.*name the two foot links"):
        load_robot(write_urdf(text))


def test_feet_can_be_named_by_the_user(write_urdf):
    robot = load_robot(write_urdf(tiny_biped_urdf()), feet=("right_shin", "left_shin"))
    assert [(f.side, f.link) for f in robot.feet] == [
        ("left", "left_shin"),
        ("right", "right_shin"),
    ]


def test_unknown_foot_name(write_urdf):
    with pytest.raises(UrdfStructureError, match="foot link 'toe' does not exist"):
        load_robot(write_urdf(tiny_biped_urdf()), feet=("toe", "right_foot"))


def test_floating_joint_in_file_is_explained(write_urdf):
    extra = '<link name="world"/><joint name="float" type="floating"><parent link="world"/><child link="pelvis"/></joint>'
    with pytest.raises(UrdfStructureError, match="floating.*studio adds the floating base"):
        load_robot(write_urdf(tiny_biped_urdf(extra)))


def test_not_a_urdf(write_urdf):
    with pytest.raises(UrdfStructureError, match="top element is <sdf>"):
        load_robot(write_urdf('<sdf version="1.6"><model name="x"/></sdf>'))


def test_nan_in_numbers(write_urdf):
    text = tiny_biped_urdf().replace('<origin xyz="0 0 -0.2"/>', '<origin xyz="0 nan -0.2"/>', 1)
    with pytest.raises(UrdfStructureError, match="finite number"):
        load_robot(write_urdf(text))


@pytest.mark.parametrize(
    ("old", "new", "named"),
    [
        ('<origin xyz="0 0 -0.2"/>', '<origin xyz="0 nan -0.2"/>', "joint 'left_knee' origin xyz"),
        ('<origin xyz="0 0 -0.2"/>', '<origin xyz="0 0 0" rpy="inf 0 0"/>', "origin rpy"),
        ('<box size="0.1 0.2 0.1"/>', '<box size="0.1 nan 0.1"/>', "'pelvis' visual size"),
        ('radius="0.02"', 'radius="nan"', "'left_thigh' visual cylinder radius"),
        ('length="0.2"', 'length="x"', "'left_thigh' visual cylinder length"),
    ],
)
def test_a_bad_number_is_named_by_its_attribute(write_urdf, old, new, named):
    """The message says which attribute holds the bad number: "joint 'left_knee' is 'nan'"
    (what a NaN in a joint's origin gave) sends the user looking at the joint's limits."""
    text = tiny_biped_urdf()
    assert old in text
    with pytest.raises(UrdfStructureError, match=re.escape(named)):
        load_robot(write_urdf(text.replace(old, new, 1)))


def test_missing_file_and_unknown_name():
    with pytest.raises(RobotLoadError, match="no such file, and not a built-in robot"):
        load_robot("no_such_robot")


def test_xacro_is_explained(write_urdf):
    with pytest.raises(RobotLoadError, match="xacro"):
        load_robot(write_urdf(tiny_biped_urdf(), name="robot.urdf.xacro"))


def test_declared_loop_that_does_not_close_is_reported(write_urdf):
    # Tie the two feet together: they stand 0.10 m apart, so the loop is open by 100 mm.
    extra = '<loop_closure name="feet_tie" link_a="left_foot" link_b="right_foot" passive_joints="left_knee"/>'
    report = robot_report(load_robot(write_urdf(tiny_biped_urdf(extra))))
    assert [(p.kind, p.subject) for p in report.problems] == [("loop", "feet_tie")]
    assert "open by 100.00 mm" in report.problems[0].message
    assert report.passive_joints == ("left_knee",) and report.n_actuated == 3


def test_loop_naming_a_missing_link(write_urdf):
    extra = '<loop_closure name="bad" link_a="left_foot" link_b="nowhere" passive_joints=""/>'
    with pytest.raises(UrdfStructureError, match="loop_closure 'bad' names link 'nowhere'"):
        load_robot(write_urdf(tiny_biped_urdf(extra)))
