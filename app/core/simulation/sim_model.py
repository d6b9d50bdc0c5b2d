"""SimModel: a robot's MJCF text and its coordinate maps, all a worker process needs.

Kept apart from `mjcf` (which uses pinocchio) so that a spawned worker running
the step loop imports numpy and mujoco only.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class SimModel:
    """The MJCF text of a robot and how its coordinates map to pinocchio's (picklable)."""

    robot_name: str
    xml: str
    floating_base: bool
    nq_pin: int
    nv_pin: int
    joint_names: tuple[str, ...]
    """Actuated joints, in the robot's order."""
    actuated_qpos: np.ndarray
    """MuJoCo qpos address of each actuated joint, shape (n,)."""
    actuated_dof: np.ndarray
    """MuJoCo dof address of each actuated joint, shape (n,)."""
    pin_scalar_q: np.ndarray
    """Pairs (pinocchio q index, MuJoCo qpos address) of one-coordinate joints, shape (k, 2)."""
    pin_continuous_q: np.ndarray
    """Pairs (pinocchio q index of cos, MuJoCo qpos address) of continuous joints, (c, 2)."""
    pin_dof: np.ndarray
    """Pairs (pinocchio v index, MuJoCo dof address) of the non-base joints, shape (d, 2)."""
    sole_geoms: tuple[str, str]
    """Names of the (left, right) sole boxes."""
    sole_sites: tuple[str, str]
    """Names of the sites at the (left, right) sole centres, on the sole plane."""
    foot_bodies: tuple[tuple[str, ...], tuple[str, ...]]
    """MuJoCo bodies that belong to the (left, right) foot (its body and what hangs below)."""
    root_body: str
    notes: tuple[str, ...] = ()
    body_links: tuple[tuple[str, str], ...] = ()
    """(MuJoCo body name, the URDF link it carries) pairs, to name a link on the floor."""
