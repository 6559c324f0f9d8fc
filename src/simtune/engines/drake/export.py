"""Drake export: a URDF and SDFormat files with Drake's own tags, ``drake.json`` for the rest, ``load_drake.py``.

Read from the Drake engine's plant after the tuned parameters were applied:

- ``robot.urdf``: links' masses, centres of mass and inertias, joint damping,
  the base welded to Drake's ``world`` link, one ``<transmission>`` per driven
  joint whose actuator carries ``<drake:controller_gains>`` (the velocity
  servo: p = 0, d = the servo gain) and whose ``<limit effort>`` is the tuned
  maximum torque, ``<drake:proximity_properties>`` friction on every
  collision box (the gripper's tuned, the rest Drake's default), and a
  ``<drake:collision_filter_group>`` that keeps the arm's shapes from touching
  each other.  ``<limit velocity>`` is the controller's clamp [rad/s]
  (Drake's discrete solver does not enforce velocity limits).
- ``floor.sdf``: the floor, a static half space (SDFormat ``<plane>``), rigid
  hydroelastic, with its friction.
- ``object_<task>.sdf``: the task's object (mass, inertia, shape, start pose
  as the model's pose), compliant hydroelastic with the run's modulus and mesh
  resolution, and its friction; a cone is a convex mesh (``object_<task>.obj``).
- ``drake.json``: what neither file can hold: the plant's time step (fixed
  when the plant is built), the contact model, and the gravity compensation
  the run fed forward to the actuators at each control update.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import cast

import numpy as np

from simtune.engines import urdf_edit as urdf
from simtune.engines.drake.engine import RESOLUTION_HINT
from simtune.engines.export_base import ExportContext, hash_comment, num, nums, write_cone_mesh, xml_comment
from simtune.tasks.spec import ObjectSpec, TaskSpec

SIDECAR = "drake.json"
SCRIPT = "load_drake.py"
DRAKE_NS = "http://drake.mit.edu"


def _mass_properties(body, context) -> urdf.Inertial:
    spatial = body.CalcSpatialInertiaInBodyFrame(context)
    com = np.asarray(spatial.get_com(), dtype=float)
    central = spatial.Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
    return urdf.Inertial(float(spatial.get_mass()), com, np.zeros(3), np.asarray(central))


def _friction(parent: ET.Element, mu: float, tag: str = "drake:proximity_properties") -> ET.Element:
    props = ET.SubElement(parent, tag)
    ET.SubElement(props, "drake:mu_dynamic", value=num(mu))
    ET.SubElement(props, "drake:mu_static", value=num(mu))
    return props


def write(ctx: ExportContext) -> list[str]:
    from pydrake.geometry import SceneGraphConfig

    first = ctx.engines[ctx.tasks[0].name]
    s = first._sys  # type: ignore[attr-defined]
    generic_mu = first.defaults()["lateral_friction_gripper"]  # the parser's friction: what the other boxes keep
    root, actuators = _write_robot(ctx, s, generic_mu)
    _write_floor(ctx)
    modulus = cast(float, SceneGraphConfig().default_proximity_properties.hydroelastic_modulus)  # Drake's default
    objects = {
        task.name: _write_object(ctx, task, task.object, modulus) for task in ctx.tasks if task.object is not None
    }
    _write_sidecar(ctx, s.timestep, ["robot.urdf", "floor.sdf"], root.get("name"), actuators, objects)
    ctx.write(SCRIPT, hash_comment(ctx.header("load_drake.py: load this export in Drake (pydrake)")) + _SCRIPT)
    return ctx.files


def _write_robot(ctx: ExportContext, s, generic_mu: float) -> tuple[ET.Element, list[dict]]:
    """robot.urdf from the engine's plant ``s`` (its _System): inertias, damping, servos, friction, the weld;
    the document's root and the actuators' sidecar entries."""
    robot = ctx.robot
    plant, pctx = s.plant, s.plant_context
    root = urdf.parse(robot.urdf)
    root.set("xmlns:drake", DRAKE_NS)
    for name, link in urdf.links(root).items():
        urdf.set_inertial(link, _mass_properties(plant.GetBodyByName(name, s.arm), pctx))
        mu = ctx.values["lateral_friction_gripper"] if robot.link_materials.get(name) == "gripper" else generic_mu
        for collision in link.findall("collision"):
            _friction(collision, mu)
    actuators = []
    for i, name in enumerate(robot.driven_joints, start=1):
        element = urdf.joints(root)[name]
        joint, actuator = s.joints[i - 1], s.actuators[i - 1]
        urdf.set_damping(element, float(joint.GetDamping(pctx)))
        v_max = ctx.params.get(f"max_velocity_joint_{i}", ctx.tasks[0].max_velocity_deg)
        urdf.set_limit(element, float(actuator.effort_limit()), float(np.radians(v_max)))
        gains = actuator.get_controller_gains()
        transmission = ET.SubElement(root, "transmission", name=f"{name}_transmission")
        ET.SubElement(transmission, "type").text = "transmission_interface/SimpleTransmission"
        ET.SubElement(
            ET.SubElement(transmission, "joint", name=name), "hardwareInterface"
        ).text = "EffortJointInterface"
        holder = ET.SubElement(transmission, "actuator", name=actuator.name())
        ET.SubElement(holder, "drake:controller_gains", p=num(gains.p), d=num(gains.d))
        # armature_joint_<n>: the servo's rotor inertia at gear ratio 1 (Drake's reflected inertia)
        ET.SubElement(holder, "drake:rotor_inertia", value=num(actuator.rotor_inertia(pctx)))
        ET.SubElement(holder, "drake:gear_ratio", value=num(actuator.gear_ratio(pctx)))
        actuators.append(
            {"name": actuator.name(), "joint": name, "effort_limit_n_m": float(actuator.effort_limit()),
             "p": float(gains.p), "d": float(gains.d)}
        )  # fmt: skip
    group = ET.SubElement(root, "drake:collision_filter_group", name="arm")
    for name in urdf.links(root):
        ET.SubElement(group, "drake:member", link=name)
    ET.SubElement(group, "drake:ignored_collision_filter_group", name="arm")
    world = ET.Element("link", name="world")
    weld = ET.Element("joint", name=f"{robot.base_link}_weld", type="fixed")
    ET.SubElement(weld, "parent", link="world")
    ET.SubElement(weld, "child", link=robot.base_link)
    ET.SubElement(weld, "origin", xyz=nums(robot.base_position), rpy="0 0 0")
    root.insert(0, weld)
    root.insert(0, world)
    what = "URDF of the tuned robot for Drake (pydrake Parser): load it as load_drake.py does"
    ctx.write("robot.urdf", urdf.document(root, ctx.header(what)))

    return root, actuators


def _write_floor(ctx: ExportContext) -> None:
    """floor.sdf: a static rigid hydroelastic half space with the floor's friction."""
    robot = ctx.robot
    floor = _sdf_model(robot.floor, static=True)
    link = ET.SubElement(floor, "link", name=robot.floor)
    collision = ET.SubElement(link, "collision", name=robot.floor)
    plane = ET.SubElement(ET.SubElement(collision, "geometry"), "plane")
    ET.SubElement(plane, "normal").text = "0 0 1"
    ET.SubElement(plane, "size").text = "100 100"
    props = ET.SubElement(collision, "drake:proximity_properties")
    ET.SubElement(props, "drake:rigid_hydroelastic")
    for tag in ("drake:mu_dynamic", "drake:mu_static"):
        ET.SubElement(props, tag).text = num(ctx.values["lateral_friction_floor"])
    ctx.write("floor.sdf", _sdf_document(floor, ctx.header("SDFormat floor for Drake: a rigid half space z <= 0")))


