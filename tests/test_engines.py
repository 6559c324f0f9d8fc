"""Engines behind one interface: every task runs, runs are deterministic, blow-ups are caught."""

import numpy as np
import pytest

from simtune.engines import engine_class, make_engine
from simtune.errors import ConfigError
from simtune.params import get_space
from simtune.tasks import TASKS, get_task

ENGINES = ["mujoco", "pybullet", "ode", "dart", "drake"]


@pytest.mark.parametrize("engine", ENGINES)
def test_every_task_runs_with_generic_parameters(engine):
    for task in TASKS.values():
        sim = make_engine(engine, task)
        n = int(min(task.duration, 10.0) * 20) + 1
        roll = sim.rollout({"timestep": 0.005}, n)
        assert roll.stable, f"{engine} {task.name}: {roll.message}"
        assert roll.wrist_pos.shape == (n, 3)
        assert (roll.object_pos is None) == (task.object is None)
        sim.close()


@pytest.mark.parametrize("engine", ENGINES)
def test_cube_rollout_is_deterministic(engine):
    """Same parameters, same trajectory, whatever the engine simulated before (no state
    such as cached contacts may leak from one rollout into the next)."""
    sim = make_engine(engine, get_task("cube"))
    params = {"timestep": 0.004, "lateral_friction_plastic": 0.8, "command_delay": 0.5}
    a = sim.rollout(params, 401)
    space = get_space("extended", sim.supported())
    rng = np.random.default_rng(0)
    for _ in range(5):
        sim.rollout({p.name: rng.uniform(p.low, p.high) for p in space.parameters}, 81)
    b = sim.rollout(params, 401)
    np.testing.assert_array_equal(a.wrist_pos, b.wrist_pos)
    np.testing.assert_array_equal(a.object_pos, b.object_pos)


@pytest.mark.parametrize("engine", ENGINES)
def test_every_parameter_of_the_space_changes_or_is_accepted(engine):
    """The whole extended space at its upper and lower bounds runs without crashing."""
    cls = engine_class(engine)
    space = get_space("extended", cls.supported())
    sim = cls(get_task("cube"))
    for corner in ("low", "high"):
        params = {p.name: getattr(p, corner) for p in space.parameters}
        roll = sim.rollout(params, 81)
        assert np.all(np.isfinite(roll.wrist_pos))


def test_generic_defaults_are_the_engines_own():
    mj = make_engine("mujoco", get_task("cube")).defaults()
    assert mj["timestep"] == 0.002 and mj["lateral_friction_plastic"] == 1.0
    pb = make_engine("pybullet", get_task("cube")).defaults()
    assert pb["timestep"] == pytest.approx(1 / 240) and pb["lateral_friction_plastic"] == 0.5
    # ODE has neither a default step nor a default surface: simtune's generic values
    ode = make_engine("ode", get_task("cube")).defaults()
    assert ode["timestep"] == 0.005 and ode["lateral_friction_plastic"] == 1.0 and ode["restitution_floor"] == 0.0
    dart = make_engine("dart", get_task("cube")).defaults()  # World's step, DynamicsAspect's friction
    assert dart["timestep"] == 0.001 and dart["lateral_friction_plastic"] == 1.0 and dart["restitution_floor"] == 0.0
    drake = make_engine("drake", get_task("cube")).defaults()  # MultibodyPlantConfig, the parser's friction
    assert drake["timestep"] == 0.001 and drake["lateral_friction_gripper"] == 1.0


@pytest.mark.parametrize("engine", ["pybullet", "ode", "dart", "drake"])
def test_max_torque_limits_the_motor(engine):
    """With a 2 N m limit the shoulder cannot hold the arm: it falls ahead of the command.

    (MuJoCo is left out: its gravity compensation acts outside the servo's force range.)
    """
    sim = make_engine(engine, get_task("single"))
    free = np.degrees(sim.rollout({}, 61).joint_angles[-1, 1])
    weak = np.degrees(sim.rollout({"max_torque_joint_2": 2.0}, 61).joint_angles[-1, 1])
    assert free == pytest.approx(-90.0, abs=1.5)
    assert weak < -100.0, f"{engine}: joint 2 at {weak:.1f} deg with a 2 N m motor"


def test_explosion_ends_rollout_with_a_flag_not_a_crash():
    sim = make_engine("mujoco", get_task("cube"))
    sim.reset({})
    sim.model.opt.timestep = 0.05
    sim.model.actuator_gainprm[:, 0] = 1e7  # a servo no integrator survives at this step
    sim.model.actuator_biasprm[:, 2] = -1e7
    roll = sim.rollout({"timestep": 0.05, **{f"max_torque_joint_{i}": 100 for i in range(1, 7)}}, 100)
    sim.model.actuator_gainprm[:, 0] = 100
    sim.model.actuator_biasprm[:, 2] = -100
    assert not roll.stable and "unstable" in roll.message
    assert np.all(np.isfinite(roll.wrist_pos))


def test_state_check_finds_the_first_broken_sample_of_a_block():
    from simtune.engines.base import _first_bad

    pos = np.tile([0.3, 0.0, 0.8], (10, 1))
    rot = np.tile(np.eye(3), (10, 1, 1))
    q = np.zeros((10, 6))
    obj = np.tile([0.5, 0.0, 0.1], (10, 1))
    assert _first_bad(pos, rot, q, obj, obj[0]) == (None, "")
    pos[6] = [3.0, 0.0, 0.0]
    q[4, 2] = np.nan
    obj[2] = [9.0, 0.0, 0.1]
    assert _first_bad(pos, rot, q, obj, obj[0]) == (2, "object thrown 8.5 m")
    assert _first_bad(pos, rot, q, None, None) == (4, "non-finite arm state")
    q[4, 2] = 0.0
    assert _first_bad(pos, rot, q, None, None) == (6, "wrist 3.0 m from the base")


def test_unknown_engine_is_a_clear_error():
    with pytest.raises(ConfigError, match="unknown engine 'ode2'.*mujoco"):
        engine_class("ode2")
