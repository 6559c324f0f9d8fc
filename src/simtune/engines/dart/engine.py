"""DART (Dynamic Animation and Robotics Toolkit) through ``dartpy``.

The arm is the generated URDF, read by DART's own URDF loader with a fixed
root joint moved to the base position.  Each arm joint gets a SERVO actuator:
DART's velocity servo is a constraint in its LCP solver that drives the joint
to the commanded velocity with at most the joint's force limits (the maximum
torque), a hard motor like PyBullet's.  The floor is a static skeleton with a
plane, the object a skeleton on a free joint with a box, cylinder or cone.
Contacts go through DART's own constraint solver (boxed LCP), with DART's
Bullet collision detector (DART's default FCL detector, with its meshed
primitives, drops the cone through the floor and lets a pushed box sink), each
mesh of the robot as its convex hull, the shape MuJoCo, PyBullet and ODE collide
with too.

Mapping (docs/parameters.md has the full table): timestep -> ``World.setTimeStep``;
masses -> ``BodyNode.setMass`` (inertia scaled with it); max torque -> the joint's
force limits; joint damping -> ``Joint.setDampingCoefficient``; Coulomb joint friction ->
``Joint.setCoulombFriction`` (DART 6 has no armature); lateral friction
and restitution -> each shape node's ``DynamicsAspect`` (DART combines two
shapes' friction with the minimum and restitution with the product); an object's
linear / angular damping -> the damping coefficients of its free joint's
translational / rotational coordinates.  DART 6 has no rolling or spinning
friction, and no per-body velocity damping for the jointed hand or the static
floor: those parameters are left out.
"""

from __future__ import annotations

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.engines._shapes import object_mass_properties
from simtune.engines.base import Engine, unloaded_hard_motors
from simtune.params.kinds import engine_parameters as kinds_of_engine
from simtune.robot import MICO
from simtune.robot.generate import robot_urdf_file
from simtune.robot.meshes import obj_vertices
from simtune.tasks.spec import TaskSpec

try:
    import dartpy
except ImportError:  # pragma: no cover - depends on the machine
    dartpy = None


def _isometry(pos, rot=None):
    t = dartpy.math.Isometry3()
    t.set_identity()
    t.set_translation(np.asarray(pos, dtype=float))
    if rot is not None:
        t.set_rotation(np.asarray(rot, dtype=float))
    return t


#: the engine's name in the registry and the kinds table
NAME = "dart"