def _write_object(ctx: ExportContext, task: TaskSpec, obj: ObjectSpec, modulus: float) -> dict:
    """object_<task>.sdf: the task's object, compliant hydroelastic with the run's modulus; its sidecar entry."""
    robot = ctx.robot
    engine = ctx.engines[task.name]
    sys_ = engine._sys  # type: ignore[attr-defined]
    name = f"object_{task.name}.sdf"
    model = _sdf_model(robot.object, static=False)
    ET.SubElement(model, "pose").text = " ".join(num(v) for v in (*obj.start_position, *obj.rpy))
    link = ET.SubElement(model, "link", name=robot.object)
    inertial = _mass_properties(sys_.object_body, sys_.plant_context)
    inertial_element = ET.SubElement(link, "inertial")
    ET.SubElement(inertial_element, "pose").text = f"{nums(inertial.xyz)} 0 0 0"
    ET.SubElement(inertial_element, "mass").text = num(inertial.mass)
    tensor = ET.SubElement(inertial_element, "inertia")
    for tag, (r, c) in {
        "ixx": (0, 0),
        "ixy": (0, 1),
        "ixz": (0, 2),
        "iyy": (1, 1),
        "iyz": (1, 2),
        "izz": (2, 2),
    }.items():
        ET.SubElement(tensor, tag).text = num(inertial.inertia[r, c])
    collision = ET.SubElement(link, "collision", name=robot.object)
    ET.SubElement(collision, "geometry").append(_geometry(ctx, obj, task.name))
    props = ET.SubElement(collision, "drake:proximity_properties")
    ET.SubElement(props, "drake:compliant_hydroelastic")
    ET.SubElement(props, "drake:mesh_resolution_hint").text = num(RESOLUTION_HINT)
    ET.SubElement(props, "drake:hydroelastic_modulus").text = num(modulus)
    mu = ctx.values[f"lateral_friction_{obj.material}"]
    for tag in ("drake:mu_dynamic", "drake:mu_static"):
        ET.SubElement(props, tag).text = num(mu)
    what = f"SDFormat of task {task.name!r}'s {obj.material} {obj.shape} for Drake (its start pose: <pose>)"
    ctx.write(name, _sdf_document(model, ctx.header(what)))
    return {
        "file": name,
        "start_position_m": [float(v) for v in obj.start_position],
        "start_rotation": np.asarray(obj.rotation, dtype=float).tolist(),
    }


