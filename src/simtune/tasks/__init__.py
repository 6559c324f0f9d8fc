"""Task registry: look tasks up by name in a project; ``a,b`` or ``seed-11`` name several at once.

Tasks are files (docs/task-files.md) gathered by a project (:mod:`simtune.tasks.project`, also
:mod:`simtune.project`); without a project
the bundled Kinova MICO project is meant.  ``TASKS`` and ``GROUPS`` are that project's tasks and groups.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from simtune.tasks.spec import MATERIALS, SHAPES, ObjectSpec, Phase, TaskSpec

if TYPE_CHECKING:
    from simtune.tasks.project import Project


def _project(project: Project | Path | str | None) -> Project:
    # on first use: importing simtune.tasks (for TaskSpec) reads no project file
    from simtune.tasks.project import get_project

    return get_project(project)


def get_task(name: str, project: Project | Path | str | None = None) -> TaskSpec:
    """The task ``name`` of ``project`` (a Project, its folder, or None: the bundled MICO project)."""
    return _project(project).task(name)


def all_task_names(project: Project | Path | str | None = None) -> list[str]:
    return _project(project).task_names()


def parse_tasks(spec: str, project: Project | Path | str | None = None) -> list[TaskSpec]:
    """Tasks named by ``spec``: one name, a group, or a comma-separated list of them."""
    return _project(project).parse_tasks(spec)


def __getattr__(name: str) -> Any:
    # read on first use: importing simtune.tasks reads no file
    if name == "TASKS":
        return dict(_project(None).tasks)
    if name == "GROUPS":
        return dict(_project(None).groups)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "GROUPS",
    "MATERIALS",
    "SHAPES",
    "TASKS",
    "ObjectSpec",
    "Phase",
    "TaskSpec",
    "all_task_names",
    "get_task",
    "parse_tasks",
]
