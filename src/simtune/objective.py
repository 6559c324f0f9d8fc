"""The objective: parameter values in, fitness out, for one engine on one or more tasks.

An :class:`Objective` holds only plain data (engine name, task specs, the
resampled recordings), so it pickles cheaply to worker processes; each process
builds its engines on first use and keeps them, resetting them between
evaluations instead of rebuilding.
"""

from __future__ import annotations

import copy
import math
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeVar

import numpy as np

from simtune.activity import task_content
from simtune.data import TaskData, load_task_data
from simtune.data.cache import cached, value_digest
from simtune.data.clock import read_later
from simtune.data.fingerprint import folders_fingerprint
from simtune.data.sanity import JointRange
from simtune.engines import Engine, engine_class, make_engine
from simtune.engines.base import MarkerBudget, Rollout
from simtune.errors import ConfigError, RecordingError, RecordingWarning, SimtuneError
from simtune.fitness import (
    PENALTY,
    FitnessWeights,
    Score,
    SignalNoise,
    TaskScore,
    noise_floor,
    rollout_joint_names,
    score_rollout,
    signal_noise,
)
from simtune.fitness import residuals as task_residuals
from simtune.params import ParameterSpace
from simtune.params.kinds import JOINT_OFFSET_RANGE, MARKER, applied_outside, kind_of, outside_generics, prior_width
from simtune.tasks import TaskSpec
from simtune.tasks.lerobot import reading_for

#: Rollouts an objective keeps per task, for the points that differ from one of them in the marker offset only
#: (:meth:`Objective._rollout_batch`): the points a least-squares phase's last batch scored, whose Jacobian comes next
RECENT_ROLLOUTS = 8


def load_task_recordings(
    folder: Path,
    task: TaskSpec,
    joint_topic: str | None = None,
    reference: str = "mean",
    repeats: str = "all",
    keep_repeats: bool = False,
) -> TaskData:
    """One task's recordings from ``folder``, with what the task and its robot tell the loader's sanity stage,
    averaged as ``reference`` says (``aligned``: on one clock, :mod:`simtune.data.clock`; ``mean``: as recorded),
    of the repeats ``repeats`` selects (``all``, ``even`` or ``odd``: :func:`simtune.data.load_task_data`), a
    repeat far from the others left out unless ``keep_repeats`` (:mod:`simtune.data.screen`).

    A task that starts its object where the recordings put it (``start_from_recordings``) needs recordings that
    track the object: joint logs alone are a one-line error.
    """
    ranges = joint_ranges(task)
    options = dict(
        wrist_body=task.wrist_body,
        object_body=task.object.mocap_body if task.object is not None else None,
        duration_s=task.duration,
        reach_m=task.robot.reach,
        base_body=task.base_body,
        joint_names=rollout_joint_names(task),
        joint_topic=joint_topic,
        lerobot=reading_for(task, ranges),  # its stated unit is checked against them too
        joint_ranges=ranges,
        reference=reference,
        repeats=repeats,
        keep_repeats=keep_repeats,
    )
    data = cached_recordings(Path(folder), task.name, options)
    if task.start_from_recordings and task.object is not None and data.object_start_mean is None:
        raise RecordingError(
            f"task {task.name!r}: start_from_recordings = true starts the object where the recordings track it, "
            f"but the recordings in {folder} are joint logs, without the object {task.object.mocap_body!r}: "
            "set start_from_recordings = false in its task file, or record the object"
        )
    return data


def cached_recordings(folder: Path, task: str, options: dict) -> TaskData:
    """``load_task_data(folder, task, **options)``, read from the start-up cache (:mod:`simtune.data.cache`) where the
    same recordings were loaded with the same options before: reading, screening and aligning ``cube``'s 23 repeats
    costs a second.  The key is the recordings' bytes (:func:`~simtune.data.fingerprint.folders_fingerprint`), the
    folder (the result names its files) and the options; a folder that cannot be fingerprinted is loaded as it is,
    so that the loader's own error says what is wrong with it."""
    try:
        files = folders_fingerprint({task: folder})[task]
    except OSError:
        return load_task_data(folder, task, **options)
    # the folder as given and as resolved: the result names its files by the path given
    what = {"folder": [str(folder), str(folder.resolve())], "files": files, "task": task, "options": options}
    return cached("references", what, lambda: load_task_data(folder, task, **options))


