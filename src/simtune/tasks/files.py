"""Task files: a task written as TOML or YAML (one schema, docs/task-files.md), read into a :class:`TaskSpec`.

Every problem is one :class:`~simtune.errors.ProjectError` line naming the file and the key
(``tasks/cube.toml: phases[2].start: ...``).  Names of joints and links are checked against the
robot when the caller knows it (:class:`RobotNames`); the project loader always does.
"""

from __future__ import annotations

import csv
import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import yaml

from simtune.data.lerobot import LeRobotReading
from simtune.errors import ProjectError
from simtune.robot.description import RobotDescription
from simtune.robot.mico import MICO
from simtune.tasks.episodes import EACH, episode_task_name
from simtune.tasks.keys import Keys, kind_of
from simtune.tasks.lerobot import SCHEDULE_KEYS, lerobot_schedule, recordings_clock, recordings_key, schedule_episode
from simtune.tasks.spec import INTERPOLATIONS, MATERIALS, SHAPES, ObjectSpec, Phase, TaskSpec
from simtune.tasks.yamlfile import load_yaml

#: The joint control laws a task file may name (``controller.law``); simtune.engines.controller runs them.
CONTROL_LAWS = ("clamped-p-velocity",)
#: Suffixes of the formats a task or project file may be written in.
TOML_SUFFIXES = (".toml",)
YAML_SUFFIXES = (".yaml", ".yml")
#: How many numbers ``object.size`` holds per shape (see ObjectSpec).
SIZE_LENGTHS = {"cube": 3, "cuboid": 3, "cylinder": 2, "cone": 2}


@dataclass(frozen=True)
class RobotNames:
    """What a task file is checked against: the robot's name, its movable joints (in order) and its links."""

    name: str
    joints: tuple[str, ...]
    links: tuple[str, ...]
    #: the link whose pose the engines report (the only one motion capture can track today)
    wrist_link: str
    #: the robot itself, which the tasks read carry (None: the bundled MICO, TaskSpec's default)
    description: RobotDescription | None = None

    @classmethod
    def of(cls, robot: RobotDescription) -> RobotNames:
        """The names of ``robot``: its driven joints, every link, its tracked link; the tasks carry it."""
        return cls(robot.name, robot.arm_joints, tuple(link.name for link in robot.links), robot.tracked_link, robot)


