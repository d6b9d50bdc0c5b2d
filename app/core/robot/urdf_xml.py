"""Safe parsing of URDF text into a checked kinematic tree description.

The XML is parsed with defusedxml, so entity declarations ("billion laughs"), external
entities and DTDs are refused before anything is expanded. The tree is then checked the way a
robotics engineer would check it by hand: every joint names links that exist, each link has at
most one parent, there is exactly one root, there are no cycles, masses are not negative.
Only then is the text handed to pinocchio.

Limits, checked before any per-link work (a 10 000-link chain is refused in well under a
second, before pinocchio, whose recursive parser would overflow its stack on it):

    MAX_LINKS = 500 links, MAX_TREE_DEPTH = 64 joints from the root to any link,
    MAX_GEOMETRIES = 5 000 <visual>/<collision> elements.

Every number must be finite and physically sane (a robot you can build on a desk, generously):

    lengths (origins, centres of mass)  |x| ≤ 100 m
    primitive sizes (box, cylinder, sphere)  0 < size ≤ 100 m, a box has exactly 3 sizes
    mesh scale  1e-6 ≤ |s| ≤ 1e3, one or three values
    rpy angles  |a| ≤ 100 rad
    link mass  0 ≤ m ≤ 10 000 kg;  inertia entries  |I| ≤ 10 000 kg·m²
    joint axis  not zero;  limits  |position| ≤ 10 000, 0 ≤ effort, velocity ≤ 1e6

The records it makes are in app.core.robot.urdf_tree; app.core.robot.urdf_write writes a
checked tree back as the strict URDF pinocchio is given (both re-exported here).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import defusedxml.ElementTree as SafeET
import numpy as np
from defusedxml import DefusedXmlException

from app.core.errors import UrdfStructureError, UrdfSyntaxError
from app.core.robot.urdf_tree import (
    Geometry,
    Inertial,
    JointElement,
    LoopElement,
    UrdfTree,
    matrix_rpy,
    rpy_matrix,
)
from app.core.robot.urdf_write import canonical_urdf

__all__ = [
    "MOVING_JOINT_TYPES",
    "SUPPORTED_JOINT_TYPES",
    "Geometry",
    "Inertial",
    "JointElement",
    "LoopElement",
    "UrdfTree",
    "canonical_urdf",
    "matrix_rpy",
    "parse_urdf",
    "rpy_matrix",
]

MAX_LINKS = 500
MAX_TREE_DEPTH = 64
MAX_GEOMETRIES = 5000
MAX_LENGTH_M = 100.0
MAX_MASS_KG = 1e4
MAX_INERTIA_KGM2 = 1e4
MAX_ANGLE_RAD = 100.0
MAX_LIMIT = 1e4
MAX_RATING = 1e6
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic")
SUPPORTED_JOINT_TYPES = (*MOVING_JOINT_TYPES, "fixed")


def parse_urdf(text: str | bytes, source: str = "URDF") -> UrdfTree:
    """Parse and check URDF text; raise UrdfSyntaxError or UrdfStructureError with a reason."""
    try:
        root = SafeET.fromstring(text, forbid_dtd=True)
    except DefusedXmlException as exc:
        raise UrdfSyntaxError(
            f"{source}: refused to parse: the file declares a DTD or XML entities ({type(exc).__name__}); "
            "URDF needs neither, remove the <!DOCTYPE …> block"
        ) from None
    except ET.ParseError as exc:
        raise UrdfSyntaxError(f"{source}: not well-formed XML: {exc}") from None
    if root.tag != "robot":
        raise UrdfStructureError(
            f"{source}: the top element is <{root.tag}>, a URDF starts with <robot>"
        )
    name = root.get("name") or "robot"
    materials = _named_materials(root)

    link_elements = root.findall("link")
    joint_elements = root.findall("joint")
    if len(link_elements) > MAX_LINKS or len(joint_elements) > MAX_LINKS:
        raise UrdfStructureError(
            f"{source}: {len(link_elements)} links and {len(joint_elements)} joints; at most "
            f"{MAX_LINKS} links are accepted (a humanoid has about 40)"
        )
    n_geometries = len(root.findall("link/visual")) + len(root.findall("link/collision"))
    if n_geometries > MAX_GEOMETRIES:
        raise UrdfStructureError(
            f"{source}: {n_geometries} visual/collision elements; at most {MAX_GEOMETRIES}"
        )
    links: list[str] = []
    inertials: dict[str, Inertial] = {}
    geometries: list[Geometry] = []
    for element in link_elements:
        link = _required(element, "name", "a <link>", source)
        if link in links:
            raise UrdfStructureError(
                f"{source}: two links are named {link!r}; link names must be unique"
            )
        links.append(link)
        inertial = element.find("inertial")
        if inertial is not None:
            inertials[link] = _inertial(inertial, link, source)
        for role in ("visual", "collision"):
            for geom in element.findall(role):
                parsed = _geometry(geom, link, role, materials, source)
                if parsed is not None:
                    geometries.append(parsed)
    if not links:
        raise UrdfStructureError(
            f"{source}: no <link> elements; a URDF describes at least one link"
        )

    joints: dict[str, JointElement] = {}
    for element in joint_elements:
        joint = _joint(element, source)
        if joint.name in joints:
            raise UrdfStructureError(
                f"{source}: two joints are named {joint.name!r}; joint names must be unique"
            )
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in links:
                raise UrdfStructureError(
                    f"{source}: joint {joint.name!r} names {role} link {link!r}, which does not exist"
                )
        joints[joint.name] = joint

    root_link = _check_tree(links, joints, source)
    loops = tuple(_loop(element, links, joints, source) for element in root.findall("loop_closure"))
    return UrdfTree(name, root_link, tuple(links), joints, inertials, tuple(geometries), loops)


def _check_tree(links: list[str], joints: dict[str, JointElement], source: str) -> str:
    parent_of: dict[str, str] = {}
    for joint in joints.values():
        if joint.child in parent_of:
            raise UrdfStructureError(
                f"{source}: link {joint.child!r} is the child of two joints "
                f"({parent_of[joint.child]!r} and {joint.name!r}): this closes a kinematic loop, "
                "which URDF cannot express; cut it and declare a <loop_closure> instead"
            )
        parent_of[joint.child] = joint.name
    roots = [link for link in links if link not in parent_of]
    for link in links:
        seen = {link}
        current = link
        while current in parent_of:
            current = joints[parent_of[current]].parent
            if current in seen:
                raise UrdfStructureError(
                    f"{source}: kinematic cycle through link {current!r}; a URDF must be a tree"
                )
            seen.add(current)
    if len(roots) != 1:
        raise UrdfStructureError(
            f"{source}: {len(roots)} root links ({', '.join(roots[:12])}); a URDF has exactly one "
            "link that is no joint's child: connect the others with joints"
        )
    depth: dict[str, int] = {roots[0]: 0}
    for link in links:
        chain = []
        current = link
        while current not in depth:
            chain.append(current)
            current = joints[parent_of[current]].parent
        for below in reversed(chain):
            depth[below] = depth[current] + 1
            current = below
            if depth[below] > MAX_TREE_DEPTH:
                raise UrdfStructureError(
                    f"{source}: link {below!r} is {depth[below]} joints below the root; at most "
                    f"{MAX_TREE_DEPTH} are accepted"
                )
    return roots[0]


def _joint(element: ET.Element, source: str) -> JointElement:
    name = _required(element, "name", "a <joint>", source)
    kind = element.get("type", "")
    if kind not in SUPPORTED_JOINT_TYPES:
        hint = (
            " (the studio adds the floating base itself: remove this joint)"
            if kind == "floating"
            else ""
        )
        raise UrdfStructureError(
            f"{source}: joint {name!r} has type {kind!r}; supported types are "
            f"{', '.join(SUPPORTED_JOINT_TYPES)}{hint}"
        )
    parent, child = element.find("parent"), element.find("child")
    if parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise UrdfStructureError(
            f"{source}: joint {name!r} needs <parent link=…> and <child link=…>"
        )
    axis = _floats(element.find("axis"), "xyz", (1.0, 0.0, 0.0), f"joint {name!r} axis", source)
    if len(axis) != 3:
        raise UrdfStructureError(f"{source}: joint {name!r} axis needs three values, got {axis}")
    if kind != "fixed" and not np.linalg.norm(axis) > 1e-9:
        raise UrdfStructureError(
            f"{source}: joint {name!r} has a zero axis; give the direction it turns or slides "
            'along (e.g. xyz="0 1 0")'
        )
    limit = element.find("limit")

    def limit_value(key: str) -> float | None:
        if limit is None or limit.get(key) is None:
            return None
        value = _float(limit.get(key, ""), f"joint {name!r} limit {key}", source)
        bound = MAX_LIMIT if key in ("lower", "upper") else MAX_RATING
        _in_range(value, -bound, bound, f"joint {name!r} limit {key}", source)
        return value

    return JointElement(
        name=name,
        kind=kind,
        parent=parent.get("link", ""),
        child=child.get("link", ""),
        T_parent_joint=_origin(element, f"joint {name!r}", source),
        axis=np.array(axis),
        lower=limit_value("lower"),
        upper=limit_value("upper"),
        effort=limit_value("effort"),
        velocity=limit_value("velocity"),
    )


def _inertial(element: ET.Element, link: str, source: str) -> Inertial:
    mass_element = element.find("mass")
    mass = _float(
        mass_element.get("value", "") if mass_element is not None else "",
        f"link {link!r} mass",
        source,
    )
    if mass < 0.0:
        raise UrdfStructureError(
            f"{source}: link {link!r} has negative mass {mass:g} kg; masses must be zero or positive"
        )
    _in_range(mass, 0.0, MAX_MASS_KG, f"link {link!r} mass [kg]", source)
    inertia = element.find("inertia")
    values = {key: 0.0 for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    if inertia is not None:
        for key in values:
            what = f"link {link!r} inertia {key} [kg·m²]"
            values[key] = _float(inertia.get(key, "0"), what, source)
            _in_range(values[key], -MAX_INERTIA_KGM2, MAX_INERTIA_KGM2, what, source)
    matrix = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    T = _origin(element, f"link {link!r} inertial", source)
    rotated = T[:3, :3] @ matrix @ T[:3, :3].T
    return Inertial(mass, T[:3, 3].copy(), rotated)


def _geometry(
    element: ET.Element, link: str, role: str, materials: dict[str, tuple], source: str
) -> Geometry | None:
    geometry = element.find("geometry")
    if geometry is None or len(geometry) == 0:
        return None
    shape = geometry[0]
    what = f"link {link!r} {role}"
    T = _origin(element, what, source)
    rgba = _rgba(element.find("material"), materials)
    if shape.tag == "box":
        size = _floats(shape, "size", None, what, source)
        if len(size) != 3:
            raise UrdfStructureError(
                f"{source}: {what} box has {len(size)} size value(s); give three: x y z [m]"
            )
        return Geometry(link, role, "box", T, _sizes(size, what, source), rgba=rgba)
    if shape.tag == "cylinder":
        size = (
            _float(shape.get("radius", ""), f"{what} cylinder radius", source),
            _float(shape.get("length", ""), f"{what} cylinder length", source),
        )
        return Geometry(link, role, "cylinder", T, _sizes(size, what, source), rgba=rgba)
    if shape.tag == "sphere":
        size = (_float(shape.get("radius", ""), f"{what} sphere radius", source),)
        return Geometry(link, role, "sphere", T, _sizes(size, what, source), rgba=rgba)
    if shape.tag == "mesh":
        uri = shape.get("filename", "")
        if not uri:
            raise UrdfStructureError(f"{source}: {what} has a <mesh> without filename")
        scale = _floats(shape, "scale", (1.0, 1.0, 1.0), what, source)
        if len(scale) == 1:
            scale = scale * 3
        if len(scale) != 3 or not all(1e-6 <= abs(s) <= 1e3 for s in scale):
            raise UrdfStructureError(
                f"{source}: {what} mesh scale {scale}: give one or three values, each of "
                "magnitude between 1e-6 and 1000"
            )
        return Geometry(link, role, "mesh", T, scale, uri=uri, rgba=rgba)
    return None


def _loop(
    element: ET.Element, links: list[str], joints: dict[str, JointElement], source: str
) -> LoopElement:
    name = element.get("name", "loop")
    link_a, link_b = element.get("link_a", ""), element.get("link_b", "")
    for link in (link_a, link_b):
        if link not in links:
            raise UrdfStructureError(
                f"{source}: loop_closure {name!r} names link {link!r}, which does not exist"
            )
    passive = tuple(element.get("passive_joints", "").split())
    for joint in passive:
        if joint not in joints or joints[joint].kind not in MOVING_JOINT_TYPES:
            raise UrdfStructureError(
                f"{source}: loop_closure {name!r} names passive joint {joint!r}, which is not a moving joint"
            )
    return LoopElement(name, link_a, link_b, passive)


def _named_materials(root: ET.Element) -> dict[str, tuple]:
    named = {}
    for material in root.findall("material"):
        rgba = _rgba(material, {})
        if material.get("name") and rgba is not None:
            named[material.get("name", "")] = rgba
    return named


def _rgba(
    material: ET.Element | None, named: dict[str, tuple]
) -> tuple[float, float, float, float] | None:
    if material is None:
        return None
    color = material.find("color")
    if color is not None and color.get("rgba"):
        try:
            values = [float(v) for v in color.get("rgba", "").split()]
        except ValueError:
            return None
        if len(values) == 4 and all(np.isfinite(values)):
            return (values[0], values[1], values[2], values[3])
    return named.get(material.get("name", ""))


def _origin(element: ET.Element, what: str, source: str) -> np.ndarray:
    origin = element.find("origin")
    xyz = _floats(origin, "xyz", (0.0, 0.0, 0.0), f"{what} origin", source)
    rpy = _floats(origin, "rpy", (0.0, 0.0, 0.0), f"{what} origin", source)
    if len(xyz) != 3 or len(rpy) != 3:
        raise UrdfStructureError(f"{source}: {what} origin needs three xyz and three rpy values")
    for value in xyz:
        _in_range(value, -MAX_LENGTH_M, MAX_LENGTH_M, f"{what} origin xyz [m]", source)
    for value in rpy:
        _in_range(value, -MAX_ANGLE_RAD, MAX_ANGLE_RAD, f"{what} origin rpy [rad]", source)
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(*rpy)
    T[:3, 3] = xyz
    return T


def _required(element: ET.Element, key: str, what: str, source: str) -> str:
    value = element.get(key)
    if not value:
        raise UrdfStructureError(f"{source}: {what} has no {key}")
    return value


def _floats(
    element: ET.Element | None, key: str, default, what: str, source: str
) -> tuple[float, ...]:
    """The numbers of attribute `key`; a bad one is named with its attribute ("joint 'hip'
    origin xyz is 'nan'"), not only with its element."""
    if element is None or element.get(key) is None:
        if default is None:
            raise UrdfStructureError(f"{source}: {what} has no {key}")
        return tuple(default)
    return tuple(_float(v, f"{what} {key}", source) for v in element.get(key, "").split())


def _float(text: str, what: str, source: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise UrdfStructureError(f"{source}: {what}: {text!r} is not a number") from None
    if not np.isfinite(value):
        raise UrdfStructureError(f"{source}: {what} is {text!r}; it must be a finite number")
    return value


def _in_range(value: float, low: float, high: float, what: str, source: str) -> None:
    if not low <= value <= high:
        raise UrdfStructureError(
            f"{source}: {what} is {value:g}; a physically sane value lies in [{low:g}, {high:g}]"
        )


def _sizes(size: tuple[float, ...], what: str, source: str) -> tuple[float, ...]:
    """Primitive sizes [m]: each in (0, MAX_LENGTH_M]."""
    for value in size:
        if not 0.0 < value <= MAX_LENGTH_M:
            raise UrdfStructureError(
                f"{source}: {what} has size {value:g} m; primitive sizes must be positive and at "
                f"most {MAX_LENGTH_M:g} m"
            )
    return size
