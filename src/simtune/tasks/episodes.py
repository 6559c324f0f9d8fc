"""Episodes as the unit of data: a LeRobot dataset of different motions, each replayed with its own commands.

A lab's dataset is many episodes, each a different motion with its own ``action`` stream.  A task file says
``schedule_episode = "each"`` (docs/task-files.md) and stands for one task per episode (:func:`episode_task_name`),
each driven by its episode's actions and compared with its episode's observations alone; the project groups them
under the file's name.  ``simtune synth --episodes N`` writes such a dataset: :func:`command_stream` draws each
episode's commands, :func:`check_stream` holds them to the robot's limits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from simtune.errors import ConfigError
from simtune.robot.description import RobotDescription
from simtune.tasks.spec import Phase, TaskSpec

#: ``schedule_episode``'s value for "every episode, each its own task"
EACH = "each"
#: seconds between the waypoints of a drawn command stream (a teleoperator's deliberate moves)
WAYPOINT_S = 1.0
#: seconds a drawn stream holds the start pose first, so that the motion's onset (the delay) shows
HOLD_S = 0.5
#: the largest excursion [rad] of a drawn waypoint from the start pose, and its share of a joint's range
MAX_EXCURSION_RAD, EXCURSION_SHARE = 0.6, 0.3
#: the share of the joint's (and the controller's) velocity limit a drawn stream's commands move at, at most
SPEED_SHARE = 0.5
#: the share of a joint's range kept clear of each limit
LIMIT_MARGIN = 0.05


def episode_task_name(task: str, episode: int) -> str:
    """The name of episode ``episode``'s task of the episode task ``task`` (``train.ep3``)."""
    return f"{task}.ep{episode}"


def _joint_bounds(robot: RobotDescription, joint: str, start: float) -> tuple[float, float, float]:
    """A joint's lowest and highest command (its limits less a margin; about the start for an unlimited one) and
    the most it moves per second."""
    j = robot.joint_by_name[joint]
    if j.lower is None or j.upper is None:
        low, high = start - math.pi, start + math.pi
    else:
        margin = LIMIT_MARGIN * (j.upper - j.lower)
        low, high = j.lower + margin, j.upper - margin
    return low, high, math.inf if j.velocity is None or j.velocity <= 0 else j.velocity


def command_stream(task: TaskSpec, rng: np.random.Generator, fps: float) -> tuple[Phase, ...]:
    """One episode's commands, drawn: the start pose held for :data:`HOLD_S`, then a waypoint every
    :data:`WAYPOINT_S` (each joint within :data:`EXCURSION_SHARE` of its range of the start pose, at most
    :data:`MAX_EXCURSION_RAD`), linearly interpolated, one phase per frame at ``fps``.

    Args:
        task: the task whose robot, driven joints, start pose, duration and velocity clamp the stream keeps to.
        rng: the episode's own random stream (same seed, same commands).
        fps: the frames per second of the dataset the commands are written to.

    Returns:
        The phases: one per frame before the task's end, within the joints' limits (less a margin of
        :data:`LIMIT_MARGIN` of each range) and moving at most :data:`SPEED_SHARE` of the slower of each joint's
        velocity limit and the controller's clamp (:func:`check_stream` holds).
    """
    start = np.radians(task.start_pose_deg)
    clamp = math.radians(task.max_velocity_deg)
    bounds = [_joint_bounds(task.robot, j, s) for j, s in zip(task.joints, start)]
    low = np.array([b[0] for b in bounds])
    high = np.array([b[1] for b in bounds])
    speed = SPEED_SHARE * np.minimum([b[2] for b in bounds], clamp)
    reach = np.minimum(MAX_EXCURSION_RAD, EXCURSION_SHARE * (high - low))
    times = [0.0, HOLD_S]
    points = [np.clip(start, low, high)] * 2
    while times[-1] < task.duration:
        wanted = np.clip(start + rng.uniform(-reach, reach), low, high)
        step = np.clip(wanted - points[-1], -speed * WAYPOINT_S, speed * WAYPOINT_S)
        times.append(times[-1] + WAYPOINT_S)
        points.append(points[-1] + step)
    frames = np.arange(int(math.ceil(task.duration * fps))) / fps
    frames = frames[frames < task.duration]
    path = np.column_stack([np.interp(frames, times, [p[i] for p in points]) for i in range(len(start))])
    return tuple(Phase(float(t), tuple(float(v) for v in np.degrees(row))) for t, row in zip(frames, path))


def check_stream(task: TaskSpec, phases: Sequence[Phase]) -> None:
    """Refuse a command stream outside ``task``'s robot's joint limits or faster than its velocity limits.

    Args:
        task: the task (robot, driven joints, start pose, controller clamp) the stream is for.
        phases: the stream, one phase per frame (:func:`command_stream`).

    Raises:
        ConfigError: naming the joint, the time and the limit broken.
    """
    start = np.radians(task.start_pose_deg)
    clamp = math.radians(task.max_velocity_deg)
    times = np.array([p.start for p in phases])
    rows = np.radians([p.targets_deg for p in phases])
    for i, joint in enumerate(task.joints):
        j = task.robot.joint_by_name[joint]
        outside = np.flatnonzero(
            (rows[:, i] < (-math.inf if j.lower is None else j.lower) - 1e-9)
            | (rows[:, i] > (math.inf if j.upper is None else j.upper) + 1e-9)
        )
        if outside.size:
            k = int(outside[0])
            raise ConfigError(
                f"task {task.name}: the command of {joint} at {times[k]:g} s, {math.degrees(rows[k, i]):.4g} deg, is "
                f"outside its limits [{math.degrees(j.lower or 0):.4g}, {math.degrees(j.upper or 0):.4g}] deg"
            )
        limit = min(clamp, math.inf if j.velocity is None or j.velocity <= 0 else j.velocity)
        path = np.concatenate([[start[i]], rows[:, i]])
        rates = np.abs(np.diff(path)) / np.maximum(np.diff(np.concatenate([[0.0], times])), 1e-9)
        rates[0] = 0.0 if times[0] == 0 else rates[0]  # the first command replaces the start pose, not a move
        fast = np.flatnonzero(rates > limit * (1 + 1e-6))
        if fast.size:
            k = int(fast[0])
            raise ConfigError(
                f"task {task.name}: the command of {joint} moves at {math.degrees(rates[k]):.4g} deg/s at "
                f"{times[k]:g} s, faster than its limit {math.degrees(limit):.4g} deg/s"
            )