def read_document(path: Path) -> dict[str, Any]:
    """The mapping a TOML or YAML file holds (chosen by its suffix); one line for an unreadable file."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (*TOML_SUFFIXES, *YAML_SUFFIXES):
        raise ProjectError(f"{path}: unknown file type {suffix or '(none)'!r}: write it as .toml, .yaml or .yml")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ProjectError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ProjectError(f"{path}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    if suffix in TOML_SUFFIXES:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ProjectError(f"{path}: not valid TOML: {exc}") from None
    else:
        try:
            data = load_yaml(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
            problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
            raise ProjectError(f"{path}: not valid YAML: {problem}{where}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ProjectError(f"{path}: expected a mapping of keys at the top level, got a {kind_of(data)}")
    return data


TASK_KEYS = (
    "name",
    "description",
    "duration",
    "joints",
    "start_pose_deg",
    "controller",
    "phases",
    "schedule_csv",
    "target_offset_deg",
    "object",
    "mocap",
    "recordings",
    "public_recordings",
    "start_from_recordings",
    "schedule_lerobot",
    "schedule_episode",
)
CONTROLLER_KEYS = ("law", "gain", "max_velocity_deg", "interpolation")
PHASE_KEYS = ("start", "targets_deg", "published_targets_deg")
OBJECT_KEYS = ("shape", "material", "mass", "size", "xy", "rpy", "mocap_body")
MOCAP_KEYS = ("link", "body", "base_body")


def load_task_files(path: Path, robot: RobotNames | None = None, project_dir: Path | None = None) -> list[TaskSpec]:
    """The tasks that the TOML or YAML file ``path`` describes: one, or with ``schedule_episode = "each"`` one per
    episode of its LeRobot dataset (those its ``[recordings] episodes`` lists; default all), each named
    :func:`~simtune.tasks.episodes.episode_task_name` (``train.ep3``), driven by its episode's actions and compared
    with its episode's observations alone (docs/task-files.md).

    Args:
        path: the task file.
        robot: the names (and robot) the file is checked against, as :func:`load_task_file`'s.
        project_dir: the folder ``recordings`` is relative to (default: the file's folder).

    Returns:
        The tasks, in episode order.
    """
    path = Path(path)
    keys = Keys(path, read_document(path), TASK_KEYS)
    if schedule_episode(keys) != EACH:
        return [load_task_file(path, robot, project_dir)]
    from simtune.data.lerobot import episode_indices, index_ranges
    from simtune.errors import RecordingError

    if not keys.has("schedule_lerobot"):
        raise keys.error("schedule_episode", "names an episode of schedule_lerobot, which the file does not give")
    _, reading = recordings_key(keys, project_dir or path.parent)
    folder = str(keys.string("schedule_lerobot"))
    try:
        found = episode_indices(path.parent / folder)
    except RecordingError as exc:
        raise ProjectError(f"{path}: schedule_lerobot: {exc}") from None
    wanted = found if reading is None or reading.episodes is None else list(reading.episodes)
    missing = [k for k in wanted if k not in found]
    if missing:
        raise keys.error(
            "recordings.episodes",
            f"no episode {missing[0]} in {folder} (the dataset's episodes: {index_ranges(found)})",
        )
    return [load_task_file(path, robot, project_dir, episode=k) for k in wanted]


def load_task_file(
    path: Path,
    robot: RobotNames | None = None,
    project_dir: Path | None = None,
    reaimed: bool = True,
    episode: int | None = None,
) -> TaskSpec:
    """The task that the TOML or YAML file ``path`` describes (docs/task-files.md).

    ``robot``: check joint and link names against it (and use its joints when the file names none).
    ``project_dir``: the folder ``recordings`` is relative to (default: the file's folder).
    ``reaimed=False`` leaves out ``target_offset_deg`` (the schedule as first written).
    ``episode``: of a file whose ``schedule_episode`` is ``"each"``, the episode whose task to read (its name
    :func:`~simtune.tasks.episodes.episode_task_name`'s; :func:`load_task_files` reads them all).
    """
    path = Path(path)
    keys = Keys(path, read_document(path), TASK_KEYS)
    name = keys.string("name", required=True)
    assert name is not None
    if not name or name.strip() != name or any(c in name for c in "/\\,+") or name in (".", ".."):
        raise keys.error("name", f"{name!r} cannot name a task (it names the recordings' folder: no / \\ , +)")
    each = schedule_episode(keys) == EACH
    if each and episode is None:
        raise keys.error(
            "schedule_episode", f'"{EACH}" stands for one task per episode: read them with load_task_files'
        )
    if episode is not None and not each:
        raise keys.error("schedule_episode", f'reading episode {episode} of a file that is not "{EACH}"')
    duration = keys.number("duration", required=True)
    if duration <= 0:
        raise keys.error("duration", f"must be above 0 seconds, got {duration:g}")
    joints = _driven_joints(keys, robot)
    per_joint = f" (one per driven joint: {', '.join(joints)})"

    start_pose = keys.numbers("start_pose_deg", len(joints), per_joint)
    recordings, lerobot = recordings_key(keys, project_dir or path.parent)
    clock = recordings_clock(keys)
    # the robot the task carries (TaskSpec's default: the bundled MICO)
    description = MICO if robot is None or robot.description is None else robot.description
    kp, max_velocity, interpolation = _controller(keys)
    offset = keys.numbers("target_offset_deg", len(joints), per_joint)
    published: tuple[Phase, ...] | None = None
    if keys.has("schedule_lerobot") or keys.has("schedule_episode"):
        phases, start_pose = lerobot_schedule(keys, path, joints, lerobot, description, start_pose, duration, episode)
    else:
        phases, published = _schedule(keys, joints, per_joint, path)
    start_pose = start_pose or (0.0,) * len(joints)
    if offset is not None and reaimed:
        phases = _offset(phases, offset)
        published = None if published is None else _offset(published, offset)
    if robot is not None and robot.description is not None:
        _check_limits(keys, robot.description, joints, start_pose, phases)
        if published is not None:
            _check_limits(keys, robot.description, joints, start_pose, published, "published_targets_deg")
    if phases[-1].start >= duration:
        key = "schedule_csv" if keys.has("schedule_csv") else f"phases[{len(phases) - 1}].start"
        raise keys.error(key, f"starts at {phases[-1].start:g} s, not before the task's end (duration {duration:g} s)")

    link, body, base_body = _mocap(keys, robot)
    obj = _object(keys)
    if obj is not None and robot is not None and robot.description is not None:
        _check_gripper_surface(keys, robot.description)
    start_from_recordings = keys.flag("start_from_recordings", False)
    if start_from_recordings and obj is None:
        raise keys.error("start_from_recordings", "the task has no object to start where the recordings put it")
    carried: dict[str, Any] = {} if robot is None or robot.description is None else {"robot": robot.description}
    description_text = keys.string("description", default="") or ""
    group = None
    if episode is not None:
        group, name = name, episode_task_name(name, episode)
        description_text = f"episode {episode} of {group}" + (f": {description_text}" if description_text else "")
        # compared with its own episode's observations, from the dataset it replays unless the file names another
        lerobot = replace(lerobot or LeRobotReading(), episodes=(episode,))
        recordings = recordings or str((path.parent / str(keys.string("schedule_lerobot"))).resolve())
    if clock is None:
        # a schedule of a LeRobot episode's actions compared with that dataset's observations: one clock, logged
        schedule_folder = keys.string("schedule_lerobot")
        same = schedule_folder is not None and recordings == str((path.parent / schedule_folder).resolve())
        clock = "shared" if same else "own"
    return TaskSpec(
        name=name,
        description=description_text,
        duration=duration,
        phases=phases,
        kp=kp,
        max_velocity_deg=max_velocity,
        interpolation=interpolation,
        object=obj,
        wrist_body=body or "",
        start_pose_deg=start_pose,
        has_public_recordings=keys.flag("public_recordings", False),
        joints=joints,
        tracked_link=link,
        base_body=base_body,
        recordings=recordings,
        start_from_recordings=start_from_recordings,
        lerobot=lerobot,
        published_phases=published,
        shared_clock=clock == "shared",
        episode_of=group,
        **carried,
    )


def _check_gripper_surface(keys: Keys, robot: RobotDescription) -> None:
    """A task with an object needs a gripper link with a collision shape for the object to touch (a task
    without one touches nothing: a robot with no shapes at all runs it)."""
    if robot.gripper_surface:
        return
    named = ", ".join(robot.gripper_links) or "none"
    raise keys.error(
        "object",
        f"robot {robot.name!r} has no gripper surface for the object to touch: no gripper link ({named}) has a "
        f"collision shape; add a <collision> to one of them in {robot.source}, or name links that have "
        "one in the project's [robot] gripper_links",
    )


def _driven_joints(keys: Keys, robot: RobotNames | None) -> tuple[str, ...]:
    """The ``joints`` the task drives (default: the robot's), checked against the robot."""
    joints = keys.strings("joints")
    if joints is None:
        if robot is None:
            raise keys.error("joints", "missing: name the driven joints (required when no robot is known)")
        joints = robot.joints
    if not joints:
        raise keys.error("joints", "name at least one driven joint")
    if len(set(joints)) != len(joints):
        raise keys.error("joints", f"a joint is named twice: {list(joints)}")
    if robot is not None:
        for i, joint in enumerate(joints):
            if joint not in robot.joints:
                raise keys.error(f"joints[{i}]", f"robot {robot.name} has no movable joint {joint!r}")
        if joints != robot.joints:
            # the engines command every movable joint of the arm they build, in the robot's order
            raise keys.error(
                "joints", f"the engines drive every arm joint of {robot.name} in order: {', '.join(robot.joints)}"
            )
    return joints


def _mocap(keys: Keys, robot: RobotNames | None) -> tuple[str, str | None, str | None]:
    """The ``[mocap]`` table: the tracked link (checked against the robot), the wrist body and the base body."""
    mocap = keys.table("mocap", MOCAP_KEYS, required=True)
    assert mocap is not None
    link = mocap.string("link", default=robot.wrist_link if robot else None, required=robot is None)
    assert link is not None
    if robot is not None:
        if link not in robot.links:
            raise mocap.error("link", f"robot {robot.name} has no link {link!r}")
        if link != robot.wrist_link:
            raise mocap.error("link", f"the engines report the pose of {robot.wrist_link} only: track that link")
    return link, mocap.string("body", required=True), mocap.string("base_body")


def _offset(phases: tuple[Phase, ...], offset: tuple[float, ...]) -> tuple[Phase, ...]:
    """``phases`` with ``offset`` [deg] added to every target row (``target_offset_deg``)."""
    return tuple(Phase(p.start, tuple(t + d for t, d in zip(p.targets_deg, offset))) for p in phases)


def _check_limits(
    keys: Keys,
    robot: RobotDescription,
    joints: tuple[str, ...],
    start: tuple[float, ...],
    phases: tuple[Phase, ...],
    targets_key: str = "targets_deg",
) -> None:
    """Every start angle and target within its joint's limits (a joint without limits takes any angle)."""
    rows = [("start_pose_deg", start), *((f"phases[{k}].{targets_key}", p.targets_deg) for k, p in enumerate(phases))]
    for key, row in rows:
        for i, (name, angle) in enumerate(zip(joints, row)):
            joint = robot.joint_by_name[name]
            if joint.lower is None or joint.upper is None:
                continue
            lower, upper = math.degrees(joint.lower), math.degrees(joint.upper)
            if not lower - 1e-6 <= angle <= upper + 1e-6:
                schedule = next((k for k in SCHEDULE_KEYS[1:] if keys.has(k)), key)
                where = schedule if key.startswith("phases") else key
                raise keys.error(
                    f"{where}[{i}]" if where == key else where,
                    f"{angle:g} deg is outside the limits of {name} [{lower:.4g}, {upper:.4g}] deg",
                )


def _controller(keys: Keys) -> tuple[float, float, str]:
    """The ``[controller]`` table: its gain, velocity clamp and interpolation between set-points."""
    controller = keys.table("controller", CONTROLLER_KEYS, required=True)
    assert controller is not None
    law = controller.string("law", default=CONTROL_LAWS[0])
    if law not in CONTROL_LAWS:
        raise controller.error("law", f"unknown control law {law!r} (known: {', '.join(CONTROL_LAWS)})")
    gain = controller.number("gain", required=True, above=0.0)
    max_velocity = controller.number("max_velocity_deg", default=30.0, above=0.0)
    interpolation = controller.string("interpolation", default=INTERPOLATIONS[0])
    if interpolation not in INTERPOLATIONS:
        raise controller.error(
            "interpolation", f"unknown interpolation {interpolation!r} (known: {', '.join(INTERPOLATIONS)})"
        )
    return gain, max_velocity, interpolation


def _schedule(
    keys: Keys, joints: tuple[str, ...], per_joint: str, path: Path
) -> tuple[tuple[Phase, ...], tuple[Phase, ...] | None]:
    """The target schedule: ``[[phases]]`` or ``schedule_csv``, exactly one of them, in time order; and the
    published schedule where a phase corrects its published targets (``published_targets_deg``), else None."""
    if keys.has("phases") == keys.has("schedule_csv"):
        raise keys.error(
            "phases", "give the schedule as [[phases]], schedule_csv or schedule_lerobot (exactly one of them)"
        )
    if keys.has("schedule_csv"):
        csv_name = keys.string("schedule_csv")
        assert csv_name is not None
        return read_schedule_csv(path.parent / csv_name, joints, f"{path}: schedule_csv: "), None
    tables = keys.tables("phases", PHASE_KEYS) or []
    if not tables:
        raise keys.error("phases", "the schedule has no phase")
    phases: list[Phase] = []
    published: list[Phase] = []
    for phase in tables:
        start = phase.number("start", required=True)
        if start < 0:
            raise phase.error("start", f"must be 0 or later, got {start:g}")
        if phases and start <= phases[-1].start:
            raise phase.error(
                "start", f"{start:g} s is not after the previous phase's start {phases[-1].start:g} s (phases in order)"
            )
        targets = phase.numbers("targets_deg", len(joints), per_joint, required=True)
        phases.append(Phase(start, targets))
        # the targets a paper or an earlier file gave, where the recordings showed the robot ran others
        published.append(Phase(start, phase.numbers("published_targets_deg", len(joints), per_joint) or targets))
    corrected = any(p != q for p, q in zip(published, phases))
    return tuple(phases), (tuple(published) if corrected else None)


def read_schedule_csv(path: Path, joints: tuple[str, ...], where: str) -> tuple[Phase, ...]:
    """Commanded targets over time: a header ``time,<joint>,...`` (seconds, degrees), then one row per change."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = [row for row in csv.reader(fh) if row and not row[0].lstrip().startswith("#")]
    except FileNotFoundError:
        raise ProjectError(f"{where}{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ProjectError(f"{where}{path}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    header = [cell.strip() for cell in rows[0]] if rows else []
    expected = ["time", *joints]
    if header != expected:
        raise ProjectError(f"{where}{path}: line 1: expected the header {','.join(expected)}, got {','.join(header)}")
    phases: list[Phase] = []
    for number, row in enumerate(rows[1:], start=2):
        if len(row) != len(expected):
            raise ProjectError(f"{where}{path}: line {number}: expected {len(expected)} values, got {len(row)}")
        try:
            values = [float(cell) for cell in row]
        except ValueError:
            raise ProjectError(f"{where}{path}: line {number}: a value is not a number: {','.join(row)}") from None
        if not all(math.isfinite(v) for v in values):
            raise ProjectError(f"{where}{path}: line {number}: a value is not finite: {','.join(row)}")
        start = values[0]
        if start < 0 or (phases and start <= phases[-1].start):
            raise ProjectError(f"{where}{path}: line {number}: time {start:g} s is not after the previous row's")
        phases.append(Phase(start, tuple(values[1:])))
    if not phases:
        raise ProjectError(f"{where}{path}: no targets (a header and at least one row)")
    return tuple(phases)


def _object(keys: Keys) -> ObjectSpec | None:
    table = keys.table("object", OBJECT_KEYS)
    if table is None:
        return None
    shape = table.string("shape", required=True)
    if shape not in SHAPES:
        raise table.error("shape", f"unknown shape {shape!r} (known: {', '.join(SHAPES)})")
    material = table.string("material", required=True)
    if material not in MATERIALS:
        raise table.error("material", f"unknown material group {material!r} (known: {', '.join(MATERIALS)})")
    mass = table.number("mass", required=True, above=0.0)
    what = {3: " (x, y, z edge lengths [m])", 2: " (radius, length [m])"}[SIZE_LENGTHS[shape]]
    size = table.numbers("size", SIZE_LENGTHS[shape], f" for a {shape}{what}", required=True)
    for i, s in enumerate(size):
        if s <= 0:
            raise table.error(f"size[{i}]", f"must be above 0, got {s:g}")
    xy = table.numbers("xy", 2, " (x, y on the floor [m])", required=True)
    rpy = table.numbers("rpy", 3, " (roll, pitch, yaw [rad])") or (0.0, 0.0, 0.0)
    body = table.string("mocap_body", default="object")
    return ObjectSpec(shape, material, mass, size, xy, rpy, mocap_body=body)  # type: ignore[arg-type]
