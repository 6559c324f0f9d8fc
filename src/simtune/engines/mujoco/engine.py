"""MuJoCo (DeepMind) behind the engine interface.

The scene is compiled once per task; each rollout restores the compiled
model's own values, writes the parameters into the model arrays and resets
the data, so no state leaks from one evaluation into the next.

Mapping (docs/parameters.md has the full table):
- timestep -> ``opt.timestep``; masses -> ``body_mass`` (inertia scaled with it);
- max torque -> the velocity servo's ``actuator_forcerange``;
- joint damping -> ``dof_damping`` of the arm joints; armature -> ``dof_armature``; Coulomb joint
  friction -> ``dof_frictionloss`` (:meth:`MujocoEngine.set_armature`, :meth:`MujocoEngine.set_joint_friction`);
  a joint's servo gain -> its velocity servo's ``kv`` (``actuator_gainprm`` and ``actuator_biasprm``:
  :meth:`MujocoEngine.set_servo_gain`);
- lateral / spinning / rolling friction -> the three ``geom_friction`` columns of
  the group's geoms (MuJoCo takes the larger of two touching geoms' values);
- linear / angular damping of an object -> ``dof_damping`` of the translational /
  rotational degrees of freedom of its free joint.
MuJoCo has no coefficient of restitution (its soft contacts have none), and no
per-body velocity damping for the jointed arm or the static floor.
"""

from __future__ import annotations

import copy
import math
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from simtune.common.geometry import matrix_quat_wxyz, rpy_matrix
from simtune.engines.base import Engine, Monitor, Rollout, unreachable_servo_limits
from simtune.engines.controller import JointController
from simtune.engines.mujoco.batch import Batch, Stepper
from simtune.params.kinds import engine_parameters as kinds_of_engine
from simtune.robot import MICO
from simtune.robot.description import RobotDescription
from simtune.robot.generate import (
    FLOOR,
    LARGEST_COMMAND_STEP,
    OBJECT_BODY,
    SERVO_KV,
    command_step,
    scene_mjcf,
    servo_gains,
)
from simtune.tasks.spec import ObjectSpec, TaskSpec

try:
    import mujoco
except ImportError:  # pragma: no cover - depends on the machine
    mujoco = None
else:
    # MuJoCo prints warnings to stdout (which --json owns) and to MUJOCO_LOG.TXT in the
    # working folder; simtune reads the same events from data.warning (see diverged()).
    mujoco.set_mju_user_warning(lambda message: None)

_FRICTION_COLUMN = {"lateral_friction": 0, "spinning_friction": 1, "rolling_friction": 2}
#: the model arrays a reset restores from the compiled model's values before applying parameters
_MODEL_ARRAYS = (
    "body_mass",
    "body_inertia",
    "actuator_forcerange",
    "dof_damping",
    "geom_friction",
    "dof_armature",
    "dof_frictionloss",
    "actuator_gainprm",
    "actuator_biasprm",
)


def compile_scene(robot: RobotDescription, obj: ObjectSpec | None):
    """The compiled scene: from the generated MJCF, or, for a robot from an MJCF file, the generated scene
    with the file's robot attached and simtune's velocity servos on its driven joints."""
    text = scene_mjcf(robot, obj)
    if robot.mjcf is None:
        return mujoco.MjModel.from_xml_string(text)
    scene = mujoco.MjSpec.from_string(text)
    part = mujoco.MjSpec.from_file(robot.mjcf)
    # simtune owns control and contacts: the file's own actuators and what may refer to them go
    for element in (*part.actuators, *part.sensors, *part.keys, *part.equalities, *part.tendons, *part.pairs):
        part.delete(element)
    for element in part.excludes:
        part.delete(element)
    held = {name for name, _ in robot.held}
    for joint in list(part.joints):
        if joint.name in held:  # welded at its zero
            part.delete(joint)
    root = part.body(robot.root)
    root.pos = list(robot.base_position)  # the file's placement moved by the project's base pose
    root.quat = list(matrix_quat_wxyz(rpy_matrix(robot.base_rpy)))
    root.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT  # the quaternion, not the file's euler or axis
    for body in [root, *root.find_all(mujoco.mjtObj.mjOBJ_BODY)]:
        if body.name != robot.root:
            body.gravcomp = 1.0  # as the generated scene: the arm's controller compensates gravity
    for geom in root.find_all(mujoco.mjtObj.mjOBJ_GEOM):
        if geom.contype or geom.conaffinity:  # the generated scene's "arm" class; visual geoms collide with nothing
            geom.contype, geom.conaffinity, geom.condim = 2, 1, 3
    for i, (joint, gain) in enumerate(zip(robot.arm_joints, servo_gains(robot))):
        servo = scene.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        servo.set_to_velocity(kv=gain)
        limit = robot.generic_effort(i)
        servo.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        servo.forcerange = [-limit, limit]
    with warnings.catch_warnings():
        # an empty prefix keeps the file's names, which simtune uses (MuJoCo warns that saving may suffer)
        warnings.simplefilter("ignore")
        scene.worldbody.add_frame().attach_body(root, "", "")
        return scene.compile()


