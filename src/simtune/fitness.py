"""Fitness: how far a simulation is from the recordings (the seed paper's equations 1 and 2).

wrist error  = mean over the 20 Hz samples of the 3-D distance between the
               simulated marker and the mean recorded wrist trajectory [m]
               (recordings that track the wrist marker)
object error = 3-D distance between the simulated and the mean recorded final
               object position [m] (tasks with an object, recordings that track it)
joint error  = mean over the 20 Hz samples and the logged joints of
               |simulated - mean recorded joint angle| [rad] (joint logs)
fitness      = wrist weight x wrist error + object weight x object error
               + joint weight x joint error, over the parts the recordings hold,
               summed over the tasks tuned together

The weights (:class:`FitnessWeights`, ``--weights joint=0.5,wrist=1,object=1``)
default to 1 for the wrist and object terms, so motion-capture fitness is the
seed paper's sum, and to :data:`JOINT_WEIGHT` m/rad for the joint term.

The simulated marker is the wrist (link_6 origin) moved by ``marker_offset_*``
in the hand frame, so the offset turns with the hand as a real marker does.
A simulation that became unstable scores :data:`PENALTY` (finite, so the
optimiser carries on) and is flagged, never silently mixed with real scores.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from simtune.data import TaskData
from simtune.data.screen import JOINT_WEIGHT  # the joint error's default weight [m/rad], below the fitness
from simtune.engines.base import Rollout
from simtune.errors import ConfigError, SimtuneError
from simtune.tasks import TaskSpec

#: Fitness of a rollout that exploded [m]: worse than any arm that stays in its workspace.
PENALTY = 10.0


@dataclass(frozen=True)
class FitnessWeights:
    """How much each part of the fitness counts (the parts the recordings lack count nothing)."""

    joint: float = JOINT_WEIGHT
    wrist: float = 1.0
    object: float = 1.0

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], where: str = "--weights") -> FitnessWeights:
        """Weights from ``{"joint": 0.1, ...}`` (keys left out keep their defaults); one-line error naming the key."""
        known = [f.name for f in fields(cls)]
        checked: dict[str, float] = {}
        for key, value in values.items():
            if key not in known:
                raise ConfigError(f"{where}: unknown weight {key!r} (known: {', '.join(known)})")
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
                raise ConfigError(f"{where}: weight {key!r} must be a finite number of at least 0, got {value!r}")
            checked[key] = float(value)
        weights = cls(**checked)
        if not any(asdict(weights).values()):
            raise ConfigError(f"{where}: every weight is 0: nothing would be fitted")
        return weights

    @classmethod
    def parse(cls, text: str, where: str = "--weights") -> FitnessWeights:
        """Weights from ``joint=0.1,wrist=1,object=1`` (keys left out keep their defaults)."""
        values: dict[str, Any] = {}
        for item in text.split(","):
            key, sep, number = (part.strip() for part in item.partition("="))
            if not sep or not key:
                raise ConfigError(f"{where}: expected KEY=NUMBER items joined by commas, got {item.strip()!r}")
            if key in values:
                raise ConfigError(f"{where}: weight {key!r} given twice")
            try:
                values[key] = float(number)
            except ValueError:
                values[key] = number
        return cls.from_mapping(values, where)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def rollout_joint_names(task: TaskSpec) -> tuple[str, ...]:
    """Names of a rollout's ``joint_angles`` columns for ``task``: its robot's driven joints, in order."""
    return task.robot.arm_joints


@dataclass
class TaskScore:
    task: str
    fitness: float
    wrist_error: float | None  # None: the recordings track no wrist marker
    object_error: float | None
    stable: bool = True
    message: str = ""
    #: stopped early because it could no longer beat its parent: fitness is a lower bound
    pruned: bool = False
    steps: int = 0  # physics steps simulated
    joint_error: float | None = None  # None: the recordings log no joint angles


@dataclass
class Score:
    """Fitness of one parameter set over one or more tasks, with its parts."""

    fitness: float
    wrist_error: float | None
    object_error: float | None
    tasks: list[TaskScore] = field(default_factory=list)
    joint_error: float | None = None

    @property
    def stable(self) -> bool:
        return all(t.stable for t in self.tasks)

    @property
    def pruned(self) -> bool:
        return any(t.pruned for t in self.tasks)

    @property
    def data_fitness(self) -> float:
        """The fit to the recordings alone: the tasks' fitness summed, without a prior's penalty (``--prior``:
        :attr:`fitness` is what the search minimises, this plus :attr:`prior_penalty`).  Without a prior, exactly
        :attr:`fitness`."""
        return float(sum(t.fitness for t in self.tasks)) if self.tasks else self.fitness

    @property
    def prior_penalty(self) -> float:
        """What a prior (``--prior``) adds to the fitness for the parameters' distance from their generic values;
        0 without one."""
        return self.fitness - self.data_fitness

    @classmethod
    def combine(cls, scores: list[TaskScore]) -> Score:
        return cls(
            fitness=float(sum(s.fitness for s in scores)),
            wrist_error=_sum_present(s.wrist_error for s in scores),
            object_error=_sum_present(s.object_error for s in scores),
            tasks=list(scores),
            joint_error=_sum_present(s.joint_error for s in scores),
        )

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> Score:
        return cls(  # a score's parts are None where its recordings lack them, and may be left out
            data["fitness"],
            data.get("wrist_error"),
            data.get("object_error"),
            [TaskScore(**t) for t in data.get("tasks", [])],
            data.get("joint_error"),
        )


def _sum_present(values) -> float | None:
    """Sum of the parts that are there; None when none is."""
    present = [v for v in values if v is not None]
    return float(sum(present)) if present else None


def marker_positions(rollout: Rollout, params: dict[str, float]) -> np.ndarray:
    """Simulated positions of the motion-capture marker: the wrist plus its offset in the hand frame."""
    offset = np.array([params.get(f"marker_offset_{a}", 0.0) for a in "xyz"])
    if not offset.any():
        return rollout.wrist_pos
    return rollout.wrist_pos + np.einsum("nij,j->ni", rollout.wrist_rot, offset)


def joint_columns(reference: TaskData, joint_names: Sequence[str]) -> list[int]:
    """Columns of a rollout's ``joint_angles`` (named ``joint_names``) holding the recorded joints, in their order."""
    missing = [j for j in reference.joint_names if j not in joint_names]
    if missing:
        raise SimtuneError(
            f"task {reference.task}: the recordings log joint(s) {', '.join(missing)} that the arm lacks "
            f"(its joints: {', '.join(joint_names)})"
        )
    return [list(joint_names).index(j) for j in reference.joint_names]


