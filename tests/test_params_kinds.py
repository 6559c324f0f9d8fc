"""The table of parameter kinds (simtune.params.kinds): the one home of the names, and the drive-train kinds
(armature, Coulomb joint friction, per-joint controller gain) in every engine that has them."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import engine_or_skip

from simtune.engines import ENGINES, engine_class
from simtune.engines.controller import JointController, controller_parameters
from simtune.errors import ConfigError
from simtune.params import SPACES, validate_params
from simtune.params.kinds import ALL_ENGINES, BY_NAME, DRIVE_KINDS, KINDS, lacking
from simtune.robot import MICO
from simtune.tasks import get_task

SAMPLES = 60  # 3 s of the `single` task


def test_every_name_of_every_space_comes_from_one_kind():
    names = [p.name for p in SPACES["calibrated"]]
    assert len(names) == len(set(names))
    for name in names:
        owners = [k.name for k in KINDS if name in k.names(MICO.n_joints)]
        assert len(owners) == 1, (name, owners)
    assert controller_parameters(6) == {
        *BY_NAME["max_velocity_joint"].names(6),
        *BY_NAME["kp_joint"].names(6),
        "command_delay",
    }


def test_the_table_takes_the_engines_names_from_the_registry():
    """The engines' names are written once, in the registry (simtune.engines.registry, data below the kinds
    table): the table used to keep its own list beside it, which a new engine had to be added to by hand.  The
    registry reads without importing the engines' base (which imports the table)."""
    import ast
    import subprocess
    import sys
    from pathlib import Path

    from simtune.params import kinds

    assert frozenset(ENGINES) == ALL_ENGINES
    tree = ast.parse(Path(kinds.__file__).read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Set | ast.List | ast.Tuple):
            named = {e.value for e in node.elts if isinstance(e, ast.Constant)}
            assert not set(ENGINES) <= named, f"params/kinds.py line {node.lineno} lists the engines by hand"
    loaded = "import sys, simtune.params.kinds; print('simtune.engines.base' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", loaded], capture_output=True, text=True, timeout=60)
    assert result.stdout.strip() == "False", result.stderr


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_each_engine_has_what_the_table_says_and_applies_it(engine):
    cls = ENGINES[engine].engine_class()  # its class even where its library is missing
    supported = cls.supported(MICO)
    for kind in KINDS:
        has = set(kind.engine_names(engine, 6))
        assert has <= supported, (engine, kind.name)
        if engine not in kind.engines:
            assert not set(kind.names(6)) & supported, (engine, kind.name)
            assert kind.name in lacking(engine)
    applier = getattr(cls, "host_class", cls)  # mujoco-warp: MuJoCo's code maps each world's parameters
    for kind in DRIVE_KINDS:
        if engine in kind.engines:  # the one method that applies it
            assert callable(getattr(applier, str(kind.apply), None)), (engine, kind.apply)


def test_a_kind_an_engine_lacks_is_refused_in_one_line(tmp_path):
    with pytest.raises(ConfigError, match="engine 'pybullet' has no parameter 'armature_joint_2'"):
        validate_params({"armature_joint_2": 0.1}, engine_class("pybullet").supported(), "pybullet")
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"friction_joint_1": 1.0}))
    proc = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "evaluate", "--engine", "drake", "--task", "single", "-p", str(params)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "'friction_joint_1'" in lines[0] and "drake" in lines[0], proc.stderr


def test_an_engine_asked_to_apply_a_kind_it_lacks_raises():
    sim = engine_or_skip("pybullet")(get_task("single"))
    try:
        with pytest.raises(ConfigError, match="armature_joint_1"):
            sim.reset({"armature_joint_1": 0.1})
    finally:
        sim.close()


def test_kp_joint_is_each_joints_own_gain():
    task = get_task("single")
    ctl = JointController(task, {"kp_joint_3": 2.5})
    assert ctl.kp.tolist() == [task.kp, task.kp, 2.5, task.kp, task.kp, task.kp]
    v = ctl.velocity(np.full(6, 0.01), np.zeros(6))
    assert v[2] == pytest.approx(0.025) and v[0] == pytest.approx(0.01 * task.kp)


