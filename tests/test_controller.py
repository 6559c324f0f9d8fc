import numpy as np
import pytest
from conftest import engine_or_skip, every_engine

from simtune.engines import make_engine
from simtune.engines.controller import JointController
from simtune.tasks import get_task


def test_command_is_clamped_proportional_velocity():
    task = get_task("single")  # joint_2 -> -100 deg, kp = 10
    ctrl = JointController(task)
    cmd = np.degrees(ctrl.command(0.0, np.zeros(6)))
    np.testing.assert_allclose(cmd, [0, -30, 0, 0, 0, 0])  # 10 * -100 clamped to -30 deg/s
    near = np.radians([0, -99, 0, 0, 0, 0])
    np.testing.assert_allclose(np.degrees(ctrl.command(5.0, near))[1], -10.0)


def test_delay_holds_the_start_pose_and_velocity_limit_is_per_joint():
    ctrl = JointController(get_task("single"), {"command_delay": 1.5, "max_velocity_joint_2": 12.0})
    assert not ctrl.command(1.4, np.zeros(6)).any()
    assert np.degrees(ctrl.command(1.6, np.zeros(6)))[1] == pytest.approx(-12.0)


@pytest.mark.parametrize("engine", every_engine())
def test_engines_follow_the_clamped_velocity_profile(engine):
    """A joint stepped to a far target moves at v_max, then slows exponentially (kp) near it."""
    sim = engine_or_skip(engine)(get_task("single"))
    roll = sim.rollout({}, 121)
    j2 = np.degrees(roll.joint_angles[:, 1])
    # 30 deg/s for the first 3 s (angles sampled before each update)
    np.testing.assert_allclose(j2[20], -30.0, atol=1.0)
    np.testing.assert_allclose(j2[60], -90.0, atol=1.5)
    # then within kp's reach: 10 deg left decays as exp(-kp t); after 2 s it is done
    np.testing.assert_allclose(j2[120], -100.0, atol=1.0)
    assert np.all(np.diff(j2) <= 1e-6), "joint 2 must move monotonically"


def test_command_delay_is_continuous_not_whole_control_periods():
    sim = make_engine("mujoco", get_task("single"))
    wrist = {d: sim.rollout({"command_delay": d}, 120).wrist_pos for d in (1.45, 1.46, 1.48, 1.50)}
    # within one 50 ms period the delay still moves the trajectory, monotonically
    gap_small = np.abs(wrist[1.46] - wrist[1.45]).max()
    gap_large = np.abs(wrist[1.48] - wrist[1.45]).max()
    assert 1e-4 < gap_small < gap_large
    # a whole period later is the same motion one sample later
    np.testing.assert_allclose(wrist[1.50][1:], wrist[1.45][:-1], atol=1e-6)
