"""``simtune design``: the motion a lab should record so that the recordings identify the chosen parameters.

1. The library (:func:`~simtune.design.schedule.library`): excursions from the template task's start pose, single
   joints in small, medium and large steps each way and every joint at once, run back to back as one task at the
   design's velocity clamp.  Each of the design's points (the generic point, and the points a tenth of each
   range below and above it) simulates it once; an excursion during which the arm touches the floor or itself, or
   leaves a joint's limits (:mod:`simtune.design.checks`) is halved, twice at the most, then dropped.
2. At each point the noise-weighted Jacobian of the library's rollout residuals over the parameters
   (:func:`simtune.uncertainty.jacobian`, one-sided: a screen that ranks excursions needs no second side, and the
   library's rollouts are most of the design's time; one batch, MuJoCo's on threads), against a reference of the
   signals the lab records (the wrist marker and/or the joint angles) with the noise it records them with; each
   excursion's rows give its information (:mod:`simtune.design.search`).
3. The chain of excursions that fills the duration with the largest smallest-over-the-points log det of its
   information plus a prior as wide as the ranges (Fedorov's exchange algorithm), checked in simulation at every
   point; an excursion to blame for a failed check is left out and the chain chosen again.
4. The designed task's own Jacobian at the generic point (and the project's current tasks', on the same signals and
   noise): each parameter's predicted 95 % interval width on each, and the combinations the design still cannot tell
   apart (:func:`simtune.identifiability.identifiability`: named, with the motion that would separate them).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from simtune.activity import declared_inactive
from simtune.data.task import TaskData
from simtune.design import checks
from simtune.design.schedule import (
    REST_S,
    Excursion,
    Timing,
    design_task,
    halved,
    library,
    rooms,
    targets_csv,
    task_toml,
    trajectory_yaml,
)
from simtune.design.search import LAMBDA, choose, information, logdet, sample_rows
from simtune.engines import engine_class, make_engine
from simtune.engines.contact import rollout_samples
from simtune.engines.controller import CONTROL_PERIOD, given_delay
from simtune.errors import ConfigError, SimtuneError
from simtune.fitness import NOISE_UNIT_M, SignalNoise, marker_positions
from simtune.identifiability import identifiability
from simtune.objective import Objective, generic_values
from simtune.params import ParameterSpace, get_space
from simtune.params.kinds import velocity_bounds
from simtune.tasks.spec import TaskSpec
from simtune.uncertainty import NULL_SHARE, Z95, directions, jacobian

#: What a lab records, as the design's ``signals`` name them.
SIGNALS = ("marker", "joints")
#: The design's points other than the generic one: each parameter this share of its range below and above its
#: generic value (within its range).
SPREAD = 0.1
#: Halvings of an excursion that fails a check before it is dropped, and rounds of the library's screening.
HALVINGS = 2
SCREEN_ROUNDS = 4
#: Rounds of choosing the chain again without an excursion to blame for a failed check.
CHOICE_ROUNDS = 3
#: The design's clamp as a share of the slowest joint's velocity limit: headroom for a servo stiffer than the
#: generic one, which runs past the clamp while it catches up; a motion that still runs past a joint's limit at a
#: design point is halved like one that leaves its range (:meth:`simtune.design.checks.PointCheck.bad_times`).
CLAMP_SHARE = 0.9
#: The simulator's parameters, not the arm's: left out of a design unless ``only`` names them.
SIMULATOR = ("timestep",)

Progress = Callable[[str, int, int], None]


@dataclass
class Design:
    """A designed task, its files' texts and what the design found (``summary``: ``simtune design --json``)."""

    task: TaskSpec
    toml: str
    csv: str
    yaml: str
    summary: dict = field(default_factory=dict)


def default_clamp(robot) -> float:
    """The design's velocity clamp [deg/s]: :data:`CLAMP_SHARE` of the slowest driven joint's velocity limit (from
    its description), or the top of its clamp's range (:func:`~simtune.params.kinds.velocity_bounds`) where that is
    lower."""
    limits = []
    for name in robot.arm_joints:
        joint = robot.joint_by_name[name]
        top = velocity_bounds(robot, joint.velocity)[1]
        given = CLAMP_SHARE * math.degrees(joint.velocity) if joint.velocity and math.isfinite(joint.velocity) else top
        limits.append(min(top, given))
    return float(min(limits))


