"""DART export: URDF files with the tuned values, ``dart.json`` for the rest, ``load_dart.py``.

Read from the DART engine after the tuned parameters were applied:

- ``robot.urdf``: each link's mass, centre of mass and inertia, joint damping,
  and a limited joint's servo force limit as ``<limit effort>`` (DART's URDF
  loader reads all three).  ``<limit velocity>`` keeps the value the run's
  joints had (10 rad/s, far above any command): DART enforces it, so the
  controller's velocity clamp (controller.yaml) cannot go there.  Continuous
  joints have no ``<limit>`` (URDF's would need a finite velocity); all force
  limits are also in ``dart.json``.
- ``object_<task>.urdf``: the task's object (mass, inertia, box or cylinder);
  URDF has no cone, so a cone's size is in ``dart.json`` and the loader gives
  the body DART's ``ConeShape``.
- ``dart.json``: what URDF cannot hold: time step, gravity, the collision
  detector (Bullet), the robot's base position, the driven joints' actuator
  type (SERVO) and force limits, limit enforcement, the floor (a plane), each
  object's start pose and the damping of its free joint, and the friction and
  restitution of every shape by material group.

Each robot mesh is the OBJ of its convex hull in simtune's mesh cache, and ``load_dart.py`` makes it collide
as the engine did: a ``MultiSphereConvexHullShape`` of the hull's vertices (``mesh_collision`` in ``dart.json``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from simtune.engines import urdf_edit as urdf
from simtune.engines.dart.engine import HULL_SPHERE_M
from simtune.engines.export_base import ExportContext, hash_comment, num
from simtune.robot import generate
from simtune.tasks.spec import ObjectSpec

SIDECAR = "dart.json"
SCRIPT = "load_dart.py"


def _inertial(body) -> urdf.Inertial:
    inertia = body.getInertia()
    return urdf.Inertial(
        mass=float(inertia.getMass()),
        xyz=np.asarray(inertia.getLocalCOM(), dtype=float),
        rpy=np.zeros(3),
        inertia=np.asarray(inertia.getMoment(), dtype=float),
    )


def _surface(shape_node) -> dict:
    aspect = shape_node.getDynamicsAspect()
    return {"friction": float(aspect.getFrictionCoeff()), "restitution": float(aspect.getRestitutionCoeff())}


def _colliding(body) -> list:
    """The shape nodes of ``body`` that collide (a mesh's own node keeps its visual aspect only)."""
    return [node for node in body.getShapeNodes() if node.hasCollisionAspect()]


def write(ctx: ExportContext) -> list[str]:
    robot = ctx.robot
    first = ctx.engines[ctx.tasks[0].name]
    skeleton = first.robot  # type: ignore[attr-defined]
    forces = _write_robot(ctx, skeleton)
    gripper = [link for link, m in robot.link_materials.items() if m == "gripper"]
    floor_shape = first.world.getSkeleton("floor").getBodyNode(0).getShapeNodes()[0]  # type: ignore[attr-defined]
    objects = {task.name: _write_object(ctx, task.name, task.object) for task in ctx.tasks if task.object is not None}
    world = first.world  # type: ignore[attr-defined]
    ctx.write_json(
        SIDECAR,
        _ABOUT,
        {
            "time_step": float(world.getTimeStep()),
            "gravity": [float(v) for v in world.getGravity()],
            "collision_detector": "bullet",
            "robot": {
                "file": "robot.urdf",
                "base_position_m": list(robot.base_position),
                "driven_joints": list(robot.driven_joints),
                "actuator": "SERVO",
                "force_limits_n_m": forces,
                # friction_joint_<n>: each driven joint's Coulomb friction (also the URDF's <dynamics friction>)
                "coulomb_friction_n_m": [
                    float(skeleton.getJoint(j).getCoulombFriction(0)) for j in robot.driven_joints
                ],
                "limit_enforcement": True,
                "gripper_links": gripper,
                "gripper_surface": _surface(_colliding(skeleton.getBodyNode(gripper[0]))[0]),
                "mesh_collision": {"shape": "MultiSphereConvexHullShape", "sphere_radius_m": HULL_SPHERE_M},
            },
            "floor": {"normal": [0.0, 0.0, 1.0], "offset_m": 0.0, "surface": _surface(floor_shape)},
            "objects": objects,
        },
    )
    ctx.write(SCRIPT, hash_comment(ctx.header("load_dart.py: load this export in DART (dartpy)")) + _SCRIPT)
    return ctx.files


def _write_robot(ctx: ExportContext, skeleton) -> list[list[float]]:
    """robot.urdf from the engine's skeleton: inertias, damping, force limits; the driven joints' force limits."""
    robot = ctx.robot
    root = urdf.parse(generate.robot_urdf(robot.description, hulls=True))  # the meshes as the engine read them
    for name, link in urdf.links(root).items():
        urdf.set_inertial(link, _inertial(skeleton.getBodyNode(name)))
    forces = []
    for name, element in urdf.joints(root).items():
        if element.get("type") == "fixed":
            continue
        joint = skeleton.getJoint(name)
        urdf.set_damping(element, float(joint.getDampingCoefficient(0)))
        urdf.set_friction(element, float(joint.getCoulombFriction(0)))
        if element.find("limit") is not None:  # DART enforces URDF velocity limits: keep the run's, not the clamp's
            urdf.set_limit(element, float(joint.getForceUpperLimit(0)), float(joint.getVelocityUpperLimit(0)))
    for name in robot.driven_joints:
        joint = skeleton.getJoint(name)
        forces.append([float(joint.getForceLowerLimit(0)), float(joint.getForceUpperLimit(0))])
    what = "URDF of the tuned robot for DART: load it as load_dart.py does (dart.json has the rest)"
    ctx.write("robot.urdf", urdf.document(root, ctx.header(what)))

    return forces


def _write_object(ctx: ExportContext, task: str, obj: ObjectSpec) -> dict:
    """object_<task>.urdf: the task's object as the engine holds it; its dart.json entry."""
    robot = ctx.robot
    body = ctx.engines[task].object  # type: ignore[attr-defined]
    free = body.getParentJoint()
    name = f"object_{task}.urdf"
    document = urdf.single_link(robot.object, _inertial(body), _geometry(obj))
    what = f"URDF of task {task!r}'s {obj.material} {obj.shape} for DART (pose, surface: dart.json)"
    ctx.write(name, urdf.document(document, ctx.header(what)))
    return {
        "file": name,
        "cone": None if obj.shape != "cone" else {"radius_m": float(obj.size[0]), "height_m": float(obj.size[1])},
        "start_position_m": [float(v) for v in obj.start_position],
        "start_rotation": np.asarray(obj.rotation, dtype=float).tolist(),
        "angular_damping": [float(free.getDampingCoefficient(k)) for k in range(3)],
        "linear_damping": [float(free.getDampingCoefficient(k)) for k in range(3, 6)],
        "surface": _surface(body.getShapeNodes()[0]),
    }


_ABOUT = {
    "what": "DART values of a tuned simtune run that URDF cannot hold; load_dart.py applies them",
    "time_step": "World.setTimeStep [s]",
    "gravity": "World.setGravity [m/s^2]",
    "collision_detector": "World.setCollisionDetector (Bullet: DART's default FCL meshes the primitives)",
    "robot": "robot.urdf with a FIXED root joint placed at base_position_m; driven joints get actuator type "
    "SERVO (the controller's velocity command is the servo's target) with force_limits_n_m [lower, upper] and "
    "joint limit enforcement; gripper_links' shapes get the gripper surface; self-collision stays off; each mesh "
    "(the OBJ of its convex hull) collides as mesh_collision's shape of its vertices, spheres of sphere_radius_m "
    "(DART hands Bullet a MeshShape as a triangle mesh, collided triangle by triangle)",
    "floor": "a static skeleton with a PlaneShape (normal, offset) and its surface",
    "objects": "per task: URDF (FLOATING root: a FreeJoint), start pose, the FreeJoint's damping "
    "coefficients (coordinates 0-2 rotation, 3-5 translation), surface; cone: DART's ConeShape of that size "
    "(URDF has no cone)",
    "surface": "DynamicsAspect friction and restitution coefficients (DART combines two shapes' friction "
    "with the minimum, restitution with the product)",
}


def _geometry(obj: ObjectSpec) -> ET.Element | None:
    if obj.shape in ("cube", "cuboid"):
        return ET.Element("box", size=" ".join(num(s) for s in obj.size))
    if obj.shape == "cylinder":
        return ET.Element("cylinder", radius=num(obj.size[0]), length=num(obj.size[1]))
    return None  # a cone: dart.json


_SCRIPT = '''"""Load the tuned DART scene of one task: the URDF files plus dart.json (what URDF cannot hold)."""

import json
import pathlib
import sys

import dartpy as d
import numpy as np

HERE = pathlib.Path(__file__).resolve().parent


def _pose(position, rotation=None):
    t = d.math.Isometry3()
    t.set_identity()
    t.set_translation(np.asarray(position, dtype=float))
    if rotation is not None:
        t.set_rotation(np.asarray(rotation, dtype=float))
    return t


def _surface(node, surface):
    aspect = node.getDynamicsAspect() or node.createDynamicsAspect()
    aspect.setFrictionCoeff(surface["friction"])
    aspect.setRestitutionCoeff(surface["restitution"])


def _collide_with_hulls(skeleton, radius):
    """Each mesh (a convex hull's OBJ) collides as a MultiSphereConvexHullShape of its vertices, as simtune's engine."""
    for body in skeleton.getBodyNodes():
        for node in list(body.getShapeNodes()):
            shape = node.getShape()
            if not node.hasCollisionAspect() or not isinstance(shape, d.dynamics.MeshShape):
                continue
            with open(shape.getMeshPath(), encoding="utf-8") as f:
                points = np.array([line.split()[1:4] for line in f if line.startswith("v ")], dtype=float)
            points = points.reshape(-1, 3) * np.asarray(shape.getScale(), dtype=float)
            hull = body.createShapeNode(d.dynamics.MultiSphereConvexHullShape([(radius, p) for p in points]))
            hull.setRelativeTransform(node.getRelativeTransform())
            hull.createCollisionAspect()
            hull.createDynamicsAspect()
            node.removeCollisionAspect()
            node.removeDynamicsAspect()


def _skeleton(file, root):
    loader = d.utils.DartLoader()
    options = d.utils.DartLoader.Options()
    options.mDefaultRootJointType = root
    loader.setOptions(options)
    return loader.parseSkeleton(str(HERE / file))


def load(task):
    """A dartpy World with the robot, the floor and ``task``'s object; returns (world, robot, object or None)."""
    side = json.loads((HERE / "dart.json").read_text())
    world = d.simulation.World()
    world.setGravity(np.asarray(side["gravity"], dtype=float))
    world.setTimeStep(side["time_step"])
    world.setCollisionDetector(d.simulation.CollisionDetectorType.BULLET)
    spec = side["robot"]
    robot = _skeleton(spec["file"], d.utils.DartLoaderRootJointType.FIXED)
    robot.getRootJoint().setTransformFromParentBodyNode(_pose(spec["base_position_m"]))
    _collide_with_hulls(robot, spec["mesh_collision"]["sphere_radius_m"])
    for name, (lower, upper) in zip(spec["driven_joints"], spec["force_limits_n_m"]):
        joint = robot.getJoint(name)
        joint.setActuatorType(d.dynamics.ActuatorType.SERVO)
        joint.setLimitEnforcement(spec["limit_enforcement"])
        joint.setForceLowerLimit(0, lower)
        joint.setForceUpperLimit(0, upper)
    for name, friction in zip(spec["driven_joints"], spec.get("coulomb_friction_n_m", [])):
        robot.getJoint(name).setCoulombFriction(0, friction)
    for link in spec["gripper_links"]:
        for node in robot.getBodyNode(link).getShapeNodes():
            if node.hasCollisionAspect():
                _surface(node, spec["gripper_surface"])
    world.addSkeleton(robot)
    floor = d.dynamics.Skeleton("floor")
    _, body = floor.createWeldJointAndBodyNodePair(None)
    plane = side["floor"]
    node = body.createShapeNode(d.dynamics.PlaneShape(np.asarray(plane["normal"], dtype=float), plane["offset_m"]))
    node.createCollisionAspect()
    _surface(node, plane["surface"])
    floor.setMobile(False)
    world.addSkeleton(floor)
    obj = side["objects"].get(task)
    if obj is None:
        return world, robot, None
    skeleton = _skeleton(obj["file"], d.utils.DartLoaderRootJointType.FLOATING)
    body = skeleton.getBodyNode(0)
    if obj["cone"] is not None:
        node = body.createShapeNode(d.dynamics.ConeShape(obj["cone"]["radius_m"], obj["cone"]["height_m"]))
        node.createCollisionAspect()
    for node in body.getShapeNodes():
        _surface(node, obj["surface"])
    free = body.getParentJoint()
    for k, value in enumerate(obj["angular_damping"] + obj["linear_damping"]):
        free.setDampingCoefficient(k, value)
    free.setTransform(_pose(obj["start_position_m"], obj["start_rotation"]))
    world.addSkeleton(skeleton)
    return world, robot, body


if __name__ == "__main__":  # load, let it stand one second, print where the wrist is
    import yaml

    control = yaml.safe_load((HERE / "controller.yaml").read_text())
    task = sys.argv[1] if len(sys.argv) > 1 else next(iter(control["tasks"]))
    world, robot, _ = load(task)
    for _ in range(round(1.0 / world.getTimeStep())):
        world.step()
    print(task, "wrist at", robot.getBodyNode(control["tracking"]["link"]).getWorldTransform().translation())
'''
