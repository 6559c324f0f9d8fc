"""Issue 50: ``simtune check DIR`` loads the robot in each engine in a child process of its own, so an engine
that takes the process down (ODE aborts on a moving link with a mass and zero inertia) is one line,
``crashed (signal 6, SIGABRT)``, and the other engines are still reported.  Before, the whole check died with
status 134 and printed nothing.  Such a URDF itself now loads everywhere: the loader gives the link the inertia of
its shapes (issue 46's corpus had one, the Lynxmotion AL5D); the crash is met with the robot built in memory."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest
from test_urdf_defects import arm

from simtune.check.project import _died
from simtune.engines import engine_class
from simtune.errors import EngineUnavailable
from simtune.tasks.init_project import init_project

pytest.importorskip("yourdfpy")

ZERO_INERTIA = '<inertial><mass value="1"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>'


@pytest.fixture(scope="module")
def crashing_project(tmp_path_factory) -> Path:
    try:
        engine_class("ode")
    except EngineUnavailable:
        pytest.skip("ODE is not installed")
    folder = tmp_path_factory.mktemp("zero-inertia")
    urdf = folder / "arm.urdf"
    urdf.write_text(arm(inertial=ZERO_INERTIA))
    return init_project(urdf, folder / "project").parent


def test_an_engine_that_crashes_is_one_line_and_the_others_are_reported(crashing_project: Path) -> None:
    from dataclasses import replace

    from simtune.check.project import _load_robot_isolated
    from simtune.project import load_project

    task = next(iter(load_project(crashing_project).tasks.values()))
    # the robot as the URDF wrote it, before the loader's stand-in: a moving link with a mass and zero inertia
    robot = task.robot
    links = tuple(
        replace(link, inertia=(0.0, 0.0, 0.0), products=(0.0, 0.0, 0.0)) if link.name == robot.driven_links[0] else link
        for link in robot.links
    )
    found = _load_robot_isolated(("ode", "pybullet"), replace(task, robot=replace(robot, links=links)), 300.0)
    assert found["ode"] == ("failed", "crashed (signal 6, SIGABRT)")
    assert found["pybullet"][0] == "loaded"  # the other engine, in its own child, still reported


def test_the_urdf_that_crashed_ode_now_loads_in_every_engine_with_a_warning(crashing_project: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "check", str(crashing_project)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "crashed" not in done.stdout + done.stderr and "Traceback" not in done.stderr
    assert "no rotational inertia" in done.stderr
    loaded = next(line for line in done.stdout.splitlines() if "engines that load the robot:" in line)
    assert "ode" in loaded and "mujoco" in loaded


def test_how_a_child_died_is_said() -> None:
    assert _died(-signal.SIGSEGV) == "crashed (signal 11, SIGSEGV)"
    assert _died(3) == "exited with status 3 without an answer"
