"""Find a biped's feet and the corners of its soles.

Feet are found by name first (links named like sole, foot, ankle, on each side of the base),
then as the lowest leaf links of the tree on the left and on the right. Left is +y (REP 103),
judged at the neutral pose, so names in any language or numbering scheme work. The user can
always name the two foot links instead.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.errors import NoFeetFound, UrdfStructureError
from app.core.robot.meshes import LinkMesh
from app.core.robot.urdf_xml import UrdfTree

NAME_SCORES = (("sole", 3.0), ("foot", 2.0), ("feet", 2.0), ("ankle", 1.0))
SIDE_MARGIN_M = 0.005
"""A foot must stand at least this far left or right of the base's x-z plane."""
SOLE_BAND_M = 0.004
"""Mesh vertices within this height of the lowest point of a foot make up its sole."""


@dataclasses.dataclass(frozen=True)
class Foot:
    side: str
    """"left" or "right"."""
    link: str
    sole_corners_m: np.ndarray
    """Corners of the sole's bounding rectangle in the foot link's frame [m], shape (4, 3),
    counter-clockwise seen from above at the neutral pose. A single repeated point when the
    foot has no geometry."""


def find_foot_links(
    tree: UrdfTree, T_world_links: dict[str, np.ndarray], override: tuple[str, str] | None = None
) -> tuple[str, str]:
    """(left, right) foot links: the user's if given, else by name, else lowest leaves."""
    if override is not None:
        for link in override:
            if link not in T_world_links:
                raise UrdfStructureError(
                    f"foot link {link!r} does not exist; links are: {', '.join(tree.links)}"
                )
        left, right = override
        if T_world_links[left][1, 3] < T_world_links[right][1, 3]:
            left, right = right, left
        return left, right

    def by_name(link: str) -> float:
        name = link.lower()
        return max((score for word, score in NAME_SCORES if word in name), default=0.0)

    leaves = [link for link in tree.links if not tree.children_of(link)]
    for pool, key in (
        ([link for link in tree.links if by_name(link) > 0.0], by_name),
        (leaves, lambda link: 0.0),
    ):
        best_left = _best(pool, T_world_links, key, side=+1.0)
        best_right = _best(pool, T_world_links, key, side=-1.0)
        if best_left is not None and best_right is not None:
            return best_left, best_right
    raise NoFeetFound(
        f"no feet found in {tree.name!r}: no links named like sole/foot/ankle on both sides of "
        "the base, and no pair of lowest leaf links left and right of it; name the two foot "
        "links (left, right) yourself"
    )


def _best(pool: list[str], T_world_links: dict[str, np.ndarray], key, side: float) -> str | None:
    on_side = [link for link in pool if side * T_world_links[link][1, 3] > SIDE_MARGIN_M]
    if not on_side:
        return None
    # Highest name score, then the lowest link (a sole below its ankle), then the longer name.
    return max(
        on_side, key=lambda link: (key(link), -round(T_world_links[link][2, 3], 4), len(link))
    )


def sole_corners(
    foot_link: str,
    rigid_links: list[str],
    meshes: list[LinkMesh],
    T_world_links: dict[str, np.ndarray],
) -> np.ndarray:
    """Corners of the sole rectangle of a foot, in the foot link's frame [m], shape (4, 3).

    The sole is made of the foot's lowest vertices (collision meshes if it has any, else
    visual) at the neutral pose; its rectangle is aligned with the foot's x and y axes as seen
    from above.
    """
    T_world_foot = T_world_links[foot_link]
    own = [m for m in meshes if m.link in rigid_links]
    role = "collision" if any(m.role == "collision" for m in own) else "visual"
    points = [
        (T_world_links[m.link] @ m.T_link_mesh)[:3, :3] @ m.mesh.vertices.T
        + (T_world_links[m.link] @ m.T_link_mesh)[:3, 3:4]
        for m in own
        if m.role == role
    ]
    if not points:
        return np.zeros((4, 3))
    world = np.concatenate(points, axis=1).T
    bottom = world[world[:, 2] < world[:, 2].min() + SOLE_BAND_M]
    heading = T_world_foot[:3, 0].copy()
    heading[2] = 0.0
    if np.linalg.norm(heading) < 1e-6:
        heading = np.array([1.0, 0.0, 0.0])
    heading /= np.linalg.norm(heading)
    lateral = np.array([-heading[1], heading[0], 0.0])
    u, v = bottom @ heading, bottom @ lateral
    z = world[:, 2].min()
    corners_world = np.array(
        [
            u.min() * heading + v.min() * lateral,
            u.max() * heading + v.min() * lateral,
            u.max() * heading + v.max() * lateral,
            u.min() * heading + v.max() * lateral,
        ]
    )
    corners_world[:, 2] = z
    T_foot_world = np.linalg.inv(T_world_foot)
    return (T_foot_world[:3, :3] @ corners_world.T + T_foot_world[:3, 3:4]).T
