"""The Kinova MICO arm (model m1n6s300): the bundled robot, one :class:`RobotDescription`.

Every engine builds the task's robot (:data:`MICO` unless the task names another)
from its description, so kinematics, inertias and collision shapes cannot drift
apart between engines.  Numbers are those of
the robot's public description as gathered in the reference facts (URDF
convention: a joint frame is its parent's frame moved by ``xyz`` then turned by
``rpy`` = roll about x, pitch about y, yaw about z, applied as Rz @ Ry @ Rx).

The three fingers are welded open: in every task the real controller holds
them at 0 with a stiff position loop, and a weld is that loop's exact limit.
"""

from __future__ import annotations

from math import pi

import numpy as np

from simtune.robot.description import Box, Joint, Link, RobotDescription

#: Where the arm's base frame sits in the world (the floor is z = 0).
BASE_POSITION = (0.0, 0.0, 0.055)

ARM_JOINTS = ("joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6")

#: The link whose frame origin the motion-capture "end effector" body tracks.
WRIST_LINK = "link_6"


def _finger_link(name: str, lo, hi) -> Link:
    return Link(
        name, 0.01, (0.022, 0.0, 0.0), (7.9e-7, 7.9e-7, 8e-8), (Box.spanning(lo, hi),), material="gripper", label=name
    )


LINKS: tuple[Link, ...] = (
    Link(
        "link_base",
        0.46784,
        (0, 0, 0.1255),
        (0.000951, 0.000951, 0.000374),
        (Box.spanning((-0.041, -0.041, 0.0), (0.041, 0.041, 0.157)),),
    ),
    Link(
        "link_1",
        0.7477,
        (0, -0.002, -0.0605),
        (0.00152, 0.00152, 0.000598),
        (Box.spanning((-0.041, -0.041, -0.160), (0.041, 0.041, 0.0)),),
        label="arm link 1",
    ),
    Link(
        "link_2",
        0.85968,
        (0, -0.145, -0.0076),
        (0.00467, 0.000387, 0.00467),
        (Box.spanning((-0.041, -0.331, -0.044), (0.041, 0.041, 0.0)),),
        label="arm link 2",
    ),
    Link(
        "link_3",
        0.606,
        (0, 0.0463, -0.0065),
        (0.000384, 0.000121, 0.000384),
        (Box.spanning((-0.041, -0.041, -0.043), (0.041, 0.123, 0.023)),),
        label="arm link 3",
    ),
    Link(
        "link_4",
        0.1785,
        (0, -0.037, -0.0642),
        (7.73e-5, 7.73e-5, 0.000143),
        (Box.spanning((-0.032, -0.053, -0.091), (0.032, 0.032, 0.0)),),
        label="arm link 4",
    ),
    Link(
        "link_5",
        0.1785,
        (0, -0.037, -0.0642),
        (7.73e-5, 7.73e-5, 0.000143),
        (Box.spanning((-0.032, -0.053, -0.091), (0.032, 0.032, 0.0)),),
        label="arm link 5",
    ),
    Link(
        "link_6",
        0.727,
        (0, 0, -0.06),
        (0.000345, 0.000345, 0.000582),
        (Box.spanning((-0.046, -0.051, -0.121), (0.046, 0.054, 0.0)),),
        label="hand with gripper",
        material="gripper",
    ),
    *(
        link
        for i in (1, 2, 3)
        for link in (
            _finger_link(f"finger_{i}", (-0.007, -0.021, -0.012), (0.051, 0.005, 0.012)),
            _finger_link(f"finger_tip_{i}", (-0.010, -0.015, -0.011), (0.044, 0.006, 0.011)),
        )
    ),
)

_FINGER_ORIGINS = {
    1: ((0.00279, 0.03126, -0.11467), (-pi / 2, 0.649262, 1.359611)),
    2: ((0.02226, -0.02707, -0.11482), (-pi / 2, 0.649262, -1.386140)),
    3: ((-0.02226, -0.02707, -0.11482), (-pi / 2, 0.649262, -1.755452)),
}

JOINTS: tuple[Joint, ...] = (
    Joint("joint_1", "continuous", "link_base", "link_1", (0, 0, 0.15675), (0, pi, 0)),
    Joint("joint_2", "revolute", "link_1", "link_2", (0, 0.0016, -0.11875), (-pi / 2, pi, pi), lower=-2.35, upper=2.35),
    Joint("joint_3", "revolute", "link_2", "link_3", (0, -0.290, 0), (0, pi, pi), lower=-2.86, upper=2.86),
    Joint("joint_4", "continuous", "link_3", "link_4", (0, 0.1231, -0.0086), (-pi / 2, 0, pi)),
    Joint("joint_5", "continuous", "link_4", "link_5", (0, -0.03703, -0.06414), (pi / 3, 0, pi)),
    Joint("joint_6", "continuous", "link_5", "link_6", (0, -0.03703, -0.06414), (pi / 3, 0, pi)),
    *(
        joint
        for i, (xyz, rpy) in _FINGER_ORIGINS.items()
        for joint in (
            Joint(f"finger_joint_{i}", "fixed", "link_6", f"finger_{i}", xyz, rpy),
            Joint(f"finger_tip_joint_{i}", "fixed", f"finger_{i}", f"finger_tip_{i}", (0.044, -0.003, 0), (0, 0, 0)),
        )
    ),
)

#: The tool frame 0.16 m beyond the wrist (informational; the wrist is what is tracked).
END_EFFECTOR_OFFSET = ((0, 0, -0.16), (pi, 0, 0))

#: The MICO as every engine builds it.  Its mass ranges are relative to the seed paper's nominal
#: masses (the paper takes link 1's for link 2).
MICO = RobotDescription(
    name="kinova_mico",
    links=LINKS,
    joints=JOINTS,
    arm_joints=ARM_JOINTS,
    tracked_link=WRIST_LINK,
    base_position=BASE_POSITION,
    nominal_masses=(0.7477, 0.7477, 0.606, 0.1785, 0.1785, 0.727),
)

LINK_BY_NAME = MICO.link_by_name

#: No pose puts the wrist farther than this from the world origin [m] (about 0.89 m): the
#: chain's offsets laid end to end.  The recordings' units are judged by it.
WRIST_REACH_M = MICO.reach


def children(link_name: str) -> list[Joint]:
    """The joints whose parent is ``link_name``, in table order."""
    return MICO.children(link_name)


def forward_kinematics(q, link: str = WRIST_LINK) -> tuple[np.ndarray, np.ndarray]:
    """World position and rotation of the MICO's ``link`` frame for arm joint angles ``q`` [rad]."""
    return MICO.forward_kinematics(q, link)
