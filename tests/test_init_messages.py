"""Issue 50, misleading messages: a joint named with an emoji and a locked joint (lower == upper) made ``simtune
init`` blame its own temporary TOML (a name escaped as two surrogates TOML refuses; a start pose rounded outside
the joint's one angle); both now give a project that loads and checks.  An API list given as None is a
ConfigError naming the argument, not a raw TypeError."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest
from test_urdf_defects import arm

from simtune import api
from simtune.errors import ConfigError
from simtune.project import load_project

pytest.importorskip("yourdfpy")


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize(
    ("name", "urdf"),
    [
        ("emoji", arm(shoulder="shoulder\N{ROBOT FACE}")),
        ("locked", arm(limit='lower="0.7" upper="0.7" effort="50" velocity="1"')),
        ("locked-odd", arm(limit='lower="0.123456789" upper="0.123456789" effort="50" velocity="1"')),
    ],
)
def test_init_writes_a_project_that_loads(tmp_path: Path, name: str, urdf: str) -> None:
    path = tmp_path / f"{name}.urdf"
    path.write_text(urdf, encoding="utf-8")
    project = tmp_path / "project"
    done = cli("init", "--robot", str(path), "--out", str(project))
    assert done.returncode == 0, done.stderr
    task = load_project(project).tasks["reach"]
    joint = task.robot.joint_by_name[task.joints[0]]
    assert math.radians(task.start_pose_deg[0]) == pytest.approx(0.0 if name == "emoji" else joint.lower, abs=1e-9)
    done = cli("check", str(project))
    assert done.returncode == 0 and "engines that load the robot" in done.stdout, done.stderr


def test_api_lists_given_none_are_named() -> None:
    with pytest.raises(ConfigError, match="^optimizers: expected names"):
        api.compare(optimizers=None, out="unused")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="^engines: expected names"):
        api.grid_spec(engines=None)  # type: ignore[arg-type]
