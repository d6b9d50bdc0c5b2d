"""A checked URDF tree written back as strict URDF for pinocchio (kinematics and inertia, no
geometry): canonical_urdf.
"""

from __future__ import annotations

import numpy as np

from app.core.robot.urdf_tree import UrdfTree, matrix_rpy


def canonical_urdf(tree: UrdfTree) -> str:
    """The kinematics and inertia of a checked tree as strict URDF, without geometry.

    Real URDFs often carry what pinocchio's urdfdom parser rejects although the robot is
    perfectly defined (capsule geometry, limits without effort, numbers with trailing
    spaces). pinocchio is given this re-written description, built from values already
    checked here, so its semantics (frames, fixed-joint merging) stay pinocchio's own.
    """
    out = [f'<robot name="{_attr(tree.name)}">']
    for link in tree.links:
        out.append(f'<link name="{_attr(link)}">')
        inertial = tree.inertials.get(link)
        if inertial is not None:
            i = inertial.inertia_kgm2
            out.append(
                f'<inertial><origin xyz="{_vec(inertial.com_m)}" rpy="0 0 0"/>'
                f'<mass value="{_num(inertial.mass_kg)}"/>'
                f'<inertia ixx="{_num(i[0, 0])}" ixy="{_num(i[0, 1])}" ixz="{_num(i[0, 2])}" '
                f'iyy="{_num(i[1, 1])}" iyz="{_num(i[1, 2])}" izz="{_num(i[2, 2])}"/></inertial>'
            )
        out.append("</link>")
    for joint in tree.joints.values():
        T = joint.T_parent_joint
        out.append(
            f'<joint name="{_attr(joint.name)}" type="{joint.kind}">'
            f'<origin xyz="{_vec(T[:3, 3])}" rpy="{_vec(matrix_rpy(T[:3, :3]))}"/>'
            f'<parent link="{_attr(joint.parent)}"/><child link="{_attr(joint.child)}"/>'
        )
        if joint.kind != "fixed":
            out.append(f'<axis xyz="{_vec(joint.axis)}"/>')
            lower = joint.lower if joint.lower is not None else -np.pi
            upper = joint.upper if joint.upper is not None else np.pi
            out.append(
                f'<limit lower="{_num(lower)}" upper="{_num(upper)}" '
                f'effort="{_num(joint.effort or 0.0)}" velocity="{_num(joint.velocity or 0.0)}"/>'
            )
        out.append("</joint>")
    out.append("</robot>")
    return "\n".join(out)


def _vec(values) -> str:
    return " ".join(_num(v) for v in values)


def _num(value: float) -> str:
    return repr(float(value))


def _attr(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
