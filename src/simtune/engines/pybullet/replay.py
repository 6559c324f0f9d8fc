"""Drive an exported PyBullet scene (the URDF files and ``pybullet.json``) through its own ``load_pybullet.py``."""

from __future__ import annotations

import json

import numpy as np

from simtune.engines.replay_base import FromFiles, load_script


class PybulletFiles(FromFiles):
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
