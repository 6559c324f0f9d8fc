"""MJCF robots a hostile user wrote (issue 71, probe 5: #16, #21, rows 7-8 and 15-20): a joint's ``ref``, NaNs and
infinities in the file's numbers, dropped equality constraints and tendons, an arm whose geoms all collide with
nothing in Drake, a driven joint named twice and a package path given for an MJCF.

Each robot is a small three-hinge arm written here into a temporary folder; the engines run only in the tests that
need them (a refusal at load needs none).
"""

import subprocess
import sys
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import CPU_ENGINES

from simtune.engines import engine_class
from simtune.errors import EngineUnavailable, RobotError, RobotWarning
from simtune.project import load_project
from simtune.robot.load import load_robot
from simtune.tasks.init_project import init_project

#: three hinges j1..j3 from the base to link3 (the tracked link), every geom colliding
ARM3 = """<mujoco model="arm3">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="base" pos="0 0 0.02">
      <inertial pos="0 0 0.03" mass="2" diaginertia="0.004 0.004 0.004"/>
      <geom type="cylinder" size="0.06 0.03" pos="0 0 0.03"/>
      <body name="link1" pos="0 0 0.06">
        <joint name="j1" axis="0 0 1" range="-2 2"/>
        <inertial pos="0 0 0.05" mass="1.2" diaginertia="0.003 0.003 0.001"/>
        <geom type="capsule" fromto="0 0 0.02 0 0 0.08" size="0.03"/>
        <body name="link2" pos="0 0 0.1">
          <joint name="j2" axis="0 1 0" range="-2 2"/>
          <inertial pos="0 0 0.1" mass="1.0" diaginertia="0.004 0.004 0.0008"/>
          <geom name="upper" type="capsule" fromto="0 0 0.02 0 0 0.18" size="0.03"/>
          <body name="link3" pos="0 0 0.2">
            <joint name="j3" axis="0 1 0" range="-2 2"/>
            <inertial pos="0 0 0.08" mass="0.6" diaginertia="0.002 0.002 0.0004"/>
            <geom type="box" size="0.02 0.02 0.05" pos="0 0 0.05"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def arm(tmp_path: Path, *edits: tuple[str, str], name: str = "arm3.xml") -> Path:
    """ARM3 with each ``(old, new)`` of ``edits`` made once, written into ``tmp_path``."""
    text = ARM3
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / name
    path.write_text(text)
    return path


def cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "simtune.cli", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300
    )


def mujoco_tracked_position(path: Path, q, body: str = "link3") -> np.ndarray:
    """Where MuJoCo's own compile of the file puts ``body`` with the hinges j1..j3 at ``q`` [rad] (qpos)."""
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    for name, angle in zip(("j1", "j2", "j3"), q):
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = angle
    mujoco.mj_kinematics(model, data)
    return data.xpos[model.body(body).id].copy()


# --------------------------------------------------------------------------- #16 row 7: a joint's ref


REF_EDIT = ('<joint name="j2" axis="0 1 0" range="-2 2"/>', '<joint name="j2" axis="0 1 0" range="-2 2" ref="0.5"/>')


def test_a_joint_ref_is_the_file_s_own_coordinate_in_the_description(tmp_path):
    """A joint's position is MuJoCo's qpos, whose ``ref`` is the pose as drawn: the description's kinematics (the
    URDF the other engines read) puts the tracked link where MuJoCo's own compile of the file does."""
    path = arm(tmp_path, REF_EDIT)
    robot = load_robot(path)
    for q in ([0.0, 0.0, 0.0], [0.3, 0.5, -0.4], [-1.0, 1.2, 0.7]):
        np.testing.assert_allclose(robot.forward_kinematics(q)[0], mujoco_tracked_position(path, q), atol=1e-9)


@pytest.mark.parametrize("engine", CPU_ENGINES)
def test_a_joint_ref_puts_the_arm_in_the_same_place_in_every_engine(tmp_path, engine):
    """MuJoCo from the file, the others from the URDF: the tracked link within a micrometre of the description at
    the start pose (the probe: 247 mm apart in MuJoCo, 25 cm between MuJoCo and PyBullet)."""
    if engine in ("dart", "drake"):
        pytest.importorskip({"dart": "dartpy", "drake": "pydrake"}[engine])
    try:
        cls = engine_class(engine)
    except EngineUnavailable as exc:
        pytest.skip(str(exc))
    init_project(arm(tmp_path, REF_EDIT), tmp_path / "project")
    task = load_project(tmp_path / "project").task("reach")
    sim = cls(task)
    try:
        sim.reset({})
        position, rotation = sim.wrist_pose()
    finally:
        sim.close()
    want_position, want_rotation = task.robot.forward_kinematics(np.radians(task.start_pose_deg))
    np.testing.assert_allclose(position, want_position, atol=1e-6)
    np.testing.assert_allclose(rotation, want_rotation, atol=1e-6)


