"""Robots, described once (:mod:`description`; the bundled MICO in :mod:`mico`), and their model files."""

from simtune.robot.description import RobotDescription
from simtune.robot.generate import robot_urdf, scene_mjcf
from simtune.robot.mico import ARM_JOINTS, BASE_POSITION, MICO, WRIST_LINK, forward_kinematics

__all__ = [
    "ARM_JOINTS",
    "BASE_POSITION",
    "MICO",
    "WRIST_LINK",
    "RobotDescription",
    "forward_kinematics",
    "robot_urdf",
    "scene_mjcf",
]