def simulation_content(engine: str, tasks: Sequence[TaskSpec], references: dict[str, TaskData]) -> dict:
    """What a simulation of ``tasks`` against ``references`` depends on besides its parameters and simtune's code,
    for a start-up cache's key (:mod:`simtune.data.cache`): the engine and its version, each task and its robot by
    content (:func:`simtune.activity.task_content`), each task's reference by value."""
    return {
        "engine": f"{engine} {engine_class(engine).version()}",
        "tasks": [task_content(t, engine) for t in tasks],
        "references": [value_digest(references[t.name]) for t in tasks],
    }


def generic_score(objective: Objective) -> Score:
    """``objective.score({})``, the engine's generic parameters, read from the start-up cache where the same
    engine, tasks, references and weights were scored before."""
    what = simulation_content(objective.engine, objective.tasks, objective.references)
    what["weights"] = objective.weights.as_dict()
    return cached("generic", what, lambda: objective.score({}))


def joint_ranges(task: TaskSpec) -> dict[str, JointRange]:
    """What each driven joint's logged angles should fit [rad]: the task's start angle, the range its schedule
    commands (start pose and every target), the joint's limits (the units check of joint logs), its velocity limit and
    the encoder offset the calibrated space tunes (the ingest's clock and offset checks, :mod:`simtune.data.ingest`)."""
    _, table = task.schedule
    angles = np.radians(table)
    ranges = {}
    for k, name in enumerate(task.joints):
        joint = task.robot.joint_by_name[name]
        if joint.kind in ("revolute", "continuous"):
            column = angles[:, k]
            ranges[name] = JointRange(
                float(column[0]),
                float(column.min()),
                float(column.max()),
                joint.lower,
                joint.upper,
                velocity=joint.velocity or None,  # 0: not given, as a URDF's missing limit reads
                tuned_offset=math.radians(JOINT_OFFSET_RANGE),
            )
    return ranges


def load_references(
    root: Path | None,
    tasks: list[TaskSpec],
    joint_topic: str | None = None,
    reference: str = "mean",
    repeats: str = "all",
    keep_repeats: bool = False,
) -> dict[str, TaskData]:
    """The recordings of each task, from ``root/<task name>/``, checked against the task and the arm, averaged as
    ``reference`` says (``aligned`` or ``mean``: :func:`load_task_recordings`), of the repeats ``repeats``
    selects (``all``, ``even`` or ``odd``), a repeat far from the others left out unless ``keep_repeats``.

    Without ``root``, each task's own recordings folder (``TaskSpec.recordings``, from its project).
    The task's duration, its robot's reach and its joint names go to the loader's sanity stage as
    plain values (data/ knows neither tasks nor robots); ``joint_topic`` picks the JointState
    topic of ROS 2 joint logs.

    The arm's start pose is checked against the recordings: where the tracked link's origin at the
    start pose lies more than :data:`START_WARN_M` from the mean recorded wrist at rest at the start,
    a RecordingWarning says by how much (a wrong start pose, frame or body; the marker offset can
    absorb a few centimetres at most).
    """
    if root is not None:
        root = Path(root)
        if not root.is_dir():
            what = "is a file, not a folder of recordings" if root.exists() else "does not exist"
            raise SimtuneError(f"data folder {root} {what} (expected {root}/<task>/*.tsv)")
    refs = {}
    for task in tasks:
        folder = recordings_folder(root, task)
        if not folder.is_dir():
            what = f"{folder} is a file, not a folder" if folder.exists() else f"folder {folder} does not exist"
            raise SimtuneError(f"no recordings for task {task.name!r}: {what}")
        refs[task.name] = load_task_recordings(folder, task, joint_topic, reference, repeats, keep_repeats)
        gap = start_pose_gap(task, refs[task.name])
        if gap is not None and gap > START_WARN_M:
            warnings.warn(
                f"task {task.name!r}: start pose check: the arm's {task.tracked_link} starts {gap * 100:.1f} cm "
                f"from the recorded wrist at rest at the start in {folder} (more than {START_WARN_M * 100:g} cm): "
                "check the task's start_pose_deg and the recordings' frame",
                RecordingWarning,
                stacklevel=2,
            )
    return refs


