"""Whether, when and how the arm touches a task's object in one engine's simulation.

A task with an object is only a pushing task if the hand reaches the object: a
schedule that misses it leaves a kinematic task with a still object (the seed
tasks' schedules come from the authors' code and no recording checks them
here).  The probe runs the ordinary rollout with the engine's generic
parameters, watches the engine's own contact list after every physics step, and
reports the first instant an arm or finger shape touches the object, the arm's
pose and the object's position then, and how far the object has moved at the
end of the task.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simtune.engines.base import Engine


def rollout_samples(duration: float, rate: float = 20.0) -> int:
    """Samples of a rollout that covers ``duration`` seconds at ``rate``, both ends included."""
    return int(round(duration * rate)) + 1


@dataclass(frozen=True)
class ContactProbe:
    """What one engine's simulation of one task shows about arm-object contact."""

    task: str
    engine: str
    touched: bool
    first_contact_s: float | None  # simulated time of the first physics step with contact
    object_displacement_m: float  # distance between the object's start and end positions
    object_start: np.ndarray  # (3,) [m]
    object_end: np.ndarray  # (3,) [m]
    #: the arm's joint angles [rad] and the object's position [m] at first contact (at the end if none)
    pose_angles: np.ndarray
    pose_object: np.ndarray
    stable: bool = True
    message: str = ""

    def as_json(self) -> dict:
        """The fields of ``simtune tasks --contact --json``, exactly."""
        return {
            "task": self.task,
            "engine": self.engine,
            "touched": self.touched,
            "first_contact_s": None if self.first_contact_s is None else round(self.first_contact_s, 6),
            "object_displacement_m": round(self.object_displacement_m, 6),
        }


def probe_contact(engine: Engine, params: dict[str, float] | None = None) -> ContactProbe:
    """Simulate ``engine``'s task with ``params`` (default: generic) and record its first arm-object contact."""
    task = engine.task
    if task.object is None:
        raise ValueError(f"task {task.name!r} has no object to touch")
    steps = 0
    first: tuple[float, np.ndarray, np.ndarray] | None = None

    def watch() -> None:
        nonlocal steps, first
        steps += 1
        if first is None and engine.arm_object_contact():
            position = engine.object_position()
            assert position is not None, "a task with an object has its position"
            first = (steps * engine.timestep, engine.joint_angles(), position)

    rollout = engine.rollout(params or {}, rollout_samples(task.duration), after_step=watch)
    assert rollout.object_pos is not None, "a task with an object samples its position"
    start, end = rollout.object_pos[0], rollout.object_pos[-1]
    time, angles, position = first if first is not None else (None, rollout.joint_angles[-1], end)
    return ContactProbe(
        task=task.name,
        engine=engine.name,
        touched=first is not None,
        first_contact_s=time,
        object_displacement_m=float(np.linalg.norm(end - start)),
        object_start=start.copy(),
        object_end=end.copy(),
        pose_angles=np.asarray(angles, dtype=float),
        pose_object=np.asarray(position, dtype=float),
        stable=rollout.stable,
        message=rollout.message,
    )


#: what a touch of the floor does to a task without an object, for the warnings of ``check`` and ``synth``
FLOOR_TOUCH_CONSEQUENCE = (
    "a task without an object is tuned as if it never did (the floor's surfaces are held), and each touch makes the "
    "fitness jump with the parameters; keep the hand clear of the floor"
)


def touch_spans_text(spans: list[tuple[float, float]] | list[list[float]], most: int | None = None) -> str:
    """``spans`` (:func:`floor_touches`) in words, ``0.65-0.71 s, 0.73-1.50 s``; past ``most`` of them, `` ...``."""
    shown = spans if most is None else spans[:most]
    return ", ".join(f"{a:.2f}-{b:.2f} s" for a, b in shown) + (" ..." if len(shown) < len(spans) else "")


def generic_floor_touches(engine: Engine) -> list[tuple[float, float]] | None:
    """What ``simtune check`` asks of a task's generic simulation: :func:`floor_touches` for a task without an
    object, the one check of a task and of a project alike.

    Args:
        engine: an engine loaded for the task.
    Returns:
        The spans [s] during which the arm touches the floor; empty for a task with an object (a touch may be the
        task's own: none asked); None where the engine cannot tell (no ``arm_floor_contact``).
    """
    if engine.task.object is not None:
        return []
    try:
        return floor_touches(engine)
    except NotImplementedError:
        return None


def floor_touches(engine: Engine, params: dict[str, float] | None = None) -> list[tuple[float, float]]:
    """When the arm touches the floor in ``engine``'s task with ``params`` (default: generic).

    A task without an object is tuned as if the arm never reached the floor (the floor's and gripper's surface
    parameters are held as inactive); an arm that does reach it makes the fitness jump with every parameter that
    moves a touch by one physics step, which no local search or Gauss-Newton interval survives.

    Args:
        engine: an engine for the task (its :meth:`~simtune.engines.base.Engine.arm_floor_contact` implemented).
        params: the parameters to simulate (default: the engine's generic values).
    Returns:
        The spans of simulated time [s] during which some arm shape touches the floor, first to last step of
        each span, in order; empty if it never does.
    """
    steps = 0
    spans: list[tuple[float, float]] = []
    touching = False

    def watch() -> None:
        nonlocal steps, touching
        steps += 1
        now = engine.arm_floor_contact()
        if now and touching:
            spans[-1] = (spans[-1][0], steps * engine.timestep)
        elif now:
            spans.append((steps * engine.timestep, steps * engine.timestep))
        touching = now

    engine.rollout(params or {}, rollout_samples(engine.task.duration), after_step=watch)
    return spans
