"""Task files and LeRobot datasets: the ``[recordings]`` table (angle unit, names, episodes) and a target
schedule taken from one episode's commanded actions (``schedule_lerobot``); docs/task-files.md.

A LeRobot dataset names its vectors' entries (``shoulder_pan.pos``) but stores no unit, so a task that
reads one states it: ``[recordings] units = "deg"`` (LeRobot's SO-100/SO-101) or ``"rad"``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simtune.data.lerobot import ANGLE_UNITS, LeRobotReading, read_info, read_lerobot_actions
from simtune.data.sanity import JointRange
from simtune.errors import ProjectError, RecordingError
from simtune.robot.description import RobotDescription
from simtune.tasks.spec import Phase, TaskSpec

if TYPE_CHECKING:
    from simtune.tasks.keys import Keys

#: keys of a task file's ``[recordings]`` table (``recordings = "folder"`` is the short form of ``folder``)
RECORDINGS_KEYS = ("folder", "units", "joints", "episodes", "clock")
#: ``[recordings] clock``: ``shared``, the commands were logged on the recordings' own clock (a LeRobot episode's
#: actions beside its observations): one command delay, the robot's, shared with every such task tuned with it;
#: ``own``, the capture started on its own (motion capture of a replayed schedule): the task's own delay
CLOCKS = ("shared", "own")
#: the schedule keys of a task file (exactly one of the first three)
SCHEDULE_KEYS = ("phases", "schedule_csv", "schedule_lerobot")


def recordings_key(keys: Keys, base: Path) -> tuple[str | None, LeRobotReading | None]:
    """The task file's ``recordings``: a folder (relative to ``base``), or a table with the folder and how
    LeRobot datasets are read; returns the absolute folder (or None) and the reading (None: no table).  Its
    ``clock`` is :func:`recordings_clock`'s."""
    value = keys.data.get("recordings")
    if value is None or isinstance(value, str):
        folder = keys.string("recordings")
        return (None if folder is None else str((base / folder).resolve())), None
    if not isinstance(value, dict):
        raise keys.error("recordings", "expected a folder (a string) or a [recordings] table")
    table = keys.table("recordings", RECORDINGS_KEYS)
    assert table is not None
    folder = table.string("folder")
    units = table.string("units")
    if units is not None and units not in ANGLE_UNITS:
        raise table.error("units", f"unknown angle unit {units!r} (known: {', '.join(ANGLE_UNITS)})")
    joints = table.data.get("joints", {})
    if not isinstance(joints, dict):
        raise table.error("joints", 'expected a table of dataset names, each mapped to a robot joint (or to "")')
    for name, joint in joints.items():
        if not isinstance(joint, str):
            raise table.error(f"joints.{name!r}", f'expected a joint name (or "" to leave it out), got {joint!r}')
    episodes = table.data.get("episodes")
    if episodes == []:
        raise table.error(
            "episodes",
            "the list is empty: it names no episode to read (name one or more, or leave `episodes` out to read "
            "all of the dataset's episodes)",
        )
    if episodes is not None and (
        not isinstance(episodes, list)
        or not all(isinstance(k, int) and not isinstance(k, bool) and k >= 0 for k in episodes)
    ):
        raise table.error("episodes", f"expected a list of episode numbers (0 or more), got {episodes!r}")
    if episodes is not None and len(set(episodes)) != len(episodes):
        raise table.error("episodes", f"an episode is named twice: {episodes}")
    reading = LeRobotReading(
        units=units,
        joints=tuple((str(name), joint) for name, joint in joints.items()),
        episodes=None if episodes is None else tuple(episodes),
    )
    return (None if folder is None else str((base / folder).resolve())), reading


def recordings_clock(keys: Keys) -> str | None:
    """The ``[recordings] clock`` the task file states (:data:`CLOCKS`), or None where it states none."""
    value = keys.data.get("recordings")
    if not isinstance(value, dict) or "clock" not in value:
        return None
    clock = value["clock"]
    if clock not in CLOCKS:
        raise keys.error("recordings.clock", f"expected one of {', '.join(map(repr, CLOCKS))}, got {clock!r}")
    return str(clock)


def schedule_episode(keys: Keys) -> int | str | None:
    """The task file's ``schedule_episode``: an episode number, ``"each"`` (every episode its own task:
    :mod:`simtune.tasks.episodes`) or None (the dataset's first)."""
    from simtune.tasks.episodes import EACH

    episode = keys.data.get("schedule_episode")
    if episode is None or episode == EACH:
        return episode
    if not isinstance(episode, int) or isinstance(episode, bool) or episode < 0:
        raise keys.error("schedule_episode", f'expected an episode number (0 or more) or "{EACH}", got {episode!r}')
    return episode


def undriven_joints(robot: RobotDescription, driven: Sequence[str]) -> tuple[str, ...]:
    """The robot's joints that a task driving ``driven`` does not drive (a dataset's names for them are left out)."""
    return tuple(j.name for j in robot.joints if j.name not in driven)


