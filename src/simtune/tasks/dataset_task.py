"""``simtune init --dataset``: the task file of a LeRobot dataset, every episode its own task.

A lab starts from a robot description and a dataset of many different episodes.  :func:`dataset_task` reads the
dataset once and writes what a user would otherwise work out by hand: the driven joints its ``action`` names map to
by name (``shoulder_pan.pos`` -> ``shoulder_pan``; the robot's other joints left out), the angle unit that fits the
joints' limits (LeRobot stores none), a duration every episode covers, a velocity clamp above anything the
episodes command, and ``schedule_episode = "each"`` (:mod:`simtune.tasks.episodes`).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simtune.data.lerobot import (
    ACTION,
    ANGLE_UNITS,
    POS_SUFFIX,
    LeRobotReading,
    feature_names,
    read_episodes,
    read_info,
    read_lerobot_actions,
)
from simtune.errors import ProjectError, RecordingError
from simtune.robot.description import RobotDescription
from simtune.tasks.lerobot import joint_limits, undriven_joints

#: the shortest episode's length is rounded down to this step [s] for the task's duration
DURATION_STEP_S = 0.5
#: the controller's velocity clamp is at least this [deg/s] and this factor above the fastest commanded motion
MIN_CLAMP_DEG, CLAMP_MARGIN = 30.0, 1.5


@dataclass(frozen=True)
class DatasetTask:
    """What :func:`dataset_task` read from a dataset and wrote for it."""

    name: str  # the task file's name (its tasks are ``<name>.ep<k>``)
    text: str  # the task file
    episodes: int
    units: str
    joints: tuple[str, ...]  # the driven joints the dataset's actions name
    duration_s: float


def task_name_of(folder: Path) -> str:
    """A task name from a dataset folder's name: what --task can name (no commas, plus signs, slashes or spaces)."""
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", folder.name).strip("._") or "episodes"
    return name


def _units(root: Path, robot: RobotDescription, joints: tuple[str, ...], episode: int) -> str:
    """The angle unit in which the first episode's actions and states fit the joints' limits: degrees unless only
    radians fit; neither: the degrees' problem, naming the dataset."""
    problems = []
    for unit in ANGLE_UNITS:
        reading = LeRobotReading(units=unit, undriven=undriven_joints(robot, joints))
        try:
            read_lerobot_actions(root, episode, joints, reading, limits=joint_limits(robot, joints))
        except RecordingError as exc:
            problems.append(str(exc))
            continue
        return unit
    raise ProjectError(f"--dataset: {problems[0]}")


