"""`simtune design` (issue 68): a designed schedule, its files, and the checks it passes in simulation."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from robot_corpus import CORPUS, init_args

from simtune.design.schedule import targets_csv, trajectory_yaml
from simtune.engines import make_engine
from simtune.engines.contact import floor_touches, rollout_samples
from simtune.errors import ConfigError
from simtune.project import bundled_project, load_project
from simtune.tasks.files import load_task_file
from simtune.tasks.spec import Phase

#: a design of the bundled MICO short enough for the slow tier (about 15 s): four parameters, 30 s
MICO_ONLY = "command_delay,joint_damping_2,max_velocity_joint_2,armature_joint_3"


def simtune(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600, cwd=cwd
    )


def one_line(done: subprocess.CompletedProcess, message: str) -> None:
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in done.stderr, done.stderr


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"engine": "mujoko"}, "mujoko"),
        ({"out": "designed.yaml"}, "written as a TOML task file"),
        ({"signals": "marker,torque"}, "unknown signal 'torque'"),
        ({"only": "no_such_parameter"}, "no_such_parameter"),
        ({"task": "no_such_task"}, "no_such_task"),
        ({"duration": -3.0}, "duration"),
    ],
)
def test_bad_input_is_refused_before_any_simulation(tmp_path, kwargs, message):
    """Each a ConfigError naming what is wrong (the command line prints it as one line, exit 2)."""
    from simtune import api

    kwargs = {"out": tmp_path / "d.toml", **kwargs}
    with pytest.raises(ConfigError) as info:
        api.design(kwargs.pop("engine", "mujoco"), **kwargs)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_the_command_line_says_a_bad_argument_in_one_line(tmp_path):
    one_line(simtune("design", "--signals", "torque", "--out", str(tmp_path / "d.toml")), "unknown signal 'torque'")


def test_the_lab_files_hold_the_schedule_at_the_controllers_rate():
    """The CSV a task file's schedule_csv reads and the ROS 2 JointTrajectory, both the targets at 20 Hz."""
    task = bundled_project().task("cube")
    short = type(task)(
        **{
            **{f: getattr(task, f) for f in task.__dataclass_fields__},
            "duration": 2.0,
            "phases": (Phase(0.5, (10.0, 20.0, 30.0, 40.0, 50.0, 60.0)), Phase(1.25, (0.0,) * 6)),
            "published_phases": None,
            "object": None,
        }
    )
    rows = [line.split(",") for line in targets_csv(short).splitlines() if line and not line.startswith("#")]
    assert rows[0] == ["time", *short.joints]
    body = np.array(rows[1:], dtype=float)
    np.testing.assert_allclose(np.diff(body[:, 0]), 0.05)
    at = {round(t, 3): row for t, *row in body}
    assert at[0.45] == [0.0] * 6 and at[0.5] == [10.0, 20.0, 30.0, 40.0, 50.0, 60.0] and at[1.25] == [0.0] * 6
    trajectory = yaml.safe_load(trajectory_yaml(short))
    assert trajectory["joint_names"] == list(short.joints)
    point = next(p for p in trajectory["points"] if p["time_from_start"] == {"sec": 0, "nanosec": 500_000_000})
    np.testing.assert_allclose(point["positions"], np.radians([10, 20, 30, 40, 50, 60]))


def _check_designed(project: Path | None, task_file: Path) -> dict:
    """The designed file read back as a task of the project, rolled out at the generic point in MuJoCo on its
    own (not by the design's checks): within its joints' limits, clear of the floor, at rest at start and end."""
    project_ = load_project(project) if project else bundled_project()
    task = load_task_file(task_file, project_.robot, project_.root)
    engine = make_engine("mujoco", task)
    samples = rollout_samples(task.duration)
    try:
        rollout = engine.rollout({}, samples)
        touches = floor_touches(engine)
    finally:
        engine.close()
    assert rollout.stable
    robot = task.robot
    for i, name in enumerate(robot.arm_joints):
        joint = robot.joint_by_name[name]
        if joint.lower is not None and joint.upper is not None and math.isfinite(joint.lower):
            angles = rollout.joint_angles[:, i]
            assert joint.lower - 1e-6 <= angles.min() and angles.max() <= joint.upper + 1e-6, name
    assert touches == [], touches
    speed = np.degrees(np.abs(np.diff(rollout.joint_angles, axis=0))) / 0.05
    assert speed[:10].max() < 1.0 and speed[-10:].max() < 1.0
    return json.loads(task_file.with_name(task_file.stem + ".design.json").read_text())


@pytest.mark.slow  # one design of four parameters of the MICO, 30 s: about 15 s
def test_a_design_of_the_mico_identifies_its_parameters_better_than_its_task(tmp_path):
    out = tmp_path / "id.toml"
    done = simtune(
        "design", "--engine", "mujoco", "--task", "cube", "--space", "drivetrain", "--only", MICO_ONLY,
        "--duration", "30", "--workers", "2", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "95 % width, cube" in done.stdout and f"wrote {out}" in " ".join(done.stdout.split())
    for suffix in (".csv", ".trajectory.yaml", ".design.json"):
        assert out.with_name("id" + suffix).is_file()
    summary = _check_designed(None, out)
    assert all(check["passed"] for check in summary["checks"])
    for p in summary["parameters"]:  # narrower on the design than on the task it replaces, each of them
        assert p["predicted_width"] is not None and p["predicted_width"] < p["current_width"], p
    assert summary["criterion"]["design_log_det"] > summary["criterion"]["current_log_det"]


@pytest.mark.slow  # init of a published SO-101, then a design of its drive train's wrist roll: about 40 s
def test_a_design_of_a_published_arm_stays_within_its_limits_and_off_the_floor(tmp_path):
    (robot,) = [r for r in CORPUS if r.name == "SO-101"]
    if robot.path is None:
        pytest.skip(f"{robot.package} is not installed")
    project = tmp_path / "so101"
    made = simtune(*map(str, init_args(robot, project)))
    assert made.returncode == 0, made.stderr
    out = project / "tasks" / "id.toml"
    only = "armature_joint_5,friction_joint_5,servo_gain_joint_5,command_delay"
    done = simtune(
        "design", "--project", str(project), "--engine", "mujoco", "--space", "drivetrain", "--only", only,
        "--duration", "30", "--json", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary == _check_designed(project, out)
    assert {p["name"] for p in summary["parameters"]} <= set(only.split(","))
    assert all(check["passed"] and check["floor_touches_s"] == [] for check in summary["checks"])