def joint_differences(rollout: Rollout, reference: TaskData, joint_names: Sequence[str]) -> np.ndarray | None:
    """Simulated minus mean recorded angle [rad], (n, logged joints); None without joint logs."""
    if reference.joint_mean is None:
        return None
    return rollout.joint_angles[:, joint_columns(reference, joint_names)] - reference.joint_mean


def score_rollout(
    rollout: Rollout,
    reference: TaskData,
    params: dict[str, float],
    *,
    weights: FitnessWeights = FitnessWeights(),
    joint_names: Sequence[str] = (),
) -> TaskScore:
    """Score one task's rollout against its recordings (``joint_names``: the rollout's joint columns,
    :func:`rollout_joint_names`; needed only where the recordings hold joint angles)."""
    n = len(reference.times)
    if len(rollout.times) != n:
        raise ValueError(f"rollout has {len(rollout.times)} samples, the reference {n}")
    distances = None
    if reference.wrist_mean is not None:
        distances = np.linalg.norm(marker_positions(rollout, params) - reference.wrist_mean, axis=1)
    joint_abs = joint_differences(rollout, reference, joint_names)
    if joint_abs is not None:
        joint_abs = np.abs(joint_abs)
    if rollout.pruned:
        # only the simulated samples count: a lower bound of the full errors
        run = rollout.samples_run
        wrist = None if distances is None else float(distances[:run].sum() / n)
        joint = None if joint_abs is None else float(joint_abs[:run].sum() / joint_abs.size)
        bound = _weighted(weights, wrist, None, joint)
        message = pruned_message(f"{rollout.times[run - 1]:.2f}")
        return TaskScore(
            reference.task, bound, wrist, None, True, message, pruned=True, steps=rollout.steps, joint_error=joint
        )
    wrist_error = None if distances is None else float(np.mean(distances))
    joint_error = None if joint_abs is None else float(np.mean(joint_abs))
    object_error = None
    if reference.object_final is not None and rollout.object_pos is not None:
        object_error = float(np.linalg.norm(rollout.object_pos[-1] - reference.object_final_mean))
    fitness = _weighted(weights, wrist_error, object_error, joint_error)
    if not rollout.stable:
        fitness = PENALTY
    return TaskScore(
        reference.task,
        fitness,
        wrist_error,
        object_error,
        rollout.stable,
        rollout.message,
        steps=rollout.steps,
        joint_error=joint_error,
    )


