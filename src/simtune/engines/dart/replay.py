"""Drive an exported DART scene (the URDF files and ``dart.json``) through its own ``load_dart.py``."""

from __future__ import annotations

import numpy as np

from simtune.engines.replay_base import FromFiles, load_script


class DartFiles(FromFiles):
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