#: A start pose whose tracked link lies farther than this [m] from the first recorded wrist position is
#: warned about: more than the marker offset's +-5 cm per axis plausibly absorbs on one axis.
START_WARN_M = 0.03


def start_pose_gap(task: TaskSpec, reference: TaskData) -> float | None:
    """Distance [m] between the tracked link's origin at the task's start pose and the mean recorded
    wrist position at rest at the start (:attr:`TaskData.wrist_start_mean`); None when the recordings track no wrist."""
    recorded = reference.wrist_start_mean
    if recorded is None:
        return None
    simulated, _ = task.robot.forward_kinematics(np.radians(task.start_pose_deg), task.tracked_link)
    return float(np.linalg.norm(simulated - recorded))


def started_as_recorded(task: TaskSpec, reference: TaskData) -> TaskSpec:
    """``task`` with its object where the recordings put it before the arm moves, when the task asks for
    it (``start_from_recordings``) and the recordings track the object; else ``task`` itself."""
    start = reference.object_start_mean
    if not task.start_from_recordings or start is None:
        return task
    return task.started_at((float(start[0]), float(start[1])))


def recordings_folder(root: Path | str | None, task: TaskSpec) -> Path:
    """Where ``task``'s recordings are: ``root/<task>``, or without a root the task's own folder."""
    if root is not None:
        return Path(root) / task.name
    if task.recordings is None:
        raise SimtuneError(
            f"task {task.name!r} has no recordings folder: give --data ROOT (ROOT/{task.name}/*.tsv) "
            "or name one in its task file (recordings = ...)"
        )
    return Path(task.recordings)


@dataclass(frozen=True)
class Prior:
    """A prior on the tuned parameters (``--prior STRENGTH``: a maximum a posteriori fit): each parameter's distance
    from its generic value, over its width, costs ``strength`` noise floors per width squared.

    In the residual vector least squares fits each parameter adds ``sqrt(strength) * (x - centre) / width *
    sqrt(floor's sum of squares)``; to the scalar fitness the other optimisers minimise, ``strength * floor's fitness
    * sum((x - centre) / width)^2`` (:meth:`Objective.prior_penalty`): at strength 1 a parameter one width off costs
    each of them what the data's noise floor scores (:func:`simtune.fitness.noise_floor`), a tenth of a width a
    hundredth of it.  The widths are the kinds' (:data:`simtune.params.kinds.PRIOR_WIDTHS`).

    ``centres`` and ``widths`` hold the parameters the prior holds, by name: those of the space with a generic value
    (the encoders' offsets and compliance: 0, their kinds' generic value) and a width (a command delay has none: it is
    the recording's clock, not the arm's).
    """

    strength: float
    centres: dict[str, float]
    widths: dict[str, float]

    @property
    def names(self) -> list[str]:
        return list(self.centres)

    def deviations(self, params: dict[str, float]) -> np.ndarray:
        """Each held parameter's distance from its centre in widths, in :attr:`names`' order (a parameter missing
        from ``params``: at its generic value, 0)."""
        return np.array(
            [(params.get(name, centre) - centre) / self.widths[name] for name, centre in self.centres.items()]
        )


def make_prior(objective: Objective, strength: float) -> Prior:
    """The prior of ``strength`` on ``objective``'s space: each parameter centred on its generic value
    (:func:`generic_values`; one without: 0 where its range holds 0, else no prior on it), its width its kind's
    (:func:`simtune.params.kinds.prior_width`); a name of no kind, and a command delay, have none.

    Args:
        objective: the run's objective (its engine, tasks and space).
        strength: the prior's strength, above 0 (1: one width off costs a noise floor).
    Returns:
        The prior.
    """
    space = objective.vector_space()
    generic = generic_values(objective, space.names)
    centres: dict[str, float] = {}
    widths: dict[str, float] = {}
    for p in space.parameters:
        centre = generic.get(p.name)
        if centre is None and p.low <= 0.0 <= p.high:
            centre = 0.0
        width = None if centre is None or kind_of(p.name) is None else prior_width(p.name, p.low, p.high, centre)
        if centre is None or width is None:
            continue
        centres[p.name] = float(centre)
        widths[p.name] = width
    return Prior(float(strength), centres, widths)


