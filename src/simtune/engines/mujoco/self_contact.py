"""Whether the arm touches itself at given poses: MuJoCo's collision detection on the arm's own shapes.

The scenes simtune simulates never collide the arm with itself (``robot/generate.py``: "arm never hits arm", as the
seed paper's MICO), so a rollout cannot say whether a motion folds a link into another.  Here the same compiled scene
has its arm shapes collide with each other too, and each pose is placed kinematically (``mj_forward``, no dynamics):
the contacts between two of the arm's links are what a real arm would hit.  A parent and its child are left out, as
MuJoCo leaves them, and so is every pair already in contact at the first pose (a description whose neighbouring
links' meshes overlap at their joint touches there from the start, and no motion is to blame for it).
"""

from __future__ import annotations

import numpy as np

from simtune.engines.mujoco.engine import compile_scene, mujoco
from simtune.robot.description import RobotDescription


def self_contacts(robot: RobotDescription, poses_rad: np.ndarray) -> list[tuple[int, str, str]]:
    """The arm's contacts with itself at each of ``poses_rad`` beyond those at the first pose.

    Args:
        robot: the robot.
        poses_rad: (poses, driven joints) joint angles [rad]; the first is the reference pose.
    Returns:
        ``(pose index, link, link)`` for each pair of links in contact at that pose and not at the first, in pose
        order (each pair named once per pose, its two links in the model's order).
    """
    model = compile_scene(robot, None)
    arm = (model.geom_contype & 2) != 0  # the scene's arm shapes (contype 2: they hit the world)
    model.geom_conaffinity[arm] |= 2  # ... and now each other
    data = mujoco.MjData(model)
    address = np.array([model.jnt_qposadr[model.joint(name).id] for name in robot.arm_joints])

    def touching(q: np.ndarray) -> set[tuple[int, int]]:
        data.qpos[address] = q
        mujoco.mj_forward(model, data)
        n = data.ncon
        g1, g2 = data.contact.geom1[:n], data.contact.geom2[:n]
        both = arm[g1] & arm[g2]
        bodies = model.geom_bodyid
        return {tuple(sorted((int(bodies[a]), int(bodies[b])))) for a, b in zip(g1[both], g2[both])}  # type: ignore[misc]

    poses = np.asarray(poses_rad, dtype=float)
    if not len(poses):
        return []
    allowed = touching(poses[0])
    found = []
    for i, q in enumerate(poses):
        for a, b in sorted(touching(q) - allowed):
            found.append((i, model.body(a).name, model.body(b).name))
    return found