def _write_sidecar(
    ctx: ExportContext, time_step: float, files: list[str], model: str | None, actuators: list[dict], objects: dict
) -> None:
    from pydrake.multibody.plant import MultibodyPlantConfig

    config = MultibodyPlantConfig(time_step=time_step)
    about = {
        "what": "Drake values of a tuned simtune run that the model files cannot hold; load_drake.py applies them",
        "plant": "MultibodyPlantConfig: time_step [s] (fixed when the plant is built), contact model and discrete "
        "contact approximation (Drake's defaults)",
        "files": "parse in this order into one plant: the robot, the floor, then the task's object (objects)",
        "actuators": "the driven joints' PD-controlled actuators as robot.urdf declares them (only the D term: "
        "the velocity servo); feed the robot's desired state input port [q = 0, v = the commanded velocities]",
        "objects": "per task: the object's file and its start pose (position, rotation matrix): the SDFormat "
        "<pose> holds it in roll-pitch-yaw, which rounds; load_drake.py sets this one as the default pose",
        "feedforward": "at each control update the run fed the robot's actuation input port the gravity "
        "compensation of the driven joints, -CalcGravityGeneralizedForces at that joint's velocity index",
    }
    ctx.write_json(
        SIDECAR,
        about,
        {
            "plant": {
                "time_step": float(time_step),
                "contact_model": config.contact_model,
                "discrete_contact_approximation": config.discrete_contact_approximation,
            },
            "files": files,
            "robot_model": model,
            "actuators": actuators,
            "feedforward": "gravity_compensation",
            "objects": objects,
        },
    )


