"""Drive an exported MJCF (``scene_<task>.xml``) with MuJoCo's own Python API: the round trip of a MuJoCo export."""

from __future__ import annotations

from simtune.engines.replay_base import FromFiles


class MujocoFiles(FromFiles):
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
