"""A robot from a URDF: the Franka Panda shipped with pybullet, built in every engine from one description."""

from pathlib import Path

import numpy as np
import pytest
from conftest import CPU_ENGINES, engine_or_skip, every_engine

from simtune.engines import ENGINES
from simtune.errors import ConfigError, RobotError
from simtune.params.space import SPACES, get_space, robot_spaces
from simtune.robot.generate import robot_urdf_file
from simtune.robot.mico import MICO
from simtune.robot.urdf import load_urdf
from simtune.tasks.spec import Phase, TaskSpec

pybullet_data = pytest.importorskip("pybullet_data")
PANDA = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
PANDA_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))


@pytest.fixture(scope="module")
def panda():
    if not PANDA.is_file():
        pytest.skip(f"no Franka Panda URDF at {PANDA}")
    return load_urdf(PANDA)


def random_poses(robot, n=5, seed=0) -> np.ndarray:
    limits = np.array([[robot.joint_by_name[j].lower, robot.joint_by_name[j].upper] for j in robot.arm_joints])
    return np.random.default_rng(seed).uniform(limits[:, 0], limits[:, 1], size=(n, len(limits)))


def pose_task(robot, q_rad) -> TaskSpec:
    pose = tuple(float(v) for v in np.degrees(q_rad))
    return TaskSpec(
        "pose", "the robot held at one pose", 1.0, (Phase(0.0, pose),), kp=1.0, start_pose_deg=pose, robot=robot
    )


def test_panda_description(panda):
    assert panda.arm_joints == PANDA_JOINTS
    assert panda.tracked_link == "panda_hand"  # where the chain branches into the fingers
    # the fingers (one a mimic joint) are held closed: fixed joints at that pose
    assert dict(panda.held) == {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}
    assert all(not panda.joint_by_name[name].moves for name, _ in panda.held)
    assert {link.name for link in panda.links if link.material == "gripper"} == {
        "panda_hand",
        "panda_leftfinger",
        "panda_rightfinger",
        "panda_grasptarget",
    }
    meshes = [s for link in panda.links for s in link.shapes]
    assert meshes and all(Path(s.path).is_absolute() and Path(s.path).is_file() for s in meshes)
    joint4 = panda.joint_by_name["panda_joint4"]
    assert (joint4.lower, joint4.upper, joint4.effort) == (-3.1416, 0.0, 87.0)
    # at zero the hand hangs 0.926 m up (link0 to link7 offsets plus the 0.107 m flange), turned -45 deg
    pos, rot = panda.forward_kinematics(np.zeros(7))
    np.testing.assert_allclose(pos, (0.088, 0.0, 0.926), atol=1e-9)
    np.testing.assert_allclose(rot[:, 2], (0.0, 0.0, -1.0), atol=1e-9)


@pytest.mark.parametrize("engine", every_engine())
def test_panda_kinematics_in_every_engine(panda, engine):
    """Each engine puts the tracked link where the description's own kinematics do, within 0.5 um at 5
    random poses: so any two engines agree within 1e-6 m."""
    cls = engine_or_skip(engine)
    for q in random_poses(panda):
        sim = cls(pose_task(panda, q))
        try:
            sim.reset({})
            np.testing.assert_allclose(sim.joint_angles(), q, atol=1e-9)
            pos, rot = sim.wrist_pose()
        finally:
            sim.close()
        want_pos, want_rot = panda.forward_kinematics(q)
        assert np.abs(pos - want_pos).max() < 5e-7, f"{engine}: tracked link {pos} vs {want_pos}"
        assert np.abs(rot - want_rot).max() < 5e-7


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_panda_reach_rolls_out_stably(panda, engine):
    """A reach over the seven joints and back: stable, on target, the hand where the kinematics put it."""
    cls = engine_or_skip(engine)
    start = (0.0, -30.0, 0.0, -120.0, 0.0, 90.0, 45.0)
    reach = (30.0, 0.0, -20.0, -90.0, 20.0, 100.0, 0.0)
    task = TaskSpec(
        "panda-reach",
        "reach out and back",
        8.0,
        (Phase(1.0, reach), Phase(4.5, start)),
        kp=1.0,
        start_pose_deg=start,
        robot=panda,
    )
    sim = cls(task)
    try:
        rollout = sim.rollout({}, 160)
    finally:
        sim.close()
    assert rollout.stable, rollout.message
    assert rollout.joint_angles.shape == (160, 7)
    at_reach = np.degrees(rollout.joint_angles[89])  # 4.45 s: the reach is all but done
    np.testing.assert_allclose(at_reach, reach, atol=1.5)
    np.testing.assert_allclose(np.degrees(rollout.joint_angles[-1]), start, atol=1.5)
    for k in (0, 89, 159):
        want, _ = panda.forward_kinematics(rollout.joint_angles[k])
        np.testing.assert_allclose(rollout.wrist_pos[k], want, atol=1e-4)


