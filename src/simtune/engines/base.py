"""The one small interface every physics engine implements.

An engine builds its scene for one task once, then runs any number of
rollouts: reset with a parameter dict, step, read joint angles and the wrist
and object poses.  The control loop, the 20 Hz sampling and the detection of
unstable simulations live here, once, so every engine runs the same protocol.
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from simtune.engines.controller import CONTROL_PERIOD, JointController
from simtune.errors import ConfigError, RobotError, SimtuneError
from simtune.params.kinds import (
    ALL_ENGINES,
    CONTROLLER,
    DRIVE_KINDS,
    ENCODERS,
    KINDS,
    MARKER,
    MATERIAL,
    applied_outside,
    engine_parameters,
    generic_joint_value,
    kinds_of,
    per_joint_kind,
)
from simtune.robot import DEFAULT_ROBOT
from simtune.robot.description import RobotDescription
from simtune.tasks.spec import MATERIALS, SHAPES, TaskSpec

#: The driven joints the engines name their per-joint parameters for: the default robot's
#: (:meth:`Engine.supported` renames them for another robot).
NAMED_JOINTS = range(1, DEFAULT_ROBOT.n_joints + 1)

#: Parameters applied outside the engine (controller, its encoders and the marker model), of the default robot.
COMMON_PARAMETERS = applied_outside(len(NAMED_JOINTS))


def per_joint(names: frozenset[str], n_joints: int) -> frozenset[str]:
    """``names`` with its per-joint parameters given for joints 1..``n_joints``."""
    kinds = kinds_of(names)
    kept = {name for name in names if per_joint_kind(name) is None}
    return frozenset(kept | {f"{kind}_{i}" for kind in kinds for i in range(1, n_joints + 1)})


#: Parameter kinds that come once per material group (``<kind>_<group>``, groups gripper,
#: floor and the two object materials): surfaces and body damping.
GROUP_KINDS = tuple(kind.name for kind in KINDS if kind.scope == MATERIAL)
#: The kinds of those that act only where two surfaces touch.
CONTACT_KINDS = ("lateral_friction", "rolling_friction", "spinning_friction", "restitution")
assert set(CONTACT_KINDS) <= set(GROUP_KINDS), "contact kinds are material kinds"

#: The lowest motor force limit [N m] the parameter spaces tune (`max_torque_joint_i`), which is
#: also every engine's generic limit.
LOWEST_TORQUE_LIMIT = 100.0


def unreachable_servo_limits(task: TaskSpec, engine_gain: float, measured_on: RobotDescription) -> dict[str, str]:
    """The torque limits of velocity servos: parameter -> why they never act.  Their gain [N m s/rad] is the
    robot's ``servo_gain``, else the engine's own ``engine_gain``.

    Such a servo's force is the gain times the velocity error, and the error stays under
    1 rad/s (the commanded speeds are at most 40 deg/s, 0.7 rad/s): below the lowest limit.
    That holds for the robot the engine measured it on, ``measured_on``; for another
    robot (whose generic limits, its URDF's efforts, may well be reached) nothing is ruled out.
    """
    gain = task.robot.servo_gain or engine_gain
    why = (
        f"the velocity servo's force ({gain:g} N m s/rad times the velocity error, under 1 rad/s) "
        f"never reaches {LOWEST_TORQUE_LIMIT:g} N m, the lowest tunable limit"
    )
    if task.robot != measured_on:
        return {}
    return {f"max_torque_joint_{i}": why for i in range(1, task.robot.n_joints + 1)}


def unloaded_hard_motors(
    engine: str, task: TaskSpec, measured_on: RobotDescription, joints: tuple[int, ...], damping: tuple[int, ...]
) -> dict[str, str]:
    """Parameters that never act where a hard velocity motor (a constraint up to its force limit)
    never reaches the lowest tunable limit: that joint's force limit, and its damping, whose torque
    the motor overrides.  ``joints`` and ``damping`` list those joints (measured on every task and
    probe of tests/test_engines.py: only a joint that drives the hand into the floor or an object,
    or takes the 20 Hz velocity steps with the whole arm's inertia, reaches the limit).  Measured on the
    robot ``measured_on``: for another robot nothing is ruled out."""
    if task.robot != measured_on:
        return {}
    limit = (
        f"{engine}'s hard velocity motor of this joint never needs {LOWEST_TORQUE_LIMIT:g} N m, "
        "the lowest tunable limit, in simtune's tasks"
    )
    held = f"{engine}'s hard velocity motor holds this joint's commanded velocity against its damping torque"
    inert = (
        f"{engine}'s hard velocity motor holds this joint's commanded velocity against its friction and inertia "
        "(as against its damping)"
    )
    drive = {f"{kind.name}_{i}": inert for kind in DRIVE_KINDS if engine.lower() in kind.engines for i in damping}
    return {f"max_torque_joint_{i}": limit for i in joints} | {f"joint_damping_{i}": held for i in damping} | drive


def library_version(library: object | None, distribution: str) -> str:
    """The version of an engine's library, installed as ``distribution``; "not installed" where ``library``, its
    module, could not be imported."""
    if library is None:
        return "not installed"
    from importlib.metadata import version

    return version(distribution)


#: A simulation whose wrist leaves this radius [m] around the base, or whose object flies
#: further than this from its start, has exploded.
WRIST_LIMIT = 2.0
OBJECT_LIMIT = 5.0
#: A robot whose reach is longer has its wrist limit at this multiple of its reach (:func:`wrist_limit`).
REACH_MARGIN = 1.5


def wrist_limit(robot) -> float:
    """The radius [m] around the base a stable simulation of ``robot``'s wrist never leaves: :data:`WRIST_LIMIT`, or
    :data:`REACH_MARGIN` times its reach for a robot longer than that allows (an industrial arm, a description drawn
    at another scale: a 4-m arm is not blown up at 2 m).

    Args:
        robot: the :class:`~simtune.robot.description.RobotDescription`.
    Returns:
        The limit [m].
    """
    return max(WRIST_LIMIT, REACH_MARGIN * robot.reach)


#: Samples between two checks of the state for a blow-up (0.5 s of simulated time at 20 Hz).
CHECK_EVERY = 10


#: sees each sample (index, wrist position, wrist rotation) of a rollout; True stops it (see Engine.rollout)
Monitor = Callable[[int, np.ndarray, np.ndarray], bool]


def marker_distance(pos: np.ndarray, rot: np.ndarray, offset: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Distance from ``target`` of the marker at ``offset`` in the wrist's frame, for a wrist at ``pos`` turned by
    ``rot``: arrays of (..., 3), (..., 3, 3), (..., 3), (..., 3); the distances (...).

    Element-wise operations only, in a fixed order, so that one row and a stack of rows round alike: a batch's
    members get the numbers each gets alone, bit for bit (a matrix product or a norm could sum in another order).
    """
    o = offset[..., None, :]  # each row's offset, against each of its rotation's rows
    marker = rot[..., 0] * o[..., 0] + rot[..., 1] * o[..., 1] + rot[..., 2] * o[..., 2]
    d = pos + marker - target
    return np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2])