class Objective:
    """Scores parameter dicts (or vectors of a space) for ``engine`` on ``tasks``, its parts weighted by ``weights``;
    with ``prior_strength`` (``--prior``), the parameters' distance from their generic values costs too (:class:`Prior`:
    a score's :attr:`~simtune.fitness.Score.fitness` then holds it, its ``data_fitness`` and the tasks' parts not)."""

    def __init__(
        self,
        engine: str,
        tasks: list[TaskSpec],
        references: dict[str, TaskData],
        space: ParameterSpace | None = None,
        weights: FitnessWeights | None = None,
        noise_weighted: bool = False,
        prior_strength: float | None = None,
    ):
        engine_class(engine)  # fail early on an unknown or missing engine
        self.engine = engine
        self.tasks = list(tasks)
        self.references = references
        self.space = space
        self.weights = FitnessWeights() if weights is None else weights
        check_weights(self.tasks, references, self.weights)
        #: each task's signal noise where the residuals weigh every signal by it (``noise_weighted``; RunConfig's
        #: ``residuals = "noise"``), else None: the plain residuals, whose squares sum to the fitness's squares
        self.noise: dict[str, SignalNoise] | None = (
            {t.name: signal_noise(references[t.name]) for t in self.tasks} if noise_weighted else None
        )
        self._engines: dict[str, Engine] = {}
        #: the parameters only the fitness's marker model reads (``marker_offset_*``): points that differ in them
        #: alone simulate the same (:meth:`_rollout_batch`, and the Evaluator's chunks)
        self.marker_names = applied_outside(self.tasks[0].robot.n_joints, (MARKER,))
        #: per task, the last rollouts simulated here, by what they simulated (:meth:`_rollout_batch`)
        self._recent: dict[str, dict[tuple, Rollout]] = {}
        #: the prior (``--prior``), None without one (or at strength 0: plain least squares)
        self.prior: Prior | None = None
        #: what one width off costs at strength 1: the tasks' noise floors, in the fitness and in the residuals'
        #: sum of squares (:func:`simtune.fitness.noise_floor`)
        self.prior_floor = (0.0, 0.0)
        if prior_strength:
            floors = [
                noise_floor(
                    references[t.name],
                    self.weights,
                    signal_noise(references[t.name]) if self.noise is None else self.noise[t.name],
                    self.noise is not None,
                    _has_object_residual(t, references),
                )
                for t in self.tasks
            ]
            self.prior_floor = (sum(f for f, _ in floors), sum(q for _, q in floors))
            self.prior = make_prior(self, prior_strength)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_engines"] = {}  # engine handles stay in the process that made them
        state["_recent"] = {}
        return state

    def with_references(self, references: dict[str, TaskData]) -> Objective:
        """This objective against other references of its tasks (a bootstrap draw of their repeats:
        :meth:`TaskData.resampled`), each signal still weighed by this objective's noise, with engines of its own.

        Args:
            references: task name -> reference, for every task.
        Returns:
            The new objective (close it when done).
        """
        other = copy.copy(self)
        other.references = dict(references)
        other._engines = {}
        other._recent = {}
        return other

    def _engine(self, task: TaskSpec) -> Engine:
        if task.name not in self._engines:
            self._engines[task.name] = make_engine(self.engine, started_as_recorded(task, self.references[task.name]))
        return self._engines[task.name]

    def prior_penalty(self, params: dict[str, float]) -> float:
        """What the prior adds to the fitness of ``params`` (:class:`Prior`); 0 without one."""
        if self.prior is None:
            return 0.0
        return self.prior.strength * self.prior_floor[0] * float(np.sum(np.square(self.prior.deviations(params))))

    def prior_residuals(self, params: dict[str, float]) -> np.ndarray:
        """The prior's rows of the residual vector of ``params``, one per parameter it holds (none without one):
        their sum of squares is ``strength`` floors' sum of squares per width squared."""
        if self.prior is None:
            return np.zeros(0)
        return math.sqrt(self.prior.strength * self.prior_floor[1]) * self.prior.deviations(params)

    def _with_prior(self, parts: list[TaskScore], penalty: float) -> Score:
        """The score of a member's task parts, its fitness the prior's ``penalty`` plus the parts in the tasks'
        order (as the pruning sums them: a pruned score still exceeds its bound)."""
        score = Score.combine(parts)
        if self.prior is None:
            return score
        total = penalty
        for part in parts:
            total += part.fitness
        return replace(score, fitness=float(total))

    def rollouts(self, params: dict[str, float]) -> dict:
        """Each task's rollout for ``params``, as long as its recordings."""
        return {t.name: self._engine(t).rollout(params, len(self.references[t.name].times)) for t in self.tasks}

    def score(self, params: dict[str, float], bound: float | None = None) -> Score:
        """Fitness of ``params`` over all tasks.

        With ``bound``, simulation stops as soon as the error accumulated so far
        proves the fitness will exceed ``bound`` (every remaining sample can only
        add to it); the score is then a flagged lower bound that still exceeds
        ``bound``.  The optimiser passes a trial's parent fitness: a trial that
        cannot beat its parent is rejected either way, so the search is unchanged.
        """
        return _one(self.score_batch([params], [bound]))

    def score_batch(
        self,
        params: Sequence[dict[str, float]],
        bounds: Sequence[float | None] | None = None,
        threads: int = 1,
    ) -> Iterator[tuple[int, Score | Exception]]:
        """:meth:`score` of each parameter dict of a batch (``bounds[i]`` for member i), yielded as
        ``(index, score)`` as each finishes; a member whose simulation raised yields the exception.

        Each task runs the whole batch through its engine's :meth:`~simtune.engines.Engine.rollout_batch`
        (on up to ``threads`` threads where the engine can); a member pruned on one task skips the rest.
        """
        # the prior's part is known before simulating: a trial whose penalty alone exceeds its bound prunes at once
        penalties = [self.prior_penalty(p) for p in params]
        spent = list(penalties)
        parts: list[list[TaskScore]] = [[] for _ in params]
        members = list(range(len(params)))
        for t, task in enumerate(self.tasks):
            reference = self.references[task.name]
            n = len(reference.times)
            monitors = None
            if bounds is not None:
                monitors = [
                    _pruning_monitor(reference, params[i], bounds[i], spent[i], self.weights.wrist) for i in members
                ]
            going_on = []
            batch = self._rollout_batch(task, [params[i] for i in members], n, monitors, threads)
            for j, rollout in batch:
                i = members[j]
                try:
                    if isinstance(rollout, Exception):
                        raise rollout
                    parts[i].append(self._score(task, rollout, params[i]))
                except Exception as exc:
                    yield i, exc
                    continue
                spent[i] += parts[i][-1].fitness
                bound = None if bounds is None else bounds[i]
                if t == len(self.tasks) - 1 or (bound is not None and spent[i] > bound):
                    yield i, self._with_prior(parts[i], penalties[i])  # the remaining tasks cannot lower the sum
                else:
                    going_on.append(i)
            members = sorted(going_on)

    def _rollout_batch(
        self,
        task: TaskSpec,
        params: Sequence[dict[str, float]],
        n_samples: int,
        monitors: Sequence[MarkerBudget | None] | None,
        threads: int,
    ) -> Iterator[tuple[int, Rollout | Exception]]:
        """``task``'s engine's :meth:`~simtune.engines.Engine.rollout_batch`, each simulation run once for the
        members that differ only in what the fitness's marker model reads (``marker_offset_*``), and not at all
        for one of the last :data:`RECENT_ROLLOUTS` simulated here: a Jacobian's marker-offset columns share the
        rollout of the point it is taken at.  Each member is yielded with its rollout as it finishes.  A member
        watched by a monitor (which reads its own marker offset and may stop its rollout early) is simulated on
        its own."""
        recent = self._recent.setdefault(task.name, {})
        keys: dict[int, tuple] = {}
        first: dict[tuple, int] = {}
        sharing: dict[int, list[int]] = {}
        done: set[int] = set()  # yielded from the rollouts kept, or sharing an earlier member's
        for i, p in enumerate(params):
            if monitors is not None and monitors[i] is not None:
                continue
            keys[i] = key = (n_samples, *sorted((n, v) for n, v in p.items() if n not in self.marker_names))
            if key in recent:
                done.add(i)
                yield i, recent[key]
                continue
            j = first.setdefault(key, i)
            if j != i:
                sharing.setdefault(j, []).append(i)
                done.add(i)
        simulated = [i for i in range(len(params)) if i not in done]
        batch = self._engine(task).rollout_batch(
            [params[i] for i in simulated],
            n_samples,
            None if monitors is None else [monitors[i] for i in simulated],
            threads,
        )
        for j, rollout in batch:
            i = simulated[j]
            if i in keys and isinstance(rollout, Rollout):
                recent[keys[i]] = rollout
                while len(recent) > RECENT_ROLLOUTS:
                    del recent[next(iter(recent))]
            yield i, rollout
            for twin in sharing.get(i, ()):
                yield twin, rollout

    def _score(self, task: TaskSpec, rollout, params: dict[str, float]) -> TaskScore:
        return score_rollout(
            rollout, self.references[task.name], params, weights=self.weights, joint_names=rollout_joint_names(task)
        )

    def _residual_count(self, task: TaskSpec) -> int:
        reference = self.references[task.name]
        n = len(reference.times)
        wrist = 3 * n if reference.wrist_mean is not None else 0
        return wrist + 3 * _has_object_residual(task, self.references) + n * len(reference.joint_names)

    def residual_counts(self) -> list[int]:
        """The length of each task's part of :meth:`residuals`, in the tasks' order."""
        return [self._residual_count(t) for t in self.tasks]

    @property
    def residual_size(self) -> int:
        """Length of :meth:`residuals`: per task 3 per 20 Hz sample with a wrist marker, 3 with an object, and
        one per sample and logged joint; then one per parameter the prior holds."""
        return sum(self.residual_counts()) + (0 if self.prior is None else len(self.prior.centres))

    def penalty_residuals(self) -> np.ndarray:
        """The residuals of a simulation that blew up or failed: their squares sum to ``PENALTY**2`` (times the
        largest noise multiplier squared where the residuals are weighed by noise: worse than any real misfit)."""
        m = self.residual_size
        largest = max((v for n in (self.noise or {}).values() for v in n.multipliers()), default=1.0)
        return np.full(m, PENALTY * max(1.0, largest) / np.sqrt(m))

    def repeat_deviations(self) -> list[np.ndarray | None]:
        """Per task, each repeat's deviation from the repeats' mean in the residuals' own units and order: row k is
        what :meth:`residuals` would be for a simulation that reproduced repeat k exactly (its wrist track, object
        end position and joint angles), so that the spread of the rows is the spread of the reference's residuals.
        None for a task with fewer than two repeats of every signal it records.

        Returns:
            One (repeats, that task's residuals) array per task, in the tasks' order, or None.
        """
        found: list[np.ndarray | None] = []
        for task in self.tasks:
            reference = self.references[task.name]
            counts = {
                len(held)
                for held in (reference.wrist_repeats, reference.object_final, reference.joint_repeats)
                if held is not None
            }
            if len(counts) != 1 or min(counts) < 2:
                found.append(None)
                continue
            found.append(
                np.stack(
                    [self._recorded_residuals(task, _repeat_as_rollout(reference, k)) for k in range(counts.pop())]
                )
            )
        return found

    def _recorded_residuals(self, task: TaskSpec, recorded: Rollout) -> np.ndarray:
        """The residuals of ``task`` for a rollout made of its recordings (no marker offset: their own wrist)."""
        reference = self.references[task.name]
        noise = None if self.noise is None else self.noise[task.name]
        return task_residuals(
            recorded, reference, {}, weights=self.weights, joint_names=reference.joint_names, noise=noise
        )

    def clock_columns(self) -> list[np.ndarray]:
        """Per task, how its residuals change per second that its reference's clock runs late: a simulation as the
        reference itself, scored against the reference read a moment earlier and later (central differences of half
        a sample), in the residuals' own units and order, zero outside the task's rows.

        What an error of the aligned reference's clock origin does to the fit where no command delay can take it up
        (:func:`simtune.uncertainty.repeat_spread`).

        Returns:
            One array of :attr:`residual_size` per task, in the tasks' order.
        """
        columns, start = [], 0
        for task, count in zip(self.tasks, self.residual_counts()):
            reference = self.references[task.name]
            half = 0.5 / reference.rate
            ends = [self._recorded_residuals(task, _reference_read_at(reference, shift)) for shift in (half, -half)]
            column = np.zeros(self.residual_size)
            column[start : start + count] = (ends[0] - ends[1]) / (2 * half)
            columns.append(column)
            start += count
        return columns

    def residuals_and_score(self, params: dict[str, float]) -> tuple[np.ndarray, Score]:
        """Residual vector of ``params`` for least squares, and its score, from the same rollouts.

        The tasks' :func:`~simtune.fitness.residuals`, stacked: the simulated marker minus the mean
        recorded wrist at every 20 Hz sample (x, y, z), divided by sqrt(samples), the simulated minus the
        recorded final object position, and the simulated minus the mean recorded joint angles, divided
        by sqrt(samples x joints); each part times the square root of its weight.  Their sum of squares is
        the weighted mean squared marker error plus squared object error plus mean squared joint error,
        summed over the tasks: the fitness with squared instead of plain distances.  With a prior, its rows
        follow (:meth:`prior_residuals`), and the score's fitness holds its penalty.  A simulation that
        blew up gets :meth:`penalty_residuals`.
        """
        return _one(self.residuals_batch([params]))

    def residuals_batch(
        self, params: Sequence[dict[str, float]], threads: int = 1
    ) -> Iterator[tuple[int, tuple[np.ndarray, Score] | Exception]]:
        """:meth:`residuals_and_score` of each parameter dict of a batch, yielded as each finishes (see
        :meth:`score_batch`)."""
        parts: list[list[np.ndarray]] = [[] for _ in params]
        scores: list[list[TaskScore]] = [[] for _ in params]
        members = list(range(len(params)))
        for t, task in enumerate(self.tasks):
            reference = self.references[task.name]
            joint_names = rollout_joint_names(task)
            going_on = []
            for j, rollout in self._rollout_batch(
                task, [params[i] for i in members], len(reference.times), None, threads
            ):
                i = members[j]
                try:
                    if isinstance(rollout, Exception):
                        raise rollout
                    scores[i].append(self._score(task, rollout, params[i]))
                    parts[i].append(
                        task_residuals(
                            rollout,
                            reference,
                            params[i],
                            weights=self.weights,
                            joint_names=joint_names,
                            noise=None if self.noise is None else self.noise[task.name],
                        )
                    )
                except Exception as exc:
                    yield i, exc
                    continue
                if t < len(self.tasks) - 1:
                    going_on.append(i)
                    continue
                score = self._with_prior(scores[i], self.prior_penalty(params[i]))
                residuals = np.concatenate([*parts[i], self.prior_residuals(params[i])])
                if not score.stable or not np.all(np.isfinite(residuals)):
                    residuals = self.penalty_residuals()
                yield i, (residuals, score)
            members = sorted(going_on)

    def residuals(self, params: dict[str, float]) -> np.ndarray:
        """The residual vector of :meth:`residuals_and_score` alone."""
        return self.residuals_and_score(params)[0]

    def vector_space(self) -> ParameterSpace:
        """The space that parameter vectors are read in; an objective made without one scores dicts only."""
        if self.space is None:
            raise TypeError("this objective has no parameter space: it scores parameter dicts, not vectors")
        return self.space

    def score_vector(self, x, bound: float | None = None) -> Score:
        return self.score(self.vector_space().to_dict(x), bound)

    def close(self) -> None:
        for engine in self._engines.values():
            engine.close()
        self._engines.clear()
        self._recent.clear()


