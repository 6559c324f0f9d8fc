"""The designed schedule: excursions from the start pose, the library they are chosen from, and the files a lab runs.

A schedule is a chain of *excursions*: from the start pose at rest, a step of some joints to a target pose, held
until the arm has settled there, then a step back to the start pose, held until it has settled again.  Each
excursion starts and ends at rest at the same pose, so what its recording tells of the parameters does not depend on
which excursions came before it: the information of a chain is the sum of its excursions' (the design's search,
:mod:`simtune.design.search`, rests on that).  The controller's steps are what the clamped-P controller of every
task drives (``docs/task-files.md``): small ones below the velocity clamp (the gain alone sets the speed), large
ones at it (the clamp and, where it commands more than the servo's force allows, the force limit), single joints
and all of them at once (their inertial coupling, and poses that load the joints differently against gravity).

The files: the task file (TOML, ``[[phases]]``), the targets at the controller's rate as a CSV (``time`` then one
column per driven joint [deg], the header a task file's ``schedule_csv`` reads) and as a ROS 2
``trajectory_msgs/JointTrajectory`` in YAML (``joint_names``; ``points``, each with ``positions`` [rad] and
``time_from_start`` ``{sec, nanosec}``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace

import numpy as np

from simtune.engines.controller import CONTROL_PERIOD
from simtune.robot.description import RobotDescription
from simtune.tasks.spec import Phase, TaskSpec

#: The arm rests at its start pose this long before the first excursion [s] (each recording's motion onset, which
#: aligns the repeats' clocks, is seen), and at least this long after the last.
REST_S = 1.0
#: An excursion holds each of its two poses for the time its largest step takes at the clamp plus this [s], at least
#: :data:`SETTLE_TIME_CONSTANTS` of the controller's time constant (1 / gain): the arm is at rest again before the
#: next step (e^-5: under 1 % of the step left).
SETTLE_S = 0.4
SETTLE_TIME_CONSTANTS = 5.0
#: A joint's room for the design's steps: its range less this share of it at each end [deg] (as ``simtune init``'s
#: reach); a continuous joint (no limits) has +-180 deg.
ROOM_MARGIN = 0.1
#: The largest step of one joint [deg].
LARGE_DEG = 60.0
#: A small step commands this share of the velocity clamp (the gain alone sets its speed: kp x step < clamp).
SMALL_SHARE = 0.5
#: Excursions that move every joint at once, in the library (their offsets drawn with the design's seed).
TOGETHER = 10


@dataclass(frozen=True)
class Excursion:
    """From the start pose, every joint to ``start + offsets_deg``, held ``hold_s``, back, held ``hold_s``."""

    offsets_deg: tuple[float, ...]
    hold_s: float
    label: str

    @property
    def length_s(self) -> float:
        return 2.0 * self.hold_s


def rooms(robot: RobotDescription, start: tuple[float, ...]) -> list[tuple[float, float]]:
    """Each driven joint's room about ``start`` [deg]: how far it may step down and up (both >= 0)."""
    out = []
    for name, angle in zip(robot.arm_joints, start):
        joint = robot.joint_by_name[name]
        if joint.lower is None or joint.upper is None:
            low, high = angle - 180.0, angle + 180.0
        else:
            lower, upper = math.degrees(joint.lower), math.degrees(joint.upper)
            margin = ROOM_MARGIN * (upper - lower)
            low, high = lower + margin, upper - margin
        out.append((max(angle - low, 0.0), max(high - angle, 0.0)))
    return out


def hold_time(offsets_deg: tuple[float, ...], kp: float, clamp_deg_s: float) -> float:
    """How long an excursion holds each pose [s]: its largest step at the clamp, then the settling (see
    :data:`SETTLE_S`), rounded up to the controller's period."""
    largest = max((abs(v) for v in offsets_deg), default=0.0)
    hold = largest / clamp_deg_s + max(SETTLE_S, SETTLE_TIME_CONSTANTS / kp)
    return math.ceil(hold / CONTROL_PERIOD - 1e-9) * CONTROL_PERIOD