def _reference(task: TaskSpec, engine: str, signals: Sequence[str], params: dict[str, float]) -> TaskData:
    """A reference of ``task``'s recorded ``signals`` as ``engine`` simulates ``params``: the Jacobian's residuals
    need only its shape (they are differences of rollouts), so no recording is needed."""
    sim = make_engine(engine, task)
    try:
        rollout = sim.rollout(params, rollout_samples(task.duration))
    finally:
        sim.close()
    if not rollout.stable:
        raise SimtuneError(f"design: the {task.name!r} task does not simulate stably in {engine}: {rollout.message}")
    n = len(rollout.times)
    joints = "joints" in signals
    return TaskData(
        task=task.name,
        rate=1.0 / CONTROL_PERIOD,
        times=np.arange(n) * CONTROL_PERIOD,
        wrist_mean=marker_positions(rollout, params) if "marker" in signals else None,
        wrist_repeats=None,
        object_final=None,
        object_start=None,
        sources=[],
        joint_names=list(task.robot.arm_joints) if joints else [],
        joint_mean=rollout.joint_angles.copy() if joints else None,
    )


@dataclass(frozen=True)
class Noise:
    """What the lab records and how well: the signals, the marker's noise [m], the encoders' [rad], the repeats."""

    signals: tuple[str, ...]
    marker_m: float
    joint_rad: float
    repeats: int

    def signal_noise(self, n_joints: int) -> SignalNoise:
        return SignalNoise(
            self.marker_m if "marker" in self.signals else None,
            None,
            (self.joint_rad,) * n_joints if "joints" in self.signals else (),
            False,
        )

    def widths(self, n_joints: int) -> list[int]:
        """Each signal's residuals per sample, in the residual vector's order (:func:`simtune.fitness.residuals`)."""
        return [3] * ("marker" in self.signals) + [n_joints] * ("joints" in self.signals)

    def sigma(self, samples: int) -> float:
        """One noise-weighted residual's standard deviation for a task of ``samples`` (the mean of the repeats)."""
        return NOISE_UNIT_M / math.sqrt(self.repeats * samples)


#: What a lab records where the design is told nothing else: both signals, the marker to 2 mm and the encoders to
#: 0.05 deg (``simtune synth``'s defaults), ten repeats.
DEFAULT_NOISE = Noise(SIGNALS, 0.002, math.radians(0.05), 10)


def _objective(engine: str, tasks: list[TaskSpec], space: ParameterSpace, noise: Noise, params) -> Objective:
    """The noise-weighted objective of ``tasks`` against references of the recorded signals (see
    :func:`_reference`), each signal weighed by the noise the lab records it with."""
    references = {t.name: _reference(t, engine, noise.signals, params) for t in tasks}
    objective = Objective(engine, tasks, references, space, noise_weighted=True)
    objective.noise = {t.name: noise.signal_noise(t.robot.n_joints) for t in tasks}
    return objective


def _scaled(objective: Objective, unit: np.ndarray, noise: Noise) -> np.ndarray:
    """The Jacobian's rows each divided by its residual's noise: its J^T J is the information (unit coordinates)."""
    out, start = [], 0
    for task in objective.tasks:
        n = len(objective.references[task.name].times)
        count = n * sum(noise.widths(task.robot.n_joints))
        out.append(unit[start : start + count] / noise.sigma(n))
        start += count
    return np.vstack(out) if out else unit


def _points(space: ParameterSpace, generic: dict[str, float]) -> list[tuple[str, np.ndarray]]:
    """The design's points: the generic one, and every parameter :data:`SPREAD` of its range below and above it."""
    x0 = space.vector_within_bounds(generic)
    low = np.array([p.low for p in space.parameters])
    high = np.array([p.high for p in space.parameters])
    width = high - low
    return [
        ("generic", x0),
        (f"generic - {SPREAD:g} x range", np.clip(x0 - SPREAD * width, low, high)),
        (f"generic + {SPREAD:g} x range", np.clip(x0 + SPREAD * width, low, high)),
    ]


def _blamed(spans: list[tuple[float, float]], times: list[float], delay: float) -> set[int]:
    """The excursions (indices into ``spans``, their commanded times) whose motion ``times`` [s] fall within: a
    motion lags its command by the point's delay, and one that goes on after an excursion's end is its doing."""
    out = set()
    for t in times:
        for k, (a, b) in enumerate(spans):
            if a + delay <= t < b + delay or (k == len(spans) - 1 and t >= a + delay):
                out.add(k)
                break
    return out