class DartEngine(Engine):
    name = NAME
    engine_parameters = kinds_of_engine(NAME, 6)  # its kinds in simtune.params.kinds

    @classmethod
    def version(cls) -> str:
        return dartpy.__version__ if dartpy is not None else "not installed"

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        # measured on every task and probe: joints 1 and 2 reach the limit (the 20 Hz velocity steps move the
        # whole arm's inertia, and pressing the floor), joints 3-6 never
        return super().inactive_parameters(task) | unloaded_hard_motors(
            "DART", task, measured_on=MICO, joints=(3, 4, 5, 6), damping=(3, 4, 5, 6)
        )

    def __init__(self, task: TaskSpec):
        super().__init__(task)
        d = dartpy
        self.world = d.simulation.World()
        self.world.setGravity(np.array([0.0, 0.0, -9.81]))
        # Bullet's collision detection: DART's default (FCL with meshed primitives) loses the
        # cone and lets a pushed box sink into the floor plane
        self.world.setCollisionDetector(d.simulation.CollisionDetectorType.BULLET)
        # no sleeping bodies: DART 6.20 puts a body that stays slow for 0.5 s to sleep, and its sleep clock
        # outlives every reset, so a rollout depended on the one before it (up to 9e-7 m on `cube` after
        # one with a slippery floor); DART before 6.20 does not sleep at all
        if hasattr(self.world, "getDeactivationOptions"):
            deactivation = self.world.getDeactivationOptions()
            deactivation.mEnabled = False
            self.world.setDeactivationOptions(deactivation)

        loader = d.utils.DartLoader()
        options = d.utils.DartLoader.Options()
        options.mDefaultRootJointType = d.utils.DartLoaderRootJointType.FIXED
        loader.setOptions(options)
        robot = task.robot
        # each mesh read as its convex hull (the shape MuJoCo, PyBullet and ODE collide with), then made a convex
        # shape of the hull's points (collide_with_hulls); the hull OBJs simtune writes name no material file, so
        # DART's hundred lines per mesh about a missing one (a published OBJ's) never come
        self.robot = loader.parseSkeleton(robot_urdf_file(robot, hulls=True))
        collide_with_hulls(self.robot)
        base_rot = rpy_matrix(robot.base_rpy) if robot.base_rpy != (0.0, 0.0, 0.0) else None
        self.robot.getRootJoint().setTransformFromParentBodyNode(_isometry(robot.base_position, base_rot))
        self._arm = [self.robot.getJoint(j) for j in robot.arm_joints]
        for joint in self._arm:
            joint.setActuatorType(d.dynamics.ActuatorType.SERVO)
            joint.setLimitEnforcement(True)  # the limited joints' stops (the MICO's joint_2/3)
        self._links = [self.robot.getBodyNode(link) for link in robot.driven_links]
        self._wrist = self.robot.getBodyNode(robot.tracked_link)
        # the skeleton's coordinates in the driven joints' order (every other joint is welded)
        self._dofs = np.array([joint.getIndexInSkeleton(0) for joint in self._arm])
        self.world.addSkeleton(self.robot)  # self-collision stays off: arm shapes never touch each other

        floor = d.dynamics.Skeleton("floor")
        _, floor_body = floor.createWeldJointAndBodyNodePair(None)
        floor_shape = floor_body.createShapeNode(d.dynamics.PlaneShape(np.array([0.0, 0.0, 1.0]), 0.0))
        floor_shape.createCollisionAspect()
        floor_shape.createDynamicsAspect()
        floor.setMobile(False)
        self.world.addSkeleton(floor)

        self._shapes = {
            "floor": [floor_shape],
            "gripper": [
                s
                for link in robot.links
                if link.material == "gripper"
                for s in self.robot.getBodyNode(link.name).getShapeNodes()
                if s.hasCollisionAspect()
            ],
        }
        self.object = None
        self._object_com = np.zeros(3)
        obj = task.object
        if obj is not None:
            skel = d.dynamics.Skeleton("object")
            self._free, self.object = skel.createFreeJointAndBodyNodePair(None)
            if obj.shape in ("cube", "cuboid"):
                shape = d.dynamics.BoxShape(np.asarray(obj.size, dtype=float))
            elif obj.shape == "cylinder":
                shape = d.dynamics.CylinderShape(obj.size[0], obj.size[1])
            else:  # DART's cone: axis z, origin at the middle of its height, like simtune's
                shape = d.dynamics.ConeShape(obj.size[0], obj.size[1])
            node = self.object.createShapeNode(shape)
            node.createCollisionAspect()
            node.createDynamicsAspect()
            self._object_com, _ = object_mass_properties(obj)
            self._set_object_mass(obj.mass)
            self._shapes[obj.material] = [node]
            self.world.addSkeleton(skel)
        self._defaults = self._read_defaults()

    def _set_object_mass(self, mass: float) -> None:
        assert self.task.object is not None and self.object is not None, "only a task with an object has one"
        com, inertia = object_mass_properties(self.task.object, mass)
        self.object.setInertia(dartpy.dynamics.Inertia(mass, com, inertia))

    def _read_defaults(self) -> dict[str, float]:
        values = {"timestep": float(self.world.getTimeStep())}
        for i, (joint, link) in enumerate(zip(self._arm, self._links), start=1):
            values[f"mass_link_{i}"] = float(link.getMass())
            # DART's own limit is infinite: the robot's generic one
            values[f"max_torque_joint_{i}"] = self.task.robot.generic_effort(i - 1)
            values[f"joint_damping_{i}"] = float(joint.getDampingCoefficient(0))
        self._link_mass = [float(link.getMass()) for link in self._links]
        self._link_moment = [np.array(link.getInertia().getMoment()) for link in self._links]
        for group, nodes in self._shapes.items():
            if not nodes:  # a group with no shape (a robot described without geometry): DART's own defaults
                values[f"lateral_friction_{group}"], values[f"restitution_{group}"] = 1.0, 0.0
                continue
            aspect = nodes[0].getDynamicsAspect()
            values[f"lateral_friction_{group}"] = float(aspect.getFrictionCoeff())
            values[f"restitution_{group}"] = float(aspect.getRestitutionCoeff())
        obj = self.task.object
        if obj is not None:
            assert self.object is not None, "made for a task with an object"
            values[obj.mass_parameter] = float(self.object.getMass())
            values[f"angular_damping_{obj.material}"] = float(self._free.getDampingCoefficient(0))
            values[f"linear_damping_{obj.material}"] = float(self._free.getDampingCoefficient(3))
        return values | self.drive_defaults()

    # --- interface ------------------------------------------------------------------
    def defaults(self) -> dict[str, float]:
        return dict(self._defaults)

    @property
    def timestep(self) -> float:
        return float(self.world.getTimeStep())

    def reset(self, params: dict[str, float]) -> None:
        p = {**self._defaults, **params}
        # a fresh collision detector: Bullet keeps contact manifolds from step to step, and
        # the last rollout's must not shape this one (same parameters, same trajectory)
        self.world.setCollisionDetector(dartpy.simulation.CollisionDetectorType.BULLET)
        self.world.setTimeStep(p["timestep"])
        for i, (joint, link) in enumerate(zip(self._arm, self._links), start=1):
            mass = p[f"mass_link_{i}"]
            inertia = link.getInertia()
            link.setInertia(
                dartpy.dynamics.Inertia(
                    mass, inertia.getLocalCOM(), self._link_moment[i - 1] * (mass / self._link_mass[i - 1])
                )
            )
            limit = p[f"max_torque_joint_{i}"]
            joint.setForceLowerLimit(0, -limit)
            joint.setForceUpperLimit(0, limit)
            joint.setDampingCoefficient(0, p[f"joint_damping_{i}"])
        for group, nodes in self._shapes.items():
            for node in nodes:
                aspect = node.getDynamicsAspect()
                aspect.setFrictionCoeff(p[f"lateral_friction_{group}"])
                aspect.setRestitutionCoeff(p[f"restitution_{group}"])
        self.apply_drive(params)
        self.robot.setPositions(self._in_skeleton_order(self.start_angles(params)))
        self.robot.setVelocities(np.zeros(self.robot.getNumDofs()))
        self.robot.resetCommands()
        self.robot.resetGeneralizedForces()
        self.robot.clearExternalForces()
        self.robot.clearConstraintImpulses()
        obj = self.task.object
        if obj is not None:
            assert self.object is not None, "made for a task with an object"
            self._set_object_mass(p[obj.mass_parameter])
            for k in range(3):
                self._free.setDampingCoefficient(k, p[f"angular_damping_{obj.material}"])
                self._free.setDampingCoefficient(k + 3, p[f"linear_damping_{obj.material}"])
            self._free.setTransform(_isometry(obj.start_position, obj.rotation))
            self._free.setVelocities(np.zeros(6))
            skel = self.object.getSkeleton()
            skel.resetGeneralizedForces()
            skel.clearExternalForces()
            skel.clearConstraintImpulses()
        self.world.reset()  # time 0, recording cleared

    def set_joint_friction(self, values: np.ndarray) -> None:
        """``friction_joint_<n>`` [N m] -> each driven joint's ``setCoulombFriction`` (DART's joint friction, a
        bounded impulse in its constraint solver)."""
        for joint, friction in zip(self._arm, values.tolist()):
            joint.setCoulombFriction(0, friction)

    def _in_skeleton_order(self, values: np.ndarray) -> np.ndarray:
        ordered = np.zeros(self.robot.getNumDofs())
        ordered[self._dofs] = values
        return ordered

    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        self.robot.setCommands(self._in_skeleton_order(np.asarray(velocities, dtype=float)))

    def step(self, n: int) -> None:
        world = self.world
        for _ in range(n):
            world.step(False)  # False: keep the servo commands for the next step

    def arm_object_contact(self) -> bool:
        return self.object is not None and self._arm_touches(self.object.getSkeleton().getName())

    def arm_floor_contact(self) -> bool:
        return self._arm_touches("floor")  # the floor's skeleton, made in __init__

    def _arm_touches(self, skeleton: str) -> bool:
        # the detector's contacts of the last step, each between two shapes: arm skeleton vs the other's
        pair = {self.robot.getName(), skeleton}
        for contact in self.world.getLastCollisionResult().getContacts():
            owners = {
                shape.getShapeFrame().asShapeNode().getBodyNode().getSkeleton().getName()
                for shape in (contact.collisionObject1, contact.collisionObject2)
            }
            if owners == pair:
                return True
        return False

    def joint_angles(self) -> np.ndarray:
        return np.array(self.robot.getPositions())[self._dofs]

    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        t = self._wrist.getWorldTransform()
        return np.array(t.translation()), np.array(t.rotation())

    def object_position(self) -> np.ndarray | None:
        if self.object is None:
            return None
        return np.array(self.object.getWorldTransform().translation())