def _has_object_residual(task: TaskSpec, references: dict[str, TaskData]) -> bool:
    return task.object is not None and references[task.name].object_final is not None


def recorded_parts(tasks: Sequence[TaskSpec], references: dict[str, TaskData]) -> list[str]:
    """The parts of the fitness the recordings of ``tasks`` hold (``wrist``, ``object``, ``joint``), in that
    order."""
    held = {
        part
        for task in tasks
        for part, there in (
            ("wrist", references[task.name].wrist_mean is not None),
            ("object", _has_object_residual(task, references)),
            ("joint", bool(references[task.name].joint_names)),
        )
        if there
    }
    return [part for part in ("wrist", "object", "joint") if part in held]


def check_weights(tasks: Sequence[TaskSpec], references: dict[str, TaskData], weights: FitnessWeights) -> None:
    """Weights that zero every part the recordings hold would score every simulation 0: a ConfigError.  It needs
    the recordings only, so a run checks it before it probes or simulates anything."""
    parts = recorded_parts(tasks, references)
    if parts and not any(getattr(weights, part) > 0 for part in parts):
        zeroed = ",".join(f"{part}=0" for part in parts)
        raise ConfigError(
            f"--weights / weights: {zeroed} weighs nothing the recordings hold ({', '.join(parts)}): every "
            "simulation would score 0; give one of them a weight above 0"
        )


