"""Re-simulation for the report: untuned and tuned rollouts, recordings, nominal parameter values."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simtune.data import TaskData
from simtune.engines import make_engine
from simtune.engines.controller import JointController
from simtune.errors import SimtuneError
from simtune.fitness import (
    FitnessWeights,
    Score,
    TaskScore,
    joint_columns,
    marker_positions,
    rollout_joint_names,
    score_rollout,
)
from simtune.objective import Objective, load_references, recordings_folder
from simtune.params.kinds import outside_generics
from simtune.report.collect import Group, ReportedRun
from simtune.tasks import TaskSpec


class References:
    """Recordings per (data folder, task, reference kind, repeats), loaded once.

    ``reference``: what every run is re-scored against (``aligned`` or ``mean``); None: each run's own (a run
    stored before the choice: the mean).  ``repeats``: of which of each task's repeats (``all``, ``even`` or
    ``odd``); None: each run's own (a run stored before the choice: all).
    """

    def __init__(self, reference: str | None = None, repeats: str | None = None) -> None:
        self.reference = reference
        self.repeats = repeats
        self._cache: dict[tuple[str, str, str, str, bool], TaskData | SimtuneError] = {}

    def get(
        self, data: str | None, task: TaskSpec, reference: str = "mean", repeats: str = "all", keep: bool = False
    ) -> TaskData:
        """``task``'s recordings under ``data`` as ``reference`` and ``repeats`` say (``keep``: every repeat, as a run
        tuned with ``--keep-repeats`` saw them; else the repeat check leaves a far one out, as the run did)."""
        key = (str(recordings_folder(data, task).resolve()), task.name, reference, repeats, keep)
        if key not in self._cache:
            try:
                root = None if data is None else Path(data)
                self._cache[key] = load_references(
                    root, [task], reference=reference, repeats=repeats, keep_repeats=keep
                )[task.name]
            except SimtuneError as exc:
                self._cache[key] = exc
        value = self._cache[key]
        if isinstance(value, SimtuneError):
            raise value
        return value

    def kind(self, run: ReportedRun) -> str:
        """The reference ``run`` is re-scored against."""
        return self.reference or run.config.reference

    def selection(self, run: ReportedRun) -> str:
        """The repeats ``run`` is re-scored against: all, even or odd."""
        return self.repeats or run.config.repeats

    def label(self, run: ReportedRun) -> str:
        """The reference ``run`` is re-scored against, as the report names it (``aligned``, ``mean of the even
        repeats``)."""
        kind, selection = self.kind(run), self.selection(run)
        return kind if selection == "all" else f"{kind} of the {selection} repeats"

    def for_run(self, run: ReportedRun) -> dict[str, TaskData]:
        return {
            t: self.get(run.config.data, run.task(t), self.kind(run), self.selection(run), run.config.keep_repeats)
            for t in run.task_names
        }


@dataclass
class TaskTrajectory:
    """One task of one group: the recordings and the untuned and tuned simulations of the marker."""

    task: str
    reference: TaskData
    untuned_marker: np.ndarray  # (n, 3)
    tuned_marker: np.ndarray
    untuned_object: np.ndarray | None  # (n, 3) or None
    tuned_object: np.ndarray | None
    untuned_score: TaskScore
    tuned_score: TaskScore
    spans: list[tuple[str, float, float]]  # the schedule's stretches as the tuned simulation runs them
    #: the logged joints' simulated angles (n, logged joints) [rad], in the recordings' order; None: no joint logs
    untuned_joints: np.ndarray | None = None
    tuned_joints: np.ndarray | None = None


@dataclass
class HeldOut:
    """The best parameters of a run tuned on some repeats (``--repeats even`` or ``odd``), scored on the others."""

    selection: str  # the repeats scored: "odd" for a run tuned on the even ones
    score: Score | None  # None: not scored (``message`` says why)
    repeats: dict[str, int] = field(default_factory=dict)  # task -> held-out repeats scored
    message: str = ""


@dataclass
class GroupSimulation:
    group: Group
    run: ReportedRun  # the group's best run, whose parameters are simulated
    params: dict[str, float]
    tasks: dict[str, TaskTrajectory]
    held_out: HeldOut | None = None  # None: the run was tuned on all its tasks' repeats

    @property
    def tuned_fitness(self) -> float:
        return float(sum(t.tuned_score.fitness for t in self.tasks.values()))


def run_weights(run: ReportedRun) -> FitnessWeights:
    """The weights of the fitness's parts ``run`` was tuned with (``--weights``; the defaults where it gave none)."""
    return FitnessWeights() if run.config.weights is None else FitnessWeights.from_mapping(run.config.weights)


