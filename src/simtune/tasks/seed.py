"""The ten tasks of the seed paper (Collins et al., ACRA 2021).

Their recordings are not public; ``simtune synth`` can make recordings of them
from a simulation.  Odd tasks push the plastic object, even tasks its wooden
replica; objects start at (0.6, 0) resting on the floor.

The joint schedules are the authors' (``_SCHEDULES``), but with the arm of
:mod:`simtune.robot.mico` none of the pushing schedules reaches its object in
any engine: the hand passes 0.8 to 8 cm away.  Each pushing schedule therefore
gets the smallest joint_2 / joint_3 offset (``SCHEDULE_FIXES``, added to every
phase's targets) with which the generic simulation pushes the object;
docs/seed-tasks.md has the evidence (``benchmarks/seed_contact_search.py``) and
the contact table per engine.  :func:`published_task` builds a task with the
authors' schedule unchanged.
"""

from dataclasses import replace
from math import pi

from simtune.tasks.spec import ObjectSpec, Phase, TaskSpec

_MASSES = {  # nominal masses [kg]: plastic, wood
    "cube": (0.07, 0.46),
    "cylinder": (0.12, 0.78),
    "cone": (0.04, 0.17),
    "cuboid": (0.14, 0.85),
}
_SIZES = {
    "cube": (0.075, 0.075, 0.075),
    "cylinder": (0.0375, 0.150),
    "cone": (0.0375, 0.100),
    "cuboid": (0.075, 0.075, 0.150),
}
_POSES = {  # how each object lies on the floor
    "cube": (0.0, 0.0, 0.0),
    "cylinder": (pi / 2, 0.0, 0.0),  # lying on its side
    "cone": (0.0, 1.92957, 0.0),  # on its side, a generator line on the floor
    "cuboid": (0.0, 0.0, 0.0),  # standing
}


def _object(shape: str, material: str) -> ObjectSpec:
    mass = _MASSES[shape][0 if material == "plastic" else 1]
    return ObjectSpec(shape, material, mass, _SIZES[shape], (0.6, 0.0), _POSES[shape])


def _phases(*rows: tuple[float, tuple[float, ...]]) -> tuple[Phase, ...]:
    return tuple(_phase(t, targets) for t, targets in rows)


def _phase(start: float, targets: tuple[float, ...]) -> Phase:
    j1, j2, j3, j4, j5, j6 = (float(a) for a in targets)  # six arm joints, or a ValueError
    return Phase(float(start), (j1, j2, j3, j4, j5, j6))


_SCHEDULES = {
    1: (10.0, None, _phases((0, (0, -90, 0, 0, 0, 0)), (3, (0, 0, 90, 0, 0, 0)), (6, (0, -90, 0, 0, 90, 0)))),
    2: (
        14.0,
        None,
        _phases(
            (0, (-2, -3, -8, 10, -2, 0)),
            (3, (47, -20, 34, 8, -19, 0)),
            (5, (46, -23, 70, 13, -42, 0)),
            (7, (19, -37, 83, 0, -63, 0)),
            (9, (-23, -26, 104, -88, -47, 0)),
            (11, (-32, -20, 34, 2, -21, 0)),
        ),
    ),
    3: (
        13.0,
        "cube",
        _phases(
            (0, (-3, -30, 101, 97, -4, -11)),
            (3, (-3, -57, 73, 101, -4, -12)),
            (5, (-3, -66, 44, 101, -4, -12)),
            (7, (15, -60, 49, 107, -3, -96)),
            (9, (15, -84, 28, 107, -4, -96)),
            (11, (-20, -84, 28, 107, -4, -96)),
        ),
    ),
    5: (
        79.0,
        "cylinder",
        _phases(
            (0, (0, -11, 105, 87, -4, 1)),
            (3, (0, -40, 94, 87, -4, 1)),
            (6, (2, -57, 70, 87, -4, 1)),
            (9, (0, -57, 63, 87, -5, 1)),
        ),
    ),
    7: (
        69.0,
        "cone",
        _phases((0, (-11, -66, 5, 11, -58, 100)), (3, (2, -88, 5, 11, -49, 100)), (6, (9, -88, 8, 11, -49, 100))),
    ),
    9: (
        9.0,
        "cuboid",
        _phases((0, (-5, -14, 110, 91, 0, 0)), (3, (-2, -40, 85, 91, 0, 0)), (6, (-2, -50, 20, 91, 0, 0))),
    ),
}


#: Degrees added to joint_2's and joint_3's target in every phase of a pushing schedule (odd task number;
#: the even task shares it), found by benchmarks/seed_contact_search.py: see docs/seed-tasks.md.
SCHEDULE_FIXES: dict[int, tuple[int, int]] = {3: (-2, 0), 5: (-18, -20), 7: (-2, 0), 9: (-18, 0)}


def offset_schedule(phases: tuple[Phase, ...], joint_2: float, joint_3: float) -> tuple[Phase, ...]:
    """``phases`` with ``joint_2`` and ``joint_3`` degrees added to those joints' targets."""
    return tuple(
        _phase(p.start, (p.targets_deg[0], p.targets_deg[1] + joint_2, p.targets_deg[2] + joint_3, *p.targets_deg[3:]))
        for p in phases
    )


def published_task(number: int) -> TaskSpec:
    """Seed task ``number`` with the authors' schedule, without the fix of :data:`SCHEDULE_FIXES`."""
    odd = number if number % 2 else number - 1
    duration, shape, phases = _SCHEDULES[odd]
    if shape is None:  # tasks 1 and 2 are two different kinematic schedules
        duration, shape, phases = _SCHEDULES[number]
    material = "plastic" if number % 2 else "wood"
    obj = _object(shape, material) if shape else None
    what = f"push the {material} {shape}" if obj else "move the arm (no object)"
    return TaskSpec(
        name=f"seed-{number}",
        description=f"seed paper task {number}: {what}",
        duration=duration,
        phases=phases,
        kp=4.0,
        object=obj,
    )


def _seed_task(number: int) -> TaskSpec:
    task = published_task(number)
    fix = SCHEDULE_FIXES.get(number if number % 2 else number - 1)
    if fix is None:
        return task
    note = " (schedule re-aimed: docs/seed-tasks.md)"
    return replace(task, phases=offset_schedule(task.phases, *fix), description=task.description + note)


TASKS = tuple(_seed_task(n) for n in range(1, 11))
