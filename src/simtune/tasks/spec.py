"""Declarative task specifications: what the arm is told to do, and with what object.

A task is data, not code: a joint-target schedule, a duration, the controller
gains, and optionally one object on the floor.  Every engine runs the same
spec through the same controller (:mod:`simtune.engines.controller`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.data.lerobot import LeRobotReading
from simtune.errors import ConfigError
from simtune.robot.description import RobotDescription
from simtune.robot.mico import ARM_JOINTS, MICO, WRIST_LINK

#: Body names of the qrg2019 motion-capture exports (robot base, wrist, object).
BASE_BODY = "RB2(Black)"
WRIST_BODY = "RB1(Orange)"

SHAPES = ("cube", "cylinder", "cone", "cuboid")
MATERIALS = ("plastic", "wood")
#: How a task's target moves between its schedule's set-points (:attr:`TaskSpec.interpolation`).
INTERPOLATIONS = ("hold", "linear")
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
    """From ``start`` seconds on, the driven joints are driven towards ``targets_deg`` (one per driven joint,
    in the robot's order)."""

    start: float
    targets_deg: tuple[float, ...]


#: Field metadata of what a task's fingerprint (``simtune.runs.task_fingerprint``) leaves out: ``"never"``
#: (catalogue entries that change no simulation), ``"default"`` (fields added after runs were stored: left out
#: at their default value, so that those runs still resume), ``"run"`` (a run setting the task carries to the
#: engines: the run's configuration and fingerprint record it, a probe's key where the engine reads it), ``"added"``
#: (fields added after probes were shipped, ``simtune.activity``: left out at their default of a run's fingerprint
#: and of a probe's key alike, so that stored runs resume and shipped probes answer).
FINGERPRINT = "fingerprint"

#: How an engine loads the robot (:attr:`TaskSpec.loading`, ``RunConfig.loading``): ``description``, as its
#: description says (PyBullet: the file's inertias, no link damping of Bullet's own); ``paper``, as the seed paper
#: loaded it (PyBullet: inertias computed from the collision shapes, Bullet's default link damping 0.04).  Every other
#: engine loads both alike.
LOADINGS = ("description", "paper")


@dataclass(frozen=True)
class TaskSpec:
    """A task: its robot, joint-target schedule, controller gains, duration and object (docs/task-files.md)."""

    name: str
    description: str = field(metadata={FINGERPRINT: "never"})
    duration: float
    phases: tuple[Phase, ...]
    kp: float  # proportional gain of the joint controller [1/s]
    max_velocity_deg: float = 30.0  # the controller's default velocity clamp [deg/s]
    object: ObjectSpec | None = None
    wrist_body: str = WRIST_BODY
    start_pose_deg: tuple[float, ...] = ()  # default: every driven joint at 0
    #: whether real recordings of this task exist in the qrg2019 data set
    has_public_recordings: bool = field(default=False, metadata={FINGERPRINT: "never"})
    #: the driven joints, in the order of every target row and of ``start_pose_deg``
    joints: tuple[str, ...] = field(default=ARM_JOINTS, metadata={FINGERPRINT: "default"})
    #: the robot link whose origin the motion-capture wrist body tracks
    tracked_link: str = field(default=WRIST_LINK, metadata={FINGERPRINT: "default"})
    #: the motion-capture body on the robot's base (recordings are checked against it)
    base_body: str | None = field(default=BASE_BODY, metadata={FINGERPRINT: "default"})
    #: the folder of this task's recordings (absolute): its task file's ``recordings``, else the project's
    #: data root / the task's name; None when neither names one
    recordings: str | None = field(default=None, metadata={FINGERPRINT: "never"})
    #: the robot the task drives (its driven joints are ``joints``, its tracked link ``tracked_link``)
    robot: RobotDescription = field(default=MICO, metadata={FINGERPRINT: "default"})
    #: whether the object starts where the recordings put it (their first second, :func:`started_as_recorded`)
    #: instead of at its ``xy``
    start_from_recordings: bool = field(default=False, metadata={FINGERPRINT: "default"})
    #: how the task reads LeRobot datasets (its task file's ``[recordings]`` table: angle unit, names, episodes)
    lerobot: LeRobotReading | None = field(default=None, metadata={FINGERPRINT: "default"})
    #: the schedule as first published, where the task file corrects it (a phase's ``published_targets_deg``):
    #: what ``--paper-exact`` and ``--targets published`` run (:meth:`as_published`); None: ``phases`` is it
    published_phases: tuple[Phase, ...] | None = field(default=None, metadata={FINGERPRINT: "default"})
    #: how the engines load the robot (:data:`LOADINGS`): a run setting (``RunConfig.loading``) the task carries to
    #: every engine built for it; :meth:`loaded_as` sets it
    loading: str = field(default="description", metadata={FINGERPRINT: "run"})
    #: how the controller's target moves between the schedule's set-points (:data:`INTERPOLATIONS`): ``hold``
    #: each until the next (phases, the paper's), or ``linear`` from each to the next over the time between them
    #: (a logged stream of set-points a trajectory controller ramped through); the start pose is held before the
    #: first, the last held after it
    interpolation: str = field(default="hold", metadata={FINGERPRINT: "added"})
    #: whether the task's commands were logged on its recordings' own clock (``[recordings] clock = "shared"``; a
    #: LeRobot episode's actions beside its observations): tuned with others, it shares the robot's one
    #: ``command_delay`` with every such task instead of its own ``command_delay_<task>``
    #: (not in the fingerprint: the task runs alike, the run's space names its delays)
    shared_clock: bool = field(default=False, metadata={FINGERPRINT: "never"})
    #: the task file's name of which this task is one episode (``schedule_episode = "each"``), else None
    episode_of: str | None = field(default=None, metadata={FINGERPRINT: "never"})

    def __post_init__(self) -> None:
        if self.loading not in LOADINGS:
            raise ConfigError(f"task {self.name!r}: loading must be one of {', '.join(LOADINGS)}, got {self.loading!r}")
        if self.interpolation not in INTERPOLATIONS:
            raise ConfigError(
                f"task {self.name!r}: interpolation must be one of {', '.join(INTERPOLATIONS)}, got "
                f"{self.interpolation!r}"
            )
        robot = self.robot
        n = robot.n_joints
        # the MICO's names are the fields' defaults: for another robot, left at them, they follow the robot
        if self.joints == ARM_JOINTS and robot.arm_joints != ARM_JOINTS:
            object.__setattr__(self, "joints", robot.arm_joints)
        if self.tracked_link == WRIST_LINK and robot.tracked_link != WRIST_LINK:
            object.__setattr__(self, "tracked_link", robot.tracked_link)
        if not self.start_pose_deg:
            object.__setattr__(self, "start_pose_deg", (0.0,) * n)
        if tuple(self.joints) != robot.arm_joints:
            raise ConfigError(
                f"task {self.name!r}: drives joints {', '.join(self.joints)}, robot {robot.name!r} drives "
                f"{', '.join(robot.arm_joints)}"
            )
        if self.tracked_link != robot.tracked_link:
            raise ConfigError(
                f"task {self.name!r}: tracks link {self.tracked_link!r}, robot {robot.name!r} reports "
                f"{robot.tracked_link!r}"
            )
        if len(self.start_pose_deg) != n:
            raise ConfigError(
                f"task {self.name!r}: start pose has {len(self.start_pose_deg)} joint angles, "
                f"robot {robot.name!r} drives {n} joints"
            )
        for k, phase in enumerate(self.phases, start=1):
            if len(phase.targets_deg) != n:
                raise ConfigError(
                    f"task {self.name!r}: phase {k} has {len(phase.targets_deg)} joint targets, "
                    f"robot {robot.name!r} drives {n} joints"
                )

    def as_published(self) -> TaskSpec:
        """The task with its published schedule (``published_phases``), itself where the file corrects nothing.

        It is the task as it was before the correction, field for field: its fingerprint is the one runs made
        before the correction stored, so that they resume, report and export with the schedule they ran."""
        if self.published_phases is None:
            return self
        return replace(self, phases=self.published_phases, published_phases=None)

    def loaded_as(self, loading: str) -> TaskSpec:
        """The task with the robot loaded as ``loading`` says (:data:`LOADINGS`)."""
        return self if loading == self.loading else replace(self, loading=loading)

    def started_at(self, xy: tuple[float, float]) -> TaskSpec:
        """The task with its object starting at ``xy`` [m] (resting on the floor, turned as before)."""
        if self.object is None:
            return self
        return replace(self, object=replace(self.object, xy=(float(xy[0]), float(xy[1]))))

    @cached_property
    def schedule(self) -> tuple[np.ndarray, np.ndarray]:
        """Phase start times, and the target rows [deg]: the start pose, then each phase's targets.

        Row ``searchsorted(starts, t, side="right")`` is in force at time ``t``.
        """
        starts = np.array([p.start for p in self.phases])
        table = np.array([self.start_pose_deg, *(p.targets_deg for p in self.phases)], dtype=float)
        return starts, table

    def stretches(self, delay: float = 0.0) -> list[tuple[str, float, float]]:
        """Each stretch of the schedule as a simulation with command delay ``delay`` [s] runs it: its label, start
        and end [s] - each phase from when its command arrives, the start pose held before the first one as a
        stretch of its own, the last one ending with the task."""
        starts = [p.start + delay for p in self.phases if p.start + delay < self.duration]
        held = [("start pose", 0.0, starts[0] if starts else self.duration)] if not starts or starts[0] > 0 else []
        ends = [*starts[1:], self.duration]
        return held + [(f"phase {k + 1}", a, b) for k, (a, b) in enumerate(zip(starts, ends)) if b > a]


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
