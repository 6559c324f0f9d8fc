"""Robots, described once (:mod:`description`; the bundled MICO in :mod:`mico`), read from a URDF or an MJCF
(:func:`load_robot`), and their model files."""

from simtune.robot.description import RobotDescription
from simtune.robot.generate import robot_urdf, scene_mjcf
from simtune.robot.load import load_robot, robot_format
from simtune.robot.mico import ARM_JOINTS, BASE_POSITION, MICO, WRIST_LINK, forward_kinematics

#: The robot a task drives unless it names another (the bundled MICO): the engines name their
#: per-joint parameters for its driven joints.
DEFAULT_ROBOT = MICO

__all__ = [
    "ARM_JOINTS",
    "BASE_POSITION",
    "DEFAULT_ROBOT",
    "MICO",
    "WRIST_LINK",
    "RobotDescription",
    "forward_kinematics",
    "load_robot",
    "robot_format",
    "robot_urdf",
    "scene_mjcf",
]