def widths(scaled: np.ndarray, space: ParameterSpace) -> tuple[list[float | None], list[bool]]:
    """Each parameter's predicted 95 % interval width [its unit] from information ``scaled^T scaled`` (Gauss-Newton
    over the singular values kept, :func:`simtune.uncertainty.directions`), and whether it is identified (its
    direction within the kept ones and its interval no wider than its range, :func:`simtune.uncertainty.analyse`'s
    rule); None where its direction lies in the discarded ones (no interval)."""
    s, vt, keep, null_share = directions(scaled)
    v_kept = vt[: len(s)][keep].T
    cov = (v_kept / s[keep] ** 2) @ v_kept.T if keep.any() else np.zeros((len(space), len(space)))
    out: list[float | None] = []
    known = []
    for i, p in enumerate(space.parameters):
        unit = 2.0 * Z95 * math.sqrt(max(float(cov[i, i]), 0.0))
        free = null_share[i] >= NULL_SHARE
        out.append(None if free else unit * (p.high - p.low))
        known.append(bool(not free and unit <= 1.0))
    return out, known


def design_experiment(
    engine: str,
    template: TaskSpec,
    compared: list[TaskSpec],
    *,
    duration: float,
    name: str,
    space_name: str = "extended",
    only: list[str] | None = None,
    noise: Noise = DEFAULT_NOISE,
    clamp: float | None = None,
    workers: int = 1,
    seed: int = 0,
    progress: Progress | None = None,
) -> Design:
    """Design a task of ``duration`` seconds whose recordings identify ``space_name``'s parameters (``only``'s).

    Args:
        engine: the engine whose parameters are designed for.
        template: the task whose robot, start pose, gain and marker the design takes (the project's first task).
        compared: the project's current tasks, whose predicted intervals the design's are set beside.
        duration: the designed task's length [s].
        name: the designed task's name.
        space_name: the parameter space.
        only: its parameters to design for (None: all, less the simulator's time step).
        noise: the signals recorded, their noise and the repeats.
        clamp: the design's velocity clamp [deg/s] (None: :func:`default_clamp`).
        workers: threads (MuJoCo) or processes for the Jacobians' rollouts.
        seed: of the library's every-joint excursions.
        progress: called with (what, done, total) as the work goes on (a progress bar).
    Returns:
        The :class:`Design`.
    Raises:
        SimtuneError: the duration leaves room for no excursion, no excursion passes the checks, or the chain
            fails them after :data:`CHOICE_ROUNDS` choices.
    """
    started = time.monotonic()
    robot = template.robot
    cls = engine_class(engine)
    clamp = default_clamp(robot) if clamp is None else float(clamp)
    full = get_space(space_name, cls.supported(robot), only, robot=robot)
    if not only:
        full = ParameterSpace(full.name, tuple(p for p in full.parameters if p.name not in SIMULATOR))
    # every joint with room stepped by a degree: what the design's schedules move (their clamps active)
    nudge = [1.0 if up >= 1.0 else -1.0 if down >= 1.0 else 0.0 for down, up in rooms(robot, template.start_pose_deg)]
    probe_task, _ = design_task(template, f"{name}-library", [Excursion(tuple(nudge), 1.0, "")], 4.0, clamp, "")
    inactive = declared_inactive(engine, [probe_task], full)
    space = ParameterSpace(full.name, tuple(p for p in full.parameters if p.name not in inactive))
    if not len(space):
        raise ConfigError(f"design: no parameter of {space_name!r} moves the arm in {engine}")
    probe = _objective(engine, [probe_task], space, noise, {})
    generic = generic_values(probe, sorted(cls.supported(robot)))
    probe.close()
    points = [(label, {**generic, **space.to_dict(x)}, x) for label, x in _points(space, generic)]
    timing = _timing(points, robot.n_joints, template.kp, clamp)
    candidates = library(robot, template.start_pose_deg, template.kp, clamp, seed, timing)
    library_name, library_words = f"{name}-library", "the excursions a design is chosen from"
    lib_task, spans = design_task(template, library_name, candidates, _length(candidates), clamp, library_words)
    delays = [given_delay(lib_task.name, values) or 0.0 for _, values, _ in points]
    budget = duration - 2 * REST_S - max(delays)
    d = len(space)
    total = 3 * len(points) + len(points) * (d + 1) + 2 * (2 * d + 1)
    done = 0

    def step(what: str, units: int) -> None:
        nonlocal done
        done += units
        if progress:
            progress(what, min(done, total), total)

    self_check = checks.mujoco_installed()
    # 1. the library, screened in simulation at every point
    tries = [0] * len(candidates)
    for _ in range(SCREEN_ROUNDS):
        lib_task, spans = design_task(template, library_name, candidates, _length(candidates), clamp, library_words)
        blamed: set[int] = set()
        for (label, values, _), delay in zip(points, delays):
            found = checks.check_point(engine, lib_task, values, label, self_check)
            blamed |= _blamed(spans, found.bad_times(), delay)
            if not found.stable:
                raise SimtuneError(f"design: the library does not simulate stably in {engine} at the {label} point")
            step("screening the library", 1)
        if not blamed:
            break
        kept, kept_tries = [], []
        for k, (excursion, count) in enumerate(zip(candidates, tries)):
            if k not in blamed:
                kept.append(excursion)
                kept_tries.append(count)
            elif count < HALVINGS:
                kept.append(halved(excursion, timing))
                kept_tries.append(count + 1)
        candidates, tries = kept, kept_tries
        total += len(points)
    else:
        raise SimtuneError(f"design: excursions still fail the checks after {SCREEN_ROUNDS} rounds of halving")
    if not candidates:
        raise SimtuneError("design: every excursion touches the floor or the arm, or leaves a joint's limits")
    lengths = [e.length_s for e in candidates]
    if budget < min(lengths):
        raise ConfigError(
            f"--duration {duration:g} s: too short for one excursion (the shortest takes {min(lengths):.2f} s, "
            f"the rests {2 * REST_S:g} s and the largest command delay {max(delays):.2f} s)"
        )
    # 2. each excursion's information at each point
    objective = _objective(engine, [lib_task], space, noise, points[0][1])
    n = len(objective.references[lib_task.name].times)
    sigma2 = noise.sigma(n) ** 2
    infos = []
    signals = noise.widths(robot.n_joints)
    for (label, _, x), delay in zip(points, delays):
        jac = jacobian(objective, x, workers, one_sided=True)  # a screen: forward differences, half the rollouts
        rows = [sample_rows((a + delay, b + delay), n, 1.0 / CONTROL_PERIOD, signals) for a, b in spans]
        infos.append(np.stack([information(jac.unit, r, sigma2) for r in rows]))
        step(f"library Jacobian at the {label} point", d + 1)
    objective.close()
    # 3. the chain, checked at every point
    banned: set[int] = set()
    for _ in range(CHOICE_ROUNDS):
        masked = [stack.copy() for stack in infos]
        for k in banned:
            for stack in masked:
                stack[k] = 0.0
        chain, value = choose(masked, lengths, budget)
        chosen = [candidates[k] for k in chain]
        description = f"designed by simtune design for {len(space)} parameters of {space_name!r} in {engine}"
        task, chain_spans = design_task(template, name, chosen, duration, clamp, description)
        results = [checks.check_point(engine, task, values, label, self_check) for label, values, _ in points]
        step("checking the chain", len(points))
        failed = [r for r in results if not r.passed]
        if not failed:
            break
        for result, delay in zip(results, delays):
            banned |= {chain[k] for k in _blamed(chain_spans, result.bad_times(), delay)}
    else:
        raise SimtuneError(
            f"design: the chosen chain still fails its checks after {CHOICE_ROUNDS} choices: "
            + "; ".join(f"{r.point}: {_failure(r)}" for r in failed)
        )
    # 4. the designed task's predicted intervals, and the current tasks'
    designed = _objective(engine, [task], space, noise, points[0][1])
    jac = jacobian(designed, points[0][2], workers)
    step("the design's Jacobian", 2 * d + 1)
    scaled = _scaled(designed, jac.unit, noise)
    designed.close()
    current = [t for t in compared if t.robot == robot]
    current_scaled = None
    if current:
        now = _objective(engine, current, space, noise, points[0][1])
        current_scaled = _scaled(now, jacobian(now, points[0][2], workers).unit, noise)
        now.close()
    step("the current tasks' Jacobian", 2 * d + 1)
    summary = _summary(
        engine, space, task, points, infos, chain, candidates, chain_spans, results, scaled, current_scaled,
        current, noise, clamp, value, jac.kinked, started, self_check,
    )  # fmt: skip
    header = [
        f"designed by `simtune design` for {engine}: {len(space)} parameters of {space_name!r}, {duration:g} s",
        f"the velocity clamp {clamp:g} deg/s is part of the design: run the controller at it",
        f"criterion (smallest over {len(points)} points of log det(J^T J / noise^2 + {LAMBDA:.3g} I)): {value:.4g}",
        "each excursion: a step from the start pose and back, each pose held until the arm rests",
        "",
    ]
    return Design(task, task_toml(task, header), targets_csv(task), trajectory_yaml(task), summary)


