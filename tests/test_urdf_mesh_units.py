"""Issue 50 item 8, second half: an STL in millimetres (its extent ~1000 x the robot's joint offsets) is named at
load (``init``, ``check``) with a warning suggesting the ``scale`` attribute; one in metres, or scaled, is not."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from test_urdf_defects import arm

from simtune.robot.urdf import load_urdf

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("yourdfpy")


def robot(tmp_path: Path, side: float, scale: str = "") -> Path:
    trimesh.creation.box(extents=(side / 6, side / 6, side)).export(tmp_path / "upper.stl")
    path = tmp_path / "arm.urdf"
    path.write_text(arm(geometry=f'<mesh filename="upper.stl"{scale}/>'))
    return path


def unit_warnings(path: Path) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_urdf(path)
    return [str(w.message) for w in caught if "millimetres" in str(w.message)]


def test_a_mesh_in_millimetres_is_named(tmp_path: Path) -> None:
    path = robot(tmp_path, 300.0)
    (line,) = unit_warnings(path)
    assert line.startswith(f"{path}: link 'upper' collision 1: mesh 'upper.stl' spans 300 m, 1000 x")
    assert 'scale="0.001 0.001 0.001"' in line


@pytest.mark.parametrize(("side", "scale"), [(0.3, ""), (300.0, ' scale="0.001 0.001 0.001"')], ids=["m", "scaled"])
def test_a_mesh_in_metres_is_not(tmp_path: Path, side: float, scale: str) -> None:
    assert unit_warnings(robot(tmp_path, side, scale)) == []


def test_init_and_check_say_it(tmp_path: Path) -> None:
    path = robot(tmp_path, 300.0)
    project = tmp_path / "project"
    for args in (["init", "--robot", str(path), "--out", str(project)], ["check", str(project)]):
        done = subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        assert "mesh 'upper.stl' spans 300 m" in done.stdout + done.stderr, args