def repeat_floor(reference: TaskData, weights: FitnessWeights = FitnessWeights()) -> np.ndarray:
    """Per repeat, the fitness the reference's mean scores against that repeat, as a simulation would be scored
    against the mean: what a simulation as good as the real arm's own repeats scores (the floor of the fitness).

    The wrist part is the repeat's mean distance from ``wrist_mean``, the object part its final object position's
    distance from the mean one, the joint part its mean absolute angle difference from ``joint_mean``.
    """
    count = len(reference.sources)
    wrist = joint = obj = np.full(count, np.nan)
    if reference.wrist_repeats is not None and reference.wrist_mean is not None:
        wrist = np.linalg.norm(reference.wrist_repeats - reference.wrist_mean[None], axis=2).mean(axis=1)
    if reference.object_final is not None:
        obj = np.linalg.norm(reference.object_final - reference.object_final.mean(axis=0), axis=1)
    if reference.joint_repeats is not None and reference.joint_mean is not None:
        joint = np.abs(reference.joint_repeats - reference.joint_mean[None]).mean(axis=(1, 2))

    def part(values: np.ndarray, i: int) -> float | None:
        return None if np.isnan(values[i]) else float(values[i])

    return np.array([_weighted(weights, part(wrist, i), part(obj, i), part(joint, i)) for i in range(count)])


@dataclass(frozen=True)
class RepeatFloor:
    """How well a task's repeats agree, with and without their clocks aligned, and the floor it sets."""

    task: str
    repeats: int
    spread_unaligned_m: float | None  # the wrist's repeat spread on the repeats' own clocks
    spread_aligned_m: float | None  # ... with their clocks aligned
    shift_min_s: float
    shift_max_s: float
    outliers: tuple[str, ...]  # the files whose shift is an outlier
    #: mean over the repeats of :func:`repeat_floor`; None with one repeat, which scores 0 against itself: no floor
    floor: float | None


def reference_floor(aligned: TaskData, weights: FitnessWeights = FitnessWeights()) -> RepeatFloor:
    """The :class:`RepeatFloor` of the aligned reference ``aligned`` (loaded with ``reference="aligned"``)."""
    from simtune.data.clock import outlying_shifts

    if aligned.alignment is None:
        raise ValueError(f"task {aligned.task}: reference_floor needs the aligned reference, not {aligned.reference}")
    shifts = aligned.alignment.shifts
    return RepeatFloor(
        task=aligned.task,
        repeats=len(aligned.sources),
        spread_unaligned_m=aligned.unaligned_spread,
        spread_aligned_m=aligned.repeat_spread,
        shift_min_s=float(shifts.min()),
        shift_max_s=float(shifts.max()),
        outliers=tuple(aligned.sources[i].name for i in outlying_shifts(shifts, 1.0 / aligned.rate)),
        floor=float(repeat_floor(aligned, weights).mean()) if len(aligned.sources) > 1 else None,
    )


def pruned_message(at: str) -> str:
    """The message of a task pruned at time ``at`` [s, as written] (the run store keeps ``at`` alone)."""
    return f"pruned at t={at} s: cannot beat its parent"


def _weighted(weights: FitnessWeights, wrist: float | None, obj: float | None, joint: float | None) -> float:
    """The fitness from its parts that are there (the motion-capture sum is unchanged by weights of 1)."""
    fitness = 0.0
    if wrist is not None:
        fitness = weights.wrist * wrist
    if obj is not None:
        fitness += weights.object * obj
    if joint is not None:
        fitness += weights.joint * joint
    return fitness


