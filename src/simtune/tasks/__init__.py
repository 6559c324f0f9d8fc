"""Task registry: look tasks up by name in a project; ``a,b`` or ``seed-11`` name several at once.

Tasks are files (docs/task-files.md) gathered by a project (:mod:`simtune.tasks.project`, also
:mod:`simtune.project`); without a project
the bundled Kinova MICO project is meant.  ``TASKS`` and ``GROUPS`` are that project's tasks and groups.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from simtune.errors import ConfigError
from simtune.tasks.spec import LOADINGS, MATERIALS, SHAPES, ObjectSpec, Phase, TaskSpec, common_robot

if TYPE_CHECKING:
    from simtune.robot.description import RobotDescription
    from simtune.tasks.project import Project


def _project(project: Project | Path | str | None) -> Project:
    # on first use: importing simtune.tasks (for TaskSpec) reads no project file
    from simtune.tasks.project import get_project

    return get_project(project)


#: Which targets a task's phases carry: ``task``, the task file's ``targets_deg`` (what the robot ran); ``published``,
#: a phase's ``published_targets_deg`` where the file corrects what was first published (:meth:`TaskSpec.as_published`)
TARGETS = ("task", "published")


def check_targets(targets: object, where: str = "targets") -> str:
    """``targets`` if it is one of :data:`TARGETS`; a one-line ConfigError naming ``where`` otherwise."""
    if targets not in TARGETS:
        raise ConfigError(f"{where} must be one of {', '.join(TARGETS)}, got {targets!r}")
    return str(targets)


def with_targets(tasks: list[TaskSpec], targets: str) -> list[TaskSpec]:
    """``tasks`` carrying ``targets`` (:data:`TARGETS`): as given, or each with its published schedule."""
    return [t.as_published() for t in tasks] if check_targets(targets) == "published" else list(tasks)


def check_loading(loading: object, where: str = "loading") -> str:
    """``loading`` if it is one of :data:`LOADINGS`; a one-line ConfigError naming ``where`` otherwise."""
    if loading not in LOADINGS:
        raise ConfigError(
            f"{where} must be one of {', '.join(LOADINGS)} (the robot as its description says, or as the paper "
            f"loaded it), got {loading!r}"
        )
    return str(loading)


def with_loading(tasks: list[TaskSpec], loading: str) -> list[TaskSpec]:
    """``tasks`` with the robot loaded as ``loading`` says (:data:`LOADINGS`)."""
    return [t.loaded_as(check_loading(loading)) for t in tasks]


def get_task(
    name: str, project: Project | Path | str | None = None, targets: str = "task", loading: str = "description"
) -> TaskSpec:
    """The task ``name`` of ``project`` (a Project, its folder, or None: the bundled MICO project), carrying
    ``targets`` (:data:`TARGETS`) and ``loading`` (:data:`LOADINGS`)."""
    return with_loading(with_targets([_project(project).task(name)], targets), loading)[0]


def all_task_names(project: Project | Path | str | None = None) -> list[str]:
    return _project(project).task_names()


def parse_tasks(
    spec: str, project: Project | Path | str | None = None, targets: str = "task", loading: str = "description"
) -> list[TaskSpec]:
    """Tasks named by ``spec``: one name, a group, or a comma-separated list of them, carrying ``targets``
    (:data:`TARGETS`: the task files' targets, or the published ones where a file corrects them) and ``loading``
    (:data:`LOADINGS`: the robot as its description says, or as the paper loaded it)."""
    return with_loading(with_targets(_project(project).parse_tasks(spec), targets), loading)


@dataclass(frozen=True)
class TaskSelection:
    """Tasks named for a run, resolved once: the project they were looked up in, the tasks (carrying their targets
    and loading) and the one robot they share."""

    project: Project
    tasks: list[TaskSpec]
    robot: RobotDescription


def select_tasks(
    spec: str, project: Project | Path | str | None = None, targets: str = "task", loading: str = "description"
) -> TaskSelection:
    """The tasks named by ``spec`` as :func:`parse_tasks` gives them, with the project they come from and their one
    robot: what a run's plan needs of ``tasks/``, in one call, the project resolved once.

    Args:
        spec: one task name, a group, or a comma-separated list of them.
        project: a Project, its folder or file, or None: the bundled MICO project.
        targets: which targets the phases carry (:data:`TARGETS`).
        loading: how the robot is loaded (:data:`LOADINGS`).

    Returns:
        The selection.

    Raises:
        ConfigError: an unknown task, targets or loading, or tasks that do not share one robot.
    """
    # parse_tasks's steps in its order (the project, its tasks, their targets, their loading), the project kept
    tasks = with_loading(with_targets((resolved := _project(project)).parse_tasks(spec), targets), loading)
    return TaskSelection(resolved, tasks, common_robot(tasks))


def held_out(tasks: list[TaskSpec], validate: str, option: str = "--validate") -> tuple[list[TaskSpec], list[TaskSpec]]:
    """The tasks a run tunes on and those it holds out (``--validate``), split once.

    Args:
        tasks: the tasks named (``--task``), in order.
        validate: empty (none held out); ``N``, the last N of ``tasks``; or a comma-separated list, each a task
            name or an episode number (``3``: the task of episode 3, ``<file>.ep3``, among ``tasks``).
        option: the option's name in messages.

    Returns:
        The tasks to tune on and those held out, each in the order of ``tasks``.

    Raises:
        ConfigError: a count or name that holds out no task, one not among ``tasks``, or all of them.
    """
    from simtune.tasks.episodes import episode_task_name

    text = validate.strip()
    if not text:
        return list(tasks), []
    names = [t.name for t in tasks]
    if text.isdigit():
        count = int(text)
        if not 1 <= count < len(tasks):
            raise ConfigError(
                f"{option} {text}: holds out the last N of the {len(tasks)} tasks named, N from 1 to {len(tasks) - 1} "
                "(at least one is left to tune on)"
            )
        held = names[-count:]
    else:
        held = []
        for part in (p.strip() for p in text.split(",")):
            by_episode = [n for n in names if part.isdigit() and n.endswith(episode_task_name("", int(part)))]
            found = [part] if part in names else by_episode
            if len(found) != 1:
                raise ConfigError(
                    f"{option}: {part!r} is not one of the tasks named ({', '.join(names)}): name a task, or an "
                    "episode's number"
                )
            if found[0] not in held:
                held.append(found[0])
        if len(held) == len(tasks):
            raise ConfigError(f"{option}: holds out every task named: leave at least one to tune on")
    return [t for t in tasks if t.name not in held], [t for t in tasks if t.name in held]


def __getattr__(name: str) -> Any:
    # read on first use: importing simtune.tasks reads no file
    if name == "TASKS":
        return dict(_project(None).tasks)
    if name == "GROUPS":
        return dict(_project(None).groups)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "GROUPS",
    "LOADINGS",
    "MATERIALS",
    "SHAPES",
    "TARGETS",
    "TASKS",
    "ObjectSpec",
    "Phase",
    "TaskSelection",
    "TaskSpec",
    "all_task_names",
    "check_loading",
    "check_targets",
    "get_task",
    "held_out",
    "parse_tasks",
    "select_tasks",
    "with_loading",
    "with_targets",
]
