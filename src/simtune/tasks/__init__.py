"""Task registry: look tasks up by name; ``a,b`` or ``seed-11`` name several at once."""

from __future__ import annotations

from simtune.errors import ConfigError
from simtune.tasks import qrg2019, seed
from simtune.tasks.spec import MATERIALS, SHAPES, ObjectSpec, Phase, TaskSpec

TASKS: dict[str, TaskSpec] = {t.name: t for t in (*qrg2019.TASKS, *seed.TASKS)}

#: Names that stand for several tasks whose fitness is summed (the seed paper's experiment 11).
GROUPS: dict[str, tuple[str, ...]] = {"seed-11": tuple(f"seed-{n}" for n in range(1, 11))}


def get_task(name: str) -> TaskSpec:
    try:
        return TASKS[name]
    except KeyError:
        raise ConfigError(f"unknown task {name!r} (known: {', '.join(all_task_names())})") from None


def all_task_names() -> list[str]:
    return [*TASKS, *GROUPS]


def parse_tasks(spec: str) -> list[TaskSpec]:
    """Tasks named by ``spec``: one name, a group, or a comma-separated list of them."""
    names: list[str] = []
    for part in (p.strip() for p in spec.split(",")):
        if not part:
            continue
        for name in GROUPS.get(part, (part,)):
            if name not in names:
                names.append(name)
    if not names:
        raise ConfigError("no task given (e.g. --task cube or --task single,cube)")
    return [get_task(n) for n in names]


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