def _timing(points, n_joints: int, kp: float, clamp: float) -> Timing:
    """The slowest controller over the points: each joint's ``kp_joint_<n>`` and ``max_velocity_joint_<n>`` where
    a point sets them, else the task's."""
    gains = [values.get(f"kp_joint_{i}", kp) for _, values, _ in points for i in range(1, n_joints + 1)]
    clamps = [values.get(f"max_velocity_joint_{i}", clamp) for _, values, _ in points for i in range(1, n_joints + 1)]
    return Timing(min(gains), min(clamps))


def _length(chain: list[Excursion]) -> float:
    return sum(e.length_s for e in chain) + 2 * REST_S


def _failure(result: checks.PointCheck) -> str:
    parts = []
    if result.floor_spans:
        parts.append(f"touches the floor at {result.floor_spans[0][0]:.2f} s")
    if result.self_contacts:
        t, a, b = result.self_contacts[0]
        parts.append(f"{a} touches {b} at {t:.2f} s")
    if result.limit_excess_deg:
        parts.append("leaves the limits of " + ", ".join(result.limit_excess_deg))
    if result.speed_excess:
        parts.append("exceeds the velocity limits of " + ", ".join(result.speed_excess))
    if result.end_speed_deg_s > checks.REST_DEG_S:
        parts.append(f"still moves at {result.end_speed_deg_s:.2g} deg/s at the end")
    return ", ".join(parts) or "unstable"


