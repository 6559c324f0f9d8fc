"""Drive exported model files with each engine's own Python API: the round trip of `simtune export`.

Nothing here builds a model from simtune's robot description: each class loads
only the files of an export folder (the model files, the sidecar, controller.yaml).
The classes are `Engine`s so that simtune's shared control loop
(`Engine.rollout`: the 20 Hz controller, its phase, the step counting) drives
them exactly as it drove the tuned run, and simtune's fitness scores them.
Used by the round-trip tests and ``benchmarks/export_round_trip.py``.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import yaml

from simtune.data import TaskData
from simtune.engines.base import Engine, Rollout
from simtune.errors import SimtuneError
from simtune.fitness import TaskScore, rollout_joint_names, score_rollout
from simtune.tasks.spec import Phase, TaskSpec


def controller(folder: Path) -> dict:
    return yaml.safe_load((folder / "controller.yaml").read_text())


def task_from_controller(folder: Path, name: str, like: TaskSpec) -> TaskSpec:
    """The task as controller.yaml gives it (``like`` only says whether there is an object to track)."""
    t = controller(folder)["tasks"][name]
    phases = tuple(Phase(p["start_s"], tuple(p["targets_deg"])) for p in t["schedule"])
    return TaskSpec(
        name,
        t["description"],
        t["duration_s"],
        phases,
        t["kp_per_s"],
        object=like.object,
        start_pose_deg=tuple(t["start_pose_deg"]),
        robot=like.robot,  # the encoders' gravity torques are the robot's
    )


def controller_params(folder: Path, name: str) -> dict[str, float]:
    """The controller's and the marker's values from controller.yaml, as simtune's controller and fitness read them."""
    ctl = controller(folder)
    params = {f"max_velocity_joint_{i}": v for i, v in enumerate(ctl["tasks"][name]["max_velocity_deg_s"], start=1)}
    # the task's own delay (tasks tuned together each had one); files from before it hold the shared one only
    params["command_delay"] = ctl["tasks"][name].get("command_delay_s", ctl["control"]["command_delay_s"])
    params.update({f"marker_offset_{a}": v for a, v in zip("xyz", ctl["tracking"]["marker_offset_m"])})
    encoders = ctl["control"].get("encoders")  # exports from before the encoder model have none
    if encoders is not None:
        for kind, key in (
            ("joint_offset", "zero_offset_deg"),
            ("compliance_joint", "compliance_rad_per_n_m"),
            ("mass_link", "gravity_link_masses_kg"),  # the controller's gravity torques; the files hold the masses
        ):
            params.update({f"{kind}_{i}": v for i, v in enumerate(encoders[key], start=1)})
    return params


def load_script(folder: Path, name: str):
    """An export's example script, imported as a module."""
    spec = importlib.util.spec_from_file_location(f"exported_{Path(name).stem}", folder / name)
    if spec is None or spec.loader is None:
        raise SimtuneError(f"{folder / name}: cannot load the export's script")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class _FromFiles(Engine):
    engine_parameters = frozenset()

    def __init__(self, task: TaskSpec, folder: Path):
        super().__init__(task)
        ctl = controller(folder)
        self.folder = folder
        self.joints = ctl["control"]["joints"]
        self.wrist = ctl["tracking"]["link"]
        self.has_object = ctl["tasks"][task.name]["object"] is not None

    def defaults(self) -> dict[str, float]:
        return {}


class MujocoFiles(_FromFiles):
    name = "mujoco (exported MJCF)"

    def __init__(self, task, folder):
        import mujoco

        super().__init__(task, folder)
        self.mj = mujoco
        self.model = mujoco.MjModel.from_xml_path(str(folder / f"scene_{task.name}.xml"))
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.qpos = [m.jnt_qposadr[m.joint(j).id] for j in self.joints]
        self.ctrl = [m.actuator(j).id for j in self.joints]

    @property
    def timestep(self):
        return float(self.model.opt.timestep)

    def reset(self, params):
        self.mj.mj_resetData(self.model, self.data)
        self.data.qpos[self.qpos] = self.start_angles(params)
        self.mj.mj_forward(self.model, self.data)

    def set_joint_velocities(self, velocities):
        self.data.ctrl[self.ctrl] = velocities

    def step(self, n):
        self.mj.mj_step(self.model, self.data, nstep=n)

    def joint_angles(self):
        return self.data.qpos[self.qpos].copy()

    def wrist_pose(self):
        b = self.model.body(self.wrist).id
        return self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()

    def object_position(self):
        return self.data.xpos[self.model.body("object").id].copy() if self.has_object else None


