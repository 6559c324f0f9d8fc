"""The calibration parameters (``--space calibrated``): encoder zero offsets and joint compliance act
on a rollout as the encoder model says, alike in every engine, and are listed where spaces are."""

import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import engine_or_skip

from simtune.engines import ENGINES, engine_class
from simtune.engines.controller import JointController
from simtune.errors import EngineUnavailable
from simtune.params import get_space
from simtune.params.kinds import FULL_LOAD_DEFLECTION_DEG
from simtune.params.space import robot_spaces
from simtune.robot.mico import MICO
from simtune.tasks import get_task
from simtune.tasks.spec import Phase, TaskSpec

#: the arm alone, driven to a pose that loads joints 2 and 3, held for 6 s to settle
SETTLE = TaskSpec(
    name="settle",
    description="drive to a loaded pose and hold it",
    duration=8.0,
    phases=(Phase(0.0, (20.0, 30.0, 40.0, 10.0, 20.0, 10.0)),),
    kp=3.0,
)
SAMPLES = 161


def settled_true_angles(engine: str, params: dict[str, float]) -> np.ndarray:
    sim = engine_or_skip(engine)(SETTLE)
    try:
        sim.rollout({"timestep": 0.002, **params}, SAMPLES)
        return sim.joint_angles()
    finally:
        sim.close()


def test_gravity_torques_match_mujocos_gravity_compensation():
    """The static computation from the description agrees with MuJoCo's own gravity forces."""
    pytest.importorskip("mujoco")
    import mujoco

    sim = engine_class("mujoco")(get_task("cube"))
    rng = np.random.default_rng(1)
    for _ in range(4):
        q = rng.uniform(-2.0, 2.0, 6)
        sim.data.qpos[:] = 0.0
        sim.data.qpos[sim._arm_qpos] = q
        mujoco.mj_forward(sim.model, sim.data)
        np.testing.assert_allclose(MICO.gravity_torques(q), -sim.data.qfrc_gravcomp[sim._arm_dof], atol=1e-9)
    heavier = MICO.gravity_torques(q, {"link_3": 2 * MICO.link_by_name["link_3"].mass})
    assert abs(heavier[1]) > abs(MICO.gravity_torques(q)[1])


def test_gravity_load_bounds_hold_and_skip_the_upright_first_joint():
    bounds = MICO.gravity_load_bounds()
    assert bounds[0] == 0.0 and (bounds[1:] > 0).all()
    rng = np.random.default_rng(2)
    worst = np.max([np.abs(MICO.gravity_torques(rng.uniform(-3, 3, 6))) for _ in range(200)], axis=0)
    assert (worst <= bounds + 1e-12).all()


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_an_encoder_offset_shifts_the_settled_joint_by_minus_the_offset(engine):
    plain = settled_true_angles(engine, {})
    shifted = settled_true_angles(engine, {"joint_offset_2": 1.5, "joint_offset_5": -2.0})
    moved = np.degrees(shifted - plain)
    np.testing.assert_allclose(moved, [0.0, -1.5, 0.0, 0.0, 2.0, 0.0], atol=0.02)


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_compliance_lets_the_joint_sag_by_compliance_times_gravity_torque(engine):
    compliance = get_space("calibrated").parameters
    high = {p.name: p.high for p in compliance if p.name == "compliance_joint_2"}
    plain = settled_true_angles(engine, {})
    sagged = settled_true_angles(engine, high)
    expected = high["compliance_joint_2"] * MICO.gravity_torques(sagged)[1]
    assert abs(np.degrees(expected)) > 0.3  # the pose loads joint 2: the test can fail
    np.testing.assert_allclose(sagged[1] - plain[1], expected, atol=np.radians(0.02))
    np.testing.assert_allclose(np.delete(sagged - plain, 1), 0.0, atol=np.radians(0.02))