#: the engine's name in the registry and the kinds table
NAME = "mujoco"


class MujocoEngine(Engine):
    name = NAME
    reads_mjcf = True
    engine_parameters = kinds_of_engine(NAME, 6)  # its kinds in simtune.params.kinds

    @classmethod
    def version(cls) -> str:
        return mujoco.__version__ if mujoco else "not installed"

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        return super().inactive_parameters(task) | unreachable_servo_limits(task, SERVO_KV, measured_on=MICO)

    def __init__(self, task: TaskSpec):
        super().__init__(task)
        robot = task.robot
        self.model = compile_scene(robot, task.object)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._arm_qpos = np.array([m.jnt_qposadr[m.joint(j).id] for j in robot.arm_joints])
        self._arm_dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in robot.arm_joints])
        self._servos = np.array([m.actuator(j).id for j in robot.arm_joints])  # each named after its joint
        step = command_step(task.max_velocity_deg)
        # a task faster than the tuned clamps (40 deg/s) steps its commands further: a light link's servo gain is
        # lowered for it as servo_gains lowers it for 40 deg/s (a SO-101 driven at 180 deg/s spun its wrist); any
        # other task keeps the scene's own gains (written to 9 digits: set anew they would move every result)
        if step > LARGEST_COMMAND_STEP and robot.servo_gain is None:
            self.set_servo_gain(np.asarray(servo_gains(robot, step)))
        self._arm_links = robot.driven_links
        self._wrist = m.body(robot.tracked_link).id
        self._object = m.body(OBJECT_BODY).id if task.object is not None else None
        self._object_dof = m.jnt_dofadr[m.joint(OBJECT_BODY).id] if task.object is not None else None
        # body id -> whether it is a part of the arm (links and fingers)
        self._arm_body = np.zeros(m.nbody, dtype=bool)
        self._arm_body[[m.body(link.name).id for link in robot.links]] = True
        self._groups = {
            "floor": [m.geom(FLOOR).id],
            "gripper": [
                m.geom(g).id
                for link in robot.links
                if link.material == "gripper"
                for g in range(m.ngeom)
                if m.geom_bodyid[g] == m.body(link.name).id
            ],
        }
        if task.object is not None:
            self._groups[task.object.material] = [m.geom(OBJECT_BODY).id]
        if robot.mjcf is None:  # the description's Coulomb friction (an MJCF file's frictionloss is its own)
            m.dof_frictionloss[self._arm_dof] = [robot.joint_by_name[j].friction for j in robot.arm_joints]
        # the compiled model's own values: every reset starts from these
        self._pristine = {
            name: getattr(m, name).copy() if name != "timestep" else m.opt.timestep
            for name in ("timestep", *_MODEL_ARRAYS)
        }

    def defaults(self) -> dict[str, float]:
        p, m = self._pristine, self.model
        values = {"timestep": float(p["timestep"])}
        for i, link in enumerate(self._arm_links, start=1):
            values[f"mass_link_{i}"] = float(p["body_mass"][m.body(link).id])
            values[f"max_torque_joint_{i}"] = float(p["actuator_forcerange"][i - 1, 1])
            values[f"joint_damping_{i}"] = float(p["dof_damping"][self._arm_dof[i - 1]])
        if self.task.object is not None:
            assert self._object is not None and self._object_dof is not None, "set for a task with an object"
            values[self.task.object.mass_parameter] = float(p["body_mass"][self._object])
            values[f"linear_damping_{self.task.object.material}"] = float(p["dof_damping"][self._object_dof])
            values[f"angular_damping_{self.task.object.material}"] = float(p["dof_damping"][self._object_dof + 3])
        for group, geoms in self._groups.items():
            for kind, col in _FRICTION_COLUMN.items():
                values[f"{kind}_{group}"] = float(p["geom_friction"][geoms[0], col])
        return values | self.drive_defaults()

    def drive_defaults(self) -> dict[str, float]:
        """The compiled model's armature and Coulomb friction (``dof_armature``, ``dof_frictionloss``) of the
        driven joints (an MJCF file's own, else the description's), and its velocity servos' gains."""
        p = self._pristine
        return {
            f"{kind}_{i}": float(p[field][dof])
            for kind, field in (("armature_joint", "dof_armature"), ("friction_joint", "dof_frictionloss"))
            for i, dof in enumerate(self._arm_dof, start=1)
        } | {f"servo_gain_joint_{i}": float(p["actuator_gainprm"][a, 0]) for i, a in enumerate(self._servos, start=1)}

    def set_armature(self, values: np.ndarray) -> None:
        """``armature_joint_<n>`` [kg m^2] -> ``dof_armature`` of the driven joints."""
        self.model.dof_armature[self._arm_dof] = values

    def set_joint_friction(self, values: np.ndarray) -> None:
        """``friction_joint_<n>`` [N m] -> ``dof_frictionloss`` of the driven joints (MuJoCo's Coulomb joint
        friction, a soft constraint solved with the contacts)."""
        self.model.dof_frictionloss[self._arm_dof] = values

    def set_servo_gain(self, values: np.ndarray) -> None:
        """``servo_gain_joint_<n>`` [N m s/rad] -> the ``kv`` of the driven joints' velocity servos (MuJoCo's
        velocity actuator: force = kv x (command - speed), its gain ``gainprm[0]`` = kv and bias ``biasprm[2]``
        = -kv)."""
        self.model.actuator_gainprm[self._servos, 0] = values
        self.model.actuator_biasprm[self._servos, 2] = -values

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def reset(self, params: dict[str, float]) -> None:
        m, p = self.model, self._pristine
        m.opt.timestep = params.get("timestep", p["timestep"])
        for name in _MODEL_ARRAYS:
            getattr(m, name)[:] = p[name]
        self.apply_drive(params)

        def set_mass(body: int, mass: float) -> None:
            m.body_inertia[body] = p["body_inertia"][body] * (mass / p["body_mass"][body])
            m.body_mass[body] = mass

        for i, link in enumerate(self._arm_links, start=1):
            if f"mass_link_{i}" in params:
                set_mass(m.body(link).id, params[f"mass_link_{i}"])
            if f"max_torque_joint_{i}" in params:
                limit = params[f"max_torque_joint_{i}"]
                m.actuator_forcerange[i - 1] = (-limit, limit)
            if f"joint_damping_{i}" in params:
                m.dof_damping[self._arm_dof[i - 1]] = params[f"joint_damping_{i}"]
        obj = self.task.object
        if obj is not None:
            assert self._object is not None and self._object_dof is not None, "set for a task with an object"
            if obj.mass_parameter in params:
                set_mass(self._object, params[obj.mass_parameter])
            d0 = self._object_dof
            if f"linear_damping_{obj.material}" in params:
                m.dof_damping[d0 : d0 + 3] = params[f"linear_damping_{obj.material}"]
            if f"angular_damping_{obj.material}" in params:
                m.dof_damping[d0 + 3 : d0 + 6] = params[f"angular_damping_{obj.material}"]
        for group, geoms in self._groups.items():
            for kind, col in _FRICTION_COLUMN.items():
                if f"{kind}_{group}" in params:
                    m.geom_friction[geoms, col] = params[f"{kind}_{group}"]
        # the constants MuJoCo derives from masses at compile time (body_invweight0, dof_M0, stat.meaninertia
        # ..., used by the contact and solver settings) follow the new masses, as a model compiled with them has
        mujoco.mj_setConst(m, self.data)
        mujoco.mj_resetData(m, self.data)
        self.data.qpos[self._arm_qpos] = self.start_angles(params)
        mujoco.mj_forward(m, self.data)

    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        self.data.ctrl[:] = velocities

    def step(self, n: int) -> None:
        mujoco.mj_step(self.model, self.data, nstep=n)

    def diverged(self) -> str:
        # MuJoCo resets the state itself when accelerations blow up; that warning is the tell
        if self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
            return "MuJoCo reported bad accelerations (simulation exploded)"
        return ""

    def arm_object_contact(self) -> bool:
        obj = self._object
        return obj is not None and self._arm_touches(lambda geoms: self.model.geom_bodyid[geoms] == obj)

    def arm_floor_contact(self) -> bool:
        return self._arm_touches(lambda geoms: geoms == self._groups["floor"][0])

    def _arm_touches(self, other: Callable[[np.ndarray], np.ndarray]) -> bool:
        """Whether a contact of the last step pairs an arm shape with a geom ``other`` picks (geom ids -> mask)."""
        n = self.data.ncon
        if not n:
            return False
        # MuJoCo's contact list holds overlapping geom pairs only (no margins in the scene)
        g1, g2 = self.data.contact.geom1[:n], self.data.contact.geom2[:n]
        bodies = self.model.geom_bodyid
        return bool(np.any((other(g1) & self._arm_body[bodies[g2]]) | (other(g2) & self._arm_body[bodies[g1]])))

    def joint_angles(self) -> np.ndarray:
        return self.data.qpos[self._arm_qpos].copy()

    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        return self.data.xpos[self._wrist].copy(), self.data.xmat[self._wrist].reshape(3, 3).copy()

    def object_position(self) -> np.ndarray | None:
        return None if self._object is None else self.data.xpos[self._object].copy()

    # --- batches: lockstep control periods, on threads -----------------------------------------------------
    def rollout_batch(
        self,
        params: Sequence[dict[str, float]],
        n_samples: int,
        monitors: Sequence[Monitor | None] | None = None,
        threads: int = 1,
    ) -> Iterator[tuple[int, Rollout | Exception]]:
        """A batch's rollouts in lockstep control periods (:mod:`simtune.engines.mujoco.batch`): each member with
        its own copy of the model and data, the controller, sampling and checks of all members as one NumPy
        computation per period, their physics steps shared among ``threads`` threads (``mj_step`` runs without
        the GIL).  Each copy is reset from the compiled model's values before every rollout (tuned masses and
        time steps differ per member) and sees the calls :meth:`rollout` makes, in the same order: the results
        are those of :meth:`rollout`, bit for bit.  A batch of one is :meth:`rollout` itself.
        """
        if len(params) < 2 or n_samples < 1:
            yield from super().rollout_batch(params, n_samples, monitors)
            return
        engines = self._thread_copies(len(params))
        ready: list[int] = []
        controllers = []
        for i, p in enumerate(params):
            monitor = monitors[i] if monitors is not None else None
            try:  # in the order Engine.rollout_steps starts: a member whose parameters fail is that member's
                engines[i].reset(p)
                controller = JointController(self.task, p)
                if not 0 < engines[i].timestep < math.inf:  # no step counts: alone, it fails as it fails
                    yield i, engines[i].rollout(p, n_samples, monitor=monitor)
                    continue
            except Exception as exc:
                yield i, exc
                continue
            ready.append(i)
            controllers.append(controller)
        if not ready:
            return
        watch = [monitors[i] if monitors is not None else None for i in ready]
        batch = Batch([engines[i] for i in ready], controllers, watch, n_samples)
        threads = max(1, min(threads, len(ready)))
        done: set[int] = set()
        try:
            for slot, rollout in batch.run(Stepper(self._thread_pool(threads), threads)):
                done.add(slot)
                yield ready[slot], rollout
        except Exception as exc:  # a failure of the batch itself is each unfinished member's
            for slot, i in enumerate(ready):
                if slot not in done:
                    yield i, exc

    def _thread_pool(self, threads: int) -> ThreadPoolExecutor | None:
        """The pool of ``threads`` - 1 threads that step beside this one (None for one thread)."""
        if threads == 1:
            return None
        if self._pool is None or self._pool_threads != threads:
            self._close_pool()
            self._pool, self._pool_threads = ThreadPoolExecutor(threads - 1, thread_name_prefix="mujoco-batch"), threads
        return self._pool

    _pool: ThreadPoolExecutor | None = None
    _pool_threads = 0
    _copies: list[MujocoEngine] | None = None

    def _thread_copies(self, n: int) -> list[MujocoEngine]:
        """This engine and copies of it (own MjModel and MjData), ``n`` in all: one per member of a batch."""
        if self._copies is None:
            self._copies = [self]
        while len(self._copies) < n:
            twin = copy.copy(self)
            twin.model = copy.deepcopy(self.model)
            twin.data = mujoco.MjData(twin.model)
            twin._copies, twin._pool = None, None
            self._copies.append(twin)
        return self._copies

    def _close_pool(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def close(self) -> None:
        self._close_pool()
        self._copies = None