def dataset_task(robot: RobotDescription, dataset: Path, tasks_dir: Path, project_dir: Path) -> DatasetTask:
    """The task file for every episode of the LeRobot dataset ``dataset``, driven by its ``action`` streams.

    Args:
        robot: the project's robot as loaded (its driven joints are the ones the dataset's names are matched to).
        dataset: the dataset's folder.
        tasks_dir: the folder the task file is written to (``schedule_lerobot`` is relative to it).
        project_dir: the project's folder (``[recordings] folder`` is relative to it).

    Returns:
        The task file and what it was made of.

    Raises:
        ProjectError: one line naming the dataset: not a dataset, names that match none of the driven joints, no
            unit that fits the limits, an episode too short.
    """
    dataset = Path(dataset).expanduser().resolve()
    try:
        info = read_info(dataset)
        names = feature_names(dataset, info, ACTION)
        episodes = read_episodes(dataset, [ACTION])
    except RecordingError as exc:
        raise ProjectError(f"--dataset: {exc}") from None
    driven = robot.arm_joints
    joints = tuple(j for j in driven if j in names or j + POS_SUFFIX in names)
    if not joints:
        raise ProjectError(
            f"--dataset: {dataset}: features.{ACTION}.names: none of {', '.join(names)} names a driven joint of "
            f"{robot.name} ({', '.join(driven)}): name the joints as the robot's description does (or <joint>.pos), "
            "or map them in the task file's [recordings.joints] by hand"
        )
    strangers = [
        n for n in names if n not in robot.joint_by_name and n.removesuffix(POS_SUFFIX) not in robot.joint_by_name
    ]
    if strangers:
        raise ProjectError(
            f"--dataset: {dataset}: features.{ACTION}.names: {', '.join(map(repr, strangers))} names no joint of "
            f"{robot.name} (its joints: {', '.join(robot.joint_by_name)}): init maps the dataset's names by name; map "
            "these in the task file's [recordings.joints] by hand"
        )
    first = episodes[0].index
    units = _units(dataset, robot, joints, first)
    lengths = []
    fastest = 0.0
    reading = LeRobotReading(units=units, undriven=undriven_joints(robot, joints))
    for episode in episodes:
        actions = read_lerobot_actions(dataset, episode.index, joints, reading)
        time = actions.time - actions.time[0]
        step = float(np.median(np.diff(time))) if len(time) > 1 else 0.0
        lengths.append(float(time[-1]) + step)
        for q in actions.targets.values():
            if len(q) > 1:
                rates = np.abs(np.diff(q)) / np.maximum(np.diff(time), 1e-9)
                # the 95th percentile: a teleoperator's steady moves, not one frame's jump
                fastest = max(fastest, float(np.quantile(rates, 0.95)))
    shortest = min(lengths)
    duration = math.floor(shortest / DURATION_STEP_S) * DURATION_STEP_S
    if duration <= 0:
        short = episodes[int(np.argmin(lengths))].index
        raise ProjectError(
            f"--dataset: {dataset}: episode {short} lasts {shortest:.3g} s: too short to be a task (at least "
            f"{DURATION_STEP_S:g} s); leave it out of the task file's [recordings] episodes by hand"
        )
    clamp = max(MIN_CLAMP_DEG, math.ceil(CLAMP_MARGIN * math.degrees(fastest) / 10.0) * 10.0)
    name = task_name_of(dataset)
    text = "\n".join(
        [
            f"# Every episode of the LeRobot dataset {dataset.name}, each its own task ({name}.ep<k>), driven by its",
            "# episode's actions and compared with its episode's observations (docs/task-files.md,",
            '# schedule_episode = "each"). Written by simtune init --dataset; edit it as any task file.',
            f"name = {_quoted(name)}",
            f'description = "{len(episodes)} episodes of {dataset.name}"',
            f"duration = {duration:g}  # [s]: the shortest episode ({shortest:.3g} s) covers it",
            f"joints = [{', '.join(map(_quoted, joints))}]  # the driven joints the dataset's actions name",
            f"schedule_lerobot = {_quoted(_relative(dataset, tasks_dir))}  # relative to this file",
            'schedule_episode = "each"',
            "",
            "[recordings]",
            f"folder = {_quoted(_relative(dataset, project_dir))}  # relative to the project",
            f'units = "{units}"  # the unit in which the actions and states fit the joints\' limits (checked)',
            "# episodes = [0, 1, 2]  # optional: which episodes become tasks (default: all)",
            "",
            "[controller]",
            'law = "clamped-p-velocity"',
            "gain = 10.0  # [1/s]",
            f"max_velocity_deg = {clamp:g}  # [deg/s]: above the fastest the episodes command "
            f"({math.degrees(fastest):.3g} deg/s)",
            "",
            "[mocap]",
            f"link = {_quoted(robot.tracked_link)}",
            'body = "hand"  # required by the schema; a dataset holds joint angles, no markers',
            "",
        ]
    )
    return DatasetTask(name, text, len(episodes), units, joints, duration)


def _quoted(value: str) -> str:
    """A TOML basic string."""
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _relative(path: Path, base: Path) -> str:
    """``path`` relative to ``base`` where both lie in one tree (a project kept beside its data), else absolute."""
    relative = os.path.relpath(path, base)
    return str(path) if relative.count("..") > 3 else Path(relative).as_posix()
