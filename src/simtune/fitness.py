"""Fitness: how far a simulation is from the recordings (the seed paper's equations 1 and 2).

wrist error  = mean over the 20 Hz samples of the 3-D distance between the
               simulated marker and the mean recorded wrist trajectory [m]
object error = 3-D distance between the simulated and the mean recorded final
               object position [m] (tasks with an object only)
fitness      = wrist error + object error, summed over the tasks tuned together

The simulated marker is the wrist (link_6 origin) moved by ``marker_offset_*``
in the hand frame, so the offset turns with the hand as a real marker does.
A simulation that became unstable scores :data:`PENALTY` (finite, so the
optimiser carries on) and is flagged, never silently mixed with real scores.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from simtune.data import TaskData
from simtune.engines.base import Rollout

#: Fitness of a rollout that exploded [m]: worse than any arm that stays in its workspace.
PENALTY = 10.0


@dataclass
class TaskScore:
    task: str
    fitness: float
    wrist_error: float
    object_error: float | None
    stable: bool = True
    message: str = ""
    #: stopped early because it could no longer beat its parent: fitness is a lower bound
    pruned: bool = False
    steps: int = 0  # physics steps simulated


@dataclass
class Score:
    """Fitness of one parameter set over one or more tasks, with its parts."""

    fitness: float
    wrist_error: float
    object_error: float | None
    tasks: list[TaskScore] = field(default_factory=list)

    @property
    def stable(self) -> bool:
        return all(t.stable for t in self.tasks)

    @property
    def pruned(self) -> bool:
        return any(t.pruned for t in self.tasks)

    @classmethod
    def combine(cls, scores: list[TaskScore]) -> Score:
        objects = [s.object_error for s in scores if s.object_error is not None]
        return cls(
            fitness=float(sum(s.fitness for s in scores)),
            wrist_error=float(sum(s.wrist_error for s in scores)),
            object_error=float(sum(objects)) if objects else None,
            tasks=list(scores),
        )

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> Score:
        return cls(
            data["fitness"], data["wrist_error"], data["object_error"], [TaskScore(**t) for t in data.get("tasks", [])]
        )


def marker_positions(rollout: Rollout, params: dict[str, float]) -> np.ndarray:
    """Simulated positions of the motion-capture marker: the wrist plus its offset in the hand frame."""
    offset = np.array([params.get(f"marker_offset_{a}", 0.0) for a in "xyz"])
    if not offset.any():
        return rollout.wrist_pos
    return rollout.wrist_pos + np.einsum("nij,j->ni", rollout.wrist_rot, offset)


def score_rollout(rollout: Rollout, reference: TaskData, params: dict[str, float]) -> TaskScore:
    """Score one task's rollout against its recordings."""
    n = len(reference.times)
    if len(rollout.times) != n:
        raise ValueError(f"rollout has {len(rollout.times)} samples, the reference {n}")
    marker = marker_positions(rollout, params)
    distances = np.linalg.norm(marker - reference.wrist_mean, axis=1)
    if rollout.pruned:
        # only the simulated samples count: a lower bound of the full wrist error
        bound = float(distances[: rollout.samples_run].sum() / n)
        message = f"pruned at t={rollout.times[rollout.samples_run - 1]:.2f} s: cannot beat its parent"
        return TaskScore(reference.task, bound, bound, None, True, message, pruned=True, steps=rollout.steps)
    wrist_error = float(np.mean(distances))
    object_error = None
    if reference.object_final is not None and rollout.object_pos is not None:
        object_error = float(np.linalg.norm(rollout.object_pos[-1] - reference.object_final_mean))
    fitness = wrist_error + (object_error or 0.0)
    if not rollout.stable:
        fitness = PENALTY
    return TaskScore(
        reference.task, fitness, wrist_error, object_error, rollout.stable, rollout.message, steps=rollout.steps
    )


def rollout_residuals(rollout: Rollout, reference: TaskData, params: dict[str, float]) -> np.ndarray:
    """One task's residual vector for least squares (kept apart from the scalar fitness above).

    The simulated marker minus the mean recorded wrist at every 20 Hz sample (x, y, z), divided by
    sqrt(samples), then, for a task with an object, the simulated minus the recorded final object
    position.  Its sum of squares is the mean squared marker distance plus the squared object distance:
    the task's fitness with squared instead of plain distances.  Coordinates rather than distances: they
    are smooth where a distance has a kink (at zero), which Gauss-Newton steps need.
    """
    n = len(reference.times)
    parts = [((marker_positions(rollout, params) - reference.wrist_mean) / np.sqrt(n)).ravel()]
    if reference.object_final is not None and rollout.object_pos is not None:
        parts.append(rollout.object_pos[-1] - reference.object_final_mean)
    return np.concatenate(parts)
