"""PyBullet export: URDF files with the tuned values, ``pybullet.json`` for the rest, ``load_pybullet.py``.

Read from the PyBullet engine after the tuned parameters were applied:

- ``robot.urdf``: each link's mass and inertia as PyBullet simulated them.
  PyBullet takes a link's inertia from its collision shapes, not from the URDF
  (unless loaded with ``URDF_USE_INERTIA_FROM_FILE``), and ``changeDynamics(mass=)``
  recomputes it the same way; the file holds those inertias, to be loaded with
  that flag.  Joint damping (``<dynamics damping>``), and each driven joint's
  motor force limit as ``<limit effort>`` and controller velocity limit as
  ``<limit velocity>`` [rad/s] (PyBullet's velocity motor enforces neither: the
  motor force comes from ``setJointMotorControlArray``, the velocity clamp is
  the controller's, see controller.yaml).
- ``floor.urdf``: the static plane (PyBullet's ``<plane>`` geometry).
- ``object_<task>.urdf``: the task's object, its tuned mass and PyBullet's
  inertia for it; a cone's convex hull is ``object_<task>.obj`` beside it.
- ``pybullet.json``: what URDF cannot hold: time step, gravity, where each
  body goes, the velocity motors' force limits, and every ``changeDynamics``
  call of the tuned run (friction, rolling and spinning friction, restitution,
  linear and angular velocity damping) in the order the run made them.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from simtune.engines import urdf_edit as urdf
from simtune.engines.export_base import ExportContext, hash_comment, num, write_cone_mesh
from simtune.engines.pybullet.engine import LOADED_LINK_DAMPING, robot_link_damping
from simtune.engines.pybullet.mapping import dynamics_changes, material_groups
from simtune.tasks.spec import ObjectSpec

SIDECAR = "pybullet.json"
SCRIPT = "load_pybullet.py"


def write(ctx: ExportContext) -> list[str]:
    import pybullet as p

    first = ctx.engines[ctx.tasks[0].name]
    _write_robot(ctx, p, first.client, first.robot)  # type: ignore[attr-defined]
    floor = urdf.single_link(
        ctx.robot.floor,
        urdf.Inertial(0.0, np.zeros(3), np.zeros(3), np.zeros((3, 3))),
        ET.Element("plane", normal="0 0 1"),
    )
    ctx.write("floor.urdf", urdf.document(floor, ctx.header("URDF of the floor: a static plane z = 0 (PyBullet's)")))
    bodies: list[dict] = [
        {"name": "floor", "task": None, "file": "floor.urdf", "position": [0.0, 0.0, 0.0], "orientation": [0, 0, 0, 1]},
        {
            "name": "robot",
            "task": None,
            "file": "robot.urdf",
            "position": list(ctx.robot.base_position),
            "orientation": [0.0, 0.0, 0.0, 1.0],
            "fixed": True,
        },
    ]
    # loaded as its description says, no robot link has Bullet's own velocity damping: undone first, before the
    # run's material values (a tuned gripper damping) are applied over it
    changes: list[dict] = []
    if robot_link_damping(ctx.tasks[0].loading) != LOADED_LINK_DAMPING:
        changes += _undamped_links(p, first.client, first.robot)  # type: ignore[attr-defined]
    for task in ctx.tasks:
        if task.object is not None:
            bodies.append(_write_object(ctx, p, task.name, task.object))
        for change in _changes(ctx, task):
            if change not in changes:
                changes.append(change)
    for entry in bodies:
        entry.setdefault("fixed", False)
    _write_sidecar(ctx, float(first.timestep), bodies, changes)
    ctx.write(SCRIPT, hash_comment(ctx.header("load_pybullet.py: load this export in PyBullet")) + _SCRIPT)
    return ctx.files


def _write_robot(ctx: ExportContext, p, client: int, body: int) -> None:
    """robot.urdf: the links' masses and inertias as PyBullet simulated them, the tuned damping and limits."""
    robot = ctx.robot
    index = {  # link name -> link index (joint j moves link j)
        p.getJointInfo(body, j, physicsClientId=client)[12].decode(): j
        for j in range(p.getNumJoints(body, physicsClientId=client))
    }
    root = urdf.parse(robot.urdf)
    for name, link in urdf.links(root).items():
        if name in index or p.getDynamicsInfo(body, -1, physicsClientId=client)[0] > 0:
            urdf.set_inertial(link, _inertial(p, client, body, index.get(name, -1)))
    velocities = ctx.tasks[0]  # the controller's velocity clamp (the same for every task unless untuned)
    for name, joint in urdf.joints(root).items():
        if joint.get("type") == "fixed":
            continue
        i = robot.driven_joints.index(name) + 1
        # the tuned damping (changeDynamics(jointDamping=) does not show in getJointInfo)
        urdf.set_damping(joint, ctx.values[f"joint_damping_{i}"])
        v_max = ctx.params.get(f"max_velocity_joint_{i}", velocities.max_velocity_deg)
        urdf.set_limit(joint, ctx.values[f"max_torque_joint_{i}"], float(np.radians(v_max)))
    what = "URDF of the tuned robot for PyBullet: load it as load_pybullet.py does (pybullet.json has the rest)"
    ctx.write("robot.urdf", urdf.document(root, ctx.header(what)))


