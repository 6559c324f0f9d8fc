"""Engines behind one interface: every task runs, runs are deterministic, blow-ups are caught."""

import numpy as np
import pytest

from simtune.engines import engine_class, make_engine
from simtune.errors import ConfigError
from simtune.params import get_space
from simtune.tasks import TASKS, get_task

ENGINES = ["mujoco", "pybullet"]


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
    sim = make_engine(engine, get_task("cube"))
    params = {"timestep": 0.004, "lateral_friction_plastic": 0.8, "command_delay": 0.5}
    a = sim.rollout(params, 401)
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


def test_unknown_engine_is_a_clear_error():
    with pytest.raises(ConfigError, match="unknown engine 'ode2'.*mujoco"):
        engine_class("ode2")