#: The radius [m] of the spheres at a hull's vertices (:func:`collide_with_hulls`): a hundredth of a millimetre
HULL_SPHERE_M = 1e-5


def collide_with_hulls(skeleton) -> None:
    """Each mesh of ``skeleton`` (read as its convex hull: ``robot_urdf_file(hulls=True)``) collides as a
    ``MultiSphereConvexHullShape`` of the hull's vertices (spheres of :data:`HULL_SPHERE_M`): the same convex
    shape, which Bullet collides by its support points.  DART 6 hands Bullet every ``MeshShape`` as a triangle
    mesh (``btGImpactMeshShape``), collided triangle by triangle even when it is a hull: measured on the SO-101
    as published (11 hulls of 150-4,900 vertices), a 7-s task took 5.2 s against 0.7 s so, its trajectory within
    0.01 mm.  The mesh's shape node keeps its visual aspect and loses its collision and dynamics ones."""
    for body in skeleton.getBodyNodes():
        for node in list(body.getShapeNodes()):
            shape = node.getShape()
            if not node.hasCollisionAspect() or not isinstance(shape, dartpy.dynamics.MeshShape):
                continue
            points = obj_vertices(shape.getMeshPath()) * np.asarray(shape.getScale(), dtype=float)
            spheres = [(HULL_SPHERE_M, point) for point in points]
            hull = body.createShapeNode(dartpy.dynamics.MultiSphereConvexHullShape(spheres))
            hull.setRelativeTransform(node.getRelativeTransform())
            hull.createCollisionAspect()
            hull.createDynamicsAspect()
            node.removeCollisionAspect()
            node.removeDynamicsAspect()
