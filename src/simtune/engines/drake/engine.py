"""Drake's MultibodyPlant (``pydrake``) behind the engine interface.

The arm is the generated URDF, parsed by Drake, with link_base welded at the
base position.  The plant is discrete (time-stepping): its step is fixed when
it is built, so simtune builds one plant/diagram per time step and keeps the
last few (a tuning run asks for a new step on nearly every evaluation, so the
cache is small).  Every other parameter lives in the plant's context and is
set on reset.

Velocity control: each arm joint has a JointActuator with Drake's
PD-controlled actuator model (only the D term: ``kd * (v_cmd - v)``), solved
implicitly in the contact solver and clamped to the actuator's effort limit
(the maximum torque), plus gravity compensation as feed-forward torque updated
at each control command (the arm's own controller compensates gravity; this
is MuJoCo's gravcomp + velocity servo, kd = MuJoCo's kv where above 100, else 100).

Contact: Drake's hydroelastic model with point-contact fallback.  The object
is a compliant hydroelastic box / cylinder / convex cone and the floor a rigid
half space (Drake's point contact gives a box on a half space a single
contact point, and the box rocks); the arm's URDF boxes touch through point
contact.  Friction: ``CoulombFriction`` on each collision geometry, static =
dynamic = the lateral friction (Drake combines two geometries as
2 mu1 mu2 / (mu1 + mu2)).  Drake's contact has no coefficient of restitution
(dissipation is Hunt-Crossley), no rolling or spinning friction, no
per-body velocity damping and no Coulomb joint friction: those parameters are left out.  The armature is
each servo's rotor inertia (gear ratio 1).
"""

from __future__ import annotations

import logging
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.engines._shapes import object_mass_properties
from simtune.engines.base import Engine, library_version, unreachable_servo_limits
from simtune.params.kinds import engine_parameters as kinds_of_engine
from simtune.robot import MICO
from simtune.robot.generate import robot_urdf_file, servo_gains
from simtune.tasks.spec import ObjectSpec, TaskSpec

if TYPE_CHECKING:  # for the annotations of _System (mypy reads pydrake as untyped: see pyproject.toml)
    from pydrake.geometry import GeometryId, SceneGraph
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import JointActuator, ModelInstanceIndex, RevoluteJoint, RigidBody
    from pydrake.systems.framework import Context

try:
    import pydrake
    from pydrake.geometry import (
        AddCompliantHydroelasticProperties,
        AddContactMaterial,
        AddRigidHydroelasticProperties,
        Box,
        CollisionFilterDeclaration,
        Convex,
        Cylinder,
        GeometrySet,
        HalfSpace,
        ProximityProperties,
        RoleAssign,
        SceneGraphConfig,
    )
    from pydrake.math import RigidTransform, RotationMatrix
    from pydrake.multibody.math import SpatialVelocity
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig
    from pydrake.multibody.tree import PdControllerGains, RotationalInertia, SpatialInertia
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
except ImportError:  # pragma: no cover - depends on the machine
    pydrake = None
else:
    # Drake logs a warning that its rigid half space takes no part in deformable
    # contact (there is none here); keep the log to errors
    logging.getLogger("drake").setLevel(logging.ERROR)

#: [N m s/rad] the velocity servo's least gain (the MICO's): MuJoCo's gain (``servo_gains``) where that is higher,
#: raised for a heavy, damped or rubbing joint (a UR10's shoulder, 1138: at 100 Drake lagged MuJoCo by 14 mm)
SERVO_KD = 100.0
#: hydroelastic mesh resolution for the objects [m]: at 1 cm the faceted 37.5 mm cylinder rolls off a
#: facet edge on its own and keeps rolling; at 5 mm it settles within 3 mm
RESOLUTION_HINT = 0.005
CACHED_PLANTS = 3


@dataclass
class _System:
    """One built diagram (plant + scene graph) for one time step."""

    timestep: float
    plant: MultibodyPlant
    scene_graph: SceneGraph
    simulator: Simulator
    context: Context
    plant_context: Context
    sg_context: Context
    arm: ModelInstanceIndex
    joints: list[RevoluteJoint]
    actuators: list[JointActuator]
    links: list[RigidBody]
    wrist: RigidBody
    object_body: RigidBody | None
    geometries: dict[str, list[GeometryId]]  # contact group -> its collision geometries
    arm_bodies: frozenset[int]  # body indices of the arm's links and fingers
    arm_geometries: frozenset[GeometryId]
    object_geometry: GeometryId | None


#: the engine's name in the registry and the kinds table
NAME = "drake"