def _sdf_model(name: str, static: bool) -> ET.Element:
    model = ET.Element("model", name=name)
    if static:
        ET.SubElement(model, "static").text = "true"
    return model


def _sdf_document(model: ET.Element, header: list[str]) -> str:
    sdf = ET.Element("sdf", version="1.9")
    sdf.set("xmlns:drake", DRAKE_NS)
    sdf.append(model)
    ET.indent(sdf, space="  ")
    return '<?xml version="1.0"?>\n' + xml_comment(header) + ET.tostring(sdf, encoding="unicode") + "\n"


def _geometry(ctx: ExportContext, obj: ObjectSpec, task: str) -> ET.Element:
    if obj.shape in ("cube", "cuboid"):
        box = ET.Element("box")
        ET.SubElement(box, "size").text = " ".join(num(v) for v in obj.size)
        return box
    if obj.shape == "cylinder":
        cylinder = ET.Element("cylinder")
        ET.SubElement(cylinder, "radius").text = num(obj.size[0])
        ET.SubElement(cylinder, "length").text = num(obj.size[1])
        return cylinder
    name = write_cone_mesh(ctx, obj, task)
    mesh = ET.Element("mesh")
    ET.SubElement(mesh, "uri").text = name
    ET.SubElement(mesh, "drake:declare_convex")
    return mesh


_SCRIPT = '''"""Load the tuned Drake scene of one task: robot.urdf, floor.sdf, the object's SDFormat, drake.json."""

import json
import pathlib
import sys

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

HERE = pathlib.Path(__file__).resolve().parent


def load(task):
    """A Simulator of the robot, the floor and ``task``'s object; returns (simulator, plant, robot model instance)."""
    side = json.loads((HERE / "drake.json").read_text())
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(**side["plant"]), builder)
    parser = Parser(plant)
    files = side["files"] + ([side["objects"][task]["file"]] if task in side["objects"] else [])
    (robot,) = parser.AddModels(str(HERE / files[0]))
    for file in files[1:]:
        parser.AddModels(str(HERE / file))
    if task in side["objects"]:  # the start pose exactly (the SDFormat <pose> is in roll-pitch-yaw, rounded)
        start = side["objects"][task]
        pose = RigidTransform(RotationMatrix(np.array(start["start_rotation"])), start["start_position_m"])
        plant.SetDefaultFloatingBaseBodyPose(plant.GetBodyByName("object"), pose)
    plant.Finalize()
    simulator = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    n = plant.num_actuated_dofs(robot)
    plant.get_desired_state_input_port(robot).FixValue(context, np.zeros(2 * n))
    plant.get_actuation_input_port(robot).FixValue(context, np.zeros(n))
    return simulator, plant, robot


def command(plant, robot, context, velocities):
    """Send joint velocity commands (the servo's desired velocities) with the run's gravity compensation."""
    plant.get_desired_state_input_port(robot).FixValue(context, np.concatenate([np.zeros(len(velocities)), velocities]))
    gravity = plant.CalcGravityGeneralizedForces(context)
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(robot)]
    plant.get_actuation_input_port(robot).FixValue(
        context, np.array([-gravity[a.joint().velocity_start()] for a in actuators])
    )


if __name__ == "__main__":  # load, let it stand one second, print where the wrist is
    import yaml

    control = yaml.safe_load((HERE / "controller.yaml").read_text())
    task = sys.argv[1] if len(sys.argv) > 1 else next(iter(control["tasks"]))
    simulator, plant, robot = load(task)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    command(plant, robot, context, np.zeros(plant.num_actuated_dofs(robot)))
    simulator.AdvanceTo(1.0)
    wrist = plant.GetBodyByName(control["tracking"]["link"], robot)
    print(task, "wrist at", plant.EvalBodyPoseInWorld(context, wrist).translation())
'''
