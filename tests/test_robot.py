"""The arm description: kinematics against the reference numbers, and the same in every engine."""

import numpy as np
import pytest
from conftest import engine_or_skip, every_engine

from simtune.robot import MICO, forward_kinematics
from simtune.robot.generate import robot_urdf, scene_mjcf
from simtune.tasks import TASKS, get_task


def test_wrist_at_start_pose_matches_recordings():
    pos, _ = forward_kinematics(np.zeros(6))
    np.testing.assert_allclose(pos, (0.0, 0.067, 0.872), atol=1e-3)


@pytest.mark.parametrize(
    ("targets_deg", "expected"),
    [
        ((0, -100, 0, 0, 0, 0), (0.533, 0.067, 0.236)),  # final pose of `single`
        ((0, -67, 30, 90, 0, 0), (0.507, -0.007, 0.340)),  # final pose of `cube`
    ],
)
def test_wrist_at_task_final_poses(targets_deg, expected):
    pos, _ = forward_kinematics(np.radians(targets_deg))
    np.testing.assert_allclose(pos, expected, atol=1.5e-3)


@pytest.mark.parametrize("engine", every_engine())
def test_engines_agree_with_kinematics_within_1mm(engine):
    sim = engine_or_skip(engine)(get_task("single"))
    rng = np.random.default_rng(1)
    worst = 0.0
    for q in rng.uniform(-2.3, 2.3, size=(50, 6)):
        set_joint_angles(sim, q)
        # the engine's own joint coordinates read back what was set (ODE measures its
        # hinge angles from the bodies, so this checks its hinge axes, zero and sign)
        np.testing.assert_allclose(sim.joint_angles(), q, atol=POSE_ATOL.get(engine, 1e-9))
        pos, rot = sim.wrist_pose()
        ref_pos, ref_rot = forward_kinematics(q)
        worst = max(worst, float(np.linalg.norm(pos - ref_pos)))
        np.testing.assert_allclose(rot, ref_rot, atol=POSE_ATOL.get(engine, 1e-6))
    assert worst < 1e-3, f"{engine}: wrist differs by {worst * 1000:.3f} mm"


def _warp_world(sim):
    """MuJoCo Warp's one world (model, data), made by a reset if the engine has none yet."""
    if sim._single is None:
        sim.reset({})
    return sim._world()


#: How exactly an engine's state holds a pose it is given [rad, and a rotation matrix's entries]: MuJoCo Warp's is
#: float32, the others' float64.
POSE_ATOL = {"mujoco-warp": 1e-5}


def set_joint_angles(sim, q):
    """Pose the arm kinematically (engine specific, test only)."""
    if sim.name == "mujoco":
        import mujoco

        sim.data.qpos[sim._arm_qpos] = q
        mujoco.mj_kinematics(sim.model, sim.data)
    elif sim.name == "mujoco-warp":
        import mujoco_warp
        import warp

        model, data = _warp_world(sim)
        qpos = data.qpos.numpy()
        qpos[0, sim._arm_qpos] = q
        data.qpos.assign(qpos)
        with warp.ScopedDevice(sim._device):  # where the engine's arrays are
            mujoco_warp.kinematics(model, data)
    elif sim.name == "pybullet":
        import pybullet

        for joint, angle in zip(sim._arm, q):
            pybullet.resetJointState(sim.robot, joint, angle, physicsClientId=sim.client)
    elif sim.name == "ode":
        sim._pose_arm(q)  # ODE has no joint coordinates: place the bodies
    elif sim.name == "dart":
        sim.robot.setPositions(np.asarray(q, dtype=float))
    elif sim.name == "drake":
        for joint, angle in zip(sim._sys.joints, q):
            joint.set_angle(sim._sys.plant_context, float(angle))
    else:
        raise AssertionError(f"no kinematic pose helper for engine {sim.name!r}")


def lift_object(sim, dz):
    """Move the task's object up by ``dz`` from its start, at rest (engine specific, test only)."""
    obj = sim.task.object
    if sim.name == "mujoco":
        import mujoco

        sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint("object").id] + 2] += dz
        mujoco.mj_forward(sim.model, sim.data)
    elif sim.name == "mujoco-warp":
        import mujoco_warp
        import warp

        model, data = _warp_world(sim)
        qpos = data.qpos.numpy()
        qpos[0, sim.host.model.jnt_qposadr[sim.host.model.joint("object").id] + 2] += dz
        data.qpos.assign(qpos)
        with warp.ScopedDevice(sim._device):  # where the engine's arrays are
            mujoco_warp.forward(model, data)
    elif sim.name == "pybullet":
        import pybullet

        pos, quat = pybullet.getBasePositionAndOrientation(sim.object, physicsClientId=sim.client)
        pybullet.resetBasePositionAndOrientation(
            sim.object, (pos[0], pos[1], pos[2] + dz), quat, physicsClientId=sim.client
        )
    elif sim.name == "ode":
        import odepy

        pos = odepy.dBodyGetPosition(sim._object)
        odepy.dBodySetPosition(sim._object, pos[0], pos[1], pos[2] + dz)
    elif sim.name == "dart":
        from simtune.engines.dart.engine import _isometry

        sim._free.setTransform(_isometry(np.add(obj.start_position, (0, 0, dz)), obj.rotation))
    elif sim.name == "drake":
        from pydrake.math import RigidTransform, RotationMatrix

        s = sim._sys
        s.plant.SetFreeBodyPose(
            s.plant_context,
            s.object_body,
            RigidTransform(RotationMatrix(obj.rotation), np.add(obj.start_position, (0, 0, dz))),
        )
    else:
        raise AssertionError(f"no object helper for engine {sim.name!r}")


def test_generated_descriptions_are_well_formed():
    import xml.etree.ElementTree as ET

    urdf = ET.fromstring(robot_urdf(MICO))
    assert len(urdf.findall("link")) == 13
    assert sum(j.get("type") != "fixed" for j in urdf.findall("joint")) == 6
    for task in TASKS.values():
        mjcf = ET.fromstring(scene_mjcf(task.robot, task.object))
        assert (mjcf.find(".//freejoint") is not None) == (task.object is not None)


@pytest.mark.parametrize("engine", every_engine())
def test_objects_rest_on_the_floor(engine):
    """Each object dropped from 5 cm settles at its resting height within 2 mm."""
    cls = engine_or_skip(engine)
    for name in ("cube", "seed-5", "seed-7", "seed-9"):
        task = get_task(name)
        sim = cls(task)
        sim.reset({})
        lift_object(sim, 0.05)
        assert sim.object_position()[2] == pytest.approx(
            task.object.rest_height + 0.05, abs=POSE_ATOL.get(engine, 1e-9)
        )
        sim.step(int(round(3.0 / sim.timestep)))  # 3 s of the engine's own time step
        height = sim.object_position()[2]
        assert abs(height - task.object.rest_height) < 2e-3, f"{engine} {name}: rests at {height:.4f} m"
        sim.close()