class MarkerBudget:
    """A :data:`Monitor` that stops a rollout once the marker's distance from ``targets[k]``, summed over the
    samples so far, exceeds ``budget`` (differential evolution's pruning of a trial that cannot beat its parent).

    Called alone it watches one rollout; :meth:`watch_all` advances many of them by one sample with one NumPy
    computation (a batch's members), with the same sums bit for bit (:func:`marker_distance`).
    """

    def __init__(self, targets: np.ndarray, offset: np.ndarray, budget: float):
        self.targets, self.offset, self.budget = targets, np.asarray(offset, dtype=float), budget
        self.spent = 0.0

    def __call__(self, k: int, pos: np.ndarray, rot: np.ndarray) -> bool:
        self.spent += float(marker_distance(pos, rot, self.offset, self.targets[k]))
        return self.spent > self.budget

    @staticmethod
    def watch_all(monitors: Sequence[MarkerBudget], k: int, pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """Sample ``k`` of each monitor's rollout (rows of ``pos`` (m, 3) and ``rot`` (m, 3, 3)); whether each
        stops.  Monitors of one target, as a batch's members of one task have."""
        if not monitors:
            return np.zeros(0, dtype=bool)
        offsets = np.array([m.offset for m in monitors])
        distances = marker_distance(pos, rot, offsets, monitors[0].targets[k])
        stop = np.empty(len(monitors), dtype=bool)
        for j, (m, d) in enumerate(zip(monitors, distances.tolist())):
            m.spent += d
            stop[j] = m.spent > m.budget
        return stop


@dataclass
class Rollout:
    """What one simulated run of a task produced, sampled at the control rate."""

    times: np.ndarray  # (n,) seconds
    wrist_pos: np.ndarray  # (n, 3) world position of the robot's tracked link's origin [m]
    wrist_rot: np.ndarray  # (n, 3, 3) world rotation of the wrist frame
    joint_angles: np.ndarray  # (n, driven joints) [rad], as the encoders read them (true angles when uncalibrated)
    object_pos: np.ndarray | None  # (n, 3) or None for tasks without an object
    stable: bool = True
    message: str = ""
    steps: int = 0  # physics steps taken
    samples_run: int = 0  # samples actually simulated (fewer if stopped early)
    pruned: bool = False  # stopped early by the monitor: the rest could not change the outcome


def _load_errors_in_one_line(init: Callable) -> Callable:
    """An engine's ``__init__`` whose failures to build a task's robot (an engine library's own exception:
    MuJoCo's XML compiler, Drake's parser, DART's skeleton ...) become one :class:`RobotError` naming the
    engine, the robot's file and the engine's first line about the element, so that no command ends in a
    traceback on a robot that one engine cannot load."""

    @functools.wraps(init)
    def build(self, task: TaskSpec, *args, **kwargs) -> None:
        try:
            init(self, task, *args, **kwargs)
        except SimtuneError:
            raise
        except Exception as exc:
            robot = task.robot
            first = next((line.strip() for line in str(exc).splitlines() if line.strip()), "")
            where = f"engine {self.name!r} cannot load robot {robot.name!r} ({robot.source})"
            raise RobotError(f"{where}: {type(exc).__name__}: {first}") from exc

    return build


class Engine(ABC):
    """A physics engine with one task's robot and object loaded."""

    name: ClassVar[str]
    #: engine-specific parameter names this engine maps onto its API
    engine_parameters: ClassVar[frozenset[str]]
    #: whether the engine builds a robot from an MJCF file itself (:attr:`RobotDescription.mjcf`); the others
    #: build it from the URDF its description generates (``robot_urdf``: its collision geoms, without armature,
    #: joint friction or springs)
    reads_mjcf: ClassVar[bool] = False
    #: whether the task's loading (:attr:`TaskSpec.loading`: as the description says, or as the paper loaded the
    #: robot) changes what this engine simulates: only then does it enter a probe's and a start-up cache's key
    reads_loading: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "__init__" in cls.__dict__:  # every engine's model building, wrapped once where it is written
            setattr(cls, "__init__", _load_errors_in_one_line(cls.__dict__["__init__"]))  # noqa: B010

    def __init__(self, task: TaskSpec):
        if self.version() == "not installed":
            from simtune.engines import not_installed  # the registry holds each engine's install command

            raise not_installed(self.name)
        self.task = task

    @classmethod
    def supported(cls, robot: RobotDescription | None = None) -> frozenset[str]:
        """The parameters this engine maps, for ``robot``'s driven joints (default: the default robot's)."""
        if cls.name in ALL_ENGINES:  # the controller's, encoders' and marker's kinds the table gives the engine
            outside = engine_parameters(cls.name, len(NAMED_JOINTS), (CONTROLLER, ENCODERS, MARKER))
        else:  # an engine outside the registry (an export's replay) runs simtune's controller in full
            outside = COMMON_PARAMETERS
        names = cls.engine_parameters | outside
        return names if robot is None else per_joint(names, robot.n_joints)

    @classmethod
    def kind_parameters(cls) -> frozenset[str]:
        """The engine's own parameters as :mod:`simtune.params.kinds` lists them (the default robot's joints): what
        an engine of the registry sets as its ``engine_parameters``."""
        return engine_parameters(cls.name, len(NAMED_JOINTS))

    @classmethod
    def version(cls) -> str:
        return "unknown"

    @classmethod
    def device(cls) -> str:
        """What the engine computes on (``simtune engines`` shows it): a GPU engine names the GPU it found."""
        return "CPU"

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        """Parameters of this engine that cannot change a rollout of ``task``: name -> why.

        Here, what the task's scene rules out in every engine: the masses of objects it
        does not have, the surfaces and damping of a material it has no object of, and,
        without an object, the surfaces of the gripper and the floor (the arm never
        reaches the floor).  An engine whose own model ignores a parameter in a task adds
        it with the reason (``super().inactive_parameters(task) | {...}``).  Every other
        parameter of an engine's ``extended`` space must change a rollout where it can
        act: ``tests/test_engines.py`` checks both directions.
        """
        obj = task.object
        inactive: dict[str, str] = {}
        for shape in SHAPES:
            for material in MATERIALS:
                if obj is None or (shape, material) != (obj.shape, obj.material):
                    inactive[f"mass_{shape}_{material}"] = f"task {task.name!r} has no {material} {shape}"
        for material in MATERIALS:
            if obj is None or obj.material != material:
                for kind in GROUP_KINDS:
                    inactive[f"{kind}_{material}"] = f"task {task.name!r} has no {material} object"
        if obj is None:
            for group in ("gripper", "floor"):
                for kind in CONTACT_KINDS:
                    # held, not measured: a task without an object is tuned as if its arm never touched the floor
                    # (`simtune check` warns where the generic arm does: probe 5 said it "never reaches" it there)
                    inactive[f"{kind}_{group}"] = (
                        f"task {task.name!r} has no object: the floor's and the gripper's surfaces are held, the task "
                        "tuned as if the arm never touched the floor"
                    )
        supported = cls.supported(task.robot)
        return {name: why for name, why in inactive.items() if name in supported}

    # --- what each engine implements -------------------------------------------------
    @abstractmethod
    def defaults(self) -> dict[str, float]:
        """The engine's own (generic) values of its engine-specific parameters."""

    @abstractmethod
    def reset(self, params: dict[str, float]) -> None:
        """Apply ``params`` (missing ones take generic values) and put the scene in its start state
        (the arm at :meth:`start_angles`)."""

    def drive_defaults(self) -> dict[str, float]:
        """The generic values of the drive-train kinds (:data:`simtune.params.kinds.DRIVE_KINDS`) this engine has:
        the robot description's (an engine whose model holds its own, as MuJoCo's of an MJCF file, overrides)."""
        robot = self.task.robot
        return {
            f"{kind.name}_{i}": generic_joint_value(kind.name, robot, i - 1, self.task.kp)
            for kind in DRIVE_KINDS
            if self.name in kind.engines
            for i in range(1, robot.n_joints + 1)
        }

    def apply_drive(self, params: dict[str, float]) -> None:
        """Apply every drive-train kind this engine has through its own method (``Kind.apply``: armature, joint
        friction), each joint's value from ``params`` or :meth:`drive_defaults`; a value of a kind the engine lacks
        is a :class:`ConfigError` naming it (never silently ignored)."""
        n = self.task.robot.n_joints
        generic = self.drive_defaults()
        for kind in DRIVE_KINDS:
            names = [f"{kind.name}_{i}" for i in range(1, n + 1)]
            if self.name not in kind.engines:
                given = [name for name in names if name in params]
                if given:
                    raise ConfigError(f"engine {self.name!r} has no parameter {given[0]!r} (see docs/parameters.md)")
                continue
            getattr(self, str(kind.apply))(np.array([params.get(name, generic[name]) for name in names], dtype=float))

    def start_angles(self, params: dict[str, float]) -> np.ndarray:
        """The driven joints' start angles [rad]: where the encoders, as ``params`` model them, read
        the task's start pose."""
        return JointController(self.task, params).start_angles()

    @property
    @abstractmethod
    def timestep(self) -> float:
        """The physics time step in force after the last reset [s]."""

    @abstractmethod
    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        """Velocity targets [rad/s] for the motors of the robot's driven joints."""

    @abstractmethod
    def step(self, n: int) -> None:
        """Advance the physics by ``n`` time steps."""

    @abstractmethod
    def joint_angles(self) -> np.ndarray:
        """The angles of the robot's driven joints [rad]."""

    @abstractmethod
    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position and 3x3 rotation of the robot's tracked link's frame."""

    @abstractmethod
    def object_position(self) -> np.ndarray | None:
        """World position of the object's origin, or None if the task has none."""

    def arm_object_contact(self) -> bool:
        """Whether an arm or finger shape touches the task's object now.

        Read from the engine's own contact list of the last physics step (shapes
        overlapping or touching, not merely near); False for a task without an object.
        Every engine of the registry implements it (tests/test_contact.py); the
        export round trip's file-driven engines need no contacts.
        """
        raise NotImplementedError(f"{self.name} does not report contacts")

    def arm_floor_contact(self) -> bool:
        """Whether an arm or finger shape touches the floor now (read as :meth:`arm_object_contact`).

        A task without an object is simulated as if the arm never reached the floor (its surfaces' parameters are
        inactive there), so a task whose arm does touch it is flagged (:func:`simtune.engines.contact.floor_touches`).
        """
        raise NotImplementedError(f"{self.name} does not report floor contacts")

    def diverged(self) -> str:
        """A reason if the engine itself reports the simulation as broken, else ''."""
        return ""

    def close(self) -> None:  # noqa: B027 - optional hook: most engines hold nothing to release
        """Release engine resources."""

    # --- the protocol, shared by all engines ---------------------------------------------
    def rollout(
        self,
        params: dict[str, float],
        n_samples: int,
        rate: float = 1.0 / CONTROL_PERIOD,
        monitor: Monitor | None = None,
        after_step: Callable[[], None] | None = None,
    ) -> Rollout:
        """Run the task for ``n_samples`` control periods and sample the state at each.

        Sample ``k`` is the state at ``k / rate`` seconds.  The controller updates
        ``controller.phase`` later in each period (at once when the command delay
        is a whole number of periods), from the state at that instant.  Physics
        steps are counted so that simulated time stays within half a step of
        both clocks whatever the time step.  ``monitor(k, wrist_pos, wrist_rot)``,
        if given, sees every sample and may stop the rollout by returning True
        (the rollout is then marked ``pruned``).  ``after_step()``, if given, is
        called after every single physics step (the steps are then taken one at
        a time, which changes no engine's result): for probes of events shorter
        than a control period, such as a first contact.
        """
        rollout = self.rollout_steps(params, n_samples, rate, monitor, after_step)
        try:
            n = next(rollout)
            while True:
                self.step(n)
                n = rollout.send(None)
        except StopIteration as finished:
            return finished.value

    def rollout_steps(
        self,
        params: dict[str, float],
        n_samples: int,
        rate: float = 1.0 / CONTROL_PERIOD,
        monitor: Monitor | None = None,
        after_step: Callable[[], None] | None = None,
    ) -> Generator[int, None, Rollout]:
        """:meth:`rollout` as a generator that yields each run of physics steps it needs, and returns the rollout.

        Whoever drives it takes ``n`` steps of this engine (``self.step(n)``) for each ``n`` it yields, then
        resumes it: :meth:`rollout` does so at once; a batch path may step many members' engines together (on
        threads, without the GIL) before it resumes them, with results equal bit for bit, since each member's
        engine sees the same calls in the same order.  With ``after_step`` it steps itself and yields nothing.
        """
        period = 1.0 / rate
        self.reset(params)
        controller = JointController(self.task, params)
        dt = self.timestep
        times = np.arange(n_samples) * period
        phase = controller.phase
        targets = controller.targets(times + phase)  # at each update instant
        wrist_pos = np.zeros((n_samples, 3))
        wrist_rot = np.tile(np.eye(3), (n_samples, 1, 1))
        angles = np.zeros((n_samples, self.task.robot.n_joints))
        has_object = self.task.object is not None
        object_pos = np.zeros((n_samples, 3)) if has_object else None
        object_start = self.object_position() if has_object else None
        t_sim, steps, stable, message, samples_run, pruned = 0.0, 0, True, "", 0, False
        checked = 0  # samples [0, checked) passed the state check
        for k in range(n_samples):
            q = controller.encoder(self.joint_angles())
            wrist_pos[k], wrist_rot[k] = self.wrist_pose()
            angles[k] = q
            if object_pos is not None:
                object_pos[k] = self.object_position()
            reason = self.diverged()
            if reason or k == n_samples - 1 or k - checked >= CHECK_EVERY - 1:
                # the state check is vectorised over the samples since the last one: a blow-up is
                # caught at most CHECK_EVERY samples late, and its first bad sample found exactly
                bad, why = _first_bad(
                    wrist_pos[checked : k + 1],
                    wrist_rot[checked : k + 1],
                    angles[checked : k + 1],
                    object_pos[checked : k + 1] if object_pos is not None else None,
                    object_start,
                    wrist_limit(self.task.robot),
                )
                if bad is None and reason:
                    bad, why = k - checked, reason
                if bad is not None:
                    samples_run = checked + bad
                    stable, message = False, f"unstable at t={times[samples_run]:.2f} s: {why}"
                    break
                checked = k + 1
            samples_run = k + 1
            if k == n_samples - 1:
                break
            if monitor is not None and monitor(k, wrist_pos[k], wrist_rot[k]):
                pruned = True
                break
            if phase:  # run on to the controller's update instant, which reads the state there
                n = int(round((k * period + phase - t_sim) / dt))
                if n > 0:
                    yield from self._advance(n, after_step)
                    t_sim += n * dt
                    steps += n
                    q = controller.encoder(self.joint_angles())
            self.set_joint_velocities(controller.velocity(targets[k], q))
            n = max(1, int(round(((k + 1) * period - t_sim) / dt)))
            yield from self._advance(n, after_step)
            t_sim += n * dt
            steps += n
        if 0 < samples_run < n_samples:  # ended early: hold the last good sample for the rest
            for samples in (wrist_pos, wrist_rot, angles, *([object_pos] if object_pos is not None else [])):
                samples[samples_run:] = samples[samples_run - 1]
        return Rollout(times, wrist_pos, wrist_rot, angles, object_pos, stable, message, steps, samples_run, pruned)

    def rollout_batch(
        self,
        params: Sequence[dict[str, float]],
        n_samples: int,
        monitors: Sequence[Monitor | None] | None = None,
        threads: int = 1,
    ) -> Iterator[tuple[int, Rollout | Exception]]:
        """The rollout of each parameter dict of a batch, yielded as ``(index, rollout)`` as each finishes.

        The seam where an engine runs a whole population at once (threads, a GPU): each member's rollout
        must equal what :meth:`rollout` gives it alone, bit for bit.  ``monitors[i]`` watches member i (see
        :meth:`rollout`); ``threads`` is how many the engine may use.  A member whose rollout raised yields
        the exception instead (the others go on).  Here: one member after the other, in order.
        """
        for i, p in enumerate(params):
            try:
                yield i, self.rollout(p, n_samples, monitor=monitors[i] if monitors is not None else None)
            except Exception as exc:  # one member's failure is that member's, as in a worker process
                yield i, exc

    def _advance(self, n: int, after_step: Callable[[], None] | None) -> Generator[int, None, None]:
        if after_step is None:
            yield n  # the driver steps
            return
        for _ in range(n):
            self.step(1)
            after_step()


def _first_bad(pos, rot, q, obj, obj_start, limit: float = WRIST_LIMIT) -> tuple[int | None, str]:
    """Index of the first sample of a block whose state is broken (non-finite, wrist beyond ``limit`` or object flown
    off), and why."""
    problems = []
    finite = np.isfinite(q).all(axis=1) & np.isfinite(pos).all(axis=1) & np.isfinite(rot).all(axis=(1, 2))
    problems.append((~finite, lambda i: "non-finite arm state"))
    with np.errstate(invalid="ignore", over="ignore"):
        reach = np.einsum("ij,ij->i", pos, pos)
        problems.append((reach > limit**2, lambda i: f"wrist {math.sqrt(reach[i]):.1f} m from the base"))
        if obj is not None:
            moved = obj - obj_start
            problems.append((~np.isfinite(moved).all(axis=1), lambda i: "non-finite object state"))
            flight = np.einsum("ij,ij->i", moved, moved)
            problems.append((flight > OBJECT_LIMIT**2, lambda i: f"object thrown {math.sqrt(flight[i]):.1f} m"))
    first, why = None, ""
    for mask, describe in problems:
        hits = np.flatnonzero(mask)
        if hits.size and (first is None or hits[0] < first):
            first, why = int(hits[0]), describe(int(hits[0]))
    return first, why