def test_joint_logs_are_encoder_readings_and_the_arm_starts_where_they_read_the_start_pose():
    """With an offset, the rollout's joint angles (what a joint log records) settle at the target,
    and the arm starts at rest: its encoders read the start pose from the first sample on."""
    sim = engine_or_skip("mujoco")(SETTLE)
    params = {"joint_offset_3": 2.5, "compliance_joint_3": 0.005}
    roll = sim.rollout(params, SAMPLES)
    np.testing.assert_allclose(roll.joint_angles[0], 0.0, atol=1e-9)
    np.testing.assert_allclose(np.degrees(roll.joint_angles[-1]), SETTLE.phases[0].targets_deg, atol=0.02)
    start = JointController(SETTLE, params).start_angles()
    assert np.degrees(start[2]) == pytest.approx(-2.5 + np.degrees(0.005 * MICO.gravity_torques(start)[2]))


def test_calibrated_space_is_extended_plus_calibration_for_every_engine():
    spaces = robot_spaces(MICO)
    extended = [p.name for p in spaces["extended"]]
    calibrated = [p.name for p in spaces["calibrated"]]
    added = calibrated[len(extended) :]
    assert calibrated[: len(extended)] == extended
    assert added == [f"joint_offset_{i}" for i in range(1, 7)] + [f"compliance_joint_{i}" for i in range(2, 7)]
    for p in spaces["calibrated"]:
        if p.name.startswith("joint_offset_"):
            assert (p.low, p.high, p.unit) == (-3.0, 3.0, "deg")
    # full load gives the stated deflection
    bounds = MICO.gravity_load_bounds()
    for p in spaces["calibrated"]:
        if p.name.startswith("compliance_joint_"):
            i = int(p.name.rsplit("_", 1)[1])
            assert np.degrees(p.high * bounds[i - 1]) == pytest.approx(FULL_LOAD_DEFLECTION_DEG)
    for engine in ENGINES:
        try:
            engine_class(engine)
        except EngineUnavailable:  # an optional engine this machine lacks
            continue
        if engine == "mujoco-warp":  # its batched controller kernel has no encoder model yet (docs/parameters.md)
            assert not set(added) & engine_class(engine).supported()
        else:
            assert set(added) <= engine_class(engine).supported(), engine


def test_params_command_lists_the_calibration_parameters():
    engine_or_skip("ode")
    out = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "params", "--space", "calibrated", "--engine", "ode"],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "COLUMNS": "200"},
    ).stdout
    for name in ("joint_offset_1", "joint_offset_6", "compliance_joint_2", "compliance_joint_6"):
        assert name in out
    assert "compliance_joint_1" not in out


def test_gravity_torques_of_a_urdf_robot_match_pybullets_inverse_dynamics():
    """Another robot (the Franka Panda's URDF, fingers held): the same statics as PyBullet's."""
    pybullet = pytest.importorskip("pybullet")
    import pybullet_data

    from simtune.robot.urdf import load_urdf

    path = f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf"
    if not os.path.isfile(path):
        pytest.skip(f"no Franka Panda URDF at {path}")
    robot = load_urdf(path)
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        body = pybullet.loadURDF(path, useFixedBase=True, physicsClientId=client)
        infos = [pybullet.getJointInfo(body, i, physicsClientId=client) for i in range(pybullet.getNumJoints(body))]
        movable = [info[1].decode() for info in infos if info[2] != pybullet.JOINT_FIXED]
        held = dict(robot.held)
        for seed in range(3):
            q = np.random.default_rng(seed).uniform(-1.0, 1.0, robot.n_joints)
            position = [q[robot.arm_joints.index(n)] if n in robot.arm_joints else held.get(n, 0.0) for n in movable]
            zeros = [0.0] * len(movable)
            holding = pybullet.calculateInverseDynamics(body, position, zeros, zeros, physicsClientId=client)
            theirs = -np.array([holding[movable.index(j)] for j in robot.arm_joints])
            np.testing.assert_allclose(robot.gravity_torques(q), theirs, atol=1e-6)
    finally:
        pybullet.disconnect(client)
    assert "compliance_joint_7" in {p.name for p in robot_spaces(robot)["calibrated"]}