#: the repeats a run tuned on some of them did not see
OTHER_REPEATS = {"even": "odd", "odd": "even"}


def simulate_group(group: Group, references: References) -> GroupSimulation:
    """Re-simulate the group's best run with generic and with its tuned parameters, on each of its tasks (scored
    with the run's own weights); a run tuned on the even or odd repeats is also scored on the others."""
    run = group.best_run
    refs = references.for_run(run)
    tasks = [run.task(t) for t in run.task_names]
    weights = run_weights(run)
    objective = Objective(run.engine, tasks, refs, weights=weights)
    params = run.best_params
    try:
        untuned = objective.rollouts({})
        tuned = objective.rollouts(params)
    finally:
        objective.close()
    out = {}
    for task in run.task_names:
        ref = refs[task]
        joints = rollout_joint_names(run.task(task))
        columns = None if ref.joint_mean is None else joint_columns(ref, joints)
        out[task] = TaskTrajectory(
            task=task,
            reference=ref,
            untuned_marker=marker_positions(untuned[task], {}),
            tuned_marker=marker_positions(tuned[task], params),
            untuned_object=untuned[task].object_pos,
            tuned_object=tuned[task].object_pos,
            untuned_score=score_rollout(untuned[task], ref, {}, weights=weights, joint_names=joints),
            tuned_score=score_rollout(tuned[task], ref, params, weights=weights, joint_names=joints),
            spans=run.task(task).stretches(JointController(run.task(task), params).delay),
            untuned_joints=None if columns is None else untuned[task].joint_angles[:, columns],
            tuned_joints=None if columns is None else tuned[task].joint_angles[:, columns],
        )
    return GroupSimulation(group, run, params, out, held_out=_held_out(run, tasks, references, weights))


def _held_out(
    run: ReportedRun, tasks: list[TaskSpec], references: References, weights: FitnessWeights
) -> HeldOut | None:
    """``run``'s best parameters scored on the repeats it was not tuned on; None where it was tuned on all of them
    (or the report re-scores it on other repeats than its own: its fitness there is already a held-out one)."""
    tuned_on = run.config.repeats
    if tuned_on not in OTHER_REPEATS or references.selection(run) != tuned_on:
        return None
    other = OTHER_REPEATS[tuned_on]
    try:
        held = {
            t.name: references.get(run.config.data, t, references.kind(run), other, run.config.keep_repeats)
            for t in tasks
        }
    except SimtuneError as exc:
        return HeldOut(other, None, message=str(exc))
    objective = Objective(run.engine, tasks, held, weights=weights)
    try:
        score = objective.score(run.best_params)
    finally:
        objective.close()
    return HeldOut(other, score, {name: len(ref.sources) for name, ref in held.items()})


def nominal_values(engine: str, tasks: list[TaskSpec]) -> dict[str, float]:
    """Generic value of every parameter ``engine`` has on these tasks: its own defaults, and the controller's and the
    marker's from the kinds table (:func:`simtune.params.kinds.outside_generics`: each joint's clamp and gain)."""
    values: dict[str, float] = {}
    for task in tasks:
        sim = make_engine(engine, task)
        try:
            for key, value in sim.defaults().items():
                values.setdefault(key, float(value))
        finally:
            sim.close()
        for key, value in outside_generics(task.robot.n_joints, task.max_velocity_deg, task.kp).items():
            values.setdefault(key, value)
    return values