def test_generated_mico_urdf_loads_back_as_the_mico():
    """The URDF writer's nine significant digits (pi as 3.14159265) are the only difference."""
    robot = load_urdf(robot_urdf_file(MICO), base_position=MICO.base_position)
    assert robot.arm_joints == MICO.arm_joints
    assert robot.tracked_link == MICO.tracked_link
    assert [link.material for link in robot.links] == [link.material for link in MICO.links]
    for q in np.random.default_rng(1).uniform(-2.3, 2.3, size=(5, 6)):
        for link in ("link_6", "finger_tip_2"):
            pos, rot = robot.forward_kinematics(q, link)
            want_pos, want_rot = MICO.forward_kinematics(q, link)
            np.testing.assert_allclose(pos, want_pos, atol=1e-7)
            np.testing.assert_allclose(rot, want_rot, atol=1e-7)


def test_parameters_follow_the_robot(panda):
    space = robot_spaces(panda)["extended"]
    names = [p.name for p in space]
    for kind in ("mass_link", "max_torque_joint", "max_velocity_joint", "joint_damping"):
        assert [n for n in names if n.startswith(f"{kind}_")] == [f"{kind}_{i}" for i in range(1, 8)]
    by_name = {p.name: p for p in space}
    # masses and described efforts by the paper's mass rule: [0.7, 1.3] x nominal
    assert (by_name["mass_link_5"].low, by_name["mass_link_5"].high) == pytest.approx((2.1, 3.9))
    assert (by_name["max_torque_joint_7"].low, by_name["max_torque_joint_7"].high) == pytest.approx((8.4, 15.6))
    # the MICO keeps the paper's names and ranges
    assert robot_spaces(MICO) == SPACES
    engine = engine_or_skip("mujoco")
    sp = get_space("extended", engine.supported(panda), robot=panda)
    assert "mass_link_7" in sp.names and "joint_damping_7" in sp.names
    assert "mass_link_7" not in get_space("extended", engine.supported()).names


def test_task_joint_count_must_match_its_robot(panda):
    with pytest.raises(ConfigError, match="phase 1 has 6 joint targets, robot 'panda' drives 7"):
        TaskSpec("t", "", 1.0, (Phase(0.0, (0.0,) * 6),), kp=1.0, robot=panda)
    with pytest.raises(ConfigError, match="start pose has 7 joint angles"):
        TaskSpec("t", "", 1.0, (), kp=1.0, start_pose_deg=(0.0,) * 7)


# --- bad input: one line naming the file and the element ------------------------------------------


def one_line(exc: pytest.ExceptionInfo, *parts: str) -> None:
    message = str(exc.value)
    assert "\n" not in message
    for part in parts:
        assert part in message, message


def test_missing_urdf(tmp_path):
    with pytest.raises(RobotError) as exc:
        load_urdf(tmp_path / "arm.urdf")
    one_line(exc, str(tmp_path / "arm.urdf"), "no such URDF file")