def _summary(
    engine, space, task, points, infos, chain, candidates, spans, results, scaled, current_scaled, current, noise,
    clamp, value, kinked, started, self_check,
) -> dict:  # fmt: skip
    predicted, known = widths(scaled, space)
    now, now_known = widths(current_scaled, space) if current_scaled is not None else ([None] * len(space), None)
    values = dict(points[0][1])
    x0 = points[0][2]
    ranges = np.array([p.high - p.low for p in space.parameters])
    parameters = []
    for i, p in enumerate(space.parameters):
        entry = {
            "name": p.name,
            "value": float(x0[i]),
            "range": [p.low, p.high],
            "predicted_width": predicted[i],
            "predicted_share": None if predicted[i] is None else predicted[i] / (p.high - p.low),
            "identified": known[i],
            "current_width": now[i],
            "current_share": None if now[i] is None else now[i] / (p.high - p.low),
            "current_identified": None if now_known is None else now_known[i],
        }
        if kinked is not None and kinked[i]:
            entry["non_smooth"] = True
        parameters.append(entry)
    weak = identifiability(space.names, scaled, x0, ranges, Z95, values)
    current_weak = (
        identifiability(space.names, current_scaled, x0, ranges, Z95, values) if current_scaled is not None else None
    )
    at_points = [
        {"point": label, "log_det": logdet(sum((stack[k] for k in chain), np.zeros(stack.shape[1:])))}
        for (label, _, _), stack in zip(points, infos)
    ]
    return {
        "engine": engine,
        "task": task.name,
        "duration_s": task.duration,
        "space": space.name,
        "parameters_designed": space.names,
        "velocity_clamp_deg_s": clamp,
        "controller_gain": task.kp,
        "signals": list(noise.signals),
        "noise": {"marker_m": noise.marker_m, "joint_deg": math.degrees(noise.joint_rad), "repeats": noise.repeats},
        "criterion": {
            "rule": f"smallest over the points of log det(J^T J / noise^2 + {LAMBDA:.4g} I), unit coordinates",
            "value": value,
            "at_points": at_points,
            "design_log_det": logdet(scaled.T @ scaled),
            "current_log_det": None if current_scaled is None else logdet(current_scaled.T @ current_scaled),
        },
        "points": [{"point": label, "values": {k: float(v) for k, v in zip(space.names, x)}} for label, _, x in points],
        "excursions": [
            {
                "label": candidates[k].label,
                "start_s": round(a, 3),
                "end_s": round(b, 3),
                "offsets_deg": list(candidates[k].offsets_deg),
            }
            for k, (a, b) in zip(chain, spans)
        ],
        "library_size": len(candidates),
        "checks": [r.as_json() for r in results],
        "self_contacts_checked": self_check,
        "current_tasks": [t.name for t in current],
        "parameters": parameters,
        "identifiability": weak,
        "current_identifiability": current_weak,
        "wall_s": round(time.monotonic() - started, 1),
    }