def test_an_undriven_joint_s_ref_is_named_where_it_is_welded(tmp_path):
    path = arm(tmp_path, REF_EDIT)
    robot = load_robot(path, arm_joints=["j1", "j3"])
    assert robot.held == (("j2", 0.5),)
    assert "joints not driven, welded as drawn: j2 (at its ref 0.5)" in robot.choices
    np.testing.assert_allclose(
        robot.forward_kinematics([0.2, -0.3])[0], mujoco_tracked_position(path, [0.2, 0.5, -0.3]), atol=1e-9
    )


# --------------------------------------------------------------------------- #16 row 8, #21, row 17: NaN, inf


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        ('<body name="link2" pos="0 0 0.1">', '<body name="link2" pos="inf 0 0">', "<body name='link2'> pos='inf 0 0'"),
        ('<body name="link3" pos="0 0 0.2">', '<body name="link3" pos="0 0 0.2" euler="0 nan 0">', "euler="),
        ('axis="0 1 0" range="-2 2"/>', 'axis="0 nan 0" range="-2 2"/>', "<joint name='j2'> axis="),
        ('0.18" size="0.03"', '0.18" size="Infinity"', "<geom name='upper'> size='Infinity'"),
        ('mass="1.0"', 'mass="nan"', "<inertial> of body 'link2' mass='nan'"),
        ('diaginertia="0.003', 'diaginertia="1e999', "<inertial> of body 'link1' diaginertia="),
        ('<geom type="box"', '<geom mass="nan" type="box"', "<geom> of body 'link3' mass='nan'"),
        ('range="-2 2"/>', 'range="-inf inf"/>', "<joint name='j1'> range='-inf inf'"),
        ('range="-2 2"/>', 'range="-2 2" armature="nan"/>', "<joint name='j1'> armature='nan'"),
        ('range="-2 2"/>', 'range="-2 2" damping="inf"/>', "<joint name='j1'> damping='inf'"),
        ("</worldbody>", '</worldbody><keyframe><key name="home" qpos="nan 0 0"/></keyframe>', "<key name='home'>"),
        ("<worldbody>", '<default><joint damping="-inf"/></default><worldbody>', "<joint> of default class 'main'"),
    ],
    ids=[
        "body-pos", "body-euler", "joint-axis", "geom-size", "inertial-mass", "overflow", "geom-mass", "range",
        "armature", "damping", "keyframe", "default",
    ],
)  # fmt: skip
def test_a_non_finite_number_is_refused_at_load_naming_file_element_and_attribute(tmp_path, old, new, words):
    path = arm(tmp_path, (old, new))
    with pytest.raises(RobotError) as caught:
        load_robot(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path} line ") and words in message, message
    assert "is not a finite number" in message


def test_a_non_finite_number_in_an_included_file_names_that_file(tmp_path):
    (tmp_path / "parts").mkdir()
    defaults = tmp_path / "parts" / "defaults.xml"
    defaults.write_text('<mujoco>\n  <default>\n    <joint armature="nan"/>\n  </default>\n</mujoco>\n')
    path = arm(tmp_path, ("<worldbody>", '<include file="parts/defaults.xml"/>\n  <worldbody>'))
    with pytest.raises(RobotError) as caught:
        load_robot(path)
    assert str(caught.value).startswith(f"{defaults} line 3: <joint> of default class 'main' armature='nan' is not a")


def test_a_name_that_reads_as_a_number_is_a_name(tmp_path):
    robot = load_robot(arm(tmp_path, ('<body name="link3"', '<body name="inf"')))
    assert robot.tracked_link == "inf"


@pytest.mark.slow  # the default tier's 4 minutes
def test_init_and_check_refuse_a_non_finite_number_in_one_line(tmp_path):
    """init writes nothing; a project whose file was edited after init is refused by check, as by every command."""
    bad = arm(tmp_path, ('range="-2 2"/>', 'range="-2 2" damping="inf"/>'), name="bad.xml")
    result = cli("init", "--robot", bad, "--out", tmp_path / "new")
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert f"{bad} line 8: <joint name='j1'> damping='inf' is not a finite number" in result.stderr
    assert not (tmp_path / "new").exists()
    good = arm(tmp_path)
    init_project(good, tmp_path / "project")
    good.write_text(ARM3.replace('mass="1.0"', 'mass="nan"'))
    result = cli("check", tmp_path / "project")
    assert result.returncode == 2, result.stdout + result.stderr
    assert "<inertial> of body 'link2' mass='nan' is not a finite number" in result.stdout + result.stderr
    assert "Traceback" not in result.stderr


# --------------------------------------------------------------------------- row 15: couplings the scene drops

COUPLED = (
    (
        "</worldbody>",
        """</worldbody>
  <equality><joint joint1="j3" joint2="j2"/></equality>
  <tendon><fixed name="split"><joint joint="j2" coef="1"/><joint joint="j3" coef="-1"/></fixed></tendon>
  <actuator><motor name="pull" tendon="split"/></actuator>""",
    ),
)


