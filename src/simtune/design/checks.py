"""A designed schedule's constraints, checked in simulation at each of the design's points.

Per point one rollout of the task (the design's engine; MuJoCo for the floor where that engine reports no floor
contact, ODE's and MuJoCo Warp's case), watched after every physics step:

- the floor: the spans during which an arm shape touches it (:func:`simtune.engines.contact.floor_touches`' rule);
- the joint limits: every sampled angle within its joint's limits;
- the velocity limits: the controller's clamp within each joint's velocity limit from the description, and the
  sampled speed (20 Hz differences) within it too;
- the force limits: MuJoCo's servo forces, their peak as a share of each joint's limit (the servo cannot exceed it:
  a step that reaches it is what tells a servo's gain from the joint's inertia, ``simtune check``'s advice);
- the arm itself: the sampled poses (and three between each two) through MuJoCo's collision detection on the arm's
  own shapes (:func:`simtune.engines.mujoco.self_contact.self_contacts`);
- at rest at the start and the end: the sampled speed over the first and the last :data:`REST_CHECK_S`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from simtune.engines import engine_class, make_engine
from simtune.engines.base import Engine
from simtune.engines.contact import rollout_samples
from simtune.tasks.spec import TaskSpec

#: The stretches at the start and the end over which the arm must be at rest [s], and the speed [deg/s] under which
#: a joint counts as at rest (a settling arm still creeps by hundredths of a degree per second).
REST_CHECK_S = 0.5
REST_DEG_S = 1.0
#: Poses placed between two samples for the arm's contacts with itself (a fast joint turns 9 deg in a sample).
BETWEEN = 3


@dataclass
class PointCheck:
    """What one rollout of a designed task showed at one point."""

    point: str
    floor_spans: list[tuple[float, float]] = field(default_factory=list)
    limit_excess_deg: dict[str, float] = field(default_factory=dict)  # joint -> how far past its limit
    speed_excess: dict[str, float] = field(default_factory=dict)  # joint -> peak speed / its limit, where above 1
    peak_force_share: dict[str, float] = field(default_factory=dict)  # joint -> peak servo force / its limit
    self_contacts: list[tuple[float, str, str]] = field(default_factory=list)  # (time, link, link)
    start_speed_deg_s: float = 0.0
    end_speed_deg_s: float = 0.0
    floor_engine: str = ""
    stable: bool = True
    angles: np.ndarray | None = None  # (samples, joints) [rad]
    #: (samples,) where some joint is beyond its limits
    _outside: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    #: (samples - 1,) the sample intervals over which some joint runs faster than its velocity limit
    _fast: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    @property
    def passed(self) -> bool:
        return (
            self.stable
            and not self.floor_spans
            and not self.limit_excess_deg
            and not self.speed_excess
            and not self.self_contacts
            and self.start_speed_deg_s <= REST_DEG_S
            and self.end_speed_deg_s <= REST_DEG_S
        )

    def bad_times(self) -> list[float]:
        """The instants [s] a constraint fails at (floor touches, contacts with itself, joint and velocity limits),
        for finding the excursion to blame (a motion too fast for a joint's limit is halved as one that leaves it)."""
        times = [a for a, _ in self.floor_spans] + [t for t, _, _ in self.self_contacts]
        if self.angles is not None and self.limit_excess_deg:
            times += list(np.flatnonzero(self._outside).astype(float) / 20.0)
        if self.speed_excess:
            times += list(np.flatnonzero(self._fast).astype(float) / 20.0)
        return sorted(times)

    def as_json(self) -> dict:
        return {
            "point": self.point,
            "passed": self.passed,
            "stable": self.stable,
            "floor_touches_s": [[round(a, 3), round(b, 3)] for a, b in self.floor_spans],
            "floor_checked_in": self.floor_engine,
            "beyond_joint_limits_deg": {k: round(v, 4) for k, v in self.limit_excess_deg.items()},
            "beyond_velocity_limits": {k: round(v, 3) for k, v in self.speed_excess.items()},
            "peak_force_share": {k: round(v, 3) for k, v in self.peak_force_share.items()},
            "self_contacts": [[round(t, 3), a, b] for t, a, b in self.self_contacts],
            "start_speed_deg_s": round(self.start_speed_deg_s, 4),
            "end_speed_deg_s": round(self.end_speed_deg_s, 4),
        }


def reports_floor(engine: str) -> bool:
    """Whether ``engine`` reports the arm's floor contacts (``Engine.arm_floor_contact``)."""
    return engine_class(engine).arm_floor_contact is not Engine.arm_floor_contact  # the base class raises


def check_point(engine: str, task: TaskSpec, params: dict[str, float], point: str, self_check: bool) -> PointCheck:
    """One rollout of ``task`` in ``engine`` at ``params``, its constraints checked (the module's list)."""
    robot = task.robot
    floor_engine = engine if reports_floor(engine) else "mujoco"
    result = PointCheck(point, floor_engine=floor_engine)
    sim = make_engine(engine, task)
    forces = np.zeros(robot.n_joints)
    limits = None
    steps = 0
    touching = False
    model = getattr(sim, "model", None) if engine == "mujoco" else None
    data = getattr(sim, "data", None) if engine == "mujoco" else None
    servos = getattr(sim, "_servos", None) if engine == "mujoco" else None

    def watch() -> None:
        nonlocal steps, touching
        steps += 1
        if floor_engine == engine:
            now = sim.arm_floor_contact()
            if now and touching:
                result.floor_spans[-1] = (result.floor_spans[-1][0], steps * sim.timestep)
            elif now:
                result.floor_spans.append((steps * sim.timestep, steps * sim.timestep))
            touching = now
        if data is not None and servos is not None:
            np.maximum(forces, np.abs(data.actuator_force[servos]), out=forces)

    try:
        rollout = sim.rollout(params, rollout_samples(task.duration), after_step=watch)
        if model is not None and servos is not None:
            limits = model.actuator_forcerange[servos, 1].copy()
    finally:
        sim.close()
    result.stable = rollout.stable
    if floor_engine != engine:
        from simtune.engines.contact import floor_touches

        supported = engine_class(floor_engine).supported(robot)
        other = make_engine(floor_engine, task)
        try:
            result.floor_spans = floor_touches(other, {k: v for k, v in params.items() if k in supported})
        finally:
            other.close()
    angles = rollout.joint_angles
    result.angles = angles
    _limits(result, task, angles)
    _speeds(result, task, angles)
    if limits is not None:
        result.peak_force_share = {
            name: float(f / lim) for name, f, lim in zip(robot.arm_joints, forces, limits) if lim > 0
        }
    if self_check:
        result.self_contacts = _self(task, angles)
    return result


def _limits(result: PointCheck, task: TaskSpec, angles: np.ndarray) -> None:
    outside = np.zeros(len(angles), dtype=bool)
    for i, name in enumerate(task.joints):
        joint = task.robot.joint_by_name[name]
        if joint.lower is None or joint.upper is None:
            continue
        below, above = joint.lower - angles[:, i], angles[:, i] - joint.upper
        excess = float(max(below.max(), above.max()))
        if excess > 1e-6:
            result.limit_excess_deg[name] = math.degrees(excess)
            outside |= (below > 1e-6) | (above > 1e-6)
    result._outside = outside


def _speeds(result: PointCheck, task: TaskSpec, angles: np.ndarray, rate: float = 20.0) -> None:
    speeds = np.abs(np.diff(angles, axis=0)) * rate  # [rad/s] per sample interval
    if not len(speeds):
        return
    fast = np.zeros(len(speeds), dtype=bool)
    for i, name in enumerate(task.joints):
        limit = task.robot.joint_by_name[name].velocity
        if limit and math.isfinite(limit) and limit > 0:
            peak = float(max(speeds[:, i].max(), math.radians(task.max_velocity_deg)))
            if peak > limit * (1 + 1e-6):
                result.speed_excess[name] = peak / limit
                fast |= speeds[:, i] > limit * (1 + 1e-6)
    result._fast = fast
    edge = max(int(round(REST_CHECK_S * rate)), 1)
    result.start_speed_deg_s = float(np.degrees(speeds[:edge].max()))
    result.end_speed_deg_s = float(np.degrees(speeds[-edge:].max()))


def _self(task: TaskSpec, angles: np.ndarray, rate: float = 20.0) -> list[tuple[float, str, str]]:
    """The arm's contacts with itself along the sampled poses (and :data:`BETWEEN` between each two); [] where
    MuJoCo is not installed (the caller says it was not checked)."""
    from simtune.engines.mujoco.self_contact import self_contacts

    steps = BETWEEN + 1
    fine = [angles[0]]
    for a, b in itertools.pairwise(angles):
        fine.extend(a + (b - a) * (k / steps) for k in range(1, steps + 1))
    found = self_contacts(task.robot, np.array(fine))
    seen: set[tuple[int, str, str]] = set()
    out = []
    for index, link_a, link_b in found:
        sample = index / steps / rate
        key = (int(sample * 2), link_a, link_b)  # one entry per pair per half second
        if key not in seen:
            seen.add(key)
            out.append((sample, link_a, link_b))
    return out


def mujoco_installed() -> bool:
    """Whether MuJoCo (the arm's contacts with itself, the floor for an engine without a floor report) is here."""
    return engine_class("mujoco").version() != "not installed"