def _write_object(ctx: ExportContext, p, task: str, obj: ObjectSpec) -> dict:
    """object_<task>.urdf: the task's object with its tuned mass and PyBullet's inertia; its entry of ``bodies``."""
    engine = ctx.engines[task]
    name = f"object_{task}.urdf"
    shape = _geometry(ctx, obj, task)
    inertial = _inertial(p, engine.client, engine.object, -1)  # type: ignore[attr-defined]
    document = urdf.single_link(ctx.robot.object, inertial, shape)
    what = f"URDF of task {task!r}'s {obj.material} {obj.shape} for PyBullet (pose: pybullet.json)"
    ctx.write(name, urdf.document(document, ctx.header(what)))
    return {
        "name": "object",
        "task": task,
        "file": name,
        "position": [float(v) for v in obj.start_position],
        "orientation": [float(v) for v in p.getQuaternionFromEuler(obj.rpy)],
    }


def _write_sidecar(ctx: ExportContext, time_step: float, bodies: list[dict], changes: list[dict]) -> None:
    robot = ctx.robot
    about = {
        "what": "PyBullet values of a tuned simtune run that URDF cannot hold; load_pybullet.py applies them",
        "time_step": "seconds per stepSimulation (setTimeStep)",
        "gravity": "setGravity [m/s^2]",
        "bodies": "loadURDF calls, in the run's order: file, basePosition, baseOrientation (x, y, z, w), "
        "useFixedBase; 'task' null = every task, else only that task's scene",
        "load_flags": "loadURDF flags for every file: URDF_USE_INERTIA_FROM_FILE (the files hold the inertias "
        "PyBullet simulated), URDF_USE_IMPLICIT_CYLINDER (a cylinder as the run's: not a convex hull of it)",
        "motors": "the driven joints' VELOCITY_CONTROL motors: their force limits [N m] (the controller sets the "
        "target velocities, see controller.yaml)",
        "change_dynamics": "changeDynamics(body, link, **values) calls of the run, in order; link null = the base",
    }
    ctx.write_json(
        SIDECAR,
        about,
        {
            "time_step": time_step,
            "gravity": [0.0, 0.0, -9.81],
            "bodies": bodies,
            "load_flags": ["URDF_USE_INERTIA_FROM_FILE", "URDF_USE_IMPLICIT_CYLINDER"],
            "motors": {
                "joints": list(robot.driven_joints),
                "forces": [float(ctx.values[f"max_torque_joint_{i}"]) for i in range(1, len(robot.driven_joints) + 1)],
            },
            "change_dynamics": changes,
        },
    )


def _inertial(p, client: int, body: int, link: int) -> urdf.Inertial:
    info = p.getDynamicsInfo(body, link, physicsClientId=client)
    return urdf.Inertial(
        mass=float(info[0]),
        xyz=np.asarray(info[3], dtype=float),
        rpy=np.asarray(p.getEulerFromQuaternion(info[4]), dtype=float),
        inertia=np.diag(info[2]),
    )


