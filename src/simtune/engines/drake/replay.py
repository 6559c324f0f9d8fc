"""Drive an exported Drake scene (URDF, SDFormat and ``drake.json``) through its own ``load_drake.py``."""

from __future__ import annotations

import json

import numpy as np

from simtune.engines.replay_base import FromFiles, load_script


class DrakeFiles(FromFiles):
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