class PybulletFiles(_FromFiles):
    name = "pybullet (exported URDF + pybullet.json, through load_pybullet.py)"

    def __init__(self, task, folder):
        import pybullet

        super().__init__(task, folder)
        self.p = pybullet
        self.script = load_script(folder, "load_pybullet.py")
        self.client = None
        self.reset({})

    @property
    def timestep(self):
        return float(self.p.getPhysicsEngineParameters(physicsClientId=self.client)["fixedTimeStep"])

    def reset(self, params):
        p = self.p
        self.client, self.ids = self.script.load(self.task.name, self.client)
        robot = self.ids["robot"]
        infos = [
            p.getJointInfo(robot, j, physicsClientId=self.client)
            for j in range(p.getNumJoints(robot, physicsClientId=self.client))
        ]
        joints = {i[1].decode(): i[0] for i in infos}
        self.arm = [joints[j] for j in self.joints]
        self.wrist_index = next(i[0] for i in infos if i[12].decode() == self.wrist)
        self.forces = json.loads((self.folder / "pybullet.json").read_text())["motors"]["forces"]
        for j, angle in zip(self.arm, self.start_angles(params)):
            p.resetJointState(robot, j, angle, 0.0, physicsClientId=self.client)

    def set_joint_velocities(self, velocities):
        self.p.setJointMotorControlArray(
            self.ids["robot"],
            self.arm,
            self.p.VELOCITY_CONTROL,
            targetVelocities=list(velocities),
            forces=self.forces,
            physicsClientId=self.client,
        )

    def step(self, n):
        for _ in range(n):
            self.p.stepSimulation(physicsClientId=self.client)

    def joint_angles(self):
        return np.array([s[0] for s in self.p.getJointStates(self.ids["robot"], self.arm, physicsClientId=self.client)])

    def wrist_pose(self):
        s = self.p.getLinkState(
            self.ids["robot"], self.wrist_index, computeForwardKinematics=True, physicsClientId=self.client
        )
        return np.array(s[4]), np.array(self.p.getMatrixFromQuaternion(s[5])).reshape(3, 3)

    def object_position(self):
        if not self.has_object:
            return None
        return np.array(self.p.getBasePositionAndOrientation(self.ids["object"], physicsClientId=self.client)[0])

    def close(self):
        if self.client is not None:
            self.p.disconnect(self.client)
            self.client = None


class DartFiles(_FromFiles):
    name = "dart (exported URDF + dart.json, through load_dart.py)"

    def __init__(self, task, folder):
        super().__init__(task, folder)
        self.script = load_script(folder, "load_dart.py")
        self.reset({})

    @property
    def timestep(self):
        return float(self.world.getTimeStep())

    def reset(self, params):
        self.world, self.robot, self.body = self.script.load(self.task.name)
        self.dofs = [self.robot.getJoint(j).getIndexInSkeleton(0) for j in self.joints]
        positions = np.zeros(self.robot.getNumDofs())
        positions[self.dofs] = self.start_angles(params)
        self.robot.setPositions(positions)

    def set_joint_velocities(self, velocities):
        commands = np.zeros(self.robot.getNumDofs())
        commands[self.dofs] = velocities
        self.robot.setCommands(commands)

    def step(self, n):
        for _ in range(n):
            self.world.step(False)

    def joint_angles(self):
        return np.asarray(self.robot.getPositions())[self.dofs]

    def wrist_pose(self):
        t = self.robot.getBodyNode(self.wrist).getWorldTransform()
        return np.array(t.translation()), np.array(t.rotation())

    def object_position(self):
        return np.array(self.body.getWorldTransform().translation()) if self.has_object else None


class DrakeFiles(_FromFiles):
    name = "drake (exported URDF + SDFormat + drake.json, through load_drake.py)"

    def __init__(self, task, folder):
        super().__init__(task, folder)
        self.script = load_script(folder, "load_drake.py")
        self.simulator, self.plant, self.robot = self.script.load(task.name)
        self.context = self.simulator.get_mutable_context()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.arm = [self.plant.GetJointByName(j, self.robot) for j in self.joints]
        self.dt = json.loads((folder / "drake.json").read_text())["plant"]["time_step"]
        self.failed = ""

    @property
    def timestep(self):
        return self.dt

    def reset(self, params):
        self.simulator.get_system().SetDefaultContext(self.context)
        for joint, angle in zip(self.arm, self.start_angles(params)):
            joint.set_angle(self.plant_context, float(angle))
            joint.set_angular_rate(self.plant_context, 0.0)
        self.context.SetTime(0.0)
        self.steps = 0
        self.set_joint_velocities(np.zeros(len(self.arm)))
        self.simulator.Initialize()

    def set_joint_velocities(self, velocities):
        self.script.command(self.plant, self.robot, self.plant_context, np.asarray(velocities, dtype=float))

    def step(self, n):
        if not self.failed:
            self.steps += n
            try:
                self.simulator.AdvanceTo(self.steps * self.dt)
            except RuntimeError as exc:
                self.failed = str(exc)

    def diverged(self):
        return self.failed

    def joint_angles(self):
        return np.array([j.get_angle(self.plant_context) for j in self.arm])

    def wrist_pose(self):
        pose = self.plant.EvalBodyPoseInWorld(self.plant_context, self.plant.GetBodyByName(self.wrist, self.robot))
        return np.array(pose.translation()), np.array(pose.rotation().matrix())

    def object_position(self):
        if not self.has_object:
            return None
        body = self.plant.GetBodyByName("object")
        return np.array(self.plant.EvalBodyPoseInWorld(self.plant_context, body).translation())


#: engine -> the class that drives its exported files (ODE has none: it has no model file)
REPLAYS: dict[str, type[_FromFiles]] = {
    "mujoco": MujocoFiles,
    "pybullet": PybulletFiles,
    "dart": DartFiles,
    "drake": DrakeFiles,
}


def replay_task(engine: str, folder: Path, task: TaskSpec, reference: TaskData) -> tuple[Rollout, TaskScore]:
    """Drive ``engine``'s exported model of ``task`` with controller.yaml's commands; its rollout and score.

    ``task`` (simtune's) only says whether there is an object to track: its
    schedule, gain and start pose are taken from controller.yaml.
    """
    exported = task_from_controller(folder, task.name, task)
    params = controller_params(folder, task.name)
    sim = REPLAYS[engine](exported, folder)
    try:
        rollout = sim.rollout(params, len(reference.times))
    finally:
        sim.close()
    return rollout, score_rollout(rollout, reference, params, joint_names=rollout_joint_names(task))