def reading_for(task: TaskSpec, ranges: Mapping[str, JointRange] | None = None) -> LeRobotReading:
    """How ``task`` reads a LeRobot dataset.

    Args:
        task: the task whose recordings are read.
        ranges: what each driven joint's angles should fit (``simtune.objective.joint_ranges``); None: the stated
            unit is taken as given.

    Returns:
        Its task file's ``[recordings]`` table, with its robot's other joints and ``ranges``, against which the
        stated unit is checked.
    """
    return replace(
        task.lerobot or LeRobotReading(),
        undriven=undriven_joints(task.robot, task.joints),
        ranges=tuple((ranges or {}).items()),
    )


def joint_limits(robot: RobotDescription, joints: Sequence[str]) -> dict[str, tuple[float | None, float | None]]:
    """The limits of ``joints``' angular joints, which a schedule's stated unit is checked against.

    Args:
        robot: the task's robot.
        joints: the joints the task drives.

    Returns:
        Per revolute or continuous joint, its lower and upper limit [rad] (None, None: a continuous joint's); a
        prismatic joint has no entry (its values are no angles to tell a unit by).
    """
    angular = [robot.joint_by_name[j] for j in joints if robot.joint_by_name[j].kind in ("revolute", "continuous")]
    return {j.name: (j.lower, j.upper) for j in angular}


#: how far [s] a stored timestamp may lie from its frame's ``index / fps`` and still be that frame's time, rounded
#: (LeRobot stores ``frame_index / fps`` as float32: 0.1 s is stored as 0.10000000149 s)
FRAME_TIME_TOLERANCE_S = 1e-4


def on_frame_grid(time: np.ndarray, fps: float | None) -> np.ndarray:
    """An episode's timestamps as the frame times they stand for: each ``k / fps`` exactly where every one lies within
    :data:`FRAME_TIME_TOLERANCE_S` of it, else as stored.

    LeRobot synthesises timestamps as ``frame_index / fps`` and stores them as float32, a little off the frame's
    time.  A schedule of set-points at those times would switch a hair after the controller's tick that falls on a
    frame's time (every third tick at 30 fps against 20 Hz), a target one frame late there, which a tuned delay
    then makes up for (5 ms in a synthesised SO-101 dataset).

    Args:
        time: the timestamps [s], the episode's first at 0.
        fps: the dataset's frame rate (``meta/info.json``); None: the timestamps stay as stored.

    Returns:
        The timestamps, on the frame grid where they are on it.
    """
    if not fps or len(time) == 0:
        return time
    frames = np.round(np.asarray(time, dtype=float) * fps)
    grid = frames / float(fps)
    return grid if float(np.max(np.abs(grid - time))) < FRAME_TIME_TOLERANCE_S else time


def lerobot_schedule(
    keys: Keys,
    path: Path,
    joints: tuple[str, ...],
    reading: LeRobotReading | None,
    robot: RobotDescription,
    start_pose: tuple[float, ...] | None,
    duration: float,
    episode: int | None = None,
) -> tuple[tuple[Phase, ...], tuple[float, ...]]:
    """The schedule of ``schedule_lerobot`` (a dataset folder, relative to the task file): one phase per frame of
    the episode ``schedule_episode`` (default: the first; ``episode`` where it says ``"each"``), its ``action`` as
    the targets, up to ``duration``.

    Returns the phases and the start pose: ``start_pose`` when the file gives one, else the episode's first
    ``observation.state``.  A driven joint that the actions do not name is held at its start angle.

    The episode is checked as a recording of the task is (at least 2 frames, timestamps in seconds, covering the
    task's duration), and the stated unit against the joints' limits and what angles in each unit look like: a
    schedule that would collapse, hold its last action or move 57 times too far or too little is a ProjectError
    naming the file, the dataset and the episode.
    """
    given = [k for k in SCHEDULE_KEYS if keys.has(k)]
    if not keys.has("schedule_lerobot"):
        raise keys.error("schedule_episode", "names an episode of schedule_lerobot, which the file does not give")
    if len(given) != 1:
        raise keys.error(given[0], f"give the schedule as {', '.join(SCHEDULE_KEYS)}: exactly one of them")
    folder = keys.string("schedule_lerobot")
    assert folder is not None
    stated = schedule_episode(keys)
    if isinstance(stated, int) or stated is None:
        episode = stated
    assert episode is not None or stated is None, "an episode task's episode is given by load_task_files"
    reading = replace(reading or LeRobotReading(), undriven=undriven_joints(robot, joints))
    try:
        actions = read_lerobot_actions(
            path.parent / folder, episode, joints, reading, duration_s=duration, limits=joint_limits(robot, joints)
        )
    except RecordingError as exc:
        raise ProjectError(f"{path}: schedule_lerobot: {exc}") from None
    if start_pose is None:
        start_pose = tuple(math.degrees(actions.start.get(j, 0.0)) for j in joints)
    held = dict(zip(joints, np.radians(start_pose)))
    time = on_frame_grid(actions.time - actions.time[0], read_info(path.parent / folder).get("fps"))
    keep = np.flatnonzero((time < duration) & np.concatenate([[True], np.diff(time) > 0]))
    targets = np.degrees(np.column_stack([actions.targets.get(j, np.full(len(time), held[j])) for j in joints]))
    phases = tuple(Phase(float(time[i]), tuple(float(v) for v in targets[i])) for i in keep)
    return phases, start_pose