def generic_values(objective: Objective, names: list[str]) -> dict[str, float]:
    """The generic values of ``names`` (those an untuned run uses, and the search's start): the engine's own, and
    for the controller's and the marker's kinds the kinds table's (:func:`simtune.params.kinds.outside_generics`:
    the first task's velocity clamp and gain, no delay, no marker offset).

    A name with neither is left out, and a search starts it mid-range: a task's own command delay (found from its
    recordings instead), and the encoders' offsets and compliance.  Their generic value is 0, but the compliance's
    0 is its lower bound, and a start there was measured worse on real ``cube`` (seed 0, no budget, 2 workers:
    0.01155 against 0.00932 from mid-range, 2026-11-27, both under a round rule since taken out), so the search
    keeps starting it mid-range.

    Args:
        objective: the run's objective (its engine and tasks).
        names: parameter names.
    Returns:
        Name -> generic value, for the names that have one.
    """
    values: dict[str, float] = {}
    for task in objective.tasks:
        sim = make_engine(objective.engine, task)
        try:
            values = {**sim.defaults(), **values}
        finally:
            sim.close()
    task = objective.tasks[0]
    outside = outside_generics(task.robot.n_joints, task.max_velocity_deg, task.kp)
    values = {**outside, **values}
    return {n: float(values[n]) for n in names if n in values}