@dataclass(frozen=True)
class Timing:
    """The slowest controller an excursion's holds must wait for [1/s, deg/s]: the smallest gain and clamp over the
    design's points and joints (a gain a quarter of its range lower settles that much later)."""

    kp: float
    clamp: float


def _excursion(offsets: list[float], timing: Timing, label: str) -> Excursion:
    rounded = tuple(round(v, 3) + 0.0 for v in offsets)  # + 0.0: no -0.0 in a file
    return Excursion(rounded, hold_time(rounded, timing.kp, timing.clamp), label)


def library(
    robot: RobotDescription, start: tuple[float, ...], kp: float, clamp: float, seed: int, timing: Timing
) -> list[Excursion]:
    """The excursions a design is chosen from, in a fixed order.

    Per driven joint, alone, each way its room allows: a small step (:data:`SMALL_SHARE` of the clamp's speed over
    the gain: below the clamp), a large one (up to :data:`LARGE_DEG`, 80 % of the room) and one between them; then
    :data:`TOGETHER` excursions of every joint at once, each joint's offset drawn within 80 % of its room (at most
    :data:`LARGE_DEG`) with ``seed``.

    Args:
        robot: the robot.
        start: the start pose [deg].
        kp: the controller's gain [1/s] (a small step's size).
        clamp: the controller's velocity clamp [deg/s].
        seed: of the offsets drawn.
        timing: the slowest controller the holds wait for.
    Returns:
        The excursions; none that moves no joint.
    """
    n = robot.n_joints
    room = rooms(robot, start)
    small = SMALL_SHARE * clamp / kp
    out: list[Excursion] = []
    for i in range(n):
        for sign, side in ((1.0, room[i][1]), (-1.0, room[i][0])):
            large = min(LARGE_DEG, 0.8 * side)
            if large <= 0.0:
                continue
            sizes = sorted({min(small, large), math.sqrt(min(small, large) * large), large})
            for size, name in zip(sizes, ("small", "medium", "large")[-len(sizes) :]):
                offsets = [0.0] * n
                offsets[i] = sign * size
                out.append(_excursion(offsets, timing, f"joint {i + 1} {name} step {sign * size:+.3g} deg"))
    rng = np.random.default_rng(seed)
    for k in range(TOGETHER):
        draws = rng.uniform(-1.0, 1.0, n)
        offsets = [float(d) * min(LARGE_DEG, 0.8 * (room[i][1] if d > 0 else room[i][0])) for i, d in enumerate(draws)]
        out.append(_excursion(offsets, timing, f"every joint at once ({k + 1})"))
    return [e for e in out if any(v != 0.0 for v in e.offsets_deg)]


def halved(excursion: Excursion, timing: Timing) -> Excursion:
    """The excursion at half its size (one that touched the floor, tried again)."""
    return _excursion([v / 2 for v in excursion.offsets_deg], timing, f"{excursion.label}, halved")


def phases(start: tuple[float, ...], chain: list[Excursion], rest_s: float = REST_S) -> tuple[tuple[Phase, ...], list]:
    """The phases of ``chain`` after ``rest_s`` at the start pose, and each excursion's (start, end) [s]."""
    out: list[Phase] = []
    spans = []
    t = rest_s
    home = tuple(float(v) for v in start)
    for excursion in chain:
        target = tuple(round(s + d, 3) + 0.0 for s, d in zip(start, excursion.offsets_deg))
        out.append(Phase(round(t, 6), target))
        out.append(Phase(round(t + excursion.hold_s, 6), home))
        spans.append((t, t + excursion.length_s))
        t += excursion.length_s
    if not out:  # nothing chosen: hold the start pose (a schedule needs a phase)
        out.append(Phase(0.0, home))
    return tuple(out), spans


def chain_length(chain: list[Excursion], rest_s: float = REST_S) -> float:
    """The time ``chain`` takes with its rests at the start and the end [s]."""
    return 2 * rest_s + sum(e.length_s for e in chain)


