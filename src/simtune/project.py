"""Projects: a robot, its task files and where their recordings are, tied together by ``simtune.toml``.

The project is defined in :mod:`simtune.tasks.project`, inside the tasks package whose registry
(``simtune.tasks.get_task``) reads it: the tasks package never imports a module outside it that imports it back.
This is its public name (docs/task-files.md).
"""

from simtune.tasks.project import (
    BUNDLED_DIR,
    PROJECT_FILES,
    PROJECT_KEYS,
    Project,
    bundled_project,
    find_project_file,
    get_project,
    load_project,
)

__all__ = [
    "BUNDLED_DIR",
    "PROJECT_FILES",
    "PROJECT_KEYS",
    "Project",
    "bundled_project",
    "find_project_file",
    "get_project",
    "load_project",
]