_T = TypeVar("_T")


def _one(results: Iterator[tuple[int, _T | Exception]]) -> _T:
    """The result of a batch of one member (its exception raised)."""
    ((_, result),) = list(results)
    if isinstance(result, Exception):
        raise result
    return result


def _pruning_monitor(
    reference: TaskData, params: dict[str, float], bound: float | None, spent: float, wrist_weight: float
):
    """The monitor that stops a task's rollout once its marker error proves the score will exceed ``bound``
    (``spent``: what the earlier tasks scored); None without a bound.  Only the marker is watched while
    simulating, so without one (or with it weighing nothing) no trial stops early."""
    if bound is None or reference.wrist_mean is None or wrist_weight <= 0:
        return None
    offset = np.array([params.get(f"marker_offset_{a}", 0.0) for a in "xyz"])
    n = len(reference.times)
    # the summed marker error that proves the bound exceeded (with a margin far above rounding, so the
    # rescored lower bound is sure to exceed it too)
    return MarkerBudget(reference.wrist_mean, offset, ((bound - spent) * n * (1 + 1e-9) + 1e-12) / wrist_weight)


def _reference_read_at(reference: TaskData, shift: float) -> Rollout:
    """The mean of ``reference`` (its wrist track and joint angles, the object at its mean end) read ``shift``
    seconds later on its own clock (linear between samples, its ends held), as a rollout would hold it."""

    def read(track: np.ndarray | None) -> np.ndarray | None:
        return None if track is None else read_later(reference.times, track, shift)

    end = None if reference.object_final is None else reference.object_final_mean
    return _recorded_rollout(reference, read(reference.wrist_mean), read(reference.joint_mean), end)


