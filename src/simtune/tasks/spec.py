"""Declarative task specifications: what the arm is told to do, and with what object.

A task is data, not code: a joint-target schedule, a duration, the controller
gains, and optionally one object on the floor.  Every engine runs the same
spec through the same controller (:mod:`simtune.controller`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from simtune.errors import ConfigError
from simtune.geometry import rpy_matrix
from simtune.robot.description import RobotDescription
from simtune.robot.mico import MICO

#: Body names of the qrg2019 motion-capture exports (robot base, wrist, object).
BASE_BODY = "RB2(Black)"
WRIST_BODY = "RB1(Orange)"

SHAPES = ("cube", "cylinder", "cone", "cuboid")
MATERIALS = ("plastic", "wood")
#: The surfaces with contact parameters of their own (``lateral_friction_<group>`` and the like): the
#: gripper, the floor and each object material.  Their order is those parameters' order in a space.
CONTACT_GROUPS = ("gripper", "floor", "wood", "plastic")


@dataclass(frozen=True)
class ObjectSpec:
    """One rigid object resting on the floor.

    ``size`` is shape specific: cube/cuboid -> full edge lengths (x, y, z);
    cylinder -> (radius, length); cone -> (base radius, height).  Cylinders and
    cones have their axis along the local z axis, with the origin at the centre
    of their bounding box.  ``rpy`` turns the object from that pose.
    """

    shape: str
    material: str
    mass: float
    size: tuple[float, ...]
    xy: tuple[float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mocap_body: str = "object"  # name of its rigid body in the recordings

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"unknown object shape {self.shape!r} (known: {', '.join(SHAPES)})")
        if self.material not in MATERIALS:
            raise ValueError(f"unknown material {self.material!r} (known: {', '.join(MATERIALS)})")

    @property
    def mass_parameter(self) -> str:
        """Name of the tuning parameter that sets this object's mass."""
        return f"mass_{self.shape}_{self.material}"

    @property
    def rotation(self) -> np.ndarray:
        return rpy_matrix(self.rpy)

    def cone_vertices(self, segments: int = 24) -> np.ndarray:
        """Vertices of the cone's convex hull in its local frame (apex up)."""
        radius, height = self.size
        angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
        ring = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.full(segments, -height / 2)], axis=1)
        return np.vstack([ring, [[0.0, 0.0, height / 2]]])

    def surface_points(self) -> np.ndarray:
        """Points on the object's outline in its local frame, enough to find its lowest point."""
        if self.shape in ("cube", "cuboid"):
            hx, hy, hz = (s / 2 for s in self.size)
            return np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        if self.shape == "cylinder":
            radius, length = self.size
            angles = np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
            ring = np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)
            return np.vstack([np.column_stack([ring, np.full(72, z)]) for z in (-length / 2, length / 2)])
        return self.cone_vertices(72)

    @property
    def rest_height(self) -> float:
        """Height of the origin when the turned object rests on the floor (z = 0)."""
        return float(-(self.surface_points() @ self.rotation.T)[:, 2].min())

    @property
    def start_position(self) -> tuple[float, float, float]:
        return (self.xy[0], self.xy[1], self.rest_height)


@dataclass(frozen=True)
class Phase:
    """From ``start`` seconds on, the robot's driven joints are driven towards ``targets_deg`` (one per
    joint, in the robot's order)."""

    start: float
    targets_deg: tuple[float, ...]


@dataclass(frozen=True)
class TaskSpec:
    """A task: the robot, its joint-target schedule, controller gains, duration and object."""

    name: str
    description: str
    duration: float
    phases: tuple[Phase, ...]
    kp: float  # proportional gain of the joint controller [1/s]
    max_velocity_deg: float = 30.0  # the controller's default velocity clamp [deg/s]
    object: ObjectSpec | None = None
    wrist_body: str = WRIST_BODY
    start_pose_deg: tuple[float, ...] = ()  # default: every driven joint at 0
    #: whether real recordings of this task exist in the qrg2019 data set
    has_public_recordings: bool = False
    robot: RobotDescription = MICO

    def __post_init__(self) -> None:
        n = self.robot.n_joints
        if not self.start_pose_deg:
            object.__setattr__(self, "start_pose_deg", (0.0,) * n)
        if len(self.start_pose_deg) != n:
            raise ConfigError(
                f"task {self.name!r}: start pose has {len(self.start_pose_deg)} joint angles, "
                f"robot {self.robot.name!r} drives {n} joints"
            )
        for k, phase in enumerate(self.phases, start=1):
            if len(phase.targets_deg) != n:
                raise ConfigError(
                    f"task {self.name!r}: phase {k} has {len(phase.targets_deg)} joint targets, "
                    f"robot {self.robot.name!r} drives {n} joints"
                )

    @cached_property
    def schedule(self) -> tuple[np.ndarray, np.ndarray]:
        """Phase start times, and the target rows [deg]: the start pose, then each phase's targets.

        Row ``searchsorted(starts, t, side="right")`` is in force at time ``t``.
        """
        starts = np.array([p.start for p in self.phases])
        table = np.array([self.start_pose_deg, *(p.targets_deg for p in self.phases)], dtype=float)
        return starts, table


def common_robot(tasks) -> RobotDescription:
    """The one robot of tasks tuned together (their parameters are one robot's)."""
    robots: list[RobotDescription] = []
    for task in tasks:
        if task.robot not in robots:
            robots.append(task.robot)
    if len(robots) != 1:
        names = ", ".join(repr(r.name) for r in robots) or "none"
        raise ConfigError(f"tasks tuned together must share one robot, not {names}")
    return robots[0]