def test_mujoco_writes_armature_and_frictionloss_and_restores_them():
    sim = engine_or_skip("mujoco")(get_task("single"))
    try:
        base = sim.rollout({}, SAMPLES).wrist_pos
        sim.reset({"armature_joint_2": 0.5, "friction_joint_3": 4.0})
        dof2, dof3 = sim._arm_dof[1], sim._arm_dof[2]
        assert sim.model.dof_armature[dof2] == 0.5 and sim.model.dof_frictionloss[dof3] == 4.0
        moved = sim.rollout({"armature_joint_2": 0.9, "friction_joint_2": 15.0}, SAMPLES).wrist_pos
        assert np.abs(moved - base).max() > 1e-3  # the arm feels them (metres)
        again = sim.rollout({}, SAMPLES).wrist_pos  # and the next reset restores the generic values
        assert np.array_equal(again, base)
        assert sim.model.dof_armature[dof2] == 0.0 and sim.model.dof_frictionloss[dof3] == 0.0
    finally:
        sim.close()


def test_mujoco_sets_each_servos_gain_and_restores_it():
    """``servo_gain_joint_<n>`` is the joint's velocity servo's kv (gain and bias together); a softer servo lags its
    command (the wrist trails by centimetres at a tenth of the MICO's gain), and the next reset restores it."""
    sim = engine_or_skip("mujoco")(get_task("single"))
    try:
        assert sim.defaults()["servo_gain_joint_2"] == 50.0  # the MICO's generic gain
        base = sim.rollout({}, SAMPLES).wrist_pos
        sim.reset({"servo_gain_joint_2": 7.5})
        servo = sim._servos[1]
        assert sim.model.actuator_gainprm[servo, 0] == 7.5 and sim.model.actuator_biasprm[servo, 2] == -7.5
        soft = sim.rollout({"servo_gain_joint_2": 5.0}, SAMPLES).wrist_pos
        assert np.abs(soft - base).max() > 0.01
        assert np.array_equal(sim.rollout({}, SAMPLES).wrist_pos, base)
        assert sim.model.actuator_gainprm[servo, 0] == 50.0 and sim.model.actuator_biasprm[servo, 2] == -50.0
    finally:
        sim.close()


def test_a_servo_gains_range_is_its_generic_gain_scaled():
    from simtune.params.space import robot_spaces
    from simtune.robot.generate import servo_gains

    space = {p.name: p for p in robot_spaces(MICO)["drivetrain"]}
    for i, gain in enumerate(servo_gains(MICO), start=1):
        assert (space[f"servo_gain_joint_{i}"].low, space[f"servo_gain_joint_{i}"].high) == (0.1 * gain, 2 * gain)


@pytest.mark.parametrize(
    "engine,name,read",
    [
        ("dart", "friction_joint_2", lambda sim: sim._arm[1].getCoulombFriction(0)),
        ("drake", "armature_joint_2", lambda sim: sim._sys.actuators[1].rotor_inertia(sim._sys.plant_context)),
    ],
)
def test_the_other_engines_apply_their_own_equivalent(engine, name, read):
    sim = engine_or_skip(engine)(get_task("single"))
    try:
        sim.reset({name: 0.4})
        assert read(sim) == pytest.approx(0.4)
        sim.reset({})
        assert read(sim) == 0.0
    finally:
        sim.close()


def test_ode_joint_friction_is_an_angular_motor_that_holds_a_weak_joint():
    """With a 2 N m motor, 1.9 N m of friction on joint 2 leaves it almost no torque to follow its command."""
    sim = engine_or_skip("ode")(get_task("single"))
    try:
        weak = {"max_torque_joint_2": 2.0}
        free = sim.rollout(weak, SAMPLES).joint_angles[:, 1]
        held = sim.rollout({**weak, "friction_joint_2": 1.9}, SAMPLES).joint_angles[:, 1]
        assert np.abs(held - free).max() > 1e-3
    finally:
        sim.close()
