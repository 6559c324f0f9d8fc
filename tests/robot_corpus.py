"""Public arm descriptions as they are published, used in place from installed packages, and the new
user's path through each: ``init -> check -> synth`` (MuJoCo) ``-> evaluate`` in every engine against
those recordings, and ``tune --only command_delay`` in MuJoCo and PyBullet, each against recordings it
made itself (the delay's recovery; how far the engines differ is the generic fitness of each against
MuJoCo's).  Shared by tests/test_robot_corpus.py (which asserts) and benchmarks/robot_corpus.py (which
measures the table of docs/robots.md).

The packages: ``pybullet_data`` (pybullet's own models), ``example-robot-data`` (a cmeel package of
public robot descriptions, ``share/example-robot-data/robots``) and ``airo-models`` (UR e-series).
"""

from __future__ import annotations

import json
import subprocess
import sys
import sysconfig
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: The true command delay ``synth`` records with by default [s], and how close tuning must come to it.
TRUE_DELAY_S = 1.5
DELAY_TOLERANCE_S = 0.05
#: The engines every corpus robot must load in, and those ``tune --only command_delay`` runs in.
ENGINES = ("mujoco", "pybullet", "ode", "dart", "drake")
TUNED_IN = ("mujoco", "pybullet")
#: Forward kinematics of an engine against the description's own [m].
FK_TOLERANCE_M = 1e-6


@dataclass(frozen=True)
class CorpusRobot:
    name: str
    package: str  # the installed package it ships in
    relative: str  # its path inside that package's data folder
    what: str  # what it exercises

    @property
    def path(self) -> Path | None:
        """The URDF in the installed package, or None where the package is not installed."""
        root = package_root(self.package)
        if root is None:
            return None
        path = root / self.relative
        return path if path.is_file() else None


def package_root(package: str) -> Path | None:
    if package == "pybullet_data":
        try:
            import pybullet_data
        except ImportError:
            return None
        return Path(pybullet_data.getDataPath())
    if package == "example-robot-data":
        root = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        return root if root.is_dir() else None
    if package == "airo-models":
        try:
            import airo_models
        except ImportError:
            return None
        return Path(airo_models.__file__).parent
    raise ValueError(package)


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


def last_json(result: subprocess.CompletedProcess) -> dict:
    return json.loads(result.stdout.strip().splitlines()[-1])


def walk(robot: CorpusRobot, folder: Path, engines=ENGINES, tuned_in=TUNED_IN, tune_seconds: float = 60) -> dict:
    """The new user's path through ``robot`` in ``folder``: what each step gave.  Every failing command is
    recorded with its exit status and stderr; nothing raises on a command's failure."""
    from simtune.project import load_project

    out: dict = {"robot": robot.name, "steps": {}, "fk_m": {}, "generic": {}, "delay": {}}
    project = folder / "project"

    def step(name: str, *args) -> subprocess.CompletedProcess:
        result = cli(*args)
        out["steps"][name] = (result.returncode, result.stderr.strip())
        return result

    if step("init", "init", "--robot", robot.path, "--out", project).returncode != 0:
        return out
    description = load_project(project).task("reach").robot
    out["joints"] = len(description.arm_joints)
    out["tracked_link"] = description.tracked_link
    poses = random_poses(description, 3)
    for engine in engines:
        out["fk_m"][engine] = fk_error(description, engine, poses)
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
        result = step(f"tune {engine}", "tune", "--project", project, "--engine", engine, "--task", "reach",
                      "--data", data, "--only", "command_delay", "--max-seconds", tune_seconds, "--out", run,
                      "--quiet", "--json")  # fmt: skip
        if result.returncode == 0:
            best = json.loads((run / "best_params.json").read_text())
            out["delay"][engine] = float(best.get("params", best)["command_delay"])
    return out
