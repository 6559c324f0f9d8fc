"""Projects: a robot, its task files and where their recordings are, tied together by ``simtune.toml``.

A project is a folder holding ``simtune.toml`` (or ``simtune.yaml``), written as docs/task-files.md
describes.  The Kinova MICO of the qrg2019 recordings and the seed paper is one such project, shipped
inside the package (:func:`bundled_project`); every command uses it when no ``--project`` is given.

Loading stops at the first problem with one line naming file and key (:class:`~simtune.errors.ProjectError`);
:meth:`Project.validate` lists what a loadable project still lacks (recordings folders, for instance).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from simtune.errors import ConfigError, ProjectError, RobotError
from simtune.robot import mico
from simtune.robot.description import RobotDescription
from simtune.tasks.files import Keys, RobotNames, load_task_files, read_document
from simtune.tasks.spec import TaskSpec

#: The names a project file may have in its folder, in the order they are looked for.
PROJECT_FILES = ("simtune.toml", "simtune.yaml", "simtune.yml")
PROJECT_KEYS = ("name", "description", "robot", "urdf", "tasks", "groups", "data")
#: The folder of the bundled MICO project (package data).
BUNDLED_DIR = Path(__file__).resolve().parent.parent / "projects" / "mico"
#: Robots known by name (``robot = "mico"``).
NAMED_ROBOTS = ("mico",)


@dataclass(frozen=True)
class Project:
    """A loaded project: its file, robot, tasks (by name, in the file's order), task groups and data root."""

    file: Path
    name: str
    description: str
    robot: RobotNames
    tasks: Mapping[str, TaskSpec]
    #: task name -> the task file it was read from
    task_files: Mapping[str, Path]
    #: names standing for several tasks whose fitness is summed (``seed-11``)
    groups: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    #: the default data root (``DATA/<task>/`` holds a task's recordings), when the project names one
    data: Path | None = None

    @property
    def root(self) -> Path:
        return self.file.parent

    def task_names(self) -> list[str]:
        return [*self.tasks, *self.groups]

    def task(self, name: str) -> TaskSpec:
        try:
            return self.tasks[name]
        except KeyError:
            raise ConfigError(
                f"unknown task {name!r} in project {self.name} (known: {', '.join(self.task_names())})"
            ) from None

    def parse_tasks(self, spec: str) -> list[TaskSpec]:
        """Tasks named by ``spec``: one name, a group, or a comma-separated list of them."""
        names: list[str] = []
        for part in (p.strip() for p in spec.split(",")):
            if not part:
                continue
            for name in self.groups.get(part, (part,)):
                if name not in names:
                    names.append(name)
        if not names:
            raise ConfigError("no task given (e.g. --task cube or --task single,cube)")
        return [self.task(n) for n in names]

    def data_root(self) -> Path | None:
        """The data root to use without ``--data``: the project's, unless a task file names another folder.

        None: each task's recordings are in its own ``recordings`` folder (``objective.load_references``).
        """
        if self.data is None or any(t.recordings != str(self.data / t.name) for t in self.tasks.values()):
            return None
        return self.data

    def validate(self) -> list[str]:
        """Problems a loaded project still has, one line each (empty: none found)."""
        problems = []
        if self.data is not None and self.data.exists() and not self.data.is_dir():
            problems.append(f"{self.file}: data: {self.data} is a file, not a folder of recordings")
        elif self.data is not None and not self.data.is_dir():
            problems.append(f"{self.file}: data: folder {self.data} does not exist")
        for name, task in self.tasks.items():
            folder = None if task.recordings is None else Path(task.recordings)
            if folder is None:
                problems.append(f"{self.task_files[name]}: no recordings folder (name one, or data in {self.file})")
            elif not folder.is_dir():
                problems.append(f"{self.task_files[name]}: recordings folder {folder} does not exist")
        return problems


def find_project_file(path: Path) -> Path:
    """The project file of ``path``: the file itself, or the one project file in the folder."""
    path = Path(path)
    if path.is_file():
        return path
    if not path.is_dir():
        raise ProjectError(f"project {path}: no such folder")
    found = [path / name for name in PROJECT_FILES if (path / name).is_file()]
    if not found:
        raise ProjectError(f"project {path}: no project file ({' or '.join(PROJECT_FILES)})")
    if len(found) > 1:
        raise ProjectError(f"project {path}: two project files ({', '.join(p.name for p in found)}): keep one")
    return found[0]


#: Keys of a project file's ``[robot]`` table (a robot from a URDF or an MJCF file; arguments of ``load_robot``).
ROBOT_KEYS = (
    "urdf",
    "mjcf",
    "name",
    "joints",
    "tracked_link",
    "base_position",
    "base_rpy",
    "held",
    "gripper_links",
    "servo_gain",
    "max_velocity_deg",
    "package_path",
    "density",
    "total_mass",
)


def resolve_robot(keys: Keys, folder: Path) -> RobotNames:
    """The robot a project file names: ``robot = "mico"`` (the bundled MICO), or a ``[robot]`` table naming a
    URDF or MJCF file (relative to ``folder``, or absolute) and how to read it (docs/task-files.md)."""
    if keys.has("urdf"):  # the spelling docs/task-files.md announced before the [robot] table
        raise keys.error("urdf", 'name the URDF in the robot table: [robot] then urdf = "<file>.urdf"')
    if not keys.has("robot"):
        raise keys.error(
            "robot", 'missing: robot = "mico", or a [robot] table with urdf = "<file>.urdf" (or mjcf = "<file>.xml")'
        )
    if isinstance(keys.data["robot"], dict):
        return RobotNames.of(_file_robot(keys, folder))
    name = keys.string("robot")
    if name not in NAMED_ROBOTS:
        raise keys.error("robot", f"unknown robot {name!r} (known: {', '.join(NAMED_ROBOTS)}; or a [robot] table)")
    links = tuple(link.name for link in mico.LINKS)
    return RobotNames("mico", mico.ARM_JOINTS, links, mico.WRIST_LINK)


def _file_robot(keys: Keys, folder: Path) -> RobotDescription:
    """The ``[robot]`` table's robot, read with :func:`~simtune.robot.load.load_robot` from its ``urdf`` or its
    ``mjcf`` file (either key: the file's root element tells the format); its errors name the key."""
    from simtune.robot.load import load_robot

    table = keys.table("robot", ROBOT_KEYS)
    assert table is not None
    if table.has("urdf") and table.has("mjcf"):
        raise table.error("mjcf", "name one robot file: urdf or mjcf, not both")
    file_key = "mjcf" if table.has("mjcf") else "urdf"
    file = table.string(file_key, required=True)
    assert file is not None
    robot_file = (folder / Path(file).expanduser()).resolve()
    if not robot_file.is_file():
        raise table.error(file_key, f"no {file_key.upper()} file {robot_file}")
    held: dict[str, float] = {}
    held_table = table.data.get("held")
    if held_table is not None and not isinstance(held_table, dict):
        raise table.error("held", "expected a table: joint name = position [rad or m]")
    for joint, position in (held_table or {}).items():
        held[str(joint)] = table.check_number(f"held.{joint}", position)
    base_position = table.numbers("base_position", 3, " (x, y, z [m])") or (0.0, 0.0, 0.0)
    base_rpy = table.numbers("base_rpy", 3, " (roll, pitch, yaw [rad])") or (0.0, 0.0, 0.0)
    joints = table.strings("joints")
    if joints is not None and not joints:
        raise table.error("joints", "name at least one driven joint (or leave the key out)")
    tracked_link = table.string("tracked_link")
    gripper_links = table.strings("gripper_links")
    servo_gain = table.number("servo_gain", above=0.0)
    clamp = table.numbers("max_velocity_deg", 2, " (the velocity clamp's range: low, high [deg/s])")
    if clamp is not None and not 0 < clamp[0] < clamp[1]:
        raise table.error("max_velocity_deg", f"expected 0 < low < high [deg/s], got {list(clamp)}")
    package_path = _package_path(table, folder)
    density, total_mass = table.number("density", above=0.0), table.number("total_mass", above=0.0)
    if density is not None and total_mass is not None:
        raise table.error("total_mass", "give density or total_mass, not both (a total mass sets the density)")
    try:
        robot = load_robot(
            robot_file,
            arm_joints=joints,
            tracked_link=tracked_link,
            base_position=base_position,
            base_rpy=base_rpy,
            held=held,
            gripper_links=gripper_links,
            name=table.string("name"),
            package_path=package_path,
            density=density,
            total_mass=total_mass,
        )
    except RobotError as exc:
        # name the key whose joint or link the file lacks; the message itself names the file
        message = str(exc)
        named = {"joints": joints or (), "tracked_link": (tracked_link,), "held": held, "gripper_links": gripper_links}
        key = next((k for k, names in named.items() if any(f"{n!r}" in message for n in names or ())), file_key)
        key = "total_mass" if ": total_mass " in message else key
        key = "density" if ": density " in message else key
        key = "package_path" if ": package_path " in message else key
        raise table.error(key, message) from None
    if servo_gain is not None:
        robot = replace(robot, servo_gain=float(servo_gain))
    return robot if clamp is None else replace(robot, max_velocity_range=(float(clamp[0]), float(clamp[1])))


def _package_path(table: Keys, folder: Path) -> list[str]:
    """The ``[robot] package_path`` entries with their folders relative to ``folder``: ``DIR`` (a package
    folder, or a folder of packages) or ``NAME=DIR`` (package NAME is folder DIR, which must exist)."""
    from simtune.robot.urdf import package_entry

    entries = []
    for i, entry in enumerate(table.strings("package_path") or ()):
        name, where = package_entry(entry)
        where = folder / where
        if name is None:
            entries.append(str(where))
            continue
        if not where.is_dir():
            raise table.error(f"package_path[{i}]", f"{entry!r}: no folder {where} for package {name!r}")
        entries.append(f"{name}={where}")
    return entries


def load_project(path: Path | str) -> Project:
    """The project in folder ``path`` (or the project file ``path``), every task file read and checked."""
    return _read_project(find_project_file(Path(path)))


def _read_project(file: Path) -> Project:
    """The project of project file ``file`` (found by :func:`find_project_file`), every task file read and checked."""
    folder = file.parent
    keys = Keys(file, read_document(file), PROJECT_KEYS)
    robot = resolve_robot(keys, folder)
    data = keys.string("data")
    data_root = None if data is None else (folder / data).resolve()
    task_entries = keys.strings("tasks", required=True) or ()
    if not task_entries:
        raise keys.error("tasks", "name at least one task file")
    tasks: dict[str, TaskSpec] = {}
    task_files: dict[str, Path] = {}
    episode_groups: dict[str, tuple[str, ...]] = {}
    for i, entry in enumerate(task_entries):
        task_file = folder / entry
        if not task_file.is_file():
            raise keys.error(f"tasks[{i}]", f"no task file {task_file}")
        # one task, or one per episode of a dataset (schedule_episode = "each"), grouped under the file's name
        episode_group: list[str] = []
        for task in load_task_files(task_file, robot, project_dir=folder):
            if task.recordings is None and data_root is not None:
                task = replace(task, recordings=str(data_root / task.name))
            if task.name in tasks:
                raise keys.error(f"tasks[{i}]", f"task {task.name!r} is also defined in {task_files[task.name]}")
            tasks[task.name] = task
            task_files[task.name] = task_file
            if task.episode_of is not None:
                episode_group.append(task.name)
                episode_groups[task.episode_of] = tuple(episode_group)
    groups: dict[str, tuple[str, ...]] = {}
    if keys.has("groups") and not isinstance(keys.data["groups"], dict):
        raise keys.error("groups", "expected a table: group name = [task names]")
    for group, members in (keys.data.get("groups") or {}).items():
        where = f"groups.{group}"
        if not isinstance(group, str) or not group or group.strip() != group or any(c in group for c in ",+"):
            # --task splits its names at commas (and grid joins tasks with +): such a group could not be named
            raise keys.error(where, f"{group!r} cannot name a group (no , or +, no spaces at its ends)")
        if group in tasks or group in episode_groups:
            raise keys.error(
                where, f"{group!r} already names a task" + (" file's episodes" if group in episode_groups else "")
            )
        if not isinstance(members, list) or not members or not all(isinstance(m, str) for m in members):
            raise keys.error(where, "expected a list of task names")
        expanded: list[str] = []
        for m in members:
            if m not in tasks and m not in episode_groups:
                raise keys.error(where, f"unknown task {m!r} (known: {', '.join([*tasks, *episode_groups])})")
            expanded.extend(n for n in episode_groups.get(m, (m,)) if n not in expanded)
        groups[str(group)] = tuple(expanded)
    groups = {**episode_groups, **groups}
    return Project(
        file=file,
        name=keys.string("name", default=folder.name) or folder.name,
        description=keys.string("description", default="") or "",
        robot=robot,
        tasks=tasks,
        task_files=task_files,
        groups=groups,
        data=data_root,
    )


@functools.cache
def bundled_project() -> Project:
    """The Kinova MICO project shipped with simtune (qrg2019 and seed-paper tasks)."""
    return load_project(BUNDLED_DIR)


#: A user's projects read in this process: the project file's resolved path -> the project and the state of the
#: files it was read from (:func:`_files_state`).  A run's readers name its project by its file many times over
#: (each task of each run of a report), and reading it means reading its robot, so it is read once; a file edited
#: since is read again.
_READ: dict[Path, tuple[Project, tuple]] = {}


def _files_state(project: Project) -> tuple:
    """Each file ``project`` was read from (its project file, task files and robot file) with its modification time
    and size: what tells a project edited since it was read.  A file gone: None in its place."""
    robot = project.robot.description
    sources = [] if robot is None else [s for s in (robot.source, robot.mjcf) if s and s != "bundled"]
    state: list[tuple[Path, int | None, int | None]] = []
    for file in (project.file, *project.task_files.values(), *map(Path, sources)):
        try:
            stat = file.stat()
            state.append((file, stat.st_mtime_ns, stat.st_size))
        except OSError:
            state.append((file, None, None))
    return tuple(state)


def get_project(project: Project | Path | str | None) -> Project:
    """``project`` loaded: a Project as it is, a folder or file loaded (once per process while its files stay as they
    were), None the bundled MICO project."""
    if project is None:
        return bundled_project()
    if isinstance(project, Project):
        return project
    file = find_project_file(Path(project))
    key = file.resolve()
    cached = _READ.get(key)
    # the same spelling as well: a project read through another path names its files by that path
    if cached is not None and cached[0].file == file and _files_state(cached[0]) == cached[1]:
        return cached[0]
    loaded = _read_project(file)  # the file just found: not looked for a second time
    _READ[key] = (loaded, _files_state(loaded))
    return loaded