#: Noise-weighted residuals are in units of this noise [m]: a signal with that noise keeps the scale of a plain
#: residual in metres (and the penalty of a blown-up rollout stays far above any real misfit).
NOISE_UNIT_M = 1e-3
#: Each signal's noise where the recordings hold one repeat (no spread to estimate it from): a motion-capture marker
#: [m], the object's final position [m] and a joint encoder [rad].
DEFAULT_NOISE = {"wrist": 1e-3, "object": 2e-3, "joint": math.radians(0.05)}
#: The least noise a signal is given however tightly its repeats agree (a synthetic recording without noise):
#: no signal is weighed more than this allows.
LEAST_NOISE = {"wrist": 1e-4, "object": 1e-4, "joint": math.radians(0.005)}


@dataclass(frozen=True)
class SignalNoise:
    """How noisy each recorded signal of a task is: the standard deviation of a repeat about the repeats' mean.

    ``wrist_m`` [m] pools the marker's three axes over every sample, ``object_m`` [m] the object's final position's
    three axes, ``joints_rad`` [rad] is one per logged joint (in the recordings' order); each None (empty) where the
    recordings lack the signal.  ``estimated``: from the repeats' spread (at least two repeats), else
    :data:`DEFAULT_NOISE`.
    """

    wrist_m: float | None
    object_m: float | None
    joints_rad: tuple[float, ...]
    estimated: bool

    def multipliers(self) -> list[float]:
        """What each present signal's residuals are multiplied by (:data:`NOISE_UNIT_M` over its noise)."""
        values = [self.wrist_m, self.object_m, *self.joints_rad]
        return [NOISE_UNIT_M / v for v in values if v is not None]


def _spread(repeats: np.ndarray | None, floor: float, axis=None) -> np.ndarray | float | None:
    """The standard deviation of repeats (first axis) about their mean (pooled over ``axis``, besides the repeats'),
    unbiased, at least ``floor``; None without two repeats."""
    if repeats is None or len(repeats) < 2:
        return None
    count = len(repeats)
    squares = np.mean((repeats - repeats.mean(axis=0)) ** 2, axis=axis) * count / (count - 1)
    return np.maximum(np.sqrt(squares), floor)


def signal_noise(reference: TaskData) -> SignalNoise:
    """Each signal's noise, from the spread of the reference's repeats (see :class:`SignalNoise`).

    Args:
        reference: a task's recordings as loaded (aligned or not: the spread of the repeats as they are averaged).
    Returns:
        The noise of the wrist marker, the object's final position and each logged joint.
    """
    wrist = _spread(reference.wrist_repeats, LEAST_NOISE["wrist"])
    obj = _spread(reference.object_final, LEAST_NOISE["object"])
    joints = None
    if reference.joint_repeats is not None:
        joints = _spread(reference.joint_repeats, LEAST_NOISE["joint"], axis=(0, 1))
    estimated = wrist is not None or obj is not None or joints is not None
    if reference.wrist_mean is not None and wrist is None:
        wrist = DEFAULT_NOISE["wrist"]
    if reference.object_final is not None and obj is None:
        obj = DEFAULT_NOISE["object"]
    if reference.joint_mean is not None and joints is None:
        joints = np.full(reference.joint_mean.shape[1], DEFAULT_NOISE["joint"])
    return SignalNoise(
        None if reference.wrist_mean is None else float(wrist),  # type: ignore[arg-type]
        None if reference.object_final is None else float(obj),  # type: ignore[arg-type]
        () if reference.joint_mean is None else tuple(float(v) for v in np.atleast_1d(joints)),  # type: ignore[arg-type]
        estimated,
    )