def test_unparsable_urdf(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text('<robot name="arm">\n  <link name="a">\n</robot>\n')
    with pytest.raises(RobotError) as exc:
        load_urdf(path)
    one_line(exc, str(path), "line", "not valid XML")


def test_missing_mesh(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(
        """<robot name="arm">
  <link name="base"><collision><geometry><mesh filename="meshes/base.stl"/></geometry></collision></link>
  <link name="tip"/>
  <joint name="j1" type="continuous"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/></joint>
</robot>
"""
    )
    with pytest.raises(RobotError) as exc:
        load_urdf(path)
    one_line(exc, str(path), "link 'base'", "'meshes/base.stl' not found")


def test_unknown_link_and_joint(panda):
    with pytest.raises(RobotError) as exc:
        load_urdf(PANDA, tracked_link="panda_link9")
    one_line(exc, str(PANDA), "tracked link 'panda_link9'")
    with pytest.raises(RobotError) as exc:
        load_urdf(PANDA, arm_joints=[*PANDA_JOINTS[:6], "panda_joint_7"])
    one_line(exc, str(PANDA), "joint 'panda_joint_7' is not a joint")


def test_mimic_joints_cannot_be_driven(panda):
    with pytest.raises(RobotError) as exc:
        load_urdf(PANDA, arm_joints=[*PANDA_JOINTS, "panda_finger_joint2"])
    one_line(exc, str(PANDA), "'panda_finger_joint2' mimics 'panda_finger_joint1'", "not supported")


def test_held_fingers_follow_their_mimic_rule(panda):
    robot = load_urdf(PANDA, held={"panda_finger_joint1": 0.03})
    assert dict(robot.held) == {"panda_finger_joint1": 0.03, "panda_finger_joint2": 0.03}
    left, _ = robot.forward_kinematics(np.zeros(7), "panda_leftfinger")
    right, _ = robot.forward_kinematics(np.zeros(7), "panda_rightfinger")
    assert np.linalg.norm(left - right) == pytest.approx(0.06)  # each finger 3 cm out from the middle


# --- an MJCF robot: MuJoCo from the file, the others from its URDF ---------------------------------------

ARM_MJCF = """<mujoco model="arm3">
  <compiler angle="radian" meshdir="{meshes}"/>
  <asset><mesh name="shell" file="link1.obj" scale="0.5 0.5 0.5"/></asset>
  <worldbody>
    <body name="base" pos="0 0 0.05">
      <inertial pos="0 0 0.05" mass="2" diaginertia="0.01 0.01 0.01"/>
      <geom type="box" size="0.05 0.05 0.05" pos="0 0 0.05"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="shoulder" axis="0 0 1"/>
        <inertial pos="0 0 0.1" mass="1" diaginertia="0.005 0.005 0.001"/>
        <geom type="mesh" mesh="shell"/>
        <body name="fore" pos="0 0 0.2" quat="0.7071068 0.7071068 0 0">
          <joint name="elbow" axis="0 0 1" range="-2 2" damping="0.1"/>
          <inertial pos="0.1 0 0" mass="0.5" diaginertia="0.001 0.002 0.002"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.03"/>
          <body name="hand" pos="0.2 0 0">
            <joint name="wrist" axis="1 0 0"/>
            <inertial pos="0.03 0 0" mass="0.3" diaginertia="0.0005 0.0005 0.0005"/>
            <geom type="sphere" size="0.04" pos="0.03 0 0"/>
            <body name="finger" pos="0.06 0 0">
              <joint name="finger" type="slide" axis="0 1 0" range="0 0.02"/>
              <inertial pos="0.01 0 0" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/>
              <geom type="box" size="0.01 0.005 0.02" pos="0.01 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><position joint="shoulder" kp="10"/><position joint="finger" kp="10"/></actuator>
  <keyframe><key name="home" qpos="0 0 0 0" ctrl="0 0"/></keyframe>
</mujoco>
"""


@pytest.fixture
def arm_mjcf(tmp_path):
    path = tmp_path / "arm.xml"
    path.write_text(ARM_MJCF.format(meshes=PANDA.parent / "meshes" / "collision"))
    return path


def test_mjcf_robot_in_mujoco(arm_mjcf):
    from simtune.robot.mjcf import load_mjcf

    robot = load_mjcf(arm_mjcf, tracked_link="hand")
    assert robot.arm_joints == ("shoulder", "elbow", "wrist")
    assert dict(robot.held) == {"finger": 0.0}  # the slide is held, its body welded
    assert robot.joint_by_name["elbow"].damping == pytest.approx(0.1)
    cls = engine_or_skip("mujoco")
    for q in np.random.default_rng(2).uniform(-1.5, 1.5, size=(3, 3)):
        sim = cls(pose_task(robot, q))
        sim.reset({})
        pos, rot = sim.wrist_pose()
        want_pos, want_rot = robot.forward_kinematics(q)
        np.testing.assert_allclose(pos, want_pos, atol=1e-9)
        np.testing.assert_allclose(rot, want_rot, atol=1e-9)
    reach = TaskSpec("arm3-reach", "", 5.0, (Phase(0.5, (40.0, 60.0, -30.0)),), kp=1.0, robot=robot)
    sim = cls(reach)
    rollout = sim.rollout({}, 100)
    assert rollout.stable, rollout.message
    np.testing.assert_allclose(np.degrees(rollout.joint_angles[-1]), (40.0, 60.0, -30.0), atol=1.0)
    assert sim.defaults()["mass_link_3"] == pytest.approx(0.3)


@pytest.mark.parametrize("engine", [e for e in CPU_ENGINES if not ENGINES[e].engine_class().reads_mjcf])
def test_mjcf_robot_elsewhere_from_its_generated_urdf(arm_mjcf, engine):
    """The other engines build an MJCF's robot from the URDF of its description: its collision geoms as shapes
    (a capsule as a cylinder and two spheres, a mesh as MuJoCo's hull of it), the same kinematics."""
    from simtune.robot.mjcf import load_mjcf

    cls = engine_or_skip(engine)
    robot = load_mjcf(arm_mjcf, tracked_link="hand")
    kinds = {link.name: [type(s).__name__ for s in link.shapes] for link in robot.links}
    assert kinds["fore"] == ["Cylinder", "Sphere", "Sphere"] and kinds["upper"] == ["Mesh"]
    for q in np.random.default_rng(3).uniform(-1.5, 1.5, size=(2, 3)):
        sim = cls(pose_task(robot, q))
        sim.reset({})
        pos, _ = sim.wrist_pose()
        np.testing.assert_allclose(pos, robot.forward_kinematics(q)[0], atol=1e-6)
        sim.close()


def test_mjcf_errors(tmp_path, arm_mjcf):
    from simtune.robot.mjcf import load_mjcf

    with pytest.raises(RobotError) as exc:
        load_mjcf(tmp_path / "none.xml")
    one_line(exc, "no such MJCF file")
    with pytest.raises(RobotError) as exc:
        load_mjcf(arm_mjcf, arm_joints=["shoulder", "finger"])
    one_line(exc, str(arm_mjcf), "'finger' is a slide")
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body name='a'></worldbody></mujoco>")
    with pytest.raises(RobotError) as exc:
        load_mjcf(broken)
    one_line(exc, str(broken), "MuJoCo cannot compile it")
