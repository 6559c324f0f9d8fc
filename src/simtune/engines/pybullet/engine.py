"""PyBullet (Bullet 3 multibody) behind the engine interface.

Each engine instance owns one DIRECT physics client.  A rollout's reset gives it the scene as loaded, so Bullet's
contact caches and warm-started solver state never carry over between evaluations: the same parameters always give
the same trajectory, bit for bit the one a freshly loaded scene gives (tests/test_engines.py, test_contact.py).
A scene without an object is loaded once and put back at each reset (:meth:`PybulletEngine._restore`: Bullet's
``restoreState`` of a snapshot taken right after loading - positions, velocities and contact points - and every
dynamics value the last rollout may have changed set back to its loaded one): loading again cost a meshed arm 0.1 s
a reset (the SO-101's 13 hulls of 150-4,900 vertices, whose shapes Bullet builds from every vertex at each load), as
much as its 8-s reach.  A scene with an object is loaded again at each reset (``resetSimulation``, ``loadURDF``):
``restoreState`` does not restore a body's sleep, so an object that came to rest and fell asleep at the end of one
rollout started the next asleep (the MICO's cube 1.8 mm off over its task); the fixed-base arm does not sleep.

The robot is loaded as its description says (``TaskSpec.loading`` "description", the default): each link's inertia
the file's (``URDF_USE_INERTIA_FROM_FILE``), no link velocity damping (Bullet gives every multibody link 0.04 of its
own, which no other engine has), a tuned mass scaling the file's inertia.  As the seed paper loaded it ("paper",
``--paper-exact``): inertias computed from the collision shapes (a tuned mass recomputing them) and Bullet's damping.

Mapping (docs/parameters.md has the full table): timestep -> ``setTimeStep``;
masses -> ``changeDynamics(mass=...)``; frictions, restitution and velocity damping
-> ``changeDynamics`` on each material group's bodies/links (:mod:`.mapping`, which
the export reads too); max torque -> the ``force`` of the velocity motors; joint
damping -> ``changeDynamics(jointDamping=...)``.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys

import numpy as np

from simtune.engines.base import Engine, library_version, unloaded_hard_motors
from simtune.engines.pybullet.mapping import DEFAULT_TIMESTEP, dynamics_changes, material_groups
from simtune.params.kinds import engine_parameters as kinds_of_engine
from simtune.robot import MICO
from simtune.robot.generate import robot_urdf_file
from simtune.tasks.spec import TaskSpec

try:
    import pybullet
except ImportError:  # pragma: no cover - depends on the machine
    pybullet = None


@contextlib.contextmanager
def _stdout_silenced():
    """Keep C-level prints (pybullet's banner on connect) off stdout, which --json owns."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            try:
                yield
            finally:
                ctypes.CDLL(None).fflush(None)  # C's stdio buffer holds the text until flushed
                os.dup2(saved, 1)
    finally:
        os.close(saved)


#: the engine's name in the registry and the kinds table
NAME = "pybullet"

#: the velocity damping a loaded multibody link has (``btMultiBody``'s ``0.04f``, a float: as a double 0.0399999991),
#: which getDynamicsInfo does not report; :meth:`PybulletEngine._restore` sets it back exactly.  The robot keeps it
#: loaded as the paper did (``TaskSpec.loading`` "paper"); as its description says, its links have none
LOADED_LINK_DAMPING = float(np.float32(0.04))


def robot_link_damping(loading: str) -> float:
    """The linear and angular velocity damping of every robot link as loaded ``loading`` (``TaskSpec.loading``):
    Bullet's own (:data:`LOADED_LINK_DAMPING`) as the paper loaded the robot, none as its description says."""
    return LOADED_LINK_DAMPING if loading == "paper" else 0.0


class PybulletEngine(Engine):
    name = NAME
    engine_parameters = kinds_of_engine(NAME, 6)  # its kinds in simtune.params.kinds
    reads_loading = True  # the file's inertias and no link damping, or the paper's loading (module docstring)

    @classmethod
    def version(cls) -> str:
        return library_version(pybullet, "pybullet")

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        # measured on every task and probe: only joint 2's motor, driving the hand into the floor, reaches the
        # limit; joints 2-6's damping shows through Bullet's iterative motor solution, joint 1's (no gravity load) not
        return super().inactive_parameters(task) | unloaded_hard_motors(
            "PyBullet", task, measured_on=MICO, joints=(1, 3, 4, 5, 6), damping=(1,)
        )

    def __init__(self, task: TaskSpec):
        super().__init__(task)
        with _stdout_silenced():
            self.client = pybullet.connect(pybullet.DIRECT)
        robot = task.robot
        # PyBullet collides with a mesh's convex hull, built from every vertex at each load: give it the hull
        self._urdf = robot_urdf_file(robot, hulls=True)
        self._generic_forces = [robot.generic_effort(i) for i in range(robot.n_joints)]
        self._timestep = DEFAULT_TIMESTEP
        self._paper_loading = task.loading == "paper"
        self._link_damping = robot_link_damping(task.loading)
        self._load()
        self._defaults = self._read_defaults()
        self._loaded_state: int | None = None  # the snapshot _restore puts back; None: each reset loads again
        if task.object is None:  # an object can fall asleep, which restoreState does not undo: loaded again instead
            self._snapshot()

    # --- scene --------------------------------------------------------------------
    def _load(self) -> None:
        p, c = pybullet, self.client
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0, 0, -9.81, physicsClientId=c)
        p.setTimeStep(self._timestep, physicsClientId=c)
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c)
        self.floor = p.createMultiBody(0, plane, physicsClientId=c)
        robot = self.task.robot
        self.robot = p.loadURDF(
            self._urdf,
            robot.base_position,
            p.getQuaternionFromEuler(robot.base_rpy),
            useFixedBase=True,
            # as the paper loaded it, Bullet computes each link's inertia from its collision shapes
            flags=0 if self._paper_loading else p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=c,
        )
        n_links = p.getNumJoints(self.robot, physicsClientId=c)
        if not self._paper_loading:  # as the description says: no velocity damping the file does not give
            for link in range(-1, n_links):
                p.changeDynamics(self.robot, link, linearDamping=0.0, angularDamping=0.0, physicsClientId=c)
        index = {
            p.getJointInfo(self.robot, j, physicsClientId=c)[12].decode(): j for j in range(n_links)
        }  # child link name -> index
        # each driven link's inertia as loaded: a tuned mass scales the file's (loaded as the description says)
        self._loaded_inertias = {j: p.getDynamicsInfo(self.robot, j, physicsClientId=c)[2] for j in index.values()}
        self._arm = [index[link] for link in robot.driven_links]
        self._wrist = index[robot.tracked_link]
        self._gripper_links = {  # name -> index
            link.name: index[link.name] for link in robot.links if link.material == "gripper" and link.name in index
        }
        # URDF joints start with a default velocity motor; switch them all to ours (zero target)
        self._forces = list(self._generic_forces)
        self.set_joint_velocities(np.zeros(len(self._arm)))
        self.object = None
        obj = self.task.object
        if obj is not None:
            if obj.shape in ("cube", "cuboid"):
                shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[s / 2 for s in obj.size], physicsClientId=c)
            elif obj.shape == "cylinder":
                shape = p.createCollisionShape(
                    p.GEOM_CYLINDER, radius=obj.size[0], height=obj.size[1], physicsClientId=c
                )
            else:
                shape = p.createCollisionShape(p.GEOM_MESH, vertices=obj.cone_vertices().tolist(), physicsClientId=c)
            quat = p.getQuaternionFromEuler(obj.rpy)
            self.object = p.createMultiBody(
                obj.mass, shape, basePosition=obj.start_position, baseOrientation=quat, physicsClientId=c
            )

    def _snapshot(self) -> None:
        """Keep the scene as :meth:`_load` left it: Bullet's state (``saveState``) and every dynamics value a reset
        may change, per (body, link), for :meth:`_restore` (a scene without an object)."""
        p, c = pybullet, self.client
        self._loaded_state = p.saveState(physicsClientId=c)
        self._loaded_dynamics: dict[tuple[int, int], dict] = {}
        for body in (self.floor, self.robot):  # no object: a scene with one is loaded again at each reset
            for link in range(-1, p.getNumJoints(body, physicsClientId=c)):
                info = p.getDynamicsInfo(body, link, physicsClientId=c)
                values = {"lateralFriction": info[1], "restitution": info[5]}
                values |= {"rollingFriction": info[6], "spinningFriction": info[7]}
                if body != self.floor:  # static: no mass, inertia or velocity damping to set
                    values |= {"mass": info[0], "localInertiaDiagonal": info[2]}
                    damping = self._link_damping if body == self.robot else LOADED_LINK_DAMPING
                    values |= {"linearDamping": damping, "angularDamping": damping}
                self._loaded_dynamics[(body, link)] = values
        self._loaded_joint_damping = [p.getJointInfo(self.robot, j, physicsClientId=c)[6] for j in self._arm]

    def _restore(self) -> None:
        """The scene as :meth:`_load` left it, without loading it again: the snapshot's state restored (bodies,
        joints, velocities, contact points), every dynamics value set back to its loaded one (a mass set by the
        last reset also recomputed its link's inertia from the collision shape: the loaded inertia is set back
        with it), the time step and the arm's motors as :meth:`_load` sets them."""
        p, c = pybullet, self.client
        assert self._loaded_state is not None, "a scene without an object has its snapshot"
        p.restoreState(self._loaded_state, physicsClientId=c)
        p.setTimeStep(self._timestep, physicsClientId=c)
        for (body, link), values in self._loaded_dynamics.items():
            p.changeDynamics(body, link, physicsClientId=c, **values)
        for joint, damping in zip(self._arm, self._loaded_joint_damping):
            p.changeDynamics(self.robot, joint, jointDamping=damping, physicsClientId=c)
        self._forces = list(self._generic_forces)
        self.set_joint_velocities(np.zeros(len(self._arm)))

    def _groups(self) -> dict[str, list[tuple[int, int]]]:
        """Material group -> (body, link) pairs it covers."""
        bodies = {"floor": self.floor, "robot": self.robot}
        if self.object is not None:
            bodies["object"] = self.object
        return {
            group: [(bodies[body], -1 if link is None else self._gripper_links[link]) for body, link in members]
            for group, members in material_groups(list(self._gripper_links), self.task.object).items()
        }

    def _read_defaults(self) -> dict[str, float]:
        p, c = pybullet, self.client
        values = {"timestep": DEFAULT_TIMESTEP}
        for i, link in enumerate(self._arm, start=1):
            values[f"mass_link_{i}"] = p.getDynamicsInfo(self.robot, link, physicsClientId=c)[0]
            values[f"max_torque_joint_{i}"] = self._generic_forces[i - 1]
            values[f"joint_damping_{i}"] = p.getJointInfo(self.robot, link, physicsClientId=c)[6]
        if self.object is not None and self.task.object is not None:
            values[self.task.object.mass_parameter] = p.getDynamicsInfo(self.object, -1, physicsClientId=c)[0]
        for group, members in self._groups().items():
            body, link = members[0]
            info = p.getDynamicsInfo(body, link, physicsClientId=c)
            values[f"lateral_friction_{group}"] = info[1]
            values[f"restitution_{group}"] = info[5]
            values[f"rolling_friction_{group}"] = info[6]
            values[f"spinning_friction_{group}"] = info[7]
            if group != "floor":
                # Bullet's default body damping (0.04), which getDynamicsInfo does not report; none on the robot's
                # links loaded as its description says
                damping = 0.0 if group == "gripper" and not self._paper_loading else 0.04
                values[f"linear_damping_{group}"] = damping
                values[f"angular_damping_{group}"] = damping
        return values

    # --- interface ------------------------------------------------------------------
    def defaults(self) -> dict[str, float]:
        return dict(self._defaults)

    @property
    def timestep(self) -> float:
        return self._timestep

    def reset(self, params: dict[str, float]) -> None:
        p, c = pybullet, self.client
        self.apply_drive(params)  # PyBullet has no drive-train kind: a value for one is refused
        self._timestep = params.get("timestep", DEFAULT_TIMESTEP)
        if self._loaded_state is not None:
            self._restore()
        else:
            self._load()
        for i, link in enumerate(self._arm, start=1):
            if f"mass_link_{i}" in params:
                mass = params[f"mass_link_{i}"]
                if self._paper_loading:  # Bullet computes the inertia for the new mass from the collision shape
                    p.changeDynamics(self.robot, link, mass=mass, physicsClientId=c)
                else:  # the file's inertia, scaled with the mass (as a change of density would)
                    loaded = self._defaults[f"mass_link_{i}"]
                    scale = mass / loaded if loaded > 0 else 1.0
                    inertia = [v * scale for v in self._loaded_inertias[link]]
                    p.changeDynamics(self.robot, link, mass=mass, localInertiaDiagonal=inertia, physicsClientId=c)
            if f"joint_damping_{i}" in params:
                p.changeDynamics(self.robot, link, jointDamping=params[f"joint_damping_{i}"], physicsClientId=c)
        self._forces = [params.get(f"max_torque_joint_{i}", f) for i, f in enumerate(self._generic_forces, start=1)]
        obj = self.task.object
        if obj is not None and obj.mass_parameter in params:
            p.changeDynamics(self.object, -1, mass=params[obj.mass_parameter], physicsClientId=c)
        for group, members in self._groups().items():
            changes = dynamics_changes(group, params)
            for body, link in members:
                if changes:
                    p.changeDynamics(body, link, physicsClientId=c, **changes)
        for joint, angle in zip(self._arm, self.start_angles(params)):
            p.resetJointState(self.robot, joint, angle, 0.0, physicsClientId=c)

    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        pybullet.setJointMotorControlArray(
            self.robot,
            self._arm,
            pybullet.VELOCITY_CONTROL,
            targetVelocities=list(velocities),
            forces=self._forces,
            physicsClientId=self.client,
        )

    def step(self, n: int) -> None:
        for _ in range(n):
            pybullet.stepSimulation(physicsClientId=self.client)

    def joint_angles(self) -> np.ndarray:
        states = pybullet.getJointStates(self.robot, self._arm, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        state = pybullet.getLinkState(
            self.robot, self._wrist, computeForwardKinematics=True, physicsClientId=self.client
        )
        rot = np.array(pybullet.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        return np.array(state[4]), rot

    def object_position(self) -> np.ndarray | None:
        if self.object is None:
            return None
        return np.array(pybullet.getBasePositionAndOrientation(self.object, physicsClientId=self.client)[0])

    def arm_object_contact(self) -> bool:
        return self.object is not None and self._arm_touches(self.object)

    def arm_floor_contact(self) -> bool:
        return self._arm_touches(self.floor)

    def _arm_touches(self, body: int) -> bool:
        points = pybullet.getContactPoints(self.robot, body, physicsClientId=self.client)
        # Bullet keeps manifold points up to its breaking distance apart: only touching ones count
        return any(point[8] <= 0.0 for point in points)

    def close(self) -> None:
        if pybullet is not None and self.client is not None and pybullet.isConnected(self.client):
            pybullet.disconnect(self.client)
        self.client = None

    def __del__(self) -> None:  # engine handles must not leak across many evaluations
        try:
            self.close()
        except Exception:
            pass