def _repeat_as_rollout(reference: TaskData, k: int) -> Rollout:
    """Repeat ``k`` of ``reference`` as a rollout would hold it (its wrist track, joint angles and, at its last
    sample, the object where that repeat left it): what :func:`~simtune.fitness.residuals` compares with the mean."""
    return _recorded_rollout(
        reference,
        None if reference.wrist_repeats is None else reference.wrist_repeats[k],
        None if reference.joint_repeats is None else reference.joint_repeats[k],
        None if reference.object_final is None else reference.object_final[k],
    )


def _recorded_rollout(
    reference: TaskData, wrist: np.ndarray | None, joints: np.ndarray | None, object_end: np.ndarray | None
) -> Rollout:
    """A rollout on ``reference``'s clock holding recorded values: the wrist track (n, 3), the joint angles (n, J)
    (zeros where not recorded) and the object at ``object_end`` at the last sample (None: no object)."""
    n = len(reference.times)
    obj = None
    if object_end is not None:
        obj = np.zeros((n, 3))
        obj[-1] = object_end
    return Rollout(
        reference.times,
        np.zeros((n, 3)) if wrist is None else wrist,
        np.tile(np.eye(3), (n, 1, 1)),
        np.zeros((n, 0)) if joints is None else joints,
        obj,
    )