def residuals(
    rollout: Rollout,
    reference: TaskData,
    params: dict[str, float],
    *,
    weights: FitnessWeights = FitnessWeights(),
    joint_names: Sequence[str] = (),
    noise: SignalNoise | None = None,
) -> np.ndarray:
    """One task's residual vector for least squares and Gauss-Newton uncertainty, beside its scalar fitness.

    The simulated marker minus the mean recorded wrist at every 20 Hz sample (x, y, z: the
    vector whose length is the fitness's per-sample wrist distance), divided by sqrt(samples);
    for a task with an object, the simulated minus the recorded final object position; with joint
    logs, the simulated minus the mean recorded angles, divided by sqrt(samples x joints); each
    part times the square root of its weight.  Their sum of squares is the weighted mean squared
    marker error plus squared object error plus mean squared joint error: the fitness with squared
    distances.  Components rather than distances, so that the Jacobian keeps each direction and
    stays smooth where a distance is near zero.

    With ``noise`` (:func:`signal_noise`), every signal is weighed by its own noise instead: each part is
    multiplied by :data:`NOISE_UNIT_M` over its signal's noise, each logged joint by its own, and a joint is a
    signal of its own (not averaged over the joints), so that a joint log recorded to 0.05 deg informs the fit as
    much as its precision warrants beside a marker recorded to millimetres.  ``weights`` then scale each part
    relative to the defaults (the joint's 0.5 m/rad, a unit conversion, is the noise's to make).
    """
    n = len(reference.times)
    parts = []
    scale = _noise_scales(noise, weights)
    if reference.wrist_mean is not None:
        wrist = (marker_positions(rollout, params) - reference.wrist_mean) / np.sqrt(n)
        parts.append(scale["wrist"] * wrist.ravel())
    if reference.object_final is not None and rollout.object_pos is not None:
        parts.append(scale["object"] * (rollout.object_pos[-1] - reference.object_final_mean))
    joints = joint_differences(rollout, reference, joint_names)
    if joints is not None:
        if noise is None:
            parts.append(np.sqrt(weights.joint) * joints.ravel() / np.sqrt(joints.size))
        else:
            per_joint = scale["joint"] * NOISE_UNIT_M / np.array(noise.joints_rad)
            parts.append((joints * per_joint).ravel() / np.sqrt(n))
    return np.concatenate(parts) if parts else np.zeros(0)


def noise_floor(
    reference: TaskData, weights: FitnessWeights, noise: SignalNoise, weighted: bool, with_object: bool
) -> tuple[float, float]:
    """What a simulation scores whose every recorded signal is off by that signal's noise (a repeat's spread about the
    repeats' mean, :func:`signal_noise`) in every component: about the fitness of the real arm against its own mean,
    the data's noise floor.  A prior (``--prior``) is measured in it.

    Args:
        reference: the task's recordings.
        weights: the fitness's weights.
        noise: the task's signal noise.
        weighted: whether the residuals are weighed by noise (RunConfig ``residuals = "noise"``) or plain.
        with_object: whether the task's fitness has an object part (a task with an object, recordings that track it).

    Returns:
        ``(fitness, sum of squares of the residuals)``: the wrist's and object's 3-D offsets of sqrt(3) noises, the
        joints' of one, weighted as :func:`score_rollout` and :func:`residuals` weigh them.
    """
    scale = _noise_scales(noise if weighted else None, weights)
    fitness = squares = 0.0
    if reference.wrist_mean is not None and noise.wrist_m is not None:
        fitness += weights.wrist * math.sqrt(3.0) * noise.wrist_m
        squares += scale["wrist"] ** 2 * 3.0 * noise.wrist_m**2
    if with_object and noise.object_m is not None:
        fitness += weights.object * math.sqrt(3.0) * noise.object_m
        squares += scale["object"] ** 2 * 3.0 * noise.object_m**2
    if noise.joints_rad:
        joints = np.square(noise.joints_rad)
        fitness += weights.joint * math.sqrt(float(joints.mean()))
        if weighted:
            squares += scale["joint"] ** 2 * NOISE_UNIT_M**2 * len(joints)
        else:
            squares += weights.joint * float(joints.mean())
    return fitness, squares


def _noise_scales(noise: SignalNoise | None, weights: FitnessWeights) -> dict[str, float]:
    """What the wrist, object and joint parts of :func:`residuals` are multiplied by (the joint's without its noise,
    which is per joint)."""
    if noise is None:
        return {"wrist": np.sqrt(weights.wrist), "object": np.sqrt(weights.object), "joint": 1.0}
    return {
        "wrist": math.sqrt(weights.wrist) * NOISE_UNIT_M / noise.wrist_m if noise.wrist_m else 0.0,
        "object": math.sqrt(weights.object) * NOISE_UNIT_M / noise.object_m if noise.object_m else 0.0,
        "joint": math.sqrt(weights.joint / JOINT_WEIGHT),
    }
