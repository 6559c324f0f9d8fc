"""The Kinova MICO arm, described once and generated for every engine."""

from simtune.robot.generate import robot_urdf, scene_mjcf
from simtune.robot.mico import ARM_JOINTS, BASE_POSITION, WRIST_LINK, forward_kinematics

__all__ = ["ARM_JOINTS", "BASE_POSITION", "WRIST_LINK", "forward_kinematics", "robot_urdf", "scene_mjcf"]