def _geometry(ctx: ExportContext, obj: ObjectSpec, task: str) -> ET.Element:
    if obj.shape in ("cube", "cuboid"):
        return ET.Element("box", size=" ".join(num(s) for s in obj.size))
    if obj.shape == "cylinder":
        return ET.Element("cylinder", radius=num(obj.size[0]), length=num(obj.size[1]))
    name = write_cone_mesh(ctx, obj, task)
    return ET.Element("mesh", filename=name)


def _undamped_links(p, client: int, body: int) -> list[dict]:
    """changeDynamics calls that take Bullet's default link damping off every link of the robot (base included)."""
    values = {"linearDamping": 0.0, "angularDamping": 0.0}
    links = [
        None,
        *(
            p.getJointInfo(body, j, physicsClientId=client)[12].decode()
            for j in range(p.getNumJoints(body, physicsClientId=client))
        ),
    ]
    return [{"body": "robot", "link": link, "task": None, "values": dict(values)} for link in links]


def _changes(ctx: ExportContext, task) -> list[dict]:
    """The changeDynamics calls of the run for ``task``'s scene: each material group's values on its bodies."""
    gripper = [link for link, material in ctx.robot.link_materials.items() if material == "gripper"]
    out = []
    for group, members in material_groups(gripper, task.object).items():
        values = {keyword: float(value) for keyword, value in dynamics_changes(group, ctx.values).items()}
        for body, link in members:
            if values:
                out.append(
                    {"body": body, "link": link, "task": task.name if body == "object" else None, "values": values}
                )
    return out


_SCRIPT = '''"""Load the tuned PyBullet scene of one task: the URDF files plus pybullet.json (what URDF cannot hold)."""

import json
import pathlib
import sys

import pybullet as p

HERE = pathlib.Path(__file__).resolve().parent


def load(task, client=None):
    """Load floor, robot and ``task``'s object into ``client`` (default: a new DIRECT one); returns (client, ids)."""
    side = json.loads((HERE / "pybullet.json").read_text())
    c = p.connect(p.DIRECT) if client is None else client
    p.resetSimulation(physicsClientId=c)
    p.setGravity(*side["gravity"], physicsClientId=c)
    p.setTimeStep(side["time_step"], physicsClientId=c)
    ids = {}
    for body in (b for b in side["bodies"] if b["task"] in (None, task)):
        ids[body["name"]] = p.loadURDF(
            str(HERE / body["file"]), body["position"], body["orientation"], useFixedBase=body["fixed"],
            flags=sum(getattr(p, flag) for flag in side["load_flags"]), physicsClientId=c,
        )
    count = p.getNumJoints(ids["robot"], physicsClientId=c)
    infos = [p.getJointInfo(ids["robot"], j, physicsClientId=c) for j in range(count)]
    links = {info[12].decode(): info[0] for info in infos}  # joint j moves link j
    for change in (ch for ch in side["change_dynamics"] if ch["task"] in (None, task)):
        link = -1 if change["link"] is None else links[change["link"]]
        p.changeDynamics(ids[change["body"]], link, physicsClientId=c, **change["values"])
    joints = {info[1].decode(): info[0] for info in infos}
    motors = [joints[name] for name in side["motors"]["joints"]]
    p.setJointMotorControlArray(
        ids["robot"], motors, p.VELOCITY_CONTROL, targetVelocities=[0.0] * len(motors),
        forces=side["motors"]["forces"], physicsClientId=c,
    )
    return c, ids


if __name__ == "__main__":  # load, let it stand one second, print where the wrist is
    import yaml

    control = yaml.safe_load((HERE / "controller.yaml").read_text())
    task = sys.argv[1] if len(sys.argv) > 1 else next(iter(control["tasks"]))
    client, ids = load(task)
    for _ in range(round(1.0 / p.getPhysicsEngineParameters(physicsClientId=client)["fixedTimeStep"])):
        p.stepSimulation(physicsClientId=client)
    links = {p.getJointInfo(ids["robot"], j)[12].decode(): j for j in range(p.getNumJoints(ids["robot"]))}
    wrist = p.getLinkState(ids["robot"], links[control["tracking"]["link"]], computeForwardKinematics=True)
    print(task, "wrist at", wrist[4])
'''
