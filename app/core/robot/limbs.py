"""Group a robot's joints by limb, for the joint panel: legs by the feet they carry, arms,
head and torso by name, sides by where the joint stands at the neutral pose (left is +y)."""

from __future__ import annotations

import numpy as np

from app.core.robot.urdf_xml import UrdfTree

ARM_WORDS = ("arm", "shoulder", "elbow", "wrist", "hand", "gripper", "finger")
HEAD_WORDS = ("head", "neck", "camera")
TORSO_WORDS = ("waist", "torso", "trunk", "chest", "spine", "pelvis", "hip_base")


def limb_of_joints(
    tree: UrdfTree, feet: tuple[str, str], T_world_links: dict[str, np.ndarray]
) -> dict[str, str]:
    """Limb name of every joint of the tree."""
    chains = []
    for foot in feet:
        chain, link = set(), foot
        while (joint := tree.parent_joint(link)) is not None:
            chain.add(joint.name)
            link = joint.parent
        chains.append(chain)
    legs = {name: "Left leg" for name in chains[0] - chains[1]}
    legs.update({name: "Right leg" for name in chains[1] - chains[0]})
    limbs = {}
    for name, joint in tree.joints.items():
        lowered = name.lower()
        y = T_world_links.get(joint.child, np.eye(4))[1, 3]
        side = "Left" if y > 0.0 else "Right"
        leg = legs.get(name) or _leg_above(tree, joint.parent, legs)
        if leg:
            limbs[name] = leg
        elif any(word in lowered for word in ARM_WORDS):
            limbs[name] = f"{side} arm"
        elif any(word in lowered for word in HEAD_WORDS):
            limbs[name] = "Head"
        elif any(word in lowered for word in TORSO_WORDS):
            limbs[name] = "Torso"
        else:
            limbs[name] = "Other"
    return limbs


def _leg_above(tree: UrdfTree, link: str, legs: dict[str, str]) -> str:
    """The leg a side branch hangs from (e.g. an ankle motor's crank on the shin), or ""."""
    while (joint := tree.parent_joint(link)) is not None:
        if joint.name in legs:
            return legs[joint.name]
        link = joint.parent
    return ""
