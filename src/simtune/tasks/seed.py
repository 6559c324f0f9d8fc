"""The ten tasks of the seed paper (Collins et al., ACRA 2021), as first written.

The tasks themselves are files of the bundled MICO project (``projects/mico/tasks/seed-N.toml``).
Their recordings are not public; ``simtune synth`` can make recordings of them
from a simulation.  Odd tasks push the plastic object, even tasks its wooden
replica; objects start at (0.6, 0) resting on the floor.

The joint schedules are the authors', but with the arm of :mod:`simtune.robot.mico`
none of the pushing schedules reaches its object in any engine: the hand passes
0.8 to 8 cm away.  Each pushing task file therefore adds the smallest joint_2 /
joint_3 offset (``target_offset_deg``) with which the generic simulation pushes
the object; docs/seed-tasks.md has the evidence (``benchmarks/seed_contact_search.py``)
and the contact table per engine.  :func:`published_task` builds a task with the
authors' schedule unchanged.
"""

from dataclasses import replace

from simtune.tasks.files import load_task_file
from simtune.tasks.spec import Phase, TaskSpec


def offset_schedule(phases: tuple[Phase, ...], joint_2: float, joint_3: float) -> tuple[Phase, ...]:
    """``phases`` with ``joint_2`` and ``joint_3`` degrees added to those joints' targets."""
    return tuple(
        Phase(p.start, (p.targets_deg[0], p.targets_deg[1] + joint_2, p.targets_deg[2] + joint_3, *p.targets_deg[3:]))
        for p in phases
    )


def published_task(number: int) -> TaskSpec:
    """Seed task ``number`` with the authors' schedule: its task file without ``target_offset_deg``."""
    from simtune.tasks.project import bundled_project

    project = bundled_project()
    name = f"seed-{number}"
    task = load_task_file(project.task_files[name], project.robot, project_dir=project.root, reaimed=False)
    note = " (schedule re-aimed: docs/seed-tasks.md)"
    return replace(task, description=task.description.removesuffix(note), recordings=project.task(name).recordings)