def test_equality_constraints_and_tendons_are_named_where_they_are_dropped(tmp_path):
    path = arm(tmp_path, *COUPLED)
    with pytest.warns(RobotWarning) as caught:
        load_robot(path)
    (message,) = [str(w.message) for w in caught if "dropped" in str(w.message)]
    assert message.startswith(f"{path}: ")
    assert "equality <joint> coupling 'j3' to 'j2'" in message
    assert "tendon 'split' on joints 'j2', 'j3' with its actuator 'pull'" in message


@pytest.fixture(scope="module")
def coupled_project(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """A project of the coupled arm, and its init's output."""
    folder = tmp_path_factory.mktemp("coupled")
    path = arm(folder, *COUPLED)
    return path, cli("init", "--robot", path, "--out", folder / "project")


def test_init_warns_of_the_dropped_couplings_once(coupled_project):
    path, result = coupled_project
    assert result.returncode == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if "equality <joint> coupling 'j3' to 'j2'" in line]
    assert len(warned) == 1 and warned[0].startswith(f"warning: {path}: "), result.stderr


@pytest.mark.slow  # check loads the robot in every engine (3 to 7 s)
def test_check_warns_of_the_dropped_couplings(coupled_project):
    path, _ = coupled_project
    result = cli("check", path.parent / "project")
    output = result.stdout + result.stderr
    assert "equality <joint> coupling 'j3' to 'j2'" in output and "tendon 'split'" in output, output


def test_an_arm_without_couplings_loads_without_a_warning(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RobotWarning)
        load_robot(arm(tmp_path))


# --------------------------------------------------------------------------- row 16: no geom collides, in Drake


def test_drake_builds_an_arm_whose_geoms_all_collide_with_nothing(tmp_path):
    """No collision shape on the gripper: its friction is Drake's default, changing nothing (the probe: IndexError)."""
    pytest.importorskip("pydrake")
    path = tmp_path / "arm3.xml"
    path.write_text(ARM3.replace("<geom ", '<geom contype="0" conaffinity="0" '))
    init_project(path, tmp_path / "project")
    task = load_project(tmp_path / "project").task("reach")
    assert not any(link.shapes for link in task.robot.links)
    sim = engine_class("drake")(task)
    try:
        assert sim.defaults()["lateral_friction_gripper"] == pytest.approx(1.0)
        sim.reset({"lateral_friction_gripper": 0.4})
        np.testing.assert_allclose(
            sim.wrist_pose()[0], task.robot.forward_kinematics(np.radians(task.start_pose_deg))[0], atol=1e-6
        )
    finally:
        sim.close()


# --------------------------------------------------------------------------- rows 19 and 20: init's options


def test_init_refuses_a_driven_joint_named_twice_naming_the_option(tmp_path):
    result = cli("init", "--robot", arm(tmp_path), "--out", tmp_path / "new", "--driven-joints", "j1,j2,j1")
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "--driven-joints j1,j2,j1: joint 'j1' named twice" in result.stderr
    assert "reach.toml" not in result.stderr
    assert not (tmp_path / "new").exists() and not list(tmp_path.glob(".new.*"))


@pytest.mark.slow  # the default tier's 4 minutes
def test_init_refuses_a_package_path_for_an_mjcf(tmp_path):
    result = cli("init", "--robot", arm(tmp_path), "--out", tmp_path / "new", "--package-path", tmp_path)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "--package-path: " in result.stderr and "is an MJCF" in result.stderr
    assert not (tmp_path / "new").exists()


def test_a_project_naming_a_package_path_for_an_mjcf_names_the_key(tmp_path):
    init_project(arm(tmp_path), tmp_path / "project")
    project_file = tmp_path / "project" / "simtune.toml"
    text = project_file.read_text()
    project_file.write_text(text.replace("[robot]\n", f'[robot]\npackage_path = ["{tmp_path}"]\n', 1))
    result = cli("params", "--project", tmp_path / "project")
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "robot.package_path: " in result.stderr and "is for a URDF's package:// names" in result.stderr


def test_a_urdfs_mass_options_are_refused_for_an_mjcf_with_the_key_named(tmp_path):
    """load_robot takes load_urdf's keywords (one signature, load_urdf's); a density or total mass given for an MJCF,
    whose bodies carry their masses, used to be dropped without a word: now one line names the key."""
    import inspect

    from simtune.robot.urdf import load_urdf

    assert inspect.signature(load_robot) == inspect.signature(load_urdf)
    for key in ("density", "total_mass"):
        with pytest.raises(RobotError, match=rf": {key} is for a URDF's links without an <inertial>"):
            load_robot(arm(tmp_path), **{key: 1000.0})
    init_project(arm(tmp_path), tmp_path / "project")
    project_file = tmp_path / "project" / "simtune.toml"
    project_file.write_text(project_file.read_text().replace("[robot]\n", "[robot]\ndensity = 900.0\n", 1))
    result = cli("params", "--project", tmp_path / "project")
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "robot.density: " in result.stderr and "is for a URDF's links" in result.stderr