def design_task(
    template: TaskSpec, name: str, chain: list[Excursion], duration: float, clamp: float, description: str
) -> tuple[TaskSpec, list]:
    """The task that runs ``chain`` for ``duration`` seconds: ``template``'s robot, start pose, gain and marker,
    the velocity clamp ``clamp``, no object; and each excursion's (start, end) [s]."""
    scheduled, spans = phases(template.start_pose_deg, chain)
    task = replace(
        template,
        name=name,
        description=description,
        duration=float(duration),
        phases=scheduled,
        max_velocity_deg=float(clamp),
        object=None,
        published_phases=None,
        recordings=None,
        has_public_recordings=False,
        start_from_recordings=False,
        lerobot=None,
    )
    return task, spans


def targets_at_rate(task: TaskSpec, rate: float = 1.0 / CONTROL_PERIOD) -> tuple[np.ndarray, np.ndarray]:
    """The targets in force at each tick of the controller's clock [deg], from 0 to the task's end: (times, rows)."""
    times = np.arange(int(round(task.duration * rate)) + 1) / rate
    starts, table = task.schedule
    rows = np.searchsorted(starts, times + 1e-9, side="right")
    return times, table[rows]


def task_toml(task: TaskSpec, header: list[str]) -> str:
    """The task file of ``task`` (``docs/task-files.md``), ``header`` as comments at its top."""

    def numbers(values) -> str:
        return json.dumps([float(f"{v:.6g}") + 0.0 for v in values])

    lines = [f"# {line}" if line else "#" for line in header]
    lines += [
        f"name = {json.dumps(task.name)}",
        f"description = {json.dumps(task.description, ensure_ascii=False)}",
        f"duration = {task.duration:g}",
        f"joints = {json.dumps(list(task.joints), ensure_ascii=False)}",
        f"start_pose_deg = {numbers(task.start_pose_deg)}",
        "",
        "[controller]",
        'law = "clamped-p-velocity"',
        f"gain = {task.kp:g}",
        f"max_velocity_deg = {task.max_velocity_deg:g}",
        "",
        "[mocap]",
        f"link = {json.dumps(task.tracked_link, ensure_ascii=False)}",
        f"body = {json.dumps(task.wrist_body, ensure_ascii=False)}",
    ]
    if task.base_body:
        lines.append(f"base_body = {json.dumps(task.base_body, ensure_ascii=False)}")
    for phase in task.phases:
        lines += ["", "[[phases]]", f"start = {phase.start:g}", f"targets_deg = {numbers(phase.targets_deg)}"]
    return "\n".join(lines) + "\n"


def targets_csv(task: TaskSpec) -> str:
    """The targets at the controller's rate: ``time,<joint>,...`` then a row per tick [s, deg] (a task file's
    ``schedule_csv`` reads it back)."""
    times, rows = targets_at_rate(task)
    lines = [",".join(["time", *task.joints])]
    for t, row in zip(times, rows):
        lines.append(",".join([f"{t:.6g}", *(f"{v:.6g}" for v in row)]))
    return "\n".join(lines) + "\n"


def trajectory_yaml(task: TaskSpec) -> str:
    """The targets at the controller's rate as a ROS 2 ``trajectory_msgs/JointTrajectory`` (YAML): positions
    [rad], ``time_from_start`` as ``{sec, nanosec}``; ``ros2 topic pub`` and ``rclpy``'s message fields take it."""
    times, rows = targets_at_rate(task)
    lines = [
        "# trajectory_msgs/JointTrajectory: the designed task's targets at the controller's rate "
        f"({1.0 / CONTROL_PERIOD:g} Hz), positions in rad",
        "header:",
        "  frame_id: ''",
        f"joint_names: {json.dumps(list(task.joints), ensure_ascii=False)}",
        "points:",
    ]
    for t, row in zip(times, rows):
        ns = int(round(t * 1e9))
        sec, nanosec = divmod(ns, 1_000_000_000)
        positions = ", ".join(f"{math.radians(v):.9g}" for v in row)
        lines.append(f"  - positions: [{positions}]")
        lines.append(f"    time_from_start: {{sec: {sec}, nanosec: {nanosec}}}")
    return "\n".join(lines) + "\n"