class DrakeEngine(Engine):
    name = NAME
    engine_parameters = kinds_of_engine(NAME, 6)  # its kinds in simtune.params.kinds

    @classmethod
    def version(cls) -> str:
        return library_version(pydrake, "drake")

    @classmethod
    def inactive_parameters(cls, task: TaskSpec) -> dict[str, str]:
        return super().inactive_parameters(task) | unreachable_servo_limits(task, SERVO_KD, measured_on=MICO)

    def __init__(self, task: TaskSpec):
        super().__init__(task)
        self._systems: OrderedDict[float, _System] = OrderedDict()
        self._urdf = robot_urdf_file(task.robot)  # a file: Drake resolves absolute mesh paths only in one
        self._sys = self._system(MultibodyPlantConfig().time_step)  # Drake's own default step
        self._failed = ""
        self._defaults = self._read_defaults()
        self._sys.simulator.Initialize()

    # --- building -------------------------------------------------------------------
    def _system(self, timestep: float) -> _System:
        if timestep in self._systems:
            self._systems.move_to_end(timestep)
            return self._systems[timestep]
        system = self._build(timestep)
        self._systems[timestep] = system
        while len(self._systems) > CACHED_PLANTS:
            self._systems.popitem(last=False)
        return system

    def _build(self, timestep: float) -> _System:
        builder = DiagramBuilder()
        sg_config = SceneGraphConfig()
        plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=timestep), sg_config, builder)
        robot = self.task.robot
        (arm,) = Parser(plant).AddModels(self._urdf)
        base = np.asarray(robot.base_position, dtype=float)
        plant.WeldFrames(
            plant.world_frame(),
            plant.GetFrameByName(robot.root, arm),
            RigidTransform(base)
            if robot.base_rpy == (0.0, 0.0, 0.0)
            else RigidTransform(RotationMatrix(rpy_matrix(robot.base_rpy)), base),
        )
        joints = [plant.GetJointByName(j, arm) for j in robot.arm_joints]
        actuators = [self._add_servo(plant, joint, i) for i, joint in enumerate(joints)]
        inspector = scene_graph.model_inspector()
        arm_geometries = [
            g for link in robot.links for g in plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link.name, arm))
        ]
        # the parser's friction for geometries that name none: Drake's default material (a robot with no collision
        # geometry at all - a kinematic description - has none to read it from: the same default, made here)
        default_friction = (
            inspector.GetProximityProperties(arm_geometries[0]).GetProperty("material", "coulomb_friction")
            if arm_geometries
            else CoulombFriction(1.0, 1.0)  # what the parser gives a URDF geometry that names no friction
        )

        floor_props = ProximityProperties()
        AddContactMaterial(friction=default_friction, properties=floor_props)
        AddRigidHydroelasticProperties(floor_props)
        floor = plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform(), HalfSpace(), "floor", floor_props)

        geometries = {
            "floor": [floor],
            "gripper": [
                g
                for link in robot.links
                if link.material == "gripper"
                for g in plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link.name, arm))
            ],
        }
        body, object_geometry = None, None
        obj = self.task.object
        if obj is not None:
            modulus = sg_config.default_proximity_properties.hydroelastic_modulus
            body, object_geometry = self._add_object(plant, obj, default_friction, modulus)
            geometries[obj.material] = [object_geometry]
        plant.Finalize()
        # arm shapes touch the floor and the object, never each other
        scene_graph.collision_filter_manager().Apply(
            CollisionFilterDeclaration().ExcludeWithin(GeometrySet(arm_geometries))
        )

        diagram = builder.Build()
        simulator = Simulator(diagram)
        context = simulator.get_mutable_context()
        plant_context = plant.GetMyMutableContextFromRoot(context)
        system = _System(
            timestep=timestep,
            plant=plant,
            scene_graph=scene_graph,
            simulator=simulator,
            context=context,
            plant_context=plant_context,
            sg_context=scene_graph.GetMyMutableContextFromRoot(context),
            arm=arm,
            joints=joints,
            actuators=actuators,
            links=[plant.GetBodyByName(link, arm) for link in robot.driven_links],
            wrist=plant.GetBodyByName(robot.tracked_link, arm),
            object_body=body,
            geometries=geometries,
            arm_bodies=frozenset(int(plant.GetBodyByName(link.name, arm).index()) for link in robot.links),
            arm_geometries=frozenset(arm_geometries),
            object_geometry=object_geometry,
        )
        plant.get_desired_state_input_port(arm).FixValue(plant_context, np.zeros(2 * len(joints)))
        plant.get_actuation_input_port(arm).FixValue(plant_context, np.zeros(len(joints)))
        self._pose(system, np.radians(self.task.start_pose_deg))
        return system

    def _add_servo(self, plant: MultibodyPlant, joint: RevoluteJoint, index: int) -> JointActuator:
        """The velocity servo of driven joint ``index`` (0 = the first): a PD actuator with only the D term, its
        gain MuJoCo's where that is above :data:`SERVO_KD` (a gain MuJoCo lowers to keep a clipped force from
        spinning a light link is not needed here: Drake solves the clamped servo implicitly)."""
        robot = self.task.robot
        actuator = plant.AddJointActuator(f"{joint.name()}_servo", joint, robot.generic_effort(index))
        gain = robot.servo_gain or max(SERVO_KD, servo_gains(robot)[index])
        actuator.set_controller_gains(PdControllerGains(p=0.0, d=gain))
        return actuator

    def _add_object(
        self, plant: MultibodyPlant, obj: ObjectSpec, friction: CoulombFriction, modulus: float
    ) -> tuple[RigidBody, GeometryId]:
        """The task's object: a rigid body with a compliant hydroelastic shape of ``friction``; it and its geometry."""
        instance = plant.AddModelInstance("object")
        body = plant.AddRigidBody("object", instance, self._object_inertia(obj, obj.mass))
        if obj.shape in ("cube", "cuboid"):
            shape = Box(*obj.size)
        elif obj.shape == "cylinder":
            shape = Cylinder(obj.size[0], obj.size[1])
        else:
            shape = Convex(np.asarray(obj.cone_vertices()).T, "cone")  # the same hull as MuJoCo and PyBullet
        props = ProximityProperties()
        AddContactMaterial(friction=friction, properties=props)
        AddCompliantHydroelasticProperties(RESOLUTION_HINT, modulus, props)
        return body, plant.RegisterCollisionGeometry(body, RigidTransform(), shape, "object", props)

    def _object_inertia(self, obj: ObjectSpec, mass: float) -> SpatialInertia:
        com, inertia = object_mass_properties(obj, mass)
        central = RotationalInertia(
            inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]
        )
        return SpatialInertia.MakeFromCentralInertia(mass, com, central)

    def _read_defaults(self) -> dict[str, float]:
        s = self._sys
        values = {"timestep": float(s.plant.time_step())}
        for i, (joint, link) in enumerate(zip(s.joints, s.links), start=1):
            values[f"mass_link_{i}"] = float(link.default_mass())
            values[f"max_torque_joint_{i}"] = self.task.robot.generic_effort(i - 1)  # the limit it was built with
            values[f"joint_damping_{i}"] = float(joint.default_damping())
        obj = self.task.object
        if obj is not None:
            assert s.object_body is not None, "built for a task with an object"
            values[obj.mass_parameter] = float(s.object_body.default_mass())
        inspector = s.scene_graph.model_inspector()
        floor = s.geometries["floor"][0]  # made with the parser's default friction
        for group, ids in s.geometries.items():
            # a group without a geometry (a gripper whose geoms all collide with nothing): the parser's default,
            # which its parameter then changes on nothing
            friction = inspector.GetProximityProperties(ids[0] if ids else floor).GetProperty(
                "material", "coulomb_friction"
            )
            values[f"lateral_friction_{group}"] = float(friction.dynamic_friction())
        return values | self.drive_defaults()

    def set_armature(self, values: np.ndarray) -> None:
        """``armature_joint_<n>`` [kg m^2] -> each servo's rotor inertia at gear ratio 1 (Drake adds the reflected
        inertia, rotor inertia x gear ratio squared, to the joint's diagonal of the mass matrix)."""
        s = self._sys
        for actuator, armature in zip(s.actuators, values.tolist()):
            actuator.SetRotorInertia(s.plant_context, armature)

    def _pose(self, s: _System, q) -> None:
        for joint, angle in zip(s.joints, q):
            joint.set_angle(s.plant_context, float(angle))
            joint.set_angular_rate(s.plant_context, 0.0)

    # --- interface ------------------------------------------------------------------
    def defaults(self) -> dict[str, float]:
        return dict(self._defaults)

    @property
    def timestep(self) -> float:
        return self._sys.timestep

    def reset(self, params: dict[str, float]) -> None:
        p = {**self._defaults, **params}
        s = self._sys = self._system(float(p["timestep"]))
        s.simulator.get_system().SetDefaultContext(s.context)  # state and parameters as built
        ctx = s.plant_context
        for i, (joint, link, actuator) in enumerate(zip(s.joints, s.links, s.actuators), start=1):
            link.SetMass(ctx, p[f"mass_link_{i}"])  # scales the link's inertia with it
            joint.SetDamping(ctx, p[f"joint_damping_{i}"])
            actuator.set_effort_limit(p[f"max_torque_joint_{i}"])
        inspector = s.scene_graph.model_inspector()
        for group, ids in s.geometries.items():
            mu = p[f"lateral_friction_{group}"]
            for gid in ids:
                props = ProximityProperties(inspector.GetProximityProperties(gid))
                props.UpdateProperty("material", "coulomb_friction", CoulombFriction(mu, mu))
                s.scene_graph.AssignRole(s.sg_context, s.plant.get_source_id(), gid, props, RoleAssign.kReplace)
        obj = self.task.object
        if obj is not None:
            assert s.object_body is not None, "built for a task with an object"
            s.object_body.SetSpatialInertiaInBodyFrame(ctx, self._object_inertia(obj, p[obj.mass_parameter]))
            s.plant.SetFreeBodyPose(
                ctx, s.object_body, RigidTransform(RotationMatrix(obj.rotation), obj.start_position)
            )
            s.plant.SetFreeBodySpatialVelocity(ctx, s.object_body, SpatialVelocity(np.zeros(3), np.zeros(3)))
        self.apply_drive(params)
        self._pose(s, self.start_angles(params))
        s.context.SetTime(0.0)
        self._steps = 0
        self._failed = ""
        self.set_joint_velocities(np.zeros(len(s.joints)))
        s.simulator.Initialize()

    def set_joint_velocities(self, velocities: np.ndarray) -> None:
        s = self._sys
        ctx = s.plant_context
        desired = np.concatenate([np.zeros(len(velocities)), velocities])
        s.plant.get_desired_state_input_port(s.arm).FixValue(ctx, desired)
        gravity = s.plant.CalcGravityGeneralizedForces(ctx)  # generalized forces of gravity
        s.plant.get_actuation_input_port(s.arm).FixValue(
            ctx, np.array([-gravity[joint.velocity_start()] for joint in s.joints])
        )

    def step(self, n: int) -> None:
        if self._failed:
            return
        s = self._sys
        self._steps += n
        try:
            s.simulator.AdvanceTo(self._steps * s.timestep)
        except RuntimeError as exc:  # e.g. the contact solver failing to converge
            self._failed = str(exc).splitlines()[0]

    def arm_object_contact(self) -> bool:
        s = self._sys
        if s.object_body is None:
            return False
        results = s.plant.get_contact_results_output_port().Eval(s.plant_context)
        # the arm's boxes have no hydroelastic properties, so they touch the object through point
        # contact; hydroelastic surfaces are checked too, should that ever change
        if self._arm_point_contact(results, int(s.object_body.index())):
            return True
        geometry = s.object_geometry
        for i in range(results.num_hydroelastic_contacts()):
            surface = results.hydroelastic_contact_info(i).contact_surface()
            m, n = surface.id_M(), surface.id_N()
            if (m == geometry and n in s.arm_geometries) or (n == geometry and m in s.arm_geometries):
                return True
        return False

    def arm_floor_contact(self) -> bool:
        s = self._sys
        results = s.plant.get_contact_results_output_port().Eval(s.plant_context)
        # the floor's half space is the world body's geometry; the arm's boxes touch the rigid floor as points
        return self._arm_point_contact(results, int(s.plant.world_body().index()))

    def _arm_point_contact(self, results, body: int) -> bool:
        """Whether a point contact of ``results`` pairs an arm body with the body of index ``body``."""
        arm = self._sys.arm_bodies
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            a, b = int(info.bodyA_index()), int(info.bodyB_index())
            if (a == body and b in arm) or (b == body and a in arm):
                return True
        return False

    def diverged(self) -> str:
        return f"Drake: {self._failed}" if self._failed else ""

    def joint_angles(self) -> np.ndarray:
        s = self._sys
        return np.array([joint.get_angle(s.plant_context) for joint in s.joints])

    def wrist_pose(self) -> tuple[np.ndarray, np.ndarray]:
        s = self._sys
        pose = s.plant.EvalBodyPoseInWorld(s.plant_context, s.wrist)
        return np.array(pose.translation()), np.array(pose.rotation().matrix())

    def object_position(self) -> np.ndarray | None:
        s = self._sys
        if s.object_body is None:
            return None
        return np.array(s.plant.EvalBodyPoseInWorld(s.plant_context, s.object_body).translation())

    def close(self) -> None:
        self._systems.clear()
